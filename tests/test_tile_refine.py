"""The deepest level of a terrain pyramid refined at the DEM's cells: the bound at every cell, the seams untouched."""

from __future__ import annotations

import numpy as np
import pytest

import tinsmith
from tinsmith.io.quantized_mesh import QUANT
from tinsmith.tiles import pyramid as pyramid_module
from tinsmith.tiles.cesium import quantized_mesh_pyramid
from tinsmith.tiles.pyramid import fill_height, pyramid_job, tile_bounds, tile_geometry

ST_HELENS = tinsmith.sample_path("st-helens")


def test_the_default_zoom_holds_the_bound_at_every_cell(tmp_path):
    """St. Helens at its default deepest level, about 1.6 nodes a 30 m cell: meshed on the nodes alone, a cell
    stood 12.97 m from the mesh with every node within 2 m; refined, every cell is within the bound."""
    summary = quantized_mesh_pyramid(ST_HELENS, tmp_path / "p", max_error=2.0, tile_cells=128, min_zoom=12,
                                     workers=1)
    deepest = summary["levels"][summary["max_zoom"]]
    assert summary["max_zoom"] == 13 and deepest["cells"] > 140_000
    assert 1.0 < deepest["max_error"] <= 2.0
    assert summary["levels"][12]["max_error"] > 2.0  # the level above is meshed to its own, larger bound


def _edges(tri: np.ndarray) -> np.ndarray:
    e = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    return e[np.lexsort(e.T[::-1])]


@pytest.mark.parametrize("fill", [False, True])
def test_refinement_keeps_the_nodes_the_seams_and_the_filled_triangles(monkeypatch, fill):
    """Every tile of the deepest level, with nodes beyond the DEM filled (3D Tiles) or not: the mesher's vertices
    stay first and unchanged, new ones lie strictly inside the tile, the triangles tile the same area
    counter-clockwise with no edge used thrice, the tile's outline is the same edges, triangles reaching a filled
    node are untouched, and the tile's cells and nodes are within the bound."""
    seen = []
    original = pyramid_module.refine_at_cells

    def spy(job, bounds, samples, missing, rows, cols, h, triangles, filled, bound):
        out = original(job, bounds, samples, missing, rows, cols, h, triangles, filled, bound)
        seen.append((rows.copy(), cols.copy(), np.asarray(triangles).copy(), filled.copy(), out))
        return out

    monkeypatch.setattr(pyramid_module, "refine_at_cells", spy)
    job = pyramid_job(ST_HELENS, max_error=2.0, tile_cells=128, max_zoom=12)  # a node every 38 m: 30 m cells
    N, added = job.tile_cells, 0
    for tile in job.tiles(12):
        seen.clear()
        g = tile_geometry(tile, job, fill=fill_height(job) if fill else None)
        if not seen:
            continue
        rows, cols, tri0, filled, out = seen[0]
        V0, tri = len(rows), np.asarray(g["triangles"], np.int64)
        added += len(out.rows)
        assert np.array_equal(g["rows"][:V0], rows) and np.array_equal(g["cols"][:V0], cols)
        assert ((out.u > 0) & (out.u < QUANT) & (out.v > 0) & (out.v < QUANT)).all()
        x, y = np.asarray(g["cols"], float), N - np.asarray(g["rows"], float)
        area = (x[tri[:, 1]] - x[tri[:, 0]]) * (y[tri[:, 2]] - y[tri[:, 0]]) - \
               (x[tri[:, 2]] - x[tri[:, 0]]) * (y[tri[:, 1]] - y[tri[:, 0]])
        area0 = (x[tri0[:, 1]] - x[tri0[:, 0]]) * (y[tri0[:, 2]] - y[tri0[:, 0]]) - \
                (x[tri0[:, 2]] - x[tri0[:, 0]]) * (y[tri0[:, 1]] - y[tri0[:, 0]])
        assert (area > 0).all() and area.sum() == pytest.approx(area0.sum(), rel=1e-12)
        e = _edges(tri)
        pairs, counts = np.unique(e, axis=0, return_counts=True)
        assert counts.max() <= 2
        pairs0, counts0 = np.unique(_edges(tri0), axis=0, return_counts=True)
        outline0 = pairs0[counts0 == 1]
        assert np.array_equal(pairs[counts == 1], outline0)  # the seams and the holes' edges, as the mesher left them
        keep0 = {tuple(sorted(t)) for t in tri0[filled[tri0].any(axis=1)]}
        keep = {tuple(sorted(t)) for t in tri[np.asarray(g["filled"])[tri].any(axis=1)]}
        assert keep == keep0
        from tinsmith.tiles.certificate import tile_certificate

        cert = tile_certificate(job, tile_bounds(*tile), g, job.h_min + g["k"] * job.h_step)
        assert cert["max_error"] <= 2.0
    assert added > 1000


def test_bound_at_nodes_leaves_the_tiles_as_meshed_and_says_so(tmp_path, capsys):
    """``--bound-at nodes``: no vertex added, fewer triangles, and the certificate shows what the cells get."""
    from tinsmith.cli.main import main
    from tinsmith.errors import InvalidOptionError

    common = ["tile", str(ST_HELENS), "--format", "quantized-mesh", "--max-error", "2", "--tile-cells", "128",
              "--min-zoom", "12", "--no-metadata", "--workers", "1", "--json"]
    import json

    reports = {}
    for where in ("cells", "nodes"):
        assert main([*common, "-o", str(tmp_path / where), "--bound-at", where]) == 0
        reports[where] = json.loads(capsys.readouterr().out)
    cells, nodes = (reports[w]["levels"]["13"] for w in ("cells", "nodes"))
    assert reports["nodes"]["bound_at"] == "nodes" and nodes["refined"] == 0 and cells["refined"] > 10_000
    assert nodes["triangles"] < cells["triangles"]
    assert nodes["max_error"] > 10.0 >= 2.0 >= cells["max_error"]  # a cell 12.97 m off with every node within 2 m
    assert main(["tile", str(ST_HELENS), "--format", "quantized-mesh", "--max-error", "2", "-o",
                 str(tmp_path / "x"), "--bound-at", "edges"]) != 0
    assert "--bound-at" in capsys.readouterr().err
    with pytest.raises(InvalidOptionError, match="bound_at must be one of cells, nodes"):
        pyramid_job(ST_HELENS, max_error=2.0, bound_at="edges")
