"""LiDAR straight to a TIN, against peers, on the shared LAZ files (issue 22).

Two tables, written to benchmarks/RESULTS_points.md:

1. **Full TIN** of every point of each file (all classes, so the Delft file
   is the 849k-point case): ``tinsmith.tin`` (duplicates merged, outline cut
   at ``max_edge="auto"``) against ``startinpy.DT().insert`` (Rust, robust
   predicates) and ``scipy.spatial.Delaunay`` (Qhull).  Each run is a fresh
   process (after one warm-up process, so numba's cache is filled); the
   time is the median of the runs of the triangulation call alone, the
   memory is the process's peak RSS growth over the triangulation.
2. **Point greedy against grid-then-greedy** at the same bound measured at
   the points: greedy on the points (``tinsmith simplify CLOUD``), and the
   usual DEM of the cloud (the lowest point a cell, empty cells inside the
   TIN's outline filled from the TIN) at 1, 1/2, 1/4 and 1/8 of the default
   cell size, each meshed by greedy at the loosest grid bound (the bound, then
   halves of it, down to 1/256) whose mesh is within the bound at every point
   it covers, the configuration with the fewest triangles kept; the vertical error
   of both measured at every point (one a x-y, the lowest) with
   ``tinsmith.vertical_error_at_points``.

Run: ``python benchmarks/points_vs_peers.py [--runs 3]`` (needs startinpy for the peer column:
``pip install startinpy``, MIT).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
DATA = HERE.parent.parent / "shared" / "data"
CLOUDS = [
    # (file, classes for the ground table, bound in z units)
    ("urban/delft_ahn3/delft_ahn3_merged.laz", [2], 0.1),
    ("terrain/lidR_forest_lakes/Topography.laz", [2], 0.1),
    ("terrain/lidR_forest_lakes/MixedConifer.laz", [2], 0.1),
    ("urban/codem_ncalm/codem_pc.laz", None, 0.1),
    ("urban/autzen_pdal/autzen_trim.laz", [2], 0.3),  # feet
]

CHILD = r"""
import json, resource, sys, time
import numpy as np
import tinsmith
tool, path = sys.argv[1], sys.argv[2]
cloud = tinsmith.read(path)
xyz = np.ascontiguousarray(cloud.xyz)
def rss():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS"):
                return int(line.split()[1]) * 1024
before = rss()
start = time.perf_counter()
if tool == "tinsmith":
    mesh = tinsmith.tin(cloud)
    n_tri, n_v = mesh.n_triangles, mesh.n_vertices
elif tool == "startinpy":
    import startinpy
    dt = startinpy.DT()
    dt.insert(xyz)
    n_tri, n_v = dt.number_of_triangles(), dt.number_of_vertices()
else:
    from scipy.spatial import Delaunay
    d = Delaunay(xyz[:, :2])
    n_tri, n_v = len(d.simplices), len(xyz)
