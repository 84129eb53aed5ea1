# The data model's classes: what type checkers and IDEs read, and what __init__.py imports on first use.

from .heightfield import Heightfield
from .mesh import TerrainMesh
from .pointcloud import PointCloud
from .stop import StopCriteria

__all__ = ["Heightfield", "PointCloud", "StopCriteria", "TerrainMesh"]
