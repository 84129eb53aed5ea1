"""A mesh handed to a flood solver as the solver's own object: an ANUGA ``Domain``.

ANUGA (Geoscience Australia and the ANU; Apache-2.0) solves the shallow water
equations by finite volumes on triangles.  :func:`to_anuga` (behind
:meth:`TerrainMesh.to_anuga <tinsmith.core.TerrainMesh.to_anuga>`) builds its
``anuga.Domain`` from the mesh with nothing re-interpolated: the triangles in
the mesh's order (counter-clockwise, as ANUGA asserts), the elevation at the
vertices from the mesh's z, and a tag on every border edge that
``domain.set_boundary`` maps to a boundary condition.  ANUGA is imported on
the first call; it is no tinsmith extra (``pip install anuga``): it installs
meshpy, whose bundled Triangle is not free for commercial use, which the
user chooses to accept, not tinsmith.
"""

from __future__ import annotations

import contextlib
import io as _io
import math
import warnings
from collections.abc import Mapping

import numpy as np

from ..core import TerrainMesh
from ..errors import InvalidInputError, InvalidMeshError, InvalidOptionError, MissingDependencyError, TinsmithWarning
from .boundaries import loop_area, named_boundaries
from .crs import is_geographic, linear_unit, refuse_geographic, to_epsg

__all__ = ["to_anuga", "border_tags"]

#: the tag of the border edges of the outer loops (round the data), ANUGA's own default tag
EXTERIOR = "exterior"
#: the tag of the border edges round a hole in the data
HOLE = "hole"


def _import_anuga():
    try:
        import anuga
    except ImportError:
        raise MissingDependencyError(
            "TerrainMesh.to_anuga needs ANUGA: pip install anuga (not a tinsmith extra: it installs meshpy, "
            "whose bundled Triangle is not free for commercial use)"
        ) from None
    return anuga


def to_anuga(mesh: TerrainMesh, *, boundary_tags=None, friction: float | None = None):
    """The ``anuga.Domain`` of the mesh; see :meth:`TerrainMesh.to_anuga` for the rules."""
    with contextlib.redirect_stdout(_io.StringIO()):  # ANUGA prints a warning on stdout when mpi4py is absent
        anuga = _import_anuga()
    triangles = _domain_triangles(mesh)
    _refuse_units(mesh)
    tags = border_tags(mesh, boundary_tags=boundary_tags, triangles=triangles)
    if friction is not None:
        friction = _manning(friction)
    xy = mesh.vertices[:, :2]
    # points relative to a round corner under the data, as ANUGA's own meshes are (its areas are products of
    # coordinates: millions of metres would cancel the digits of small triangles); the corner is the domain's
    # geo_reference, with the EPSG code when the CRS has one
    x0, y0 = (math.floor(float(c)) for c in xy.min(axis=0))
    epsg = to_epsg(mesh.crs)
    with warnings.catch_warnings():  # ANUGA reads the datum of the EPSG code through a PROJ string: pyproj warns
        warnings.filterwarnings("ignore", "You will likely lose important projection information", UserWarning)
        geo = anuga.Geo_reference(xllcorner=x0, yllcorner=y0, **({"epsg": epsg} if epsg else {}))
    domain = anuga.Domain(xy - (x0, y0), triangles, boundary=tags, geo_reference=geo)
    z = mesh.vertices[:, 2][triangles]
    domain.set_quantity("elevation", z, location="vertices")
    domain.set_quantity("stage", z, location="vertices")  # dry: the water surface on the ground, to the last digit
    if friction is not None:
        domain.set_quantity("friction", friction)
    _warn_in_line(domain, (x0, y0))
    return domain


def in_line_border_triangles(domain) -> np.ndarray:
    """The triangles of an ANUGA domain with one border edge whose two neighbours' centroids lie on one line
    with their own.

    ANUGA reconstructs a triangle's quantities from the centroids of its neighbours; with one border edge
    that is two neighbours, and when their centroids are in line with the triangle's own the elevation's edge
    values come out NaN and the whole run goes non-finite within its first steps.  Grid-aligned meshes
    (vertices on cell centres, as greedy insertion and the quality mesher place them) can have such
    triangles; in ``benchmarks/flood_solver.py`` every run that went non-finite (5 of 24 greedy and quality
    runs) had at least one and every other run none.
    """
    nb = np.asarray(domain.neighbours)
    inner = nb >= 0
    two = np.flatnonzero(inner.sum(axis=1) == 2)
    if not len(two):
        return two
    c = np.asarray(domain.centroid_coordinates)
    pair = np.sort(np.where(inner[two], nb[two], -1), axis=1)[:, 1:]  # the two neighbours, in index order
    p, q = c[pair[:, 0]] - c[two], c[pair[:, 1]] - c[two]
    cross = p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0]
    scale = np.einsum("ij,ij->i", p, p) + np.einsum("ij,ij->i", q, q)
    return two[np.abs(cross) <= 1e-12 * scale]


def _warn_in_line(domain, corner) -> None:
    bad = in_line_border_triangles(domain)
    if len(bad):
        x, y = (np.asarray(domain.centroid_coordinates)[bad[0]] + corner).tolist()
        warnings.warn(
            f"{len(bad)} border triangle(s) of this mesh have their two neighbours' centroids in line with their "
            f"own (the first at x={x:.2f}, y={y:.2f}): ANUGA's reconstruction there gives NaN and its runs go "
            "non-finite; move or add a vertex near them, or mesh with method='cvt' or 'remesh'",
            TinsmithWarning, stacklevel=3)


