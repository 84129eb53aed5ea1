"""Raster readers: GDAL rasters (through rasterio), numpy arrays and PNG elevation tiles.

Every reader returns a :class:`~tinsmith.core.Heightfield`.  Errors name the
file (see :mod:`tinsmith.io._errors`).
"""

from __future__ import annotations

import contextlib
import os
import re
import threading
import warnings
from pathlib import Path

import numpy as np

from .. import _checks
from ..core import Heightfield
from ..errors import FormatError, InvalidInputError, InvalidOptionError, TinsmithError, TinsmithWarning
from ..resources import check_memory, raster_read_bytes
from ._errors import file_named_errors, format_error, option_value, with_file_name
from .crs import to_wkt
from .registry import reader

__all__ = [
    "GDAL_SUFFIXES",
    "decode_rgb",
    "read_gdal",
    "read_numpy",
    "raster_georeferencing",
    "raster_info",
    "read_png_tile",
    "read_window",
    "tile_transform",
]

#: Suffixes read through GDAL; the reader is also the fallback (``"*"``) for unknown ones.
GDAL_SUFFIXES = (".tif", ".tiff", ".dem", ".asc", ".img", ".hgt", ".bil", ".vrt", ".nc")
#: Half the width of the web-mercator world (EPSG:3857), in metres.
WEB_MERCATOR_HALF = 20037508.342789244
#: Deepest web-mercator zoom level accepted for a tile index.
MAX_ZOOM = 30
ENCODINGS = ("terrarium", "mapbox", "raw")


@contextlib.contextmanager
def _gdal_errors(path: Path, what: str, *, quiet_georeferencing: bool = False):
    """GDAL failures (open or read) of ``path`` within the block become :class:`FormatError`."""
    from rasterio.errors import NotGeoreferencedWarning, RasterioError

    try:
        from rasterio._err import CPLE_BaseError
    except ImportError:  # pragma: no cover - private module moved
        CPLE_BaseError = RasterioError

    try:
        with warnings.catch_warnings():
            if quiet_georeferencing:
                warnings.simplefilter("ignore", NotGeoreferencedWarning)
            yield
    except (RasterioError, CPLE_BaseError) as exc:
        raise format_error(path, what, exc) from exc


@contextlib.contextmanager
def _gdal_dataset(path: Path, what: str, *, quiet_georeferencing: bool = False):
    """Open ``path`` with rasterio; GDAL failures (open or read) become :class:`FormatError`."""
    import rasterio

    with _gdal_errors(path, what, quiet_georeferencing=quiet_georeferencing), rasterio.open(path) as ds:
        yield ds


#: The dataset :func:`read_window` last read, per thread: (path, change time, size, process), dataset.
_KEPT = threading.local()


def _kept_open(path: Path):
    """``path`` opened with rasterio and kept open for the next window of the same file in this thread and process.

    A tile job reads hundreds of windows of one DEM (sampling and checking
    every tile); opening the file each time cost about as much as reading.
    The file is opened again when it changed (modification time or size) or
    in another process (a forked worker never shares the parent's file
    position).
    """
    import rasterio

    try:
        st = os.stat(path)
    except OSError:  # rasterio says what is wrong with it
        return rasterio.open(path)
    key = (str(path), st.st_mtime_ns, st.st_size, os.getpid())
    held = getattr(_KEPT, "held", None)
    if held is not None and held[0] == key and not held[1].closed:
        return held[1]
    if held is not None and held[0][3] == key[3]:
        held[1].close()
    _KEPT.held = None
    ds = rasterio.open(path)
    _KEPT.held = (key, ds)
    return ds


def _crs_wkt(ds) -> str | None:
    return ds.crs.to_wkt() if ds.crs else None


