"""Render the pictures of the README and of the method pages: python docs/make_figures.py (needs the viz extra).

Every method meshes the St. Helens sample with the same budget, 8,000
vertices (5.4% of the cells; the quadtree with the diagonal rule needs 6,015
at least, for the full-resolution steps along the ragged outline of the data), and the close-up frames the same window on
the crater rim; the captions carry the measured vertical error.
"""

from pathlib import Path

import tinsmith
from tinsmith.viz import plot_mesh

HERE = Path(__file__).parent
IMG = HERE / "img"
BUDGET = 8000

hf = tinsmith.sample("st-helens")
x0, y0 = 562000.0, 5113600.0  # the crater rim
window = (x0, y0, x0 + 1200.0, y0 + 1200.0)
wide = (x0 - 600.0, y0 - 600.0, x0 + 1800.0, y0 + 1800.0)

plot_mesh(
    tinsmith.simplify(hf, method="grid"),
    IMG / "st_helens_grid.png",
    window=window,
    title="St. Helens sample, method grid (full resolution)",
)
greedy = tinsmith.simplify(hf, method="greedy", max_error=5)
plot_mesh(
    greedy,
    IMG / "st_helens_greedy.png",
    window=wide,
    title=f"St. Helens sample, method greedy, max_error 5 m: {greedy.n_vertices:,} of {hf.n_valid:,} cells",
)

runs = [
    ("greedy", {}),
    ("subsample", {}),
    ("features", {"measure": "sobel"}),
    ("quadtree", {}),
    ("quadtree", {"diagonal": "rule"}),
    ("decimate", {}),
    ("cvt", {}),
]
runs.append(("remesh", {}))
for name, options in runs:
    budget = {"n_vertices": BUDGET} if name == "remesh" else {"max_vertices": BUDGET}  # remesh: exactly the budget
    mesh = tinsmith.simplify(hf, method=name, **budget, **options)
    err = tinsmith.vertical_error(mesh, hf)
    label = name + "".join(f", {k}={v}" for k, v in options.items())
    suffix = "".join(f"_{v}" for v in options.values())
    plot_mesh(
        mesh,
        IMG / f"method_{name}{suffix}.png",
        window=wide,
        title=f"{label}, {'n_vertices' if name == 'remesh' else 'max_vertices'} {BUDGET:,}: max error {err['max']:.1f} m, RMS {err['rmse']:.2f} m",
    )
    print(f"{label}: {mesh.n_vertices} vertices, {mesh.n_triangles} triangles, max {err['max']:.2f}, rmse {err['rmse']:.3f}")

# the urban block model of the Delft DSM (needs ../shared/data)
DELFT = HERE.parent.parent / "shared/data/urban/delft_ahn3/delft_dsm_0.5m.tif"
if DELFT.exists():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    dsm = tinsmith.read_heightfield(DELFT)
    from tinsmith.algorithms.urban.urban import urban_model  # the tree with the mesh (tinsmith.blocks: the mesh)

    model = urban_model(dsm, lod=4, noise_factor=10, min_width=3.0, simplify_tolerance=0.5)
    v, t = model.mesh.vertices, model.mesh.triangles
    x0, y0 = v[:, 0].min(), v[:, 1].min()
    corners = v[t]
    crop = ((corners[:, :, 0] > x0 + 90) & (corners[:, :, 0] < x0 + 210)
            & (corners[:, :, 1] > y0 + 60) & (corners[:, :, 1] < y0 + 180)).all(axis=1)
    tri = v[t[crop]]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    light = np.array([0.4, -0.5, 0.77]) / np.linalg.norm([0.4, -0.5, 0.77])
    fig = plt.figure(figsize=(13, 6.2), constrained_layout=True)
    ax1 = fig.add_subplot(1, 2, 1)
    xmin, ymin, xmax, ymax = dsm.bounds
    ax1.imshow(np.where(dsm.valid, dsm.z, np.nan), extent=(xmin, xmax, ymin, ymax), cmap="gray")
    colours = plt.cm.plasma(np.linspace(0.1, 0.9, len(model.tree.thresholds)))
    for region in model.tree.regions:
        if region.level:
            for ring in [region.outline] + region.holes:
                ring = np.vstack([ring, ring[:1]])
                ax1.plot(ring[:, 0], ring[:, 1], color=colours[region.level], lw=0.6)
    ax1.set_title(f"building tree: {model.stats['n_regions']} regions, coloured by level")
    ax1.ticklabel_format(useOffset=False, style="plain")
    ax1.tick_params(labelsize=7)
    ax2 = fig.add_subplot(1, 2, 2, projection="3d")
    ax2.add_collection3d(Poly3DCollection(tri, facecolors=plt.cm.Greys(0.25 + 0.7 * np.clip(normal @ light, 0.05, 1)),
                                          edgecolors=(0, 0, 0, 0.2), linewidths=0.2))
    ax2.set_xlim(x0 + 90, x0 + 210)
    ax2.set_ylim(y0 + 60, y0 + 180)
    ax2.set_zlim(-5, 45)
    ax2.view_init(elev=35, azim=-60)
    ax2.set_box_aspect((1, 1, 0.4))
    ax2.set_axis_off()
    ax2.set_title(f"block model (crop): {model.mesh.n_vertices:,} vertices in all, one crack-free surface")
    fig.suptitle("Delft DSM 0.5 m, urban(lod=4, noise_factor=10, min_width=3, simplify_tolerance=0.5)")
    fig.savefig(IMG / "urban_delft.png", dpi=90)
    plt.close(fig)
    print(f"urban: {model.stats}")

