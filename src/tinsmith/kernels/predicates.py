"""Robust geometric predicates: orientation and in-circle tests that are never wrong.

Both follow Shewchuk (1997), "Adaptive precision floating-point arithmetic and
fast robust geometric predicates": a floating-point evaluation with a
forward error bound answers almost every call; only when the bound cannot
certify the sign is the determinant evaluated exactly with floating-point
expansions (sums of non-overlapping doubles), which is slow but rare.

A DEM grid is full of exactly collinear and cocircular points, whose
determinants are exactly zero and so always fail the filter.  For them a
second, cheap certificate applies: when every coordinate is a whole number
and all pairwise differences are below 2**12, every product and sum of
the floating-point evaluation is exact (the in-circle terms stay below
12 * 4096**4 < 2**53), so its sign, zero included, is the true
one.

Like Shewchuk's, they assume that no product underflows (coordinate
differences far above 1e-150), which holds for any geographic data.

Conventions: ``orient2d(a, b, c) > 0`` when a, b, c turn counter-clockwise in
a frame with y pointing up (so in pixel space (col, row), with rows pointing
down, it means clockwise on screen); ``incircle(a, b, c, d) > 0`` when d lies
inside the circle through a, b, c given counter-clockwise.  Only the sign of
the returned value is meaningful.
"""

import numpy as np

from ._jit import jit, jit_inline, stack_buffer

_EPS = 2.0**-53
_SPLITTER = 134217729.0  # 2**27 + 1
_CCW_BOUND = (3.0 + 16.0 * _EPS) * _EPS
_ICC_BOUND = (10.0 + 96.0 * _EPS) * _EPS
_SMALL_INT = 2048.0  # |coordinate - first| < 2048: pairwise differences < 4096


# -- error-free transformations ------------------------------------------------------------
@jit
def _two_sum(a, b):
    x = a + b
    bv = x - a
    av = x - bv
    return x, (a - av) + (b - bv)


@jit
def _fast_two_sum(a, b):  # |a| >= |b|
    x = a + b
    return x, b - (x - a)


@jit
def _split(a):
    c = _SPLITTER * a
    hi = c - (c - a)
    return hi, a - hi


@jit
def _two_product(a, b):
    x = a * b
    ahi, alo = _split(a)
    bhi, blo = _split(b)
    err = x - ahi * bhi - alo * bhi - ahi * blo
    return x, alo * blo - err


# -- expansions: non-overlapping doubles in increasing magnitude, h[:n] of a buffer ----------------
# Every function writes into buffers its caller provides (in the caller's
# stack frame, see stack_buffer) and returns the new length, so the exact
# predicates allocate nothing and can run in kernels compiled without
# reference counting.
@jit
def _keep(out, k, x):
    """Append component x to out[:k] unless it is zero (zero elimination); return the new length."""
    if x != 0.0:
        out[k] = x
        k += 1
    return k


@jit
def _close(out, k, q):
    """Append the last (largest) component, keeping at least one; return the length."""
    if q != 0.0 or k == 0:
        out[k] = q
        k += 1
    return k


@jit
def _grow(h, n, b):
    """h[:n] + b exactly, in place (Shewchuk's GROW-EXPANSION with zero elimination); h needs n + 1 slots."""
    q = b
    k = 0
    for i in range(n):  # writes h[k] with k <= i after reading h[i]
        q, x = _two_sum(q, h[i])
        k = _keep(h, k, x)
    return _close(h, k, q)


@jit
def _diff(out, a, b):
    """a - b exactly into out (2 slots); return the length."""
    out[0] = a
    return _grow(out, 1, -b)


@jit
def _add(h, n, f, m):
    """h[:n] + f[:m] exactly, in place; h needs n + m slots."""
    for j in range(m):
        n = _grow(h, n, f[j])
    return n


@jit
def _scale(out, e, n, b):
    """e[:n] * b exactly into out (SCALE-EXPANSION with zero elimination); out needs 2n slots."""
    q, x = _two_product(e[0], b)
    k = _keep(out, 0, x)
    for i in range(1, n):
        p1, p0 = _two_product(e[i], b)
        s, x = _two_sum(q, p0)
        k = _keep(out, k, x)
        q, x = _fast_two_sum(p1, s)
        k = _keep(out, k, x)
    return _close(out, k, q)


@jit
def _mul(out, e, n, f, m, tmp):
    """e[:n] * f[:m] exactly into out (2nm slots), with tmp (2n slots) as scratch."""
    k = _scale(out, e, n, f[0])
    for j in range(1, m):
        k = _add(out, k, tmp, _scale(tmp, e, n, f[j]))
    return k


