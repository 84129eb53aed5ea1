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

from ._jit import jit

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


# -- expansions: arrays of non-overlapping doubles, increasing magnitude -----------------------
@jit
def _keep(out, n, h):
    """Append component h to out[:n] unless it is zero (zero elimination); return the new length."""
    if h != 0.0:
        out[n] = h
        n += 1
    return n


@jit
def _close(out, n, q):
    """Append the last (largest) component, keeping at least one; return the expansion."""
    if q != 0.0 or n == 0:
        out[n] = q
        n += 1
    return out[:n]


@jit
def _grow(e, b):
    """e + b exactly (Shewchuk's GROW-EXPANSION with zero elimination)."""
    out = np.empty(len(e) + 1)
    q = b
    n = 0
    for i in range(len(e)):
        q, h = _two_sum(q, e[i])
        n = _keep(out, n, h)
    return _close(out, n, q)


@jit
def _diff(a, b):
    """a - b exactly, as an expansion (of at most two terms)."""
    return _grow(np.array([a]), -b)


@jit
def _add(e, f):
    """e + f exactly."""
    h = e
    for j in range(len(f)):
        h = _grow(h, f[j])
    return h


@jit
def _scale(e, b):
    """e * b exactly (SCALE-EXPANSION with zero elimination)."""
    out = np.empty(2 * len(e))
    q, h = _two_product(e[0], b)
    n = _keep(out, 0, h)
    for i in range(1, len(e)):
        p1, p0 = _two_product(e[i], b)
        s, h = _two_sum(q, p0)
        n = _keep(out, n, h)
        q, h = _fast_two_sum(p1, s)
        n = _keep(out, n, h)
    return _close(out, n, q)


@jit
def _mul(e, f):
    """e * f exactly."""
    h = _scale(e, f[0])
    for j in range(1, len(f)):
        h = _add(h, _scale(e, f[j]))
    return h


@jit
def _sub(e, f):
    return _add(e, -f)


@jit
def _sign(e):
    """Sign of an expansion: that of its largest (last) component."""
    v = e[len(e) - 1]
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
    left = _mul(_diff(ax, cx), _diff(by, cy))
    right = _mul(_diff(ay, cy), _diff(bx, cx))
    return _sign(_sub(left, right))


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
    adx, ady = _diff(ax, dx), _diff(ay, dy)
    bdx, bdy = _diff(bx, dx), _diff(by, dy)
    cdx, cdy = _diff(cx, dx), _diff(cy, dy)
    bc = _sub(_mul(bdx, cdy), _mul(bdy, cdx))
    ca = _sub(_mul(cdx, ady), _mul(cdy, adx))
    ab = _sub(_mul(adx, bdy), _mul(ady, bdx))
    alift = _add(_mul(adx, adx), _mul(ady, ady))
    blift = _add(_mul(bdx, bdx), _mul(bdy, bdy))
    clift = _add(_mul(cdx, cdx), _mul(cdy, cdy))
    det = _add(_add(_mul(alift, bc), _mul(blift, ca)), _mul(clift, ab))
    return _sign(det)


@jit
def incircle(ax, ay, bx, by, cx, cy, dx, dy):
    """Positive when d is inside the circle through counter-clockwise a, b, c; sign always right."""
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
