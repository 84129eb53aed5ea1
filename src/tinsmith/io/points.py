"""Point-cloud readers: LAS/LAZ (through laspy) and XYZ text.

Both return a :class:`~tinsmith.core.PointCloud` and accept ``classes`` to keep
only some ASPRS classes (e.g. ``[2]`` for ground).  Errors name the file (see
:mod:`tinsmith.io._errors`).
"""

from __future__ import annotations

import io
from numbers import Integral
from pathlib import Path

import numpy as np

from .. import _checks
from ..core import PointCloud
from ..errors import FormatError, InvalidOptionError, NoDataError, TinsmithError, require
from ..resources import check_memory
from ._errors import format_error, option_value, with_file_name
from .registry import reader

__all__ = ["read_las", "read_xyz"]

#: Per-point LAS dimensions kept as attributes when the point format has them.
LAS_ATTRIBUTES = ("intensity", "return_number", "number_of_returns", "red", "green", "blue")
#: Lines before the first line of numbers that may be a header.
MAX_HEADER_LINES = 50
_SEPARATORS = str.maketrans({",": " ", ";": " "})


def class_codes(classes) -> tuple[int, ...] | None:
    """The ``classes`` option as a tuple of ASPRS codes (0..255), or None."""
    if classes is None:
        return None
    if isinstance(classes, str) or not (isinstance(classes, Integral) or np.iterable(classes)):
        raise InvalidOptionError(f"classes must be class codes such as [2, 6], got {classes!r}")
    values = [classes] if isinstance(classes, Integral) else list(classes)
    if not values:
        raise InvalidOptionError("classes must list at least one class code, got an empty list")
    return tuple(
        option_value(_checks.integer, f"classes[{i}]", v, minimum=0, maximum=255) for i, v in enumerate(values)
    )


def _keep_classes(cloud: PointCloud, codes) -> PointCloud:
    return cloud if codes is None else cloud.filter_classes(codes)


# -- LAS / LAZ --------------------------------------------------------------------------------
@reader((".las", ".laz"), kind="points", description="LAS/LAZ point cloud", options=("classes",))
@with_file_name
def read_las(path: Path, *, classes=None) -> PointCloud:
    """Read a LAS or LAZ file.

    Parameters
    ----------
    path : Path
    classes : iterable of int, optional
        ASPRS class codes to keep; :class:`NoDataError` when none is present.

    Returns
    -------
    PointCloud
        Scaled x, y, z; classification (uint8); attributes intensity,
        return_number, number_of_returns and red/green/blue when present; the
        CRS of the header as WKT (None when absent or unreadable).
    """
    codes = class_codes(classes)
    las = _load_las(path)
    cloud = PointCloud(
        np.column_stack((np.asarray(las.x), np.asarray(las.y), np.asarray(las.z))),
        classification=np.asarray(las.classification, dtype=np.uint8),
        attributes=_las_attributes(las),
        crs=_las_crs(las),
    )
    return _keep_classes(cloud, codes)


#: Bytes per point beyond the LAS record: x, y, z as float64 (scaled once, then stacked), the class
#: and the attributes kept, and the cloud's own copies.  Measured peaks of tinsmith.read in all:
#: 90 bytes a point on the 640,510-point Delft AHN3 tile, 158 on the 73,403-point lidR Topography
#: tile (fixed costs weigh more there), with 28-byte records.
LAS_BYTES_PER_POINT = 130


def _load_las(path: Path):
    laspy = require("laspy", "lidar", "reading LAS/LAZ files")
    if path.suffix.lower() == ".laz" and not laspy.LazBackend.detect_available():
        require("lazrs", "lidar", "reading LAZ files")
    try:
        with laspy.open(path) as reader:  # the header alone: the point count
            header = reader.header
        check_memory(header.point_count * (header.point_format.size + LAS_BYTES_PER_POINT),
                     f"reading {str(path)!r} ({header.point_count:,} points)",
                     "keep fewer points (a class with --classes, or a tile of the survey)")
        return laspy.read(path)
    except (TinsmithError, MemoryError):
        raise
    except Exception as exc:  # laspy/lazrs errors on damaged or truncated files
        raise format_error(path, "a LAS/LAZ point cloud", exc) from exc


def _las_attributes(las) -> dict[str, np.ndarray]:
    present = set(las.point_format.dimension_names)
    return {name: np.asarray(las[name]) for name in LAS_ATTRIBUTES if name in present}


def _las_crs(las) -> str | None:
    try:
        crs = las.header.parse_crs()
        return crs.to_wkt() if crs is not None else None
    except Exception:  # an unreadable CRS record leaves the cloud without a CRS
        return None


