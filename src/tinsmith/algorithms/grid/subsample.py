"""Regular subsampling: every ``step``-th row and column of the grid, triangulated (the Salt Lake City thesis, section 2.1).

The simplest level of detail and the baseline of the Salt Lake City thesis' comparison of
methods (Table 2.1).  Rows 0, step, 2 step, ... are kept, and always the last
row, likewise the columns, so the extent of the data is kept; the coarse
lattice is triangulated as the full-resolution grid is (Goebbels and Pohle-Fröhlich (2015)'s diagonal
rule, one triangle where a corner is nodata, none where two are).  It is
fast and blind to the terrain: a peak between two kept rows is cut off, and
a hole narrower than the step is bridged.

Without ``step`` the stop rule chooses it: the finest step whose mesh fits
``max_vertices`` / ``max_triangles``, or the coarsest step of the pyramid
1, 2, 4, ... whose measured vertical error meets ``max_error``.
"""

from __future__ import annotations

import numpy as np

from ... import _checks
from ...core import Heightfield, StopCriteria, TerrainMesh
from ...errors import InvalidInputError, InvalidOptionError
from ...metrics import vertical_error
from ...triangulation.grid import lattice_mesh
from ..registry import register

__all__ = ["subsample", "subsample_pyramid"]


def kept(n: int, step: int) -> np.ndarray:
    """The kept indices of an axis of ``n`` cells: 0, step, 2 step, ... and ``n - 1``."""
    return np.unique(np.r_[np.arange(0, n, step), n - 1])


def subsample_mesh(hf: Heightfield, step: int) -> TerrainMesh:
    """The mesh of every ``step``-th row and column of ``hf`` (and the last ones)."""
    h, w = hf.shape
    mesh = lattice_mesh(hf, kept(h, step), kept(w, step))
    mesh.info["step"] = step
    return mesh


def _counts(hf: Heightfield, step: int) -> tuple[int, int]:
    """(vertices, triangles) of :func:`subsample_mesh` without building it."""
    h, w = hf.shape
    valid = hf.valid[np.ix_(kept(h, step), kept(w, step))]
    corners = (
        valid[:-1, :-1].astype(np.int8) + valid[:-1, 1:] + valid[1:, :-1] + valid[1:, 1:]
    )
    return int(valid.sum()), int(2 * np.count_nonzero(corners == 4) + np.count_nonzero(corners == 3))


def _coarsest(hf: Heightfield) -> int:
    """The step beyond which the lattice no longer changes (first and last rows and columns only)."""
    return max(max(hf.shape) - 1, 1)


def _step_for_counts(hf: Heightfield, stop: StopCriteria) -> int:
    """The finest step whose mesh fits the count rules."""
    limit_v = stop.max_vertices if stop.max_vertices is not None else np.inf
    limit_t = stop.max_triangles if stop.max_triangles is not None else np.inf

    def fits(step):
        v, t = _counts(hf, step)
        return t > 0 and stop.counts_fit(v, t)

    # the vertex count falls roughly as 1 / step**2: start near the answer
    step = max(1, int(np.sqrt(hf.n_valid / min(limit_v, limit_t / 2.0 + 1.0))))
    while step > 1 and fits(step - 1):
        step -= 1
    while not fits(step):
        if step >= _coarsest(hf):
            v, t = _counts(hf, step)
            raise InvalidInputError(
                f"the coarsest subsampling has {v} vertices and {t} triangles, "
                f"more than max_vertices={stop.max_vertices} / max_triangles={stop.max_triangles} allow"
            )
        step += 1
    return step


def _step_for_error(hf: Heightfield, max_error: float) -> tuple[int, TerrainMesh]:
    """The coarsest step of the pyramid 1, 2, 4, ... whose mesh's measured error is at most ``max_error``."""
    steps = [1]
    while steps[-1] < _coarsest(hf):
        steps.append(steps[-1] * 2)
    for step in reversed(steps):
        if _counts(hf, step)[1] == 0:
            continue
        mesh = subsample_mesh(hf, step)
        err = vertical_error(mesh, hf)["max"]
        if err <= max_error:
            mesh.info["error"] = {"max": err}
            return step, mesh
    raise AssertionError("step 1 reproduces every valid cell")  # pragma: no cover


@register("subsample")
def subsample(hf: Heightfield, *, step, stop: StopCriteria, progress=None) -> TerrainMesh:
    """Keep every ``step``-th row and column (and the last ones) and triangulate the coarse lattice.

    ``step`` and the stop rules are alternatives: with ``max_vertices`` or
    ``max_triangles`` the finest step that fits is taken, with
    ``max_error`` the coarsest step of 1, 2, 4, ... whose measured vertical
    error meets it (cells the coarse mesh does not cover, next to holes,
    are not counted).  The step used is ``mesh.info["step"]``.

    Examples
    --------
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> dem = tinsmith.Heightfield(hf.z[200:264, 100:164], cell_size=30.0, crs=hf.crs)  # a 64 x 64 window
    >>> mesh = tinsmith.subsample(dem, step=4)  # rows and columns 0, 4, ..., 60 and the last, 63
    >>> mesh.n_vertices, mesh.info["step"]
    (289, 4)
    >>> coarse = tinsmith.subsample(dem, max_vertices=300)  # the finest step that fits
    >>> coarse.n_vertices <= 300
    True
    """
    if step is not None and stop.is_set:
        raise InvalidOptionError("give either step or a stop rule (max_error, max_vertices, max_triangles), not both")
    if step is not None:
        return subsample_mesh(hf, step)
    if stop.max_error is not None:
        step_e, mesh = _step_for_error(hf, stop.max_error)
        if stop.max_vertices is None and stop.max_triangles is None:
            return mesh
        step = max(step_e, _step_for_counts(hf, stop))  # the first rule reached wins
        return mesh if step == step_e else subsample_mesh(hf, step)
    if stop.is_set:
        return subsample_mesh(hf, _step_for_counts(hf, stop))
    return subsample_mesh(hf, 2)


def subsample_pyramid(hf: Heightfield, levels: int = 4) -> list[TerrainMesh]:
    """Meshes at steps 1, 2, 4, ..., 2**(levels - 1): a pyramid of levels of detail, finest first.

    Examples
    --------
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> dem = tinsmith.Heightfield(hf.z[200:264, 100:164], cell_size=30.0, crs=hf.crs)  # a 64 x 64 window
    >>> levels = tinsmith.subsample_pyramid(dem, levels=3)
    >>> [mesh.n_vertices for mesh in levels]  # steps 1, 2 and 4
    [4096, 1089, 289]
    """
    levels = _checks.integer("levels", levels, minimum=1)
    return [subsample(hf, step=2**k) for k in range(levels)]
