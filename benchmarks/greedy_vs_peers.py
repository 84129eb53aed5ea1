"""Greedy insertion: tinsmith against pydelatin, side by side in one run.

    pip install -e ".[test]" pydelatin scipy
    python benchmarks/greedy_vs_peers.py                 # writes benchmarks/RESULTS.md
    python benchmarks/greedy_vs_peers.py --quick         # St. Helens and Grand Canyon only

For every DEM and max_error, each tool runs in a fresh process per repetition
(median of ``--repeat`` runs, the two tools taking turns): the same interface for both, a float32 array in
and a mesh out.  Time and peak memory cover only that call: tinsmith's kernels
are loaded (and compiled on the very first run) on a 64 x 64 warm-up grid
before the clock starts, and that load time is reported on its own.  Peak
memory is the growth of the resident set above what the process held before
the call (the kernel's high-water mark is reset through /proc/self/clear_refs).
Both meshes are then judged by tinsmith's own metrics against the DEM.

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
    jit = 0.0
    if tool == "tinsmith":
        import tinsmith

        start = time.perf_counter()
        warm = np.random.default_rng(0).normal(size=(64, 64)).astype(np.float32)
        tinsmith.greedy(tinsmith.Heightfield(warm, cell_size=1.0), max_error=0.5)
        jit = time.perf_counter() - start

        def run():
            hf = tinsmith.Heightfield(z, cell_size=1.0, nodata=float("nan") if nodata else None)
            mesh = tinsmith.greedy(hf, max_error=max_error)
            return mesh.vertices, mesh.triangles
    else:
        from pydelatin import Delatin

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

    sources = [
        ("St. Helens 468x327", ST_HELENS),
        ("Grand Canyon 256x256", SHARED / "data/terrain_rgb/terrarium_grand_canyon_z11_385_803_elev.tif"),
    ]
    if not quick:
        sources.append(("make_large_dem 4097x4097", large_dem(workdir)))
    dems = []
    for name, path in sources:
        with rasterio.open(path) as ds:
            z = ds.read(1).astype(np.float32)
            mask = ds.read_masks(1) == 0
        if mask.any():
            # nearest valid cell, so that pydelatin sees no spikes
            idx = ndimage.distance_transform_edt(mask, return_distances=False, return_indices=True)
            z = z[tuple(idx)]
        dems.append((name, z, mask if mask.any() else None))
    return dems


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
    else:  # tinsmith: world coordinates of the cell_size=1 grid
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
    ap.add_argument("--quick", action="store_true", help="skip the 4097 x 4097 DEM")
    ap.add_argument("--errors", type=float, nargs="+", default=[20.0, 5.0, 1.0])
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
            for max_error in args.errors:
                result = {}
                for tool, r in measure(("tinsmith", "pydelatin"), z, max_error, args.repeat, tmp).items():
                    result[tool] = (r, judge(z, r["vertices"], r["triangles"], tool))
                    print(name, max_error, tool, f"{r['time']:.3f}s", f"{r['peak_mb']:.0f}MB", result[tool][1], flush=True)
                ts, ts_j = result["tinsmith"]
                pd, pd_j = result["pydelatin"]
                rows.append((name, max_error, ts, ts_j, pd, pd_j))
                if mask is not None:
                    r = measure(("tinsmith",), z, max_error, args.repeat, tmp, nodata_mask=mask)["tinsmith"]
                    j = judge(np.where(mask, np.nan, z), r["vertices"], r["triangles"], "tinsmith", nodata_mask=mask)
                    rows.append((name + " (holes cut)", max_error, r, j, None, None))
                    print(name, "holes cut", max_error, f"{r['time']:.3f}s", j, flush=True)
    write_table(rows, args)


def write_table(rows, args) -> None:
    lines = [
        "# Greedy insertion: tinsmith vs pydelatin",
        "",
        f"Command: `python benchmarks/greedy_vs_peers.py{' --quick' if args.quick else ''} --repeat {args.repeat}`  ",
        f"{machine()}; median of {args.repeat} runs, each in a fresh process, the two tools taking turns.",
        "Errors are tinsmith's metrics against the DEM (every valid cell).",
        "Time and memory cover the call only (array in, mesh out); tinsmith's kernel load time is the jit column.",
        "",
        "| DEM | max_error | tinsmith s | pydelatin s | time ratio | tinsmith MB | pydelatin MB | tinsmith triangles | pydelatin triangles | count ratio | tinsmith max / RMS | pydelatin max / RMS | jit s |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, max_error, ts, ts_j, pd, pd_j in rows:
        if pd is None:
            lines.append(
                f"| {name} | {max_error:g} | {ts['time']:.3f} | - | - | {ts['peak_mb']:.0f} | - | {ts_j[1]:,} | - | - "
                f"| {ts_j[2]:.3f} / {ts_j[3]:.3f} | - | {ts['jit']:.2f} |"
            )
            continue
        lines.append(
            f"| {name} | {max_error:g} | {ts['time']:.3f} | {pd['time']:.3f} | {ts['time'] / pd['time']:.2f} "
            f"| {ts['peak_mb']:.0f} | {pd['peak_mb']:.0f} | {ts_j[1]:,} | {pd_j[1]:,} | {ts_j[1] / pd_j[1]:.4f} "
            f"| {ts_j[2]:.3f} / {ts_j[3]:.3f} | {pd_j[2]:.3f} / {pd_j[3]:.3f} | {ts['jit']:.2f} |"
        )
    Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
