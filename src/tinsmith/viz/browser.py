"""Open a page in headless Chromium and report what happened: console messages, requests, images, a screenshot.

For tests and docs: the report and the viewer must load offline, without
errors.  Needs the ``playwright`` Python package and a Chromium binary
(Debian's ``chromium`` package; no browser download).
"""

from __future__ import annotations

import shutil
from pathlib import Path

from ..errors import MissingDependencyError, require

__all__ = ["cesium_page_result", "cesium_sample_3dtiles_terrain", "cesium_sample_terrain", "cesium_terrain_data",
           "chromium_path", "render_page"]

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
         "--disable-sync", "--no-first-run", "--disable-quic"]


def chromium_path() -> str | None:
    """The Chromium binary on the PATH, or None."""
    for name in ("chromium", "chromium-browser", "google-chrome"):
        found = shutil.which(name)
        if found:
            return found
    return None


def render_page(path, screenshot=None, *, full_page: bool = False, wait_for: str | None = None,
                viewport=(1280, 900), timeout_ms: int = 60_000) -> dict:
    """Load the local file ``path``; return ``{"console", "errors", "requests", "images", "ready"}``.

    ``console`` holds (type, text) of every console message, ``errors`` the
    uncaught exceptions, ``requests`` every URL the page asked for (the page
    itself included), ``images`` (src prefix, natural width) of every <img>.
    ``wait_for`` is a CSS selector to wait for (e.g. ``body[data-ready]``);
    ``ready`` is the body's ``data-ready`` attribute.
    """
    sync = require("playwright.sync_api", "test", "driving a headless browser")
    binary = chromium_path()
    if binary is None:
        raise MissingDependencyError("no Chromium binary on the PATH (Debian: apt-get install chromium)")
    url = Path(path).resolve().as_uri()
    out = {"console": [], "errors": [], "requests": []}
    with sync.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=binary, args=FLAGS)
        try:
            page = browser.new_page(viewport={"width": viewport[0], "height": viewport[1]})
            page.on("console", lambda m: out["console"].append((m.type, m.text)))
            page.on("pageerror", lambda e: out["errors"].append(str(e)))
            page.on("request", lambda r: out["requests"].append(r.url))
            page.goto(url, wait_until="load", timeout=timeout_ms)
            if wait_for:
                page.wait_for_selector(wait_for, state="attached", timeout=timeout_ms)
            out["images"] = page.eval_on_selector_all(
                "img", "els => els.map(e => [e.src.slice(0, 22), e.complete ? e.naturalWidth : 0])")
            out["ready"] = page.evaluate("document.body.dataset.ready || null")
            if screenshot is not None:
                page.screenshot(path=str(screenshot), full_page=full_page)
        finally:
            browser.close()
    return out


_CESIUM_PAGE = """<!DOCTYPE html><html><head><meta charset="utf-8"><script>window.CESIUM_BASE_URL = "/cesium/";</script>
<script src="/cesium/Cesium.js"></script><link rel="icon" href="data:,"></head><body><script>
(async () => {
  try {
SCRIPT
  } catch (e) { window.result = {error: String(e)}; }
})();
</script></body></html>"""

_SAMPLE = """
    const provider = await Cesium.CesiumTerrainProvider.fromUrl("./", {requestVertexNormals: true});
    const out = {};
    for (const level of LEVELS) {
      const carto = POINTS.map(([lon, lat]) => Cesium.Cartographic.fromDegrees(lon, lat));
      out[level] = (await Cesium.sampleTerrain(provider, level, carto)).map(c => c.height);
    }
    window.result = {heights: out, normals: provider.hasVertexNormals};
"""

_TILES = """
    const provider = await Cesium.CesiumTerrainProvider.fromUrl("./",
      {requestVertexNormals: true, requestWaterMask: true, requestMetadata: true});
    const scheme = provider.tilingScheme;
    const out = [];
    for (const [z, x, yTms] of TILES) {
      const y = scheme.getNumberOfYTilesAtLevel(z) - 1 - yTms;  // Cesium counts rows from the north
      const before = provider.getTileDataAvailable(x, y, z);
      // as the globe does: the tiles above, from level 0 down, each loaded when Cesium takes it as available
      // (a tile of a metadata level tells the availability of the levels below it)
      for (let up = 0; up < z; up += STEP) {
        const ux = x >> (z - up), uy = y >> (z - up);
        if (provider.getTileDataAvailable(ux, uy, up)) {
          const r = provider.requestTileGeometry(ux, uy, up);
          if (r) { await r; }
        }
      }
      const available = provider.getTileDataAvailable(x, y, z);
      let data = null;
      if (available) {
        const request = provider.requestTileGeometry(x, y, z);
        data = request ? await request : null;
      }
      out.push({tile: [z, x, yTms], before: before === undefined ? null : before, available: available,
                water: data && data.waterMask ? Array.from(data.waterMask) : null,
                normals: data && data._encodedNormals ? data._encodedNormals.length : 0,
                vertices: data ? data._quantizedVertices.length / 3 : 0});
    }
    window.result = {tiles: out, hasWaterMask: provider.hasWaterMask, hasMetadata: provider.hasMetadata,
                     hasVertexNormals: provider.hasVertexNormals};
"""

