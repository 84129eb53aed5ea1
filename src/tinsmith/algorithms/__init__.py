"""Methods: one module per method, each registered by name in :mod:`.registry`."""

from . import grid as _grid  # noqa: F401  (registers "grid")
from . import greedy as _greedy  # noqa: F401  (registers "greedy")
from . import subsample as _subsample  # noqa: F401  (registers "subsample")
from . import features as _features  # noqa: F401  (registers "features")
from . import quadtree as _quadtree  # noqa: F401  (registers "quadtree")
from . import decimate as _decimate  # noqa: F401  (registers "decimate")
from . import cvt as _cvt  # noqa: F401  (registers "cvt")
from . import remesh as _remesh  # noqa: F401  (registers "remesh")
from .compare import compare_methods
from .cvt import cvt
from .decimate import Decimation, decimate
from .delaunay import Triangulation, delaunay
from .features import features, importance
from .greedy import GreedyEngine, greedy
from .grid import grid
from .quadtree import QuadtreeHierarchy, quadtree
from .remesh import remesh
from .subsample import subsample, subsample_pyramid
from .city import CityModel, city
from .urban import BuildingTree, UrbanModel, building_tree, urban
from .registry import DEFAULT_METHOD, Method, Option, get_method, methods, register, simplify

__all__ = ["DEFAULT_METHOD", "Decimation", "GreedyEngine", "Triangulation", "compare_methods", "cvt", "decimate", "delaunay", "features", "importance", "Method", "Option", "QuadtreeHierarchy", "get_method", "greedy", "grid", "methods", "quadtree", "register", "remesh", "simplify", "subsample", "subsample_pyramid", "BuildingTree", "UrbanModel", "building_tree", "urban", "CityModel", "city"]