# -- GDAL -------------------------------------------------------------------------------
@reader(
    GDAL_SUFFIXES + ("*",),
    kind="raster",
    description="GDAL raster such as GeoTIFF, USGS DEM or ESRI ASCII grid",
    options=("nodata", "band", "cell_size"),
)
@with_file_name
def read_gdal(path: Path, *, nodata=None, band=None, cell_size=None) -> Heightfield:
    """Read one band of any raster GDAL can open.

    Parameters
    ----------
    path : Path
    nodata : float, optional
        Height that also marks missing cells (``nan`` for NaN cells), on top of
        the cells GDAL masks (the file's declared nodata, internal masks).
    band : int, optional
        1-based band number.  Default: band 1, with a :class:`TinsmithWarning`
        when the file has more than one (alpha bands not counted).
    cell_size : float, optional
        Only for a file without georeferencing (no transform, no CRS): its
        cell size, making a north-up grid with the south-west corner at
        (0, 0).  Such a file without ``cell_size`` is an error, rather than a
        grid silently mirrored by GDAL's pixel coordinates.

    Returns
    -------
    Heightfield
        With the file's transform, CRS (WKT) and band data type.  Its
        ``nodata`` is the given one, else the file's declared value.
    """
    with _gdal_dataset(path, _gdal_what(path), quiet_georeferencing=True) as ds:
        return heightfield_from_dataset(ds, str(path), nodata=nodata, band=band, cell_size=cell_size)


def heightfield_from_dataset(ds, name: str, *, nodata=None, band=None, cell_size=None) -> Heightfield:
    """One band of an open rasterio dataset (:func:`read_gdal`'s rules; ``name`` for the messages)."""
    band = _band_number(band, ds, name)
    check_memory(
        raster_read_bytes(ds.height, ds.width, np.dtype(ds.dtypes[band - 1]).itemsize),
        f"reading {name!r} ({ds.height:,} x {ds.width:,} cells)",
        "'tinsmith tile' meshes a raster of any size in windows",
    )
    z = ds.read(band)
    mask = ds.read_masks(band) == 0
    declared = ds.nodatavals[band - 1]
    georeferenced = not (ds.transform.is_identity and not ds.crs)
    if georeferenced and cell_size is not None:
        raise InvalidOptionError(f"cell_size applies only to rasters without georeferencing; {name!r} has its own")
    georef = {"transform": tuple(ds.transform)[:6]} if georeferenced else {"cell_size": cell_size}
    if not georeferenced and cell_size is None:
        raise InvalidInputError(f"{name!r} has no georeferencing: pass cell_size (CLI --cell-size)")
    crs = _crs_wkt(ds)
    source_dtype = ds.dtypes[band - 1]
    return Heightfield(
        z,
        **georef,
        crs=crs,
        nodata=nodata if nodata is not None else declared,
        nodata_mask=mask,
        source_dtype=source_dtype,
    )


