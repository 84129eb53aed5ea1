"""Point clouds meshed in tiles (tinsmith.tiles.tile_cloud): seams that join, the bound at every point, resuming."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import tinsmith
from tinsmith import PointCloud
from tinsmith.algorithms.greedy import greedy as greedy_module
from tinsmith.errors import InvalidInputError, InvalidOptionError, NoDataError
from tinsmith.io.points import read_clouds
from tinsmith.metrics import point_seam_defects
from tinsmith.tiles import point_threads, tile_cloud
from tinsmith.tiles.point_threads import tile_points
from tinsmith.triangulation.pointtin import checked_points

from .conftest import independent_heights, shared, stop_after, write_las

#: The surveys of this module: ground points (class 2) in UTM 11N.
SURVEY = {"classes": 2, "crs": "EPSG:32611"}


def terrain(n=6000, seed=0, size=300.0):
    """Ground points of a hilly terrain with a lake (no points) and a sparse patch (ground under a canopy)."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0, size, (n, 2))
    lake = np.hypot(xy[:, 0] - 0.6 * size, xy[:, 1] - 0.4 * size) < 0.1 * size
    sparse = (xy[:, 1] > 0.75 * size) & (rng.random(n) < 0.75)
    xy = xy[~lake & ~sparse]
    z = 20 * np.sin(xy[:, 0] / 40) * np.cos(xy[:, 1] / 55) + 0.05 * xy[:, 0] + rng.normal(0, 0.05, len(xy))
    return np.column_stack([xy, z])


def survey(folder, xyz, files=2):
    """``xyz`` written as ``files`` LAS files cut along x, as a survey is delivered."""
    folder.mkdir(exist_ok=True)
    edges = np.linspace(xyz[:, 0].min(), xyz[:, 0].max() + 1e-9, files + 1)
    for k in range(files):
        part = xyz[(xyz[:, 0] >= edges[k]) & (xyz[:, 0] < edges[k + 1])]
        write_las(folder / f"part_{k}.las", part, **SURVEY)
    return folder


def check_run(run, points, bound):
    """The merged mesh: valid, no T-junction or crack at the seams, the bound at every point it covers."""
    mesh = run.merge()
    assert len(run.specs) > 1
    assert mesh.check() == []
    defects = point_seam_defects(mesh, run.seam_segments())
    assert defects["t_junctions"] == 0 and defects["cracks"] == 0 and defects["overused_edges"] == 0
    assert (run.seam_segments()[:, 4] > 0).sum() > 10  # seams were there to join
    from tinsmith.metrics import seam_coverage

    ref = tinsmith.tin(PointCloud(points), max_edge=run.max_edge)
    gaps = seam_coverage(mesh, ref, run.seam_lines(), run.max_edge / 20)
    assert gaps["missed"] <= 0.01 * gaps["reference_covered"]  # no crack between tiles
    z = independent_heights(mesh, points[:, :2])
    inside = ~np.isnan(z)
    assert np.abs(z[inside] - points[inside, 2]).max() <= bound * (1 + 1e-9)
    return mesh, inside


def test_tiles_join_and_hold_the_bound_at_every_point(tmp_path):
    folder = survey(tmp_path / "survey", terrain())
    cloud = read_clouds(folder)
    points = checked_points(cloud)
    run = tile_cloud(folder, max_error=0.2, tile_size=100, max_edge=20, workers=1)
    assert len(run.specs) == 9 and run.max_error <= 0.2
    mesh, inside = check_run(run, points, 0.2)
    # as much covered as one run over the whole cloud, within a few points near the seams
    single = tinsmith.greedy(cloud, max_error=0.2, max_edge=20)
    single_inside = ~np.isnan(independent_heights(single, points[:, :2]))
    assert inside.sum() >= single_inside.sum() - 0.002 * len(points)
    assert run.covered == inside.sum() or abs(run.covered - inside.sum()) <= 0.001 * len(points)
    # the lake stays open, the sparse patch covered
    c = mesh.vertices[mesh.triangles].mean(axis=1)
    assert not (np.hypot(c[:, 0] - 180, c[:, 1] - 120) < 20).any()
    assert (c[:, 1] > 240).sum() > 50
    # seams cost few vertices: within 15% of the single run
    assert mesh.n_vertices <= 1.15 * single.n_vertices


