"""Metrics that judge any mesh against any heightfield."""

from __future__ import annotations

from .. import _lazy
from ..core import Heightfield, TerrainMesh

# the measures of the submodules, imported on first use (numba and scipy load only when needed): see __init__.pyi
__getattr__, __dir__, __all__ = _lazy.attach(__name__, __file__)


def mesh_metrics(mesh: TerrainMesh, hf: Heightfield | None = None) -> dict:
    """Counts, triangle quality in 3-D and 2-D, and (with ``hf``) the vertical error.

    Returns
    -------
    dict
        ``n_vertices``, ``n_triangles``, ``quality_3d``, ``quality_2d`` and,
        when ``hf`` is given, ``vertical_error`` (see :func:`vertical_error`).

    Examples
    --------
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> dem = tinsmith.Heightfield(hf.z[200:264, 100:164], cell_size=30.0, crs=hf.crs)  # a 64 x 64 window
    >>> report = tinsmith.mesh_metrics(tinsmith.greedy(dem, max_error=10.0), dem)
    >>> sorted(report)
    ['n_triangles', 'n_vertices', 'quality_2d', 'quality_3d', 'vertical_error']
    >>> report["vertical_error"]["max"] <= 10.0
    True
    """
    from .quality import triangle_quality
    from .vertical import vertical_error

    out = {
        "n_vertices": mesh.n_vertices,
        "n_triangles": mesh.n_triangles,
        "quality_3d": triangle_quality(mesh, 3),
        "quality_2d": triangle_quality(mesh, 2),
    }
    if hf is not None:
        out["vertical_error"] = vertical_error(mesh, hf)
    return out

