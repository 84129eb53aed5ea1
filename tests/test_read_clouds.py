"""Many point-cloud files as one cloud: tinsmith.io.expand_sources, cloud_header and read_clouds."""

from __future__ import annotations

import numpy as np
import pytest

from tinsmith.core import PointCloud
from tinsmith.errors import (
    FileError,
    FormatError,
    InputNotFoundError,
    InvalidInputError,
    InvalidOptionError,
    NoDataError,
    ResourceError,
)
from tinsmith.io import CloudInfo, cloud_header, expand_sources, read, read_clouds, read_heightfield
from tinsmith.io.points import read_las, read_xyz
from tinsmith.resources import MEMORY_LIMIT_VARIABLE

from .conftest import shared, write_las

laspy = pytest.importorskip("laspy")
pyproj = pytest.importorskip("pyproj")

DELFT_1 = "urban/delft_ahn3/ahn3_cropped_1.laz"
DELFT_2 = "urban/delft_ahn3/ahn3_cropped_2.laz"
DELFT_MERGED = "urban/delft_ahn3/delft_ahn3_merged.laz"
TOPOGRAPHY = "terrain/lidR_forest_lakes/Topography.laz"
MIXED_CONIFER = "terrain/lidR_forest_lakes/MixedConifer.laz"
CODEM = "urban/codem_ncalm/codem_pc.laz"
AUTZEN = "urban/autzen_pdal/autzen_trim.laz"


def random_las(path, n=200, *, epsg=None, point_format=1, origin=(500000.0, 4000000.0), seed=0):
    """A small LAS file of ``n`` random points in a 100 m square at ``origin``, classes 1, 2 and 6."""
    rng = np.random.default_rng(seed)
    x = origin[0] + rng.uniform(0, 100, n)
    y = origin[1] + rng.uniform(0, 100, n)
    z = rng.uniform(0, 10, n)
    classes = rng.choice([1, 2, 6], n).astype(np.uint8)
    intensity = rng.integers(0, 1000, n).astype(np.uint16)
    return write_las(path, np.column_stack([x, y, z]), classes=classes, crs=None if epsg is None else f"EPSG:{epsg}",
                     scales=0.01, offsets=(origin[0], origin[1], 0.0), point_format=point_format, intensity=intensity)


def assert_same_cloud(a: PointCloud, b: PointCloud):
    """Same points in the same order, same classes, attributes (values and dtypes) and CRS."""
    np.testing.assert_array_equal(a.xyz, b.xyz)
    np.testing.assert_array_equal(a.classification, b.classification)
    assert a.classification.dtype == b.classification.dtype
    assert a.attributes.keys() == b.attributes.keys()
    for name in a.attributes:
        np.testing.assert_array_equal(a.attributes[name], b.attributes[name])
        assert a.attributes[name].dtype == b.attributes[name].dtype, name
    assert a.crs == b.crs


def sorted_keys(cloud: PointCloud, origin, scale=1000.0) -> np.ndarray:
    """The points (x, y, z in scale units from ``origin``, class) packed in one int64 each, sorted:
    the cloud as a set.

    Rounded to the LAS scale because files with different offsets give the same
    stored coordinates that differ in the last bit.
    """
    ints = np.round((cloud.xyz - origin) * scale).astype(np.int64)
    assert ints.min() >= 0
    bits = [int(ints[:, i].max()).bit_length() for i in range(3)]
    assert sum(bits) + 8 <= 63
    key = ints[:, 0]
    for i in (1, 2):
        key = (key << bits[i]) | ints[:, i]
    return np.sort((key << 8) | cloud.classification)


# -- expand_sources ---------------------------------------------------------------------------
def test_folder_files_sorted_other_files_left_out(tmp_path):
    for name in ("b.laz", "a.las", "c.xyz", "notes.md", "dem.tif"):
        (tmp_path / name).write_bytes(b"")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "d.laz").write_bytes(b"")
    assert [p.name for p in expand_sources(tmp_path)] == ["a.las", "b.laz", "c.xyz"]


def test_glob_sorted_and_list_order_kept_without_duplicates(tmp_path):
    for name in ("t2.laz", "t1.laz", "t3.las"):
        (tmp_path / name).write_bytes(b"")
    assert [p.name for p in expand_sources(str(tmp_path / "*.laz"))] == ["t1.laz", "t2.laz"]
    given = [tmp_path / "t3.las", str(tmp_path / "*.laz"), tmp_path / "sub" / ".." / "t1.laz", tmp_path]
    (tmp_path / "sub").mkdir()
    assert [p.name for p in expand_sources(given)] == ["t3.las", "t1.laz", "t2.laz"]


