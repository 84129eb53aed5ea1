"""Cesium quantized-mesh-1.0 terrain tiles: encode and decode.

The format (https://github.com/CesiumGS/quantized-mesh): an 88-byte header
(tile centre in ECEF, height range, bounding sphere, horizon occlusion
point), the vertices as u, v, height in 0..32767 (zig-zag delta coded), the
triangles (high-water-mark coded), the vertex indices on the tile's four
edges, then extensions (here: oct-encoded vertex normals, id 1).  Heights
are metres above the WGS84 ellipsoid.

Everything is little-endian; indices are 16-bit up to 65,536 vertices and
32-bit beyond (with the index data aligned to 4 bytes).
"""

from __future__ import annotations

import json
import struct

import numpy as np

from ..errors import FormatError

__all__ = ["QUANT", "WATER_MASK_SIZE", "WGS84", "decode_tile", "ecef", "edge_indices", "ellipsoid_normals", "encode_tile",
           "height_at", "horizon_occlusion_point", "oct_decode", "oct_encode", "vertex_normals"]

#: The quantized range of u, v and height.
QUANT = 32767
#: WGS84 semi-axes (metres).
WGS84 = (6378137.0, 6378137.0, 6356752.3142451793)
_HEADER = struct.Struct("<3d2f4d3d")
_NORMALS, _WATER, _METADATA = 1, 2, 4
#: Side of a water mask that mixes land and water (bytes).
WATER_MASK_SIZE = 256


def ecef(lon, lat, h) -> np.ndarray:
    """(N, 3) Earth-centred, Earth-fixed coordinates of WGS84 longitudes, latitudes (degrees) and heights."""
    a, _, b = WGS84
    lon, lat = np.radians(lon), np.radians(lat)
    e2 = 1.0 - (b * b) / (a * a)
    n = a / np.sqrt(1.0 - e2 * np.sin(lat) ** 2)
    return np.column_stack([(n + h) * np.cos(lat) * np.cos(lon), (n + h) * np.cos(lat) * np.sin(lon),
                            (n * (1.0 - e2) + h) * np.sin(lat)])


def horizon_occlusion_point(points: np.ndarray, center: np.ndarray) -> np.ndarray:
    """Cesium's horizon-culling point of ``points`` seen along ``center``, in ellipsoid-scaled space."""
    radii = np.array(WGS84)
    direction = center / radii
    direction = direction / np.linalg.norm(direction)
    scaled = points / radii
    mag2 = np.einsum("ij,ij->i", scaled, scaled)
    mag = np.sqrt(mag2)
    unit = scaled / mag[:, None]
    mag2, mag = np.maximum(mag2, 1.0), np.maximum(mag, 1.0)
    cos_a = unit @ direction
    sin_a = np.linalg.norm(np.cross(unit, direction), axis=1)
    cos_b = 1.0 / mag
    sin_b = np.sqrt(mag2 - 1.0) * cos_b
    with np.errstate(divide="ignore", invalid="ignore"):
        magnitude = float(np.max(1.0 / (cos_a * cos_b - sin_a * sin_b)))
    if not (np.isfinite(magnitude) and magnitude > 0):  # a tile reaching round the horizon: nothing can hide it
        magnitude = 1e3
    return direction * magnitude


def oct_encode(normals: np.ndarray) -> np.ndarray:
    """(N, 2) uint8 oct-encoding (Cesium's, range 255) of unit vectors."""
    n = normals / np.abs(normals).sum(axis=1, keepdims=True)
    x, y, z = n[:, 0], n[:, 1], n[:, 2]
    sx, sy = np.where(x >= 0, 1.0, -1.0), np.where(y >= 0, 1.0, -1.0)
    ox = np.where(z < 0, (1.0 - np.abs(y)) * sx, x)
    oy = np.where(z < 0, (1.0 - np.abs(x)) * sy, y)
    return np.rint((np.column_stack([ox, oy]) * 0.5 + 0.5) * 255).astype(np.uint8)


def oct_decode(encoded: np.ndarray) -> np.ndarray:
    """Unit vectors of (N, 2) uint8 oct-encoded normals."""
    xy = encoded.astype(np.float64) / 255 * 2.0 - 1.0
    x, y = xy[:, 0], xy[:, 1]
    z = 1.0 - np.abs(x) - np.abs(y)
    sx, sy = np.where(x >= 0, 1.0, -1.0), np.where(y >= 0, 1.0, -1.0)
    xx = np.where(z < 0, (1.0 - np.abs(y)) * sx, x)
    yy = np.where(z < 0, (1.0 - np.abs(x)) * sy, y)
    v = np.column_stack([xx, yy, z])
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _zigzag_delta(values: np.ndarray) -> np.ndarray:
    d = np.diff(values.astype(np.int32), prepend=0)
    return ((d << 1) ^ (d >> 31)).astype(np.uint16)


def _unzigzag_delta(codes: np.ndarray) -> np.ndarray:
    c = codes.astype(np.int32)
    return np.cumsum((c >> 1) ^ -(c & 1)).astype(np.int32)


