"""Draw docs/img/method_flood.png: the quality and flood methods at the same error bound, triangles coloured by the
time step an explicit solver could take on them.

The St. Helens sample at max_error 10: each triangle's expected CFL step (inradius over the wave speed of the
expected flow, :func:`tinsmith.algorithms.flood.flood.wave_speed`), the stream breaklines, the outflow segments
of flood's outline and the triangles where its time step relaxed the error bound.

    python docs/make_flood_figure.py
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import LogNorm  # noqa: E402

import tinsmith  # noqa: E402
from tinsmith.algorithms.flood import flood as F  # noqa: E402
from tinsmith.io.boundaries import named_boundaries  # noqa: E402

HERE = Path(__file__).resolve().parent
BOUND = 10.0


def main() -> None:
    hf = tinsmith.sample("st-helens")
    speed = F.wave_speed(hf, None, 100.0, 0.03)
    quality = tinsmith.quality(hf, max_error=BOUND)
    flood = tinsmith.flood(hf, max_error=BOUND)
    report = flood.info["flood"]
    norm = LogNorm(vmin=0.5, vmax=100.0)
    fig, axes = plt.subplots(1, 3, figsize=(16, 7.2))
    for ax, mesh, title in [
        (axes[0], quality, f"quality, max_error {BOUND:g} m: {quality.n_triangles:,} triangles,\n"
                           f"smallest step {F.triangle_steps(quality, hf, speed).min():.2f} s"),
        (axes[1], flood, f"flood, max_error {BOUND:g} m, time step auto {report['time_step']:.1f} s:\n"
                         f"{flood.n_triangles:,} triangles, smallest step {report['min_step']:.2f} s"),
    ]:
        x, y = mesh.vertices[:, 0], mesh.vertices[:, 1]
        image = ax.tripcolor(x, y, mesh.triangles, facecolors=F.triangle_steps(mesh, hf, speed), norm=norm, cmap="viridis",
                             edgecolors="none")
        ax.triplot(x, y, mesh.triangles, color="white", linewidth=0.15)
        ax.set_title(title, fontsize=9)
    x, y = flood.vertices[:, 0], flood.vertices[:, 1]
    border = {tuple(sorted(e)) for lp in named_boundaries(flood)["outline"] for e in zip(lp[:-1], lp[1:], strict=True)}
    for a, b in np.asarray(flood.constrained_edges).reshape(-1, 2):
        if (min(a, b), max(a, b)) not in border:  # the stream breaklines
            axes[1].plot(x[[a, b]], y[[a, b]], color="blue", linewidth=2.0)
    for name, ids in flood.node_strings.items():
        if name.startswith("outflow"):
            axes[1].plot(x[ids], y[ids], color="red", linewidth=3)
    fig.colorbar(image, ax=axes[:2], shrink=0.6, location="bottom",
                 label="expected CFL step (s): inradius / (|u| + sqrt(g h)) of the expected flow")
    err, _ = F._triangle_errors(flood, hf)
    ratio = np.where(err > BOUND * (1 + 1e-9), err / BOUND, np.nan)
    cmap = plt.get_cmap("magma_r").copy()
    cmap.set_under("white")
    relaxed = axes[2].tripcolor(x, y, flood.triangles, facecolors=np.nan_to_num(ratio, nan=0.0), cmap=cmap,
                                vmin=1.0, vmax=5.0, edgecolors="none")
    axes[2].triplot(x, y, flood.triangles, color="grey", linewidth=0.1)
    r = report["relaxed"]
    axes[2].set_title(f"flood: where the time step relaxed the bound ({r['triangles']:,} triangles, "
                      f"{100 * r['area_share']:.0f}% of the area;\nworst {r['max_error']:.0f} m); white: within "
                      f"{BOUND:g} m", fontsize=9)
    fig.colorbar(relaxed, ax=axes[2], shrink=0.6, location="bottom", label="largest error / max_error")
    for ax in axes:
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
    fig.text(0.35, 0.96, "blue: stream breaklines; red: outflow segments of the outline", ha="center", fontsize=9)
    out = HERE / "img" / "method_flood.png"
    fig.savefig(out, dpi=80, bbox_inches="tight")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
