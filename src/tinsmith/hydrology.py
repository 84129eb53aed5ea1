"""Hydrology of a heightfield: filled surface, D8 flow, contributing area, streams and HAND.

The steps build on one another, and each public function runs the ones it
needs (a few tenths of a second on a million cells once the kernels are
compiled):

1. :func:`fill_depressions`: Priority-Flood with epsilon (Barnes, Lehman &
   Mulla 2014) from the grid's edge and from every cell next to nodata, so
   that every cell has a strictly lower neighbour on a path to an outlet.
2. :func:`flow_directions`: D8, the steepest descent on the filled surface.
3. :func:`flow_accumulation`: contributing area in map units squared.
4. :func:`stream_lines`: the cells whose contributing area exceeds
   ``min_area``, as polylines split at confluences.
5. :func:`height_above_drainage`: HAND (Rennó et al. 2008).
6. :func:`normal_depth`: the depth and speed of steady flow under uniform
   rain (Manning's formula on the contributing area), what the flood
   method sizes its triangles by.

Nodata cells take no part in the flow: the valid cells next to them are
outlets, like the cells on the grid's edge.  The kernels are in
:mod:`tinsmith.kernels.hydro`.
"""

from __future__ import annotations

import numpy as np

from . import _checks
from .core import Heightfield
from .errors import InvalidInputError, NoDataError

#: Default stream threshold: this many cells of contributing area (see :func:`stream_lines`).
DEFAULT_STREAM_CELLS = 1000
#: :func:`normal_depth`'s defaults: rain rate (m/s: 100 mm/h) and Manning's n (s/m^(1/3)).
DEFAULT_RAIN = 0.1 / 3600.0
DEFAULT_MANNING = 0.03
#: The flow width (m) of a discharge Q (m3/s) is at least ``WIDTH_COEFF * sqrt(Q)``: the width exponent 0.5 of
#: Leopold & Maddock's (1953) downstream hydraulic geometry, w = a Q^b, with a = 3 (channels widen as they carry
#: more; without it all of a river's water would run one cell wide).
WIDTH_COEFF = 3.0
#: The least slope in :func:`normal_depth` (flats of the filled surface would give an infinite depth).
MIN_SLOPE = 1e-3
GRAVITY = 9.81

__all__ = [
    "DEFAULT_STREAM_CELLS",
    "fill_depressions",
    "flow_accumulation",
    "flow_directions",
    "height_above_drainage",
    "normal_depth",
    "stream_lines",
]


def _check(hf) -> Heightfield:
    if not isinstance(hf, Heightfield):
        raise InvalidInputError(f"hf must be a tinsmith.Heightfield, got {type(hf).__name__}")
    if not hf.valid.any():
        raise NoDataError("hf has no valid cell: every cell of the heightfield is nodata")
    return hf


def _filled(hf: Heightfield) -> np.ndarray:
    from .kernels import hydro

    return hydro.priority_flood_epsilon(np.asarray(hf.z, dtype=np.float64), np.ascontiguousarray(hf.valid))


def _directions(hf: Heightfield) -> tuple[np.ndarray, np.ndarray]:
    """(filled, D8 codes) of a checked ``hf``."""
    from .kernels import hydro

    filled = _filled(hf)
    dx, dy = hf.cell_size
    return filled, hydro.d8(filled, np.ascontiguousarray(hf.valid), float(dx), float(dy))


def _flow(hf: Heightfield):
    """(filled, D8 codes, downstream flat index, topological order, contributing area) of a checked ``hf``."""
    from .kernels import hydro

    valid = np.ascontiguousarray(hf.valid)
    filled, codes = _directions(hf)
    dx, dy = hf.cell_size
    down = hydro.downstream(codes)
    order = hydro.topological_order(down, valid.ravel())
    acc = hydro.accumulate(down, order, float(dx * dy)).reshape(hf.shape)
    acc[~valid] = np.nan
    return filled, codes, down, order, acc


def _min_area(hf: Heightfield, min_area) -> float:
    if min_area is None:
        dx, dy = hf.cell_size
        return DEFAULT_STREAM_CELLS * dx * dy
    return _checks.number("min_area", min_area, minimum=0, exclusive_min=True)


