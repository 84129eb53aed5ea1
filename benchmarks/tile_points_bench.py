"""A 100-million-point survey meshed in tiles on 1 and 2 workers (issue 22): time, memory, seams, the bound.

The survey is ``make_large_cloud.py`` (25 LAZ files, 5 x 5 km of Big Tujunga
terrain, 4 points/m2, 53% ground) made once into ``$TMPDIR/tinsmith_bench``.
Each run is a fresh process: ``tinsmith.tiles.tile_cloud`` on the ground class
(bucketing every file, every tile meshed by greedy insertion on its points),
then the merge and the PLY written, as ``tinsmith tile`` does; the peak memory
is the RSS of the process and its workers, summed, sampled every 50 ms.

Then, from the run's parts folder, outside the timing:

- the seams of the merged mesh (:func:`tinsmith.metrics.point_seam_defects`);
- the error at every ground point: each tile's points (its bucket, the points
  it owns, one a x-y, the lowest) against the tile's mesh with
  :func:`tinsmith.vertical_error_at_points`, and a random million of them
  against the merged mesh with matplotlib's triangle interpolator (code
  that is not ours).

Run: ``python benchmarks/tile_points_bench.py [--bound 0.25] [--runs 1]``; writes
``benchmarks/RESULTS_tile_points.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import HERE, machine  # noqa: E402
from tile_bench import measured  # noqa: E402

WORK = Path(os.environ.get("TMPDIR", tempfile.gettempdir())) / "tinsmith_bench"

CHILD = r"""
import json, sys, time
from tinsmith.io import write
from tinsmith.tiles import tile_cloud
folder, out, parts, bound, workers = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4]), int(sys.argv[5])
start = time.perf_counter()
run = tile_cloud(folder, max_error=bound, classes=[2], workers=workers, parts=parts)
tiles = time.perf_counter() - start
mesh = run.merge()
write(mesh, out)
print(json.dumps({"seconds": time.perf_counter() - start, "tiles_seconds": tiles, "tiles": len(run.specs),
                  "max_edge": run.max_edge, "max_error": run.max_error, "points": run.points,
                  "covered": run.covered, "vertices": mesh.n_vertices, "triangles": mesh.n_triangles}))
"""


def survey() -> Path:
    folder = WORK / "cloud100m"
    subprocess.run([sys.executable, str(HERE / "make_large_cloud.py"), str(folder), "--points", "100e6",
                    "--files", "5x5", "--seed", "1"], check=True)
    return folder


def verify(parts: Path, out: Path, bound: float) -> dict:
    """The seams and the error at every ground point, from a finished run's parts folder."""
    import matplotlib.tri as mtri

    import tinsmith
    from tinsmith.metrics import point_seam_defects, vertical_error_at_points
    from tinsmith.tiles.points import PointTileResult, PointTileSpec
    from tinsmith.triangulation.pointtin import checked_points

    names = sorted(p.stem for p in parts.glob("tile_*.npz"))
    worst, n_points, n_covered, sample = 0.0, 0, 0, []
    rng = np.random.default_rng(0)
    seams = []
    for name in names:
        with np.load(parts / f"{name}.npz") as d:
            r = PointTileResult.from_dict(d)
        seams.append(r.seams)
        bucket = parts / "buckets" / name
        xyz = np.concatenate([np.load(p) for p in sorted(bucket.glob("*.npy"))])
        i, j = (int(v) for v in name.split("_")[1:])
        xs, ys = _cuts(parts)
        own = xyz[PointTileSpec(i, j, xs, ys).owns(xyz)]
        pts = checked_points(tinsmith.PointCloud(own))
        e = vertical_error_at_points(tinsmith.TerrainMesh(r.vertices, r.triangles), pts)
        worst = max(worst, float(np.nan_to_num(e["max"])))
        n_points += e["n_valid"]
        n_covered += e["n_covered"]
        sample.append(pts[rng.random(len(pts)) < 1e6 / 5.3e7])
    mesh = tinsmith.read(out)
    defects = point_seam_defects(mesh, np.unique(np.concatenate(seams), axis=0))
    s = np.concatenate(sample)
    tri = mtri.Triangulation(mesh.vertices[:, 0], mesh.vertices[:, 1], mesh.triangles)
    z = np.ma.filled(mtri.LinearTriInterpolator(tri, mesh.vertices[:, 2])(s[:, 0], s[:, 1]), np.nan)
    inside = ~np.isnan(z)
    return {"bound": bound, "max_error_tiles": worst, "points": n_points, "covered": n_covered,
            "sample": int(len(s)), "sample_covered": int(inside.sum()),
            "sample_max_error": float(np.abs(z[inside] - s[inside, 2]).max()), **defects}