def test_missing_file(tmp_path):
    missing = tmp_path / "nope.laz"
    with pytest.raises(InputNotFoundError, match="nope.laz"):
        expand_sources([missing])
    with pytest.raises(InputNotFoundError, match="nope.laz"):
        read_clouds(missing)


def test_glob_matching_nothing(tmp_path):
    pattern = str(tmp_path / "tiles" / "*.laz")
    with pytest.raises(InputNotFoundError, match="no file matches") as info:
        read_clouds(pattern)
    assert pattern in str(info.value)


def test_empty_folder_and_folder_without_clouds(tmp_path):
    with pytest.raises(FileError, match="is empty") as info:
        read_clouds(tmp_path)
    assert str(tmp_path) in str(info.value)
    (tmp_path / "dem.tif").write_bytes(b"")
    with pytest.raises(FileError, match="no point-cloud file") as info:
        expand_sources(tmp_path)
    assert str(tmp_path) in str(info.value) and "dem.tif" in str(info.value)


def test_not_a_cloud_and_no_source(tmp_path):
    (tmp_path / "dem.tif").write_bytes(b"")
    with pytest.raises(InvalidInputError, match="dem.tif"):
        expand_sources(tmp_path / "dem.tif")
    with pytest.raises(InvalidInputError, match="matches no point-cloud file"):
        expand_sources(str(tmp_path / "*.tif"))
    with pytest.raises(InvalidInputError, match="no point-cloud source"):
        expand_sources([])


# -- cloud_header -----------------------------------------------------------------------------
def test_cloud_header_from_header_only():
    path = shared(TOPOGRAPHY)
    info = cloud_header(path)
    assert isinstance(info, CloudInfo)
    assert info.path == path and info.count == 73403
    cloud = read(path)
    np.testing.assert_allclose(info.bounds, cloud.bounds, atol=1e-6)
    assert pyproj.CRS.from_wkt(info.crs_wkt).to_epsg() == 2949
    assert cloud_header(shared(DELFT_2)).crs_wkt is None


def test_cloud_header_text(tmp_path):
    path = tmp_path / "pts.xyz"
    path.write_text("x y z\n0 0 1\n2 3 4\n1 5 2\n")
    assert cloud_header(path) == CloudInfo(path, 3, (0.0, 0.0, 1.0, 2.0, 5.0, 4.0), None)


# -- read_clouds: one file is read_las --------------------------------------------------------
@pytest.mark.parametrize("relative", [DELFT_2, TOPOGRAPHY, CODEM, AUTZEN])
def test_one_file_equals_read_las(relative):
    path = shared(relative)
    assert_same_cloud(read_clouds(path, chunk_size=50_000), read_las(path))


def test_one_file_classes_equals_read_las():
    path = shared(TOPOGRAPHY)
    assert_same_cloud(read_clouds([path], classes=[2, 9], chunk_size=10_000), read_las(path, classes=[2, 9]))


def test_one_text_file_equals_read_xyz(tmp_path):
    path = tmp_path / "pts.csv"
    path.write_text("x,y,z,class\n0,0,1,2\n2,3,4,6\n1,5,2,2\n")
    assert_same_cloud(read_clouds(path), read_xyz(path))
    np.testing.assert_array_equal(read_clouds(path, classes=[2]).xyz, read_xyz(path, classes=[2]).xyz)


def test_text_with_nan_refused(tmp_path):
    path = tmp_path / "pts.xyz"
    path.write_text("0 0 1\n2 3 nan\n")
    with pytest.raises(InvalidInputError, match="NaN") as info:
        read_clouds(path)
    assert str(path) in str(info.value)


# -- read_clouds: several files ---------------------------------------------------------------
def test_delft_crops_equal_merged_as_a_set():
    pattern = str(shared(DELFT_1).parent / "ahn3_cropped_*.laz")  # a glob on the shared data
    assert [p.name for p in expand_sources(pattern)] == ["ahn3_cropped_1.laz", "ahn3_cropped_2.laz"]
    both = read_clouds(pattern)
    merged = read_las(shared(DELFT_MERGED))
    assert len(both) == 640510 + 208432 == len(merged)
    assert both.crs is None
    assert set(both.attributes) == {"intensity", "return_number", "number_of_returns"}
    origin = np.array(merged.bounds[:3])
    np.testing.assert_array_equal(sorted_keys(both, origin), sorted_keys(merged, origin))


