"""Render the pictures in the README: python docs/make_figures.py (needs the viz extra)."""

from pathlib import Path

import tinsmith
from tinsmith.viz import plot_mesh

HERE = Path(__file__).parent

hf = tinsmith.sample("st-helens")
x0, y0 = 562000.0, 5113600.0  # the crater rim
window = (x0, y0, x0 + 1200.0, y0 + 1200.0)
plot_mesh(
    tinsmith.simplify(hf, method="grid"),
    HERE / "img" / "st_helens_grid.png",
    window=window,
    title="St. Helens sample, method grid (full resolution)",
)
greedy = tinsmith.simplify(hf, method="greedy", max_error=5)
plot_mesh(
    greedy,
    HERE / "img" / "st_helens_greedy.png",
    window=(x0 - 600.0, y0 - 600.0, x0 + 1800.0, y0 + 1800.0),
    title=f"St. Helens sample, method greedy, max_error 5 m: {greedy.n_vertices:,} of 148,885 cells",
)
