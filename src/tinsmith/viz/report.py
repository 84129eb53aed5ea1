"""One self-contained HTML report that judges meshes against their DEM.

Everything is inside the file: figures as PNG data URLs, the metrics as a
table and as JSON (``<script type="application/json" id="metrics">``, the
same dictionaries as ``tinsmith metrics --json``), no script, no style
sheet or font from elsewhere, so it opens offline.
"""

from __future__ import annotations

import base64
import html
import io
import json
import platform
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from .._version import __version__
from ..core import Heightfield, TerrainMesh
from ..io import atomic_paths
from ..metrics import mesh_metrics
from .figures import (
    default_detail,
    figure_contours,
    figure_error,
    figure_hillshades,
    figure_quality,
    figure_wireframe,
    save,
)

__all__ = ["report_html", "write_report"]

_STYLE = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:1.5rem auto;max-width:1200px;color:#222}
h1{font-size:1.5rem}h2{font-size:1.2rem;margin-top:2rem;border-bottom:1px solid #ccc}
table{border-collapse:collapse;font-size:.85rem}td,th{border:1px solid #ccc;padding:.25rem .5rem;text-align:right}
th:first-child,td:first-child{text-align:left}img{max-width:100%;height:auto}
.row{display:flex;flex-wrap:wrap;gap:1rem}.row figure{margin:0}code{background:#f4f4f4;padding:0 .2rem}
"""

_COLUMNS = [
    ("vertices", lambda m: f"{m['n_vertices']:,}"),
    ("triangles", lambda m: f"{m['n_triangles']:,}"),
    ("max error", lambda m: _num(m["vertical_error"]["max"])),
    ("RMSE", lambda m: _num(m["vertical_error"]["rmse"])),
    ("mean |e|", lambda m: _num(m["vertical_error"]["mean_abs"])),
    ("bias", lambda m: _num(m["vertical_error"]["bias"])),
    ("p99", lambda m: _num(m["vertical_error"]["p99"])),
    ("coverage", lambda m: f"{100 * m['vertical_error']['coverage']:.2f}%"),
    ("min angle (3-D)", lambda m: _num(m["quality_3d"]["min_angle"]["min"])),
    ("median min angle", lambda m: _num(m["quality_3d"]["min_angle"]["median"])),
    ("max aspect ratio", lambda m: _num(m["quality_3d"]["aspect_ratio"]["max"])),
    ("angles < 20°", lambda m: f"{100 * m['quality_3d']['share_min_angle_below_20']:.1f}%"),
]


def _num(x) -> str:
    return "-" if x is None else f"{x:.4g}"


def _png(fig) -> str:
    buf = io.BytesIO()
    save(fig, buf)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _img(fig, alt: str) -> str:
    return f'<figure><img alt="{html.escape(alt)}" src="{_png(fig)}"></figure>'


def _versions() -> dict:
    import importlib.metadata as md

    out = {"tinsmith": __version__, "python": platform.python_version(), "platform": platform.platform()}
    for name in ("numpy", "numba", "scipy", "rasterio", "matplotlib"):
        try:
            out[name] = md.version(name)
        except md.PackageNotFoundError:  # pragma: no cover - all are dependencies of the viz extra or the core
            out[name] = "not installed"
    return out


def report_html(hf: Heightfield, meshes: dict[str, TerrainMesh], *, dem_name: str = "DEM",
                settings: dict | None = None, detail=None) -> tuple[str, dict]:
    """The report page and the metrics it shows (name -> :func:`tinsmith.mesh_metrics`).

    Parameters
    ----------
    hf : Heightfield
        The DEM every mesh is judged against.
    meshes : dict of str -> TerrainMesh
        Names (file names, method names) and meshes, in the order shown.
    settings : dict, optional
        How the meshes were made (method, options, commands), shown as JSON.
    detail : (xmin, ymin, xmax, ymax), optional
        World window of the wireframe close-ups; default the roughest part of the DEM.
    """
    metrics = {name: mesh_metrics(m, hf) for name, m in meshes.items()}
    first = next(iter(meshes.values()))
    detail = detail or default_detail(hf, first)
    head = "".join(f"<th>{html.escape(c)}</th>" for c, _ in _COLUMNS)
    rows = "".join(
        f"<tr><td>{html.escape(name)}</td>" + "".join(f"<td>{f(m)}</td>" for _, f in _COLUMNS) + "</tr>"
        for name, m in metrics.items()
    )
    h, w = hf.shape
    parts = [
        f"<h1>tinsmith report: {html.escape(dem_name)}</h1>",
        f"<p>{h:,} x {w:,} cells, {hf.n_valid:,} with data; cell {abs(hf.cell_size[0]):.4g} x "
        f"{abs(hf.cell_size[1]):.4g}; heights {hf.z_range[0]:.4g} to {hf.z_range[1]:.4g}. "
        "Errors are mesh minus DEM at the cell centres the mesh covers, in z units.</p>",
        "<h2>Metrics</h2>", f"<table><tr><th>mesh</th>{head}</tr>{rows}</table>",
        "<h2>Hillshades</h2>", _img(figure_hillshades(hf, meshes), "hillshades"),
        "<h2>Error maps</h2>",
        '<div class="row">' + "".join(_img(figure_error(m, hf, n), f"error of {n}") for n, m in meshes.items()) + "</div>",
        "<h2>Triangles in a detail</h2>",
        f"<p>Window x {detail[0]:.2f} to {detail[2]:.2f}, y {detail[1]:.2f} to {detail[3]:.2f}.</p>",
        '<div class="row">' + "".join(_img(figure_wireframe(m, hf, detail, n), f"wireframe of {n}")
                                      for n, m in meshes.items()) + "</div>",
        "<h2>Triangle quality</h2>", _img(figure_quality(meshes), "quality histograms"),
        "<h2>Contours</h2>",
        '<div class="row">' + "".join(_img(figure_contours(m, hf, n), f"contours of {n}") for n, m in meshes.items())
        + "</div>",
        "<h2>Settings and versions</h2>",
        "<pre>" + html.escape(json.dumps({"settings": settings or {}, "versions": _versions(),
                                          "made": datetime.now(UTC).isoformat(timespec="seconds")},
                                         indent=1, default=str)) + "</pre>",
    ]
    data = json.dumps(_plain(metrics)).replace("</", "<\\/")
    page = ("<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>tinsmith report: {html.escape(dem_name)}</title><style>{_STYLE}</style></head><body>"
            + "".join(parts)
            + f'<script type="application/json" id="metrics">{data}</script></body></html>')
    return page, metrics


def _plain(x):
    if isinstance(x, dict):
        return {k: _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, np.generic):
        return x.item()
    return x


def write_report(path, hf: Heightfield, meshes: dict[str, TerrainMesh], **kwargs) -> dict:
    """Write :func:`report_html` to ``path`` atomically; return the metrics shown."""
    page, metrics = report_html(hf, meshes, **kwargs)
    path = Path(path)
    with atomic_paths(path) as (tmp,):
        tmp.write_text(page, encoding="utf-8")
    return metrics
