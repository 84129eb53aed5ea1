"""Point-cloud readers: LAS/LAZ (through laspy) and XYZ text.

Both return a :class:`~tinsmith.core.PointCloud` and accept ``classes`` to keep
only some ASPRS classes (e.g. ``[2]`` for ground).  Errors name the file (see
:mod:`tinsmith.io._errors`).

Many files, one cloud: :func:`read_clouds` reads every file that
:func:`expand_sources` finds in files, folders and globs, LAS/LAZ in chunks
(only the kept points stay in memory), and refuses files in different CRSs;
:func:`cloud_header` gives a file's point count, bounds and CRS without its
points.
"""

from __future__ import annotations

import glob
import io
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import _checks
from ..core import PointCloud
from ..core.pointcloud import class_codes
from ..errors import (
    FileError,
    FormatError,
    InputNotFoundError,
    InvalidInputError,
    InvalidOptionError,
    NoDataError,
    TinsmithError,
    require,
)
from ..resources import FIXED, PARSE_BYTES_PER_FILE_BYTE, check_memory, format_bytes
from ._errors import first_line, format_error, option_value, with_file_name
from .crs import describe
from .registry import reader

__all__ = ["CLOUD_SUFFIXES", "CloudInfo", "cloud_header", "clouds_info", "expand_sources", "iter_xyz", "read_clouds",
           "read_las", "read_xyz"]

#: Per-point LAS dimensions kept as attributes when the point format has them.
LAS_ATTRIBUTES = ("intensity", "return_number", "number_of_returns", "red", "green", "blue")
#: Lines before the first line of numbers that may be a header.
MAX_HEADER_LINES = 50
_SEPARATORS = str.maketrans({",": " ", ";": " "})


def _keep_classes(cloud: PointCloud, codes) -> PointCloud:
    return cloud if codes is None else cloud.filter_classes(codes)


# -- LAS / LAZ --------------------------------------------------------------------------------
@reader((".las", ".laz"), kind="points", description="LAS/LAZ point cloud", options=("classes",))
@with_file_name
def read_las(path: Path, *, classes=None) -> PointCloud:
    """Read a LAS or LAZ file: :func:`read_clouds` of this one file.

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

    Raises
    ------
    FormatError
        A damaged file, or one that holds fewer points than its header
        announces (cut short, even at a record boundary): the message names
        the file and both counts.
    """
    return read_clouds([path], classes=classes)


def las_cloud(las) -> PointCloud:
    """The PointCloud of a laspy ``LasData``: scaled x, y, z, the class codes, the attributes kept, the CRS."""
    return PointCloud(
        np.column_stack((np.asarray(las.x), np.asarray(las.y), np.asarray(las.z))),
        classification=np.asarray(las.classification, dtype=np.uint8),
        attributes=_las_attributes(las),
        crs=_las_crs(las),
    )


#: Bytes per point beyond the LAS record: x, y, z as float64 (scaled once, then stacked), the class
#: and the attributes kept, and the cloud's own copies.  Measured peaks of tinsmith.read in all:
#: 90 bytes a point on the 640,510-point Delft AHN3 tile, 158 on the 73,403-point lidR Topography
#: tile (fixed costs weigh more there), with 28-byte records.
LAS_BYTES_PER_POINT = 130


#: LAZ decompression: laspy's choice (its multi-threaded lazrs backend first) unless set.
_LAZ_BACKEND = None


def single_threaded_laz() -> None:
    """Decompress LAZ on the calling thread from now on (in this process).

    A worker forked from a process that has already decompressed LAZ with
    lazrs' thread pool inherits the pool's state but not its threads, and would
    wait for them for ever: the process pools of tiled runs call this in every
    worker they start.
    """
    global _LAZ_BACKEND
    laspy = require("laspy", "lidar", "reading LAS/LAZ files")
    backend = laspy.LazBackend.Lazrs
    _LAZ_BACKEND = backend if backend.is_available() else None


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


