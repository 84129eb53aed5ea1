"""tinsmith's Processing algorithms: simplify, tile, urban, reconstruct, metrics and report.

Each runs the API function the command of the same name runs, on the
layers' files and geometries (:mod:`.base`), so a run in QGIS gives the
mesh the same call through the API gives.
"""

from __future__ import annotations

import json
from pathlib import Path

from qgis.core import (
    QgsProcessing,
    QgsProcessingContext,
    QgsProcessingException,
    QgsProcessingOutputNumber,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterEnum,
    QgsProcessingParameterFeatureSource,
    QgsProcessingParameterFile,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterMeshLayer,
    QgsProcessingParameterNumber,
    QgsProcessingParameterRasterLayer,
    QgsProcessingParameterString,
    QgsProcessingUtils,
)

from .base import CLOUDS, TinsmithAlgorithm, layer_path, mesh_filter, with_layer_crs
from .parameters import add_options, foreign_options, method_kwargs, registry_options

__all__ = ["ALGORITHMS"]


def _stop_rules(algorithm) -> None:
    """MAX_ERROR, MAX_VERTICES, MAX_TRIANGLES: each optional (the method's own default stop applies)."""
    algorithm.addParameter(QgsProcessingParameterNumber(
        "MAX_ERROR", "Vertical error bound (z units)", QgsProcessingParameterNumber.Double, optional=True, minValue=0.0))
    for name, label in (("MAX_VERTICES", "At most this many vertices"), ("MAX_TRIANGLES", "At most this many triangles")):
        algorithm.addParameter(QgsProcessingParameterNumber(name, label, QgsProcessingParameterNumber.Integer,
                                                            optional=True, minValue=1))


def _stop_kwargs(algorithm, parameters, context) -> dict:
    out = {}
    if parameters.get("MAX_ERROR") not in (None, ""):
        out["max_error"] = algorithm.parameterAsDouble(parameters, "MAX_ERROR", context)
    for name in ("MAX_VERTICES", "MAX_TRIANGLES"):
        if parameters.get(name) not in (None, ""):
            out[name.lower()] = algorithm.parameterAsInt(parameters, name, context)
    return out


def _mesh_output(algorithm, label: str = "Mesh") -> None:
    algorithm.addParameter(QgsProcessingParameterFileDestination("OUTPUT", label, mesh_filter()))


def _counts(algorithm, *, error: bool = True) -> None:
    """The outputs of a mesh's counts (and its vertical error against the input)."""
    names = [("N_VERTICES", "Vertices"), ("N_TRIANGLES", "Triangles")]
    if error:
        names += [("VERTICAL_ERROR_MAX", "Largest vertical error"), ("VERTICAL_ERROR_RMSE", "RMS vertical error")]
    for name, label in names:
        algorithm.addOutput(QgsProcessingOutputNumber(name, label))


def _results(mesh, path, error=None) -> dict:
    out = {"OUTPUT": path, "N_VERTICES": mesh.n_vertices, "N_TRIANGLES": mesh.n_triangles}
    if error:
        out.update(VERTICAL_ERROR_MAX=error.get("max"), VERTICAL_ERROR_RMSE=error.get("rmse"))
    return out


