"""Quantized-mesh heights above the WGS 84 ellipsoid, converted from the DEM's vertical CRS by PROJ.

The DEMs here are small synthetic GeoTIFFs near (-117, 34) in UTM zone 11N.
EGM96 (EPSG:5773) is the geoid whose grid Debian's proj-data ships (the CI
script installs it); NAVD88 (EPSG:5703) needs NOAA grids that are not
installed, which is the refusal path.
"""

from __future__ import annotations

import gzip
import json
import os
import pickle

import numpy as np
import pytest

from tinsmith.cli.main import main
from tinsmith.errors import InvalidOptionError
from tinsmith.io.quantized_mesh import QUANT, decode_tile
from tinsmith.tiles.cesium import quantized_mesh_pyramid
from tinsmith.tiles.heights import MissingGridError, ellipsoid_heights
from tinsmith.tiles.pyramid import pyramid_job, tile_geometry

UTM_EGM96 = "EPSG:32611+5773"
UTM_NAVD88 = "EPSG:32611+5703"
#: What GDAL writes for a DEM whose vertical datum nobody recorded (as in many LiDAR products).
UTM_UNKNOWN = ('COMPOUNDCRS["WGS 84 / UTM zone 11N + unknown",PROJCRS["WGS 84 / UTM zone 11N",BASEGEOGCRS["WGS 84",'
               'DATUM["World Geodetic System 1984",ELLIPSOID["WGS 84",6378137,298.257223563]]],CONVERSION["UTM zone 11N",'
               'METHOD["Transverse Mercator"],PARAMETER["Latitude of natural origin",0],PARAMETER["Longitude of natural '
               'origin",-117],PARAMETER["Scale factor at natural origin",0.9996],PARAMETER["False easting",500000],'
               'PARAMETER["False northing",0]],CS[Cartesian,2],AXIS["easting",east,LENGTHUNIT["metre",1]],AXIS["northing",'
               'north,LENGTHUNIT["metre",1]]],VERTCRS["unknown",VDATUM["unknown"],CS[vertical,1],AXIS["up",up,'
               'LENGTHUNIT["metre",1]]]]')
ZOOMS = {"min_zoom": 12, "max_zoom": 14, "tile_cells": 16}


def _dem(path, crs, nodata_corner=True):
    """128 x 128 cells of 30 m of smooth hills (200 to 500 m), its south-west corner without data."""
    import rasterio
    from rasterio.crs import CRS
    from rasterio.transform import Affine

    r, c = np.mgrid[0:128, 0:128]
    z = 350 + 120 * np.sin(r / 17.0) * np.cos(c / 23.0) + 0.3 * c
    if nodata_corner:
        z[100:, :20] = -9999.0
    with rasterio.open(path, "w", driver="GTiff", width=128, height=128, count=1, dtype="float64", crs=CRS.from_user_input(crs),
                       transform=Affine(30.0, 0.0, 495_000.0, 0.0, -30.0, 3_765_000.0), nodata=-9999.0) as ds:
        ds.write(z, 1)
    return path


def _egm96_installed() -> bool:
    try:
        ellipsoid_heights(UTM_EGM96)
    except MissingGridError:
        if os.environ.get("CI"):
            raise  # the CI script installs Debian's proj-data, which ships EGM96
        return False
    return True


needs_egm96 = pytest.mark.skipif(not _egm96_installed(), reason="PROJ's EGM96 grid not installed (apt-get install proj-data)")


@pytest.fixture(scope="module")
def dems(tmp_path_factory):
    folder = tmp_path_factory.mktemp("heights")
    return {"egm96": _dem(folder / "egm96.tif", UTM_EGM96), "plain": _dem(folder / "plain.tif", "EPSG:32611"),
            "navd88": _dem(folder / "navd88.tif", UTM_NAVD88), "unknown": _dem(folder / "unknown.tif", UTM_UNKNOWN)}


def _tiles(job):
    from tinsmith.tiles.pyramid import lonlat_bounds, tiles_of_level

    bounds = lonlat_bounds(job.raster)
    return [t for z in range(job.min_zoom, job.max_zoom + 1) for t in tiles_of_level(z, bounds)]


