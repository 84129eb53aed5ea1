"""Projection-based surface reconstruction of point clouds in linear time (Gopi and Krishnan 2002, Gopi and Krishnan 2002).

``tinsmith.reconstruct(points)`` meshes an unorganised point cloud (a LiDAR
tile, a scan) without gridding it first.  The points are bucketed in a 2-D
*dexel* array (orthographic projection on the x-y plane, each dexel's
points sorted by height), so every neighbour search is a look at a few
dexels.

* ``mode="heightfield"`` (section 5.1): a fixed dexel grid keeps one
  representative per dexel (the highest point: the surface first seen from
  above), so ``dexel_size`` is the level of simplification; neighbours come
  only from adjacent dexels, and since every neighbour is visible, the
  visibility and angle tests are skipped.  Each 2 x 2 block of occupied
  dexels becomes two triangles (the Delaunay diagonal), three occupied
  dexels one: linear time, a planar triangulation by construction.
* ``mode="general"``: the full algorithm for surfaces that fold over
  (see :mod:`tinsmith.algorithms.reconstruct.projection`).
* ``mode="auto"``: heightfield when fewer than half of the occupied dexels
  (at the default size) hold points more than three dexels apart in
  height, general otherwise (a closed surface puts two layers over most
  dexels).
"""

from __future__ import annotations

import warnings

import numpy as np

from ... import _checks
from ...core import PointCloud, TerrainMesh
from ...core.pointcloud import class_codes
from ...errors import InvalidInputError, InvalidOptionError, TinsmithWarning
from ...io.crs import describe, is_geographic, reproject_hint
from ...kernels.dexel import dexel_triangles
from ..registry import register
from .projection import dexel_grid, general_mesh

__all__ = ["reconstruct"]

MODES = ("auto", "heightfield", "general")
VIEWS = ("any", "above")


def _enough(xyz: np.ndarray) -> None:
    if len(xyz) < 3:
        raise InvalidInputError(f"reconstruct needs at least 3 points, got {len(xyz)}")
    if not np.isfinite(xyz).all():
        raise InvalidInputError("points must be finite; found NaN or infinite coordinates")


