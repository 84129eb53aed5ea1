"""Goebbels and Pohle-Fröhlich (2015)'s tables on the Delft DTM and DSM.

Quadtree triangles with spline and land-use steered Haar filtering.

    python benchmarks/wavelet_delft.py      # writes benchmarks/RESULTS_wavelet.md and docs/img/wavelet_*.png

Land use: the BGT extract of the same area (``vector/delft_bgt``) with the
default roles.  Every count is of the quadtree with the diagonal rule
(formula 1), whose bound ``epsilon`` holds against the filtered heights as
in the paper; "unfiltered" is the same quadtree on the input.

- Table 2: delta 4 m, 3 spline iterations: unfiltered, spline only, spline
  with the unfiltered heights of classes 1 and 2, filter (3), filter (4);
  and tinsmith's soft replacement (with unfiltered detail, and with filter 4).
- Table 3: spline iterations 1 to 6 at epsilon 0.05 and 0.2 (filter 4, hard as the paper).
- Table 4: iterations 1 to 6 for delta 1, 2, 4, 6 (filter 4, hard, epsilon 0.2),
  and the count "auto" picks.
- Error by class against the unfiltered heights at epsilon 0.2.
- What flat water costs the quadtree (DTM).
"""

from __future__ import annotations

import time
import warnings

import numpy as np
from _common import HERE, ROOT, SHARED, machine

import tinsmith
from tinsmith.algorithms.grid.quadtree import QuadtreeHierarchy
from tinsmith.algorithms.wavelet.landuse import read_landuse
from tinsmith.algorithms.wavelet.spline import spline_filter
from tinsmith.errors import TinsmithWarning

DELFT = SHARED / "data/urban/delft_ahn3"
BGT = SHARED / "data/vector/delft_bgt/delft_bgt_all_epsg28992.geojson"
EPSILONS = (0.2, 0.1, 0.05)
ITERATIONS = range(1, 7)
DELTAS = (1.0, 2.0, 4.0, 6.0)

#: Table 2's columns after "unfiltered" and "spline only": (header, options of wavelet_filter)
VARIANTS = [
    ("spline, unfiltered detail", {"variant": None, "replace": "hard"}),
    ("filter (3)", {"variant": 3, "replace": "hard"}),
    ("filter (4)", {"variant": 4, "replace": "hard"}),
    ("soft, unfiltered detail", {"variant": None, "replace": "soft"}),
    ("soft, filter (4)", {"variant": 4, "replace": "soft"}),
]


def counts(hf, epsilons=EPSILONS) -> list:
    tree = QuadtreeHierarchy(hf, diagonal="rule")
    return [tree.mesh(e).n_triangles for e in epsilons]


def filtered(hf, landuse, iterations, **options):
    return tinsmith.wavelet_filter(hf, landuse=landuse, spline_iterations=iterations, **options).heightfield


def fmt(n: int) -> str:
    return f"{n:,}"


def table_2(hf, landuse) -> list:
    base = counts(hf)
    columns = [("spline only", counts(spline_filter(hf, 3)))]
    columns += [(name, counts(filtered(hf, landuse, 3, **opts))) for name, opts in VARIANTS]
    lines = ["| epsilon | unfiltered | " + " | ".join(name for name, _ in columns) + " |",
             "| --- " * (2 + len(columns)) + "|"]
    for k, e in enumerate(EPSILONS):
        cells = [f"{fmt(c[k])} ({base[k] / c[k]:.1f}x)" for _, c in columns]
        lines.append(f"| {e} | {fmt(base[k])} | " + " | ".join(cells) + " |")
    return lines


def table_3(hf, landuse) -> list:
    lines = ["| spline iterations | spline only, 0.05 m | filter (4), 0.05 m | spline only, 0.2 m | filter (4), 0.2 m |",
             "| --- | --- | --- | --- | --- |"]
    for k in ITERATIONS:
        s = counts(spline_filter(hf, k), (0.05, 0.2))
        f = counts(filtered(hf, landuse, k, variant=4, replace="hard"), (0.05, 0.2))
        lines.append(f"| {k} | {fmt(s[0])} | {fmt(f[0])} | {fmt(s[1])} | {fmt(f[1])} |")
    return lines


