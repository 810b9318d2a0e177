"""The model fit's budget: the comparison's inputs through the points, re-fitted.

:mod:`accelcal.methods.response.budget_fit` moves the points a fit was made
from by each input and fits the model again. Checked here in closed form: a
common relative factor moves ``S0`` by ``S0 d`` and leaves ``fn``, ``zeta``
and ``f_3dB`` (the model is linear in ``S0``); a channel delay is taken whole
by a fitted delay term; and through the rig: a channel delay simulated and
reduced moves ``fn`` as the budget's coefficient says.
"""

import dataclasses

import numpy as np
import pytest

from accelcal.budget import budgets
from accelcal.budget.lab import load_lab
from accelcal.methods.response import fit_model, reduce
from accelcal.rigs.shaker_response import DutResponse, ResponseRig, default_reference
from helpers.budget import lab_text, standard
from helpers.paths import ROOT

LAB = ROOT / "examples" / "lab.toml"
FREQUENCIES = (10.0, 40.0, 80.0, 160.0, 400.0, 800.0)
REFIT = 1e-5
"""Relative tolerance of a re-fit's coefficient against its closed form: the re-fits
converge to about 1e-4 of the parameters' own standard uncertainty (found: 1e-6)."""
COMMON_GAIN = 1e-6
"""Largest ``|d y / d ln g| / y`` of ``fn``, ``zeta``, ``f_3dB`` for a common relative gain
``g`` on every point: zero in exact arithmetic (the model is linear in ``S0`` and the
weights stay), the re-fits' tolerance (xtol 1e-15) and the central differences' rounding
leave about 1e-11."""


def _rig(**settings):
    return ResponseRig(frequencies=FREQUENCIES, sample_rate=5000.0, periods=10, **settings)


@pytest.fixture(scope="module")
def base():
    rec = _rig().simulate(DutResponse(), seed=11)
    red = reduce(rec)
    return rec, red, fit_model(red)


@pytest.fixture(scope="module")
def example(base):
    """The fit's budgets with the example lab file and the data."""
    rec, _, fit = base
    return budgets(fit, load_lab(LAB), records=rec)


def _budget(bs, name):
    return next(b for b in bs if b.coefficient == name)


def _row(b, quantity):
    return next(r for r in b.rows if r.quantity == quantity)


def test_the_reference_moves_s0_by_its_relative_u(base, example, tmp_path):
    fit = base[2]
    s0 = fit.estimate.values[0]
    # with the data: the table's U / 2 at the reference frequency (80 Hz), 0.25 %
    b = _budget(example, "S0")
    row = _row(b, "reference_sensitivity")
    table = default_reference()
    rel = np.interp(80.0, table.frequency_hz, table.magnitude_U) / 2 / abs(
        table.sensitivity(80.0)[0])
    assert rel == pytest.approx(0.0025)
    assert row.u == pytest.approx(rel * abs(table.sensitivity(80.0)[0]) * 1e3)  # mV/g
    assert row.contribution / s0 == pytest.approx(rel, rel=REFIT)
    # the lab's relative u alone: u(S0) / S0 = hypot(u_ref, the fit's own)
    path = tmp_path / "lab.toml"
    path.write_text(lab_text(standard("reference_sensitivity", 0.0, "%", u=0.4)),
                    encoding="utf-8")
    b = _budget(budgets(fit, load_lab(path)), "S0")
    assert _row(b, "reference_sensitivity").sensitivity == pytest.approx(s0 / 100, rel=REFIT)
    type_a = fit.estimate.std[0] / s0
    assert b.u_c / s0 == pytest.approx(np.hypot(0.004, type_a), rel=REFIT)


@pytest.mark.parametrize("quantity", ["reference_sensitivity", "daq_gain_mismatch",
                                      "sensor_temperature"])
def test_a_common_gain_moves_s0_alone(base, example, quantity):
    fit, lab, bs = base[2], load_lab(LAB), example
    s0_row = _row(_budget(bs, "S0"), quantity)
    relative = s0_row.sensitivity / fit.estimate.values[0]  # d ln S0 per lab unit
    expected = {"reference_sensitivity": lambda: 1.0 / s0_row.estimate,  # per mV/g
                "daq_gain_mismatch": lambda: 1e-6,  # per ppm
                "sensor_temperature": lambda: lab.standards["sensitivity_tc"].value_in(
                    "1/degC")}[quantity]()
    assert relative == pytest.approx(expected, rel=REFIT)
    for name in ("fn", "zeta", "f_3dB"):
        c = _row(_budget(bs, name), quantity).sensitivity
        value = fit.estimate.values[fit.estimate.names.index(name)]
        assert abs(c / relative / value) < COMMON_GAIN, name