# -- many files, one cloud --------------------------------------------------------------------
#: Suffixes of the point-cloud files :func:`expand_sources` takes from folders and globs.
CLOUD_SUFFIXES = (".las", ".laz", ".xyz", ".txt", ".csv")
_LAS_SUFFIXES = (".las", ".laz")
_GLOB_CHARACTERS = re.compile(r"[*?\[]")
#: Bytes of each kept attribute (LAS_ATTRIBUTES) per point in the cloud.
_ATTRIBUTE_BYTES = {"intensity": 2, "return_number": 1, "number_of_returns": 1, "red": 2, "green": 2, "blue": 2}
#: Bytes of a kept point without attributes: x, y, z (float64) and the class (uint8).
KEPT_BYTES_PER_POINT = 3 * 8 + 1
#: Copies of the kept points alive at the peak: the per-chunk parts and the concatenated arrays,
#: then the concatenated arrays and the cloud's own copy.  With one chunk (its LAS records and
#: their scaled copies: LAS_BYTES_PER_POINT) and FIXED for the libraries, the estimate of
#: read_clouds; measured on the 848,942-point Delft AHN3 merge: numpy's peak 2 x 29 bytes a kept
#: point plus the chunk, the process's peak 76-80 MiB against an estimate of 126-239 MiB
#: (chunks of 100,000 and 2,000,000 points).
KEPT_COPIES = 2


def _shown(paths, limit: int = 3) -> str:
    names = [p.name for p in paths[:limit]]
    return ", ".join(names) + (", ..." if len(paths) > limit else "")


def _folder_files(folder: Path, given: str) -> list[Path]:
    entries = sorted(folder.iterdir(), key=lambda p: p.name)
    files = [p for p in entries if p.is_file() and p.suffix.lower() in CLOUD_SUFFIXES]
    if not entries:
        raise FileError(f"folder {given!r} is empty: it holds no point-cloud file ({', '.join(CLOUD_SUFFIXES)})")
    if not files:
        raise FileError(
            f"folder {given!r} holds no point-cloud file ({', '.join(CLOUD_SUFFIXES)}); it has {len(entries)} "
            f"other entries ({_shown(entries)})"
        )
    return files


def _glob_files(pattern: str) -> list[Path]:
    matches = sorted(glob.glob(pattern, recursive=True))
    if not matches:
        raise InputNotFoundError(f"no file matches {pattern!r}")
    found = [Path(m) for m in matches]
    files = [p for p in found if p.is_file() and p.suffix.lower() in CLOUD_SUFFIXES]
    if not files:
        raise InvalidInputError(
            f"{pattern!r} matches no point-cloud file ({', '.join(CLOUD_SUFFIXES)}), only {len(found)} other "
            f"entries ({_shown(found)})"
        )
    return files


def expand_sources(sources) -> list[Path]:
    """The point-cloud files named by ``sources``, in order, each once.

    Parameters
    ----------
    sources : str, Path or list of them
        Each a file; a folder (the ``.las``, ``.laz``, ``.xyz``, ``.txt`` and
        ``.csv`` files directly in it, sorted by name); or a glob pattern such
        as ``tiles/*.laz`` (``**`` recurses; matches sorted, other suffixes
        left out).  A path that exists is never taken as a pattern.

    Returns
    -------
    list of Path
        Duplicates (the same file by resolved path) removed, first occurrence kept.

    Raises
    ------
    InputNotFoundError
        A file that does not exist, a glob that matches nothing.
    FileError
        An empty folder, a folder without point-cloud files.
    InvalidInputError
        No source, a file or glob matches that are not point clouds.
    """
    items = [sources] if isinstance(sources, (str, os.PathLike)) else sources
    try:
        items = list(items)
    except TypeError:
        raise InvalidInputError(f"sources must be a path or a list of paths, got {sources!r}") from None
    if not items:
        raise InvalidInputError("no point-cloud source given: name files, folders or glob patterns")
    files: list[Path] = []
    for item in items:
        if not isinstance(item, (str, os.PathLike)):
            raise InvalidInputError(f"sources must be paths (str or Path), got {item!r}")
        given = os.fspath(item)
        if not given:
            raise InvalidInputError("an empty string is not a point-cloud source")
        path = Path(given)
        if path.is_dir():
            files += _folder_files(path, given)
        elif path.exists():
            if path.suffix.lower() not in CLOUD_SUFFIXES:
                raise InvalidInputError(
                    f"{given!r} is not a point-cloud file: expected {', '.join(CLOUD_SUFFIXES)}"
                )
            files.append(path)
        elif _GLOB_CHARACTERS.search(given):
            files += _glob_files(given)
        else:
            raise InputNotFoundError(f"input file {given!r} does not exist")
    seen: set[Path] = set()
    unique = []
    for f in files:
        key = f.resolve()
        if key not in seen:
            seen.add(key)
            unique.append(f)
    return unique