_SAMPLE_3DTILES = """
    const provider = await Cesium.Cesium3DTilesTerrainProvider.fromUrl("./tileset.json", {requestVertexNormals: NORMALS});
    const carto = POINTS.map(([lon, lat]) => Cesium.Cartographic.fromDegrees(lon, lat));
    await Cesium.sampleTerrainMostDetailed(provider, carto, true);
    const levels = carto.map(c => provider.availability.computeMaximumLevelAtPosition(c));
    window.result = {heights: carto.map(c => c.height), levels: levels};
"""


def cesium_page_result(pyramid, cesium_build, script: str, *, timeout_ms: int = 120_000) -> dict:
    """What ``script`` (the body of an async function that sets ``window.result``) gives in headless Chromium.

    ``pyramid`` is the folder served at ``/`` (by the server of ``tinsmith
    serve``, :func:`tinsmith.viz.serve.make_server`, with the headers CesiumJS
    needs); ``cesium_build`` is CesiumJS's ``Build/Cesium`` folder (from npm),
    served at ``/cesium/``.  Raises :class:`RuntimeError` with Cesium's
    message when the script fails.
    """
    import threading

    from .serve import find_cesium, make_server

    sync = require("playwright.sync_api", "test", "driving a headless browser")
    binary = chromium_path()
    if binary is None:
        raise MissingDependencyError("no Chromium binary on the PATH (Debian: apt-get install chromium)")
    page = _CESIUM_PAGE.replace("SCRIPT", script)
    server = make_server(pyramid, port=0, cesium=find_cesium(cesium_build), page=page.encode())
    threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True).start()
    errors: list = []
    try:
        with sync.sync_playwright() as p:
            browser = p.chromium.launch(executable_path=binary, args=FLAGS)
            try:
                tab = browser.new_page()
                tab.on("pageerror", lambda exc: errors.append(str(exc)))
                tab.goto(server.url)
                tab.wait_for_function("window.result !== undefined", timeout=timeout_ms)
                result = tab.evaluate("window.result")
            finally:
                browser.close()
    finally:
        server.shutdown()
        server.server_close()
    if "error" in result or errors:
        raise RuntimeError(f"CesiumJS failed: {result.get('error') or errors[0]}")
    return result


def cesium_sample_terrain(pyramid, cesium_build, points, levels, *, timeout_ms: int = 120_000) -> dict:
    """Heights CesiumJS itself reads from a quantized-mesh pyramid: ``{level: [height per point]}``.

    ``CesiumTerrainProvider`` (with vertex normals) and ``sampleTerrain`` run
    on ``points`` ((lon, lat) degrees) at each level (see
    :func:`cesium_page_result`).
    """
    import json

    script = _SAMPLE.replace("POINTS", json.dumps([[float(a), float(b)] for a, b in points]))
    script = script.replace("LEVELS", json.dumps([int(z) for z in levels]))
    result = cesium_page_result(pyramid, cesium_build, script, timeout_ms=timeout_ms)
    return {int(z): h for z, h in result["heights"].items()}


def cesium_terrain_data(pyramid, cesium_build, tiles, *, timeout_ms: int = 120_000) -> dict:
    """What CesiumJS decodes of quantized-mesh tiles, with normals, water mask and metadata requested.

    ``tiles`` are (z, x, y) with rows from the south (the pyramid's).  For
    each: whether Cesium took it as available before and after loading the
    availability the tiles above carry, and of its decoded ``TerrainData``
    the water mask (a list of bytes), the count of encoded normals and of
    vertices.  Also the provider's ``hasWaterMask``, ``hasMetadata`` and
    ``hasVertexNormals``.
    """
    import json

    layer = json.loads((Path(pyramid) / "layer.json").read_text())
    script = _TILES.replace("TILES", json.dumps([[int(v) for v in t] for t in tiles]))
    script = script.replace("STEP", str(int(layer.get("metadataAvailability", 1))))
    return cesium_page_result(pyramid, cesium_build, script, timeout_ms=timeout_ms)



def cesium_sample_3dtiles_terrain(tileset, cesium_build, points, *, normals: bool = False,
                                  timeout_ms: int = 120_000) -> tuple[list, list]:
    """Heights CesiumJS itself reads from 3D Tiles terrain at its most detailed tiles: (heights, levels).

    ``tileset`` is the folder of ``tileset.json``; in headless Chromium,
    ``Cesium3DTilesTerrainProvider`` and ``sampleTerrainMostDetailed``
    (failing on a tile that fails) run on ``points`` ((lon, lat) degrees);
    ``levels`` are the deepest available level at each point, by the
    provider's availability.  ``normals`` has the provider read the tiles'
    vertex normals (see :func:`cesium_page_result`).
    """
    import json

    script = _SAMPLE_3DTILES.replace("POINTS", json.dumps([[float(a), float(b)] for a, b in points]))
    script = script.replace("NORMALS", "true" if normals else "false")
    result = cesium_page_result(tileset, cesium_build, script, timeout_ms=timeout_ms)
    return result["heights"], result["levels"]
