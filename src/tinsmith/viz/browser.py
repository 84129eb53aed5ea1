"""Open a page in headless Chromium and report what happened: console messages, requests, images, a screenshot.

For tests and docs: the report and the viewer must load offline, without
errors.  Needs the ``playwright`` Python package and a Chromium binary
(Debian's ``chromium`` package; no browser download).
"""

from __future__ import annotations

import shutil
from pathlib import Path

from ..errors import MissingDependencyError, require

__all__ = ["cesium_sample_3dtiles_terrain", "cesium_sample_terrain", "chromium_path", "render_page", "serve_cesium"]

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
<script src="/cesium/Cesium.js"></script></head><body><script>
(async () => {
  try {
    const provider = await Cesium.CesiumTerrainProvider.fromUrl("/terrain/", {requestVertexNormals: true});
    const out = {};
    for (const level of LEVELS) {
      const carto = POINTS.map(([lon, lat]) => Cesium.Cartographic.fromDegrees(lon, lat));
      out[level] = (await Cesium.sampleTerrain(provider, level, carto)).map(c => c.height);
    }
    window.result = {heights: out, normals: provider.hasVertexNormals};
  } catch (e) { window.result = {error: String(e)}; }
})();
</script></body></html>"""


_CESIUM_3DTILES_PAGE = """<!DOCTYPE html><html><head><meta charset="utf-8"><script>window.CESIUM_BASE_URL = "/cesium/";</script>
<script src="/cesium/Cesium.js"></script></head><body><script>
(async () => {
  try {
    const provider = await Cesium.Cesium3DTilesTerrainProvider.fromUrl("/terrain/tileset.json",
      {requestVertexNormals: NORMALS});
    const carto = POINTS.map(([lon, lat]) => Cesium.Cartographic.fromDegrees(lon, lat));
    await Cesium.sampleTerrainMostDetailed(provider, carto, true);
    const levels = carto.map(c => provider.availability.computeMaximumLevelAtPosition(c));
    window.result = {heights: carto.map(c => c.height), levels: levels};
  } catch (e) { window.result = {error: (e && (e.stack || e.message)) || JSON.stringify(e)}; }
})();
</script></body></html>"""


def _gzip_terrain_headers(handler) -> None:
    if handler.path.split("?")[0].endswith(".terrain"):
        handler.send_header("Content-Encoding", "gzip")
        handler.send_header("Content-Type", "application/vnd.quantized-mesh")


def serve_cesium(cesium_build, folders: dict, page: str, *, headers=None, timeout_ms: int = 120_000,
                 wait_for: str = "window.result !== undefined", result: str = "window.result", screenshot=None,
                 viewport=(1280, 900)):
    """Serve CesiumJS's build (as ``/cesium/``), ``folders`` ({url name: path}) and ``page`` to headless Chromium.

    Returns what ``result`` (a JavaScript expression) evaluates to once
    ``wait_for`` holds; ``headers(handler)`` may add response headers;
    ``screenshot`` is a path for a picture of the page at that moment.
    Raises :class:`RuntimeError` on an uncaught page error.
    """
    import functools
    import http.server
    import tempfile
    import threading

    sync = require("playwright.sync_api", "test", "driving a headless browser")
    binary = chromium_path()
    if binary is None:
        raise MissingDependencyError("no Chromium binary on the PATH (Debian: apt-get install chromium)")

    class Handler(http.server.SimpleHTTPRequestHandler):
        def end_headers(self):
            if headers is not None:
                headers(self)
            super().end_headers()

        def log_message(self, *args):
            pass

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        (root / "cesium").symlink_to(Path(cesium_build).resolve())
        for name, folder in folders.items():
            (root / name).symlink_to(Path(folder).resolve())
        (root / "index.html").write_text(page)
        server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(Handler, directory=str(root)))
        threading.Thread(target=server.serve_forever, daemon=True).start()
        errors: list = []
        try:
            with sync.sync_playwright() as p:
                browser = p.chromium.launch(executable_path=binary, args=FLAGS)
                try:
                    tab = browser.new_page(viewport={"width": viewport[0], "height": viewport[1]})
                    tab.on("pageerror", lambda exc: errors.append(str(exc)))
                    tab.goto(f"http://127.0.0.1:{server.server_port}/index.html")
                    tab.wait_for_function(wait_for, timeout=timeout_ms)
                    out = tab.evaluate(result)
                    if screenshot is not None:
                        tab.screenshot(path=str(screenshot))
                finally:
                    browser.close()
        finally:
            server.shutdown()
    if errors:
        raise RuntimeError(f"CesiumJS failed: {errors[0]}")
    return out


def cesium_sample_terrain(pyramid, cesium_build, points, levels, *, timeout_ms: int = 120_000) -> dict:
    """Heights CesiumJS itself reads from a quantized-mesh pyramid: ``{level: [height per point]}``.

    ``pyramid`` is the folder of ``layer.json``; ``cesium_build`` is
    CesiumJS's ``Build/Cesium`` folder (from npm).  A local HTTP server
    serves both (tiles with ``Content-Encoding: gzip``) to headless Chromium,
    where ``CesiumTerrainProvider`` (with vertex normals) and
    ``sampleTerrain`` run on ``points`` ((lon, lat) degrees) at each level.
    Raises :class:`RuntimeError` with Cesium's message when it fails.
    """
    import json

    page = _CESIUM_PAGE.replace("POINTS", json.dumps([[float(a), float(b)] for a, b in points]))
    page = page.replace("LEVELS", json.dumps([int(z) for z in levels]))
    result = serve_cesium(cesium_build, {"terrain": pyramid}, page, headers=_gzip_terrain_headers, timeout_ms=timeout_ms)
    if "error" in result:
        raise RuntimeError(f"CesiumJS failed: {result['error']}")
    return {int(z): h for z, h in result["heights"].items()}


def cesium_sample_3dtiles_terrain(tileset, cesium_build, points, *, normals: bool = False,
                                  timeout_ms: int = 120_000) -> tuple[list, list]:
    """Heights CesiumJS itself reads from 3D Tiles terrain at its most detailed tiles: (heights, levels).

    ``tileset`` is the folder of ``tileset.json``; in headless Chromium,
    ``Cesium3DTilesTerrainProvider`` and ``sampleTerrainMostDetailed``
    (failing on a tile that fails) run on ``points`` ((lon, lat) degrees);
    ``levels`` are the deepest available level at each point, by the
    provider's availability.  ``normals`` has the provider read the
    tiles' vertex normals.  Raises :class:`RuntimeError` with Cesium's
    message when it fails.
    """
    import json

    page = _CESIUM_3DTILES_PAGE.replace("POINTS", json.dumps([[float(a), float(b)] for a, b in points]))
    page = page.replace("NORMALS", "true" if normals else "false")
    result = serve_cesium(cesium_build, {"terrain": tileset}, page, timeout_ms=timeout_ms)
    if "error" in result:
        raise RuntimeError(f"CesiumJS failed: {result['error']}")
    return result["heights"], result["levels"]
