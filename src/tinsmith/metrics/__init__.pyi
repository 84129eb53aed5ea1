# The names of tinsmith.metrics: what type checkers and IDEs read, and what __init__.py imports on first use.
# (A stub lazy_loader reads takes only `from .module import name` lines, so the data model comes in whole.)

import tinsmith.core

from .quality import aspect_ratios, triangle_angles, triangle_quality
from .surface import closest_points, contour_distance, dem_heights, vertical_error_at_centroids
from .topology import (
    border_edges,
    border_loops,
    non_delaunay_edges,
    point_seam_defects,
    seam_coverage,
    seam_defects,
    self_intersections,
    surface_problems,
)
from .urban import footprint_iou, match_buildings, polygon_mask, raised_footprint, rmse_over
from .vertical import rasterize, source_error, vertical_error, vertical_error_at_points

def mesh_metrics(mesh: tinsmith.core.TerrainMesh, hf: tinsmith.core.Heightfield | None = None) -> dict: ...

__all__ = [
    "aspect_ratios",
    "border_edges",
    "border_loops",
    "closest_points",
    "contour_distance",
    "dem_heights",
    "footprint_iou",
    "match_buildings",
    "mesh_metrics",
    "non_delaunay_edges",
    "point_seam_defects",
    "polygon_mask",
    "raised_footprint",
    "rasterize",
    "rmse_over",
    "seam_coverage",
    "seam_defects",
    "self_intersections",
    "source_error",
    "surface_problems",
    "triangle_angles",
    "triangle_quality",
    "vertical_error",
    "vertical_error_at_centroids",
    "vertical_error_at_points",
]
