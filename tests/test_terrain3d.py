"""3D Tiles terrain: the tileset, subtree and glTF layout CesiumJS's Cesium3DTilesTerrainProvider reads, seams, and
CesiumJS itself sampling it against the DEM.

The readers here are written from the specs (glTF 2.0 section 4.4 "GLB File Format Specification"; 3D Tiles 1.1
"Implicit Tiling", "Subtree Binary Format", "Availability"), not from the writer.
"""

from __future__ import annotations

import json
import os
import struct
import time
from pathlib import Path

import numpy as np
import pytest

import tinsmith
from tinsmith.cli.main import main
from tinsmith.tiles.cesium import quantized_mesh_pyramid
from tinsmith.tiles.terrain3d import terrain_3dtiles

ST_HELENS = tinsmith.sample_path("st-helens")
CESIUM = Path(__file__).parent / "js/node_modules/cesium/Build/Cesium"
#: The fixture's pyramid: at level 12 a node every 38 m (under two 30 m cells), so the DEM is sampled, not averaged;
#: and tiles 4.9 km tall, over the 4,095 m under which CesiumJS re-encodes a tile's vertices in 12 bits (its
#: TerrainEncoding), so that CesiumJS's heights are float32 ones.
KW = {"max_error": 2.0, "tile_cells": 128, "max_zoom": 12, "normals": True, "workers": 1}


@pytest.fixture(scope="module")
def tileset(tmp_path_factory):
    out = tmp_path_factory.mktemp("t3d") / "terrain"
    return out, terrain_3dtiles(ST_HELENS, out, **KW)


def read_glb(path: Path) -> dict:
    """JSON and arrays of a glb: accessors by index as numpy arrays, the node matrix (column-major)."""
    data = path.read_bytes()
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    assert (magic, version, length) == (b"glTF", 2, len(data))
    n_json, kind = struct.unpack_from("<I4s", data, 12)
    assert kind == b"JSON" and n_json % 4 == 0
    doc = json.loads(data[20:20 + n_json])
    n_bin, kind = struct.unpack_from("<I4s", data, 20 + n_json)
    assert kind == b"BIN\0" and 28 + n_json + n_bin == len(data)
    binary = data[28 + n_json:]
    types = {5126: np.float32, 5123: np.uint16, 5125: np.uint32}
    sizes = {"SCALAR": 1, "VEC3": 3}

    def accessor(i):
        a = doc["accessors"][i]
        view = doc["bufferViews"][a["bufferView"]]
        start = view.get("byteOffset", 0) + a.get("byteOffset", 0)
        dtype = types[a["componentType"]]
        assert start % np.dtype(dtype).itemsize == 0  # CesiumJS makes typed arrays right on the buffer
        return np.frombuffer(binary, dtype, a["count"] * sizes[a["type"]], start).reshape(a["count"], -1).squeeze(1) \
            if a["type"] == "SCALAR" else np.frombuffer(binary, dtype, a["count"] * 3, start).reshape(-1, 3)

    prim = doc["meshes"][0]["primitives"][0]
    edges = {k: accessor(v) for k, v in prim["extensions"]["CESIUM_tile_edges"].items()}
    normals = accessor(prim["attributes"]["NORMAL"]) if "NORMAL" in prim["attributes"] else None
    return {"doc": doc, "positions": accessor(prim["attributes"]["POSITION"]), "indices": accessor(prim["indices"]),
            "normals": normals,
            "edges": edges, "matrix": np.array(doc["nodes"][0]["matrix"]).reshape(4, 4).T}


def ecef_of(glb: dict) -> np.ndarray:
    """Earth-centred positions as CesiumJS computes them: (y-up to z-up) x node matrix x position, in float64."""
    y_up_to_z_up = np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]], float)
    m = y_up_to_z_up @ glb["matrix"]
    p = glb["positions"].astype(np.float64)
    return p @ m[:3, :3].T + m[:3, 3]


def geodetic(points: np.ndarray):
    from pyproj import Transformer

    t = Transformer.from_crs("EPSG:4978", "EPSG:4979", always_xy=True)
    return t.transform(points[:, 0], points[:, 1], points[:, 2])


def read_subtree(path: Path) -> tuple[dict, bytes]:
    data = path.read_bytes()
    magic, version, n_json, n_bin = struct.unpack_from("<4sIQQ", data, 0)
    assert (magic, version) == (b"subt", 1) and n_json % 8 == 0 and 24 + n_json + n_bin == len(data)
    return json.loads(data[24:24 + n_json]), data[24 + n_json:]


