"""Quantized-mesh extensions: water mask, metadata (availability and the error certificate), normals across seams.

Each is checked against something our writer did not compute: the water
polygons reprojected by geopandas and tested by shapely, the tiles on disk,
the DEM read by rasterio with cell centres moved by pyproj, the
``quantized-mesh-tile`` package's decoder, and CesiumJS itself.
"""

from __future__ import annotations

import gzip
import io
import json
import os
from pathlib import Path

import numpy as np
import pytest

from tinsmith.errors import InputNotFoundError, InvalidOptionError
from tinsmith.io.quantized_mesh import QUANT, decode_tile, encode_tile, height_at
from tinsmith.tiles.cesium import quantized_mesh_pyramid
from tinsmith.tiles.pyramid import METADATA_LEVELS, tile_bounds

ROOT = Path(__file__).resolve().parents[1]
DELFT = ROOT / "../shared/data/urban/delft_ahn3/delft_dtm_0.5m.tif"
CANAL = ROOT / "../shared/data/vector/delft_bgt/bgt_waterdeel.sqlite"
ST_HELENS = ROOT / "../shared/data/terrain/st_helens/SainteHelens_30m.tif"
TUJUNGA = ROOT / "../shared/data/terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif"
CESIUM = Path(__file__).parent / "js/node_modules/cesium/Build/Cesium"

pytestmark = pytest.mark.skipif(not DELFT.exists(), reason="the shared data is not beside the project")


@pytest.fixture(scope="module")
def delft(tmp_path_factory):
    """The Delft DTM (EPSG:28992) with its canal (a BGT polygon, EPSG:28992) as water, down to level 19."""
    out = tmp_path_factory.mktemp("delft")
    with pytest.warns(UserWarning):  # the canal is reprojected and clipped to the DEM's bounds, and says so
        summary = quantized_mesh_pyramid(DELFT, out, max_error=0.3, tile_cells=64, max_zoom=19, normals=True,
                                         water=CANAL, attribution="AHN3, BGT (CC0)", workers=2)
    tiles = {}
    for f in out.glob("*/*/*.terrain"):
        tiles[(int(f.parent.parent.name), int(f.parent.name), int(f.stem))] = gzip.decompress(f.read_bytes())
    return out, summary, tiles


def _canal_lonlat(bounds):
    """The canal in longitude and latitude, clipped to the pyramid's bounds: geopandas and shapely, not tinsmith."""
    gpd = pytest.importorskip("geopandas")
    import shapely

    canal = gpd.read_file(CANAL).to_crs("EPSG:4326").union_all()
    return shapely.clip_by_rect(canal, *bounds)


def test_extensions_round_trip_through_our_decoder():
    rng = np.random.default_rng(3)
    uv = np.array([[0, 0], [QUANT, 0], [0, QUANT], [QUANT, QUANT]])
    tri = np.array([[0, 1, 3], [0, 3, 2]])
    lon, lat, h = uv[:, 0] / QUANT * 0.01, uv[:, 1] / QUANT * 0.01 + 45, np.full(4, 100.0)
    mask = (rng.random((256, 256)) < 0.3).astype(np.uint8) * 255
    normals = np.tile([0.0, 0.0, 1.0], (4, 1))
    for water in (0, 255, mask):
        meta = {"available": [[{"startX": 1, "startY": 2, "endX": 3, "endY": 2}]], "tinsmith": {"max_error": 0.25}}
        d = decode_tile(encode_tile(lon, lat, h, uv[:, 0], uv[:, 1], np.zeros(4, int), tri, 100.0, 101.0,
                                    normals=normals, water=water, metadata=meta))
        assert d["metadata"] == meta
        assert np.array_equal(d["water"], water)
        assert np.allclose(d["normals"], normals, atol=0.02)
    with pytest.raises(ValueError, match="water mask"):
        encode_tile(lon, lat, h, uv[:, 0], uv[:, 1], np.zeros(4, int), tri, 100.0, 101.0, water=np.zeros((4, 4)))


def test_layer_json_lists_the_root_and_the_extensions(delft):
    out, summary, _ = delft
    layer = json.loads((out / "layer.json").read_text())
    assert layer["extensions"] == ["octvertexnormals", "watermask", "metadata"]
    assert layer["metadataAvailability"] == METADATA_LEVELS
    assert layer["available"] == [[{"startX": 0, "startY": 0, "endX": 1, "endY": 0}]]  # the root alone
    assert layer["attribution"] == "AHN3, BGT (CC0)"
    w, s, e, n = layer["bounds"]
    assert 4.36 < w < e < 4.38 and 52.0 < s < n < 52.02
    assert summary["extensions"] == layer["extensions"]


