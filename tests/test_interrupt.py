"""Runs stopped by SIGKILL leave no partial output and no temporary file; tile resumes to the same mesh.

The commands run as real processes (``python -m tinsmith``).  ``simplify`` is
killed while it writes (its anonymous output file is seen in ``/proc/PID/fd``)
and at other moments; ``tile`` is killed after a few tiles are logged in its
parts folder, then run again.  Waits are bounded generously to catch hangs
only: no test here depends on how fast the machine is.
"""

from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import rasterio
from rasterio.transform import Affine

import tinsmith

pytestmark = pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="needs Linux's /proc")

#: Bound on any wait here: a hang guard, minutes for work of seconds.
PATIENCE = 240.0


def _dem(path: Path, size: int) -> Path:
    r, c = np.mgrid[0:size, 0:size]
    z = (100 + 30 * np.sin(r / 37.0) * np.cos(c / 23.0) + 0.05 * r + 3 * np.sin(r * c / 900.0)).astype(np.float32)
    with rasterio.open(path, "w", driver="GTiff", width=size, height=size, count=1, dtype="float32",
                       transform=Affine(2, 0, 400000, 0, -2, 5000000), crs="EPSG:32610") as ds:
        ds.write(z, 1)
    return path


def _start(*args) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "tinsmith", *map(str, args)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def _open_in(pid: int, folder: Path) -> bool:
    """Whether process ``pid`` holds a file of ``folder`` open (an anonymous output shows as ``folder/#N (deleted)``)."""
    try:
        fds = os.listdir(f"/proc/{pid}/fd")
    except OSError:
        return False
    for fd in fds:
        try:
            target = os.readlink(f"/proc/{pid}/fd/{fd}")
        except OSError:
            continue
        if target.startswith(str(folder) + "/"):
            return True
    return False


def _kill_when(proc: subprocess.Popen, condition) -> bool:
    """SIGKILL ``proc`` as soon as ``condition()`` holds; False when it ended first."""
    deadline = time.monotonic() + PATIENCE
    while proc.poll() is None:
        if condition():
            proc.send_signal(signal.SIGKILL)
            proc.wait(PATIENCE)
            return True
        assert time.monotonic() < deadline, "the command hung"
        time.sleep(0.0005)
    return False


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_simplify_killed_while_writing_leaves_nothing(tmp_path):
    dem = _dem(tmp_path / "dem.tif", 900)
    before = _digest(dem)
    out = tmp_path / "out"
    out.mkdir()
    killed_writing = 0
    for attempt in range(3):
        proc = _start("simplify", dem, "-o", out / "mesh.obj", "-o", out / "mesh.ply", "--method", "grid")
        if _kill_when(proc, lambda: _open_in(proc.pid, out)):
            killed_writing += 1
        assert sorted(os.listdir(out)) == [] or proc.returncode == 0, (attempt, os.listdir(out))
    assert killed_writing >= 1, "never caught the command while it wrote"
    # killed at other moments (reading, meshing, after the last file is in place): nothing, or every file whole
    # (as an uninterrupted run writes them)
    whole = tmp_path / "whole"
    whole.mkdir()
    assert _start("simplify", dem, "-o", whole / "mesh.obj", "--method", "grid").wait(PATIENCE) == 0
    expected = {name: _digest(whole / name) for name in os.listdir(whole)}
    killed_early = 0
    for delay in (0.3, 1.0, 2.0):
        for name in os.listdir(out):
            (out / name).unlink()
        proc = _start("simplify", dem, "-o", out / "mesh.obj", "--method", "grid")
        time.sleep(delay)
        proc.send_signal(signal.SIGKILL)
        proc.wait(PATIENCE)
        found = {name: _digest(out / name) for name in os.listdir(out)}
        assert found in ({}, expected), (delay, proc.returncode, sorted(found))
        killed_early += proc.returncode == -signal.SIGKILL and not found
    assert killed_early >= 1, "every run had written its mesh before it was killed"
    assert _digest(dem) == before


def test_tile_killed_midway_resumes_to_the_same_mesh(tmp_path):
    dem = _dem(tmp_path / "dem.tif", 640)
    before = _digest(dem)
    whole = tmp_path / "whole"
    whole.mkdir()
    done = subprocess.run([sys.executable, "-m", "tinsmith", "tile", dem, "-o", whole / "mesh.ply", "--max-error",
                           "0.5", "--tile-size", "64", "--workers", "1"], capture_output=True, text=True,
                          timeout=PATIENCE)
    assert done.returncode == 0, done.stderr

    out = tmp_path / "out"
    out.mkdir()
    target, parts = out / "mesh.ply", out / "mesh.ply.parts"
    log = parts / "tiles.jsonl"

    def logged(n: int) -> bool:
        try:
            return log.read_text().count("\n") >= n
        except OSError:
            return False

    proc = _start("tile", dem, "-o", target, "--max-error", "0.5", "--tile-size", "64", "--workers", "1")
    assert _kill_when(proc, lambda: logged(5)), "the tiled run ended before it could be stopped"
    # no output, no temporary file: only the parts folder with its own files
    assert os.listdir(out) == ["mesh.ply.parts"]
    names = os.listdir(parts)
    assert not [n for n in names if n.startswith(".")], names
    assert {"job.json", "tiles.jsonl"} <= set(names) and sum(n.endswith(".npz") for n in names) >= 5

    resumed = subprocess.run([sys.executable, "-m", "tinsmith", "tile", dem, "-o", target, "--max-error", "0.5",
                              "--tile-size", "64", "--workers", "1", "--json"], capture_output=True, text=True,
                             timeout=PATIENCE)
    assert resumed.returncode == 0, resumed.stderr
    assert json.loads(resumed.stdout)["reused_tiles"] >= 5
    assert sorted(os.listdir(out)) == ["mesh.ply", "mesh.prj"]  # the parts folder is removed after success
    a, b = tinsmith.read_mesh(whole / "mesh.ply"), tinsmith.read_mesh(target)
    np.testing.assert_array_equal(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.triangles, b.triangles)
    assert _digest(dem) == before


def test_named_temporaries_of_a_killed_process_are_removed_by_the_next_write(tmp_path):
    """GeoPackage and GeoJSON need a named temporary; what a killed run left is swept by the next write."""
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = tmp_path / f".mesh.gpkg.{dead.pid}.abc123.tmp.gpkg"
    stale.write_bytes(b"half a file")
    mine = tmp_path / f".other.ply.{os.getpid()}.xyz.tmp.ply"  # a live process's: left alone
    mine.write_bytes(b"in use")
    mesh = tinsmith.simplify(tinsmith.sample("st-helens"), max_error=50)
    tinsmith.write(mesh, tmp_path / "mesh.gpkg")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([mine.name, "mesh.gpkg"])
