"""City models (tinsmith.city and ``tinsmith city``): trees out, one building per building, straight outlines,
flat and planar roofs, and a watertight solid, on synthetic cities with known answers and on Delft."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import tinsmith
from tinsmith import Heightfield
from tinsmith.algorithms.urban.buildings import building_cells, class_shares, split_buildings
from tinsmith.algorithms.urban.regularize import regularize
from tinsmith.cli.main import main
from tinsmith.errors import InvalidInputError
from tinsmith.metrics import self_intersections, surface_problems

from .conftest import shared

shapely = pytest.importorskip("shapely")
trimesh = pytest.importorskip("trimesh")

DELFT_DSM = "urban/delft_ahn3/delft_dsm_0.5m.tif"
DELFT_DTM = "urban/delft_ahn3/delft_dtm_0.5m.tif"
BGT = "vector/delft_bgt/bgt_pand.sqlite"
CELL = 0.5


def _rotated_box(cx, cy, length, width, angle):
    box = shapely.box(-length / 2, -width / 2, length / 2, width / 2)
    return shapely.affinity.translate(shapely.affinity.rotate(box, angle, origin=(0, 0)), cx, cy)


def synthetic_city(seed: int = 0, *, tree: bool = True, slope: float = 0.02):
    """A 100 m x 80 m DSM at 0.5 m on a sloping ground: buildings (two touching at different heights, one rotated
    30 degrees with a gable roof) and, optionally, a tree crown touching a house.  Returns (dsm, dtm, truth)
    where truth is a list of (polygon, roof function (x, y) -> z)."""
    rng = np.random.default_rng(seed)
    h, w = 160, 200
    rows, cols = np.mgrid[0:h, 0:w]
    x, y = (cols + 0.5) * CELL, 80.0 - (rows + 0.5) * CELL
    ground = 10.0 + slope * x + 0.01 * y
    truth = [
        (shapely.box(10, 10, 30, 25), lambda x, y: np.full_like(x, 19.0)),
        (shapely.box(30, 10, 42, 25), lambda x, y: np.full_like(x, 24.0)),  # touches the first, 5 m higher
        (_rotated_box(70, 50, 24, 12, 30.0), None),  # a gable roof, ridge along its length
        (shapely.box(15, 45, 35, 65), lambda x, y: 21.0 + 0.3 * (x - 15)),  # a mono-pitch roof
    ]
    # the gable: height falls off from the ridge line
    c, s = np.cos(np.radians(30)), np.sin(np.radians(30))
    truth[2] = (truth[2][0], lambda x, y: 26.0 - 0.8 * np.abs(-(x - 70) * s + (y - 50) * c))
    z = ground.copy()
    pts = shapely.points(x.ravel(), y.ravel())
    for poly, roof in truth:
        inside = shapely.contains(poly, pts).reshape(h, w)
        z[inside] = roof(x[inside], y[inside])
    if tree:  # a round crown of 6 m radius leaning on the first house, bumpy like a real one
        d = np.hypot(x - 8.0, y - 30.0)
        crown = 10.0 + 9.0 * np.sqrt(np.clip(1 - (d / 6.0) ** 2, 0, None)) + rng.normal(0, 0.4, d.shape)
        z = np.where(d < 6.0, np.maximum(z, crown), z)
    z += rng.normal(0, 0.02, z.shape)
    dsm = Heightfield(z, cell_size=CELL, origin=(0.0, 80.0), crs="EPSG:28992")
    dtm = Heightfield(ground, cell_size=CELL, origin=(0.0, 80.0), crs="EPSG:28992")
    return dsm, dtm, truth


def _iou(a, b) -> float:
    return a.intersection(b).area / a.union(b).area


def _check_solid(mesh):
    problems = surface_problems(mesh)
    assert all(v == 0 for v in problems.values()), problems
    assert self_intersections(mesh) == 0
    tm = trimesh.Trimesh(mesh.vertices - mesh.vertices.min(axis=0), mesh.triangles, process=False)
    assert tm.is_watertight and tm.is_winding_consistent and tm.is_volume
    assert tm.volume > 0


def test_trees_are_not_buildings_and_touching_roofs_at_different_heights_are_two():
    dsm, dtm, truth = synthetic_city()
    cells, counts = building_cells(dsm, dtm)
    labels = split_buildings(dsm, cells)
    x, y = dsm.pixel_to_world(*np.mgrid[0:dsm.shape[0], 0:dsm.shape[1]])
    crown = (np.hypot(x - 8.0, y - 30.0) < 5.0) & (y > 26.0)  # the crown, off the house
    assert (labels[crown] >= 0).mean() < 0.05  # the crown is out
    assert labels.max() + 1 == len(truth)
    # the two touching houses are two buildings, each one label
    for poly, _ in truth:
        inner = shapely.contains_xy(poly.buffer(-1.0), x, y)
        found = np.unique(labels[inner])
        assert len(found) == 1 and found[0] >= 0


@pytest.mark.parametrize("roof", ["steps", "gables"])
def test_a_row_of_houses_under_one_roof_is_cut_into_its_houses(roof):
    """Five 6 m wide houses in a row, 30 degrees to the grid: ridges along the row at slightly different heights,
    or gables facing the street (valleys between the houses)."""
    h, w = 120, 140
    rows, cols = np.mgrid[0:h, 0:w]
    x, y = (cols + 0.5) * CELL, 60.0 - (rows + 0.5) * CELL
    c, s = np.cos(np.radians(30)), np.sin(np.radians(30))
    u, v = (x - 10) * c + (y - 15) * s, -(x - 10) * s + (y - 15) * c  # along and across the row
    inside = (u >= 0) & (u < 30) & (v >= 0) & (v < 10)
    house = np.floor(u / 6.0)
    if roof == "steps":
        top = 12.0 + 0.4 * (house % 2) + 0.2 * house - 0.5 * np.abs(v - 5)  # ridge along the row
    else:
        top = 14.0 - 0.8 * np.abs(u - 6 * house - 3)  # a gable per house, valleys between them
    z = np.where(inside, top, 0.0) + np.random.default_rng(0).normal(0, 0.02, (h, w))
    dsm = Heightfield(z, cell_size=CELL, origin=(0.0, 60.0))
    ground = Heightfield(np.zeros((h, w)), cell_size=CELL, origin=(0.0, 60.0))
    model = tinsmith.city(dsm, ground=ground)
    assert len(model.buildings) == 5
    truth = [_rotated_box(10 + (6 * k + 3) * c - 5 * s, 15 + (6 * k + 3) * s + 5 * c, 6, 10, 30) for k in range(5)]
    for t in truth:
        assert max(_iou(b.outline, t) for b in model.buildings) > 0.75
    whole = tinsmith.city(dsm, ground=ground, split_rows=False)
    assert len(whole.buildings) == 1


def test_regularized_outline_has_right_angles_along_the_building():
    dsm, dtm, truth = synthetic_city(tree=False)
    model = tinsmith.city(dsm, ground=dtm)
    rotated = truth[2][0]
    outline = max((b.outline for b in model.buildings), key=lambda p: _iou(p, rotated))
    assert _iou(outline, rotated) > 0.9
    ring = np.asarray(outline.exterior.coords)[:-1]
    assert len(ring) == 4  # a rectangle, not a staircase
    edges = np.roll(ring, -1, axis=0) - ring
    angles = np.degrees(np.arctan2(edges[:, 1], edges[:, 0])) % 90.0
    assert np.all(np.minimum(np.abs(angles - 30.0), 90 - np.abs(angles - 30.0)) < 1.0)
    assert outline.is_valid


@pytest.mark.parametrize("roofs", ["flat", "planes"])
def test_synthetic_city_is_a_watertight_solid(roofs):
    dsm, dtm, truth = synthetic_city()
    model = tinsmith.city(dsm, ground=dtm, roofs=roofs, solid=True)
    assert model.stats["n_buildings"] == len(truth)
    _check_solid(model.mesh)
    patch = model.mesh.triangle_attributes["patch"]
    assert set(np.unique(patch)) == {0, 1, 2, 3, 4}
    # the bottom at the base, below every ground height
    assert np.allclose(model.mesh.vertices[model.mesh.triangles[patch == 4]][..., 2], model.stats["base"])
    assert model.stats["base"] < dtm.z.min()


def test_planar_roofs_follow_pitched_roofs():
    dsm, dtm, truth = synthetic_city(tree=False)
    flat = tinsmith.city(dsm, ground=dtm, roofs="flat")
    planes = tinsmith.city(dsm, ground=dtm, roofs="planes")
    grid = Heightfield(np.zeros(dsm.shape), transform=dsm.transform)
    inner = np.zeros(dsm.shape, bool)
    x, y = dsm.pixel_to_world(*np.mgrid[0:dsm.shape[0], 0:dsm.shape[1]])
    for poly, _ in truth:
        inner |= shapely.contains_xy(poly.buffer(-1.0), x, y)

    def rmse(model):
        z = tinsmith.rasterize(model.mesh, grid)
        e = (z - dsm.z)[inner]
        return float(np.sqrt(np.mean(e * e)))

    assert rmse(planes) < 0.1 < rmse(flat) / 5
    assert all(b.n_facets >= 1 for b in planes.buildings)


def test_footprints_make_one_prism_each_with_the_dsm_height():
    dsm, dtm, truth = synthetic_city()
    footprints = [p for p, _ in truth]
    model = tinsmith.city(dsm, ground=dtm, footprints=footprints, roof_height="median", solid=True)
    assert len(model.buildings) == len(footprints)
    for b, poly in zip(sorted(model.buildings, key=lambda b: b.outline.centroid.x),
                       sorted(footprints, key=lambda p: p.centroid.x), strict=False):
        assert _iou(b.outline, poly) > 0.99
    first = next(b for b in model.buildings if _iou(b.outline, footprints[0]) > 0.99)
    assert first.height == pytest.approx(19.0, abs=0.05)
    _check_solid(model.mesh)


def test_no_building_gives_the_terrain_solid_and_says_so():
    dsm, dtm, _ = synthetic_city()
    ground_only = Heightfield(dtm.z, transform=dtm.transform, crs=dtm.crs)
    model = tinsmith.city(ground_only, ground=dtm, solid=True)
    assert model.stats["n_buildings"] == 0 and "no building" in model.stats["note"]
    _check_solid(model.mesh)


def test_bad_input_is_refused_with_the_parameter_named():
    dsm, dtm, _ = synthetic_city()
    with pytest.raises(InvalidInputError, match="base height"):
        tinsmith.city(dsm, ground=dtm, solid=True, base=100.0)
    with pytest.raises(InvalidInputError, match="do not overlap the data"):  # no CRS to move them by
        tinsmith.city(dsm, ground=dtm, footprints=[shapely.box(1e6, 1e6, 1e6 + 10, 1e6 + 10)])
    with pytest.raises(InvalidInputError, match="roofs"):
        tinsmith.city(dsm, roofs="gothic")
    with pytest.raises(InvalidInputError, match="roof statistic"):
        tinsmith.city(dsm, roof_height="p101")


def test_city_model_owns_the_rules_of_which_options_go_together():
    """The command's one call (city_model) refuses, before any work, what its options cannot do together."""
    from tinsmith.algorithms.urban.city import city_model, city_options
    from tinsmith.errors import InvalidOptionError

    dsm, dtm, _ = synthetic_city()
    for kwargs, message in (({"lod": 3}, "lod is an option of roofs 'levels'"),
                            ({"roofs": "levels", "solid": True}, "solid needs roofs 'flat' or 'planes'"),
                            ({"roofs": "levels", "footprints": "b.gpkg"}, "footprints needs roofs"),
                            ({"base": 0.0}, "base is the height of a solid's bottom")):
        with pytest.raises(InvalidOptionError, match=message):
            city_options(**kwargs)
        with pytest.raises(InvalidOptionError, match=message):
            city_model(dsm, **kwargs)
    with pytest.raises(InvalidInputError, match="roofs must be one of"):
        city_model(dsm, roofs="gothic")
    assert city_options(roofs="levels", lod=3) == {"lod": 3, "noise_factor": 10, "min_width": None,
                                                  "max_roughness": None, "relative_to_ground": False,
                                                  "simplify_tolerance": 0.0}
    one = city_model(dsm, ground=dtm, roofs="planes", lod=None)  # None: not given (as the command passes it)
    assert np.array_equal(one.mesh.triangles, tinsmith.city(dsm, ground=dtm, roofs="planes").mesh.triangles)
    levels = city_model(dsm, ground=dtm, roofs="levels", lod=3)
    assert levels.stats["thresholds"] and levels.mesh.info["method"] == "urban"


