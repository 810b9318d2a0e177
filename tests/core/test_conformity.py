"""Conformity decisions against closed forms (JCGM 106, ILAC-G8) and the spec file's checks."""

import math

import pytest

from accelcal.conformity import Spec, coverage_factor, decide, evaluate, load_spec, parse_spec
from accelcal.errors import AccelcalError

SPEC = """
title = "Acceptance specification QA-3000"
document = "SPEC-0042 rev B"

[[limit]]
quantity = "K0"
lower = -5000
upper = 5000
unit = "ug"

[[limit]]
quantity = "hysteresis"
upper = 30
unit = "ug"
method = "hysteresis"

[[limit]]
quantity = "K1"
lower = -200
upper = 200
unit = "ppm"
serial = "SN-1"
"""


def test_estimate_at_a_limit_has_risk_one_half():
    d = decide(5000.0, 120.0, None, -5000.0, 5000.0)
    assert d.outcome == "accept"
    assert d.false_accept_risk == pytest.approx(0.5, abs=1e-12)


def test_two_u_inside_a_one_sided_limit_has_the_normal_tail():
    d = decide(4.0, 1.0, math.inf, None, 6.0)
    assert d.accepted
    assert d.risk == pytest.approx(0.022750131948, rel=1e-9)


def test_student_t_tail_is_heavier_than_the_normal():
    d = decide(0.0, 1.0, 5, -2.0, 2.0)
    from scipy.special import stdtr

    assert d.risk == pytest.approx(2 * stdtr(5, -2.0), rel=1e-9)
    assert d.risk > 2 * 0.02275


def test_guarded_rule_shrinks_the_zone_by_u_expanded():
    d = decide(4.85, 0.1, None, -5.0, 5.0, rule="guarded")
    assert d.guard == pytest.approx(0.2)
    assert d.acceptance == pytest.approx((-4.8, 4.8))
    assert d.outcome == "inconclusive"
    assert decide(4.7, 0.1, None, -5.0, 5.0, rule="guarded").outcome == "accept"
    assert decide(5.1, 0.1, None, -5.0, 5.0, rule="guarded").outcome == "reject"
    assert decide(4.85, 0.1, None, -5.0, 5.0).outcome == "accept"


def test_explicit_guard_and_t_coverage_factor():
    assert coverage_factor(None) == 2.0
    assert coverage_factor(10) == pytest.approx(2.28, abs=0.01)
    d = decide(0.0, 1.0, 10, -5.0, 5.0, rule="guarded", guard=1.0)
    assert d.acceptance == (-4.0, 4.0)


def test_a_reject_states_the_false_reject_risk():
    d = decide(5.1, 0.1, None, -5.0, 5.0)
    assert d.outcome == "reject"
    assert d.risk == pytest.approx(1 - 0.841344746, rel=1e-6)


def test_spec_file_round_trip_and_matching(tmp_path):
    path = tmp_path / "spec.toml"
    path.write_text(SPEC)
    spec = load_spec(path)
    assert isinstance(spec, Spec)
    assert spec.document == "SPEC-0042 rev B"
    assert len(spec.limits_for("hysteresis at +0.5 g", method="acceptance/hysteresis")) == 1
    assert not spec.limits_for("hysteresis at +0.5 g", method="acceptance/threshold")
    assert not spec.limits_for("K1", serial="SN-2")
    rows = [{"quantity": "K0", "estimate": 0.006, "std": 0.0001, "unit": "g"},
            {"quantity": "K0", "estimate": 0.001, "std": float("nan"), "unit": "g"},
            {"quantity": "K2", "estimate": 1.0, "std": 1.0, "unit": "ug/g^2"}]
    (out,) = evaluate(spec, rows)
    assert out["estimate"] == pytest.approx(6000.0)
    assert out["decision"] == "reject"


@pytest.mark.parametrize(("text", "needle"), [
    ("title = 'x'", "no limits"),
    ("[[limit]]\nquantity = 'K0'\nunit = 'ug'", "give lower, upper"),
    ("[[limit]]\nquantity = 'K0'\nlower = 5\nupper = 1\nunit = 'ug'", "above upper"),
    ("[[limit]]\nquantity = 'K0'\nupper = 1\nunit = 'ppm'", "does not fit"),
    ("[[limit]]\nquantity = 'k0'\nupper = 1\nunit = 'ug'", "did you mean K0"),
    ("[[limit]]\nquantity = 'K0'\nupper = 1\nunit = 'ug'\nuper = 3", "unknown key"),
    ("decision_rule = 'lenient'\n[[limit]]\nquantity = 'K0'\nupper = 1\nunit = 'ug'",
     "decision_rule"),
    ("[[limit]\n", "not TOML"),
    ("[[limit]]\nquantity = 'K0'\nupper = 1\nunit = 'ug'\nband_hz = [10, 20]",
     "band_hz applies to magnitude deviation only"),
    ("[[limit]]\nquantity = 'magnitude deviation'\nupper = 1\nunit = '%'\nband_hz = [20, 10]",
     "band_hz must be [from, to]"),
    ("[[limit]]\nquantity = 'magnitude deviation'\nupper = 1\nunit = '%'\nband_hz = [0, 10]",
     "band_hz must be [from, to]"),
    ("[[limit]]\nquantity = 'magnitude deviation'\nupper = 1\nunit = 'deg'", "use one of %"),
])
def test_bad_spec_files_give_one_line(tmp_path, text, needle):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(AccelcalError) as err:
        load_spec(path)
    assert needle in str(err.value)
    assert "\n" not in str(err.value)


def test_bad_decisions_are_refused():
    with pytest.raises(AccelcalError):
        decide(0.0, 1.0, None, None, None)
    with pytest.raises(AccelcalError):
        decide(0.0, -1.0, None, -1.0, 1.0)
    with pytest.raises(AccelcalError):
        parse_spec({"limit": [{"quantity": "K0", "upper": 1, "unit": "ug"}],
                    "decision_rule": 3})


def test_a_magnitude_band_holds_over_its_frequencies():
    spec = parse_spec({"limit": [{"quantity": "magnitude deviation", "lower": -5, "upper": 5,
                                  "unit": "%", "band_hz": [10, 500]},
                                 {"quantity": "magnitude deviation", "upper": 1,
                                  "unit": "ppm"}]})
    banded, everywhere = spec.limits
    assert banded.band_hz == (10.0, 500.0)
    assert [banded.covers(f) for f in (9.99, 10, 500, 500.01)] == [False, True, True, False]
    assert everywhere.band_hz is None
    assert everywhere.covers(1e6)
    assert len(spec.limits_for("magnitude deviation at 80 Hz")) == 2