@dataclass(frozen=True)
class CloudInfo:
    """What a point-cloud file holds, from its header: see :func:`cloud_header`.

    Attributes
    ----------
    path : Path
    count : int
        Number of points.
    bounds : tuple of float
        ``(xmin, ymin, zmin, xmax, ymax, zmax)``.
    crs_wkt : str or None
        The CRS as WKT; None when the file has none (always for text clouds).
    """

    path: Path
    count: int
    bounds: tuple[float, float, float, float, float, float]
    crs_wkt: str | None

    def __repr__(self) -> str:
        crs = _crs_name(self.crs_wkt) if self.crs_wkt else None
        return f"CloudInfo(path={str(self.path)!r}, count={self.count:,}, bounds={self.bounds!r}, crs={crs!r})"


@dataclass(frozen=True)
class _LasHeader:
    info: CloudInfo
    dimensions: frozenset
    record_size: int
    tolerance: float  # half the coarsest x/y scale: header bounds may be off by that much


def _require_las(path: Path):
    laspy = require("laspy", "lidar", "reading LAS/LAZ files")
    if path.suffix.lower() == ".laz" and not laspy.LazBackend.detect_available():
        require("lazrs", "lidar", "reading LAZ files")
    return laspy


def _header_crs(header) -> str | None:
    try:
        crs = header.parse_crs()
        return crs.to_wkt() if crs is not None else None
    except Exception:  # an unreadable CRS record leaves the cloud without a CRS (as read_las)
        return None


def truncated_las(path, held: int, announced: int) -> FormatError:
    """The error for a LAS/LAZ file that holds fewer points than its header announces."""
    return FormatError(
        f"{str(path)!r} holds {held:,} points but its header announces {announced:,}: the file is truncated or damaged"
    )


def _check_record_count(path: Path, count: int, offset: int, record: int) -> None:
    """An uncompressed LAS file must be long enough for the records its header announces (from its size alone)."""
    held = max(path.stat().st_size - offset, 0) // max(record, 1)
    if held < count:
        raise truncated_las(path, held, count)


def _las_header(path: Path) -> _LasHeader:
    laspy = _require_las(path)
    try:
        with laspy.open(path) as reader:
            header = reader.header
            count = int(header.point_count)
            if not header.are_points_compressed:
                _check_record_count(path, count, int(header.offset_to_point_data), int(header.point_format.size))
            mins, maxs = (tuple(float(v) for v in a) for a in (header.mins, header.maxs))
            info = CloudInfo(path, count, (*mins, *maxs), _header_crs(header))
            return _LasHeader(
                info,
                frozenset(header.point_format.dimension_names),
                int(header.point_format.size),
                0.5 * float(max(abs(header.scales[0]), abs(header.scales[1]))),
            )
    except (TinsmithError, MemoryError):
        raise
    except Exception as exc:  # laspy errors on damaged files and on files that are not LAS
        raise format_error(path, "a LAS/LAZ point cloud", exc) from exc


def _check_file(path: Path) -> None:
    if not path.exists():
        raise InputNotFoundError(f"input file {str(path)!r} does not exist")
    if path.is_dir():
        raise FileError(f"input {str(path)!r} is a folder, expected a file")
    if path.suffix.lower() not in CLOUD_SUFFIXES:
        raise InvalidInputError(f"{str(path)!r} is not a point-cloud file: expected {', '.join(CLOUD_SUFFIXES)}")


def _read_text_cloud(path: Path) -> PointCloud:
    """A text cloud as :func:`tinsmith.io.read` reads it: memory check, then :func:`read_xyz`."""
    size = path.stat().st_size
    check_memory(FIXED + PARSE_BYTES_PER_FILE_BYTE * size, f"reading {str(path)!r} ({format_bytes(size)})",
                 "split the file, or write it in a binary format")
    try:
        return read_xyz(path)
    except (TinsmithError, MemoryError):
        raise
    except Exception as exc:  # pragma: no cover - read_xyz reports its own failures
        raise format_error(path, "XYZ text", exc) from exc


