"""Metrics of building models: footprints against reference polygons, heights over building cells.

Needs the ``vector`` extra (shapely) for polygons.  Rasters of polygons
use rasterio (core).
"""

from __future__ import annotations

import numpy as np

from ..core import Heightfield, TerrainMesh
from ..errors import require
from .vertical import rasterize

__all__ = ["footprint_iou", "match_buildings", "polygon_mask", "raised_footprint", "rmse_over"]


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
    return {"iou": inter / union if union else float("nan"), "found_area": a.area, "reference_area": b.area,
            "intersection": inter}


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


def _box_sides(polygon) -> tuple[float, float]:
    """(length, width) of the smallest rotated rectangle around ``polygon``."""
    shapely = require("shapely", "vector", "building dimensions")
    box = shapely.oriented_envelope(polygon)
    if box.geom_type != "Polygon":
        return 0.0, 0.0
    p = np.asarray(box.exterior.coords)
    a, b = np.hypot(*(p[1] - p[0])[:2]), np.hypot(*(p[2] - p[1])[:2])
    return max(a, b), min(a, b)


def match_buildings(found, reference, *, within=None, min_iou: float = 0.5) -> dict:
    """Each reference building against the found polygon that overlaps it most: IoU and oriented-box dimensions.

    Returns ``per_building`` (one dict per reference polygon inside
    ``within``: ``iou``, and for matches with ``iou >= min_iou`` the
    ``length`` and ``width`` of both oriented boxes), ``mean_iou``,
    ``matched`` (share with ``iou >= min_iou``) and the mean absolute
    ``length_error`` and ``width_error`` of the matches (world units).
    """
    shapely = require("shapely", "vector", "matching buildings")
    found = [shapely.make_valid(p) for p in found]
    reference = [shapely.make_valid(p) for p in reference if within is None or p.intersects(within)]
    tree = shapely.STRtree(found)
    rows = []
    for ref in reference:
        best, best_iou = None, 0.0
        for i in tree.query(ref, predicate="intersects"):
            iou = ref.intersection(found[i]).area / ref.union(found[i]).area
            if iou > best_iou:
                best, best_iou = found[i], iou
        row = {"iou": best_iou}
        if best is not None and best_iou >= min_iou:
            (rl, rw), (fl, fw) = _box_sides(ref), _box_sides(best)
            row.update(length=fl, width=fw, ref_length=rl, ref_width=rw)
        rows.append(row)
    matched = [r for r in rows if "length" in r]
    return {
        "per_building": rows,
        "mean_iou": float(np.mean([r["iou"] for r in rows])) if rows else float("nan"),
        "matched": len(matched) / len(rows) if rows else float("nan"),
        "length_error": float(np.mean([abs(r["length"] - r["ref_length"]) for r in matched])) if matched else float("nan"),
        "width_error": float(np.mean([abs(r["width"] - r["ref_width"]) for r in matched])) if matched else float("nan"),
    }
