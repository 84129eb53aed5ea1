"""CRS helpers: everything is kept as WKT in the data model; formats want other spellings."""

from __future__ import annotations

import functools
import re

__all__ = ["describe", "linear_unit", "to_epsg", "to_esri_wkt", "to_wkt"]


@functools.lru_cache(maxsize=64)
def _crs(text: str):
    from rasterio.crs import CRS

    return CRS.from_user_input(text)


def to_wkt(crs) -> str | None:
    """WKT of anything rasterio/pyproj understands (EPSG code, WKT, CRS object), or None."""
    if crs is None or crs == "":
        return None
    if hasattr(crs, "to_wkt"):
        return crs.to_wkt()
    return _crs(str(crs)).to_wkt()


def to_epsg(wkt: str | None) -> int | None:
    """The EPSG code of a CRS when it has one."""
    if not wkt:
        return None
    try:
        return _crs(wkt).to_epsg()
    except Exception:  # a CRS without an EPSG equivalent
        return None


def to_esri_wkt(wkt: str) -> str:
    """ESRI-flavoured WKT 1, as ``.prj`` sidecar files hold it."""
    return _crs(wkt).to_wkt(version="WKT1_ESRI")


def linear_unit(wkt: str | None) -> str:
    """Name of the horizontal unit ("metre", "foot", "US survey foot", ...); "unknown" without a CRS."""
    if not wkt:
        return "unknown"
    try:
        return _crs(wkt).linear_units or "unknown"
    except Exception:
        return "unknown"


def describe(wkt: str | None) -> str:
    """Short human name: ``"EPSG:26710 (NAD27 / UTM zone 10N)"``, the WKT name, or ``"none"``."""
    if not wkt:
        return "none"
    match = re.search(r'^\s*[A-Z_0-9]+\s*\[\s*"([^"]*)"', wkt)
    name = match.group(1) if match else "unnamed CRS"
    code = to_epsg(wkt)
    return f"EPSG:{code} ({name})" if code else name
