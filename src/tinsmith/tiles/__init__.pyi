# The names of tinsmith.tiles: what type checkers and IDEs read, and what __init__.py imports on first use.

from .points import TiledPointRun, point_layout, tile_cloud
from .run import TiledRun, independent_tiles, layout, tile_raster
from .worker import TILE_METHODS, TileJob, TileResult, TileSpec, mesh_tile

POINTS_PER_TILE: int
BOUND_AT: tuple[str, ...]

__all__ = [
    "BOUND_AT",
    "POINTS_PER_TILE",
    "TILE_METHODS",
    "TileJob",
    "TileResult",
    "TileSpec",
    "TiledPointRun",
    "TiledRun",
    "independent_tiles",
    "layout",
    "mesh_tile",
    "point_layout",
    "tile_cloud",
    "tile_raster",
]