@jit
def _cross(out, a, na, b, nb, c, nc, d, nd, tmp):
    """a*b - c*d exactly into out (2 na nb + 2 nc nd slots); tmp needs 2 max(na, nc) + 2 nc nd slots."""
    k = _mul(out, a, na, b, nb, tmp)
    other = tmp[2 * max(na, nc):]
    m = _mul(other, c, nc, d, nd, tmp)
    for i in range(m):
        other[i] = -other[i]
    return _add(out, k, other, m)


@jit
def _sign(h, n):
    """Sign of an expansion: that of its largest (last) component."""
    v = h[n - 1]
    return 1.0 if v > 0.0 else (-1.0 if v < 0.0 else 0.0)


@jit
def _small_ints(values):
    """True when all values are whole numbers within _SMALL_INT of the first one."""
    base = values[0]
    for v in values:
        if v != np.floor(v) or abs(v - base) >= _SMALL_INT:
            return False
    return True


# -- predicates ---------------------------------------------------------------------------------
@jit
def orient2d_exact(ax, ay, bx, by, cx, cy):
    """Sign of orient2d by exact arithmetic (+1, -1 or 0)."""
    buf = stack_buffer(48)
    acx, bcy, acy, bcx = buf[0:2], buf[2:4], buf[4:6], buf[6:8]
    n1, n2 = _diff(acx, ax, cx), _diff(bcy, by, cy)
    n3, n4 = _diff(acy, ay, cy), _diff(bcx, bx, cx)
    det = buf[8:24]
    return _sign(det, _cross(det, acx, n1, bcy, n2, acy, n3, bcx, n4, buf[24:48]))


@jit
def orient2d(ax, ay, bx, by, cx, cy):
    """Twice the signed area of (a, b, c); its sign is always right."""
    left = (ax - cx) * (by - cy)
    right = (ay - cy) * (bx - cx)
    det = left - right
    if left > 0.0:
        if right <= 0.0:
            return det
        total = left + right
    elif left < 0.0:
        if right >= 0.0:
            return det
        total = -left - right
    else:
        # left is exactly zero (a difference of floats is zero only when they are equal)
        return det
    if abs(det) >= _CCW_BOUND * total:
        return det
    if _small_ints((ax, bx, cx)) and _small_ints((ay, by, cy)):
        return det
    return orient2d_exact(ax, ay, bx, by, cx, cy)


@jit
def incircle_exact(ax, ay, bx, by, cx, cy, dx, dy):
    """Sign of incircle by exact arithmetic (+1, -1 or 0)."""
    buf = stack_buffer(2224)
    # the six differences, 2 terms each
    d = buf[0:12]
    na, nay = _diff(d[0:2], ax, dx), _diff(d[2:4], ay, dy)
    nb, nby = _diff(d[4:6], bx, dx), _diff(d[6:8], by, dy)
    nc, ncy = _diff(d[8:10], cx, dx), _diff(d[10:12], cy, dy)
    adx, ady, bdx, bdy, cdx, cdy = d[0:2], d[2:4], d[4:6], d[6:8], d[8:10], d[10:12]
    tmp = buf[12:48]
    # the 2 x 2 minors and the lifts, 16 terms each at most
    bc, ca, ab = buf[48:64], buf[64:80], buf[80:96]
    n_bc = _cross(bc, bdx, nb, cdy, ncy, bdy, nby, cdx, nc, tmp)
    n_ca = _cross(ca, cdx, nc, ady, nay, cdy, ncy, adx, na, tmp)
    n_ab = _cross(ab, adx, na, bdy, nby, ady, nay, bdx, nb, tmp)
    alift, blift, clift = buf[96:112], buf[112:128], buf[128:144]
    lift = tmp[20:28]
    n_al = _add(alift, _mul(alift, adx, na, adx, na, tmp), lift, _mul(lift, ady, nay, ady, nay, tmp))
    n_bl = _add(blift, _mul(blift, bdx, nb, bdx, nb, tmp), lift, _mul(lift, bdy, nby, bdy, nby, tmp))
    n_cl = _add(clift, _mul(clift, cdx, nc, cdx, nc, tmp), lift, _mul(lift, cdy, ncy, cdy, ncy, tmp))
    # the three products, 512 terms each at most, summed into the first
    det, term, scratch = buf[144:1680], buf[1680:2192], buf[2192:2224]
    n = _mul(det, alift, n_al, bc, n_bc, scratch)
    n = _add(det, n, term, _mul(term, blift, n_bl, ca, n_ca, scratch))
    n = _add(det, n, term, _mul(term, clift, n_cl, ab, n_ab, scratch))
    return _sign(det, n)


