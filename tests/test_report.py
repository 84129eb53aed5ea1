"""The HTML report, the viewer page, the PNG helpers, and both pages in headless Chromium."""

from __future__ import annotations

import json
import os
import re

import numpy as np
import pytest

import tinsmith
from tinsmith.viz import figures
from tinsmith.viz.browser import chromium_path, render_page
from tinsmith.viz.report import report_html
from tinsmith.viz.viewer import viewer_html, write_viewer

from .conftest import run_cli


@pytest.fixture(scope="module")
def st_helens_meshes(tmp_path_factory):
    """St. Helens meshed by greedy, quadtree and cvt, written as PLY files."""
    hf = tinsmith.sample("st-helens")
    folder = tmp_path_factory.mktemp("meshes")
    made = {"greedy": tinsmith.greedy(hf, max_error=5), "quadtree": tinsmith.quadtree(hf, max_error=5),
            "cvt": tinsmith.cvt(hf, max_vertices=4000, max_iter=20)}
    paths = {}
    for name, mesh in made.items():
        paths[name] = folder / f"{name}.ply"
        tinsmith.write(mesh, paths[name])
    return hf, paths


def _embedded_metrics(page: str) -> dict:
    return json.loads(re.search(r'<script type="application/json" id="metrics">(.*?)</script>', page, re.DOTALL).group(1))


def test_report_numbers_equal_the_metrics_command(st_helens_meshes, tmp_path, capsys):
    hf, paths = st_helens_meshes
    out = tmp_path / "report.html"
    code, _, err = run_cli(capsys, "report", "--sample", "st-helens", *paths.values(), "-o", out)
    assert code == 0, err
    page = out.read_text()
    assert out.stat().st_size < 20e6
    shown = _embedded_metrics(page)
    for _name, path in paths.items():
        code, text, err = run_cli(capsys, "metrics", path, "--sample", "st-helens", "--json")
        assert code == 0, err
        expected = json.loads(text)
        for key in ("mesh", "dem", "timings"):
            expected.pop(key)
        assert shown[path.name] == expected
        # the table shows the same numbers, rounded
        row = re.search(rf"<tr><td>{re.escape(path.name)}</td>(.*?)</tr>", page).group(1)
        assert f"<td>{expected['n_triangles']:,}</td>" in row
        assert f"<td>{expected['vertical_error']['max']:.4g}</td>" in row


def test_report_is_self_contained_with_every_figure(st_helens_meshes):
    hf, paths = st_helens_meshes
    meshes = {name: tinsmith.read_mesh(p) for name, p in paths.items()}
    page, _ = report_html(hf, meshes, dem_name="st-helens", settings={"why": "test"})
    # hillshades, 3 error maps, 3 wireframes, quality, 3 contour plots
    assert page.count('<img alt="') == 11
    assert all(src.startswith("data:image/png;base64,") for src in re.findall(r'src="([^"]*)"', page))
    assert not re.search(r'(?:src|href)="(?:https?:)?//', page)
    for heading in ("Metrics", "Hillshades", "Error maps", "Triangles in a detail", "Triangle quality", "Contours",
                    "Settings and versions"):
        assert f"<h2>{heading}</h2>" in page
    assert "&quot;numba&quot;" in page and "&quot;why&quot;: &quot;test&quot;" in page


def test_simplify_writes_a_report_and_refuses_a_point_cloud_input(tmp_path, capsys):
    code, out, err = run_cli(capsys, "simplify", "--sample", "st-helens", "--max-error", "10", "-o", tmp_path / "m.ply",
                             "--report", tmp_path / "r.html")
    assert code == 0, err
    assert "report" in out and (tmp_path / "r.html").exists()
    assert _embedded_metrics((tmp_path / "r.html").read_text())["greedy"]["n_triangles"] > 0
    code, _, err = run_cli(capsys, "simplify", "--sample", "st-helens", "-o", tmp_path / "m.ply", "--report",
                           tmp_path / "r.txt")
    assert code == 1 and ".html" in err


