"""Urban surface models: thresholds, collapsed contouring, the building tree, the noise controller."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import tinsmith
from tinsmith import Heightfield, InvalidInputError
from tinsmith.algorithms.urban.urban import building_tree, urban_model, urban_thresholds
from tinsmith.kernels import contour as kc

from .bad_inputs import degrees_las
from .conftest import shared


def _rings(q):
    q = np.asarray(q, bool)
    labels, n = kc.label_squares(q, np.ones((q.shape[0] - 1, q.shape[1] - 1), bool))
    ring_label, start, xy, n_points = kc.trace(labels, n, np.zeros((labels.shape[0] + 1, labels.shape[1] + 1), bool))
    return [(int(ring_label[r]), xy[start[r]:start[r + 1]].tolist()) for r in range(len(ring_label))], n_points


def _area(ring):
    p = np.asarray(ring, float)
    return 0.5 * float(np.dot(p[:, 0], np.roll(p[:, 1], -1)) - np.dot(np.roll(p[:, 0], -1), p[:, 1]))


def test_thresholds_follow_the_documented_rule_on_known_statistics():
    # 1000 heights: mean 10, sample standard deviation 2, from -? to ?: built exactly
    rng = np.random.default_rng(0)
    z = rng.normal(size=1000)
    z = (z - z.mean()) / z.std(ddof=1) * 2.0 + 10.0
    t = urban_thresholds(z, 4)
    np.testing.assert_allclose(t[1:-1], [8.5, 9.5, 10.5, 11.5])  # centres of four slices of [8, 12]
    assert t[0] == z.min() and t[-1] == z.max()
    np.testing.assert_allclose(urban_thresholds(z, 1)[1:-1], [10.0])
    # a centre outside the range of the heights is left out (a skewed distribution)
    skewed = np.r_[np.zeros(90), np.full(10, 30.0)]
    assert (np.diff(urban_thresholds(skewed, 8)) > 0).all() and urban_thresholds(skewed, 8)[0] == 0.0
    with pytest.raises(InvalidInputError, match="do not vary"):
        urban_thresholds(np.full(50, 3.0), 4)
    with pytest.raises(InvalidInputError, match="lod"):
        urban_thresholds(z, 0)


def test_the_thesis_example_contour_of_25_points_compresses_to_its_4_corners():
    # the Salt Lake City thesis, figures 4.3 to 4.5: an 11 x 7 grid, a 9 x 5 block of qualifying points from point 12
    q = np.zeros((7, 11), bool)
    q[1:6, 1:10] = True
    rings, n_points = _rings(q)
    assert rings == [(1, [[1, 1], [9, 1], [9, 5], [1, 5]])]  # points 12, 20, 64, 56
    assert n_points[1] == 45


def test_outlines_run_through_grid_points_with_holes_and_corner_touches():
    # an L, a block with a courtyard, and two squares that meet at a corner only
    q = np.zeros((12, 16), bool)
    q[1:6, 1:3] = True
    q[4:6, 1:6] = True  # L: vertical bar and foot
    q[1:8, 8:15] = True
    q[3:5, 10:13] = False  # courtyard: 2 x 3 points out
    q[9:11, 1:3] = True
    q[10:12, 2:4] = True  # touches the block above-left at one point, through squares (9,1) and (10,2)
    rings, n_points = _rings(q)
    by_label = {}
    for label, ring in rings:
        by_label.setdefault(label, []).append(ring)
    l_shape = by_label[1]
    assert len(l_shape) == 1 and len(l_shape[0]) == 6  # an L has six corners
    courtyard = by_label[2]
    assert len(courtyard) == 2
    outer, hole = sorted(courtyard, key=_area, reverse=True)
    assert _area(outer) > 0 > _area(hole)  # opposite windings
    assert sorted(map(tuple, hole)) == [(9, 2), (9, 5), (13, 2), (13, 5)]  # through the courtyard's edge points
    assert len(by_label) == 4  # the two corner-touching squares are regions of their own
    for rings_of in by_label.values():
        for ring in rings_of:
            p = np.asarray(ring + ring[:1])
            steps = np.diff(p, axis=0)
            assert ((steps == 0).sum(axis=1) == 1).all()  # N/S/E/W moves only
            assert (np.sign(steps[1:]) != np.sign(steps[:-1])).any(axis=1).all()  # corners only


@settings(max_examples=80, deadline=None)
@given(arrays(bool, st.tuples(st.integers(2, 14), st.integers(2, 14))))
def test_traced_rings_enclose_exactly_the_qualifying_squares(q):
    labels, n = kc.label_squares(q, np.ones((q.shape[0] - 1, q.shape[1] - 1), bool))
    ring_label, start, xy, n_points = kc.trace(labels, n, np.zeros((labels.shape[0] + 1, labels.shape[1] + 1), bool))
    for lab in range(1, n + 1):
        area = sum(_area(xy[start[r]:start[r + 1]]) for r in range(len(ring_label)) if ring_label[r] == lab)
        assert area == pytest.approx(np.count_nonzero(labels == lab))  # outer minus holes = its squares
        corners = np.zeros(q.shape, bool)
        ii, jj = np.nonzero(labels == lab)
        for di in (0, 1):
            for dj in (0, 1):
                corners[ii + di, jj + dj] = True
        assert n_points[lab] == corners.sum() and q[corners].all()


def _city():
    z = np.zeros((60, 80))
    z[10:30, 10:40] = 12.0  # building A, 20 x 30 points
    z[15:25, 15:25] = 20.0  # a tower on A
    z[40:55, 50:75] = 8.0  # building B with a courtyard
    z[45:50, 58:66] = 0.0
    z[3:6, 70:73] = 15.0  # a lamp post: 9 points
    return Heightfield(z, cell_size=0.5)


def test_the_tree_nests_regions_and_leaves_are_roof_tops():
    tree = building_tree(_city(), lod=4, noise_factor=10)
    (root,) = tree.roots
    assert root.level == 0 and root.area == pytest.approx(59 * 79 * 0.25)
    leaves = sorted(tree.leaves(), key=lambda r: r.height)
    assert [r.height for r in leaves] == [8.0, 20.0]  # B and the tower on A; the lamp post is noise
    tower = leaves[1]
    assert tower.area == pytest.approx(9 * 9 * 0.25) and tower.n_points == 100 and tower.width == pytest.approx(4.5, rel=0.2)
    chain = [tower]
    while chain[-1].parent is not None:
        chain.append(tree.regions[chain[-1].parent])
    assert chain[-1] is root and [r.level for r in chain] == sorted([r.level for r in chain], reverse=True)
    a = next(r for r in chain if r.height == 12.0)
    assert a.area == pytest.approx(19 * 29 * 0.25)
    court = leaves[0]
    assert len(court.holes) == 1 and court.area == pytest.approx((14 * 24 - 6 * 9) * 0.25)
    for region in tree.regions:  # world rings: outlines counter-clockwise, holes clockwise
        assert _area(region.outline) > 0 and all(_area(h) < 0 for h in region.holes)
    assert tree.dropped["noise_factor"] >= 1


def test_the_noise_controller_by_count_area_and_width():
    hf = _city()
    keep_all = building_tree(hf, lod=4, noise_factor=0)
    assert any(r.n_points == 9 for r in keep_all.leaves())  # the lamp post
    by_area = building_tree(hf, lod=4, noise_factor=0, min_area=2.0)
    assert not any(r.n_points == 9 for r in by_area.regions) and by_area.dropped["min_area"] >= 1
    # a row of trees: 3 points wide, 60 long; min_width 2 m (4 cells) removes it, the buildings stay
    z = hf.z.copy()
    z[35:38, 5:65] = 9.0
    trees = Heightfield(z, cell_size=0.5)
    with_row = building_tree(trees, lod=4, noise_factor=10)
    without = building_tree(trees, lod=4, noise_factor=10, min_width=2.0)
    assert len(without.regions) < len(with_row.regions) and without.dropped["min_width"] >= 1
    assert sorted(r.height for r in without.leaves()) == [8.0, 20.0]
    with pytest.raises(InvalidInputError, match="noise_factor"):
        building_tree(hf, noise_factor=-1)


def test_a_flat_or_empty_surface_model_is_refused_clearly():
    with pytest.raises(InvalidInputError, match="do not vary"):
        building_tree(Heightfield(np.full((10, 10), 4.0), cell_size=1.0))
    with pytest.raises(tinsmith.NoDataError):
        Heightfield(np.full((10, 10), np.nan), cell_size=1.0, nodata=float("nan"))


@pytest.mark.slow
def test_delft_surface_model_gives_a_tree_of_its_buildings():
    hf = tinsmith.read_heightfield(shared("urban/delft_ahn3/delft_dsm_0.5m.tif"))
    tree = building_tree(hf, lod=4, noise_factor=10)
    assert len(tree.roots) == 1 and len(tree.leaves()) > 50
    for region in tree.regions:
        assert region.n_points >= 10 or region.level == 0
        if region.parent is not None:
            parent = tree.regions[region.parent]
            assert parent.level < region.level and region.area <= parent.area


def _boxes_on_a_slope():
    """Four 8 m boxes (20 x 20 points of 1 m) on ground rising 60 m across the grid."""
    r, c = np.mgrid[0:100, 0:200]
    ground = 0.3 * c + 0.0 * r
    z = ground.copy()
    for c0 in (10, 60, 110, 160):
        z[40:60, c0:c0 + 20] += 8.0
    return Heightfield(z, cell_size=1.0), Heightfield(ground, cell_size=1.0)


def test_the_opening_recovers_a_tilted_ground_exactly():
    from tinsmith.algorithms.urban.urban import estimate_ground

    hf, truth = _boxes_on_a_slope()
    ground = estimate_ground(hf, window=30.0)
    np.testing.assert_allclose(ground.z, truth.z, atol=1e-9)
    holed = Heightfield(np.where(np.arange(200) % 50 == 7, np.nan, hf.z), cell_size=1.0, nodata=float("nan"))
    g = estimate_ground(holed, window=30.0)
    assert np.isnan(g.z[:, 7]).all() and np.isfinite(g.z[:, 8]).all()


def test_boxes_on_a_slope_need_heights_above_the_ground():
    hf, truth = _boxes_on_a_slope()
    for tree in (
        building_tree(hf, lod=4, noise_factor=10, relative_to_ground=True, ground_window=30.0),
        building_tree(hf, lod=4, noise_factor=10, relative_to_ground=True, ground=truth),
    ):
        tops = [r for r in tree.leaves() if r.level > 0]
        assert len(tops) == 4  # the four boxes, one region each, nothing else
        assert sorted(round(r.area) for r in tops) == [361] * 4
    # the documented failure of absolute thresholds (the thesis' limitation 5): they slice the slope,
    # so the leaves are strips of uphill ground, and the boxes downhill are never told apart
    absolute = building_tree(hf, lod=4, noise_factor=10)
    leaves = [r for r in absolute.leaves() if r.level > 0]
    assert sorted(round(r.area) for r in leaves) != [361] * 4
    assert max(r.area for r in absolute.regions if r.level > 0) > 1000  # ground strips, not boxes
    with pytest.raises(InvalidInputError, match="same shape and transform"):
        building_tree(hf, relative_to_ground=True, ground=Heightfield(truth.z[:50], cell_size=1.0))
    with pytest.raises(InvalidInputError, match="only with relative_to_ground"):
        building_tree(hf, ground=truth)


def _check_block_model(mesh, hf):
    from tinsmith.metrics import surface_problems

    problems = surface_problems(mesh)
    assert {k: v for k, v in problems.items() if k != "border"} == {"degenerate": 0, "duplicate": 0, "overused": 0,
                                                                     "misoriented": 0}
    # the border is the outline of the data, nothing else
    t = mesh.triangles
    e = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    u, c = np.unique(e, axis=0, return_counts=True)
    rows, cols = hf.world_to_pixel(mesh.vertices[:, 0], mesh.vertices[:, 1])
    rows, cols = np.round(rows), np.round(cols)
    border = u[c == 1]
    h, w = hf.shape
    on_edge = lambda i: (rows[i] == 0) | (rows[i] == h - 1) | (cols[i] == 0) | (cols[i] == w - 1)  # noqa: E731
    assert on_edge(border[:, 0]).all() and on_edge(border[:, 1]).all()
    # faces up or walls vertical: no triangle faces down
    v = mesh.vertices[t]
    normal = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    assert (normal[:, 2] > -1e-9 * np.abs(normal).max()).all()
    walls = np.abs(normal[:, 2]) < 1e-12 * np.linalg.norm(normal, axis=1)
    return walls, normal


def test_the_block_model_is_one_crack_free_surface_with_walls_facing_out():
    from tinsmith.algorithms.urban.blocks import block_model
    from tinsmith.algorithms.urban.urban import estimate_ground

    hf = _city()
    tree = building_tree(hf, lod=4, noise_factor=10)
    mesh = block_model(hf, tree, estimate_ground(hf, window=20.0))
    walls, normal = _check_block_model(mesh, hf)
    assert sorted(np.unique(mesh.vertices[:, 2])) == [0.0, 8.0, 12.0, 20.0]
    # every wall faces away from the block it bounds: the higher side is behind it
    v = mesh.vertices[mesh.triangles[walls]]
    centre = v.mean(axis=1)
    outward = normal[walls][:, :2] / np.linalg.norm(normal[walls][:, :2], axis=1)[:, None]
    r, c = hf.world_to_pixel(*(centre[:, :2] + 0.5 * outward).T)  # one cell out: lower than the wall top
    out_z = hf.z[np.clip(np.round(r).astype(int), 0, 59), np.clip(np.round(c).astype(int), 0, 79)]
    assert (out_z < v[:, :, 2].max(axis=1)).all()
    r, c = hf.world_to_pixel(*(centre[:, :2] - 0.25 * outward).T)  # behind the wall: the block itself
    assert (hf.z[np.round(r).astype(int), np.round(c).astype(int)] == v[:, :, 2].max(axis=1)).all()
    assert walls.sum() > 0 and len(mesh.boundary_edges()) > 0


def test_block_models_of_boxes_on_a_slope_and_of_delft_are_valid():
    from tinsmith.algorithms.urban.blocks import block_model
    from tinsmith.algorithms.urban.urban import estimate_ground

    hf, truth = _boxes_on_a_slope()
    tree = building_tree(hf, lod=4, noise_factor=10, relative_to_ground=True, ground=truth)
    mesh = block_model(hf, tree, truth)
    _check_block_model(mesh, hf)
    dsm = tinsmith.read_heightfield(shared("urban/delft_ahn3/delft_dsm_0.5m.tif"))
    tree = building_tree(dsm, lod=4, noise_factor=10)
    mesh = block_model(dsm, tree, estimate_ground(dsm))
    _check_block_model(mesh, dsm)
    assert mesh.n_vertices < dsm.n_valid / 2


def test_urban_returns_tree_block_model_and_statistics_and_the_command_writes_them(tmp_path, capsys):
    import json

    from tinsmith.cli.main import main

    hf = _city()
    model = urban_model(hf, lod=4, noise_factor=10, ground_window=20.0)
    st = model.stats
    assert st["n_buildings"] == 2 and st["n_leaves"] == 2 and st["n_vertices"] == model.mesh.n_vertices
    assert st["points_kept"] == pytest.approx(model.mesh.n_vertices / hf.n_valid)
    assert model.mesh.info["method"] == "urban"
    mesh = tinsmith.blocks(hf, lod=4, noise_factor=10, ground_window=20.0)  # the method: the same mesh
    np.testing.assert_array_equal(mesh.triangles, model.mesh.triangles)
    assert mesh.info["method"] == "blocks" and mesh.info["urban"] == st
    with pytest.warns(DeprecationWarning, match="tinsmith.urban is deprecated .* tinsmith.blocks") as caught:
        old = tinsmith.urban(hf, lod=4, noise_factor=10, ground_window=20.0)
    assert caught[0].filename == __file__ and old.stats == st
    dsm = tmp_path / "city.tif"
    hf_crs = Heightfield(hf.z, cell_size=0.5, origin=(85000.0, 447500.0), crs="EPSG:28992")
    tinsmith.write(tinsmith.grid(hf_crs), dsm, grid=hf_crs)  # the full-resolution mesh re-rasterised: the DSM itself
    out, buildings = tmp_path / "city.ply", tmp_path / "b.geojson"
    args = ["city", str(dsm), "-o", str(out), "--buildings", str(buildings), "--ground-window", "20", "--json",
            "--roofs", "levels"]
    assert main(args) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["n_buildings"] == 2 and tinsmith.read_mesh(out).n_triangles == report["n_triangles"]
    features = json.loads(buildings.read_text())["features"]
    assert len(features) == report["n_regions"]
    tower = max(features, key=lambda f: f["properties"]["height"] or -np.inf)  # null: a region with no own squares
    assert tower["properties"]["height"] == 20.0 and tower["properties"]["parent"] >= 0
    assert "28992" in json.dumps(json.loads(buildings.read_text()).get("crs"))
    # bad input: one line, exit 1, nothing written
    bad = tmp_path / "bad.ply"
    assert main(["city", str(dsm), "-o", str(bad), "--roofs", "levels", "--lod", "0"]) == 1
    assert "lod must be" in capsys.readouterr().err and not bad.exists()
    assert main(["city", str(dsm), "-o", str(bad), "--roofs", "levels", "--noise-factor", "-2"]) == 1
    assert "noise_factor" in capsys.readouterr().err and not bad.exists()
    assert main(["city", str(dsm), "-o", str(bad), "--buildings", str(tmp_path / "b.shp")]) != 0
    assert not bad.exists()
    # the default city model: the tower, 8 m above A, is a building of its own
    assert main(["city", str(dsm), "-o", str(out), "--ground-window", "20", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["n_buildings"] == 3


def test_simplified_outlines_turn_staircases_into_diagonals_and_stay_crack_free():
    from tinsmith.algorithms.urban.blocks import _douglas_peucker

    r, c = np.mgrid[0:80, 0:80]
    z = np.where(np.hypot(r - 40, c - 40) < 25, 15.0, 0.0)  # a round tower
    band = np.abs((r - 20) - (c - 10)) < 4
    z[band] = np.maximum(z[band], 6.0)  # and a diagonal wing through it
    hf = Heightfield(z, cell_size=1.0)
    plain = tinsmith.blocks(hf, ground_window=60.0)
    meshes = [tinsmith.blocks(hf, ground_window=60.0, simplify_tolerance=t) for t in (0.75, 1.5)]
    counts = [plain.n_vertices] + [m.n_vertices for m in meshes]
    assert counts[0] > counts[1] > counts[2]
    for mesh in meshes:
        walls, _ = _check_block_model(mesh, hf)
        v = mesh.vertices[mesh.triangles[walls]]
        d = v[:, :, :2].max(axis=1) - v[:, :, :2].min(axis=1)
        assert ((d[:, 0] > 0) & (d[:, 1] > 0)).any()  # diagonal walls
    # the same points kept whichever way a chain is walked
    pts = np.array([[0, 0], [1, 0], [1, 1], [2, 1], [2, 2], [3, 2], [3, 3], [4, 3]])
    for tol in (0.1, 0.8, 2.0):
        assert (_douglas_peucker(pts, tol) == _douglas_peucker(pts[::-1], tol)[::-1]).all()
    with pytest.raises(InvalidInputError, match="simplify_tolerance"):
        tinsmith.blocks(hf, simplify_tolerance=-1.0)


def test_footprint_metrics_on_known_shapes():
    shapely = pytest.importorskip("shapely")
    from tinsmith.metrics import footprint_iou, polygon_mask, raised_footprint, rmse_over

    a, b = shapely.box(0, 0, 10, 10), shapely.box(5, 0, 15, 10)
    out = footprint_iou([a], [b])
    assert out["iou"] == pytest.approx(50 / 150) and out["intersection"] == pytest.approx(50)
    assert footprint_iou([a], [b], within=shapely.box(5, 0, 10, 10))["iou"] == pytest.approx(1.0)
    hf = _city()  # 0.5 m cells, origin (0, 30): building A is rows 10..29, cols 10..39
    mask = polygon_mask([shapely.box(5.0, 15.0, 20.0, 25.0)], hf)
    assert mask.sum() == 30 * 20 and mask[10, 10] and not mask[9, 10]
    flat = Heightfield(np.zeros(hf.shape), cell_size=0.5)
    grid = tinsmith.grid(hf)
    fp = raised_footprint(grid, hf, flat, 10.0)  # cells above 10 m: A (12 m, with its tower) and the lamp post
    assert sum(p.area for p in fp) == pytest.approx((20 * 30 + 9) * 0.25)
    assert rmse_over(grid, hf, np.ones(hf.shape, bool)) == 0.0


def test_delft_block_model_meets_the_reference_outlines():
    shapely = pytest.importorskip("shapely")
    from tinsmith.io.vector import read_polygons
    from tinsmith.metrics import footprint_iou

    hf = tinsmith.read_heightfield(shared("urban/delft_ahn3/delft_dsm_0.5m.tif"))
    reference, crs = read_polygons(shared("vector/delft_bgt/bgt_pand.sqlite"))
    assert len(reference) == 160 and "28992" in crs
    model = urban_model(hf, lod=4, noise_factor=10, min_width=3.0, relative_to_ground=True)
    outlines = [shapely.Polygon(r.outline, r.holes) for r in model.tree.regions if r.level == 1]
    hull = shapely.union_all(reference).convex_hull
    assert footprint_iou(outlines, reference, within=hull)["iou"] > 0.75
    model = urban_model(hf, lod=4, noise_factor=10, max_roughness=0.3)  # the thesis setting, tree crowns dropped
    outlines = [shapely.Polygon(r.outline, r.holes) for r in model.tree.regions if r.level == 1]
    assert footprint_iou(outlines, reference, within=hull)["iou"] > 0.75


def test_buildings_are_matched_one_by_one_with_their_oriented_boxes():
    shapely = pytest.importorskip("shapely")
    from shapely import affinity

    from tinsmith.metrics import match_buildings

    ref = [affinity.rotate(shapely.box(0, 0, 20, 8), 30, origin=(0, 0)), shapely.box(50, 50, 60, 60)]
    found = [affinity.rotate(shapely.box(0.5, 0, 20.5, 9), 30, origin=(0, 0)), shapely.box(100, 100, 101, 101)]
    out = match_buildings(found, ref)
    first, second = out["per_building"]
    assert first["iou"] == pytest.approx(156 / 184) and second["iou"] == 0.0  # 19.5 x 8 shared
    assert first["length"] == pytest.approx(20.0) and first["width"] == pytest.approx(9.0)
    assert first["ref_length"] == pytest.approx(20.0) and first["ref_width"] == pytest.approx(8.0)
    assert out["matched"] == 0.5 and out["width_error"] == pytest.approx(1.0) and out["length_error"] == pytest.approx(0.0)


def test_cityjson_has_the_terrain_and_every_building_with_roofs_and_walls(tmp_path):
    import json

    hf = Heightfield(_city().z, cell_size=0.5, origin=(85000.0, 447500.0), crs="EPSG:28992")
    mesh = tinsmith.blocks(hf, ground_window=20.0)
    path = tmp_path / "city.json"
    tinsmith.write(mesh, path)
    doc = json.loads(path.read_text())
    assert doc["type"] == "CityJSON" and doc["version"] == "2.0"
    assert doc["metadata"]["referenceSystem"].endswith("/EPSG/0/28992")
    objects = doc["CityObjects"]
    buildings = {k: o for k, o in objects.items() if o["type"] == "Building"}
    assert len(buildings) == mesh.info["urban"]["n_buildings"] == 2
    n_vertices = len(doc["vertices"])
    kinds = mesh.triangle_attributes["kind"]
    total = 0
    for o in buildings.values():
        (geom,) = o["geometry"]
        assert geom["type"] == "MultiSurface" and geom["lod"] == "1"
        assert len(geom["semantics"]["values"]) == len(geom["boundaries"])
        assert {0, 1} == set(geom["semantics"]["values"])  # roofs and walls
        total += len(geom["boundaries"])
    terrain = objects["terrain"]["geometry"][0]["boundaries"]
    assert len(terrain) == int((kinds == 0).sum()) and total + len(terrain) == mesh.n_triangles
    flat = [i for surface in terrain for ring in surface for i in ring]
    assert min(flat) >= 0 and max(flat) < n_vertices
    # coordinates back within a millimetre
    scale, translate = doc["transform"]["scale"], doc["transform"]["translate"]
    back = np.array(doc["vertices"]) * scale + translate
    assert np.abs(back - mesh.vertices).max() <= 0.0005 + 1e-9
    # any other mesh: one TINRelief
    tinsmith.write(tinsmith.grid(hf), tmp_path / "tin.json")
    tin = json.loads((tmp_path / "tin.json").read_text())["CityObjects"]
    assert list(tin) == ["terrain"] and tin["terrain"]["type"] == "TINRelief"


def test_the_ground_between_buildings_follows_the_terrain_with_ground_error():
    from tinsmith.metrics import rmse_over

    r, c = np.mgrid[0:100, 0:160]
    hill = 20 * np.exp(-((r - 50) ** 2 + (c - 80) ** 2) / 900.0)
    z = hill.copy()
    open_ground = np.ones(z.shape, bool)
    for c0 in (20, 110):
        z[40:60, c0:c0 + 20] += 8.0
        open_ground[40:60, c0:c0 + 20] = False
    hf, ground = Heightfield(z, cell_size=1.0), Heightfield(hill, cell_size=1.0)
    coarse = tinsmith.blocks(hf, relative_to_ground=True, ground=ground)
    fine = tinsmith.blocks(hf, relative_to_ground=True, ground=ground, ground_error=0.25)
    _check_block_model(fine, hf)
    assert rmse_over(fine, hf, open_ground) < 0.25 < 1.0 < rmse_over(coarse, hf, open_ground)
    assert fine.n_vertices < 2 * coarse.n_vertices
    with pytest.raises(InvalidInputError, match="ground_error"):
        tinsmith.blocks(hf, ground_error=-1.0)


def test_rough_tree_crowns_are_dropped_and_roofs_kept_with_max_roughness():
    from tinsmith.algorithms.urban.urban import roughness

    rng = np.random.default_rng(5)
    r, c = np.mgrid[0:80, 0:120]
    z = np.zeros((80, 120))
    z[10:40, 10:50] = 6.0 + 0.4 * np.minimum(r[10:40, 10:50] - 10, 39 - r[10:40, 10:50])  # a gabled roof: two planes
    crown = np.hypot(r - 55, c - 90) < 12
    z[crown] = 8.0 + rng.normal(0.0, 1.0, crown.sum())  # a tree: rough
    hf = Heightfield(z, cell_size=0.5)
    rough = roughness(hf)
    assert np.median(rough[12:37, 12:47]) == pytest.approx(0.0, abs=1e-12)  # planes are smooth, ridge or not
    assert np.median(rough[48:62, 83:97]) > 0.4
    keep_all = building_tree(hf, lod=4, noise_factor=10)
    smooth_only = building_tree(hf, lod=4, noise_factor=10, max_roughness=0.3)
    centre = lambda reg: reg.outline.mean(axis=0)  # noqa: E731
    assert any(np.hypot(*(centre(reg) - [45.25, 12.25])) < 4 for reg in keep_all.at_level(1))  # the tree, world (x, y)
    kept = smooth_only.at_level(1)
    assert len(kept) == 1 and smooth_only.dropped["max_roughness"] >= 1
    assert kept[0].area == pytest.approx(29 * 39 * 0.25)


def test_block_models_stay_manifold_on_hills_and_around_nodata():
    from tinsmith.metrics import surface_problems

    # a low box cut into a steep slope: uphill, the ground is higher than its roof
    r, c = np.mgrid[0:60, 0:60]
    slope = 2.0 * c
    z = slope.copy()
    z[20:40, 20:40] = 45.0  # the roof: below the ground uphill (c > 22), above it downhill
    hf = Heightfield(z, cell_size=1.0)
    mesh = tinsmith.blocks(hf, relative_to_ground=True, ground=Heightfield(slope, cell_size=1.0))
    problems = surface_problems(mesh)
    assert (problems["overused"], problems["misoriented"], problems["degenerate"]) == (0, 0, 0)
    dsm = tinsmith.read_heightfield(shared("urban/codem_ncalm/codem_dsm_1m.tif"))  # hilly, 3% nodata
    for options in ({}, {"simplify_tolerance": 1.0, "max_roughness": 0.3, "ground_error": 0.5}):
        problems = surface_problems(tinsmith.blocks(dsm, **options))
        assert (problems["overused"], problems["misoriented"], problems["degenerate"]) == (0, 0, 0)


def test_block_model_of_a_survey_with_nodata_cells():
    """A DSM gridded from a survey has cells without data (a canal): the walls there still close (was an IndexError)."""
    from tinsmith.io.points import read_clouds
    from tinsmith.metrics import surface_problems

    path = shared("urban/delft_ahn3/ahn3_cropped_2.laz")
    hf = read_clouds([path]).to_heightfield(0.5, statistic="max")
    assert hf.n_valid < hf.n_cells
    mesh = tinsmith.blocks(hf)
    problems = surface_problems(mesh)
    assert mesh.info["urban"]["n_buildings"] > 0
    assert problems["overused"] == 0 and problems["misoriented"] == 0 and problems["degenerate"] == 0


# -- a surface model in degrees (issue 42) -------------------------------------------------------
def _geographic_dsm(path=None):
    """A 20 x 24 DSM in EPSG:4326 near Berlin (cells of 0.0001 degrees): the ground window of 60 is 600,000 cells."""
    z = np.full((20, 24), 35.0)
    z[6:12, 8:16] = 50.0
    transform = (0.0001, 0.0, 13.4, 0.0, -0.0001, 52.5)
    if path is None:
        return Heightfield(z, transform=transform, crs="EPSG:4326")
    import rasterio
    from rasterio.transform import Affine

    with rasterio.open(path, "w", driver="GTiff", width=24, height=20, count=1, dtype="float32", crs="EPSG:4326",
                       transform=Affine(*transform)) as ds:
        ds.write(z.astype(np.float32), 1)
    return path


def _assert_refused_in_one_line(message):
    assert "EPSG:4326 (WGS 84) is geographic" in message
    assert "600,000 cells" in message and "EPSG:32633" in message  # UTM zone 33N, where the data lies
    assert "\n" not in message


@pytest.mark.parametrize("call", [
    lambda hf: tinsmith.blocks(hf),
    lambda hf: tinsmith.city(hf),
    lambda hf: tinsmith.city(hf, ground=hf),
    lambda hf: __import__("tinsmith.algorithms.urban.urban", fromlist=["x"]).estimate_ground(hf),
], ids=["blocks", "city", "city-with-ground", "estimate_ground"])
def test_a_geographic_dsm_is_refused_before_anything_is_allocated(call):
    with pytest.raises(InvalidInputError) as info:
        call(_geographic_dsm())
    _assert_refused_in_one_line(str(info.value))


def test_a_geographic_dsm_is_refused_by_the_tiled_run(tmp_path):
    from tinsmith.tiles.city import city_tiles

    with pytest.raises(InvalidInputError) as info:
        city_tiles(_geographic_dsm(tmp_path / "geo.tif"), tile_size=64, workers=1)
    _assert_refused_in_one_line(str(info.value))


def test_the_urban_command_refuses_a_geographic_dsm_or_cloud_in_one_line(tmp_path, capsys):
    pytest.importorskip("laspy")
    from tinsmith.cli.main import main

    dsm = _geographic_dsm(tmp_path / "geo.tif")
    rng = np.random.default_rng(0)
    cloud = degrees_las(tmp_path / "geo.las", 13.4 + rng.uniform(0, 0.002, 300), 52.498 + rng.uniform(0, 0.002, 300),
                        rng.uniform(30, 50, 300))
    out = tmp_path / "out"
    out.mkdir()
    for args in ([dsm], [dsm, "--roofs", "levels"], [dsm, "--tile-size", "64", "--workers", "1"], [cloud],
                 [dsm, "--ground", dsm, "--solid"]):
        code = main(["city", *map(str, args), "-o", str(out / "city.ply")])
        err = capsys.readouterr().err
        lines = err.strip().splitlines()
        assert code == 1 and len(lines) == 1 and lines[0].startswith("tinsmith: error:"), err
        assert "is geographic" in lines[0] and "EPSG:32633" in lines[0] and str(args[0].name) in lines[0]
    assert list(out.iterdir()) == []
