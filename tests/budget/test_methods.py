"""The centrifuge's, thermal test's and triad's measurement models: each input where it enters."""

import dataclasses
import math

import pytest

from accelcal.budget import budgets
from accelcal.budget.lab import load_lab
from helpers.budget import lab_text, standard
from helpers.paths import EXAMPLES


def _by(bs, coefficient):
    return next(b for b in bs if b.coefficient == coefficient)


def _row(budget, quantity):
    return next(r for r in budget.rows if r.quantity == quantity)


@pytest.fixture(scope="module")
def centrifuge_record():
    from accelcal.defaults import default_model
    from accelcal.rigs.centrifuge import simulate

    positions = ("IA-in", "IA-out", "OA-in", "OA-out", "PA-in", "PA-out", "IA-tan")
    return simulate(default_model(), positions, (5.0, 20.0, 35.0, 50.0),
                    seed=2)


@pytest.mark.slow
def test_centrifuge_radius_and_rate_through_the_reduction(centrifuge_record, write_lab):
    from accelcal.methods.centrifuge import reduce_centrifuge

    lab = load_lab(write_lab(lab_text(
        standard("centrifuge_radius", 0.5, "m", u=20, uncertainty_unit="um"),
        standard("centrifuge_rate", 0.0, "ppm", u=5.0),
        standard("local_gravity", 9.80665, "m/s^2", u=1e-5))))
    red = reduce_centrifuge(centrifuge_record, priors="none")
    b = _by(budgets(red, lab, records=centrifuge_record), "K2")
    radius, rate = _row(b, "centrifuge_radius"), _row(b, "centrifuge_rate")
    # one-sided check of the central difference: the reduction with R + u(R)
    moved = reduce_centrifuge(dataclasses.replace(
        centrifuge_record, radius_m=centrifuge_record.radius_m + 20e-6), priors="none")
    direct = (moved.value("K2") - red.value("K2")) * 1e6 / 20e-6  # ug/g^2 per m
    assert radius.sensitivity == pytest.approx(direct, rel=0.02)
    assert radius.sensitivity != 0
    assert rate.sensitivity != 0
    assert _row(b, "local_gravity").u == pytest.approx(1e-5)


def test_thermal_temperature_offset_moves_the_bias_by_its_coefficient(write_lab):
    from accelcal.methods import thermal

    path = EXAMPLES / "thermal.csv"
    lab = load_lab(write_lab(lab_text(standard("sensor_temperature", 25.0, "degC", u=0.1))))
    red = thermal.reduce(path)
    bs = budgets(red, lab, records=path)
    k0 = _by(bs, "K0+Kpp")
    slope = _by(bs, "K0_T1").estimate  # ug/degC at T0: a common offset of the readings
    assert _row(k0, "sensor_temperature").sensitivity == pytest.approx(-slope, rel=0.02)
    # the coefficients themselves barely move with a common offset (the K0_T2 term only)
    t1 = _row(_by(bs, "K0_T1"), "sensor_temperature").sensitivity
    assert abs(t1) == pytest.approx(2 * abs(_by(bs, "K0_T2").estimate), rel=0.05)


def test_triad_scale_factors_move_with_gravity_one_to_one(write_lab):
    from accelcal.methods import triad

    path = EXAMPLES / "triad.csv"
    lab = load_lab(write_lab(lab_text(standard("local_gravity", 9.81, "m/s^2", u=1e-4))))
    red = triad.reduce(path)
    bs = budgets(red, lab, records=path)
    s_x = _by(bs, "s_x")
    g = red.assumed("gravity")
    assert _row(s_x, "local_gravity").sensitivity == pytest.approx(s_x.estimate / g, rel=1e-4)
    assert math.isfinite(s_x.u_c)


def test_every_declared_input_is_in_the_vocabulary_and_modelled():
    import importlib

    from accelcal import catalog
    from accelcal.budget.lab import QUANTITIES

    modelled = [m for m in catalog.METHODS if m.budget_inputs]
    assert {m.name for m in modelled} >= {"tumble", "dividing-head", "centrifuge", "triad",
                                          "thermal", "response", "noise", "transverse", "vre"}
    for m in modelled:
        assert set(m.budget_inputs) <= set(QUANTITIES), m.name
        assert len(set(m.budget_inputs)) == len(m.budget_inputs), m.name
        assert callable(importlib.import_module(f"{m.package}.budget").data_model), m.name


