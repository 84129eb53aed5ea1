"""Method ``blocks``: the Salt Lake City thesis' block model as a registered method (the model itself: tests/test_urban.py)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import tinsmith
from tinsmith import Heightfield, InvalidOptionError
from tinsmith.algorithms.urban.urban import urban_model
from tinsmith.cli.main import main


def _dsm() -> tuple[Heightfield, Heightfield]:
    """Two boxes and a tower on a gentle slope (1 m cells, metres), and the slope alone (the ground)."""
    r, c = np.mgrid[0:60, 0:80]
    ground = 10.0 + 0.05 * c
    z = ground.copy()
    z[10:30, 10:35] += 9.0
    z[35:55, 45:70] += 6.0
    z[40:48, 55:63] += 8.0
    origin = (85000.0, 447560.0)
    return (Heightfield(z, cell_size=1.0, origin=origin, crs="EPSG:28992"),
            Heightfield(ground, cell_size=1.0, origin=origin, crs="EPSG:28992"))


def _write_tif(path, hf: Heightfield) -> None:
    import rasterio
    from rasterio.transform import Affine

    with rasterio.open(path, "w", driver="GTiff", width=hf.shape[1], height=hf.shape[0], count=1, dtype="float64",
                       crs=hf.crs, transform=Affine(*hf.transform[:6])) as ds:
        ds.write(hf.z.astype(np.float64), 1)


def test_blocks_is_the_mesh_of_the_block_model():
    dsm, _ = _dsm()
    model = urban_model(dsm, ground_window=40.0)
    mesh = tinsmith.blocks(dsm, ground_window=40.0)
    np.testing.assert_array_equal(mesh.vertices, model.mesh.vertices)
    np.testing.assert_array_equal(mesh.triangles, model.mesh.triangles)
    assert mesh.info["method"] == "blocks" and mesh.info["urban"] == model.stats and model.stats["n_buildings"] >= 1
    assert len(mesh.info["triangle_building"]) == mesh.n_triangles
    with pytest.raises(InvalidOptionError, match="'blocks' takes no stop rules, got max_vertices"):
        tinsmith.blocks(dsm, max_vertices=100)


def test_ground_and_mask_are_rasters_in_the_api_and_files_on_the_command_line(tmp_path, capsys):
    dsm, ground = _dsm()
    cells = np.zeros(dsm.shape, bool)
    cells[:, :40] = True  # only the first box may be a building
    mask = Heightfield(cells.astype(np.float64), cell_size=1.0, origin=(85000.0, 447560.0), crs="EPSG:28992")
    options = dict(relative_to_ground=True, ground_window=40.0)
    from_array = tinsmith.blocks(dsm, ground=ground, mask=cells, **options)
    from_raster = tinsmith.blocks(dsm, ground=ground, mask=mask, **options)
    np.testing.assert_array_equal(from_array.triangles, from_raster.triangles)
    assert from_array.info["urban"]["n_buildings"] == 1
    files = {name: tmp_path / f"{name}.tif" for name in ("dsm", "ground", "mask")}
    for name, hf in zip(files, (dsm, ground, mask), strict=True):
        _write_tif(files[name], hf)
    assert tinsmith.blocks(dsm, ground=str(files["ground"]), mask=files["mask"],
                           **options).n_triangles == from_array.n_triangles  # a path is read as a raster
    out = tmp_path / "blocks.ply"
    code = main(["simplify", str(files["dsm"]), "--method", "blocks", "--relative-to-ground", "--ground-window", "40",
                 "--ground", str(files["ground"]), "--mask", str(files["mask"]), "-o", str(out), "--json"])
    report, err = capsys.readouterr()
    assert code == 0, err
    assert json.loads(report)["n_triangles"] == from_array.n_triangles == tinsmith.read_mesh(out).n_triangles
