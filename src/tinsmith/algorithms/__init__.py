"""Methods: one subpackage per method family, each method declared in :mod:`.catalogue` and registered in
:mod:`.registry`.

The families (each subpackage's docstring lists its modules, the method's own first):
:mod:`.greedy` (greedy insertion on grids and point clouds),
:mod:`.quality` (an error bound and an angle bound), :mod:`.grid` (grid, subsample, quadtree, features,
decimate), :mod:`.cvt` (curvature CVT, height fit), :mod:`.remesh` (isotropic remeshing),
:mod:`.urban` (urban models, city meshes), :mod:`.wavelet` (spline and wavelet filtering, land use) and
:mod:`.reconstruct` (reconstruction of point clouds).  The shared layer stays here: :mod:`.registry`
and :mod:`.catalogue` (every method's record), :mod:`.compare` and :mod:`.lod`.

Importing this package imports no method: the registry lists them from their declarations, and a
method's module is imported when it first runs.  The method functions are ``tinsmith.greedy``,
``tinsmith.cvt``, ...; ``tinsmith.algorithms.greedy.greedy`` is the module.
"""

from .. import _lazy
from .registry import DEFAULT_METHOD, Declaration, Method, Option, declare, get_method, methods, register, simplify

#: names defined by a method's module, imported on first use
_LAZY = {
    "compare_methods": "compare",
    "Decimation": "grid.decimate",
    "importance": "grid.features",
    "GreedyEngine": "greedy.engine",
    "QuadtreeHierarchy": "grid.quadtree",
    "subsample_pyramid": "grid.subsample",
    "CityModel": "urban.city",
    "BuildingTree": "urban.urban",
    "UrbanModel": "urban.urban",
    "building_tree": "urban.urban",
}


__getattr__ = _lazy.attributes(__name__, _LAZY)


__all__ = ["DEFAULT_METHOD", "Declaration", "Method", "Option", "declare", "get_method", "methods", "register",
           "simplify", *_LAZY]
