"""The one path of every geometry option (tinsmith.io.geometry): what users' vectors are like, as they come.

Reprojected (datum shifts included) with a note, cleaned (multi-parts split,
empty and invalid features skipped, close vertices merged, crossings noded,
null Z draped), clipped to the data's outline with one warning, and the same
whatever form the geometry takes (file, GeoDataFrame, shapely, arrays).
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

import tinsmith
from tinsmith.cli.main import main
from tinsmith.errors import InvalidInputError, NoDataError, TinsmithNote, TinsmithWarning
from tinsmith.io.geometry import data_outline, prepare
from tinsmith.shapes import stream_network

from .bad_inputs import heights
from .conftest import shared

shapely = pytest.importorskip("shapely")

UTM10 = "EPSG:32610"
BIG_TUJUNGA = "terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif"


def dem(valid=None) -> tinsmith.Heightfield:
    z = heights(40, 50).astype(np.float64)
    if valid is not None:
        z = np.where(valid, z, np.nan)
    return tinsmith.Heightfield(z, transform=(2.0, 0.0, 500000.0, 0.0, -2.0, 4100080.0), crs=UTM10,
                                nodata=np.nan if valid is not None else None)


def write_geojson(path: Path, geometries, crs: str | None = "urn:ogc:def:crs:EPSG::32610") -> Path:
    doc = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {}, "geometry": None if g is None else json.loads(shapely.to_geojson(g))}
        for g in geometries]}
    if crs:
        doc["crs"] = {"type": "name", "properties": {"name": crs}}
    path.write_text(json.dumps(doc))
    return path


def quiet(call):
    """(result, notes, warnings) of a call."""
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        out = call()
    notes = [str(w.message) for w in seen if issubclass(w.category, TinsmithNote)]
    warns = [str(w.message) for w in seen if issubclass(w.category, TinsmithWarning)]
    return out, notes, warns


LINE = shapely.LineString([(500010.0, 4100010.0), (500050.0, 4100060.0), (500090.0, 4100020.0)])


def test_every_form_gives_the_same_mesh(tmp_path):
    """A file, a GeoDataFrame, a GeoSeries, shapely geometries and arrays: one path, one mesh."""
    gpd = pytest.importorskip("geopandas")
    hf = dem()
    forms = {
        "file": write_geojson(tmp_path / "l.geojson", [LINE]),
        "path-string": str(tmp_path / "l.geojson"),
        "geodataframe": gpd.GeoDataFrame(geometry=[LINE], crs=UTM10),
        "geoseries": gpd.GeoSeries([LINE], crs=UTM10),
        "shapely": LINE,
        "shapely-list": [LINE],
        "array": np.asarray(LINE.coords),
        "arrays": [np.asarray(LINE.coords)],
    }
    meshes = {name: tinsmith.simplify(hf, max_error=0.5, breaklines=value) for name, value in forms.items()}
    ref = meshes.pop("file")
    for name, mesh in meshes.items():
        assert np.array_equal(mesh.vertices, ref.vertices) and np.array_equal(mesh.triangles, ref.triangles), name
    plain = tinsmith.simplify(hf, max_error=0.5)
    assert not np.array_equal(plain.triangles, ref.triangles)


def test_other_datum_is_reprojected_with_one_note(tmp_path):
    """NAD27 / UTM 10N lines meet a WGS 84 / UTM 10N DEM: moved by pyproj's datum shift (some 100 m), said once."""
    from pyproj import Transformer

    hf = dem()
    move = Transformer.from_crs(UTM10, "EPSG:26710", always_xy=True)
    nad27 = shapely.transform(LINE, lambda xy: np.column_stack(move.transform(xy[:, 0], xy[:, 1])))
    assert shapely.hausdorff_distance(nad27, LINE) > 50  # the shift is real
    path = write_geojson(tmp_path / "nad27.geojson", [nad27], "urn:ogc:def:crs:EPSG::26710")
    lines, notes, warns = quiet(lambda: prepare("lines", path, hf, "breaklines"))
    assert len(notes) == 1 and "NAD27" in notes[0] and "WGS 84 / UTM zone 10N" in notes[0] and not warns
    assert len(lines) == 1
    back = shapely.LineString(lines[0])
    assert shapely.hausdorff_distance(back, LINE) < 0.2 * 2.0 + 1e-6  # within the merging grid of a tenth of a cell


