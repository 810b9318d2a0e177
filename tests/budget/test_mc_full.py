"""The JCGM 101 check through the full model: each trial draws every input and runs the reduction.

A linear case the full model validates (and agrees with the linearised
one); the tilt of the rotation axis, whose effect on the scale factor is
``1 / cos(beta) - 1`` (zero slope at zero: the GUM's c = 0), which it does
not validate; the same draws for a seed whatever the workers.
"""

import json
import math

import pytest

from accelcal.budget import budgets
from accelcal.budget.lab import load_lab
from accelcal.budget.render import render_budgets
from accelcal.methods import tumble
from helpers.budget import lab_text, linear_tumble, standard
from helpers.cli import assert_one_line_error, run_cli
from helpers.paths import ROOT

LAB = ROOT / "examples" / "lab.toml"


def _by(bs, coefficient):
    return next(b for b in bs if b.coefficient == coefficient)


@pytest.fixture
def record():
    """A 12-position tumble of ``E = 1.3 (5e-4 + cos theta)`` V, reduced for K0 and K1."""
    rec = linear_tumble(12)
    return rec, tumble.reduce(rec, terms=["K0", "K1"], sigma=1e-6, priors="none")


def test_local_gravity_through_the_full_model_is_validated_and_agrees_with_the_linear(
        record, write_lab):
    rec, red = record
    lab = load_lab(write_lab(lab_text(standard("local_gravity", 9.81, "m/s^2", u=1e-4))))
    full = _by(budgets(red, lab, records=rec, check={"trials": 20_000, "seed": 3}), "K1")
    linear = _by(budgets(red, lab, records=rec,
                         check={"model": "linear", "trials": 20_000, "seed": 3}), "K1")
    c = full.check
    assert c.model == "reduction"
    assert linear.check.model == "linearised"
    assert full.u_c == pytest.approx(1e6 * 1e-4 / 9.81, rel=1e-3)  # u(g)/g, 10.2 ppm
    assert c.delta == pytest.approx(0.5)  # u_c = 10 ppm to two digits
    assert c.validated
    assert c.stabilised
    assert 2 * c.s_low <= c.delta
    # y (g / g0)^-1 at u(g)/g = 1e-5: normal to a part in 1e5, both models within delta
    assert c.mc_low == pytest.approx(linear.check.mc_low, abs=c.delta)
    assert c.mc_high == pytest.approx(linear.check.mc_high, abs=c.delta)
    assert c.mc_std == pytest.approx(full.u_c, rel=0.01)


def test_a_large_axis_tilt_is_not_validated_through_the_full_model(record, write_lab):
    rec, red = record
    lab = load_lab(write_lab(lab_text(standard("head_axis_tilt", 0.0, "deg", u=1.0))))
    b = _by(budgets(red, lab, records=rec, check={"trials": 40_000, "seed": 5}), "K1")
    tilt = next(r for r in b.rows if r.quantity == "head_axis_tilt")
    assert tilt.sensitivity == 0.0  # cos(beta): no slope at zero, the GUM sees nothing
    c = b.check
    sigma2 = math.radians(1.0) ** 2
    # K1 / cos(beta) - K1 = K1 beta^2 / 2 (1 + ...): mean sigma^2 / 2, a chi-square of 1 dof
    assert c.mc_mean == pytest.approx(1e6 * sigma2 / 2, rel=0.05)  # 152 ppm
    assert c.mc_high == pytest.approx(1e6 * sigma2 / 2 * 5.19, rel=0.05)  # chi2(1) at 97.7 %
    assert c.gum_high < 1.0  # the Type A part only: U well under 1 ppm
    assert not c.validated
    assert c.d_high > 100 * c.delta
    linear = _by(budgets(red, lab, records=rec,
                         check={"model": "linear", "seed": 5}), "K1")  # 10^6
    assert linear.check.validated  # the linearised model agrees with the GUM: it is the GUM


def test_the_sensor_temperature_through_its_polynomial(record, write_lab):
    from accelcal.model import ErrorModel
    from accelcal.terms import TemperatureTerms

    rec, red = record
    # at the reference temperature a quadratic term has no slope: the GUM gives it nothing
    lab = load_lab(write_lab(lab_text(standard("sensor_temperature", 20.0, "degC", u=2.0))))
    model = ErrorModel(K1=1.3, temperature=TemperatureTerms(20.0, {"K0_T2": 1e-6}))
    b = _by(budgets(red, lab, records=rec, model=model,
                    check={"trials": 20_000, "seed": 4}), "K0")
    assert next(r for r in b.rows if r.quantity == "sensor_temperature").sensitivity == 0.0
    c = b.check
    # K0 moves by 1 ug/degC^2 dT^2, dT ~ N(0, 2 degC): 4 ug on average, a chi-square of 1 dof
    assert c.mc_mean - b.estimate == pytest.approx(4.0, rel=0.05)
    assert c.mc_high - b.estimate == pytest.approx(4.0 * 5.19, rel=0.05)
    assert not c.validated