def _cloud(points, classes) -> PointCloud:
    """The input as a PointCloud, class filter applied, checked for what any mesh needs."""
    if isinstance(points, PointCloud):
        cloud = points
    else:
        xyz = np.asarray(points, dtype=np.float64) if not isinstance(points, str) else None
        if xyz is None or xyz.ndim != 2 or xyz.shape[1] != 3:
            raise InvalidInputError(
                f"points must be a PointCloud or an (N, 3) array of x, y, z, got {getattr(xyz, 'shape', type(points).__name__)}"
            )
        if classes is not None:
            raise InvalidOptionError("classes needs a PointCloud with a classification (read it from a LAS/LAZ file)")
        _enough(xyz)  # before PointCloud, whose own errors say less
        cloud = PointCloud(xyz)
    codes = class_codes(classes)
    if codes is not None:
        cloud = cloud.filter_classes(codes)
    xyz = cloud.xyz
    _enough(xyz)
    n = len(xyz)
    centred = xyz - xyz.mean(axis=0)
    spread = np.linalg.svd(centred[:: max(1, n // 200_000)], compute_uv=False)
    scale = max(float(np.abs(centred).max()), np.finfo(float).tiny)
    if spread[0] <= 1e-12 * scale:
        raise InvalidInputError(f"all {n} points are at the same place; nothing to mesh")
    if spread[1] <= 1e-9 * spread[0]:
        raise InvalidInputError(f"all {n} points lie on one line; nothing to mesh")
    return cloud


def _dexel_size(cloud: PointCloud, dexel_size) -> float:
    if dexel_size is None:
        return cloud.default_cell_size()
    return _checks.number("dexel_size", dexel_size, minimum=0.0, exclusive_min=True)


def layered_share(cloud: PointCloud, size: float) -> float:
    """Share of the occupied dexels whose points are more than three dexels apart in height."""
    rows, cols, (ny, nx), _ = dexel_grid(cloud.xyz[:, :2], size)
    cell = rows * nx + cols
    z = cloud.xyz[:, 2]
    occupied = np.unique(cell)
    lo = np.full(ny * nx, np.inf)
    hi = np.full(ny * nx, -np.inf)
    np.minimum.at(lo, cell, z)
    np.maximum.at(hi, cell, z)
    return float(np.mean(hi[occupied] - lo[occupied] > 3.0 * size))


def heightfield_mesh(cloud: PointCloud, size: float) -> TerrainMesh:
    """Section 5.1: the highest point of each dexel, joined to the representatives of the adjacent dexels."""
    xyz = cloud.xyz
    rows, cols, (ny, nx), _ = dexel_grid(xyz[:, :2], size)
    cell = rows * nx + cols
    order = np.lexsort((-xyz[:, 2], cell))  # by dexel, highest first
    first = np.r_[True, cell[order][1:] != cell[order][:-1]]
    keep = order[first]  # one representative per dexel, in dexel order
    rep = np.full(ny * nx, -1, np.int64)
    rep[cell[keep]] = np.arange(len(keep))
    pts = xyz[keep]
    tri = dexel_triangles(rep.reshape(ny, nx), np.ascontiguousarray(pts[:, 0]), np.ascontiguousarray(pts[:, 1]))
    if len(tri) == 0:
        raise InvalidInputError(
            f"no two adjacent dexels of size {size:g} hold points, so nothing joins; choose a larger dexel_size"
        )
    used, tri = np.unique(tri, return_inverse=True)
    mesh = TerrainMesh(pts[used], tri.reshape(-1, 3), crs=cloud.crs)
    mesh.info["reconstruct"] = {"mode": "heightfield", "dexel_size": size, "points_in": len(xyz),
                                "dexels": ny * nx, "representatives": len(keep)}
    return mesh


@register("reconstruct")
def reconstruct(cloud: PointCloud, *, mode, mu, max_angle, min_angle, dexel_size, view, workers, progress=None,
                classes=None) -> TerrainMesh:
    """Mesh a point cloud in one pass (Gopi and Krishnan 2002): every vertex an input point, no stop rule.

    ``data`` is a :class:`PointCloud` or an (N, 3) array of x, y, z.
    ``mesh.info["reconstruct"]`` records the mode and counts.  ``classes``
    is deprecated: keep the classes when reading
    (``tinsmith.read(path, classes=[2])``) or with
    :meth:`PointCloud.filter_classes`.

    Examples
    --------
    >>> import tinsmith
    >>> from tinsmith import shapes
    >>> sphere = tinsmith.reconstruct(shapes.sphere_points(400, radius=10.0))  # a closed surface: general mode
    >>> sphere.info["reconstruct"]["mode"], sphere.n_vertices
    ('general', 400)
    >>> len(sphere.boundary_edges())  # closed: no border
    0
    >>> scene = tinsmith.reconstruct(shapes.box_scene(), mode="heightfield", dexel_size=2.0)
    >>> scene.n_vertices <= 41 * 41  # one point per 2 m dexel of the 80 x 80 m scene
    True
    """
    if progress is not None:
        progress(0.0)
    mesh = _reconstruct(cloud, mode=mode, mu=mu, max_angle=max_angle, min_angle=min_angle, dexel_size=dexel_size,
                        classes=classes, view=view, workers=workers)
    if progress is not None:
        progress(1.0)
    return mesh


def _reconstruct(points, *, mode: str = "auto", mu: float = 2.5, max_angle: float = 120.0, min_angle: float = 10.0,
                 dexel_size=None, classes=None, view: str = "any", workers=None) -> TerrainMesh:
    """The reconstruction of a point cloud (what :func:`reconstruct` runs).

    Parameters
    ----------
    points : PointCloud or (N, 3) array_like
        The cloud (world coordinates).
    mode : {"auto", "heightfield", "general"}
        See the module docstring.
    mu : float
        Locally uniform sampling: a point's neighbours lie within ``mu`` times
        its distance to its second-nearest point (general mode).
    max_angle : float
        Degrees; consecutive neighbours further apart than this around a point
        leave a gap (a border or hole), general mode.
    min_angle : float
        Degrees; neighbours that would make a smaller angle are dropped where
        that traps no point (general mode; 0 turns it off).
    dexel_size : float, optional
        Dexel width in world units; in heightfield mode the level of
        simplification (one point per dexel).  Default: twice the mean point
        spacing, rounded (:meth:`PointCloud.default_cell_size`).
    classes : int or sequence of int, optional
        ASPRS classes to keep (a PointCloud with classification only).
    view : {"any", "above"}
        General mode: "above" for an airborne scan, whose sensor saw every
        surface from above: while the surfaces grow no triangle may face
        more than 17 degrees below the horizon, so the front cannot wrap
        round a roof edge or an eave and turn the roof beyond upside down
        (the fold of section 8.1); a last pass over the points left on a
        border then closes the gaps between the finished surfaces (an
        eave's underside) with the paper's rules.  "any" (default) keeps
        the paper's rules throughout, for closed and folded surfaces.
    workers : int, optional
        Threads for general mode (default: every core).  Clouds of 200,000
        points or more are meshed in strips (one per 100,000 points, at
        most 8, from the cloud alone), so the mesh is the same on any
        number of workers.

    Returns
    -------
    TerrainMesh
        Interpolating: every vertex is an input point.  ``info["reconstruct"]``
        records the mode and counts.
    """
    mode = _checks.choice("mode", mode, MODES)
    mu = _checks.number("mu", mu, minimum=1.0, exclusive_min=True)
    max_angle = _checks.number("max_angle", max_angle, minimum=60.0, maximum=180.0)
    min_angle = _checks.number("min_angle", min_angle, minimum=0.0, maximum=59.0)
    view = _checks.choice("view", view, VIEWS)
    workers = _checks.workers(workers)
    cloud = _cloud(points, classes)
    if is_geographic(cloud.crs):  # nothing blows up (sizes come from the spacing), but the shape means little
        xmin, ymin, _, xmax, ymax, _ = cloud.bounds
        warnings.warn(
            f"the CRS {describe(cloud.crs)} is geographic: x and y are degrees while heights are not, so the surface "
            f"stands nearly upright and its shape, the mode chosen and every length mix units; "
            f"{reproject_hint((xmin, ymin, xmax, ymax))}",
            TinsmithWarning, stacklevel=4)  # the caller of the registry's public function
    size = _dexel_size(cloud, dexel_size)
    if mode == "auto":
        mode = "heightfield" if layered_share(cloud, size) < 0.5 else "general"
    if mode == "heightfield":
        xy = cloud.xyz[:, :2]
        if np.linalg.svd(xy - xy.mean(axis=0), compute_uv=False)[1] <= 1e-9 * np.ptp(xy, axis=0).max():
            raise InvalidInputError("the points' x-y positions lie on one line; a heightfield mesh needs an area")
        return heightfield_mesh(cloud, size)
    return general_mesh(cloud, mu=mu, max_angle=max_angle, min_angle=min_angle, dexel_size=size, view=view,
                        workers=workers)
