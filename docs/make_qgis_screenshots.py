"""Screenshots of tinsmith in QGIS, taken headless: the Processing toolbox, and a quality mesh over the hillshade.

    python docs/make_qgis_screenshots.py   # writes docs/img/qgis_toolbox.png and docs/img/qgis_mesh.png

Needs Debian's python3-qgis and qgis-providers (QGIS 3.22), as the tests do
(tests/qgis_session.py), and the shared data beside the project (Big Tujunga).
"""

import json
import os
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # tests.qgis_session
os.environ["QT_QPA_PLATFORM"] = "offscreen"
if "XDG_RUNTIME_DIR" not in os.environ:  # Qt wants one of its own (0700)
    os.environ["XDG_RUNTIME_DIR"] = tempfile.mkdtemp(prefix="xdg-")
os.environ.setdefault("GDAL_PAM_ENABLED", "NO")
from tests.qgis_session import DIST_PACKAGES, PLUGINS  # noqa: E402

sys.path += [str(DIST_PACKAGES), str(PLUGINS)]
from qgis.core import (  # noqa: E402
    QgsApplication,
    QgsBilinearRasterResampler,
    QgsHillshadeRenderer,
    QgsMapRendererSequentialJob,
    QgsMapSettings,
    QgsMeshLayer,
    QgsRasterLayer,
)
from qgis.PyQt.QtCore import QSize  # noqa: E402
from qgis.PyQt.QtGui import QColor  # noqa: E402

IMG = Path(__file__).parent / "img"
DEM = Path(__file__).resolve().parents[2] / "shared" / "data" / "terrain" / "big_tujunga_canyon" / "srtm_bigtujunga30m_utm11.tif"

QgsApplication.setPrefixPath("/usr", True)
app = QgsApplication([], True)  # widgets: the toolbox
app.initQgis()
import processing  # noqa: E402
from processing.core.Processing import Processing  # noqa: E402

Processing.initialize()
from qgis.gui import QgsProcessingToolboxTreeView  # noqa: E402

from tinsmith.qgis import TinsmithProvider  # noqa: E402

provider = TinsmithProvider()
QgsApplication.processingRegistry().addProvider(provider)

# -- the toolbox, filtered to tinsmith's algorithms --------------------------------------------------------
toolbox = QgsProcessingToolboxTreeView(None, QgsApplication.processingRegistry())
toolbox.setFilterString("tinsmith")
toolbox.expandAll()
toolbox.header().hide()
toolbox.resize(420, 200)
toolbox.grab().save(str(IMG / "qgis_toolbox.png"))

# -- a quality mesh with a breakline, run through Processing, over the DEM's hillshade ------------------------
with tempfile.TemporaryDirectory() as tmp:
    import tinsmith

    hf = tinsmith.read_heightfield(DEM)
    x0, y0, x1, y1 = hf.bounds
    line = [[x0 + 3000.0, y0 + 3000.0], [x1 - 3000.0, y1 - 3000.0]]
    breaklines = Path(tmp) / "breakline.geojson"
    breaklines.write_text(json.dumps({"type": "FeatureCollection",
                                      "crs": {"type": "name", "properties": {"name": "EPSG:32611"}},
                                      "features": [{"type": "Feature", "properties": {},
                                                    "geometry": {"type": "LineString", "coordinates": line}}]}))
    out = Path(tmp) / "big_tujunga.2dm"
    processing.run("tinsmith:simplify", {"INPUT": str(DEM), "METHOD": "quality", "MAX_ERROR": 40.0,
                                         "BREAKLINES": str(breaklines), "OUTPUT": str(out)})
    dem = QgsRasterLayer(str(DEM), "dem")
    shade = QgsHillshadeRenderer(dem.dataProvider(), 1, 315.0, 45.0)
    shade.setZFactor(0.35)
    dem.setRenderer(shade)
    dem.resampleFilter().setZoomedInResampler(QgsBilinearRasterResampler())
    mesh = QgsMeshLayer(str(out), "mesh", "mdal")
    mesh.setCrs(dem.crs())  # what the provider does when it loads a 2DM
    settings = mesh.rendererSettings()
    frame = settings.nativeMeshSettings()
    frame.setEnabled(True)
    frame.setColor(QColor(200, 30, 30))
    frame.setLineWidth(0.2)
    settings.setNativeMeshSettings(frame)
    settings.setActiveScalarDatasetGroup(-1)
    mesh.setRendererSettings(settings)
    mapping = QgsMapSettings()
    mapping.setLayers([mesh, dem])
    mapping.setDestinationCrs(dem.crs())
    extent = dem.extent()
    extent.scale(0.3)  # the middle, where the triangles can be told apart
    mapping.setExtent(extent)
    mapping.setOutputSize(QSize(900, 520))
    mapping.setBackgroundColor(QColor(255, 255, 255))
    job = QgsMapRendererSequentialJob(mapping)
    job.start()
    job.waitForFinished()
    job.renderedImage().save(str(IMG / "qgis_mesh.png"))
print("wrote", IMG / "qgis_toolbox.png", IMG / "qgis_mesh.png")
