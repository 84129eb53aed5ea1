"""Terrain as 3D Tiles for CesiumJS's ``Cesium3DTilesTerrainProvider``: the quantized-mesh pyramid's tiles, as glTF.

The tiles, their sampling, meshing and seams are those of :mod:`.cesium`
(``pyramid_job``, ``tile_geometry``); only the container differs.  What the
provider reads (CesiumJS 1.145, ``packages/engine/Source/Core/``
``Cesium3DTilesTerrainProvider.js``, ``Cesium3DTilesTerrainData.js``,
``Cesium3DTilesTerrainGeometryProcessor.js``, and ``Scene/ImplicitTileset.js``,
``Scene/ImplicitSubtree.js``, ``Scene/MetadataSemantic.js``,
``Scene/GltfPipeline/parseGlb.js``):

* ``tileset.json``: ``root.children[0]`` and ``[1]`` are two implicit
  quadtrees (``implicitTiling``: ``QUADTREE``, ``subtreeLevels``,
  ``availableLevels``, ``subtrees.uri``; ``content.uri`` a template of
  ``{level}``, ``{x}``, ``{y}``; a ``region`` bounding volume), the western
  and eastern hemispheres: level ``z`` of the geographic tiling scheme is
  level ``z`` of the quadtree of ``x // 2**z``, at implicit x ``x % 2**z``
  and implicit y counted from the south (our TMS rows).  The tileset's
  ``schema`` holds the class of the tile metadata.
* Subtree files (binary, fetched on demand): tile availability (which also
  gives Cesium each tile's child mask; unavailable children are upsampled
  from the parent), content availability, child-subtree availability, and
  a property table of tile metadata read by semantic: ``TILE_MINIMUM_HEIGHT``,
  ``TILE_MAXIMUM_HEIGHT`` (the oriented bounding box is built from these
  and the tile's rectangle), ``TILE_BOUNDING_SPHERE`` (4 numbers, also the
  centre of Cesium's vertex encoding), ``TILE_HORIZON_OCCLUSION_POINT``
  (ellipsoid-scaled, as in quantized-mesh).  We add ``TILE_GEOMETRIC_ERROR``,
  the tile's measured error, for 3D Tiles readers; the terrain provider
  refines by its own level error and skirts tiles with 5 times it.
* One glb per tile (:func:`tinsmith.io.tiles3d.encode_glb`): ``nodes[0].matrix``
  times CesiumJS's y-up to z-up rotation places the float32 ``POSITION`` in
  Earth-centred coordinates; longitude, latitude and height come from those
  positions, except that the vertices of the ``CESIUM_tile_edges`` accessors
  get u or v exactly 0 or 1.  ``EXT_meshopt_compression`` is optional (not
  used here); ``NORMAL`` is read only with ``requestVertexNormals`` (written
  with ``normals``); a water mask is an ``EXT_structural_metadata`` property
  texture with the ``WATERMASK`` semantic (not written here).

Seams: a vertex's Earth-centred position is rounded to a grid of ``2**-k``
metres fixed per level, and so is each tile's translation, with ``k`` such
that every offset from the translation is exactly a float32; CesiumJS adds
them back in float64, so neighbours decode the same position (hence the same
longitude, latitude and height) for every shared edge vertex.  Heights are the
pyramid's quantized heights (one step for the whole pyramid, see
:mod:`.cesium`), metres above the WGS84 ellipsoid.

Levels: every level from 0 (the two level-0 tiles always exist, the one
without data as the flat ellipsoid) to ``max_zoom`` over the DEM's bounds.
CesiumJS assumes a terrain tile covers its whole rectangle (it builds skirts
from the four edges and finds no height outside the triangles), so nodes
without data take the ellipsoid's height (:func:`fill_height`, within half a
height step of 0): the DEM stands on the ellipsoid with a cliff round it.
Coarse tiles without data are a grid of the ellipsoid fine enough for their
level's bound (two triangles over a level-0 tile would meet at the poles).

Precision in CesiumJS: it re-encodes a tile's vertices in 12 bits (its
``TerrainEncoding``) when the tile, skirts included, fits in 4,095 m; then
heights are rounded to (height range + skirts) / 4095 and u, v to 1/4095 of
the tile, which ``sampleTerrain`` sees (up to 0.8 m on St. Helens' slopes at
level 13).  Larger tiles keep float32 vertices.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..errors import InvalidOptionError
from ..io import atomic_paths
from ..io.quantized_mesh import QUANT, ecef, edge_indices, horizon_occlusion_point
from ..io.tiles3d import bitstream, encode_glb, encode_subtree, morton
from .certificate import tile_certificate
from .pyramid import (
    PyramidJob,
    fill_height,
    job_record,
    open_pyramid,
    pyramid_job,
    tile_bounds,
    tile_geometry,
    tiles_of_level,
    write_tiles,
)

__all__ = ["SUBTREE_LEVELS", "terrain_3dtiles", "terrain_tile"]

#: Levels per subtree file (the last subtrees hold fewer when the levels do not divide evenly).
SUBTREE_LEVELS = 6
_ROOTS = ("west", "east")
_HALF_METRES = 20037508.35  # half the equator: the widest tile of level 0 spans no more
_FORMAT = "3dtiles-terrain"

_SCHEMA = {"id": "tinsmith_terrain", "classes": {"tile": {"properties": {
    "minimumHeight": {"type": "SCALAR", "componentType": "FLOAT64", "semantic": "TILE_MINIMUM_HEIGHT"},
    "maximumHeight": {"type": "SCALAR", "componentType": "FLOAT64", "semantic": "TILE_MAXIMUM_HEIGHT"},
    "boundingSphere": {"type": "SCALAR", "componentType": "FLOAT64", "array": True, "count": 4,
                       "semantic": "TILE_BOUNDING_SPHERE"},
    "horizonOcclusionPoint": {"type": "VEC3", "componentType": "FLOAT64", "semantic": "TILE_HORIZON_OCCLUSION_POINT"},
    "geometricError": {"type": "SCALAR", "componentType": "FLOAT64", "semantic": "TILE_GEOMETRIC_ERROR"},
}}}}
#: The metadata of a tile as the log keeps it, in the schema's order, and how many numbers each holds.
_FIELDS = (("minimumHeight", "min_height", 1), ("maximumHeight", "max_height", 1), ("boundingSphere", "sphere", 4),
           ("horizonOcclusionPoint", "horizon", 3), ("geometricError", "geometric_error", 1))


def _grid_step(z: int, job: PyramidJob) -> float:
    """Metres of level z's position grid: offsets within a tile of up to ``2**24`` steps are exact float32."""
    h = max(abs(job.h_min), abs(job.h_min + QUANT * job.h_step))
    reach = _HALF_METRES / 2 ** z + 2 * h + 1.0
    return 2.0 ** (math.ceil(math.log2(reach)) - 24)