def _pyproj_heights(crs, lon, lat, h):
    """What pyproj itself gives at these nodes: the node to the DEM's CRS, then the DEM's CRS to EPSG:4979."""
    from pyproj import Transformer

    x, y = Transformer.from_crs("EPSG:4326", "EPSG:32611", always_xy=True).transform(lon, lat)
    return Transformer.from_crs(crs, "EPSG:4979", always_xy=True).transform(x, y, h)[2]


@needs_egm96
def test_converted_heights_are_pyprojs_at_every_node(dems):
    job = pyramid_job(dems["egm96"], max_error=1.0, **ZOOMS)
    given = pyramid_job(dems["egm96"], max_error=1.0, vertical_crs="none", **ZOOMS)
    assert job.heights.grids == ("us_nga_egm96_15.tif",) and "EGM96" in job.heights.description
    assert given.heights.operation is None
    got, nodes = [], []
    for tile in _tiles(job)[:12]:
        g, g0 = tile_geometry(tile, job), tile_geometry(tile, given)
        if not g0["data"]:
            continue
        # the same nodes (the conversion moves every height by a smooth amount; the meshes may differ)
        mine = dict(zip(zip(g["u"].tolist(), g["v"].tolist(), strict=True), g["height"].tolist(), strict=True))
        for u, v, lon, lat, h, beyond in zip(g0["u"].tolist(), g0["v"].tolist(), g0["lon"], g0["lat"], g0["height"],
                                             g0["filled"], strict=True):
            if (u, v) in mine and not beyond:  # beyond the DEM both stand on the ellipsoid
                got.append(mine[u, v])
                nodes.append((lon, lat, h))
    lon, lat, h = np.array(nodes).T
    want = _pyproj_heights(UTM_EGM96, lon, lat, h)
    # nodes are placed in the DEM's CRS by pyproj on a lattice and bilinearly between (millimetres): 0.1 mm of height
    assert len(got) > 50 and np.abs(np.array(got) - want).max() < 1e-4
    assert np.all((want - h > -40) & (want - h < -25))  # EGM96 lies about 32 m below the ellipsoid here


@needs_egm96
def test_pyramid_decodes_to_ellipsoidal_heights_and_names_the_grid(dems, tmp_path):
    out = tmp_path / "qm"
    summary = quantized_mesh_pyramid(dems["egm96"], out, max_error=1.0, workers=1, **ZOOMS)
    layer = json.loads((out / "layer.json").read_text())
    for record in (summary["heights"], layer["tinsmith"]["heights"]):
        assert record["vertical_crs"] == "EGM96 height (EPSG:5773)" and record["to"] == "EPSG:4979"
        assert record["grids"] == ["us_nga_egm96_15.tif"]
    assert "us_nga_egm96_15.tif" in layer["description"] and "EGM96" in layer["description"]
    given = quantized_mesh_pyramid(dems["egm96"], tmp_path / "given", max_error=1.0, vertical_crs="none", workers=1,
                                   **ZOOMS)
    assert given["heights"]["note"] == "vertical CRS ignored (vertical_crs 'none'); heights taken as given + offset (0 m)"
    step = summary["height_step"]
    got, nodes = [], []
    for z, x, y in [(14, p.parent.name, p.stem) for p in (out / "14").glob("*/*.terrain")]:
        d = _decoded(out, z, x, y)
        d0 = _decoded(tmp_path / "given", z, x, y)
        if not _heights(d0).any():  # no data: the flat ellipsoid in both
            continue
        h = _heights(d)
        h0 = dict(zip(zip(d0["u"].tolist(), d0["v"].tolist(), strict=True), _heights(d0).tolist(), strict=True))
        for u, v, hh in zip(d["u"].tolist(), d["v"].tolist(), h.tolist(), strict=True):
            beyond = abs(hh) < step and abs(h0.get((u, v), 1.0)) < step  # beyond the DEM: the ellipsoid in both
            if (u, v) in h0 and not beyond:  # the same node in both pyramids: converted as pyproj converts it
                size = 180.0 / 2 ** z
                lon, lat = -180 + (int(x) + u / QUANT) * size, -90 + (int(y) + v / QUANT) * size
                got.append(hh)
                nodes.append((lon, lat, h0[u, v]))
    lon, lat, h = np.array(nodes).T
    want = _pyproj_heights(UTM_EGM96, lon, lat, h)
    assert len(got) > 100 and np.abs(np.array(got) - want).max() <= step / 2 + given["height_step"] / 2 + 1e-3


