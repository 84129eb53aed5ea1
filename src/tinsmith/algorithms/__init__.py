"""Methods: one subpackage per method family, each method declared in :mod:`.catalogue` and registered in
:mod:`.registry`.

The families (each subpackage's docstring lists its modules, the method's own first):
:mod:`.greedy` (greedy insertion on grids and point clouds),
:mod:`.quality` (an error bound and an angle bound), :mod:`.grid` (grid, subsample, quadtree, features,
decimate), :mod:`.cvt` (curvature CVT, height fit), :mod:`.remesh` (isotropic remeshing),
:mod:`.urban` (the block model, city models), :mod:`.wavelet` (spline and wavelet filtering, land use) and
:mod:`.reconstruct` (reconstruction of point clouds).  The shared layer stays here: :mod:`.declaration`
(what a method's record holds), :mod:`.catalogue` (every method's record), :mod:`.registry` (the records
listed, the methods run), :mod:`.compare` and :mod:`.lod`.

Importing this package imports no method: the registry lists them from their declarations, and a
method's module is imported when it first runs.  The method functions are ``tinsmith.greedy``,
``tinsmith.cvt``, ...; ``tinsmith.algorithms.greedy.greedy`` is the module.
"""

from .. import _lazy

# the registry's names and those of the method modules below (their classes, helpers), imported on first
# use: see __init__.pyi
__getattr__, __dir__, __all__ = _lazy.attach(__name__, __file__)