def test_a_common_phase_moves_the_dynamics_not_s0(example):
    bs = example
    s0 = _row(_budget(bs, "S0"), "reference_phase")
    fn = _row(_budget(bs, "fn"), "reference_phase")
    assert abs(fn.contribution) > 0.5  # Hz: 0.25 deg on every point
    assert abs(s0.contribution) < 0.2 * _row(_budget(bs, "S0"), "reference_sensitivity"
                                             ).contribution


def test_a_fitted_delay_takes_the_channel_delay_whole(base):
    rec, red, _ = base
    fit = fit_model(red, "second-order,delay")
    bs = budgets(fit, load_lab(LAB), records=rec)
    # exp(-i 2 pi f tau) on the points is the delay term's own: 1 ns per ns (lab unit ns)
    assert _row(_budget(bs, "delay"), "daq_delay_mismatch").sensitivity == pytest.approx(
        1e-9, rel=1e-4)
    # fn does not move (without the delay term: 1.4e-3 Hz per ns)
    assert abs(_row(_budget(bs, "fn"), "daq_delay_mismatch").sensitivity) < 1e-6


def test_a_channel_delay_through_the_rig(base, example):
    """The delay mismatch simulated, reduced and fitted: fn moves as the coefficient says."""
    h = 1e-6  # s
    stated = {"gain_ratio": 1.0, "delay_s": 0.0}
    moved = []
    for s in (1, -1):
        r = _rig(delay_s=s * h).simulate(DutResponse(), seed=11)
        r = dataclasses.replace(r, metadata={**r.metadata, "daq": stated})
        moved.append(fit_model(reduce(r)).estimate.values[1])
    c = _row(_budget(example, "fn"), "daq_delay_mismatch").sensitivity  # Hz per ns
    assert c * 1e9 == pytest.approx((moved[0] - moved[1]) / (2 * h), rel=0.02)


def test_every_comparison_input_enters_the_fit(base, example):
    from accelcal import catalog

    fit, bs = base[2], example
    assert [b.coefficient for b in bs] == ["S0", "fn", "zeta", "f_3dB"]
    inputs = catalog.method("response").budget_inputs
    assert {r.quantity for r in bs[0].rows} == {"Type A", *inputs}
    # S0's U covers the reference's relative U (0.5 %, k = 2): 500 times the fit's own
    assert bs[0].U / fit.estimate.values[0] >= 0.005
    assert bs[0].U / (2 * fit.estimate.std[0]) > 100


def test_the_full_models_linear_inputs_move_each_row_by_its_contribution(base, example):
    """A row's standard of its own (the reference's table at 80 Hz, u = 0.25 mV/g where the
    lab states 0.025 mV/g of its 10 mV/g) enters the Monte Carlo per the lab's u."""
    from accelcal.budget.full import model_of
    from accelcal.methods.response.budget import data_model

    rec, _, fit = base
    lab = load_lab(LAB)
    study, _ = model_of(example, fit, lab, data_model(fit, rec))
    linear = {q: (u, sens) for q, _, u, _, sens in study.linear}
    for q in ("reference_sensitivity", "reference_phase", "sensor_temperature"):
        u, sens = linear[q]
        assert u == lab.standards[q].u
        for b, c in zip(example, sens, strict=True):
            assert c * u == pytest.approx(_row(b, q).sensitivity * _row(b, q).u, rel=1e-12,
                                          abs=1e-300)
    u, sens = linear["reference_sensitivity"]
    assert sens[0] * u / fit.estimate.values[0] == pytest.approx(0.0025, rel=REFIT)


def test_a_fit_to_laser_points_has_none_of_the_comparisons_inputs():
    from accelcal.rigs.response_routes import LaserRig

    rec = LaserRig().simulate(seed=2)
    bs = budgets(fit_model(reduce(rec)), load_lab(LAB), records=rec)
    assert {r.quantity for b in bs for r in b.rows} == {"Type A"}
    assert any(n.startswith("reference_sensitivity: an input of the comparison, not of "
                            "response/laser") for n in bs[0].notes)


def test_without_the_points_the_common_gains_enter_s0_in_closed_form(base):
    """A record's numbers alone (its input files not found): ``S0 d``, the rest named."""
    fit = dataclasses.replace(base[2], observations={})
    lab = load_lab(LAB)
    s0, fn = budgets(fit, lab)[:2]
    ref = lab.standards["reference_sensitivity"]  # 10 mV/g, u 0.025 mV/g
    assert _row(s0, "reference_sensitivity").contribution / s0.estimate == pytest.approx(
        ref.u / ref.value, rel=1e-12)
    assert _row(fn, "reference_sensitivity").sensitivity == 0.0
    assert "reference_phase" not in {r.quantity for r in s0.rows}
    assert any(n.startswith("reference_phase: the points the fit was made from were not "
                            "found") for n in s0.notes)