def test_city_is_deterministic():
    dsm, dtm, _ = synthetic_city()
    a = tinsmith.city(dsm, ground=dtm, roofs="planes", solid=True).mesh
    b = tinsmith.city(dsm, ground=dtm, roofs="planes", solid=True).mesh
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.triangles, b.triangles)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 10_000), st.sampled_from(["flat", "planes"]))
def test_random_cities_are_watertight_volumes(seed, roofs):
    """Random boxes at random heights and angles, touching or overlapping, on a random slope."""
    rng = np.random.default_rng(seed)
    h, w = 80, 100
    rows, cols = np.mgrid[0:h, 0:w]
    x, y = (cols + 0.5) * CELL, 40.0 - (rows + 0.5) * CELL
    ground = 5.0 + rng.uniform(-0.05, 0.05) * x + rng.uniform(-0.05, 0.05) * y
    z = ground.copy()
    pts = shapely.points(x.ravel(), y.ravel())
    for _ in range(rng.integers(1, 7)):
        poly = _rotated_box(rng.uniform(5, 45), rng.uniform(5, 35), rng.uniform(4, 15), rng.uniform(4, 10),
                            rng.uniform(0, 90))
        inside = shapely.contains(poly, pts).reshape(h, w)
        tilt = rng.uniform(-0.5, 0.5) if roofs == "planes" else 0.0
        z[inside] = rng.uniform(8, 20) + tilt * x[inside]
    dsm = Heightfield(z, cell_size=CELL, origin=(0.0, 40.0))
    dtm = Heightfield(ground, cell_size=CELL, origin=(0.0, 40.0))
    model = tinsmith.city(dsm, ground=dtm, roofs=roofs, solid=True)
    _check_solid(model.mesh)


