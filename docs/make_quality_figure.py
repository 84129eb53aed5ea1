"""Draw docs/img/method_quality.png: greedy insertion and the quality method at the same error bound.

The St. Helens sample at max_error 20: greedy's mesh, and quality's with a 30-degree bound and a
region (a band across the crater with its own max_area) drawn in colour, by refinement alone
(``improve=0``) and with the default improvement passes.

    python docs/make_quality_figure.py
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import shapely  # noqa: E402

import tinsmith  # noqa: E402

HERE = Path(__file__).resolve().parent


def main() -> None:
    hf = tinsmith.sample("st-helens")
    x0, y0, x1, y1 = hf.bounds
    band = shapely.LineString([(x0, y0 + 0.35 * (y1 - y0)), (x1, y0 + 0.65 * (y1 - y0))]).buffer(500.0)
    greedy = tinsmith.greedy(hf, max_error=20.0)
    refined, quality = (tinsmith.simplify(hf, method="quality", max_error=20.0, min_angle=30.0, improve=improve,
                                          regions=[(band, 5000.0, "band")]) for improve in (0, 30))
    fig, axes = plt.subplots(1, 3, figsize=(13.5, 6.4))
    for ax, mesh, title in [
        (axes[0], greedy, f"greedy, max_error 20:\n{greedy.n_vertices:,} vertices"),
        (axes[1], refined, f"quality, refinement alone (improve 0):\n{refined.n_vertices:,} vertices"),
        (axes[2], quality, f"quality (default, improved):\n{quality.n_vertices:,} vertices"),
    ]:
        x, y = mesh.vertices[:, 0], mesh.vertices[:, 1]
        region = mesh.triangle_attributes.get("region")
        if region is not None:
            inside = mesh.triangles[region == 1]
            ax.tripcolor(x, y, inside, facecolors=[1.0] * len(inside), cmap="Blues", vmin=0, vmax=2.5,
                         edgecolors="none")
        ax.triplot(x, y, mesh.triangles, color="black", linewidth=0.25)
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title(title, fontsize=10)
    fig.tight_layout()
    out = HERE / "img" / "method_quality.png"
    fig.savefig(out, dpi=90, bbox_inches="tight")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
