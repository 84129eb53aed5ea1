"""LiDAR straight to a TIN, against peers, on the shared LAZ files (issues 22 and 47).

Three tables, written to benchmarks/RESULTS_points.md:

1. **Full TIN** of every point of each file (all classes, so the Delft file
   is the 849k-point case; with ``--survey`` the first file of the 100M-point
   survey of ``tile_points_bench.py`` too): ``tinsmith.tin`` (duplicates
   merged, outline cut at ``max_edge="auto"``) on one worker pinned to one
   core, and on two workers, against ``startinpy.DT().insert`` (Rust,
   robust predicates, one thread) pinned to one core and not.  Each run is a
   fresh process (after one warm-up process per tool, so the bytecode and
   page caches are filled), taking turns so that load hits every tool
   alike; the median of ``--runs`` runs.  A process times two calls: the
   *first* (the library's import and, for tinsmith, the loading of its
   kernels, compiled ahead of time at install (``tinsmith.kernels.ahead``: no
   numba in the process), then the TIN) and the *next* (a second TIN of the
   same cloud in that process).  The children import from compiled bytecode
   (:data:`PYCACHE`), as an installed package does.  Memory is the growth of the
   process's peak resident size over each call (the peak reset and freed
   memory handed back to the system before it), the result held.  The
   triangles' hash (taken after the clock and the memory reading) shows
   whether one and two workers made the same mesh.
2. **A thin corridor** (a road or pipeline survey, 50 m wide, 2.5 to 20 km long): the full
   TIN's time a point against the length, tinsmith on one and two workers and startinpy.
   ``--only-corridor`` runs this table alone and replaces it in the results (as
   ``--only-full-tin`` does the first).
3. **Point greedy against grid-then-greedy** at the same bound measured at
   the points: greedy on the points (``tinsmith simplify CLOUD``), and the
   usual DEM of the cloud (the lowest point a cell, empty cells inside the
   TIN's outline filled from the TIN) at 1, 1/2, 1/4 and 1/8 of the default
   cell size, each meshed by greedy at the loosest grid bound (the bound, then
   halves of it, down to 1/256) whose mesh is within the bound at every point
   it covers, the configuration with the fewest triangles kept; the vertical error
   of both measured at every point (one a x-y, the lowest) with
   ``tinsmith.vertical_error_at_points``.
4. **Greedy on the points on threads** (``greedy(cloud, workers=2)``: tiles of
   about 100,000 points under the survey's seam contract) against the
   one-piece run on one core, on Delft's ground, CODEM and (``--survey``) the
   ground of the survey's first file: time, vertices, error at every point,
   and whether 2 and 3 workers make the same mesh.  ``--only-greedy-threads``
   runs this table alone and replaces it in the results.

Run: ``python benchmarks/points_vs_peers.py [--runs 5] [--survey DIR]`` (needs
startinpy for the peer: ``pip install startinpy``, MIT; the survey is made by
``make_large_cloud.py DIR --points 100e6 --files 5x5 --seed 1``).
"""

from __future__ import annotations

import argparse
import json
import os
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
#: The clouds of the greedy-on-threads table (two tiles or more; the lidR forests and Autzen make one).
THREADED_CLOUDS = ("urban/delft_ahn3/delft_ahn3_merged.laz", "urban/codem_ncalm/codem_pc.laz")
#: The first file of the 100M-point survey (``--survey``).
SURVEY_FIRST = "cloud_00_00.laz"

