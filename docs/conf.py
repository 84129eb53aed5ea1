"""Sphinx configuration of the tinsmith documentation site: the pages of docs/ and the API from the docstrings.

Build (warnings are errors, as in the test suite):  python -m sphinx -W -b html docs docs/_build
"""

project = "tinsmith"
author = "tinsmith developers"
extensions = ["sphinx.ext.autodoc", "sphinx.ext.napoleon", "myst_parser"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "notebook.ipynb", "*.py"]
autodoc_member_order = "bysource"
autodoc_typehints = "description"
napoleon_numpy_docstring = True
napoleon_google_docstring = False
myst_heading_anchors = 3
html_theme = "alabaster"


def _local_files(app, docname, source):
    """Links to files beyond docs/ (the benchmark tables) become downloads of those files, as MyST's
    ``path:`` links, instead of references to pages the site does not hold."""
    import re

    source[0] = re.sub(r"\]\(((?:\.\./)+(?:benchmarks|src|tests)/[^)\s]+)\)", r"](path:\1)", source[0])


def setup(app):
    app.connect("source-read", _local_files)
