"""The :class:`Heightfield`: a georeferenced elevation grid with explicit nodata."""

from __future__ import annotations

import math

import numpy as np

from .. import _checks
from ..errors import InvalidInputError, NoDataError

__all__ = ["Heightfield", "pixel_to_world", "world_to_pixel"]


#: No elevation in any unit (metres, feet, millimetres) reaches this magnitude; such a cell is a
#: nodata value nobody declared (1e30, float32's -3.4e38), and meshing it would make a spike.
MAX_ABS_HEIGHT = 1e8


def _refuse_impossible_heights(heights: np.ndarray, dense: bool) -> None:
    """Raise when valid cells hold heights beyond :data:`MAX_ABS_HEIGHT` (``dense``: no NaN in ``heights``)."""
    lo, hi = (heights.min(), heights.max()) if dense else (np.nanmin(heights), np.nanmax(heights))
    if max(-float(lo), float(hi)) <= MAX_ABS_HEIGHT:
        return
    bad = np.abs(heights) > MAX_ABS_HEIGHT
    values, counts = np.unique(heights[bad], return_counts=True)
    value = values[np.argmax(counts)].item()  # float32's shortest form: --nodata 1e+30 matches 1e30 stored as float32
    value = float(str(values.dtype.type(value))) if values.dtype == np.float32 else value
    raise InvalidInputError(
        f"{int(bad.sum()):,} cell(s) hold heights beyond +/-{MAX_ABS_HEIGHT:g} (e.g. {value!r}), which no elevation "
        f"reaches in any unit: an undeclared nodata value? declare it: --nodata {value!r} (nodata={value!r} in Python)"
    )