def test_points_on_seam_lines_and_corners_are_seam_vertices(tmp_path):
    xyz = terrain(3000, seed=3)
    rng = np.random.default_rng(4)
    on = np.column_stack([np.full(20, 100.0), rng.uniform(5, 295, 20)])  # on the cut x = 100
    on = np.vstack([on, np.column_stack([rng.uniform(5, 295, 20), np.full(20, 200.0)]), [[100.0, 200.0]]])
    z = 20 * np.sin(on[:, 0] / 40) * np.cos(on[:, 1] / 55) + 3.0  # off the surface: they must become vertices
    xyz = np.vstack([xyz, np.column_stack([on, z]), [[0, 0, 0], [300, 300, 0]]])
    folder = survey(tmp_path / "survey", xyz)
    points = checked_points(read_clouds(folder))
    run = tile_cloud(folder, max_error=0.3, tile_size=100, workers=1)
    assert run.specs[0].xs[1] == 100.0 and run.specs[0].ys[2] == 200.0
    mesh, inside = check_run(run, points, 0.3)
    online = (points[:, 0] == 100.0) | (points[:, 1] == 200.0)
    assert online.sum() == len(on)
    z = independent_heights(mesh, points[online, :2])
    assert np.abs(z - points[online, 2]).max() < 1e-9  # 3 m off the surface, yet exact: seam vertices


def test_same_mesh_on_one_or_two_workers_and_after_a_resume(tmp_path):
    folder = survey(tmp_path / "survey", terrain(4000, seed=1), files=3)
    one = tile_cloud(folder, max_error=0.3, tile_size=120, workers=1).merge()
    two = tile_cloud(folder, max_error=0.3, tile_size=120, workers=2).merge()
    assert np.array_equal(one.vertices, two.vertices) and np.array_equal(one.triangles, two.triangles)
    parts = tmp_path / "parts"
    with pytest.raises(KeyboardInterrupt):  # 3 files bucketed, then 3 tiles, then stopped
        tile_cloud(folder, max_error=0.3, tile_size=120, workers=1, parts=parts, progress=stop_after(6))
    again = tile_cloud(folder, max_error=0.3, tile_size=120, workers=1, parts=parts)
    assert again.reused == 3
    merged = again.merge()
    assert np.array_equal(merged.vertices, one.vertices) and np.array_equal(merged.triangles, one.triangles)


def test_files_are_streamed_into_the_buckets_chunk_by_chunk(tmp_path, monkeypatch):
    """A file passes into the buckets a chunk at a time (no worker holds a whole file); the tiles get the same
    points in the same order, so the mesh is the one a whole-file read gives."""
    import tinsmith.tiles.points as tiled

    folder = survey(tmp_path / "survey", terrain(4000, seed=2), files=2)
    whole = tile_cloud(folder, max_error=0.3, tile_size=120, workers=1, parts=tmp_path / "whole")
    monkeypatch.setattr(tiled, "BUCKET_CHUNK", 500)
    chunked = tile_cloud(folder, max_error=0.3, tile_size=120, workers=1, parts=tmp_path / "chunked")
    first = sorted((tmp_path / "chunked" / "buckets").glob("*/00000.*.npy"))
    assert len({p.name for p in first}) > 2  # the first file, in several chunks
    a, b = whole.merge(), chunked.merge()
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.triangles, b.triangles)


