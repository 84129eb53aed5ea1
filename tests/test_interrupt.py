"""Runs stopped by SIGKILL or SIGTERM leave no partial output, no temporary file and no worker; tile resumes.

The commands run as real processes (``python -m tinsmith``).  ``simplify`` is
killed while it writes (its anonymous output file is seen in ``/proc/PID/fd``)
and at other moments; ``tile`` is killed after a few tiles are logged in its
parts folder, then run again; ``tile --workers 2`` gets SIGTERM (it ends as
Ctrl-C ends it) or SIGKILL once its two workers exist, and the workers must
end with it.  Waits are bounded generously to catch hangs only: no test here
depends on how fast the machine is.
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


def _children(pid: int) -> list[int]:
    """The processes whose parent is ``pid`` (from /proc/*/stat)."""
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                stat = Path(f"/proc/{entry}/stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                found.append(int(entry))
    return found


def _lines(path: Path) -> int:
    try:
        return path.read_text().count("\n")
    except OSError:
        return 0


def _running(pid: int) -> bool:
    """Whether ``pid`` is a process that has not ended (a zombie has ended, waiting for its reaper)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] not in ("Z", "X")
    except OSError:
        return False


def _noisy_dem(path: Path, size: int) -> Path:
    """Rough terrain: greedy insertion keeps most cells, so a tile of 512 cells takes a while."""
    r, c = np.mgrid[0:size, 0:size]
    noise = np.random.default_rng(7).normal(0, 0.6, (size, size))
    z = (100 + 30 * np.sin(r / 37.0) * np.cos(c / 23.0) + 0.05 * r + noise).astype(np.float32)
    with rasterio.open(path, "w", driver="GTiff", width=size, height=size, count=1, dtype="float32",
                       transform=Affine(2, 0, 400000, 0, -2, 5000000), crs="EPSG:32610") as ds:
        ds.write(z, 1)
    return path


def _stop_pooled_tile(tmp_path: Path, sig: int, tiles_done: int = 0) -> tuple[subprocess.Popen, str, Path]:
    """Start ``tile --workers 2``, send ``sig`` once both workers exist (and ``tiles_done`` tiles are logged);
    the workers must end with the run.

    Returns the process, its standard error and the output folder.
    """
    dem = _noisy_dem(tmp_path / "dem.tif", 1024)
    out = tmp_path / "out"
    out.mkdir()
    proc = _start("tile", dem, "-o", out / "mesh.ply", "--max-error", "0.5", "--tile-size", "512", "--workers", "2")
    workers: list[int] = []
    try:
        deadline = time.monotonic() + PATIENCE
        log = out / "mesh.ply.parts" / "tiles.jsonl"
        while len(workers) < 2 or (tiles_done and _lines(log) < tiles_done):
            assert proc.poll() is None, f"the run ended before it could be stopped: {proc.stderr.read()!r}"
            assert time.monotonic() < deadline, "the run hung"
            time.sleep(0.01)
            workers = workers if len(workers) == 2 else _children(proc.pid)
        proc.send_signal(sig)
        proc.wait(PATIENCE)
        deadline = time.monotonic() + PATIENCE  # a hang guard: the workers end in well under a second
        while any(_running(w) for w in workers) and time.monotonic() < deadline:
            time.sleep(0.05)
        left = [w for w in workers if _running(w)]
        assert not left, f"workers {left} outlived the run"
        err = proc.stderr.read().decode()  # no worker holds the pipe open any more
    finally:
        for w in workers:  # the ones this test started, should they have outlived the run
            if _running(w):
                os.kill(w, signal.SIGKILL)
        if proc.poll() is None:
            proc.kill()
    return proc, err, out


def _no_output_and_no_temporary(out: Path) -> None:
    """Only the parts folder (resumable state: its own files, none of them temporary), or nothing."""
    assert set(os.listdir(out)) <= {"mesh.ply.parts"}, os.listdir(out)
    parts = out / "mesh.ply.parts"
    if parts.exists():
        names = os.listdir(parts)
        assert not [n for n in names if n.startswith(".")], names
        assert all(n in ("job.json", "tiles.jsonl") or (n.startswith("tile_") and n.endswith(".npz"))
                   for n in names), names


@pytest.mark.parametrize("tiles_done", [0, 1], ids=["at-once", "after-a-tile"])
def test_tile_terminated_ends_as_ctrl_c_does_and_its_workers_with_it(tmp_path, tiles_done):
    """SIGTERM (a job scheduler, a container's stop): exit code 1 and 'tinsmith: aborted', as for Ctrl-C; the
    parts folder kept for its finished tiles, gone when there were none."""
    proc, err, out = _stop_pooled_tile(tmp_path, signal.SIGTERM, tiles_done)
    assert proc.returncode == 1, (proc.returncode, err)
    assert [line for line in err.splitlines() if line.strip()] == ["tinsmith: aborted"], err
    _no_output_and_no_temporary(out)
    parts = out / "mesh.ply.parts"
    if tiles_done:
        names = os.listdir(parts)
        assert {"job.json", "tiles.jsonl"} <= set(names) and sum(n.endswith(".npz") for n in names) >= tiles_done
    elif parts.exists():  # kept only for the tiles it holds
        assert any(n.endswith(".npz") for n in os.listdir(parts)), os.listdir(parts)


def test_tile_killed_takes_its_workers_with_it(tmp_path):
    """SIGKILL (the OOM killer, ``kill -9``) runs no cleanup: the kernel ends the workers (parent-death signal)."""
    proc, err, out = _stop_pooled_tile(tmp_path, signal.SIGKILL)
    assert proc.returncode == -signal.SIGKILL, (proc.returncode, err)
    assert "Traceback" not in err, err
    _no_output_and_no_temporary(out)


def test_a_stopped_pool_does_not_wait_for_a_result_cut_short(tmp_path):
    """A worker ended in the middle of sending its result must not leave the process waiting for the rest."""
    script = tmp_path / "half.py"
    script.write_text(f"""
import gc, os, struct, sys, time
from multiprocessing.queues import SimpleQueue
from tinsmith._pool import process_pool, stop_pool

def half(flag):  # the header of a 1000-byte result, 10 bytes of it, then nothing
    queue = [o for o in gc.get_objects() if isinstance(o, SimpleQueue)][0]
    os.write(queue._writer.fileno(), struct.pack("!i", 1000) + b"x" * 10)
    open(flag, "w").close()
    time.sleep({PATIENCE})

if __name__ == "__main__":
    pool = process_pool(1)
    flag = {str(tmp_path / "sending")!r}
    pool.submit(half, flag)
    while not os.path.exists(flag):
        time.sleep(0.01)
    stop_pool(pool)
    print("stopped")
""")
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=PATIENCE)
    assert done.returncode == 0 and done.stdout.strip() == "stopped", done.stderr


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
        if _kill_when(proc, lambda proc=proc: _open_in(proc.pid, out)):
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