class Heightfield:
    """A raster of heights ``z[row, col]`` with an affine transform, a CRS and nodata.

    Row 0 is the north edge (as in GeoTIFF).  Heights are stored as float32 when
    that holds every value of the input exactly (float32, int16, uint8, ...: most
    DEMs, at half the memory) and as float64 otherwise, with NaN in every nodata
    cell, so an algorithm that forgets the mask produces NaN, never a silent
    spike.  The array is read-only; the caller's array is copied.

    Parameters
    ----------
    z : (H, W) array_like
        Heights.  ``H`` and ``W`` must both be at least 2.
    transform : sequence of 6 floats, optional
        Affine transform ``(a, b, c, d, e, f)`` in the order of the ``affine``
        package: the *corner* of cell ``(row, col)`` is at
        ``x = a*col + b*row + c``, ``y = d*col + e*row + f``.  Mutually
        exclusive with ``cell_size``.
    cell_size : float or (float, float), optional
        Cell width and height for a north-up grid without a transform.
    origin : (float, float), optional
        With ``cell_size``: world ``(x, y)`` of the north-west corner of the
        grid.  Default ``(0, H * dy)``, so the south-west corner is ``(0, 0)``.
    crs : str, optional
        Coordinate reference system as WKT (or any string the writers accept,
        such as ``"EPSG:32610"``).
    nodata : float, optional
        Heights equal to this value are nodata; ``nan`` marks NaN cells.
    nodata_mask : (H, W) bool array_like, optional
        True where the cell is nodata, combined with ``nodata``.
    source_dtype : str, optional
        Type of the heights in the file they came from; writers use it to
        write a raster back without loss.  Default: the dtype of ``z``.

    Raises
    ------
    InvalidInputError
        For a grid smaller than 2 x 2, a degenerate transform, or non-finite
        heights in cells that are not declared nodata.
    NoDataError
        When every cell is nodata.

    Examples
    --------
    >>> import numpy as np
    >>> import tinsmith
    >>> z = np.array([[3.0, 4.0, 5.0], [2.0, np.nan, 4.0], [1.0, 2.0, 3.0]])
    >>> hf = tinsmith.Heightfield(z, cell_size=10.0, nodata=float("nan"))
    >>> hf
    Heightfield(3 x 3, cell 10 x 10, z 1..5, nodata 11.1%, crs=none)
    >>> hf.bounds  # the south-west corner at (0, 0) by default
    (0.0, 0.0, 30.0, 30.0)
    >>> hf.n_valid, bool(hf.valid[1, 1])
    (8, False)
    """

    def __init__(
        self,
        z,
        *,
        transform=None,
        cell_size=None,
        origin=None,
        crs: str | None = None,
        nodata: float | None = None,
        nodata_mask=None,
        source_dtype: str | None = None,
    ):
        heights, source = _as_heights(z)
        self.source_dtype = str(source_dtype or source)
        invalid, self.nodata = _nodata_cells(heights, nodata, nodata_mask)

        # every cell finite (the common case) is decided without a temporary grid
        all_finite = bool(np.isfinite(heights.min()) and np.isfinite(heights.max()))
        bad = None if all_finite else ~np.isfinite(heights) & ~invalid
        if bad is not None and bad.any():
            n_nan = int(np.isnan(heights[bad]).sum())
            n_inf = int(bad.sum()) - n_nan
            raise InvalidInputError(
                f"z has {n_nan} NaN and {n_inf} infinite cells that are not declared nodata; "
                "declare them with nodata=nan (CLI: --nodata nan) or a nodata_mask"
            )
        if invalid.all():
            raise NoDataError("every cell of the heightfield is nodata")
        if invalid.any():
            heights[invalid] = np.nan
        _refuse_impossible_heights(heights, all_finite and not invalid.any())
        heights.flags.writeable = False
        invalid.flags.writeable = False
        self.z = heights
        self.nodata_mask = invalid
        self.transform = _grid_transform(heights.shape, transform, cell_size, origin)
        self.crs = crs or None

    # -- shape and georeferencing ---------------------------------------------------
    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols)."""
        return self.z.shape

    @property
    def cell_size(self) -> tuple[float, float]:
        """(width, height) of a cell in world units."""
        a, b, _, d, e, _ = self.transform
        return (math.hypot(a, d), math.hypot(b, e))

    @property
    def is_north_up(self) -> bool:
        """True when the grid has no rotation or shear and row 0 is north."""
        a, b, _, d, e, _ = self.transform
        return b == 0.0 and d == 0.0 and a > 0.0 and e < 0.0

    @property
    def handedness(self) -> int:
        """+1 when (col, row) -> (x, y) keeps orientation, -1 when it mirrors (north-up)."""
        a, b, _, d, e, _ = self.transform
        return 1 if a * e - b * d > 0 else -1

    def pixel_to_world(self, row, col):
        """World ``(x, y)`` of cell centres; ``row`` and ``col`` may be fractional arrays."""
        return pixel_to_world(self.transform, row, col)

    def world_to_pixel(self, x, y):
        """Fractional ``(row, col)`` whose cell centre is at world ``(x, y)``."""
        return world_to_pixel(self.transform, x, y)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the cell edges."""
        h, w = self.shape
        corners_r = np.array([0, 0, h, h], dtype=np.float64) - 0.5
        corners_c = np.array([0, w, 0, w], dtype=np.float64) - 0.5
        x, y = self.pixel_to_world(corners_r, corners_c)
        return (float(x.min()), float(y.min()), float(x.max()), float(y.max()))

    # -- content ----------------------------------------------------------------------
    @property
    def valid(self) -> np.ndarray:
        """(H, W) bool, True where the cell has a height."""
        return ~self.nodata_mask

    @property
    def n_cells(self) -> int:
        return int(self.z.size)

    @property
    def n_valid(self) -> int:
        return int(self.z.size - np.count_nonzero(self.nodata_mask))

    @property
    def nodata_fraction(self) -> float:
        return 1.0 - self.n_valid / self.n_cells

    @property
    def z_range(self) -> tuple[float, float]:
        return (float(np.nanmin(self.z)), float(np.nanmax(self.z)))

    def grid_spec(self) -> dict:
        """Shape, transform and CRS: what a writer needs to rasterise onto this grid."""
        return {"shape": list(self.shape), "transform": list(self.transform), "crs": self.crs}

    def __repr__(self) -> str:
        h, w = self.shape
        dx, dy = self.cell_size
        lo, hi = self.z_range
        return (
            f"Heightfield({h} x {w}, cell {dx:g} x {dy:g}, z {lo:g}..{hi:g}, "
            f"nodata {100 * self.nodata_fraction:.1f}%, crs={'yes' if self.crs else 'none'})"
        )


