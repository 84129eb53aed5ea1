"""``tinsmith serve``: the headers CesiumJS needs, nothing outside the folder, nothing written, and the page in a browser."""

from __future__ import annotations

import contextlib
import gzip
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

import tinsmith
from tinsmith.cli.main import main
from tinsmith.errors import FileError
from tinsmith.viz.serve import find_cesium, make_server, pyramid_manifest, resolve_request

ROOT = Path(__file__).resolve().parents[1]
CESIUM = Path(__file__).parent / "js/node_modules/cesium/Build/Cesium"
SECRET = b"outside the served folder"
TILE = gzip.compress(b"quantized mesh bytes", mtime=0)


@pytest.fixture
def folder(tmp_path):
    """A pyramid folder of every kind of file, a secret beside it, and symlinks in and out."""
    pyramid = tmp_path / "pyramid"
    (pyramid / "0" / "0").mkdir(parents=True)
    (pyramid / "0" / "1").mkdir(parents=True)
    (pyramid / "layer.json").write_text(json.dumps({"format": "quantized-mesh-1.0", "bounds": [-122.3, 46.1, -122.1, 46.3],
                                                     "extensions": ["octvertexnormals", "watermask"]}))
    (pyramid / "0" / "0" / "0.terrain").write_bytes(TILE)
    (pyramid / "0" / "1" / "0.terrain").write_bytes(b"not gzipped")
    (pyramid / "tileset.json").write_text(json.dumps({"asset": {"version": "1.1"}}))
    (pyramid / "0.glb").write_bytes(b"glTF\x02\x00\x00\x00")
    (pyramid / "0.0.0.subtree").write_bytes(b"subt\x01\x00\x00\x00")
    (pyramid / ".tinsmith-job.json").write_text("{}")
    (tmp_path / "secret.txt").write_bytes(SECRET)
    (tmp_path / "outside").mkdir()
    (tmp_path / "outside" / "secret.txt").write_bytes(SECRET)
    (pyramid / "out.txt").symlink_to(tmp_path / "secret.txt")
    (pyramid / "outdir").symlink_to(tmp_path / "outside")
    (pyramid / "inside.terrain").symlink_to(pyramid / "0" / "0" / "0.terrain")
    build = tmp_path / "node_modules" / "cesium" / "Build" / "Cesium"
    build.mkdir(parents=True)
    (build / "Cesium.js").write_text("var Cesium = {};")
    return pyramid


@contextlib.contextmanager
def running(folder, **kwargs):
    """A server of ``folder`` on a free port, in a thread, for the length of the block."""
    server = make_server(folder, port=0, **kwargs)
    thread = threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)  # quick to stop
    thread.start()
    try:
        yield server
    finally:
        server.shutdown()
        server.server_close()
        thread.join(5)


def raw(server, target: str, method: str = "GET", headers: str = "", body: bytes = b"", host=None):
    """One request exactly as written (no client normalises the path): (status, {header: value}, body)."""
    address = (host or server.server_address[0], server.server_port)
    with socket.create_connection(address, timeout=10) as sock:
        request = f"{method} {target} HTTP/1.1\r\nHost: x\r\nConnection: close\r\n{headers}"
        if body:
            request += f"Content-Length: {len(body)}\r\n"
        sock.sendall(request.encode("latin-1") + b"\r\n" + body)
        data = b""
        while chunk := sock.recv(65536):
            data += chunk
    head, _, payload = data.partition(b"\r\n\r\n")
    lines = head.decode("latin-1").split("\r\n")
    fields = dict(line.split(": ", 1) for line in lines[1:])
    return int(lines[0].split()[1]), fields, payload


def listing(path: Path) -> dict:
    """Every file and folder under ``path`` (symlinks not followed): size and modification time."""
    out = {}
    for folder, dirs, files in os.walk(path):
        for name in dirs + files:
            p = Path(folder) / name
            st = p.lstat()
            out[str(p.relative_to(path))] = (st.st_size, st.st_mtime_ns)
    return out


