"""The command line, through its real entry point (in-process and as the installed script)."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest

from tinsmith.io import WRITERS

from .bad_inputs import degrees_las
from .conftest import run_cli as run
from .conftest import shared, write_las, write_tif

#: The GeoTIFFs this module writes: float32 heights on 10 m cells.
TEN_METRE = {"transform": (10, 0, 1000, 0, -10, 2000), "dtype": "float32"}


def test_simplify_sample_prints_the_summary(tmp_path, capsys):
    out_file = tmp_path / "st_helens.ply"
    code, out, err = run(capsys, "simplify", "--sample", "st-helens", "-o", out_file)
    assert code == 0, err
    assert out_file.exists() and out_file.with_suffix(".prj").exists()
    assert "468 x 327 = 153,036 cells (148,885 valid) -> method greedy" in out
    assert "coverage 100.00%" in out
    assert "time:" in out and "timings" not in out
    code, out, err = run(capsys, "simplify", "--sample", "st-helens", "-o", out_file, "--json")
    report = json.loads(out)
    # default bound: 1/1000 of the relief (682..2543 m)
    assert report["vertical_error"]["max"] <= (2543 - 682) / 1000
    assert report["n_vertices"] < 148_885 / 2


def test_simplify_with_max_error_and_max_vertices(tmp_path, capsys):
    out_file = tmp_path / "out.ply"
    code, out, err = run(capsys, "simplify", "--sample", "st-helens", "-o", out_file, "--max-error", "2", "--json")
    assert code == 0, err
    assert json.loads(out)["vertical_error"]["max"] <= 2.0
    code, out, err = run(capsys, "simplify", "--sample", "st-helens", "-o", out_file, "--max-vertices", "5000", "--json")
    assert code == 0, err
    assert json.loads(out)["n_vertices"] <= 5000


def test_simplify_writes_every_format_in_one_run_with_json_and_timings(tmp_path, capsys):
    suffixes = sorted(WRITERS)
    outs = [tmp_path / f"mesh{s}" for s in suffixes]
    args = ["simplify", "--sample", "st-helens", "--method", "grid", "--json", "-v"]
    for o in outs:
        args += ["-o", o]
    code, out, err = run(capsys, *args)
    assert code == 0, err
    report = json.loads(out)
    assert report["n_vertices"] == 148_885 and report["method"] == "grid"
    assert report["vertical_error"]["max"] == 0.0 and report["vertical_error"]["coverage"] == 1.0
    assert set(report["outputs"]) == {str(o) for o in outs}
    assert {"read", "method", "metrics"} <= set(report["timings"])
    for o in outs:
        assert o.exists() and o.stat().st_size > 0, o
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")], "temporary files left behind"


def test_metrics_of_the_grid_mesh_against_its_dem_is_exact(tmp_path, capsys):
    mesh_file = tmp_path / "m.ply"
    assert run(capsys, "simplify", "--sample", "st-helens", "--method", "grid", "-o", mesh_file)[0] == 0
    code, out, err = run(capsys, "metrics", mesh_file, "--sample", "st-helens", "--json")
    assert code == 0, err
    m = json.loads(out)
    assert m["vertical_error"]["max"] == 0.0
    assert m["vertical_error"]["coverage"] == 1.0
    assert m["n_triangles"] == 296_203
    code, out, _ = run(capsys, "metrics", mesh_file, shared("terrain/st_helens/SainteHelens.dem"))
    assert code == 0 and "max 0, RMS 0" in out and "min angle" in out


RASTERS = [
    ("terrain/st_helens/SainteHelens.dem", "468 rows x 327 cols", "EPSG:26710", "4,151 cells (2.71%)"),
    ("terrain/st_helens/SainteHelens_30m.tif", "468 rows x 327 cols", "EPSG:26710", "4,151 cells"),
    ("terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif", "643 rows x 1,197 cols", "EPSG:32611", "0 cells"),
    ("terrain/landlab_west_bijou/west_bijou_gully.asc", "89 rows x 43 cols", "crs: none", "2,739 cells"),
    ("terrain_rgb/terrarium_grand_canyon_z11_385_803_elev.tif", "256 rows x 256 cols", "EPSG:3857", "0 cells"),
    ("terrain_rgb/terrarium_grand_canyon_z11_385_803.png", "256 rows x 256 cols", "EPSG:3857", "0 cells"),
    ("urban/delft_ahn3/delft_dsm_0.5m.tif", "458 rows x 529 cols", "EPSG:28992", "0 cells"),
    ("urban/delft_ahn3/delft_dtm_0.5m.tif", "458 rows x 529 cols", "EPSG:28992", "0 cells"),
    ("urban/codem_ncalm/codem_dsm_1m.tif", "344 rows x 405 cols", "32616", "4,499 cells"),
]


@pytest.mark.parametrize("relative, size, crs, nodata", RASTERS)
def test_info_on_every_shared_raster(capsys, relative, size, crs, nodata):
    code, out, err = run(capsys, "info", shared(relative))
    assert code == 0, err
    assert size in out and crs in out and f"nodata: {nodata}" in out and "z range:" in out


POINT_CLOUDS = [
    ("terrain/lidR_forest_lakes/Topography.laz", "73,403", "1: 61,347, 2: 8,159, 9: 3,897"),
    ("terrain/lidR_forest_lakes/MixedConifer.laz", "37,657", "1: 31,832, 2: 5,820, 11: 5"),
    ("urban/delft_ahn3/ahn3_cropped_1.laz", "640,510", "1: 196,137, 2: 195,988, 6: 246,753, 9: 267, 26: 1,365"),
    ("urban/delft_ahn3/ahn3_cropped_2.laz", "208,432", "2: 87,130"),
    ("urban/delft_ahn3/delft_ahn3_merged.laz", "848,942", "6: 280,065"),
    ("urban/codem_ncalm/codem_pc.laz", "222,224", "0: 222,224"),
    ("urban/autzen_pdal/autzen_trim.laz", "110,000", "1: 83,893, 2: 26,107"),
]


@pytest.mark.parametrize("relative, count, classes", POINT_CLOUDS)
def test_info_on_every_shared_point_cloud(capsys, relative, count, classes):
    code, out, err = run(capsys, "info", shared(relative))
    assert code == 0, err
    assert f"points: {count}" in out and classes in out


def test_every_shared_raster_and_point_cloud_is_covered(shared_data):
    listed = {r[0] for r in RASTERS} | {p[0] for p in POINT_CLOUDS}
    found = {
        str(p.relative_to(shared_data))
        for p in shared_data.rglob("*")
        if p.suffix.lower() in {".tif", ".dem", ".asc", ".png", ".laz", ".las"}
    }
    assert found <= listed


def test_info_json_and_mesh_info(tmp_path, capsys):
    code, out, _ = run(capsys, "info", "--sample", "st-helens", "--json")
    report = json.loads(out)
    assert code == 0 and report["rows"] == 468 and report["nodata_cells"] == 4151
    mesh_file = tmp_path / "m.obj"
    run(capsys, "simplify", "--sample", "st-helens", "--method", "grid", "-o", mesh_file)
    code, out, _ = run(capsys, "info", mesh_file)
    assert code == 0 and "triangles: 296,203" in out and "valid triangulation: yes" in out


def test_simplify_a_point_cloud_grids_it(tmp_path, capsys):
    out_file = tmp_path / "ground.ply"
    code, out, err = run(
        capsys, "simplify", shared("terrain/lidR_forest_lakes/Topography.laz"), "--classes", "2",
        "--cell-size", "4", "--statistic", "mean", "--method", "grid", "-o", out_file, "--json",
    )
    assert code == 0, err
    report = json.loads(out)
    assert report["cells"] == 72 * 72 and report["vertical_error"]["max"] == 0.0
    assert out_file.exists()


def test_listing_commands(capsys):
    code, out, _ = run(capsys, "methods")
    assert code == 0 and out.startswith("grid: full resolution") and "greedy (default): greedy insertion" in out
    code, out, _ = run(capsys, "methods", "--json")
    assert [m["name"] for m in json.loads(out)["methods"]][:2] == ["grid", "greedy"]
    code, out, _ = run(capsys, "samples")
    assert code == 0 and out.startswith("st-helens: Mount St. Helens")
    code, out, _ = run(capsys, "formats")
    assert code == 0 and ".gpkg" in out and ".laz" in out
    assert run(capsys, "--version")[1].startswith("tinsmith, version")
    code, out, _ = run(capsys, "simplify", "--help")
    assert code == 0 and "--max-error" in out


# -- bad input: exit 1, one line naming the problem, no output file ---------------------------
def _bad_inputs(tmp_path):
    cases = {}
    cases["missing input"] = (["simplify", tmp_path / "nope.tif"], "does not exist")
    (tmp_path / "text.tif").write_text("this is not a raster\n")
    cases["unreadable input"] = (["simplify", tmp_path / "text.tif"], "cannot read")
    whole = write_tif(tmp_path / "whole.tif", np.arange(400.0).reshape(20, 20), **TEN_METRE)
    data = whole.read_bytes()
    (tmp_path / "truncated.tif").write_bytes(data[: len(data) // 2])
    cases["truncated input"] = (["simplify", tmp_path / "truncated.tif"], "truncated.tif")
    write_tif(tmp_path / "empty.tif", np.full((4, 4), -9999.0), nodata=-9999, **TEN_METRE)
    cases["all nodata"] = (["simplify", tmp_path / "empty.tif"], "nodata")
    write_tif(tmp_path / "one.tif", [[5.0]], **TEN_METRE)
    cases["1x1 raster"] = (["simplify", tmp_path / "one.tif"], "2 x 2")
    z = np.ones((5, 5))
    z[2, 2] = np.nan
    write_tif(tmp_path / "nan.tif", z, **TEN_METRE)
    cases["undeclared NaN"] = (["simplify", tmp_path / "nan.tif"], "NaN")
    z[2, 2] = np.inf
    write_tif(tmp_path / "inf.tif", z, **TEN_METRE)
    cases["undeclared inf"] = (["simplify", tmp_path / "inf.tif"], "infinite")
    cases["negative max error"] = (["simplify", whole, "--max-error", "-1"], "max_error must be a finite number >= 0")
    cases["unknown method"] = (["simplify", whole, "--method", "magic"], "unknown method 'magic'")
    cases["unknown option"] = (["simplify", whole, "--smoothness", "3"], "no such option")
    cases["missing output folder"] = (["simplify", whole, "-o", tmp_path / "no" / "dir" / "out.ply"], "output folder")
    cases["unsupported suffix"] = (["simplify", whole, "-o", tmp_path / "out.xyzzy"], "unsupported output suffix .xyzzy")
    return cases


BAD = [
    "missing input", "unreadable input", "truncated input", "all nodata", "1x1 raster", "undeclared NaN",
    "undeclared inf", "negative max error", "unknown method", "unknown option", "missing output folder",
    "unsupported suffix",
]


@pytest.mark.parametrize("case", BAD)
def test_bad_input_gives_one_line_and_no_output(tmp_path, capsys, case):
    args, expected = _bad_inputs(tmp_path)[case]
    if not any(str(a) == "-o" for a in args):
        args = [*args, "-o", tmp_path / "out.ply"]
    before = set(tmp_path.rglob("*"))
    code, out, err = run(capsys, *args)
    assert code == 1
    assert out == ""
    assert len(err.strip().splitlines()) == 1, err
    assert expected.lower() in err.lower()
    assert set(tmp_path.rglob("*")) == before  # nothing written, no temporary left


def test_laz_without_points_of_the_requested_class(tmp_path, capsys):
    laz = shared("terrain/lidR_forest_lakes/Topography.laz")
    for command in (["simplify", laz, "--classes", "6", "-o", tmp_path / "x.ply"], ["info", laz, "--classes", "6"]):
        code, out, err = run(capsys, *command)
        assert code == 1 and len(err.strip().splitlines()) == 1
        assert "no points of class" in err and "6" in err
    assert list(tmp_path.iterdir()) == []


def test_option_that_does_not_apply_and_verbose_traceback(tmp_path, capsys):
    code, _, err = run(capsys, "info", "--sample", "st-helens", "--classes", "2")
    assert code == 1 and "does not apply" in err
    code, _, err = run(capsys, "info", tmp_path / "nope.tif", "-v")
    assert code == 1 and "Traceback" in err and err.strip().splitlines()[-1].startswith("tinsmith: error")


def test_installed_console_script_runs_the_readme_command(tmp_path):
    exe = shutil.which("tinsmith")
    if exe is None:
        pytest.skip("console script not on PATH")
    proc = subprocess.run(
        [exe, "simplify", "--sample", "st-helens", "-o", "st_helens.ply"],
        cwd=tmp_path, capture_output=True, text=True, timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    assert "method greedy" in proc.stdout and "coverage 100.00%" in proc.stdout
    proc = subprocess.run([exe, "simplify", "nope.tif", "-o", "x.ply"], cwd=tmp_path, capture_output=True, text=True)
    assert proc.returncode == 1 and proc.stderr.count("\n") == 1
    proc = subprocess.run([sys.executable, "-m", "tinsmith", "methods"], capture_output=True, text=True)
    assert proc.returncode == 0 and "grid" in proc.stdout


def test_method_options_come_from_the_registry(tmp_path, capsys):
    from tinsmith.algorithms import registry
    from tinsmith.algorithms.registry import Option, register
    from tinsmith.triangulation.grid import grid_mesh

    seen = {}

    @register("cli-toy", description="test", options=[Option("rounds", int, 2, "rounds", minimum=1)])
    def toy(hf, *, rounds, stop, progress):
        seen.update(rounds=rounds, max_vertices=stop.max_vertices)
        return grid_mesh(hf)

    try:
        out_file = tmp_path / "t.ply"
        code, out, err = run(capsys, "simplify", "--sample", "st-helens", "--method", "cli-toy",
                             "--rounds", "3", "--max-vertices", "500", "-o", out_file)
        assert code == 0, err
        assert seen == {"rounds": 3, "max_vertices": 500}
        code, out, _ = run(capsys, "simplify", "--help")
        assert "--rounds" in out and "[cli-toy] rounds; default 2" in out
        code, _, err = run(capsys, "simplify", "--sample", "st-helens", "--rounds", "3", "-o", out_file)
        assert code == 1 and "method 'greedy' has no option 'rounds'" in err
        code, _, err = run(capsys, "simplify", "--sample", "st-helens", "--method", "cli-toy",
                           "--rounds", "0", "-o", out_file)
        assert code == 1 and "'--rounds': 0 is not in the range x>=1" in err  # the bound, checked by click
    finally:
        registry._REGISTRY.pop("cli-toy")


def test_breaklines_and_control_points_from_vector_files(tmp_path, capsys):
    import pyogrio.raw
    import shapely

    from tinsmith import sample

    xmin, ymin, _, _ = sample("st-helens").bounds
    line = shapely.LineString([[xmin + 3000, ymin + 3000], [xmin + 7000, ymin + 9000]])
    points = shapely.MultiPoint([[xmin + 5000, ymin + 5000]])
    for name, geom, kind, crs in [
        ("lines.gpkg", line, "LineString", "EPSG:26710"),
        ("points.geojson", points, "MultiPoint", "EPSG:26710"),
        ("wgs84.gpkg", line, "LineString", "EPSG:4326"),
    ]:
        pyogrio.raw.write(
            str(tmp_path / name), geometry=np.array([shapely.to_wkb(geom)], dtype=object), field_data=[],
            fields=[], geometry_type=kind, crs=crs, driver="GPKG" if name.endswith("gpkg") else "GeoJSON",
        )
    out_file = tmp_path / "out.ply"
    code, out, err = run(
        capsys, "simplify", "--sample", "st-helens", "--max-error", "5", "--breaklines", tmp_path / "lines.gpkg",
        "--control-points", tmp_path / "points.geojson", "-o", out_file, "--json",
    )
    assert code == 0, err
    assert json.loads(out)["vertical_error"]["max"] <= 5
    code, _, err = run(capsys, "simplify", "--sample", "st-helens", "--breaklines", tmp_path / "wgs84.gpkg", "-o", out_file)
    # the DEM's own coordinates labelled WGS 84: out of its range, nothing to place (tinsmith.io.geometry)
    assert code == 1 and "is the file's CRS right" in err and len(err.strip().splitlines()) == 1, err


def test_quality_regions_from_a_vector_file_reach_the_solver_file(tmp_path, capsys):
    import meshio
    import pyogrio.raw
    import shapely

    from tinsmith import sample

    xmin, ymin, _, _ = sample("st-helens").bounds
    channel = shapely.LineString([[xmin + 3000, ymin + 3000], [xmin + 7000, ymin + 9000]]).buffer(300)
    pyogrio.raw.write(
        str(tmp_path / "regions.geojson"), geometry=np.array([shapely.to_wkb(channel)], dtype=object),
        field_data=[np.array([5000.0]), np.array(["channel"], dtype=object)], fields=["max_area", "name"],
        geometry_type="Polygon", crs="EPSG:26710", driver="GeoJSON",
    )
    out_file = tmp_path / "out.msh"
    code, out, err = run(capsys, "simplify", "--sample", "st-helens", "--method", "quality", "--max-error", "20",
                         "--regions", tmp_path / "regions.geojson", "-o", out_file)
    assert code == 0, err
    assert "plan-view angles: min 30 deg for a bound of 30" in out
    assert "vertices taken back in" in out  # the improvement passes ran
    ref = meshio.read(out_file)
    assert set(ref.field_data) == {"outline", "terrain", "channel"}


def test_every_dem_command_takes_a_sample(tmp_path, capsys):
    code, out, err = run(capsys, "tile", "--sample", "st-helens", "-o", tmp_path / "t.ply", "--max-error", "10",
                         "--tile-size", "200")
    assert code == 0, err
    assert (tmp_path / "t.ply").is_file()
    code, _, err = run(capsys, "tile", "x.tif", "y.tif", "--sample", "st-helens", "-o", tmp_path / "t.ply",
                       "--max-error", "10")
    assert code == 1 and "not both" in err


def test_compare_and_tile_take_every_method_or_say_why(tmp_path, capsys):
    import tinsmith

    names = [m.name for m in tinsmith.methods()]
    code, out, err = run(capsys, "compare", "--sample", "st-helens", "--max-vertices", "1500", "--json",
                         "--methods", ",".join(names))
    assert code == 0, err
    rows = {r["method"]: r for r in json.loads(out)["rows"]}
    assert set(rows) == set(names)
    for name, row in rows.items():
        assert row["n_vertices"] is not None or (row["error"] and "\n" not in row["error"]), name
    code, out, err = run(capsys, "compare", "--sample", "st-helens", "--max-error", "20", "--json", "--methods", "cvt")
    assert code == 0 and "takes max_vertices" in json.loads(out)["rows"][0]["error"]
    for name in names:
        code, _, err = run(capsys, "tile", "--sample", "st-helens", "-o", tmp_path / f"{name}.ply", "--max-error", "20",
                           "--tile-size", "256", "--method", name, "--workers", "1")
        assert code == 0 or (name in err and len(err.strip().splitlines()) == 1), (name, err)


def test_wavelet_is_a_method_and_a_prefilter(tmp_path, capsys):
    code, out, err = run(capsys, "simplify", "--sample", "st-helens", "--method", "wavelet", "--max-error", "2",
                         "-o", tmp_path / "w.ply", "--json")
    assert code == 0, err
    assert json.loads(out)["vertical_error"]["coverage"] == 1.0
    code, _, err = run(capsys, "simplify", "--sample", "st-helens", "--method", "wavelet", "--prefilter", "wavelet",
                       "--landuse", "x.gpkg", "-o", tmp_path / "w.ply")
    assert code == 1 and "leave out --prefilter" in err


# -- point clouds as tinsmith.read takes them (issue 42) --------------------------------------------
def _las(path, n=200, epsg=32610, seed=0):
    """``n`` ground points in a 60 m square, heights a sine of x as stored (x to 1 cm)."""
    rng = np.random.default_rng(seed)
    x, y = 500000 + rng.uniform(0, 60, n), 4100000 + rng.uniform(0, 60, n)
    stored_x = np.round((x - 500000.0) / 0.01) * 0.01 + 500000.0
    return write_las(path, np.column_stack([x, y, 30 + np.sin(stored_x / 7)]), classes=2, crs=f"EPSG:{epsg}",
                     scales=0.01, offsets=(500000.0, 4100000.0, 0.0))


@pytest.mark.parametrize("command", [["info"], ["simplify", "-o", "m.ply"], ["reconstruct", "-o", "m.ply"],
                                     ["lod", "-o", "levels", "--levels", "5"],
                                     ["remesh", "-o", "m.ply", "--vertices", "50"], ["city", "-o", "m.ply"],
                                     ["compare", "--max-error", "1"]])
def test_las_cut_at_a_record_boundary_is_refused_by_every_command(tmp_path, capsys, command):
    laspy = pytest.importorskip("laspy")
    whole = _las(tmp_path / "whole.las")
    header = laspy.open(whole).header
    cut = tmp_path / "in" / "cut.las"
    cut.parent.mkdir()
    cut.write_bytes(whole.read_bytes()[: header.offset_to_point_data + 120 * header.point_format.size])
    out = tmp_path / "out"
    out.mkdir()
    name, *rest = command
    for given in (cut, cut.parent, tmp_path / "in" / "*.las"):
        args = [name, given, *[out / a if a in ("m.ply", "levels") else a for a in rest]]
        code, _, err = run(capsys, *args)
        assert code == 1 and len(err.strip().splitlines()) == 1, err
        assert f"{str(cut)!r} holds 120 points but its header announces 200" in err
    assert list(out.iterdir()) == []


def test_clouds_as_a_list_a_folder_and_a_glob(tmp_path, capsys):
    folder = tmp_path / "survey"
    folder.mkdir()
    for i in range(3):
        _las(folder / f"t{i}.las", n=100, seed=i)
    counts = []
    for given in ([folder / "t0.las", folder / "t1.las", folder / "t2.las"], [folder], [folder / "t*.las"]):
        code, out, err = run(capsys, "reconstruct", *given, "-o", tmp_path / "m.ply", "--json")
        assert code == 0, err
        counts.append(json.loads(out)["points"])
    assert counts == [300, 300, 300]


def test_clouds_in_different_crss_refused_as_by_the_api(tmp_path, capsys):
    import tinsmith

    a, b = _las(tmp_path / "a.las", epsg=32610), _las(tmp_path / "b.las", epsg=32611)
    with pytest.raises(tinsmith.TinsmithError) as info:
        tinsmith.read([a, b])
    for command in (["simplify", a, b, "-o", tmp_path / "m.ply"], ["reconstruct", tmp_path, "-o", tmp_path / "m.ply"],
                    ["info", a, b]):
        code, _, err = run(capsys, *command)
        assert code == 1 and err.strip() == f"tinsmith: error: {info.value}", err
    assert not (tmp_path / "m.ply").exists()


def test_empty_folder_and_glob_matching_nothing(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    for given, needle in ((tmp_path / "empty", "is empty"), (tmp_path / "tiles" / "*.laz", "no file matches")):
        for command in (["simplify", given, "-o", tmp_path / "m.ply"], ["reconstruct", given, "-o", tmp_path / "m.ply"]):
            code, _, err = run(capsys, *command)
            assert code == 1 and len(err.strip().splitlines()) == 1 and needle in err and str(given) in err, err


# -- several bands (issue 42) ---------------------------------------------------------------------
def _three_bands(path):
    z = (50 + np.add.outer(np.arange(20.0), np.sin(np.arange(24.0)))).astype(np.float32)
    return write_tif(path, np.stack([z + 100 * b for b in range(3)]), transform=(5, 0, 500000, 0, -5, 4100100))


@pytest.mark.parametrize("command", [["simplify", "-o", "m.ply"], ["info"], ["remesh", "-o", "m.ply", "--vertices", "60"],
                                     ["tile", "-o", "m.ply", "--max-error", "1", "--workers", "1"],
                                     ["city", "-o", "m.ply", "--ground-window", "20"], ["compare", "--max-error", "1"]])
def test_several_bands_one_warning_and_band_option(tmp_path, capsys, command):
    dem = _three_bands(tmp_path / "bands.tif")
    name, *rest = command
    args = [name, dem, *[tmp_path / a if a in ("m.ply", "levels") else a for a in rest]]
    code, _, err = run(capsys, *args)
    lines = err.strip().splitlines()
    assert code == 0 and len(lines) == 1, err
    assert lines[0].startswith("tinsmith: warning:") and "bands.tif" in lines[0] and "3 bands" in lines[0]
    assert "--band N" in lines[0]
    code, _, err = run(capsys, *args, "--band", "2")
    assert code == 0 and err.strip() == "", err
    for bad, needle in (("0", "--band"), ("4", "the file has 3 bands")):
        code, _, err = run(capsys, *args, "--band", bad)
        lines = err.strip().splitlines()
        assert code == 1 and len(lines) == 1 and "error" in lines[0] and needle in lines[0], err


def test_band_2_is_the_band_meshed(tmp_path, capsys):
    dem = _three_bands(tmp_path / "bands.tif")
    code, out, err = run(capsys, "info", dem, "--band", "2", "--json")
    assert code == 0 and err == ""
    assert json.loads(out)["z_min"] >= 149.0  # band 1 starts at 49


def test_one_band_and_terrarium_tiles_read_in_silence(tmp_path, capsys):
    dem = write_tif(tmp_path / "one.tif", np.arange(400.0).reshape(20, 20), **TEN_METRE)
    for given in (dem, shared("terrain_rgb/terrarium_grand_canyon_z11_385_803.png")):
        code, _, err = run(capsys, "simplify", given, "-o", tmp_path / "m.ply")
        assert code == 0 and err.strip() == "", err


def test_reconstruct_warns_once_about_a_geographic_cloud(tmp_path, capsys):
    pytest.importorskip("laspy")
    rng = np.random.default_rng(0)
    degrees_las(tmp_path / "geo.las", 13.4 + rng.uniform(0, 0.002, 300), 52.498 + rng.uniform(0, 0.002, 300),
                rng.uniform(30, 35, 300))
    code, _, err = run(capsys, "reconstruct", tmp_path / "geo.las", "-o", tmp_path / "m.ply")
    lines = err.strip().splitlines()
    assert code == 0 and len(lines) == 1 and lines[0].startswith("tinsmith: warning:") and "geographic" in lines[0]
    assert "EPSG:32633" in lines[0]


# -- one module-level command per module, each a thin layer over the API (issue 43) -------------------------
def test_every_command_is_a_module_level_object_of_its_own_module():
    import importlib
    import inspect

    from tinsmith.cli.main import COMMANDS, cli

    assert list(cli.commands.values()) == list(COMMANDS)  # registered from the one list
    for name, command in cli.commands.items():
        module = importlib.import_module(command.callback.__module__)
        assert getattr(module, name) is command, f"{name} is not {module.__name__}.{name}"
        lines, _ = inspect.getsourcelines(command.callback)
        body = lines[next(i for i, line in enumerate(lines) if line.lstrip().startswith("def ")):]
        assert len(body) <= 60, f"the callback of {name} is {len(body)} lines: keep the command a thin layer"


def test_urban_is_the_hidden_old_name_of_city(tmp_path, capsys):
    dem = write_tif(tmp_path / "dsm.tif", np.full((30, 30), 10.0))
    code, out, err = run(capsys, "--help")
    assert "  city " in out and "urban" not in out
    for name in ("city", "urban"):  # an option of the block model without --roofs levels: the API's rule
        code, _, err = run(capsys, name, dem, "-o", tmp_path / "m.ply", "--lod", "3")
        lines = err.strip().splitlines()
        assert code == 1
        assert lines[-1] == "tinsmith: error: lod is an option of roofs 'levels' (the Salt Lake City thesis' block model)"
        assert lines[:-1] == ([] if name == "city" else [
            "tinsmith: note: 'tinsmith urban' is now 'tinsmith city' (the same options); the old name goes in a later "
            "release"])
    code, out, err = run(capsys, "urban", dem, "-o", tmp_path / "m.ply", "--json")
    assert code == 0 and err.startswith("tinsmith: note: 'tinsmith urban' is now 'tinsmith city'"), err
    assert json.loads(out)["n_buildings"] == 0 and (tmp_path / "m.ply").exists()


def test_wavelet_epsilon_is_the_hidden_old_name_of_max_error(tmp_path, capsys, monkeypatch):
    import tinsmith.cli.wavelet
    from tinsmith.errors import TinsmithError

    given = []

    def wavelet_mesh(hf, max_error, **kwargs):
        given.append(max_error)
        raise TinsmithError("stopped")

    monkeypatch.setattr(tinsmith.cli.wavelet, "wavelet_mesh", wavelet_mesh)
    args = ["wavelet", "--sample", "st-helens", "--landuse", tmp_path / "l.gpkg", "-o", tmp_path / "w.ply"]
    assert "--epsilon" not in run(capsys, "wavelet", "--help")[1]
    for extra, value, note in (([], 0.2, False), (["--max-error", "0.5"], 0.5, False), (["--epsilon", "0.7"], 0.7, True)):
        code, _, err = run(capsys, *args, *extra)
        assert code == 1 and given[-1] == value and err.strip().splitlines()[-1] == "tinsmith: error: stopped"
        assert ("tinsmith: note: --epsilon is now --max-error" in err) == note, err
    code, _, err = run(capsys, *args, "--epsilon", "0.7", "--max-error", "0.5")
    assert code == 1 and "--epsilon is the old name of --max-error: give one of them" in err
