"""Heights above the WGS 84 ellipsoid for web terrain, from a DEM's vertical CRS (PROJ through pyproj).

Quantized-mesh tiles (https://github.com/CesiumGS/quantized-mesh: "heights in
metres above the WGS84 ellipsoid") and 3D Tiles (https://docs.ogc.org/cs/22-025r4/22-025r4.html,
positions in ECEF, EPSG:4978) place terrain on the ellipsoid, while most DEMs
hold heights above a geoid (EGM96, NAVD88, NAP...), tens of metres away.

:func:`ellipsoid_heights` reads the DEM's CRS and decides:

* a compound CRS with a vertical part (EPSG:32611+5703, EPSG:4326+5773,
  EPSG:28992+5709...), or a horizontal CRS with a vertical CRS given by the
  user (``vertical_crs``, for the many DEMs whose file lacks it): PROJ's
  transformation from it to WGS 84 ellipsoidal heights (EPSG:4979), chosen by
  :class:`pyproj.transformer.TransformerGroup` (``always_xy=True``) and named
  (its description and grids);
* a horizontal CRS alone, a vertical part of unknown datum (GDAL writes
  ``VDATUM["unknown"]``), a 3D geographic CRS, or ``vertical_crs="none"``:
  heights taken as given (plus the user's ``height_offset``), and said so.

Without the geoid grid a transformation needs, PROJ does not fail: it falls
back to a "ballpark vertical transformation", which leaves heights unchanged
(PROJ's ``createBallparkVerticalTransformation``, in
``src/iso19111/operation/coordinateoperationfactory.cpp``).  That would put a
DEM on NAVD88 about 30 m too high in California, so it is refused in one
line naming the missing grid and how to get it (``projsync --file NAME`` or
``pyproj sync --file NAME``, or Debian's ``proj-data`` package for EGM96).

PROJ looks for grids in pyproj's data folder, the user's PROJ folder (where
``projsync`` writes) and ``PROJ_DATA``; a wheel of pyproj does not look in
the system's PROJ folder, where Debian's ``proj-data`` puts its grids, so
:data:`SYSTEM_GRID_DIRS` that exist are added after those (once per
process, workers included) before any transformation is chosen.

The conversion is applied to the sampled nodes of a tile, vectorised, once
per tile (:meth:`EllipsoidHeights.to_ellipsoid`): a pure function of the
node's coordinates and sampled height, so that the same node in neighbouring
tiles gets the same height bit for bit.
"""

from __future__ import annotations

import functools
import math
import os
import warnings
from dataclasses import dataclass, replace

import numpy as np

from ..errors import InvalidInputError, InvalidOptionError

__all__ = ["ELLIPSOIDAL", "SYSTEM_GRID_DIRS", "EllipsoidHeights", "MissingGridError", "ellipsoid_heights"]

#: WGS 84 geographic 3D (longitude, latitude, ellipsoidal height): the heights of quantized-mesh and 3D Tiles.
ELLIPSOIDAL = "EPSG:4979"
#: The words PROJ puts in the name of the no-op it uses for a vertical CRS it has no (available) transformation for.
BALLPARK = "ballpark vertical transformation"
#: System folders of PROJ data (Debian's proj-data installs into the first), searched after pyproj's own.
SYSTEM_GRID_DIRS = ("/usr/share/proj", "/usr/local/share/proj")
#: Grids (PROJ's names) that Debian's proj-data ships, under their older names PROJ maps (egm96_15.gtx).
DEBIAN_GRIDS = frozenset({"us_nga_egm96_15.tif"})
#: Nodes a side of the lattice over the DEM on which the range of the converted heights is estimated.
_RANGE_NODES = 65


class MissingGridError(InvalidInputError):
    """The transformation of a DEM's vertical CRS needs a PROJ grid that is not installed."""


