"""Point-cloud preparation for the projection front (Gopi and Krishnan 2002, section 4): distinct points, the dexel array,
nearest-point distances, each in linear time (one sort of hashes for the duplicates).

The dexel array: the points of dexel ``k = row * nx + col`` are
``cidx[cstart[k]:cstart[k + 1]]``, sorted by z; ``cell[i]`` is point i's
dexel.
"""

import math

import numpy as np

from ._jit import jit

_MIX = (0x1E3779B97F4A7C15, 0x42B2AE3D27D4EB4F, 0x165667B19E3779F9)  # odd 63-bit mixers (int64 arithmetic wraps)


@jit
def first_occurrences(bits):
    """True for the first of each set of equal rows of ``bits`` (N, 3) int64 (the bit patterns of the
    coordinates, -0.0 turned into 0.0 beforehand): rows are hashed, the hashes sorted, equal hashes compared."""
    n = bits.shape[0]
    key = np.empty(n, np.int64)
    for i in range(n):
        h = bits[i, 0] * _MIX[0]
        h = (h ^ (h >> 29)) + bits[i, 1] * _MIX[1]
        h = (h ^ (h >> 31)) + bits[i, 2] * _MIX[2]
        key[i] = h ^ (h >> 32)
    order = np.argsort(key)
    keep = np.ones(n, np.bool_)
    i = 0
    while i < n:
        j = i + 1
        while j < n and key[order[j]] == key[order[i]]:
            j += 1
        for a in range(i, j):
            ia = order[a]
            if not keep[ia]:
                continue
            for b in range(i, j):
                ib = order[b]
                if ib > ia and keep[ib] and bits[ia, 0] == bits[ib, 0] and bits[ia, 1] == bits[ib, 1] \
                        and bits[ia, 2] == bits[ib, 2]:
                    keep[ib] = False  # a later copy
        i = j
    return keep


@jit
def bucket(cell, z, n_cells):
    """(cstart, cidx): the points by dexel (a counting sort), each dexel's points sorted by z."""
    n = cell.shape[0]
    cstart = np.zeros(n_cells + 1, np.int64)
    for i in range(n):
        cstart[cell[i] + 1] += 1
    for k in range(n_cells):
        cstart[k + 1] += cstart[k]
    fill = cstart[:-1].copy()
    cidx = np.empty(n, np.int64)
    for i in range(n):  # in input order: ties in z keep it
        cidx[fill[cell[i]]] = i
        fill[cell[i]] += 1
    for k in range(n_cells):
        lo, hi = cstart[k], cstart[k + 1]
        if hi - lo > 32:
            part = cidx[lo:hi].copy()
            cidx[lo:hi] = part[np.argsort(z[part], kind="mergesort")]
        else:
            for a in range(lo + 1, hi):  # insertion sort, stable
                q = cidx[a]
                b = a - 1
                while b >= lo and z[cidx[b]] > z[q]:
                    cidx[b + 1] = cidx[b]
                    b -= 1
                cidx[b + 1] = q
    return cstart, cidx


@jit
def nearest_distances(p, cstart, cidx, x0, y0, h, nx, ny, k=1):
    """Distance from each point to its k-th nearest other point (points distinct), searched ring by ring of
    dexels about its own until no nearer point can lie further out (inf when there are fewer)."""
    n = p.shape[0]
    out = np.empty(n)
    best = np.empty(k)  # the k smallest squared distances so far, ascending
    for i in range(n):
        px, py, pz = p[i, 0], p[i, 1], p[i, 2]
        col = min(nx - 1, int(math.floor((px - x0) / h)))
        row = min(ny - 1, int(math.floor((py - y0) / h)))
        best[:] = np.inf
        ring = 0
        while True:
            for r in range(max(0, row - ring), min(ny - 1, row + ring) + 1):
                edge_row = r == row - ring or r == row + ring
                step = 1 if edge_row else 2 * ring  # inner rows: only the two end dexels are on the ring
                c = col - ring
                while c <= col + ring:
                    if 0 <= c < nx:
                        cell = r * nx + c
                        for m in range(cstart[cell], cstart[cell + 1]):
                            q = cidx[m]
                            if q != i:
                                d = (p[q, 0] - px) ** 2 + (p[q, 1] - py) ** 2 + (p[q, 2] - pz) ** 2
                                if d < best[k - 1]:
                                    j = k - 1
                                    while j > 0 and best[j - 1] > d:
                                        best[j] = best[j - 1]
                                        j -= 1
                                    best[j] = d
                    c += step
            # every dexel further out is at least this far from the point in x-y
            reach = min(px - (x0 + (col - ring) * h), x0 + (col + ring + 1) * h - px,
                        py - (y0 + (row - ring) * h), y0 + (row + ring + 1) * h - py)
            if best[k - 1] <= reach * reach or (ring >= row and ring >= col and ring >= ny - 1 - row
                                                and ring >= nx - 1 - col):
                break
            ring += 1
        out[i] = math.sqrt(best[k - 1])
    return out
