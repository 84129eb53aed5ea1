"""Decimation: tinsmith against VTK's vtkQuadricDecimation (through pyvista) at equal vertex counts.

    pip install -e ".[test]" pyvista fast-simplification
    python benchmarks/decimate_vs_vtk.py          # writes benchmarks/RESULTS_decimate.md

Every tool starts from the same full-resolution mesh of the DEM (tinsmith's
grid mesh: one vertex per cell, two triangles per square) and reduces it to
1% and 5% of the cells.  VTK (``PolyData.decimate``, vtkQuadricDecimation,
defaults; and with ``boundary_constraints``) is asked first; its vertex count
is then the budget of tinsmith's ``decimate``, and its triangle count that
of fast-simplification (MIT; the Fast Quadric Mesh Simplification
algorithm, which takes a triangle count), so all are judged at about the
same size.  The clock covers the decimation only: each tool
gets its input in its own form (a pyvista PolyData, arrays) built before
the clock starts, and the runs of the tools take turns, best of ``--repeat``.

Every output is judged against every valid cell of the DEM by tinsmith's
metrics: max and RMS vertical error, coverage (below 100%, the outline has
moved inwards) and the triangles that are turned over or flat seen from
above (the mesh is then no valid TIN).  The two peers are general 3-D
decimators: they move vertices off the cells, optimise the 3-D (not the
vertical) distance, and do not guard the 2-D orientation.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from _common import HERE, SHARED, machine

DEMS = [
    ("St. Helens 30 m", None),
    ("Big Tujunga 30 m", SHARED / "data/terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif"),
]


def judge(name, vertices, triangles, hf, seconds):
    import tinsmith

    mesh = tinsmith.TerrainMesh(vertices, triangles)
    err = tinsmith.vertical_error(mesh, hf)
    orient = mesh.orientations()
    return {
        "tool": name, "n_vertices": mesh.n_vertices, "n_triangles": mesh.n_triangles,
        "max": err["max"], "rmse": err["rmse"], "coverage": err["coverage"],
        "turned": int(np.count_nonzero(orient <= 0)), "time": seconds,
    }


def run(hf, share, repeat):
    import fast_simplification
    import pyvista as pv

    import tinsmith
    from tinsmith.triangulation.grid import grid_mesh

    fine = grid_mesh(hf)
    centre = fine.vertices.mean(axis=0)  # VTK works in float32: centred, as a user would
    poly = pv.PolyData(fine.vertices - centre, np.column_stack([np.full(fine.n_triangles, 3), fine.triangles]).ravel())
    reduction = 1.0 - share * hf.n_valid / fine.n_vertices
    times = {k: [] for k in ("vtk", "vtk_boundary", "tinsmith", "fast")}
    out = {}
    for _ in range(repeat):
        for key, kwargs in (("vtk", {}), ("vtk_boundary", {"boundary_constraints": True})):
            start = time.perf_counter()
            red = poly.decimate(reduction, **kwargs)
            times[key].append(time.perf_counter() - start)
            out[key] = (np.asarray(red.points, np.float64) + centre, red.faces.reshape(-1, 4)[:, 1:])
        n = len(out["vtk"][0])
        start = time.perf_counter()
        mesh = tinsmith.decimate(hf, max_vertices=n)
        times["tinsmith"].append(time.perf_counter() - start)
        out["tinsmith"] = (mesh.vertices, mesh.triangles)
        start = time.perf_counter()
        pts, tris = fast_simplification.simplify(fine.vertices - centre, fine.triangles, target_count=len(out["vtk"][1]))
        times["fast"].append(time.perf_counter() - start)
        out["fast"] = (pts + centre, tris)
    names = {"vtk": "VTK vtkQuadricDecimation", "vtk_boundary": "VTK, boundary_constraints",
             "tinsmith": "tinsmith decimate", "fast": "fast-simplification"}
    return [judge(names[k], *out[k], hf, min(times[k])) for k in ("tinsmith", "vtk", "vtk_boundary", "fast")]


def table(rows):
    ref = next(r for r in rows if r["tool"] == "VTK vtkQuadricDecimation")
    lines = [
        "| tool | vertices | triangles | max error | RMS error | coverage | turned over | time | time / VTK |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in rows:
        lines.append(
            f"| {r['tool']} | {r['n_vertices']:,} | {r['n_triangles']:,} | {r['max']:.2f} | {r['rmse']:.3f} | "
            f"{100 * r['coverage']:.2f}% | {r['turned']} | {r['time']:.3f} s | {r['time'] / ref['time']:.2f} |"
        )
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shares", type=float, nargs="+", default=[0.01, 0.05], help="vertex budgets as shares of the valid cells")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", default=str(HERE / "RESULTS_decimate.md"))
    args = ap.parse_args()

    import tinsmith

    tinsmith.decimate(tinsmith.sample("st-helens"), max_vertices=1000)  # kernels loaded (compiled) first
    lines = [
        "# Decimation: tinsmith vs VTK (vtkQuadricDecimation) at equal vertex counts",
        "",
        "Command: `python benchmarks/decimate_vs_vtk.py`  ",
        f"{machine()}. Errors in metres against every valid cell; time is the decimation alone, best of {args.repeat}.",
    ]
    for label, path in DEMS:
        if path is not None and not path.exists():
            print(f"skipped {label}: {path} not found")
            continue
        hf = tinsmith.sample("st-helens") if path is None else tinsmith.read_heightfield(path)
        for share in args.shares:
            rows = run(hf, share, args.repeat)
            h, w = hf.shape
            lines += ["", f"## {label}, {h} x {w} ({hf.n_valid:,} valid cells), {share:.0%} of the cells", ""]
            lines.append(table(rows))
            print(label, share, [(r["tool"], r["n_vertices"], round(r["max"], 2), round(r["time"], 3)) for r in rows], flush=True)
    Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