def test_the_metadata_lists_exactly_the_tiles_on_disk(delft):
    """Every tile of a metadata level lists, for each of the next levels, the tiles below it that exist."""
    out, summary, tiles = delft
    listed = {(0, 0, 0), (0, 1, 0)}
    for (z, x, y), raw in tiles.items():
        meta = decode_tile(raw)["metadata"]
        assert set(meta["tinsmith"]) >= {"max_error", "mesh_error", "bound", "cells"}
        if z % METADATA_LEVELS:
            assert "available" not in meta
            continue
        for k, ranges in enumerate(meta["available"], start=1):
            for r in ranges:
                for xx in range(r["startX"], r["endX"] + 1):
                    for yy in range(r["startY"], r["endY"] + 1):
                        assert xx >> k == x and yy >> k == y  # below this tile
                        listed.add((z + k, xx, yy))
    assert listed == set(tiles)


def test_the_water_mask_is_the_canal(delft):
    """Each tile's mask against the canal's polygon tested at the mask's pixel centres (geopandas, shapely)."""
    import shapely

    out, summary, tiles = delft
    canal = _canal_lonlat(summary["bounds"])
    mixed = 0
    for (z, x, y), raw in tiles.items():
        water = decode_tile(raw)["water"]
        w, s, e, n = tile_bounds(z, x, y)
        lon = w + (np.arange(256) + 0.5) * (e - w) / 256
        lat = n - (np.arange(256) + 0.5) * (n - s) / 256
        LON, LAT = np.meshgrid(lon, lat)
        want = shapely.contains_xy(canal, LON, LAT)
        got = np.broadcast_to(np.asarray(water), (256, 256)) == 255
        # vertices closer than a tenth of a cell (5 cm) are merged: a pixel on the shore may differ
        assert (got != want).mean() <= 0.01, (z, x, y)
        if isinstance(water, np.ndarray):
            mixed += 1
            assert 0 < got.mean() < 1
    assert mixed >= 5
    deepest = [t for t in tiles if t[0] == 19]
    assert any(isinstance(decode_tile(tiles[t])["water"], int) for t in deepest)  # the one-byte all-land form


def _edge_normals(d, side, along) -> dict:
    hdr = d["header"]
    height = hdr["min_height"] + d["h"] / QUANT * (hdr["max_height"] - hdr["min_height"])
    return {(int(d[along][i]), round(float(height[i]), 2)): d["normals"][i] for i in d[side]}


def test_normals_agree_on_both_sides_of_every_seam(delft):
    out, summary, tiles = delft
    seams = 0
    for (z, x, y), raw in tiles.items():
        a = decode_tile(raw)
        for (nx, ny), mine, theirs, along in (((x + 1, y), "east", "west", "v"), ((x, y + 1), "north", "south", "u")):
            if (z, nx, ny) not in tiles or a["normals"] is None:
                continue
            b = decode_tile(tiles[(z, nx, ny)])
            na, nb = _edge_normals(a, mine, along), _edge_normals(b, theirs, along)
            for key in set(na) & set(nb):  # the same vertex: same place along the edge, same height
                assert np.array_equal(na[key], nb[key])
                seams += 1
    assert seams > 50


def _height_in(d, bounds, lon, lat, keep) -> float:
    """As :func:`height_at` (Cesium's barycentric interpolation), over the triangles ``keep`` only."""
    return height_at({**d, "triangles": d["triangles"][keep]}, bounds, lon, lat)


