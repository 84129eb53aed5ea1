"""LiDAR straight to a TIN: tinsmith.tin, greedy insertion on points, constraints, many files (issue 22)."""

import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tinsmith
from tinsmith import PointCloud
from tinsmith.errors import InvalidInputError, NoDataError

from .conftest import independent_heights, shared

OPTION_ERRORS = (tinsmith.InvalidOptionError, InvalidInputError)
FOREST = ["terrain/lidR_forest_lakes/MixedConifer.laz", "terrain/lidR_forest_lakes/Topography.laz"]


def random_cloud(n=3000, seed=0, f=lambda x, y: 0.3 * x + 0.1 * y):
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0, 100, (n, 2))
    return PointCloud(np.column_stack([xy, f(xy[:, 0], xy[:, 1])]))


def test_tin_of_points_on_a_plane_interpolates_it_exactly():
    cloud = random_cloud()
    mesh = tinsmith.tin(cloud, max_edge=None)
    assert mesh.n_vertices == len(cloud)
    q = np.random.default_rng(1).uniform(20, 80, (500, 2))
    assert np.allclose(independent_heights(mesh, q), 0.3 * q[:, 0] + 0.1 * q[:, 1], atol=1e-9)
    # Delaunay: the same triangles as scipy's (no four cocircular points in random input)
    from scipy.spatial import Delaunay

    assert np.array_equal(mesh.vertices, cloud.xyz)  # distinct points keep their order
    ours = {tuple(sorted(t)) for t in mesh.triangles.tolist()}
    theirs = {tuple(sorted(t)) for t in Delaunay(cloud.xyz[:, :2]).simplices.tolist()}
    assert ours == theirs


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(min_value=0.0, max_value=1e12, allow_subnormal=True), min_size=1, max_size=300),
       st.integers(0, 3))
def test_median_kernel_is_numpy_median(values, repeat):
    from tinsmith.kernels.pointtin import median

    v = np.array(values * (repeat + 1))  # repeated values put the middle ones in one bin
    kept = v.copy()
    assert median(v) == np.median(v)
    assert np.array_equal(v, kept)  # not reordered


def test_median_edge_is_that_of_every_edge_once():
    from tinsmith.kernels.pointtin import edge_lengths, median
    from tinsmith.triangulation.pointtin import point_tin

    ptin = point_tin(random_cloud(2000, seed=4), max_edge=None)
    tri = ptin.triangles
    px, py = ptin.m[0], ptin.m[1]
    pairs = {tuple(sorted(p)) for t in tri.tolist() for p in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))}
    a, b = np.array(sorted(pairs)).T
    expected = np.sqrt((px[a] - px[b]) ** 2 + (py[a] - py[b]) ** 2)
    lengths = edge_lengths(ptin.m)
    assert np.array_equal(np.sort(lengths), np.sort(expected))
    assert median(lengths) == np.median(expected)


@settings(max_examples=60, deadline=None)
@given(st.integers(3, 400), st.integers(0, 2**32 - 1), st.booleans(), st.integers(1, 3))
def test_median_edge_from_the_triangles_alone_is_that_of_every_edge(n, seed, grid, workers):
    """edge_median (halfedges and the hull once more, no lengths array, in parts on threads) is np.median of
    every edge once."""
    from tinsmith.kernels.pointtin import edge_lengths
    from tinsmith.triangulation import pointtin
    from tinsmith.triangulation.strips import triangles_of, triangulate_unique

    rng = np.random.default_rng(seed)
    xy = rng.integers(0, 12, (n, 2)).astype(float) if grid else rng.uniform(0, 100, (n, 2))  # grids: ties
    if np.linalg.matrix_rank(xy - xy[0]) < 2:
        return
    m, _, _ = triangulate_unique(xy, 1)
    expected = np.median(edge_lengths(m))
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(pointtin, "PART_TRIANGLES", 4)  # parts of a few triangles, the first with the hull
        assert pointtin.edge_median(m[0], m[1], triangles_of(m), workers) == expected