def _decoded(out, z, x, y):
    return decode_tile(gzip.decompress((out / str(z) / str(x) / f"{y}.terrain").read_bytes()))


def _heights(d):
    return d["header"]["min_height"] + d["h"] / QUANT * (d["header"]["max_height"] - d["header"]["min_height"])


@needs_egm96
def test_neighbouring_tiles_share_identical_edge_heights_after_conversion(dems, tmp_path):
    out = tmp_path / "qm"
    summary = quantized_mesh_pyramid(dems["egm96"], out, max_error=0.5, workers=1, **ZOOMS)
    layer = json.loads((out / "layer.json").read_text())
    lo, step = layer["tinsmith"]["height_min"], layer["tinsmith"]["height_step"]

    def edge(d, name, along):
        k = np.rint((_heights(d) - lo) / step).astype(int)  # the pyramid-wide height step index
        return {int(d[along][i]): int(k[i]) for i in d[name].tolist()}

    shared = 0
    for z in range(summary["min_zoom"], summary["max_zoom"] + 1):
        names = {(int(p.parent.name), int(p.stem)) for p in (out / str(z)).glob("*/*.terrain")}
        for x, y in names:
            for nx, ny, mine, theirs, along in ((x + 1, y, "east", "west", "v"), (x, y + 1, "north", "south", "u")):
                if (nx, ny) not in names:
                    continue
                da, db = _decoded(out, z, x, y), _decoded(out, z, nx, ny)
                if not (_heights(da).any() and _heights(db).any()):  # a tile without data is the flat ellipsoid
                    continue
                a, b = edge(da, mine, along), edge(db, theirs, along)
                both = set(a) & set(b)
                assert all(a[p] == b[p] for p in both), (z, x, y, mine)
                shared += len(both)
    assert shared > 100


def test_missing_grid_is_refused_in_one_line_naming_it(dems):
    """PROJ alone would leave NAVD88 heights unchanged (a ballpark transformation); the pyramid refuses."""
    import warnings

    from pyproj import Transformer
    from pyproj.transformer import TransformerGroup

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        group = TransformerGroup(UTM_NAVD88, "EPSG:4979", always_xy=True)
        if group.best_available:
            pytest.skip("NOAA's geoid grids are installed here: nothing is missing")
        assert Transformer.from_crs(UTM_NAVD88, "EPSG:4979", always_xy=True).transform(500_000.0, 3_762_000.0, 100.0)[2] == 100.0
    missing = [g.short_name for g in group.unavailable_operations[0].grids if not g.available]
    with pytest.raises(MissingGridError) as caught:
        pyramid_job(dems["navd88"], max_error=1.0, **ZOOMS)
    message = str(caught.value)
    assert "\n" not in message and "NAVD88 height (EPSG:5703)" in message
    assert all(f"projsync --file {name}" in message for name in missing)
    # the override meets the same refusal; 'none' takes the heights as given
    with pytest.raises(MissingGridError):
        pyramid_job(dems["plain"], max_error=1.0, vertical_crs="EPSG:5703", **ZOOMS)
    assert pyramid_job(dems["navd88"], max_error=1.0, vertical_crs="none", **ZOOMS).heights.operation is None


def test_without_a_vertical_crs_heights_are_taken_as_given_plus_the_offset(dems, tmp_path):
    job = pyramid_job(dems["plain"], max_error=1.0, **ZOOMS)
    shifted = pyramid_job(dems["plain"], max_error=1.0, height_offset=-32.5, **ZOOMS)
    assert job.heights.operation is None
    assert shifted.heights.note(-32.5) == "no vertical CRS; heights taken as given + offset (-32.5 m)"
    tile = next(t for t in _tiles(job) if t[0] == 14 and tile_geometry(t, job)["data"])
    a, b = tile_geometry(tile, job), tile_geometry(tile, shifted)
    dem = ~a["filled"]  # beyond the DEM both stand on the ellipsoid, offset or not
    assert np.array_equal(a["u"], b["u"]) and np.array_equal(a["filled"], b["filled"]) and dem.any()
    assert np.allclose(b["height"][dem], a["height"][dem] - 32.5, atol=1e-9) and not b["height"][~dem].any()
    summary = quantized_mesh_pyramid(dems["plain"], tmp_path / "qm", max_error=1.0, height_offset=-32.5, workers=1,
                                     **ZOOMS)
    assert summary["heights"]["vertical_crs"] is None and summary["heights"]["height_offset"] == -32.5
    layer = json.loads((tmp_path / "qm" / "layer.json").read_text())
    assert "no vertical CRS; heights taken as given + offset (-32.5 m)" in layer["description"]
    # a vertical part of unknown datum says no more than none: taken as given too, and said so
    unknown = pyramid_job(dems["unknown"], max_error=1.0, height_offset=-32.5, **ZOOMS)
    assert unknown.heights.operation is None and "of unknown datum" in unknown.heights.note(-32.5)
    assert np.array_equal(tile_geometry(tile, unknown)["height"], b["height"])


