"""Alliez et al. (2003)'s remesher on St. Helens and a hemisphere, beside greedy insertion and pymeshlab's isotropic remeshing.

    python benchmarks/remesh_bench.py      # writes benchmarks/RESULTS_remesh.md and docs/img/remesh_*.png

- St. Helens full-resolution mesh (148,885 vertices) to 2k, 10k and 50k
  vertices, uniform and curvature (gamma 1 and 2): exact count, share of
  triangles with min angle >= 30 degrees and aspect ratio <= 3 in 3-D,
  vertical RMSE against the DEM beside greedy insertion's at the same count,
  the boundary's length against the input's, time.
- pymeshlab (GPL, a peer only) `meshing_isotropic_explicit_remeshing` with
  the target edge length of tinsmith's uniform mesh, in the same run: its
  vertex count, the same quality figures, RMSE and time.
- Two crossing breaklines over the crater at 10k vertices.
- A hemisphere (a disk-like, non-terrain mesh) through the conformal path.
"""

from __future__ import annotations

import time
from itertools import pairwise

import numpy as np
from _common import HERE, ROOT, SHARED, machine
from closed_shapes import closed_rows, pymeshlab_remesh

import tinsmith
from tinsmith.metrics.quality import aspect_ratios, triangle_angles
from tinsmith.metrics.surface import polyline_distances

COUNTS = (2_000, 10_000, 50_000)
SETTINGS = [("uniform", {"density": "uniform"}), ("curvature, gamma 1", {"density": "curvature", "gamma": 1.0}),
            ("curvature, gamma 2", {"density": "curvature", "gamma": 2.0})]


def quality(mesh) -> tuple:
    ang = triangle_angles(mesh, 3).min(axis=1)
    asp = aspect_ratios(mesh, 3)
    return float(((ang >= 30) & (asp <= 3)).mean()), float(np.percentile(ang, 1)), float(asp.max())


def boundary_length(mesh, dims: int = 3) -> float:
    b = mesh.boundary_edges()
    return float(np.linalg.norm(mesh.vertices[b[:, 0], :dims] - mesh.vertices[b[:, 1], :dims], axis=1).sum())


def on_boundary(mesh, source) -> float:
    """Largest x-y distance of an output boundary vertex from the input boundary (segments)."""
    b = source.boundary_edges()
    a, c = source.vertices[b[:, 0], :2], source.vertices[b[:, 1], :2]
    pts = mesh.vertices[np.unique(mesh.boundary_edges()), :2]
    from scipy.spatial import cKDTree

    mid = cKDTree((a + c) / 2)
    _, near = mid.query(pts, k=8)
    best = np.full(len(pts), np.inf)
    for j in range(near.shape[1]):
        pa, pc = a[near[:, j]], c[near[:, j]]
        d = pc - pa
        t = np.clip(((pts - pa) * d).sum(1) / np.maximum((d * d).sum(1), 1e-300), 0, 1)
        best = np.minimum(best, np.linalg.norm(pts - (pa + t[:, None] * d), axis=1))
    return float(best.max())


def breakline_rows(source) -> list:
    """Two crossing breaklines over the crater at 10k vertices: vertices on them, edges crossing, length kept."""
    lines = [np.array([[559000.0, 5112000.0], [562000.0, 5116500.0], [566500.0, 5118500.0]]),
             np.array([[560000.0, 5119000.0], [565000.0, 5111000.0]])]
    start = time.perf_counter()
    mesh = tinsmith.remesh(source, max_vertices=10_000, breaklines=lines)
    elapsed = time.perf_counter() - start
    xy = mesh.vertices[:, :2]
    e, _ = mesh.edges()
    rows = ["", "## Breaklines", "",
            "St. Helens at 10,000 vertices, uniform, with two crossing polylines over the crater (x-y, UTM): "
            f"{elapsed:.1f} s, {100 * quality(mesh)[0]:.2f}% good.", "",
            "| breakline | length (m) | output vertices on it | length of the output polyline through them | "
            "edges crossing it |",
            "| --- | --- | --- | --- | --- |"]
    for i, line in enumerate(lines):
        dist, arc = polyline_distances(xy, line)
        on = dist < 1e-6
        length = float(np.linalg.norm(np.diff(line, axis=0), axis=1).sum())
        kept = float(np.linalg.norm(np.diff(xy[on][np.argsort(arc[on])], axis=0), axis=1).sum())
        crossing = 0
        for a, b in pairwise(line):
            p, q = xy[e[:, 0]], xy[e[:, 1]]

            def orient(u, v, w):
                return (v[..., 0] - u[..., 0]) * (w[..., 1] - u[..., 1]) - (v[..., 1] - u[..., 1]) * (w[..., 0] - u[..., 0])

            # signed distances (m) of each end from the other segment's line; an end on the line is no crossing
            ab, pq = np.linalg.norm(b - a), np.maximum(np.linalg.norm(q - p, axis=1), 1e-300)
            d1, d2 = orient(a, b, p) / ab, orient(a, b, q) / ab
            d3, d4 = orient(p, q, a) / pq, orient(p, q, b) / pq
            apart = (np.abs(d1) > 1e-6) & (np.abs(d2) > 1e-6) & (np.abs(d3) > 1e-6) & (np.abs(d4) > 1e-6)
            crossing += int((apart & (d1 * d2 < 0) & (d3 * d4 < 0)).sum())
        rows.append(f"| {i + 1} | {length:,.0f} | {int(on.sum())} | {kept / length:.4f} of it | {crossing} |")
    return rows