def cloud_header(path) -> CloudInfo:
    """Point count, bounds and CRS of a point-cloud file.

    LAS/LAZ: from the header alone (no point is read).  Text clouds have no
    header: the file is read (they are small) and has no CRS.
    """
    path = Path(path)
    _check_file(path)
    if path.suffix.lower() in _LAS_SUFFIXES:
        return _las_header(path).info
    cloud = _read_text_cloud(path)
    return CloudInfo(path, len(cloud), cloud.bounds, None)


def clouds_info(sources) -> tuple[list[CloudInfo], str | None]:
    """The headers of every file of ``sources`` (see :func:`expand_sources`) and the CRS they share.

    Raises :class:`InvalidInputError` naming two files in different CRSs.
    """
    infos = [cloud_header(f) for f in expand_sources(sources)]
    return infos, _common_crs({i.path: i for i in infos})


def _crs_name(wkt: str) -> str:
    try:
        from pyproj import CRS

        return CRS.from_wkt(wkt).name
    except Exception:  # no pyproj, or a WKT it cannot read: the WKT's own first name
        match = re.search(r'"([^"]*)"', wkt)
        return match.group(1) if match else wkt[:60]


def _same_crs(a: str, b: str) -> bool:
    if a == b:
        return True
    try:
        from pyproj import CRS
    except ImportError:  # pragma: no cover - pyproj comes with laspy's CRS support
        return False
    try:
        return CRS.from_wkt(a) == CRS.from_wkt(b)
    except Exception:  # a WKT pyproj cannot read: the texts differ
        return False


def _common_crs(headers: dict[Path, CloudInfo]) -> str | None:
    """The CRS of the files that have one, refusing two different ones; None when none has one."""
    first = None
    for path, info in headers.items():
        if info.crs_wkt is None:
            continue
        if first is None:
            first = info
        elif not _same_crs(first.crs_wkt, info.crs_wkt):
            a, b = _crs_name(first.crs_wkt), _crs_name(info.crs_wkt)
            if a == b:
                a, b = describe(first.crs_wkt), describe(info.crs_wkt)
                if a == b:
                    a, b = f"{a}, as defined there", f"{b}, defined differently"
            raise InvalidInputError(
                f"clouds {str(first.path)!r} ({a}) and {str(path)!r} ({b}) are in different CRSs; "
                "reproject them to one (pdal translate, las2las) or read them apart"
            )
    return first.crs_wkt if first is not None else None


def _bounds_option(bounds) -> tuple[float, float, float, float] | None:
    if bounds is None:
        return None
    values = None if isinstance(bounds, str) or not np.iterable(bounds) else tuple(bounds)
    if values is None or len(values) != 4:
        raise InvalidOptionError(f"bounds must be (xmin, ymin, xmax, ymax), got {bounds!r}")
    names = ("xmin", "ymin", "xmax", "ymax")
    xmin, ymin, xmax, ymax = (option_value(_checks.number, f"bounds {n}", v) for n, v in zip(names, values, strict=True))
    if xmin > xmax or ymin > ymax:
        raise InvalidOptionError(
            f"bounds must be (xmin, ymin, xmax, ymax) with xmin <= xmax and ymin <= ymax, got {values!r}"
        )
    return xmin, ymin, xmax, ymax


def _outside(header: _LasHeader, box) -> bool:
    """Whether the header bounds show that no point of the file lies in ``box`` (valid bounds only)."""
    xmin, ymin, _, xmax, ymax, _ = header.info.bounds
    if header.info.count == 0:
        return True
    if not (np.isfinite([xmin, ymin, xmax, ymax]).all() and xmin <= xmax and ymin <= ymax):
        return False  # bounds the writer did not fill in: read the file
    if xmin == xmax == ymin == ymax == 0.0:
        return False
    tol = header.tolerance
    return xmax < box[0] - tol or xmin > box[2] + tol or ymax < box[1] - tol or ymin > box[3] + tol