def _as_heights(z) -> tuple[np.ndarray, np.dtype]:
    """A private copy of ``z`` as float32 (when that is lossless) or float64, and the dtype it had."""
    arr = np.asarray(z)
    if arr.ndim != 2:
        raise InvalidInputError(f"z must be a 2-D array (rows, cols), got shape {arr.shape}")
    if arr.shape[0] < 2 or arr.shape[1] < 2:
        raise InvalidInputError(
            f"z must have at least 2 x 2 cells to form a triangle, got {arr.shape[0]} x {arr.shape[1]}"
        )
    if not (np.issubdtype(arr.dtype, np.number) and not np.issubdtype(arr.dtype, np.complexfloating)):
        raise InvalidInputError(f"z must hold real numbers, got dtype {arr.dtype}")
    lossless32 = np.can_cast(arr.dtype, np.float32, casting="safe")
    return np.array(arr, dtype=np.float32 if lossless32 else np.float64, copy=True), arr.dtype


def _nodata_cells(heights: np.ndarray, nodata, nodata_mask) -> tuple[np.ndarray, float | None]:
    """(True where a cell is declared nodata by ``nodata_mask`` or ``nodata``, ``nodata`` as a float or None)."""
    invalid = np.zeros(heights.shape, dtype=bool)
    if nodata_mask is not None:
        m = np.asarray(nodata_mask)
        if m.shape != heights.shape:
            raise InvalidInputError(
                f"nodata_mask must have the shape of z {heights.shape}, got {m.shape}"
            )
        invalid |= m.astype(bool)
    if nodata is not None:
        try:
            nodata = float(nodata)
        except (TypeError, ValueError):
            raise InvalidInputError(f"nodata must be a number or nan, got {nodata!r}") from None
        invalid |= np.isnan(heights) if math.isnan(nodata) else heights == nodata
    return invalid, nodata


def _grid_transform(shape: tuple[int, int], transform, cell_size, origin) -> tuple:
    """The affine transform (a, b, c, d, e, f) of a grid of ``shape`` from a transform, or a cell size and origin."""
    if transform is not None and cell_size is not None:
        raise InvalidInputError("give either transform or cell_size, not both")
    if transform is None:
        if cell_size is None:
            raise InvalidInputError(
                "a heightfield needs georeferencing: pass cell_size (and origin) or transform"
            )
        dx, dy = _pair("cell_size", cell_size)
        if origin is None:
            origin = (0.0, shape[0] * dy)
        x0, y0 = (_checks.number(f"origin[{i}]", v) for i, v in enumerate(_pair_raw("origin", origin)))
        transform = (dx, 0.0, x0, 0.0, -dy, y0)
    elif origin is not None:
        raise InvalidInputError("origin goes with cell_size; a transform already places the grid")
    t = tuple(float(v) for v in tuple(transform)[:6])
    if len(t) != 6 or not all(math.isfinite(v) for v in t):
        raise InvalidInputError(f"transform must be 6 finite numbers (a, b, c, d, e, f), got {transform!r}")
    if t[0] * t[4] - t[1] * t[3] == 0.0:
        raise InvalidInputError(f"transform must not be degenerate (a*e - b*d != 0), got {t!r}")
    return t


def _pair_raw(name, value):
    if np.ndim(value) == 0:
        return (value, value)
    seq = tuple(value)
    if len(seq) != 2:
        raise InvalidInputError(f"{name} must be a number or a pair of numbers, got {value!r}")
    return seq


def _pair(name, value):
    return tuple(
        _checks.number(name, v, minimum=0.0, exclusive_min=True) for v in _pair_raw(name, value)
    )


def pixel_to_world(transform, row, col):
    """World ``(x, y)`` of the centres of cells ``(row, col)`` of a grid with the affine ``transform``."""
    a, b, c, d, e, f = transform
    col = np.asarray(col, dtype=np.float64) + 0.5
    row = np.asarray(row, dtype=np.float64) + 0.5
    return a * col + b * row + c, d * col + e * row + f


def world_to_pixel(transform, x, y):
    """Fractional ``(row, col)`` whose cell centre is at world ``(x, y)`` in a grid with the affine ``transform``."""
    a, b, c, d, e, f = transform
    det = a * e - b * d
    x = np.asarray(x, dtype=np.float64) - c
    y = np.asarray(y, dtype=np.float64) - f
    col = (e * x - b * y) / det - 0.5
    row = (-d * x + a * y) / det - 0.5
    return row, col
