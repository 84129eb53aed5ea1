"""TerrainMesh.to_anuga (tinsmith.io.flood): the domain is the mesh, every border edge is tagged, and a short
real event in ANUGA keeps its mass, stays finite and runs downhill."""

import collections
import contextlib
import io
import sys

import numpy as np
import pytest

import tinsmith
from tinsmith import shapes
from tinsmith.core import Heightfield
from tinsmith.errors import InvalidInputError, InvalidMeshError, InvalidOptionError, MissingDependencyError, TinsmithWarning
from tinsmith.io.boundaries import named_boundaries
from tinsmith.io.flood import border_tags

with contextlib.redirect_stdout(io.StringIO()):  # ANUGA prints a warning on stdout when mpi4py is absent
    anuga = pytest.importorskip("anuga")

RAIN = 0.01  # m/s: a storm no sky gives, so that a few seconds move water a measurable way


@pytest.fixture(scope="module")
def helens():
    hf = tinsmith.read_heightfield(tinsmith.sample_path("st-helens"))
    return tinsmith.simplify(hf, method="quality", max_error=40)


def _plane(nx=16, ny=8, cell=10.0, hole=None, crs="EPSG:32610"):
    """A plane falling 1 in 20 towards x = 0, on a grid of cells (a block of nodata for a hole)."""
    z = np.tile(0.05 * cell * np.arange(nx + 1, dtype=float), (ny + 1, 1))
    if hole is not None:
        z[hole] = np.nan
    mesh = tinsmith.simplify(Heightfield(z, transform=(cell, 0, 500000.0, 0, -cell, 4100000.0 + ny * cell),
                                         crs=crs, nodata=float("nan")), method="grid")
    return mesh


def _border_keys(domain):
    """(triangle, edge) of every edge without a neighbour in ANUGA's own neighbour structure."""
    t, e = np.nonzero(domain.neighbours < 0)
    return set(zip(t.tolist(), e.tolist(), strict=True))


def _depth(domain):
    q = domain.quantities
    return q["stage"].centroid_values - q["elevation"].centroid_values, q["elevation"].centroid_values


def _evolve(domain, seconds):
    domain.set_store(False)
    for _ in domain.evolve(yieldstep=seconds / 4, finaltime=seconds):
        pass


# -- the domain is the mesh -----------------------------------------------------------------------------------

def test_domain_is_the_mesh(helens):
    assert 2000 < helens.n_triangles < 4000
    domain = helens.to_anuga(friction=0.03)
    assert len(domain) == helens.n_triangles
    np.testing.assert_array_equal(domain.triangles, helens.triangles)  # same order, already counter-clockwise
    origin = np.array([domain.geo_reference.xllcorner, domain.geo_reference.yllcorner])
    np.testing.assert_allclose(domain.nodes + origin, helens.vertices[:, :2], rtol=0, atol=1e-6)
    assert domain.geo_reference.get_epsg() == 26710  # NAD27 / UTM zone 10N, the DEM's
    # elevation at the vertices is the mesh's z, not re-interpolated
    z = domain.quantities["elevation"].vertex_values
    np.testing.assert_array_equal(z, helens.vertices[:, 2][helens.triangles])
    assert (domain.areas > 0).all()
    np.testing.assert_array_equal(domain.quantities["friction"].centroid_values, 0.03)
    h, _ = _depth(domain)
    np.testing.assert_array_equal(h, 0.0)  # dry


def test_every_border_edge_is_tagged(helens):
    domain = helens.to_anuga()
    assert _border_keys(domain) == set(domain.boundary) == set(border_tags(helens))  # none left to ANUGA's default
    assert len(domain.boundary) == len(helens.boundary_edges())
    assert set(domain.boundary.values()) == {"exterior"}


def test_holes_are_tagged_apart_and_clockwise_meshes_turned():
    mesh = _plane(hole=(slice(3, 6), slice(6, 10)))
    loops = named_boundaries(mesh)["outline"]
    assert len(loops) == 2
    domain = mesh.to_anuga()
    assert _border_keys(domain) == set(domain.boundary)
    counts = collections.Counter(domain.boundary.values())
    assert counts == {"exterior": len(loops[0]) - 1, "hole": len(loops[1]) - 1}
    # the same mesh wound clockwise throughout: turned, the same tags
    flipped = tinsmith.TerrainMesh(mesh.vertices, mesh.triangles[:, ::-1], crs=mesh.crs)
    turned = flipped.to_anuga()
    assert (turned.areas > 0).all() and collections.Counter(turned.boundary.values()) == counts
    np.testing.assert_array_equal(turned.quantities["elevation"].centroid_values,
                                  domain.quantities["elevation"].centroid_values)


