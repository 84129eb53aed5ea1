"""Synthetic surfaces and point clouds with known shapes, for trying the methods and checking them.

The closed surfaces the remesher's tests and benchmark measure (a sphere or
ellipsoid, a torus), the evenly spread clouds reconstruction is checked on
(a sphere, a torus), and the box scene of ``docs/methods/reconstruct.md``.
The kernels' warm-up (:mod:`tinsmith.warmup`) meshes a small sphere from here.
"""

from __future__ import annotations

import numpy as np

from .core import TerrainMesh


def sphere_points(n: int, radius: float = 1.0) -> np.ndarray:
    """(n, 3) points spread evenly over a sphere: the Fibonacci lattice."""
    k = np.arange(n) + 0.5
    phi = np.arccos(1 - 2 * k / n)
    theta = np.pi * (1 + 5**0.5) * k
    return radius * np.column_stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)])


def ellipsoid(n: int, axes=(1.0, 1.0, 1.0)) -> TerrainMesh:
    """A closed mesh of ``n`` vertices: the convex hull of the unit Fibonacci lattice, faces outward, scaled by
    ``axes`` (equal axes: a sphere)."""
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
    about ``n`` points with steps of the same length both ways."""
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
    """A closed mesh of a torus: ``nu`` x ``nv`` vertices on a grid of its two angles, two triangles a step."""
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
    (the box scene of docs/methods/reconstruct.md)."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-40, 40, (20_000, 2))
    top = np.column_stack([xy, np.where((np.abs(xy) <= 10).all(axis=1), 10.0, 0.0)])
    along, height, side = rng.uniform(-10, 10, 800), rng.uniform(0, 10, 800), rng.integers(0, 4, 800)
    x = np.select([side == 0, side == 1, side == 2], [along, np.full(800, 10.0), along], np.full(800, -10.0))
    y = np.select([side == 0, side == 1, side == 2], [np.full(800, -10.0), along, np.full(800, 10.0)], along)
    return np.vstack([top, np.column_stack([x, y, height])])
