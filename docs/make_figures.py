"""Render the pictures of the README and of the method pages: python docs/make_figures.py (needs the viz extra).

Every method meshes the St. Helens sample with the same budget, 8,000
vertices (5.4% of the cells; the quadtree with the diagonal rule needs 6,019
at least, for the full-resolution strips along the edges of the data), and the close-up frames the same window on
the crater rim; the captions carry the measured vertical error.
"""

from pathlib import Path

import tinsmith
from tinsmith.viz import plot_mesh

HERE = Path(__file__).parent
IMG = HERE / "img"
BUDGET = 8000

hf = tinsmith.sample("st-helens")
x0, y0 = 562000.0, 5113600.0  # the crater rim
window = (x0, y0, x0 + 1200.0, y0 + 1200.0)
wide = (x0 - 600.0, y0 - 600.0, x0 + 1800.0, y0 + 1800.0)

plot_mesh(
    tinsmith.simplify(hf, method="grid"),
    IMG / "st_helens_grid.png",
    window=window,
    title="St. Helens sample, method grid (full resolution)",
)
greedy = tinsmith.simplify(hf, method="greedy", max_error=5)
plot_mesh(
    greedy,
    IMG / "st_helens_greedy.png",
    window=wide,
    title=f"St. Helens sample, method greedy, max_error 5 m: {greedy.n_vertices:,} of {hf.n_valid:,} cells",
)

runs = [
    ("greedy", {}),
    ("subsample", {}),
    ("features", {"measure": "sobel"}),
    ("quadtree", {}),
    ("quadtree", {"diagonal": "rule"}),
    ("decimate", {}),
]
for name, options in runs:
    mesh = tinsmith.simplify(hf, method=name, max_vertices=BUDGET, **options)
    err = tinsmith.vertical_error(mesh, hf)
    label = name + "".join(f", {k}={v}" for k, v in options.items())
    suffix = "".join(f"_{v}" for v in options.values())
    plot_mesh(
        mesh,
        IMG / f"method_{name}{suffix}.png",
        window=wide,
        title=f"{label}, max_vertices {BUDGET:,}: max error {err['max']:.1f} m, RMS {err['rmse']:.2f} m",
    )
    print(f"{label}: {mesh.n_vertices} vertices, {mesh.n_triangles} triangles, max {err['max']:.2f}, rmse {err['rmse']:.3f}")