def _wanted(codes) -> np.ndarray | None:
    """Per class code 0..255, whether it is kept (None: every class)."""
    if codes is None:
        return None
    wanted = np.zeros(256, dtype=bool)
    wanted[list(codes)] = True
    return wanted


def _point_mask(x, y, cls, box, wanted, class_counts):
    """Boolean mask of the points to keep (None: all), counting the classes found in the box."""
    keep = None
    if box is not None:
        keep = (x >= box[0]) & (x <= box[2]) & (y >= box[1]) & (y <= box[3])
    if wanted is not None:
        if cls is None:
            return np.zeros(len(x), dtype=bool)
        in_box = cls if keep is None else cls[keep]
        class_counts += np.bincount(in_box, minlength=256)
        by_class = wanted[cls]
        keep = by_class if keep is None else keep & by_class
    if keep is not None and keep.all():
        return None
    return keep


class _Parts:
    """Per-chunk arrays of the kept points, concatenated once at the end."""

    def __init__(self, attributes):
        self.xyz: list[np.ndarray] = []
        self.cls: list[np.ndarray | None] = []
        self.attributes = {name: [] for name in attributes}
        self.kept = 0

    def add(self, x, y, z, cls, attributes, keep) -> None:
        xyz = np.column_stack((x, y, z)) if keep is None else np.column_stack((x[keep], y[keep], z[keep]))
        if not len(xyz):
            return
        self.xyz.append(xyz)
        self.cls.append(None if cls is None else (cls.copy() if keep is None else cls[keep]))
        for name, values in self.attributes.items():
            values.append(np.array(attributes[name]) if keep is None else np.asarray(attributes[name])[keep])
        self.kept += len(xyz)

    def cloud(self, crs) -> PointCloud:
        xyz = np.concatenate(self.xyz)
        self.xyz.clear()
        cls = None
        if all(c is not None for c in self.cls):
            cls = np.concatenate(self.cls)
        self.cls.clear()
        attributes = {name: np.concatenate(values) for name, values in self.attributes.items()}
        self.attributes.clear()
        return PointCloud(xyz, classification=cls, attributes=attributes, crs=crs)


def _xyz_and_class(laspy):
    """The laspy ``DecompressionSelection`` of x, y, z and the class (None without laspy)."""
    if laspy is None:
        return None
    fields = laspy.DecompressionSelection
    return fields.XY_RETURNS_CHANNEL | fields.Z | fields.CLASSIFICATION


def _las_chunks(laspy, path: Path, chunk_size: int, announced: int, selection=None):
    """The chunks of a LAS/LAZ file; laspy's failures become a FormatError naming the file.

    Every point the header announces must be read: a file cut short (even at a
    record boundary, which laspy reads as fewer points in silence) is a
    FormatError naming the file and both counts.  ``selection`` (a laspy
    ``DecompressionSelection``) decompresses only those fields of a LAZ file
    whose points are of format 6 or above (layered chunks); others decompress
    whole.
    """
    try:
        extra = {} if selection is None else {"decompression_selection": selection}
        reader = laspy.open(path, laz_backend=_LAZ_BACKEND, **extra)
    except Exception as exc:
        raise format_error(path, "a LAS/LAZ point cloud", exc) from exc
    done = 0
    with reader:
        chunks = reader.chunk_iterator(chunk_size)
        while True:
            try:
                chunk = next(chunks)
            except StopIteration:
                break
            except MemoryError:
                raise
            except Exception as exc:  # laspy/lazrs errors on damaged or truncated files
                raise FormatError(
                    f"cannot read {str(path)!r} as a LAS/LAZ point cloud: {done:,} of the {announced:,} points its "
                    f"header announces read, then {first_line(exc)}: the file is truncated or damaged"
                ) from exc
            done += len(chunk)
            yield chunk
    if done != announced:
        raise truncated_las(path, done, announced)


def _class_list(codes) -> str:
    codes = sorted(set(codes))
    return f"class {codes[0]}" if len(codes) == 1 else "classes " + ", ".join(map(str, codes))


