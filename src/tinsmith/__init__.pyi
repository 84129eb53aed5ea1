# The public API of tinsmith: what type checkers and IDEs read, and what tinsmith/__init__.py imports on
# first use (lazy_loader).  Keep __all__ the same as the names below (tests/test_contract.py checks it).

from . import errors
from ._version import __version__
from .algorithms.compare import compare_methods
from .algorithms.cvt.cvt import cvt
from .algorithms.cvt.fit import fit_heights
from .algorithms.flood.flood import flood
from .algorithms.greedy.engine import GreedyEngine
from .algorithms.greedy.greedy import greedy
from .algorithms.grid.decimate import Decimation, decimate
from .algorithms.grid.features import features
from .algorithms.grid.grid import grid
from .algorithms.grid.quadtree import QuadtreeHierarchy, quadtree
from .algorithms.grid.subsample import subsample, subsample_pyramid
from .algorithms.quality.quality import quality
from .algorithms.reconstruct.reconstruct import reconstruct
from .algorithms.registry import DEFAULT_METHOD, get_method, methods, simplify
from .algorithms.remesh.remesh import remesh
from .algorithms.urban.city import city
from .algorithms.urban.ground import ground
from .algorithms.urban.urban import blocks, building_tree, urban
from .algorithms.wavelet.landuse import LandUse, read_landuse
from .algorithms.wavelet.wavelet import wavelet, wavelet_filter
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
from .hydrology import (
    fill_depressions,
    flow_accumulation,
    flow_directions,
    height_above_drainage,
    normal_depth,
    stream_lines,
)
from .io import read, read_heightfield, read_mesh, write
from .io.boundaries import segment_outline
from .metrics import (
    mesh_metrics,
    non_delaunay_edges,
    rasterize,
    triangle_quality,
    vertical_error,
    vertical_error_at_points,
)
from .samples import SAMPLES, sample, sample_path
from .triangulation.delaunay import Triangulation, delaunay
from .triangulation.pointtin import tin

__all__ = [
    "DEFAULT_METHOD",
    "SAMPLES",
    "Decimation",
    "FileError",
    "FormatError",
    "GreedyEngine",
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
    "UnsupportedFormatError",
    "__version__",
    "blocks",
    "building_tree",
    "city",
    "compare_methods",
    "cvt",
    "decimate",
    "delaunay",
    "errors",
    "features",
    "fill_depressions",
    "fit_heights",
    "flood",
    "flow_accumulation",
    "flow_directions",
    "get_method",
    "greedy",
    "grid",
    "ground",
    "height_above_drainage",
    "mesh_metrics",
    "methods",
    "non_delaunay_edges",
    "normal_depth",
    "quadtree",
    "quality",
    "rasterize",
    "read",
    "read_heightfield",
    "read_landuse",
    "read_mesh",
    "reconstruct",
    "remesh",
    "sample",
    "sample_path",
    "segment_outline",
    "simplify",
    "stream_lines",
    "subsample",
    "subsample_pyramid",
    "tin",
    "triangle_quality",
    "urban",
    "vertical_error",
    "vertical_error_at_points",
    "wavelet",
    "wavelet_filter",
    "write",
]