def test_each_file_type_gets_its_headers(folder):
    accept = ("Accept: application/vnd.quantized-mesh;extensions=octvertexnormals-watermask-metadata,"
              "application/octet-stream;q=0.9,*/*;q=0.01\r\n")  # what CesiumJS 1.145 sends
    with running(folder) as server:
        status, fields, body = raw(server, "/0/0/0.terrain?v=1.0.0", headers=accept)
        assert status == 200 and body == TILE
        assert fields["Content-Type"] == "application/vnd.quantized-mesh"
        assert fields["Content-Encoding"] == "gzip" and fields["Access-Control-Allow-Origin"] == "*"
        assert fields["Content-Length"] == str(len(TILE))
        status, fields, body = raw(server, "/0/1/0.terrain")  # no gzip magic: sent as it is, not labelled gzip
        assert status == 200 and body == b"not gzipped" and "Content-Encoding" not in fields
        for target, kind in (("/layer.json", "application/json"), ("/tileset.json", "application/json"),
                             ("/0.glb", "model/gltf-binary"), ("/0.0.0.subtree", "application/octet-stream")):
            status, fields, body = raw(server, target)
            assert status == 200 and fields["Content-Type"] == kind, target
            assert fields["Access-Control-Allow-Origin"] == "*" and "Content-Encoding" not in fields
            assert body == (folder / target[1:]).read_bytes()
        status, fields, body = raw(server, "/0/0/0.terrain", method="HEAD")
        assert status == 200 and body == b"" and fields["Content-Length"] == str(len(TILE))
        assert fields["Content-Encoding"] == "gzip"


@pytest.mark.parametrize("target", [
    "/../secret.txt", "/0/../../secret.txt", "/0/0/../../../secret.txt", "/./layer.json",
    "/%2e%2e/secret.txt", "/%2E%2E/secret.txt", "/.%2e/secret.txt", "/..%2fsecret.txt", "/0%2f..%2f..%2fsecret.txt",
    "/%2e%2e%2fsecret.txt", "/%252e%252e/secret.txt", "/%25252e%25252e/secret.txt", "/%252e%252e%252fsecret.txt",
    "/%c0%ae%c0%ae/secret.txt", "/..\\secret.txt", "/0\\..\\..\\secret.txt", "/%5c..%5csecret.txt",
    "/layer.json%00", "/layer.json%00.terrain", "/layer.json\x00", "/0/0/0.terrain\x00.png",
    "SECRET_ABSOLUTE", "//SECRET_ABSOLUTE", "http://127.0.0.1/../secret.txt", "secret.txt", "*",
    "/out.txt", "/outdir/secret.txt", "/outdir", "/.tinsmith-job.json", "/0", "/0/", "/0/0/",
    "/C:/secret.txt", "/cesium/../secret.txt", "/cesium/%2e%2e/secret.txt", "/cesium/../../secret.txt",
    "/cesium/%2e%2e/%2e%2e/%2e%2e/secret.txt", "/cesium/", "/missing.terrain",
])
def test_nothing_outside_the_folder_is_served(folder, target):
    build = folder.parent / "node_modules" / "cesium" / "Build" / "Cesium"
    target = target.replace("SECRET_ABSOLUTE", str(folder.parent / "secret.txt").lstrip("/"))
    with running(folder, cesium=build) as server:
        status, _, body = raw(server, target)
    assert status == 404, target
    assert SECRET not in body


def test_the_resolver_refuses_what_the_server_refuses(folder):
    root = folder.resolve()
    assert resolve_request(root, "/layer.json") == root / "layer.json"
    assert resolve_request(root, "/inside.terrain") == root / "0" / "0" / "0.terrain"  # a symlink within
    for target in ("/../secret.txt", "/%2e%2e/secret.txt", "/out.txt", "/outdir/secret.txt", "/0", "/", ""):
        assert resolve_request(root, target) is None, target


def test_a_symlink_inside_the_folder_is_served(folder):
    with running(folder) as server:
        status, fields, body = raw(server, "/inside.terrain")
    assert status == 200 and body == TILE and fields["Content-Encoding"] == "gzip"


