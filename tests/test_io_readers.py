"""Readers of tinsmith.io.raster and tinsmith.io.points, on the shared real data and on bad inputs."""

from __future__ import annotations

import shutil
import warnings

import numpy as np
import pytest
import rasterio

from tinsmith.core import Heightfield, PointCloud
from tinsmith.errors import (
    FileError,
    FormatError,
    InputNotFoundError,
    InvalidInputError,
    InvalidOptionError,
    NoDataError,
    TinsmithWarning,
)
from tinsmith.io import read, read_heightfield
from tinsmith.io.crs import to_epsg
from tinsmith.io.raster import decode_rgb, raster_info, tile_transform

from .conftest import shared, write_tif

ST_HELENS_DEM = "terrain/st_helens/SainteHelens.dem"
ST_HELENS_TIF = "terrain/st_helens/SainteHelens_30m.tif"
TERRARIUM_PNG = "terrain_rgb/terrarium_grand_canyon_z11_385_803.png"
TERRARIUM_TIF = "terrain_rgb/terrarium_grand_canyon_z11_385_803_elev.tif"
DELFT_LAZ = "urban/delft_ahn3/ahn3_cropped_2.laz"
TOPOGRAPHY_LAZ = "terrain/lidR_forest_lakes/Topography.laz"


def assert_names(exc_info, path):
    """The error message names the file."""
    assert str(path) in str(exc_info.value)


# -- GDAL rasters on real data ----------------------------------------------------------------
@pytest.mark.parametrize("relative", [ST_HELENS_DEM, ST_HELENS_TIF])
def test_st_helens(relative):
    hf = read(shared(relative))
    assert isinstance(hf, Heightfield)
    assert hf.shape == (468, 327)
    assert to_epsg(hf.crs) == 26710
    assert int(hf.nodata_mask.sum()) == 4151
    assert hf.z_range == (682.0, 2543.0)
    assert hf.cell_size == (30.0, 30.0)
    assert hf.source_dtype == "int16"
    assert hf.nodata == -32767.0


def test_st_helens_dem_and_tif_identical():
    dem, tif = read(shared(ST_HELENS_DEM)), read(shared(ST_HELENS_TIF))
    np.testing.assert_array_equal(dem.z, tif.z)
    np.testing.assert_array_equal(dem.nodata_mask, tif.nodata_mask)
    assert dem.transform == tif.transform


def test_big_tujunga():
    hf = read(shared("terrain/big_tujunga_canyon/srtm_bigtujunga30m_utm11.tif"))
    assert hf.shape == (643, 1197)
    assert hf.n_valid == hf.n_cells
    assert to_epsg(hf.crs) == 32611
    assert hf.z_range == (315.0, 2295.0)


def test_west_bijou_ascii_grid():
    hf = read(shared("terrain/landlab_west_bijou/west_bijou_gully.asc"))
    assert hf.shape == (89, 43)
    assert int(hf.nodata_mask.sum()) == 2739
    assert hf.crs is None
    assert hf.transform == (3.0, 0.0, 559705.0, 0.0, -3.0, 4380487.0)
    lo, hi = hf.z_range
    assert 1680.7 < lo < 1680.8 and 1725.4 < hi < 1725.5


def test_codem_dsm_float64_with_nodata():
    hf = read(shared("urban/codem_ncalm/codem_dsm_1m.tif"))
    assert hf.shape == (344, 405)
    assert hf.source_dtype == "float64"
    assert hf.nodata == -9999.0
    assert int(hf.nodata_mask.sum()) == 4499
    assert np.isnan(hf.z[hf.nodata_mask]).all()
    assert 'AUTHORITY["EPSG","32616"]' in hf.crs  # compound: UTM 16N + unknown vertical
    assert hf.z_range[0] > 225.0


def test_delft_dsm():
    hf = read(shared("urban/delft_ahn3/delft_dsm_0.5m.tif"))
    assert hf.shape == (458, 529)
    assert to_epsg(hf.crs) == 28992
    assert hf.cell_size == (0.5, 0.5)
    assert hf.bounds == pytest.approx((84808.0, 447412.5, 85072.5, 447641.5))
    assert hf.n_valid == hf.n_cells