def test_png_helpers_write_pictures(st_helens_meshes, tmp_path):
    hf, paths = st_helens_meshes
    mesh = tinsmith.read_mesh(paths["greedy"])
    written = [
        figures.plot_hillshades(hf, {"greedy": mesh}, tmp_path / "h.png"),
        figures.plot_error(mesh, hf, tmp_path / "e.png"),
        figures.plot_wireframe(mesh, hf, tmp_path / "w.png"),
        figures.plot_quality({"greedy": mesh}, tmp_path / "q.png"),
        figures.plot_contours(mesh, hf, tmp_path / "c.png"),
    ]
    for p in written:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and p.stat().st_size > 5000


def test_hillshade_of_a_plane_facing_the_light_is_uniform():
    x = np.arange(20.0)
    plane = np.add.outer(-x, x)  # rises to the east and to the north (rows run south)
    shade = figures.hillshade(plane, (1.0, 1.0))
    assert np.ptp(shade) < 1e-12 and 0 < shade[0, 0] <= 1


def test_viewer_page_carries_the_mesh_and_refuses_an_empty_one(st_helens_meshes, tmp_path, capsys):
    _, paths = st_helens_meshes
    mesh = tinsmith.read_mesh(paths["greedy"])
    page = viewer_html(mesh, title="greedy")
    data = json.loads(re.search(r'<script type="application/json" id="mesh">(.*?)</script>', page, re.DOTALL).group(1))
    assert data["n_vertices"] == mesh.n_vertices and data["n_triangles"] == mesh.n_triangles
    assert not re.search(r'(?:src|href)="(?:https?:)?//', page)
    empty = tinsmith.TerrainMesh(mesh.vertices[:3], np.empty((0, 3), np.int64))
    with pytest.raises(tinsmith.InvalidInputError, match="no triangles"):
        viewer_html(empty)
    code, out, err = run_cli(capsys, "view", paths["greedy"], "-o", tmp_path / "v.html")
    assert code == 0, err
    assert (tmp_path / "v.html").exists() and "needs no network" in out
    code, _, err = run_cli(capsys, "view", tmp_path / "missing.ply")
    assert code == 1 and "missing.ply" in err


# -- in a real browser ----------------------------------------------------------------------
needs_browser = pytest.mark.skipif(
    chromium_path() is None and not os.environ.get("CI"),
    reason="no Chromium here (CI installs Debian's chromium package and runs these)",
)


def _offline(result, page) -> None:
    assert result["errors"] == []
    assert [m for m in result["console"] if m[0] == "error"] == []
    assert all(url == page.resolve().as_uri() or url.startswith("data:") for url in result["requests"])


@needs_browser
def test_report_renders_in_headless_chromium(st_helens_meshes, tmp_path):
    pytest.importorskip("playwright")
    hf, paths = st_helens_meshes
    report = tmp_path / "report.html"
    tinsmith.viz.report.write_report(report, hf, {n: tinsmith.read_mesh(p) for n, p in paths.items()},
                                     dem_name="st-helens")
    shot = tmp_path / "report.png"
    result = render_page(report, shot, full_page=True)
    _offline(result, report)
    assert len(result["images"]) == 11 and all(width > 0 for _, width in result["images"])
    assert shot.stat().st_size > 50_000


@needs_browser
def test_viewer_renders_st_helens_in_headless_chromium(st_helens_meshes, tmp_path):
    pytest.importorskip("playwright")
    from PIL import Image

    _, paths = st_helens_meshes
    page = write_viewer(tinsmith.read_mesh(paths["greedy"]), tmp_path / "view.html", title="greedy")
    shot = tmp_path / "view.png"
    result = render_page(page, shot, wait_for="body[data-ready]")
    _offline(result, page)
    assert result["ready"] == "1"  # drawn with WebGL, not the no-WebGL message
    pixels = np.asarray(Image.open(shot).convert("RGB"), dtype=float)
    background = np.array([0.11, 0.13, 0.16]) * 255
    drawn = np.abs(pixels - background).sum(axis=2) > 30
    assert drawn.mean() > 0.1  # the terrain covers a good part of the picture
