"""``tinsmith urban --tile-size``: a city larger than one piece, window by window, against the run in one piece.

    pip install -e ".[all,test]"
    python benchmarks/urban_tiled.py --mosaic 4     # writes benchmarks/RESULTS_urban_tiled.md

The Delft DSM (0.5 m) mirrored into a ``mosaic`` x ``mosaic`` city (each
copy flipped so the streets run on across the seams; 4: 1,832 x 2,116 =
3.9M cells), meshed as a watertight solid in one piece and in windows of
1,024 cells on 1 and 2 workers.  Wall time and the peak memory of the
command and its workers summed, and how the footprints of the two runs
compare (union IoU, building counts).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np
from _common import HERE, SHARED, machine
from tile_bench import measured

DELFT = SHARED / "data/urban/delft_ahn3/delft_dsm_0.5m.tif"


def mosaic(path: Path, n: int) -> None:
    import tinsmith
    from tinsmith.io.gis_formats import write_grid

    hf = tinsmith.read_heightfield(DELFT)
    rows = [np.concatenate([hf.z if j % 2 == 0 else hf.z[:, ::-1] for j in range(n)], axis=1) for _ in range(1)]
    row = rows[0]
    z = np.concatenate([row if i % 2 == 0 else row[::-1, :] for i in range(n)], axis=0)
    big = tinsmith.Heightfield(z, transform=hf.transform, crs=hf.crs)
    write_grid(z, path, big)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mosaic", type=int, default=4)
    ap.add_argument("--tile-size", type=int, default=1024)
    ap.add_argument("--out", default=str(HERE / "RESULTS_urban_tiled.md"))
    args = ap.parse_args()

    import shapely

    from tinsmith.metrics import footprint_iou

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        dsm = tmp / "city.tif"
        mosaic(dsm, args.mosaic)
        import tinsmith

        shape = tinsmith.read_heightfield(dsm).shape
        runs = []
        base = [sys.executable, "-m", "tinsmith", "urban", str(dsm), "--solid", "--json"]
        for label, extra in (("one piece", []),
                             (f"tiles of {args.tile_size}, 1 worker", ["--tile-size", str(args.tile_size), "--workers", "1"]),
                             (f"tiles of {args.tile_size}, 2 workers", ["--tile-size", str(args.tile_size), "--workers", "2"])):
            name = label.replace(" ", "_").replace(",", "")
            out, outlines = tmp / f"{name}.stl", tmp / f"{name}.geojson"
            wall, peak, report = measured([*base, "-o", str(out), "--buildings", str(outlines), *extra])
            found = [shapely.geometry.shape(f["geometry"]) for f in json.loads(outlines.read_text())["features"]]
            runs.append({"label": label, "wall": wall, "peak": peak, "buildings": report["n_buildings"],
                         "vertices": report["n_vertices"], "found": found})
            print(label, wall, peak, report["n_buildings"], flush=True)
        ref = runs[0]["found"]
        for r in runs:
            r["iou"] = footprint_iou(r["found"], ref)["iou"]
    lines = [
        "# `tinsmith urban --tile-size`: a city window by window against one piece",
        "",
        f"Command: `python benchmarks/urban_tiled.py --mosaic {args.mosaic}`  ",
        f"{machine()}. The Delft DSM mirrored {args.mosaic} x {args.mosaic}: {shape[0]:,} x {shape[1]:,} = "
        f"{shape[0] * shape[1] / 1e6:.1f}M cells of 0.5 m; `--solid`, defaults otherwise (ground estimated, flat "
        "roofs at p70). Peak memory: the command and its workers, summed.",
        "",
        "| run | wall (s) | peak memory (GB) | buildings | mesh points | footprints: union IoU with one piece |",
        "|---|---|---|---|---|---|",
    ]
    for r in runs:
        lines.append(f"| {r['label']} | {r['wall']:.1f} | {r['peak']:.2f} | {r['buildings']:,} | {r['vertices']:,} "
                     f"| {r['iou']:.4f} |")
    Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
