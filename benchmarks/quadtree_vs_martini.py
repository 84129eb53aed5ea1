"""Quadtree (RTIN): tinsmith against pymartini, side by side in one run.

    pip install -e ".[test]"                      # pymartini comes with the test extra
    python benchmarks/quadtree_vs_martini.py      # writes benchmarks/RESULTS_quadtree.md
    python benchmarks/quadtree_vs_martini.py --quick

Both take a (2^k + 1)-square float32 grid: St. Helens padded to 513 x 513
(edges repeated) and the 4097 x 4097 DEM of make_large_dem.py.  Timings are
in one process, the best of ``--repeat`` runs, each tool's code loaded (and
compiled) before the clock starts:

- hierarchy: tinsmith's ``QuadtreeHierarchy(hf, strict=False)`` against
  pymartini's ``Martini(n)`` plus ``create_tile`` (the first is reusable for
  tiles of one size, so ``create_tile`` alone is listed too);
- extraction: ``QuadtreeHierarchy.mesh(e)`` (a TerrainMesh in world
  coordinates) against ``get_mesh(e)`` (pixel coordinates); these take
  milliseconds, so they take turns, best of ten times ``--repeat`` runs.

The meshes of the non-strict mode are compared triangle by triangle with
pymartini's; the strict mode's meshes are listed beside them, every mesh
judged by tinsmith's metrics.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from _common import HERE, large_dem, machine


def best_pair(ours, theirs, repeat):
    """Best times of two calls that take turns ``repeat`` times (a slow spell of the machine hits both), with their results."""
    times, results = ([], []), [None, None]
    for _ in range(repeat):
        for k, fn in enumerate((ours, theirs)):
            start = time.perf_counter()
            results[k] = fn()
            times[k].append(time.perf_counter() - start)
    return min(times[0]), results[0], min(times[1]), results[1]


def best(fn, repeat):
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - start)
    return min(times), out


def load(quick: bool, workdir: Path):
    import tinsmith

    z = tinsmith.sample("st-helens").z
    z = np.where(np.isnan(z), np.nanmin(z), z)
    dems = [("St. Helens padded 513x513", np.pad(z, ((0, 513 - z.shape[0]), (0, 513 - z.shape[1])), mode="edge"))]
    if not quick:
        import rasterio

        with rasterio.open(large_dem(workdir)) as ds:
            dems.append(("make_large_dem 4097x4097", ds.read(1)))
    return [(name, np.ascontiguousarray(z, dtype=np.float32)) for name, z in dems]


def pixel_triangles(mesh, hf):
    r, c = hf.world_to_pixel(mesh.vertices[:, 0], mesh.vertices[:, 1])
    px = np.rint(np.column_stack([c, r])).astype(np.int64)
    return np.sort(np.sort(px[mesh.triangles] @ np.array([1, 1 << 20]), axis=1), axis=0)


def martini_triangles(vertices, triangles):
    v = vertices.reshape(-1, 2).astype(np.int64)
    return np.sort(np.sort(v[triangles.reshape(-1, 3)] @ np.array([1, 1 << 20]), axis=1), axis=0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="St. Helens only")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--errors", type=float, nargs="+", default=[20.0, 5.0, 1.0])
    ap.add_argument("--out", default=str(HERE / "RESULTS_quadtree.md"))
    ap.add_argument("--workdir", default=str(HERE / ".cache"))
    args = ap.parse_args()
    Path(args.workdir).mkdir(exist_ok=True)

    from pymartini import Martini

    import tinsmith

    warm = tinsmith.Heightfield(np.random.default_rng(0).normal(size=(65, 65)).astype(np.float32), cell_size=1.0)
    for strict in (False, True):
        tinsmith.QuadtreeHierarchy(warm, strict=strict).mesh(0.5)
    Martini(65).create_tile(warm.z).get_mesh(0.5)

    rows = []
    for name, z in load(args.quick, Path(args.workdir)):
        n = z.shape[0]
        hf = tinsmith.Heightfield(z, cell_size=1.0)
        t_ours, tree = best(lambda hf=hf: tinsmith.QuadtreeHierarchy(hf, strict=False), args.repeat)
        t_strict, strict_tree = best(lambda hf=hf: tinsmith.QuadtreeHierarchy(hf, strict=True), args.repeat)
        t_init, martini = best(lambda n=n: Martini(n), args.repeat)
        t_tile, tile = best(lambda martini=martini, z=z: martini.create_tile(z), args.repeat)
        for e in args.errors:
            # milliseconds each: ten times the repeats, the two taking turns
            t_mesh, mesh, t_get, (verts, tris) = best_pair(lambda tree=tree, e=e: tree.mesh(e),
                                                           lambda tile=tile, e=e: tile.get_mesh(e), 10 * args.repeat)
            same = np.array_equal(pixel_triangles(mesh, hf), martini_triangles(verts, tris))
            strict_mesh = strict_tree.mesh(e)
            row = dict(
                dem=name, e=e, hier=t_ours, strict_hier=t_strict, init=t_init, tile=t_tile, mesh=t_mesh, get=t_get,
                same=same, tris=mesh.n_triangles, m_tris=len(tris.reshape(-1, 3)),
                err=tinsmith.vertical_error(mesh, hf)["max"], strict_tris=strict_mesh.n_triangles,
                strict_err=tinsmith.vertical_error(strict_mesh, hf)["max"],
            )
            rows.append(row)
            print(row, flush=True)
    write(rows, args)


def write(rows, args) -> None:
    lines = [
        "# Quadtree (RTIN): tinsmith vs pymartini",
        "",
        f"Command: `python benchmarks/quadtree_vs_martini.py{' --quick' if args.quick else ''} --repeat {args.repeat}`  ",
        f"{machine()}; best of {args.repeat} runs in one process (extraction: {10 * args.repeat}, the two tools taking "
        "turns), code loaded before timing.",
        "Hierarchy: `QuadtreeHierarchy(hf, strict=False)` against `Martini(n)` + `create_tile`; extraction: "
        "`mesh(e)` (world coordinates) against `get_mesh(e)` (pixel coordinates). Errors by tinsmith's metrics.",
        "",
        "| DEM | max_error | hierarchy s (strict) | pymartini Martini(n) + create_tile s "
        "| hierarchy ratio (vs create_tile alone) | mesh s | get_mesh s | extraction ratio | same meshes | triangles "
        "| Martini max error | strict triangles | strict max error |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['dem']} | {r['e']:g} | {r['hier']:.3f} ({r['strict_hier']:.3f}) | {r['init']:.3f} + {r['tile']:.3f} "
            f"| {r['hier'] / (r['init'] + r['tile']):.2f} ({r['hier'] / r['tile']:.2f}) | {r['mesh']:.4f} | {r['get']:.4f} "
            f"| {r['mesh'] / r['get']:.2f} | {'yes' if r['same'] else 'NO'} | {r['tris']:,} | {r['err']:.3f} "
            f"| {r['strict_tris']:,} | {r['strict_err']:.3f} |"
        )
    Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
