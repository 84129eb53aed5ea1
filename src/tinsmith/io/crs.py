"""CRS helpers: the data model keeps a CRS as WKT text; formats want other spellings.

Built on pyproj (MIT), which reads every CRS spelling rasterio and laspy produce.
"""

from __future__ import annotations

import functools

from ..errors import InvalidInputError

__all__ = ["describe", "linear_unit", "metres_per_unit", "refuse_geographic", "to_epsg", "to_esri_wkt", "to_wkt", "utm_epsg"]


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


#: Metres of a degree of latitude (about; a degree of longitude shrinks with its cosine).
M_PER_DEGREE = 111_320.0


def metres_per_unit(wkt: str | None) -> float:
    """Metres in one horizontal unit of a CRS: a degree's (:data:`M_PER_DEGREE`) for a geographic one, 1 without
    a CRS (taken as metres)."""
    if not wkt:
        return 1.0
    horizontal = _horizontal(wkt)
    return M_PER_DEGREE if horizontal.is_geographic else horizontal.axis_info[0].unit_conversion_factor


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


def utm_epsg(lon: float, lat: float) -> int | None:
    """EPSG code of the WGS 84 / UTM zone of a point (326zz north, 327zz south); None off the globe."""
    if not (-180.0 <= lon <= 180.0 and -84.0 <= lat <= 84.0):
        return None  # beyond UTM (polar regions: a polar stereographic CRS)
    zone = min(int((lon + 180.0) // 6.0) + 1, 60)
    return (32600 if lat >= 0 else 32700) + zone


def reproject_hint(bounds) -> str:
    """``e.g. EPSG:32633 (WGS 84 / UTM zone 33N, where the data lies): gdalwarp ... or las2las ...`` for
    data in degrees covering ``bounds`` (xmin, ymin, xmax, ymax: longitude, latitude)."""
    code = None
    if bounds is not None:
        xmin, ymin, xmax, ymax = bounds[:4]
        code = utm_epsg(0.5 * (xmin + xmax), 0.5 * (ymin + ymax))
    target = f"EPSG:{code}" if code else "a projected CRS in metres"
    where = f"e.g. {describe(target)}, where the data lies" if code else "e.g. a polar stereographic or local CRS"
    return (f"reproject to a projected CRS first ({where}): gdalwarp -t_srs {code and target or 'EPSG:...'} "
            f"for a raster, pdal translate or las2las for a point cloud")


def refuse_geographic(crs, bounds, what: str, why: str) -> None:
    """Refuse data in a geographic CRS for ``what``, whose parameters are lengths in metres.

    An :class:`InvalidInputError` of one line: the CRS, ``why`` (what the
    metres would become in degrees) and where to reproject.  Nothing when
    the CRS is projected or unknown.
    """
    if not is_geographic(crs):
        return
    raise InvalidInputError(
        f"{what} measures in metres, but the CRS {describe(crs)} is geographic: x and y are degrees, so {why}; "
        f"{reproject_hint(bounds)}"
    )