def test_node_strings_and_the_callers_tags():
    mesh = _plane()
    x, y = mesh.vertices[:, 0], mesh.vertices[:, 1]
    west = np.flatnonzero(np.isclose(x, x.min()))
    west = west[np.argsort(y[west])]
    mesh.node_strings = {"outlet": west, "inside": np.flatnonzero(np.isclose(x, x.min() + 10))}
    domain = mesh.to_anuga()
    on_west = {k for k, tag in domain.boundary.items() if tag == "outlet"}
    assert len(on_west) == len(west) - 1
    assert set(domain.boundary.values()) == {"exterior", "outlet"}  # an interior node string tags nothing
    assert _border_keys(domain) == set(domain.boundary)
    # a callable of the midpoint: the north side; None keeps the node string's and the default tags
    north = y.max()
    named = mesh.to_anuga(boundary_tags=lambda mx, my: "north" if my == north else None)
    counts = collections.Counter(named.boundary.values())
    assert counts == {"north": 16, "outlet": 8, "exterior": 16 + 8}  # the south and east sides
    # a mapping {tag: vertex indices}: over the node string of the same name, and a new one
    east = np.flatnonzero(np.isclose(x, x.max()))
    renamed = mesh.to_anuga(boundary_tags={"outlet": west[:3], "inflow": east})
    counts = collections.Counter(renamed.boundary.values())
    assert counts["outlet"] == 2 and counts["inflow"] == len(east) - 1
    # the caller's names win over every node string of the mesh, whatever their order
    mesh.node_strings = {"gate": west[:3], "outlet": west}
    counts = collections.Counter(mesh.to_anuga(boundary_tags={"gate": west[:2]}).boundary.values())
    assert counts["gate"] == 1 and counts["outlet"] == len(west) - 2
    counts = collections.Counter(mesh.to_anuga(boundary_tags={"weir": west[:3]}).boundary.values())
    assert counts["weir"] == 2 and "gate" not in counts


@pytest.mark.parametrize(("tags", "match"), [
    ({"wall": [0]}, "two or more vertex indices"),
    ({"wall": [0, 10**6]}, "two or more vertex indices"),
    ({"": [0, 1]}, "non-empty string"),
    (["exterior"], "a mapping"),
])
def test_bad_boundary_tags_are_refused(tags, match):
    with pytest.raises(InvalidOptionError, match=match):
        _plane(4, 4).to_anuga(boundary_tags=tags)


def test_a_callable_must_name_with_strings():
    with pytest.raises(InvalidOptionError, match="non-empty string"):
        _plane(4, 4).to_anuga(boundary_tags=lambda x, y: 3)


@pytest.mark.parametrize("friction", [-0.01, float("nan"), "rough", True])
def test_bad_friction_is_refused(friction):
    with pytest.raises(InvalidOptionError, match="Manning's n"):
        _plane(4, 4).to_anuga(friction=friction)


# -- what cannot be a domain ----------------------------------------------------------------------------------

def test_meshes_that_cannot_be_domains_are_refused_in_one_line():
    square = np.array([[0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0], [5, 5, 3]], float)
    cases = [
        (tinsmith.TerrainMesh(square, np.empty((0, 3), int)), "no triangles"),
        (shapes.ellipsoid(200), "closed surface"),
        # three triangles on the edge 0-2
        (tinsmith.TerrainMesh(square, [[0, 1, 2], [0, 2, 3], [0, 2, 4]]), "more than two triangles"),
        # one triangle folded over its neighbour
        (tinsmith.TerrainMesh(square, [[0, 1, 2], [0, 3, 2]]), "clockwise"),
        (tinsmith.TerrainMesh(np.vstack([square, [[20, 20, 0]]]), [[0, 1, 2], [0, 2, 5]]), "zero area"),
    ]
    for mesh, match in cases:
        with pytest.raises(InvalidMeshError, match=match) as err:
            mesh.to_anuga()
        assert "\n" not in str(err.value) and "ANUGA" in str(err.value)


def test_degrees_and_feet_are_refused():
    mesh = _plane(4, 4)
    lonlat = tinsmith.TerrainMesh((mesh.vertices - [500000, 4100000, 0]) * [1e-5, 1e-5, 1] + [-122.2, 46.2, 0],
                                  mesh.triangles, crs="EPSG:4326")
    with pytest.raises(InvalidInputError, match="geographic.*EPSG:32610") as err:
        lonlat.to_anuga()
    assert "\n" not in str(err.value)
    feet = tinsmith.TerrainMesh(mesh.vertices, mesh.triangles, crs="EPSG:2264")  # NAD83 / North Carolina (ftUS)
    with pytest.raises(InvalidInputError, match="metres.*foot"):
        feet.to_anuga()


