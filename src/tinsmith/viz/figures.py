"""Pictures that judge a mesh against its DEM: hillshades, the error map, a wireframe, quality, contours.

Each ``figure_*`` function draws into a new matplotlib figure and returns it;
each ``plot_*`` writes that figure as a PNG (atomically) for docs and
notebooks.  :mod:`tinsmith.viz.report` puts them into one HTML page.  The
figures are drawn by Agg outside pyplot: making one neither chooses nor
switches matplotlib's backend (a notebook's stays as it is), and pyplot does
not keep it open.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from ..core import Heightfield, TerrainMesh
from ..errors import require
from ..io import atomic_paths
from ..metrics import rasterize
from ..metrics.quality import aspect_ratios, triangle_angles

__all__ = [
    "default_detail", "figure_contours", "figure_error", "figure_hillshades", "figure_quality", "figure_wireframe",
    "hillshade", "plot_contours", "plot_error", "plot_hillshades", "plot_quality", "plot_wireframe", "save",
]


def _figure(**kwargs):
    """A new :class:`matplotlib.figure.Figure` (``kwargs``: its size and layout) on an Agg canvas of its own."""
    require("matplotlib", "viz", "drawing figures")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(**kwargs)
    FigureCanvasAgg(fig)
    return fig


def hillshade(z: np.ndarray, cell: tuple[float, float], azimuth: float = 315.0, altitude: float = 45.0) -> np.ndarray:
    """Lambertian hillshade in 0..1 of a grid (NaN stays NaN); light from ``azimuth`` (degrees from north)."""
    dy, dx = np.gradient(np.asarray(z, np.float64), cell[1], cell[0])
    slope = np.arctan(np.hypot(dx, dy))
    aspect = np.arctan2(-dx, dy)  # rows run south
    az, alt = np.radians(360.0 - azimuth + 90.0), np.radians(altitude)
    return np.clip(np.sin(alt) * np.cos(slope) + np.cos(alt) * np.sin(slope) * np.cos(az - aspect), 0, 1)


def _extent(hf: Heightfield):
    xmin, ymin, xmax, ymax = hf.bounds
    return (xmin, xmax, ymin, ymax)


def default_detail(hf: Heightfield, mesh: TerrainMesh) -> tuple[float, float, float, float]:
    """A square window of about 30 mean edge lengths round the roughest part of the DEM."""
    z = np.where(hf.valid, hf.z, np.nan).astype(np.float64)
    gy, gx = np.gradient(z)  # NaN next to nodata: the outline of the data is not a slope
    slope = np.hypot(gx, gy)
    r, c = np.unravel_index(np.nanargmax(slope), hf.shape) if np.isfinite(slope).any() else (hf.shape[0] // 2, hf.shape[1] // 2)
    x, y = hf.pixel_to_world(r, c)
    v, t = mesh.vertices, mesh.triangles
    edge = float(np.median(np.linalg.norm(v[t[:, 0], :2] - v[t[:, 1], :2], axis=1))) if len(t) else 1.0
    xmin, ymin, xmax, ymax = hf.bounds
    half = min(15 * edge, (xmax - xmin) / 2, (ymax - ymin) / 2)
    x = min(max(float(x), xmin + half), xmax - half)
    y = min(max(float(y), ymin + half), ymax - half)
    return (x - half, y - half, x + half, y + half)


def figure_hillshades(hf: Heightfield, meshes: dict):
    """The DEM's hillshade beside each mesh's (the mesh rasterised on the DEM's grid)."""
    n = 1 + len(meshes)
    fig = _figure(figsize=(4.2 * n, 4.2), constrained_layout=True)
    axes = fig.subplots(1, n, squeeze=False)
    cell = tuple(abs(c) for c in hf.cell_size)
    panels = [("DEM", np.where(hf.valid, hf.z, np.nan))] + [(name, rasterize(m, hf)) for name, m in meshes.items()]
    for ax, (name, z) in zip(axes[0], panels, strict=True):
        ax.imshow(hillshade(z, cell), cmap="gray", extent=_extent(hf), vmin=0, vmax=1, interpolation="nearest")
        ax.set_title(name)
        _plain_axes(ax)
    return fig


def figure_error(mesh: TerrainMesh, hf: Heightfield, name: str = "mesh"):
    """Mesh minus DEM at every cell centre, diverging colours symmetric about zero, colour bar in z units."""
    err = rasterize(mesh, hf) - np.where(hf.valid, hf.z, np.nan)
    lim = float(np.nanmax(np.abs(err))) if np.isfinite(err).any() else 1.0
    fig = _figure(figsize=(5.6, 4.6), constrained_layout=True)
    ax = fig.subplots()
    im = ax.imshow(err, cmap="RdBu_r", vmin=-lim or -1, vmax=lim or 1, extent=_extent(hf), interpolation="nearest")
    fig.colorbar(im, ax=ax, shrink=0.85, label="mesh − DEM (z units)")
    ax.set_title(f"{name}: error, max |e| {lim:.3g}")
    _plain_axes(ax)
    return fig


def figure_wireframe(mesh: TerrainMesh, hf: Heightfield, window=None, name: str = "mesh"):
    """The mesh's edges over the DEM's hillshade in a zoomed window (world x-y)."""
    fig = _figure(figsize=(5.0, 5.0), constrained_layout=True)
    from matplotlib.tri import Triangulation

    window = window or default_detail(hf, mesh)
    ax = fig.subplots()
    cell = tuple(abs(c) for c in hf.cell_size)
    ax.imshow(hillshade(np.where(hf.valid, hf.z, np.nan), cell), cmap="gray", extent=_extent(hf), vmin=0, vmax=1,
              interpolation="nearest")
    v = mesh.vertices
    ax.triplot(Triangulation(v[:, 0], v[:, 1], mesh.triangles), color="tab:red", lw=0.5)
    ax.set_xlim(window[0], window[2])
    ax.set_ylim(window[1], window[3])
    ax.set_title(f"{name}: triangles in a detail")
    _plain_axes(ax)
    return fig


def figure_quality(meshes: dict):
    """Histograms of every mesh's smallest angles (degrees, 3-D) and aspect ratios."""
    fig = _figure(figsize=(10, 3.8), constrained_layout=True)
    a1, a2 = fig.subplots(1, 2)
    for name, m in meshes.items():
        if not m.n_triangles:
            continue
        a1.hist(triangle_angles(m, 3).min(axis=1), bins=60, range=(0, 60), histtype="step", lw=1.4, label=name)
        asp = aspect_ratios(m, 3)
        a2.hist(np.minimum(asp, 10), bins=60, range=(1, 10), histtype="step", lw=1.4, label=name)
    a1.set_xlabel("smallest angle (degrees)")
    a2.set_xlabel("aspect ratio (10: 10 or more)")
    for ax in (a1, a2):
        ax.set_ylabel("triangles")
        ax.legend(fontsize=8)
    return fig


def figure_contours(mesh: TerrainMesh, hf: Heightfield, name: str = "mesh", levels: int = 12):
    """Contour lines of the DEM (black) and of the mesh (red) at the same heights."""
    dem = np.where(hf.valid, hf.z, np.nan)
    tin = rasterize(mesh, hf)
    lo, hi = float(np.nanmin(dem)), float(np.nanmax(dem))
    heights = np.linspace(lo, hi, levels + 2)[1:-1]
    rows, cols = np.arange(hf.shape[0]), np.arange(hf.shape[1])
    X, Y = hf.pixel_to_world(rows[:, None] + 0 * cols[None, :], cols[None, :] + 0 * rows[:, None])
    fig = _figure(figsize=(5.6, 4.8), constrained_layout=True)
    ax = fig.subplots()
    ax.contour(X, Y, dem, levels=heights, colors="k", linewidths=0.7)
    ax.contour(X, Y, tin, levels=heights, colors="tab:red", linewidths=0.7)
    ax.set_title(f"{name}: contours, DEM black, mesh red")
    ax.set_aspect("equal")
    _plain_axes(ax)
    return fig


def _plain_axes(ax) -> None:
    ax.ticklabel_format(useOffset=False, style="plain")
    ax.tick_params(labelsize=7)


def save(fig, target) -> None:
    """Write ``fig`` as PNG to a path (atomically) or a binary file object, and close it."""
    if isinstance(target, (str, Path)):
        with atomic_paths(Path(target)) as (tmp,):
            fig.savefig(tmp, dpi=100, format="png")
    else:
        fig.savefig(target, dpi=100, format="png")
    pyplot = sys.modules.get("matplotlib.pyplot")  # a figure the caller made with pyplot; ours are not in it
    if pyplot is not None:
        pyplot.close(fig)


def plot_hillshades(hf: Heightfield, meshes: dict, path) -> Path:
    """PNG of :func:`figure_hillshades`."""
    save(figure_hillshades(hf, meshes), path)
    return Path(path)


def plot_error(mesh: TerrainMesh, hf: Heightfield, path, name: str = "mesh") -> Path:
    """PNG of :func:`figure_error`."""
    save(figure_error(mesh, hf, name), path)
    return Path(path)


def plot_wireframe(mesh: TerrainMesh, hf: Heightfield, path, window=None, name: str = "mesh") -> Path:
    """PNG of :func:`figure_wireframe`."""
    save(figure_wireframe(mesh, hf, window, name), path)
    return Path(path)


def plot_quality(meshes: dict, path) -> Path:
    """PNG of :func:`figure_quality`."""
    save(figure_quality(meshes), path)
    return Path(path)


def plot_contours(mesh: TerrainMesh, hf: Heightfield, path, name: str = "mesh") -> Path:
    """PNG of :func:`figure_contours`."""
    save(figure_contours(mesh, hf, name), path)
    return Path(path)