def bits_of(doc: dict, binary: bytes, key: dict, length: int) -> np.ndarray:
    if "constant" in key:
        return np.full(length, bool(key["constant"]))
    view = doc["bufferViews"][key["bitstream"]]
    assert view["byteOffset"] % 8 == 0
    raw = np.frombuffer(binary, np.uint8, view["byteLength"], view["byteOffset"])
    return np.array([(raw[i // 8] >> (i % 8)) & 1 for i in range(length)], bool)


def property_values(doc: dict, binary: bytes, name: str, n: int, width: int) -> np.ndarray:
    """(n, width) FLOAT64 values of a property of the subtree's tile property table."""
    view = doc["bufferViews"][doc["propertyTables"][doc["tileMetadata"]]["properties"][name]["values"]]
    return np.frombuffer(binary, np.float64, n * width, view["byteOffset"]).reshape(n, width)


def interleave(x: int, y: int) -> int:
    return sum((((x >> b) & 1) << (2 * b)) | (((y >> b) & 1) << (2 * b + 1)) for b in range(16))


def test_tileset_json_holds_two_implicit_quadtrees_with_the_metadata_semantics(tileset):
    out, summary = tileset
    ts = json.loads((out / "tileset.json").read_text())
    assert ts["asset"]["version"] == "1.1"
    semantics = {p["semantic"]: p for p in ts["schema"]["classes"]["tile"]["properties"].values()}
    assert set(semantics) >= {"TILE_MINIMUM_HEIGHT", "TILE_MAXIMUM_HEIGHT", "TILE_BOUNDING_SPHERE",
                              "TILE_HORIZON_OCCLUSION_POINT", "TILE_GEOMETRIC_ERROR"}
    assert semantics["TILE_BOUNDING_SPHERE"]["count"] == 4 and semantics["TILE_HORIZON_OCCLUSION_POINT"]["type"] == "VEC3"
    west, east = ts["root"]["children"]
    assert west["boundingVolume"]["region"][:4] == pytest.approx([-np.pi, -np.pi / 2, 0, np.pi / 2])
    assert east["boundingVolume"]["region"][:4] == pytest.approx([0, -np.pi / 2, np.pi, np.pi / 2])
    for child in (west, east):
        it = child["implicitTiling"]
        assert it["subdivisionScheme"] == "QUADTREE" and it["availableLevels"] == KW["max_zoom"] + 1
        assert it["subtreeLevels"] == summary["subtree_levels"]
        assert "{level}" in child["content"]["uri"] and "{level}" in it["subtrees"]["uri"]
    finest = summary["levels"][KW["max_zoom"]]
    assert summary["max_zoom"] == KW["max_zoom"] and finest["mesh_error"] <= KW["max_error"]
    # the certificate, against every DEM cell: the deepest level is refined at the cells, so the bound holds there too
    assert 0 < finest["max_error"] <= KW["max_error"]


def test_subtree_availability_and_metadata_match_the_tiles(tileset):
    """Every available bit names a glb and every glb has its bit; child subtrees likewise; heights agree."""
    out, summary = tileset
    ts = json.loads((out / "tileset.json").read_text())
    levels = summary["subtree_levels"]
    tiles_seen = subtrees_seen = 0
    for child in ts["root"]["children"]:
        name = child["content"]["uri"].split("/")[0]
        glbs = {tuple(int(p) for p in (*f.parent.parent.relative_to(out / name).parts, f.parent.name, f.stem))
                for f in (out / name).glob("*/*/*.glb")}
        files = {tuple(int(p) for p in f.relative_to(out / name / "subtrees").with_suffix("").parts)
                 for f in (out / name / "subtrees").glob("*/*/*.subtree")}
        available = set()
        for (top, sx, sy) in files:
            doc, binary = read_subtree(out / name / "subtrees" / str(top) / str(sx) / f"{sy}.subtree")
            bits = bits_of(doc, binary, doc["tileAvailability"], (4 ** levels - 1) // 3)
            assert doc["tileAvailability"]["availableCount"] == bits.sum() == doc["propertyTables"][0]["count"]
            order = []
            for local in range(levels):
                for lx in range(2 ** local):
                    for ly in range(2 ** local):
                        index = (4 ** local - 1) // 3 + interleave(lx, ly)
                        if bits[index]:
                            order.append((index, (top + local, (sx << local) + lx, (sy << local) + ly)))
            order.sort()
            available |= {t for _, t in order}
            child_bits = bits_of(doc, binary, doc["childSubtreeAvailability"], 4 ** levels)
            for lx in range(2 ** levels):
                for ly in range(2 ** levels):
                    key = (top + levels, (sx << levels) + lx, (sy << levels) + ly)
                    assert child_bits[interleave(lx, ly)] == (key in files)
            lo, hi, sphere = (property_values(doc, binary, name, len(order), width)
                              for name, width in (("minimumHeight", 1), ("maximumHeight", 1), ("boundingSphere", 4)))
            for i, (_, (z, x, y)) in enumerate(order):
                glb = read_glb(out / name / str(z) / str(x) / f"{y}.glb")
                p = ecef_of(glb)
                h = geodetic(p)[2]
                assert lo[i, 0] - 1e-3 <= h.min() and h.max() <= hi[i, 0] + 1e-3
                assert np.linalg.norm(p - sphere[i, :3], axis=1).max() <= sphere[i, 3] + 1e-6
            subtrees_seen += 1
        assert available == glbs
        tiles_seen += len(glbs)
    assert tiles_seen == summary["tiles"] and subtrees_seen == summary["subtrees"] >= 3


def test_glb_edges_lie_on_the_tile_bounds_in_clockwise_order(tileset):
    out, summary = tileset
    trimesh = pytest.importorskip("trimesh")
    z = summary["max_zoom"]
    size = 180.0 / 2 ** z
    files = sorted((out / "west" / str(z)).glob("*/*.glb"))
    for f in files[:6]:
        glb = read_glb(f)
        ix, y = int(f.parent.name), int(f.stem)
        west, south = -180.0 + ix * size, -90.0 + y * size
        lon, lat, _ = geodetic(ecef_of(glb))
        n = len(glb["positions"])
        assert glb["indices"].max() < n and len(glb["indices"]) % 3 == 0
        e = glb["edges"]
        for key, coord, value, along, sign in (("left", lon, west, lat, 1), ("bottom", lat, south, lon, -1),
                                               ("right", lon, west + size, lat, -1), ("top", lat, south + size, lon, 1)):
            assert len(e[key]) >= 2
            assert np.abs(coord[e[key]] - value).max() < 1e-7  # degrees: about a centimetre
            assert np.all(sign * np.diff(along[e[key]]) > 0)  # clockwise round the tile
        up = glb["normals"].astype(np.float64) @ np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]]).T  # y-up to z-up
        assert np.allclose(np.linalg.norm(up, axis=1), 1, atol=1e-6)
        p = ecef_of(glb)
        outward = p / np.array([6378137.0, 6378137.0, 6356752.314245179]) ** 2  # the ellipsoid's normal direction
        cos = np.einsum("ij,ij->i", up, outward / np.linalg.norm(outward, axis=1, keepdims=True))
        assert cos.min() > 0 and np.median(cos) > 0.8  # outward; near horizontal only on the cliff round the DEM
        loaded = trimesh.load(f, force="mesh")  # a general glTF reader takes it too
        assert len(loaded.faces) == len(glb["indices"]) // 3


def test_neighbours_decode_identical_positions_on_their_shared_edges(tileset):
    """At every level, the positions CesiumJS computes on a shared edge are the same float64 numbers on both sides."""
    out, summary = tileset
    shared = 0
    for z in range(summary["max_zoom"] + 1):
        tiles = {}
        for root, name in enumerate(("west", "east")):
            for f in (out / name / str(z)).glob("*/*.glb"):
                tiles[((root << z) + int(f.parent.name), int(f.stem))] = f
        for (x, y), f in tiles.items():
            for (nx, ny), mine, theirs in (((x + 1, y), "right", "left"), ((x, y + 1), "top", "bottom")):
                if (nx, ny) not in tiles:
                    continue
                a, b = read_glb(f), read_glb(tiles[(nx, ny)])
                pa, pb = ecef_of(a)[a["edges"][mine]], ecef_of(b)[b["edges"][theirs]]
                assert {tuple(p) for p in pa.tolist()} == {tuple(p) for p in pb.tolist()}
                shared += len(pa)
    assert shared > 500


def test_the_same_job_writes_the_same_bytes_and_resumes(tileset, tmp_path):
    out, summary = tileset
    again = tmp_path / "again"
    terrain_3dtiles(ST_HELENS, again, **KW)
    mine = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file() and ".tinsmith" not in p.name}
    theirs = {p.relative_to(again): p.read_bytes() for p in again.rglob("*") if p.is_file() and ".tinsmith" not in p.name}
    assert mine == theirs
    victim = next((again / "west" / str(KW["max_zoom"])).glob("*/*.glb"))
    victim.unlink()
    resumed = terrain_3dtiles(ST_HELENS, again, **KW)
    assert resumed["reused"] == summary["tiles"] - 1 and victim.read_bytes() == mine[victim.relative_to(again)]


def test_bad_input_is_refused_in_one_line(tmp_path):
    import rasterio

    plain = tmp_path / "plain.tif"
    with rasterio.open(plain, "w", driver="GTiff", width=8, height=8, count=1, dtype="float32",
                       transform=rasterio.transform.from_origin(0, 80, 10, 10)) as dst:
        dst.write(np.ones((1, 8, 8), np.float32))
    with pytest.raises(tinsmith.InvalidInputError, match="no CRS"):
        terrain_3dtiles(plain, tmp_path / "a", max_error=1.0)
    qm = tmp_path / "qm"
    quantized_mesh_pyramid(ST_HELENS, qm, max_error=50.0, tile_cells=16, min_zoom=10, max_zoom=10, workers=1)
    with pytest.raises(tinsmith.FileError, match="another job") as err:  # a quantized-mesh pyramid of the same DEM
        terrain_3dtiles(ST_HELENS, qm, max_error=50.0, tile_cells=16, max_zoom=10, workers=1)
    assert "\n" not in str(err.value)
    with pytest.raises(tinsmith.InvalidOptionError, match="min_zoom must be 0"):
        terrain_3dtiles(ST_HELENS, tmp_path / "b", max_error=50.0, min_zoom=3)


def test_cli_writes_3d_tiles_terrain(tmp_path, capsys):
    out = tmp_path / "t"
    code = main(["tile", str(ST_HELENS), "-o", str(out), "--format", "3dtiles-terrain", "--max-error", "20",
                 "--tile-cells", "16", "--max-zoom", "10", "--workers", "1"])
    text, err = capsys.readouterr()
    assert code == 0, err
    assert "3D Tiles terrain" in text and "level 10:" in text
    assert (out / "tileset.json").exists()
    code = main(["tile", str(ST_HELENS), "-o", str(tmp_path / "u"), "--format", "3dtiles-terrain", "--max-error", "20",
                 "--min-zoom", "2"])
    assert code != 0 and "min_zoom must be 0" in capsys.readouterr().err


def dem_heights(lon, lat):
    """The DEM's bilinear height between cell centres at (lon, lat), from rasterio and pyproj (not from tinsmith)."""
    z, row, col, _, _, nodata = _dem_cells(lon, lat)
    c, r = col - 0.5, row - 0.5
    c0, r0 = np.floor(c).astype(int), np.floor(r).astype(int)
    tc, tr = c - c0, r - r0
    h = (z[r0, c0] * (1 - tr) * (1 - tc) + z[r0, c0 + 1] * (1 - tr) * tc + z[r0 + 1, c0] * tr * (1 - tc)
         + z[r0 + 1, c0 + 1] * tr * tc)
    window_ok = np.array([np.all(z[max(a - 4, 0):a + 6, max(b - 4, 0):b + 6] != nodata) for a, b in zip(r0, c0, strict=True)])
    return h, window_ok


def _dem_cells(lon, lat):
    """The DEM, the fractional (row, col) of (lon, lat) in it, its transform, CRS and nodata, by rasterio and pyproj."""
    import rasterio
    from pyproj import Transformer

    with rasterio.open(ST_HELENS) as src:
        z = src.read(1).astype(np.float64)
        inv, crs, transform, nodata = ~src.transform, src.crs, src.transform, src.nodata
    x, y = Transformer.from_crs("EPSG:4326", crs, always_xy=True).transform(lon, lat)
    x, y = np.asarray(x), np.asarray(y)
    return z, inv.d * x + inv.e * y + inv.f, inv.a * x + inv.b * y + inv.c, transform, crs, nodata


def cell_centres(lon, lat):
    """(lon, lat, height) of the centre of the DEM cell holding each point."""
    from pyproj import Transformer

    z, row, col, transform, crs, _ = _dem_cells(lon, lat)
    r, c = np.floor(row).astype(int), np.floor(col).astype(int)
    x, y = transform * (c + 0.5, r + 0.5)
    clon, clat = Transformer.from_crs(crs, "EPSG:4326", always_xy=True).transform(x, y)
    return np.asarray(clon), np.asarray(clat), z[r, c]


def four_cells(lon, lat):
    """The lowest and highest of the four cells whose centres surround each point."""
    z, row, col, _, _, _ = _dem_cells(lon, lat)
    r0, c0 = np.floor(row - 0.5).astype(int), np.floor(col - 0.5).astype(int)
    around = np.stack([z[r0, c0], z[r0, c0 + 1], z[r0 + 1, c0], z[r0 + 1, c0 + 1]])
    return around.min(axis=0), around.max(axis=0)


def random_points(n: int, seed: int):
    """n seeded points inside the DEM whose 10 x 10 cells round them all hold data, as (lon, lat)."""
    import rasterio
    from pyproj import Transformer

    rng = np.random.default_rng(seed)
    with rasterio.open(ST_HELENS) as src:
        H, W = src.shape
        t, crs = src.transform, src.crs
    to_geo = Transformer.from_crs(crs, "EPSG:4326", always_xy=True)
    lon, lat = np.empty(0), np.empty(0)
    while len(lon) < n:
        r, c = rng.uniform(5, H - 6, 4 * n), rng.uniform(5, W - 6, 4 * n)
        x, y = t * (c, r)
        a, b = to_geo.transform(x, y)
        ok = dem_heights(a, b)[1]
        lon, lat = np.r_[lon, a[ok]], np.r_[lat, b[ok]]
    return lon[:n], lat[:n]


@pytest.mark.skipif(not CESIUM.exists() and not os.environ.get("CI"),
                    reason="CesiumJS not installed here (CI runs npm ci in tests/js)")
def test_cesiumjs_samples_the_dem_within_the_error_bound(tileset):
    """CesiumJS's Cesium3DTilesTerrainProvider and sampleTerrainMostDetailed, in headless Chromium, at 1,000 points.

    Seeded random points inside the DEM, three ways:
    - moved to the nearest node of the deepest level's sampling grid: expected is the DEM's bilinear height there
      (rasterio, pyproj);
    - moved to the nearest DEM cell centre: expected is the cell's height;
    - where they are: between cell centres the DEM's height is a matter of interpolation (the mesh is up to 6.9 m
      from the bilinear height there on these 30 m slopes, all within the bound of the cells), so the mesh is held
      to the range of the four cells around.
    Allowed: the level's error bound plus the height step plus 1 cm for CesiumJS's float32 vertex encoding.
    """
    pytest.importorskip("playwright")
    from tinsmith.viz.browser import cesium_sample_3dtiles_terrain

    out, summary = tileset
    lon, lat = random_points(1000, seed=7)
    spacing = 180.0 / 2 ** summary["max_zoom"] / KW["tile_cells"]
    # a node on a tile's edge moves one node in: CesiumJS's interpolateMeshHeight needs barycentric weights >= 0
    # exactly, which rounding denies a point on an edge now and then (it then answers 0.0)
    k_lon, k_lat = np.rint((lon + 180.0) / spacing), np.rint((lat + 90.0) / spacing)
    k_lon, k_lat = (np.where(k % KW["tile_cells"] == 0, k + 1, k) for k in (k_lon, k_lat))
    node_lon, node_lat = -180.0 + k_lon * spacing, -90.0 + k_lat * spacing
    cell_lon, cell_lat, cell_h = cell_centres(lon, lat)
    start = time.perf_counter()
    points = list(zip(np.r_[node_lon, cell_lon, lon], np.r_[node_lat, cell_lat, lat], strict=True))
    heights, levels = cesium_sample_3dtiles_terrain(out, CESIUM, points, normals=True)
    seconds = time.perf_counter() - start
    heights = np.asarray(heights, float)
    at_nodes = np.abs(heights[:1000] - dem_heights(node_lon, node_lat)[0])
    at_cells = np.abs(heights[1000:2000] - cell_h)
    lo, hi = four_cells(lon, lat)
    beyond = np.maximum(lo - heights[2000:], heights[2000:] - hi)
    between = np.abs(heights[2000:] - dem_heights(lon, lat)[0])
    allowed = KW["max_error"] + summary["height_step"] + 0.01
    print(f"\nCesiumJS - DEM at 1000 nodes: max {at_nodes.max():.3f} m, mean {at_nodes.mean():.3f} m; at 1000 cell "
          f"centres: max {at_cells.max():.3f} m (allowed {allowed:.3f}); between: beyond the four cells' range by "
          f"{beyond.max():.3f} m at most, from the bilinear height max {between.max():.3f} m, mean "
          f"{between.mean():.3f} m; {seconds:.1f} s in the browser")
    assert set(levels) == {summary["max_zoom"]}
    assert at_nodes.max() <= allowed and at_cells.max() <= allowed
    assert beyond.max() <= allowed
