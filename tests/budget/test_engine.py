"""Budgets of a tumble against hand computations: local gravity, DAQ gain, angles, correlations."""

import math

import numpy as np
import pytest

from accelcal.budget import budgets
from accelcal.budget.lab import load_lab
from accelcal.methods import tumble
from helpers.budget import lab_text, linear_tumble, standard


def _by(bs, coefficient):
    return next(b for b in bs if b.coefficient == coefficient)


def _row(budget, quantity):
    return next(r for r in budget.rows if r.quantity == quantity)


@pytest.fixture
def linear(write_lab):
    """A noiseless K0 + K1 tumble, its reduction and a lab of gravity, gain and angles."""
    record = linear_tumble(12)
    red = tumble.reduce(record, terms=["K0", "K1"], sigma=1e-6, priors="none")
    lab = load_lab(write_lab(lab_text(
        standard("local_gravity", 9.81, "m/s^2", U=0.1, k=2, uncertainty_unit="mGal"),
        standard("daq_gain", 0.0, "ppm", u=10.0, dof=20),
        standard("head_angle", 0.0, "arcsec", bounds=1.0, distribution="rectangular"))))
    return record, red, lab


def test_local_gravity_on_the_scale_factor_is_u_g_over_g(linear):
    record, red, lab = linear
    b = _by(budgets(red, lab, records=record), "K1")
    g_row = _row(b, "local_gravity")
    # K1 = K1' g_n / g: c = -K1 / g, in ppm of K1: -1e6 / g per m/s^2
    assert g_row.sensitivity == pytest.approx(-1e6 / 9.81, rel=1e-9)
    assert g_row.contribution == pytest.approx(1e6 * 0.05e-5 / 9.81, rel=1e-9)
    assert b.unit == "ppm"


def test_local_gravity_on_the_bias_scales_with_it(linear):
    record, red, lab = linear
    b = _by(budgets(red, lab, records=record), "K0")
    # a bias in g referred to the test's 1 g: K0 g / g_n, c = K0 / g (ug per m/s^2)
    assert _row(b, "local_gravity").sensitivity == pytest.approx(b.estimate / 9.81, rel=1e-6)


def test_daq_gain_on_k1_is_one_to_one_in_ppm_and_leaves_the_bias(linear):
    record, red, lab = linear
    bs = budgets(red, lab, records=record)
    k1 = _row(_by(bs, "K1"), "daq_gain")
    assert k1.sensitivity == pytest.approx(1.0, rel=1e-5)  # Kragten's difference = analytic 1
    assert k1.contribution == pytest.approx(10.0, rel=1e-5)
    assert abs(_row(_by(bs, "K0"), "daq_gain").sensitivity) < 1e-6  # K0 = b0 / b1: cancels


def test_head_angle_vector_against_the_linear_least_squares(linear):
    record, red, lab = linear
    n = record.angles_rad.size
    bs = budgets(red, lab, records=record)
    # a position error d_i moves the regressor cos(theta_i) by -sin(theta_i) d_i; with a
    # perfect fit db = P[:, i] sin(theta_i) b1 d_i, P = (A^T A)^-1 A^T: per radian
    theta = record.angles_rad
    design = np.column_stack([np.ones(n), np.cos(theta)])
    pinv = np.linalg.pinv(design)
    per_rad_k1 = 1e6 * np.sqrt(np.sum((pinv[1] * np.sin(theta)) ** 2))  # ppm of K1
    per_rad_k0 = 1e6 * np.sqrt(np.sum((pinv[0] * np.sin(theta)) ** 2))  # ug
    arcsec = math.pi / 648000
    assert per_rad_k1 == pytest.approx(1e6 / math.sqrt(2 * n))  # uniform positions
    assert _row(_by(bs, "K1"), "head_angle").sensitivity == pytest.approx(
        per_rad_k1 * arcsec, rel=1e-4)
    assert _row(_by(bs, "K0"), "head_angle").sensitivity == pytest.approx(
        per_rad_k0 * arcsec, rel=1e-3)
    u = _row(_by(bs, "K1"), "head_angle").u
    assert u == pytest.approx(1 / math.sqrt(3))