def border_tags(mesh: TerrainMesh, *, boundary_tags=None, triangles=None) -> dict[tuple[int, int], str]:
    """``{(triangle, edge): tag}`` for every border edge, ANUGA's boundary dictionary (edge i of a
    triangle is the one opposite its vertex i).  The rules are :meth:`TerrainMesh.to_anuga`'s."""
    tri = _domain_triangles(mesh) if triangles is None else np.asarray(triangles, np.int64)  # keys below: n^2
    n = mesh.n_vertices
    oriented = TerrainMesh(mesh.vertices, tri)
    # every directed edge of every triangle: edge i runs from vertex i+1 to vertex i+2 (opposite vertex i)
    heads = tri[:, [1, 2, 0]].ravel()
    tails = tri[:, [2, 0, 1]].ravel()
    keys = heads * n + tails
    order = np.argsort(keys, kind="stable")
    tags: dict[tuple[int, int], str] = {}
    edges: list[tuple[int, int]] = []
    for loop in named_boundaries(oriented)["outline"]:
        name = EXTERIOR if loop_area(mesh.vertices, loop) > 0 else HOLE  # counter-clockwise: round the data
        at = order[np.searchsorted(keys, loop[:-1] * n + loop[1:], sorter=order)]
        for k, (a, b) in zip(at.tolist(), zip(loop[:-1].tolist(), loop[1:].tolist(), strict=True), strict=True):
            tags[(k // 3, k % 3)] = name
            edges.append((a, b))
    named = dict(mesh.node_strings)
    if isinstance(boundary_tags, Mapping):
        callers = {_tag(name): _string(name, ids, n) for name, ids in boundary_tags.items()}
        named = {name: ids for name, ids in named.items() if name not in callers} | callers  # the caller's last
    elif boundary_tags is not None and not callable(boundary_tags):
        raise InvalidOptionError(
            "boundary_tags is a mapping {tag: vertex indices in order} or a callable (x, y) -> tag of an edge's "
            f"midpoint; got {type(boundary_tags).__name__}"
        )
    if named:
        along = {}
        for name, ids in named.items():  # later strings win: the caller's over the mesh's
            ids = np.asarray(ids, np.int64)
            along |= {(min(a, b), max(a, b)): name for a, b in zip(ids[:-1].tolist(), ids[1:].tolist(), strict=True)}
        for key, (a, b) in zip(list(tags), edges, strict=True):
            name = along.get((min(a, b), max(a, b)))
            if name is not None:
                tags[key] = name
    if callable(boundary_tags):
        v = mesh.vertices
        for key, (a, b) in zip(list(tags), edges, strict=True):
            name = boundary_tags(0.5 * (v[a, 0] + v[b, 0]), 0.5 * (v[a, 1] + v[b, 1]))
            if name is not None:
                tags[key] = _tag(name)
    return tags


def _domain_triangles(mesh: TerrainMesh) -> np.ndarray:
    """The triangles counter-clockwise seen from above (a mesh wound the other way throughout is turned),
    or an error of one line saying why the mesh cannot be a domain."""
    what = "an ANUGA domain needs a 2-D mesh seen from above"
    if mesh.n_triangles == 0:
        raise InvalidMeshError(f"{what}; this mesh has no triangles")
    if is_geographic(mesh.crs):
        refuse_geographic(mesh.crs, (*mesh.bounds[:2], *mesh.bounds[3:5]), "ANUGA",
                          "its lengths, areas, depths and velocities would mix degrees with metres")
    if len(mesh.boundary_edges()) == 0:
        raise InvalidMeshError(f"{what}, with an outline; this mesh is a closed surface (no border edge)")
    tri = mesh.triangles
    if (mesh.orientations() < 0).all():
        tri = tri[:, [0, 2, 1]]
    problems = TerrainMesh(mesh.vertices, tri).check()
    if problems:
        raise InvalidMeshError(f"{what}: {'; '.join(problems)}")
    return np.ascontiguousarray(tri, np.int64)


def _refuse_units(mesh: TerrainMesh) -> None:
    unit = linear_unit(mesh.crs)
    if unit not in ("metre", "meter", "unknown"):
        raise InvalidInputError(
            f"ANUGA works in metres, but the CRS of the mesh measures in {unit}; "
            "reproject to a projected CRS in metres first (e.g. the data's UTM zone)"
        )


def _manning(value) -> float:
    try:
        n = float(value)
    except (TypeError, ValueError):
        n = math.nan
    if isinstance(value, bool) or not (math.isfinite(n) and n >= 0):
        raise InvalidOptionError(f"friction is Manning's n, one finite number >= 0 (e.g. 0.03); got {value!r}")
    return n


def _tag(name) -> str:
    if not isinstance(name, str) or not name:
        raise InvalidOptionError(f"a boundary tag is a non-empty string; got {name!r}")
    return name


def _string(name: str, ids, n: int) -> np.ndarray:
    try:
        ids = np.asarray(ids, dtype=np.int64).ravel()
    except (TypeError, ValueError) as err:
        raise InvalidOptionError(f"boundary_tags[{name!r}] must be vertex indices in order; got {ids!r}") from err
    if len(ids) < 2 or ids.min() < 0 or ids.max() >= n:
        raise InvalidOptionError(
            f"boundary_tags[{name!r}] must be two or more vertex indices in 0..{n - 1}; got {ids.tolist()[:8]}"
        )
    return ids