class SimplifyAlgorithm(TinsmithAlgorithm):
    NAME = "simplify"
    LABEL = "Simplify a DEM into a mesh"
    HELP = ("Makes a triangle mesh of a raster (INPUT) or a point cloud (POINTS) with one of tinsmith's methods "
            "(the METHOD list holds every registered one; its options are under Advanced, each saying which methods "
            "take it). Stop at a vertical error bound, a vertex count or a triangle count. quality and flood mesh for "
            "a 2-D solver: breaklines, regions and streams come from vector layers in any CRS. STREAMS also cuts the "
            "outline into named boundary segments (inflow_N, outflow_N, wall_N) that 2DM, UGRID and Gmsh outputs "
            "carry. The output is loaded as a mesh layer with the input's CRS.")

    def initAlgorithm(self, config=None):
        from ..algorithms.registry import DEFAULT_METHOD, methods

        records = methods()
        self.addParameter(QgsProcessingParameterRasterLayer("INPUT", "DEM", optional=True))
        self.add_points()
        self.addParameter(QgsProcessingParameterEnum(
            "METHOD", "Method", options=[r.name for r in records], defaultValue=DEFAULT_METHOD, usesStaticStrings=True))
        _stop_rules(self)
        options = registry_options(records)
        if "streams" not in options:
            self.addParameter(QgsProcessingParameterFeatureSource(
                "STREAMS", "Streams (boundary segments)", [QgsProcessing.TypeVectorLine], optional=True))
        add_options(self, options)
        _mesh_output(self)
        _counts(self)

    def work(self, parameters, context, feedback):
        from ..algorithms.registry import get_method, methods
        from ..core import Heightfield
        from ..io.boundaries import segment_outline
        from ..metrics import source_error

        record = get_method(self.parameterAsEnumString(parameters, "METHOD", context))
        data, name = self.elevation(parameters, "INPUT", context, points=record.input in ("points", "elevation"))
        kwargs = {**_stop_kwargs(self, parameters, context),
                  **method_kwargs(self, record, parameters, context, data.crs,
                                  lambda option: self.heightfield(parameters, option, context))}
        record.bind(dict(kwargs))  # bad options fail before the work
        ignored = foreign_options(record, registry_options(methods()), parameters)
        if ignored:
            feedback.pushWarning(f"tinsmith: warning: method {record.name} does not take {', '.join(ignored)}; "
                                 "left out")
        feedback.pushInfo(f"method {record.name}: {json.dumps({k: str(v)[:60] for k, v in kwargs.items()})}")
        mesh = record.function(data, progress=self.progress(feedback, 0, 85), **kwargs)
        streams = None if "streams" in kwargs else self.geometries(parameters, "STREAMS", context, data.crs)
        if streams:
            mesh = segment_outline(mesh, streams=streams)
        mesh.info["name"] = name  # 2DM's and LandXML's name
        error = source_error(mesh, data, kwargs)
        feedback.setProgress(90)
        grid = data if isinstance(data, Heightfield) else None
        path = self.write_mesh(mesh, parameters, "OUTPUT", context, feedback, grid=grid)
        feedback.pushInfo(f"{mesh.n_vertices:,} vertices, {mesh.n_triangles:,} triangles; vertical error max "
                          f"{error['max']:.3g}, RMS {error['rmse']:.3g}")
        return _results(mesh, path, error)


class TileAlgorithm(TinsmithAlgorithm):
    NAME = "tile"
    LABEL = "Simplify a large DEM in tiles"
    HELP = ("Meshes a raster of any size tile by tile, in bounded memory, reading only windows of the file; the "
            "tiles' seams are shared, so the merged mesh has no cracks and holds the vertical error bound everywhere. "
            "WORKERS > 1 runs tiles in separate Python processes. The merged mesh is loaded as a mesh layer.")

    def initAlgorithm(self, config=None):
        from ..algorithms.catalogue import TILE_METHODS

        self.addParameter(QgsProcessingParameterRasterLayer("INPUT", "DEM"))
        self.addParameter(QgsProcessingParameterEnum("METHOD", "Tile-local method", options=list(TILE_METHODS),
                                                     defaultValue="greedy", usesStaticStrings=True))
        self.addParameter(QgsProcessingParameterNumber("MAX_ERROR", "Vertical error bound (z units)",
                                                       QgsProcessingParameterNumber.Double, minValue=0.0))
        self.addParameter(QgsProcessingParameterNumber("TILE_SIZE", "Tile side (cells)",
                                                       QgsProcessingParameterNumber.Integer, defaultValue=1024,
                                                       minValue=16))
        self.addParameter(QgsProcessingParameterNumber("WORKERS", "Processes", QgsProcessingParameterNumber.Integer,
                                                       defaultValue=1, minValue=1))
        _mesh_output(self, "Merged mesh")
        _counts(self, error=False)

    def work(self, parameters, context, feedback):
        from ..tiles import tile_raster

        layer = self.raster_layer(parameters, "INPUT", context)
        report = self.progress(feedback, 0, 90)
        tiled = tile_raster(layer_path(layer), max_error=self.parameterAsDouble(parameters, "MAX_ERROR", context),
                            method=self.parameterAsEnumString(parameters, "METHOD", context),
                            tile_size=self.parameterAsInt(parameters, "TILE_SIZE", context),
                            workers=self.parameterAsInt(parameters, "WORKERS", context),
                            progress=lambda done, total: report(done / max(total, 1)))
        mesh = with_layer_crs(tiled.merge(), layer)
        path = self.write_mesh(mesh, parameters, "OUTPUT", context, feedback)
        return _results(mesh, path)


