"""Tiled runs: the seam contract (no cracks, no T-junctions, the bound), executors, resuming, the CLI."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import numpy as np
import pytest
import rasterio
from hypothesis import given, settings
from hypothesis import strategies as st

import tinsmith
import tinsmith.metrics  # a subpackage: loaded for tinsmith.metrics.seam_defects when this file runs alone
from tinsmith.kernels.seam import simplify_profile
from tinsmith.tiles import independent_tiles, tile_raster

from .conftest import run_cli, shared, stop_after, write_tif

ST_HELENS = tinsmith.sample_path("st-helens")


def seam_defects(mesh, hf):
    """(T-junctions, cracks); no edge may be shared by more than two triangles."""
    d = tinsmith.metrics.seam_defects(mesh, hf)
    assert d["overused_edges"] == 0
    return d["t_junctions"], d["cracks"]


# -- the 1-D seam simplification --------------------------------------------------------
@settings(max_examples=60, deadline=None)
@given(
    z=st.lists(st.floats(-50, 50), min_size=2, max_size=200),
    holes=st.lists(st.integers(0, 199), max_size=20),
    bound=st.sampled_from([0.0, 0.3, 5.0]),
)
def test_property_profile_within_bound_between_kept_samples(z, holes, bound):
    z = np.array(z)
    valid = np.ones(len(z), np.uint8)
    valid[[h for h in holes if h < len(z)]] = 0
    keep = np.zeros(len(z), np.uint8)
    keep[0] = keep[-1] = 1
    change = np.flatnonzero(np.diff(valid.astype(int)) != 0)
    keep[change] = keep[change + 1] = 1
    keep &= valid
    forced = keep.copy()
    simplify_profile(np.where(valid, z, 0.0), valid, keep, bound, np.arange(len(z), dtype=np.float64))
    assert (keep >= forced).all() and not (keep & ~valid.astype(bool)).any()
    idx = np.flatnonzero(keep)
    for a, b in zip(idx[:-1], idx[1:], strict=False):
        if b - a > 1 and valid[a:b + 1].all():
            k = np.arange(a + 1, b)
            line = z[a] + (z[b] - z[a]) * ((k - a) / (b - a))
            assert np.abs(line - z[a + 1:b]).max() <= bound


# -- the seam contract on real and random grids -------------------------------------------
@pytest.mark.parametrize("tile_size", [64, 100])
def test_tiles_of_st_helens_join_within_the_bound(tile_size):
    hf = tinsmith.read_heightfield(ST_HELENS)
    run = tile_raster(ST_HELENS, max_error=1.0, tile_size=tile_size, workers=1)
    mesh = run.merge()
    assert mesh.check() == []
    assert seam_defects(mesh, hf) == (0, 0)
    err = tinsmith.vertical_error(mesh, hf)
    assert err["max"] <= 1.0 and run.max_error <= 1.0 and err["coverage"] == 1.0
    single = tinsmith.greedy(hf, max_error=1.0)
    assert abs(mesh.n_triangles - single.n_triangles) <= 0.1 * single.n_triangles


def test_independent_tiles_do_not_join_and_the_check_sees_it():
    """Quadtree tiles meshed apart do not line up (greedy insertion's happen to: a hull edge's
    cells are refined by its own profile alone, as the seams are)."""
    hf = tinsmith.read_heightfield(ST_HELENS)
    t_junctions, cracks = seam_defects(independent_tiles(hf, 128, "quadtree", max_error=2.0), hf)
    assert t_junctions > 0 and cracks > 0


@pytest.mark.parametrize("method, options", [("quadtree", {}), ("cvt", {"ratio": 0.02, "max_iter": 10})])
def test_tile_local_methods_keep_the_seam_contract(method, options):
    hf = tinsmith.read_heightfield(ST_HELENS)
    mesh = tile_raster(ST_HELENS, max_error=2.0, tile_size=128, method=method, options=options, workers=1).merge()
    assert mesh.check() == []
    assert seam_defects(mesh, hf) == (0, 0)
    assert tinsmith.vertical_error(mesh, hf)["max"] <= 2.0


@settings(max_examples=40, deadline=None)
@given(
    shape=st.tuples(st.integers(4, 40), st.integers(4, 40)),
    seed=st.integers(0, 10_000),
    missing=st.sampled_from([0.0, 0.05, 0.3]),
    tile_size=st.integers(2, 17),
    max_error=st.sampled_from([0.05, 0.5, 2.0]),
    method=st.sampled_from(["greedy", "quadtree"]),
)
def test_property_tiles_join_on_any_grid_with_holes(shape, seed, missing, tile_size, max_error, method):
    rng = np.random.default_rng(seed)
    z = rng.normal(0, 1, shape).cumsum(0).cumsum(1) * 0.3
    z[rng.random(shape) < missing] = np.nan
    if np.isnan(z).all():
        return
    with tempfile.TemporaryDirectory() as tmp:
        path = write_tif(Path(tmp) / "dem.tif", np.where(np.isnan(z), -9999.0, z), transform=(2, 0, 500000, 0, -2, 5100000),
                         nodata=-9999.0, dtype="float64")
        hf = tinsmith.read_heightfield(path)
        mesh = tile_raster(path, max_error=max_error, tile_size=tile_size, method=method, workers=1).merge()
    if mesh.n_triangles == 0:
        return
    assert mesh.check() == []
    assert seam_defects(mesh, hf) == (0, 0)
    assert tinsmith.vertical_error(mesh, hf)["max"] <= max_error


def test_wavelet_prefilter_in_tiles_keeps_the_seam_contract():
    dem = shared("urban/delft_ahn3/delft_dtm_0.5m.tif")
    landuse = shared("vector/delft_bgt/delft_bgt_all_epsg28992.geojson")
    hf = tinsmith.read_heightfield(dem)
    run = tile_raster(dem, max_error=0.2, tile_size=256, workers=1,
                      prefilter={"landuse": str(landuse), "spline_iterations": 3})
    mesh = run.merge()
    assert mesh.check() == [] and seam_defects(mesh, hf) == (0, 0)
    assert run.max_error <= 0.2  # against the filtered heights inside, the unfiltered ones on the seams


# -- executors and resuming ------------------------------------------------------------------
def _same(a, b):
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.triangles, b.triangles)


def test_process_pool_gives_the_serial_result():
    serial = tile_raster(ST_HELENS, max_error=1.0, tile_size=100, workers=1).merge()
    pooled = tile_raster(ST_HELENS, max_error=1.0, tile_size=100, workers=2).merge()
    _same(serial, pooled)


def test_dask_local_cluster_by_address_gives_the_local_result():
    distributed = pytest.importorskip("distributed")
    local = tile_raster(ST_HELENS, max_error=1.0, tile_size=100, workers=1).merge()
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        remote = tile_raster(ST_HELENS, max_error=1.0, tile_size=100, scheduler=cluster.scheduler_address).merge()
    _same(local, remote)


def test_rerun_skips_finished_tiles_and_a_new_job_starts_over(tmp_path):
    parts = tmp_path / "parts"
    first = tile_raster(ST_HELENS, max_error=1.0, tile_size=100, workers=1, parts=parts)
    assert first.reused == 0
    n = len(first.specs)
    assert len(list(parts.glob("tile_*.npz"))) == n
    # an interrupted run: two tiles never finished
    for name in ("tile_0000_0001.npz", "tile_0002_0003.npz"):
        (parts / name).unlink()
    again = tile_raster(ST_HELENS, max_error=1.0, tile_size=100, workers=1, parts=parts)
    assert again.reused == n - 2
    _same(first.merge(), again.merge())
    other = tile_raster(ST_HELENS, max_error=2.0, tile_size=100, workers=1, parts=parts)
    assert other.reused == 0


# -- errors --------------------------------------------------------------------------------
def test_bad_input_gives_clear_errors(tmp_path):
    with pytest.raises(tinsmith.InvalidOptionError, match="method must be one of"):
        tile_raster(ST_HELENS, max_error=1.0, method="grid")
    with pytest.raises(tinsmith.InvalidOptionError, match="max_error must be > 0"):
        tile_raster(ST_HELENS, max_error=0.0)
    with pytest.raises(tinsmith.InvalidOptionError, match="unknown option"):
        tile_raster(ST_HELENS, max_error=1.0, method="quadtree", options={"ratio": 0.1})
    with pytest.raises(tinsmith.InvalidInputError, match="tile_size"):
        tile_raster(ST_HELENS, max_error=1.0, tile_size=1)
    with pytest.raises(tinsmith.TinsmithError, match="missing.tif"):
        tile_raster(tmp_path / "missing.tif", max_error=1.0)
    plain = tmp_path / "plain.tif"
    with rasterio.open(plain, "w", driver="GTiff", height=8, width=8, count=1, dtype="float32") as ds:
        ds.write(np.zeros((1, 8, 8), np.float32))
    with pytest.raises(tinsmith.InvalidInputError, match="no georeferencing"):
        tile_raster(plain, max_error=1.0)


# -- the command line ------------------------------------------------------------------------
def test_cli_tile_merges_and_keeps_tiles(tmp_path, capsys):
    code, out, err = run_cli(capsys, "tile", ST_HELENS, "-o", tmp_path / "m.ply", "--max-error", 2,
                             "--tile-size", 128, "--workers", 1)
    assert code == 0, err
    assert "12 tiles of 128" in out and "bound 2" in out
    assert (tmp_path / "m.ply").exists() and not (tmp_path / "m.ply.parts").exists()
    mesh = tinsmith.read_mesh(tmp_path / "m.ply")
    assert seam_defects(mesh, tinsmith.read_heightfield(ST_HELENS)) == (0, 0)
    code, out, err = run_cli(capsys, "tile", ST_HELENS, "-o", tmp_path / "tiles", "--max-error", 2,
                             "--tile-size", 128, "--workers", 1, "--keep-tiles", "--suffix", "obj", "--json")
    assert code == 0, err
    assert json.loads(out)["tiles"] == 12
    assert len(list((tmp_path / "tiles").glob("tile_*.obj"))) == 12


def test_cli_tile_errors_are_one_line(tmp_path, capsys):
    code, _, err = run_cli(capsys, "tile", ST_HELENS, "-o", tmp_path / "m.ply")
    assert code == 1 and "--max-error" in err
    code, _, err = run_cli(capsys, "tile", ST_HELENS, "-o", tmp_path / "m.ply", "--max-error", 1, "--strict")
    assert code == 1 and "do not belong to method greedy" in err
    code, _, err = run_cli(capsys, "tile", ST_HELENS, "-o", tmp_path / "no" / "m.ply", "--max-error", 1)
    assert code == 1 and "does not exist" in err and len(err.strip().splitlines()) == 1


def test_a_run_stopped_midway_resumes_from_its_finished_tiles(tmp_path):
    parts = tmp_path / "parts"

    with pytest.raises(KeyboardInterrupt):
        tile_raster(ST_HELENS, max_error=1.0, tile_size=100, workers=1, parts=parts, progress=stop_after(3))
    (parts / "tiles.jsonl").open("a").write('{"name": "tile_0003_00')  # a line cut short by the stop
    again = tile_raster(ST_HELENS, max_error=1.0, tile_size=100, workers=1, parts=parts)
    assert again.reused == 3
    _same(again.merge(), tile_raster(ST_HELENS, max_error=1.0, tile_size=100, workers=1).merge())


@pytest.mark.parametrize("workers", [1, 2])
def test_a_run_stopped_before_any_tile_leaves_no_parts(tmp_path, workers):
    """Nothing done, nothing to resume from: the parts folder goes (a folder that was there stays, emptied)."""
    parts = tmp_path / "parts"
    with pytest.raises(KeyboardInterrupt):
        tile_raster(ST_HELENS, max_error=1.0, tile_size=100, workers=workers, parts=parts, progress=stop_after(0))
    assert list(tmp_path.iterdir()) == []
    parts.mkdir()
    with pytest.raises(KeyboardInterrupt):
        tile_raster(ST_HELENS, max_error=1.0, tile_size=100, workers=workers, parts=parts, progress=stop_after(0))
    assert list(tmp_path.iterdir()) == [parts] and list(parts.iterdir()) == []
    # stopped with tiles done: they stay for the next run (in the pool, stopped at once, not after every tile)
    with pytest.raises(KeyboardInterrupt):
        tile_raster(ST_HELENS, max_error=1.0, tile_size=100, workers=workers, parts=parts, progress=stop_after(2))
    names = sorted(p.name for p in parts.iterdir())
    assert {"job.json", "tiles.jsonl"} <= set(names) and sum(n.endswith(".npz") for n in names) == 2, names
    assert not [n for n in names if n.startswith(".")], names
    assert tile_raster(ST_HELENS, max_error=1.0, tile_size=100, workers=1, parts=parts).reused == 2


def test_a_folder_refused_as_parts_is_left_alone(tmp_path):
    parts = tmp_path / "parts"
    parts.mkdir()
    (parts / "mine.txt").write_text("data")
    (parts / "job.json").write_text("{}")
    with pytest.raises(tinsmith.TinsmithError, match="parts folder"):
        tile_raster(ST_HELENS, max_error=1.0, tile_size=100, workers=1, parts=parts)
    assert sorted(p.name for p in parts.iterdir()) == ["job.json", "mine.txt"]


# an unreachable scheduler leaves nothing: the bad-input catalog (tests/test_bad_inputs.py), for raster, cloud and
# pyramid runs (each waits out the client's 20 s of retries)