def _first_use_order(triangles: np.ndarray, n: int) -> np.ndarray:
    """New index of every vertex: the order of first use in the triangle list (what high-water marks need)."""
    flat = triangles.ravel()
    _, first = np.unique(flat, return_index=True)
    order = flat[np.sort(first)]
    if len(order) != n:
        raise ValueError("every vertex of a quantized-mesh tile must belong to a triangle")
    new = np.empty(n, np.int64)
    new[order] = np.arange(n)
    return new


def encode_tile(lon, lat, height, u, v, h, triangles, h_min: float, h_max: float, *, normals=False, water=None,
                metadata: dict | None = None) -> bytes:
    """One tile's bytes (not gzipped).

    Parameters
    ----------
    lon, lat, height : (N,) float
        The vertices in WGS84 degrees and metres above the ellipsoid (for the
        header and the normals).
    u, v, h : (N,) int
        Their quantized coordinates in 0..32767: u west to east, v south to
        north, h from ``h_min`` (0) to ``h_max`` (32767).
    triangles : (T, 3) int
        Counter-clockwise seen from above; every vertex belongs to one.
    normals : bool or (N, 3) float
        Add the oct-encoded vertex normals extension (id 1): True for the
        area-weighted normals of the tile's own triangles, or the unit
        normals (ECEF) of the vertices, in their input order.
    water : None, int or (256, 256) uint8
        Add the water mask extension (id 2): 0 (all land) or 255 (all water),
        or the mask from the north-west corner, rows north to south.
    metadata : dict or None
        Add the metadata extension (id 4) holding this JSON object.
    """
    n = len(u)
    tri = np.asarray(triangles, np.int64).reshape(-1, 3)
    new = _first_use_order(tri, n)
    order = np.argsort(new)
    u, v, h = (np.asarray(a, np.int64)[order] for a in (u, v, h))
    given = None if isinstance(normals, bool) else np.asarray(normals, np.float64).reshape(-1, 3)[order]
    lon, lat, height = (np.asarray(a, np.float64)[order] for a in (lon, lat, height))
    tri = new[tri]
    for name, a in (("u", u), ("v", v), ("h", h)):
        if len(a) and (a.min() < 0 or a.max() > QUANT):
            raise ValueError(f"quantized {name} must lie in 0..{QUANT}")
    points = ecef(lon, lat, height)
    lo, hi = points.min(axis=0), points.max(axis=0)
    center = (lo + hi) / 2
    radius = float(np.sqrt(((points - center) ** 2).sum(axis=1).max()))
    horizon = horizon_occlusion_point(points, center)
    out = [_HEADER.pack(*center, h_min, h_max, *center, radius, *horizon), struct.pack("<I", n)]
    for a in (u, v, h):
        out.append(_zigzag_delta(a).tobytes())
    wide = n > 65536
    itype = np.uint32 if wide else np.uint16
    if wide:
        size = sum(len(b) for b in out)
        out.append(b"\0" * (-size % 4))
    # high-water-mark coding
    flat = tri.ravel()
    highest = np.maximum.accumulate(np.r_[-1, flat[:-1]]) + 1 if len(flat) else flat
    out.append(struct.pack("<I", len(tri)))
    out.append((highest - flat).astype(itype).tobytes())
    for idx in edge_indices(u, v).values():  # west, south, east, north
        out.append(struct.pack("<I", len(idx)) + idx.astype(itype).tobytes())
    if given is not None or normals is True:
        unit = vertex_normals(points, tri) if given is None else given
        out.append(struct.pack("<BI", _NORMALS, 2 * n) + oct_encode(unit).tobytes())
    if water is not None:
        mask = np.asarray(water, np.uint8)
        if mask.shape not in ((), (1,), (WATER_MASK_SIZE, WATER_MASK_SIZE)):
            raise ValueError(f"a water mask is one byte or {WATER_MASK_SIZE} x {WATER_MASK_SIZE}, got shape {mask.shape}")
        out.append(struct.pack("<BI", _WATER, mask.size) + mask.tobytes())
    if metadata is not None:
        text = json.dumps(metadata, separators=(",", ":"), sort_keys=True).encode()
        out.append(struct.pack("<BII", _METADATA, 4 + len(text), len(text)) + text)
    return b"".join(out)


def edge_indices(u: np.ndarray, v: np.ndarray) -> dict[str, np.ndarray]:
    """Indices of the vertices on the tile's west, south, east and north edges (in that order), each sorted along
    its edge (south to north, west to east)."""
    out = {}
    for name, edge, along in (("west", u == 0, v), ("south", v == 0, u), ("east", u == QUANT, v),
                              ("north", v == QUANT, u)):
        idx = np.flatnonzero(edge)
        out[name] = idx[np.argsort(along[idx], kind="stable")]
    return out


