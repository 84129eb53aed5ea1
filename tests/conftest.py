"""What the tests share: the real data in ../shared/data, small analytic surfaces, and one set of helpers.

Every test that reads the shared data finds it through :func:`shared` (or the
``shared_data`` fixture): the folder is located from this file, never from the
working directory, and a test skips with the missing path as its reason when the
folder or the file is absent.  The helpers that write inputs (:func:`write_tif`,
:func:`write_las`), run the command line (:func:`run_cli`) or build and judge
meshes (:func:`grid_mesh`, :func:`good_share`, :func:`euler`,
:func:`independent_heights`) live here once; test modules import them from
``.conftest``.
"""

from __future__ import annotations

import contextlib
import faulthandler
import os
import sys
from pathlib import Path

import numpy as np
import pytest

import tinsmith
from tinsmith.core import Heightfield

# The tests check standard error line by line; on a fresh numba cache the command line would add
# its compile notice. Tests of the notice itself turn it back on (tests/test_startup.py).
os.environ["TINSMITH_COMPILE_NOTICE"] = "0"

#: The repository's root folder (tests/..), whatever the working directory.
ROOT = Path(__file__).resolve().parents[1]
#: The real data the tests read: ../shared/data beside the repository.
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


def shared(relative: str = "") -> Path:
    """Path of ``relative`` (a file or folder) in ../shared/data, or of the folder itself; skips the test when absent.

    Call it inside a test (or a fixture), not at import: a module must collect without the data.
    """
    if not SHARED_DATA.is_dir():
        pytest.skip(f"shared data not available: no folder {SHARED_DATA}")
    path = SHARED_DATA / relative
    if not path.exists():
        pytest.skip(f"shared data not available: {relative} is not in {SHARED_DATA}")
    return path


@pytest.fixture
def shared_data() -> Path:
    """The ../shared/data folder (the test skips without it); files in it: :func:`shared`."""
    return shared()


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


# -- inputs the tests write -----------------------------------------------------------------------
#: The grid of :func:`write_tif` unless told otherwise: 2 m cells from (500000, 4000000), the north-west corner.
TRANSFORM = (2.0, 0.0, 500000.0, 0.0, -2.0, 4000000.0)


def write_tif(path, z, *, transform=TRANSFORM, crs="EPSG:32610", nodata=None, dtype=None, alpha=False):
    """A GeoTIFF of the heights ``z`` (rows, cols), or of several bands (bands, rows, cols); returns ``path``.

    ``transform`` is the affine ``(a, b, c, d, e, f)``, or None for a file without georeferencing;
    ``crs`` any rasterio CRS input or None; ``dtype`` the bands' type (default: that of ``z``);
    ``alpha`` marks the last band as an alpha band.
    """
    import rasterio
    from rasterio.transform import Affine

    z = np.asarray(z)
    bands = z[None] if z.ndim == 2 else z
    dtype = dtype or str(z.dtype)
    with rasterio.open(path, "w", driver="GTiff", width=bands.shape[2], height=bands.shape[1], count=len(bands),
                       dtype=dtype, transform=Affine(*transform) if transform else None, crs=crs, nodata=nodata) as ds:
        for b, band in enumerate(bands, 1):
            ds.write(band.astype(dtype), b)
        if alpha:
            from rasterio.enums import ColorInterp

            ds.colorinterp = [ColorInterp.gray] * (len(bands) - 1) + [ColorInterp.alpha]
    return path


def write_las(path, xyz, *, classes=None, crs="EPSG:32610", scales=0.001, offsets=None, point_format=1, **dimensions):
    """A LAS 1.2 file of the points ``xyz`` (N, 3); returns ``path``.  Skips the test without laspy (or pyproj).

    ``classes``: one class for every point or one per point (None: none written); ``crs``: any pyproj input,
    or None for a file without one; ``scales``: the stored resolution, one for x, y and z or three;
    ``offsets``: default the floor of the smallest coordinates; ``dimensions``: more point fields by name
    (``intensity=...``).
    """
    laspy = pytest.importorskip("laspy")
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    header = laspy.LasHeader(point_format=point_format, version="1.2")
    header.scales = np.broadcast_to(np.asarray(scales, np.float64), 3).copy()
    if offsets is not None:
        header.offsets = np.asarray(offsets, np.float64)
    else:
        header.offsets = np.floor(xyz.min(axis=0)) if len(xyz) else np.zeros(3)
    if crs is not None:
        pyproj = pytest.importorskip("pyproj")
        header.add_crs(pyproj.CRS.from_user_input(crs))
    data = laspy.LasData(header)
    data.x, data.y, data.z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    if classes is not None:
        data.classification = np.broadcast_to(np.asarray(classes, np.uint8), len(xyz))
    for name, values in dimensions.items():
        setattr(data, name, values)
    data.write(path)
    return path


# -- the command line ------------------------------------------------------------------------------
def run_cli(capsys, *args):
    """Run ``tinsmith ARGS`` in this process through its real entry point: (exit code, stdout, stderr).

    ``args`` may be paths or numbers (each passed as ``str``); ``capsys`` is the test's fixture.
    """
    from tinsmith.cli.main import main

    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


# -- meshes ----------------------------------------------------------------------------------------
def grid_mesh(z, cell: float = 1.0):
    """The full-resolution mesh (method ``grid``) of the heights ``z`` on square cells of ``cell``; NaN is nodata."""
    return tinsmith.simplify(Heightfield(np.asarray(z, float), cell_size=cell, nodata=float("nan")), method="grid")


def good_share(mesh) -> float:
    """Share of the triangles that are well shaped in 3-D: smallest angle at least 30 degrees, aspect ratio at most 3."""
    from tinsmith.metrics.quality import aspect_ratios, triangle_angles

    ang = triangle_angles(mesh, 3).min(axis=1)
    return float(((ang >= 30) & (aspect_ratios(mesh, 3) <= 3)).mean())


def euler(mesh) -> int:
    """The Euler characteristic V - E + F of a mesh (2 for a closed sphere, 0 for a torus, 1 for a disk)."""
    e, _ = mesh.edges()
    return mesh.n_vertices - len(e) + mesh.n_triangles


def independent_heights(mesh, xy):
    """Mesh heights at points by matplotlib's triangle finder and interpolator (not our kernels); NaN outside."""
    import matplotlib.tri as mtri

    tri = mtri.Triangulation(mesh.vertices[:, 0], mesh.vertices[:, 1], mesh.triangles)
    z = mtri.LinearTriInterpolator(tri, mesh.vertices[:, 2])(xy[:, 0], xy[:, 1])
    return np.ma.filled(z, np.nan)
