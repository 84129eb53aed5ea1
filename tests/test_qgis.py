"""tinsmith's QGIS Processing provider, run by QGIS itself (headless), against the same runs through the API."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys

import numpy as np
import pytest

import tinsmith
from tests.conftest import shared, write_las
from tests.qgis_session import qgis_app
from tinsmith.io.slivers import SliverWarning

#: A shared DEM of bare terrain (30 m SRTM, UTM 11N) and a shared city DSM (0.5 m AHN3, RD New).
DEM = "terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif"
DSM = "urban/delft_ahn3/delft_dsm_0.5m.tif"


@pytest.fixture(scope="module")
def q():
    return qgis_app()


def _run(q, algorithm, parameters, *, load=True):
    """``processing.run``; with ``load``, its results loaded into the project as the toolbox loads them, the
    post-processors applied (the CRS set on a mesh layer).  Returns (results, the layers loaded, by file)."""
    from processing.gui.Postprocessing import handleAlgorithmResults

    project = q.core.QgsProject.instance()
    project.removeAllMapLayers()
    feedback = q.core.QgsProcessingFeedback()
    context = q.core.QgsProcessingContext()
    context.setProject(project)
    results = q.processing.run(algorithm, parameters, onFinish=handleAlgorithmResults if load else None,
                               feedback=feedback, context=context)
    from tinsmith.qgis.base import layer_path

    layers = {layer_path(lay): lay for lay in project.mapLayers().values()}
    return results, layers


def _line_file(path, crs: str, coordinates) -> str:
    """A one-line GeoJSON file in ``crs`` (GeoJSON with a named CRS, which GDAL and QGIS honour)."""
    path.write_text(json.dumps({"type": "FeatureCollection", "crs": {"type": "name", "properties": {"name": crs}},
                                "features": [{"type": "Feature", "properties": {},
                                              "geometry": {"type": "LineString", "coordinates": coordinates}}]}))
    return str(path)


def _check_layer(layer, n_triangles: int, epsg: int) -> None:
    assert layer is not None and type(layer).__name__ == "QgsMeshLayer"
    assert layer.isValid()
    assert layer.crs().authid() == f"EPSG:{epsg}"
    assert layer.dataProvider().faceCount() == n_triangles


def test_the_toolbox_lists_the_algorithms_and_every_method(q):
    registry = q.core.QgsApplication.processingRegistry()
    provider = registry.providerById("tinsmith")
    assert provider is not None and provider.name() == "tinsmith"
    assert {a.name() for a in provider.algorithms()} == {"simplify", "tile", "urban", "reconstruct", "metrics", "report"}
    simplify = registry.algorithmById("tinsmith:simplify")
    method = simplify.parameterDefinition("METHOD")
    assert method.usesStaticStrings() and method.options() == [m.name for m in tinsmith.methods()]
    names = {p.name() for p in simplify.parameterDefinitions()}
    options = {o.name.upper() for m in tinsmith.methods() for o in m.options if not o.replaced_by}
    assert options <= names and {"INPUT", "MAX_ERROR", "OUTPUT", "BREAKLINES", "REGIONS"} <= names
    assert all(n == n.upper() for n in names)


@pytest.fixture(scope="module")
def quality_run():
    """(DEM path, the breakline's corners, the API's quality mesh with it): computed once for both outputs."""
    import shapely

    dem = shared(DEM)
    hf = tinsmith.read_heightfield(dem)
    x0, y0, x1, y1 = hf.bounds
    line = [[x0 + 3000.0, y0 + 3000.0], [x1 - 3000.0, y1 - 3000.0], [x1 - 3000.0, y0 + 3000.0]]
    return dem, line, tinsmith.simplify(hf, method="quality", max_error=40.0, breaklines=[shapely.LineString(line)])


@pytest.mark.parametrize("suffix", [".nc", ".2dm"])
def test_simplify_quality_with_breaklines_is_the_api_run_as_a_mesh_layer(q, tmp_path, suffix, quality_run):
    dem, line, api = quality_run
    breaklines = _line_file(tmp_path / "breaklines.geojson", "EPSG:32611", line)
    out = tmp_path / f"mesh{suffix}"
    results, layers = _run(q, "tinsmith:simplify", {"INPUT": str(dem), "METHOD": "quality", "MAX_ERROR": 40.0,
                                                    "BREAKLINES": breaklines, "OUTPUT": str(out)})
    assert results["N_TRIANGLES"] == api.n_triangles and results["N_VERTICES"] == api.n_vertices
    _check_layer(layers.get(str(out)), api.n_triangles, 32611)
    written = tinsmith.read(out)
    assert np.array_equal(written.triangles, api.triangles)


def test_a_breaklines_layer_in_another_crs_is_reprojected(q, tmp_path):
    from pyproj import Transformer

    dem = shared(DEM)
    hf = tinsmith.read_heightfield(dem)
    x0, y0, x1, y1 = hf.bounds
    to_degrees = Transformer.from_crs(hf.crs, "EPSG:4326", always_xy=True)
    line = [list(to_degrees.transform(x0 + 3000.0, y0 + 3000.0)), list(to_degrees.transform(x1 - 3000.0, y1 - 3000.0))]
    breaklines = _line_file(tmp_path / "wgs84.geojson", "urn:ogc:def:crs:OGC:1.3:CRS84", line)
    results, _ = _run(q, "tinsmith:simplify", {"INPUT": str(dem), "METHOD": "quality", "MAX_ERROR": 40.0,
                                               "BREAKLINES": breaklines, "OUTPUT": str(tmp_path / "m.nc")}, load=False)
    mesh = tinsmith.read(tmp_path / "m.nc")
    assert len(mesh.constrained_edges) > 0  # the line landed on the DEM, in its CRS
    along = mesh.vertices[np.unique(mesh.constrained_edges)][:, :2]
    assert along[:, 0].min() >= x0 + 2900 and along[:, 0].max() <= x1 - 2900


def test_tile_is_the_api_run(q, tmp_path):
    from tinsmith.tiles import tile_raster

    dem = shared(DEM)
    out = tmp_path / "tiled.2dm"
    results, layers = _run(q, "tinsmith:tile", {"INPUT": str(dem), "MAX_ERROR": 30.0, "TILE_SIZE": 400, "WORKERS": 1,
                                                "OUTPUT": str(out)})
    api = tile_raster(str(dem), max_error=30.0, tile_size=400, workers=1).merge()
    assert results["N_TRIANGLES"] == api.n_triangles
    _check_layer(layers.get(str(out)), api.n_triangles, 32611)


def test_urban_is_the_api_run_with_its_outlines(q, tmp_path):
    dsm = shared(DSM)
    out, outlines = tmp_path / "city.2dm", tmp_path / "buildings.gpkg"
    results, layers = _run(q, "tinsmith:urban", {"INPUT": str(dsm), "OUTPUT": str(out), "BUILDINGS": str(outlines)})
    api = tinsmith.city(tinsmith.read_heightfield(dsm))
    assert results["N_TRIANGLES"] == api.mesh.n_triangles and results["N_BUILDINGS"] == api.stats["n_buildings"]
    _check_layer(layers.get(str(out)), api.mesh.n_triangles, 28992)
    vector = layers.get(str(outlines))
    assert vector is not None and vector.isValid() and vector.featureCount() == api.stats["n_buildings"]
    assert vector.crs().authid() == "EPSG:28992"


def test_metrics_are_the_api_metrics(q, tmp_path):
    dem = shared(DEM)
    hf = tinsmith.read_heightfield(dem)
    mesh = tinsmith.simplify(hf, method="greedy", max_error=30.0)
    with pytest.warns(SliverWarning):  # greedy's slivers, said when written to a solver format
        path = tinsmith.write(mesh, tmp_path / "greedy.2dm")  # its CRS in the .prj beside it, which QGIS does not read
    report = tmp_path / "metrics.json"
    results, _ = _run(q, "tinsmith:metrics", {"MESH": str(path), "DEM": str(dem), "OUTPUT": str(report)}, load=False)
    api = tinsmith.mesh_metrics(mesh, hf)
    assert results["N_TRIANGLES"] == mesh.n_triangles
    assert results["VERTICAL_ERROR_MAX"] == pytest.approx(api["vertical_error"]["max"])
    assert results["VERTICAL_ERROR_RMSE"] == pytest.approx(api["vertical_error"]["rmse"])
    assert results["QUALITY_2D_MIN_ANGLE_MIN"] == pytest.approx(api["quality_2d"]["min_angle"]["min"])
    assert results["QUALITY_2D_SHARE_MIN_ANGLE_BELOW_20"] == pytest.approx(api["quality_2d"]["share_min_angle_below_20"])
    assert json.loads(report.read_text())["vertical_error"]["max"] == pytest.approx(api["vertical_error"]["max"])


def test_reconstruct_and_report(q, tmp_path):
    rng = np.random.default_rng(3)
    xy = rng.uniform(0, 50, (3000, 2))
    las = write_las(tmp_path / "cloud.las", np.column_stack([xy + [500000, 4100000], np.sin(xy[:, 0] / 8) * 3]),
                    crs="EPSG:32611")
    out = tmp_path / "surface.nc"
    results, layers = _run(q, "tinsmith:reconstruct", {"INPUT": str(las), "MODE": "heightfield", "OUTPUT": str(out)})
    api = tinsmith.simplify(tinsmith.read(las), method="reconstruct", mode="heightfield")
    assert results["N_TRIANGLES"] == api.n_triangles
    _check_layer(layers.get(str(out)), api.n_triangles, 32611)

    dem = shared(DEM)
    mesh_file = tinsmith.write(tinsmith.simplify(tinsmith.read_heightfield(dem), max_error=40.0), tmp_path / "g.nc")
    html = tmp_path / "report.html"
    results, _ = _run(q, "tinsmith:report", {"MESH": str(mesh_file), "DEM": str(dem), "OUTPUT": str(html)}, load=False)
    assert results["OUTPUT"] == str(html) and "<html" in html.read_text()[:500].lower()


def test_an_error_is_the_command_lines_one_line_and_writes_nothing(q, tmp_path):
    out = tmp_path / "never.2dm"
    with pytest.raises(q.core.QgsProcessingException) as caught:
        _run(q, "tinsmith:simplify", {"INPUT": str(shared(DEM)), "METHOD": "quadtree", "MAX_TRIANGLES": 1,
                                      "OUTPUT": str(out)}, load=False)
    message = str(caught.value).splitlines()[-1]  # Processing puts "Unable to execute algorithm" above it
    assert message.startswith("tinsmith: error: the coarsest quadtree mesh has") and "max_triangles=1 " in message
    assert not out.exists() and not list(tmp_path.iterdir())


def test_cancel_stops_the_run_and_writes_nothing(q, tmp_path):
    registry = q.core.QgsApplication.processingRegistry()
    algorithm = registry.createAlgorithmById("tinsmith:simplify")
    feedback = q.core.QgsProcessingFeedback()
    feedback.cancel()
    context = q.core.QgsProcessingContext()
    out = tmp_path / "never.nc"
    with pytest.raises(q.core.QgsProcessingException, match="cancelled"):
        algorithm.processAlgorithm({"INPUT": str(shared(DEM)), "METHOD": "greedy", "MAX_ERROR": 5.0, "OUTPUT": str(out)},
                                   context, feedback)
    assert not out.exists()


def test_the_plugin_installs_into_a_profile_and_loads(q, tmp_path):
    done = subprocess.run([sys.executable, "-m", "tinsmith.qgis", "install", "--qgis-dir", str(tmp_path)],
                          capture_output=True, text=True, check=True)
    folder = tmp_path / "profiles" / "default" / "python" / "plugins" / "tinsmith_processing"
    assert str(folder) in done.stdout
    meta = (folder / "metadata.txt").read_text()
    assert "hasProcessingProvider=yes" in meta and f"version={tinsmith.__version__}" in meta
    spec = importlib.util.spec_from_file_location("tinsmith_processing", folder / "__init__.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    plugin = module.classFactory(None)
    registry = q.core.QgsApplication.processingRegistry()
    registry.removeProvider(q.provider)  # the plugin adds its own, as QGIS would at start
    try:
        plugin.initProcessing()
        assert registry.algorithmById("tinsmith:simplify") is not None
        plugin.unload()
        assert registry.providerById("tinsmith") is None
    finally:
        from tinsmith.qgis.provider import TinsmithProvider

        q.provider = TinsmithProvider()
        registry.addProvider(q.provider)


def test_without_qgis_the_installer_runs_and_the_provider_says_what_is_missing(tmp_path):
    code = ("import sys; sys.modules['qgis'] = None\n"  # QGIS's bindings not importable
            "import tinsmith.qgis as q\n"
            "from tinsmith.qgis.plugin import install\n"
            f"print(install('default', {str(tmp_path)!r}))\n"
            "try:\n    q.TinsmithProvider()\nexcept Exception as exc:\n    print(type(exc).__name__, exc)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    folder, error = done.stdout.strip().splitlines()
    assert folder.endswith("tinsmith_processing")
    assert (tmp_path / "profiles" / "default" / "python" / "plugins" / "tinsmith_processing" / "metadata.txt").is_file()
    assert error.startswith("MissingDependencyError tinsmith.qgis.TinsmithProvider needs QGIS's Python bindings")


def test_simplify_takes_a_point_cloud_file(q, tmp_path):
    rng = np.random.default_rng(5)
    xy = rng.uniform(0, 80, (4000, 2))
    z = 100 + 5 * np.sin(xy[:, 0] / 10) + 0.02 * xy[:, 1]
    classes = np.where(np.arange(len(xy)) % 4 == 0, 5, 2)  # every fourth point vegetation
    las = write_las(tmp_path / "cloud.las", np.column_stack([xy + [500000, 4100000], z]), classes=classes,
                    crs="EPSG:32611")
    out = tmp_path / "tin.nc"
    results, layers = _run(q, "tinsmith:simplify", {"POINTS": str(las), "CLASSES": "2", "METHOD": "greedy",
                                                    "MAX_ERROR": 0.1, "OUTPUT": str(out)})
    api = tinsmith.simplify(tinsmith.read(las, classes=[2]), method="greedy", max_error=0.1)
    assert results["N_TRIANGLES"] == api.n_triangles and results["VERTICAL_ERROR_MAX"] <= 0.1 + 1e-9
    _check_layer(layers.get(str(out)), api.n_triangles, 32611)
    with pytest.raises(q.core.QgsProcessingException, match="INPUT .a DEM. or POINTS"):
        _run(q, "tinsmith:simplify", {"INPUT": str(shared(DEM)), "POINTS": str(las), "OUTPUT": str(out)}, load=False)


def test_metrics_at_the_points_of_a_cloud(q, tmp_path):
    rng = np.random.default_rng(8)
    xy = rng.uniform(0, 60, (3000, 2)) + [500000, 4100000]
    las = write_las(tmp_path / "cloud.las", np.column_stack([xy, 50 + np.cos(xy[:, 1] / 9) * 2]), crs="EPSG:32611")
    cloud = tinsmith.read(las)
    mesh = tinsmith.simplify(cloud, method="greedy", max_error=0.2)
    path = tinsmith.write(mesh, tmp_path / "tin.nc")
    results, _ = _run(q, "tinsmith:metrics", {"MESH": str(path), "POINTS": str(las)}, load=False)
    api = tinsmith.metrics.source_error(mesh, cloud)
    assert results["VERTICAL_ERROR_MAX"] == pytest.approx(api["max"]) and api["max"] <= 0.2 + 1e-9
    assert results["VERTICAL_ERROR_RMSE"] == pytest.approx(api["rmse"])