CHILD = r"""
import ctypes, hashlib, json, os, sys, time
tool, path, workers = sys.argv[1], sys.argv[2], int(sys.argv[3])
if workers == 1:
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
import numpy as np
import tinsmith
cloud = tinsmith.read(path)
xyz = np.ascontiguousarray(cloud.xyz)
libc = ctypes.CDLL("libc.so.6")
def status(key):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key):
                return int(line.split()[1]) * 1024
def run():
    if tool == "tinsmith":
        return tinsmith.tin(cloud, workers=workers)
    import startinpy
    dt = startinpy.DT()
    dt.insert(xyz)
    return dt
def summary(result):
    if tool == "tinsmith":
        digest = hashlib.sha1(result.triangles.tobytes() + result.vertices.tobytes()).hexdigest()[:12]
        copied = 0 if result.vertices is cloud.xyz else result.vertices.nbytes  # the mesh's own coordinates
        return result.n_triangles, digest, copied
    return result.number_of_triangles(), "-", 0
out = {}
for label in ("first", "next"):
    libc.malloc_trim(0)
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")
    before = status("VmRSS")
    start = time.perf_counter()
    result = run()
    out[label] = time.perf_counter() - start
    out[label + "_mem"] = status("VmHWM") - before
    n, digest, copied = summary(result)  # after the clock and the memory reading
    del result
out.update(triangles=int(n), hash=digest, points=len(xyz), coordinates=copied)
print(json.dumps(out))
"""

#: (label, tool, workers) of the full-TIN table.
RUNS = [("tinsmith, 1 worker, 1 core", "tinsmith", 1), ("tinsmith, 2 workers", "tinsmith", 2),
        ("startinpy, 1 core", "startinpy", 1), ("startinpy", "startinpy", 0)]


#: the children's compiled bytecode: a package installed by pip imports from it, so they do too, wherever the
#: environment forbids writing it beside the sources (PYTHONDONTWRITEBYTECODE); the warm-up process writes it
PYCACHE = Path(__file__).resolve().parent / ".cache" / "pycache"


def child_env() -> dict:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    return {**env, "PYTHONPYCACHEPREFIX": str(PYCACHE)}


def run_child(code: str, *args) -> dict:
    """The JSON that a fresh process running ``code`` with ``args`` prints last."""
    out = subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True, text=True,
                         env=child_env())
    if out.returncode:
        raise RuntimeError(out.stderr)
    return json.loads(out.stdout.strip().splitlines()[-1])


def child(tool: str, path: Path, workers: int) -> dict:
    return run_child(CHILD, tool, path, workers)


