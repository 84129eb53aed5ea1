"""Load a tinsmith quantized-mesh pyramid in CesiumJS itself (headless Chromium) and compare heights.

    python benchmarks/cesium_check.py [--cesium DIR]   # writes benchmarks/RESULTS_cesium.md

CesiumJS comes from npm into a scratch folder (`npm install cesium@1`, not
kept in the repo).  A local HTTP server serves the pyramid (gzipped tiles with
`Content-Encoding: gzip`) and Cesium's build; the page asks Cesium's own
`CesiumTerrainProvider` and `sampleTerrain` for heights at random points on
every level, and the script compares them with the same points interpolated
in the tiles by tinsmith's decoder (barycentric in the tile's triangle), and
with the DEM.
"""

from __future__ import annotations

import argparse
import gzip
import json
import subprocess
import tempfile
from pathlib import Path

import numpy as np
from _common import HERE, ST_HELENS, machine

import tinsmith
from tinsmith.io.quantized_mesh import decode_tile, height_at
from tinsmith.tiles.cesium import quantized_mesh_pyramid
from tinsmith.tiles.pyramid import tile_bounds
from tinsmith.viz.browser import cesium_sample_terrain


def ours(out: Path, z: int, lon: float, lat: float) -> float:
    """Height at (lon, lat) in tinsmith's decoding of the level-z tile."""
    size = 180.0 / 2 ** z
    x, y = int((lon + 180) // size), int((lat + 90) // size)
    tile = decode_tile(gzip.decompress((out / str(z) / str(x) / f"{y}.terrain").read_bytes()))
    return height_at(tile, tile_bounds(z, x, y), lon, lat)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--cesium", default="/tmp/cesium_check", help="scratch folder for `npm install cesium`")
    args = ap.parse_args()
    scratch = Path(args.cesium)
    scratch.mkdir(parents=True, exist_ok=True)
    build = scratch / "node_modules/cesium/Build/Cesium"
    if not build.exists():
        subprocess.run(["npm", "install", "cesium@1", "--no-audit", "--no-fund"], cwd=scratch, check=True)
    version = json.loads((scratch / "node_modules/cesium/package.json").read_text())["version"]
    from pyproj import Transformer

    hf = tinsmith.read_heightfield(ST_HELENS)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        summary = quantized_mesh_pyramid(ST_HELENS, root / "terrain", max_error=2.0, normals=True, workers=2)
        rng = np.random.default_rng(0)
        w, s, e, n = summary["bounds"]
        lon = rng.uniform(w + 0.01, e - 0.01, 200)
        lat = rng.uniform(s + 0.01, n - 0.01, 200)
        levels = [summary["max_zoom"] - 4, summary["max_zoom"] - 2, summary["max_zoom"]]
        heights = cesium_sample_terrain(root / "terrain", build, zip(lon, lat, strict=True), levels)
        # the DEM at the same points (bilinear in its cell centres)
        x, y = Transformer.from_crs("EPSG:4326", hf.crs, always_xy=True).transform(lon, lat)
        r, c = hf.world_to_pixel(x, y)
        from scipy.ndimage import map_coordinates

        dem = map_coordinates(np.where(hf.valid, hf.z, np.nan).astype(float), [r, c], order=1)
        rows = []
        for z in levels:
            cesium = np.array(heights[z], dtype=float)
            mine = np.array([ours(root / "terrain", z, a, b) for a, b in zip(lon, lat, strict=True)])
            ok = np.isfinite(cesium) & np.isfinite(mine) & np.isfinite(dem)
            rows.append((z, int(ok.sum()), float(np.abs(cesium - mine)[ok].max()), float(np.abs(cesium - dem)[ok].max()),
                         float(np.sqrt(np.mean((cesium - dem)[ok] ** 2))), summary["levels"][z]["bound"]))
            print(rows[-1], flush=True)
    lines = ["# A tinsmith quantized-mesh pyramid read by CesiumJS itself", "", machine() + f", CesiumJS {version}, "
             "headless Chromium", "", "Rerun: `python benchmarks/cesium_check.py` (writes this file).", "",
             "St. Helens sample, `quantized_mesh_pyramid(max_error=2, normals=True)`, levels "
             f"{summary['min_zoom']}..{summary['max_zoom']}, {summary['tiles']} tiles. CesiumJS's `CesiumTerrainProvider` "
             "(with vertex normals) and `sampleTerrain` give the heights at 200 random points on three levels; they are "
             "compared with tinsmith's own decoding of the same tiles (the point interpolated in its triangle) and with "
             "the DEM (bilinear).", "",
             "| level | points | max \\|Cesium − tinsmith decoder\\| (m) | max \\|Cesium − DEM\\| (m) | RMS Cesium − DEM (m) "
             "| level bound (m) |",
             "| --- | --- | --- | --- | --- | --- |"]
    for z, k, d1, d2, rms, bound in rows:
        lines.append(f"| {z} | {k} | {d1:.2e} | {d2:.2f} | {rms:.2f} | {bound:.2f} |")
    (HERE / "RESULTS_cesium.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