def test_iter_xyz_reads_a_file_in_chunks_of_the_kept_classes(tmp_path):
    from tinsmith.io.points import iter_xyz

    xyz = terrain(3000, seed=3)
    path = tmp_path / "c.las"
    cls = np.where(np.arange(len(xyz)) % 3 == 0, 6, 2).astype(np.uint8)
    write_las(path, xyz, classes=cls, crs="EPSG:32611")
    chunks = list(iter_xyz(path, classes=[2], chunk_size=700))
    assert len(chunks) == -(-len(xyz) // 700) and all(len(c) <= 700 for c in chunks)
    np.testing.assert_array_equal(np.concatenate(chunks), read_clouds([path], classes=[2]).xyz)
    assert list(iter_xyz(path, classes=[9])) == []  # no point of the class: nothing
    with pytest.raises(InvalidOptionError, match="chunk_size"):
        list(iter_xyz(path, chunk_size=0))


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.integers(0, 10_000), st.floats(0.05, 1.0), st.floats(60.0, 160.0))
def test_any_cloud_any_tiling_joins_and_holds_the_bound(tmp_path_factory, seed, bound, tile_size):
    folder = survey(tmp_path_factory.mktemp("survey"), terrain(2500, seed=seed))
    points = checked_points(read_clouds(folder))
    run = tile_cloud(folder, max_error=bound, tile_size=tile_size, workers=1)
    mesh = run.merge()
    assert mesh.check() == []
    defects = point_seam_defects(mesh, run.seam_segments())
    assert defects["t_junctions"] == 0 and defects["cracks"] == 0 and defects["overused_edges"] == 0
    z = independent_heights(mesh, points[:, :2])
    inside = ~np.isnan(z)
    assert inside.mean() > 0.97
    assert np.abs(z[inside] - points[inside, 2]).max() <= bound * (1 + 1e-9)


def test_delft_ground_in_tiles_against_one_run():
    path = shared("urban/delft_ahn3/delft_ahn3_merged.laz")
    cloud = tinsmith.read(path, classes=[2])
    points = checked_points(cloud)
    run = tile_cloud(path, max_error=0.1, classes=[2], tile_size=90, workers=1)
    mesh, inside = check_run(run, points, 0.1)
    single = tinsmith.greedy(cloud, max_error=0.1)
    assert inside.mean() > 0.9999
    assert mesh.n_triangles <= 1.1 * single.n_triangles


def test_greedy_on_threads_is_the_survey_run_of_the_cloud(tmp_path, monkeypatch):
    """One cloud meshed by greedy on threads in tiles: the survey's run of the same points, tile for tile; the
    same mesh on 2 and 3 workers; every point within the bound; about the one-piece mesh's size."""
    folder = survey(tmp_path / "survey", terrain(), files=1)
    cloud = read_clouds(folder)
    points = checked_points(cloud)
    run = tile_cloud(folder, max_error=0.2, tile_size=100, workers=1)
    mesh = tile_points(cloud, max_error=0.2, tile_size=100, workers=2)
    assert np.array_equal(mesh.vertices, run.merge().vertices) and np.array_equal(mesh.triangles, run.merge().triangles)
    mesh, inside = check_run(run, points, 0.2)

    monkeypatch.setattr(point_threads, "TILE_POINTS", 1500)  # tiles of about 1,500 of the 4,500 points
    two = tinsmith.greedy(cloud, max_error=0.2, workers=2)
    three = tinsmith.greedy(cloud, max_error=0.2, workers=3)
    assert two.info["tiles"] >= 3 and two.info["workers"] == 2 and two.info["max_error_used"] == 0.2
    assert np.array_equal(two.vertices, three.vertices) and np.array_equal(two.triangles, three.triangles)
    assert two.check() == []
    z = independent_heights(two, points[:, :2])
    covered = ~np.isnan(z)
    assert np.abs(z[covered] - points[covered, 2]).max() <= 0.2 * (1 + 1e-9)
    one = tinsmith.greedy(cloud, max_error=0.2, workers=1)
    assert "tiles" not in one.info
    one_covered = ~np.isnan(independent_heights(one, points[:, :2]))
    assert covered.sum() >= one_covered.sum() - 0.002 * len(points)
    assert one.n_vertices <= two.n_vertices <= 1.15 * one.n_vertices


