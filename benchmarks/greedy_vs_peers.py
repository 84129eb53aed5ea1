"""Greedy insertion: tinsmith against pydelatin, side by side in one run.

    pip install -e ".[test]" pydelatin scipy
    python benchmarks/greedy_vs_peers.py                 # writes benchmarks/RESULTS.md
    python benchmarks/greedy_vs_peers.py --quick         # the real DEMs only (no 2049 / 4097 grids)

DEMs: the real ones (St. Helens, Big Tujunga, the Delft DTM, the west Bijou
gully, the terrarium tile) and grids of 2049 x 2049 and 4097 x 4097 made
with ``make_large_dem.py`` from St. Helens and from Big Tujunga.  For each
DEM the max_error values are those that give greedy insertion about 150,000
and about 600,000 triangles (what the grid allows: at most 80% of two
triangles a cell), found by bisection on a first run in this process, so that
every row lies in the 100k-1M range where the two tools are compared.

For every DEM and max_error, each tool runs in a fresh process per repetition
(median of ``--repeat`` runs, the two tools taking turns): the same interface for both, a float32 array in
and a mesh out.  Time and peak memory cover only that call.  Before the clock
starts, each tool meshes the same 600 x 600 random warm-up grid: tinsmith's
kernels load there (compiled on the very first run; that load time is
reported on its own), and both tools start the timed call with an allocator
that has already handed out and taken back memory (a first touch of a page
costs about 2 us on this machine, a few ms of a 50-100 ms call).  Peak
memory is the growth of the resident set above what the process held before
the call (the kernel's high-water mark is reset through /proc/self/clear_refs).
Both meshes are then judged by tinsmith's own metrics against the DEM.
tinsmith runs on one core (``workers=1``, bit for bit the mesh of before
``workers`` existed) and, on grids of at least 1M cells, with ``workers=2``
(tiles on two threads, seams shared; its own column).

pydelatin cannot skip nodata, so DEMs with nodata are given to both tools
with the holes filled from the nearest valid cell; tinsmith's run that cuts
the holes out instead is listed as well.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _common import HERE, SHARED, ST_HELENS, large_dem, machine


# -- child process: one run of one tool --------------------------------------------------------
def _rss_kib(field: str) -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1])
    raise RuntimeError(field)


def _reset_peak() -> None:
    Path("/proc/self/clear_refs").write_text("5")


def child(tool: str, array_path: str, max_error: float, out_path: str, nodata: bool) -> None:
    z = np.load(array_path)
    # both tools first mesh the same warm-up grid (tinsmith: its kernels load), so that both start the timed call
    # with an allocator that has handed out and taken back memory: a fresh page costs about 2 us on this machine
    warm = np.random.default_rng(0).normal(size=(600, 600)).astype(np.float32)
    jit = 0.0
    if tool.startswith("tinsmith"):
        import tinsmith

        workers = 2 if tool == "tinsmith-2" else 1
        start = time.perf_counter()
        tinsmith.greedy(tinsmith.Heightfield(warm, cell_size=1.0), max_error=0.5, workers=workers)
        jit = time.perf_counter() - start

        def run():
            hf = tinsmith.Heightfield(z, cell_size=1.0, nodata=float("nan") if nodata else None)
            mesh = tinsmith.greedy(hf, max_error=max_error, workers=workers)
            return mesh.vertices, mesh.triangles
    else:
        from pydelatin import Delatin

        Delatin(warm, max_error=0.5)

        def run():
            d = Delatin(z, max_error=max_error)
            return d.vertices, d.triangles

    before = _rss_kib("VmRSS")
    _reset_peak()
    start = time.perf_counter()
    vertices, triangles = run()
    elapsed = time.perf_counter() - start
    peak = _rss_kib("VmHWM")
    np.savez(out_path, vertices=np.asarray(vertices), triangles=np.asarray(triangles))
    print(json.dumps({"time": elapsed, "jit": jit, "peak_mb": (peak - before) / 1024.0}))


# -- parent ----------------------------------------------------------------------------------------
def load_dems(quick: bool, workdir: Path) -> list[tuple[str, np.ndarray, np.ndarray | None]]:
    """(name, filled float32 heights, nodata mask or None)."""
    import rasterio
    from scipy import ndimage

    tujunga = SHARED / "data/terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif"
    sources = [
        ("St. Helens 30 m", ST_HELENS),
        ("Big Tujunga 30 m", tujunga),
        ("Delft DTM 0.5 m", SHARED / "data/urban/delft_ahn3/delft_dtm_0.5m.tif"),
        ("west Bijou gully", SHARED / "data/terrain/landlab_west_bijou/west_bijou_gully.asc"),
        ("Grand Canyon terrarium tile", SHARED / "data/terrain_rgb/terrarium_grand_canyon_z11_385_803_elev.tif"),
    ]
    if not quick:
        sources += [
            ("make_large_dem 2049 (Big Tujunga)", large_dem(workdir, 2049, tujunga)),
            ("make_large_dem 2049 (St. Helens)", large_dem(workdir, 2049)),
            ("make_large_dem 4097 (St. Helens)", large_dem(workdir)),
            ("make_large_dem 4097 (Big Tujunga)", large_dem(workdir, 4097, tujunga)),
        ]
    dems = []
    for name, path in sources:
        with rasterio.open(path) as ds:
            z = ds.read(1).astype(np.float32)
            mask = ds.read_masks(1) == 0
        mask |= ~np.isfinite(z)
        if mask.any():
            # nearest valid cell, so that pydelatin sees no spikes
            idx = ndimage.distance_transform_edt(mask, return_distances=False, return_indices=True)
            z = z[tuple(idx)]
        dems.append((f"{name} {z.shape[0]}x{z.shape[1]}", z, mask if mask.any() else None))
    return dems


def errors_for(z: np.ndarray, targets=(150_000, 600_000)) -> list[float]:
    """max_error values (3 significant digits) giving greedy insertion about each target triangle count."""
    import tinsmith

    hf = tinsmith.Heightfield(z, cell_size=1.0)
    cap = 0.8 * 2 * z.size
    out = []
    for target in targets:
        target = min(target, cap)
        lo, hi = 1e-4 * float(np.ptp(z)) + 1e-6, float(np.ptp(z))
        for _ in range(14):  # bisection in log space on the error
            mid = float(np.sqrt(lo * hi))
            n = tinsmith.greedy(hf, max_error=mid, workers=1).n_triangles
            lo, hi = (mid, hi) if n > target else (lo, mid)
        e = float(f"{np.sqrt(lo * hi):.3g}")
        if e not in out:
            out.append(e)
    return out


def measure(tools, z, max_error, repeat, workdir, nodata_mask=None):
    """Median time, kernel load time and peak memory of each tool, with its last mesh.

    The tools take turns (A B A B ...), so that a slow spell of this shared
    machine falls on both rather than on one.
    """
    array_path = workdir / "input.npy"
    if nodata_mask is not None:
        z = z.copy()
        z[nodata_mask] = np.nan
    np.save(array_path, z)
    runs = {tool: [] for tool in tools}
    for _ in range(repeat):
        for tool in tools:
            proc = subprocess.run(
                [sys.executable, __file__, "--child", tool, str(array_path), str(max_error),
                 str(workdir / f"mesh_{tool}.npz"), "1" if nodata_mask is not None else "0"],
                capture_output=True, text=True, check=True,
            )
            runs[tool].append(json.loads(proc.stdout.strip().splitlines()[-1]))
    results = {}
    for tool in tools:
        mesh = np.load(workdir / f"mesh_{tool}.npz")
        results[tool] = {
            "time": statistics.median(r["time"] for r in runs[tool]),
            "jit": statistics.median(r["jit"] for r in runs[tool]),
            "peak_mb": statistics.median(r["peak_mb"] for r in runs[tool]),
            "vertices": mesh["vertices"],
            "triangles": mesh["triangles"],
        }
    return results


def judge(z, vertices, triangles, tool, nodata_mask=None):
    """n_vertices, n_triangles, max and RMS error by tinsmith's metrics (pixel coordinates)."""
    import tinsmith

    hf = tinsmith.Heightfield(z, cell_size=1.0, nodata_mask=nodata_mask)
    v = np.asarray(vertices, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.int64)
    if tool == "pydelatin":  # x = column, y = (rows - 1) - row, z = height
        rows, cols = (z.shape[0] - 1) - v[:, 1], v[:, 0]
        zs = v[:, 2]
    else:  # tinsmith (either way): world coordinates of the cell_size=1 grid
        rows, cols = hf.world_to_pixel(v[:, 0], v[:, 1])
        zs = v[:, 2]
    x, y = hf.pixel_to_world(rows, cols)
    mesh = tinsmith.TerrainMesh(np.column_stack([x, y, zs]), t)
    area = mesh.signed_areas_2d()
    mesh.triangles[area < 0] = mesh.triangles[area < 0][:, [0, 2, 1]]
    err = tinsmith.vertical_error(mesh, hf)
    return len(v), len(t), err["max"], err["rmse"], err["coverage"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--child", nargs=5, metavar=("TOOL", "ARRAY", "MAX_ERROR", "OUT", "NODATA"))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="skip the 2049 and 4097 grids")
    ap.add_argument("--errors", type=float, nargs="+", help="these max_error values on every DEM (default: per DEM)")
    ap.add_argument("--only", help="run only the DEMs whose name contains this text (e.g. 4097)")
    ap.add_argument("--out", default=str(HERE / "RESULTS.md"))
    ap.add_argument("--workdir", default=str(HERE / ".cache"))
    args = ap.parse_args()
    if args.child:
        tool, array_path, max_error, out_path, nodata = args.child
        child(tool, array_path, float(max_error), out_path, nodata == "1")
        return

    workdir = Path(args.workdir)
    workdir.mkdir(exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory(dir=workdir) as tmp:
        tmp = Path(tmp)
        for name, z, mask in load_dems(args.quick, workdir):
            if args.only and args.only not in name:
                continue
            tools = ("tinsmith", "pydelatin") + (("tinsmith-2",) if z.size >= 1_000_000 else ())
            for max_error in args.errors or errors_for(z):
                result = {}
                for tool, r in measure(tools, z, max_error, args.repeat, tmp).items():
                    result[tool] = (r, judge(z, r["vertices"], r["triangles"], tool))
                    print(name, max_error, tool, f"{r['time']:.3f}s", f"{r['peak_mb']:.0f}MB", result[tool][1], flush=True)
                rows.append((name, max_error, *result["tinsmith"], *result["pydelatin"], result.get("tinsmith-2")))
                if mask is not None:
                    r = measure(("tinsmith",), z, max_error, args.repeat, tmp, nodata_mask=mask)["tinsmith"]
                    j = judge(np.where(mask, np.nan, z), r["vertices"], r["triangles"], "tinsmith", nodata_mask=mask)
                    rows.append((name + " (holes cut)", max_error, r, j, None, None, None))
                    print(name, "holes cut", max_error, f"{r['time']:.3f}s", j, flush=True)
    write_table(rows, args)


def write_table(rows, args) -> None:
    lines = [
        "# Greedy insertion: tinsmith vs pydelatin",
        "",
        f"Command: `python benchmarks/greedy_vs_peers.py{' --quick' if args.quick else ''} --repeat {args.repeat}`  ",
        f"{machine()}; median of {args.repeat} runs, each in a fresh process, the tools taking turns.",
        "Errors are tinsmith's metrics against the DEM (every valid cell).",
        "Time and memory cover the call only (array in, mesh out), after each tool has meshed the same 600 x 600 warm-up "
        "grid in the same process; tinsmith's kernel load time (that warm-up) is the jit column.",
        "tinsmith s: one core (`workers=1`); 2 workers: tiles on two threads with shared seams (grids of 1M cells or more).",
        "",
        "| DEM | max_error | tinsmith s | pydelatin s | time ratio | 2 workers s (ratio) | tinsmith MB | pydelatin MB "
        "| tinsmith triangles | pydelatin triangles | count ratio | 2 workers triangles | tinsmith max / RMS "
        "| pydelatin max / RMS | 2 workers max | jit s |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, max_error, ts, ts_j, pd, pd_j, two in rows:
        if pd is None:
            lines.append(
                f"| {name} | {max_error:g} | {ts['time']:.3f} | - | - | - | {ts['peak_mb']:.0f} | - | {ts_j[1]:,} | - | - "
                f"| - | {ts_j[2]:.3f} / {ts_j[3]:.3f} | - | - | {ts['jit']:.2f} |"
            )
            continue
        w2 = f"{two[0]['time']:.3f} ({two[0]['time'] / pd['time']:.2f})" if two else "-"
        lines.append(
            f"| {name} | {max_error:g} | {ts['time']:.3f} | {pd['time']:.3f} | {ts['time'] / pd['time']:.2f} | {w2} "
            f"| {ts['peak_mb']:.0f} | {pd['peak_mb']:.0f} | {ts_j[1]:,} | {pd_j[1]:,} | {ts_j[1] / pd_j[1]:.4f} "
            f"| {f'{two[1][1]:,}' if two else '-'} | {ts_j[2]:.3f} / {ts_j[3]:.3f} | {pd_j[2]:.3f} / {pd_j[3]:.3f} "
            f"| {f'{two[1][2]:.3f}' if two else '-'} | {ts['jit']:.2f} |"
        )
    Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
