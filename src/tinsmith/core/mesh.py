"""The :class:`TerrainMesh`: a triangulated irregular network in world coordinates."""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from .. import _hooks
from ..errors import InvalidInputError, InvalidMeshError
from .attributes import Attributes, Info, check_edges, check_labels, check_node_strings, check_tables

__all__ = ["TerrainMesh"]


class TerrainMesh:
    """Triangles over world-coordinate vertices, counter-clockwise seen from +z.

    Plain arrays are the mesh; everything else (edges, areas, bounds) is derived
    on demand.  Beside them a mesh carries typed data that writers and
    metrics read:

    - ``vertex_attributes`` and ``triangle_attributes``: named arrays with one
      row per vertex / per triangle (:class:`~tinsmith.core.attributes.Attributes`;
      the length is checked when an array is set).  The names tinsmith uses:
      ``region`` (per triangle: the area a ``quality`` run meshed on its own,
      1, 2, ...; 0 outside every area), ``kind`` (0 ground, 1 roof, 2 wall,
      of an urban mesh), ``patch`` (0 ground, 1 buildings, 2 walls, 3 sides,
      4 bottom, of a city mesh), ``building`` (the building of a triangle,
      -1 for none), ``face`` (the region of the urban block model a triangle
      belongs to) and, per vertex, ``site`` (``"free"``, ``"boundary"`` or
      ``"fixed"``: the kind of a CVT site).
    - ``constrained_edges``: (E, 2) int64 vertex pairs the method kept as
      edges (breaklines, the outline of the data); empty when none.
    - ``node_strings``: ``{name: vertex indices in order}``, the named
      polylines a file held (a 2DM's node strings).
    - ``labels``: ``{attribute: {code: name}}``, the names of the codes of a
      coded attribute (``labels["region"]``, ``labels["patch"]``).
    - ``tables``: ``{attribute: {column: array over the codes 0, 1, ...}}``,
      values per code of a coded attribute (``tables["building"]["height"]``,
      the measured height of each building of a city model).

    ``info`` carries the diagnostics of the run that made the mesh:
    ``method``, ``options``, ``timings`` (stage -> seconds), ``error`` (the
    achieved vertical error, when measured) and the method's own statistics.
    The per-element keys it held in 0.1 (``info["triangle_region"]``, ...)
    are still answered, from the fields above, with a ``DeprecationWarning``.

    Parameters
    ----------
    vertices : (N, 3) array_like of float
        x, y, z in the CRS of the source data.
    triangles : (M, 3) array_like of int
        Vertex indices of each triangle, held as int64, or as int32 when
        given int32 (half the memory: what :func:`tinsmith.tin` makes).
    crs : str, optional
        Coordinate reference system as WKT.
    info : dict, optional
        Diagnostics; see above.
    vertex_attributes, triangle_attributes : dict, optional
        ``{name: array}`` with N (M) rows.
    constrained_edges : (E, 2) array_like of int, optional
    node_strings : dict, optional
        ``{name: 1-D array of vertex indices}``.
    labels, tables : dict, optional
        See above.

    Raises
    ------
    InvalidInputError
        For wrong shapes, non-finite coordinates or out-of-range indices.  The
        geometric rules (:meth:`check`) are not enforced here so that any mesh
        read from a file can still be measured; call :meth:`validate` for them.
    InvalidMeshError
        For an attribute whose length is not the vertex or triangle count, or
        edge data indexing a vertex that does not exist.

    Examples
    --------
    >>> import tinsmith
    >>> square = tinsmith.TerrainMesh([[0, 0, 1], [10, 0, 2], [10, 10, 3], [0, 10, 2]],
    ...                               [[0, 1, 2], [0, 2, 3]], crs="EPSG:32610")
    >>> square.n_vertices, square.n_triangles
    (4, 2)
    >>> square.bounds
    (0.0, 0.0, 1.0, 10.0, 10.0, 3.0)
    >>> square.check()  # counter-clockwise, no overlap: no broken rule
    []
    >>> len(square.boundary_edges())
    4
    >>> import numpy as np
    >>> zoned = tinsmith.TerrainMesh(square.vertices, square.triangles,
    ...                              triangle_attributes={"region": np.array([1, 2])},
    ...                              labels={"region": {1: "channel", 2: "meadow"}})
    >>> half = zoned.submesh([1])
    >>> half.n_vertices, half.triangle_attributes["region"].tolist()
    (3, [2])
    """

    def __init__(self, vertices, triangles, *, crs: str | None = None, info: dict | None = None,
                 vertex_attributes: dict | None = None, triangle_attributes: dict | None = None,
                 constrained_edges=None, node_strings: dict | None = None, labels: dict | None = None,
                 tables: dict | None = None):
        v = np.ascontiguousarray(vertices, dtype=np.float64)
        if v.ndim != 2 or v.shape[1] != 3:
            raise InvalidInputError(f"vertices must have shape (N, 3), got {v.shape}")
        if not np.isfinite(v).all():
            raise InvalidInputError("vertices must be finite; found NaN or infinite coordinates")
        t = np.asarray(triangles)
        if t.size == 0:
            t = t.reshape(0, 3)
        if t.ndim != 2 or t.shape[1] != 3:
            raise InvalidInputError(f"triangles must have shape (M, 3), got {t.shape}")
        if not np.issubdtype(t.dtype, np.integer):
            raise InvalidInputError(f"triangles must hold integer indices, got dtype {t.dtype}")
        t = np.ascontiguousarray(t, dtype=np.int32 if t.dtype == np.int32 else np.int64)
        if t.size and (t.min() < 0 or t.max() >= len(v)):
            raise InvalidInputError(
                f"triangles index vertices 0..{len(v) - 1}, got indices {t.min()}..{t.max()}"
            )
        self.vertices = v
        self.triangles = t
        self.crs = crs or None
        self.vertex_attributes = vertex_attributes
        self.triangle_attributes = triangle_attributes
        self.constrained_edges = constrained_edges
        self.node_strings = node_strings
        self.labels = labels
        self.tables = tables
        self.info = info  # last: keys of 0.1 in it go to the fields above

    # -- the typed data, checked when set ------------------------------------------------------------------------
    @property
    def info(self) -> Info:
        """The run's diagnostics (a dict)."""
        return self._info

    @info.setter
    def info(self, value) -> None:
        self._info = Info(self, value or {})

    @property
    def vertex_attributes(self) -> Attributes:
        """``{name: array}`` with one row per vertex."""
        return self._vertex_attributes

    @vertex_attributes.setter
    def vertex_attributes(self, value) -> None:
        self._vertex_attributes = Attributes(self, "vertex", value)

    @property
    def triangle_attributes(self) -> Attributes:
        """``{name: array}`` with one row per triangle."""
        return self._triangle_attributes

    @triangle_attributes.setter
    def triangle_attributes(self, value) -> None:
        self._triangle_attributes = Attributes(self, "triangle", value)

    @property
    def constrained_edges(self) -> np.ndarray:
        """(E, 2) int64 vertex pairs kept as edges by the method (breaklines, the outline); (0, 2) when none."""
        return self._constrained_edges

    @constrained_edges.setter
    def constrained_edges(self, value) -> None:
        self._constrained_edges = check_edges(value, len(self.vertices))

    @property
    def node_strings(self) -> dict[str, np.ndarray]:
        """``{name: int64 vertex indices in order}``: named polylines (a 2DM file's node strings)."""
        return self._node_strings

    @node_strings.setter
    def node_strings(self, value) -> None:
        self._node_strings = check_node_strings(value, len(self.vertices))

    @property
    def labels(self) -> dict[str, dict[int, str]]:
        """``{attribute: {code: name}}``: the names of the codes of a coded attribute."""
        return self._labels

    @labels.setter
    def labels(self, value) -> None:
        self._labels = check_labels(value)

    @property
    def tables(self) -> dict[str, dict[str, np.ndarray]]:
        """``{attribute: {column: values by code}}``: per-code values of a coded attribute."""
        return self._tables

    @tables.setter
    def tables(self, value) -> None:
        self._tables = check_tables(value)

    def _parts(self) -> dict:
        """The keyword arguments that rebuild this mesh's typed data and metadata (arrays shared, not copied)."""
        return {"crs": self.crs, "info": dict(self.info), "vertex_attributes": dict(self.vertex_attributes),
                "triangle_attributes": dict(self.triangle_attributes), "constrained_edges": self.constrained_edges,
                "node_strings": self.node_strings, "labels": self.labels, "tables": self.tables}

    def copy(self, *, vertices=None) -> TerrainMesh:
        """A copy of the mesh and all it carries (arrays copied; ``info`` copied one level deep).

        ``vertices`` (N, 3) gives the copy other vertex positions (the same
        number of vertices): a mesh fitted or smoothed in place of this one.
        """
        parts = self._parts()
        parts["vertex_attributes"] = self.vertex_attributes.copied()
        parts["triangle_attributes"] = self.triangle_attributes.copied()
        parts["constrained_edges"] = self.constrained_edges.copy()
        parts["node_strings"] = {k: v.copy() for k, v in self.node_strings.items()}
        parts["tables"] = {a: {c: v.copy() for c, v in cols.items()} for a, cols in self.tables.items()}
        new = self.vertices.copy() if vertices is None else vertices
        if len(new) != self.n_vertices:
            raise InvalidMeshError(f"copy(vertices=...) takes {self.n_vertices} vertices, got {len(new)}")
        return TerrainMesh(new, self.triangles.copy(), **parts)

    def submesh(self, triangles) -> TerrainMesh:
        """The mesh of some of the triangles (a boolean mask or indices), without the vertices they leave unused.

        Triangle and vertex attributes keep the rows of what is kept; a
        constrained edge is kept when both its vertices are; a node string
        keeps its kept vertices, in order (a string left with fewer than two
        is dropped).  Labels, tables and ``info`` are kept as they are.
        """
        index = np.asarray(triangles)
        if index.size == 0:
            index = index.astype(np.int64)
        if index.dtype == bool and len(index) != self.n_triangles:
            raise InvalidMeshError(f"submesh takes a mask of {self.n_triangles} triangles, got {len(index)}")
        tri = self.triangles[index].reshape(-1, 3)
        kept = np.unique(tri)
        remap = np.full(self.n_vertices, -1, np.int64)
        remap[kept] = np.arange(len(kept))
        parts = self._parts()
        parts["vertex_attributes"] = self.vertex_attributes.taken(kept)
        parts["triangle_attributes"] = self.triangle_attributes.taken(index)
        cons = self.constrained_edges
        parts["constrained_edges"] = remap[cons[(remap[cons] >= 0).all(axis=1)]]
        strings = {name: remap[ids][remap[ids] >= 0] for name, ids in self.node_strings.items()}
        parts["node_strings"] = {name: ids for name, ids in strings.items() if len(ids) >= 2}
        return TerrainMesh(self.vertices[kept], remap[tri], **parts)

    @property
    def n_vertices(self) -> int:
        return len(self.vertices)

    @property
    def n_triangles(self) -> int:
        return len(self.triangles)

    @property
    def bounds(self) -> tuple[float, float, float, float, float, float]:
        """(xmin, ymin, zmin, xmax, ymax, zmax) of the vertices."""
        lo, hi = self.vertices.min(axis=0), self.vertices.max(axis=0)
        return (*map(float, lo), *map(float, hi))

    def signed_areas_2d(self) -> np.ndarray:
        """(M,) signed area of each triangle's x-y projection (> 0 counter-clockwise)."""
        p = self.vertices[self.triangles]
        # relative to the first corner, so large world offsets do not cancel digits
        u = p[:, 1, :2] - p[:, 0, :2]
        w = p[:, 2, :2] - p[:, 0, :2]
        return 0.5 * (u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0])

    def orientations(self) -> np.ndarray:
        """(M,) exact sign (+1, 0, -1) of each triangle's x-y orientation.

        The floating-point area decides where its error bound allows; the
        few nearly degenerate triangles are decided in exact rational
        arithmetic.
        """
        p = self.vertices[self.triangles][:, :, :2]
        u = p[:, 1] - p[:, 0]
        w = p[:, 2] - p[:, 0]
        a, b = u[:, 0] * w[:, 1], u[:, 1] * w[:, 0]
        sign = np.sign(a - b).astype(np.int64)
        # differences and products each round once: 8 units of roundoff bound it generously
        doubtful = np.flatnonzero(np.abs(a - b) <= 8 * np.finfo(float).eps * (np.abs(a) + np.abs(b)))
        for i in doubtful:
            (x0, y0), (x1, y1), (x2, y2) = (tuple(map(Fraction, q)) for q in p[i])
            exact = (x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0)
            sign[i] = (exact > 0) - (exact < 0)
        return sign

    def edges(self) -> tuple[np.ndarray, np.ndarray]:
        """Undirected edges ``(E, 2)`` (smaller index first) and how many triangles use each."""
        t = self.triangles
        e = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
        e.sort(axis=1)
        return np.unique(e, axis=0, return_counts=True)

    def boundary_edges(self) -> np.ndarray:
        """(B, 2) edges used by exactly one triangle."""
        e, counts = self.edges()
        return e[counts == 1]

    def check(self) -> list[str]:
        """Every rule the mesh breaks, as sentences; empty when the mesh is valid.

        Rules: no degenerate triangle (repeated vertex or zero projected area),
        counter-clockwise seen from above, no duplicate triangle, every edge
        used by at most two triangles; and every attribute still has one row per
        vertex or triangle (the arrays of the mesh may have been replaced).
        """
        problems = self.vertex_attributes.problems() + self.triangle_attributes.problems()
        t = self.triangles
        if len(t) == 0:
            return [*problems, "the mesh has no triangles"]
        repeated = (t[:, 0] == t[:, 1]) | (t[:, 1] == t[:, 2]) | (t[:, 0] == t[:, 2])
        orientation = self.orientations()
        flat = (orientation == 0) & ~repeated
        cw = orientation < 0
        for bad, what in (
            (repeated, "repeat a vertex"),
            (flat, "have zero area seen from above"),
            (cw, "are clockwise seen from above"),
        ):
            if bad.any():
                problems.append(f"{int(bad.sum())} triangles {what} (first: {int(np.flatnonzero(bad)[0])})")
        key = np.sort(t, axis=1)
        n_unique = len(np.unique(key, axis=0))
        if n_unique != len(t):
            problems.append(f"{len(t) - n_unique} triangles duplicate another")
        e, counts = self.edges()
        over = counts > 2
        if over.any():
            a, b = e[over][0]
            problems.append(f"{int(over.sum())} edges are shared by more than two triangles (first: {a}-{b})")
        return problems

    def validate(self) -> TerrainMesh:
        """Raise :class:`InvalidMeshError` listing the broken rules; return self if none."""
        problems = self.check()
        if problems:
            raise InvalidMeshError("invalid mesh: " + "; ".join(problems))
        return self

    # -- the Python GIS stack: tinsmith.io.interop's functions, a layer above (tinsmith._hooks) --------------
    def to_trimesh(self):
        """A ``trimesh.Trimesh`` with the same vertices and faces."""
        return _hooks.call("to_trimesh", self)

    def to_pyvista(self):
        """A ``pyvista.PolyData`` (pyvista installed) with the same vertices and triangles."""
        return _hooks.call("to_pyvista", self)

    def to_geodataframe(self):
        """A ``geopandas.GeoDataFrame`` (geopandas installed): one 3-D polygon per triangle, with the CRS."""
        return _hooks.call("to_geodataframe", self)

    def to_xarray(self, grid):
        """The mesh re-rasterised on ``grid`` (a Heightfield or a georeferenced DataArray) as an
        ``xarray.DataArray`` (xarray installed; with rioxarray's CRS and transform when rioxarray is)."""
        return _hooks.call("to_xarray", self, grid)

    def to_xugrid(self):
        """An ``xugrid.UgridDataset`` (xugrid installed): the UGRID 1.0 mesh of :mod:`tinsmith.io.ugrid`, with the
        elevation, the attributes, the named boundary edges and the CRS."""
        return _hooks.call("to_xugrid", self)

    # -- solvers: tinsmith.io.flood's functions, a layer above (tinsmith._hooks) ------------------------------
    def to_anuga(self, *, boundary_tags=None, friction: float | None = None):
        """An ``anuga.Domain`` on this mesh (``pip install anuga``: no tinsmith extra, see :mod:`tinsmith.io.flood`).

        Nothing is re-interpolated: the domain's points are the vertices' x, y
        (relative to a round corner under the data, the domain's
        ``geo_reference``, with the EPSG code of the CRS), its triangles are
        the mesh's in the same order, counter-clockwise as ANUGA needs (a mesh
        wound clockwise throughout is turned), and ``elevation`` is set at
        the vertices from their z.  ``stage`` starts on the ground (dry), and
        ``friction`` is Manning's ``n`` when given.

        Every border edge carries a tag, the names ``domain.set_boundary``
        maps to boundary conditions: ``"exterior"`` (ANUGA's default tag) on
        the outer loops of the outline and ``"hole"`` on the loops round holes
        in the data (:func:`tinsmith.io.boundaries.named_boundaries`); an edge
        between two consecutive vertices of one of the mesh's
        ``node_strings`` takes the string's name; then ``boundary_tags``
        names segments of the caller's:

        - a mapping ``{tag: vertex indices in order}``: the border edges
          along each polyline (over the node strings of the same name);
        - a callable ``(x, y) -> tag or None``, called with the midpoint of
          every border edge; ``None`` keeps the tag the edge had.

        ANUGA works in metres: a mesh in a geographic CRS (degrees), or in a
        CRS in feet, is refused (:class:`~tinsmith.errors.InvalidInputError`)
        naming a projected CRS to reproject to; so is a mesh that cannot be a
        domain (:class:`~tinsmith.errors.InvalidMeshError`): no triangles, a
        closed surface, an edge of three or more triangles, or a triangle that
        is degenerate or folds over the others seen from above.  ANUGA writes
        its results to ``<domain name>.sww`` in the working folder while it
        evolves unless ``domain.set_store(False)`` (or ``set_datadir``).

        Examples
        --------
        >>> import tinsmith
        >>> square = tinsmith.TerrainMesh([[0, 0, 1], [10, 0, 2], [10, 10, 3], [0, 10, 2]],
        ...                               [[0, 1, 2], [0, 2, 3]], crs="EPSG:32610",
        ...                               node_strings={"inflow": [3, 0]})
        >>> domain = square.to_anuga(friction=0.03)
        >>> len(domain), sorted(domain.get_boundary_tags())
        (2, ['exterior', 'inflow'])
        >>> domain.quantities["elevation"].vertex_values.tolist()
        [[1.0, 2.0, 3.0], [1.0, 3.0, 2.0]]
        >>> east = square.to_anuga(boundary_tags=lambda x, y: "outflow" if x == 10 else None)
        >>> sorted(east.get_boundary_tags())
        ['exterior', 'inflow', 'outflow']
        """
        return _hooks.call("to_anuga", self, boundary_tags=boundary_tags, friction=friction)

    def _repr_html_(self) -> str:
        return _hooks.call("repr_html", self)

    def __repr__(self) -> str:
        method = self.info.get("method", "?")
        return f"TerrainMesh({self.n_vertices} vertices, {self.n_triangles} triangles, method={method})"
