"""The named lines and areas of a mesh that solvers hang their boundary conditions and materials on.

A 2-D solver (SMS/TUFLOW/BASEMENT through 2DM, TELEMAC or OpenFOAM through
Gmsh) needs more than triangles: the loops of the outline (an inflow here,
a wall there), the breaklines (a dyke crest, a channel bank) and the areas
with their own roughness.  :func:`named_boundaries` recovers the lines from
any :class:`~tinsmith.core.TerrainMesh`; :func:`triangle_regions` reads the
areas a method recorded.  The 2DM and Gmsh writers use both.
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from ..core import TerrainMesh
from ..triangulation.edges import border_edges, edge_twins


def named_boundaries(mesh: TerrainMesh) -> dict[str, list[np.ndarray]]:
    """``{"outline": loops, "breaklines": lines}`` as vertex-index polylines.

    ``outline``: every closed loop of the mesh border (first vertex repeated
    at the end), counter-clockwise round the data and clockwise round a hole
    (seen from +z, for a counter-clockwise mesh); the loop enclosing the
    largest area first.  ``breaklines``: the constrained edges the method
    recorded (``mesh.constrained_edges``) that are not on the border nor
    between two regions (:func:`triangle_regions`), chained into polylines that end where three or more meet (a closed
    breakline repeats its first vertex).  Recorded edges that are not edges
    of the mesh (a mesh edited after it was made) are left out.
    """
    n = mesh.n_vertices
    loops = _loops(border_edges(mesh.triangles, n)) if mesh.n_triangles else []
    loops.sort(key=lambda lp: -abs(loop_area(mesh.vertices, lp)))
    return {"outline": loops, "breaklines": _chains(_interior_constraints(mesh))}


def triangle_regions(mesh: TerrainMesh) -> tuple[np.ndarray, list[str]]:
    """(region of every triangle, names): region 0 is the mesh outside every recorded area ("terrain").

    A method that meshed areas of their own (``quality``'s ``regions``)
    records ``triangle_attributes["region"]`` (1, 2, ... per triangle) and
    their names in ``labels["region"]``; any other mesh is one region.
    """
    region = mesh.triangle_attributes.get("region")
    labels = mesh.labels.get("region", {})
    if region is None or len(region) != mesh.n_triangles:
        return np.zeros(mesh.n_triangles, np.int64), ["terrain"]
    region = np.asarray(region, np.int64)
    top = int(region.max()) if len(region) else 0
    names = ["terrain"] + [labels.get(k, f"region_{k}") for k in range(1, top + 1)]
    return region, names


def loop_area(vertices: np.ndarray, loop: np.ndarray) -> float:
    """Signed plan-view area of a closed loop (first vertex repeated): positive counter-clockwise seen from +z."""
    x, y = vertices[loop, 0], vertices[loop, 1]
    with np.errstate(all="ignore"):  # coordinates near the float limits: no order among such loops
        x, y = x - x.mean(), y - y.mean()
        area = 0.5 * float(np.dot(x[:-1], y[1:]) - np.dot(x[1:], y[:-1]))
    return area if np.isfinite(area) else 0.0


#: Node strings whose name starts with one of these (any case) are open (liquid) boundaries in the solver formats.
OPEN_PREFIXES = ("inflow", "outflow", "open")


def open_strings(mesh: TerrainMesh, loops: list[np.ndarray]) -> dict[str, np.ndarray]:
    """The node strings of ``mesh`` that are open boundaries (named ``inflow*``, ``outflow*``, ``open*``), in their
    order, each checked to run along the border (``loops``: :func:`named_boundaries`' outline).

    Raises
    ------
    InvalidInputError
        An open node string with an edge that is not on the border, named with the edge.
    """
    from ..errors import InvalidInputError

    border = {(a, b) for lp in loops for a, b in zip(lp[:-1].tolist(), lp[1:].tolist(), strict=True)}
    out = {}
    for name, ids in mesh.node_strings.items():
        if not name.lower().startswith(OPEN_PREFIXES):
            continue
        ids = np.asarray(ids, np.int64)
        for a, b in zip(ids[:-1].tolist(), ids[1:].tolist(), strict=True):
            if (a, b) not in border and (b, a) not in border:
                raise InvalidInputError(
                    f"node string {name!r} is an open boundary but its edge {a}-{b} is not on the border of the mesh"
                )
        out[name] = ids
    return out


def _interior_constraints(mesh: TerrainMesh) -> np.ndarray:
    """The recorded constrained edges inside the mesh between triangles of one region, (E, 2) sorted pairs
    (an edge between two regions is the regions' boundary: their materials say it)."""
    cons = mesh.constrained_edges
    if len(cons) == 0:
        return np.empty((0, 2), np.int64)
    base = mesh.n_vertices + 1
    cons = np.sort(cons, axis=1)
    cons = cons[(cons < mesh.n_vertices).all(axis=1)]  # the vertices may have been replaced since
    first, second, key = edge_twins(mesh.triangles, mesh.n_vertices)
    region, _ = triangle_regions(mesh)
    keep = np.isin(key, cons[:, 0] * base + cons[:, 1]) & (region[first // 3] == region[second // 3])
    return np.column_stack([key[keep] // base, key[keep] % base])


def _loops(directed: np.ndarray) -> list[np.ndarray]:
    """Closed loops of directed border edges (a vertex where two loops touch is left by its unused edge)."""
    out = defaultdict(list)
    for a, b in sorted(map(tuple, directed.tolist()), reverse=True):
        out[a].append(b)  # popped from the end: the smallest target first
    loops = []
    for start in sorted(out):
        while out[start]:
            loop = [start]
            v = out[start].pop()
            while v != start:
                loop.append(v)
                if not out[v]:  # pragma: no cover - a border always closes (every vertex: as many in as out)
                    break
                v = out[v].pop()
            loops.append(np.asarray(loop + [start], np.int64))
    return loops


def _chains(edges: np.ndarray) -> list[np.ndarray]:
    """Polylines of undirected edges, broken where a vertex has other than two of them; rings closed."""
    if len(edges) == 0:
        return []
    nbr = defaultdict(list)
    for a, b in edges.tolist():
        nbr[a].append(b)
        nbr[b].append(a)
    for v in nbr:
        nbr[v].sort()
    used = set()

    def walk(a, b):
        line = [a, b]
        used.add((min(a, b), max(a, b)))
        while len(nbr[b]) == 2:
            c = nbr[b][0] if nbr[b][1] == line[-2] else nbr[b][1]
            if (min(b, c), max(b, c)) in used:
                break
            used.add((min(b, c), max(b, c)))
            line.append(c)
            b = c
        return np.asarray(line, np.int64)

    chains = []
    for v in sorted(nbr):
        if len(nbr[v]) != 2:
            chains += [walk(v, u) for u in nbr[v] if (min(v, u), max(v, u)) not in used]
    for v in sorted(nbr):  # what is left are rings
        for u in nbr[v]:
            if (min(v, u), max(v, u)) not in used:
                chains.append(walk(v, u))
    return chains


# -- the outline cut into the segments a flood solver takes -------------------------------------------------------

#: The default opening round a stream's crossing, in lengths of the crossed outline edge (see :func:`segment_outline`).
OPENING_EDGES = 3.0


def segment_outline(mesh: TerrainMesh, streams=None, lines=None, *, width: float | None = None,
                    tolerance: float | None = None, order: str = "heights") -> TerrainMesh:
    """A copy of ``mesh`` whose ``node_strings`` cut its outline into the named segments of a flood solver.

    Every border edge goes to exactly one segment, a run of consecutive
    vertices of one loop of the outline (:func:`named_boundaries`), written
    in the loop's direction (a closed loop repeats its first vertex):

    - ``inflow_N`` / ``outflow_N``: where a stream of ``streams`` crosses an
      outer loop, the border edges that overlap an opening of ``width``
      centred on the crossing, measured along the outline (default
      :data:`OPENING_EDGES` = 3 times the length of the crossed edge: that
      edge and about one on either side).  An edge two openings share goes
      to the nearest crossing; touching openings of one kind make one
      segment.  ``inflow`` where the stream enters the domain, ``outflow``
      where it leaves it;
    - ``wall_N``: the rest of the outer loops, one per run;
    - ``hole_N``: the rest of each loop round a hole in the data;
    - the names of ``lines``, ``{name: polyline}``, over all of these: the
      border edges whose ends and midpoint all lie within ``tolerance`` of
      the line (default: half the median length of a border edge) take its
      name (a later line over an earlier one; a name whose edges make several runs is numbered ``name_1``, ``name_2``, ...).

    Direction of a stream, ``order``: ``"heights"`` (default) reads a stream
    downstream in the order of its vertices unless the mesh says otherwise:
    the heights of the mesh at the stream's vertices inside the domain and at
    its crossings, against the distance along the stream, rise (least-squares
    slope > 0), and the stream is then read the other way.  ``"vertices"``
    trusts the order of the vertices (downstream) whatever the heights.

    ``streams`` and the polylines of ``lines``: ``(K, 2)`` or ``(K, 3)``
    arrays in the mesh's coordinates (z is not used), shapely lines (a
    MultiLineString in ``lines``: several lines under one name), or for
    ``streams`` a vector file, GeoDataFrame or GeoSeries of lines too
    (reprojected to the mesh's CRS when both have one, with a
    :class:`~tinsmith.errors.TinsmithNote`).  A stream that never crosses
    the outline adds nothing.  Node strings of ``mesh`` that run along the
    border are replaced; those inside it (breaklines) are kept.  The names
    come in a fixed order: outer loops first (the largest first), then the
    holes, each from its westernmost (then southernmost) vertex on round
    the loop (a run through that vertex first).

    The writers that honour node strings take the segments: 2DM node strings
    and Gmsh physical groups, ADCIRC's open (inflow/outflow) and land
    segments, :meth:`TerrainMesh.to_anuga`'s boundary tags.

    Raises
    ------
    InvalidInputError
        A stream or line that is not a polyline of at least two points, or
        holds a non-finite coordinate.
    InvalidOptionError
        ``width`` or ``tolerance`` not a finite number > 0; ``order`` not
        one of ``"heights"``, ``"vertices"``.

    Examples
    --------
    >>> import numpy as np
    >>> import tinsmith
    >>> x, y = np.meshgrid(np.arange(5.0), np.arange(5.0))
    >>> hf = tinsmith.Heightfield(10 - x, cell_size=1.0)  # a plane falling to the east
    >>> mesh = tinsmith.simplify(hf, method="grid")
    >>> river = np.array([[-1.0, 2.0], [5.0, 2.0]])       # drawn west to east, across the square
    >>> segments = tinsmith.segment_outline(mesh, streams=[river])
    >>> sorted(segments.node_strings)
    ['inflow_1', 'outflow_1', 'wall_1', 'wall_2']
    >>> segments.vertices[segments.node_strings["inflow_1"], 0].tolist()  # on the high west side
    [0.5, 0.5, 0.5, 0.5]
    """
    from ..errors import InvalidOptionError

    if order not in ("heights", "vertices"):
        raise InvalidOptionError(f"order is 'heights' or 'vertices', got {order!r}")
    width = _positive("width", width)
    tolerance = _positive("tolerance", tolerance)
    xy = np.asarray(mesh.vertices, np.float64)[:, :2]
    loops = named_boundaries(mesh)["outline"]
    if not loops:
        return mesh.copy()
    area = [loop_area(mesh.vertices, lp) for lp in loops]
    sense = 1.0 if area[0] >= 0 else -1.0  # the largest loop goes round the data: +1 when the domain is on the left
    outer = [a * sense >= 0 for a in area]
    loops = [_start_west(xy, lp) for lp in loops]
    order_loops = sorted(range(len(loops)), key=lambda k: not outer[k])  # outer loops first, then the holes
    loops, outer = [loops[k] for k in order_loops], [outer[k] for k in order_loops]
    border_lengths = np.concatenate([np.hypot(*(xy[lp[1:]] - xy[lp[:-1]]).T) for lp in loops])
    if tolerance is None:
        tolerance = 0.5 * float(np.median(border_lengths))
    # labels per edge: -1 wall/hole, 0 inflow, 1 outflow, 2 + k the k-th user line
    labels = [np.full(len(lp) - 1, -1, np.int64) for lp in loops]
    polylines = _stream_lines(streams, "streams", mesh)
    crossings = _crossings(mesh, xy, loops, outer, sense, polylines, order)
    _open(xy, loops, labels, crossings, width)
    names = _user_lines(lines, xy, loops, labels, tolerance)
    strings, counters = {}, {}
    for lp, lab, out in zip(loops, labels, outer, strict=True):
        for ids, value in _runs_of(lp, lab):
            kind = ("wall" if out else "hole") if value < 0 else ("inflow", "outflow")[value] if value < 2 \
                else names[value - 2]
            counters[kind] = counters.get(kind, 0) + 1
            strings[(kind, counters[kind])] = ids
    result = {}
    for (kind, k), ids in strings.items():
        user = kind not in ("wall", "hole", "inflow", "outflow")
        result[kind if user and counters[kind] == 1 else f"{kind}_{k}"] = ids
    new = mesh.copy()
    along = {(min(a, b), max(a, b)) for lp in loops for a, b in zip(lp[:-1].tolist(), lp[1:].tolist(), strict=True)}
    kept = {name: ids for name, ids in new.node_strings.items() if name not in result and not (
        len(ids) >= 2 and all((min(a, b), max(a, b)) in along for a, b in zip(ids[:-1].tolist(), ids[1:].tolist(),
                                                                                 strict=True)))}
    new.node_strings = kept | result
    return new


def _positive(name: str, value) -> float | None:
    from ..errors import InvalidOptionError

    if value is None:
        return None
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = float("nan")
    if isinstance(value, bool) or not (np.isfinite(v) and v > 0):
        raise InvalidOptionError(f"{name} is a length in the mesh's units, one finite number > 0; got {value!r}")
    return v


def _start_west(xy: np.ndarray, loop: np.ndarray) -> np.ndarray:
    """The loop started at its westernmost vertex (the southernmost of those)."""
    ring = loop[:-1]
    k = int(np.lexsort((xy[ring, 1], xy[ring, 0]))[0])
    ring = np.roll(ring, -k)
    return np.append(ring, ring[0])


def _polyline(item, name: str) -> np.ndarray:
    """One polyline as (K, 2) float64, or a one-line error naming it."""
    from ..errors import InvalidInputError

    if hasattr(item, "geom_type"):  # a shapely line
        import shapely

        item = shapely.get_coordinates(item)
    try:
        line = np.asarray(item, dtype=np.float64)
    except (TypeError, ValueError):
        line = np.empty((0,))
    if line.ndim != 2 or line.shape[1] not in (2, 3) or len(line) < 2:
        raise InvalidInputError(f"{name} must be a (K, 2) or (K, 3) polyline of at least two points, got "
                                f"{type(item).__name__} of shape {getattr(line, 'shape', '?')}")
    if not np.isfinite(line[:, :2]).all():
        raise InvalidInputError(f"{name} holds a non-finite coordinate (NaN or infinity)")
    return line[:, :2]


def _stream_lines(value, name: str, mesh: TerrainMesh) -> list[np.ndarray]:
    """The polylines of ``streams``: arrays and shapely lines as they are, vector data through the geometry
    path (read, reprojected to the mesh's CRS)."""
    import os

    if value is None:
        return []
    if isinstance(value, np.ndarray) and value.ndim == 2:
        value = [value]
    if isinstance(value, (list, tuple)) or (isinstance(value, np.ndarray) and value.dtype != object):
        return [_polyline(item, f"{name}[{i}]") for i, item in enumerate(value)]
    if not (isinstance(value, (str, os.PathLike)) or hasattr(value, "geometry") or hasattr(value, "geom_type")
            or type(value).__name__ == "GeoSeries"):
        from ..errors import InvalidInputError

        raise InvalidInputError(f"{name} must be a vector file, a GeoDataFrame, shapely lines or a list of (K, 2) "
                                f"arrays, got {type(value).__name__}")
    import shapely

    from .geometry import _reproject, load, say

    out, notes = [], []
    for feats in load(value, name, "lines"):
        feats, note = _reproject(shapely, feats, mesh.crs)
        if note:
            notes.append(note)
        geoms = feats.geometries[~shapely.is_missing(feats.geometries)]
        for part in shapely.get_parts(geoms):
            if shapely.get_type_id(part) in (1, 2) and np.isfinite(shapely.get_coordinates(part)).all():
                out.append(shapely.get_coordinates(part))
    say(notes, None)
    return [line for line in out if len(line) >= 2]


def _crossings(mesh, xy, loops, outer, sense, polylines, order) -> list[tuple[int, float, int]]:
    """(loop, position along the loop in edges, 0 inflow / 1 outflow) of every crossing of an outer loop."""
    from ..kernels.raster import sample_triangles

    edges = [(k, i) for k, lp in enumerate(loops) if outer[k] for i in range(len(lp) - 1)]
    if not edges or not polylines:
        return []
    k_of = np.array([k for k, _ in edges])
    i_of = np.array([i for _, i in edges])
    a_id = np.array([loops[k][i] for k, i in edges])
    b_id = np.array([loops[k][i + 1] for k, i in edges])
    a, b = xy[a_id], xy[b_id]
    s = b - a
    z = np.asarray(mesh.vertices, np.float64)[:, 2]
    v = np.asarray(mesh.vertices, np.float64)
    found = []
    for line in polylines:
        p, r = line[:-1], line[1:] - line[:-1]
        hits = []  # (position along the stream, edge, u, entering)
        for lo in range(0, len(p), 256):
            pp, rr = p[lo:lo + 256, None, :], r[lo:lo + 256, None, :]
            d = a[None] - pp
            denom = rr[..., 0] * s[None, :, 1] - rr[..., 1] * s[None, :, 0]
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (d[..., 0] * s[None, :, 1] - d[..., 1] * s[None, :, 0]) / denom
                u = (d[..., 0] * rr[..., 1] - d[..., 1] * rr[..., 0]) / denom
            ok = (denom != 0) & (t >= 0) & (t < 1) & (u >= 0) & (u < 1)
            for j, e in zip(*np.nonzero(ok), strict=True):
                hits.append((lo + j + t[j, e], int(e), float(u[j, e]), denom[j, e] * sense < 0))
        if not hits:
            continue
        hits.sort()
        flip = False
        if order == "heights":
            seg = np.hypot(r[:, 0], r[:, 1])
            along = np.concatenate([[0.0], np.cumsum(seg)])
            inside = sample_triangles(v[:, 0].copy(), v[:, 1].copy(), v[:, 2].copy(), mesh.triangles,
                                      line[:, 0].copy(), line[:, 1].copy())
            dist = [along[int(q)] + (q - int(q)) * seg[int(q)] for q, *_ in hits]
            height = [z[a_id[e]] + uu * (z[b_id[e]] - z[a_id[e]]) for _, e, uu, _ in hits]
            keep = np.isfinite(inside)
            dist = np.concatenate([along[keep], dist])
            height = np.concatenate([inside[keep], height])
            if len(dist) >= 2 and np.ptp(dist) > 0:
                flip = bool(np.polyfit(dist, height, 1)[0] > 0)
        for _, e, uu, entering in hits:
            found.append((int(k_of[e]), int(i_of[e]) + uu, 0 if entering != flip else 1))
    return found


def _open(xy, loops, labels, crossings, width) -> None:
    """Label the edges of the opening round every crossing (the nearest crossing where openings overlap)."""
    best: dict[tuple[int, int], tuple[float, float, int]] = {}
    for n, (k, pos, _) in enumerate(crossings):
        lp = loops[k]
        length = np.hypot(*(xy[lp[1:]] - xy[lp[:-1]]).T)
        start = np.concatenate([[0.0], np.cumsum(length)])
        total = start[-1]
        i = int(pos)
        at = start[i] + (pos - i) * length[i]
        half = 0.5 * (OPENING_EDGES * length[i] if width is None else width)

        def circ(d, total=total):  # signed distance along the loop, the short way round
            return (d + 0.5 * total) % total - 0.5 * total

        d0, d1 = circ(start[:-1] - at), circ(start[1:] - at)
        dist = np.where((d0 <= 0) & (d1 >= 0), 0.0, np.minimum(np.abs(d0), np.abs(d1)))
        dist[i] = 0.0
        mid = np.abs(circ(start[:-1] + 0.5 * length - at))
        for j in np.flatnonzero(dist < half).tolist() + [i]:
            score = (float(dist[j]), float(mid[j]), n)
            if (k, j) not in best or score < best[(k, j)]:
                best[(k, j)] = score
    for (k, j), (*_, n) in best.items():
        labels[k][j] = crossings[n][2]


def _user_lines(lines, xy, loops, labels, tolerance) -> list[str]:
    """Label the border edges along each of ``lines`` (the later line over the earlier); their names."""
    from ..errors import InvalidInputError

    if lines is None:
        return []
    if not hasattr(lines, "items"):
        raise InvalidInputError(f"lines is a mapping {{name: polyline}}, got {type(lines).__name__}")
    names = []
    for name, item in lines.items():
        if not isinstance(name, str) or not name.strip():
            raise InvalidInputError(f"lines are named by non-empty strings, got {name!r}")
        parts = [item]
        if getattr(item, "geom_type", None) == "MultiLineString":  # several lines under one name
            import shapely

            parts = list(shapely.get_parts(item))
        code = 2 + len(names)
        names.append(name)
        for part in parts:
            line = _polyline(part, f"lines[{name!r}]")
            p, r = line[:-1], line[1:] - line[:-1]
            rr = np.maximum((r * r).sum(axis=1), 1e-300)
            for lp, lab in zip(loops, labels, strict=True):
                near = np.ones(len(lp) - 1, bool)
                for q in (xy[lp[:-1]], 0.5 * (xy[lp[:-1]] + xy[lp[1:]]), xy[lp[1:]]):
                    t = np.clip(((q[:, None, :] - p[None]) * r[None]).sum(axis=2) / rr[None], 0.0, 1.0)
                    gap = np.hypot(*(q[:, None, :] - (p[None] + t[..., None] * r[None])).transpose(2, 0, 1))
                    near &= gap.min(axis=1) <= tolerance
                lab[near] = code
    return names


def _runs_of(loop: np.ndarray, label: np.ndarray) -> list[tuple[np.ndarray, int]]:
    """The loop cut into runs of edges of one label, from the run holding the loop's first vertex on."""
    n = len(label)
    starts = [i for i in range(n) if label[i] != label[i - 1]]
    if not starts:
        return [(loop.astype(np.int64), int(label[0]))]
    cuts = starts + [n] if starts[0] == 0 else [starts[-1] - n] + starts  # a run wrapping round the start first
    ring = loop[:-1]
    return [(ring[np.arange(s, e + 1) % n].astype(np.int64), int(label[s % n]))
            for s, e in zip(cuts[:-1], cuts[1:], strict=True)]
