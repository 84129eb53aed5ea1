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
    loops.sort(key=lambda lp: -abs(_area(mesh.vertices, lp)))
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


def _area(vertices: np.ndarray, loop: np.ndarray) -> float:
    x, y = vertices[loop, 0], vertices[loop, 1]
    with np.errstate(all="ignore"):  # coordinates near the float limits: no order among such loops
        x, y = x - x.mean(), y - y.mean()
        area = 0.5 * float(np.dot(x[:-1], y[1:]) - np.dot(x[1:], y[:-1]))
    return area if np.isfinite(area) else 0.0


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