def test_greedy_on_points_tiles_only_an_error_bound_without_constraints(monkeypatch):
    """Other stop rules, constraints and the convex hull run in one piece (its TIN on the threads); without
    workers, clouds of PARALLEL_POINTS points and more are tiled on every core."""
    monkeypatch.setattr(point_threads, "TILE_POINTS", 1500)
    cloud = PointCloud(terrain())
    for options in ({"max_vertices": 500}, {"max_edge": None},
                    {"breaklines": [np.array([[50.0, 50.0], [250.0, 60.0]])]}, {"holes": [[(10, 10), (40, 10), (40, 40)]]}):
        mesh = tinsmith.greedy(cloud, **({"max_error": 0.3} | options), workers=2)
        assert "tiles" not in mesh.info, options
    assert "tiles" not in tinsmith.greedy(cloud, max_error=0.3).info  # a small cloud: one piece
    monkeypatch.setattr(greedy_module, "PARALLEL_POINTS", 1000)
    default = tinsmith.greedy(cloud, max_error=0.3)
    assert default.info["tiles"] >= 3 and default.info["workers"] >= 1
    assert np.array_equal(default.triangles, tinsmith.greedy(cloud, max_error=0.3, workers=2).triangles)
    # no stop rule: 1/1000 of the height range, as in one piece
    unbound = tinsmith.greedy(cloud, workers=2)
    assert unbound.info["tiles"] >= 3
    assert unbound.info["max_error_used"] == tinsmith.greedy(cloud, workers=1).info["max_error_used"]
    with pytest.raises(InvalidOptionError, match="max_error must be > 0"):
        tile_points(cloud, max_error=0.0, workers=2)


def test_delft_ground_greedy_on_two_threads():
    cloud = tinsmith.read(shared("urban/delft_ahn3/delft_ahn3_merged.laz"), classes=[2])
    points = checked_points(cloud)
    two = tinsmith.greedy(cloud, max_error=0.1, workers=2)
    one = tinsmith.greedy(cloud, max_error=0.1, workers=1)
    assert two.info["tiles"] > 1 and two.check() == []
    # "auto" sampled in blocks over the cloud: within 3% of the whole TIN's, which one piece takes
    assert two.info["max_edge"] == pytest.approx(one.info["max_edge"], rel=0.03)
    error = tinsmith.vertical_error_at_points(two, points)
    assert error["n_covered"] == error["n_valid"] == len(points) and error["max"] <= 0.1 * (1 + 1e-9)
    assert abs(two.n_vertices - one.n_vertices) <= 0.01 * one.n_vertices


