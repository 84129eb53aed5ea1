"""Land-use steered spline and Haar filtering (Goebbels and Pohle-Fröhlich 2015, sections 5 and 6).

Roles, classes, the filter, the CLI.
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

import tinsmith
from tinsmith import Heightfield, LandUse
from tinsmith.algorithms.grid.quadtree import QuadtreeHierarchy
from tinsmith.algorithms.wavelet.landuse import landuse_classes, read_landuse
from tinsmith.algorithms.wavelet.spline import max_iterations, spline_approximation
from tinsmith.algorithms.wavelet.wavelet import TABLE_1, wavelet_model
from tinsmith.cli.main import main
from tinsmith.errors import InvalidInputError, InvalidOptionError, TinsmithWarning

from .conftest import shared

BGT = "vector/delft_bgt/delft_bgt_all_epsg28992.geojson"
DTM = "urban/delft_ahn3/delft_dtm_0.5m.tif"
DSM = "urban/delft_ahn3/delft_dsm_0.5m.tif"


def grid(z, crs="EPSG:28992"):
    """A grid of 1 m cells whose cell (row, col) has its centre at x = col + 0.5, y = -(row + 0.5)."""
    return Heightfield(np.asarray(z, float), cell_size=1.0, origin=(0.0, 0.0), crs=crs)


def box(c0, r0, c1, r1):
    """The polygon over cells c0..c1-1, r0..r1-1 of :func:`grid`."""
    return shapely.box(c0, -r1, c1, -r0)


# -- roles ------------------------------------------------------------------------------
def test_bgt_roles_from_the_merged_file_and_from_a_layer_name():
    lu = read_landuse(shared(BGT))
    counts = {r: int((lu.roles == r).sum()) for r in set(lu.roles)}
    # water 3, bridges 3, road parts 151, the weir 1, quay walls (bgt_type=kademuur) 13
    assert counts == {"water": 3, "bridge": 3, "street": 151, "embankment": 1, "shoreline": 13}
    assert "Amersfoort" in lu.crs
    roads = read_landuse(shared("vector/delft_bgt/bgt_wegdeel.sqlite"))  # the layer is named trafficarea
    assert len(roads.geometries) == 151 and set(roads.roles) == {"street"}


def test_roles_by_attribute_and_field_value_and_their_errors():
    path = shared(BGT)
    by_value = read_landuse(path, roles={"bgt_pand": "shoreline"}, attribute="bgt_layer")
    assert len(by_value.geometries) == 160
    parking = read_landuse(path, roles={"function=parkeervlak": "street", "FUNCTION=Voetpad": "street"})
    assert len(parking.geometries) == 36 + 78  # keys compare without regard to case
    with pytest.warns(TinsmithWarning, match="no feature .* has a role"):
        assert len(read_landuse(path, roles={"nothing": "water"}).geometries) == 0
    with pytest.raises(InvalidOptionError, match="attribute 'usage' is not a column"):
        read_landuse(path, attribute="usage")
    with pytest.raises(InvalidOptionError, match="roles"):
        read_landuse(path, roles={"wegdeel": "road"})
    with pytest.raises(tinsmith.InputNotFoundError, match="does not exist"):
        read_landuse("/no/such/landuse.gpkg")
    with pytest.raises(InvalidInputError, match="'water' must be polygons"):
        LandUse([shapely.LineString([(0, 0), (1, 1)])], ["water"])


# -- classes ----------------------------------------------------------------------------
def test_classes_near_features_streets_touching_bridges_and_embankment_interiors():
    hf = grid(np.zeros((40, 60)))
    lu = LandUse(
        [box(5, 5, 15, 35), box(15, 15, 20, 20), box(20, 15, 30, 20), box(40, 30, 55, 34), box(45, 2, 50, 8)],
        ["water", "bridge", "street", "street", "embankment"],
    )
    c = landuse_classes(hf, lu, window=5, bridge_extension=0.5)
    assert c.water.max() == 1 and (c.water[5:35, 5:15] == 1).all() and c.water.sum() == 300
    assert c.sources["street"][17, 25] and not c.sources["street"][32, 47]  # only the street touching the bridge
    assert c.near[17, 29] and c.near[17, 31] and not c.near[17, 33]  # 2 points beyond the street's end
    assert c.near[20, 3] and not c.near[20, 2]  # the shoreline: 2 points beyond the water's outline
    assert c.embankment[2:8, 45:50].all() and c.embankment.sum() == 30
    assert not c.near[32, 47]


def test_features_in_another_crs_are_reprojected_and_those_outside_reported():
    from pyproj import Transformer

    hf = grid(np.zeros((30, 30)))
    native = LandUse([box(5, 5, 12, 20)], ["water"], crs="EPSG:28992")
    to_wgs84 = Transformer.from_crs("EPSG:28992", "EPSG:4326", always_xy=True)
    # a point of the polygon far from the grid's origin is not on the grid in degrees: move it to RD first
    shift = shapely.affinity.translate(native.geometries[0], 85000, 447000)
    hf_rd = Heightfield(np.zeros((30, 30)), cell_size=1.0, origin=(85000.0, 447000.0), crs="EPSG:28992")
    in_degrees = shapely.transform(shift, lambda xy: np.column_stack(to_wgs84.transform(xy[:, 0], xy[:, 1])))
    a = landuse_classes(hf_rd, LandUse([shift], ["water"], crs="EPSG:28992"))
    b = landuse_classes(hf_rd, LandUse([in_degrees], ["water"], crs="EPSG:4326"))
    np.testing.assert_array_equal(a.water > 0, b.water > 0)
    assert (a.water > 0).sum() == 7 * 15
    with pytest.warns(TinsmithWarning, match="1 entirely outside"):
        c = landuse_classes(hf_rd, LandUse([box(85100, 447100, 85110, 447110)], ["bridge"], crs="EPSG:28992"))
    assert c.outside == 1 and not c.near.any()
    with pytest.raises(InvalidInputError, match="do not overlap the data"):  # no CRS to move them by
        landuse_classes(hf, LandUse([box(100, 100, 110, 110)], ["bridge"]))
    with pytest.raises(InvalidOptionError, match="window must be odd"):
        landuse_classes(hf, native, window=4)


# -- the filter -------------------------------------------------------------------------
def test_hard_replacement_is_the_papers_rule():
    rng = np.random.default_rng(4)
    z = np.cumsum(np.cumsum(rng.normal(0, 0.3, (65, 65)), 0), 1) / 8
    hf = grid(z)
    lu = LandUse([box(10, 10, 30, 30)], ["embankment"])
    for variant in (None, 3, 4):
        result = tinsmith.wavelet_filter(hf, landuse=lu, spline_iterations=2, delta=1.0, variant=variant, replace="hard")
        spline = spline_approximation(z, 2)
        f = result.heightfield.z
        detailed = np.isin(result.classes, (1, 2, 3, 4))
        assert (result.classes[10:30, 10:30] == 2).all()  # the embankment's interior
        np.testing.assert_array_equal(f[~detailed], spline[~detailed])  # class 3: the spline
        moved = detailed & (f != spline)
        assert (np.abs(f - spline)[moved] > 0.3).all()  # the detail replaces the spline only beyond 0.3 m
        if variant is None:
            np.testing.assert_array_equal(f[moved], z[moved])
            assert np.array_equal(moved, detailed & (np.abs(z - spline) > 0.3))
        assert (np.abs(z - spline)[result.classes == 3] > 1.0).all()
        assert (np.abs(z - spline)[result.classes == 5] <= 1.0).all()


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 10_000), st.integers(17, 70), st.integers(17, 70), st.integers(1, 3),
       st.floats(0.05, 3.0), st.floats(0.0, 0.6))
def test_soft_unfiltered_detail_keeps_every_class_within_its_bound(seed, h, w, iterations, delta, tolerance):
    rng = np.random.default_rng(seed)
    z = np.cumsum(rng.normal(0, 0.4, (h, w)), axis=1) + rng.normal(0, 0.2, (h, w))
    hf = grid(z)
    c0, c1 = sorted(rng.integers(0, w, 2))
    r0, r1 = sorted(rng.integers(0, h, 2))
    features = [box(c0, r0, c1 + 1, r1 + 1), box(0, 0, w // 3 + 1, h // 3 + 1)]
    lu = LandUse(features, ["embankment", "forest"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TinsmithWarning)
        result = tinsmith.wavelet_filter(hf, landuse=lu, spline_iterations=iterations, delta=delta, variant=None,
                                         replace="soft", replace_tolerance=tolerance, window=3)
    e = np.abs(result.heightfield.z - z)
    bound = {1: min(tolerance, 0.4), 2: min(tolerance, 0.1), 3: min(tolerance, 0.5), 4: min(tolerance, 20.0), 5: delta}
    for code, b in bound.items():
        assert (e[result.classes == code] <= b + 1e-9).all(), code


def test_auto_keeps_the_iteration_count_of_fewest_triangles_and_the_mesh_meets_max_error():
    rng = np.random.default_rng(1)
    z = np.cumsum(np.cumsum(rng.normal(0, 0.2, (40, 110)), 0), 1) / 10
    hf = grid(z)
    mesh = tinsmith.wavelet(hf, max_error=0.1)
    result = tinsmith.wavelet_filter(hf, max_error=0.1)
    tried = result.triangles
    assert sorted(tried) == list(range(1, 1 + min(6, max_iterations(40)))) and mesh.n_triangles == min(tried.values())
    assert result.spline_iterations == min(k for k, v in tried.items() if v == mesh.n_triangles)
    assert tinsmith.vertical_error(mesh, result.heightfield)["max"] <= 0.1 + 1e-9
    assert mesh.check() == []
    assert mesh.info["wavelet"]["classes"]["class 1"] == 0  # no land use: no class 1
    again = tinsmith.simplify(hf, method="wavelet", max_error=0.1)
    np.testing.assert_array_equal(again.triangles, mesh.triangles)  # deterministic
    assert again.info["max_error_used"] == 0.1 and tinsmith.wavelet(hf).info["max_error_used"] == 0.2


def test_the_former_names_epsilon_and_return_filter_still_work_with_a_warning():
    hf = grid(np.cumsum(np.random.default_rng(2).normal(0, 0.3, (30, 40)), axis=1))
    with pytest.warns(DeprecationWarning) as caught:
        mesh, result = tinsmith.wavelet(hf, epsilon=0.1, return_filter=True)
    assert sorted(str(w.message).split(" of ")[0] for w in caught) == ["epsilon", "return_filter"]
    assert all(w.filename == __file__ for w in caught)
    np.testing.assert_array_equal(mesh.triangles, tinsmith.wavelet(hf, max_error=0.1).triangles)
    np.testing.assert_array_equal(result.heightfield.z, tinsmith.wavelet_filter(hf, max_error=0.1).heightfield.z)
    with pytest.warns(DeprecationWarning, match="epsilon of wavelet_filter is deprecated"):
        tinsmith.wavelet_filter(hf, epsilon=0.1)
    both, filtered = wavelet_model(hf, max_error=0.1)  # the two in one run, without the deprecated keyword
    np.testing.assert_array_equal(both.triangles, mesh.triangles)
    np.testing.assert_array_equal(filtered.classes, result.classes)


def test_errors_name_the_option():
    hf = grid(np.zeros((20, 20)))
    with pytest.raises(InvalidOptionError, match="thresholds has no row 'class4'"):
        tinsmith.wavelet(hf, thresholds={"class4": [0.1] * 9})
    with pytest.raises(InvalidOptionError, match="at least 0"):
        tinsmith.wavelet(hf, thresholds={"class1": [-0.1] * 9})
    with pytest.raises(InvalidOptionError, match="one length"):
        tinsmith.wavelet(hf, thresholds={"class1": [0.1] * 5})
    with pytest.raises(InvalidOptionError, match="variant must be 3 or 4"):
        tinsmith.wavelet(hf, variant=5)
    with pytest.raises(InvalidOptionError, match="spline_iterations must be 'auto' or a whole number from 0 to 5"):
        tinsmith.wavelet(hf, spline_iterations=7)
    with pytest.raises(InvalidOptionError, match="replace must be one of"):
        tinsmith.wavelet(hf, replace="blend")
    with pytest.raises(InvalidInputError, match="max_error must be a finite number > 0"):
        tinsmith.wavelet(hf, max_error=0)
    with pytest.warns(DeprecationWarning), pytest.raises(InvalidInputError, match="epsilon must be a finite number > 0"):
        tinsmith.wavelet(hf, epsilon=0)  # the name the caller used
    with pytest.raises(InvalidOptionError, match="'wavelet' takes max_error, not max_vertices"):
        tinsmith.wavelet(hf, max_vertices=100)
    with pytest.raises(InvalidOptionError, match="roles and attribute need a land-use file"):
        tinsmith.wavelet(hf, roles={"waterdeel": "water"})
    with pytest.raises(InvalidInputError, match="takes a Heightfield"):
        tinsmith.wavelet(np.zeros((4, 4)))


# -- Delft --------------------------------------------------------------------------------
def test_delft_dtm_water_is_flat_and_soft_detail_keeps_class_1_within_its_bound():
    hf = tinsmith.read_heightfield(shared(DTM))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TinsmithWarning)  # one road part lies beyond the DEM
        options = dict(landuse=shared(BGT), variant=None, max_error=0.2)
        mesh, result = tinsmith.wavelet(hf, **options), tinsmith.wavelet_filter(hf, **options)
    bodies, flat = result.landuse.water, result.classes == 6
    assert bodies.max() >= 2 and flat.sum() > 0.95 * (bodies > 0).sum()  # all but bridge decks
    for k in range(1, bodies.max() + 1):
        assert np.ptp(result.heightfield.z[flat & (bodies == k)]) == 0  # flat
    assert result.class_counts()["class 1"] > 10_000
    report = mesh.info["wavelet"]["error_by_class"]
    assert report["class 1"]["filter_max"] <= 0.3 + 1e-9
    assert report["class 1"]["max"] <= 0.3 + 0.2 + 1e-6  # the filter's bound plus epsilon
    assert report["class 1, embankment interior"]["max"] <= 0.1 + 0.2 + 1e-6
    unfiltered = QuadtreeHierarchy(hf, diagonal="rule").mesh(0.2).n_triangles
    assert mesh.n_triangles < 0.6 * unfiltered  # measured: 0.50


def test_delft_dsm_bridges_over_water_keep_their_deck():
    from tinsmith.algorithms.wavelet.landuse import _burn

    hf = tinsmith.read_heightfield(shared(DSM))
    lu = read_landuse(shared(BGT))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TinsmithWarning)
        result = tinsmith.wavelet_filter(hf, landuse=lu, spline_iterations=3)
    water = result.landuse.water > 0
    decks = _burn(lu.geometries[lu.roles == "bridge"], hf, all_touched=False)
    over_water = water & decks
    assert over_water.sum() > 300 and (result.classes[over_water] != 6).all()  # not flattened with the water
    assert np.ptp(result.heightfield.z[decks]) > 0.5  # the decks keep their shape: not flattened with the water


# -- command line -------------------------------------------------------------------------
def test_cli_wavelet_writes_the_mesh_the_filtered_heights_and_the_classes(tmp_path, capsys):
    out, filtered, classes = tmp_path / "delft.ply", tmp_path / "filtered.tif", tmp_path / "classes.tif"
    code = main(["wavelet", str(shared(DTM)), "--landuse", str(shared(BGT)), "-o", str(out), "--filtered", str(filtered),
                 "--class-map", str(classes), "--spline-iterations", "3", "--replace", "soft", "--json"])
    stdout, err = capsys.readouterr()
    assert code == 0, err
    assert "warning: land use 'delft_bgt_all_epsg28992.geojson': 1 entirely outside it" in err
    report = json.loads(stdout)
    assert report["spline_iterations"] == 3 and report["n_triangles"] == tinsmith.read_mesh(out).n_triangles
    assert set(report["error_by_class"]) == {"class 1", "class 1, embankment interior", "class 3", "water"}
    f = tinsmith.read_heightfield(filtered)
    c = tinsmith.read_heightfield(classes)
    assert f.shape == c.shape == (458, 529) and set(np.unique(c.z[c.valid])) <= {1, 2, 3, 4, 5, 6}


def test_cli_prefilter_and_errors(tmp_path, capsys):
    out = tmp_path / "g.ply"
    code = main(["simplify", str(shared(DTM)), "--method", "greedy", "--max-error", "0.3", "--prefilter", "wavelet",
                 "--landuse", str(shared(BGT)), "--spline-iterations", "4", "-o", str(out)])
    stdout, err = capsys.readouterr()
    assert code == 0, err
    assert "unfiltered" in stdout
    assert main(["simplify", "--sample", "st-helens", "--landuse", str(shared(BGT)), "-o", str(out)]) == 1
    assert "go with --prefilter wavelet" in capsys.readouterr().err
    assert main(["wavelet", "--sample", "st-helens", "--landuse", str(shared(BGT)), "-o", str(out), "--role", "x:road"]) == 1
    assert "expected KEY:ROLE" in capsys.readouterr().err
    assert main(["wavelet", "--sample", "st-helens", "--landuse", str(shared(BGT)), "-o", str(out),
                 "--filtered", str(tmp_path / "f.png")]) == 1
    assert "GeoTIFF" in capsys.readouterr().err
    assert main(["wavelet", "--sample", "st-helens", "--landuse", str(tmp_path / "none.gpkg"), "-o", str(out)]) == 1
    assert "does not exist" in capsys.readouterr().err
    assert not out.exists() or out.stat().st_size > 0


def test_table_1_is_the_default():
    assert TABLE_1["class1"] == (0.0, 0.1, 0.1, 0.2, 0.2, 0.2, 0.3, 0.3, 0.4)
    assert TABLE_1["forest"][5:] == (20.0,) * 4


def test_nodata_stays_nodata_and_is_never_meshed():
    rng = np.random.default_rng(7)
    z = np.cumsum(rng.normal(0, 0.3, (50, 60)), axis=1)
    z[10:20, 30:45] = np.nan
    hf = Heightfield(z, cell_size=1.0, origin=(0.0, 0.0), crs="EPSG:28992", nodata=float("nan"))
    lu = LandUse([box(25, 5, 50, 25)], ["water"], crs="EPSG:28992")
    mesh, result = tinsmith.wavelet(hf, landuse=lu, max_error=0.1), tinsmith.wavelet_filter(hf, landuse=lu, max_error=0.1)
    assert (result.classes[10:20, 30:45] == 0).all() and result.heightfield.nodata_mask[10:20, 30:45].all()
    flat = result.classes == 6
    assert flat.sum() == 25 * 20 - 10 * 15 and np.ptp(result.heightfield.z[flat]) == 0
    covered = ~np.isnan(tinsmith.rasterize(mesh, hf))
    assert not (covered & hf.nodata_mask).any()
