"""The data model: numpy only, no I/O."""

from .heightfield import Heightfield
from .mesh import TerrainMesh
from .pointcloud import PointCloud
from .stop import StopCriteria

__all__ = ["Heightfield", "PointCloud", "StopCriteria", "TerrainMesh"]
