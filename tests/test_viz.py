"""Pictures leave the caller's matplotlib alone: no backend chosen or switched, no pyplot figure left open."""

from __future__ import annotations

import subprocess
import sys

import pytest

pytest.importorskip("matplotlib")

# A fresh interpreter whose user has chosen a backend (svg here; a notebook's would be inline) before tinsmith
# draws anything: every picture the library makes must leave that choice as it was.
CHILD = """
import io, sys
import matplotlib
matplotlib.use("svg")
import tinsmith
from tinsmith.viz import figures, plot

hf = tinsmith.sample("st-helens")
mesh = tinsmith.simplify(hf, method="subsample", step=16)
out = sys.argv[1]
plot.plot_mesh(mesh, out + "/mesh.png")
figures.plot_hillshades(hf, {"m": mesh}, out + "/hillshades.png")
figures.plot_error(mesh, hf, out + "/error.png")
figures.plot_wireframe(mesh, hf, out + "/wireframe.png")
figures.plot_quality({"m": mesh}, out + "/quality.png")
figures.plot_contours(mesh, hf, out + "/contours.png")
figures.save(figures.figure_error(mesh, hf), io.BytesIO())
assert "<img src='data:image/png;base64," in mesh._repr_html_()
print(matplotlib.get_backend(), "matplotlib.pyplot" in sys.modules)
"""


def test_pictures_keep_the_users_backend(tmp_path):
    done = subprocess.run([sys.executable, "-c", CHILD, str(tmp_path)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["svg", "False"]
    assert all((tmp_path / f"{name}.png").stat().st_size > 1000
               for name in ("mesh", "hillshades", "error", "wireframe", "quality", "contours"))