def test_type_a_row_and_welch_satterthwaite(linear):
    record, red, lab = linear
    b = _by(budgets(red, lab, records=record), "K1")
    a = _row(b, "Type A")
    assert a.u == pytest.approx(red.std("K1") / red.value("K1") * 1e6, rel=1e-9)
    assert a.dof == math.inf  # the noise was given
    parts = [r.contribution for r in b.rows]
    assert b.u_c == pytest.approx(math.sqrt(sum(p * p for p in parts)))
    finite = [(r.contribution, r.dof) for r in b.rows if math.isfinite(r.dof)]
    assert b.nu_eff == pytest.approx(b.u_c**4 / sum(p**4 / d for p, d in finite))


def test_missing_inputs_are_noted_and_left_out(linear):
    record, red, lab = linear
    b = _by(budgets(red, lab, records=record), "K1")
    quantities = {r.quantity for r in b.rows}
    assert "daq_offset" not in quantities
    assert any("not declared in the lab file" in n and "daq_offset" in n for n in b.notes)


def test_without_the_data_only_the_analytic_inputs(linear):
    _, red, lab = linear
    b = _by(budgets(red, lab), "K1")
    assert {r.quantity for r in b.rows} == {"Type A", "local_gravity"}
    assert any("daq_gain: the input data were not found" in n for n in b.notes)


def test_load_resistor_and_its_correlation_with_the_gain(write_lab):
    record = linear_tumble(8, unit="mA")
    red = tumble.reduce(record, terms=["K0", "K1"], sigma=1e-6, priors="none")
    lab = load_lab(write_lab(lab_text(
        standard("daq_gain", 0.0, "ppm", u=10.0),
        standard("load_resistor", 1000.0, "ohm", u=0.02),
        extra='\n[[correlation]]\nquantities = ["daq_gain", "load_resistor"]\nr = 0.5\n')))
    b = _by(budgets(red, lab, records=record), "K1")
    gain, resistor = _row(b, "daq_gain"), _row(b, "load_resistor")
    assert resistor.sensitivity == pytest.approx(-1e6 / 1000.0, rel=1e-5)  # I = V / R
    assert resistor.contribution == pytest.approx(20.0, rel=1e-5)  # 0.02 ohm = 20 ppm
    cross = 2 * 0.5 * gain.sensitivity * gain.u * resistor.sensitivity * resistor.u
    plain = sum(r.contribution**2 for r in b.rows)
    assert b.correlated
    assert b.u_c == pytest.approx(math.sqrt(plain + cross))


def test_sensor_temperature_through_the_temperature_coefficients(linear, write_lab):
    from accelcal.model import ErrorModel
    from accelcal.terms import TemperatureTerms

    record, red, _ = linear
    lab = load_lab(write_lab(lab_text(standard("sensor_temperature", 25.0, "degC", u=0.1))))
    model = ErrorModel(K1=1.3, temperature=TemperatureTerms(
        20.0, {"K0_T1": 2e-6, "K1_T1": 3e-6, "K1_T2": 1e-7}))
    bs = budgets(red, lab, records=record, model=model)
    assert _row(_by(bs, "K0"), "sensor_temperature").sensitivity == pytest.approx(2.0)
    # d/dT of K1_T1 (T - T0) + K1_T2 (T - T0)^2 at T = 25: 3 + 2 (0.1) 5 ppm/degC
    assert _row(_by(bs, "K1"), "sensor_temperature").sensitivity == pytest.approx(4.0)


def test_a_method_without_a_model_keeps_type_a_and_priors(write_lab):
    import dataclasses

    red = tumble.reduce(linear_tumble(8), terms=["K0", "K1"], sigma=1e-6)
    other = dataclasses.replace(red, family="unmodelled")
    lab = load_lab(write_lab(lab_text(standard("daq_gain", 0.0, "ppm", u=10.0))))
    b = _by(budgets(other, lab), "K1")
    assert "no lab inputs modelled for this method" in b.notes
    assert "daq_gain" not in {r.quantity for r in b.rows}
    assert any(r.quantity.startswith("prior ") for r in b.rows)


