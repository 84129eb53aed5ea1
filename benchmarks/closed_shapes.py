"""Closed and higher-genus surfaces for the remesh benchmark: tinsmith's charts against pymeshlab, same run.

    python benchmarks/closed_shapes.py     # prints the section; remesh_bench.py adds it to RESULTS_remesh.md

Inputs: a sphere (convex hull of 20,000 Fibonacci points), a torus (a
240 x 80 parametric grid), a genus-2 surface (a level set contoured by VTK,
so with marching-cubes slivers), a torus reconstructed by tinsmith from a
jittered cloud of 20,000 points (its slivers give noisy normals), and a
watertight city block from ``tinsmith.city(..., solid=True)`` on a small
synthetic DSM (two buildings on sloping ground: sharp edges everywhere),
and the same from a 50 x 50 m window of the Delft DSM and DTM (real roofs,
walls and slivers).
Each is remeshed to N vertices; pymeshlab's isotropic explicit remeshing
gets the mean edge length of tinsmith's mesh.  Hausdorff distance: the
largest distance from the points of one mesh (vertices and triangle
centroids) to the other surface, both ways, exact point-to-triangle
(relative to the bounding-box diagonal).
"""

from __future__ import annotations

import time

import numpy as np

import tinsmith
from tinsmith import shapes
from tinsmith.metrics import self_intersections
from tinsmith.metrics.quality import aspect_ratios, triangle_angles
from tinsmith.metrics.surface import closest_points
from tinsmith.shapes import ellipsoid, torus_points


def pymeshlab_remesh(source, target_len):
    """pymeshlab's isotropic explicit remeshing (GPL; a peer in the benchmarks only) at ``target_len``, 10 iterations,
    feature angle 60: (mesh, seconds of the call)."""
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(source.vertices, source.triangles))
    start = time.perf_counter()
    ms.meshing_isotropic_explicit_remeshing(iterations=10, targetlen=pymeshlab.PureValue(target_len), featuredeg=60)
    elapsed = time.perf_counter() - start
    m = ms.current_mesh()
    return tinsmith.TerrainMesh(m.vertex_matrix(), m.face_matrix()), elapsed


def sphere(n=20_000):
    return ellipsoid(n, (10.0, 10.0, 10.0))


def torus(nu=240, nv=80):
    return shapes.torus(nu, nv)


def genus_two(step=0.02):
    import pyvista as pv

    lo, hi = np.array([-0.45, -0.85, -0.35]), np.array([2.45, 0.85, 0.35])
    grid = pv.ImageData(dimensions=np.ceil((hi - lo) / step).astype(int) + 1, spacing=(step,) * 3, origin=lo)
    x, y, z = grid.points.T
    grid["f"] = (x * (x - 1) ** 2 * (x - 2) + y ** 2) ** 2 + z ** 2 - 0.02
    surface = grid.contour([1e-9], scalars="f").triangulate().clean()
    return tinsmith.TerrainMesh(np.asarray(surface.points, float) * 10.0, surface.faces.reshape(-1, 4)[:, 1:])


def scanned_torus(n=20_000, seed=0):
    cloud = torus_points(n, seed=seed) * 3.0
    return tinsmith.reconstruct(tinsmith.PointCloud(cloud), mode="general")


def city_block():
    cell = 0.5
    rows, cols = np.mgrid[0:160, 0:200]
    x, y = (cols + 0.5) * cell, 80.0 - (rows + 0.5) * cell
    ground = 2.0 + 0.02 * x
    z = ground.copy()
    z[(x > 15) & (x < 45) & (y > 20) & (y < 40)] += 12.0
    c, s = np.cos(np.radians(25)), np.sin(np.radians(25))
    u, w = (x - 70) * c + (y - 45) * s, -(x - 70) * s + (y - 45) * c
    z[(np.abs(u) < 12) & (np.abs(w) < 7)] += 9.0 - 0.4 * np.abs(w[(np.abs(u) < 12) & (np.abs(w) < 7)])
    dsm = tinsmith.Heightfield(z, cell_size=cell, origin=(0.0, 80.0))
    dtm = tinsmith.Heightfield(ground, cell_size=cell, origin=(0.0, 80.0))
    return tinsmith.city(dsm, ground=dtm, solid=True).mesh


def delft_block(size=100, row=150, col=200):
    """A 50 x 50 m window of the Delft DSM and DTM (0.5 m) as a watertight city solid: real roofs and walls."""
    from _common import SHARED

    cut = []
    for name in ("dsm", "dtm"):
        h = tinsmith.read_heightfield(SHARED / f"data/urban/delft_ahn3/delft_{name}_0.5m.tif")
        a, _, c, _, e, f = h.transform
        cut.append(tinsmith.Heightfield(np.asarray(h.z)[row:row + size, col:col + size], cell_size=a,
                                        origin=(c + col * a, f + row * e)))
    return tinsmith.city(cut[0], ground=cut[1], solid=True).mesh


