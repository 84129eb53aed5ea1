"""Many point-cloud files, one cloud: files, folders and globs, read in chunks, one CRS.

``read_clouds(["tiles/*.laz"], classes=[2])`` reads every LAS/LAZ (or XYZ)
file the sources name, LAS/LAZ in chunks of :data:`CHUNK` points with
laspy's chunk iterator (only the kept classes of a chunk stay in memory),
and refuses files in different CRSs, naming both.  A file without a CRS
takes the others'.
"""

from __future__ import annotations

import glob as _glob
from pathlib import Path

import numpy as np

from ..core import PointCloud
from ..errors import FileError, InputNotFoundError, InvalidInputError, NoDataError, TinsmithError, require
from ..resources import check_memory
from ._errors import format_error
from .crs import describe
from .points import class_codes, read_xyz

__all__ = ["cloud_sources", "read_clouds"]

CLOUD_SUFFIXES = (".las", ".laz", ".xyz", ".txt", ".csv")
#: Points read at a time from a LAS/LAZ file.
CHUNK = 2_000_000
#: Bytes a kept point costs while the files are read: x, y, z, class, and the final copy.
KEPT_BYTES_PER_POINT = 2 * 25


def cloud_sources(sources) -> list[Path]:
    """The files named by ``sources`` (a path or a list): files, folders (their cloud files) and globs, in order."""
    items = [sources] if isinstance(sources, (str, Path)) else list(sources)
    if not items:
        raise InvalidInputError("no input given: name point-cloud files, a folder or a glob")
    files: list[Path] = []
    for item in items:
        text = str(item)
        path = Path(text)
        if any(ch in text for ch in "*?[") and not path.exists():
            found = sorted(Path(p) for p in _glob.glob(text))
            if not found:
                raise InputNotFoundError(f"no file matches {text!r}")
            files += [p for p in found if p.is_file()]
        elif path.is_dir():
            found = sorted(p for p in path.iterdir() if p.is_file() and p.suffix.lower() in CLOUD_SUFFIXES)
            if not found:
                raise FileError(f"folder {text!r} holds no point-cloud file ({', '.join(CLOUD_SUFFIXES)})")
            files += found
        elif path.exists():
            files.append(path)
        else:
            raise InputNotFoundError(f"input file {text!r} does not exist")
    seen, out = set(), []
    for f in files:
        key = f.resolve()
        if key not in seen:
            seen.add(key)
            out.append(f)
    for f in out:
        if f.suffix.lower() not in CLOUD_SUFFIXES:
            raise InvalidInputError(f"{str(f)!r} is not a point cloud; expected {', '.join(CLOUD_SUFFIXES)}")
    return out


def _same_crs(a: str, b: str) -> bool:
    try:
        from pyproj import CRS

        return CRS.from_user_input(a).equals(CRS.from_user_input(b), ignore_axis_order=True)
    except Exception:  # no pyproj, or a CRS it cannot read: compare the texts
        return a == b


def _las_chunks(path: Path, codes, progress, done: list):
    laspy = require("laspy", "lidar", "reading LAS/LAZ files")
    try:
        with laspy.open(path) as reader:
            header = reader.header
            try:
                crs = header.parse_crs()
                crs = crs.to_wkt() if crs is not None else None
            except Exception:  # an unreadable CRS record: no CRS
                crs = None
            parts = []
            for chunk in reader.chunk_iterator(CHUNK):
                cls = np.asarray(chunk.classification, dtype=np.uint8)
                keep = np.isin(cls, codes) if codes is not None else slice(None)
                parts.append((np.column_stack([np.asarray(chunk.x)[keep], np.asarray(chunk.y)[keep],
                                               np.asarray(chunk.z)[keep]]), cls[keep]))
                done[0] += len(cls)
                if progress is not None:
                    progress(done[0])
    except TinsmithError:
        raise
    except Exception as exc:  # laspy/lazrs errors on damaged or truncated files
        raise format_error(path, "a LAS/LAZ point cloud", exc) from exc
    return parts, crs


def read_clouds(sources, *, classes=None, progress=None) -> PointCloud:
    """One :class:`PointCloud` of every file ``sources`` names (see the module notes).

    ``progress(points_read, points_total)`` is called after each chunk.
    Attributes other than the class are not kept (a TIN needs x, y, z).
    """
    files = cloud_sources(sources)
    codes = class_codes(classes)
    laspy = require("laspy", "lidar", "reading LAS/LAZ files") if any(
        f.suffix.lower() in (".las", ".laz") for f in files) else None
    counts = []
    for f in files:
        if f.suffix.lower() in (".las", ".laz"):
            try:
                with laspy.open(f) as reader:
                    counts.append(int(reader.header.point_count))
            except Exception as exc:
                raise format_error(f, "a LAS/LAZ point cloud", exc) from exc
        else:
            counts.append(0)
    total = sum(counts)
    check_memory(KEPT_BYTES_PER_POINT * total, f"reading {total:,} points from {len(files)} files",
                 "keep fewer points (--classes), or mesh the survey in tiles with 'tinsmith tile'")
    xyz, cls, crs_of = [], [], []
    done = [0]
    report = (lambda n: progress(n, total)) if progress is not None else None
    for f in files:
        if f.suffix.lower() in (".las", ".laz"):
            parts, crs = _las_chunks(f, codes, report, done)
            xyz += [p[0] for p in parts]
            cls += [p[1] for p in parts]
        else:
            cloud = read_xyz(f)
            crs = None
            keep = np.isin(cloud.classification, codes) if codes is not None and cloud.classification is not None \
                else slice(None)
            xyz.append(cloud.xyz[keep])
            cls.append(cloud.classification[keep] if cloud.classification is not None
                       else np.zeros(len(cloud.xyz[keep]), np.uint8))
        crs_of.append((f, crs))
    known = [(f, c) for f, c in crs_of if c]
    for f, c in known[1:]:
        if not _same_crs(known[0][1], c):
            raise InvalidInputError(
                f"clouds {str(known[0][0])!r} ({describe(known[0][1])}) and {str(f)!r} ({describe(c)}) are in "
                "different CRSs; reproject them to one (pdal translate, las2las) or mesh them apart"
            )
    points = np.concatenate(xyz) if xyz else np.empty((0, 3))
    if len(points) == 0:
        where = f"{len(files)} files" if len(files) > 1 else repr(str(files[0]))
        raise NoDataError(f"no points of class {list(codes)} in {where}" if codes else f"no points in {where}")
    return PointCloud(points, classification=np.concatenate(cls), crs=known[0][1] if known else None)