def full_tin_table(runs: int, clouds: list[Path]) -> list[str]:
    import tinsmith

    rows = ["| cloud | points | run | first call, median (s) | next call, median (s) | first call runs (s) | "
            "peak growth, first call (MB) | peak growth, next call (MB) | triangles | triangles' hash | "
            "first call / startinpy's (same cores) | next call / startinpy's (same cores) | "
            "memory, next call / startinpy's | next call, bytes a point: peak growth / beyond the mesh's coordinates |",
            "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for path in clouds:
        n = len(tinsmith.read(path))
        results: dict[str, list] = {}
        for _label, tool, workers in RUNS:
            child(tool, path, workers)  # warm-up: caches, page cache
        for _ in range(runs):  # interleaved, so that load on the machine hits every tool alike
            for label, tool, workers in RUNS:
                results.setdefault(label, []).append(child(tool, path, workers))
        med = {label: {key: float(np.median([r[key] for r in rs])) for key in ("first", "next", "first_mem", "next_mem")}
               for label, rs in results.items()}
        for label, _tool, workers in RUNS:
            rs, m = results[label], med[label]
            peer = med["startinpy, 1 core" if workers == 1 else "startinpy"]
            first_runs = ", ".join(f"{r['first']:.3f}" for r in rs)
            rows.append(
                f"| {path.name} | {n:,} | {label} | {m['first']:.3f} | {m['next']:.3f} | "
                f"{first_runs} | {m['first_mem'] / 2**20:.0f} | "
                f"{m['next_mem'] / 2**20:.0f} | {rs[0]['triangles']:,} | {rs[0]['hash']} | "
                f"{m['first'] / peer['first']:.2f}x | {m['next'] / peer['next']:.2f}x | "
                f"{m['next_mem'] / peer['next_mem']:.2f}x | {m['next_mem'] / n:.0f} / "
                f"{(m['next_mem'] - rs[0]['coordinates']) / n:.0f} |")
        print("\n".join(rows[-len(RUNS):]), flush=True)
    return rows


#: The corridor table: a strip of points this wide (m) at this density (points/m2), at 30 degrees to x, ...
CORRIDOR_WIDTH, CORRIDOR_DENSITY = 50.0, 2.0
#: ... of these lengths (m).
CORRIDOR_LENGTHS = [2_500.0, 5_000.0, 10_000.0, 20_000.0]


def corridor(length: float, seed: int = 0) -> np.ndarray:
    """(N, 3) points of a corridor survey (a road, a pipeline): CORRIDOR_WIDTH wide, ``length`` long, at 30 degrees.

    In the order of a flight along the corridor (by distance along it), as a
    survey delivers them: a peer that walks from its last insertion is not
    sent back and forth along 20 km.
    """
    rng = np.random.default_rng(seed)
    n = int(CORRIDOR_DENSITY * CORRIDOR_WIDTH * length)
    along, across = np.sort(rng.uniform(0, length, n)), rng.uniform(0, CORRIDOR_WIDTH, n)
    c, s = np.cos(np.radians(30)), np.sin(np.radians(30))
    x, y = 500_000 + along * c - across * s, 4_000_000 + along * s + across * c
    z = 200 + 0.01 * along + np.sin(along / 300) * 5 + rng.normal(0, 0.03, n)
    return np.round(np.column_stack([x, y, z]), 3)  # millimetre coordinates, as in a LAS file


def corridor_table(runs: int) -> list[str]:
    """Time of a full TIN of a thin corridor against its length: per point, it should not grow."""
    import time

    import startinpy

    import tinsmith

    rows = ["| corridor length (km) | points | tinsmith, 1 worker (s) | tinsmith, 2 workers (s) | startinpy (s) | "
            "tinsmith 1 worker, us a point | tinsmith 2 workers, us a point | startinpy, us a point |",
            "| --- | --- | --- | --- | --- | --- | --- | --- |"]

    def timed(fn, warm=True):
        if warm:
            fn()
        times = []
        for _ in range(runs if warm else 1):
            t = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t)
        return float(np.median(times))

    for length in CORRIDOR_LENGTHS:
        xyz = corridor(length)
        cloud = tinsmith.PointCloud(xyz)
        one = timed(lambda: tinsmith.tin(cloud, workers=1))  # noqa: B023 - called at once
        two = timed(lambda: tinsmith.tin(cloud, workers=2))  # noqa: B023
        peer = timed(lambda: startinpy.DT().insert(xyz), warm=False)  # noqa: B023 - compiled: one run
        n = len(xyz)
        rows.append(f"| {length / 1000:g} | {n:,} | {one:.3f} | {two:.3f} | {peer:.3f} | {1e6 * one / n:.2f} | "
                    f"{1e6 * two / n:.2f} | {1e6 * peer / n:.2f} |")
        print(rows[-1], flush=True)
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


GREEDY_CHILD = r"""
import hashlib, json, os, sys, time
how, path, classes, bound = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4])
if how.endswith("1"):
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
import tinsmith
from tinsmith.tiles.point_threads import tile_points
from tinsmith.triangulation.pointtin import checked_points
cloud = tinsmith.read(path, classes=None if classes == "all" else [int(c) for c in classes.split(",")])
def run():
    if how == "one piece 1":
        return tinsmith.greedy(cloud, max_error=bound, workers=1)
    return tile_points(cloud, max_error=bound, workers=int(how[-1]))
run()  # numba's start and the kernels' loading
start = time.perf_counter()
mesh = run()
seconds = time.perf_counter() - start
e = tinsmith.vertical_error_at_points(mesh, checked_points(cloud))
print(json.dumps({"seconds": seconds, "vertices": mesh.n_vertices, "tiles": mesh.info.get("tiles", 1),
                  "max": e["max"], "covered": e["n_covered"], "points": e["n_valid"],
                  "hash": hashlib.sha1(mesh.triangles.tobytes() + mesh.vertices.tobytes()).hexdigest()[:12]}))
"""

