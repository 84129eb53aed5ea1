"""Urban models of the Delft DSM against the official building outlines (BGT panden), and greedy insertion at the same size.

    pip install -e ".[test]"
    python benchmarks/urban_delft.py          # writes benchmarks/RESULTS_urban.md

The thesis' three settings (LOD 1 / NF 40, LOD 4 / NF 40, LOD 4 / NF 10) at
the cell size of the data (0.5 m), and the same with the options that go
beyond it.  For each: the block model's points (vertices) against the
cells; the union IoU of its building outlines (the regions on the ground)
against the reference, inside the convex hull of the reference (the
reference maps the central blocks only); the union IoU of the cells the
mesh raises more than 2 m above the ground (the rule that also judges
greedy insertion, which has no outlines); and the vertical RMSE over the
cells of the reference buildings; and, per reference building, the
median height of the mesh over its cells against the top of the block
3dfier gives it (its LoD 1 model of the same data, matched by the BGT
``lokaalid``; 3dfier's ``measuredHeight`` is a height above the block's
base, not an elevation).  Greedy insertion gets the block model's vertex count.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from _common import HERE, SHARED, machine

DSM = SHARED / "data/urban/delft_ahn3/delft_dsm_0.5m.tif"
BGT = SHARED / "data/vector/delft_bgt/bgt_pand.sqlite"
RAISED = 2.0  # metres above the ground: a building (or a tree) in the raster rule

SETTINGS = [
    ("thesis LOD 1 / NF 40", dict(lod=1, noise_factor=40)),
    ("thesis LOD 4 / NF 40", dict(lod=4, noise_factor=40)),
    ("thesis LOD 4 / NF 10", dict(lod=4, noise_factor=10)),
    ("LOD 4 / NF 10, min_width 3 m", dict(lod=4, noise_factor=10, min_width=3.0)),
    ("LOD 4 / NF 10, min_width 3 m, relative to ground", dict(lod=4, noise_factor=10, min_width=3.0, relative_to_ground=True)),
    ("LOD 4 / NF 10, min_width 3 m, simplify 0.5 m", dict(lod=4, noise_factor=10, min_width=3.0, simplify_tolerance=0.5)),
    ("LOD 4 / NF 10, max_roughness 0.3 m", dict(lod=4, noise_factor=10, max_roughness=0.3)),
    ("LOD 4 / NF 10, max_roughness 0.3 m, simplify 0.5 m",
     dict(lod=4, noise_factor=10, max_roughness=0.3, simplify_tolerance=0.5)),
]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(HERE / "RESULTS_urban.md"))
    args = ap.parse_args()

    import shapely

    import tinsmith
    from tinsmith.algorithms.urban.urban import estimate_ground, urban_model
    from tinsmith.io.vector import read_polygons
    from tinsmith.metrics import footprint_iou, match_buildings, polygon_mask, raised_footprint, rmse_over

    hf = tinsmith.read_heightfield(DSM)
    reference, _ = read_polygons(BGT)
    hull = shapely.union_all(reference).convex_hull
    buildings = polygon_mask(reference, hf)
    ground = estimate_ground(hf)
    heights = reference_heights(hf)
    tinsmith.blocks(hf, lod=1)  # kernels loaded first
    rows = []
    for label, options in SETTINGS:
        start = time.perf_counter()
        model = urban_model(hf, **options)
        elapsed = time.perf_counter() - start
        outlines = [shapely.Polygon(r.outline, r.holes) for r in model.tree.regions if r.level == 1]
        n = model.mesh.n_vertices
        start = time.perf_counter()
        greedy = tinsmith.greedy(hf, max_vertices=n)
        t_greedy = time.perf_counter() - start
        row = {
            "setting": label, "n": n, "kept": n / hf.n_valid, "buildings": model.stats["n_buildings"],
            "iou_outlines": footprint_iou(outlines, reference, within=hull)["iou"],
            "match": match_buildings(outlines, reference, within=hull),
            "iou_raised": footprint_iou(raised_footprint(model.mesh, hf, ground, RAISED), reference, within=hull)["iou"],
            "rmse": rmse_over(model.mesh, hf, buildings), "time": elapsed,
            "g_iou_raised": footprint_iou(raised_footprint(greedy, hf, ground, RAISED), reference, within=hull)["iou"],
            "g_rmse": rmse_over(greedy, hf, buildings), "g_time": t_greedy,
            "height": height_error(model.mesh, hf, heights), "g_height": height_error(greedy, hf, heights),
        }
        rows.append(row)
        print({k: v for k, v in row.items() if k != "match"}, flush=True)
    lines = [
        "# Urban models of the Delft DSM (the Salt Lake City thesis, chapter 4) against the BGT building outlines",
        "",
        "Command: `python benchmarks/urban_delft.py`  ",
        f"{machine()}. DSM {hf.shape[0]} x {hf.shape[1]} cells of 0.5 m ({hf.n_valid:,} valid); reference: "
        f"{len(reference)} BGT building polygons, compared inside their convex hull "
        f"({hull.area:,.0f} m2). Greedy insertion gets the block model's vertex count.",
        "",
        "| setting | block model points | of the cells | buildings | IoU, outlines | per-building IoU (mean) "
        "| matched (IoU >= 0.5) "
        "| IoU, raised > 2 m | RMSE over buildings (m) | height error vs 3dfier (m) | time (s) | greedy IoU, raised > 2 m "
        "| greedy RMSE over buildings (m) | greedy height error (m) | greedy time (s) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['setting']} | {r['n']:,} | {100 * r['kept']:.1f}% | {r['buildings']} | {r['iou_outlines']:.3f} "
            f"| {r['match']['mean_iou']:.3f} | {100 * r['match']['matched']:.1f}% "
            f"| {r['iou_raised']:.3f} | {r['rmse']:.2f} | {r['height']:.2f} | {r['time']:.2f} | {r['g_iou_raised']:.3f} "
            f"| {r['g_rmse']:.2f} | {r['g_height']:.2f} | {r['g_time']:.3f} |"
        )
    lines += [
        "",
        "IoU, outlines: the union of the buildings (regions on the ground) against the union of the reference, "
        "inside the reference's convex hull. Per-building: each reference building against the outline that "
        "overlaps it most; one outline of a block of row houses covers many reference buildings, so few match. "
        "RMSE over buildings: the mesh's height minus the DSM's over the cells of the reference buildings "
        "(flat roofs at the median height against sloping roofs). Height error: the mean absolute difference, over "
        f"the {len(heights[0])} reference buildings, between the median height of the mesh over a building's cells "
        f"and the top of 3dfier's LoD 1 block for it (the DSM's own median differs from it by {heights[2]:.2f} m on "
        "average).",
    ]
    lines += ["", "![where the outlines and the reference differ](../docs/img/urban_delft_iou.png)"]
    Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")
    picture(hf, reference, hull, urban_model(hf, lod=4, noise_factor=10), HERE.parent / "docs/img/urban_delft_iou.png")


def reference_heights(hf):
    """(per-building cell masks, the top of 3dfier's block for each, mean |DSM median - top|), matched by lokaalid."""
    from urban_cities import reference

    from tinsmith.metrics import polygon_mask

    polygons, lokaalid, tops = reference()
    masks, values = [], []
    for key, polygon in zip(lokaalid, polygons, strict=True):
        mask = polygon_mask([polygon], hf) & hf.valid
        if key in tops and mask.any():
            masks.append(mask)
            values.append(tops[key])
    values = np.array(values)
    dsm = np.array([np.median(hf.z[m]) for m in masks])
    return masks, values, float(np.mean(np.abs(dsm - values)))


def height_error(mesh, hf, heights) -> float:
    """Mean |median height of the mesh over a reference building's cells - the top of 3dfier's block|."""
    from tinsmith.metrics import rasterize

    masks, values, _ = heights
    tin = rasterize(mesh, hf)
    ours = np.array([np.nanmedian(tin[m]) for m in masks])
    return float(np.nanmean(np.abs(ours - values)))


def picture(hf, reference, hull, model, path) -> None:
    """Where the thesis setting's buildings (LOD 4 / NF 10) and the reference agree and differ, inside the hull."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import shapely

    found = shapely.union_all([shapely.Polygon(r.outline, r.holes) for r in model.tree.regions if r.level == 1])
    found = found.intersection(hull)
    ref = shapely.union_all(reference).intersection(hull)
    parts = [
        (found.intersection(ref), "#4c9a2a", f"both: {found.intersection(ref).area:,.0f} m2"),
        (found.difference(ref), "#d1495b", f"found only (trees, sheds, walls): {found.difference(ref).area:,.0f} m2"),
        (ref.difference(found), "#2e86de", f"reference only: {ref.difference(found).area:,.0f} m2"),
    ]
    fig, ax = plt.subplots(figsize=(9, 8), constrained_layout=True)
    xmin, ymin, xmax, ymax = hf.bounds
    ax.imshow(np.where(hf.valid, hf.z, np.nan), extent=(xmin, xmax, ymin, ymax), cmap="gray", alpha=0.6)
    for geom, colour, label in parts:
        for poly in shapely.get_parts(geom):
            if poly.geom_type == "Polygon" and not poly.is_empty:
                ax.fill(*poly.exterior.xy, color=colour, alpha=0.75, lw=0)
        ax.fill([], [], color=colour, label=label)
    ax.plot(*hull.exterior.xy, "k--", lw=0.8, label="reference's convex hull")
    iou = found.intersection(ref).area / found.union(ref).area
    ax.set_title(f"Delft, LOD 4 / NF 10: buildings against BGT, IoU {iou:.3f}")
    ax.legend(loc="lower left", fontsize=8)
    ax.ticklabel_format(useOffset=False, style="plain")
    ax.tick_params(labelsize=7)
    fig.savefig(path, dpi=80)
    plt.close(fig)


if __name__ == "__main__":
    main()
