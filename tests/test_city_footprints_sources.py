"""City models from footprints as users have them: GeoParquet in WGS 84 (Overture, Microsoft's footprints), GeoPackage,
GeoJSON, Shapefile and FlatGeobuf; a set larger than the DSM cut to it, footprints without a building in the DSM
listed, the height statistic named, and the roofs' RMSE over the building cells reported (LoD 1.2 and 2.2)."""

from __future__ import annotations

import json
import sys
import warnings

import numpy as np
import pytest

import tinsmith
from tinsmith import Heightfield
from tinsmith.cli.main import main
from tinsmith.errors import FormatError, MissingDependencyError

from .conftest import shared

shapely = pytest.importorskip("shapely")
gpd = pytest.importorskip("geopandas")
pytest.importorskip("pyarrow")
trimesh = pytest.importorskip("trimesh")

DELFT_DSM = "urban/delft_ahn3/delft_dsm_0.5m.tif"
BGT = "vector/delft_bgt/bgt_pand.sqlite"
#: A 200 x 200 cell window of the Delft DSM (100 m a side, rows of houses): most BGT footprints fall outside it and
#: two dozen cross its edges.
ROWS, COLS = slice(100, 300), slice(250, 450)


@pytest.fixture(scope="module")
def delft(tmp_path_factory):
    """(the cropped DSM's GeoTIFF, the DSM, a GeoParquet of the BGT footprints and four more in WGS 84, the frame
    in RD New).  Of the four: two are far outside the window, one crosses its east edge, one its south edge."""
    from tinsmith.io.gis_formats import write_grid

    folder = tmp_path_factory.mktemp("footprints")
    hf = tinsmith.read_heightfield(shared(DELFT_DSM))
    a, b, c, d, e, f = hf.transform
    dsm = Heightfield(hf.z[ROWS, COLS], transform=(a, b, c + a * COLS.start, d, e, f + e * ROWS.start), crs=hf.crs)
    write_grid(dsm.z, folder / "dsm.tif", dsm)
    x0, y0, x1, y1 = dsm.bounds
    frame = gpd.read_file(shared(BGT))[["lokaalid", "geometry"]]
    extra = [shapely.box(x1 + 50, y0 + 50, x1 + 70, y0 + 65), shapely.box(x0 - 300, y1 + 100, x0 - 280, y1 + 120),
             shapely.box(x1 - 6, y0 + 60, x1 + 6, y0 + 72), shapely.box(x0 + 40, y0 - 5, x0 + 52, y0 + 5)]
    extra = gpd.GeoDataFrame({"lokaalid": [f"extra{i}" for i in range(4)]}, geometry=extra, crs=frame.crs)
    frame = gpd.GeoDataFrame(np.concatenate([frame.to_numpy(), extra.to_numpy()]), columns=frame.columns,
                             geometry="geometry", crs=frame.crs)
    parquet = folder / "footprints.parquet"
    frame.to_crs("EPSG:4326").to_parquet(parquet)
    return folder / "dsm.tif", tinsmith.read_heightfield(folder / "dsm.tif"), parquet, frame


def _box(dsm):
    """The box of the DSM's cell centres: the domain a city model's footprints are cut to."""
    from tinsmith.algorithms.urban.city import centres_box

    return centres_box(dsm.transform, dsm.shape)


def test_geoparquet_in_wgs84_larger_than_the_dsm_gives_a_watertight_lod22_model(delft, tmp_path, capsys):
    path, dsm, parquet, frame = delft
    obj, outlines = tmp_path / "city.obj", tmp_path / "b.gpkg"
    code = main(["city", str(path), "-o", str(obj), "--footprints", str(parquet), "--solid", "--roofs", "planes",
                 "--buildings", str(outlines), "--json"])
    out, err = capsys.readouterr()
    assert code == 0, err
    stats = json.loads(out)
    fp = stats["footprints"]
    box = _box(dsm)
    inside = {i for i, g in enumerate(frame.geometry) if box.contains(g)}
    crossing = {i for i, g in enumerate(frame.geometry) if box.intersects(g)} - inside
    assert {len(frame) - 1, len(frame) - 2} <= crossing and len(inside) > 30
    assert fp["read"] == len(frame) and fp["outside"] == len(frame) - len(inside) - len(crossing)
    assert fp["cut"] == len(crossing) and fp["skipped"] == 0 and fp["covered"] == []
    # every footprint inside is modelled; of those crossing the edge, those without a building in the DSM are listed
    written = gpd.read_file(outlines)
    modelled = set(written["footprint"].tolist())
    assert inside <= modelled and modelled <= inside | crossing
    assert set(fp["unmatched"]) == crossing - modelled
    assert fp["modelled"] == stats["n_buildings"] == len(written)
    assert set(written["roof_stat"]) == {"p70"} and stats["roof_height"] == "p70" and stats["lod"] == "2.2"
    # one warning line says what was cut and what was outside; a note says the reprojection
    lines = [line for line in err.splitlines() if line.strip()]
    warning = [line for line in lines if "warning" in line]
    assert len(warning) == 1 and f"{len(crossing)} of {len(frame)} features clipped" in warning[0]
    assert any("reprojected from EPSG:4326" in line for line in lines)
    # the solid: watertight and a volume once trimesh merges the vertices of the OBJ's groups
    solid = trimesh.load(obj, process=False, force="mesh")
    solid.merge_vertices()
    assert solid.is_watertight and solid.is_volume
    # the roof RMSE over the building cells, one cell in: planar roofs follow the DSM well under a storey
    assert stats["roof_cells"] > 5000 and 0.2 < stats["roof_rmse"] < 1.5