@jit_inline
def incircle_inline(ax, ay, bx, by, cx, cy, dx, dy):
    """:func:`incircle` inlined into the caller: the call costs more than the filter's arithmetic."""
    adx, ady = ax - dx, ay - dy
    bdx, bdy = bx - dx, by - dy
    cdx, cdy = cx - dx, cy - dy
    bdxcdy, cdxbdy = bdx * cdy, cdx * bdy
    cdxady, adxcdy = cdx * ady, adx * cdy
    adxbdy, bdxady = adx * bdy, bdx * ady
    alift = adx * adx + ady * ady
    blift = bdx * bdx + bdy * bdy
    clift = cdx * cdx + cdy * cdy
    det = alift * (bdxcdy - cdxbdy) + blift * (cdxady - adxcdy) + clift * (adxbdy - bdxady)
    permanent = (
        (abs(bdxcdy) + abs(cdxbdy)) * alift + (abs(cdxady) + abs(adxcdy)) * blift + (abs(adxbdy) + abs(bdxady)) * clift
    )
    if abs(det) > _ICC_BOUND * permanent:
        return det
    if _small_ints((ax, bx, cx, dx)) and _small_ints((ay, by, cy, dy)):
        return det
    return incircle_exact(ax, ay, bx, by, cx, cy, dx, dy)


@jit_inline
def incircle_small_ints(ax, ay, bx, by, cx, cy, dx, dy):
    """:func:`incircle` for whole numbers whose pairwise differences are at most D = 2**12 (the caller knows).

    There the plain evaluation is exact, so its sign, zero included, is the
    true one, and the filter's bound, which :func:`incircle_inline` computes
    on every call, is not needed: each lift and each 2 x 2 minor is a whole
    number of at most 2 D**2 = 2**25, each product at most 2**50, their sum
    below 2**52.  Greedy insertion on a grid of at most 4097 cells a side
    tests its Lawson flips with this.
    """
    adx, ady = ax - dx, ay - dy
    bdx, bdy = bx - dx, by - dy
    cdx, cdy = cx - dx, cy - dy
    alift = adx * adx + ady * ady
    blift = bdx * bdx + bdy * bdy
    clift = cdx * cdx + cdy * cdy
    return alift * (bdx * cdy - cdx * bdy) + blift * (cdx * ady - adx * cdy) + clift * (adx * bdy - bdx * ady)


@jit_inline
def orient2d_small_ints(ax, ay, bx, by, cx, cy):
    """:func:`orient2d` for whole-number coordinates whose pairwise differences are at most 2**12: exact as it is."""
    return (ax - cx) * (by - cy) - (ay - cy) * (bx - cx)


@jit
def incircle(ax, ay, bx, by, cx, cy, dx, dy):
    """Positive when d is inside the circle through counter-clockwise a, b, c; sign always right."""
    return incircle_inline(ax, ay, bx, by, cx, cy, dx, dy)


@jit_inline
def _lex_after(ax, ay, bx, by):
    """True when point a comes after point b in x-then-y order."""
    return ax > bx or (ax == bx and ay > by)


@jit_inline
def incircle_perturbed(ax, ay, bx, by, cx, cy, dx, dy):
    """:func:`incircle` with its zero broken by a symbolic perturbation: never 0 for four distinct points.

    The perturbation of Devillers and Teillaud (2011, "Perturbations for
    Delaunay and weighted Delaunay 3D triangulations", section 3; CGAL's
    ``Delaunay_triangulation_2::side_of_oriented_circle`` with ``perturb``)
    lifts each point by an infinitesimal that grows with its place in x-then-y
    order.  Where d is exactly on the circle through counter-clockwise a, b, c,
    the sign is that of the leading term of the perturbed determinant: the
    orientation of the triangle whose corner is replaced by d, taken for the
    last of the four points in that order, then the one before (two steps
    always decide), and outside when d itself comes last.  With it the
    Delaunay triangulation of a point set is unique whatever the order of
    insertion, cocircular points (grids, quantised LiDAR) included, so a
    triangulation made in parts can be the sequential one exactly.
    """
    det = incircle_inline(ax, ay, bx, by, cx, cy, dx, dy)
    if det != 0.0:
        return det
    # the four points from the last in x-then-y order: a (0), b (1), c (2) or d (3)
    xs = (ax, bx, cx, dx)
    ys = (ay, by, cy, dy)
    done0 = done1 = done2 = done3 = False
    for _ in range(2):
        last = -1
        lx = ly = 0.0
        for k in range(4):
            if (k == 0 and done0) or (k == 1 and done1) or (k == 2 and done2) or (k == 3 and done3):
                continue
            if last < 0 or _lex_after(xs[k], ys[k], lx, ly):
                last, lx, ly = k, xs[k], ys[k]
        if last == 3:
            return -1.0
        if last == 2:
            o = orient2d(ax, ay, bx, by, dx, dy)
            done2 = True
        elif last == 1:
            o = orient2d(ax, ay, dx, dy, cx, cy)
            done1 = True
        else:
            o = orient2d(dx, dy, bx, by, cx, cy)
            done0 = True
        if o != 0.0:
            return o
    return -1.0