elapsed = time.perf_counter() - start
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps({"time": elapsed, "mem": max(0, peak - before), "triangles": int(n_tri), "vertices": int(n_v)}))
"""


def child(tool: str, path: Path) -> dict:
    out = subprocess.run([sys.executable, "-c", CHILD, tool, str(path)], capture_output=True, text=True)
    if out.returncode:
        raise RuntimeError(out.stderr)
    return json.loads(out.stdout.strip().splitlines()[-1])


def full_tin_table(runs: int) -> list[str]:
    tools = ["tinsmith", "startinpy", "scipy"]
    try:
        import startinpy  # noqa: F401
    except ImportError:
        tools.remove("startinpy")
    rows = ["| cloud | points | tool | time, median (s) | runs (s) | peak memory growth (MB) | triangles | ratio to startinpy |",
            "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for name, _, _ in CLOUDS:
        path = DATA / name
        import tinsmith

        n = len(tinsmith.read(path))
        results = {}
        for tool in tools:
            child(tool, path)  # warm-up: caches, page cache
        for _ in range(runs):  # interleaved, so that load on the machine hits every tool alike
            for tool in tools:
                results.setdefault(tool, []).append(child(tool, path))
        ref = np.median([r["time"] for r in results["startinpy"]]) if "startinpy" in results else None
        for tool in tools:
            times = [r["time"] for r in results[tool]]
            med = float(np.median(times))
            ratio = f"{med / ref:.2f}x" if ref else "-"
            rows.append(f"| {Path(name).name} | {n:,} | {tool} | {med:.3f} | {', '.join(f'{t:.3f}' for t in times)} | "
                        f"{max(r['mem'] for r in results[tool]) / 2**20:.0f} | {results[tool][0]['triangles']:,} | {ratio} |")
        print(rows[-3:] if ref else rows[-2:], flush=True)
    return rows


def filled_grid(cloud, tin_mesh, cell_size=None):
    """The cloud gridded (lowest point a cell), the empty cells inside the TIN's outline filled from the
    TIN (lidR's rasterize_terrain way): the usual DEM of a ground class."""
    from tinsmith.core import Heightfield
    from tinsmith.kernels.raster import sample_triangles

    hf = cloud.to_heightfield(cell_size, statistic="min")
    z = np.array(hf.z, dtype=np.float64)
    rows, cols = np.nonzero(~hf.valid)
    x, y = hf.pixel_to_world(rows, cols)
    v = tin_mesh.vertices
    z[rows, cols] = sample_triangles(v[:, 0].copy(), v[:, 1].copy(), v[:, 2].copy(), tin_mesh.triangles,
                                     np.asarray(x, np.float64), np.asarray(y, np.float64))
    return Heightfield(z, transform=hf.transform, crs=hf.crs, nodata=float("nan"))


#: Grid bounds tried, as shares of the bound at the points, until the error at the points meets it ...
GRID_SHARES = [2.0 ** -k for k in range(9)]
#: ... on grids of these shares of the default cell size.
CELL_SHARES = [1.0, 0.5, 0.25, 0.125]


def grid_then_greedy(cloud, pts, bound):
    """The fewest triangles grid-then-greedy needs to meet ``bound`` at every point it covers.

    Returns (cell size, grid bound, mesh, error, seconds, met) of the best configuration: the one with
    the fewest triangles among those that meet the bound, else the finest one tried.
    """
    import time

    import tinsmith

    tin_mesh = tinsmith.tin(cloud)
    default = cloud.default_cell_size()
    best = None
    for cell_share in CELL_SHARES:
        t = time.perf_counter()
        dem = filled_grid(cloud, tin_mesh, default * cell_share)
        for share in [GRID_SHARES[-1], *GRID_SHARES]:  # the finest first: can this grid meet it at all?
            mesh = tinsmith.greedy(dem, max_error=bound * share)
            e = tinsmith.vertical_error_at_points(mesh, pts)
            if share == GRID_SHARES[-1] and e["max"] > bound:
                break
            if e["max"] <= bound:
                break
        found = (default * cell_share, bound * share, mesh, e, time.perf_counter() - t, e["max"] <= bound)
        if best is None or (found[5] and (not best[5] or mesh.n_triangles < best[2].n_triangles)) \
                or (not found[5] and not best[5]):
            best = found
    return best


def greedy_table() -> list[str]:
    import time

    import tinsmith
    from tinsmith.triangulation.pointtin import checked_points

    rows = ["| cloud | classes | points | bound at the points | method | grid bound | vertices | triangles | "
            "max error at points | RMS at points | points covered | time (s) |",
            "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for name, classes, bound in CLOUDS:
        cloud = tinsmith.read(DATA / name, classes=classes)
        pts = checked_points(cloud)
        t = time.perf_counter()
        on_points = tinsmith.greedy(cloud, max_error=bound)
        t_points = time.perf_counter() - t
        e = tinsmith.vertical_error_at_points(on_points, pts)
        rows.append(f"| {Path(name).name} | {classes or 'all'} | {len(pts):,} | {bound:g} | greedy on points | - | "
                    f"{on_points.n_vertices:,} | {on_points.n_triangles:,} | {e['max']:.3f} | {e['rmse']:.3f} | "
                    f"{100 * e['coverage']:.2f}% | {t_points:.2f} |")
        cell, grid_bound, gridded, e, secs, met = grid_then_greedy(cloud, pts, bound)
        note = "" if met else f" ({bound:g} not met on any grid tried)"
        rows.append(f"| {Path(name).name} | {classes or 'all'} | {len(pts):,} | {bound:g} | grid ({cell:.3g} cells, min, "
                    f"filled from the TIN) then greedy{note} | {grid_bound:.4g} | {gridded.n_vertices:,} | "
                    f"{gridded.n_triangles:,} | {e['max']:.3f} | {e['rmse']:.3f} | {100 * e['coverage']:.2f}% | {secs:.2f} |")
        print(rows[-2:], flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    import platform

    lines = ["# LiDAR to a TIN: tinsmith against peers", "",
             f"Made by `python benchmarks/points_vs_peers.py --runs {args.runs}` on {platform.node()} "
             f"({platform.machine()}, {__import__('os').cpu_count()} cores).", "",
             "## Full TIN of every point", "",
             "tinsmith's time includes merging duplicate x-y and cutting the outline at max_edge='auto'; "
             "startinpy merges points closer than its snap tolerance; scipy keeps duplicates apart.", ""]
    lines += full_tin_table(args.runs)
    lines += ["", "## Greedy insertion on the points against grid-then-greedy, at the same bound at the points", "",
              "Errors are measured at every point (one a x-y, the lowest). The grid's bound holds at its cells, not "
              "at the points, so it is tightened (halved, down to 1/256 of the bound) until the error at the points "
              "meets the bound, on grids of 1, 1/2, 1/4 and 1/8 of the default cell size (the lowest point a cell, "
              "empty cells inside the TIN's outline filled from the TIN); the row shows the configuration with the "
              "fewest triangles that meets it. A cell holds one height, so a grid may never meet it; the time "
              "includes gridding.", ""]
    lines += greedy_table()
    (HERE / "RESULTS_points.md").write_text("\n".join(lines) + "\n")
    print("wrote", HERE / "RESULTS_points.md")


if __name__ == "__main__":
    main()