# -- XYZ text ---------------------------------------------------------------------------------
@reader(
    (".xyz", ".txt", ".csv"),
    kind="points",
    description="XYZ text point cloud with columns x y z [class]",
    options=("classes",),
)
@with_file_name
def read_xyz(path: Path, *, classes=None) -> PointCloud:
    """Read points from text: one point per line, ``x y z`` and optionally a class code.

    Columns are separated by whitespace, commas or semicolons.  Lines starting
    with ``#`` and header lines before the first line of numbers are skipped.

    Parameters
    ----------
    path : Path
    classes : iterable of int, optional
        Class codes to keep; needs the 4th (class) column.

    Raises
    ------
    FormatError
        For a line with a different number of columns than the first line
        of numbers, a field that is not a number, or a class that is not a
        whole number 0..255 (the message names the line).
    """
    codes = class_codes(classes)
    text = path.read_text(encoding="utf-8-sig", errors="replace").translate(_SEPARATORS)
    start, ncols = _data_start(path, text)
    table = _parse_table(path, text, start, ncols)
    classification = _class_column(path, text, start, table[:, 3]) if ncols == 4 else None
    return _keep_classes(PointCloud(table[:, :3], classification=classification), codes)


def _fields(line: str) -> list[str]:
    """The fields of a line (separators already turned into spaces); [] for comments."""
    return line.split("#", 1)[0].split()


def _is_number(field: str) -> bool:
    try:
        float(field)
    except ValueError:
        return False
    return True


def _data_start(path: Path, text: str) -> tuple[int, int]:
    """0-based index of the first line of numbers, and its number of columns."""
    header = 0
    for index, line in enumerate(io.StringIO(text)):
        fields = _fields(line)
        if not fields:
            continue
        if all(_is_number(f) for f in fields):
            if len(fields) not in (3, 4):
                raise FormatError(
                    f"{str(path)!r} line {index + 1}: expected 3 or 4 columns (x y z [class]), "
                    f"got {len(fields)}: {line.strip()[:80]!r}"
                )
            return index, len(fields)
        header += 1
        if header > MAX_HEADER_LINES:
            break
    else:
        raise NoDataError(f"{str(path)!r} has no points: no line of numbers x y z [class]")
    raise FormatError(
        f"{str(path)!r} has no line of numbers x y z [class] in its first {MAX_HEADER_LINES} "
        "non-empty lines; is it an XYZ text file?"
    )


def _parse_table(path: Path, text: str, start: int, ncols: int) -> np.ndarray:
    try:
        table = np.loadtxt(io.StringIO(text), comments="#", skiprows=start, ndmin=2, dtype=np.float64)
    except ValueError as exc:
        raise _locate_bad_line(path, text, start, ncols) or format_error(path, "XYZ text", exc) from exc
    if table.shape[1] != ncols:  # pragma: no cover - loadtxt reports changing column counts
        raise FormatError(f"{str(path)!r}: expected {ncols} columns, got {table.shape[1]}")
    return table


def _data_lines(text: str, start: int):
    """``(line number, fields)`` of every data line from ``start`` on (1-based numbers)."""
    for index, line in enumerate(io.StringIO(text)):
        if index >= start:
            fields = _fields(line)
            if fields:
                yield index + 1, fields


def _locate_bad_line(path: Path, text: str, start: int, ncols: int) -> FormatError | None:
    """The error for the first line numpy could not parse, or None when none is found."""
    for number, fields in _data_lines(text, start):
        shown = " ".join(fields)[:80]
        if len(fields) != ncols:
            return FormatError(
                f"{str(path)!r} line {number}: expected {ncols} columns like the first line of "
                f"numbers, got {len(fields)}: {shown!r}"
            )
        bad = next((f for f in fields if not _is_number(f)), None)
        if bad is not None:
            return FormatError(f"{str(path)!r} line {number}: {bad!r} is not a number (in {shown!r})")
    return None


def _class_column(path: Path, text: str, start: int, values: np.ndarray) -> np.ndarray:
    bad = (values != np.round(values)) | (values < 0) | (values > 255) | ~np.isfinite(values)
    if bad.any():
        row = int(np.argmax(bad))
        number = next(n for i, (n, _) in enumerate(_data_lines(text, start)) if i == row)
        raise FormatError(
            f"{str(path)!r} line {number}: the 4th column is the class and must be a whole number "
            f"0..255, got {values[row]:g}"
        )
    return values.astype(np.uint8)
