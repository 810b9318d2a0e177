"""The shared piece for unestimated terms: alias matrix, priors, Type B, combination names."""

import math

import numpy as np
import pytest

import accelcal
from accelcal.aliasing import (
    Contribution,
    Prior,
    alias_matrix,
    aliases,
    default_priors,
    propagate,
    welch_satterthwaite,
)
from accelcal.identifiability import combination_name, inseparable


def _tumble_columns():
    theta = np.arange(24) * 2 * np.pi / 24
    c, s = np.cos(theta), np.sin(theta)
    x = np.column_stack([np.ones_like(c), c, c**2, c**3, c**4, s, c * s])
    z = np.column_stack([s**2, np.sign(c) / 2, np.sign(c) * c / 2])
    return x, z


def test_alias_matrix_is_the_weighted_least_squares_formula():
    x, z = _tumble_columns()
    w = np.linspace(1.0, 3.0, x.shape[0])
    a = alias_matrix(x, z, weights=w)
    xtw = x.T * w
    assert np.allclose(a, np.linalg.solve(xtw @ x, xtw @ z), atol=1e-12)
    # a_p^2 = 1 - a_i^2: Kpp moves K0 by +1 and K2 by -1 per unit, nothing else
    assert a[0, 0] == pytest.approx(1.0)
    assert a[2, 0] == pytest.approx(-1.0)
    assert np.allclose(np.delete(a[:, 0], [0, 2]), 0.0, atol=1e-9)


def test_inseparable_terms_name_their_rows():
    x, z = _tumble_columns()
    names = ("Kpp", "K0_asym", "K1_asym")
    assert inseparable(x, z, names) == ("Kpp",)
    a = alias_matrix(x, z[:, :1])
    assert combination_name("K0", {"Kpp": a[0, 0]}) == "K0+Kpp"
    assert combination_name("K2", {"Kpp": a[2, 0]}) == "K2-Kpp"
    assert combination_name("K3", {"K1_asym": 0.5}) == "K3+0.5*K1_asym"
    assert combination_name("K1", {"Kpp": 1e-12}) == "K1"


def test_propagation_adds_a_u2_at_and_itemises_each_row():
    x, z = _tumble_columns()
    a = alias_matrix(x, z[:, 1:])
    rows = ("K0", "K1", "K2", "K3", "K4", "Kp", "Kip")
    priors = {"K0_asym": Prior("K0_asym", 3e-6, "g", "rectangular", source="default"),
              "K1_asym": Prior("K1_asym", 2e-6, "g/g", "normal", dof=8)}
    cov, parts = propagate(a, rows, ("K0_asym", "K1_asym"), priors, row_units={"K0": "g"})
    u = np.array([3e-6 / math.sqrt(3), 2e-6])
    assert np.allclose(cov, (a * u**2) @ a.T, rtol=1e-12, atol=0)
    k0 = [c for c in parts if c.row == "K0"]
    assert {c.input for c in k0} == {"K1_asym"}  # sgn(a_i)/2 has no constant part here
    assert k0[0].contribution == pytest.approx(abs(a[0, 1]) * 2e-6)
    assert k0[0].unit == "g"
    assert k0[0].dof == 8
    assert sum(c.contribution**2 for c in parts if c.row == "K1") == pytest.approx(cov[1, 1])
    entries = aliases(a, rows, ("K0_asym", "K1_asym"))
    assert all(abs(e.sensitivity) > 1e-9 for e in entries)
    assert {(e.row, e.term) for e in entries} == {(c.row, c.input) for c in parts}


def test_welch_satterthwaite_is_the_gum_formula():
    parts = [Contribution("K0", "a", 1.0, 2.0, 2.0, dof=4), Contribution("K0", "b", 1.0, 1.0, 1.0)]
    var_a, nu_a = 9.0, 6
    expected = (var_a + 4 + 1) ** 2 / (var_a**2 / nu_a + 2.0**4 / 4)
    assert welch_satterthwaite(var_a, nu_a, parts) == pytest.approx(expected)
    assert welch_satterthwaite(1.0, math.inf, parts[1:]) == math.inf


