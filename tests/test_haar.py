"""Haar wavelets of Goebbels and Pohle-Fröhlich (2015) (Algorithms 2 and 3, formulas 3 and 4)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tinsmith.algorithms.wavelet.haar import haar_transform
from tinsmith.errors import InvalidOptionError


@settings(max_examples=50, deadline=None)
@given(st.integers(0, 10_000), st.integers(2, 40), st.integers(2, 40), st.integers(1, 4))
def test_the_transform_is_inverted_exactly_at_any_size(seed, h, w, levels):
    z = np.random.default_rng(seed).normal(0, 10, (h, w))
    coeffs = haar_transform(z, levels)
    np.testing.assert_allclose(coeffs.reconstruct(), z, atol=1e-10)
    np.testing.assert_allclose(coeffs.reconstruct(np.zeros(levels)), z, atol=1e-10)  # threshold 0 keeps all


def test_algorithm_2_and_the_simplified_column_step_by_hand():
    z = np.array([[4.0, 2.0, 1.0, 1.0], [0.0, 2.0, 3.0, 5.0]])
    # one level on a 2 x 4 grid: row means [[3, 1], [1, 4]], row half differences [[1, 0], [-1, -1]];
    # then the columns of the means only: means of means [[2, 2.5]], their half differences [[1, -1.5]]
    c = haar_transform(z, 1)
    np.testing.assert_array_equal(c.row[0], [[1.0, 0.0], [-1.0, -1.0]])
    np.testing.assert_array_equal(c.means, [[2.0, 2.5]])
    np.testing.assert_array_equal(c.col[0], [[1.0, -1.5]])
    # formula 3 with threshold 1.2: every row difference and the column one of 1 go, the column one of -1.5 stays
    np.testing.assert_array_equal(c.reconstruct([1.2]), [[2.0, 2.0, 1.0, 1.0], [2.0, 2.0, 4.0, 4.0]])
    # formula 4: on the right block the column coefficient is large (m0 = 0), so the row ones of level 0 stay too
    np.testing.assert_array_equal(c.reconstruct([1.2], variant=4), [[2.0, 2.0, 1.0, 1.0], [2.0, 2.0, 3.0, 5.0]])


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 10_000), st.integers(1, 4), st.floats(0.0, 3.0))
def test_formula_4_matches_the_papers_sums_and_its_ends_are_exact(seed, levels, t):
    z = np.random.default_rng(seed).normal(0, 2, (24, 20))
    c = haar_transform(z, levels)
    np.testing.assert_allclose(c.reconstruct(np.zeros(levels), variant=4), z, atol=1e-10)
    np.testing.assert_allclose(c.reconstruct(np.full(levels, 1e9), variant=4),
                               c.reconstruct(np.full(levels, 1e9), variant=3), atol=1e-12)  # the means alone
    # formula 4 point by point from its definition (the paper's sums), against the array version
    padded = (c.means.shape[0] << levels, c.means.shape[1] << levels)
    terms = [c._terms(i, padded) for i in range(levels)]
    base = np.kron(c.means, np.ones((1 << levels, 1 << levels)))
    for j, k in [(0, 0), (5, 7), (23, 19), (12, 3)]:
        m1 = max([i for i in range(levels) if abs(terms[i][0][j, k]) >= t], default=-1)
        m0 = max([i for i in range(levels) if abs(terms[i][1][j, k]) >= t], default=-1)
        expected = base[j, k] + sum(terms[i][0][j, k] for i in range(max(m1, m0) + 1)) \
            + sum(terms[i][1][j, k] for i in range(max(m1 - 1, m0) + 1))
        assert c.reconstruct(np.full(levels, t), variant=4)[j, k] == pytest.approx(expected, abs=1e-10)
    with pytest.raises(InvalidOptionError, match="variant must be 3 or 4"):
        c.reconstruct(np.zeros(levels), variant=2)


def test_thresholds_per_point_and_level():
    rng = np.random.default_rng(3)
    z = np.kron(rng.normal(0, 5, (4, 4)), np.ones((8, 8))) + rng.normal(0, 0.05, (32, 32))
    c = haar_transform(z, 3)
    smooth = c.reconstruct([0.0, 0.0, 1.0])  # the finest level's noise below 1 m goes, block steps stay
    assert np.abs(smooth - np.kron(z.reshape(4, 8, 4, 8).mean(axis=(1, 3)), np.ones((8, 8)))).max() < 0.1
    rows = np.zeros((32, 32), dtype=np.int64)
    rows[:, 16:] = 1  # the right half takes the second row: it keeps only the coarsest means
    mixed = c.reconstruct([[0.0] * 3, [1e9] * 3], rows=rows)
    np.testing.assert_allclose(mixed[:, :16], z[:, :16], atol=1e-10)
    np.testing.assert_allclose(mixed[:, 16:], np.kron(c.means, np.ones((8, 8)))[:, 16:], atol=1e-10)
    with pytest.raises(InvalidOptionError, match=r"thresholds must hold 3 values"):
        c.reconstruct([0.1, 0.2])
    with pytest.raises(InvalidOptionError, match="needs `rows`"):
        c.reconstruct([[0.0] * 3, [1.0] * 3])
    with pytest.raises(InvalidOptionError, match="must index the 2 rows"):
        c.reconstruct([[0.0] * 3, [1.0] * 3], rows=rows + 1)
    with pytest.raises(InvalidOptionError, match="at least 0"):
        c.reconstruct([0.1, -0.2, 0.1])
    with pytest.raises(InvalidOptionError, match="levels must be a whole number"):
        haar_transform(z, 0)
    with pytest.raises(InvalidOptionError, match="finite value"):
        haar_transform(np.full((4, 4), np.nan), 1)