def vertex_normals(points: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals in ECEF (the ellipsoid's normal where a vertex has no area)."""
    p0, p1, p2 = points[tri[:, 0]], points[tri[:, 1]], points[tri[:, 2]]
    face = np.cross(p1 - p0, p2 - p0)
    acc = np.zeros_like(points)
    for k in range(3):
        np.add.at(acc, tri[:, k], face)
    norm = np.linalg.norm(acc, axis=1)
    ok = norm > 0
    acc[ok] /= norm[ok, None]
    acc[~ok] = ellipsoid_normals(points[~ok])
    return acc


def ellipsoid_normals(points: np.ndarray) -> np.ndarray:
    """(N, 3) unit normals of the WGS84 ellipsoid (geodetic up) at ECEF ``points``."""
    up = points / np.array(WGS84) ** 2
    return up / np.linalg.norm(up, axis=1, keepdims=True)


def decode_tile(data: bytes) -> dict:
    """The contents of a (not gzipped) tile: header, u, v, h, triangles, edge indices, and the extensions (None
    when absent): normals, water (0/255 or a (256, 256) mask, rows from the north) and metadata (a dict)."""
    try:
        values = _HEADER.unpack_from(data, 0)
        pos = _HEADER.size
        (n,) = struct.unpack_from("<I", data, pos)
        pos += 4
        uvh = [_unzigzag_delta(np.frombuffer(data, np.uint16, n, pos + 2 * n * k)) for k in range(3)]
        pos += 6 * n
        wide = n > 65536
        itype, isize = (np.uint32, 4) if wide else (np.uint16, 2)
        if wide:
            pos += -pos % 4
        (t,) = struct.unpack_from("<I", data, pos)
        pos += 4
        codes = np.frombuffer(data, itype, 3 * t, pos).astype(np.int64)
        pos += 3 * t * isize
        fresh = codes == 0  # high-water marks: a code of 0 is the next new vertex
        flat = (np.cumsum(fresh) - fresh) - codes  # the mark before each index, less its code
        edges = []
        for _ in range(4):
            (k,) = struct.unpack_from("<I", data, pos)
            pos += 4
            edges.append(np.frombuffer(data, itype, k, pos).astype(np.int64))
            pos += k * isize
        normals = water = metadata = None
        while pos < len(data):
            ext, length = struct.unpack_from("<BI", data, pos)
            pos += 5
            if pos + length > len(data):
                raise ValueError(f"extension {ext} runs {pos + length - len(data)} bytes past the end")
            if ext == _NORMALS:
                normals = oct_decode(np.frombuffer(data, np.uint8, 2 * n, pos).reshape(-1, 2))
            elif ext == _WATER:
                mask = np.frombuffer(data, np.uint8, length, pos)
                water = int(mask[0]) if length == 1 else mask.reshape(WATER_MASK_SIZE, WATER_MASK_SIZE)
            elif ext == _METADATA:
                (size,) = struct.unpack_from("<I", data, pos)
                metadata = json.loads(data[pos + 4:pos + 4 + size].decode())
            pos += length
    except (struct.error, ValueError) as exc:
        raise FormatError(f"not a quantized-mesh tile: {exc}") from None
    header = dict(zip(["center", "min_height", "max_height", "sphere_center", "sphere_radius", "horizon"],
                      [values[0:3], values[3], values[4], values[5:8], values[8], values[9:12]], strict=True))
    return {"header": header, "u": uvh[0], "v": uvh[1], "h": uvh[2], "triangles": flat.reshape(-1, 3),
            "west": edges[0], "south": edges[1], "east": edges[2], "north": edges[3], "normals": normals,
            "water": water, "metadata": metadata}


def height_at(tile: dict, bounds, lon: float, lat: float) -> float:
    """Height of a decoded tile at (lon, lat), interpolated in the triangle that holds it (NaN outside every one).

    ``bounds`` is the tile's (west, south, east, north) in degrees; as
    Cesium's ``QuantizedMeshTerrainData.interpolateHeight``, barycentric in
    (u, v) over the decoded heights.
    """
    w, s, e, n = bounds
    pu, pv = (lon - w) / (e - w) * QUANT, (lat - s) / (n - s) * QUANT
    hdr = tile["header"]
    h = hdr["min_height"] + tile["h"] / QUANT * (hdr["max_height"] - hdr["min_height"])
    u, v = tile["u"].astype(np.float64), tile["v"].astype(np.float64)
    a, b, c = tile["triangles"].T
    det = (v[b] - v[c]) * (u[a] - u[c]) + (u[c] - u[b]) * (v[a] - v[c])
    with np.errstate(divide="ignore", invalid="ignore"):
        l1 = ((v[b] - v[c]) * (pu - u[c]) + (u[c] - u[b]) * (pv - v[c])) / det
        l2 = ((v[c] - v[a]) * (pu - u[c]) + (u[a] - u[c]) * (pv - v[c])) / det
    l3 = 1.0 - l1 - l2
    inside = np.flatnonzero((l1 >= -1e-9) & (l2 >= -1e-9) & (l3 >= -1e-9) & (det != 0))
    if not len(inside):
        return float("nan")
    k = inside[0]
    return float(l1[k] * h[a[k]] + l2[k] * h[b[k]] + l3[k] * h[c[k]])