@dataclass(frozen=True)
class EllipsoidHeights:
    """How a DEM's heights become metres above the WGS 84 ellipsoid (picklable: tile workers receive it).

    Attributes
    ----------
    vertical_crs : str
        Name of the DEM's vertical CRS ("" when it has none).
    operation : str or None
        WKT of PROJ's transformation from the DEM's (compound) CRS to
        EPSG:4979, or None when heights are taken as given.
    description : str
        PROJ's description of that transformation, or why there is none.
    grids : tuple of str
        The grids it uses (PROJ's names).
    low, high : float
        Bounds of the converted heights over the DEM (with a margin): the
        pyramid quantizes heights in this range.
    """

    vertical_crs: str
    operation: str | None
    description: str
    grids: tuple[str, ...] = ()
    low: float = -math.inf
    high: float = math.inf

    def note(self, height_offset: float = 0.0) -> str:
        """One sentence for summaries: what was done to the heights."""
        plus = f" + offset ({height_offset:g} m)"
        if self.operation is None:
            return f"{self.description}; heights taken as given{plus}"
        grids = f" (grid {', '.join(self.grids)})" if self.grids else ""
        return f"{self.vertical_crs} to WGS 84 ellipsoidal heights by PROJ: {self.description}{grids}{plus}"

    def record(self, height_offset: float = 0.0) -> dict:
        """The summary's and layer.json's ``heights`` entry."""
        return {"vertical_crs": self.vertical_crs or None, "to": ELLIPSOIDAL if self.operation else None,
                "operation": self.description if self.operation else None, "grids": list(self.grids),
                "height_offset": height_offset, "note": self.note(height_offset)}

    def to_ellipsoid(self, x, y, h) -> np.ndarray:
        """Heights ``h`` (NaN: no data) at points ``(x, y)`` of the DEM's CRS, above the WGS 84 ellipsoid.

        Vectorised over the points (a tile's nodes); deterministic, so the
        same node of two tiles gets the same height.
        """
        h = np.asarray(h, dtype=np.float64)
        if self.operation is None:
            return h
        out = h.copy()
        ok = np.isfinite(h)
        if not ok.any():
            return out
        x, y = np.broadcast_to(x, h.shape)[ok], np.broadcast_to(y, h.shape)[ok]
        with np.errstate(invalid="ignore", over="ignore"):
            _, _, converted = _operation(self.operation).transform(x, y, h[ok])
        converted = np.asarray(converted, dtype=np.float64)
        bad = ~np.isfinite(converted)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InvalidInputError(f"PROJ cannot convert the height at ({x[i]:.10g}, {y[i]:.10g}) of the DEM's CRS with "
                                    f"{self.description!r}: the point is outside its grid "
                                    f"{', '.join(self.grids) or '(none)'} or its area of use")
        if converted.min() < self.low or converted.max() > self.high:
            raise InvalidInputError(f"a converted height ({converted.min():.6g}..{converted.max():.6g} m) is outside "
                                    f"the range estimated over the DEM ({self.low:.6g}..{self.high:.6g} m); "
                                    "give vertical_crs 'none' and height_offset instead")
        out[ok] = converted
        return out

    def over(self, raster, lo: float, hi: float) -> EllipsoidHeights:
        """This conversion with the bounds of the converted heights of a DEM whose heights are within [lo, hi].

        The separation (converted minus given height) is evaluated on a
        lattice of 65 x 65 points over the DEM at both ``lo`` and ``hi``; the
        bounds are its extremes widened by the largest change between
        neighbouring lattice points plus a metre (the separation varies
        slowly: geoid grids are interpolated between nodes 1 to 15 minutes
        apart).  Heights outside them are refused when converted, never
        wrapped round the quantization.
        """
        if self.operation is None:
            return replace(self, low=float(lo), high=float(hi))
        H, W = raster.shape
        a, b, c, d, e, f = raster.transform
        t = np.linspace(0.0, 1.0, _RANGE_NODES)
        C, R = np.meshgrid(t * W, t * H)
        X, Y = a * C + b * R + c, d * C + e * R + f
        seps = []
        for level in (lo, hi):
            with np.errstate(invalid="ignore", over="ignore"):
                _, _, z = _operation(self.operation).transform(X, Y, np.full(X.shape, float(level)))
            seps.append(np.asarray(z, dtype=np.float64) - level)
        sep = np.stack(seps)
        sep[~np.isfinite(sep)] = np.nan  # PROJ's inf outside the grid
        if np.isnan(sep).all():
            raise InvalidInputError(f"PROJ cannot convert any height of {raster.path!r} with {self.description!r}: "
                                    f"the DEM is outside its grid {', '.join(self.grids) or '(none)'} or its area of use")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN differences where the lattice leaves the grid
            jump = max(np.nanmax(np.abs(np.diff(sep, axis=1)), initial=0.0), np.nanmax(np.abs(np.diff(sep, axis=2)), initial=0.0))
        margin = float(jump) + 1.0
        return replace(self, low=float(lo + np.nanmin(sep) - margin), high=float(hi + np.nanmax(sep) + margin))


