"""Quality meshes at the error bound of greedy insertion: vertices and plan-view angles against greedy and Triangle.

For each DEM, max_error is the error greedy insertion reaches with 1% and 5% of the valid cells.  Rows:

- greedy: greedy insertion at that bound (our exact scan; slivers allowed);
- quality, refinement alone: ``method="quality"`` with ``improve=0``: Delaunay refinement only;
- quality: ``method="quality"`` at that bound with ``min_angle=30`` (the exact bound *and* 30 degrees), with its
  default improvement passes (vertices removed and moved while both bounds hold);
- cvt + greedy anchors: ``method="cvt"`` with quality's vertex count, half of them greedy insertion's first
  insertions held still (``anchor_fraction=0.5``): well-shaped, but no error bound, so its error is measured;
- triangle q30: Triangle (Shewchuk; ``pip install triangle``, non-commercial licence: a peer here only) run on
  greedy's vertices with ``q30`` (quality only: Triangle has no error test, and its Steiner points get the DEM's
  bilinear height, so its error is reported as measured).

Columns: vertices, ratio to greedy, share of triangles with a plan-view minimum angle >= 30 degrees, smallest
plan-view angle, share of triangles with a 3-D minimum angle >= 30 degrees (what a surface solver sees),
max vertical error over every valid cell (tinsmith.metrics), time.

Then the solver files: a quality mesh of the Big Tujunga DEM with a breakline and a region (a channel band with
its own max_area) written as SMS 2DM and Gmsh .msh, and read back: the 2DM with Py2DM (node strings, materials),
the .msh with meshio and with the ``gmsh`` Python package (GPL: here only, never a dependency; skipped where it
does not install).  Writes RESULTS_quality.md.

    python benchmarks/quality_vs_peers.py
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

import tinsmith
from tinsmith.core import TerrainMesh
from tinsmith.kernels.quality import bilinear
from tinsmith.metrics import vertical_error
from tinsmith.metrics.quality import triangle_angles

HERE = Path(__file__).resolve().parent
DEMS = [
    ("St. Helens (sample)", HERE.parent / "src/tinsmith/data/samples/st_helens_30m.tif"),
    ("Big Tujunga", HERE.parent / "../shared/data/terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif"),
    ("Delft DTM", HERE.parent / "../shared/data/urban/delft_ahn3/delft_dtm_0.5m.tif"),
    ("CODEM DSM (not tuned on; nodata holes)", HERE.parent / "../shared/data/urban/codem_ncalm/codem_dsm_1m.tif"),
]


def row(name, mesh, hf, greedy_n, seconds):
    a = triangle_angles(mesh, dims=2).min(axis=1)
    a3 = triangle_angles(mesh, dims=3).min(axis=1)
    err = vertical_error(mesh, hf)
    return (f"| {name} | {mesh.n_vertices:,} | {mesh.n_vertices / greedy_n:.2f} | {100 * (a >= 30 - 1e-6).mean():.1f}% "
            f"| {a.min():.2f} | {100 * (a3 >= 30 - 1e-6).mean():.1f}% | {err['max']:.4g} "
            f"({100 * err['coverage']:.1f}% covered) | {seconds:.2f} |")


def triangle_peer(hf, greedy):
    import triangle

    xy = greedy.vertices[:, :2]
    t0 = time.perf_counter()
    out = triangle.triangulate({"vertices": xy}, "q30Q")
    seconds = time.perf_counter() - t0
    v = out["vertices"]
    row_, col = hf.world_to_pixel(v[:, 0], v[:, 1])
    h, w = hf.shape
    z = hf.z.ravel().astype(np.float32)
    valid = hf.valid.ravel().view(np.uint8)
    heights = np.array([bilinear(z, valid, False, h, w, c, r, np.nan) for r, c in zip(row_, col, strict=True)])
    tri = out["triangles"]
    keep = np.isfinite(heights[tri]).all(axis=1)  # triangles with a corner over nodata are dropped
    used, tri = np.unique(tri[keep], return_inverse=True)
    return TerrainMesh(np.column_stack([v[used], heights[used]]), tri.reshape(-1, 3)), seconds


def main() -> None:
    lines = ["# Quality meshes at greedy's error bound (`benchmarks/quality_vs_peers.py`)", "",
             "Rerun: `python benchmarks/quality_vs_peers.py` (Triangle rows need `pip install triangle`).", "",
             "| mesh | vertices | x greedy | plan angles >= 30 | smallest plan angle | 3-D angles >= 30 | max error "
             "| time (s) |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    try:
        import triangle  # noqa: F401
        have_triangle = True
    except ImportError:
        have_triangle = False
    for label, path in DEMS:
        if not path.exists():
            print(f"skipping {label}: {path} not found", file=sys.stderr)
            continue
        hf = tinsmith.read_heightfield(path)
        for share in (0.01, 0.05):
            greedy = tinsmith.greedy(hf, max_vertices=int(share * hf.n_valid))
            bound = float(greedy.info["error"]["max"])
            lines.append(f"| **{label}, {share:.0%} of {hf.n_valid:,} cells: max_error {bound:.4g}** | | | | | | | |")
            t0 = time.perf_counter()
            greedy = tinsmith.greedy(hf, max_error=bound)
            lines.append(row("greedy", greedy, hf, greedy.n_vertices, time.perf_counter() - t0))
            t0 = time.perf_counter()
            refined = tinsmith.simplify(hf, method="quality", max_error=bound, min_angle=30.0, improve=0)
            lines.append(row("quality, refinement alone (improve 0)", refined, hf, greedy.n_vertices,
                             time.perf_counter() - t0))
            t0 = time.perf_counter()
            quality = tinsmith.simplify(hf, method="quality", max_error=bound, min_angle=30.0)
            lines.append(row("**quality, min_angle 30 (default: refinement + improvement)**", quality, hf,
                             greedy.n_vertices, time.perf_counter() - t0))
            t0 = time.perf_counter()
            cvt = tinsmith.simplify(hf, method="cvt", max_vertices=quality.n_vertices, anchor_fraction=0.5)
            lines.append(row("cvt + greedy anchors (0.5), quality's vertices", cvt, hf, greedy.n_vertices,
                             time.perf_counter() - t0))
            if have_triangle:
                peer, seconds = triangle_peer(hf, greedy)
                lines.append(row("triangle q30 on greedy's vertices", peer, hf, greedy.n_vertices, seconds))
            print("\n".join(lines[-6:]), flush=True)
    lines += solver_files()
    print("\n".join(lines[-12:]), flush=True)
    out = HERE / "RESULTS_quality.md"
    keep = ""  # the section of quality_min_angle.py stays
    if out.exists() and "\n## Angle limit and guards" in out.read_text():
        keep = "\n" + out.read_text()[out.read_text().index("\n## Angle limit and guards"):]
    out.write_text("\n".join(lines) + "\n" + keep)


def solver_files() -> list[str]:
    """Write a quality mesh with a breakline and a region as 2DM and .msh; read them back with other tools."""
    import tempfile

    import meshio
    import shapely

    hf = tinsmith.read_heightfield(DEMS[1][1])
    x0, y0, x1, y1 = hf.bounds
    cy = 0.5 * (y0 + y1)
    crest = np.array([[x0 + 0.2 * (x1 - x0), cy], [x0 + 0.8 * (x1 - x0), cy]])
    channel = shapely.LineString([(x0, y0 + 0.3 * (y1 - y0)), (x1, y0 + 0.7 * (y1 - y0))]).buffer(300.0)
    mesh = tinsmith.simplify(hf, method="quality", max_error=20.0, breaklines=[crest],
                             regions=[(channel, 20_000.0, "channel")])
    out = ["", "## Solver files", "",
           f"Big Tujunga, `quality` at max_error 20 with a breakline (`crest`) and a region (`channel`, a 600 m band "
           f"across the DEM, max_area 20,000 m²): {mesh.n_vertices:,} vertices, {mesh.n_triangles:,} triangles, "
           f"{int((mesh.triangle_attributes['region'] == 1).sum()):,} in the channel.", "",
           "| file | read by | what it found |", "| --- | --- | --- |"]
    with tempfile.TemporaryDirectory() as tmp:
        p2dm, pmsh = tinsmith.write(mesh, Path(tmp) / "m.2dm"), tinsmith.write(mesh, Path(tmp) / "m.msh")
        try:
            import py2dm

            with py2dm.Reader(str(p2dm)) as reader:
                strings = [f"{ns.name} ({ns.num_nodes} nodes)" for ns in reader.iter_node_strings()]
                materials = sorted({e.materials[0] for e in reader.iter_elements()})
                out.append(f"| .2dm | Py2DM {py2dm.__version__} | {reader.num_nodes:,} nodes, {reader.num_elements:,} "
                           f"elements, materials {materials}; node strings: {', '.join(strings)} |")
        except ImportError:
            out.append("| .2dm | Py2DM | not installed |")
        ref = meshio.read(pmsh)
        groups = ", ".join(f"{name} (dim {v[1]}, tag {v[0]})" for name, v in ref.field_data.items())
        cells = ", ".join(f"{len(c.data):,} {c.type}s" for c in ref.cells)
        out.append(f"| .msh | meshio {meshio.__version__} | {cells}; physical groups: {groups} |")
        try:
            import gmsh
        except (ImportError, OSError) as exc:
            out.append(f"| .msh | gmsh | does not install here ({type(exc).__name__}) |")
        else:
            gmsh.initialize()
            try:
                gmsh.option.setNumber("General.Terminal", 0)
                gmsh.open(str(pmsh))
                found = []
                for dim, tag in gmsh.model.getPhysicalGroups():
                    nodes = gmsh.model.mesh.getNodesForPhysicalGroup(dim, tag)[0]
                    found.append(f"{gmsh.model.getPhysicalName(dim, tag)} (dim {dim}: {len(nodes):,} nodes)")
                types, tags, _ = gmsh.model.mesh.getElements(2)
                out.append(f"| .msh | gmsh {gmsh.__version__} | {sum(len(t) for t in tags):,} triangles; "
                           f"physical groups: {', '.join(found)} |")
            finally:
                gmsh.finalize()
    return out


if __name__ == "__main__":
    main()