def test_no_crs_and_no_overlap_is_refused_with_both_extents(tmp_path):
    hf = dem()
    far = shapely.LineString([(10.0, 10.0), (60.0, 80.0)])
    with pytest.raises(InvalidInputError, match=r"do not overlap the data.*\(10, 10, 60, 80\).*500001"):
        prepare("lines", far, hf, "breaklines")
    no_crs = tinsmith.Heightfield(dem().z, transform=dem().transform)  # the data has none, the file has one
    path = write_geojson(tmp_path / "far.geojson", [far])
    with pytest.raises(InvalidInputError, match="the data has no CRS"):
        prepare("lines", path, no_crs, "breaklines")


def test_lines_are_clipped_to_the_valid_cells_not_the_box():
    """A line across a nodata hole becomes two lines, each ending on the hole's rim; greedy keeps both."""
    valid = np.ones((40, 50), bool)
    valid[10:30, 20:30] = False
    hf = dem(valid)
    line = shapely.LineString([(500005.0, 4100040.0), (500095.0, 4100040.0)])
    lines, notes, warns = quiet(lambda: prepare("lines", line, hf, "breaklines"))
    assert len(lines) == 2 and len(warns) == 1 and "1 of 1 features clipped" in warns[0]
    hole = data_outline(hf)
    assert len(hole.interiors) == 1
    for piece in lines:
        assert hole.buffer(1e-6).covers(shapely.LineString(piece))
    mesh, _, _ = quiet(lambda: tinsmith.simplify(hf, max_error=0.5, breaklines=line))
    assert mesh.n_triangles > 0


def test_leaving_and_entering_again_makes_several_lines():
    hf = dem()
    x0, y0, x1, y1 = hf.bounds
    zigzag = shapely.LineString([(x0 + 5, y0 + 10), (x0 + 30, y1 + 50), (x0 + 60, y0 + 10)])
    lines, _, warns = quiet(lambda: prepare("lines", zigzag, hf, "breaklines"))
    assert len(lines) == 2 and "clipped" in warns[0]


def test_crossing_lines_share_a_vertex_and_close_vertices_merge():
    hf = dem()
    a = shapely.LineString([(500010.0, 4100010.0), (500090.0, 4100070.0)])
    b = shapely.LineString([(500010.0, 4100070.0), (500090.0, 4100010.0)])
    # a third line whose first vertex is 0.05 cells from a's first vertex: merged into it
    c = shapely.LineString([(500010.1, 4100010.05), (500002.0, 4100040.0)])
    lines, _, warns = quiet(lambda: prepare("lines", [a, b, c], hf, "breaklines"))
    assert not warns
    ends = np.concatenate([line[[0, -1]] for line in lines])
    crossing = np.array([500050.0, 4100040.0])
    assert (np.hypot(*(ends - crossing).T) < 1e-9).sum() == 4  # four pieces meet at the crossing
    every = np.concatenate(lines)
    near = {tuple(p) for p in every.tolist() if np.hypot(p[0] - 500010.0, p[1] - 4100010.0) < 0.5}
    assert near == {(500010.0, 4100010.0)}  # c's first vertex merged into a's


def test_multi_parts_empty_and_invalid(tmp_path):
    hf = dem()
    multi = shapely.MultiLineString([[(500010.0, 4100010.0), (500030.0, 4100030.0)],
                                     [(500050.0, 4100050.0), (500070.0, 4100020.0)]])
    path = tmp_path / "mixed.geojson"
    doc = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {}, "geometry": json.loads(shapely.to_geojson(multi))},
        {"type": "Feature", "properties": {}, "geometry": None},
        {"type": "Feature", "properties": {}, "geometry": {"type": "LineString", "coordinates": [[500020.0, 4100020.0]]}},
    ], "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32610"}}}
    path.write_text(json.dumps(doc))
    lines, _, warns = quiet(lambda: prepare("lines", path, hf, "breaklines"))
    assert len(lines) == 2 and len(warns) == 1 and "2 empty or invalid skipped" in warns[0]
    only_bad = write_geojson(tmp_path / "bad.geojson", [None])
    with pytest.raises(NoDataError, match="bad.geojson"):
        prepare("lines", only_bad, hf, "breaklines")
    points = write_geojson(tmp_path / "points.geojson", [shapely.Point(500020.0, 4100020.0)])
    with pytest.raises(NoDataError, match="found Point"):
        prepare("lines", points, hf, "breaklines")