class RasterInfo:
    """What a windowed run needs to know of a GDAL raster without reading its cells."""

    def __init__(self, path, shape, transform, crs, nodata, dtype, band):
        self.path, self.shape, self.transform, self.crs = str(path), shape, transform, crs
        self.nodata, self.dtype, self.band = nodata, dtype, band

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the cell edges."""
        a, b, c, d, e, f = self.transform
        h, w = self.shape
        xs = [c + a * col + b * row for row in (0, h) for col in (0, w)]
        ys = [f + d * col + e * row for row in (0, h) for col in (0, w)]
        return (min(xs), min(ys), max(xs), max(ys))

    def window_transform(self, row0: int, col0: int) -> tuple[float, ...]:
        """The affine transform of a window whose first cell is (row0, col0)."""
        a, b, c, d, e, f = self.transform
        return (a, b, a * col0 + b * row0 + c, d, e, d * col0 + e * row0 + f)


@with_file_name
def raster_info(path: Path, *, band=None, nodata=None) -> RasterInfo:
    """Shape, transform, CRS and nodata of one band of a georeferenced GDAL raster (no cells read).

    ``band`` None: band 1, with a :class:`TinsmithWarning` when the file has several (as :func:`read_gdal`).
    """
    with _gdal_dataset(path, _gdal_what(path), quiet_georeferencing=True) as ds:
        band = _band_number(band, ds, str(path))
        if ds.transform.is_identity and not ds.crs:
            raise InvalidInputError(f"{str(path)!r} has no georeferencing; tiled runs need a georeferenced raster")
        declared = ds.nodatavals[band - 1]
        return RasterInfo(path, (ds.height, ds.width), tuple(ds.transform)[:6], _crs_wkt(ds),
                          nodata if nodata is not None else declared, ds.dtypes[band - 1], band)


def raster_georeferencing(path: Path) -> tuple[str | None, tuple, float]:
    """``(crs, bounds, cell)`` of a GDAL raster from its header: the CRS as WKT, ``(xmin, ymin, xmax, ymax)``, the cell size."""
    with _gdal_dataset(path, _gdal_what(path), quiet_georeferencing=True) as ds:
        a, b, _, d, e, _ = tuple(ds.transform)[:6]
        return (ds.crs.to_wkt() if ds.crs else None), tuple(ds.bounds), abs(a * e - b * d) ** 0.5


def read_window(info: RasterInfo, rows: tuple[int, int], cols: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Heights (float64, NaN where there is no data) and the valid mask of cells ``rows[0]..rows[1]`` x ``cols[0]..cols[1]``.

    Both ranges are inclusive.  Nodata is the band's mask (the declared value,
    internal masks), the ``nodata`` of ``info``, and NaN.
    """
    from rasterio.windows import Window

    path = Path(info.path)
    window = Window(cols[0], rows[0], cols[1] - cols[0] + 1, rows[1] - rows[0] + 1)
    with file_named_errors(path), _gdal_errors(path, _gdal_what(path), quiet_georeferencing=True):
        ds = _kept_open(path)
        z = ds.read(info.band, window=window).astype(np.float64)
        valid = ds.read_masks(info.band, window=window) != 0
    if info.nodata is not None:
        valid &= ~_equal_to(z, info.nodata)
    valid &= np.isfinite(z)
    z[~valid] = np.nan
    return z, valid


def _gdal_what(path: Path) -> str:
    if path.suffix.lower() in GDAL_SUFFIXES:
        return "a GDAL raster"
    return f"a GDAL raster (no other reader handles suffix {path.suffix or '(none)'!r})"


def _band_number(band, ds, name: str) -> int:
    """The band to read: ``band`` checked against the file's count; None is band 1, said aloud when there are more."""
    count = ds.count
    if band is None:
        heights = height_bands(ds)
        if len(heights) > 1:
            warnings.warn(
                f"{name!r} has {len(heights)} bands ({_band_names(ds, heights)}); reading band 1: pass --band N "
                "(band=N) to read another",
                TinsmithWarning,
                stacklevel=2,
            )
        return 1
    try:
        return _checks.integer("band", band, minimum=1, maximum=count)
    except InvalidInputError as exc:
        plural = "" if count == 1 else "s"
        raise InvalidOptionError(f"{exc} (the file has {count} band{plural})") from None


def height_bands(ds) -> list[int]:
    """The 1-based numbers of the bands of ``ds`` that may hold heights: all but alpha bands."""
    from rasterio.enums import ColorInterp

    interps = tuple(ds.colorinterp) if ds.colorinterp else ()
    return [i + 1 for i in range(ds.count) if i >= len(interps) or interps[i] != ColorInterp.alpha]


def _band_names(ds, bands) -> str:
    """``1 red, 2 green, 3 blue`` or ``1, 2``: the bands with their descriptions or colour meanings when they have one."""
    shown = []
    for b in bands[:4]:
        label = (ds.descriptions[b - 1] if ds.descriptions else None) or ""
        if not label and ds.colorinterp:
            interp = ds.colorinterp[b - 1].name
            label = "" if interp in ("undefined", "gray", "grey") else interp
        shown.append(f"{b} {label}".strip())
    return ", ".join(shown) + (", ..." if len(bands) > 4 else "")


