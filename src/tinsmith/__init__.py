"""tinsmith: elevation data (DEM rasters, LiDAR, dense meshes) to compact, well-shaped TINs.

The flat public API::

    import tinsmith
    hf = tinsmith.read_heightfield("dem.tif")          # or tinsmith.sample("st-helens")
    mesh = tinsmith.simplify(hf, method="grid")        # any name from tinsmith.methods()
    print(tinsmith.mesh_metrics(mesh, hf)["vertical_error"])
    tinsmith.write(mesh, "dem.ply")
"""

from . import errors
from ._version import __version__
from .algorithms import (
    DEFAULT_METHOD,
    Decimation,
    GreedyEngine,
    Triangulation,
    compare_methods,
    cvt,
    decimate,
    delaunay,
    features,
    get_method,
    greedy,
    grid,
    methods,
    QuadtreeHierarchy,
    quadtree,
    remesh,
    simplify,
    subsample,
    subsample_pyramid,
    building_tree,
    city,
    urban,
)
from .core import Heightfield, PointCloud, StopCriteria, TerrainMesh
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
from .io import read, read_heightfield, read_mesh, write
from .algorithms.fit import fit_heights
from .algorithms.reconstruct import reconstruct
from .algorithms.pointtin import tin
from .algorithms.landuse import LandUse, read_landuse
from .algorithms.wavelet import wavelet, wavelet_filter
from .metrics import mesh_metrics, non_delaunay_edges, rasterize, triangle_quality, vertical_error, vertical_error_at_points
from .samples import SAMPLES, sample_path

def sample(name: str = "st-helens") -> Heightfield:
    """The embedded sample heightfield ``name`` (see :data:`SAMPLES`)."""
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