def fill_depressions(hf: Heightfield) -> Heightfield:
    """The heightfield with every depression filled, so that every cell drains to an outlet.

    Priority-Flood+epsilon of Barnes, Lehman & Mulla (2014), "Priority-Flood:
    An optimal depression-filling and watershed-labeling algorithm",
    Computers & Geosciences 62, 117-127 (their Algorithm 3, with the pit
    queue).  The flood starts from the outlets: the valid cells on the
    grid's edge and those with a nodata cell among their 8 neighbours, which
    keep their heights.  Cells are taken lowest first (ties: the first one
    reached first, so the result is deterministic); a cell no higher than the
    cell it is reached from is raised to the next float64 above that one.
    So every filled cell ends strictly higher than a neighbour on its way to
    an outlet (flats get a gradient of a few ulps and drain too), no cell is
    lowered, and a pit rises to its spill height (plus those ulps).

    Parameters
    ----------
    hf : Heightfield
        The surface; nodata cells stay nodata.

    Returns
    -------
    Heightfield
        Same grid, transform, CRS and nodata; float64 heights.

    Raises
    ------
    InvalidInputError
        When ``hf`` is not a :class:`~tinsmith.Heightfield`.
    NoDataError
        When it has no valid cell.

    Examples
    --------
    >>> import numpy as np
    >>> import tinsmith
    >>> z = np.full((5, 5), 10.0)
    >>> z[2, 2] = 3.0                       # a pit in a flat plateau
    >>> z[0, 2] = 8.0                       # its spill point on the edge
    >>> filled = tinsmith.fill_depressions(tinsmith.Heightfield(z, cell_size=1.0))
    >>> bool(np.all(filled.z >= z)), round(float(filled.z[2, 2]), 6)
    (True, 10.0)
    """
    hf = _check(hf)
    filled = _filled(hf)
    return Heightfield(filled, transform=hf.transform, crs=hf.crs, nodata_mask=hf.nodata_mask)


def flow_directions(hf: Heightfield) -> np.ndarray:
    """D8 flow directions on the depression-filled surface.

    Each valid cell drains to its steepest strictly lower valid neighbour of
    :func:`fill_depressions`' surface: the drop divided by the distance
    between the cell centres (the cell width or height, ``hypot`` of both on
    a diagonal).  Of equal slopes the lowest code wins.  Filling leaves every
    cell but the outlets a strictly lower neighbour, so flats drain and
    every path ends at an outlet.

    Parameters
    ----------
    hf : Heightfield

    Returns
    -------
    (H, W) int8 array
        0 east, then clockwise: 1 south-east, 2 south, 3 south-west, 4 west,
        5 north-west, 6 north, 7 north-east (row 0 is north, as in the
        grid); -1 at outlets (cells on the edge or next to nodata with no
        lower neighbour) and nodata cells.  :data:`tinsmith.kernels.hydro.DR`
        and ``DC`` hold the row and column steps.

    Raises
    ------
    InvalidInputError, NoDataError
        As :func:`fill_depressions`.

    Examples
    --------
    >>> import numpy as np
    >>> import tinsmith
    >>> z = np.add.outer(np.arange(4.0, 0.0, -1.0), np.zeros(3))  # falls to the south (last row)
    >>> tinsmith.flow_directions(tinsmith.Heightfield(z, cell_size=1.0))
    array([[ 2,  2,  2],
           [ 2,  2,  2],
           [ 2,  2,  2],
           [-1, -1, -1]], dtype=int8)
    """
    return _directions(_check(hf))[1]


