"""3D Tiles terrain pieces: a terrain tile as binary glTF, and implicit-tiling subtree files.

Binary glTF 2.0 (https://registry.khronos.org/glTF/specs/2.0/glTF-2.0.html,
section 4.4 "GLB File Format Specification"): a 12-byte header, a JSON chunk
padded with spaces and a BIN chunk padded with zeros, both to 4 bytes.  A
terrain tile, as CesiumJS's ``Cesium3DTilesTerrainGeometryProcessor`` reads it,
is one node with a ``matrix`` and one triangle primitive: ``POSITION`` as
float32 (the node's y-up frame), optionally ``NORMAL`` (float32), ``indices`` (uint16 or uint32) and the
``CESIUM_tile_edges`` extension naming four index accessors (``left``,
``bottom``, ``right``, ``top``: the vertices on the tile's west, south, east
and north edges, in clockwise order round the tile).  An edge the mesh does
not reach has an accessor of count 0 (CesiumJS reads it; the glTF schema asks
for at least 1).

Subtree files (3D Tiles 1.1, section "Implicit Tiling", "Subtree Binary
Format"): magic ``subt``, version 1, the JSON and binary lengths as uint64,
the JSON padded with spaces to 8 bytes, the binary chunk whose buffer views
start on 8-byte boundaries.  Availability bitstreams hold bit ``i`` in byte
``i // 8`` at position ``i % 8`` (least significant first); a tile's bit is
its level offset ``(4**l - 1) / 3`` plus its Morton index within the subtree
(x in the even bits, y in the odd bits).
"""

from __future__ import annotations

import json
import struct

import numpy as np

__all__ = ["bitstream", "encode_glb", "encode_subtree", "morton"]

_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963
_FLOAT, _UNSIGNED_SHORT, _UNSIGNED_INT = 5126, 5123, 5125
_TRIANGLES = 4


def morton(x, y):
    """Morton (Z-order) index of local tile coordinates: bits of x at even positions, of y at odd ones."""
    x, y = np.asarray(x, np.int64), np.asarray(y, np.int64)
    out = np.zeros(np.broadcast(x, y).shape, np.int64)
    for bit in range(31):
        out |= ((x >> bit) & 1) << (2 * bit) | ((y >> bit) & 1) << (2 * bit + 1)
    return out


def bitstream(bits: np.ndarray) -> bytes:
    """An availability bitstream: bit i in byte i // 8, least significant bit first."""
    return np.packbits(np.asarray(bits, bool), bitorder="little").tobytes()


def _pad(data: bytes, align: int, fill: bytes = b"\0") -> bytes:
    return data + fill * (-len(data) % align)


def encode_glb(positions: np.ndarray, triangles: np.ndarray, edges: dict, matrix, normals=None) -> bytes:
    """One terrain tile as binary glTF.

    Parameters
    ----------
    positions : (N, 3) float32
        Vertex positions in the node's frame (glTF is y-up).
    triangles : (T, 3) int
        Counter-clockwise seen from outside.
    edges : dict
        ``left``, ``bottom``, ``right``, ``top``: vertex indices on each edge.
    matrix : 16 floats
        The node's matrix, column-major (glTF), placing the positions.
    normals : (N, 3) float, optional
        Unit vertex normals in the same frame (the ``NORMAL`` attribute).
    """
    positions = np.ascontiguousarray(positions, np.float32).reshape(-1, 3)
    n = len(positions)
    itype, icode = (np.uint16, _UNSIGNED_SHORT) if n <= 65535 else (np.uint32, _UNSIGNED_INT)
    blobs, views, accessors = [], [], []

    def add(data: np.ndarray, accessor: dict, target=None) -> int:
        offset = sum(len(b) for b in blobs)
        raw = data.tobytes()
        if raw:
            views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(raw),
                          **({"target": target} if target else {})})
            blobs.append(_pad(raw, 4))
            accessor = {"bufferView": len(views) - 1, **accessor}
        else:  # an empty edge: count 0 on the first buffer view
            accessor = {"bufferView": 0, **accessor}
        accessors.append(accessor)
        return len(accessors) - 1

    lo, hi = positions.min(axis=0), positions.max(axis=0)
    pos = add(positions, {"componentType": _FLOAT, "count": n, "type": "VEC3",
                          "min": [float(v) for v in lo], "max": [float(v) for v in hi]}, _ARRAY_BUFFER)
    attributes = {"POSITION": pos}
    if normals is not None:
        attributes["NORMAL"] = add(np.ascontiguousarray(normals, np.float32).reshape(-1, 3),
                                   {"componentType": _FLOAT, "count": n, "type": "VEC3"}, _ARRAY_BUFFER)
    tri = np.asarray(triangles, np.int64).reshape(-1)
    ind = add(tri.astype(itype), {"componentType": icode, "count": len(tri), "type": "SCALAR"}, _ELEMENT_ARRAY_BUFFER)
    edge_ids = {}
    for name in ("left", "bottom", "right", "top"):
        idx = np.asarray(edges[name], np.int64)
        edge_ids[name] = add(idx.astype(itype), {"componentType": icode, "count": len(idx), "type": "SCALAR"})
    binary = b"".join(blobs)
    gltf = {
        "asset": {"version": "2.0", "generator": "tinsmith"},
        "extensionsUsed": ["CESIUM_tile_edges"],
        "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "matrix": [float(v) for v in matrix]}],
        "meshes": [{"primitives": [{"attributes": attributes, "indices": ind, "mode": _TRIANGLES,
                                    "extensions": {"CESIUM_tile_edges": edge_ids}}]}],
        "accessors": accessors, "bufferViews": views, "buffers": [{"byteLength": len(binary)}],
    }
    text = _pad(json.dumps(gltf, separators=(",", ":")).encode(), 4, b" ")
    chunks = struct.pack("<I4s", len(text), b"JSON") + text + struct.pack("<I4s", len(binary), b"BIN\0") + binary
    return struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks


def encode_subtree(subtree: dict, views: list[bytes]) -> bytes:
    """A binary subtree file: ``subtree`` (JSON without buffers) and its buffer views, in one internal buffer.

    The JSON's ``bitstream`` and property-table ``values`` numbers index
    ``views``; each view starts on an 8-byte boundary.
    """
    offsets, binary = [], b""
    for v in views:
        offsets.append(len(binary))
        binary += _pad(v, 8)
    doc = dict(subtree)
    if views:
        doc["buffers"] = [{"byteLength": len(binary)}]
        doc["bufferViews"] = [{"buffer": 0, "byteOffset": o, "byteLength": len(v)} for o, v in zip(offsets, views,
                                                                                                     strict=True)]
    text = _pad(json.dumps(doc, separators=(",", ":")).encode(), 8, b" ")
    return struct.pack("<4sIQQ", b"subt", 1, len(text), len(binary)) + text + binary