@pytest.fixture(scope="module")
def from_parquet(delft):
    """The buildings tinsmith.city makes of the GeoParquet on the cropped DSM (its warnings said elsewhere)."""
    _, dsm, parquet, _ = delft
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return tinsmith.city(dsm, footprints=parquet).buildings


@pytest.mark.parametrize("suffix", [".gpkg", ".geojson", ".shp", ".fgb"])
def test_every_format_gives_the_same_buildings_as_the_geoparquet(delft, from_parquet, tmp_path, suffix, capsys):
    path, dsm, parquet, frame = delft
    other = tmp_path / f"footprints{suffix}"
    gpd.read_parquet(parquet).to_file(other)
    out = tmp_path / "city.ply"
    assert main(["city", str(path), "-o", str(out), "--footprints", str(other)]) == 0
    text = capsys.readouterr().out
    assert "LoD 1.2 flat roofs (heights at p70)" in text and "roof RMSE (mesh minus DSM) over" in text
    summary = next(line for line in text.splitlines() if line.strip().startswith("footprints:"))
    assert f"{len(frame)} read; {len(from_parquet)} modelled" in summary
    assert len(from_parquet) >= sum(_box(dsm).contains(g) for g in frame.geometry)


def test_footprints_without_a_building_in_the_dsm_are_listed_and_left_out():
    """On a synthetic DSM: footprints on bare ground, on a house, over cells without data, and one thinner than a
    cell on a wall; the positions in the input of those without a building are reported, the buildings keep theirs."""
    z = np.zeros((80, 100))  # 0.5 m cells: x 0..50, y 0..40
    z[10:30, 10:40] = 9.0  # a house, x 5..20, y 25..35, 9 m high
    z[40:60, 20] = 3.0  # a wall one cell thick, x 10..10.5, y 10..20
    nodata = np.zeros(z.shape, bool)
    nodata[50:70, 60:90] = True  # x 30..45, y 5..15
    dsm = Heightfield(z, cell_size=0.5, origin=(0.0, 40.0), crs="EPSG:28992", nodata_mask=nodata)
    ground = Heightfield(np.zeros(z.shape), cell_size=0.5, origin=(0.0, 40.0), crs="EPSG:28992")
    footprints = [shapely.box(25, 20, 28, 24), shapely.box(5, 25, 20, 35), shapely.box(31, 6, 44, 14),
                  shapely.box(10.1, 12, 10.2, 18)]
    model = tinsmith.city(dsm, ground=ground, footprints=footprints)
    fp = model.stats["footprints"]
    assert fp["unmatched"] == [0, 2] and fp["modelled"] == 2 and fp["outside"] == fp["cut"] == 0
    assert sorted(b.footprint for b in model.buildings) == [1, 3]
    house = next(b for b in model.buildings if b.footprint == 1)
    assert house.height == pytest.approx(9.0) and house.measured_height == pytest.approx(9.0)
    assert house.outline.symmetric_difference(footprints[1]).area < 1e-6
    assert model.stats["roof_rmse"] == pytest.approx(0.0, abs=1e-6) and model.stats["roof_cells"] == 28 * 18


def test_roof_rmse_of_lod12_and_lod22_on_a_gable_roof():
    """A gable roof: a flat block at p70 is off by metres at the eaves and ridge; planar faces follow it."""
    rows, cols = np.mgrid[0:80, 0:100]
    x, y = (cols + 0.5) * 0.5, 40.0 - (rows + 0.5) * 0.5
    z = np.zeros(x.shape)
    house = (x > 10) & (x < 40) & (y > 10) & (y < 30)
    z[house] = 14.0 - 0.6 * np.abs(y[house] - 20.0)  # ridge at 14 m, eaves at 8 m
    dsm = Heightfield(z, cell_size=0.5, origin=(0.0, 40.0), crs="EPSG:28992")
    ground = Heightfield(np.zeros(z.shape), cell_size=0.5, origin=(0.0, 40.0), crs="EPSG:28992")
    outline = [shapely.box(10, 10, 40, 30)]
    flat = tinsmith.city(dsm, ground=ground, footprints=outline).stats
    planes = tinsmith.city(dsm, ground=ground, footprints=outline, roofs="planes").stats
    assert (flat["lod"], planes["lod"]) == ("1.2", "2.2")
    assert flat["roof_cells"] == planes["roof_cells"] == 58 * 38  # one cell in from the walls
    expected = np.sqrt(np.mean((np.percentile(z[house], 70) - z[house][np.abs(y[house] - 20) < 9.5]) ** 2))
    assert flat["roof_rmse"] == pytest.approx(expected, rel=0.05)
    assert planes["roof_rmse"] < 0.1 < 1.0 < flat["roof_rmse"]


def test_geoparquet_needs_pyarrow_and_a_parquet_file(tmp_path, monkeypatch):
    from tinsmith.io.vector import read_layers

    bad = tmp_path / "broken.parquet"
    bad.write_bytes(b"PAR1 not really")
    with pytest.raises(FormatError, match="broken.parquet.*GeoParquet"):
        read_layers(bad, "footprints")
    frame = gpd.GeoDataFrame({"name": ["a"]}, geometry=[shapely.box(0, 0, 1, 1)], crs="EPSG:4326")
    named = tmp_path / "footprints.data"  # another suffix: told by the magic number
    frame.to_parquet(named)
    (layer,) = read_layers(named, "footprints")
    assert len(layer.geometries) == 1 and list(layer.fields["name"]) == ["a"] and "WGS 84" in layer.crs
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    with pytest.raises(MissingDependencyError, match=r"GeoParquet.*pyarrow.*tinsmith\[gis\]"):
        read_layers(named, "footprints")