@needs_egm96
def test_override_gives_a_plain_dem_the_vertical_crs_its_file_lacks(dems):
    given = pyramid_job(dems["plain"], max_error=1.0, vertical_crs="EPSG:5773", height_offset=2.0, **ZOOMS)
    compound = pyramid_job(dems["egm96"], max_error=1.0, height_offset=2.0, **ZOOMS)
    assert given.heights.grids == compound.heights.grids == ("us_nga_egm96_15.tif",)
    for tile in _tiles(given)[::7]:
        a, b = tile_geometry(tile, given), tile_geometry(tile, compound)
        assert np.array_equal(a["height"], b["height"]) and np.array_equal(a["k"], b["k"])
    with pytest.raises(InvalidOptionError, match="vertical_crs must be a vertical CRS .* got 'EPSG:4326'"):
        pyramid_job(dems["plain"], max_error=1.0, vertical_crs="EPSG:4326", **ZOOMS)
    with pytest.raises(InvalidOptionError, match="got 'EPSG:99999999'"):
        pyramid_job(dems["plain"], max_error=1.0, vertical_crs="EPSG:99999999", **ZOOMS)


@needs_egm96
def test_workers_in_other_processes_convert_as_this_one(dems, tmp_path):
    job = pyramid_job(dems["egm96"], max_error=1.0, **ZOOMS)
    again = pickle.loads(pickle.dumps(job))
    tile = _tiles(job)[-1]
    assert np.array_equal(tile_geometry(tile, again)["height"], tile_geometry(tile, job)["height"])
    one = quantized_mesh_pyramid(dems["egm96"], tmp_path / "one", max_error=1.0, workers=1, **ZOOMS)
    two = quantized_mesh_pyramid(dems["egm96"], tmp_path / "two", max_error=1.0, workers=2, **ZOOMS)
    assert one["tiles"] == two["tiles"]
    for p in (tmp_path / "one").glob("*/*/*.terrain"):
        assert p.read_bytes() == (tmp_path / "two" / p.relative_to(tmp_path / "one")).read_bytes()


@needs_egm96
def test_cli_vertical_crs(dems, tmp_path, capsys):
    code = main(["tile", str(dems["plain"]), "-o", str(tmp_path / "qm"), "--format", "quantized-mesh", "--max-error", "1",
                 "--tile-cells", "16", "--min-zoom", "12", "--max-zoom", "13", "--workers", "1", "--vertical-crs", "EPSG:5773"])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "EGM96 height (EPSG:5773) to WGS 84 ellipsoidal heights by PROJ" in out and "us_nga_egm96_15.tif" in out
    code = main(["tile", str(dems["navd88"]), "-o", str(tmp_path / "qm2"), "--format", "quantized-mesh",
                 "--max-error", "1", "--tile-cells", "16", "--min-zoom", "12", "--max-zoom", "13", "--workers", "1"])
    out, err = capsys.readouterr()
    assert code != 0 and "projsync --file" in err and len(err.strip().splitlines()) == 1
    code = main(["tile", str(dems["plain"]), "-o", str(tmp_path / "qm3"), "--format", "quantized-mesh",
                 "--max-error", "1", "--workers", "1", "--vertical-crs", "EPSG:32611"])
    out, err = capsys.readouterr()
    assert code != 0 and "vertical_crs must be a vertical CRS" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "qm2").exists() and not (tmp_path / "qm3").exists()