def test_regularize_keeps_a_valid_polygon_for_any_blob():
    rng = np.random.default_rng(3)
    for _ in range(20):
        cells = shapely.union_all([shapely.box(c, r, c + 1, r + 1) for r, c in rng.integers(0, 12, (60, 2))])
        for part in shapely.get_parts(cells):
            out = regularize(part, cell=1.0)
            assert out.is_valid and out.geom_type == "Polygon"
            assert out.symmetric_difference(part).area <= 0.25 * part.area + 1e-9


def test_class_shares_tell_buildings_and_vegetation_from_the_cloud():
    xyz = np.array([[0.1, 0.1, 5.0], [0.2, 0.2, 5.0], [1.1, 0.1, 9.0], [1.2, 0.2, 9.0], [1.3, 0.3, 9.0]])
    cloud = tinsmith.PointCloud(xyz, classification=[6, 6, 5, 5, 6])
    hf = Heightfield(np.zeros((2, 2)), cell_size=1.0, origin=(0.0, 1.0))
    building, vegetation = class_shares(cloud, hf)
    assert building[0, 0] == 1.0 and vegetation[0, 0] == 0.0
    assert building[0, 1] == pytest.approx(1 / 3) and vegetation[0, 1] == pytest.approx(2 / 3)
    assert np.isnan(building[1, 0])
    # no classes but returns: several returns are vegetation
    cloud = tinsmith.PointCloud(xyz, attributes={"number_of_returns": np.array([1, 1, 3, 2, 1])})
    building, vegetation = class_shares(cloud, hf)
    assert building is None and vegetation[0, 1] == pytest.approx(2 / 3)
    assert class_shares(tinsmith.PointCloud(xyz), hf) is None