#: urban's own parameters: (QGIS name, keyword of tinsmith.city, kind, label).
_CITY = (
    ("ROOFS", "roofs", ("flat", "planes", "levels"), "Roofs: flat (LoD 1.2), planes (LoD 2.2), levels (block model)"),
    ("ROOF_HEIGHT", "roof_height", str, "Roof height statistic (median, max or pNN)"),
    ("GROUND_WINDOW", "ground_window", float, "Ground estimate window (world units)"),
    ("MIN_HEIGHT", "min_height", float, "Least building height above the ground (z units)"),
    ("MAX_RESIDUAL", "max_residual", float, "Roof planarity: largest RMS residual of a 3 x 3 plane (z units)"),
    ("STEP", "step", float, "Roof height jump that separates two buildings (z units)"),
    ("MIN_AREA", "min_area", float, "Smallest building (world units squared)"),
    ("GROUND_ERROR", "ground_error", float, "Vertical error of the ground between buildings (z units)"),
    ("SOLID", "solid", bool, "Close the model into a watertight solid"),
    ("BASE_HEIGHT", "base", float, "Height of the solid's bottom"),
    ("MARGIN", "margin", float, "Grow the domain by this much on every side (world units)"),
)


class UrbanAlgorithm(TinsmithAlgorithm):
    NAME = "urban"
    LABEL = "City model of a DSM (urban)"
    HELP = ("A city model of a surface model: buildings (found, or your footprints), roofs and terrain, as a mesh "
            "(loaded as a mesh layer when QGIS reads its format; .obj and .stl carry one group or solid per patch for "
            "a CFD mesher), and optionally the building outlines as a vector layer. Without a ground raster (DTM) "
            "the ground is estimated from the DSM.")

    def initAlgorithm(self, config=None):
        import inspect

        from ..algorithms.urban.city import city

        defaults = {k: p.default for k, p in inspect.signature(city).parameters.items()}  # the API's, shown as they are
        self.addParameter(QgsProcessingParameterRasterLayer("INPUT", "DSM"))
        self.addParameter(QgsProcessingParameterRasterLayer("GROUND", "Ground (DTM on the DSM's grid)", optional=True))
        self.addParameter(QgsProcessingParameterRasterLayer("MASK", "Where buildings may be (non-zero)", optional=True))
        self.addParameter(QgsProcessingParameterFeatureSource(
            "FOOTPRINTS", "Building footprints", [QgsProcessing.TypeVectorPolygon], optional=True))
        for name, keyword, kind, label in _CITY:
            default = defaults[keyword]
            if isinstance(kind, tuple):
                parameter = QgsProcessingParameterEnum(name, label, options=list(kind), defaultValue=default,
                                                       usesStaticStrings=True)
            elif kind is bool:
                parameter = QgsProcessingParameterBoolean(name, label, defaultValue=default)
            elif kind is str:
                parameter = QgsProcessingParameterString(name, label, defaultValue=default)
            else:
                parameter = QgsProcessingParameterNumber(name, label, QgsProcessingParameterNumber.Double,
                                                         defaultValue=default, optional=True)
            self.addParameter(parameter)
        _mesh_output(self, "City mesh")
        self.addParameter(QgsProcessingParameterFileDestination(
            "BUILDINGS", "Building outlines", "GeoPackage (*.gpkg);;GeoJSON (*.geojson)", optional=True,
            createByDefault=False))
        for name, label in (("N_VERTICES", "Vertices"), ("N_TRIANGLES", "Triangles"), ("N_BUILDINGS", "Buildings")):
            self.addOutput(QgsProcessingOutputNumber(name, label))

    def work(self, parameters, context, feedback):
        from ..algorithms.urban.city import city
        from ..io.gis_formats import write_city_outlines

        dsm = self.heightfield(parameters, "INPUT", context)
        kwargs = {}
        for name, keyword, kind, _ in _CITY:
            if parameters.get(name) in (None, ""):
                continue
            kwargs[keyword] = (self.parameterAsEnumString(parameters, name, context) if isinstance(kind, tuple)
                               else self.parameterAsBool(parameters, name, context) if kind is bool
                               else self.parameterAsString(parameters, name, context) if kind is str
                               else self.parameterAsDouble(parameters, name, context))
        for name, keyword in (("GROUND", "ground"), ("MASK", "mask")):
            if parameters.get(name) not in (None, ""):
                kwargs[keyword] = self.heightfield(parameters, name, context)
        footprints = self.geometries(parameters, "FOOTPRINTS", context, dsm.crs)
        if footprints is not None:
            kwargs["footprints"] = footprints
        feedback.setProgress(5)
        model = city(dsm, **kwargs)
        feedback.setProgress(85)
        path = self.write_mesh(model.mesh, parameters, "OUTPUT", context, feedback, grid=dsm)
        out = {"OUTPUT": path, "N_VERTICES": model.mesh.n_vertices, "N_TRIANGLES": model.mesh.n_triangles,
               "N_BUILDINGS": model.stats.get("n_buildings")}
        outlines = self.parameterAsFileOutput(parameters, "BUILDINGS", context)
        if outlines:
            write_city_outlines(model, outlines, crs=dsm.crs)
            context.addLayerToLoadOnCompletion(outlines, QgsProcessingContext.LayerDetails(
                Path(outlines).stem, context.project(), "BUILDINGS", QgsProcessingUtils.LayerHint.Vector))
            out["BUILDINGS"] = outlines
        return out


