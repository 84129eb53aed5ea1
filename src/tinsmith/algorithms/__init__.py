"""Methods: one module per method, each declared in :mod:`.catalogue` and registered in :mod:`.registry`.

Importing this package imports no method: the registry lists them from their
declarations, and a method's module is imported when it first runs.  The
method functions are ``tinsmith.greedy``, ``tinsmith.cvt``, ...; here the
names of the modules (``tinsmith.algorithms.greedy``) are the modules.
"""

from .. import _lazy
from .registry import DEFAULT_METHOD, Declaration, Method, Option, declare, get_method, methods, register, simplify

#: names defined by a method's module, imported on first use
_LAZY = {
    "compare_methods": "compare",
    "Decimation": "decimate",
    "Triangulation": "delaunay",
    "importance": "features",
    "GreedyEngine": "greedy",
    "QuadtreeHierarchy": "quadtree",
    "subsample_pyramid": "subsample",
    "CityModel": "city",
    "BuildingTree": "urban",
    "UrbanModel": "urban",
    "building_tree": "urban",
}


__getattr__ = _lazy.attributes(__name__, _LAZY)


__all__ = ["DEFAULT_METHOD", "Declaration", "Method", "Option", "declare", "get_method", "methods", "register",
           "simplify", *_LAZY]