# -- real data ---------------------------------------------------------------------------------

@pytest.mark.slow
def test_delft_buildings_match_the_cadastre_and_the_solid_is_watertight():
    from tinsmith.io.vector import read_polygons
    from tinsmith.metrics import footprint_iou

    dsm = tinsmith.read_heightfield(shared(DELFT_DSM))
    model = tinsmith.city(dsm, solid=True)
    reference, _ = read_polygons(shared(BGT))
    hull = shapely.union_all(reference).convex_hull
    iou = footprint_iou([b.outline for b in model.buildings], reference, within=hull)
    assert iou["iou"] >= 0.8
    assert iou["intersection"] / iou["found_area"] >= 0.8 and iou["intersection"] / iou["reference_area"] >= 0.8
    _check_solid(model.mesh)
    with_footprints = tinsmith.city(dsm, footprints=list(reference))
    for b in with_footprints.buildings:
        assert b.outline.is_valid


def _delft_crop(tmp_path, rows=slice(100, 300), cols=slice(250, 450)):
    """A 200 x 200 cell window of the Delft DSM and DTM (central blocks of row houses), as GeoTIFFs."""
    from tinsmith.io.gis_formats import write_grid

    out = []
    for src, name in ((DELFT_DSM, "dsm.tif"), (DELFT_DTM, "dtm.tif")):
        hf = tinsmith.read_heightfield(shared(src))
        a, b, c, d, e, f = hf.transform
        crop = Heightfield(hf.z[rows, cols], transform=(a, b, c + a * cols.start, d, e, f + e * rows.start), crs=hf.crs)
        write_grid(crop.z, tmp_path / name, crop)
        out.append(tmp_path / name)
    return out