def ellipsoid_heights(crs: str | None, vertical_crs: str | None = None) -> EllipsoidHeights:
    """How the heights of a DEM in ``crs`` become WGS 84 ellipsoidal heights.

    Parameters
    ----------
    crs : str
        The DEM's CRS (WKT, ``EPSG:XXXX`` or ``EPSG:XXXX+YYYY``), e.g.
        :attr:`tinsmith.io.raster.RasterInfo.crs`.
    vertical_crs : str, optional
        The DEM's vertical CRS when its file lacks it (``EPSG:5703``...); it
        replaces the file's vertical part if there is one.  ``"none"``: take
        the heights as given, whatever the file says.

    Returns
    -------
    EllipsoidHeights
        PROJ's transformation to EPSG:4979 (with the grids it uses), or none
        with the reason.

    Raises
    ------
    MissingGridError
        The transformation needs a grid that is not installed: PROJ would
        leave the heights unchanged.
    InvalidOptionError
        ``vertical_crs`` is no vertical CRS.
    InvalidInputError
        PROJ knows no transformation from the vertical CRS to the ellipsoid.
    """
    from pyproj import CRS
    from pyproj.crs import CompoundCRS
    from pyproj.exceptions import CRSError

    try:
        given = CRS.from_user_input(crs)
    except CRSError as exc:
        raise InvalidInputError(f"the DEM's CRS is not one PROJ reads: {exc}") from None
    if vertical_crs is not None and str(vertical_crs).strip().lower() == "none":
        return EllipsoidHeights("", None, "vertical CRS ignored (vertical_crs 'none')")
    horizontal, vertical = _split(given)
    if vertical is not None and vertical_crs is None and _unknown(vertical):
        return EllipsoidHeights("", None, f"vertical CRS {vertical.name!r} of unknown datum (vertical_crs names it)")
    if vertical_crs is not None:
        try:
            vertical = CRS.from_user_input(vertical_crs)
        except CRSError:
            raise InvalidOptionError(f"vertical_crs must be a vertical CRS PROJ knows (e.g. EPSG:5703 for NAVD88 "
                                     f"height), got {vertical_crs!r}") from None
        if not vertical.is_vertical:
            raise InvalidOptionError(f"vertical_crs must be a vertical CRS (e.g. EPSG:5703 for NAVD88 height), got "
                                     f"{vertical_crs!r}, {vertical.type_name} {vertical.name!r}")
        if horizontal is None:  # a 3D geographic CRS given a vertical one: its 2D part
            horizontal = given.to_2d()
    if vertical is None:
        if horizontal is None:
            return EllipsoidHeights("", None, f"3D geographic CRS {given.name}: ellipsoidal heights")
        return EllipsoidHeights("", None, "no vertical CRS")
    source = given if vertical_crs is None else CompoundCRS(f"{horizontal.name} + {vertical.name}", [horizontal, vertical])
    return _conversion(source, _label(vertical))


