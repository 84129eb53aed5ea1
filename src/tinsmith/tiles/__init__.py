"""Any size: seamless tiles, local or Dask execution, and Cesium quantized-mesh pyramids."""

from .points import TiledPointRun, point_layout, tile_cloud
from .run import TiledRun, independent_tiles, layout, tile_raster
from .worker import TILE_METHODS, TileJob, TileResult, TileSpec, mesh_tile

__all__ = ["TILE_METHODS", "TileJob", "TileResult", "TileSpec", "TiledPointRun", "TiledRun", "point_layout", "tile_cloud", "independent_tiles", "layout", "mesh_tile", "tile_raster"]
