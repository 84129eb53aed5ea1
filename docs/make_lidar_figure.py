"""docs/img/lidar_ground_tin.png: a forest ground TIN before (gridded, holes) and after (the points' TIN).

Run: ``python docs/make_lidar_figure.py`` (reads ../shared/data/terrain/lidR_forest_lakes/MixedConifer.laz).
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import tinsmith  # noqa: E402

HERE = Path(__file__).resolve().parent
SRC = HERE.parent.parent / "shared" / "data" / "terrain" / "lidR_forest_lakes" / "MixedConifer.laz"


def main() -> None:
    ground = tinsmith.read(SRC, classes=[2])
    gridded = tinsmith.greedy(ground.to_heightfield(), max_error=0.1)
    points = tinsmith.greedy(ground, max_error=0.1)
    fig, axes = plt.subplots(1, 2, figsize=(13, 6.4))
    for ax, mesh, title in (
        (axes[0], gridded, f"before: gridded at {ground.default_cell_size():g} m, then greedy ({gridded.n_triangles:,} triangles)"),
        (axes[1], points, f"after: greedy on the points ({points.n_triangles:,} triangles)"),
    ):
        v = mesh.vertices
        ax.tripcolor(v[:, 0], v[:, 1], mesh.triangles, v[:, 2], cmap="terrain", shading="gouraud")
        ax.triplot(v[:, 0], v[:, 1], mesh.triangles, color="k", linewidth=0.15)
        ax.plot(ground.xyz[:, 0], ground.xyz[:, 1], ",", color="crimson", alpha=0.4)
        ax.set_aspect("equal")
        ax.set_title(title, fontsize=10)
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle("Ground (class 2) of the lidR MixedConifer plot, 5,820 points, bound 0.1 m at every point (red dots)")
    fig.tight_layout()
    out = HERE / "img" / "lidar_ground_tin.png"
    fig.savefig(out, dpi=80)
    print("wrote", out)


if __name__ == "__main__":
    main()
