"""Synthetic surfaces and point clouds with known shapes, for trying the methods and checking them.

The closed surfaces the remesher's tests and benchmark measure (a sphere or
ellipsoid, a torus), the evenly spread clouds reconstruction is checked on
(a sphere, a torus), the box scene of ``docs/methods/reconstruct.md``, and a
stream network on a DEM as a GIS user would have it (reaching beyond the DEM)
for the vector inputs' tests and benchmark.
The kernels' warm-up (:mod:`tinsmith.warmup`) meshes a small sphere from here.
"""

from __future__ import annotations

import numpy as np

from .core import TerrainMesh


def sphere_points(n: int, radius: float = 1.0) -> np.ndarray:
    """(n, 3) points spread evenly over a sphere: the Fibonacci lattice.

    Examples
    --------
    >>> import numpy as np
    >>> from tinsmith import shapes
    >>> points = shapes.sphere_points(500, radius=2.0)
    >>> points.shape, bool(np.allclose(np.linalg.norm(points, axis=1), 2.0))
    ((500, 3), True)
    """
    k = np.arange(n) + 0.5
    phi = np.arccos(1 - 2 * k / n)
    theta = np.pi * (1 + 5**0.5) * k
    return radius * np.column_stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)])


def ellipsoid(n: int, axes=(1.0, 1.0, 1.0)) -> TerrainMesh:
    """A closed mesh of ``n`` vertices: the convex hull of the unit Fibonacci lattice, faces outward, scaled by
    ``axes`` (equal axes: a sphere).

    Examples
    --------
    >>> from tinsmith import shapes
    >>> mesh = shapes.ellipsoid(200, axes=(3.0, 2.0, 1.0))
    >>> mesh.n_vertices, mesh.n_triangles, len(mesh.boundary_edges())  # closed: 2 n - 4 triangles, no border
    (200, 396, 0)
    >>> all(high <= axis for high, axis in zip(mesh.bounds[3:], (3.0, 2.0, 1.0)))  # xmax, ymax, zmax
    True
    """
    from scipy.spatial import ConvexHull

    p = sphere_points(n)
    t = ConvexHull(p).simplices
    flip = (np.cross(p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]]) * p[t].mean(axis=1)).sum(axis=1) < 0
    t[flip] = t[flip][:, [0, 2, 1]]
    return TerrainMesh(p * np.asarray(axes), t)


def torus_points(n: int | None = None, *, grid=None, seed: int = 0, jitter: float = 0.25, big: float = 3.0,
                 small: float = 1.0) -> np.ndarray:
    """Points spread evenly over a torus (radii ``big`` and ``small``): a grid of its two angles, each point
    moved by up to ``jitter`` of a step (locally uniform sampling).  ``grid`` = (around, across) steps, or
    about ``n`` points with steps of the same length both ways.

    Examples
    --------
    >>> import numpy as np
    >>> from tinsmith import shapes
    >>> points = shapes.torus_points(grid=(30, 10), big=3.0, small=1.0)
    >>> points.shape
    (300, 3)
    >>> ring = np.hypot(np.hypot(points[:, 0], points[:, 1]) - 3.0, points[:, 2])  # distance to the core circle
    >>> bool(np.allclose(ring, 1.0))
    True
    """
    if grid is None:
        nu = round(np.sqrt(n * big / small))
        nv = round(n / nu)
    else:
        nu, nv = grid
    rng = np.random.default_rng(seed)
    u = (np.arange(nu)[:, None] + 0.5 + rng.uniform(-jitter, jitter, (nu, nv))) * 2 * np.pi / nu
    v = (np.arange(nv)[None, :] + 0.5 + rng.uniform(-jitter, jitter, (nu, nv))) * 2 * np.pi / nv
    u, v = u.ravel(), v.ravel()
    return np.column_stack([(big + small * np.cos(v)) * np.cos(u), (big + small * np.cos(v)) * np.sin(u),
                            small * np.sin(v)])


def torus(nu: int, nv: int, big: float = 10.0, small: float = 3.0) -> TerrainMesh:
    """A closed mesh of a torus: ``nu`` x ``nv`` vertices on a grid of its two angles, two triangles a step.

    Examples
    --------
    >>> from tinsmith import shapes
    >>> mesh = shapes.torus(24, 8)
    >>> mesh.n_vertices, mesh.n_triangles, len(mesh.boundary_edges())  # closed, genus 1: 2 triangles a vertex
    (192, 384, 0)
    """
    u, w = np.meshgrid(np.arange(nu) * 2 * np.pi / nu, np.arange(nv) * 2 * np.pi / nv, indexing="ij")
    p = np.column_stack([((big + small * np.cos(w)) * np.cos(u)).ravel(), ((big + small * np.cos(w)) * np.sin(u)).ravel(),
                         (small * np.sin(w)).ravel()])
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    a, b = i * nv + j, ((i + 1) % nu) * nv + j
    c, d = ((i + 1) % nu) * nv + (j + 1) % nv, i * nv + (j + 1) % nv
    t = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return TerrainMesh(p, t)


