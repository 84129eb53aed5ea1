"""Error diffusion of sample counts over the triangles of a mesh (Alliez et al. 2003, section 3.3).

Every triangle holds an ideal, fractional number of samples.  Triangles are
taken one by one; each gets its ideal number plus the error it received,
rounded to the nearest whole number (never below zero), and passes the
rounding error on to its unprocessed neighbours in proportion to the length
of the edges they share.  No error is ever dropped: a triangle without an
unprocessed neighbour hands its error to the next triangle taken.

**Path** (region growing): from a seed triangle (on the boundary when the
component has one) the processed region grows one triangle at a time
without splitting what is left: a candidate shares two or three edges with
the region or the mesh boundary (an ear), or one edge while its opposite
vertex is not yet on that border.  Among the candidates the one that makes
the region most compact (area / perimeter) goes next (an indexed max-heap).
**Leftovers** (what the growth cannot reach on surfaces with handles or
several boundaries) are sampled over a spanning tree of their dual graph,
children first, each passing its rounding error to its parent.

Layout: ``tri`` int64 (M, 3); ``adj`` int64 (M, 3) the triangle across the
edge opposite each corner (-1: boundary); ``elen`` float64 (M, 3) the length
of that edge; ``area`` and ``amount`` float64 (M,).
"""

import numpy as np

from ._jit import jit
from .heap import HEAP_SIZE, heap_push, heap_remove, heap_update

#: ``state`` of a triangle.
FREE, QUEUED, DONE = 0, 1, 2


@jit
def _key(t, adj, elen, area, state, region):
    """Compactness of the region (area / perimeter) after adding triangle ``t``, minus before."""
    a, p = region[0], region[1]
    perim = elen[t, 0] + elen[t, 1] + elen[t, 2]
    shared = 0.0
    for c in range(3):
        u = adj[t, c]
        if u >= 0 and state[u] == DONE:
            shared += elen[t, c]
    after = (a + area[t]) / max(p + perim - 2.0 * shared, 1e-300)
    before = a / p if p > 0 else 0.0
    return after - before


@jit
def _candidate(t, tri, adj, state, touched):
    """Whether taking ``t`` keeps the unprocessed region in one piece (see the module docstring)."""
    k = 0
    lone = -1
    for c in range(3):
        u = adj[t, c]
        if u < 0 or state[u] == DONE:
            k += 1
            lone = c
    if k >= 2:
        return True
    if k == 0:
        return False
    return not touched[tri[t, lone]]  # the vertex opposite the one border edge


@jit
def diffuse_triangles(tri, adj, elen, area, amount, seeds, n_vertices, carry):
    """(samples per triangle int64 (M,), the error left for what comes next): see the module docstring.

    ``seeds``: one seed triangle per connected component, in order;
    ``carry``: the error received from before.
    """
    m = tri.shape[0]
    count = np.zeros(m, np.int64)
    err = np.zeros(m)
    state = np.zeros(m, np.int8)
    touched = np.zeros(n_vertices, np.bool_)
    for t in range(m):  # the mesh boundary is the first border of the unprocessed region
        for c in range(3):
            if adj[t, c] < 0:
                touched[tri[t, (c + 1) % 3]] = True
                touched[tri[t, (c + 2) % 3]] = True
    heap = np.empty(m, np.int64)
    qpos = np.full(m, -1, np.int64)
    key = np.empty(m)
    q = (heap, qpos, key)
    cnt = np.zeros(4, np.int64)
    region = np.zeros(2)  # area, perimeter of the processed region of the current component
    for s in range(seeds.shape[0]):
        seed = seeds[s]
        if state[seed] == DONE:
            continue
        region[0] = 0.0
        region[1] = 0.0
        t = seed
        while t >= 0:
            # take t
            total = amount[t] + err[t] + carry
            carry = 0.0
            n = np.int64(np.floor(total + 0.5))
            if n < 0:
                n = 0
            count[t] = n
            e = total - n
            if qpos[t] >= 0:
                heap_remove(t, q, cnt)
            state[t] = DONE
            shared = 0.0
            open_len = 0.0
            for c in range(3):
                u = adj[t, c]
                if u >= 0 and state[u] == DONE:
                    shared += elen[t, c]
                elif u >= 0:
                    open_len += elen[t, c]
            region[0] += area[t]
            region[1] += elen[t, 0] + elen[t, 1] + elen[t, 2] - 2.0 * shared
            if open_len > 0.0:
                for c in range(3):
                    u = adj[t, c]
                    if u >= 0 and state[u] != DONE:
                        err[u] += e * elen[t, c] / open_len
            else:
                carry = e
            for c in range(3):
                touched[tri[t, c]] = True
            for c in range(3):
                u = adj[t, c]
                if u < 0 or state[u] == DONE:
                    continue
                if _candidate(u, tri, adj, state, touched):
                    k = _key(u, adj, elen, area, state, region)
                    if qpos[u] >= 0:
                        heap_update(u, q, k, cnt)
                    else:
                        heap_push(u, q, k, cnt)
                elif qpos[u] >= 0:
                    heap_remove(u, q, cnt)
            # the next: the most compact candidate that still keeps the rest in one piece
            t = -1
            while cnt[HEAP_SIZE] > 0:
                best = heap[0]
                if _candidate(best, tri, adj, state, touched):
                    t = best
                    break
                heap_remove(best, q, cnt)
    # leftovers: a spanning forest of their dual graph, children before parents
    parent = np.full(m, -1, np.int64)
    order = np.empty(m, np.int64)
    n_order = 0
    for r in range(m):
        if state[r] != FREE:
            continue
        state[r] = QUEUED
        head = n_order
        order[n_order] = r
        n_order += 1
        while head < n_order:
            t = order[head]
            head += 1
            for c in range(3):
                u = adj[t, c]
                if u >= 0 and state[u] == FREE:
                    state[u] = QUEUED
                    parent[u] = t
                    order[n_order] = u
                    n_order += 1
    for i in range(n_order - 1, -1, -1):
        t = order[i]
        total = amount[t] + err[t]
        if parent[t] < 0:  # a root: what came before flows in here, what is left flows on
            total += carry
            carry = 0.0
        n = np.int64(np.floor(total + 0.5))
        if n < 0:
            n = 0
        count[t] = n
        state[t] = DONE
        if parent[t] >= 0:
            err[parent[t]] += total - n
        else:
            carry = total - n
    return count, carry


@jit
def diffuse_chain(amount, carry):
    """Samples per edge along one backbone (1-D error diffusion, section 3.4); the error left at its end."""
    count = np.zeros(amount.shape[0], np.int64)
    for i in range(amount.shape[0]):
        total = amount[i] + carry
        n = np.int64(np.floor(total + 0.5))
        if n < 0:
            n = 0
        count[i] = n
        carry = total - n
    return count, carry
