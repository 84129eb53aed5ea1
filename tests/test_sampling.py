"""The feature skeleton and exact-count sampling by error diffusion (Alliez et al. 2003, sections 2 and 3)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tinsmith
from tinsmith.algorithms.remesh.sampling import CORNER, FEATURE, SURFACE, sample_mesh, vertex_density
from tinsmith.algorithms.remesh.skeleton import feature_skeleton, mesh_edges
from tinsmith.errors import InvalidMeshError, InvalidOptionError

from .conftest import grid_mesh, punch_holes


def roof(n=21):
    """Two planes at 45 degrees meeting along a ridge (a 90-degree dihedral) over an n x n grid."""
    c = np.arange(n)
    return grid_mesh(np.tile(-np.abs(c - n // 2).astype(float), (n, 1)))


def test_a_flat_square_has_four_corners_and_four_boundary_backbones():
    mesh = grid_mesh(np.zeros((11, 16)))
    s = feature_skeleton(mesh)
    assert len(s.corners) == 4 and len(s.backbones) == 4
    assert set(s.kind) == {"boundary"} and not any(s.closed)
    assert s.length(mesh.vertices) == pytest.approx(2 * (10 + 15))
    assert sorted(len(b) - 1 for b in s.backbones) == [10, 10, 15, 15]


def test_a_ridge_is_a_sharp_backbone_between_two_corners():
    mesh = roof()
    s = feature_skeleton(mesh, feature_angle=60)
    sharp = [b for b, k in zip(s.backbones, s.kind, strict=False) if k == "sharp"]
    assert len(sharp) == 1 and len(sharp[0]) == 21
    assert np.ptp(mesh.vertices[sharp[0], 0]) == 0  # along the ridge column
    assert len(s.corners) == 6  # the square's corners and the ridge's two ends on the boundary
    assert not any(k == "sharp" for k in feature_skeleton(mesh, feature_angle=100).kind)  # 90 degrees < 100


def test_mesh_edges_refuses_non_manifold_and_misoriented_meshes():
    with pytest.raises(InvalidMeshError, match="not manifold"):
        mesh_edges(np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]]))
    with pytest.raises(InvalidMeshError, match="not consistently oriented"):
        mesh_edges(np.array([[0, 1, 2], [0, 1, 3]]))
    assert len(mesh_edges(np.array([[0, 1, 2], [1, 0, 4]])).edges) == 5


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 10_000), st.integers(3, 25), st.integers(3, 25), st.data(),
       st.sampled_from(["uniform", "curvature"]), st.floats(0.1, 4.0))
def test_the_count_is_exact_and_every_sample_lies_on_the_mesh(seed, h, w, holes, density, scale):
    z = np.random.default_rng(seed).normal(0, 1, (h, w)).cumsum(axis=0)
    z, _ = punch_holes(z, holes)
    try:
        mesh = grid_mesh(z)
    except tinsmith.NoDataError:
        return
    corners = len(feature_skeleton(mesh).corners)
    n = corners + 1 + int(scale * mesh.n_vertices)
    s = sample_mesh(mesh, n, density=density, seed=seed)
    assert len(s.points) == n
    surf = s.kind == SURFACE
    assert (s.bary[surf] >= -1e-12).all() and np.allclose(s.bary[surf].sum(axis=1), 1.0)
    corners_xyz = mesh.vertices[mesh.triangles[s.triangle[surf]]]
    np.testing.assert_allclose(np.einsum("ij,ijk->ik", s.bary[surf], corners_xyz), s.points[surf])
    feat = np.flatnonzero(s.kind == FEATURE)
    for i in feat[:50]:
        b = s.skeleton.backbones[s.backbone[i]]
        a, c = mesh.vertices[b[s.edge[i]]], mesh.vertices[b[s.edge[i] + 1]]
        np.testing.assert_allclose(a + s.t[i] * (c - a), s.points[i])
    np.testing.assert_array_equal(s.points[s.kind == CORNER], mesh.vertices[s.vertex[s.kind == CORNER]])


def test_uniform_sampling_follows_the_calibration_and_is_deterministic():
    mesh = grid_mesh(np.zeros((41, 41)), cell=0.5)  # a flat 20 x 20 square
    s = sample_mesh(mesh, 500, seed=3)
    rs, rf = s.rates
    assert rs == pytest.approx(2 * rf**2 / np.sqrt(3))
    assert rs * 400 + rf * 80 + 4 == pytest.approx(500)
    assert (s.kind == FEATURE).sum() == pytest.approx(rf * 80, abs=1)
    assert s.adjusted == 0
    half = s.points[s.kind == SURFACE]
    left = (half[:, 0] < half[:, 0].min() + 10).sum()
    assert abs(left - rs * 200) <= 0.05 * rs * 200  # the error diffusion keeps the density locally
    np.testing.assert_array_equal(sample_mesh(mesh, 500, seed=3).points, s.points)


def test_curvature_density_of_a_sphere_cap_is_even_and_of_a_ridge_is_high_on_it():
    r, n = 10.0, 41
    c = np.linspace(-5, 5, n)
    x, y = np.meshgrid(c, c)
    cap = grid_mesh(np.sqrt(r * r - x * x - y * y), cell=10 / (n - 1))
    d = vertex_density(cap, density="curvature")
    assert np.percentile(d, 5) > 0.9 and np.percentile(d, 95) < 1.1
    ridge = roof()
    d = vertex_density(ridge, density="curvature", gamma=2.0)
    on = ridge.vertices[:, 0] == ridge.vertices[:, 0][np.argmax(ridge.vertices[:, 2])]
    assert d[on].min() > 5 * np.median(d[~on])
    smooth = vertex_density(ridge, density="curvature", gamma=2.0, smooth=3)
    assert smooth.max() < d.max()  # the low pass spreads the peak


def test_errors():
    mesh = grid_mesh(np.zeros((5, 5)))
    with pytest.raises(InvalidOptionError, match="n_vertices must exceed the 4 corners"):
        sample_mesh(mesh, 4)
    with pytest.raises(tinsmith.InvalidInputError, match="density must be one of"):
        sample_mesh(mesh, 20, density="random")
    with pytest.raises(tinsmith.InvalidInputError, match="feature_angle"):
        sample_mesh(mesh, 20, feature_angle=200)
    with pytest.raises(tinsmith.InvalidInputError, match="needs a TerrainMesh"):
        sample_mesh(np.zeros((3, 3)), 20)


def test_st_helens_budgets_are_exact_without_balancing():
    mesh = tinsmith.simplify(tinsmith.sample("st-helens"), method="grid")
    for n in (2_000, 50_000):
        for density in ("uniform", "curvature"):
            s = sample_mesh(mesh, n, density=density)
            assert len(s.points) == n and s.adjusted == 0