@pytest.mark.parametrize("workers", [1, 2])
def test_lean_tin_is_the_mesh_of_the_full_triangulation(workers):
    """tin() (triangles alone, int32, in strips) makes the mesh build_point_tin(...).to_mesh() makes."""
    from tinsmith.triangulation.pointtin import build_point_tin, tin_mesh
    from tinsmith.triangulation.strips import STRIP_POINTS

    rng = np.random.default_rng(5)
    xy = rng.uniform(0, 1000, (3 * STRIP_POINTS, 2))
    xy = xy[np.hypot(*(xy - 500).T) > 60]  # a gap that max_edge opens, leaving some points outside
    xy = np.concatenate([xy, xy[:500], [[500.0, 500.0]]])  # duplicates, and a point alone in the gap
    xyz = np.column_stack([xy, rng.normal(size=len(xy))])
    for duplicates in ("lowest", "mean"):
        lean = tin_mesh(xyz, duplicates=duplicates, workers=workers)
        full = build_point_tin(xyz, duplicates=duplicates, workers=workers).to_mesh()
        assert lean.info["strips"] > 1 and lean.info["duplicates_merged"] == 500
        assert lean.info["points_outside"] >= 1 and lean.info == full.info
        assert lean.triangles.dtype == np.int32
        np.testing.assert_array_equal(lean.triangles, full.triangles)
        np.testing.assert_array_equal(lean.vertices, full.vertices)
    assert lean.check() == []


def test_an_int32_tin_goes_on_to_the_mesh_consumers():
    """tin() holds int32 triangles: decimation, the flood solver's border tags (edge keys past 2^31 with
    more than 46,341 vertices), the metrics and the writers take them as int64 ones."""
    from tinsmith.io.flood import border_tags

    rng = np.random.default_rng(7)
    xy = rng.uniform(0, 1000, (50_000, 2))
    mesh = tinsmith.tin(PointCloud(np.column_stack([xy, np.sin(xy[:, 0] / 50) * 10])), max_edge=None)
    wide = tinsmith.TerrainMesh(mesh.vertices, mesh.triangles.astype(np.int64))
    assert mesh.triangles.dtype == np.int32 and mesh.n_vertices > 46_341
    assert border_tags(mesh, triangles=mesh.triangles) == border_tags(wide, triangles=wide.triangles)
    small = tinsmith.tin(PointCloud(np.column_stack([xy[:3000], np.sin(xy[:3000, 0] / 50) * 10])))
    one, two = tinsmith.decimate(small, max_error=0.5), tinsmith.decimate(
        tinsmith.TerrainMesh(small.vertices, small.triangles.astype(np.int64)), max_error=0.5)
    np.testing.assert_array_equal(one.triangles, two.triangles)
    assert one.check() == []


def test_duplicates_rule_picks_the_height():
    xyz = np.array([[0, 0, 5.0], [0, 0, 1.0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 0, 3.0]])
    cloud = PointCloud(xyz)
    for rule, z in (("lowest", 1.0), ("highest", 5.0), ("mean", 3.0)):
        mesh = tinsmith.tin(cloud, duplicates=rule, max_edge=None)
        assert mesh.n_vertices == 4 and mesh.info["duplicates_merged"] == 2
        assert mesh.vertices[(mesh.vertices[:, :2] == 0).all(axis=1), 2][0] == z


def test_max_edge_opens_a_gap_and_keeps_sparse_patches():
    rng = np.random.default_rng(2)
    dense = rng.uniform(0, 100, (6000, 2))
    gap = (np.hypot(dense[:, 0] - 50, dense[:, 1] - 50) < 15)  # a lake: no points
    sparse = (dense[:, 0] > 80) & (rng.random(len(dense)) < 0.7)  # sparse ground under a canopy
    xy = dense[~gap & ~sparse]
    mesh = tinsmith.tin(PointCloud(np.column_stack([xy, np.zeros(len(xy))])))
    c = mesh.vertices[mesh.triangles].mean(axis=1)
    assert not (np.hypot(c[:, 0] - 50, c[:, 1] - 50) < 10).any()  # the lake is open
    a = mesh.vertices[mesh.triangles][:, :, :2]
    u, v = a[:, 1] - a[:, 0], a[:, 2] - a[:, 0]
    area = 0.5 * np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])
    in_sparse = c[:, 0] > 82
    assert area[in_sparse].sum() > 0.95 * 18 * 100  # the sparse strip stays covered


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 10_000), st.floats(0.01, 2.0))
def test_point_greedy_bound_holds_at_every_point(seed, bound):
    cloud = random_cloud(400, seed, lambda x, y: 3 * np.sin(x / 7) * np.cos(y / 11) + 0.01 * x * y)
    mesh = tinsmith.greedy(cloud, max_error=bound)
    pts = tinsmith.triangulation.pointtin.checked_points(cloud)
    z = independent_heights(mesh, pts[:, :2])
    inside = ~np.isnan(z)
    assert inside.mean() > 0.97
    assert np.abs(z[inside] - pts[inside, 2]).max() <= bound * (1 + 1e-9)
    ours = tinsmith.vertical_error_at_points(mesh, pts)
    assert ours["max"] <= bound