def table_4(hf, landuse) -> list:
    lines = ["| delta | " + " | ".join(f"{k} iterations" for k in ITERATIONS) + " | auto picks |",
             "| --- " * (len(ITERATIONS) + 2) + "|"]
    for delta in DELTAS:
        row = {k: counts(filtered(hf, landuse, k, delta=delta, replace="hard"), (0.2,))[0] for k in ITERATIONS}
        auto = tinsmith.wavelet_filter(hf, landuse=landuse, delta=delta, max_error=0.2, replace="hard")
        best = min(row, key=lambda k: (row[k], k))
        assert auto.spline_iterations == best and auto.triangles == row, (auto.triangles, row)
        lines.append(f"| {delta:g} | " + " | ".join(fmt(row[k]) for k in ITERATIONS) + f" | {auto.spline_iterations} |")
    return lines


def class_errors(hf, landuse) -> tuple:
    lines = ["| setting | iterations (auto) | triangles | class | cells | filter max | mesh max | mesh RMS |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    results = {}
    for name, opts in [("paper: filter (4), hard", {"variant": 4, "replace": "hard"}),
                       ("default: filter (4), soft", {"variant": 4}),
                       ("soft, unfiltered detail", {"variant": None, "replace": "soft"}),
                       ("soft, unfiltered detail, water not flattened",
                        {"variant": None, "replace": "soft", "flatten_water": False})]:
        start = time.perf_counter()
        mesh = tinsmith.wavelet(hf, landuse=landuse, max_error=0.2, **opts)
        result = tinsmith.wavelet_filter(hf, landuse=landuse, max_error=0.2, **opts)  # what the mesh was made of
        elapsed = time.perf_counter() - start
        results[name] = (mesh, result, elapsed)
        for cls, e in mesh.info["wavelet"]["error_by_class"].items():
            lines.append(f"| {name} | {result.spline_iterations} | {fmt(mesh.n_triangles)} | {cls} | {fmt(e['cells'])} | "
                         f"{e['filter_max']:.3f} | {e['max']:.3f} | {e['rmse']:.3f} |")
    return lines, results


def water_cost(hf, landuse) -> list:
    """What flat water costs the quadtree at 0.2 m: the DTM with its water flattened, and a flat
    water surface a step above (or below) otherwise flat land."""
    result = tinsmith.wavelet_filter(hf, landuse=landuse, spline_iterations=1)
    flat = result.classes == 6
    z = hf.z.astype(np.float64)
    z[flat] = result.heightfield.z[flat]
    rows = [("the DTM, unfiltered", counts(hf, (0.2,))[0]),
            ("the DTM, unfiltered, water flattened", counts(tinsmith.Heightfield(z, transform=hf.transform), (0.2,))[0])]
    for step in (0.3, 0.6, 1.0):
        rows.append((f"flat land, the water {step} m above it",
                     counts(tinsmith.Heightfield(np.where(flat, step, 0.0), transform=hf.transform), (0.2,))[0]))
    return ["| surface | triangles at 0.2 m |", "| --- | --- |"] + [f"| {name} | {fmt(n)} |" for name, n in rows]


def pictures(hf, results) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    _, result, _ = results["paper: filter (4), hard"]
    fig, ax = plt.subplots(1, 3, figsize=(18, 6.2))
    lo, hi = np.percentile(hf.z, [1, 99])
    ax[0].imshow(hf.z, vmin=lo, vmax=hi, cmap="terrain")
    ax[0].set_title("Delft DTM 0.5 m (unfiltered)")
    ax[1].imshow(result.heightfield.z, vmin=lo, vmax=hi, cmap="terrain")
    ax[1].set_title(f"filtered: filter (4), {result.spline_iterations} spline iterations, water flat")
    colours = ["white", "tab:red", "darkred", "tab:orange", "gold", "lightgrey", "tab:blue"]
    ax[2].imshow(result.classes, cmap=ListedColormap(colours), vmin=-0.5, vmax=6.5, interpolation="nearest")
    ax[2].set_title("classes: 1 red (embankment dark), 2 orange, 3 grey, water blue")
    for a in ax:
        a.set_xticks([])
        a.set_yticks([])
    fig.tight_layout()
    fig.savefig(ROOT / "docs/img/wavelet_classes.png", dpi=90)
    plt.close(fig)

    meshes = [("unfiltered quadtree", QuadtreeHierarchy(hf, diagonal="rule").mesh(0.2))]
    meshes += [(name, results[name][0]) for name in ("paper: filter (4), hard", "soft, unfiltered detail")]
    fig, ax = plt.subplots(1, 3, figsize=(21, 7.4))
    for a, (name, mesh) in zip(ax, meshes, strict=True):
        row, col = hf.world_to_pixel(mesh.vertices[:, 0], mesh.vertices[:, 1])
        a.triplot(col, row, mesh.triangles, lw=0.15, color="k")
        a.set_xlim(0, hf.shape[1] - 1)
        a.set_ylim(hf.shape[0] - 1, 0)
        a.set_aspect(1)
        a.set_xticks([])
        a.set_yticks([])
        a.set_title(f"{name}: {mesh.n_triangles:,} triangles at 0.2 m")
    fig.tight_layout()
    fig.savefig(ROOT / "docs/img/wavelet_meshes.png", dpi=70)
    plt.close(fig)


def main() -> None:
    warnings.simplefilter("ignore", TinsmithWarning)  # one road part of the extract lies beyond the DEM
    landuse = read_landuse(BGT)
    lines = ["# Spline and land-use steered Haar filtering (Goebbels and Pohle-Fröhlich 2015): quadtree triangles on Delft", "",
             "Command: `python benchmarks/wavelet_delft.py`  ", f"{machine()}.", "",
             "Quadtree with the diagonal rule; its bound epsilon holds against the filtered heights, as in the paper. "
             "Land use: the BGT extract with the default roles (3 water parts, 3 bridge decks, 151 road parts, "
             "13 quay walls, 1 weir as embankment); window 9 points, bridges extended by 2 m, replacement "
             "tolerance 0.3 m, Table 1's thresholds. Ratios: unfiltered triangles over filtered.", ""]
    start = time.perf_counter()
    for name in ("dtm", "dsm"):
        hf = tinsmith.read_heightfield(DELFT / f"delft_{name}_0.5m.tif")
        title = f"Delft {name.upper()} 0.5 m, {hf.shape[0]} x {hf.shape[1]}"
        lines += [f"## {title}", "", "### Table 2: delta 4 m, 3 spline iterations", ""] + table_2(hf, landuse)
        lines += ["", "### Table 3: spline iterations (delta 4 m, filter 4, hard)", ""] + table_3(hf, landuse)
        lines += ["", "### Table 4: triangles at 0.2 m against spline iterations and delta (filter 4, hard)", ""]
        lines += table_4(hf, landuse)
        err_lines, results = class_errors(hf, landuse)
        lines += ["", "### Error against the unfiltered heights by class, epsilon 0.2 m, auto iterations", ""] + err_lines
        lines += ["", "Time of `tinsmith.wavelet` with auto (six filters and quadtrees): "
                  + ", ".join(f"{k} {v[2]:.2f} s" for k, v in results.items()) + ".", ""]
        if name == "dtm":
            lines += ["### What flat water costs the quadtree", "",
                      "The water parts of this DTM are interpolated surfaces whose heights vary by up to 2 m; "
                      "flattened, each meets its banks with a step along the whole shoreline, which the quadtree "
                      "follows at single cells.", ""] + water_cost(hf, landuse) + [""]
            pictures(hf, results)
    lines += [f"Total run time {time.perf_counter() - start:.0f} s.", ""]
    (HERE / "RESULTS_wavelet.md").write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