def flow_accumulation(hf: Heightfield) -> np.ndarray:
    """Contributing area of every cell along :func:`flow_directions`, in map units squared.

    The number of cells that drain through a cell (itself included) times
    the cell area, summed in a topological order of the flow graph (every
    cell before the one it drains to): O(n), no recursion.  The outlets'
    values sum to the valid area.

    Parameters
    ----------
    hf : Heightfield

    Returns
    -------
    (H, W) float64 array
        NaN at nodata.

    Raises
    ------
    InvalidInputError, NoDataError
        As :func:`fill_depressions`.

    Examples
    --------
    >>> import numpy as np
    >>> import tinsmith
    >>> z = np.add.outer(np.arange(4.0, 0.0, -1.0), np.zeros(3))  # falls to the south
    >>> tinsmith.flow_accumulation(tinsmith.Heightfield(z, cell_size=10.0))[:, 1]
    array([100., 200., 300., 400.])
    """
    hf = _check(hf)
    return _flow(hf)[4]


def stream_lines(hf: Heightfield, min_area: float | None = None) -> list[np.ndarray]:
    """The stream network: polylines through the cells whose contributing area exceeds ``min_area``.

    A polyline runs from a channel head or a confluence downstream to the
    next confluence (which it includes, so the pieces join) or to an outlet,
    through the cell centres.  Polylines are ordered by the row-major index
    of their first cell; a stream of a single cell is left out.

    Parameters
    ----------
    hf : Heightfield
    min_area : float, optional
        Contributing area, in map units squared, a cell must exceed to be a
        stream.  Default: :data:`DEFAULT_STREAM_CELLS` (1000) cells, which
        gives the main valleys of a 30 m DEM (0.9 km2) and the drains and
        ditches of a 0.5 m city DTM (250 m2).

    Returns
    -------
    list of (k, 3) float64 arrays
        World ``x, y`` of the cell centres and the cells' heights (of ``hf``,
        not filled), upstream first.

    Raises
    ------
    InvalidInputError
        When ``hf`` is not a :class:`~tinsmith.Heightfield` or ``min_area``
        is not a finite number > 0.
    NoDataError
        When ``hf`` has no valid cell.

    Examples
    --------
    >>> import numpy as np
    >>> import tinsmith
    >>> rows, cols = np.mgrid[0:6, 0:5]
    >>> z = np.abs(cols - 2) + 0.1 * (5 - rows)        # a V valley along column 2, falling south
    >>> hf = tinsmith.Heightfield(z, cell_size=1.0)
    >>> lines = tinsmith.stream_lines(hf, min_area=12.0)  # the axis cells of rows 2..5 (15..30 cells upstream)
    >>> len(lines), lines[0][:, 0].tolist(), lines[0][:, 1].tolist()
    (1, [2.5, 2.5, 2.5, 2.5], [3.5, 2.5, 1.5, 0.5])
    """
    hf = _check(hf)
    threshold = _min_area(hf, min_area)
    from .kernels import hydro

    _, _, down, _, acc = _flow(hf)
    stream = np.nan_to_num(acc, nan=0.0).ravel() > threshold
    cells, offsets = hydro.trace_streams(down, stream)
    rows, cols = np.divmod(cells, hf.shape[1])
    x, y = hf.pixel_to_world(rows.astype(np.float64), cols.astype(np.float64))
    z = np.asarray(hf.z, dtype=np.float64).ravel()[cells]
    points = np.column_stack([x, y, z])
    return [points[a:b] for a, b in zip(offsets[:-1], offsets[1:], strict=True)]


def height_above_drainage(hf: Heightfield, min_area: float | None = None) -> np.ndarray:
    """HAND: each cell's height above the stream cell it drains to (Rennó et al. 2008).

    Rennó, Nobre, Cuartas, Soares, Hodnett, Tomasella & Waterloo (2008),
    "HAND, a new terrain descriptor using SRTM-DEM", Remote Sensing of
    Environment 112, 3469-3481.  Heights are those of
    :func:`fill_depressions`' surface, so HAND is 0 on the streams of
    :func:`stream_lines` (same ``min_area``) and >= 0 everywhere; the
    depth of a filled pit is ``fill_depressions(hf).z - hf.z``.

    Parameters
    ----------
    hf : Heightfield
    min_area : float, optional
        As :func:`stream_lines`.

    Returns
    -------
    (H, W) float64 array
        NaN at nodata and at cells whose flow reaches an outlet without
        passing a stream.

    Raises
    ------
    InvalidInputError, NoDataError
        As :func:`stream_lines`.

    Examples
    --------
    >>> import numpy as np
    >>> import tinsmith
    >>> rows, cols = np.mgrid[0:6, 0:5]
    >>> z = np.abs(cols - 2) + 0.1 * (5 - rows)        # a V valley along column 2
    >>> hand = tinsmith.height_above_drainage(tinsmith.Heightfield(z, cell_size=1.0), min_area=4.5)
    >>> np.round(hand[3], 3)
    array([2., 1., 0., 1., 2.])
    """
    hf = _check(hf)
    threshold = _min_area(hf, min_area)
    from .kernels import hydro

    filled, _, down, order, acc = _flow(hf)
    stream = np.nan_to_num(acc, nan=0.0).ravel() > threshold
    flat = filled.ravel()
    base = hydro.drainage_height(flat, down, order, stream)
    return (flat - base).reshape(hf.shape)


