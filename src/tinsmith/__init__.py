"""tinsmith: elevation data (DEM rasters, LiDAR, dense meshes) to compact, well-shaped TINs.

The flat public API::

    import tinsmith
    hf = tinsmith.read_heightfield("dem.tif")          # or tinsmith.sample("st-helens")
    mesh = tinsmith.simplify(hf, method="grid")        # any name from tinsmith.methods()
    print(tinsmith.mesh_metrics(mesh, hf)["vertical_error"])
    tinsmith.write(mesh, "dem.ply")

Every name is imported on first use (PEP 562), so ``import tinsmith`` and the
command line start at once and load numba, scipy and the readers only for
the work that needs them.
"""

from . import _hooks, _lazy, errors
from ._version import __version__
from .errors import (
    FileError,
    FormatError,
    InputNotFoundError,
    InvalidInputError,
    InvalidMeshError,
    InvalidOptionError,
    MissingDependencyError,
    NoDataError,
    TinsmithError,
    UnknownMethodError,
    UnsupportedFormatError,
)

#: public name -> the module (under ``tinsmith.``) that defines it
_LAZY = {
    "DEFAULT_METHOD": "algorithms.registry",
    "get_method": "algorithms.registry",
    "methods": "algorithms.registry",
    "simplify": "algorithms.registry",
    "Decimation": "algorithms.grid.decimate",
    "decimate": "algorithms.grid.decimate",
    "GreedyEngine": "algorithms.greedy.engine",
    "greedy": "algorithms.greedy.greedy",
    "Triangulation": "triangulation.delaunay",
    "delaunay": "triangulation.delaunay",
    "compare_methods": "algorithms.compare",
    "cvt": "algorithms.cvt.cvt",
    "features": "algorithms.grid.features",
    "grid": "algorithms.grid.grid",
    "QuadtreeHierarchy": "algorithms.grid.quadtree",
    "quadtree": "algorithms.grid.quadtree",
    "remesh": "algorithms.remesh.remesh",
    "subsample": "algorithms.grid.subsample",
    "subsample_pyramid": "algorithms.grid.subsample",
    "building_tree": "algorithms.urban.urban",
    "urban": "algorithms.urban.urban",
    "city": "algorithms.urban.city",
    "Heightfield": "core",
    "PointCloud": "core",
    "StopCriteria": "core",
    "TerrainMesh": "core",
    "read": "io",
    "read_heightfield": "io",
    "read_mesh": "io",
    "write": "io",
    "fit_heights": "algorithms.cvt.fit",
    "reconstruct": "algorithms.reconstruct.reconstruct",
    "tin": "triangulation.pointtin",
    "LandUse": "algorithms.wavelet.landuse",
    "read_landuse": "algorithms.wavelet.landuse",
    "wavelet": "algorithms.wavelet.wavelet",
    "wavelet_filter": "algorithms.wavelet.wavelet",
    "mesh_metrics": "metrics",
    "non_delaunay_edges": "metrics",
    "rasterize": "metrics",
    "triangle_quality": "metrics",
    "vertical_error": "metrics",
    "vertical_error_at_points": "metrics",
    "SAMPLES": "samples",
    "sample_path": "samples",
}


__getattr__ = _lazy.attributes(__name__, _LAZY)

# The calls a layer makes into a layer above it (tinsmith._hooks), installed here: this module sits above every
# layer, and Python runs it before any module of the package.  Each target is imported on its first call.
_hooks.install(
    tile_heightfield=_lazy.function("tinsmith.tiles.run", "tile_heightfield"),
    **{name: _lazy.function("tinsmith.io.interop", name)
       for name in ("to_trimesh", "to_pyvista", "to_geodataframe", "to_xarray", "repr_html")},
)


def __dir__():
    return sorted(set(globals()) | set(__all__))


def sample(name: str = "st-helens"):
    """The embedded sample heightfield ``name`` (see :data:`SAMPLES`).

    Examples
    --------
    >>> import tinsmith
    >>> tinsmith.sample("st-helens")
    Heightfield(468 x 327, cell 30 x 30, z 682..2543, nodata 2.7%, crs=yes)
    """
    from .io import read_heightfield
    from .samples import sample_path

    return read_heightfield(sample_path(name))


__all__ = [
    "__version__",
    "DEFAULT_METHOD",
    "Decimation",
    "SAMPLES",
    "FileError",
    "GreedyEngine",
    "FormatError",
    "Heightfield",
    "InputNotFoundError",
    "InvalidInputError",
    "InvalidMeshError",
    "InvalidOptionError",
    "LandUse",
    "MissingDependencyError",
    "NoDataError",
    "PointCloud",
    "QuadtreeHierarchy",
    "StopCriteria",
    "TerrainMesh",
    "TinsmithError",
    "Triangulation",
    "UnknownMethodError",
    "compare_methods",
    "UnsupportedFormatError",
    "cvt",
    "decimate",
    "delaunay",
    "errors",
    "features",
    "fit_heights",
    "get_method",
    "greedy",
    "grid",
    "mesh_metrics",
    "methods",
    "non_delaunay_edges",
    "quadtree",
    "rasterize",
    "read",
    "reconstruct",
    "tin",
    "remesh",
    "read_heightfield",
    "read_landuse",
    "read_mesh",
    "sample",
    "sample_path",
    "simplify",
    "subsample",
    "subsample_pyramid",
    "building_tree",
    "city",
    "urban",
    "triangle_quality",
    "vertical_error",
    "vertical_error_at_points",
    "wavelet",
    "wavelet_filter",
    "write",
]
