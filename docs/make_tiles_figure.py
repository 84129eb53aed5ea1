"""The page of ``tinsmith serve`` in headless Chromium: Delft's DTM with its canal as water, lit by its normals.

    python docs/make_tiles_figure.py    # writes docs/img/tiles_served_delft.png

Needs the test extra (playwright), Debian's chromium, CesiumJS from ``npm ci
--prefix tests/js``, and the shared data beside the project.  The pyramid is
what ``tinsmith tile ../shared/data/urban/delft_ahn3/delft_dtm_0.5m.tif
--format quantized-mesh --max-error 0.2 --normals --water
../shared/data/vector/delft_bgt/bgt_waterdeel.sqlite`` writes.
"""

import tempfile
import threading
import warnings
from pathlib import Path

from PIL import Image

from tinsmith.tiles.cesium import quantized_mesh_pyramid
from tinsmith.viz.browser import FLAGS, chromium_path
from tinsmith.viz.serve import find_cesium, make_server

HERE = Path(__file__).parent
DATA = HERE.parent / "../shared/data"
CESIUM = HERE.parent / "tests/js/node_modules/cesium/Build/Cesium"

with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
    warnings.simplefilter("ignore")  # the canal reprojected and clipped: said on the command line
    out = Path(tmp) / "delft"
    quantized_mesh_pyramid(DATA / "urban/delft_ahn3/delft_dtm_0.5m.tif", out, max_error=0.2, normals=True,
                           water=DATA / "vector/delft_bgt/bgt_waterdeel.sqlite", workers=2)
    server = make_server(out, port=0, cesium=find_cesium(CESIUM))
    threading.Thread(target=server.serve_forever, daemon=True).start()
    from playwright.sync_api import sync_playwright

    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=chromium_path(), args=FLAGS)
            page = browser.new_page(viewport={"width": 1100, "height": 700})
            errors = []
            page.on("pageerror", lambda exc: errors.append(str(exc)))
            page.goto(server.url)
            page.wait_for_selector("body[data-ready]", state="attached", timeout=180_000)
            status = page.evaluate("window.tinsmith")
            assert status["state"] == "terrain" and not status["errors"] and not errors, (status, errors)
            page.wait_for_timeout(1500)  # the water's waves are drawn over time
            page.screenshot(path=str(Path(tmp) / "page.png"))
            browser.close()
    finally:
        server.shutdown()
        server.server_close()
    Image.open(Path(tmp) / "page.png").convert("RGB").save(HERE / "img/tiles_served_delft.png", optimize=True)
print("wrote", HERE / "img/tiles_served_delft.png")