SHAPES = [("sphere", sphere, (2_000, 10_000)), ("torus", torus, (2_000, 10_000)),
          ("genus 2 (marching cubes)", genus_two, (2_000, 10_000)),
          ("torus reconstructed from 20k points", scanned_torus, (5_000,)),
          ("city block, solid", city_block, (2_000, 8_000)),
          ("Delft DSM window, city solid", delft_block, (2_000, 10_000))]


def euler(mesh) -> int:
    e, _ = mesh.edges()
    return mesh.n_vertices - len(e) + mesh.n_triangles


def quality(mesh) -> tuple:
    ang = triangle_angles(mesh, 3).min(axis=1)
    asp = aspect_ratios(mesh, 3)
    return float(((ang >= 30) & (asp <= 3)).mean()), float(np.percentile(ang, 1)), float(asp.max())


def hausdorff(a, b) -> float:
    """Largest distance from a's vertices and centroids to b's surface and back, over b's bounding-box diagonal."""
    def one_way(p, q):
        pts = np.concatenate([p.vertices, p.vertices[p.triangles].mean(axis=1)])
        return float(np.linalg.norm(closest_points(q.vertices, q.triangles, pts) - pts, axis=1).max())

    return max(one_way(a, b), one_way(b, a)) / float(np.linalg.norm(np.ptp(b.vertices, axis=0)))


def picture(meshes: list, path) -> None:
    """The remeshed shapes side by side, shaded by the light on each triangle; their seams are not drawn."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    fig = plt.figure(figsize=(5 * len(meshes), 5))
    light = np.array([0.4, -0.5, 0.77])
    for i, (name, mesh) in enumerate(meshes):
        ax = fig.add_subplot(1, len(meshes), i + 1, projection="3d")
        p = mesh.vertices[mesh.triangles]
        n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        shade = 0.3 + 0.65 * np.abs((n / np.linalg.norm(n, axis=1)[:, None]) @ light)  # either side lit
        ax.add_collection3d(Poly3DCollection(p, facecolors=np.column_stack([shade, shade, shade, np.ones_like(shade)]),
                                             edgecolors=(0, 0, 0, 0.35), linewidths=0.15))
        lo, hi = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
        mid, half = (lo + hi) / 2, (hi - lo).max() / 2
        ax.set_xlim(mid[0] - half, mid[0] + half)
        ax.set_ylim(mid[1] - half, mid[1] + half)
        ax.set_zlim(mid[2] - half, mid[2] + half)
        ax.set_axis_off()
        ax.set_title(f"{name}: {mesh.n_vertices:,} vertices", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def closed_rows(picture_path=None) -> list:
    lines = ["", "## Closed and higher-genus surfaces (charts, section 4.1)", "",
             "The surface is cut into disk-like charts whose borders are sampled once and shared, each chart is "
             "flattened and relaxed, and the seams are relaxed once the surface is whole "
             "(`docs/methods/remesh.md`). Good: min angle >= 30 and aspect <= 3 in 3-D. Hausdorff: both ways, "
             "relative to the input's bounding-box diagonal. pymeshlab (same run) gets tinsmith's mean edge length.",
             "", "| input | vertices / triangles / Euler | N | result vertices | border edges | Euler | good | "
             "min angle p1 | max aspect | self-intersections | Hausdorff | charts | time | pymeshlab vertices | "
             "its good | its Euler | its Hausdorff | its time |", "| --- " * 18 + "|"]
    shown = []
    for name, make, counts in SHAPES:
        source = make()
        for n in counts:
            start = time.perf_counter()
            mesh = tinsmith.remesh(source, max_vertices=n)
            elapsed = time.perf_counter() - start
            if n == counts[0]:
                shown.append((name, mesh))
            good, p1, worst = quality(mesh)
            e, _ = mesh.edges()
            target = float(np.linalg.norm(mesh.vertices[e[:, 0]] - mesh.vertices[e[:, 1]], axis=1).mean())
            try:
                peer, peer_time = pymeshlab_remesh(source, target)
                pg = quality(peer)[0]
                peer_cols = (f"{peer.n_vertices:,} | {100 * pg:.2f}% | {euler(peer)} | {hausdorff(peer, source):.1e} | "
                             f"{peer_time:.1f} s")
            except ImportError:
                peer_cols = "pymeshlab not installed | | | |"
            lines.append(f"| {name} | {source.n_vertices:,} / {source.n_triangles:,} / {euler(source)} | {n:,} | "
                         f"{mesh.n_vertices:,} | {len(mesh.boundary_edges())} | {euler(mesh)} | {100 * good:.2f}% | "
                         f"{p1:.1f} | {worst:.2f} | {self_intersections(mesh)} | {hausdorff(mesh, source):.1e} | "
                         f"{mesh.info['remesh']['charts']} | {elapsed:.1f} s | {peer_cols} |")
    if picture_path is not None:
        picture([shown[i] for i in (1, 2, 4)], picture_path)
        lines += ["", f"![closed shapes](../{picture_path.relative_to(picture_path.parents[2])})"]
    return lines


if __name__ == "__main__":
    tinsmith.remesh(sphere(2000), max_vertices=300)  # kernels loaded
    print("\n".join(closed_rows()))
