"""The data model: numpy only, no I/O.

The classes are imported on first use (the command line starts without numpy): see ``__init__.pyi``.
"""

from .. import _lazy

__getattr__, __dir__, __all__ = _lazy.attach(__name__, __file__)
