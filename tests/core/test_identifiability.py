"""The one identifiability module: rank, null space, estimable combinations, one tolerance."""

import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from accelcal.errors import AccelcalError
from accelcal.fitting import least_squares
from accelcal.identifiability import RANK_RTOL, analyse, describe, numerical_rank


def _in_row_space(design, weights, names):
    """Independent check (Searle 1971, 5.4): c is estimable iff c = A' z for some z."""
    c = np.array([dict(weights).get(n, 0.0) for n in names])
    z, *_ = np.linalg.lstsq(design.T, c, rcond=None)
    return np.allclose(design.T @ z, c, atol=1e-9 * np.abs(c).max())


def test_full_rank_design_identifies_everything():
    rng = np.random.default_rng(1)
    a = rng.normal(size=(40, 4))
    ident = analyse(a, "abcd")
    assert ident.full_rank
    assert ident.identifiable == tuple("abcd")
    assert ident.null_space.shape == (4, 0)
    assert ident.combinations == ()
    # the condition number is that of the column-equilibrated design
    eq = a / np.linalg.norm(a, axis=0)
    assert ident.condition_number == pytest.approx(np.linalg.cond(eq), rel=1e-12)


def test_single_overload_determines_only_k2_plus_3b_k3():
    # Guan2021: with one overload b the K2 and K3 columns A^2/2 and 3 b A^2/2 are proportional
    b, amp = 2.0, np.arange(5.0, 11.0)
    design = np.stack([amp**2 / 2, 3 * b * amp**2 / 2], axis=1)
    ident = analyse(design, ("K2", "K3"), units={"K2": "g/g^2", "K3": "g/g^3"})
    assert ident.rank == 1
    assert ident.identifiable == ()
    (combo,) = ident.combinations
    assert dict(combo.weights) == pytest.approx({"K2": 1.0, "K3": 3 * b})
    assert combo.label == "K2 + 6 K3"
    assert combo.unit == "g/g^2"
    assert _in_row_space(design, combo.weights, ("K2", "K3"))


def test_unobservable_column_and_partial_identifiability():
    x = np.linspace(-1.0, 1.0, 9)
    design = np.stack([np.ones_like(x), x, np.zeros_like(x), 2 * x], axis=1)
    ident = analyse(design, ("c", "a", "z", "a2"))
    assert ident.identifiable == ("c",)
    assert ident.unobservable == ("z",)
    assert ident.unidentifiable == ("a", "z", "a2")
    labels = [c.label for c in ident.combinations]
    assert labels == ["a + 2 a2"]


def test_rank_decision_does_not_depend_on_units():
    # Columns scaled by 1e-12 and 1e9 (a K4 in g/g^4 beside a bias in ug): same rank.
    rng = np.random.default_rng(2)
    a = rng.normal(size=(30, 3))
    a[:, 2] = a[:, 0] + a[:, 1]
    scaled = a * np.array([1e-12, 1.0, 1e9])
    assert analyse(a, "xyz").rank == analyse(scaled, "xyz").rank == 2


@settings(max_examples=40, deadline=None)
@given(st.integers(2, 6), st.integers(0, 3), st.integers(0, 10_000))
def test_combinations_are_estimable_and_complete(p, deficiency, seed):
    deficiency = min(deficiency, p - 1)
    rng = np.random.default_rng(seed)
    base = rng.normal(size=(25, p - deficiency))
    mix = rng.normal(size=(p - deficiency, p))
    design = base @ mix  # rank p - deficiency
    names = [f"x{i}" for i in range(p)]
    ident = analyse(design, names)
    assert ident.rank == p - deficiency
    for combo in ident.combinations:
        assert _in_row_space(design, combo.weights, names)
    # identifiable + independent combinations account for the whole rank
    assert len(ident.identifiable) + len(ident.combinations) == ident.rank


def test_analyse_is_linear_in_rows():
    # 2e6 x 6: an n x n factor would need 32 TB; the R factor route takes a fraction of a second
    rng = np.random.default_rng(3)
    a = rng.normal(size=(2_000_000, 6))
    t0 = time.perf_counter()
    ident = analyse(a, list("abcdef"))
    assert ident.full_rank
    assert time.perf_counter() - t0 < 20.0


def test_numerical_rank_uses_the_stated_tolerance():
    assert numerical_rank([1.0, 2 * RANK_RTOL, 0.5 * RANK_RTOL]) == 2
    assert numerical_rank([]) == 0
    assert numerical_rank([0.0, 0.0]) == 0


def test_describe_signs_and_weights():
    assert describe({"K0": 1.0, "Kpp": -1.0}) == "K0 - Kpp"
    assert describe({"K2": -2.5, "K3": 1.0}) == "- 2.5 K2 + K3"


def test_least_squares_refuses_rank_deficiency_naming_the_terms():
    x = np.linspace(0.0, 1.0, 10)
    with pytest.raises(AccelcalError, match=r"rank 1 < 2 .*a, b cannot be separated"):
        least_squares(np.stack([x, 2 * x], axis=1), x, ("a", "b"), {}, "demo")


def test_least_squares_matches_numpy_lstsq_and_textbook_covariance():
    rng = np.random.default_rng(4)
    a = rng.normal(size=(50, 3))
    y = a @ np.array([1.0, -2.0, 0.5]) + rng.normal(scale=0.1, size=50)
    est = least_squares(a, y, "abc", {}, "demo")
    ref, rss, *_ = np.linalg.lstsq(a, y, rcond=None)
    np.testing.assert_allclose(est.values, ref, rtol=1e-12)
    np.testing.assert_allclose(est.covariance, np.linalg.inv(a.T @ a) * rss[0] / 47, rtol=1e-10)
    assert est.dof == 47
