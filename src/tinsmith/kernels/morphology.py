"""Grey-scale morphology on grids: running minimum and maximum over square windows, linear time.

A square window is separable: a running extreme along the rows, then
along the columns.  Each 1-D pass keeps a monotone deque of indices, so its
cost does not depend on the window.  NaN (nodata) never wins: it is
treated as +inf for a minimum and -inf for a maximum, and a window of
nodata only gives NaN.
"""

import numpy as np

from ._jit import jit


@jit
def _running_1d(values, half, take_min, out, deque):
    """Extreme of ``values[i - half : i + half + 1]`` for every ``i`` (clipped at the ends), into ``out``."""
    n = len(values)
    head = tail = 0
    nxt = 0
    for i in range(n):
        hi = min(n - 1, i + half)
        while nxt <= hi:
            v = values[nxt]
            if v == v:  # not NaN
                while tail > head:
                    last = values[deque[tail - 1]]
                    if (last >= v) if take_min else (last <= v):
                        tail -= 1
                    else:
                        break
                deque[tail] = nxt
                tail += 1
            nxt += 1
        while tail > head and deque[head] < i - half:
            head += 1
        out[i] = values[deque[head]] if tail > head else np.nan


@jit
def _along_rows(z, half, take_min):
    h, w = z.shape
    out = np.empty((h, w))
    deque = np.empty(w, np.int64)
    for i in range(h):
        _running_1d(z[i], half, take_min, out[i], deque)
    return out


def running_extreme(z, half, take_min):
    """(H, W) float64: the minimum (``take_min``) or maximum of ``z`` over the (2 half + 1)-square window of each cell."""
    rows = _along_rows(np.ascontiguousarray(z, dtype=np.float64), half, take_min)
    return np.ascontiguousarray(_along_rows(np.ascontiguousarray(rows.T), half, take_min).T)
