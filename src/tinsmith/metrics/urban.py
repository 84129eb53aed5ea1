"""Metrics of building models: footprints against reference polygons, heights over building cells.

Needs the ``vector`` extra (shapely) for polygons.  Rasters of polygons
use rasterio (core).
"""

from __future__ import annotations

import numpy as np

from ..core import Heightfield, TerrainMesh
from ..errors import require
from .vertical import rasterize

__all__ = ["footprint_iou", "polygon_mask", "raised_footprint", "rmse_over"]


def footprint_iou(found, reference, *, within=None) -> dict:
    """Intersection over union of the union of ``found`` polygons and the union of ``reference`` polygons.

    ``within`` (a polygon) restricts both to the area the reference covers
    (a reference that maps part of the data only).  Returns ``iou``,
    ``found_area``, ``reference_area`` and ``intersection`` (world units
    squared).
    """
    shapely = require("shapely", "vector", "comparing footprints")
    a = shapely.union_all(shapely.make_valid(np.asarray(found, dtype=object))) if len(found) else shapely.Polygon()
    b = shapely.union_all(shapely.make_valid(np.asarray(reference, dtype=object)))
    if within is not None:
        a, b = a.intersection(within), b.intersection(within)
    inter = a.intersection(b).area
    union = a.union(b).area
    return {"iou": inter / union if union else float("nan"), "found_area": a.area, "reference_area": b.area, "intersection": inter}


def polygon_mask(polygons, hf: Heightfield) -> np.ndarray:
    """(H, W) bool: the cells of ``hf`` whose centre lies in one of the polygons."""
    from rasterio import features
    from rasterio.transform import Affine

    shapes = [(p, 1) for p in polygons if not p.is_empty]
    if not shapes:
        return np.zeros(hf.shape, bool)
    return features.rasterize(shapes, out_shape=hf.shape, transform=Affine(*hf.transform[:6]), fill=0, dtype="uint8") > 0


def raised_footprint(mesh: TerrainMesh, hf: Heightfield, ground: Heightfield, min_height: float):
    """The cells where ``mesh`` stands more than ``min_height`` above ``ground``, as polygons (the rule for any mesh).

    One square polygon per cell, merged: the footprint a mesh without
    building outlines (greedy insertion, say) implies.
    """
    shapely = require("shapely", "vector", "footprints of a mesh")
    raised = (rasterize(mesh, hf) - np.where(ground.valid, ground.z, np.nan)) > min_height
    rows, cols = np.nonzero(raised & hf.valid)
    if len(rows) == 0:
        return []
    a, b, c, d, e, f = hf.transform[:6]
    cx = np.stack([cols, cols + 1, cols + 1, cols], axis=1).astype(float)  # the cell's corners, (N, 4)
    cy = np.stack([rows, rows, rows + 1, rows + 1], axis=1).astype(float)
    x = a * cx + b * cy + c
    y = d * cx + e * cy + f
    cells = shapely.polygons(np.stack([x, y], axis=2))
    return list(shapely.get_parts(shapely.union_all(cells)))


def rmse_over(mesh: TerrainMesh, hf: Heightfield, mask: np.ndarray) -> float:
    """Root mean square of mesh height minus ``hf`` over the valid cells of ``mask`` (walls are not heights: skipped)."""
    tin = rasterize(mesh, hf)
    sel = mask & hf.valid & ~np.isnan(tin)
    e = tin[sel] - hf.z[sel]
    return float(np.sqrt(np.mean(e * e))) if e.size else float("nan")
