"""Render the pictures in the README: python docs/make_figures.py (needs the viz extra)."""

from pathlib import Path

import tinsmith
from tinsmith.viz import plot_mesh

HERE = Path(__file__).parent

hf = tinsmith.sample("st-helens")
mesh = tinsmith.simplify(hf, method="grid")
x0, y0 = 562000.0, 5113600.0  # the crater rim
plot_mesh(
    mesh,
    HERE / "img" / "st_helens_grid.png",
    window=(x0, y0, x0 + 1200.0, y0 + 1200.0),
    title="St. Helens sample, method grid (full resolution)",
)
