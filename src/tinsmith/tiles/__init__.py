"""Any size: seamless tiles, local or Dask execution, and Cesium quantized-mesh pyramids."""

from .. import _lazy

#: Default size of a tiled point-cloud run: about this many points (of every class) per tile.
POINTS_PER_TILE = 3_000_000

#: public name -> the submodule defining it (imported on first use)
_LAZY = {
    **dict.fromkeys(("TiledPointRun", "point_layout", "tile_cloud"), "points"),
    **dict.fromkeys(("TiledRun", "independent_tiles", "layout", "tile_raster"), "run"),
    **dict.fromkeys(("TILE_METHODS", "TileJob", "TileResult", "TileSpec", "mesh_tile"), "worker"),
}
__getattr__ = _lazy.attributes(__name__, _LAZY)

__all__ = ["POINTS_PER_TILE", "TILE_METHODS", "TileJob", "TileResult", "TileSpec", "TiledPointRun", "TiledRun", "point_layout", "tile_cloud", "independent_tiles", "layout", "mesh_tile", "tile_raster"]