def test_cli_urban_writes_named_solids_groups_and_cityjson(tmp_path):
    stl, obj, cj, outlines = (tmp_path / n for n in ("city.stl", "city.obj", "city.json", "b.geojson"))
    dsm, dtm = _delft_crop(tmp_path)
    code = main(["city", str(dsm), "--ground", str(dtm), "-o", str(stl), "-o", str(obj), "-o", str(cj),
                 "--buildings", str(outlines), "--solid", "--roofs", "planes"])
    assert code == 0
    text = stl.read_text()
    assert [line.split()[1] for line in text.splitlines() if line.startswith("solid ")] == [
        "ground", "buildings", "walls", "sides", "bottom"]
    assert [line.split()[1] for line in obj.read_text().splitlines() if line.startswith("g ")] == [
        "ground", "buildings", "walls", "sides", "bottom"]
    loaded = trimesh.load(obj, process=False)
    assert loaded.is_watertight and loaded.is_volume
    doc = json.loads(cj.read_text())
    buildings = [o for o in doc["CityObjects"].values() if o["type"] == "Building"]
    assert buildings and all(o["geometry"][0]["lod"] == "2.2" for o in buildings)
    assert all(o["attributes"]["measuredHeight"] > 2.0 for o in buildings)
    assert json.loads(outlines.read_text())["features"]


