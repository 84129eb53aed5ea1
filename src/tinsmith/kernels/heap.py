"""An indexed max-heap of items 0..N-1 with float64 keys (greedy insertion's triangles, decimation's vertices).

``q = (heap, qpos, key)``: ``heap[i]`` is the item at heap position ``i``,
``key[i]`` its key, ``qpos[item]`` its position or -1 when absent.  The size
lives in ``cnt[HEAP_SIZE]`` of the caller's counter array, so that a kernel
keeps all its counts in one array.
"""

from ._jit import jit_inline

#: Slot of the caller's ``cnt`` array that holds the heap size.
HEAP_SIZE = 3


# The keys live beside the heap entries, so that a sift compares neighbouring
# entries instead of chasing a per-triangle array.  A sift carries a hole
# down (or up) and writes the moving item once, at the end: the positions
# are those of swapping at every level (the same heap, the same ties), with
# half the writes.
@jit_inline
def _up(i, q):
    heap, qpos, key = q
    t, k = heap[i], key[i]
    while i > 0:
        parent = (i - 1) >> 1
        if k <= key[parent]:
            break
        u = heap[parent]
        heap[i] = u
        key[i] = key[parent]
        qpos[u] = i
        i = parent
    heap[i] = t
    key[i] = k
    qpos[t] = i


@jit_inline
def _down(i, n, q):
    """Sift the item at ``i`` down within the first ``n`` positions; True when it moved."""
    heap, qpos, key = q
    t, k = heap[i], key[i]
    start = i
    while True:
        left = 2 * i + 1
        if left >= n:
            break
        j = left
        if left + 1 < n and key[left + 1] > key[left]:
            j = left + 1
        if key[j] <= k:
            break
        u = heap[j]
        heap[i] = u
        key[i] = key[j]
        qpos[u] = i
        i = j
    heap[i] = t
    key[i] = k
    qpos[t] = i
    return i > start


@jit_inline
def heap_push(t, q, e, cnt):
    heap, qpos, key = q
    n = cnt[HEAP_SIZE]
    heap[n] = t
    key[n] = e
    qpos[t] = n
    cnt[HEAP_SIZE] = n + 1
    _up(n, q)


@jit_inline
def heap_update(t, q, e, cnt):
    """Set the key of ``t`` (which must be in the heap) to ``e`` and restore the heap."""
    i = q[1][t]
    q[2][i] = e
    if not _down(i, cnt[HEAP_SIZE], q):
        _up(i, q)


@jit_inline
def heap_remove(t, q, cnt):
    qpos = q[1]
    i = qpos[t]
    if i < 0:
        return
    n = cnt[HEAP_SIZE] - 1
    if i != n:  # the last item fills the gap
        heap, key = q[0], q[2]
        u = heap[n]
        heap[i] = u
        key[i] = key[n]
        qpos[u] = i
        if not _down(i, n, q):
            _up(i, q)
    qpos[t] = -1
    cnt[HEAP_SIZE] = n


@jit_inline
def heap_requeue(t, q, e, has_candidate, cnt):
    """Key ``t`` on ``e`` (pushing it when absent), or take it out when it has nothing left (``has_candidate`` False)."""
    if q[1][t] >= 0:
        if has_candidate:
            heap_update(t, q, e, cnt)
        else:
            heap_remove(t, q, cnt)
    elif has_candidate:
        heap_push(t, q, e, cnt)