def test_point_greedy_stop_rules_and_levels():
    cloud = random_cloud(2000, 3, lambda x, y: np.hypot(x - 50, y - 50))
    mesh = tinsmith.greedy(cloud, max_vertices=200)
    assert mesh.n_vertices <= 200
    from tinsmith.algorithms.greedy.greedy_points import PointGreedyEngine
    from tinsmith.triangulation.pointtin import build_point_tin, prepare_points

    engine = PointGreedyEngine(build_point_tin(prepare_points(cloud)[0]))
    coarse, fine = engine.levels([2.0, 0.5])
    assert coarse.n_vertices < fine.n_vertices
    assert coarse.info["error"]["max"] <= 2.0 and fine.info["error"]["max"] <= 0.5
    again = tinsmith.greedy(cloud, max_error=0.5)
    assert np.array_equal(again.vertices, tinsmith.greedy(cloud, max_error=0.5).vertices)  # deterministic


@pytest.mark.parametrize("name", FOREST)
def test_forest_ground_tin_covers_the_concave_hull_and_holds_the_bound(name):
    shapely = pytest.importorskip("shapely")
    ground = tinsmith.read(shared(name), classes=[2])
    mesh = tinsmith.tin(ground)
    # an independent concave hull: GEOS's, with holes, at the same edge length
    xy = np.unique(ground.xyz[:, :2], axis=0)
    from scipy.spatial import Delaunay

    t = Delaunay(xy).simplices
    e = np.hypot(*(xy[t] - xy[t[:, [1, 2, 0]]]).transpose(2, 0, 1))
    lo, hi = e.min(), e.max()
    ratio = (mesh.info["max_edge"] - lo) / (hi - lo)
    hull = shapely.concave_hull(shapely.MultiPoint(xy), ratio=ratio, allow_holes=True)
    covered = shapely.union_all(shapely.polygons(mesh.vertices[mesh.triangles][:, :, :2]))
    assert covered.intersection(hull).area >= 0.99 * hull.area
    greedy = tinsmith.greedy(ground, max_error=0.1)
    pts = tinsmith.triangulation.pointtin.checked_points(ground)
    z = independent_heights(greedy, pts[:, :2])
    assert np.isnan(z).mean() < 0.01
    ok = ~np.isnan(z)
    assert np.abs(z[ok] - pts[ok, 2]).max() <= 0.1 + 1e-9


def test_flat_polygon_is_one_flat_constrained_surface():
    shapely = pytest.importorskip("shapely")
    cloud = random_cloud(4000, 4, lambda x, y: 0.05 * (x - 50) ** 2 / 10 + 0.1 * y)
    lake = shapely.Point(50, 50).buffer(12)
    mesh = tinsmith.greedy(cloud, max_error=0.05, flat=[lake])
    c = mesh.vertices[mesh.triangles].mean(axis=1)
    inside = shapely.contains_xy(lake.buffer(-0.5), c[:, 0], c[:, 1])
    z = mesh.vertices[mesh.triangles[inside]][:, :, 2]
    assert inside.sum() > 10 and np.ptp(z) == 0.0  # flat at one level
    hole = tinsmith.tin(cloud, holes=[lake])
    c = hole.vertices[hole.triangles].mean(axis=1)
    assert not shapely.contains_xy(lake, c[:, 0], c[:, 1]).any()


def test_a_flat_polygon_keeps_its_triangles_when_max_edge_keeps_none():
    """The outline's "no triangle kept" error is decided after flat polygons keep theirs."""
    r, c = np.mgrid[0:20, 0:20]
    xyz = np.column_stack([c.ravel(), r.ravel(), np.zeros(r.size)]).astype(float)
    lake = [[-1.0, -1.0], [20.0, -1.0], [20.0, 20.0], [-1.0, 20.0]]
    mesh = tinsmith.tin(PointCloud(xyz), max_edge=0.5, flat=[lake])
    assert mesh.n_triangles > 0 and mesh.check() == []
    with pytest.raises(NoDataError, match="max_edge"):
        tinsmith.tin(PointCloud(xyz), max_edge=0.5)