def _tile_error(tile, job: PyramidJob, g: dict, height: np.ndarray) -> dict:
    """A tile's certificate, whose ``max_error`` is its geometric error: the largest vertical error against the DEM
    at every cell it covers (:mod:`.certificate`; the triangles reaching nodes filled for lack of data left out)."""
    return tile_certificate(job, tile_bounds(*tile), g, height)


def _edges(u: np.ndarray, v: np.ndarray) -> dict:
    """Indices of the vertices on each edge, clockwise round the tile (CesiumJS's skirt order)."""
    e = edge_indices(u, v)
    return {"left": e["west"], "bottom": e["south"][::-1], "right": e["east"][::-1], "top": e["north"]}


def terrain_tile(tile: tuple[int, int, int], job: PyramidJob):
    """Sample, mesh and encode one tile: (glb bytes, its metadata and stats)."""
    start = time.perf_counter()
    z = tile[0]
    g = tile_geometry(tile, job, fill=fill_height(job))  # every node without data: a tile covers its rectangle
    height = job.h_min + g["k"] * job.h_step
    step = _grid_step(z, job)
    points = np.rint(ecef(g["lon"], g["lat"], height) / step) * step
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre = np.rint((lo + hi) / 2 / step) * step
    local = points - centre
    yup = np.column_stack([local[:, 0], local[:, 2], -local[:, 1]])  # glTF's y-up frame
    if not np.array_equal(yup.astype(np.float32).astype(np.float64), yup):
        raise ValueError(f"tile {tile}: offsets on the {step} m grid are not exact float32")
    matrix = np.eye(4)
    matrix[:3, 3] = [centre[0], centre[2], -centre[1]]
    normals = None
    if job.normals:  # the sampled surface's at each node, the same on both sides of a seam (as in quantized-mesh)
        n = g["normals"]
        normals = np.column_stack([n[:, 0], n[:, 2], -n[:, 1]])
    data = encode_glb(yup, g["triangles"], _edges(np.asarray(g["u"]), np.asarray(g["v"])), matrix.T.ravel(), normals)
    sphere_centre = (lo + hi) / 2
    radius = float(np.sqrt(((points - sphere_centre) ** 2).sum(axis=1).max()))
    # rounding a position to the grid moves it by at most step * sqrt(3) / 2: its height by no more than step
    meta = {"min_height": float(height.min()) - step, "max_height": float(height.max()) + step,
            "sphere": [*map(float, sphere_centre), radius],
            "horizon": [float(c) for c in horizon_occlusion_point(points, sphere_centre)],
            "max_error": float(g["max_error"]), "bound": float(g["bound"]),
            "vertices": len(points), "triangles": len(g["triangles"]), "data": bool(g["data"]), "refined": g["refined"],
            "seconds": time.perf_counter() - start}
    cert = _tile_error(tile, job, g, height)
    meta.update(geometric_error=float(cert["max_error"]), cells=cert["cells"], uncovered=cert["uncovered"])
    return data, meta