def test_simulated_tumble_budget_is_complete(tumble_file, write_lab):
    from pathlib import Path

    from helpers.paths import ROOT

    lab = load_lab(Path(ROOT, "examples", "lab.toml"))
    red = tumble.reduce(tumble_file)
    bs = budgets(red, lab, records=tumble_file)
    assert {b.coefficient for b in bs} >= {"K0+Kpp", "K1", "K2-Kpp"}
    for b in bs:
        assert [r.contribution for r in b.rows] == sorted((r.contribution for r in b.rows),
                                                          reverse=True)
        assert b.u_c >= _row(b, "Type A").u
    k0 = _by(bs, "K0+Kpp")
    # the example's DAQ offset, 2 uV on a sensor of about 1.3 V/g: 2e-6 / 1.3 g
    assert _row(k0, "daq_offset").contribution == pytest.approx(2e-6 / red.value("K1") * 1e6,
                                                                rel=1e-3)


def test_gravity_exponents_against_reductions_at_another_gravity():
    from accelcal.budget.engine import ORDER_EXPONENT
    from accelcal.io.formats.tumble import TumbleRecord

    theta = 2 * np.pi * np.arange(12) / 12
    k1, k0, k2 = 1.3, 5e-4, 2e-5

    def reduced(s):  # a tumble where 1 g of the positions is s g_n
        a = s * np.cos(theta)
        rec = TumbleRecord(theta, k1 * (k0 + a + k2 * a**2), "OA", "V")
        red = tumble.reduce(rec, terms=["K0", "K1", "K2"], sigma=1e-7, priors="none")
        return {n: red.value(n) for n in ("K0", "K1", "K2")}

    eps = 1e-4
    up, down = reduced(1 + eps), reduced(1 - eps)
    # the reduction's coefficient moves as s^q with the true 1 g: the coefficient per g_n is
    # the reduction's times g^-q, the budget's exponent p = -q (K1 in V/g, K0 = b0/b1 in g,
    # K2 = b2/b1 in g/g^2)
    q = {n: (math.log(up[n]) - math.log(down[n])) / (math.log(1 + eps) - math.log(1 - eps))
         for n in up}
    assert -q["K1"] == pytest.approx(ORDER_EXPONENT["scale"], abs=1e-6)
    assert -q["K0"] == pytest.approx(ORDER_EXPONENT["bias"], abs=1e-6)
    assert -q["K2"] == pytest.approx(ORDER_EXPONENT["second"], abs=1e-6)


def test_a_non_zero_error_value_is_named_as_an_unapplied_correction(linear, write_lab):
    record, red, _ = linear
    lab = load_lab(write_lab(lab_text(standard("daq_gain", 5.0, "ppm", u=2.0))))
    b = _by(budgets(red, lab, records=record), "K1")
    assert any(n.startswith("daq_gain: the declared value 5 ppm is a correction") for n in b.notes)
    assert _row(b, "daq_gain").contribution == pytest.approx(2.0, rel=1e-5)


def test_the_vector_row_keeps_its_per_position_sensitivities(linear):
    record, red, lab = linear
    row = _row(_by(budgets(red, lab, records=record), "K1"), "head_angle")
    assert len(row.components) == record.angles_rad.size
    assert row.sensitivity == pytest.approx(math.sqrt(sum(c * c for c in row.components)))
    # sin(2 theta_i) / N per radian on K1 (uniform positions), in ppm per arcsec
    theta = record.angles_rad
    expected = 1e6 * np.sin(2 * theta) / theta.size * math.pi / 648000
    assert np.allclose(np.abs(row.components), np.abs(expected), rtol=1e-3, atol=1e-9)


def test_a_failing_re_run_leaves_the_input_out_with_a_note(linear, write_lab):
    from accelcal.budget.engine import DataModel, itemise
    from accelcal.errors import AccelcalError

    _, red, _ = linear
    lab = load_lab(write_lab(lab_text(standard("daq_gain", 0.0, "ppm", u=10.0))))

    def refuse(**_):
        raise AccelcalError("the perturbed data cannot be reduced")

    bs = itemise(red, lab, data_model=DataModel(refuse, 12), inputs=("daq_gain",))
    b = _by(bs, "K1")
    assert "daq_gain" not in {r.quantity for r in b.rows}
    assert any("daq_gain: the reduction run again on the perturbed data did not give K1" in n
               for n in b.notes)


def test_unreadable_data_leave_the_data_inputs_out(linear, tmp_path):
    _, red, lab = linear
    bad = tmp_path / "gone.csv"
    b = _by(budgets(red, lab, records=bad), "K1")
    assert {r.quantity for r in b.rows} == {"Type A", "local_gravity"}
    assert any(n.startswith("the input data could not be read again") for n in b.notes)
