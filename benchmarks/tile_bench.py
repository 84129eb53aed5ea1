"""Tiled runs: seams against single-pass greedy, 1 vs 2 workers on 100M cells, a Cesium pyramid.

    python benchmarks/tile_bench.py [--workdir DIR]   # writes benchmarks/RESULTS_tiles.md (about 10 min)

- The 4097 x 4097 DEM (make_large_dem.py, St. Helens, seed 1) as 16 tiles of
  1024, merged: T-junctions and cracks (tinsmith.metrics.seam_defects), the
  max error against the whole DEM, triangles against single-pass greedy
  insertion (the peer: the same method without tiles) at the same bound.
- The 10001 x 10001 DEM (make_large_dem.py --size 10001, seed 1) through the
  command line, `tinsmith tile ... --max-error 1 --tile-size 1024`, with 1
  and 2 worker processes (three times each, alternated) and on a Dask
  LocalCluster of 2, and at 0.25 m with 1 and 2 workers: wall time and the
  peak memory of the whole process tree (every process's RSS summed,
  sampled every 50 ms).
- A quantized-mesh pyramid of the 4097 DEM: tiles, triangles and time.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import psutil
from _common import HERE, ROOT, SHARED, ST_HELENS, large_dem, machine

import tinsmith
from tinsmith.tiles import independent_tiles, tile_raster

REPEATS = 3


def big_dem(workdir: Path) -> Path:
    path = workdir / "big10001.tif"
    if not path.exists():
        subprocess.run([sys.executable, str(SHARED / "tools/make_large_dem.py"), str(ST_HELENS), str(path),
                        "--size", "10001", "--seed", "1"], check=True)
    return path


def measured(cmd: list[str]) -> tuple[float, float, dict]:
    """Run ``cmd``; (wall seconds, peak summed RSS of it and its children in GB, its JSON report)."""
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    peak = [0]
    done = threading.Event()

    def sample():
        root = psutil.Process(proc.pid)
        while not done.is_set():
            try:
                procs = [root, *root.children(recursive=True)]
                peak[0] = max(peak[0], sum(p.memory_info().rss for p in procs if p.is_running()))
            except psutil.Error:
                pass
            time.sleep(0.05)

    thread = threading.Thread(target=sample, daemon=True)
    thread.start()
    out, err = proc.communicate()
    done.set()
    thread.join()
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed: {err}")
    return wall, peak[0] / 1e9, json.loads(out)


def seams_4097(dem: Path, rows: list) -> None:
    hf = tinsmith.read_heightfield(dem)
    for bound in (2.0, 1.0, 0.5):
        start = time.perf_counter()
        run = tile_raster(dem, max_error=bound, tile_size=1024, workers=2)
        merged = run.merge()
        t_tiles = time.perf_counter() - start
        start = time.perf_counter()
        single = tinsmith.greedy(hf, max_error=bound)
        t_single = time.perf_counter() - start
        defects = tinsmith.metrics.seam_defects(merged, hf)
        err = tinsmith.vertical_error(merged, hf)
        assert merged.check() == [] and defects["t_junctions"] == 0 and defects["cracks"] == 0
        assert err["max"] <= bound and abs(merged.n_triangles / single.n_triangles - 1) <= 0.10
        rows.append((bound, len(run.specs), merged.n_triangles, single.n_triangles,
                     merged.n_triangles / single.n_triangles, defects, err["max"], err["rmse"],
                     tinsmith.vertical_error(single, hf)["rmse"], t_tiles, t_single))
        print(rows[-1], flush=True)


def scale_10001(dem: Path, work: Path) -> list:
    """The CLI on the 10001 DEM: (bound, label, walls, peak GB, report) for 1 and 2 workers, alternated, and Dask."""
    exe = [sys.executable, "-m", "tinsmith"]
    runs = [(1.0, "1 worker", ["--workers", "1"]), (1.0, "2 workers", ["--workers", "2"])] * REPEATS
    runs += [(1.0, "Dask LocalCluster, 2 workers", ["--scheduler", "local", "--workers", "2"]),
             (0.25, "1 worker", ["--workers", "1"]), (0.25, "2 workers", ["--workers", "2"])]
    rows: dict = {}
    for bound, label, extra in runs:
        out = work / "big10001.ply"
        for stale in (out, work / "big10001.ply.parts"):
            shutil.rmtree(stale, ignore_errors=True) if stale.is_dir() else stale.unlink(missing_ok=True)
        wall, peak, report = measured([*exe, "tile", str(dem), "-o", str(out), "--max-error", str(bound),
                                       "--tile-size", "1024", "--json", *extra])
        row = rows.setdefault((bound, label), [bound, label, [], 0.0, report])
        row[2].append(wall)
        row[3] = max(row[3], peak)
        print(bound, label, round(wall, 1), round(peak, 2), report["n_triangles"], flush=True)
    return list(rows.values())


def pyramid_4097(dem: Path, work: Path) -> tuple:
    out = work / "pyramid4097"
    shutil.rmtree(out, ignore_errors=True)
    wall, peak, report = measured([sys.executable, "-m", "tinsmith", "tile", str(dem), "-o", str(out),
                                   "--format", "quantized-mesh", "--max-error", "1", "--workers", "2", "--json"])
    size = sum(p.stat().st_size for p in out.rglob("*.terrain"))
    return wall, peak, report, size


def figure(path: Path) -> None:
    """St. Helens in tiles of 128 at 2 m: the whole mesh coloured by tile, and a four-tile corner close up,
    beside quadtree tiles meshed apart (their T-junctions in red)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    hf = tinsmith.read_heightfield(ST_HELENS)
    run = tile_raster(ST_HELENS, max_error=2.0, tile_size=128, workers=1)
    merged = run.merge()
    corner = hf.pixel_to_world(128, 256)
    half = 900.0
    fig, axes = plt.subplots(1, 3, figsize=(16, 5.6))
    ax = axes[0]
    cmap = plt.get_cmap("tab20")
    for k, spec in enumerate(run.specs):
        m = run.tile_mesh(spec)
        if m.n_triangles:
            ax.triplot(m.vertices[:, 0], m.vertices[:, 1], m.triangles, lw=0.15, color=cmap(k % 20))
    ax.plot([corner[0] - half, corner[0] + half, corner[0] + half, corner[0] - half, corner[0] - half],
            [corner[1] - half, corner[1] - half, corner[1] + half, corner[1] + half, corner[1] - half], "k-", lw=1)
    ax.set_title(f"12 tiles of 128 cells, merged: {merged.n_triangles:,} triangles, max error 2 m")
    apart = independent_tiles(hf, 128, "quadtree", max_error=2.0)
    for ax, (label, mesh) in zip(axes[1:], [("seam contract (greedy)", merged), ("quadtree tiles meshed apart", apart)],
                                 strict=True):
        v, t = mesh.vertices, mesh.triangles
        ax.triplot(v[:, 0], v[:, 1], t, lw=0.5, color="0.3")
        d = tinsmith.metrics.seam_defects(mesh, hf)
        bad = v[d["t_junction_vertices"]]
        if len(bad):
            ax.plot(bad[:, 0], bad[:, 1], "o", ms=5, mfc="none", mec="red", mew=1.2)
        for r in (128,):
            x, y = hf.pixel_to_world(np.array([r, r]), np.array([0, 467]))
            ax.plot(x, y, "b--", lw=0.6)
        for c in (256,):
            x, y = hf.pixel_to_world(np.array([0, 326]), np.array([c, c]))
            ax.plot(x, y, "b--", lw=0.6)
        ax.set_xlim(corner[0] - half, corner[0] + half)
        ax.set_ylim(corner[1] - half, corner[1] + half)
        ax.set_title(f"{label}: {d['t_junctions']} T-junctions, {d['cracks']} cracks")
    for ax in axes:
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--workdir", default=os.environ.get("TMPDIR", "/tmp") + "/tinsmith_bench")
    args = ap.parse_args()
    work = Path(args.workdir)
    work.mkdir(parents=True, exist_ok=True)
    dem4097, dem10001 = large_dem(work), big_dem(work)

    figure(ROOT / "docs/img/tiles_seams.png")
    seams: list = []
    seams_4097(dem4097, seams)
    scale = scale_10001(dem10001, work)
    pyr = pyramid_4097(dem4097, work)

    lines = ["# Tiled runs", "", machine(), "",
             "Rerun: `python benchmarks/tile_bench.py` (writes this file).", "",
             "## 4097 x 4097 DEM as 16 tiles of 1024, merged, against single-pass greedy insertion", "",
             "Greedy insertion per tile under the seam contract, 2 worker processes; the peer is the same method "
             "in one pass over the whole grid. Errors are measured against the whole DEM.", "",
             "| bound (m) | tiles | tiled triangles | single-pass triangles | ratio | T-junctions | cracks | "
             "max error (m) | RMS tiled / single (m) | time tiled / single (s) |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for b, n, tt, ts, ratio, d, emax, rms, rms1, t1, t2 in seams:
        lines.append(f"| {b} | {n} | {tt:,} | {ts:,} | {ratio:.4f} | {d['t_junctions']} | {d['cracks']} | "
                     f"{emax:.3f} | {rms:.3f} / {rms1:.3f} | {t1:.1f} / {t2:.1f} |")
    lines += ["", "## 10001 x 10001 DEM (100M cells), `tinsmith tile --max-error E --tile-size 1024`", "",
              "Wall time of the whole command (start-up and imports, read, tiles, merge, PLY write) and the peak of the "
              f"summed resident memory of every process it started. At 1 m, 1 and 2 workers ran {REPEATS} times each, "
              "alternated; the speed-up is of the medians, with the range of the ratios of each pair of runs. "
              "About 1 s of every run is Python start-up and imports, the same for any number of workers.", "",
              "| bound (m) | run | wall, median (s) | runs (s) | speed-up vs 1 worker | peak memory (GB) | tiles | "
              "triangles | max error (m) |",
              "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    medians = {(b, label): float(np.median(walls)) for b, label, walls, _, _ in scale}
    for b, label, walls, peak, r in scale:
        base = medians[(b, "1 worker")]
        ratio = f"{base / medians[(b, label)]:.2f}x"
        ones = next(w for bb, lab, w, _, _ in scale if bb == b and lab == "1 worker")
        if label == "2 workers" and len(walls) > 1:
            pairs = [one / two for one, two in zip(ones, walls, strict=True)]
            ratio += f" ({min(pairs):.2f}–{max(pairs):.2f})"
        lines.append(f"| {b} | {label} | {np.median(walls):.1f} | {', '.join(f'{w:.1f}' for w in walls)} | {ratio} | "
                     f"{peak:.2f} | {r['tiles']} | {r['n_triangles']:,} | {r['max_error']:.3f} |")
    wall, peak, r, size = pyr
    lines += ["", "## Quantized-mesh pyramid of the 4097 DEM (`--format quantized-mesh --max-error 1`, 2 workers)", "",
              f"{r['tiles']:,} tiles, levels {r['min_zoom']}..{r['max_zoom']}, {size / 1e6:.1f} MB gzipped, "
              f"{wall:.1f} s, peak memory {peak:.2f} GB.", "",
              "| level | tiles | without data | triangles | max error (m) | bound (m) |",
              "| --- | --- | --- | --- | --- | --- |"]
    for z, lvl in r["levels"].items():
        lines.append(f"| {z} | {lvl['tiles']} | {lvl['empty']} | {lvl['triangles']:,} | {lvl['max_error']:.2f} | "
                     f"{lvl['bound']:.2f} |")
    (HERE / "RESULTS_tiles.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
