"""Memory estimates and refusals (tinsmith.resources)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

import tinsmith
from tinsmith.errors import InvalidOptionError, ResourceError
from tinsmith.resources import (
    MEMORY_LIMIT_VARIABLE,
    available_memory,
    check_memory,
    estimate_method,
    format_bytes,
    parse_size,
    raster_read_bytes,
)

from .conftest import shared


@pytest.mark.parametrize("text, expected", [("8000000", 8_000_000), ("512M", 512 * 2**20), ("8G", 8 * 2**30),
                                            ("1.5t", int(1.5 * 2**40)), ("2GiB", 2 * 2**30), (" 64 k ", 64 * 2**10)])
def test_sizes_parse(text, expected):
    assert parse_size(text) == expected


@pytest.mark.parametrize("text", ["", "abc", "-1G", "8X", "0", "1e3"])
def test_bad_sizes_name_the_variable(text):
    with pytest.raises(InvalidOptionError, match=MEMORY_LIMIT_VARIABLE):
        parse_size(text)


def test_available_memory_is_positive_and_the_variable_sets_it(monkeypatch):
    monkeypatch.delenv(MEMORY_LIMIT_VARIABLE, raising=False)
    free = available_memory()
    assert 0 < free < 2**62
    monkeypatch.setenv(MEMORY_LIMIT_VARIABLE, "100T")
    assert available_memory() > 99 * 2**40  # a user who knows better can raise it
    monkeypatch.setenv(MEMORY_LIMIT_VARIABLE, "1M")
    assert available_memory() == 0  # less than the interpreter itself holds


def test_estimates_grow_with_the_input_and_the_requested_vertices():
    for method in ("greedy", "grid", "quadtree", "decimate", "cvt", "remesh", "wavelet"):
        assert estimate_method(method, 10_000) < estimate_method(method, 1_000_000)
    assert estimate_method("remesh", 153_036, 2_000) < estimate_method("remesh", 153_036, 50_000)
    assert estimate_method("remesh", 153_036, 10**9) > 1e12  # the issue's --vertices 1000000000: terabytes
    assert raster_read_bytes(200_000, 200_000, 4) > 100 * 2**30


def test_the_refusal_is_one_line_with_the_estimate_what_is_available_and_what_to_do(monkeypatch):
    monkeypatch.setenv(MEMORY_LIMIT_VARIABLE, "1G")
    with pytest.raises(ResourceError) as info:
        check_memory(5 * 2**40, "reading 'big.tif' (1 x 1 cells)", "use 'tinsmith tile'")
    text = str(info.value)
    assert "\n" not in text and "5 TiB" in text and "available" in text and text.endswith("use 'tinsmith tile'")
    assert isinstance(info.value, MemoryError)
    monkeypatch.setenv(MEMORY_LIMIT_VARIABLE, "1000T")
    check_memory(1000, "a small step")  # fits: no error
    assert format_bytes(1536 * 2**20) == "1.5 GiB"


def test_a_raster_too_large_for_memory_is_refused_before_reading(tmp_path):
    import rasterio
    from rasterio.transform import Affine
    from rasterio.windows import Window

    path = tmp_path / "huge.tif"
    with rasterio.open(path, "w", driver="GTiff", width=200_000, height=200_000, count=1, dtype="float32",
                       tiled=True, blockxsize=256, blockysize=256, compress="deflate", sparse_ok=True,
                       transform=Affine(1, 0, 0, 0, -1, 200_000), crs="EPSG:32610") as ds:
        ds.write(np.ones((256, 256), np.float32), 1, window=Window(0, 0, 256, 256))
    assert path.stat().st_size < 50 * 2**20  # sparse: the test costs no disk
    with pytest.raises(ResourceError, match="200,000 x 200,000 cells.*tinsmith tile"):
        tinsmith.read_heightfield(path)


CHILD = r"""
import json, os, sys
import tinsmith

def status(key):
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) * 1024 for line in f if line.startswith(key + ":"))

hf = tinsmith.read_heightfield(sys.argv[1])
options = json.loads(sys.argv[3])
small = tinsmith.Heightfield(hf.z[200:240, 150:190], transform=hf.transform, crs=hf.crs, nodata=float("nan"))
tinsmith.simplify(small, method=sys.argv[2], **options)  # kernels compiled (or loaded) before measuring
with open("/proc/self/clear_refs", "w") as f:
    f.write("5")  # resets the peak resident size (VmHWM)
base = status("VmRSS")
tinsmith.simplify(hf, method=sys.argv[2], **options)
print(json.dumps({"peak": status("VmHWM") - base, "cells": hf.n_cells}))
"""

@pytest.mark.parametrize("dem", ["terrain/st_helens/SainteHelens_30m.tif",
                                 pytest.param("terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif",
                                              marks=pytest.mark.long)])
@pytest.mark.parametrize("method, options", [("greedy", {"max_error": 0.0}), ("remesh", {"n_vertices": 3000})])
def test_the_estimate_covers_the_measured_peak_on_real_dems(dem, method, options):
    done = subprocess.run([sys.executable, "-c", CHILD, str(shared(dem)), method, json.dumps(options)],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    run = json.loads(done.stdout.strip().splitlines()[-1])
    estimate = estimate_method(method, run["cells"], options.get("n_vertices", 0))
    assert estimate >= run["peak"], (estimate, run)
