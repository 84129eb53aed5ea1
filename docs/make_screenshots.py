"""Screenshots of the HTML report and the 3-D viewer of St. Helens in headless Chromium.

    python docs/make_screenshots.py    # writes docs/img/report_st_helens.png and docs/img/viewer_st_helens.png

Needs the test extra (playwright) and Debian's chromium; the same pages the
browser tests load (tests/test_report.py).
"""

import tempfile
from pathlib import Path

from PIL import Image

import tinsmith
from tinsmith.viz.browser import render_page
from tinsmith.viz.report import write_report
from tinsmith.viz.viewer import write_viewer

IMG = Path(__file__).parent / "img"

hf = tinsmith.sample("st-helens")
meshes = {"greedy": tinsmith.greedy(hf, max_error=5), "quadtree": tinsmith.quadtree(hf, max_error=5),
          "cvt": tinsmith.cvt(hf, max_vertices=8000)}
with tempfile.TemporaryDirectory() as tmp:
    tmp = Path(tmp)
    write_report(tmp / "report.html", hf, meshes, dem_name="st-helens",
                 settings={"greedy": "max_error 5", "quadtree": "max_error 5", "cvt": "max_vertices 8000"})
    result = render_page(tmp / "report.html", tmp / "report.png", full_page=True)
    assert not result["errors"] and not [m for m in result["console"] if m[0] == "error"], result
    page = Image.open(tmp / "report.png")
    page.crop((0, 0, page.width, min(page.height, 2000))).resize((page.width // 2, min(page.height, 2000) // 2)).save(
        IMG / "report_st_helens.png", optimize=True)
    write_viewer(meshes["greedy"], tmp / "view.html", title="St. Helens, greedy, max error 5 m", exaggeration=1.5)
    result = render_page(tmp / "view.html", IMG / "viewer_st_helens.png", wait_for="body[data-ready]")
    assert result["ready"] == "1" and not result["errors"], result
print("wrote", IMG / "report_st_helens.png", IMG / "viewer_st_helens.png")
