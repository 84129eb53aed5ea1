"""The version of tinsmith: the one place it is written (pyproject.toml reads it from here).

A literal, not ``importlib.metadata.version("tinsmith")``: reading the
installed metadata costs about 50 ms at every start of the command line.
"""

__version__ = "0.1.0"