def box_scene(seed: int = 0) -> np.ndarray:
    """A 20 m box, 10 m high, on 80 x 80 m of flat ground: 20,000 random ground and roof points, 800 on the walls
    (the box scene of docs/methods/reconstruct.md).

    Examples
    --------
    >>> import tinsmith
    >>> from tinsmith import shapes
    >>> points = shapes.box_scene()
    >>> points.shape
    (20800, 3)
    >>> print(f"{points[:, 2].min():.0f} {points[:, 2].max():.0f}")  # from the ground to the roof
    0 10
    >>> tinsmith.reconstruct(points).n_vertices <= len(points)
    True
    """
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-40, 40, (20_000, 2))
    top = np.column_stack([xy, np.where((np.abs(xy) <= 10).all(axis=1), 10.0, 0.0)])
    along, height, side = rng.uniform(-10, 10, 800), rng.uniform(0, 10, 800), rng.integers(0, 4, 800)
    x = np.select([side == 0, side == 1, side == 2], [along, np.full(800, 10.0), along], np.full(800, -10.0))
    y = np.select([side == 0, side == 1, side == 2], [np.full(800, -10.0), along, np.full(800, 10.0)], along)
    return np.vstack([top, np.column_stack([x, y, height])])


def stream_network(hf, n: int = 10, seed: int = 3, beyond: float = 1000.0) -> list[np.ndarray]:
    """Polylines (world x, y) of a stream network as a GIS user has it for a DEM: not cut to it.

    Steepest-descent paths from ``n`` cells drawn with ``seed`` (they run down the valleys; every other cell
    kept); a path that reaches the DEM's edge goes on ``beyond`` world units the way it went.  Three more: a
    line across the whole DEM and ``beyond`` past both sides, one that leaves the DEM and enters it again, and
    one wholly outside it.

    Examples
    --------
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> dem = tinsmith.Heightfield(hf.z[200:264, 100:164], cell_size=30.0, crs=hf.crs)  # a 64 x 64 window
    >>> from tinsmith import shapes
    >>> lines = shapes.stream_network(dem, n=10)
    >>> all(line.ndim == 2 and line.shape[1] == 2 for line in lines)
    True
    >>> xmin, ymin, xmax, ymax = dem.bounds
    >>> bool(lines[-1][:, 0].min() > xmax)  # the last one lies wholly outside the DEM
    True
    """
    z = np.where(hf.valid, hf.z, np.inf)
    h, w = z.shape
    lines = []
    for r, c in np.random.default_rng(seed).integers([min(5, h - 1)] * 2, [max(h - 5, 1), max(w - 5, 1)],
                                                     size=(n, 2)).tolist():
        path = [(r, c)]
        while True:
            window = z[max(r - 1, 0):r + 2, max(c - 1, 0):c + 2]
            dr, dc = np.unravel_index(np.argmin(window), window.shape)
            nr, nc = max(r - 1, 0) + int(dr), max(c - 1, 0) + int(dc)
            if z[nr, nc] >= z[r, c]:
                break
            r, c = nr, nc
            path.append((r, c))
        if len(path) < 6:
            continue
        rc = np.asarray(path, float)[::2]
        xy = np.column_stack(hf.pixel_to_world(rc[:, 0], rc[:, 1]))
        if r in (0, h - 1) or c in (0, w - 1):
            d = xy[-1] - xy[-3]
            xy = np.vstack([xy, xy[-1] + beyond * d / np.hypot(*d)])
        lines.append(xy)
    x0, y0, x1, y1 = hf.bounds
    dx, dy = x1 - x0, y1 - y0
    mid = (y0 + y1) / 2
    lines.append(np.array([[x0 - beyond, mid + 0.1 * dy], [x1 + beyond, mid - 0.15 * dy]]))
    lines.append(np.array([[x0 + 0.2 * dx, y1 - 0.3 * dy], [x0 + 0.35 * dx, y1 + beyond],
                           [x0 + 0.5 * dx, y1 - 0.25 * dy]]))
    lines.append(np.array([[x1 + 0.4 * beyond, y0 - 0.9 * beyond], [x1 + beyond, y0 - 0.3 * beyond]]))
    return lines
