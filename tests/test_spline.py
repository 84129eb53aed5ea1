"""Linear-spline best approximation on coarser scales (Goebbels and Pohle-Fröhlich 2015, section 3, Algorithm 1)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tinsmith import Heightfield
from tinsmith.algorithms.wavelet.spline import (
    coarse_knots,
    max_iterations,
    spline_approximation,
    spline_filter,
    spline_reduce,
)
from tinsmith.errors import InvalidOptionError

from .conftest import shared

DELFT_DTM = "urban/delft_ahn3/delft_dtm_0.5m.tif"


def test_a_hat_is_approximated_by_its_mean_on_the_coarse_scale():
    # rows holding one fine hat of height 1 on [0, 2]: the best line over the single coarse interval is the
    # constant 1/2 (the symmetric hat's mean); the columns are then constant and stay so
    np.testing.assert_allclose(spline_reduce(np.array([[0.0, 1.0, 0.0]] * 3)), 0.5)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 10_000), st.integers(3, 40), st.integers(3, 40), st.booleans())
def test_the_residual_is_orthogonal_to_every_coarse_hat(seed, n_rows, n_cols, uneven):
    """Best approximation: the fine function minus the coarse one has zero L2 inner product with each coarse hat
    (nodes at unit spacing, or uneven as after coarsening a side of even length)."""
    from tinsmith.algorithms.wavelet.spline import _approximate

    rng = np.random.default_rng(seed)
    y = rng.normal(size=(n_cols, n_rows))
    pos = np.cumsum(np.r_[0.0, rng.uniform(0.5, 2.0, n_cols - 1) if uneven else np.ones(n_cols - 1)])
    x = _approximate(y, pos)
    knots = coarse_knots(n_cols)
    prolong = np.column_stack([np.interp(pos, pos[knots], e) for e in np.eye(len(knots))])
    d = np.diff(pos)
    gram = np.diag(np.r_[d, 0] / 3 + np.r_[0, d] / 3) + np.diag(d / 6, 1) + np.diag(d / 6, -1)
    residual = y - prolong @ x
    np.testing.assert_allclose(prolong.T @ gram @ residual, 0.0, atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(st.integers(3, 70), st.integers(3, 70), st.floats(-5, 5), st.floats(-5, 5), st.floats(-100, 100))
def test_planes_are_kept_at_every_scale(n_rows, n_cols, a, b, c):
    r, col = np.mgrid[0:n_rows, 0:n_cols].astype(float)
    plane = a * r + b * col + c
    for iterations in range(min(max_iterations(n_rows), max_iterations(n_cols)) + 1):
        np.testing.assert_allclose(spline_approximation(plane, iterations), plane, atol=1e-9 * (1 + abs(c)))


def test_coarsening_and_its_limits():
    assert coarse_knots(9).tolist() == [0, 2, 4, 6, 8]
    assert coarse_knots(8).tolist() == [0, 2, 4, 6, 7]  # the last interval one step long
    assert max_iterations(5 * 2**4 + 1) == 7 and max_iterations(3) == 1 and max_iterations(2) == 0  # to 2 knots
    z = np.random.default_rng(0).normal(size=(33, 20))
    with pytest.raises(InvalidOptionError, match=r"spline_iterations must be a whole number from 0 to 5 for a 33 x 20 grid"):
        spline_approximation(z, 6)
    with pytest.raises(InvalidOptionError, match="spline_iterations"):
        spline_approximation(z, 1.5)
    np.testing.assert_array_equal(spline_approximation(z, 0), z)


def test_smoothing_grows_with_the_iterations_and_nodata_stays_nodata():
    rng = np.random.default_rng(1)
    r, c = np.mgrid[0:81, 0:81].astype(float)
    smooth = np.sin(r / 13) * np.cos(c / 17) * 5
    z = smooth + rng.normal(0, 0.5, smooth.shape)
    errors = [np.sqrt(np.mean((spline_approximation(z, k) - smooth) ** 2)) for k in range(5)]
    assert errors[1] < errors[0]  # one step removes noise
    roughness = [np.abs(np.diff(spline_approximation(z, k), 2, axis=0)).mean() for k in range(5)]
    assert all(b < a for a, b in zip(roughness, roughness[1:], strict=False))
    mask = np.zeros(z.shape, bool)
    mask[30:40, 50:60] = True
    hf = Heightfield(np.where(mask, -9999.0, z), cell_size=1.0, nodata=-9999.0)
    out = spline_filter(hf, 2)
    assert out.nodata_mask[mask].all() and not out.nodata_mask[~mask].any()
    assert np.isfinite(out.z[~mask]).all()


def test_delft_dtm_spline_steps():
    import tinsmith

    hf = tinsmith.read(shared(DELFT_DTM))
    out = [spline_filter(hf, k) for k in (1, 2, 3)]
    rmse = [float(np.sqrt(np.mean((o.z - hf.z) ** 2))) for o in out]
    assert rmse[0] < rmse[1] < rmse[2]
    lo, hi = hf.z_range
    assert all(lo - 1.0 < o.z.min() and o.z.max() < hi + 1.0 for o in out)  # no overshoot beyond a metre
    assert out[0].transform == hf.transform and out[0].crs == hf.crs