# -- numpy ------------------------------------------------------------------------------
_NPY_MAGIC = b"\x93NUMPY"
_ZIP_MAGIC = b"PK\x03\x04"
_NPZ_METADATA = ("transform", "cell_size", "crs", "nodata")


@reader(
    (".npy", ".npz"),
    kind="raster",
    description="numpy height array in .npy or .npz",
    options=("nodata", "cell_size"),
)
@with_file_name
def read_numpy(path: Path, *, nodata=None, cell_size=None) -> Heightfield:
    """Read a 2-D height array from ``.npy`` or ``.npz``.

    Parameters
    ----------
    path : Path
        ``.npy``: a bare 2-D array, georeferenced by ``cell_size``.  ``.npz``:
        heights under ``"z"`` (else the only 2-D array), with optional arrays
        ``"transform"`` (6 floats), ``"cell_size"``, ``"crs"`` (string) and
        ``"nodata"``.
    nodata : float, optional
        Height that also marks missing cells (``nan`` for NaN cells).
    cell_size : float or (float, float), optional
        Cell size in world units; overrides the stored georeferencing (the
        stored transform's north-west corner is kept as origin).

    Raises
    ------
    InvalidInputError
        When neither the file nor ``cell_size`` georeferences the array.
    """
    stored = _load_numpy(path)
    z = stored["z"]
    declared = stored.get("nodata")
    both = nodata is not None and declared is not None
    return Heightfield(
        z,
        **_numpy_georeferencing(path, stored, cell_size),
        crs=_stored_crs(stored.get("crs")),
        nodata=nodata if nodata is not None else declared,
        nodata_mask=_equal_to(z, declared) if both else None,
    )


def _load_numpy(path: Path) -> dict:
    """The arrays of a .npy/.npz file: ``{"z": ..., [metadata keys]}``."""
    with open(path, "rb") as fh:
        magic = fh.read(6)
    if not (magic.startswith(_NPY_MAGIC) or magic.startswith(_ZIP_MAGIC)):
        raise FormatError(f"{str(path)!r} is not a numpy .npy/.npz file (it starts with {magic!r})")
    try:
        data = np.load(path, allow_pickle=False)
        if isinstance(data, np.ndarray):
            return {"z": data}
        with data:
            return _npz_contents(path, data)
    except (TinsmithError, MemoryError):
        raise
    except Exception as exc:  # object arrays, damaged archives (BadZipFile, zlib.error, EOFError)
        raise format_error(path, "a numpy file", exc) from exc


def _npz_contents(path: Path, data) -> dict:
    keys = list(data.files)
    if "z" in keys:
        key = "z"
    else:
        planes = [k for k in keys if data[k].ndim == 2]
        if len(planes) != 1:
            raise InvalidInputError(
                f"{str(path)!r} has no array 'z' and {len(planes)} 2-D arrays to choose from "
                f"(keys: {', '.join(keys) or 'none'}); save the heights under 'z'"
            )
        key = planes[0]
    out = {"z": data[key]}
    for name in _NPZ_METADATA:
        if name in keys:
            out[name] = _metadata(name, data[name])
    return out


def _metadata(name: str, arr: np.ndarray):
    if name == "transform":
        return tuple(float(v) for v in arr.ravel())
    if name == "crs":
        value = arr.item() if arr.size == 1 else ""
        return value.decode() if isinstance(value, bytes) else str(value)
    value = arr.tolist()
    return value[0] if isinstance(value, list) and len(value) == 1 else value


def _numpy_georeferencing(path: Path, stored: dict, cell_size) -> dict:
    """``transform=`` or ``cell_size=``/``origin=`` for :class:`Heightfield`."""
    transform = stored.get("transform")
    if cell_size is not None:
        origin = (transform[2], transform[5]) if transform is not None and len(transform) >= 6 else None
        return {"cell_size": cell_size, "origin": origin}
    found = {k: stored[k] for k in ("transform", "cell_size") if k in stored}
    if not found:
        hint = " or save a 'transform' array in the .npz" if path.suffix.lower() == ".npz" else ""
        raise InvalidInputError(
            f"{str(path)!r} has no georeferencing: pass cell_size (CLI --cell-size){hint}"
        )
    return found


