"""Any size: seamless tiles, local or Dask execution, and Cesium quantized-mesh pyramids.

The names below are imported on first use: see ``__init__.pyi``.
"""

from .. import _lazy

#: Default size of a tiled point-cloud run: about this many points (of every class) per tile.
POINTS_PER_TILE = 3_000_000
#: Where the deepest level of a terrain pyramid holds its bound (:func:`.pyramid.pyramid_job`'s ``bound_at``).
BOUND_AT = ("cells", "nodes")

__getattr__, __dir__, __all__ = _lazy.attach(__name__, __file__)