def test_cesium_is_served_under_its_prefix_only(folder):
    build = folder.parent / "node_modules" / "cesium" / "Build" / "Cesium"
    with running(folder, cesium=build) as server:
        status, fields, body = raw(server, "/cesium/Cesium.js")
        assert status == 200 and body == b"var Cesium = {};" and fields["Content-Type"] == "text/javascript"
        assert raw(server, "/cesium/layer.json")[0] == 404  # the pyramid is not under /cesium/
    with running(folder) as server:  # no build: 404, and the page says how to get one
        assert raw(server, "/cesium/Cesium.js")[0] == 404


def test_only_get_and_head_and_nothing_is_written(folder):
    before = listing(folder.parent)
    with running(folder) as server:
        for method in ("POST", "PUT", "DELETE", "PATCH", "OPTIONS", "TRACE", "MKCOL", "FOO"):
            for target in ("/layer.json", "/new.terrain", "/"):
                status, fields, _ = raw(server, target, method=method, body=b"written?")
                assert status == 405, (method, target)
                assert fields["Allow"] == "GET, HEAD"
        for target in ("/", "/layer.json", "/0/0/0.terrain", "/0/", "/../secret.txt", "/nothing"):
            raw(server, target)
    assert listing(folder.parent) == before
    assert not (folder / "new.terrain").exists()


def test_the_page_is_served_at_the_root_and_needs_no_network(folder):
    with running(folder) as server:
        status, fields, body = raw(server, "/")
    assert status == 200 and fields["Content-Type"] == "text/html; charset=utf-8"
    page = body.decode()
    for wanted in ("requestWaterMask: true", "requestVertexNormals: true", "requestMetadata: true", "enableLighting = true",
                   "baseLayer: false", "geocoder: false", "Cesium3DTilesTerrainProvider.fromUrl", "npm install cesium"):
        assert wanted in page, wanted
    assert not re.search(r"(https?:)?//[a-z0-9.-]+\.[a-z]{2,}", page, re.I), "the page names another host"
    assert len(body) < 16_000


def test_a_3d_tiles_terrain_folder_is_a_pyramid_too(folder):
    (folder / "layer.json").unlink()
    assert pyramid_manifest(folder) == (folder.resolve(), "3dtiles-terrain")
    with running(folder) as server:
        assert raw(server, "/layer.json")[0] == 404
        status, fields, _ = raw(server, "/tileset.json")
        assert status == 200 and fields["Content-Type"] == "application/json"
    (folder / "tileset.json").unlink()
    with pytest.raises(FileError, match="has no layer.json or tileset.json"):
        pyramid_manifest(folder)


def test_default_address_is_loopback_and_host_is_honoured(folder):
    server = make_server(folder, port=0)
    try:
        assert server.server_address[0] == "127.0.0.1"
    finally:
        server.server_close()
    with running(folder, host="127.0.0.2") as server:  # another loopback address: listening there and only there
        assert server.server_address[0] == "127.0.0.2"
        assert raw(server, "/layer.json", host="127.0.0.2")[0] == 200
        with pytest.raises(ConnectionRefusedError):
            socket.create_connection(("127.0.0.1", server.server_port), timeout=5).close()


def test_find_cesium_looks_where_it_says(folder, tmp_path):
    build = (tmp_path / "node_modules" / "cesium" / "Build" / "Cesium").resolve()
    assert find_cesium(None, environ={}, start=folder / "0" / "0") == build  # node_modules in a parent
    assert find_cesium(str(tmp_path / "node_modules" / "cesium"), environ={}) == build  # the npm package's root
    assert find_cesium(None, environ={"TINSMITH_CESIUM": str(build)}, start="/") == build
    empty = tmp_path / "empty"
    empty.mkdir()
    assert find_cesium(None, environ={}, start=empty) == build
    assert find_cesium(None, environ={}, start="/") is None
    with pytest.raises(FileError, match="--cesium '.*pyramid' is no CesiumJS build"):
        find_cesium(str(folder), environ={"TINSMITH_CESIUM": str(build)})
    with pytest.raises(FileError, match="TINSMITH_CESIUM '.*' is no CesiumJS build"):
        find_cesium(None, environ={"TINSMITH_CESIUM": str(empty)})