def _no_points(files, read, codes, box, class_counts, extent) -> NoDataError:
    what = "no points" if codes is None else f"no points of {_class_list(codes)}"
    where = repr(str(files[0])) if len(files) == 1 else f"{len(files)} files ({_shown(files)})"
    within = "" if box is None else f" within bounds ({', '.join(f'{v:.12g}' for v in box)})"
    if box is not None and not read and extent is not None:
        return NoDataError(
            f"{what}{within} in {where}: by their headers the files cover x {extent[0]:.12g} .. "
            f"{extent[2]:.12g}, y {extent[1]:.12g} .. {extent[3]:.12g}"
        )
    if codes is None:
        return NoDataError(f"{what}{within} in {where}")
    if not class_counts.any():
        return NoDataError(f"{what}{within} in {where}: {'the bounds hold' if box else 'the files hold'} no points")
    present = ", ".join(f"{c} ({class_counts[c]} points)" for c in np.flatnonzero(class_counts))
    there = " there" if box is not None else ""
    return NoDataError(f"{what}{within} in {where}; the classes present{there} are {present}")


def iter_xyz(path, *, classes=None, chunk_size: int = 2_000_000):
    """The kept points of one point-cloud file, chunk by chunk, as (N, 3) arrays of x, y, z.

    A LAS/LAZ file is read ``chunk_size`` points at a time (of point format 6
    or above only x, y, z and the class decompressed), so a file of any size
    passes in the memory of one chunk; a text file is parsed whole.  The
    chunks, concatenated, are ``read_clouds([path], classes=classes).xyz``;
    chunks that keep no point are not yielded, so a file without a point of
    ``classes`` yields nothing.  A damaged or truncated file raises the
    FormatError of :func:`read_clouds`, after the chunks before the damage.
    """
    codes = class_codes(classes)
    chunk_size = option_value(_checks.integer, "chunk_size", chunk_size, minimum=1)
    path = Path(path)
    _check_file(path)
    wanted = _wanted(codes)
    counts = np.zeros(256, dtype=np.int64)
    if path.suffix.lower() not in _LAS_SUFFIXES:
        cloud = _read_text_cloud(path)
        if codes is not None and cloud.classification is None:
            raise NoDataError(f"{str(path)!r} has no class column (x y z only); cannot keep {_class_list(codes)}")
        keep = _point_mask(cloud.xyz[:, 0], cloud.xyz[:, 1], cloud.classification, None, wanted, counts)
        xyz = cloud.xyz if keep is None else cloud.xyz[keep]
        if len(xyz):
            yield xyz
        return
    laspy = require("laspy", "lidar", "reading LAS/LAZ files")
    header = _las_header(path)
    for chunk in _las_chunks(laspy, path, chunk_size, header.info.count, _xyz_and_class(laspy)):
        x, y, z = np.asarray(chunk.x), np.asarray(chunk.y), np.asarray(chunk.z)
        keep = _point_mask(x, y, np.asarray(chunk.classification, dtype=np.uint8), None, wanted, counts)
        del chunk
        xyz = np.column_stack((x, y, z)) if keep is None else np.column_stack((x[keep], y[keep], z[keep]))
        if len(xyz):
            yield xyz