def test_priors_are_checked_and_defaults_come_from_the_default_accelerometer():
    import accelcal

    with pytest.raises(ValueError, match="not a finite non-negative"):
        Prior("K0_asym", -1.0)
    with pytest.raises(ValueError, match="distribution"):
        Prior("K0_asym", 1.0, distribution="triangular")
    pri = default_priors(("K0_asym", "K4", "Kpp"))
    assert set(pri) == {"K0_asym", "Kpp"}  # K4 is zero in the default model
    assert pri["K0_asym"].value == pytest.approx(2 * abs(accelcal.default_model().K0_asym))
    assert pri["K0_asym"].source == "default"
    assert pri["K0_asym"].unit == "g"


def test_records_carry_the_combination_name_and_old_records_stay_readable(tmp_path):
    from accelcal.io.calibration_record import CalibrationRecord

    rec = CalibrationRecord(
        serial="S1", method="tumble-lsq", names=("K0+Kpp", "K1"),
        estimates=np.array([-6.3e-4, 1.3]), covariance=np.diag([1e-14, 1e-12]),
        units={"K0+Kpp": "g", "K1": "V/g"}, date="2026-01-01", software="accelcal",
        plain={"K0+Kpp": "K0"})
    back = CalibrationRecord.from_json(rec.to_json())
    assert back.names == ("K0+Kpp", "K1")
    assert back.plain == {"K0+Kpp": "K0"}
    old = rec.to_dict()
    old["coefficients"][0] = {k: v for k, v in old["coefficients"][0].items() if k != "plain"}
    old["coefficients"][0]["name"] = "K0"
    import json

    before = CalibrationRecord.from_json(json.dumps(old).replace('"K0+Kpp"', '"K0"'))
    assert before.names == ("K0", "K1")
    assert before.plain == {}


def test_a_reduction_read_back_from_json_keeps_its_row_names_and_plain_names():
    from accelcal.methods import tumble
    from accelcal.results import Reduction
    from accelcal.rigs.tumble import uniform_positions

    rec = tumble.simulate(uniform_positions(24), accelcal.default_model(), noise=1e-6, seed=1)
    red = tumble.reduce(rec)
    back = Reduction.from_json(red.to_json())
    keys = [(r["coefficient"], r["plain"]) for r in red.rows()]
    assert ("K0+Kpp", "K0") in keys
    assert [(r["coefficient"], r["plain"]) for r in back.rows()] == keys
    assert back.value("K0") == back.value("K0+Kpp") == red.value("K0")


def test_a_reduction_read_back_from_json_keeps_its_type_b_aliases_and_priors():
    import json

    from accelcal.errors import AccelcalError
    from accelcal.methods import tumble
    from accelcal.results import Reduction
    from accelcal.rigs.tumble import uniform_positions

    rec = tumble.simulate(uniform_positions(24), accelcal.default_model(), noise=1e-6, seed=1)
    red = tumble.reduce(rec, route="fourier")
    assert red.type_b
    assert red.priors
    back = Reduction.from_json(red.to_json())
    assert back.type_b == red.type_b
    assert back.priors == red.priors
    assert any(math.isinf(c.dof) for c in back.type_b)  # null dof reads back infinite
    bare = tumble.reduce(rec, route="fourier", priors="none")
    assert bare.aliases
    assert Reduction.from_json(bare.to_json()).aliases == bare.aliases
    # JSON written before these keys existed reads with none
    old = {k: v for k, v in red.to_dict().items() if k not in ("type_b", "aliases", "priors")}
    before = Reduction.from_dict(old)
    assert (before.type_b, before.aliases, before.priors) == ((), (), ())
    bad = red.to_dict()
    bad["type_b"][0]["u"] = "big"
    with pytest.raises(AccelcalError, match=r"type_b\[0\]: u must be a number"):
        Reduction.from_json(json.dumps(bad))