def hemisphere(n=20_000, seed=0):
    from scipy.spatial import ConvexHull

    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    p /= np.linalg.norm(p, axis=1)[:, None]
    p[:, 2] = np.abs(p[:, 2])
    theta = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    pts = np.concatenate([p[p[:, 2] > 0.02], np.column_stack([np.cos(theta), np.sin(theta), np.zeros_like(theta)])])
    hull = ConvexHull(np.concatenate([pts, [[0, 0, -1.0]]]))
    tri = hull.simplices[(hull.simplices < len(pts)).all(axis=1)]
    normal = np.cross(pts[tri[:, 1]] - pts[tri[:, 0]], pts[tri[:, 2]] - pts[tri[:, 0]])
    flip = (normal * pts[tri].mean(axis=1)).sum(axis=1) < 0
    tri[flip] = tri[flip][:, [0, 2, 1]]
    return tinsmith.TerrainMesh(pts * 10.0, tri)


TUJUNGA = SHARED / "data/terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif"
TUJUNGA_HF = None


def tujunga_source():
    """Big Tujunga's full-resolution mesh (read once)."""
    global TUJUNGA_HF
    if TUJUNGA_HF is None:
        TUJUNGA_HF = tinsmith.read_heightfield(TUJUNGA)
        tujunga_source.mesh = tinsmith.simplify(TUJUNGA_HF, method="grid")
    return tujunga_source.mesh


def main() -> None:
    hf = tinsmith.sample("st-helens")
    source = tinsmith.simplify(hf, method="grid")
    base_len, base_2d = boundary_length(source), boundary_length(source, 2)
    lines = ["# Remeshing with an exact vertex budget (Alliez et al. 2003)", "", "Command: `python benchmarks/remesh_bench.py`  ",
             f"{machine()}.", "",
             f"St. Helens full-resolution mesh: {source.n_vertices:,} vertices, {source.n_triangles:,} triangles, "
             f"boundary {base_len:,.0f} m in 3-D, {base_2d:,.0f} m in x-y. "
             "Default options (feature angle 60, 40 Lloyd iterations, seed 0). "
             "Good: min angle >= 30 degrees and aspect ratio <= 3, in 3-D. RMSE: vertical, over every valid cell.", "",
             "| vertices | density | result vertices | good | min angle p1 | max aspect | RMSE | greedy RMSE | "
             "boundary length / input, 3-D | in x-y | boundary vertex off the input boundary | time |",
             "| --- " * 12 + "|"]
    kept = {}
    for n in COUNTS:
        greedy = tinsmith.simplify(hf, method="greedy", max_vertices=n)
        g_rmse = tinsmith.vertical_error(greedy, hf)["rmse"]
        for name, opts in SETTINGS:
            start = time.perf_counter()
            mesh = tinsmith.remesh(source, max_vertices=n, **opts)
            elapsed = time.perf_counter() - start
            good, p1, worst = quality(mesh)
            rmse = tinsmith.vertical_error(mesh, hf)["rmse"]
            lines.append(f"| {n:,} | {name} | {mesh.n_vertices:,} | {100 * good:.2f}% | {p1:.1f} | {worst:.2f} | "
                         f"{rmse:.2f} | {g_rmse:.2f} | {boundary_length(mesh) / base_len:.4f} | "
                         f"{boundary_length(mesh, 2) / base_2d:.4f} | "
                         f"{on_boundary(mesh, source):.2e} m | {elapsed:.1f} s |")
            kept[(n, name)] = mesh
    lines += ["", "## pymeshlab's isotropic explicit remeshing (GPL; a peer in the benchmark only)", "",
              "Target edge length: the mean edge length of tinsmith's uniform mesh; 10 iterations, feature angle 60. "
              "pymeshlab does not take a vertex count. Both run in this process, one after the other; the time ratio "
              "is tinsmith's time over pymeshlab's (below 1: tinsmith is faster). Big Tujunga (SRTM 30 m, "
              f"{tujunga_source().n_vertices:,} vertices at full resolution) is the second DEM.", "",
              "| DEM | tinsmith vertices | target edge (m) | pymeshlab vertices | good | tinsmith good | min angle p1 | "
              "tinsmith's | max aspect | vertical RMSE / max (m) | tinsmith's | pymeshlab time | tinsmith time | "
              "time ratio |", "| --- " * 14 + "|"]
    peers = {}
    tujunga = tujunga_source()
    for dem, mesh_in, height, counts in (("St. Helens", source, hf, COUNTS), ("Big Tujunga", tujunga, None, (50_000,))):
        for n in counts:
            start = time.perf_counter()
            ours = tinsmith.remesh(mesh_in, max_vertices=n)
            ours_time = time.perf_counter() - start
            e, _ = ours.edges()
            target = float(np.linalg.norm(ours.vertices[e[:, 0]] - ours.vertices[e[:, 1]], axis=1).mean())
            try:
                peer, peer_time = pymeshlab_remesh(mesh_in, target)
            except ImportError:
                lines.append(f"| {dem} | {n:,} | {target:.1f} | pymeshlab not installed |" + " |" * 10)
                continue
            if dem == "St. Helens":
                peers[n] = peer
            good, p1, worst = quality(peer)
            ours_good, ours_p1, _ = quality(ours)
            grid = height if height is not None else TUJUNGA_HF
            err, ours_err = tinsmith.vertical_error(peer, grid), tinsmith.vertical_error(ours, grid)
            lines.append(f"| {dem} | {n:,} | {target:.1f} | {peer.n_vertices:,} | {100 * good:.2f}% | "
                         f"{100 * ours_good:.2f}% | {p1:.1f} | {ours_p1:.1f} | {worst:.2f} | "
                         f"{err['rmse']:.2f} / {err['max']:.0f} | {ours_err['rmse']:.2f} / {ours_err['max']:.0f} | "
                         f"{peer_time:.1f} s | {ours_time:.1f} s | {ours_time / peer_time:.2f} |")
    lines += breakline_rows(source)
    hemi = hemisphere()
    start = time.perf_counter()
    mesh = tinsmith.remesh(hemi, max_vertices=3_000)
    elapsed = time.perf_counter() - start
    good, p1, worst = quality(mesh)
    radius = np.linalg.norm(mesh.vertices, axis=1)
    lines += ["", "## A hemisphere through the conformal path", "",
              f"Input: {hemi.n_vertices:,} vertices on a sphere of radius 10 (random points, convex hull). "
              f"Output: {mesh.n_vertices:,} vertices ({mesh.info['remesh']['parameterization']}), "
              f"{100 * good:.2f}% good, min angle p1 {p1:.1f}, max aspect {worst:.2f}, "
              f"radius {radius.min():.4f} to {radius.max():.4f}, {elapsed:.1f} s.", ""]
    lines += closed_rows(ROOT / "docs/img/remesh_closed.png")
    (HERE / "RESULTS_remesh.md").write_text("\n".join(lines))
    print("\n".join(lines))
    pictures(kept, mesh, peers)


