"""The data model: numpy only, no I/O.

The classes are imported on first use (the command line starts without numpy).
"""

from .. import _lazy

_LAZY = {"Heightfield": "heightfield", "TerrainMesh": "mesh", "PointCloud": "pointcloud", "StopCriteria": "stop"}
__getattr__ = _lazy.attributes(__name__, _LAZY)

__all__ = ["Heightfield", "PointCloud", "StopCriteria", "TerrainMesh"]
