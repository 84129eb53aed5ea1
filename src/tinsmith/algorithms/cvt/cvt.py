"""Curvature centroidal Voronoi tessellation (cCVT): quasi-uniform, terrain-adaptive TINs (Duan et al. 2016, Algorithm 2).

The sites are laid out and then moved, again and again, to the centroids
of their cells under a density built from the DEM's mean curvature
(:func:`~tinsmith.algorithms.cvt.curvature.curvature_density`), until the CVT
energy ``E = sum_i integral_{cell_i} rho |p - v_i|^2`` stops falling:

1. **Sites** (Algorithm 2, step 2).  The outline of the data is cut into
   *runs* between fixed corners (sharp turns with long arms, and any fixed
   point on the outline); the *boundary sites* slide along their run, in
   order, and never leave it.  Control points, breakline points and
   *anchors* (``anchor_fraction`` of the budget: greedy insertion's first
   insertions at least half a spacing inside the outline, the error-driven
   feature points) never move.  The free sites start at peaks, pits and
   saddles (thinned to the local spacing) and at cells drawn with
   probability ``sqrt(rho)`` (the density of sites in a 2-D CVT), from the
   ``seed``.
2. **Iteration** (steps 3-4).  Constrained Delaunay triangulation of the
   sites (:func:`~tinsmith.triangulation.delaunay.delaunay`; chords between
   consecutive boundary sites and the breaklines are the constraints, and
   triangles outside the chords are dropped); the barycentric dual cell of
   each site as its approximate Voronoi cell; each cell clipped exactly
   against the DEM's triangles (:mod:`tinsmith.kernels.cvt`) for its mass,
   centroid and energy; free sites move to their centroid; boundary sites
   take a 1-D Lloyd step along their run, with the density that spaces
   them like the sites inside (as Alliez et al. (2003) treats its backbones); heights
   are the DEM's at the site (vertical projection onto the DEM surface).
   It stops when the relative energy change is below ``tol`` or after
   ``max_iter`` iterations.
3. **Acceleration.**  Plain Lloyd converges linearly (the paper needed about
   140 iterations).  The default is L-BFGS on the energy (Liu et al. 2009,
   "On centroidal Voronoi tessellation - energy smoothness and fast
   computation"), with the inverse masses as the initial Hessian;
   ``"anderson"`` mixes the Lloyd map (type II, window 5).  Either is
   safeguarded as in Peng et al. 2018: an accelerated step is kept only if
   the energy falls, else the plain Lloyd step is taken and the history is
   cleared.

Coordinates are pixels (x = col, y = row); lengths, spacings and the energy
use the cell size in world units, so non-square cells are handled.
"""

from __future__ import annotations

import math
from itertools import pairwise

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from ...core import Heightfield, StopCriteria, TerrainMesh
from ...errors import InvalidInputError, InvalidOptionError
from ...kernels import cvt as kc
from ...triangulation.breaklines import breakline_segments, snap_to_cells
from ...triangulation.delaunay import delaunay
from ...triangulation.grid import diagonal_rule, filled
from ...triangulation.outline import boundary_segments, signed_area
from ..greedy.engine import GreedyEngine
from ..registry import register
from .curvature import curvature_density

__all__ = ["cvt", "CVTState"]

FREE, SLIDE, FIXED = 0, 1, 2
_WINDOW = 5  # Anderson history length


def _loops(valid: np.ndarray) -> list[np.ndarray]:
    """The outline of the data as closed loops of (row, col) vertices (straight runs merged)."""
    segs = boundary_segments(valid)
    if len(segs) == 0:
        return []
    key = {}
    for k, (a, b) in enumerate(segs.tolist()):
        key.setdefault(tuple(a), []).append(k)
        key.setdefault(tuple(b), []).append(k)
    used = np.zeros(len(segs), bool)
    loops = []
    for start in range(len(segs)):
        if used[start]:
            continue
        used[start] = True
        first, cur = tuple(segs[start, 0]), tuple(segs[start, 1])
        loop = [first]
        while cur != first:
            loop.append(cur)
            nxt = [k for k in key[cur] if not used[k]]
            if not nxt:  # pragma: no cover - the outline is a union of closed loops
                break
            k = nxt[0]
            used[k] = True
            a, b = tuple(segs[k, 0]), tuple(segs[k, 1])
            cur = b if a == cur else a
        loops.append(np.array(loop, np.float64))
    return loops


