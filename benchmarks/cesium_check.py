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
import functools
import gzip
import http.server
import json
import subprocess
import tempfile
import threading
from pathlib import Path

import numpy as np
from _common import HERE, ST_HELENS, machine

import tinsmith
from tinsmith.io.quantized_mesh import QUANT, decode_tile
from tinsmith.tiles.cesium import quantized_mesh_pyramid, tile_bounds

PAGE = """<!DOCTYPE html><html><head><meta charset="utf-8"><script>window.CESIUM_BASE_URL = "/cesium/";</script>
<script src="/cesium/Cesium.js"></script></head><body><script>
(async () => {
  try {
    const provider = await Cesium.CesiumTerrainProvider.fromUrl("/terrain/", {requestVertexNormals: true});
    const points = POINTS;
    const out = {};
    for (const level of LEVELS) {
      const carto = points.map(([lon, lat]) => Cesium.Cartographic.fromDegrees(lon, lat));
      const got = await Cesium.sampleTerrain(provider, level, carto);
      out[level] = got.map(c => c.height);
    }
    window.result = {heights: out, normals: provider.hasVertexNormals};
  } catch (e) { window.result = {error: String(e)}; }
})();
</script></body></html>"""


class Handler(http.server.SimpleHTTPRequestHandler):
    def end_headers(self):
        if self.path.split("?")[0].endswith(".terrain"):
            self.send_header("Content-Encoding", "gzip")
            self.send_header("Content-Type", "application/vnd.quantized-mesh")
        super().end_headers()

    def log_message(self, *args):
        pass


def ours(out: Path, z: int, lon: float, lat: float) -> float:
    """Height at (lon, lat) interpolated in tinsmith's decoding of the level-z tile."""
    size = 180.0 / 2 ** z
    x, y = int((lon + 180) // size), int((lat + 90) // size)
    d = decode_tile(gzip.decompress((out / str(z) / str(x) / f"{y}.terrain").read_bytes()))
    w, s, _, _ = tile_bounds(z, x, y)
    pu, pv = (lon - w) / size * QUANT, (lat - s) / size * QUANT
    h = d["header"]["min_height"] + d["h"] / QUANT * (d["header"]["max_height"] - d["header"]["min_height"])
    u, v = d["u"].astype(float), d["v"].astype(float)
    for a, b, c in d["triangles"]:
        det = (v[b] - v[c]) * (u[a] - u[c]) + (u[c] - u[b]) * (v[a] - v[c])
        l1 = ((v[b] - v[c]) * (pu - u[c]) + (u[c] - u[b]) * (pv - v[c])) / det
        l2 = ((v[c] - v[a]) * (pu - u[c]) + (u[a] - u[c]) * (pv - v[c])) / det
        l3 = 1 - l1 - l2
        if min(l1, l2, l3) >= -1e-9:
            return float(l1 * h[a] + l2 * h[b] + l3 * h[c])
    return float("nan")


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
        (root / "cesium").symlink_to(build)
        summary = quantized_mesh_pyramid(ST_HELENS, root / "terrain", max_error=2.0, normals=True, workers=2)
        rng = np.random.default_rng(0)
        w, s, e, n = summary["bounds"]
        lon = rng.uniform(w + 0.01, e - 0.01, 200)
        lat = rng.uniform(s + 0.01, n - 0.01, 200)
        levels = [summary["max_zoom"] - 4, summary["max_zoom"] - 2, summary["max_zoom"]]
        page = PAGE.replace("POINTS", json.dumps(np.column_stack([lon, lat]).tolist())).replace("LEVELS", json.dumps(levels))
        (root / "index.html").write_text(page)
        server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(Handler, directory=str(root)))
        threading.Thread(target=server.serve_forever, daemon=True).start()
        from playwright.sync_api import sync_playwright

        from tinsmith.viz.browser import FLAGS, chromium_path

        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=chromium_path(), args=FLAGS)
            page_ = browser.new_page()
            errors = []
            page_.on("pageerror", lambda exc: errors.append(str(exc)))
            page_.goto(f"http://127.0.0.1:{server.server_port}/index.html")
            page_.wait_for_function("window.result !== undefined", timeout=120_000)
            result = page_.evaluate("window.result")
            browser.close()
        server.shutdown()
        assert "error" not in result and not errors, (result, errors)
        # the DEM at the same points (bilinear in its cell centres)
        x, y = Transformer.from_crs("EPSG:4326", hf.crs, always_xy=True).transform(lon, lat)
        r, c = hf.world_to_pixel(x, y)
        from scipy.ndimage import map_coordinates

        dem = map_coordinates(np.where(hf.valid, hf.z, np.nan).astype(float), [r, c], order=1)
        rows = []
        for z in levels:
            cesium = np.array(result["heights"][str(z)], dtype=float)
            mine = np.array([ours(root / "terrain", z, a, b) for a, b in zip(lon, lat)])
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
             "| level | points | max \\|Cesium − tinsmith decoder\\| (m) | max \\|Cesium − DEM\\| (m) | RMS Cesium − DEM (m) | level bound (m) |",
             "| --- | --- | --- | --- | --- | --- |"]
    for z, k, d1, d2, rms, bound in rows:
        lines.append(f"| {z} | {k} | {d1:.2e} | {d2:.2f} | {rms:.2f} | {bound:.2f} |")
    (HERE / "RESULTS_cesium.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
