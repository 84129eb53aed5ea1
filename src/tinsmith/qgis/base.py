"""What every tinsmith algorithm in QGIS shares: QGIS layers in, meshes out as layers with their CRS, errors and
progress the Processing way.

- Rasters come in as the files of QGIS raster layers (read by tinsmith, so a
  run in QGIS and the same run through the API read the same heights); a
  CRS the user set on the layer stands in for one the file lacks.
- Vector layers come in as shapely geometries in the raster's CRS: QGIS
  reprojects the features (any CRS, memory layers, selections), so no file
  is needed.
- A mesh file an algorithm writes is loaded as a mesh layer when QGIS reads
  its format (MDAL: 2DM, UGRID NetCDF, PLY, SELAFIN), and the CRS is set on
  the layer: 2DM has no place for one, and QGIS does not read the ``.prj``
  beside it.
- A :class:`~tinsmith.errors.TinsmithError` becomes a ``QgsProcessingException``
  with the command line's one line (``tinsmith: error: ...``); QGIS's cancel
  button stops a run at its next progress report.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

from qgis.core import (
    QgsCoordinateReferenceSystem,
    QgsFeatureRequest,
    QgsMeshLayer,
    QgsProcessingAlgorithm,
    QgsProcessingContext,
    QgsProcessingException,
    QgsProcessingLayerPostProcessorInterface,
    QgsProcessingParameterFile,
    QgsProcessingParameterString,
    QgsProcessingUtils,
)

from ..errors import TinsmithError

__all__ = ["CLOUDS", "Cancelled", "TinsmithAlgorithm", "layer_path", "mesh_filter", "with_layer_crs"]

#: The file filter of point-cloud inputs (QGIS 3.22 as Debian builds it has no point-cloud layers: no PDAL).
CLOUDS = "Point clouds (*.las *.laz *.xyz *.txt *.csv *.LAS *.LAZ)"


class Cancelled(QgsProcessingException):
    """The user pressed cancel."""


def layer_path(layer) -> str:
    """The file behind a layer: its source without GDAL/MDAL's decorations (``driver:"file":name``, ``|layername``)."""
    source = layer.source() if hasattr(layer, "source") else str(layer)
    quoted = re.search(r'"([^"]+)"', source)
    return quoted.group(1) if quoted else source.split("|")[0]


def with_layer_crs(data, layer):
    """``data`` (read from the layer's file) with the CRS the user set on the layer where the file has none."""
    if not data.crs and layer.crs().isValid():
        data.crs = layer.crs().toWkt()
    return data


def mesh_filter() -> str:
    """The file filter of a mesh output: every format tinsmith writes, UGRID and 2DM first (QGIS reads them)."""
    from ..io import WRITERS

    first = [".nc", ".2dm"]
    suffixes = first + sorted(s for s in WRITERS if s not in first and s not in (".tif", ".tiff", ".png"))
    return ";;".join(f"{WRITERS[s].description.split(' (')[0]} (*{s} *{s.upper()})" for s in suffixes)


class _SetCrs(QgsProcessingLayerPostProcessorInterface):
    """Sets the CRS on a mesh layer QGIS loads when the algorithm has run."""

    def __init__(self, wkt: str):
        super().__init__()
        self.wkt = wkt

    def postProcessLayer(self, layer, context, feedback):
        if layer is not None and self.wkt:
            layer.setCrs(QgsCoordinateReferenceSystem.fromWkt(self.wkt))


#: The post-processors of the layers still to load (QGIS does not own them): path -> processor.
_POST: dict[str, _SetCrs] = {}


