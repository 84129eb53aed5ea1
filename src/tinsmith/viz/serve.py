"""Serve a terrain pyramid over HTTP to CesiumJS, with an offline page that shows it.

A folder written by ``tinsmith tile --format quantized-mesh`` (``layer.json``
and gzipped ``{z}/{x}/{y}.terrain``) or by a 3D Tiles terrain writer
(``tileset.json``, ``*.subtree``, ``*.glb``) is served read-only by the
standard library's :class:`http.server.ThreadingHTTPServer`:

* ``/`` is a small page (package data, ``tinsmith/data/serve/index.html``)
  that shows the pyramid in CesiumJS with vertex normals, water mask and
  metadata requested, lit, and flies to its bounds.  It asks nothing of the
  network beyond this server: no Cesium ion token, no base imagery, no
  geocoder.
* ``/cesium/...`` is a CesiumJS ``Build/Cesium`` folder (npm's ``cesium``
  package; not shipped with tinsmith), found by :func:`find_cesium`.
* Every other path is a file of the pyramid.  Tiles are sent as stored:
  ``.terrain`` as ``application/vnd.quantized-mesh`` with
  ``Content-Encoding: gzip`` when the file starts with gzip's magic bytes
  (the quantized-mesh-1.0 spec, CesiumGS/quantized-mesh: "Terrain tiles are
  served gzipped"), ``.glb`` as ``model/gltf-binary`` (RFC 9130's glTF
  registration), ``.subtree`` as ``application/octet-stream``, the JSON
  manifests as ``application/json``; every response carries
  ``Access-Control-Allow-Origin: *`` so another page may load the tiles.

CesiumJS's ``CesiumTerrainProvider`` asks for tiles with ``Accept:
application/vnd.quantized-mesh;extensions=octvertexnormals-watermask-metadata,
application/octet-stream;q=0.9,*/*;q=0.01``, listing only the extensions
``layer.json`` declares; a tile carries exactly those, and CesiumJS skips an
extension it did not ask for by its length, so static files answer every
such request.  The response says ``Vary: Accept`` all the same.

Safety: the server binds 127.0.0.1 unless told otherwise, answers only GET
and HEAD (405 otherwise), writes nothing, lists no folder, and serves a file
only when its real path (symlinks resolved) lies under the served folder:
``..`` and ``.`` segments, hidden names, percent-encoded slashes,
backslashes, NUL and other control bytes, double encoding and absolute
request targets all get 404 (:func:`resolve_request`).
"""

from __future__ import annotations

import errno
import mimetypes
import os
import socket
import sys
import threading
import webbrowser
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from pathlib import Path
from urllib.parse import unquote

from ..errors import FileError, InvalidOptionError

__all__ = ["MANIFESTS", "PyramidServer", "find_cesium", "make_server", "pyramid_manifest", "resolve_request",
           "serve_pyramid"]

#: The file that makes a folder a pyramid, by format.
MANIFESTS = {"layer.json": "quantized-mesh", "tileset.json": "3dtiles-terrain"}

#: Content types by suffix (others: :mod:`mimetypes`, else application/octet-stream).
TYPES = {".terrain": "application/vnd.quantized-mesh", ".json": "application/json", ".glb": "model/gltf-binary",
         ".subtree": "application/octet-stream", ".js": "text/javascript", ".mjs": "text/javascript",
         ".css": "text/css", ".wasm": "application/wasm", ".html": "text/html; charset=utf-8",
         ".ktx2": "image/ktx2", ".svg": "image/svg+xml"}

#: Where the page loads CesiumJS from.
CESIUM_PREFIX = "/cesium/"

#: The environment variable naming a CesiumJS ``Build/Cesium`` folder.
CESIUM_ENV = "TINSMITH_CESIUM"

HOW_TO_GET_CESIUM = ("CesiumJS is not shipped with tinsmith: run `npm install cesium` here, or pass "
                     f"--cesium node_modules/cesium/Build/Cesium (or set {CESIUM_ENV})")

_GZIP_MAGIC = b"\x1f\x8b"


def _cesium_build(path: Path) -> Path | None:
    """``path`` if it is a CesiumJS ``Build/Cesium`` folder, or the one inside an npm ``cesium`` package; else None."""
    for folder in (path, path / "Build" / "Cesium"):
        if (folder / "Cesium.js").is_file():
            return folder.resolve()
    return None


def find_cesium(given=None, *, environ=None, start=None) -> Path | None:
    """The CesiumJS ``Build/Cesium`` folder to serve under ``/cesium/``, or None when there is none.

    ``given`` (the ``--cesium`` option) first, then ``$TINSMITH_CESIUM``; a
    folder named either way must hold ``Cesium.js`` (itself or its
    ``Build/Cesium``), else :class:`~tinsmith.errors.FileError`.  Without
    either, the first ``node_modules/cesium/Build/Cesium`` in ``start``
    (default: the current folder) or one of its parents.
    """
    environ = os.environ if environ is None else environ
    for value, name in ((given, "--cesium"), (environ.get(CESIUM_ENV), CESIUM_ENV)):
        if value:
            found = _cesium_build(Path(value))
            if found is None:
                raise FileError(f"{name} {str(value)!r} is no CesiumJS build: no Cesium.js in it or in its "
                                "Build/Cesium (npm install cesium puts one in node_modules/cesium/Build/Cesium)")
            return found
    here = Path(start or Path.cwd()).resolve()
    for folder in (here, *here.parents):
        found = _cesium_build(folder / "node_modules" / "cesium")
        if found is not None:
            return found
    return None


