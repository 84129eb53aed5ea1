# The names of tinsmith.io: what type checkers and IDEs read; __init__.py imports the point-cloud readers'
# names on first use (lazy_loader) and defines the rest.  (A stub lazy_loader reads takes only
# `from .module import name` lines, so the data model comes in whole.)

import os
import pathlib

import tinsmith.core

from ._atomic import atomic_paths
from .points import CloudInfo, cloud_header, expand_sources, read_clouds
from .registry import READ_OPTIONS as READ_OPTIONS
from .registry import Reader, Writer

READERS: dict[str, Reader]
WRITERS: dict[str, Writer]
RASTER_FALLBACK: str
TEXT_CLOUDS: tuple[str, ...]
COMMON_NODATA: tuple[float, ...]

def reader_for(path: str | os.PathLike) -> Reader: ...
def writer_for(path: str | os.PathLike) -> Writer: ...
def is_cloud_sources(path) -> bool: ...
def read(path, **options) -> tinsmith.core.Heightfield | tinsmith.core.PointCloud | tinsmith.core.TerrainMesh: ...
def georeferencing(source, cell_size: float | None = None) -> tuple[str | None, tuple | None, float | None]: ...
def read_heightfield(path, *, cell_size: float | None = None, statistic: str = "max",
                     **options) -> tinsmith.core.Heightfield: ...
def height_warnings(hf: tinsmith.core.Heightfield) -> list[str]: ...
def read_mesh(path) -> tinsmith.core.TerrainMesh: ...
def check_output_path(path) -> Writer: ...
def write(mesh: tinsmith.core.TerrainMesh, path, *, grid: tinsmith.core.Heightfield | None = None) -> pathlib.Path: ...

__all__ = [
    "READERS",
    "WRITERS",
    "atomic_paths",
    "CloudInfo",
    "check_output_path",
    "cloud_header",
    "expand_sources",
    "georeferencing",
    "is_cloud_sources",
    "read",
    "read_clouds",
    "read_heightfield",
    "read_mesh",
    "reader_for",
    "write",
    "writer_for",
]