def test_user_nodata_adds_to_file_nodata():
    path = shared(ST_HELENS_TIF)
    plain = read(path)
    low = read(path, nodata=682)
    assert low.n_valid == plain.n_valid - int(np.sum(plain.z == 682.0))
    assert low.z_range[0] > 682.0


# -- PNG elevation tiles ----------------------------------------------------------------------
def test_terrarium_png_matches_derived_geotiff():
    png, ref = read(shared(TERRARIUM_PNG)), read(shared(TERRARIUM_TIF))
    assert png.shape == ref.shape == (256, 256)
    np.testing.assert_array_equal(png.z, ref.z)
    np.testing.assert_allclose(png.transform, ref.transform, rtol=0, atol=1e-6)
    assert to_epsg(png.crs) == 3857
    assert png.n_valid == png.n_cells


def test_png_tile_option_and_path_layout(tmp_path):
    ref = read(shared(TERRARIUM_TIF))
    plain = tmp_path / "tile.png"
    shutil.copy(shared(TERRARIUM_PNG), plain)
    for tile in ("11/385/803", (11, 385, 803), [11, 385, 803]):
        hf = read(plain, encoding="terrarium", tile=tile)
        np.testing.assert_allclose(hf.transform, ref.transform, rtol=0, atol=1e-6)
    nested = tmp_path / "11" / "385" / "803.png"
    nested.parent.mkdir(parents=True)
    shutil.copy(shared(TERRARIUM_PNG), nested)
    np.testing.assert_array_equal(read(nested, encoding="terrarium").z, ref.z)