def _root_and_x(z: int, x: int) -> tuple[int, int]:
    """Which implicit quadtree (0 west, 1 east) holds geographic tile column x of level z, and its implicit x."""
    return x >> z, x & ((1 << z) - 1)


def _tile_path(tile) -> str:
    z, x, y = tile
    root, ix = _root_and_x(z, x)
    return f"{_ROOTS[root]}/{z}/{ix}/{y}.glb"


def _subtrees(metas: dict, levels: int) -> dict[str, bytes]:
    """Every subtree file (relative path -> bytes) of the available tiles ``metas`` ({(z, x, y): metadata})."""
    groups: dict[tuple, list] = {}
    child_roots: dict[tuple, list] = {}
    for (z, x, y) in metas:
        root, ix = _root_and_x(z, x)
        top = z - z % levels
        local = z - top
        sx, sy = ix >> local, y >> local
        groups.setdefault((root, top, sx, sy), []).append(
            ((4 ** local - 1) // 3 + int(morton(ix - (sx << local), y - (sy << local))), (z, x, y)))
        if z and not local:  # the root of a child subtree of the subtree above
            px, py = ix >> levels, y >> levels
            child_roots.setdefault((root, z - levels, px, py), []).append(
                int(morton(ix - (px << levels), y - (py << levels))))
    files = {}
    for (root, top, sx, sy), inside in sorted(groups.items()):
        children = child_roots.get((root, top, sx, sy), [])
        inside.sort()
        bits = np.zeros((4 ** levels - 1) // 3, bool)
        bits[[i for i, _ in inside]] = True
        views = [bitstream(bits)]
        doc = {"tileAvailability": {"bitstream": 0, "availableCount": len(inside)},
               "contentAvailability": [{"bitstream": 0, "availableCount": len(inside)}]}
        if children:
            child_bits = np.zeros(4 ** levels, bool)
            child_bits[children] = True
            views.append(bitstream(child_bits))
            doc["childSubtreeAvailability"] = {"bitstream": 1, "availableCount": len(children)}
        else:
            doc["childSubtreeAvailability"] = {"constant": 0}
        properties = {}
        for name, key, _ in _FIELDS:
            values = np.array([metas[t][key] for _, t in inside], np.float64)
            properties[name] = {"values": len(views)}
            views.append(values.tobytes())
        doc["propertyTables"] = [{"class": "tile", "count": len(inside), "properties": properties}]
        doc["tileMetadata"] = 0
        files[f"{_ROOTS[root]}/subtrees/{top}/{sx}/{sy}.subtree"] = encode_subtree(doc, views)
    return files


def _tileset(job: PyramidJob, metas: dict, levels: int, bounds) -> dict:
    """tileset.json: two implicit quadtrees (west and east hemispheres) under one root."""
    lo = min(m["min_height"] for m in metas.values())
    hi = max(m["max_height"] for m in metas.values())
    children = []
    for root, name in enumerate(_ROOTS):
        west = -math.pi + root * math.pi
        children.append({
            "boundingVolume": {"region": [west, -math.pi / 2, west + math.pi, math.pi / 2, lo, hi]},
            "geometricError": metas[(0, root, 0)]["geometric_error"], "refine": "REPLACE",
            "content": {"uri": f"{name}/{{level}}/{{x}}/{{y}}.glb"},
            "implicitTiling": {"subdivisionScheme": "QUADTREE", "subtreeLevels": levels,
                               "availableLevels": job.max_zoom + 1,
                               "subtrees": {"uri": f"{name}/subtrees/{{level}}/{{x}}/{{y}}.subtree"}},
        })
    error = max(m["geometric_error"] for m in metas.values())  # the root and the tileset: no tile is worse
    return {
        "asset": {"version": "1.1", "generator": "tinsmith", "tilesetVersion": "1.0.0"},
        "schema": _SCHEMA, "geometricError": error,
        "root": {"boundingVolume": {"region": [-math.pi, -math.pi / 2, math.pi, math.pi / 2, lo, hi]},
                 "geometricError": error, "refine": "REPLACE", "children": children},
        "extras": {"tinsmith": {"name": Path(job.raster.path).stem, "bounds": list(bounds),
                                "height_min": job.h_min, "height_step": job.h_step, "cell_metres": job.cell_m,
                                "max_error": job.max_error, "method": job.method, "max_zoom": job.max_zoom,
                                "height_offset": job.height_offset,
                                "description": "heights in metres above the WGS84 ellipsoid: the DEM's plus "
                                               f"{job.height_offset} m; geometricError per tile in its metadata "
                                               "(TILE_GEOMETRIC_ERROR): the tile's measured maximum vertical error"}},
    }


def terrain_3dtiles(source, out_dir, *, max_error: float, method: str = "greedy", options: dict | None = None,
                    tile_cells: int = 256, min_zoom: int = 0, max_zoom: int | None = None, normals: bool = False,
                    height_offset: float = 0.0, vertical_crs: str | None = None, workers: int | None = None,
                    scheduler: str | None = None, band: int = 1, nodata=None, bound_at: str = "cells",
                    progress: Callable[[int, int], None] | None = None) -> dict:
    """Write a DEM as 3D Tiles terrain for CesiumJS into ``out_dir`` (``tileset.json`` last).

    Parameters are those of :func:`tinsmith.tiles.cesium.quantized_mesh_pyramid`
    (the same tiles and error bounds), except that ``min_zoom`` must be 0:
    the provider starts from the two level-0 tiles; ``normals`` adds the
    ``NORMAL`` attribute (read with ``requestVertexNormals``).  Tiles already in
    ``out_dir`` from the same job are kept (resume); the folder of another
    job is refused.  Returns a summary (levels, tiles, triangles, errors, the
    height step, subtree files).
    """
    job = pyramid_job(source, max_error=max_error, method=method, options=options, tile_cells=tile_cells,
                      min_zoom=min_zoom, max_zoom=max_zoom, normals=normals, height_offset=height_offset,
                      vertical_crs=vertical_crs, band=band, nodata=nodata, metadata=False, bound_at=bound_at)
    if job.min_zoom != 0:
        raise InvalidOptionError(f"min_zoom must be 0 for 3D Tiles terrain (CesiumJS's Cesium3DTilesTerrainProvider "
                                 f"starts from the two level-0 tiles), got {job.min_zoom}")
    bounds = job.bounds
    tiles = [(0, 0, 0), (0, 1, 0)] + [t for z in range(1, job.max_zoom + 1) for t in tiles_of_level(z, bounds)]
    out_dir = Path(out_dir)
    made = not out_dir.exists()
    done, log = open_pyramid(out_dir, {**job_record(job, bounds), "format": _FORMAT}, _tile_path)
    todo = [t for t in tiles if t not in done]
    reused = len(tiles) - len(todo)
    write_tiles(terrain_tile, todo, job, out_dir, _tile_path, done, log, made, workers, scheduler, progress,
                len(tiles))
    levels = min(SUBTREE_LEVELS, job.max_zoom + 1)
    subtrees = _subtrees(done, levels)
    for name, data in sorted(subtrees.items()):
        target = out_dir / name
        target.parent.mkdir(parents=True, exist_ok=True)
        with atomic_paths(target) as (tmp,):
            tmp.write_bytes(data)
    with atomic_paths(out_dir / "tileset.json") as (tmp,):
        tmp.write_text(json.dumps(_tileset(job, done, levels, bounds), indent=1))
    per_level: dict[int, dict] = {}
    for (z, _, _), s in sorted(done.items()):
        lvl = per_level.setdefault(z, {"tiles": 0, "empty": 0, "triangles": 0, "max_error": 0.0, "mesh_error": 0.0,
                                       "cells": 0, "uncovered": 0, "bound": s["bound"]})
        lvl["tiles"] += 1
        lvl["cells"] += s.get("cells", 0)
        lvl["uncovered"] += s.get("uncovered", 0)
        lvl["empty"] += not s["data"]
        lvl["triangles"] += s["triangles"]
        lvl["refined"] = lvl.get("refined", 0) + s.get("refined", 0)
        lvl["max_error"] = max(lvl["max_error"], s["geometric_error"])  # against the DEM's cells
        lvl["mesh_error"] = max(lvl["mesh_error"], s["max_error"])  # against the tile's nodes
    return {"levels": per_level, "tiles": len(done), "reused": reused, "subtrees": len(subtrees),
            "subtree_levels": levels, "height_step": job.h_step, "bounds": bounds, "min_zoom": 0,
            "max_zoom": job.max_zoom, "heights": job.heights.record(job.height_offset), "bound_at": job.bound_at}