class ReconstructAlgorithm(TinsmithAlgorithm):
    NAME = "reconstruct"
    LABEL = "Reconstruct a surface from a point cloud"
    HELP = ("Projection-based surface reconstruction of a LiDAR point cloud (LAS, LAZ, XYZ): a mesh through the points "
            "themselves, overhangs and walls included in general mode. The options are the reconstruct method's.")

    def initAlgorithm(self, config=None):
        from ..algorithms.registry import get_method

        self.addParameter(QgsProcessingParameterFile("INPUT", "Point cloud", fileFilter=CLOUDS))
        self.add_classes()
        add_options(self, registry_options([get_method("reconstruct")]), advanced=False)
        _mesh_output(self)
        _counts(self, error=False)

    def work(self, parameters, context, feedback):
        from ..algorithms.registry import get_method
        from ..io import read

        record = get_method("reconstruct")
        cloud = read(self.parameterAsFile(parameters, "INPUT", context), classes=self.classes(parameters, context))
        kwargs = method_kwargs(self, record, parameters, context, cloud.crs, lambda name: None)
        mesh = record.function(cloud, progress=self.progress(feedback, 0, 90), **kwargs)
        return _results(mesh, self.write_mesh(mesh, parameters, "OUTPUT", context, feedback))


def _mesh_of(algorithm, parameters, context):
    """The mesh layer's file read by tinsmith, with the layer's CRS where the file has none."""
    from ..io import read_mesh

    layer = algorithm.parameterAsMeshLayer(parameters, "MESH", context)
    if layer is None:
        raise QgsProcessingException(f"MESH: expected a mesh layer or file, got {parameters.get('MESH')!r}")
    return with_layer_crs(read_mesh(layer_path(layer)), layer), layer


