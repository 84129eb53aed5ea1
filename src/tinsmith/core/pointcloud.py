"""The :class:`PointCloud`: unorganised 3-D points with classes and attributes."""

from __future__ import annotations

import math
from numbers import Integral

import numpy as np

from .. import _checks
from ..errors import InvalidInputError, InvalidOptionError, NoDataError
from ..resources import check_memory
from .heightfield import Heightfield

__all__ = ["PointCloud", "class_codes"]


#: Peak bytes per cell of gridding a cloud: heights, counts and sums (float64), the Heightfield.
GRIDDING_BYTES_PER_CELL = 48


class PointCloud:
    """Points ``xyz`` in world coordinates, with optional ASPRS classes and attributes.

    Parameters
    ----------
    xyz : (N, 3) array_like
        Coordinates; copied to float64 and made read-only.
    classification : (N,) array_like of int, optional
        ASPRS class codes (2 ground, 6 building, 9 water, ...).
    attributes : dict of str -> (N,) array_like, optional
        Any further per-point values (intensity, return number, colour, ...).
    crs : str, optional
        Coordinate reference system as WKT.

    Raises
    ------
    InvalidInputError
        For a wrong shape or non-finite coordinates.
    NoDataError
        For an empty cloud.

    Examples
    --------
    >>> import numpy as np
    >>> import tinsmith
    >>> rng = np.random.default_rng(0)
    >>> xy = rng.uniform(0.0, 100.0, size=(2000, 2))
    >>> cloud = tinsmith.PointCloud(np.column_stack([xy, 0.1 * xy[:, 0]]),
    ...                             classification=np.where(xy[:, 1] < 50.0, 2, 6))
    >>> len(cloud), sorted(cloud.class_counts())
    (2000, [2, 6])
    >>> ground = cloud.filter_classes([2])
    >>> bool(ground.bounds[4] < 50.0)  # ymax of the ground points
    True
    >>> grid = cloud.to_heightfield(cell_size=5.0)
    >>> grid.shape
    (20, 20)
    """

    def __init__(self, xyz, *, classification=None, attributes=None, crs: str | None = None):
        pts = np.array(xyz, dtype=np.float64, copy=True)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise InvalidInputError(f"xyz must have shape (N, 3), got {pts.shape}")
        if len(pts) == 0:
            raise NoDataError("the point cloud has no points")
        if not np.isfinite(pts).all():
            raise InvalidInputError(
                f"xyz has {int((~np.isfinite(pts)).any(axis=1).sum())} points with NaN or infinite coordinates"
            )
        pts.flags.writeable = False
        self.xyz = pts
        n = len(pts)
        if classification is not None:
            cls = np.array(classification, copy=True)
            if cls.shape != (n,):
                raise InvalidInputError(f"classification must have shape ({n},), got {cls.shape}")
            if not np.issubdtype(cls.dtype, np.integer):
                raise InvalidInputError(f"classification must hold integers, got dtype {cls.dtype}")
            cls.flags.writeable = False
        self.classification = cls if classification is not None else None
        self.attributes = {}
        for key, values in (attributes or {}).items():
            arr = np.asarray(values)
            if arr.shape[:1] != (n,):
                raise InvalidInputError(f"attribute {key!r} must have {n} values, got shape {arr.shape}")
            self.attributes[key] = arr
        self.crs = crs or None

    def __len__(self) -> int:
        return len(self.xyz)

    @property
    def bounds(self) -> tuple[float, float, float, float, float, float]:
        """(xmin, ymin, zmin, xmax, ymax, zmax)."""
        lo, hi = self.xyz.min(axis=0), self.xyz.max(axis=0)
        return (*map(float, lo), *map(float, hi))

    def class_counts(self) -> dict[int, int]:
        """Number of points per class code (empty when the cloud has no classes)."""
        if self.classification is None:
            return {}
        codes, counts = np.unique(self.classification, return_counts=True)
        return {int(c): int(k) for c, k in zip(codes, counts, strict=True)}

    def select(self, keep) -> PointCloud:
        """A new cloud with the points where the boolean mask ``keep`` is True."""
        keep = np.asarray(keep, dtype=bool)
        return PointCloud(
            self.xyz[keep],
            classification=None if self.classification is None else self.classification[keep],
            attributes={k: v[keep] for k, v in self.attributes.items()},
            crs=self.crs,
        )

    def filter_classes(self, classes) -> PointCloud:
        """Keep the points whose class is in ``classes`` (e.g. ``[2]`` for ground).

        Raises :class:`NoDataError` when no point is left, naming the classes present.
        """
        wanted = sorted({int(c) for c in classes})
        if self.classification is None:
            raise NoDataError(f"the point cloud has no classification; cannot keep classes {wanted}")
        keep = np.isin(self.classification, wanted)
        if not keep.any():
            present = ", ".join(f"{c} ({k} points)" for c, k in self.class_counts().items())
            raise NoDataError(f"no points of class {wanted}; the classes present are {present}")
        return self.select(keep)

    def default_cell_size(self) -> float:
        """Twice the mean point spacing, rounded to a 1-2-5 value no smaller than 2/3 of it.

        That puts about four points (at least two) in a cell on average, so few
        cells of an evenly sampled area are empty.
        """
        xmin, ymin, _, xmax, ymax, _ = self.bounds
        area = max((xmax - xmin) * (ymax - ymin), 1e-12)
        raw = 2.0 * math.sqrt(area / len(self))
        exponent = math.floor(math.log10(raw))
        for step in (1.0, 2.0, 5.0, 10.0):
            if step * 10.0**exponent >= raw / 1.5:
                return step * 10.0**exponent
        return 10.0 ** (exponent + 1)  # pragma: no cover - loop always returns

    def to_heightfield(self, cell_size: float | None = None, statistic: str = "max") -> Heightfield:
        """Grid the points: each cell gets the max, min or mean height of its points.

        The grid is north-up, aligned to whole multiples of ``cell_size``, and
        just covers the points.  Cells without points are nodata (holes stay
        holes; no interpolation invents heights).

        Parameters
        ----------
        cell_size : float, optional
            Cell width and height in world units; default
            :meth:`default_cell_size`.
        statistic : {"max", "min", "mean"}
            "max" gives a surface model (first surface), "min" the lowest
            return, "mean" a smoothed surface.
        """
        statistic = _checks.choice("statistic", statistic, ("max", "min", "mean"))
        if cell_size is None:
            cell_size = self.default_cell_size()
        cs = _checks.number("cell_size", cell_size, minimum=0.0, exclusive_min=True)
        xmin, ymin, _, xmax, ymax, _ = self.bounds
        span = max(xmax - xmin, ymax - ymin)
        if span / cs > 2**31:  # before any floor(): a tiny cell size would overflow
            raise InvalidInputError(
                f"cell_size {cs:g} makes a grid more than 2^31 cells wide over {span:g} units; choose a larger cell_size"
            )
        x0 = math.floor(xmin / cs) * cs
        y0 = math.ceil(ymax / cs) * cs
        if y0 == ymax:
            y0 += cs  # keep the northernmost points strictly inside the top row
        cols = max(2, math.floor((xmax - x0) / cs) + 1)
        rows = max(2, math.floor((y0 - ymin) / cs) + 1)
        check_memory(GRIDDING_BYTES_PER_CELL * rows * cols,
                     f"gridding {len(self):,} points at cell_size {cs:g} ({rows:,} x {cols:,} cells)",
                     "choose a larger cell_size")
        x, y, z = self.xyz.T
        col = np.clip(((x - x0) / cs).astype(np.int64), 0, cols - 1)
        row = np.clip(((y0 - y) / cs).astype(np.int64), 0, rows - 1)
        flat = row * cols + col
        grid = np.full(rows * cols, np.nan)
        if statistic == "mean":
            counts = np.bincount(flat, minlength=rows * cols)
            sums = np.bincount(flat, weights=z, minlength=rows * cols)
            hit = counts > 0
            grid[hit] = sums[hit] / counts[hit]
        else:
            # sort by cell then height; the last (max) or first (min) of each run wins
            order = np.lexsort((z, flat))
            f_sorted = flat[order]
            boundary = f_sorted[1:] != f_sorted[:-1]
            # the last of each cell's run for the max, the first for the min
            pick = np.flatnonzero(np.r_[boundary, True] if statistic == "max" else np.r_[True, boundary])
            grid[f_sorted[pick]] = z[order[pick]]
        return Heightfield(
            grid.reshape(rows, cols),
            transform=(cs, 0.0, x0, 0.0, -cs, y0),
            crs=self.crs,
            nodata=np.nan,
            source_dtype="float64",
        )

    def __repr__(self) -> str:
        return f"PointCloud({len(self)} points, classes={sorted(self.class_counts())}, crs={'yes' if self.crs else 'none'})"


def class_codes(classes) -> tuple[int, ...] | None:
    """The ``classes`` option as a tuple of ASPRS codes (0..255), or None; :class:`InvalidOptionError` otherwise."""
    if classes is None:
        return None
    if isinstance(classes, str) or not (isinstance(classes, Integral) or np.iterable(classes)):
        raise InvalidOptionError(f"classes must be class codes such as [2, 6], got {classes!r}")
    values = [classes] if isinstance(classes, Integral) else list(classes)
    if not values:
        raise InvalidOptionError("classes must list at least one class code, got an empty list")
    codes = []
    for i, v in enumerate(values):
        try:
            codes.append(_checks.integer(f"classes[{i}]", v, minimum=0, maximum=255))
        except InvalidInputError as exc:  # an option's value: the option's error
            raise InvalidOptionError(str(exc)) from None
    return tuple(codes)