#: (label, how) of the greedy-on-threads table: one piece on one core, tiles on one core, tiles on 2 (and 3) threads.
GREEDY_RUNS = [("one piece, 1 worker, 1 core", "one piece 1"), ("tiles, 1 worker, 1 core", "tiles 1"),
               ("tiles, 2 workers", "tiles 2")]


def greedy_threads_table(runs: int, clouds: list[tuple[Path, list | None, float]]) -> list[str]:
    """Greedy on the points in tiles on threads (``greedy(cloud, workers=2)``) against one piece, fresh processes."""
    rows = ["| cloud | classes | points | bound | run | tiles | time, median (s) | runs (s) | time / one piece's | "
            "vertices | vertices / one piece's | max error at points | points covered | mesh hash |",
            "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for path, classes, bound in clouds:
        cls = "all" if classes is None else ",".join(str(c) for c in classes)

        def child(how):
            return run_child(GREEDY_CHILD, how, path, cls, bound)  # noqa: B023

        results: dict[str, list] = {}
        for _ in range(runs):  # taking turns
            for label, how in GREEDY_RUNS:
                results.setdefault(label, []).append(child(how))
        three = child("tiles 3")
        base = float(np.median([r["seconds"] for r in results[GREEDY_RUNS[0][0]]]))
        base_v = results[GREEDY_RUNS[0][0]][0]["vertices"]
        for label, _how in GREEDY_RUNS + [("tiles, 3 workers (one run)", None)]:
            rs = results.get(label, [three])
            r, t = rs[0], float(np.median([r["seconds"] for r in rs]))
            times = ", ".join(f"{x['seconds']:.3f}" for x in rs)
            rows.append(f"| {path.name} | {cls} | {r['points']:,} | {bound:g} | {label} | {r['tiles']} | {t:.3f} | "
                        f"{times} | {t / base:.2f}x | {r['vertices']:,} | "
                        f"{r['vertices'] / base_v:.4f} | {r['max']:.4f} | {r['covered']:,} of {r['points']:,} | "
                        f"{r['hash']} |")
        print("\n".join(rows[-4:]), flush=True)
    return rows


GREEDY_THREADS_HEAD = "## Greedy insertion on the points on threads"
GREEDY_THREADS_TEXT = (
    "`tinsmith.greedy(cloud, max_error=..., workers=2)`: the points cut into tiles of about 100,000 points, meshed on "
    "threads under the survey's seam contract (`tinsmith.tiles.point_threads`), against the one-piece run on one core "
    "(`workers=1`). Each run is a fresh process, the configurations taking turns, timing the second call (after numba's "
    "start); the median of the runs. Errors at every point (one a x-y, the lowest). The hash shows that 2 and 3 "
    "workers make the same mesh.")


FULL_TIN_HEAD = "## Full TIN of every point"
CORRIDOR_HEAD = f"## A thin corridor: {CORRIDOR_WIDTH:g} m wide, {CORRIDOR_DENSITY:g} points/m2, 2.5 to 20 km long"
CORRIDOR_TEXT = ("Synthetic (millimetre coordinates, at 30 degrees to x, in flight order along the corridor), in one "
                 "process: tinsmith the median of the runs after a first call, startinpy one run. The time a point "
                 "should not grow with the length.")
FULL_TIN_TEXT = (
    "tinsmith's time includes merging duplicate x-y and cutting the outline at max_edge='auto'; "
    "startinpy merges points closer than its snap tolerance. One-worker runs of tinsmith and the first "
    "startinpy row are pinned to one core; ratios compare runs on the same cores. The *first call* of a "
    "fresh process includes the library's start (for tinsmith, the loading of its kernels compiled ahead "
    "of time at install, without numba, and of the modules of the TIN's path, from compiled bytecode as an "
    "installed package has it), the *next call* is a second TIN in that process.")


def replace_section(out: Path, head: str, section: list[str]) -> None:
    """Write ``section`` in place of the section of ``out`` that starts with the heading ``head`` (to the next
    heading of its level or the end), or after the rest when it has none."""
    text = out.read_text()
    if head in text:
        start = text.index(head)
        end = text.find("\n## ", start + len(head))
        rest = text[end:] if end >= 0 else ""
        text = text[:start]
    else:
        text, rest = text.rstrip("\n") + "\n\n", ""
    out.write_text(text + "\n".join(section) + "\n" + rest)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--survey", type=Path, help="the 100M-point survey's folder: its first file joins the TIN table")
    parser.add_argument("--only-greedy-threads", action="store_true",
                        help="run the table of greedy on threads alone and replace it in RESULTS_points.md")
    parser.add_argument("--only-full-tin", action="store_true",
                        help="run the full-TIN table alone and replace it in RESULTS_points.md")
    parser.add_argument("--only-corridor", action="store_true",
                        help="run the corridor table alone and replace it in RESULTS_points.md")
    args = parser.parse_args()
    import platform

    clouds = [DATA / name for name, _, _ in CLOUDS]
    if args.survey is not None:
        clouds.append(args.survey / SURVEY_FIRST)
    threaded = [(DATA / name, classes, bound) for name, classes, bound in CLOUDS if name in THREADED_CLOUDS]
    if args.survey is not None:
        threaded.append((args.survey / SURVEY_FIRST, [2], 0.25))
    out = HERE / "RESULTS_points.md"
    only = [(args.only_full_tin, "--only-full-tin", FULL_TIN_HEAD, FULL_TIN_TEXT,
             lambda: full_tin_table(args.runs, clouds)),
            (args.only_corridor, "--only-corridor", CORRIDOR_HEAD, CORRIDOR_TEXT, lambda: corridor_table(args.runs)),
            (args.only_greedy_threads, "--only-greedy-threads", GREEDY_THREADS_HEAD, GREEDY_THREADS_TEXT,
             lambda: greedy_threads_table(args.runs, threaded))]
    for chosen, flag, head, text, table in only:
        if chosen:
            command = f"python benchmarks/points_vs_peers.py {flag} --runs {args.runs}" + (
                " --survey DIR" if args.survey else "")
            section = [head, "", f"Made by `{command}` on {platform.node()}. " + text, "", *table()]
            replace_section(out, head, section)
            print("wrote", out)
            return
    command = f"python benchmarks/points_vs_peers.py --runs {args.runs}" + (" --survey DIR" if args.survey else "")
    lines = ["# LiDAR to a TIN: tinsmith against peers", "",
             f"Made by `{command}` on {platform.node()} ({platform.machine()}, {os.cpu_count()} cores).", "",
             FULL_TIN_HEAD, "",
             FULL_TIN_TEXT, ""]
    lines += full_tin_table(args.runs, clouds)
    lines += ["", CORRIDOR_HEAD, "", CORRIDOR_TEXT, ""]
    lines += corridor_table(args.runs)
    lines += ["", "## Greedy insertion on the points against grid-then-greedy, at the same bound at the points", "",
              "Errors are measured at every point (one a x-y, the lowest). The grid's bound holds at its cells, "
              "not at the points, so it is tightened (halved, down to 1/256 of the bound) until the error at the "
              "points meets the bound, on grids of 1, 1/2, 1/4 and 1/8 of the default cell size (the lowest point "
              "a cell, empty cells inside the TIN's outline filled from the TIN); the row shows the configuration "
              "with the fewest triangles that meets it. A cell holds one height, so a grid may never meet it; the "
              "time includes gridding.", ""]
    lines += greedy_table()
    lines += ["", GREEDY_THREADS_HEAD, "", GREEDY_THREADS_TEXT, ""]
    lines += greedy_threads_table(args.runs, threaded)
    out.write_text("\n".join(lines) + "\n")
    print("wrote", out)


if __name__ == "__main__":
    main()