class MetricsAlgorithm(TinsmithAlgorithm):
    NAME = "metrics"
    LABEL = "Judge a mesh against a DEM"
    HELP = ("The vertical error of a mesh at every valid cell of a DEM, or every point of a point cloud (largest, "
            "RMS, mean, 99th percentile, share covered), and its triangles' quality (smallest angles in plan and in "
            "3-D, the share under 20 degrees), as tinsmith metrics gives them; optionally written to a JSON file.")

    def initAlgorithm(self, config=None):
        self.addParameter(QgsProcessingParameterMeshLayer("MESH", "Mesh"))
        self.addParameter(QgsProcessingParameterRasterLayer("DEM", "DEM", optional=True))
        self.add_points()
        self.addParameter(QgsProcessingParameterFileDestination("OUTPUT", "Metrics (JSON)", "JSON (*.json)",
                                                                optional=True, createByDefault=False))
        for name, label in _METRICS:
            self.addOutput(QgsProcessingOutputNumber(name, label))

    def work(self, parameters, context, feedback):
        from ..core import Heightfield
        from ..io._atomic import atomic_paths
        from ..metrics import mesh_metrics, source_error

        mesh, _ = _mesh_of(self, parameters, context)
        source, _ = self.elevation(parameters, "DEM", context, points=True)
        if isinstance(source, Heightfield):
            result = mesh_metrics(mesh, source)
        else:  # at every point, one a x-y (the lowest, as the TIN of the points keeps it), as the command line
            result = {**mesh_metrics(mesh), "vertical_error": source_error(mesh, source)}
        out = {name: _dig(result, name) for name, _ in _METRICS}
        path = self.parameterAsFileOutput(parameters, "OUTPUT", context)
        if path:
            with atomic_paths(Path(path)) as (tmp,):
                tmp.write_text(json.dumps(result, indent=2, default=float), encoding="utf-8")
            out["OUTPUT"] = path
        for name, label in _METRICS:
            feedback.pushInfo(f"{label}: {out[name]}")
        return out


#: The metrics' outputs: (name, label); the name spells the path into tinsmith.mesh_metrics's result.
_METRICS = (
    ("N_VERTICES", "Vertices"),
    ("N_TRIANGLES", "Triangles"),
    ("VERTICAL_ERROR_MAX", "Largest vertical error"),
    ("VERTICAL_ERROR_RMSE", "RMS vertical error"),
    ("VERTICAL_ERROR_MEAN_ABS", "Mean absolute vertical error"),
    ("VERTICAL_ERROR_P99", "99th percentile of the vertical error"),
    ("VERTICAL_ERROR_COVERAGE", "Share of the valid cells the mesh covers"),
    ("QUALITY_2D_MIN_ANGLE_MIN", "Smallest plan-view angle (degrees)"),
    ("QUALITY_3D_MIN_ANGLE_MIN", "Smallest 3-D angle (degrees)"),
    ("QUALITY_2D_SHARE_MIN_ANGLE_BELOW_20", "Share of triangles with a plan-view angle under 20 degrees"),
)


def _dig(result: dict, name: str):
    """``VERTICAL_ERROR_MAX`` -> ``result["vertical_error"]["max"]`` (the longest key that matches at each level)."""
    rest, node = name.lower(), result
    while isinstance(node, dict) and rest:
        key = max((k for k in node if rest == k or rest.startswith(k + "_")), key=len, default=None)
        if key is None:
            return None
        node, rest = node[key], rest[len(key) + 1:]
    return node if not rest else None


class ReportAlgorithm(TinsmithAlgorithm):
    NAME = "report"
    LABEL = "HTML report of a mesh against its DEM"
    HELP = ("The report tinsmith report writes: the mesh over the DEM's hillshade, maps of the vertical error, the "
            "triangles' quality, with the figures behind them, in one HTML file.")

    def initAlgorithm(self, config=None):
        self.addParameter(QgsProcessingParameterMeshLayer("MESH", "Mesh"))
        self.addParameter(QgsProcessingParameterRasterLayer("DEM", "DEM"))
        self.addParameter(QgsProcessingParameterFileDestination("OUTPUT", "Report", "HTML (*.html)"))

    def work(self, parameters, context, feedback):
        from ..viz.report import write_report

        mesh, layer = _mesh_of(self, parameters, context)
        dem = self.heightfield(parameters, "DEM", context)
        path = self.parameterAsFileOutput(parameters, "OUTPUT", context)
        write_report(path, dem, {layer.name() or "mesh": mesh},
                     dem_name=Path(layer_path(self.raster_layer(parameters, "DEM", context))).name)
        return {"OUTPUT": path}


ALGORITHMS = (SimplifyAlgorithm, TileAlgorithm, UrbanAlgorithm, ReconstructAlgorithm, MetricsAlgorithm, ReportAlgorithm)
