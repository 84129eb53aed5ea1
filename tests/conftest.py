"""Shared fixtures: small analytic surfaces and the real data in ../shared/data."""

from __future__ import annotations

import contextlib
import faulthandler
import os
import sys
from pathlib import Path

import numpy as np
import pytest

from tinsmith.core import Heightfield

# The tests check standard error line by line; on a fresh numba cache the command line would add
# its compile notice. Tests of the notice itself turn it back on (tests/test_startup.py).
os.environ["TINSMITH_COMPILE_NOTICE"] = "0"

ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = ROOT.parent / "shared" / "data"


def pytest_addoption(parser):
    parser.addoption("--long", action="store_true",
                     help="also run the long measurements (marked long): the same checks on larger data")


def pytest_collection_modifyitems(config, items):
    if config.getoption("--long"):
        return
    skip = pytest.mark.skip(reason="long measurement: run with --long")
    for item in items:
        if "long" in item.keywords:
            item.add_marker(skip)


def shared(relative: str) -> Path:
    """Path of a file in ../shared/data; skips the test when the folder is absent."""
    path = SHARED_DATA / relative
    if not path.exists():
        pytest.skip(f"shared data not available: {relative}")
    return path


@pytest.fixture
def plane_hf() -> Heightfield:
    """Tilted plane z = 100 + 0.5 x - 0.25 y on a 12 x 15 grid of 2 m cells, EPSG:32610."""
    rows, cols = 12, 15
    hf0 = Heightfield(np.zeros((rows, cols)), cell_size=2.0, origin=(500000.0, 4000030.0))
    r, c = np.mgrid[0:rows, 0:cols]
    x, y = hf0.pixel_to_world(r, c)
    return Heightfield(
        100 + 0.5 * (x - 500000.0) - 0.25 * (y - 4000000.0),
        cell_size=2.0,
        origin=(500000.0, 4000030.0),
        crs="EPSG:32610",
    )


@pytest.fixture
def cone_hf() -> Heightfield:
    """Cone of height 50 over a 41 x 41 grid of 1 m cells with a nodata corner block."""
    r, c = np.mgrid[0:41, 0:41]
    z = 50.0 - np.hypot(r - 20.0, c - 20.0)
    mask = np.zeros_like(z, dtype=bool)
    mask[:5, :5] = True
    return Heightfield(z, cell_size=1.0, nodata_mask=mask)


def punch_holes(z, data):
    """(z with NaN where a drawn boolean mask is True, the mask): a copy, for hypothesis tests with nodata."""
    from hypothesis import strategies as st
    from hypothesis.extra.numpy import arrays

    mask = data.draw(arrays(bool, z.shape, elements=st.booleans()))
    z = z.copy()
    z[mask] = np.nan
    return z, mask


def stop_after(n: int):
    """A progress callback ``(done, total)`` that interrupts a run once ``n`` tiles are done (a user's Ctrl-C)."""
    def progress(done, total):
        if done == n:
            raise KeyboardInterrupt
    return progress


@contextlib.contextmanager
def hang_guard(seconds: float = 300):
    """Abort the whole run with every thread's stack if the block takes longer than ``seconds``.

    A guard against hangs (a loop that never ends, a pool that never returns),
    not a performance limit: the bound is minutes for work of a second.
    """
    faulthandler.dump_traceback_later(seconds, exit=True, file=sys.__stderr__)
    try:
        yield
    finally:
        faulthandler.cancel_dump_traceback_later()
