"""Duan et al. (2016)'s Table 1 for any DEM: cCVT against greedy insertion at the same vertex count.

    python benchmarks/cvt_table1.py DEM [--ratio 0.01] [--interval 80] [--anchor-fraction 0.25] [--fit-heights]

Measures, for both meshes: mean |e|, max |e| and RMS of the vertical error on
the vertical lines through every cCVT triangle centroid (the paper's
measure) and over every valid cell; max and 99th-percentile aspect ratio in
3-D (``longest edge * perimeter / (4 sqrt(3) area)``, 1 for equilateral);
the share of triangles whose smallest angle is at least 30 degrees; and the
mean and Hausdorff distance between the mesh's contours and the DEM's at
``--interval``.  Heights and distances are in the DEM's units.
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def measure(mesh, hf, at, interval: float) -> dict:
    """The Table 1 measures of ``mesh`` (errors at the centroids of ``at``'s triangles)."""
    from tinsmith import metrics

    cen = metrics.vertical_error_at_centroids(mesh, hf, at=at)
    cells = metrics.vertical_error(mesh, hf)
    ar = metrics.aspect_ratios(mesh)
    angle = metrics.triangle_angles(mesh).min(axis=1)
    contours = metrics.contour_distance(mesh, hf, interval)
    return {
        "vertices": mesh.n_vertices, "triangles": mesh.n_triangles,
        "centroid_mean": cen["mean_abs"], "centroid_max": cen["max"], "centroid_rmse": cen["rmse"],
        "cell_mean": cells["mean_abs"], "cell_max": cells["max"], "cell_rmse": cells["rmse"],
        "coverage": cells["coverage"],
        "aspect_max": float(ar.max()), "aspect_p99": float(np.percentile(ar, 99)),
        "angle30": float(np.mean(angle >= 30.0)),
        "contour_mean": contours["mean"], "contour_hausdorff": contours["hausdorff"],
    }


def table1(hf, *, ratio: float, interval: float, fit: bool = False, **cvt_options):
    """(cCVT row, greedy row, cCVT mesh, greedy mesh); each row has the measures and ``time`` (s)."""
    import tinsmith

    start = time.perf_counter()
    cvt = tinsmith.cvt(hf, ratio=ratio, **cvt_options)
    t_cvt = time.perf_counter() - start
    start = time.perf_counter()
    greedy = tinsmith.greedy(hf, max_vertices=cvt.n_vertices)
    t_greedy = time.perf_counter() - start
    if fit:
        cvt, greedy = tinsmith.fit_heights(cvt, hf), tinsmith.fit_heights(greedy, hf)
    rows = []
    for mesh, seconds in ((cvt, t_cvt), (greedy, t_greedy)):
        rows.append({**measure(mesh, hf, cvt, interval), "time": seconds})
    return rows[0], rows[1], cvt, greedy


HEADER = (
    "| method | vertices | centroids: mean / max / RMS | all cells: mean / max / RMS | max aspect | "
    "p99 aspect | min angle >= 30 | contours: mean / Hausdorff | time |\n"
    "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"
)


def row(name: str, r: dict) -> str:
    return (
        f"| {name} | {r['vertices']:,} | {r['centroid_mean']:.2f} / {r['centroid_max']:.1f} / {r['centroid_rmse']:.2f} | "
        f"{r['cell_mean']:.2f} / {r['cell_max']:.1f} / {r['cell_rmse']:.2f} | {r['aspect_max']:.2f} | "
        f"{r['aspect_p99']:.2f} | {100 * r['angle30']:.1f}% | {r['contour_mean']:.1f} / {r['contour_hausdorff']:.0f} | "
        f"{r['time']:.1f} s |"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dem")
    ap.add_argument("--ratio", type=float, default=0.01, help="share of the valid cells kept as vertices")
    ap.add_argument("--interval", type=float, default=80.0, help="contour interval (z units)")
    ap.add_argument("--anchor-fraction", type=float, default=0.0)
    ap.add_argument("--density-gamma", type=float, default=1.0)
    ap.add_argument("--fit-heights", action="store_true", help="fitted heights for both meshes")
    args = ap.parse_args()

    import tinsmith

    hf = tinsmith.read_heightfield(args.dem)
    c, g, _, _ = table1(hf, ratio=args.ratio, interval=args.interval, fit=args.fit_heights,
                        anchor_fraction=args.anchor_fraction, density_gamma=args.density_gamma)
    print(f"{args.dem}: {hf.shape[0]} x {hf.shape[1]}, {hf.n_valid:,} valid cells, ratio {args.ratio}, "
          f"contours every {args.interval:g}")
    print(HEADER)
    print(row("cCVT", c))
    print(row("greedy", g))
    print(f"RMSE ratio cCVT / greedy: centroids {c['centroid_rmse'] / g['centroid_rmse']:.3f}, "
          f"cells {c['cell_rmse'] / g['cell_rmse']:.3f}")


if __name__ == "__main__":
    main()
