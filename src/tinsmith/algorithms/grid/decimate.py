"""Decimation: quadric edge collapse from the full-resolution mesh.

After the Salt Lake City thesis, section 2.2, and Garland and Heckbert 1997.

The top-down method of the Salt Lake City thesis' review (section 2.2, Table 2.1): start
from every cell (:func:`grid_mesh`, or any dense TIN) and remove vertices
one by one, the cheapest first, until the rule is met.  The cost of moving
vertex ``v`` onto a neighbour ``u`` is Garland and Heckbert's quadric error
metric, with the *vertical* distance to a plane, as terrain needs: every
triangle adds ``area * (a x + b y + c - z)**2`` (its plane ``z = a x + b y
+ c``) to its corners' quadrics, and a collapse adds the quadric of ``v``
to that of ``u``.  The collapse is a half-edge collapse, so every kept
vertex is an input sample with its exact height.

What keeps the result a valid 2.5-D mesh, which general mesh decimators
(VTK's vtkQuadricDecimation, fast-simplification) do not promise:

- no collapse turns a triangle over or flattens it seen from above (exact
  orientation test), and the link condition keeps the mesh manifold;
- the outline stays in place: a border vertex only slides along the
  border into its neighbour, and only where the border runs straight, so
  corners of the data and of its holes never move and the covered area
  is the input's.

The collapse sequence is computed once (:class:`Decimation`); a mesh with
any number of collapses is read off it, which is how ``max_error`` is met
(the smallest mesh whose measured error meets the bound, by bisection over
the sequence) and how levels of detail share the work.
"""

from __future__ import annotations

import numpy as np

from ...core import Heightfield, StopCriteria, TerrainMesh
from ...errors import InvalidInputError
from ...kernels import decimate as kd
from ...metrics import vertical_error, vertical_error_at_points
from ...triangulation.grid import grid_mesh
from ..registry import register

__all__ = ["Decimation", "decimate"]


class Decimation:
    """The collapse sequence of a heightfield or a dense mesh; :meth:`mesh` reads off any level.

    Parameters
    ----------
    source : Heightfield or TerrainMesh
        A heightfield is decimated from its full-resolution mesh; a mesh
        must be a valid 2.5-D triangulation (:meth:`TerrainMesh.check`).
    target_vertices : int, optional
        Stop collapsing at this many vertices (default: go on while any
        collapse is valid).

    Attributes
    ----------
    n_steps : int
        Collapses computed; ``mesh(k)`` takes the first ``k``.

    Examples
    --------
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> dem = tinsmith.Heightfield(hf.z[200:264, 100:164], cell_size=30.0, crs=hf.crs)  # a 64 x 64 window
    >>> sequence = tinsmith.Decimation(dem)  # every collapse computed once
    >>> sequence.n_vertices
    4096
    >>> coarse, fine = sequence.mesh(sequence.n_steps), sequence.mesh(1000)  # any level read off
    >>> fine.n_vertices, coarse.n_vertices < fine.n_vertices
    (3096, True)
    >>> sequence.max_error(coarse) >= sequence.max_error(fine)
    True
    """

    def __init__(self, source, *, target_vertices: int = 0):
        if isinstance(source, Heightfield):
            self.hf = source
            fine = _used(grid_mesh(source))  # a valid cell with no valid neighbour square is in no triangle
            rows, cols = source.world_to_pixel(fine.vertices[:, 0], fine.vertices[:, 1])
            x, y = np.round(cols), np.round(rows)  # whole numbers: straight borders are exactly straight
        elif isinstance(source, TerrainMesh):
            self.hf = None
            fine = _used(source)
            problems = fine.check()
            if problems:
                raise InvalidInputError("decimate needs a valid 2.5-D mesh: " + "; ".join(problems))
            x, y = fine.vertices[:, 0], fine.vertices[:, 1]
            scale = max(np.ptp(x), np.ptp(y)) or 1.0
            x, y = (x - x.min()) / scale, (y - y.min()) / scale
        else:
            raise InvalidInputError(f"decimate takes a Heightfield or a TerrainMesh, got {type(source).__name__}")
        tri = fine.triangles.astype(np.int64)  # a copy the kernels rewrite, int64 as they index
        p = np.column_stack([x, y])[tri]
        if ((p[0, 1, 0] - p[0, 0, 0]) * (p[0, 2, 1] - p[0, 0, 1]) - (p[0, 2, 0] - p[0, 0, 0]) * (p[0, 1, 1] - p[0, 0, 1])) < 0:
            y = -y  # pixel rows run down: mirror so the triangles stay counter-clockwise
        z = fine.vertices[:, 2] - fine.vertices[:, 2].mean()  # costs do not depend on it; the rounding does
        x, y = np.ascontiguousarray(x, np.float64), np.ascontiguousarray(y, np.float64)
        locked = np.zeros(len(x), np.bool_)
        head, nxt = kd.corner_lists(tri, len(x))
        bn = kd.border(x, y, tri, head, nxt, locked)
        quad = kd.quadrics(x, y, z, tri)
        self.gone, self.into, self.costs, self.n_triangles_after = kd.collapse(
            x, y, z, tri, locked, quad, bn, head, nxt, int(target_vertices)
        )
        self.fine = fine
        self.n_steps = len(self.gone)

    @property
    def n_vertices(self) -> int:
        """Vertices of the input mesh (no collapse)."""
        return self.fine.n_vertices

    def mesh(self, k: int) -> TerrainMesh:
        """The mesh after the first ``k`` collapses (``n_vertices - k`` vertices)."""
        k = int(np.clip(k, 0, self.n_steps))
        rep = kd.representatives(self.fine.n_vertices, self.gone, self.into, k)
        tri = rep[self.fine.triangles]
        tri = tri[(tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2]) & (tri[:, 0] != tri[:, 2])]
        mesh = _used(TerrainMesh(self.fine.vertices, tri, crs=self.fine.crs))
        mesh.info["collapses"] = k
        if "grid" in self.fine.info:
            mesh.info["grid"] = self.fine.info["grid"]
        return mesh

    def max_error(self, mesh: TerrainMesh) -> float:
        """The largest vertical error of ``mesh`` against the source: every valid cell, or every input vertex."""
        if self.hf is not None:
            return float(vertical_error(mesh, self.hf)["max"])
        return float(vertical_error_at_points(mesh, self.fine.vertices)["max"])

    def steps_for(self, stop: StopCriteria) -> int:
        """The number of collapses the stop rules ask for (see :func:`decimate`)."""
        k = 0
        if stop.max_vertices is not None:
            k = max(k, self.n_vertices - stop.max_vertices)
        if stop.max_triangles is not None:
            over = np.flatnonzero(self.n_triangles_after > stop.max_triangles)
            before = self.fine.n_triangles > stop.max_triangles
            k = max(k, (int(over[-1]) + 2 if len(over) else 1) if before else 0)
        if k > self.n_steps:
            raise InvalidInputError(
                f"max_vertices={stop.max_vertices} / max_triangles={stop.max_triangles} leave no room: "
                f"decimation stops at {self.n_vertices - self.n_steps} vertices and "
                f"{self.mesh(self.n_steps).n_triangles} triangles (the corners of the outline stay)"
            )
        if stop.max_error is not None:
            k = max(k, self._most_within(stop.max_error, k))
        return k

    def _most_within(self, max_error: float, lo: int) -> int:
        """The most collapses from ``lo`` on whose measured error meets ``max_error`` (bisection; ``lo`` if none)."""
        hi, best = self.n_steps, lo
        if self.max_error(self.mesh(lo)) > max_error:
            return lo
        lo += 1
        while lo <= hi:
            mid = (lo + hi) // 2
            if self.max_error(self.mesh(mid)) <= max_error:
                best, lo = mid, mid + 1
            else:
                hi = mid - 1
        return best