# reconstruct: a LiDAR tile in heightfield mode and an evenly sampled torus in general mode
CODEM = HERE.parent.parent / "shared/data/urban/codem_ncalm/codem_pc.laz"
if CODEM.exists():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from tinsmith.algorithms.reconstruct.reconstruct import reconstruct
    from tinsmith.shapes import torus_points

    def shaded(ax, v, t, light=(0.4, -0.5, 0.77)):
        tri = v[t]
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        normal /= np.linalg.norm(normal, axis=1)[:, None]
        light = np.asarray(light) / np.linalg.norm(light)
        ax.add_collection3d(Poly3DCollection(tri, facecolors=plt.cm.Greys(0.25 + 0.7 * np.clip(normal @ light, 0.05, 1)),
                                             edgecolors=(0, 0, 0, 0.15), linewidths=0.1))
        lo, hi = tri.reshape(-1, 3).min(axis=0), tri.reshape(-1, 3).max(axis=0)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_zlim(lo[2], hi[2])
        ax.set_axis_off()

    cloud = tinsmith.read(CODEM)
    mesh = reconstruct(cloud, mode="heightfield")
    v, t = mesh.vertices, mesh.triangles
    x0, y0 = np.median(v[:, 0]), np.median(v[:, 1])
    crop = (np.abs(v[t][:, :, 0] - x0) < 60).all(axis=1) & (np.abs(v[t][:, :, 1] - y0) < 60).all(axis=1)
    fig = plt.figure(figsize=(19, 6.2), constrained_layout=True)
    ax1 = fig.add_subplot(1, 3, 1, projection="3d")
    shaded(ax1, v, t[crop])
    ax1.set_box_aspect((1, 1, 0.35))
    ax1.view_init(elev=40, azim=-60)
    ax1.set_title(f"CODEM LiDAR, heightfield mode, 120 m crop\n{mesh.n_vertices:,} of {len(cloud):,} points kept")
    # a torus sampled evenly (a jittered grid of its two angles), general mode
    ring = torus_points(grid=(245, 82))
    closed = reconstruct(ring, mode="general")
    ax2 = fig.add_subplot(1, 3, 2, projection="3d")
    shaded(ax2, closed.vertices, closed.triangles)
    ax2.set_box_aspect((1, 1, 0.25))
    ax2.view_init(elev=35, azim=-60)
    info = closed.info["reconstruct"]
    ax2.set_title(f"torus, general mode\n{closed.n_vertices:,} points, {closed.n_triangles:,} triangles, "
                  f"{info['border_loops']} border loops")
    # the Delft cloud's ground and buildings in general mode: walls and roofs, a crop about the tallest roof
    delft = HERE.parent.parent / "shared/data/urban/delft_ahn3/delft_ahn3_merged.laz"
    if delft.exists():
        cloud = tinsmith.read(delft, classes=[2, 6])
        city = reconstruct(cloud, mode="general")
        v, t = city.vertices, city.triangles
        top = v[np.argmax(np.where(np.abs(v[:, 2] - np.median(v[:, 2])) < 40, v[:, 2], -np.inf))]
        crop = (np.abs(v[t][:, :, 0] - top[0]) < 40).all(axis=1) & (np.abs(v[t][:, :, 1] - top[1]) < 40).all(axis=1)
        ax3 = fig.add_subplot(1, 3, 3, projection="3d")
        shaded(ax3, v, t[crop])
        ax3.set_box_aspect((1, 1, 0.45))
        ax3.view_init(elev=30, azim=-50)
        info = city.info["reconstruct"]
        ax3.set_title(f"Delft AHN3 LiDAR, ground and buildings, general mode, 80 m crop\n{len(cloud):,} points, "
                      f"{city.n_triangles:,} triangles, {info['border_loops']:,} border loops")
    fig.savefig(IMG / "reconstruct.png", dpi=90)
    plt.close(fig)
