"""Open a page in headless Chromium and report what happened: console messages, requests, images, a screenshot.

For tests and docs: the report and the viewer must load offline, without
errors.  Needs the ``playwright`` Python package and a Chromium binary
(Debian's ``chromium`` package; no browser download).
"""

from __future__ import annotations

import shutil
from pathlib import Path

from ..errors import MissingDependencyError, require

__all__ = ["chromium_path", "render_page"]

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