def test_cli_urban_footprints_in_another_crs_are_reprojected(tmp_path):
    from pyproj import Transformer

    from tinsmith.io.vector import read_polygons

    reference, _ = read_polygons(shared(BGT))
    to_wgs = Transformer.from_crs("EPSG:28992", "EPSG:4326", always_xy=True)
    moved = shapely.transform(reference[:20], lambda xy: np.column_stack(to_wgs.transform(xy[:, 0], xy[:, 1])))
    src = tmp_path / "fp.geojson"
    src.write_text(json.dumps({
        "type": "FeatureCollection",
        "features": [{"type": "Feature", "properties": {}, "geometry": json.loads(shapely.to_geojson(g))} for g in moved],
    }))
    out = tmp_path / "b.geojson"
    assert main(["city", str(shared(DELFT_DSM)), "-o", str(tmp_path / "c.ply"), "--footprints", str(src),
                 "--buildings", str(out)]) == 0
    found = [shapely.geometry.shape(f["geometry"]) for f in json.loads(out.read_text())["features"]]
    assert len(found) == 20
    ious = [max(_iou(f, r) for f in found) for r in reference[:20]]
    assert min(ious) > 0.95


def test_cli_urban_footprints_elsewhere_warn_in_one_line(tmp_path, capsys):
    """Footprints in the DSM's CRS but elsewhere: one warning, the terrain alone."""
    dsm, _, _ = synthetic_city()
    from tinsmith.io.gis_formats import write_grid

    src = tmp_path / "dsm.tif"
    write_grid(dsm.z, src, dsm)
    far = tmp_path / "far.geojson"
    far.write_text(json.dumps({"type": "FeatureCollection", "crs": {
        "type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::28992"}}, "features": [{
        "type": "Feature", "properties": {},
        "geometry": json.loads(shapely.to_geojson(shapely.box(9e4, 4e5, 9e4 + 10, 4e5 + 10)))}]}))
    assert main(["city", str(src), "-o", str(tmp_path / "c.ply"), "--footprints", str(far)]) == 0
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1 and err[0].startswith("tinsmith: warning:") and "1 entirely outside" in err[0], err
    assert (tmp_path / "c.ply").exists()


def test_tiled_run_finds_the_same_buildings_whole_across_tile_borders(tmp_path):
    """Windows of 64 cells with a halo of 8 cut every building; each is found again whole and kept once."""
    from tinsmith.io.gis_formats import write_grid
    from tinsmith.metrics import footprint_iou
    from tinsmith.tiles.city import city_tiles

    dsm, dtm, truth = synthetic_city()
    dsm_file, dtm_file = tmp_path / "dsm.tif", tmp_path / "dtm.tif"
    write_grid(dsm.z, dsm_file, dsm)
    write_grid(dtm.z, dtm_file, dtm)
    one = tinsmith.city(tinsmith.read_heightfield(dsm_file), ground=tinsmith.read_heightfield(dtm_file), solid=True)
    tiled = city_tiles(dsm_file, ground=dtm_file, tile_size=64, halo=8, solid=True, workers=1)
    assert tiled.stats["tiles"] == 12
    assert len(tiled.buildings) == len(one.buildings) == len(truth)
    iou = footprint_iou([b.outline for b in tiled.buildings], [b.outline for b in one.buildings])
    assert iou["iou"] > 0.99
    for b in tiled.buildings:
        assert max(_iou(b.outline, t) for t, _ in truth) > 0.85
    _check_solid(tiled.mesh)
    # the command: one line of refusal for what a tiled run does not do
    assert main(["city", str(dsm_file), "-o", str(tmp_path / "c.stl"), "--tile-size", "64", "--roofs", "planes"]) == 1
    out = tmp_path / "t.stl"
    assert main(["city", str(dsm_file), "-o", str(out), "--tile-size", "64", "--ground", str(dtm_file), "--solid",
                 "--workers", "1"]) == 0
    assert out.exists()