def test_self_intersecting_polygons_are_repaired():
    hf = dem()
    bowtie = shapely.Polygon([(500010.0, 4100010.0), (500040.0, 4100040.0), (500040.0, 4100010.0),
                              (500010.0, 4100040.0)])
    polys, _, warns = quiet(lambda: prepare("polygons", [bowtie], hf, "holes"))
    assert len(polys) == 2 and all(p.is_valid for p in polys) and "1 self-intersecting repaired" in warns[0]


def test_null_z_is_draped_full_z_kept_on_a_cloud():
    rng = np.random.default_rng(0)
    xy = rng.uniform(0, 80, (800, 2)) + [500000.0, 4100000.0]
    cloud = tinsmith.PointCloud(np.column_stack([xy, 10 + 0.1 * (xy[:, 0] - 500000.0)]), crs=UTM10)
    full = shapely.LineString([(500010.0, 4100010.0, 5.0), (500060.0, 4100060.0, 6.0)])
    null = shapely.LineString([(500010.0, 4100060.0, 5.0), (500060.0, 4100010.0, np.nan)])
    lines, _, _ = quiet(lambda: prepare("lines", [full, null], cloud, "breaklines"))
    widths = sorted(line.shape[1] for line in lines)
    assert widths == [2, 2, 3, 3]  # noded at their crossing: the null-Z line's two pieces go 2-D (draped)
    mesh, _, _ = quiet(lambda: tinsmith.simplify(cloud, max_error=0.2, breaklines=[full, null]))
    assert np.isfinite(mesh.vertices).all()


def test_a_3d_line_keeps_its_heights_through_a_reprojection():
    gpd = pytest.importorskip("geopandas")
    rng = np.random.default_rng(0)
    xy = rng.uniform(0, 80, (800, 2)) + [500000.0, 4100000.0]
    cloud = tinsmith.PointCloud(np.column_stack([xy, np.zeros(len(xy))]), crs=UTM10)
    line = shapely.LineString([(500010.0, 4100010.0, 5.0), (500060.0, 4100060.0, 6.0)])
    nad27 = gpd.GeoDataFrame(geometry=[line], crs=UTM10).to_crs("EPSG:26710")
    (back,), notes, _ = quiet(lambda: prepare("lines", nad27, cloud, "breaklines"))
    assert len(notes) == 1 and back.shape == (2, 3)
    np.testing.assert_allclose(back, np.asarray(line.coords), atol=1e-6)


def test_points_outside_are_dropped_and_counted():
    hf = dem()
    pts = np.array([[500020.0, 4100020.0], [500030.0, 4100030.0], [400000.0, 4100030.0]])
    kept, _, warns = quiet(lambda: prepare("points", pts, hf, "control_points"))
    assert len(kept) == 2 and "1 entirely outside" in warns[0]


def test_regions_keep_their_fields_through_a_geodataframe():
    gpd = pytest.importorskip("geopandas")
    hf = dem()
    frame = gpd.GeoDataFrame({"max_area": [20.0, None], "name": ["fine", None]},
                             geometry=[shapely.box(500010, 4100010, 500040, 4100040),
                                       shapely.box(500050, 4100030, 500200, 4100070)], crs=UTM10)
    items, _, warns = quiet(lambda: prepare("regions", frame, hf, "regions"))
    assert [(a, n) for _, a, n in items] == [(20.0, "fine"), (None, "region_1")]
    assert "1 of 2 features clipped" in warns[0]
    mesh, _, _ = quiet(lambda: tinsmith.quality(hf, max_error=1.0, regions=frame) if hasattr(tinsmith, "quality")
                       else tinsmith.simplify(hf, method="quality", max_error=1.0, regions=frame))
    assert mesh.n_triangles > 0


def test_a_cloud_outline_follows_the_points_not_their_box():
    """An L-shaped cloud: a line across the empty corner is cut there."""
    rng = np.random.default_rng(1)
    xy = rng.uniform(0, 100, (6000, 2))
    xy = xy[(xy[:, 0] < 40) | (xy[:, 1] < 40)] + [500000.0, 4100000.0]
    cloud = tinsmith.PointCloud(np.column_stack([xy, np.zeros(len(xy))]), crs=UTM10)
    outline = data_outline(cloud)
    assert outline.area < 0.8 * 100 * 100
    line = shapely.LineString([(500020.0, 4100080.0), (500080.0, 4100080.0)])  # from the arm into the empty corner
    lines, _, warns = quiet(lambda: prepare("lines", line, cloud, "breaklines"))
    assert len(lines) == 1 and np.ptp(lines[0][:, 0]) < 35 and "clipped" in warns[0]


