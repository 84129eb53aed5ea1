"""Seed 004's spline low pass on the Delft DTM and DSM: quadtree triangles against spline iterations.

    python benchmarks/spline_delft.py      # writes benchmarks/RESULTS_spline.md

The first part of the land-use filter (issue 8): every cell takes the spline
heights (class 3 everywhere; the land-use classes and the Haar wavelets are
not in yet).  The quadtree with the diagonal rule (formula 1) meshes the
filtered heights to ``epsilon`` (its error is measured against the filtered
heights, as in the paper); iteration 0 is the unfiltered quadtree.  Also the
RMS and largest change of the heights the filter makes.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from _common import HERE, SHARED, machine

import tinsmith
from tinsmith.algorithms.spline import spline_filter

DELFT = SHARED / "data/urban/delft_ahn3"
ITERATIONS = range(7)
EPSILONS = (0.05, 0.1, 0.2)


def main() -> None:
    lines = ["# Spline low pass (seed 004, section 3): quadtree triangles on Delft", "",
             "Command: `python benchmarks/spline_delft.py`  ",
             f"{machine()}. Quadtree with the diagonal rule on the filtered heights; iteration 0 is unfiltered.",
             "", "Every cell takes the spline heights here: the land-use classes and the Haar wavelets that keep "
             "landmarks (issue 8) are not in yet, so these counts are for the spline alone, and the largest change "
             "of a height shows what it costs (on the DSM, whole buildings are flattened).", ""]
    for name in ("dtm", "dsm"):
        hf = tinsmith.read(DELFT / f"delft_{name}_0.5m.tif")
        lines += [f"## Delft {name.upper()} 0.5 m, {hf.shape[0]} x {hf.shape[1]}", "",
                  "| spline iterations | filter time | RMS change | largest change | "
                  + " | ".join(f"triangles at {e} m" for e in EPSILONS) + " |",
                  "| --- | --- | --- | --- | " + " | ".join("---" for _ in EPSILONS) + " |"]
        counts = {e: [] for e in EPSILONS}
        for k in ITERATIONS:
            start = time.perf_counter()
            filtered = spline_filter(hf, k)
            seconds = time.perf_counter() - start
            change = filtered.z - hf.z
            cells = []
            for e in EPSILONS:
                n = tinsmith.simplify(filtered, method="quadtree", max_error=e, diagonal="rule").n_triangles
                counts[e].append(n)
                cells.append(f"{n:,}")
            lines.append(f"| {k} | {seconds:.3f} s | {np.sqrt(np.mean(change ** 2)):.3f} m | "
                         f"{np.abs(change).max():.3f} m | " + " | ".join(cells) + " |")
        lines.append("")
        for e in EPSILONS:
            best = int(np.argmin(counts[e]))
            lines.append(f"- epsilon {e} m: fewest triangles after {best} iterations, {counts[e][best]:,}, "
                         f"{counts[e][0] / counts[e][best]:.1f}x fewer than unfiltered ({counts[e][0]:,}).")
        lines.append("")
    out = HERE / "RESULTS_spline.md"
    Path(out).write_text("\n".join(lines))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