def test_breaklines_become_edges_3d_and_draped():
    cloud = random_cloud(3000, 5)
    line3 = np.array([[10.0, 10.0, 50.0], [90.0, 80.0, 60.0]])
    mesh = tinsmith.tin(cloud, breaklines=[line3])
    ends = [np.flatnonzero((np.abs(mesh.vertices - p) < 1e-9).all(axis=1)) for p in line3]
    assert all(len(e) == 1 for e in ends)  # the 3-D vertices keep their heights
    draped = tinsmith.greedy(cloud, max_error=0.01, breaklines=[line3[:, :2]])
    assert len(draped.constrained_edges) > 10  # densified at the point spacing
    assert np.allclose(draped.vertices[:, 2], 0.3 * draped.vertices[:, 0] + 0.1 * draped.vertices[:, 1])


@pytest.mark.parametrize(
    "cloud, options, error",
    [
        (PointCloud(np.column_stack([np.zeros(5), np.zeros(5), np.arange(5.0)])), {}, NoDataError),
        (PointCloud(np.column_stack([np.arange(5.0), np.arange(5.0), np.zeros(5)])), {}, InvalidInputError),
        (random_cloud(50), {"max_edge": -1}, OPTION_ERRORS),
        (random_cloud(50), {"max_edge": "big"}, OPTION_ERRORS),
        (random_cloud(50), {"duplicates": "first"}, OPTION_ERRORS),
        (random_cloud(50), {"holes": [np.array([[500, 500], [600, 500], [600, 600.0]])]}, InvalidInputError),
        (random_cloud(50), {"classes": [2]}, NoDataError),
    ],
)
def test_bad_point_input_gives_a_clear_error(cloud, options, error):
    with pytest.raises(error if isinstance(error, tuple) else (error,)) as info:
        tinsmith.tin(cloud, **options)
    assert "\n" not in str(info.value)


def run(*args):
    return subprocess.run([sys.executable, "-m", "tinsmith", *map(str, args)], capture_output=True, text=True)


def test_cli_simplify_meshes_several_clouds_and_refuses_mixed_crs(tmp_path):
    a, _ = shared("urban/delft_ahn3/ahn3_cropped_1.laz"), shared("urban/delft_ahn3/ahn3_cropped_2.laz")
    out = tmp_path / "ground.ply"
    done = run("simplify", a.parent / "ahn3_cropped_*.laz", "--classes", "2", "--max-error", "0.2", "-o", out)
    assert done.returncode == 0, done.stderr
    assert "2 files" in done.stdout and "points" in done.stdout
    metrics = run("metrics", out, a, "--classes", "2", "--json")
    assert metrics.returncode == 0, metrics.stderr
    mixed = run("simplify", shared(FOREST[0]), shared("urban/codem_ncalm/codem_pc.laz"), "-o", tmp_path / "x.ply")
    assert mixed.returncode == 1
    lines = mixed.stderr.strip().splitlines()
    assert len(lines) == 1 and "NAD83 / UTM zone 12N" in lines[0] and "WGS 84 / UTM zone 16N" in lines[0]
    assert not (tmp_path / "x.ply").exists()
    empty = run("simplify", shared(FOREST[0]), "--classes", "7", "-o", tmp_path / "y.ply")
    assert empty.returncode == 1 and len(empty.stderr.strip().splitlines()) == 1 and "class" in empty.stderr
    none = run("simplify", tmp_path / "nothing_*.laz", "-o", tmp_path / "z.ply")
    assert none.returncode == 1 and "no file matches" in none.stderr