def pictures(kept, hemi_mesh, peers) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 3, figsize=(21, 10))
    for a, name in zip(ax, [s for s, _ in SETTINGS], strict=True):
        m = kept[(10_000, name)]
        a.triplot(m.vertices[:, 0], m.vertices[:, 1], m.triangles, lw=0.15, color="k")
        a.set_xlim(559500, 564500)
        a.set_ylim(5113500, 5119000)
        a.set_aspect(1)
        a.set_xticks([])
        a.set_yticks([])
        a.set_title(f"St. Helens, 10,000 vertices, {name} (crater)")
    fig.tight_layout()
    fig.savefig(ROOT / "docs/img/remesh_st_helens.png", dpi=60)
    plt.close(fig)
    if peers:  # the quality histogram beside pymeshlab's
        fig, ax = plt.subplots(1, len(peers), figsize=(6 * len(peers), 4.2))
        bins = np.linspace(0, 60, 61)
        for a, (n, peer) in zip(np.atleast_1d(ax), peers.items(), strict=True):
            for m, label in ((kept[(n, "uniform")], "tinsmith"), (peer, "pymeshlab")):
                a.hist(triangle_angles(m, 3).min(axis=1), bins=bins, histtype="step", density=True,
                       label=f"{label} ({m.n_vertices:,} vertices)")
            a.axvline(30, color="grey", lw=0.8)
            a.set_xlabel("smallest angle of a triangle, 3-D (degrees)")
            a.set_title(f"St. Helens, about {n:,} vertices, uniform")
            a.legend(loc="upper left")
        fig.tight_layout()
        fig.savefig(ROOT / "docs/img/remesh_quality.png", dpi=70)
        plt.close(fig)
    fig = plt.figure(figsize=(8, 7))
    a = fig.add_subplot(projection="3d")
    a.plot_trisurf(hemi_mesh.vertices[:, 0], hemi_mesh.vertices[:, 1], hemi_mesh.vertices[:, 2],
                   triangles=hemi_mesh.triangles, color="w", edgecolor="k", linewidth=0.2)
    a.set_box_aspect((1, 1, 0.5))
    a.set_title("hemisphere, 3,000 vertices, conformal path")
    fig.savefig(ROOT / "docs/img/remesh_hemisphere.png", dpi=70)
    plt.close(fig)


if __name__ == "__main__":
    main()