# -- the acceptance: a real DEM, streams in another datum reaching 1 km beyond it --------------------------

@pytest.mark.parametrize("datum", ["EPSG:26711", "EPSG:4326"])
@pytest.mark.parametrize("method", ["greedy", "quality"])
def test_streams_in_another_datum_reaching_beyond_a_real_dem(tmp_path, capsys, datum, method):
    """Big Tujunga (WGS 84 / UTM 11N, 30 m) cut to 150 x 250 cells; streams in NAD27 / UTM 11N or WGS 84
    geographic: exit 0, one note and one warning, every clipped stream in the 2DM's node strings, the bound and
    the angle as without lines."""
    from pyproj import Transformer

    from tinsmith.io.gis_formats import write_grid
    from tinsmith.metrics import mesh_metrics
    from tinsmith.metrics.quality import triangle_angles

    full = tinsmith.read_heightfield(shared(BIG_TUJUNGA))
    a, b, c, d, e, f = full.transform
    r0, c0 = 200, 400
    hf = tinsmith.Heightfield(full.z[r0:r0 + 150, c0:c0 + 250].copy(), crs=full.crs,
                              transform=(a, b, c + a * c0 + b * r0, d, e, f + d * c0 + e * r0))
    dem_path = tmp_path / "crop.tif"
    write_grid(hf.z, dem_path, hf)
    move = Transformer.from_crs(hf.crs, datum, always_xy=True)
    streams = [np.column_stack(move.transform(xy[:, 0], xy[:, 1])) for xy in stream_network(hf)]
    doc = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {}, "geometry": {"type": "LineString", "coordinates": s.tolist()}}
        for s in streams]}
    if datum != "EPSG:4326":  # a GeoJSON without a CRS is WGS 84 geographic
        doc["crs"] = {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::26711"}}
    lines_file = tmp_path / "streams.geojson"
    lines_file.write_text(json.dumps(doc))
    out, plain_out = tmp_path / "mesh.2dm", tmp_path / "plain.2dm"
    assert main(["simplify", str(dem_path), "--method", method, "--max-error", "2", "-o", str(plain_out)]) == 0
    capsys.readouterr()
    assert main(["simplify", str(dem_path), "--method", method, "--max-error", "2", "--breaklines", str(lines_file),
                 "-o", str(out), "--json"]) == 0
    printed = capsys.readouterr()
    summary = json.loads(printed.out)
    err = [line for line in printed.err.splitlines() if line.strip()]
    slivers = [line for line in err if "under 10 degrees" in line]  # a solver format: greedy's slivers named
    assert len(slivers) == (method == "greedy") and all("--method quality" in line for line in slivers), err
    err = [line for line in err if line not in slivers]
    assert len(err) == 2 and err[0].startswith("tinsmith: note:") and "reprojected from" in err[0], err
    assert err[1].startswith("tinsmith: warning:") and "clipped" in err[1] and "1 entirely outside" in err[1], err
    mesh, plain = tinsmith.read(out), tinsmith.read(plain_out)
    # every clipped stream lies along the node strings' edges (within the snap to the nearest cell centre)
    fitted, _, _ = quiet(lambda: prepare("lines", lines_file, hf, "breaklines"))
    network = shapely.MultiLineString([mesh.vertices[ids, :2] for ids in mesh.node_strings.values()
                                       if len(ids) > 1])
    cell = abs(a)
    for line in fitted:
        dense = shapely.segmentize(shapely.LineString(line), cell / 4)
        far = shapely.distance(network, shapely.points(shapely.get_coordinates(dense))).max()
        assert far <= cell * np.sqrt(0.5) + 1e-6, far
    # the bound and the angle as without lines
    for m in (mesh, plain):
        assert mesh_metrics(m, hf)["vertical_error"]["max"] <= 2.0 + 1e-9
    if method == "quality":  # every angle at the bound, but where two lines (or a line and the edge) meet tighter
        assert triangle_angles(plain, 2).min() >= 30.0 - 1e-6
        below = (triangle_angles(mesh, 2).min(axis=1) < 30.0 - 1e-6).sum()
        assert below <= summary["quality"]["below_min_angle"] < 0.002 * mesh.n_triangles