def test_without_anuga_the_refusal_names_the_package(monkeypatch):
    monkeypatch.setitem(sys.modules, "anuga", None)  # import anuga: ImportError
    with pytest.raises(MissingDependencyError, match="TerrainMesh.to_anuga needs ANUGA: pip install anuga"):
        _plane(4, 4).to_anuga()


# -- a short real event ---------------------------------------------------------------------------------------

def test_rain_on_st_helens_keeps_its_mass_and_runs_downhill(helens):
    domain = helens.to_anuga(friction=0.03)
    domain.set_boundary({"exterior": anuga.Reflective_boundary(domain)})
    anuga.Rate_operator(domain, rate=RAIN)
    seconds = 60.0
    _evolve(domain, seconds)
    for name in ("stage", "xmomentum", "ymomentum"):
        assert np.isfinite(domain.quantities[name].centroid_values).all(), name
    rained = RAIN * seconds * domain.get_area()
    assert domain.get_water_volume() == pytest.approx(rained, rel=1e-6)  # walls all round: nothing leaves
    h, z = _depth(domain)
    assert h.min() >= 0
    area = domain.areas
    # rain fell evenly; by now the water sits lower than the ground it fell on, deeper in the low half
    assert np.sum(h * area * z) / np.sum(h * area) < np.sum(area * z) / np.sum(area) - 10.0
    low = z < np.median(z)
    assert h[low].mean() > 1.3 * h[~low].mean()


def test_an_outlet_tagged_by_a_callable_drains_the_plane():
    mesh = _plane()
    west = mesh.vertices[:, 0].min()
    domain = mesh.to_anuga(friction=0.02, boundary_tags=lambda x, y: "outlet" if x == west else None)
    domain.set_quantity("stage", expression="elevation + 0.2")  # a sheet of water 0.2 m deep on the slope
    start = domain.get_water_volume()
    domain.set_boundary({"exterior": anuga.Reflective_boundary(domain), "outlet": anuga.Transmissive_boundary(domain)})
    _evolve(domain, 20.0)
    h, z = _depth(domain)
    assert np.isfinite(h).all()
    assert domain.get_water_volume() < 0.8 * start  # out through the low side, the only open one
    # and the same sheet behind walls all round keeps its volume, deepening downhill
    closed = mesh.to_anuga(friction=0.02)
    closed.set_quantity("stage", expression="elevation + 0.2")
    closed.set_boundary({"exterior": anuga.Reflective_boundary(closed)})
    _evolve(closed, 20.0)
    assert closed.get_water_volume() == pytest.approx(start, rel=1e-9)
    h, z = _depth(closed)
    assert h[z < np.median(z)].mean() > h[z > np.median(z)].mean() + 0.1


# -- border triangles ANUGA cannot reconstruct ----------------------------------------------------------------

def test_border_triangles_with_neighbours_in_line_are_where_anuga_goes_non_finite(helens):
    """West Bijou's quality mesh of 183 triangles has two border triangles whose neighbours' centroids lie in
    line with their own: to_anuga says so, and they are where a short rain run turns NaN first."""
    from tinsmith.io.flood import in_line_border_triangles

    from .conftest import shared

    hf = tinsmith.read_heightfield(shared("terrain/landlab_west_bijou/west_bijou_gully.asc"))
    mesh = tinsmith.simplify(hf, method="quality", max_triangles=198)
    with pytest.warns(TinsmithWarning, match=r"border triangle\(s\) of this mesh have their two neighbours"):
        domain = mesh.to_anuga(friction=0.03)
    flagged = in_line_border_triangles(domain)
    assert len(flagged) >= 1
    domain.set_store(False)
    domain.set_boundary({tag: anuga.Reflective_boundary(domain) for tag in set(domain.boundary.values())})
    anuga.Rate_operator(domain, rate=0.1 / 3600)
    q = domain.quantities
    broken = []
    with contextlib.redirect_stdout(io.StringIO()):
        for _ in domain.evolve(yieldstep=0.01, finaltime=1.0):  # to the first step with a non-finite value
            values = np.column_stack([q[k].centroid_values for k in ("stage", "xmomentum", "ymomentum")])
            broken = np.flatnonzero(~np.isfinite(values).all(axis=1))
            if len(broken):
                break
    assert len(broken) and set(broken.tolist()) <= set(flagged.tolist()), (broken, flagged)
    assert len(in_line_border_triangles(helens.to_anuga())) == 0  # the St. Helens mesh of the other tests: none