def test_cli_flat_polygons_from_a_file_in_another_crs_are_reprojected(tmp_path):
    pytest.importorskip("pyogrio")
    import pyogrio
    import shapely
    from pyproj import Transformer

    src = shared(FOREST[1])
    water = tinsmith.read(src, classes=[9])
    lakes = shapely.union_all(shapely.buffer(shapely.points(water.xyz[:, :2]), 4.0)).buffer(-2.0)
    to_wgs = Transformer.from_crs(2949, 4326, always_xy=True)
    lakes_wgs = shapely.transform(lakes, lambda xy: np.column_stack(to_wgs.transform(xy[:, 0], xy[:, 1])))
    path = tmp_path / "lakes.geojson"
    pyogrio.write_dataframe(__import__("geopandas").GeoDataFrame(geometry=[lakes_wgs], crs=4326), path) \
        if _has("geopandas") else pyogrio.raw.write(path, geometry=np.array([shapely.to_wkb(lakes_wgs)], dtype=object),
                                                   field_data=[], fields=[], crs="EPSG:4326", driver="GeoJSON",
                                                   geometry_type="MultiPolygon")
    out = tmp_path / "g.ply"
    done = run("simplify", src, "--classes", "2", "--flat", path, "--max-error", "0.2", "-o", out)
    assert done.returncode == 0, done.stderr
    far = tmp_path / "far.geojson"
    pyogrio.raw.write(far, geometry=np.array([shapely.to_wkb(shapely.box(0, 0, 1, 1))], dtype=object), field_data=[],
                      fields=[], crs="EPSG:2949", driver="GeoJSON", geometry_type="Polygon")
    bad = run("simplify", src, "--classes", "2", "--flat", far, "-o", tmp_path / "h.ply")
    # wholly outside the cloud: one warning, the mesh without them (tinsmith.io.geometry)
    lines = bad.stderr.strip().splitlines()
    assert bad.returncode == 0 and len(lines) == 1 and "entirely outside" in lines[0], bad.stderr
    assert (tmp_path / "h.ply").exists()


def _has(module):
    try:
        __import__(module)
        return True
    except ImportError:
        return False


def test_tin_checks_memory_against_its_own_need(monkeypatch):
    """tin() without constraints asks for what its path takes, not for the full triangulation greedy starts from."""
    from tinsmith import resources
    from tinsmith.errors import ResourceError
    from tinsmith.triangulation import pointtin

    xy = np.random.default_rng(3).uniform(0, 100, (20_000, 2))
    cloud = PointCloud(np.column_stack([xy, 0.1 * xy[:, 0]]))
    need = pointtin.tin_mesh_bytes(len(xy), 1)
    assert need < pointtin.TIN_BYTES_PER_POINT * len(xy)
    monkeypatch.setattr(resources, "available_memory", lambda: int(need) + 1)
    assert tinsmith.tin(cloud, workers=1).n_vertices > 0
    with pytest.raises(ResourceError, match="the TIN of 20,000 points"):
        tinsmith.tin(cloud, workers=1, holes=[[(10, 10), (20, 10), (20, 20)]])  # the PointTin's path
    monkeypatch.setattr(resources, "available_memory", lambda: int(need) - 1)
    with pytest.raises(ResourceError, match="the TIN of 20,000 points needs about"):
        tinsmith.tin(cloud, workers=1)


PEAK_CHILD = r"""
import json, sys
import numpy as np
import tinsmith
from tinsmith.triangulation.pointtin import tin_mesh_bytes

def status(key):
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) * 1024 for line in f if line.startswith(key + ":"))

n, workers = int(sys.argv[1]), int(sys.argv[2])
xy = np.random.default_rng(7).uniform(0, 1000, (n, 2)).round(1)  # duplicates: the mesh copies its coordinates
cloud = tinsmith.PointCloud(np.column_stack([xy, np.sin(xy[:, 0] / 50)]))
tinsmith.tin(cloud, workers=workers)  # kernels loaded before measuring
with open("/proc/self/clear_refs", "w") as f:
    f.write("5")  # resets the peak resident size (VmHWM)
base = status("VmRSS")
mesh = tinsmith.tin(cloud, workers=workers)
print(json.dumps({"peak": status("VmHWM") - base, "bound": tin_mesh_bytes(n, workers),
                  "copied": mesh.vertices is not cloud.xyz}))
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads the peak resident size from /proc")
@pytest.mark.parametrize("n, workers", [(40_000, 2), (300_000, 1), (300_000, 2)])
def test_tin_memory_bound_covers_the_measured_peak(n, workers):
    import json

    done = subprocess.run([sys.executable, "-c", PEAK_CHILD, str(n), str(workers)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    run = json.loads(done.stdout.strip().splitlines()[-1])
    assert run["copied"] and 0 < run["peak"] <= run["bound"], run