def normal_depth(hf: Heightfield, rain: float = DEFAULT_RAIN, manning: float = DEFAULT_MANNING
                 ) -> tuple[np.ndarray, np.ndarray]:
    """The depth and speed of steady flow under uniform rain: (depth, velocity), each (H, W), m and m/s.

    Every cell carries the rain on its contributing area (:func:`flow_accumulation`), ``Q = rain * A``, over a
    width ``W = max(cell width, WIDTH_COEFF * sqrt(Q))`` (Leopold & Maddock 1953: channels widen as the square
    root of their discharge), at the depth where Manning's formula for a wide channel carries it,
    ``q = Q / W = h^(5/3) sqrt(S) / n``, so ``h = (n q / sqrt(S))^(3/5)`` and ``u = q / h``, with ``S`` the
    slope of the depression-filled surface (at least :data:`MIN_SLOPE`).  An estimate of where the water
    runs deep and fast once an event has filled the network (the depressions already full), in the units of
    a metric CRS: what a shallow-water solver's time step depends on (the wave speed ``u + sqrt(g h)``).

    Parameters
    ----------
    hf : Heightfield
        Heights in metres on a grid in metres.
    rain : float
        Rain rate, m/s (default 100 mm/h).
    manning : float
        Manning's n, s/m^(1/3) (default 0.03).

    Returns
    -------
    (depth, velocity) : two (H, W) float64 arrays
        NaN at nodata.

    Raises
    ------
    InvalidInputError, NoDataError
        As :func:`fill_depressions`, or ``rain`` / ``manning`` not a finite number > 0.

    Examples
    --------
    >>> import numpy as np, tinsmith
    >>> z = np.add.outer(np.zeros(5), np.arange(5.0, 0.0, -1.0))  # a plane falling 1 m per 10 m cell to the east
    >>> depth, speed = tinsmith.normal_depth(tinsmith.Heightfield(z, cell_size=10.0), rain=0.001, manning=0.03)
    >>> q = 0.001 * 10.0 * 10.0 * np.arange(1, 6) / 10.0  # discharge per metre of width, growing downstream
    >>> bool(np.allclose(depth[2], (0.03 * q / np.sqrt(0.1)) ** 0.6))
    True
    """
    hf = _check(hf)
    rain = _checks.number("rain", rain, minimum=0, exclusive_min=True)
    manning = _checks.number("manning", manning, minimum=0, exclusive_min=True)
    filled, _, _, _, acc = _flow(hf)
    dx, dy = (abs(float(v)) for v in hf.cell_size)
    gy, gx = np.gradient(np.where(hf.valid, filled, np.nan), dy, dx)
    slope = np.hypot(gx, gy)
    slope = np.where(np.isfinite(slope), np.maximum(slope, MIN_SLOPE), MIN_SLOPE)
    discharge = rain * acc
    width = np.maximum(min(dx, dy), WIDTH_COEFF * np.sqrt(discharge))
    q = discharge / width
    depth = (manning * q / np.sqrt(slope)) ** 0.6
    with np.errstate(invalid="ignore", divide="ignore"):
        speed = np.where(depth > 0, q / depth, 0.0)
    depth[~hf.valid] = np.nan
    speed[~hf.valid] = np.nan
    return depth, speed
