"""CRS helpers: the data model keeps a CRS as WKT text; formats want other spellings.

Built on pyproj (MIT), which reads every CRS spelling rasterio and laspy produce.
"""

from __future__ import annotations

import functools

__all__ = ["describe", "linear_unit", "to_epsg", "to_esri_wkt", "to_wkt"]


@functools.lru_cache(maxsize=64)
def _crs(text: str):
    from pyproj import CRS

    return CRS.from_user_input(text)


def to_wkt(crs) -> str | None:
    """WKT of anything pyproj understands (EPSG code, WKT, CRS object), or None."""
    if crs is None or crs == "":
        return None
    if hasattr(crs, "to_wkt"):
        return crs.to_wkt()
    return _crs(str(crs)).to_wkt()


def _horizontal(wkt: str):
    crs = _crs(wkt)
    return crs.sub_crs_list[0] if crs.is_compound and crs.sub_crs_list else crs


def to_epsg(wkt: str | None) -> int | None:
    """The EPSG code of a CRS (of its horizontal part, for a compound CRS) when it has one."""
    if not wkt:
        return None
    try:
        return _horizontal(wkt).to_epsg()
    except Exception:  # not a CRS pyproj can parse
        return None


def to_esri_wkt(wkt: str) -> str:
    """ESRI-flavoured WKT 1 of the horizontal CRS, as ``.prj`` sidecar files hold it."""
    return _horizontal(wkt).to_wkt(version="WKT1_ESRI")


def linear_unit(wkt: str | None) -> str:
    """Name of the horizontal unit ("metre", "foot", "US survey foot", ...); "unknown" without a CRS."""
    if not wkt:
        return "unknown"
    try:
        axes = _horizontal(wkt).axis_info
        return axes[0].unit_name if axes else "unknown"
    except Exception:
        return "unknown"


#: What a user hears when a DEM's CRS is geographic (``crs``: its short name).
GEOGRAPHIC_WARNING = (
    "the CRS {crs} is geographic: x and y are degrees while heights are not, so slopes, triangle shapes, areas "
    "and distances mix units; reproject to a projected CRS first (e.g. gdalwarp -t_srs EPSG:32633) for a mesh "
    "to simulate on"
)


def is_geographic(wkt: str | None) -> bool:
    """Whether the horizontal part of a CRS is in degrees (latitude and longitude); False when unknown."""
    if not wkt:
        return False
    try:
        crs = _crs(wkt)
    except Exception:
        return False
    horizontal = crs.sub_crs_list[0] if crs.is_compound else crs
    return bool(horizontal.is_geographic)


def describe(wkt: str | None) -> str:
    """Short human name: ``"EPSG:26710 (NAD27 / UTM zone 10N)"``; a compound CRS part by part."""
    if not wkt:
        return "none"
    try:
        crs = _crs(wkt)
    except Exception:
        return "unparsable CRS"
    parts = crs.sub_crs_list if crs.is_compound else [crs]
    names = []
    for part in parts:
        code = part.to_epsg()
        names.append(f"EPSG:{code} ({part.name})" if code else part.name)
    return " + ".join(names)
