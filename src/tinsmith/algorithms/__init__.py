"""Methods: one module per method, each registered by name in :mod:`.registry`."""

from . import grid as _grid  # noqa: F401  (registers "grid")
from . import greedy as _greedy  # noqa: F401  (registers "greedy")
from . import subsample as _subsample  # noqa: F401  (registers "subsample")
from . import features as _features  # noqa: F401  (registers "features")
from .compare import compare_methods
from .delaunay import Triangulation, delaunay
from .features import features, importance
from .greedy import GreedyEngine, greedy
from .grid import grid
from .subsample import subsample, subsample_pyramid
from .registry import DEFAULT_METHOD, Method, Option, get_method, methods, register, simplify

__all__ = ["DEFAULT_METHOD", "GreedyEngine", "Triangulation", "compare_methods", "delaunay", "features", "importance", "Method", "Option", "get_method", "greedy", "grid", "methods", "register", "simplify", "subsample", "subsample_pyramid"]