def test_the_reduction_runs_again_per_trial_with_correlated_gain_and_resistor(write_lab):
    rec = linear_tumble(8, unit="mA")
    red = tumble.reduce(rec, terms=["K0", "K1"], sigma=1e-6, priors="none")
    lab = load_lab(write_lab(lab_text(
        standard("daq_gain", 0.0, "ppm", u=10.0),
        standard("load_resistor", 1000.0, "ohm", u=0.02),
        extra='\n[[correlation]]\nquantities = ["daq_gain", "load_resistor"]\nr = 0.5\n')))
    b = _by(budgets(red, lab, records=rec, check={"trials": 150, "seed": 1}), "K1")
    # u_c^2 = 10^2 + 20^2 - 2 0.5 10 20 (I = V / R: the resistor's slope is negative)
    assert b.u_c == pytest.approx(math.sqrt(300.0), rel=1e-3)  # and a small Type A
    assert b.check.mc_std == pytest.approx(b.u_c, rel=0.2)  # 150 trials: s.e. ~6 %
    assert b.check.failed == 0
    assert b.check.trials == 150


def test_same_seed_same_draws_another_seed_others(record, write_lab):
    rec, red = record
    lab = load_lab(write_lab(lab_text(standard("daq_gain", 0.0, "ppm", u=10.0),
                                      standard("head_angle", 0.0, "arcsec", bounds=1.0,
                                               distribution="rectangular"))))
    first = budgets(red, lab, records=rec, check={"trials": 20, "seed": 7})
    again = budgets(red, lab, records=rec, check={"trials": 20, "seed": 7})
    other = budgets(red, lab, records=rec, check={"trials": 20, "seed": 8})
    assert [b.check for b in first] == [b.check for b in again]
    assert _by(first, "K1").check.mc_low != _by(other, "K1").check.mc_low
    text = render_budgets(first, "table")
    assert "Monte Carlo (20 trials, reduction model): 95.45 % interval" in text
    assert "NOT stable at the tolerance: give more --trials (JCGM 101 7.9)" in text


def test_a_long_run_is_refused_with_its_estimate(record, write_lab):
    from accelcal.budget.mc import MAX_SECONDS
    from accelcal.errors import AccelcalError

    rec, red = record
    lab = load_lab(write_lab(lab_text(standard("daq_gain", 0.0, "ppm", u=10.0))))
    with pytest.raises(AccelcalError, match=f"the bound is {MAX_SECONDS:g} s"):
        budgets(red, lab, records=rec, check={"trials": 1_000_000, "seed": 1})


def test_cli_check_through_the_reduction(tumble_file, write_lab, capsys):
    lab = write_lab(lab_text(standard("daq_gain", 0.0, "ppm", u=8.0)))
    code, out, err = run_cli(["budget", tumble_file, "--lab", lab, "--coefficient", "K1",
                              "--check", "mc", "--trials", "100", "--format", "json"], capsys)
    assert code == 0, err
    c = json.loads(out)[0]["check"]
    assert c["model"] == "reduction"
    assert c["trials"] == 100
    assert c["mc_low"] < c["mc_high"]
    assert {"gum_low", "gum_high", "d_low", "d_high", "delta", "validated", "s_low", "s_high",
            "stabilised", "failed"} <= set(c)


def test_cli_refuses_a_run_over_the_bound_in_one_line(tumble_file, capsys):
    code, _, err = run_cli(["budget", tumble_file, "--lab", LAB, "--check", "mc",
                            "--trials", "1000000"], capsys)
    assert_one_line_error(code, err, "--force")


@pytest.mark.slow
def test_same_result_in_process_and_on_one_or_two_workers(record, write_lab):
    rec, red = record
    lab = load_lab(write_lab(lab_text(standard("daq_gain", 0.0, "ppm", u=10.0),
                                      standard("local_gravity", 9.81, "m/s^2", u=1e-5))))
    options = {"trials": 600, "seed": 11}
    here = [b.check for b in budgets(red, lab, records=rec, check=options)]
    for workers in (1, 2):
        there = [b.check for b in budgets(red, lab, records=rec,
                                          check={**options, "workers": workers})]
        assert there == here, workers


@pytest.mark.slow
def test_gain_and_gravity_through_the_reduction_validated_and_as_the_linear(record, write_lab):
    rec, red = record
    lab = load_lab(write_lab(lab_text(standard("daq_gain", 0.0, "ppm", u=10.0),
                                      standard("local_gravity", 9.81, "m/s^2", u=1e-5))))
    full = _by(budgets(red, lab, records=rec, check={"trials": 4000, "seed": 2}), "K1")
    linear = _by(budgets(red, lab, records=rec, check={"model": "linear", "seed": 2}), "K1")
    c = full.check
    assert full.u_c == pytest.approx(math.hypot(10.0, 1.0194), rel=1e-3)
    assert c.validated, c
    assert c.stabilised  # 4000 reductions: the linearised control variate does the rest
    assert c.failed == 0
    tol = max(c.delta, 4 * max(c.s_low, c.s_high))
    assert c.mc_low == pytest.approx(linear.check.mc_low, abs=tol)
    assert c.mc_high == pytest.approx(linear.check.mc_high, abs=tol)


@pytest.mark.slow
def test_the_indexing_head_record_through_its_reduction_run_again(capsys):
    from helpers.paths import EXAMPLES

    code, out, err = run_cli(["budget", EXAMPLES / "calibration_record.json", "--lab", LAB,
                              "--data", EXAMPLES, "--coefficient", "K_I", "--check", "mc",
                              "--trials", "100", "--format", "json"], capsys)
    assert code == 0, err
    b = json.loads(out)[0]
    c = b["check"]
    assert c["model"] == "reduction"
    assert c["failed"] == 0
    assert c["mc_std"] == pytest.approx(b["u_c"], rel=0.1)
    assert c["mc_low"] < b["estimate"] < c["mc_high"]
