"""The remesher's Lloyd step in parameter space: cell moments by walking from the last owner.

A quadrature point belongs to the nearest corner of the triangle of the
sites' (constrained Delaunay) triangulation that holds it.  Sites move
little from one Lloyd iteration to the next, so each point starts at a
triangle of the site that owned it last time and walks to the triangle
holding it (a visibility walk: cross the first edge the point lies
beyond), a step or two in the common case, instead of a fresh location of
every point.  A point whose walk leaves the triangulation (a concave stretch
of the domain between it and its start) or runs past ``max_steps`` is
reported for a full location.

Layout: ``sites`` float64 (N, 2), ``tri`` int64 (M, 3) counter-clockwise,
``qpts`` float64 (Q, 2), ``qw`` float64 (Q,), ``owner`` int64 (Q,).
"""

import numpy as np

from ._jit import jit


@jit
def moments(sites, tri, neighbour, first, qpts, qw, owner, max_steps):
    """Mass and first moments of every site's cell, walking each point from its last owner's triangle.

    ``neighbour[t, k]`` is the triangle across the edge opposite corner k
    (-1 on the border), ``first[v]`` a triangle of site v (-1 for none).

    ``owner`` is updated in place.  Returns (mass (N,), mx (N,), my (N,),
    lost): ``lost`` holds the points whose walk did not end in a triangle;
    they are in no sum and keep their owner.
    """
    n = sites.shape[0]
    mass = np.zeros(n)
    mx = np.zeros(n)
    my = np.zeros(n)
    lost = np.empty(qpts.shape[0], np.int64)
    n_lost = 0
    for q in range(qpts.shape[0]):
        x, y = qpts[q, 0], qpts[q, 1]
        o = owner[q]
        t = first[o] if o >= 0 else -1
        found = False
        step = 0
        while t >= 0 and step < max_steps:
            crossed = -1
            for kk in range(3):  # the edge to test first turns with the step, so no walk circles for ever
                k = (kk + step) % 3
                a = tri[t, (k + 1) % 3]
                b = tri[t, (k + 2) % 3]
                side = (sites[b, 0] - sites[a, 0]) * (y - sites[a, 1]) - (sites[b, 1] - sites[a, 1]) * (x - sites[a, 0])
                if side < 0.0:
                    crossed = k
                    break
            if crossed < 0:
                found = True
                break
            t = neighbour[t, crossed]
            step += 1
        if not found:
            lost[n_lost] = q
            n_lost += 1
            continue
        best = tri[t, 0]
        best_d = (sites[best, 0] - x) ** 2 + (sites[best, 1] - y) ** 2
        for k in range(1, 3):
            v = tri[t, k]
            d = (sites[v, 0] - x) ** 2 + (sites[v, 1] - y) ** 2
            if d < best_d:
                best, best_d = v, d
        owner[q] = best
        mass[best] += qw[q]
        mx[best] += qw[q] * x
        my[best] += qw[q] * y
    return mass, mx, my, lost[:n_lost]


@jit
def wall_regions(tri, half, walls, n_vertices):
    """(region (M,), count): the pieces of a triangulation that no wall edge separates.

    ``tri`` and ``half`` are the flat corner and twin-halfedge arrays of
    :mod:`.tin` (halfedge ``3t + k`` runs from corner ``k`` to corner
    ``k + 1``); ``walls`` holds the sorted keys ``min * n_vertices + max`` of
    the wall edges.
    """
    m = tri.shape[0] // 3
    region = np.full(m, -1, np.int64)
    stack = np.empty(m, np.int64)
    count = 0
    for seed in range(m):
        if region[seed] >= 0:
            continue
        region[seed] = count
        top = 0
        stack[0] = seed
        top = 1
        while top > 0:
            top -= 1
            t = stack[top]
            for k in range(3):
                e = 3 * t + k
                o = half[e]
                if o < 0 or region[o // 3] >= 0:
                    continue
                a = tri[e]
                b = tri[3 * t + (k + 1) % 3]
                key = min(a, b) * n_vertices + max(a, b)
                i = np.searchsorted(walls, key)
                if i < walls.shape[0] and walls[i] == key:
                    continue
                region[o // 3] = count
                stack[top] = o // 3
                top += 1
        count += 1
    return region, count


@jit
def region_probes(sites, tri, region, n_regions):
    """(x, y, usable), each (n_regions,): the centroid of each region's largest triangle, the point at which to
    test whether the region lies inside the walls (a region never crosses a wall; the centroid of a sliver along
    a wall is too close to it for the test).  A region of slivers only is not usable: it is a pocket between a
    straight wall and the hull (inside the walls it would join the rest of the inside).  ``tri`` is (M, 3)."""
    best = np.full(n_regions, -1, np.int64)
    best_area = np.full(n_regions, -1.0)
    for t in range(tri.shape[0]):
        ax, ay = sites[tri[t, 0], 0], sites[tri[t, 0], 1]
        area = abs((sites[tri[t, 1], 0] - ax) * (sites[tri[t, 2], 1] - ay)
                   - (sites[tri[t, 2], 0] - ax) * (sites[tri[t, 1], 1] - ay))
        if area > best_area[region[t]]:
            best_area[region[t]] = area
            best[region[t]] = t
    largest = best_area.max() if n_regions > 0 else 0.0
    x = np.zeros(n_regions)
    y = np.zeros(n_regions)
    usable = np.zeros(n_regions, np.bool_)
    for r in range(n_regions):
        t = best[r]
        if t < 0 or best_area[r] <= 1e-12 * largest:
            continue
        x[r] = (sites[tri[t, 0], 0] + sites[tri[t, 1], 0] + sites[tri[t, 2], 0]) / 3.0
        y[r] = (sites[tri[t, 0], 1] + sites[tri[t, 1], 1] + sites[tri[t, 2], 1]) / 3.0
        usable[r] = True
    return x, y, usable
