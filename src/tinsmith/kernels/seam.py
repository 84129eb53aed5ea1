"""1-D simplification of a height profile within a vertical error bound (the tile seams).

The profile between two kept samples is the straight line through them; a
sample off that line by more than the bound splits the span at its worst
sample (Douglas-Peucker with the vertical distance, which keeps the same
samples as 1-D greedy insertion: each span's decision depends on that span
alone).
"""

import numpy as np

from ._jit import jit


@jit
def simplify_profile(z, valid, keep, bound, pos):
    """Mark in ``keep`` (uint8, in place) the samples that hold ``z`` within ``bound`` between kept ones.

    ``pos`` are the samples' increasing positions along the profile (the
    cell index on a raster side).  ``keep`` comes in with the forced samples
    set (both ends among them); every span between two consecutive forced
    samples whose samples are all ``valid`` is split at its worst sample until
    each sample lies within ``bound`` of the line through its span's ends
    (spans over missing samples are left alone).  Returns the largest
    remaining error.
    """
    n = len(z)
    starts = np.empty(n, np.int64)
    ends = np.empty(n, np.int64)
    top = 0
    prev = -1
    run = 0  # valid samples in a row, up to i
    for i in range(n):
        run = run + 1 if valid[i] else 0
        if keep[i]:
            if prev >= 0 and i - prev > 1 and run > i - prev:
                starts[top] = prev
                ends[top] = i
                top += 1
            prev = i
    worst_all = 0.0
    while top > 0:
        top -= 1
        a = starts[top]
        b = ends[top]
        za = z[a]
        dz = z[b] - za
        span = pos[b] - pos[a]
        worst = -1.0
        at = -1
        for k in range(a + 1, b):
            e = abs(za + dz * ((pos[k] - pos[a]) / span) - z[k])
            if e > worst:
                worst = e
                at = k
        if worst > bound:
            keep[at] = 1
            starts[top] = a
            ends[top] = at
            top += 1
            starts[top] = at
            ends[top] = b
            top += 1
        elif worst > worst_all:
            worst_all = worst
    return worst_all
