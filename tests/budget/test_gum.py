"""The GUM's arithmetic against its formulas: Welch-Satterthwaite, t tables, correlation."""

import math

import pytest

from accelcal.budget.gum import (
    Input,
    combine,
    coverage_factor,
    dof_from_reliability,
    from_bounds,
    from_expanded,
)


def test_coverage_factor_against_t_tables():
    # GUM table G.2 (95.45 %): nu = 10 -> 2.28, nu = 20 -> 2.13, infinite -> 2.00
    assert coverage_factor(10) == pytest.approx(2.28, abs=0.005)
    assert coverage_factor(20) == pytest.approx(2.13, abs=0.005)
    assert coverage_factor(math.inf) == pytest.approx(2.00, abs=0.001)


def test_type_b_conversions():
    assert from_expanded(0.2, 2) == pytest.approx(0.1)
    assert from_bounds(1.0, "rectangular") == pytest.approx(1 / math.sqrt(3))
    assert from_bounds(1.0, "triangular") == pytest.approx(1 / math.sqrt(6))
    assert from_bounds(1.0, "u-shaped") == pytest.approx(1 / math.sqrt(2))
    assert dof_from_reliability(0.1) == pytest.approx(50.0)  # GUM G.4.2: 1/2 (0.1)^-2


def test_welch_satterthwaite_against_its_formula():
    terms = [(Input("a", 0.0, 1.0, dof=5), 2.0), (Input("b", 0.0, 3.0, dof=12), -0.5),
             (Input("c", 0.0, 0.7), 1.0)]
    b = combine("y", 1.0, "ug", terms)
    parts = [2.0 * 1.0, 0.5 * 3.0, 0.7]
    u_c = math.sqrt(sum(p * p for p in parts))
    nu = u_c**4 / (parts[0] ** 4 / 5 + parts[1] ** 4 / 12)
    assert b.u_c == pytest.approx(u_c)
    assert b.nu_eff == pytest.approx(nu)
    assert b.k == pytest.approx(coverage_factor(nu))
    assert pytest.approx(b.k * u_c) == b.U
    assert [r.quantity for r in b.rows] == ["a", "b", "c"]  # largest first
    assert sum(r.share for r in b.rows) == pytest.approx(1.0)
    assert not b.correlated


def test_correlation_enters_u_c():
    terms = [(Input("a", 0.0, 1.0), 1.0), (Input("b", 0.0, 2.0), -1.0)]
    b = combine("y", 0.0, "ppm", terms, correlation={("b", "a"): 0.5})
    assert b.u_c == pytest.approx(math.sqrt(1 + 4 + 2 * 0.5 * 1.0 * (-2.0)))
    assert b.correlated
    with pytest.raises(ValueError, match="not in"):
        combine("y", 0.0, "ppm", terms, correlation={("a", "b"): 1.5})