def test_the_certificate_is_the_error_against_the_dem(delft):
    """Every DEM cell in a tile, placed by pyproj and rasterio and interpolated as Cesium does (height_at)."""
    import rasterio
    from pyproj import Transformer

    out, summary, tiles = delft
    rows = [line.split(",") for line in (out / "certificate.csv").read_text().split()[1:]]
    assert len(rows) == len(tiles)
    by_tile = {tuple(map(int, r[:3])): r for r in rows}
    with rasterio.open(DELFT) as src:
        dem = src.read(1).astype(np.float64)
        R, C = np.mgrid[0:dem.shape[0], 0:dem.shape[1]]
        xs, ys = rasterio.transform.xy(src.transform, R.ravel(), C.ravel())
        lon, lat = Transformer.from_crs(src.crs, "EPSG:4326", always_xy=True).transform(np.array(xs), np.array(ys))
    deepest = max((t for t in tiles if t[0] == 19), key=lambda t: float(by_tile[t][3]))
    coarse = max((t for t in tiles if t[0] == 17), key=lambda t: int(by_tile[t][6]))  # 8 x 8 cells a node
    assert int(by_tile[coarse][6]) > 10_000
    for tile in (deepest, coarse):
        w, s, e, n = tile_bounds(*tile)
        d = decode_tile(tiles[tile])
        inside = np.flatnonzero((lon >= w) & (lon <= e) & (lat >= s) & (lat <= n))
        # beyond the DEM the tile stands on the ellipsoid (height 0): its triangles there are no surface of the DEM
        hdr = d["header"]
        fill = np.abs(hdr["min_height"] + d["h"] / QUANT * (hdr["max_height"] - hdr["min_height"])) < 1e-3
        dem_only = ~fill[d["triangles"]].any(axis=1)
        errors = [abs(_height_in(d, (w, s, e, n), lon[i], lat[i], dem_only) - dem.ravel()[i]) for i in inside]
        errors = np.array([v for v in errors if np.isfinite(v)])
        r = by_tile[tile]
        # every cell counted (a cell on the tile's very edge may fall either way: positions from a lattice)
        assert abs(int(r[6]) - len(errors)) <= max(2, len(errors) // 10_000)
        assert float(r[3]) == pytest.approx(errors.max(), abs=0.002)  # float32 header, lattice of positions
        assert decode_tile(tiles[tile])["metadata"]["tinsmith"]["max_error"] == pytest.approx(float(r[3]), rel=1e-5)
    # the deepest level is refined at the DEM's cells: its bound holds there, not only at the nodes
    assert 0 < float(by_tile[deepest][3]) <= float(by_tile[deepest][5])


def test_an_independent_decoder_reads_every_tile(delft):
    """quantized-mesh-tile (MIT) decodes vertices, triangles, normals and water masks as we wrote them."""
    terrain = pytest.importorskip("quantized_mesh_tile.terrain")
    import warnings

    out, summary, tiles = delft
    for (z, x, y), raw in tiles.items():
        ours = decode_tile(raw)
        w, s, e, n = tile_bounds(z, x, y)
        theirs = terrain.TerrainTile(west=w, south=s, east=e, north=n)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # it skips the metadata extension, and says so
            theirs.fromBytesIO(io.BytesIO(raw), hasLighting=True, hasWatermask=True)
        assert np.array_equal(theirs.u, ours["u"]) and np.array_equal(theirs.v, ours["v"])
        assert np.array_equal(theirs.h, ours["h"])
        assert np.array_equal(np.reshape(theirs.indices, (-1, 3)), ours["triangles"])
        assert np.allclose(theirs.vLight, ours["normals"], atol=1e-6)
        mask = np.array(theirs.watermask, dtype=np.uint8)
        assert np.array_equal(mask.reshape(np.shape(ours["water"])), ours["water"])


def test_bad_water_and_metadata_options_say_so_in_one_line(tmp_path):
    with pytest.raises(InputNotFoundError, match="water file .*nope.gpkg.* does not exist"):
        quantized_mesh_pyramid(DELFT, tmp_path / "a", max_error=1.0, water=tmp_path / "nope.gpkg", workers=1)
    with pytest.raises(InvalidOptionError, match="metadata needs min_zoom=0"):
        quantized_mesh_pyramid(DELFT, tmp_path / "b", max_error=1.0, min_zoom=12, metadata=True, workers=1)
    with pytest.raises(InvalidOptionError, match="'flat'"):
        quantized_mesh_pyramid(DELFT, tmp_path / "c", max_error=1.0, water="  ", workers=1)
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists() and not (tmp_path / "c").exists()


def test_flat_lakes_are_water_and_whole_metre_plateaus_are_not(tmp_path):
    """A hydro-flattened lake in a DEM of whole metres is found; the plateaus rounding makes on slopes are not,
    here nor on two real DEMs of whole metres (St. Helens, Big Tujunga), which have no flattened lake."""
    import rasterio
    from affine import Affine

    from tinsmith.io.raster import raster_info
    from tinsmith.tiles.water import flat_water

    rng = np.random.default_rng(1)
    r, c = np.mgrid[0:200, 0:300]
    z = np.rint(500 + 0.002 * ((r - 100) ** 2 + (c - 150) ** 2) + 0.05 * c + rng.normal(0, 0.2, r.shape))
    lake = z <= 508
    z[lake] = 508
    path = tmp_path / "lake.tif"
    with rasterio.open(path, "w", driver="GTiff", width=300, height=200, count=1, dtype="float32", crs="EPSG:32610",
                       transform=Affine(10, 0, 500000, 0, -10, 5100000)) as dst:
        dst.write(z.astype(np.float32), 1)
    polygons = flat_water(raster_info(path))
    assert len(polygons) == 1
    assert polygons[0].area == pytest.approx(lake.sum() * 100, rel=0.05)
    for dem in (ST_HELENS, TUJUNGA):
        assert flat_water(raster_info(dem)) == []


@pytest.mark.skipif(not CESIUM.exists() and not os.environ.get("CI"),
                    reason="CesiumJS not installed here (CI runs npm ci in tests/js)")
def test_cesiumjs_decodes_the_water_mask_availability_and_normals(delft):
    """CesiumJS, asked for normals, water mask and metadata, in headless Chromium: its decoded TerrainData."""
    pytest.importorskip("playwright")
    from tinsmith.viz.browser import cesium_terrain_data

    out, summary, tiles = delft
    over_canal = [t for t in sorted(tiles) if t[0] >= 17 and isinstance(decode_tile(tiles[t])["water"], np.ndarray)]
    land = [t for t in sorted(tiles) if t[0] == 19 and isinstance(decode_tile(tiles[t])["water"], int)]
    missing = (19, 0, 0)  # no such tile: the metadata must say so
    asked = over_canal[:3] + land[:2] + [missing]
    result = cesium_terrain_data(out, CESIUM, asked)
    assert result["hasWaterMask"] and result["hasMetadata"] and result["hasVertexNormals"]
    # the first tile asked: unknown until the tiles above told it (layer.json lists level 0 alone)
    assert asked[0][0] > METADATA_LEVELS and result["tiles"][0]["before"] is None
    for tile, got in zip(asked, result["tiles"], strict=True):
        if tile == missing:
            assert got["available"] is False
            continue
        assert got["available"] is True
        ours = decode_tile(tiles[tile])
        assert got["vertices"] == len(ours["u"]) and got["normals"] == 2 * len(ours["u"])
        assert np.array_equal(np.array(got["water"], dtype=np.uint8), np.ravel(ours["water"]))
    canal = _canal_lonlat(summary["bounds"])
    import shapely

    z, x, y = over_canal[0]
    w, s, e, n = tile_bounds(z, x, y)
    LON, LAT = np.meshgrid(w + (np.arange(256) + 0.5) * (e - w) / 256, n - (np.arange(256) + 0.5) * (n - s) / 256)
    cesium = np.array(result["tiles"][0]["water"]).reshape(256, 256) == 255
    assert (cesium != shapely.contains_xy(canal, LON, LAT)).mean() <= 0.01  # water where the canal is


def test_the_water_class_of_a_point_cloud_marks_its_lakes(tmp_path):
    """A LiDAR tile with lakes (Quebec, class 9): the masks hold its water points and not its ground points."""
    laspy = pytest.importorskip("laspy")
    from pyproj import Transformer

    from tinsmith.tiles.points import cloud_pyramid, tile_cloud

    laz = ROOT / "../shared/data/terrain/lidR_forest_lakes/Topography.laz"
    run = tile_cloud(laz, max_error=0.3, tile_size=150, workers=1, parts=tmp_path / "parts")
    out = tmp_path / "pyramid"
    with pytest.warns(UserWarning):  # the water's area is reprojected to degrees, and clipped: said
        summary = cloud_pyramid(run, out, max_error=0.3, water="class", workers=1)
    assert "watermask" in summary["extensions"]
    z = summary["max_zoom"]
    masks = {}
    for f in (out / str(z)).glob("*/*.terrain"):
        masks[(int(f.parent.name), int(f.stem))] = decode_tile(gzip.decompress(f.read_bytes()))["water"]
    las = laspy.read(laz)
    codes = np.asarray(las.classification)
    lon, lat = Transformer.from_crs("EPSG:2949", "EPSG:4326", always_xy=True).transform(np.asarray(las.x),
                                                                                        np.asarray(las.y))
    size = 180.0 / 2 ** z

    def wet(i) -> bool:
        x, y = int((lon[i] + 180) // size), int((lat[i] + 90) // size)
        w, s, e, n = tile_bounds(z, x, y)
        mask = np.broadcast_to(np.asarray(masks[(x, y)]), (256, 256))
        return bool(mask[min(255, int((n - lat[i]) / (n - s) * 256)), min(255, int((lon[i] - w) / (e - w) * 256))])

    rng = np.random.default_rng(0)
    water = rng.choice(np.flatnonzero(codes == 9), 500, replace=False)
    ground = rng.choice(np.flatnonzero(codes == 2), 500, replace=False)
    assert np.mean([wet(i) for i in water]) >= 0.9
    assert np.mean([wet(i) for i in ground]) <= 0.05


def test_without_the_certificate_nothing_claims_a_measurement(tmp_path, capsys):
    """--no-certificate: no certificate.csv, no error against the DEM in the metadata, and the report says so."""
    from tinsmith.cli.main import main

    out = tmp_path / "qm"
    code = main(["tile", str(ST_HELENS), "-o", str(out), "--format", "quantized-mesh", "--max-error", "20",
                 "--tile-cells", "32", "--max-zoom", "11", "--workers", "1", "--no-certificate"])
    printed = capsys.readouterr().out
    assert code == 0 and "not measured against the DEM (--no-certificate)" in printed
    assert not (out / "certificate.csv").exists()
    meta = decode_tile(gzip.decompress((out / "11").glob("*/*.terrain").__next__().read_bytes()))["metadata"]
    assert set(meta["tinsmith"]) == {"mesh_error", "bound"}
