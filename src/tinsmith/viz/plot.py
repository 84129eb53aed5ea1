"""Top views of a mesh: shaded heights over the whole extent, and the triangles of a window."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core import TerrainMesh
from ..errors import require
from ..io import atomic_paths

__all__ = ["plot_mesh"]


def plot_mesh(mesh: TerrainMesh, path, *, window=None, title: str | None = None, dpi: int = 110) -> Path:
    """Write a PNG: the mesh coloured by height, and a close-up of its triangles.

    Parameters
    ----------
    mesh : TerrainMesh
    path : str or Path
        Output PNG (written atomically).
    window : (xmin, ymin, xmax, ymax), optional
        World window of the close-up; default a square of about 40 mean edge
        lengths around the centre of the mesh.
    title : str, optional
    dpi : int
    """
    require("matplotlib", "viz", "plotting meshes")
    # An Agg canvas of its own, outside pyplot: the caller's backend (a notebook's) is never switched.
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle
    from matplotlib.tri import Triangulation

    v, t = mesh.vertices, mesh.triangles
    tri = Triangulation(v[:, 0], v[:, 1], t)
    xmin, ymin, _, xmax, ymax, _ = mesh.bounds
    if window is None:
        edge = np.median(np.linalg.norm(v[t[:, 0], :2] - v[t[:, 1], :2], axis=1))
        cx, cy = (xmin + xmax) / 2, (ymin + ymax) / 2
        half = min(20 * edge, (xmax - xmin) / 2, (ymax - ymin) / 2)
        window = (cx - half, cy - half, cx + half, cy + half)

    fig = Figure(figsize=(11, 5.2), constrained_layout=True)
    FigureCanvasAgg(fig)
    ax1, ax2 = fig.subplots(1, 2)
    shade = ax1.tripcolor(tri, v[:, 2], shading="gouraud", cmap="terrain")
    ax1.add_patch(
        Rectangle(window[:2], window[2] - window[0], window[3] - window[1], fill=False, ec="k", lw=1.2)
    )
    ax1.set_title(f"{mesh.n_vertices:,} vertices, {mesh.n_triangles:,} triangles")
    fig.colorbar(shade, ax=ax1, shrink=0.8, label="z")
    ax2.tripcolor(tri, v[:, 2], shading="gouraud", cmap="terrain")
    ax2.triplot(tri, color="k", lw=0.4)
    ax2.set_xlim(window[0], window[2])
    ax2.set_ylim(window[1], window[3])
    ax2.set_title("triangles in the framed window")
    for ax in (ax1, ax2):
        ax.set_aspect("equal")
        ax.ticklabel_format(useOffset=False, style="plain")
        ax.tick_params(labelsize=7)
    if title:
        fig.suptitle(title)
    path = Path(path)
    with atomic_paths(path) as (temp,):
        fig.savefig(temp, dpi=dpi, format="png")
    return path