def pyramid_manifest(folder) -> tuple[Path, str]:
    """``(folder resolved, format)`` of a pyramid folder, by its manifest (:data:`MANIFESTS`); else FileError."""
    path = Path(folder)
    if not path.exists():
        raise FileError(f"{str(folder)!r} does not exist (give the folder of a terrain pyramid)")
    if not path.is_dir():
        raise FileError(f"{str(folder)!r} is not a folder (give the folder of a terrain pyramid)")
    for name, kind in MANIFESTS.items():
        if (path / name).is_file():
            return path.resolve(), kind
    raise FileError(f"{str(folder)!r} has no {' or '.join(MANIFESTS)}: not a terrain pyramid (tinsmith tile "
                    "--format quantized-mesh writes one)")


def _segments(target: str) -> list[str] | None:
    """The path segments of a request target, or None when it is anything but a plain relative file path."""
    path = target.split("?", 1)[0].split("#", 1)[0]
    if not path.startswith("/") or path.startswith("//"):  # absolute-form (http://...) or a network path
        return None
    lowered = path.lower()
    if "\\" in path or "%2f" in lowered or "%5c" in lowered or "%00" in lowered:
        return None
    try:
        decoded = unquote(path, errors="strict")
    except UnicodeDecodeError:
        return None
    if "%" in decoded:  # double encoding (%252e...): never a name tinsmith writes
        return None
    parts = decoded[1:].split("/")
    for part in parts:
        if part == "" or part.startswith(".") or ":" in part or any(ord(c) < 32 or ord(c) == 127 for c in part):
            return None
    return parts


def resolve_request(root: Path, target: str) -> Path | None:
    """The regular file under ``root`` a request target names, or None (then: 404).

    ``root`` must be resolved already.  A target is refused when its path
    (query and fragment dropped) is not a plain ``/a/b/c`` of names: an
    empty, ``.`` or ``..`` or hidden (dot) segment, a backslash, a colon, a
    control byte, a percent-encoded slash, backslash or NUL, or anything
    still percent-encoded after one decoding.  A symlink is followed, and
    then its target must lie under ``root`` too.
    """
    parts = _segments(target)
    if not parts:
        return None
    real = Path(os.path.realpath(root.joinpath(*parts)))
    if real != root and root not in real.parents:
        return None
    return real if real.is_file() else None


def _page() -> bytes:
    return (resources.files("tinsmith") / "data" / "serve" / "index.html").read_bytes()


class PyramidHandler(BaseHTTPRequestHandler):
    """GET and HEAD of the page, of CesiumJS under ``/cesium/``, and of the pyramid's files; 405 for the rest."""

    protocol_version = "HTTP/1.1"  # keep-alive: CesiumJS asks for many small tiles
    server_version, sys_version = "tinsmith", ""
    server: PyramidServer

    def __getattr__(self, name):
        if name.startswith("do_"):  # any other method, known or not
            return self._not_allowed
        raise AttributeError(name)

    def do_GET(self):
        self._answer(body=True)

    def do_HEAD(self):
        self._answer(body=False)

    def _not_allowed(self):
        self.close_connection = True
        length = self.headers.get("Content-Length", "")
        if length.isdigit() and int(length) <= 1 << 20:  # read (and drop) a small body, so the answer is not reset
            self.rfile.read(int(length))
        self._send(HTTPStatus.METHOD_NOT_ALLOWED, b"only GET and HEAD\n", "text/plain; charset=utf-8",
                   {"Allow": "GET, HEAD"}, body=True)

    def _answer(self, body: bool) -> None:
        path = self.path.split("?", 1)[0].split("#", 1)[0]
        if path in ("/", "/index.html"):
            self._send(HTTPStatus.OK, self.server.page, "text/html; charset=utf-8", {}, body)
            return
        if path.startswith(CESIUM_PREFIX):
            root, target = self.server.cesium, self.path[len(CESIUM_PREFIX) - 1:]
        else:
            root, target = self.server.root, self.path
        found = None if root is None else resolve_request(root, target)
        if found is None:
            self._send(HTTPStatus.NOT_FOUND, b"not found\n", "text/plain; charset=utf-8", {}, body)
            return
        try:
            with open(found, "rb") as f:
                data = f.read()
        except OSError:
            self._send(HTTPStatus.NOT_FOUND, b"not found\n", "text/plain; charset=utf-8", {}, body)
            return
        suffix = found.suffix.lower()
        kind = TYPES.get(suffix) or mimetypes.guess_type(found.name)[0] or "application/octet-stream"
        extra = {}
        if suffix == ".terrain":
            extra["Vary"] = "Accept"
            if data[:2] == _GZIP_MAGIC:
                extra["Content-Encoding"] = "gzip"
        self._send(HTTPStatus.OK, data, kind, extra, body)

    def _send(self, status, data: bytes, kind: str, extra: dict, body: bool) -> None:
        self.send_response(status)
        self.send_header("Content-Type", kind)
        self.send_header("Content-Length", str(len(data)))
        self.send_header("Access-Control-Allow-Origin", "*")
        self.send_header("X-Content-Type-Options", "nosniff")
        self.send_header("Cache-Control", "no-cache")  # a pyramid may be written again under the same names
        for key, value in extra.items():
            self.send_header(key, value)
        self.end_headers()
        if body:
            self.wfile.write(data)

    def log_message(self, format, *args):
        if self.server.log is not None:
            self.server.log(f"{self.address_string()} {format % args}")

    def log_request(self, code="-", size="-"):
        if isinstance(code, int) and code >= 400:  # only what went wrong
            super().log_request(code, size)