class CVTState:
    """The sites of a cCVT run and the machinery to triangulate and move them.

    Built by :func:`cvt`; exposed for tests and the benchmarks (energy per
    iteration, every iteration's mesh).
    """

    def __init__(self, hf: Heightfield, *, n_sites: int, density_gamma: float, density_floor: float,
                 anchor_fraction: float, control_points, breaklines, seed: int):
        self.hf = hf
        h, w = hf.shape
        if h < 2 or w < 2:
            raise InvalidInputError(f"cvt needs at least 2 x 2 cells, got {h} x {w}")
        self.sx, self.sy = hf.cell_size
        self.valid = hf.valid
        self.rho = curvature_density(hf, gamma=density_gamma, floor=density_floor)
        self.main = diagonal_rule(hf.z)
        # heights everywhere for the projection: nodata takes its nearest cell's height
        self.z = np.ascontiguousarray(filled(hf))
        self.rng = np.random.default_rng(seed)
        self.n_sites = n_sites
        self._spacing(n_sites)
        fixed_rc, self.constraint_pairs = self._user_fixed(control_points, breaklines)
        n_anchor = int(round(anchor_fraction * n_sites))
        anchors = self._anchors(n_anchor, fixed_rc) if n_anchor else np.empty((0, 2))
        self.n_anchors = len(anchors)
        self._layout(np.vstack([fixed_rc, anchors])[:, ::-1])

    # -- layout -------------------------------------------------------------------------
    def _spacing(self, n: int) -> None:
        """Target spacing of the sites (world units) per cell: sites per area proportional to sqrt(rho)."""
        root = np.sqrt(np.where(self.valid, self.rho, 0.0))
        cell_area = self.sx * self.sy
        per_area = n * root / (root.sum() * cell_area)  # sites per world area
        with np.errstate(divide="ignore"):
            self.spacing = np.sqrt(2.0 / (math.sqrt(3.0) * per_area))  # equilateral lattice
        self.mean_spacing = math.sqrt(2.0 * self.valid.sum() * cell_area / (math.sqrt(3.0) * n))
        self.root = root

    def _local_spacing(self, x, y) -> np.ndarray:
        h, w = self.valid.shape
        r = np.clip(np.rint(y).astype(int), 0, h - 1)
        c = np.clip(np.rint(x).astype(int), 0, w - 1)
        s = self.spacing[r, c]
        return np.where(np.isfinite(s), s, self.mean_spacing)

    def _user_fixed(self, control_points, breaklines):
        """(K, 2) (row, col) of fixed user points, and constraint index pairs over them."""
        pts = []
        pairs = []
        if control_points is not None:
            cp = snap_to_cells(self.hf, "control_points", control_points)
            pts += [tuple(map(float, p)) for p in cp.tolist()]
        if breaklines is not None:
            segs = breakline_segments(self.hf, breaklines)
            index = {}

            def node(p):
                if p not in index:
                    index[p] = len(pts)
                    pts.append(p)
                return index[p]

            for r0, c0, r1, c1 in segs.tolist():
                a, b = (float(r0), float(c0)), (float(r1), float(c1))
                length = math.hypot((r1 - r0) * self.sy, (c1 - c0) * self.sx)
                mid = self._local_spacing(np.array([(c0 + c1) / 2]), np.array([(r0 + r1) / 2]))[0]
                pieces = max(1, int(round(length / mid)))
                ids = [node(a)]
                for k in range(1, pieces):  # points on the segment, fixed, so it stays an edge
                    f = k / pieces
                    ids.append(node((r0 + f * (r1 - r0), c0 + f * (c1 - c0))))
                ids.append(node(b))
                pairs += list(pairwise(ids))
        rc = np.array(pts, np.float64).reshape(-1, 2)
        # the same cell named twice (a control point on a breakline) is one site
        rc, inverse = np.unique(rc, axis=0, return_inverse=True)
        pairs = inverse.ravel()[np.asarray(pairs, np.int64).reshape(-1, 2)] if pairs else np.empty((0, 2), np.int64)
        return rc, pairs

    def _anchors(self, n: int, taken: np.ndarray) -> np.ndarray:
        """(K, 2) (row, col) of greedy insertion's first ``n`` insertions at least half a spacing inside the outline.

        Insertions on or next to the outline are skipped: the sliding
        boundary sites follow the border, and a still point beside them
        would make slivers.
        """
        engine = GreedyEngine(self.hf)
        before = engine.to_mesh().vertices
        r0, c0 = self.hf.world_to_pixel(before[:, 0], before[:, 1])
        old = set(map(tuple, np.rint(np.column_stack([r0, c0])).tolist())) | set(map(tuple, taken.tolist()))
        depth = ndimage.distance_transform_edt(np.pad(self.valid, 1))[1:-1, 1:-1] - 1.0  # cells to the outline
        cell = math.sqrt(self.sx * self.sy)
        out = []
        ask = n
        while len(out) < n:
            start = engine.n_vertices
            engine.refine(max_vertices=start + ask)
            after = engine.to_mesh().vertices  # in insertion order
            rows, cols = self.hf.world_to_pixel(after[:, 0], after[:, 1])
            rc = np.rint(np.column_stack([rows, cols])).astype(np.int64)
            deep = depth[rc[:, 0], rc[:, 1]] * cell >= 0.5 * self._local_spacing(rc[:, 1], rc[:, 0])
            out = [p for p, ok in zip(rc.tolist(), deep, strict=True) if ok and tuple(p) not in old][:n]
            if engine.n_vertices == start:  # nothing left to insert
                break
            ask = n - len(out)
        return np.array(out, np.float64).reshape(-1, 2)

    def _layout(self, fixed_xy: np.ndarray) -> None:
        """Boundary runs and sites, fixed sites, then free sites up to the budget."""
        x, y, kind, run, s = [], [], [], [], []
        n_fixed = len(fixed_xy)
        x += fixed_xy[:, 0].tolist()
        y += fixed_xy[:, 1].tolist()
        kind += [FIXED] * n_fixed
        run += [-1] * n_fixed
        s += [0.0] * n_fixed
        self.runs = []  # per run: (rx, ry, cum) in world units, and its 1-D density moments (t, L0, L1)
        self.run_sites = []  # per run: its sliding sites in order
        self.loops = []  # per loop: the site indices in order around it
        # islands of data and holes smaller than about two sites are not traced (the mesh covers such holes
        # and leaves such islands out); the largest loop always is
        loops = _loops(self.valid)
        areas = [abs(self._loop_area(lp)) for lp in loops]
        loops = [lp for lp, a in zip(loops, areas, strict=True) if a >= 2.0 * self.mean_spacing**2 or a == max(areas)]
        fixed_set = {(round(p[1], 9), round(p[0], 9)): k for k, p in enumerate(fixed_xy.tolist())}
        near = self._near_edge(fixed_xy[:, 1], fixed_xy[:, 0])
        loops = [self._with_points_on(lp, fixed_xy[near, ::-1]) for lp in loops]
        plans = [(lp, self._corners(lp, fixed_set)) for lp in loops]
        new_corners = {(round(lp[a, 0], 9), round(lp[a, 1], 9)) for lp, corners in plans for a in corners}
        # at most half of what the fixed sites leave goes to the boundary
        budget_slide = max(0, (self.n_sites - n_fixed - len(new_corners - set(fixed_set))) // 2)
        # each run's geometry, and how many sliding sites it wants from the spacing along it
        geometry = [[self._run_geometry(lp[np.arange(a, b + 1) % len(lp)])
                     for a, b in pairwise([*corners, corners[0] + len(lp)])] for lp, corners in plans]
        total_want = sum(max(0.0, g[3][-1] - 1.0) for runs in geometry for g in runs)
        scale = min(1.0, budget_slide / total_want) if total_want else 1.0
        for (lp, corners), runs in zip(plans, geometry, strict=True):
            order = []
            for a, (rx, ry, cum, density, t_samples, l0, l1) in zip(corners, runs, strict=True):
                # the corner at the start of the run: an existing fixed point or a new one
                key = (round(lp[a % len(lp), 0], 9), round(lp[a % len(lp), 1], 9))
                if key not in fixed_set:
                    fixed_set[key] = len(x)
                    x.append(lp[a % len(lp), 1])
                    y.append(lp[a % len(lp), 0])
                    kind.append(FIXED)
                    run.append(-1)
                    s.append(0.0)
                order.append(fixed_set[key])
                m = int(max(0.0, density[-1] - 1.0) * scale + 0.5)
                sites = []
                if m > 0:
                    targets = (np.arange(m) + 1.0) / (m + 1.0) * density[-1]
                    for t in np.interp(targets, density, cum):
                        px, py = self._at(rx, ry, cum, t)
                        sites.append(len(x))
                        x.append(px / self.sx)
                        y.append(py / self.sy)
                        kind.append(SLIDE)
                        run.append(len(self.runs))
                        s.append(t)
                self.runs.append((rx, ry, cum, t_samples, l0, l1))
                self.run_sites.append(np.array(sites, np.int64))
                order += sites
            self.loops.append(np.array(order, np.int64))
        n_free = self.n_sites - len(x)
        if n_free < 0 or len(x) + n_free < 3:
            raise InvalidOptionError(
                f"the vertex budget ({self.n_sites}) is below the {len(x)} sites that must be kept "
                "(corners of the data, control points, breakline points, anchors); ask for more vertices"
            )
        self.chords = np.concatenate(
            [np.column_stack([lp, np.roll(lp, -1)]) for lp in self.loops if len(lp) >= 3]
        ) if self.loops else np.empty((0, 2), np.int64)
        self.constraints = np.concatenate([self.chords, self.constraint_pairs]).astype(np.int64)
        fx, fy = self._free_sites(n_free, np.array(x, np.float64), np.array(y, np.float64))
        self.x = np.ascontiguousarray(np.r_[np.array(x, np.float64), fx])
        self.y = np.ascontiguousarray(np.r_[np.array(y, np.float64), fy])
        self.kind = np.r_[np.array(kind, np.int8), np.full(len(fx), FREE, np.int8)]
        self.site_run = np.r_[np.array(run, np.int64), np.full(len(fx), -1, np.int64)]
        self.s = np.r_[np.array(s, np.float64), np.zeros(len(fx))]

    def inside(self, x, y, px, py) -> np.ndarray:
        """True where pixel points (px, py) lie on the data and inside the outline chords of the sites (x, y)."""
        ok = kc.covered_points(px, py, self.valid)
        if len(self.chords):
            c = self.chords
            seg = np.column_stack([x[c[:, 0]], y[c[:, 0]], x[c[:, 1]], y[c[:, 1]]])
            ok &= kc.inside_loops(px, py, seg)
        return ok

    def _near_edge(self, x, y) -> np.ndarray:
        """True for pixel points within a cell of the edge of the data: the only ones that can lie on the outline."""
        edge = self.valid & ~ndimage.binary_erosion(self.valid, np.ones((3, 3), bool), border_value=0)
        h, w = edge.shape
        r0 = np.clip(np.floor(y).astype(int), 0, h - 1)
        c0 = np.clip(np.floor(x).astype(int), 0, w - 1)
        r1, c1 = np.minimum(r0 + 1, h - 1), np.minimum(c0 + 1, w - 1)
        return edge[r0, c0] | edge[r1, c0] | edge[r0, c1] | edge[r1, c1]

    @staticmethod
    def _with_points_on(lp: np.ndarray, rc: np.ndarray) -> np.ndarray:
        """The loop with the points ``rc`` (row, col) that lie on its segments (not at its vertices) inserted."""
        a, d = lp, np.roll(lp, -1, axis=0) - lp
        extra = [[] for _ in range(len(lp))]
        for p in rc:
            rel = p - a
            t = (rel * d).sum(axis=1) / (d * d).sum(axis=1)
            on = (np.abs(d[:, 0] * rel[:, 1] - d[:, 1] * rel[:, 0]) < 1e-9) & (t > 1e-12) & (t < 1.0 - 1e-12)
            for k in np.flatnonzero(on).tolist():
                extra[k].append((t[k], p))
        if not any(extra):
            return lp
        out = []
        for k in range(len(lp)):
            out.append(lp[k])
            out += [p for _, p in sorted(extra[k], key=lambda e: e[0])]
        return np.array(out)

    def _loop_area(self, lp: np.ndarray) -> float:
        """Signed area (world units) of a loop of (row, col) vertices."""
        return signed_area(lp[:, ::-1]) * self.sx * self.sy

    def _corners(self, lp: np.ndarray, fixed_set: dict) -> list[int]:
        """Indices into ``lp`` where runs start: sharp turns with long arms, fixed points on it; at least three."""
        n = len(lp)
        nxt = np.roll(lp, -1, axis=0) - lp
        prv = lp - np.roll(lp, 1, axis=0)
        lens_n = np.hypot(nxt[:, 0] * self.sy, nxt[:, 1] * self.sx)
        lens_p = np.hypot(prv[:, 0] * self.sy, prv[:, 1] * self.sx)
        cos = (nxt[:, 0] * prv[:, 0] * self.sy**2 + nxt[:, 1] * prv[:, 1] * self.sx**2) / (lens_n * lens_p)
        local = self._local_spacing(lp[:, 1], lp[:, 0])
        sharp = (cos < math.cos(math.radians(30.0))) & (np.minimum(lens_n, lens_p) >= 0.5 * local)
        on_loop = np.array([(round(p[0], 9), round(p[1], 9)) in fixed_set for p in lp.tolist()])
        idx = sorted(set(np.flatnonzero(sharp | on_loop).tolist()))
        if len(idx) < 3:  # a smooth loop: three corners spread along it, the sharpest turn first
            cum = np.r_[0.0, np.cumsum(lens_n)]
            first = int(np.argmin(cos))
            shift = (cum - cum[first]) % cum[-1]
            picks = {first}
            for t in (cum[-1] / 3.0, 2.0 * cum[-1] / 3.0):
                picks.add(int(np.argmin(np.abs(shift[:n] - t))))
            idx = sorted(set(idx) | picks)
        return idx

    def _run_geometry(self, poly: np.ndarray):
        """(rx, ry, cum, density, t, L0, L1) of a run: its polyline in world units and cumulative lengths; the
        cumulative count of local spacings at its vertices; arc lengths every half cell and the cumulative
        integrals of the 1-D density ``lambda = spacing^-3`` and of ``lambda t``.

        A 1-D CVT places points with density proportional to ``lambda^(1/3)``,
        so this ``lambda`` spaces boundary sites at the target spacing.
        """
        rx, ry = poly[:, 1] * self.sx, poly[:, 0] * self.sy
        cum = np.r_[0.0, np.cumsum(np.hypot(np.diff(rx), np.diff(ry)))]
        n = max(2, int(math.ceil(cum[-1] / (0.5 * min(self.sx, self.sy)))) + 1)
        t = np.linspace(0.0, cum[-1], n)
        inv = 1.0 / self._local_spacing(np.interp(t, cum, poly[:, 1]), np.interp(t, cum, poly[:, 0]))
        density = np.interp(cum, t, _cumulative(t, inv))
        lam = inv**3
        return rx, ry, cum, density, t, _cumulative(t, lam), _cumulative(t, lam * t)

    @staticmethod
    def _at(rx, ry, cum, t):
        k = min(max(int(np.searchsorted(cum, t, side="right")) - 1, 0), len(cum) - 2)
        length = cum[k + 1] - cum[k]
        f = 0.0 if length == 0 else (t - cum[k]) / length
        return rx[k] + f * (rx[k + 1] - rx[k]), ry[k] + f * (ry[k + 1] - ry[k])

    def _free_sites(self, n: int, x: np.ndarray, y: np.ndarray):
        """Peaks, pits and saddles thinned to the local spacing, then cells drawn with probability sqrt(rho).

        ``x``, ``y``: the sites laid out so far (the boundary and fixed ones).
        """
        if n == 0:
            return np.empty(0), np.empty(0)
        fr, fc = self._critical_points(max(0, n // 5))
        weights = self.root.ravel() / self.root.sum()
        h, w = self.valid.shape
        taken = cKDTree(np.column_stack([x * self.sx, y * self.sy])) if len(x) else None
        xs, ys = [], []
        px, py = fc.astype(float), fr.astype(float)
        for attempt in range(40):
            ok = self.inside(x, y, px, py)
            if taken is not None and attempt < 20:  # keep clear of the sites that stay put, while that is possible
                gap = taken.query(np.column_stack([px * self.sx, py * self.sy]))[0]
                ok &= gap >= 0.5 * self._local_spacing(px, py)
            xs += px[ok].tolist()
            ys += py[ok].tolist()
            need = n - len(xs)
            if need <= 0:
                break
            cells = self.rng.choice(weights.size, size=need, replace=need > np.count_nonzero(weights), p=weights)
            px = cells % w + self.rng.uniform(-0.5, 0.5, need)
            py = cells // w + self.rng.uniform(-0.5, 0.5, need)
        if len(xs) < n:  # pragma: no cover - the data is smaller than the budget asks
            raise InvalidOptionError(f"could not place {n} sites on the data; ask for fewer vertices")
        return np.array(xs[:n]), np.array(ys[:n])

    def _critical_points(self, limit: int):
        """(rows, cols) of up to ``limit`` peaks, pits and saddles, strongest |curvature| first, one per spacing."""
        if limit == 0:
            return np.empty(0, int), np.empty(0, int)
        z = self.z
        core = z[1:-1, 1:-1]
        ring = [z[:-2, :-2], z[:-2, 1:-1], z[:-2, 2:], z[1:-1, 2:], z[2:, 2:], z[2:, 1:-1], z[2:, :-2], z[1:-1, :-2]]
        signs = np.stack([np.sign(r - core) for r in ring])
        peak = (signs < 0).all(axis=0)
        pit = (signs > 0).all(axis=0)
        changes = (signs != np.roll(signs, 1, axis=0)).sum(axis=0)
        saddle = changes >= 4
        ok = np.zeros_like(self.valid)
        ok[1:-1, 1:-1] = (peak | pit | saddle) & ndimage.binary_erosion(self.valid, np.ones((3, 3)))[1:-1, 1:-1]
        r, c = np.nonzero(ok)
        if len(r) == 0:
            return r, c
        strength = self.rho[r, c]
        order = np.lexsort((c, r, -strength))[: 20 * limit]
        r, c = r[order], c[order]
        keep_r, keep_c = [], []
        bucket = {}
        spacing = self._local_spacing(c.astype(float), r.astype(float))
        b = max(1.0, float(np.min(spacing)) / max(self.sx, self.sy))
        for rr, cc, sp in zip(r.tolist(), c.tolist(), spacing.tolist(), strict=True):
            reach = sp / max(self.sx, self.sy)
            kb = int(math.ceil(reach / b))
            br, bc = int(rr // b), int(cc // b)
            near = False
            for i in range(br - kb, br + kb + 1):
                for j in range(bc - kb, bc + kb + 1):
                    for (qr, qc) in bucket.get((i, j), ()):
                        if ((qr - rr) * self.sy) ** 2 + ((qc - cc) * self.sx) ** 2 < sp * sp:
                            near = True
            if not near:
                bucket.setdefault((br, bc), []).append((rr, cc))
                keep_r.append(rr)
                keep_c.append(cc)
                if len(keep_r) == limit:
                    break
        return np.array(keep_r, int), np.array(keep_c, int)

    # -- iteration ----------------------------------------------------------------------
    def triangulate(self, x=None, y=None) -> np.ndarray:
        """(M, 3) triangles of the constrained Delaunay triangulation of the sites, outside the outline dropped."""
        x = self.x if x is None else x
        y = self.y if y is None else y
        pts = np.column_stack([x * self.sx, y * self.sy])
        tri = delaunay(pts, constraints=self.constraints if len(self.constraints) else None).triangles
        if len(self.chords):
            gx, gy = x[tri].mean(axis=1), y[tri].mean(axis=1)
            seg = np.column_stack([x[self.chords[:, 0]], y[self.chords[:, 0]], x[self.chords[:, 1]], y[self.chords[:, 1]]])
            tri = tri[kc.inside_loops(gx, gy, seg)]
        return np.ascontiguousarray(tri)

    def evaluate(self, x, y):
        """(triangles, cell integrals (N, 5), energy per site) at the site positions (x, y)."""
        tri = self.triangulate(x, y)
        cells = kc.cell_integrals(x, y, tri, self.rho, self.main)
        mass, mx, my, mxx, myy = cells.T
        e = self.sx**2 * (mxx - 2.0 * x * mx + x * x * mass) + self.sy**2 * (myy - 2.0 * y * my + y * y * mass)
        return tri, cells, np.maximum(e, 0.0) * self.sx * self.sy

    def lloyd_target(self, x, y, s, cells):
        """The Lloyd map: free sites to their centroids, sliding sites to the centroid of their stretch of run."""
        mass = cells[:, 0]
        gx, gy, gs = x.copy(), y.copy(), s.copy()
        has = mass > 0.0
        cx = np.where(has, cells[:, 1] / np.where(has, mass, 1.0), x)
        cy = np.where(has, cells[:, 2] / np.where(has, mass, 1.0), y)
        for k, (_rx, _ry, cum, t, l0, l1) in enumerate(self.runs):
            ids = self.run_sites[k]
            if not len(ids):
                continue
            # 1-D Lloyd along the run: each site to the centroid of its stretch (half-way to its neighbours)
            ends = np.r_[0.0, s[ids], cum[-1]]
            lo = np.interp(0.5 * (ends[:-2] + ends[1:-1]), t, l0), np.interp(0.5 * (ends[:-2] + ends[1:-1]), t, l1)
            hi = np.interp(0.5 * (ends[1:-1] + ends[2:]), t, l0), np.interp(0.5 * (ends[1:-1] + ends[2:]), t, l1)
            mass = hi[0] - lo[0]
            gs[ids] = np.where(mass > 0, (hi[1] - lo[1]) / np.where(mass > 0, mass, 1.0), s[ids])
        self.place_sliding(gx, gy, gs)
        ok = (self.kind == FREE) & has & self.inside(gx, gy, cx, cy)
        gx[ok], gy[ok] = cx[ok], cy[ok]
        return gx, gy, gs

    def place_sliding(self, x, y, s) -> None:
        """Put the sliding sites at their arc lengths ``s`` (kept inside their run and in order), in place."""
        for k, (rx, ry, cum, *_) in enumerate(self.runs):
            ids = self.run_sites[k]
            if not len(ids):
                continue
            margin = 1e-6 * cum[-1]
            s[ids] = np.sort(np.clip(s[ids], margin, cum[-1] - margin))
            for i in ids.tolist():
                px, py = self._at(rx, ry, cum, s[i])
                x[i], y[i] = px / self.sx, py / self.sy

    def pack(self, x, y, s) -> np.ndarray:
        """The free parameters as one vector (world units): free sites' x and y, sliding sites' arc length."""
        free = self.kind == FREE
        return np.r_[x[free] * self.sx, y[free] * self.sy, s[self.kind == SLIDE]]

    def unpack(self, q, x, y, s):
        """Site arrays from a parameter vector; free sites that would leave the data keep ``x, y``."""
        free = np.flatnonzero(self.kind == FREE)
        nf = len(free)
        nx, ny, ns = x.copy(), y.copy(), s.copy()
        ns[self.kind == SLIDE] = q[2 * nf:]
        self.place_sliding(nx, ny, ns)
        px, py = q[:nf] / self.sx, q[nf: 2 * nf] / self.sy
        ok = self.inside(nx, ny, px, py)
        nx[free[ok]], ny[free[ok]] = px[ok], py[ok]
        return nx, ny, ns

    def unstick(self, x, y, cells) -> None:
        """Free sites with an empty cell (on top of another site) are nudged by up to half a cell, in place."""
        stuck = np.flatnonzero((self.kind == FREE) & (cells[:, 0] <= 0.0))
        for i in stuck.tolist():
            for _ in range(8):
                dx, dy = self.rng.uniform(-0.5, 0.5, 2)
                if self.inside(x, y, np.array([x[i] + dx]), np.array([y[i] + dy]))[0]:
                    x[i] += dx
                    y[i] += dy
                    break

    def weights(self, cells) -> np.ndarray:
        """Twice the mass (world area times density) of each free parameter's site: ``grad E = -weights * (lloyd - q)``."""
        w = 2.0 * cells[:, 0] * self.sx * self.sy
        return np.r_[w[self.kind == FREE], w[self.kind == FREE], w[self.kind == SLIDE]]

    def run(self, *, tol: float, max_iter: int, acceleration: str, progress=None, on_iteration=None) -> dict:
        """Iterate until the relative energy change is below ``tol`` or ``max_iter``; the run's record.

        Each iteration proposes a step from the Lloyd map ``G`` (free sites to
        their centroids, boundary sites along their run): plain Lloyd takes
        ``G(q)``; Anderson mixes the last few ``G`` values so that the
        residuals ``G(q) - q`` cancel (type II, window 5); L-BFGS takes the
        quasi-Newton direction with ``-weights * (G(q) - q)`` as the energy
        gradient (exact for Voronoi cells, Liu et al. 2009) and the inverse
        masses as the initial Hessian, so its first step is Lloyd's.  An
        accelerated step that raises the energy is replaced by the Lloyd step
        and the history is cleared (Peng et al. 2018).
        """
        x, y, s = self.x.copy(), self.y.copy(), self.s.copy()
        tri, cells, e = self.evaluate(x, y)
        energy = float(e.sum())
        energies = [energy]
        evaluations = 1
        if on_iteration:
            on_iteration(0, x, y, tri, energy)
        hist_a, hist_b = [], []  # Anderson: changes of G and of the residual; L-BFGS: steps and gradient changes
        last = None
        rejected = 0
        reason = "max_iter"
        it = 0
        while it < max_iter:
            self.unstick(x, y, cells)
            gx, gy, gs = self.lloyd_target(x, y, s, cells)
            q, gq = self.pack(x, y, s), self.pack(gx, gy, gs)
            f = gq - q
            proposal = None
            if acceleration == "anderson" and len(q):
                if last is not None:
                    hist_a.append(gq - last[1])
                    hist_b.append(f - last[2])
                last = (q, gq, f)
                if hist_a:
                    del hist_a[:-_WINDOW], hist_b[:-_WINDOW]
                    theta = np.linalg.lstsq(np.column_stack(hist_b), f, rcond=None)[0]
                    proposal = gq - np.column_stack(hist_a) @ theta
            elif acceleration == "lbfgs" and len(q):
                wts = self.weights(cells)
                grad = -wts * f
                if last is not None:
                    step, dg = q - last[0], grad - last[1]
                    if step @ dg > 1e-12 * np.linalg.norm(step) * np.linalg.norm(dg):
                        hist_a.append(step)
                        hist_b.append(dg)
                        del hist_a[:-_WINDOW], hist_b[:-_WINDOW]
                last = (q, grad)
                if hist_a:
                    proposal = q + _two_loop(grad, np.where(wts > 0, 1.0 / np.where(wts > 0, wts, 1.0), 0.0),
                                             hist_a, hist_b)
            step = (gx, gy, gs) if proposal is None else self.unpack(proposal, gx, gy, gs)
            tri_n, cells_n, e_n = self.evaluate(*step[:2])
            evaluations += 1
            new = float(e_n.sum())
            if proposal is not None and new > energy:
                # the accelerated step raised the energy: take the plain Lloyd step, forget the history
                rejected += 1
                hist_a, hist_b, last = [], [], None
                step = (gx, gy, gs)
                tri_n, cells_n, e_n = self.evaluate(gx, gy)
                evaluations += 1
                new = float(e_n.sum())
            it += 1
            change = abs(energy - new) / max(energy, np.finfo(float).tiny)
            (x, y, s), tri, cells, energy = step, tri_n, cells_n, new
            energies.append(energy)
            if on_iteration:
                on_iteration(it, x, y, tri, energy)
            if progress:
                progress(0.1 + 0.85 * it / max(max_iter, 1))
            if change < tol:
                reason = "tol"
                break
        self.x, self.y, self.s = x, y, s
        self.triangles = tri
        return {"iterations": it, "evaluations": evaluations, "energy": energies, "stop_reason": reason,
                "rejected_steps": rejected}

    def to_mesh(self, tri=None) -> TerrainMesh:
        """The current sites as a mesh in world coordinates, heights on the DEM surface."""
        tri = self.triangulate() if tri is None else tri
        used, tri = np.unique(tri, return_inverse=True)
        tri = tri.reshape(-1, 3).astype(np.int64)
        x, y = self.x[used], self.y[used]
        z = kc.surface_heights(x, y, self.z, self.main)
        wx, wy = self.hf.pixel_to_world(y, x)
        if self.hf.handedness < 0:  # counter-clockwise in (col, row) is clockwise in the world
            tri = tri[:, [0, 2, 1]]
        site = np.array(["free", "boundary", "fixed"])[self.kind[used]]
        return TerrainMesh(np.column_stack([wx, wy, z]), tri, crs=self.hf.crs, info={"grid": self.hf.grid_spec()},
                           vertex_attributes={"site": site})


def _cumulative(t: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Trapezoidal running integral of samples ``f`` at ``t``, starting at 0."""
    return np.r_[0.0, np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(t))]


def _two_loop(grad, h0, steps, changes):
    """The L-BFGS direction ``-H grad`` from the stored steps and gradient changes, ``h0`` the initial inverse Hessian."""
    r = grad.copy()
    alphas = []
    for a, b in zip(reversed(steps), reversed(changes), strict=True):
        rho = 1.0 / (a @ b)
        alpha = rho * (a @ r)
        r -= alpha * b
        alphas.append((rho, alpha))
    r *= h0
    for (a, b), (rho, alpha) in zip(zip(steps, changes, strict=True), reversed(alphas), strict=True):
        r += a * (alpha - rho * (b @ r))
    return -r


@register("cvt")
def cvt(hf: Heightfield, *, ratio, density_gamma, density_floor, anchor_fraction, tol, max_iter, acceleration,
        seed, breaklines, control_points, stop: StopCriteria, progress=None) -> TerrainMesh:
    """Curvature CVT: ``max_vertices`` (or ``ratio`` of the valid cells, at least 4) sites in a centroidal Voronoi tessellation.

    Only ``max_vertices`` is a stop rule here: the number of vertices is
    chosen up front (a site on top of another is dropped at the end, so
    the count can fall short by a few), and at most the number of valid
    cells (more sites than cells would add nothing the DEM holds).  Fitted heights (the least-squares
    fit to every cell instead of the DEM's height at each site) are
    :func:`tinsmith.fit_heights`, or ``--fit-heights`` on the command line.
    See :mod:`tinsmith.algorithms.cvt.cvt`.

    Examples
    --------
    >>> import tinsmith
    >>> hf = tinsmith.sample("st-helens")
    >>> dem = tinsmith.Heightfield(hf.z[200:264, 100:164], cell_size=30.0, crs=hf.crs)  # a 64 x 64 window
    >>> mesh = tinsmith.cvt(dem, max_vertices=150)
    >>> 140 <= mesh.n_vertices <= 150  # sites on top of one another are dropped
    True
    >>> q = tinsmith.triangle_quality(mesh, dims=2)
    >>> q["min_angle"]["median"] > 40.0  # well-shaped triangles
    True
    """
    n = stop.max_vertices if stop.max_vertices is not None else max(4, int(round(ratio * hf.n_valid)))
    n = min(n, hf.n_valid)  # a maximum, as for every method: more sites than cells add nothing from the DEM
    if n < 4:
        raise InvalidOptionError(f"cvt needs max_vertices of at least 4, got {n}")
    if progress:
        progress(0.0)
    state = CVTState(hf, n_sites=n, density_gamma=density_gamma, density_floor=density_floor,
                     anchor_fraction=anchor_fraction, control_points=control_points, breaklines=breaklines, seed=seed)
    if progress:
        progress(0.1)
    record = state.run(tol=tol, max_iter=max_iter, acceleration=acceleration, progress=progress)
    mesh = state.to_mesh(state.triangles)
    mesh.info["cvt"] = {
        **record,
        "sites": {"boundary": int((state.kind == SLIDE).sum()), "fixed": int((state.kind == FIXED).sum()),
                  "anchors": state.n_anchors, "free": int((state.kind == FREE).sum())},
    }
    if progress:
        progress(1.0)
    return mesh
