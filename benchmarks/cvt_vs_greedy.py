"""cCVT (Duan et al. 2016) against greedy insertion: Table 1, the anchor / fitted-heights trade-off, convergence, time.

    pip install -e ".[test]"
    python benchmarks/cvt_vs_greedy.py          # writes benchmarks/RESULTS_cvt.md and docs/img/cvt_*.png

On St. Helens (the sample) and Big Tujunga (shared data), at 1% and 5% of the
valid cells:

* Table 1 (see ``cvt_table1.py``) for pure cCVT (``anchor_fraction=0``, the
  default options) and greedy insertion at the same vertex count;
* the trade-off: ``anchor_fraction`` 0, 0.25, 0.5, 0.75, each with the DEM's
  heights at the vertices and with fitted heights (least squares over every
  cell, :func:`tinsmith.fit_heights`); RMSE over every cell as a ratio to
  greedy's (interpolating, and fitted too), max and 99th-percentile aspect
  ratio, share of min angle >= 30 degrees;
* convergence on St. Helens at 1%: the energy per iteration of plain Lloyd,
  Anderson and L-BFGS (``tol=0``, 100 iterations), and the time of the
  default run (curvature and every iteration included), median of 3.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np
from _common import HERE, ROOT, SHARED, ST_HELENS, machine
from cvt_table1 import HEADER, row, table1

DEMS = [
    ("St. Helens 30 m", ST_HELENS),
    ("Big Tujunga 30 m", SHARED / "data/terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif"),
]
IMG = ROOT / "docs/img"


def tradeoff(hf, ratio, fractions):
    import tinsmith
    from tinsmith import metrics

    n = max(4, int(round(ratio * hf.n_valid)))
    greedy = tinsmith.greedy(hf, max_vertices=n)
    g = metrics.vertical_error(greedy, hf)["rmse"]
    g_fit = metrics.vertical_error(tinsmith.fit_heights(greedy, hf), hf)["rmse"]
    lines = [
        f"greedy at {n:,} vertices: RMSE {g:.2f} (fitted heights: {g_fit:.2f})",
        "",
        "| anchor_fraction | heights | RMSE | RMSE / greedy | RMSE / greedy fitted | max error | max aspect | "
        "p99 aspect | min angle >= 30 | time |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    results = []
    for fraction in fractions:
        start = time.perf_counter()
        mesh = tinsmith.cvt(hf, max_vertices=n, anchor_fraction=fraction)
        seconds = time.perf_counter() - start
        ar = metrics.aspect_ratios(mesh)
        angle = metrics.triangle_angles(mesh).min(axis=1)
        for label, m in (("DEM", mesh), ("fitted", tinsmith.fit_heights(mesh, hf))):
            e = metrics.vertical_error(m, hf)
            r = {"fraction": fraction, "heights": label, "rmse": e["rmse"], "ratio": e["rmse"] / g,
                 "ratio_fit": e["rmse"] / g_fit, "max": e["max"], "aspect_max": float(ar.max()),
                 "aspect_p99": float(np.percentile(ar, 99)), "angle30": float(np.mean(angle >= 30))}
            results.append(r)
            lines.append(
                f"| {fraction:g} | {label} | {r['rmse']:.2f} | {r['ratio']:.3f} | {r['ratio_fit']:.3f} | {r['max']:.1f} | "
                f"{r['aspect_max']:.2f} | {r['aspect_p99']:.2f} | {100 * r['angle30']:.1f}% | {seconds:.1f} s |"
            )
            print(label, fraction, {k: round(v, 3) if isinstance(v, float) else v for k, v in r.items()}, flush=True)
    return lines, results


def convergence(hf, ratio, iterations):
    import tinsmith

    curves = {}
    for acc in ("lloyd", "anderson", "lbfgs"):
        mesh = tinsmith.cvt(hf, ratio=ratio, acceleration=acc, tol=0.0, max_iter=iterations)
        info = mesh.info["cvt"]
        curves[acc] = (np.array(info["energy"]), info["evaluations"], info["rejected_steps"])
    best = min(c[0].min() for c in curves.values())
    target = curves["lloyd"][0][-1]
    lines = [
        f"Energy relative to the start; target: plain Lloyd's energy after {iterations} iterations "
        f"({target / curves['lloyd'][0][0]:.4f}).",
        "",
        "| method | 5 | 10 | 20 | 50 | " + f"{iterations} | iterations to reach the target | evaluations | rejected steps |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for acc, (e, evals, rejected) in curves.items():
        rel = e / e[0]
        reach = np.flatnonzero(e <= target)
        lines.append(
            f"| {acc} | " + " | ".join(f"{rel[k]:.4f}" for k in (5, 10, 20, 50, iterations))
            + f" | {reach[0] if len(reach) else 'not reached'} | {evals} | {rejected} |"
        )
    _plot_energy(curves, best)
    return lines


def _plot_energy(curves, best):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.2), constrained_layout=True)
    names = {"lloyd": "plain Lloyd", "anderson": "Anderson (window 5)", "lbfgs": "L-BFGS (window 5)"}
    for acc, (e, _, _) in curves.items():
        ax.semilogy(np.arange(len(e)), (e - best * 0.999) / e[0], label=names[acc])
    ax.set_xlabel("iteration")
    ax.set_ylabel("(E - 0.999 E_best) / E_0")
    ax.set_title("cCVT energy, St. Helens at 1% of the cells")
    ax.legend()
    fig.savefig(IMG / "cvt_energy.png", dpi=90)
    plt.close(fig)


def _plot_meshes(hf, cvt, greedy, c_row, g_row):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    xmin, ymin, xmax, ymax = hf.bounds
    fig, axes = plt.subplots(1, 2, figsize=(12, 8.4), constrained_layout=True)
    for ax, mesh, name, r in ((axes[0], cvt, "cCVT", c_row), (axes[1], greedy, "greedy", g_row)):
        ax.imshow(np.where(hf.valid, hf.z, np.nan), extent=(xmin, xmax, ymin, ymax), cmap="terrain")
        ax.triplot(mesh.vertices[:, 0], mesh.vertices[:, 1], mesh.triangles, lw=0.35, color="k")
        ax.set_title(f"{name}: {mesh.n_vertices:,} vertices, RMSE {r['cell_rmse']:.1f} m, "
                     f"max aspect {r['aspect_max']:.1f}")
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle("St. Helens at 1% of the cells")
    fig.savefig(IMG / "cvt_vs_greedy.png", dpi=80)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ratios", type=float, nargs="+", default=[0.01, 0.05])
    ap.add_argument("--fractions", type=float, nargs="+", default=[0.0, 0.25, 0.5, 0.75])
    ap.add_argument("--interval", type=float, default=80.0)
    ap.add_argument("--iterations", type=int, default=100)
    ap.add_argument("--out", default=str(HERE / "RESULTS_cvt.md"))
    args = ap.parse_args()

    import tinsmith

    tinsmith.cvt(tinsmith.sample("st-helens"), ratio=0.002, max_iter=3)  # kernels loaded (compiled) first
    lines = [
        "# cCVT (Duan et al. 2016) against greedy insertion",
        "",
        "Command: `python benchmarks/cvt_vs_greedy.py` (Table 1 alone for any DEM: "
        "`python benchmarks/cvt_table1.py DEM --ratio 0.01`)  ",
        f"{machine()}. Heights, errors and distances in metres; aspect ratio in 3-D, 1 for equilateral; "
        f"contours every {args.interval:g} m. Errors at centroids are on the vertical lines through every cCVT "
        "triangle's centroid (the paper's measure), for both meshes.",
    ]
    acceptance = []
    for label, path in DEMS:
        if not Path(path).exists():
            print(f"skipped {label}: {path} not found")
            continue
        hf = tinsmith.read_heightfield(path)
        h, w = hf.shape
        for ratio in args.ratios:
            c, g, cvt, greedy = table1(hf, ratio=ratio, interval=args.interval)
            title = f"{label}, {h} x {w} ({hf.n_valid:,} valid cells), {ratio:.0%} of the cells"
            lines += ["", f"## {title}", "", "### Table 1: pure cCVT (anchor_fraction 0) and greedy", "", HEADER,
                      row("cCVT", c), row("greedy", g), "",
                      f"RMSE ratio cCVT / greedy: {c['cell_rmse'] / g['cell_rmse']:.3f} over every cell, "
                      f"{c['centroid_rmse'] / g['centroid_rmse']:.3f} at the centroids. "
                      f"cCVT iterations: {cvt.info['cvt']['iterations']} ({cvt.info['cvt']['stop_reason']})."]
            acceptance.append(
                f"| {label}, {ratio:.0%} | {c['aspect_max']:.2f} | {100 * c['angle30']:.1f}% | "
                f"{c['cell_rmse'] / g['cell_rmse']:.3f} | {'yes' if c['aspect_max'] <= 5 and c['angle30'] >= 0.95 else 'no'} |"
            )
            print(title, row("cCVT", c), row("greedy", g), sep="\n", flush=True)
            if label.startswith("St. Helens") and ratio == 0.01:
                _plot_meshes(hf, cvt, greedy, c, g)
            t_lines, _ = tradeoff(hf, ratio, args.fractions)
            lines += ["", "### Trade-off: anchors from greedy insertion, fitted heights", ""] + t_lines
    lines += ["", "## Acceptance: pure cCVT", "",
              "| case | max aspect | min angle >= 30 | RMSE / greedy | max aspect <= 5 and >= 95% at 30 degrees |",
              "| --- | --- | --- | --- | --- |"] + acceptance
    hf = tinsmith.sample("st-helens")
    lines += ["", "## Convergence, St. Helens at 1%", ""] + convergence(hf, 0.01, args.iterations)
    times = []
    for _ in range(3):
        start = time.perf_counter()
        mesh = tinsmith.cvt(hf, ratio=0.01)
        times.append(time.perf_counter() - start)
    lines += ["", f"Default run (L-BFGS, tol 1e-4; curvature, sites, every iteration): "
              f"{statistics.median(times):.2f} s median of 3 ({', '.join(f'{t:.2f}' for t in times)}), "
              f"{mesh.info['cvt']['iterations']} iterations, {mesh.n_vertices:,} vertices."]
    Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