class PyramidServer(ThreadingHTTPServer):
    """A threading HTTP server of one pyramid folder (and CesiumJS); its threads die with the process."""

    daemon_threads = True

    def __init__(self, address, root: Path, cesium: Path | None, log=None, page: bytes | None = None):
        self.root, self.cesium, self.log = root, cesium, log
        self.page = _page() if page is None else page
        super().__init__(address, PyramidHandler)

    def handle_error(self, request, client_address):
        """A client that hung up mid-answer is no error; anything else is one line to the log, not a traceback."""
        error = sys.exc_info()[1]
        if isinstance(error, ConnectionError | TimeoutError) or self.log is None:
            return
        self.log(f"{client_address[0]}: {type(error).__name__}: {error}")

    @property
    def url(self) -> str:
        host, port = self.server_address[:2]
        shown = "127.0.0.1" if host == "0.0.0.0" else f"[{host}]" if ":" in host else host
        return f"http://{shown}:{port}/"


def make_server(folder, *, host: str = "127.0.0.1", port: int = 8000, cesium=None, log=None,
                page: bytes | None = None) -> PyramidServer:
    """A bound (not yet serving) :class:`PyramidServer` of the pyramid in ``folder``.

    ``cesium`` is the CesiumJS build (see :func:`find_cesium`; None: the page
    says how to get one); ``log`` takes one line per failed request (None:
    silent); ``page`` replaces the bundled page at ``/`` (a test's own).
    Port 0 picks a free one (``server.server_port``).
    """
    root, _ = pyramid_manifest(folder)
    if not 0 <= int(port) <= 65535:
        raise InvalidOptionError(f"port {port} is out of range (0-65535; 0 picks a free one)")
    server_class = PyramidServer
    if ":" in host:
        server_class = type("PyramidServer6", (PyramidServer,), {"address_family": socket.AF_INET6})
    try:
        return server_class((host, int(port)), root, cesium, log, page)
    except socket.gaierror:
        raise InvalidOptionError(f"host {host!r} is no address of this machine") from None
    except OSError as exc:
        if exc.errno == errno.EADDRINUSE:
            raise InvalidOptionError(f"port {port} on {host} is in use; give another port (0 picks a free one)") from None
        if exc.errno in (errno.EADDRNOTAVAIL, errno.EAFNOSUPPORT):
            raise InvalidOptionError(f"host {host!r} is no address of this machine") from None
        if exc.errno == errno.EACCES:
            raise InvalidOptionError(f"port {port} on {host} needs privileges; give a port above 1023") from None
        raise


def _has_display() -> bool:
    """Whether a browser can open a window here (macOS and Windows always; elsewhere an X or Wayland display)."""
    return sys.platform in ("darwin", "win32") or bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def serve_pyramid(folder, *, host: str = "127.0.0.1", port: int = 8000, cesium=None, open_browser: bool = True,
                  echo=print, ready=None) -> None:
    """Serve the pyramid in ``folder`` until Ctrl-C (KeyboardInterrupt, which is re-raised after a clean stop).

    ``cesium`` is the ``--cesium`` option (see :func:`find_cesium`);
    ``open_browser`` opens the page with :mod:`webbrowser` when there is a
    display; ``echo`` takes the lines to show (the address, a missing
    CesiumJS, failed requests); ``ready`` (for tests) is called with the
    server once it listens.
    """
    build = find_cesium(cesium)
    server = make_server(folder, host=host, port=port, cesium=build, log=echo)
    try:
        kind = pyramid_manifest(folder)[1]
        bound = server.server_address
        echo(f"serving the {kind} pyramid {folder} on {bound[0]} port {bound[1]}: open {server.url} (Ctrl-C stops)")
        if build is None:
            echo(f"note: no CesiumJS build found, so the page cannot show the terrain. {HOW_TO_GET_CESIUM}")
        if ready is not None:
            ready(server)
        if open_browser and _has_display():
            threading.Timer(0.3, webbrowser.open, (server.url,)).start()
        server.serve_forever()
    finally:
        server.server_close()