def test_survey_auto_max_edge_is_sampled_over_the_files_not_their_centre(tmp_path, monkeypatch):
    from tinsmith.io.points import clouds_info
    from tinsmith.tiles import point_edge
    from tinsmith.triangulation.pointtin import auto_max_edge_of

    monkeypatch.setattr(point_edge, "SPREAD_POINTS", 30)  # blocks of 30 points: a small survey is "large"
    rng = np.random.default_rng(5)
    xy = np.vstack([rng.uniform(0, 300, (60_000, 2)),
                    rng.uniform(140, 160, (1_500, 2))])  # a thicket at the survey's centre, 6 times as dense
    xyz = np.column_stack([xy, 0.01 * xy[:, 0]])
    cell = (xy // 100).astype(int)
    folder = tmp_path / "survey"
    folder.mkdir()
    for i in range(3):  # 3 x 3 files
        for j in range(3):
            write_las(folder / f"part_{i}{j}.las", xyz[(cell[:, 0] == j) & (cell[:, 1] == i)], **SURVEY)
    infos, _ = clouds_info(folder)
    edge = point_edge.survey_max_edge(infos, [2], "lowest", 2)
    centre = next(i for i in infos if i.path.name == "part_11.las")
    assert centre.count >= point_edge.SURVEY_SAMPLE_FACTOR * 64 * 30  # the centre file holds the blocks
    points = read_clouds([centre.path]).xyz
    x0, y0, _, x1, y1, _ = centre.bounds
    assert edge == point_edge.spread_max_edge(points, (x0, y0, x1, y1), 1)  # its blocks, streamed
    whole = auto_max_edge_of(points)
    thicket = auto_max_edge_of(points[np.abs(points[:, :2] - 150).max(axis=1) <= 10])
    assert edge == pytest.approx(whole, rel=0.15)
    assert thicket < 0.6 * whole  # what a sample at the centre alone takes
    # a class only a far file holds: the sample keeps none of it, and every file is read for it (a few points)
    corner = xyz[(cell[:, 0] == 2) & (cell[:, 1] == 2)]
    rare = corner[:400] + [0.0, 0.0, 1.0]
    write_las(folder / "part_22.las", np.vstack([corner, rare]), classes=np.r_[np.full(len(corner), 2),
                                                                              np.full(400, 9)], crs=SURVEY["crs"])
    infos, _ = clouds_info(folder)
    stored = read_clouds([folder / "part_22.las"], classes=[9]).xyz  # (at the file's resolution)
    assert point_edge.survey_max_edge(infos, [9], "lowest", 1) == auto_max_edge_of(stored)
    with pytest.raises(NoDataError, match="too few points"):
        point_edge.survey_max_edge(infos, [7], "lowest", 1)


def test_bad_tiled_point_runs_are_refused_in_one_line(tmp_path):
    folder = survey(tmp_path / "survey", terrain(1500))
    with pytest.raises(InvalidOptionError, match="max_error"):
        tile_cloud(folder, max_error=0)
    with pytest.raises(InvalidOptionError, match="max_edge"):
        tile_cloud(folder, max_error=0.5, max_edge=None)
    with pytest.raises(NoDataError, match="class"):
        tile_cloud(folder, max_error=0.5, classes=[6])
    write_las(folder / "other.las", terrain(100) + [1000, 0, 0], classes=2, crs="EPSG:26910")
    with pytest.raises(InvalidInputError, match="different CRSs"):
        tile_cloud(folder, max_error=0.5)


def test_dask_local_cluster_by_address_gives_the_local_result(tmp_path):
    distributed = pytest.importorskip("distributed")
    folder = survey(tmp_path / "survey", terrain(3000, seed=2))
    local = tile_cloud(folder, max_error=0.3, tile_size=120, workers=1).merge()
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        remote = tile_cloud(folder, max_error=0.3, tile_size=120, scheduler=cluster.scheduler_address).merge()
    assert np.array_equal(local.vertices, remote.vertices) and np.array_equal(local.triangles, remote.triangles)


def test_tile_command_meshes_a_folder_of_clouds(tmp_path):
    import json
    import subprocess
    import sys

    folder = survey(tmp_path / "survey", terrain(3000, seed=5))
    out = tmp_path / "ground.ply"
    done = subprocess.run([sys.executable, "-m", "tinsmith", "tile", str(folder), "-o", str(out), "--max-error", "0.3",
                           "--tile-size", "100", "--workers", "1", "--json"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stdout)
    assert report["tiles"] == 9 and report["max_error"] <= 0.3 and report["points_covered"] > 0.97 * report["points"]
    mesh = tinsmith.read(out)
    assert mesh.n_triangles == report["n_triangles"] and not (tmp_path / "ground.ply.parts").exists()
    measured = subprocess.run([sys.executable, "-m", "tinsmith", "metrics", str(out), str(folder), "--json"],
                              capture_output=True, text=True)
    assert measured.returncode == 0, measured.stderr
    error = json.loads(measured.stdout)["vertical_error"]
    assert error["max"] <= 0.3 and error["coverage"] > 0.97
    bad = subprocess.run([sys.executable, "-m", "tinsmith", "tile", str(folder), "-o", str(tmp_path / "x.ply"),
                          "--max-error", "0.3", "--method", "cvt"], capture_output=True, text=True)
    assert bad.returncode == 1 and len(bad.stderr.strip().splitlines()) == 1 and "--method cvt" in bad.stderr
    assert not (tmp_path / "x.ply").exists()


def test_info_and_reconstruct_take_a_folder_of_clouds(tmp_path):
    import json
    import subprocess
    import sys

    xyz = terrain(2000, seed=6)
    folder = survey(tmp_path / "survey", xyz, files=3)
    done = subprocess.run([sys.executable, "-m", "tinsmith", "info", str(folder), "--json"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stdout)
    assert report["kind"] == "survey" and report["files"] == 3 and report["points"] == len(xyz)
    assert "32611" in report["crs"]
    out = tmp_path / "r.ply"
    done = subprocess.run([sys.executable, "-m", "tinsmith", "reconstruct", str(folder / "*.las"), "-o", str(out), "--json"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["points"] == len(xyz) and tinsmith.read(out).n_triangles > 100


def test_a_quantized_mesh_pyramid_of_a_tiled_cloud(tmp_path):
    import gzip
    import json

    from tinsmith.io.quantized_mesh import QUANT, decode_tile
    from tinsmith.tiles.points import cloud_pyramid

    xyz = terrain(4000, seed=7) + [400000.0, 3800000.0, 500.0]  # UTM 11N, in the San Gabriel mountains
    folder = survey(tmp_path / "survey", xyz)
    run = tile_cloud(folder, max_error=0.3, tile_size=100, workers=1, parts=tmp_path / "parts")
    out = tmp_path / "pyramid"
    summary = cloud_pyramid(run, out, max_error=0.3, workers=1)
    layer = json.loads((out / "layer.json").read_text())
    assert layer["format"] == "quantized-mesh-1.0" and summary["cell_size"] == pytest.approx(run.max_edge / 12)
    assert all(lvl["mesh_error"] <= lvl["bound"] for lvl in summary["levels"].values())
    finest = summary["levels"][summary["max_zoom"]]
    assert finest["triangles"] > 0 and finest["bound"] == 0.3
    heights = []
    for f in (out / str(summary["max_zoom"])).rglob("*.terrain"):
        d = decode_tile(gzip.decompress(f.read_bytes()))
        span = d["header"]["max_height"] - d["header"]["min_height"]
        heights += list(d["header"]["min_height"] + d["h"] / QUANT * span)
    heights = np.array(heights)
    z = xyz[:, 2]
    beyond = np.abs(heights) < 1e-3  # beyond the survey the tiles stand on the ellipsoid
    assert beyond.any() and z.min() - 1 <= heights[~beyond].min() and heights.max() <= z.max() + 1
    with pytest.raises(InvalidInputError, match="no CRS"):
        no_crs = survey(tmp_path / "bare", terrain(1500))
        for f in no_crs.glob("*.las"):
            write_las(f, read_clouds(f).xyz, classes=2, crs=None)
        cloud_pyramid(tile_cloud(no_crs, max_error=0.5, tile_size=100, workers=1), tmp_path / "p2", max_error=0.5)


def test_lod_and_compare_take_a_folder_of_clouds(tmp_path):
    import json
    import subprocess
    import sys

    folder = survey(tmp_path / "survey", terrain(3000, seed=8), files=2)
    done = subprocess.run([sys.executable, "-m", "tinsmith", "compare", str(folder), "--methods", "greedy,quadtree",
                           "--max-error", "0.5", "--json"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert [r["method"] for r in json.loads(done.stdout)["rows"]] == ["greedy", "quadtree"]
    done = subprocess.run([sys.executable, "-m", "tinsmith", "lod", str(folder / "part_0.las"), str(folder / "part_1.las"),
                           "-o", str(tmp_path / "levels"), "--levels", "2,0.5", "--json"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert len(json.loads((tmp_path / "levels" / "index.json").read_text())["levels"]) == 2