@pytest.mark.filterwarnings("ignore::rasterio.errors.NotGeoreferencedWarning")
def test_mapbox_decoding_and_alpha_nodata(tmp_path):
    heights = np.array([[0.0, 100.5], [1234.5, -50.0]])
    code = np.round((heights + 10000.0) * 10).astype(np.int64)
    rgba = np.stack([code // 65536, (code // 256) % 256, code % 256, np.full(code.shape, 255)]).astype(np.uint8)
    rgba[3, 0, 0] = 0  # transparent pixel: nodata
    path = tmp_path / "terrain-rgb_z0_0_0.png"
    with rasterio.open(path, "w", driver="PNG", width=2, height=2, count=4, dtype="uint8") as ds:
        ds.write(rgba)
    hf = read(path)
    assert hf.nodata_mask.tolist() == [[True, False], [False, False]]
    np.testing.assert_allclose(hf.z[~hf.nodata_mask], heights[~hf.nodata_mask], atol=1e-6)
    assert hf.bounds == pytest.approx((-20037508.342789244, -20037508.342789244, 20037508.342789244, 20037508.342789244))


def test_decode_rgb_terrarium_formula():
    rgb = np.array([[[128]], [[10]], [[64]]], dtype=np.uint8)
    assert decode_rgb(rgb, "terrarium")[0, 0] == 128 * 256 + 10 + 64 / 256 - 32768


def test_tile_transform_whole_world():
    a, b, c, d, e, f = tile_transform(1, 1, 1, 256, 256)
    assert (c, f) == (0.0, 0.0)
    assert a == -e == 20037508.342789244 / 256


@pytest.mark.filterwarnings("ignore::rasterio.errors.NotGeoreferencedWarning")
def test_raw_png_uses_world_file(tmp_path):
    z = (np.arange(12, dtype=np.uint16).reshape(3, 4) + 1000)
    path = tmp_path / "dem.png"
    with rasterio.open(path, "w", driver="PNG", width=4, height=3, count=1, dtype="uint16") as ds:
        ds.write(z, 1)
    (tmp_path / "dem.pgw").write_text("5\n0\n0\n-5\n1002.5\n2997.5\n")
    hf = read(path, encoding="raw")
    np.testing.assert_array_equal(hf.z, z)
    assert hf.transform == (5.0, 0.0, 1000.0, 0.0, -5.0, 3000.0)
    assert hf.source_dtype == "uint16"


def test_png_without_encoding(tmp_path):
    path = tmp_path / "tile.png"
    shutil.copy(shared(TERRARIUM_PNG), path)
    with pytest.raises(InvalidInputError, match="encoding") as info:
        read(path)
    assert_names(info, path)
    assert "--encoding" in str(info.value)


def test_png_without_tile(tmp_path):
    path = tmp_path / "terrarium.png"
    shutil.copy(shared(TERRARIUM_PNG), path)
    with pytest.raises(InvalidInputError, match="tile") as info:
        read(path)
    assert_names(info, path)
    assert "--tile Z/X/Y" in str(info.value)


@pytest.mark.parametrize("tile", ["11/2048/0", (3, 0, -1), "a/b/c", (1, 2)])
def test_png_bad_tile(tile):
    with pytest.raises(InvalidOptionError, match="tile"):
        read(shared(TERRARIUM_PNG), tile=tile)


def test_png_bad_encoding():
    with pytest.raises(InvalidOptionError, match="encoding must be one of"):
        read(shared(TERRARIUM_PNG), encoding="rgb")


# -- numpy ------------------------------------------------------------------------------------
def test_npy_round_trip(tmp_path):
    z = np.arange(20, dtype=np.float32).reshape(4, 5)
    path = tmp_path / "heights.npy"
    np.save(path, z)
    hf = read(path, cell_size=2.5)
    np.testing.assert_array_equal(hf.z, z)
    assert hf.cell_size == (2.5, 2.5)
    assert hf.source_dtype == "float32"
    assert read_heightfield(path, cell_size=2.5).shape == (4, 5)


def test_npy_without_cell_size(tmp_path):
    path = tmp_path / "x.npy"
    np.save(path, np.zeros((3, 3)))
    with pytest.raises(InvalidInputError) as info:
        read(path)
    assert str(info.value) == f"{str(path)!r} has no georeferencing: pass cell_size (CLI --cell-size)"


def test_npz_round_trip_with_transform(tmp_path):
    z = np.array([[1.0, 2.0, -9999.0], [4.0, np.nan, 6.0]])
    transform = (10.0, 0.0, 1000.0, 0.0, -10.0, 5000.0)
    path = tmp_path / "grid.npz"
    np.savez(path, z=z, transform=np.array(transform), crs="EPSG:32610", nodata=-9999.0)
    hf = read(path, nodata=float("nan"))
    assert hf.transform == transform
    assert to_epsg(hf.crs) == 32610
    assert hf.nodata_mask.tolist() == [[False, False, True], [False, True, False]]
    np.testing.assert_array_equal(hf.z[~hf.nodata_mask], [1.0, 2.0, 4.0, 6.0])

    resized = read(path, nodata=float("nan"), cell_size=5.0)  # the option overrides, origin kept
    assert resized.transform == (5.0, 0.0, 1000.0, 0.0, -5.0, 5000.0)


def test_npz_only_2d_array_and_ambiguous(tmp_path):
    single = tmp_path / "single.npz"
    np.savez(single, heights=np.ones((2, 3)), cell_size=1.0)
    assert read(single).shape == (2, 3)
    ambiguous = tmp_path / "two.npz"
    np.savez(ambiguous, a=np.ones((2, 2)), b=np.ones((2, 2)), cell_size=1.0)
    with pytest.raises(InvalidInputError, match="keys: a, b, cell_size") as info:
        read(ambiguous)
    assert_names(info, ambiguous)


def test_npy_not_numpy(tmp_path):
    path = tmp_path / "fake.npy"
    path.write_text("1 2 3\n")
    with pytest.raises(FormatError) as info:
        read(path, cell_size=1.0)
    assert_names(info, path)


# -- GeoTIFF round trip and bad rasters ------------------------------------------------------
def test_geotiff_round_trip(tmp_path):
    z = np.random.default_rng(0).normal(100.0, 5.0, (30, 40)).astype(np.float32)
    z[0, 0] = -1.0
    path = write_tif(tmp_path / "dem.tif", z, nodata=-1.0)
    hf = read(path)
    assert hf.shape == (30, 40)
    assert hf.transform == (2.0, 0.0, 500000.0, 0.0, -2.0, 4000000.0)
    assert to_epsg(hf.crs) == 32610
    assert hf.nodata == -1.0 and hf.source_dtype == "float32"
    assert hf.nodata_mask.sum() == 1 and hf.nodata_mask[0, 0]
    np.testing.assert_array_equal(hf.z[1:], z[1:])


def test_missing_file(tmp_path):
    path = tmp_path / "nope.tif"
    with pytest.raises(InputNotFoundError) as info:
        read(path)
    assert_names(info, path)


def test_truncated_geotiff(tmp_path):
    path = write_tif(tmp_path / "cut.tif", np.random.default_rng(1).random((200, 300)).astype(np.float32))
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(FormatError) as info:
        read(path)
    assert_names(info, path)
    assert "\n" not in str(info.value)


def test_text_file_with_tif_suffix(tmp_path):
    path = tmp_path / "notes.tif"
    path.write_text("this is not a raster\n")
    with pytest.raises(FormatError) as info:
        read(path)
    assert_names(info, path)
    assert isinstance(info.value, FileError) and isinstance(info.value, OSError)


def test_unknown_suffix_goes_to_gdal(tmp_path):
    tif = write_tif(tmp_path / "dem.tif", np.ones((3, 3), dtype=np.int16))
    renamed = tmp_path / "dem.weird"
    shutil.copy(tif, renamed)
    assert read(renamed).shape == (3, 3)
    junk = tmp_path / "junk.weird"
    junk.write_text("nothing")
    with pytest.raises(FormatError, match="'.weird'") as info:
        read(junk)
    assert_names(info, junk)


def test_all_nodata_raster(tmp_path):
    path = write_tif(tmp_path / "empty.tif", np.full((4, 4), -9999.0, dtype=np.float32), nodata=-9999.0)
    with pytest.raises(NoDataError) as info:
        read(path)
    assert_names(info, path)


def test_one_cell_raster(tmp_path):
    path = write_tif(tmp_path / "one.tif", np.ones((1, 1), dtype=np.float32))
    with pytest.raises(InvalidInputError, match="2 x 2") as info:
        read(path)
    assert_names(info, path)


def test_nan_cells_need_declared_nodata(tmp_path):
    z = np.ones((5, 5), dtype=np.float32)
    z[2, 3] = np.nan
    path = write_tif(tmp_path / "holes.tif", z)
    with pytest.raises(InvalidInputError, match="NaN") as info:
        read(path)
    assert_names(info, path)
    hf = read(path, nodata=float("nan"))
    assert hf.nodata_mask.sum() == 1 and hf.nodata_mask[2, 3]


def test_band_out_of_range():
    path = shared(ST_HELENS_TIF)
    with pytest.raises(InvalidOptionError) as info:
        read(path, band=2)
    message = str(info.value)
    assert "band" in message and "1 band" in message and "got 2" in message
    assert_names(info, path)


def test_option_that_does_not_apply():
    with pytest.raises(InvalidOptionError, match="'classes' does not apply"):
        read(shared(ST_HELENS_TIF), classes=[2])


# -- LAS / LAZ ------------------------------------------------------------------------------
def test_delft_laz_class_counts():
    cloud = read(shared(DELFT_LAZ))
    assert isinstance(cloud, PointCloud)
    assert len(cloud) == 208432
    assert cloud.class_counts() == {1: 86308, 2: 87130, 6: 33312, 9: 568, 26: 1114}
    assert cloud.classification.dtype == np.uint8
    assert cloud.crs is None
    assert {"intensity", "return_number", "number_of_returns"} <= set(cloud.attributes)
    assert cloud.bounds[0] == pytest.approx(85000.001) and cloud.bounds[5] == pytest.approx(26.329)


def test_laz_keep_ground_only():
    ground = read(shared(DELFT_LAZ), classes=[2])
    assert len(ground) == 87130
    assert ground.class_counts() == {2: 87130}
    assert len(ground.attributes["intensity"]) == 87130


def test_laz_class_not_present():
    path = shared(DELFT_LAZ)
    with pytest.raises(NoDataError) as info:
        read(path, classes=[99])
    message = str(info.value)
    assert "99" in message and "2 (87130 points)" in message and "26 (1114 points)" in message
    assert_names(info, path)


def test_codem_laz_crs_and_colour():
    cloud = read(shared("urban/codem_ncalm/codem_pc.laz"))
    assert len(cloud) == 222224
    assert to_epsg(cloud.crs) == 32616
    assert cloud.class_counts() == {0: 222224}
    assert {"red", "green", "blue"} <= set(cloud.attributes)


def test_topography_laz():
    cloud = read(shared(TOPOGRAPHY_LAZ))
    assert len(cloud) == 73403
    assert cloud.class_counts() == {1: 61347, 2: 8159, 9: 3897}
    assert to_epsg(cloud.crs) == 2949


def test_read_heightfield_grids_laz():
    hf = read_heightfield(shared(TOPOGRAPHY_LAZ), cell_size=2.0, classes=[2])
    assert isinstance(hf, Heightfield)
    assert to_epsg(hf.crs) == 2949
    assert hf.cell_size == (2.0, 2.0)
    lo, hi = hf.z_range
    assert lo >= 788.9 and hi <= 829.8


def test_truncated_laz(tmp_path):
    path = tmp_path / "cut.laz"
    data = shared(TOPOGRAPHY_LAZ).read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(FormatError) as info:
        read(path)
    assert_names(info, path)


def test_empty_las(tmp_path):
    laspy = pytest.importorskip("laspy")
    path = tmp_path / "empty.las"
    las = laspy.create(point_format=1, file_version="1.2")
    las.write(path)
    with pytest.raises(NoDataError) as info:
        read(path)
    assert_names(info, path)


@pytest.mark.parametrize("classes", ["2", [2.5], [-1], []])
def test_bad_classes_option(classes):
    with pytest.raises(InvalidOptionError, match="classes"):
        read(shared(TOPOGRAPHY_LAZ), classes=classes)


# -- XYZ text -------------------------------------------------------------------------------
XYZ_TEXT = """x,y,z,class
# a comment line
10.0,20.0,1.5,2
11.0;20.0;1.75;6

12.5 21.0 2.0 2
"""


def test_xyz_round_trip(tmp_path):
    path = tmp_path / "points.csv"
    path.write_text(XYZ_TEXT)
    cloud = read(path)
    np.testing.assert_array_equal(cloud.xyz, [[10.0, 20.0, 1.5], [11.0, 20.0, 1.75], [12.5, 21.0, 2.0]])
    assert cloud.classification.tolist() == [2, 6, 2]
    assert cloud.crs is None
    ground = read(path, classes=[2])
    assert len(ground) == 2 and ground.class_counts() == {2: 2}


def test_xyz_array_round_trip(tmp_path):
    xyz = np.random.default_rng(2).uniform(0.0, 1000.0, (500, 3))
    path = tmp_path / "cloud.xyz"
    np.savetxt(path, xyz, header="x y z")
    np.testing.assert_allclose(read(path).xyz, xyz, rtol=1e-15)


@pytest.mark.parametrize(
    "name, text, options, error, message",
    [
        ("bad.xyz", "x y z\n1 2 3\n4 5 6\n7 8\n", {}, FormatError, "line 4: expected 3 columns"),
        ("word.txt", "1 2 3\n4 five 6\n", {}, FormatError, "line 2: 'five' is not a number"),
        ("cls.xyz", "1 2 3 2\n# note\n4 5 6 2.5\n", {}, FormatError, "line 3"),
        ("plain.xyz", "1 2 3\n4 5 6\n", {"classes": [2]}, NoDataError, "no classification"),
        ("empty.xyz", "x y z\n", {}, NoDataError, "no points"),
    ],
)
def test_xyz_bad_content(tmp_path, name, text, options, error, message):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(error, match=message) as info:
        read(path, **options)
    assert_names(info, path)


@pytest.mark.filterwarnings("ignore::rasterio.errors.NotGeoreferencedWarning")
def test_raw_png_without_georeferencing(tmp_path):
    path = tmp_path / "bare.png"
    with rasterio.open(path, "w", driver="PNG", width=3, height=3, count=1, dtype="uint16") as ds:
        ds.write(np.ones((3, 3), dtype=np.uint16), 1)
    with pytest.raises(InvalidInputError, match="no georeferencing") as info:
        read(path, encoding="raw")
    assert_names(info, path)
    assert read(path, encoding="raw", tile="0/0/0").shape == (3, 3)


# -- several bands (issue 42) -----------------------------------------------------------------
def _bands_tif(path, count, *, dtype="float32", alpha=False):
    z = np.add.outer(np.arange(6.0), np.arange(8.0))
    return write_tif(path, np.stack([z + 100 * b for b in range(count)]), transform=(5, 0, 500000, 0, -5, 4100030),
                     dtype=dtype, alpha=alpha)


def _tinsmith_warnings(call):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = call()
    return result, [str(w.message) for w in caught if issubclass(w.category, TinsmithWarning)]


def test_several_bands_read_band_1_with_one_warning(tmp_path):
    path = _bands_tif(tmp_path / "three.tif", 3)
    hf, said = _tinsmith_warnings(lambda: read(path))
    assert hf.z_range == (0.0, 12.0)
    assert len(said) == 1 and str(path) in said[0] and "3 bands" in said[0] and "band=N" in said[0]
    assert "\n" not in said[0]
    hf, said = _tinsmith_warnings(lambda: read_heightfield(path, band=2))
    assert said == [] and hf.z_range == (100.0, 112.0)
    _, said = _tinsmith_warnings(lambda: read(path, band=1))
    assert said == []
    info, said = _tinsmith_warnings(lambda: raster_info(path))
    assert info.band == 1 and len(said) == 1 and "3 bands" in said[0]
    info, said = _tinsmith_warnings(lambda: raster_info(path, band=3))
    assert info.band == 3 and said == []
    with pytest.raises(InvalidOptionError, match=r"got 4 \(the file has 3 bands\)"):
        read(path, band=4)
    with pytest.raises(InvalidOptionError, match="got 0"):
        read(path, band=0)


def test_one_band_and_a_band_with_alpha_read_in_silence(tmp_path):
    for path in (_bands_tif(tmp_path / "one.tif", 1), _bands_tif(tmp_path / "alpha.tif", 2, dtype="uint8", alpha=True)):
        _, said = _tinsmith_warnings(lambda path=path: read(path))
        assert said == [], said


def test_terrarium_png_decoded_from_its_three_bands_in_silence():
    hf, said = _tinsmith_warnings(lambda: read(shared(TERRARIUM_PNG)))
    assert said == [] and hf.shape == (256, 256)
    np.testing.assert_array_equal(hf.z, read(shared(TERRARIUM_TIF)).z)


def test_read_window_reads_a_rewritten_file_anew_and_names_a_missing_one(tmp_path):
    """Windows of one file reuse its open dataset; a file written again (or gone) is never read from the old one."""
    from tinsmith.errors import FileError
    from tinsmith.io.raster import read_window

    path = write_tif(tmp_path / "dem.tif", np.arange(12, dtype=np.float32).reshape(3, 4))
    info = raster_info(path)
    assert read_window(info, (0, 0), (0, 3))[0].tolist() == [[0, 1, 2, 3]]
    assert read_window(info, (2, 2), (1, 2))[0].tolist() == [[9, 10]]
    write_tif(path, np.arange(100, 115, dtype=np.float32).reshape(3, 5))
    assert read_window(info, (0, 0), (0, 3))[0].tolist() == [[100, 101, 102, 103]]
    path.unlink()
    with pytest.raises(FileError, match="dem.tif"):
        read_window(info, (0, 0), (0, 3))