def _cuts(parts: Path):
    from tinsmith.io.points import clouds_info
    from tinsmith.tiles.points import point_layout

    job = json.loads((parts / "job.json").read_text())
    infos, _ = clouds_info([f["path"] for f in job["files"]])
    b = np.array([i.bounds for i in infos])
    bounds = (b[:, 0].min(), b[:, 1].min(), b[:, 3].max(), b[:, 4].max())
    spec = point_layout(bounds, job["tile_size"])[0]
    return spec.xs, spec.ys


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bound", type=float, default=0.25)
    parser.add_argument("--workers", default="2,1")
    parser.add_argument("--folder", type=Path, help="another survey (default: the 100M-point one, made once)")
    args = parser.parse_args()
    folder = args.folder or survey()
    rows = []
    checks = {}
    for workers in (int(w) for w in args.workers.split(",")):
        parts = WORK / f"points_parts_w{workers}"
        out = WORK / f"points_w{workers}.ply"
        shutil.rmtree(parts, ignore_errors=True)
        wall, peak, report = measured([sys.executable, "-c", CHILD, str(folder), str(out), str(parts),
                                       str(args.bound), str(workers)])
        print(workers, wall, peak, report, flush=True)
        rows.append((workers, wall, peak, report))
        checks[workers] = verify(parts, out, args.bound)
        print(checks[workers], flush=True)
    base = next((w for w in rows if w[0] == 1), rows[0])[1]
    lines = ["# A 100-million-point survey in tiles", "",
             f"Made by `python benchmarks/tile_points_bench.py --bound {args.bound:g}`. {machine()}.", "",
             f"Survey: `make_large_cloud.py --points 100e6 --files 5x5 --seed 1` (25 LAZ files, 5 x 5 km, "
             "4 points/m2, Big Tujunga terrain with fBm detail, forest and lakes). The ground class (2) is meshed "
             f"by greedy insertion on its points, tile by tile, to {args.bound:g} m at every point; the whole run "
             "(bucketing the 25 files, the tiles, the merge, the PLY written) in a fresh process; peak memory "
             "is that process's RSS and its workers', summed.", "",
             "| workers | wall (s) | speed-up | peak memory, all processes (GB) | tiles | ground points | vertices | "
             "triangles | max error in the tiles |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for workers, wall, peak, r in rows:
        lines.append(f"| {workers} | {wall:.1f} | {base / wall:.2f}x | {peak:.2f} | {r['tiles']} | {r['points']:,} | "
                     f"{r['vertices']:,} | {r['triangles']:,} | {r['max_error']:.4f} |")
    lines += ["", "Checks from each run's parts folder, outside the timing:", "",
              "| workers | T-junctions | cracks | seam border edges | max error at every ground point (per tile) | "
              "points covered | random sample vs merged mesh (matplotlib) |",
              "| --- | --- | --- | --- | --- | --- | --- |"]
    for workers, c in checks.items():
        lines.append(f"| {workers} | {c['t_junctions']} | {c['cracks']} | {c['seam_border_edges']} | "
                     f"{c['max_error_tiles']:.4f} | {c['covered']:,} of {c['points']:,} "
                     f"({100 * c['covered'] / c['points']:.4f}%) | max {c['sample_max_error']:.4f} over "
                     f"{c['sample_covered']:,} of {c['sample']:,} points |")
    (HERE / "RESULTS_tile_points.md").write_text("\n".join(lines) + "\n")
    print("wrote", HERE / "RESULTS_tile_points.md")


if __name__ == "__main__":
    main()