@pytest.mark.parametrize("case", ["missing", "file", "no-manifest", "port-in-use", "bad-cesium", "bad-host"])
def test_cli_errors_take_one_line(folder, tmp_path, capsys, case):
    args = ["serve", str(folder), "--no-open", "--port", "0"]
    blocker = None
    if case == "missing":
        args[1] = str(tmp_path / "nope")
    elif case == "file":
        args[1] = str(folder / "layer.json")
    elif case == "no-manifest":
        args[1] = str(folder / "0")
    elif case == "port-in-use":
        blocker = socket.socket()
        blocker.bind(("127.0.0.1", 0))
        blocker.listen()
        args[4] = str(blocker.getsockname()[1])
    elif case == "bad-cesium":
        args += ["--cesium", str(tmp_path / "outside")]
    else:
        args += ["--host", "192.0.2.1"]  # TEST-NET-1 (RFC 5737): no address of this machine
    try:
        code = main(args)
    finally:
        if blocker is not None:
            blocker.close()
    err = capsys.readouterr().err
    assert code == 1
    assert len(err.strip().splitlines()) == 1 and err.startswith("tinsmith: error: "), err
    expected = {"missing": "does not exist", "file": "is not a folder", "no-manifest": "has no layer.json or tileset.json",
                "port-in-use": "is in use", "bad-cesium": "is no CesiumJS build", "bad-host": "no address"}[case]
    assert expected in err