def _stored_crs(text: str | None) -> str | None:
    if not text:
        return None
    try:
        return to_wkt(text)
    except Exception as exc:  # pyproj's CRSError
        raise InvalidInputError(f"the stored 'crs' {text!r} is not a coordinate reference system: {exc}") from None


def _equal_to(z: np.ndarray, value) -> np.ndarray:
    """True where ``z`` equals ``value``; a NaN ``value`` matches NaN cells."""
    value = float(value)
    return np.isnan(z) if np.isnan(value) else z == value


# -- PNG elevation tiles ------------------------------------------------------------------
_TILE_IN_NAME = re.compile(r"(?:^|[^a-z0-9])z(\d+)_(\d+)_(\d+)(?![0-9])", re.IGNORECASE)


@reader(
    (".png", ".webp"),
    kind="raster",
    description="PNG elevation tile in Terrarium, Mapbox Terrain-RGB or raw encoding",
    options=("encoding", "tile", "nodata"),
)
@with_file_name
def read_png_tile(path: Path, *, encoding=None, tile=None, nodata=None) -> Heightfield:
    """Read an elevation tile stored as an image.

    Parameters
    ----------
    path : Path
    encoding : {"terrarium", "mapbox", "raw"}, optional
        ``"terrarium"``: ``h = R*256 + G + B/256 - 32768``; ``"mapbox"``
        (Terrain-RGB): ``h = -10000 + (R*65536 + G*256 + B) * 0.1``;
        ``"raw"``: band 1 holds the heights (a 16-bit grayscale DEM).
        Default: "terrarium" when the file name contains "terrarium",
        "mapbox" when it contains "terrain-rgb", "terrainrgb" or "mapbox".
    tile : (z, x, y) or "z/x/y", optional
        Web-mercator tile index that georeferences the image (EPSG:3857).
        Default for RGB encodings: parsed from a file name holding
        ``z{Z}_{X}_{Y}`` or a path ending in ``{Z}/{X}/{Y}.png``.  A raw
        image without ``tile`` uses the file's own georeferencing (world file).
    nodata : float, optional
        Decoded height that also marks missing pixels; pixels with alpha 0
        are always nodata.
    """
    encoding = _encoding(path, encoding)
    index = _tile_option(tile) if tile is not None else None
    if index is None and encoding != "raw":
        index = _tile_from_path(path)
        if index is None:
            raise InvalidInputError(
                f"{str(path)!r} has no tile index in its name (z{{Z}}_{{X}}_{{Y}} or {{Z}}/{{X}}/{{Y}}.png): "
                "pass tile (CLI --tile Z/X/Y) to georeference it"
            )
    with _gdal_dataset(path, "an image", quiet_georeferencing=True) as ds:
        mask = ds.read_masks(1) == 0
        if encoding == "raw":
            z, source_dtype = ds.read(1), ds.dtypes[0]
        else:
            z, source_dtype = decode_rgb(_rgb_bands(ds, encoding), encoding), "float32"
        georef = tile_georeferencing(*index, *z.shape[::-1]) if index else _file_georeferencing(path, ds)
    return Heightfield(z, **georef, nodata=nodata, nodata_mask=mask, source_dtype=source_dtype)


def decode_rgb(rgb, encoding: str) -> np.ndarray:
    """Heights (float64) from the (3, H, W) R, G, B bands of a Terrarium or Mapbox tile."""
    r, g, b = (np.asarray(band, dtype=np.float64) for band in rgb[:3])
    if encoding == "terrarium":
        return r * 256.0 + g + b / 256.0 - 32768.0
    if encoding == "mapbox":
        return -10000.0 + (r * 65536.0 + g * 256.0 + b) * 0.1
    raise InvalidOptionError(f"encoding must be 'terrarium' or 'mapbox' to decode RGB, got {encoding!r}")


