"""One large LAZ file into tiles: the memory of the bucket stage, streamed against a whole-file read.

A survey delivered as one big file (``make_large_cloud.py --points N --files 1x1``, made once in
``$TMPDIR/tinsmith_bench``) is meshed in tiles by ``tinsmith.tiles.tile_cloud``. Its first stage puts
every file's ground points into per-tile buckets. Each row is a fresh process, its peak memory the RSS of
the process and its workers, summed, sampled every 50 ms:

- *whole file*: the file's ground points read at once (``read_clouds``, x, y, z and the class), as the
  bucket stage did before it streamed;
- *streamed*: the bucket stage as it runs now (``iter_xyz``: 2 million points at a time);
- *the whole run*: ``tile_cloud`` on one worker, buckets, tiles and merge.

Run: ``python benchmarks/bucket_memory.py [--points 20e6]``; writes ``benchmarks/RESULTS_bucket_memory.md``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import HERE, machine  # noqa: E402
from tile_bench import measured  # noqa: E402

WORK = Path(os.environ.get("TMPDIR", tempfile.gettempdir())) / "tinsmith_bench"

WHOLE = r"""
import json, sys
from tinsmith.io.points import read_clouds
xyz = read_clouds([sys.argv[1]], classes=[2], attributes=False).xyz
print(json.dumps({"points": len(xyz)}))
"""

STREAMED = r"""
import json, sys
from tinsmith.io.points import iter_xyz
from tinsmith.tiles.points import BUCKET_CHUNK
print(json.dumps({"points": sum(len(c) for c in iter_xyz(sys.argv[1], classes=[2], chunk_size=BUCKET_CHUNK))}))
"""

RUN = r"""
import json, sys, tempfile
from tinsmith.tiles import tile_cloud
run = tile_cloud(sys.argv[1], max_error=0.25, classes=[2], workers=1, parts=tempfile.mkdtemp())
mesh = run.merge()
print(json.dumps({"points": run.points, "tiles": len(run.specs), "vertices": mesh.n_vertices}))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", default="20e6")
    args = ap.parse_args()
    folder = WORK / f"one_file_{args.points}"
    if not (folder / "cloud_00_00.laz").exists():
        subprocess.run([sys.executable, str(HERE / "make_large_cloud.py"), str(folder), "--points", args.points,
                        "--files", "1x1", "--seed", "1"], check=True)
    path = folder / "cloud_00_00.laz"
    size = path.stat().st_size / 1e6
    rows = []
    for label, code in (("whole file (read at once)", WHOLE), ("streamed (the bucket stage now)", STREAMED),
                        ("the whole run, one worker", RUN)):
        wall, peak, report = measured([sys.executable, "-c", code, str(path)])
        print(label, wall, peak, report, flush=True)
        rows.append((label, wall, peak, report))
    whole = rows[0][2]
    lines = ["# One large file into tiles: the memory of the bucket stage", "",
             f"Made by `python benchmarks/bucket_memory.py --points {args.points}`. {machine()}.", "",
             f"The file: `make_large_cloud.py --points {args.points} --files 1x1 --seed 1`, one LAZ file of "
             f"{size:,.0f} MB; its ground class (2) is what the buckets keep. Each row is a fresh process; peak memory "
             "is its RSS and its workers', summed.", "",
             "| what | ground points | wall (s) | peak memory (GB) | against the whole-file read |",
             "| --- | --- | --- | --- | --- |"]
    for label, wall, peak, report in rows:
        lines.append(f"| {label} | {report['points']:,} | {wall:.1f} | {peak:.2f} | {peak / whole:.2f}x |")
    (HERE / "RESULTS_bucket_memory.md").write_text("\n".join(lines) + "\n")
    print("wrote", HERE / "RESULTS_bucket_memory.md")


if __name__ == "__main__":
    main()
