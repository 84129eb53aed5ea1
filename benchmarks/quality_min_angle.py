"""quality at its largest accepted min_angle (33), the default (30) and beyond the limit (34): does it finish?

Issue 42: ``--min-angle 34`` ran for minutes on a smooth 300 x 300 DEM where 33 took a second (Delaunay
refinement past about 33.8 degrees can cascade, each generation of Steiner points making shorter edges).  The limit
is now 33, and two guards (a vertex budget, a stall guard) end a run that does not converge with one error line.

For St. Helens (the sample), Big Tujunga and the Delft DTM at the max_error greedy insertion reaches with 5% of the
valid cells (as in ``quality_vs_peers.py``), and the smooth bowl of the issue at its default max_error: the default
run (refinement + improvement) at 30 and 33 degrees, and at 34 through the method without its option checks (the
value is refused on the command line).  Columns: vertices (final; refinement alone in brackets), the ratio to the
30-degree run, the smallest plan-view angle, the max vertical error, the stall guard's count and limit (Steiner
points in triangles under 0.1 cell), the time of the call, and how it ended.  One run each in one process after a
warm-up (timings on a shared 2-core machine are noisy).  Writes the "Angle limit and guards" section of
RESULTS_quality.md (the rest of the file is kept).

    python benchmarks/quality_min_angle.py
"""

from __future__ import annotations

import sys
import time

import numpy as np
from quality_vs_peers import DEMS as PEER_DEMS  # a sibling script: run from benchmarks/
from quality_vs_peers import HERE

import tinsmith
from tinsmith.algorithms.quality import quality as q
from tinsmith.core.stop import default_max_error
from tinsmith.errors import InvalidOptionError
from tinsmith.metrics import vertical_error
from tinsmith.metrics.quality import triangle_angles

DEMS = PEER_DEMS[:3]  # St. Helens, Big Tujunga, the Delft DTM
HEADING = "## Angle limit and guards (`benchmarks/quality_min_angle.py`)"


def bowl(n: int = 300) -> tinsmith.Heightfield:
    """The smooth DEM of issue 42: a paraboloid, 300 x 300 cells of 1 m."""
    r, c = np.mgrid[0:n, 0:n].astype(np.float64)
    return tinsmith.Heightfield((((r - n / 2) ** 2 + (c - n / 2) ** 2) / 100.0).astype(np.float32), cell_size=1.0)


def run(hf, angle, max_error, improve=30):
    """(mesh or None, error line or None, seconds): the method, without the option checks above the limit."""
    t0 = time.perf_counter()
    try:
        if angle <= 33.0:
            mesh = tinsmith.simplify(hf, method="quality", max_error=max_error, min_angle=angle, improve=improve)
        else:
            mesh = q.quality.__wrapped__(hf, min_angle=angle, max_area=None, grading=None, improve=improve,
                                         regions=None, breaklines=None, control_points=None,
                                         stop=tinsmith.StopCriteria(max_error=max_error))
        return mesh, None, time.perf_counter() - t0
    except InvalidOptionError as exc:
        return None, str(exc), time.perf_counter() - t0


def main() -> None:
    run(bowl(60), 30.0, None)  # warm-up: compile the kernels
    lines = [HEADING, "",
             "Rerun: `python benchmarks/quality_min_angle.py`. min_angle is accepted up to 33 degrees; 34 runs "
             "through the method without its option checks. One run each, after a warm-up.", "",
             "| DEM, max_error | min_angle | vertices (refinement alone) | x 30 deg | smallest plan angle | max error "
             "| stall count / limit | time (s) | ended |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    cases = [("bowl of issue 42, 300 x 300 (default max_error)", bowl(), None)]
    for label, path in DEMS:
        if not path.exists():
            print(f"skipping {label}: {path} not found", file=sys.stderr)
            continue
        hf = tinsmith.read_heightfield(path)
        bound = float(tinsmith.greedy(hf, max_vertices=int(0.05 * hf.n_valid)).info["error"]["max"])
        cases.append((f"{label} (5% of {hf.n_valid:,} cells)", hf, bound))
    for label, hf, bound in cases:
        base = None
        for angle in (30.0, 33.0, 34.0):
            mesh, error, seconds = run(hf, angle, bound)
            refined = run(hf, angle, bound, improve=0)[0] if mesh is not None else None
            used = bound if bound is not None else default_max_error(hf)
            head = f"{label}, {used:.4g}"
            if mesh is None:
                guard = "stall guard" if "stall guard" in error else "vertex budget"
                at = error.split("stopped it at ")[1].split(" vertices")[0]
                lines.append(f"| {head} | {angle:g} | - | - | - | - | - | {seconds:.2f} | **{guard}** at {at} "
                             "vertices (exit 1) |")
            else:
                base = base or mesh.n_vertices
                info = mesh.info["quality"]
                err = vertical_error(mesh, hf)
                angles = triangle_angles(mesh, dims=2).min(axis=1)
                lines.append(
                    f"| {head} | {angle:g} | {mesh.n_vertices:,} ({refined.n_vertices:,}) | "
                    f"{mesh.n_vertices / base:.2f} | {angles.min():.2f} | {err['max']:.4g} "
                    f"({err['coverage']:.1%} covered) | {info['stall_points']:,} / {info['stall_limit']:,} | "
                    f"{seconds:.2f} | finished ({mesh.info['stop_reason']}) |")
            print(lines[-1], flush=True)
    out = HERE / "RESULTS_quality.md"
    text = out.read_text() if out.exists() else ""
    if HEADING in text:  # replace the section (up to the next heading of its level or the end)
        start = text.index(HEADING)
        end = text.find("\n## ", start + len(HEADING))
        text = text[:start] + text[end + 1:] if end >= 0 else text[:start]
    out.write_text(text.rstrip("\n") + "\n\n" + "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