class TinsmithAlgorithm(QgsProcessingAlgorithm):
    """A tinsmith algorithm: subclasses give ``NAME``, ``LABEL``, ``HELP``, ``initAlgorithm`` and ``work``.

    ``work(parameters, context, feedback)`` does the work with the helpers
    below; :meth:`processAlgorithm` turns tinsmith's errors into Processing's.
    """

    NAME = ""
    LABEL = ""
    HELP = ""

    def name(self) -> str:
        return self.NAME

    def displayName(self) -> str:
        return self.LABEL

    def shortHelpString(self) -> str:
        return self.HELP

    def createInstance(self):
        return type(self)()

    def processAlgorithm(self, parameters, context, feedback):
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                try:
                    return self.work(parameters, context, feedback)
                finally:
                    for warning in caught:  # tinsmith's warnings (slivers, nodata, ...) in the log, one line each
                        if feedback is not None:
                            feedback.pushWarning(f"tinsmith: warning: {warning.message}")
        except QgsProcessingException:
            raise
        except (TinsmithError, OSError, MemoryError) as exc:
            raise QgsProcessingException(f"tinsmith: error: {exc}") from exc

    def work(self, parameters, context, feedback) -> dict:
        raise NotImplementedError

    # -- progress -------------------------------------------------------------------------------

    @staticmethod
    def progress(feedback, start: float = 0.0, stop: float = 100.0):
        """A tinsmith progress callback (a fraction 0..1) reporting ``start``..``stop`` percent; it raises
        :class:`Cancelled` once the user cancels."""

        def report(fraction) -> None:
            if feedback is not None and feedback.isCanceled():
                raise Cancelled("tinsmith: cancelled")
            if feedback is not None:
                feedback.setProgress(start + (stop - start) * min(max(float(fraction), 0.0), 1.0))

        return report

    # -- inputs ---------------------------------------------------------------------------------

    def raster_layer(self, parameters, name: str, context):
        """The raster layer of parameter ``name``; a Processing error naming it when there is none."""
        layer = self.parameterAsRasterLayer(parameters, name, context)
        if layer is None:
            raise QgsProcessingException(f"{name}: expected a raster layer or file, got {parameters.get(name)!r}")
        return layer

    def add_classes(self) -> None:
        """The parameter :meth:`classes` reads: ``CLASSES``."""
        self.addParameter(QgsProcessingParameterString("CLASSES", "Point classes to keep (e.g. 2 for ground)",
                                                       optional=True))

    def add_points(self) -> None:
        """The parameters :meth:`elevation` reads beside the raster: ``POINTS`` and ``CLASSES``."""
        self.addParameter(QgsProcessingParameterFile("POINTS", "Point cloud (instead of a DEM)", optional=True,
                                                     fileFilter=CLOUDS))
        self.add_classes()

    def classes(self, parameters, context) -> list[int] | None:
        """The point classes of parameter ``CLASSES`` ("2", "2, 9"), or None for every point."""
        text = self.parameterAsString(parameters, "CLASSES", context) if parameters.get("CLASSES") else ""
        try:
            return [int(c) for c in text.replace(",", " ").split()] or None
        except ValueError:
            raise QgsProcessingException(f"CLASSES: expected class codes such as 2 or 2, 9, got {text!r}") from None

    def elevation(self, parameters, raster: str, context, *, points: bool):
        """(the heights, their name): the raster parameter ``raster`` (a DEM), or the point-cloud file of ``POINTS``
        with the classes of ``CLASSES``, kept as points with ``points`` and gridded without."""
        from ..io import read

        given = [name for name in (raster, "POINTS") if parameters.get(name) not in (None, "")]
        if len(given) != 1:
            raise QgsProcessingException(f"give {raster} (a DEM) or POINTS (a point-cloud file): one of them, got "
                                         + (" and ".join(given) or "neither"))
        if given == [raster]:
            return self.heightfield(parameters, raster, context), self.raster_layer(parameters, raster, context).name()
        path = self.parameterAsFile(parameters, "POINTS", context)
        cloud = read(path, classes=self.classes(parameters, context))
        return (cloud if points else cloud.to_heightfield()), Path(path).stem

    def heightfield(self, parameters, name: str, context):
        """The raster layer's file read by tinsmith; the layer's CRS where the file has none."""
        from ..io import read_heightfield

        layer = self.raster_layer(parameters, name, context)
        return with_layer_crs(read_heightfield(layer_path(layer)), layer)

    def geometries(self, parameters, name: str, context, crs: str | None, fields=()):
        """The features of a vector parameter as shapely geometries in ``crs`` (None: not given); with ``fields``,
        ``(geometry, value, ...)`` items, a missing field None."""
        import shapely

        source = self.parameterAsSource(parameters, name, context)
        if source is None:
            return None
        request = QgsFeatureRequest()
        if crs:
            request.setDestinationCrs(QgsCoordinateReferenceSystem.fromWkt(crs), context.transformContext())
        names = {f.name().lower(): f.name() for f in source.fields()}
        items = []
        for feature in source.getFeatures(request):
            geometry = feature.geometry()
            if geometry is None or geometry.isEmpty():
                continue
            shape = shapely.from_wkb(bytes(geometry.asWkb()))
            if fields:
                values = [feature[names[f]] if f in names else None for f in fields]
                items.append((shape, *[None if v is None or v == "" or str(v) == "NULL" else v for v in values]))
            else:
                items.append(shape)
        return items

    # -- outputs --------------------------------------------------------------------------------

    def write_mesh(self, mesh, parameters, name: str, context, feedback, grid=None) -> str:
        """Write ``mesh`` to the file of output ``name`` and have QGIS load it as a mesh layer with the mesh's CRS."""
        from ..io import write

        path = self.parameterAsFileOutput(parameters, name, context)
        if not path:
            raise QgsProcessingException(f"{name}: expected an output file name")
        write(mesh, path, grid=grid)
        self.load_mesh(path, mesh.crs, name, context, feedback)
        return path

    @staticmethod
    def load_mesh(path: str, crs: str | None, name: str, context, feedback) -> None:
        """Have QGIS load ``path`` as a mesh layer when the run ends, with ``crs`` set on it (when QGIS reads the
        format; a word in the log otherwise)."""
        probe = QgsMeshLayer(path, Path(path).stem, "mdal")
        if not probe.isValid():
            if feedback is not None:
                feedback.pushInfo(f"{Path(path).name}: written; QGIS does not read this format as a mesh layer")
            return
        details = QgsProcessingContext.LayerDetails(Path(path).stem, context.project(), name,
                                                    QgsProcessingUtils.LayerHint.Mesh)
        _POST[path] = _SetCrs(crs or "")
        details.setPostProcessor(_POST[path])
        context.addLayerToLoadOnCompletion(path, details)