def test_response_reference_in_closed_form_and_a_common_gain_cancels(tmp_path, write_lab):
    from accelcal.io.formats.response import write
    from accelcal.methods import response

    path = tmp_path / "response.csv"
    write(path, response.simulate(seed=3, frequencies=(20.0, 160.0)))
    lab = load_lab(write_lab(lab_text(
        standard("reference_sensitivity", 10.0, "mV/g", U=0.5, k=2, uncertainty_unit="%"),
        standard("reference_phase", 0.0, "deg", u=0.2),
        standard("daq_gain", 0.0, "ppm", u=8.0))))
    bs = budgets(response.reduce(path), lab, records=path)
    mag = _by(bs, "S(160 Hz) magnitude")
    phase = _by(bs, "S(160 Hz) phase")
    assert mag.unit == "%"
    # the record's reference table states U (0.5 % and 0.5 deg, k = 2): it replaces the
    # lab's u (0.2 deg), interpolated at the step's frequency
    assert _row(mag, "reference_sensitivity").contribution == pytest.approx(0.25)
    assert _row(phase, "reference_phase").contribution == pytest.approx(0.25)
    assert _row(mag, "reference_phase").contribution == 0.0
    assert abs(_row(mag, "daq_gain").sensitivity) < 1e-9  # the same DAQ on both channels


def test_noise_coefficients_scale_with_the_gain(write_lab):
    from accelcal.methods import noise

    lab = load_lab(write_lab(lab_text(standard("daq_gain", 0.0, "ppm", u=10.0))))
    bs = budgets(noise.reduce(EXAMPLES / "still.csv"), lab)
    n = _by(bs, "N")
    assert _row(n, "daq_gain").contribution == pytest.approx(n.estimate * 10e-6, rel=1e-12)


def test_transverse_orders_of_the_amplitude(write_lab):
    from accelcal.methods import transverse

    lab = load_lab(write_lab(lab_text(standard("reference_sensitivity", 10.0, "mV/g", u=0.05))))
    bs = budgets(transverse.reduce(EXAMPLES / "shaker"), lab)
    ko, koo = _by(bs, "Ko"), _by(bs, "Koo")
    # 0.05 mV/g of 10 mV/g is 0.5 %: Ko (order 1) moves 0.5 %, Koo (order 2) 1 %
    assert _row(ko, "reference_sensitivity").contribution == pytest.approx(
        abs(ko.estimate) * 0.005, rel=1e-9)
    assert _row(koo, "reference_sensitivity").contribution == pytest.approx(
        abs(koo.estimate) * 0.01, rel=1e-9)


def test_dividing_head_from_its_data_in_memory(write_lab):
    from accelcal.io.formats.dividing_head import read_head_record
    from accelcal.methods import dividing_head

    data = dividing_head.HeadData.from_record(read_head_record(EXAMPLES / "indexing_head.csv"))
    red = dividing_head.reduce(data, "single")
    lab = load_lab(write_lab(lab_text(standard("daq_gain", 0.0, "ppm", u=8.0))))
    bs = budgets(red, lab, records=data)
    k_i = [b for b in bs if b.coefficient == "K_I"]
    assert len(k_i) == 4  # every sensor
    for b in k_i:
        assert _row(b, "daq_gain").sensitivity == pytest.approx(1.0, rel=1e-3)


def test_vre_amplitude_through_the_identification(write_lab):
    from accelcal.methods import vre

    path = EXAMPLES / "vibrafuge.csv"
    lab = load_lab(write_lab(lab_text(standard("reference_sensitivity", 10.0, "mV/g", u=0.05))))
    b = _by(budgets(vre.reduce(path), lab, records=path), "K2")
    # dU1 = K2 A^2 / 2 + ...: K2 ~ A^-2, so 0.5 % on A is 1 % on K2
    assert _row(b, "reference_sensitivity").contribution == pytest.approx(
        0.01 * abs(b.estimate), rel=0.01)


def test_docs_list_each_methods_inputs():
    import re

    from accelcal import catalog
    from helpers.paths import ROOT

    text = (ROOT / "docs" / "budget.md").read_text(encoding="utf-8")
    table = dict(re.findall(r"^\| ([a-z, -]+) \| ([a-z_, ]+) \|", text, re.M))
    same = tuple(table["tumble"].split(", "))  # "the same": the row above, the tumble's
    for m in catalog.METHODS:
        listed = next((v for k, v in table.items() if m.name in k.split(", ")), None)
        assert listed is not None, m.name
        expected = {"the same": same, "none yet": ()}.get(listed, tuple(listed.split(", ")))
        assert m.budget_inputs == expected, m.name