def _used(mesh: TerrainMesh) -> TerrainMesh:
    """``mesh`` without the vertices no triangle uses."""
    kept = np.unique(mesh.triangles)
    if len(kept) == mesh.n_vertices:
        return mesh
    index = np.full(mesh.n_vertices, -1, np.int64)
    index[kept] = np.arange(len(kept))
    return TerrainMesh(mesh.vertices[kept], index[mesh.triangles], crs=mesh.crs, info=mesh.info)


@register("decimate")
def decimate(source, *, stop: StopCriteria, progress=None) -> TerrainMesh:
    """Collapse edges of the full-resolution mesh (or of a dense TIN), the cheapest first, until the rule is met.

    ``max_vertices`` and ``max_triangles`` give the largest mesh within
    them; ``max_error`` the smallest mesh of the sequence whose measured
    vertical error (against every valid cell of a heightfield, or every
    vertex of an input mesh) meets it, by bisection: the error of
    decimation does not grow strictly with each collapse, so it meets the
    bound but need not be the very smallest such mesh.  With both kinds,
    the first rule reached wins, as in greedy insertion.  Without a rule,
    1% of the vertices are kept.  Vertices are input samples; corners of
    the outline (and of nodata holes) always stay.

    Examples
    --------
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> dem = tinsmith.Heightfield(hf.z[200:264, 100:164], cell_size=30.0, crs=hf.crs)  # a 64 x 64 window
    >>> mesh = tinsmith.decimate(dem, max_vertices=300)
    >>> mesh.n_vertices <= 300
    True
    >>> coarser = tinsmith.decimate(mesh, max_vertices=100)  # a dense TIN decimated further
    >>> coarser.n_vertices <= 100, set(map(tuple, coarser.vertices)) <= set(map(tuple, mesh.vertices))
    (True, True)
    """
    n = source.n_valid if isinstance(source, Heightfield) else source.n_vertices
    if not stop.is_set:
        stop = StopCriteria(max_vertices=max(4, n // 100))
    target = 0 if stop.max_error is not None or stop.max_vertices is None else stop.max_vertices
    if progress:
        progress(0.0)
    dec = Decimation(source, target_vertices=target)
    if progress:
        progress(0.7)
    k = dec.steps_for(stop)
    mesh = dec.mesh(k)
    if stop.max_error is not None:
        mesh.info["error"] = {"max": dec.max_error(mesh)}
    if progress:
        progress(1.0)
    return mesh