def _interruptible() -> None:
    """In the child: SIGINT as a terminal delivers it, even when the test run ignores it (a run started in the
    background by a non-interactive shell does, and Python then never turns SIGINT into KeyboardInterrupt)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def test_the_command_serves_until_ctrl_c_and_stops_cleanly(folder, tmp_path):
    """A real process: the address on 127.0.0.1, the notice without CesiumJS, and SIGINT ends it without a traceback."""
    env = {k: v for k, v in os.environ.items() if k != "TINSMITH_CESIUM"}
    env["PYTHONPATH"] = str(ROOT / "src") + os.pathsep + env.get("PYTHONPATH", "")
    shutil.rmtree(tmp_path / "node_modules")  # no CesiumJS here or in a parent
    cwd = tmp_path / "outside"
    proc = subprocess.Popen([sys.executable, "-m", "tinsmith", "serve", str(folder), "--port", "0", "--no-open"],
                            cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=_interruptible)
    try:
        first = proc.stderr.readline()
        match = re.search(r"on 127\.0\.0\.1 port (\d+): open http://127\.0\.0\.1:(\d+)/", first)
        assert match, first
        notice = proc.stderr.readline()
        assert "no CesiumJS build found" in notice and "npm install cesium" in notice and "--cesium" in notice
        with socket.create_connection(("127.0.0.1", int(match.group(1))), timeout=10) as sock:
            sock.sendall(b"GET /layer.json HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
            assert sock.recv(100).startswith(b"HTTP/1.1 200")
        time.sleep(0.2)
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=20)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0
    assert "Traceback" not in err and err.strip().splitlines() == ["tinsmith serve: stopped"]


@pytest.fixture(scope="module")
def sample_pyramid(tmp_path_factory):
    from tinsmith.tiles.cesium import quantized_mesh_pyramid

    out = tmp_path_factory.mktemp("sample-pyramid")
    quantized_mesh_pyramid(tinsmith.sample_path("st-helens"), out, max_error=10.0, tile_cells=32, max_zoom=10, certify=False,
                           normals=True, workers=1)
    return out


@pytest.mark.skipif(not CESIUM.exists() and not os.environ.get("CI"),
                    reason="CesiumJS not installed here (CI runs npm ci in tests/js)")
def test_the_page_shows_the_pyramid_in_cesiumjs(sample_pyramid):
    """Headless Chromium loads the page: the provider is ready, the tiles load, no page error, no other host."""
    from tinsmith.viz.browser import FLAGS, chromium_path

    if not os.environ.get("CI"):
        pytest.importorskip("playwright")
        if chromium_path() is None:
            pytest.skip("no Chromium binary on the PATH")
    from playwright.sync_api import sync_playwright

    errors, requests = [], []
    with running(sample_pyramid, cesium=find_cesium(CESIUM)) as server, sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium_path(), args=FLAGS)
        try:
            page = browser.new_page(viewport={"width": 640, "height": 400})
            page.on("pageerror", lambda exc: errors.append(str(exc)))
            page.on("request", lambda r: requests.append(r.url))
            page.goto(server.url)
            page.wait_for_selector("body[data-ready]", state="attached", timeout=120_000)
            status = page.evaluate("window.tinsmith")
            page.screenshot(path=str(Path(os.environ.get("TMPDIR", "/tmp")) / "tinsmith-serve-page.png"))
        finally:
            browser.close()
    assert status["state"] == "terrain" and status["provider"] == "ready", status
    assert status["kind"] == "quantized-mesh" and status["errors"] == [] and errors == []
    bounds = json.loads((sample_pyramid / "layer.json").read_text())["bounds"]
    assert status["bounds"] == pytest.approx(bounds)
    foreign = [u for u in requests if not u.startswith((server.url, f"blob:{server.url}", "data:"))]
    assert not foreign, foreign
    assert any(".terrain" in u for u in requests) and any(u.endswith("/cesium/Cesium.js") for u in requests)


def test_tile_serve_goes_with_a_pyramid_only(tmp_path, capsys):
    code = main(["tile", "--sample", "st-helens", "-o", str(tmp_path / "m.ply"), "--max-error", "5", "--serve"])
    err = capsys.readouterr().err
    assert code == 1 and err.strip() == "tinsmith tile: error: --serve goes with --format quantized-mesh or 3dtiles-terrain"
    assert not (tmp_path / "m.ply").exists()


def test_tile_serve_serves_the_finished_pyramid(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "TINSMITH_CESIUM"}
    env["PYTHONPATH"] = str(ROOT / "src") + os.pathsep + env.get("PYTHONPATH", "")
    out = tmp_path / "qm"
    proc = subprocess.Popen([sys.executable, "-m", "tinsmith", "tile", "--sample", "st-helens", "-o", str(out),
                             "--format", "quantized-mesh", "--max-error", "20", "--tile-cells", "16", "--min-zoom", "9",
                             "--max-zoom", "9", "--workers", "1", "--serve", "--no-open"],
                            cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=_interruptible)
    try:
        for line in proc.stderr:
            match = re.search(r"on 127\.0\.0\.1 port (\d+): open", line)
            if match:
                break
        assert match, "no address on standard error"
        with socket.create_connection(("127.0.0.1", int(match.group(1))), timeout=10) as sock:
            sock.sendall(b"GET /layer.json HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
            data = b""
            while chunk := sock.recv(65536):
                data += chunk
        assert data.startswith(b"HTTP/1.1 200") and data.endswith((out / "layer.json").read_bytes())
        proc.send_signal(signal.SIGINT)
        stdout, err = proc.communicate(timeout=20)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0 and "level 9:" in stdout
    assert "Traceback" not in err and err.strip().splitlines()[-1] == "tinsmith serve: stopped"


def test_the_page_without_cesiumjs_says_how_to_get_it(folder):
    from tinsmith.viz.browser import FLAGS, chromium_path

    if not os.environ.get("CI"):
        pytest.importorskip("playwright")
        if chromium_path() is None:
            pytest.skip("no Chromium binary on the PATH")
    from playwright.sync_api import sync_playwright

    with running(folder) as server, sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium_path(), args=FLAGS)
        try:
            page = browser.new_page()
            page.goto(server.url)
            page.wait_for_selector("body[data-ready]", state="attached", timeout=30_000)
            state, text = page.evaluate("[document.body.dataset.ready, document.getElementById('panel').innerText]")
        finally:
            browser.close()
    assert state == "no-cesium"
    assert "npm install cesium" in text and "--cesium" in text