def test_folder_glob_and_list_read_the_same(tmp_path):
    paths = [random_las(tmp_path / f"tile_{i}.las", n=100 + i, epsg=26912, seed=i) for i in (2, 0, 1)]
    (tmp_path / "README.md").write_text("not a cloud")
    by_folder = read_clouds(tmp_path)
    by_glob = read_clouds(str(tmp_path / "tile_*.las"))
    by_list = read_clouds(sorted(paths) + [paths[0]])
    assert len(by_folder) == 303
    assert_same_cloud(by_folder, by_glob)
    assert_same_cloud(by_folder, by_list)
    # file after file, in the order of the names
    expected = [read_las(tmp_path / f"tile_{i}.las") for i in range(3)]
    np.testing.assert_array_equal(by_folder.xyz, np.concatenate([c.xyz for c in expected]))
    np.testing.assert_array_equal(by_folder.attributes["intensity"],
                                  np.concatenate([c.attributes["intensity"] for c in expected]))
    assert by_folder.crs == expected[0].crs


def test_classes_filter_over_files():
    paths = [shared(DELFT_2), shared(DELFT_1)]
    ground = read_clouds(paths, classes=[2, 9], chunk_size=100_000)
    expected = [read_las(p, classes=[2, 9]) for p in paths]
    np.testing.assert_array_equal(ground.xyz, np.concatenate([c.xyz for c in expected]))
    assert ground.class_counts() == {2: 87130 + 195988, 9: 568 + 267}


def test_class_not_present_names_classes_and_files():
    with pytest.raises(NoDataError) as info:
        read_clouds([shared(DELFT_1), shared(DELFT_2)], classes=[7])
    message = str(info.value)
    assert "class 7 in 2 files" in message and "ahn3_cropped_1.laz" in message and "ahn3_cropped_2.laz" in message
    assert message.endswith("the classes present are 1 (282445 points), 2 (283118 points), 6 (280065 points), "
                            "9 (835 points), 26 (2479 points)")


def test_bounds_equal_numpy_filter_closed_box():
    path = shared(DELFT_2)
    whole = read_las(path)
    x, y = whole.xyz[:, 0], whole.xyz[:, 1]
    # edges on the coordinates of two points: a closed box keeps the points on its edges
    xmin, ymin, _, xmax, ymax, _ = whole.bounds
    corner = int(np.argmin(np.hypot(x - (0.7 * xmin + 0.3 * xmax), y - (0.3 * ymin + 0.7 * ymax))))
    inside = np.flatnonzero((x > x[corner] + 20) & (x < x[corner] + 40) & (y < y[corner] - 30))
    other = inside[0]
    box = (float(x[corner]), float(y[other]), float(x[other]), float(y[corner]))
    keep = (x >= box[0]) & (x <= box[2]) & (y >= box[1]) & (y <= box[3])
    assert keep[corner] and keep[other] and 1000 < keep.sum() < len(whole) // 2
    assert_same_cloud(read_clouds(path, bounds=box, chunk_size=30_000), whole.select(keep))
    ground = read_clouds(path, bounds=box, classes=[2])
    assert_same_cloud(ground, whole.select(keep & (whole.classification == 2)))


