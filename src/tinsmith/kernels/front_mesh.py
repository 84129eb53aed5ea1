"""The front's mesh (Gopi and Krishnan 2002, general mode): the strips' pieces turned to agree before the joining
front; after the front, the triangles numbered from 0, then components, border loops and the turn of each component,
in linear time.

Buffers as in :mod:`tinsmith.kernels.projection`: ``tri`` (T, 3), ``nxt``
(3 T) the next triangle at the same point per corner, ``head`` (N) the first
triangle at each point.
"""

import numpy as np

from ._jit import jit, jit_inline
from .projection import COMPLETED, _has


@jit_inline
def _root(parent, v):
    while parent[v] != v:
        parent[v] = parent[parent[v]]  # path halving
        v = parent[v]
    return v


@jit
def surface_summary(p, tri, nxt, head, state):
    """(component label per point (-1 unused), flip per label, border loops) of the front's mesh.

    Components and border loops by union-find, a border edge being one whose
    reverse no triangle walks.  A component with a border edge is open and
    should face upwards (its triangles' summed normal points up); a closed
    one outwards (positive enclosed volume); ``flip`` says which do not.
    """
    n = head.shape[0]
    parent = np.arange(n)
    for t in range(tri.shape[0]):
        for k in (1, 2):
            a, b = _root(parent, tri[t, 0]), _root(parent, tri[t, k])
            if a != b:
                parent[max(a, b)] = min(a, b)
    label = np.full(n, -1, np.int64)
    for v in range(n):
        if head[v] >= 0:
            label[v] = _root(parent, v)
    is_open = np.zeros(n, np.bool_)
    up = np.zeros(n)  # summed z of twice the triangle areas
    volume = np.zeros(n)  # six times the signed volume of the cones from the origin
    loop = np.arange(n)
    on_border = np.zeros(n, np.bool_)
    for t in range(tri.shape[0]):
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        ux, uy, uz = p[b, 0] - p[a, 0], p[b, 1] - p[a, 1], p[b, 2] - p[a, 2]
        vx, vy, vz = p[c, 0] - p[a, 0], p[c, 1] - p[a, 1], p[c, 2] - p[a, 2]
        cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        up[label[a]] += cz
        volume[label[a]] += p[a, 0] * cx + p[a, 1] * cy + p[a, 2] * cz
        for k in range(3):
            a, b = tri[t, k], tri[t, (k + 1) % 3]
            if state[a] != COMPLETED and not _has(tri, head, nxt, b, a):  # a completed point's fan is closed
                is_open[label[a]] = True
                on_border[a] = on_border[b] = True
                ra, rb = _root(loop, a), _root(loop, b)
                if ra != rb:
                    loop[max(ra, rb)] = min(ra, rb)
    flip = np.zeros(n, np.bool_)
    for v in range(n):
        if label[v] == v:
            flip[v] = up[v] < 0.0 if is_open[v] else volume[v] < 0.0
    loops = 0
    for v in range(n):
        if on_border[v] and _root(loop, v) == v:
            loops += 1
    return label, flip, loops


@jit
def compact(tri, nxt, head, first, end):
    """Number the triangles of the runs ``first[j]`` .. ``end[j] - 1`` (in increasing order) from 0, in place:
    rows of ``tri`` and ``nxt`` moved down, every triangle number in ``nxt`` and ``head`` renumbered; the count."""
    shift = np.empty(first.shape[0], np.int64)  # what run j's numbers drop by
    total = 0
    for j in range(first.shape[0]):
        shift[j] = first[j] - total
        total += end[j] - first[j]
    for j in range(first.shape[0]):
        for t in range(first[j], end[j]):
            for k in range(3):
                tri[t - shift[j], k] = tri[t, k]
                nxt[3 * (t - shift[j]) + k] = nxt[3 * t + k]
    for i in range(3 * total):
        nxt[i] = _renumber(nxt[i], first, shift)
    for v in range(head.shape[0]):
        head[v] = _renumber(head[v], first, shift)
    return total


@jit_inline
def _renumber(t, first, shift):
    if t < 0:
        return t
    j = first.shape[0] - 1
    while first[j] > t:
        j -= 1
    return t - shift[j]


@jit
def pieces(p, tri, first, end):
    """(piece of each point, -1 unmeshed; summed normal of its triangles, (N, 3)) over the triangles of the runs
    ``first[j]`` .. ``end[j] - 1``: the strips' pieces before the joining front, by union-find."""
    n = p.shape[0]
    parent = np.arange(n)
    normal = np.zeros((n, 3))
    meshed = np.zeros(n, np.bool_)
    for j in range(first.shape[0]):
        for t in range(first[j], end[j]):
            a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
            for k in (1, 2):
                ra, rb = _root(parent, a), _root(parent, tri[t, k])
                if ra != rb:
                    parent[max(ra, rb)] = min(ra, rb)
            ux, uy, uz = p[b, 0] - p[a, 0], p[b, 1] - p[a, 1], p[b, 2] - p[a, 2]
            vx, vy, vz = p[c, 0] - p[a, 0], p[c, 1] - p[a, 1], p[c, 2] - p[a, 2]
            cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
            for v in (a, b, c):
                normal[v, 0] += cx
                normal[v, 1] += cy
                normal[v, 2] += cz
                meshed[v] = True
    label = np.full(n, -1, np.int64)
    for v in range(n):
        if meshed[v]:
            label[v] = _root(parent, v)
    return label, normal


@jit
def turn_pieces(tri, nxt, first, end, label, turned):
    """Reverse every triangle of the runs whose piece (``label`` of its first corner) is ``turned``: two corners
    swapped, with their links to the next triangle at the same point; how many."""
    count = 0
    for j in range(first.shape[0]):
        for t in range(first[j], end[j]):
            if turned[label[tri[t, 0]]]:
                tri[t, 1], tri[t, 2] = tri[t, 2], tri[t, 1]
                nxt[3 * t + 1], nxt[3 * t + 2] = nxt[3 * t + 2], nxt[3 * t + 1]
                count += 1
    return count
