"""Which files a command reads and writes, so that no output ever replaces an input.

``tinsmith simplify dem.tif -o dem.tif`` would replace the DEM by its lossy
re-rasterised mesh, and ``simplify dem.asc -o dem.ply`` would overwrite the
``dem.prj`` the ASCII grid takes its CRS from (the PLY writer puts the CRS in a
``.prj`` sidecar).  :func:`check_outputs` compares every file a command will
write (outputs and their sidecars) with every file it reads (inputs and the
files read with them: GDAL's own file list, world files, ``.aux.xml``,
shapefile parts) before any work, and refuses with one line naming both.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

from ..errors import FileError
from . import reader_for

__all__ = ["check_outputs", "files_read_with", "files_written_with"]

#: The parts of a shapefile (OGR reads them with the ``.shp``).
SHAPEFILE_PARTS = (".shx", ".dbf", ".prj", ".cpg", ".qix", ".sbn", ".sbx")


def _gdal_files(path: Path) -> list[Path]:
    """GDAL's own list of the files a raster consists of (sidecars, a VRT's sources); empty when it cannot open it."""
    try:
        import rasterio

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # NotGeoreferencedWarning: the reader says what matters
            with rasterio.open(path) as ds:
                return [Path(f) for f in ds.files]
    except Exception:  # not a raster, or damaged: the reader reports it
        return []


def files_read_with(path) -> list[Path]:
    """``path`` and the files a reader takes with it.

    For rasters, GDAL's own file list (``dem.prj`` of an ASCII grid, world
    files, ``.aux.xml``, a VRT's sources); for a shapefile, its parts.
    """
    path = Path(path)
    found = [path]
    if not path.is_file():
        return found
    if path.suffix.lower() == ".shp":
        found += [p for p in (path.with_suffix(s) for s in SHAPEFILE_PARTS) if p.exists()]
    elif reader_for(path).kind == "raster" and path.suffix.lower() not in (".npy", ".npz"):
        found += _gdal_files(path)
    return found


def files_written_with(path) -> list[Path]:
    """``path`` and the ``.prj`` sidecar its writer adds when the format cannot carry a CRS."""
    from . import WRITERS  # every format module (numpy): imported when an output is checked

    path = Path(path)
    record = WRITERS.get(path.suffix.lower())
    if record is not None and not record.carries_crs:
        return [path, path.with_suffix(".prj")]
    return [path]


def _key(path: Path):
    """Identity of a file: (device, inode) when it exists (hard links, symbolic links), else its real path."""
    try:
        st = os.stat(path)
        return ("inode", st.st_dev, st.st_ino)
    except OSError:
        return ("path", os.path.realpath(path))


def check_outputs(outputs, inputs=()) -> None:
    """Refuse, before any work, outputs that would replace an input or each other.

    Parameters
    ----------
    outputs : iterable of path
        Every file the command will write (``None`` entries are skipped); the
        ``.prj`` sidecars of mesh formats that cannot carry a CRS count too.
    inputs : iterable of path
        Every file the command reads (``None`` entries are skipped); the files
        read with them (:func:`files_read_with`) count as inputs too.

    Raises
    ------
    FileError
        One line naming the output and the input it would replace, or the
        output named twice.
    """
    read = {}
    for given in (Path(p) for p in inputs if p is not None):
        for f in files_read_with(given):
            read.setdefault(_key(f), (f, given))
    primaries = {}
    for given in (Path(p) for p in outputs if p is not None):
        key = _key(given)
        if key in primaries:
            first = primaries[key]
            same = "is named twice" if first == given else f"and {str(first)!r} are the same file"
            raise FileError(f"output {str(given)!r} {same}; give each output once")
        primaries[key] = given
        for f in files_written_with(given):
            if _key(f) not in read:
                continue
            source, input_path = read[_key(f)]
            if f == given and source == input_path:
                raise FileError(
                    f"output {str(given)!r} is the input {str(input_path)!r}: writing it would replace the input; "
                    "choose another output name"
                )
            what = f"output {str(given)!r}" if f == given else f"output {str(given)!r} writes {str(f)!r}, which"
            raise FileError(
                f"{what} is read with the input {str(input_path)!r}: writing it would replace part of the input; "
                "choose another output name"
            )