def tile_transform(z: int, x: int, y: int, width: int, height: int) -> tuple[float, ...]:
    """Affine transform (EPSG:3857 metres) of a ``width`` x ``height`` image of tile ``z/x/y``."""
    size = 2.0 * WEB_MERCATOR_HALF / 2**z
    west = -WEB_MERCATOR_HALF + x * size
    north = WEB_MERCATOR_HALF - y * size
    return (size / width, 0.0, west, 0.0, -size / height, north)


def tile_georeferencing(z: int, x: int, y: int, width: int, height: int) -> dict:
    """``transform=`` and ``crs=`` (WKT of EPSG:3857) of a web-mercator tile image."""
    return {"transform": tile_transform(z, x, y, width, height), "crs": to_wkt("EPSG:3857")}


def _encoding(path: Path, encoding) -> str:
    if encoding is not None:
        value = encoding.lower() if isinstance(encoding, str) else encoding
        return option_value(_checks.choice, "encoding", value, ENCODINGS)
    name = path.name.lower()
    if "terrarium" in name:
        return "terrarium"
    if any(key in name for key in ("terrain-rgb", "terrainrgb", "mapbox")):
        return "mapbox"
    raise InvalidInputError(
        f"{str(path)!r}: cannot tell how heights are encoded from the file name; "
        "pass encoding 'terrarium', 'mapbox' or 'raw' (CLI --encoding)"
    )


def _tile_option(tile) -> tuple[int, int, int]:
    if isinstance(tile, str):
        parts = [p.strip() for p in tile.strip().split("/")]
        parts = [int(p) if p.isdigit() else p for p in parts]
    else:
        try:
            parts = list(tile)
        except TypeError:
            parts = []
    if len(parts) != 3:
        raise InvalidOptionError(f"tile must be (z, x, y) or a string 'z/x/y', got {tile!r}")
    return _checked_tile(parts, "tile", InvalidOptionError)


def _tile_from_path(path: Path) -> tuple[int, int, int] | None:
    match = _TILE_IN_NAME.search(path.stem)
    if match:
        parts = [int(v) for v in match.groups()]
    elif len(path.parts) >= 3 and all(p.isdigit() for p in (path.parts[-3], path.parts[-2], path.stem)):
        parts = [int(path.parts[-3]), int(path.parts[-2]), int(path.stem)]
    else:
        return None
    return _checked_tile(parts, "the tile index in the file name", InvalidInputError)


def _checked_tile(parts, name: str, error) -> tuple[int, int, int]:
    try:
        z = _checks.integer(f"{name} zoom", parts[0], minimum=0, maximum=MAX_ZOOM)
        top = 2**z - 1
        x = _checks.integer(f"{name} x (at zoom {z})", parts[1], minimum=0, maximum=top)
        y = _checks.integer(f"{name} y (at zoom {z})", parts[2], minimum=0, maximum=top)
    except InvalidInputError as exc:
        raise error(str(exc)) from None
    return (z, x, y)


def _rgb_bands(ds, encoding: str) -> np.ndarray:
    if ds.count < 3 or any(t != "uint8" for t in ds.dtypes[:3]):
        raise InvalidInputError(
            f"{encoding} encoding needs an 8-bit RGB or RGBA image, got {ds.count} band(s) of "
            f"{ds.dtypes[0]}; for a grayscale height image pass encoding 'raw'"
        )
    return ds.read((1, 2, 3))


def _file_georeferencing(path: Path, ds) -> dict:
    if ds.transform.is_identity and not ds.crs:
        raise InvalidInputError(
            f"{str(path)!r} has no georeferencing: add a world file beside it "
            "or pass tile (CLI --tile Z/X/Y)"
        )
    return {"transform": tuple(ds.transform)[:6], "crs": _crs_wkt(ds)}
