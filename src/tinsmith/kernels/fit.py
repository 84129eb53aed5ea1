"""Kernels of the height fit (:mod:`tinsmith.algorithms.cvt.fit`): products with the normal equations of the
cell-by-vertex matrix of barycentric weights, matrix-free."""

from ._jit import jit


@jit
def normal_product(tri, owner_flat, bary_flat, cells, z, out, reg):
    """out = (A^T A + reg I) z, with A the cell-by-vertex matrix of barycentric weights."""
    for v in range(len(out)):
        out[v] = reg * z[v]
    for k in range(len(cells)):
        i = cells[k]
        t = owner_flat[i]
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        s = bary_flat[i, 0] * z[a] + bary_flat[i, 1] * z[b] + bary_flat[i, 2] * z[c]
        out[a] += bary_flat[i, 0] * s
        out[b] += bary_flat[i, 1] * s
        out[c] += bary_flat[i, 2] * s


@jit
def right_side(tri, owner_flat, bary_flat, cells, target, z0, reg):
    """A^T target + reg z0, with A the cell-by-vertex matrix of barycentric weights."""
    out = reg * z0.copy()
    for k in range(len(cells)):
        i = cells[k]
        t = owner_flat[i]
        for m in range(3):
            out[tri[t, m]] += bary_flat[i, m] * target[k]
    return out