def test_files_outside_bounds_not_read(tmp_path):
    # a damaged crop 1 whose header is intact: outside the bounds it is skipped, not read
    data = shared(DELFT_1).read_bytes()
    cut = tmp_path / "cut.laz"
    cut.write_bytes(data[: len(data) // 2])
    box = (85010.0, 447450.0, 85050.0, 447600.0)
    calls = []
    cloud = read_clouds([cut, shared(DELFT_2)], bounds=box, progress=lambda done, total: calls.append((done, total)))
    whole = read_las(shared(DELFT_2))
    x, y = whole.xyz[:, 0], whole.xyz[:, 1]
    np.testing.assert_array_equal(cloud.xyz, whole.xyz[(x >= box[0]) & (x <= box[2]) & (y >= box[1]) & (y <= box[3])])
    assert calls[-1] == (208432, 208432)  # the skipped file's points are not in the total
    with pytest.raises(FormatError) as info:
        read_clouds([cut, shared(DELFT_2)])
    assert str(cut) in str(info.value)


def test_bounds_outside_every_file():
    with pytest.raises(NoDataError, match="within bounds") as info:
        read_clouds([shared(DELFT_1), shared(DELFT_2)], bounds=(0, 0, 10, 10))
    assert "84808.3" in str(info.value)


def test_progress_increasing_to_the_total():
    calls = []
    read_clouds([shared(DELFT_1), shared(DELFT_2)], chunk_size=100_000,
                progress=lambda done, total: calls.append((done, total)))
    done = [d for d, _ in calls]
    assert len(calls) == 7 + 3
    assert all(b > a for a, b in zip(done, done[1:], strict=False))
    assert {t for _, t in calls} == {640510 + 208432}
    assert done[-1] == 640510 + 208432


# -- CRS --------------------------------------------------------------------------------------
def test_different_crs_refused_naming_both(tmp_path):
    a = random_las(tmp_path / "a.las", epsg=26912)
    b = random_las(tmp_path / "b.las", epsg=32616)
    with pytest.raises(InvalidInputError) as info:
        read_clouds([a, b])
    message = str(info.value)
    assert f"{str(a)!r} (NAD83 / UTM zone 12N)" in message
    assert f"{str(b)!r} (WGS 84 / UTM zone 16N)" in message
    assert "different CRSs" in message and "\n" not in message


def test_different_crs_refused_on_real_files():
    with pytest.raises(InvalidInputError, match="different CRSs") as info:
        read_clouds([shared(MIXED_CONIFER), shared(TOPOGRAPHY)])
    assert "NAD83 / UTM zone 12N" in str(info.value) and "MTM zone 7" in str(info.value)


def test_file_without_crs_takes_the_others(tmp_path):
    bare = random_las(tmp_path / "bare.las", seed=1)
    placed = random_las(tmp_path / "placed.las", epsg=26912, seed=2)
    cloud = read_clouds([bare, placed])
    assert len(cloud) == 400
    assert cloud.crs == read_las(placed).crs
    assert pyproj.CRS.from_wkt(cloud.crs).to_epsg() == 26912


def test_same_crs_accepted(tmp_path):
    a = random_las(tmp_path / "a.las", epsg=32616, seed=1)
    b = random_las(tmp_path / "b.las", epsg=32616, seed=2, origin=(500100.0, 4000000.0))
    assert len(read_clouds([a, b])) == 400


# -- attributes and mixed formats -------------------------------------------------------------
def test_attributes_missing_in_one_file_dropped(tmp_path):
    grey = random_las(tmp_path / "grey.las", point_format=1, seed=1)
    colour = random_las(tmp_path / "colour.las", point_format=3, seed=2)
    assert {"red", "green", "blue"} <= set(read_clouds(colour).attributes)
    both = read_clouds([grey, colour])
    assert set(both.attributes) == {"intensity", "return_number", "number_of_returns"}
    np.testing.assert_array_equal(both.attributes["intensity"][:200], read_las(grey).attributes["intensity"])


def test_las_and_text_together(tmp_path):
    las = random_las(tmp_path / "a.las", n=50)
    text = tmp_path / "b.xyz"
    text.write_text("500001 4000001 1 2\n500002 4000002 2 6\n")
    cloud = read_clouds([las, text])
    assert len(cloud) == 52 and cloud.attributes == {}
    np.testing.assert_array_equal(cloud.xyz[50:], [[500001, 4000001, 1], [500002, 4000002, 2]])
    assert len(read_clouds([las, text], classes=[6])) == int((read_las(las).classification == 6).sum()) + 1
    plain = tmp_path / "c.xyz"
    plain.write_text("500001 4000001 1\n")
    assert read_clouds([las, plain]).classification is None  # not every file has classes
    with pytest.raises(NoDataError, match="c.xyz"):
        read_clouds([las, plain], classes=[2])


@pytest.mark.parametrize(
    "options",
    [{"bounds": (1, 2, 3)}, {"bounds": (1, 0, 0, 1)}, {"chunk_size": 0}, {"progress": 3}, {"classes": "2"}],
)
def test_bad_options(tmp_path, options):
    with pytest.raises(InvalidOptionError):
        read_clouds(random_las(tmp_path / "a.las", n=5), **options)


def test_memory_checked_from_the_headers_before_reading(monkeypatch):
    calls = []
    monkeypatch.setenv(MEMORY_LIMIT_VARIABLE, "1M")
    with pytest.raises(ResourceError, match="reading 848,942 points from 2 LAS/LAZ files"):
        read_clouds([shared(DELFT_1), shared(DELFT_2)], progress=lambda done, total: calls.append(done))
    assert calls == []  # refused before any chunk


# -- tinsmith.read takes what the command line takes (issue 42) --------------------------------
def test_read_takes_a_list_a_folder_and_a_glob(tmp_path):
    paths = [random_las(tmp_path / f"t{i}.las", n=50, seed=i, epsg=32616) for i in range(3)]
    expected = read_clouds(paths)
    assert len(expected) == 150
    for sources in (paths, [str(p) for p in paths], tuple(paths), tmp_path, str(tmp_path), str(tmp_path / "t*.las"),
                    [tmp_path / "t0.las", str(tmp_path / "t[12].las")]):
        assert_same_cloud(read(sources), expected)
    assert_same_cloud(read([paths[1]]), read_las(paths[1]))
    assert_same_cloud(read(paths, classes=[2]), read_clouds(paths, classes=[2]))
    hf = read_heightfield(paths, cell_size=5.0)
    assert hf.cell_size == (5.0, 5.0) and pyproj.CRS.from_wkt(hf.crs).to_epsg() == 32616


def test_read_of_sources_refuses_raster_options(tmp_path):
    random_las(tmp_path / "a.las", n=20)
    with pytest.raises(InvalidOptionError, match="'band' does not apply to point clouds"):
        read(tmp_path, band=2)
    with pytest.raises(InvalidOptionError, match="unknown read option 'colour'"):
        read([tmp_path / "a.las"], colour=1)


def test_read_of_an_empty_folder_or_a_glob_matching_nothing(tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(FileError, match="is empty") as info:
        read(empty)
    assert str(empty) in str(info.value)
    pattern = str(tmp_path / "tiles" / "*.laz")
    with pytest.raises(InputNotFoundError, match="no file matches") as info:
        read(pattern)
    assert pattern in str(info.value)
    with pytest.raises(InvalidInputError, match="no point-cloud source"):
        read([])
    with pytest.raises(InputNotFoundError, match="no file matches"):
        read_heightfield([pattern])


def test_read_of_clouds_in_different_crss_as_read_clouds(tmp_path):
    a = random_las(tmp_path / "a.las", epsg=26912)
    b = random_las(tmp_path / "b.las", epsg=32616)
    with pytest.raises(InvalidInputError) as by_read:
        read([a, b])
    with pytest.raises(InvalidInputError) as by_read_clouds:
        read_clouds([a, b])
    assert str(by_read.value) == str(by_read_clouds.value)
    assert str(a) in str(by_read.value) and str(b) in str(by_read.value)


def cut_at_a_record(source, target, keep):
    """``source`` cut after its ``keep``-th point record: laspy reads it as ``keep`` points without a word."""
    header = laspy.open(source).header
    target.write_bytes(source.read_bytes()[: header.offset_to_point_data + keep * header.point_format.size])
    return target


def test_las_cut_at_a_record_boundary_refused_everywhere(tmp_path):
    whole = random_las(tmp_path / "whole.las", n=200)
    folder = tmp_path / "survey"
    folder.mkdir()
    cut = cut_at_a_record(whole, folder / "cut.las", 120)
    assert len(laspy.read(cut).points) == 120  # what laspy alone makes of it
    for call in (lambda: read(cut), lambda: read_las(cut), lambda: read_clouds(cut), lambda: read([cut]),
                 lambda: read(folder), lambda: read(str(folder / "*.las")), lambda: read_heightfield(cut),
                 lambda: read(cut, classes=[2])):
        with pytest.raises(FormatError) as info:
            call()
        message = str(info.value)
        assert f"{str(cut)!r} holds 120 points but its header announces 200" in message, message
        assert "\n" not in message


def test_laz_with_fewer_points_than_its_header_refused_with_both_counts(tmp_path):
    laz = random_las(tmp_path / "whole.laz", n=200)
    data = bytearray(laz.read_bytes())
    data[107:111] = (300).to_bytes(4, "little")  # the LAS 1.2 point count: 100 more than the file holds
    more = tmp_path / "more.laz"
    more.write_bytes(bytes(data))
    with pytest.raises(FormatError) as info:
        read(more)
    message = str(info.value)
    assert str(more) in message and "of the 300 points its header announces" in message and "\n" not in message


def test_without_attributes_the_same_points_and_classes(tmp_path):
    laspy = pytest.importorskip("laspy")
    rng = np.random.default_rng(3)
    n = 5000
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = [0.001, 0.001, 0.001]
    las = laspy.LasData(header)
    las.x, las.y, las.z = rng.uniform(0, 100, n), rng.uniform(0, 100, n), rng.uniform(0, 10, n)
    las.classification = rng.choice([1, 2, 6], n).astype(np.uint8)
    las.intensity = rng.integers(0, 1000, n).astype(np.uint16)
    path = tmp_path / "six.laz"
    las.write(path)
    full = read_clouds([path], classes=[2])
    lean = read_clouds([path], classes=[2], attributes=False)
    np.testing.assert_array_equal(full.xyz, lean.xyz)
    np.testing.assert_array_equal(full.classification, lean.classification)
    assert "intensity" in full.attributes and not lean.attributes