def read_clouds(sources, *, classes=None, bounds=None, progress=None, chunk_size: int = 2_000_000,
                attributes: bool = True) -> PointCloud:
    """Read many point-cloud files as one cloud.

    Parameters
    ----------
    sources : str, Path or list of them
        Files, folders and glob patterns: see :func:`expand_sources`.
    classes : iterable of int, optional
        ASPRS class codes to keep.
    bounds : (xmin, ymin, xmax, ymax), optional
        Keep only the points with ``xmin <= x <= xmax`` and ``ymin <= y <=
        ymax`` (a closed box).  LAS/LAZ files whose header bounds lie outside
        it are not read beyond their header.
    progress : callable, optional
        ``progress(points_done, points_total)`` after each chunk (a text file
        is one chunk); the total is the sum of the point counts of the files
        read, and the last call has ``points_done == points_total``.
    attributes : bool
        False: x, y, z and the class alone, and of a LAZ file of point format 6
        or above only those fields are decompressed (a file of the 100M-point
        survey of the benchmarks read and bucketed in 2.2 s instead of 3.5 s).
    chunk_size : int
        Points read at a time from a LAS/LAZ file.

    Returns
    -------
    PointCloud
        The kept points, file after file in the order of ``sources``.  The
        attributes of :func:`read_las` that every file read has; the class when
        every file read has one; the CRS the files share (files without a CRS
        take it).  For one LAS/LAZ file without ``bounds``, the same cloud as
        :func:`read_las`.

    Raises
    ------
    InvalidInputError
        Two files in different CRSs (naming both).
    NoDataError
        No point is kept (naming the classes and the files).
    FormatError
        A damaged file (naming it).
    ResourceError
        When the points the files may hold cannot fit in memory (estimated
        from the headers before any point is read).
    """
    codes = class_codes(classes)
    box = _bounds_option(bounds)
    if progress is not None and not callable(progress):
        raise InvalidOptionError(f"progress must be a function progress(done, total), got {progress!r}")
    chunk_size = option_value(_checks.integer, "chunk_size", chunk_size, minimum=1)
    files = expand_sources(sources)
    wanted = _wanted(codes)

    las_files = [f for f in files if f.suffix.lower() in _LAS_SUFFIXES]
    laspy = require("laspy", "lidar", "reading LAS/LAZ files") if las_files else None
    headers = {f: _las_header(f) for f in las_files}  # _las_header checks for a LAZ backend
    crs = _common_crs({f: h.info for f, h in headers.items()})
    extent = None  # of the files with points, for the message when the bounds leave none
    if any(h.info.count for h in headers.values()):
        boxes = np.array([h.info.bounds for h in headers.values() if h.info.count])
        extent = (boxes[:, 0].min(), boxes[:, 1].min(), boxes[:, 3].max(), boxes[:, 4].max())
    skipped = {f for f, h in headers.items() if box is not None and _outside(h, box)}
    read = [f for f in files if f not in skipped]

    dims = [h.dimensions for f, h in headers.items() if f not in skipped]
    if any(f.suffix.lower() not in _LAS_SUFFIXES for f in read):
        dims.append(frozenset())
    selection = _xyz_and_class(laspy) if not attributes else None
    attributes = [name for name in LAS_ATTRIBUTES if attributes and dims and all(name in d for d in dims)]

    las_read = [headers[f] for f in read if f in headers]
    if las_read:
        most = sum(h.info.count for h in las_read)
        per_point = KEPT_BYTES_PER_POINT + sum(_ATTRIBUTE_BYTES[name] for name in attributes)
        chunk = min(chunk_size, max(h.info.count for h in las_read))
        record = max(h.record_size for h in las_read)
        check_memory(
            FIXED + KEPT_COPIES * per_point * most + chunk * (record + LAS_BYTES_PER_POINT),
            f"reading {most:,} points from {len(las_read)} LAS/LAZ file{'s' if len(las_read) > 1 else ''}",
            "keep fewer points (classes, bounds), or read the survey tile by tile",
        )

    texts = {f: _read_text_cloud(f) for f in read if f not in headers}
    if codes is not None:
        for f, cloud in texts.items():
            if cloud.classification is None:
                raise NoDataError(f"{str(f)!r} has no class column (x y z only); cannot keep {_class_list(codes)}")
    total = sum(h.info.count for h in las_read) + sum(len(c) for c in texts.values())

    parts = _Parts(attributes)
    class_counts = np.zeros(256, dtype=np.int64)
    done = 0
    for f in read:
        if f in texts:  # already parsed: one chunk
            cloud = texts.pop(f)
            x, y, z = cloud.xyz.T
            parts.add(x, y, z, cloud.classification, {},
                      _point_mask(x, y, cloud.classification, box, wanted, class_counts))
            done += len(cloud)
            del cloud, x, y, z
            if progress is not None:
                progress(done, total)
            continue
        for chunk in _las_chunks(laspy, f, chunk_size, headers[f].info.count, selection):
            x, y, z = np.asarray(chunk.x), np.asarray(chunk.y), np.asarray(chunk.z)
            cls = np.asarray(chunk.classification, dtype=np.uint8)
            keep = _point_mask(x, y, cls, box, wanted, class_counts)
            parts.add(x, y, z, cls, {name: chunk[name] for name in attributes}, keep)
            done += len(x)
            del chunk, x, y, z, cls, keep
            if progress is not None:
                progress(done, total)
    if not parts.kept:
        raise _no_points(files, read, codes, box, class_counts, extent)
    return parts.cloud(crs)
