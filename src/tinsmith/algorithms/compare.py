"""Several methods on one heightfield under one stop rule, judged by one set of metrics.

The measured version of the Salt Lake City thesis' Table 2.1 (its comparison of subsampling,
quadtrees, feature methods, refinement and decimation): each method runs
with the same budget (``max_vertices``, ``max_triangles``) or the same error
bound (``max_error``), and every mesh is judged by :func:`tinsmith.mesh_metrics`
against the same cells.  A method without stop rules (``grid``, the
reference) runs as it is.
"""

from __future__ import annotations

import time

import numpy as np

from ..core import Heightfield, StopCriteria
from ..errors import InvalidInputError, InvalidOptionError, TinsmithError
from ..metrics import mesh_metrics
from .registry import get_method

__all__ = ["compare_methods"]

_FIELDS = ("n_vertices", "n_triangles", "max_error", "rmse", "coverage", "min_angle", "max_aspect_ratio", "time")


def compare_methods(hf: Heightfield, methods, *, max_error=None, max_vertices=None, max_triangles=None) -> list[dict]:
    """One row per method: counts, vertical error, 3-D triangle quality, coverage and run time.

    Parameters
    ----------
    hf : Heightfield
    methods : sequence of str
        Registered method names (see :func:`tinsmith.methods`).
    max_error, max_vertices, max_triangles
        The stop rule every method gets; exactly one must be given.

    Returns
    -------
    list of dict
        ``method``, ``n_vertices``, ``n_triangles``, ``max_error``, ``rmse``,
        ``coverage``, ``min_angle`` (degrees, the smallest of any triangle),
        ``max_aspect_ratio`` and ``time`` (seconds, the method alone: each
        method first runs once on a small grid of the same kind, so that
        loading its compiled kernels is not timed).  A method that cannot
        meet the rule on this input gets ``None`` in every field and the
        reason in ``error``.

    Examples
    --------
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> dem = tinsmith.Heightfield(hf.z[200:264, 100:164], cell_size=30.0, crs=hf.crs)  # a 64 x 64 window
    >>> rows = tinsmith.compare_methods(dem, ["greedy", "quadtree"], max_error=10.0)
    >>> [row["method"] for row in rows]
    ['greedy', 'quadtree']
    >>> all(row["max_error"] <= 10.0 and row["coverage"] == 1.0 for row in rows)
    True
    """
    rule = {k: v for k, v in dict(max_error=max_error, max_vertices=max_vertices, max_triangles=max_triangles).items()
            if v is not None}
    if len(rule) != 1:
        raise InvalidOptionError("compare needs exactly one stop rule: max_error, max_vertices or max_triangles")
    StopCriteria(**rule)  # the value is checked before any method runs
    names = list(methods)
    if not names:
        raise InvalidOptionError("compare needs at least one method")
    records = [get_method(name) for name in names]  # unknown names fail before any work
    rows = []
    for record in records:
        (key,) = rule
        if record.stop_rules and key not in record.stop_rules:  # e.g. cvt under max_error: said in its row
            rows.append({"method": record.name, **dict.fromkeys(_FIELDS),
                         "error": f"takes {record.describe_stop_rules()}, not {key}"})
            continue
        _warm_up(record, hf)
        kwargs = rule if record.stop_rules else {}
        start = time.perf_counter()
        try:
            mesh = record.function(hf, **kwargs)
        except InvalidInputError as exc:  # this method cannot meet the rule on this input
            rows.append({"method": record.name, **dict.fromkeys(_FIELDS), "error": str(exc)})
            continue
        elapsed = time.perf_counter() - start
        m = mesh_metrics(mesh, hf)
        err, q = m["vertical_error"], m["quality_3d"]
        rows.append({
            "method": record.name,
            "n_vertices": mesh.n_vertices,
            "n_triangles": mesh.n_triangles,
            "max_error": err["max"],
            "rmse": err["rmse"],
            "coverage": err["coverage"],
            "min_angle": q["min_angle"]["min"],
            "max_aspect_ratio": q["aspect_ratio"]["max"],
            "time": elapsed,
        })
    return rows


def _warm_up(record, hf: Heightfield) -> None:
    """Run a method once on a 24 x 24 grid with the heights' type and nodata of ``hf`` (loads its kernels)."""
    r, c = np.mgrid[0:24, 0:24]
    z = (np.sin(r / 3.0) * 10 + c).astype(hf.z.dtype)
    mask = np.zeros(z.shape, bool)
    if hf.nodata_mask.any():
        mask[:3, :3] = True
    try:
        budget = {"max_vertices": 50} if record.exact_budget else {}  # a method that needs its count
        record.function(Heightfield(z, cell_size=1.0, nodata_mask=mask), **budget)
    except TinsmithError:  # pragma: no cover - the warm-up only loads kernels
        pass
