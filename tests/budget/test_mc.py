"""The JCGM 101 check: a budget it validates, and one it does not (a dominant rectangular input)."""

import math

import pytest

from accelcal.budget.gum import Input, combine
from accelcal.budget.mc import check, sample, tolerance


def test_tolerance_of_two_significant_digits():
    # JCGM 101 7.9.2: u_c = 0.58 -> 58 10^-2 -> delta = 0.005; 1.2 -> 12 10^-1 -> 0.05
    assert tolerance(0.577) == pytest.approx(0.005)
    assert tolerance(1.2) == pytest.approx(0.05)
    assert tolerance(35.0) == pytest.approx(0.5)


def test_samples_have_the_stated_standard_uncertainty():
    import numpy as np

    rng = np.random.default_rng(3)
    for dist in ("normal", "rectangular", "triangular", "u-shaped", "two-point"):
        x = sample(dist, 2.0, math.inf, 200_000, rng)
        assert x.std() == pytest.approx(2.0, rel=0.01), dist
        assert abs(x.mean()) < 0.02, dist
    t = sample("student-t", 1.0, 10.0, 200_000, rng)
    assert t.std() == pytest.approx(math.sqrt(10 / 8), rel=0.02)  # scale u, nu dof


def test_several_normal_inputs_validate_the_gum():
    terms = [(Input("a", 0.0, 1.0), 1.0), (Input("b", 0.0, 1.0), -0.8),
             (Input("c", 0.0, 0.5), 1.2)]
    b = combine("y", 10.0, "ug", terms)  # u_c = sqrt 2 = 1.4: delta = 0.05
    c = check(b, trials=200_000, seed=5)
    assert c.gum_high - 10.0 == pytest.approx(2.0 * b.u_c, rel=1e-3)  # nu_eff infinite: k = 2
    assert c.mc_high - 10.0 == pytest.approx(2.0 * b.u_c, rel=0.01)
    assert c.validated
    assert c.d_low <= c.delta
    assert c.d_high <= c.delta


def test_a_dominant_rectangular_input_is_not_validated():
    a = 1.0
    terms = [(Input("r", 0.0, a / math.sqrt(3), distribution="rectangular"), 1.0),
             (Input("n", 0.0, 1e-3), 1.0)]
    b = combine("y", 0.0, "ppm", terms)
    c = check(b, trials=200_000, seed=7)
    # GUM: k = 2 on u = a / sqrt 3 gives 1.155 a; the rectangle's 95.45 % half-width: 0.9545 a
    assert c.gum_high == pytest.approx(2 * a / math.sqrt(3), rel=1e-3)
    se = math.sqrt(0.0227 * 0.977 / 200_000) / 0.5  # quantile's standard error, density 1/2a
    assert c.mc_high == pytest.approx(0.9545 * a, abs=5 * se + 1e-3)
    assert c.mc_low == pytest.approx(-0.9545 * a, abs=5 * se + 1e-3)
    assert c.delta == pytest.approx(0.005)
    assert not c.validated
    assert c.d_high == pytest.approx(1.1547 - 0.9545, abs=0.005)


def test_correlated_inputs_follow_their_correlation():
    terms = [(Input("a", 0.0, 1.0), 1.0), (Input("b", 0.0, 1.0), 1.0)]
    corr = {("a", "b"): 0.8}
    b = combine("y", 0.0, "ug", terms, correlation=corr)
    c = check(b, trials=100_000, seed=2, correlation=corr)
    assert c.mc_std == pytest.approx(b.u_c, rel=0.01)  # sqrt(2 + 1.6)
    assert b.u_c == pytest.approx(math.sqrt(3.6))


def test_a_vector_input_is_sampled_element_by_element():
    # twelve independent rectangular position errors of equal weight: their sum is close to
    # normal, so the GUM (k = 2 on the RSS) is validated although each element is rectangular
    c = (0.5,) * 12
    rss = math.sqrt(sum(x * x for x in c))
    vector = Input("head_angle", 0.0, 1.0, distribution="rectangular", components=c)
    b = combine("y", 0.0, "ug", [(vector, rss)])
    assert b.rows[0].components == c
    assert "components" not in b.rows[0].as_dict()
    checked = check(b, trials=200_000, seed=11)
    assert checked.mc_std == pytest.approx(b.u_c, rel=0.01)
    assert checked.mc_high == pytest.approx(2.0 * b.u_c, rel=0.02)  # not 0.9545 sqrt 3 u_c
