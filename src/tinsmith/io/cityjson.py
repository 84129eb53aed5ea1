"""CityJSON 2.0 output: the terrain as a TINRelief, and the buildings of an urban block model.

A mesh made by :func:`tinsmith.blocks` carries ``triangle_attributes["building"]``
(the building of each triangle, -1 for the ground) and
``triangle_attributes["kind"]`` (0 ground, 1 roof, 2 wall): each building becomes
a ``Building`` with an LoD 1 ``MultiSurface`` of its roofs and walls (with
their semantics, RoofSurface and WallSurface), the ground a ``TINRelief``.
A city model (:func:`tinsmith.city`) gives each building its LoD (1.2 for
flat roofs, 2.2 for planar ones) and its measured height (roof above the
ground under it, ``tables["building"]["height"]``); the sides and bottom of a solid
(``triangle_attributes["patch"]`` above 2) are not written.  Any
other mesh is written as one ``TINRelief``.  Coordinates are stored
as integers with a millimetre scale, as the specification recommends.
"""

from __future__ import annotations

import json

import numpy as np

from ..core import TerrainMesh
from .crs import to_epsg
from .registry import writer

__all__ = ["cityjson", "write_cityjson"]

#: Millimetres: the scale of the stored coordinates.
SCALE = 0.001


def cityjson(mesh: TerrainMesh) -> dict:
    """The CityJSON 2.0 document of ``mesh`` (see the module docstring)."""
    v = mesh.vertices
    translate = v.min(axis=0) if len(v) else np.zeros(3)
    ints = np.round((v - translate) / SCALE).astype(np.int64)
    tri = mesh.triangles
    attrs = mesh.triangle_attributes
    building = np.asarray(attrs.get("building", np.full(len(tri), -1)))
    kind = np.asarray(attrs.get("kind", np.zeros(len(tri), np.int64)))
    patch = attrs.get("patch")
    measured = mesh.tables.get("building", {}).get("height")  # a city model's roof above ground, per building
    lod = str(mesh.info.get("lod", "1"))
    objects = {}
    ground = building < 0
    terrain = ground if patch is None else np.asarray(patch) == 0  # not the sides and bottom of a solid
    objects["terrain"] = {
        "type": "TINRelief",
        "geometry": [{"type": "CompositeSurface", "lod": "1", "boundaries": [[t] for t in tri[terrain].tolist()]}],
    }
    for b in np.unique(building[~ground]):
        sel = building == b
        z = v[tri[sel], 2]
        height = float(measured[b]) if measured is not None else float(z.max() - z.min())
        objects[f"building_{int(b)}"] = {
            "type": "Building",
            "attributes": {"measuredHeight": round(height, 3), "roofHeight": round(float(z.max()), 3)},
            "geometry": [{
                "type": "MultiSurface",
                "lod": lod,
                "boundaries": [[t] for t in tri[sel].tolist()],
                "semantics": {
                    "surfaces": [{"type": "RoofSurface"}, {"type": "WallSurface"}],
                    "values": [0 if k == 1 else 1 for k in kind[sel].tolist()],
                },
            }],
        }
    doc = {
        "type": "CityJSON",
        "version": "2.0",
        "transform": {"scale": [SCALE] * 3, "translate": [float(t) for t in translate]},
        "CityObjects": objects,
        "vertices": ints.tolist(),
    }
    epsg = to_epsg(mesh.crs) if mesh.crs else None
    if epsg:
        doc["metadata"] = {"referenceSystem": f"https://www.opengis.net/def/crs/EPSG/0/{epsg}"}
    return doc


@writer(
    [".json"],
    description="CityJSON 2.0: the terrain as a TINRelief; the buildings of an urban model as LoD 1 surfaces",
    carries_crs=True,
)
def write_cityjson(mesh: TerrainMesh, path, *, grid=None) -> None:
    with open(path, "w", encoding="utf-8") as f:
        json.dump(cityjson(mesh), f, separators=(",", ":"))
