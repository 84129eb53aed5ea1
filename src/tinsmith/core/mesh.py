"""The :class:`TerrainMesh`: a triangulated irregular network in world coordinates."""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from .. import _hooks
from ..errors import InvalidInputError, InvalidMeshError

__all__ = ["TerrainMesh"]


class TerrainMesh:
    """Triangles over world-coordinate vertices, counter-clockwise seen from +z.

    Plain arrays are the mesh; everything else (edges, areas, bounds) is derived
    on demand.  ``info`` carries the diagnostics of the run that made it:
    ``method``, ``options``, ``timings`` (stage -> seconds) and ``error`` (the
    achieved vertical error, when measured).

    Parameters
    ----------
    vertices : (N, 3) array_like of float
        x, y, z in the CRS of the source data.
    triangles : (M, 3) array_like of int
        Vertex indices of each triangle.
    crs : str, optional
        Coordinate reference system as WKT.
    info : dict, optional
        Diagnostics; see above.

    Raises
    ------
    InvalidInputError
        For wrong shapes, non-finite coordinates or out-of-range indices.  The
        geometric rules (:meth:`check`) are not enforced here so that any mesh
        read from a file can still be measured; call :meth:`validate` for them.
    """

    def __init__(self, vertices, triangles, *, crs: str | None = None, info: dict | None = None):
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
        t = np.ascontiguousarray(t, dtype=np.int64)
        if t.size and (t.min() < 0 or t.max() >= len(v)):
            raise InvalidInputError(
                f"triangles index vertices 0..{len(v) - 1}, got indices {t.min()}..{t.max()}"
            )
        self.vertices = v
        self.triangles = t
        self.crs = crs or None
        self.info = dict(info or {})

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
        used by at most two triangles.
        """
        problems = []
        t = self.triangles
        if len(t) == 0:
            return ["the mesh has no triangles"]
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

    def _repr_html_(self) -> str:
        return _hooks.call("repr_html", self)

    def __repr__(self) -> str:
        method = self.info.get("method", "?")
        return f"TerrainMesh({self.n_vertices} vertices, {self.n_triangles} triangles, method={method})"