def _split(crs):
    """(horizontal, vertical) parts of a CRS: (crs, None) for a 2D one, (None, None) for a 3D geographic one."""
    if crs.is_compound:
        parts = crs.sub_crs_list
        vertical = next((p for p in parts if p.is_vertical), None)
        horizontal = next((p for p in parts if not p.is_vertical), None)
        return horizontal, vertical
    if crs.is_vertical:
        raise InvalidInputError(f"the DEM's CRS {crs.name!r} is vertical only: it cannot place the DEM on the globe")
    if len(crs.axis_info) == 3:
        return None, None
    return crs, None


def _unknown(vertical) -> bool:
    """A vertical CRS that says nothing: no authority code, its name or datum "unknown..." (as GDAL writes them)."""
    names = (vertical.name, vertical.datum.name if vertical.datum is not None else "")
    return vertical.to_epsg(min_confidence=70) is None and any(n.lower().startswith(("unknown", "unnamed")) for n in names)


def _label(vertical) -> str:
    code = vertical.to_epsg(min_confidence=90)
    return f"{vertical.name} (EPSG:{code})" if code else vertical.name


def _conversion(source, label: str) -> EllipsoidHeights:
    """PROJ's best transformation available from ``source`` to EPSG:4979, or a one-line refusal."""
    from pyproj.exceptions import ProjError
    from pyproj.transformer import TransformerGroup

    use_system_grids()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # pyproj's "best transformation is not available": handled here
            group = TransformerGroup(source, ELLIPSOIDAL, always_xy=True)
    except ProjError as exc:
        raise InvalidInputError(f"PROJ cannot relate {label} to WGS 84 ellipsoidal heights: {exc}") from None
    usable = [t for t in group.transformers if not _ballpark(t)]
    if not usable:
        missing = [g.short_name for op in group.unavailable_operations[:1] for g in op.grids if not g.available]
        if missing:
            raise MissingGridError(_missing_message(label, missing))
        raise InvalidInputError(f"PROJ knows no transformation from {label} to WGS 84 ellipsoidal heights, only a ballpark "
                                "one that leaves heights unchanged; give vertical_crs 'none' and the geoid undulation "
                                "as height_offset")
    chosen = usable[0]
    grids = tuple(dict.fromkeys(g.short_name for op in (chosen.operations or ()) for g in op.grids))
    return EllipsoidHeights(label, chosen.to_wkt(), chosen.description, grids)


def _ballpark(transformer) -> bool:
    """True if the transformation's vertical part is PROJ's no-op fallback."""
    return any(BALLPARK in op.name for op in (transformer.operations or ())) or BALLPARK in transformer.description


def _missing_message(label: str, grids: list[str]) -> str:
    names, get = ", ".join(grids), " and ".join(f"`projsync --file {g}`" for g in grids)
    debian = " (or `apt-get install proj-data`)" if set(grids) <= DEBIAN_GRIDS else ""
    return (f"converting {label} to WGS 84 ellipsoidal heights needs PROJ's grid{'s' * (len(grids) > 1)} {names}, not "
            f"installed (without {'them' if len(grids) > 1 else 'it'} PROJ would leave the heights unchanged): get "
            f"{'them' if len(grids) > 1 else 'it'} with {get}{debian}, or give vertical_crs 'none' and height_offset")


def use_system_grids() -> None:
    """Let PROJ find grids in the system folders of :data:`SYSTEM_GRID_DIRS` that exist, after pyproj's own."""
    from pyproj import datadir

    current = datadir.get_data_dir().split(os.pathsep)
    for folder in SYSTEM_GRID_DIRS:
        if os.path.isdir(folder) and folder not in current:
            datadir.append_data_dir(folder)
            current.append(folder)


@functools.lru_cache(maxsize=8)
def _operation(wkt: str):
    """The transformation of a WKT (built once per process; grids found as when it was chosen)."""
    from pyproj import Transformer

    use_system_grids()
    return Transformer.from_pipeline(wkt)
