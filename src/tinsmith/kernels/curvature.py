"""Discrete mean curvature of a triangle mesh (Meyer, Desbrun, Schroeder and Barr 2003).

At vertex ``i`` the mean curvature normal is

    K(i) = 1 / (2 A_mixed(i)) * sum over neighbours j of (cot a_ij + cot b_ij) (x_i - x_j)

with ``a_ij`` and ``b_ij`` the angles opposite edge ij, and ``A_mixed`` the
mixed area of the paper (section 3.3): the Voronoi area of the vertex in
each non-obtuse triangle, half the triangle's area when the angle at the
vertex is obtuse, a quarter when another angle is.  ``|K| = 2 |H|``.

Buffer layout: ``v`` float64 (N, 3), ``tri`` int64 (M, 3); outputs
float64 (N, 3) and (N,).
"""

import numpy as np

from ._jit import jit


@jit
def mean_curvature_normal(v, tri):
    """(K summed over the triangles, before the division by 2 A_mixed; A_mixed; the area-weighted normal) of every vertex."""
    n = v.shape[0]
    k = np.zeros((n, 3))
    area = np.zeros(n)
    normal = np.zeros((n, 3))
    e = np.empty((3, 3))  # e[c] = the edge opposite corner c, from the next corner to the one after
    cot = np.empty(3)
    for t in range(tri.shape[0]):
        ids = (tri[t, 0], tri[t, 1], tri[t, 2])
        for c in range(3):
            a, b = ids[(c + 1) % 3], ids[(c + 2) % 3]
            for d in range(3):
                e[c, d] = v[b, d] - v[a, d]
        cx = e[2, 1] * e[0, 2] - e[2, 2] * e[0, 1]  # (x1 - x0) x (x2 - x1): twice the area, along the normal
        cy = e[2, 2] * e[0, 0] - e[2, 0] * e[0, 2]
        cz = e[2, 0] * e[0, 1] - e[2, 1] * e[0, 0]
        twice = np.sqrt(cx * cx + cy * cy + cz * cz)
        if twice == 0.0:
            continue
        obtuse = -1
        for c in range(3):
            # the angle at corner c lies between x_c+1 - x_c = e[c+2] and x_c+2 - x_c = -e[c+1]
            u0, u1 = e[(c + 1) % 3], e[(c + 2) % 3]
            dot = -(u0[0] * u1[0] + u0[1] * u1[1] + u0[2] * u1[2])
            cot[c] = dot / twice
            if dot < 0.0:
                obtuse = c
        for c in range(3):
            i, j = ids[(c + 1) % 3], ids[(c + 2) % 3]  # the edge opposite corner c
            for d in range(3):
                diff = v[i, d] - v[j, d]
                k[i, d] += cot[c] * diff
                k[j, d] -= cot[c] * diff
        for c in range(3):
            i = ids[c]
            if obtuse < 0:
                # Voronoi area: (|x_c - x_c+1|^2 cot(angle at c+2) + |x_c - x_c+2|^2 cot(angle at c+1)) / 8
                near = e[(c + 2) % 3, 0] ** 2 + e[(c + 2) % 3, 1] ** 2 + e[(c + 2) % 3, 2] ** 2
                far = e[(c + 1) % 3, 0] ** 2 + e[(c + 1) % 3, 1] ** 2 + e[(c + 1) % 3, 2] ** 2
                area[i] += (near * cot[(c + 2) % 3] + far * cot[(c + 1) % 3]) / 8.0
            elif obtuse == c:
                area[i] += twice / 4.0
            else:
                area[i] += twice / 8.0
            normal[i, 0] += cx
            normal[i, 1] += cy
            normal[i, 2] += cz
    return k, area, normal
