"""Methods: one module per method, each registered by name in :mod:`.registry`."""

from . import grid as _grid  # noqa: F401  (registers "grid")
from .grid import grid
from .registry import DEFAULT_METHOD, Method, Option, get_method, methods, register, simplify

__all__ = ["DEFAULT_METHOD", "Method", "Option", "get_method", "grid", "methods", "register", "simplify"]
