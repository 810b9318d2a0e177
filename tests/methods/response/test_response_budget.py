"""The comparison's budget: each closed form against the reduction of re-simulated data.

Every input's sensitivity coefficient (:mod:`accelcal.methods.response.budget`)
is checked by central differences (Kragten): the rig simulates the campaign
with the input at ``+h`` and ``-h`` (noise-free), the stepped-sine reduction
reduces both, and ``(y(+h) - y(-h)) / 2h`` is compared with the budget's
coefficient at every step, magnitude (% of the estimate) and phase (deg).
"""

import dataclasses

import numpy as np
import pytest

from accelcal.budget import budgets
from accelcal.budget.lab import load_lab
from accelcal.methods.response import reduce
from accelcal.rigs.shaker_response import DutResponse, default_reference, simulate
from helpers.budget import lab_text, standard
from helpers.paths import ROOT

LAB = ROOT / "examples" / "lab.toml"
RIG = {"frequencies": (100.0, 400.0, 440.0, 480.0, 1000.0), "sample_rate": 20000.0,
       "periods": 20, "noise": 0.0}
DUT = DutResponse()
TRANSVERSE = 0.01  # examples/lab.toml: the DUT's transverse sensitivity, 1 %


def _record(dut=DUT, *, stated=None, **rig):
    """A noise-free record; ``stated``: the DAQ mismatch the record states instead of the rig's."""
    rec = simulate(dut, seed=0, **(RIG | rig))
    if stated is not None:
        rec = dataclasses.replace(rec, metadata={**rec.metadata, "daq": stated})
    return rec


def _kragten(plus, minus, base, step):
    """Per unit ``step``: magnitude in % of the base's, phase in deg, at every step."""
    vp, vm, v0 = (np.asarray(r.estimate.values) for r in (plus, minus, base))
    mag = (np.abs(vp) - np.abs(vm)) / np.abs(v0) * 100.0 / (2 * step)
    phase = np.rad2deg(np.angle(vp / vm)) / (2 * step)
    return mag, phase


def _coefficients(reduction, record, quantity, lab=LAB):
    """The budget's coefficients of ``quantity``: (magnitude per step, phase per step)."""
    bs = budgets(reduction, load_lab(lab), records=record)
    names = reduction.estimate.names

    def one(title):
        b = next(b for b in bs if b.coefficient == title)
        return next(r.sensitivity for r in b.rows if r.quantity == quantity)

    return (np.array([one(f"{n} magnitude") for n in names]),
            np.array([one(f"{n} phase") for n in names]))


@pytest.fixture
def write_lab(tmp_path):
    def write(text):
        path = tmp_path / "lab.toml"
        path.write_text(text, encoding="utf-8")
        return path

    return write


@pytest.fixture(scope="module")
def base():
    rec = _record()
    return rec, reduce(rec)


# input -> (rig settings at +h as a function of h, h in the lab's unit, its size in the rig)
CASES = {
    "relative_motion": (lambda h: {"relative_motion": (h, h)}, 0.5, 0.01),
    "transverse_motion": (lambda h: {"transverse": (h, h),
                                     "transverse_sensitivity": TRANSVERSE}, 1.0, 0.01),
    "daq_gain_mismatch": (lambda h: {"gain_ratio": 1 + h, "stated": {"gain_ratio": 1.0,
                                                                     "delay_s": 0.0}},
                          100.0, 1e-6),
    "daq_delay_mismatch": (lambda h: {"delay_s": h, "stated": {"gain_ratio": 1.0,
                                                               "delay_s": 0.0}},
                           500.0, 1e-9),
}


@pytest.mark.parametrize("quantity", sorted(CASES))
def test_closed_form_against_the_rerun(base, quantity):
    settings, h, size = CASES[quantity]
    rec, red = base
    plus, minus = (reduce(_record(**settings(s * h * size))) for s in (1, -1))
    mag, phase = _kragten(plus, minus, red, h)
    c_mag, c_phase = _coefficients(red, rec, quantity)
    # a complex input's bound is per component: the rig moved both, the budget's
    # coefficient is of one (Re on the magnitude, Im on the phase)
    np.testing.assert_allclose(c_mag, mag, rtol=2e-3, atol=1e-9)
    np.testing.assert_allclose(c_phase, phase, rtol=2e-3, atol=1e-9)
    assert np.any(np.abs(c_mag) > 1e-6) or np.any(np.abs(c_phase) > 1e-6)


def test_delay_enters_the_phase_as_2_pi_f(base):
    rec, red = base
    c_mag, c_phase = _coefficients(red, rec, "daq_delay_mismatch")
    f = np.asarray(red.observations["frequency_hz"])
    np.testing.assert_allclose(c_phase, -360.0 * f * 1e-9, rtol=1e-12)  # deg per ns
    assert not np.any(c_mag)


def test_temperature_and_its_coefficient(base, write_lab):
    rec, red = base
    alpha, dt, h = 150e-6, 2.0, 0.1
    hot = load_lab(write_lab(lab_text(standard("sensor_temperature", 23.0 + dt, "degC", u=h),
                                      standard("sensitivity_tc", 150.0, "ppm/degC", u=30.0))))
    # the DUT 2 degC warm: its S0 scaled by 1 + alpha dT; moved by +-h degC and +-h alpha
    runs = {key: reduce(_record(dataclasses.replace(DUT, S0=DUT.S0 * (1 + a * t))))
            for key, (a, t) in {"t+": (alpha, dt + h), "t-": (alpha, dt - h),
                                "a+": (alpha * 1.1, dt), "a-": (alpha * 0.9, dt)}.items()}
    mag_t, _ = _kragten(runs["t+"], runs["t-"], red, h)
    mag_a, _ = _kragten(runs["a+"], runs["a-"], red, alpha * 0.1 * 1e6)  # per ppm/degC
    bs = budgets(red, hot, records=rec)
    for q, expected in (("sensor_temperature", mag_t), ("sensitivity_tc", mag_a)):
        got = [next(r.sensitivity for r in b.rows if r.quantity == q) for b in bs
               if b.coefficient.endswith("magnitude")]
        np.testing.assert_allclose(got, expected, rtol=1e-6)
        assert all(next(r.sensitivity for r in b.rows if r.quantity == q) == 0 for b in bs
                   if b.coefficient.endswith("phase"))


def test_transverse_sensitivity_takes_the_transverse_motion(base, write_lab):
    rec, red = base
    tau, h = 0.02, 0.001
    lab = write_lab(lab_text(standard("transverse_motion", 2.0, "%", u=1.0),
                             standard("transverse_sensitivity", 1.0, "%", u=0.1)))
    plus, minus = (reduce(_record(transverse=(tau, tau), transverse_sensitivity=TRANSVERSE + s))
                   for s in (h, -h))
    mag, phase = _kragten(plus, minus, red, h * 100)  # per %
    c_mag, c_phase = _coefficients(red, rec, "transverse_sensitivity", lab)
    np.testing.assert_allclose(c_mag, mag, rtol=0.03)  # the base is at tau = 0
    np.testing.assert_allclose(c_phase, phase, rtol=0.03)


def test_distortion_does_not_reach_the_fits_and_the_rerun_says_so(base):
    rec, red = base
    distorted = reduce(_record(distortion=(0.02, 0.02)))
    moved = np.abs(np.asarray(distorted.estimate.values) / np.asarray(red.estimate.values) - 1)
    assert moved.max() < 1e-9  # 2 % of each harmonic: the fits hold them
    c_mag, c_phase = _coefficients(red, rec, "distortion")
    assert np.abs(c_mag).max() < 1e-6
    assert np.abs(c_phase).max() < 1e-6


def test_frequency_error_through_the_slope_and_the_fits(base):
    rec, red = base
    eps = 1e-4  # relative: the data at f (1 + eps), stated f
    runs = []
    for s in (1, -1):
        moved = _record(frequencies=tuple(f * (1 + s * eps) for f in RIG["frequencies"]))
        runs.append(reduce(dataclasses.replace(moved, frequency=rec.frequency)))
    mag, phase = _kragten(*runs, red, eps * 1e6)  # per ppm
    c_mag, c_phase = _coefficients(red, rec, "frequency")
    # the DUT's slope comes from the points' differences against log f: the step
    # between two close ones (440 Hz) has it to 3 %, the steps beside a far one to
    # 10 %; the first and last (one-sided, an octave or two from their neighbour)
    # within a factor of 2.5, of the right sign (1.8 and 2.1 here)
    inner = slice(1, 4)
    np.testing.assert_allclose(c_mag[2], mag[2], rtol=0.03)
    np.testing.assert_allclose(c_phase[2], phase[2], rtol=0.03)
    np.testing.assert_allclose(c_mag[inner], mag[inner], rtol=0.1)
    np.testing.assert_allclose(c_phase[inner], phase[inner], rtol=0.1)
    for c, k in ((c_mag, mag), (c_phase, phase)):
        ratio = c[[0, 4]] / k[[0, 4]]
        assert np.all((ratio > 0.4) & (ratio < 2.5)), ratio
    assert np.abs(c_phase).min() > 1e-6


def test_reference_table_interpolated_with_its_u(base):
    rec, red = base
    table = default_reference()
    h = 0.01
    scaled = [dataclasses.replace(table, magnitude=tuple(m * (1 + s * h) for m in table.magnitude),
                                  phase_deg=tuple(p + s * h for p in table.phase_deg))
              for s in (1, -1)]
    plus, minus = (reduce(rec, reference=t) for t in scaled)
    mag, phase = _kragten(plus, minus, red, h)
    bs = budgets(red, load_lab(LAB), records=rec)
    f = np.asarray(red.observations["frequency_hz"])
    for i, name in enumerate(red.estimate.names):
        b_mag = next(b for b in bs if b.coefficient == f"{name} magnitude")
        row = next(r for r in b_mag.rows if r.quantity == "reference_sensitivity")
        s_ref = abs(table.sensitivity(f[i])[0])
        assert row.estimate == pytest.approx(s_ref * 1e3)  # the lab's mV/g
        assert row.u == pytest.approx(np.interp(f[i], table.frequency_hz, table.magnitude_U)
                                      / 2 * 1e3)  # U, k = 2
        # per relative h: y moves h (100 h %), per mV/g 100 / S_ref %
        assert row.sensitivity * s_ref * 1e3 * h == pytest.approx(mag[i] * h, rel=1e-6)
        b_phase = next(b for b in bs if b.coefficient == f"{name} phase")
        row = next(r for r in b_phase.rows if r.quantity == "reference_phase")
        assert row.sensitivity == pytest.approx(phase[i], rel=1e-6)
        assert row.u == pytest.approx(0.25)


def test_every_input_in_the_example_lab_and_missing_ones_named(base, write_lab):
    from accelcal import catalog

    rec, red = base
    inputs = catalog.method("response").budget_inputs
    b = budgets(red, load_lab(LAB), records=rec)[0]
    assert {r.quantity for r in b.rows} == {"Type A", *inputs}
    bare = budgets(red, load_lab(write_lab(lab_text(standard("daq_gain", 0.0, "ppm", u=8.0)))),
                   records=rec)[0]
    note = next(n for n in bare.notes if n.startswith("inputs of the method's model"))
    assert all(q in note for q in inputs if q != "daq_gain")


def test_a_lab_without_the_coefficients_names_them(base, write_lab):
    rec, red = base
    lab = load_lab(write_lab(lab_text(standard("sensor_temperature", 23.0, "degC", u=0.1),
                                      standard("transverse_motion", 0.0, "%", bounds=5.0,
                                               distribution="rectangular"))))
    b = budgets(red, lab, records=rec)[0]
    assert {r.quantity for r in b.rows} == {"Type A"}
    assert any("sensitivity_tc" in n and n.startswith("sensor_temperature") for n in b.notes)
    assert any("transverse_sensitivity" in n and n.startswith("transverse_motion")
               for n in b.notes)


def test_a_delay_in_hertz_is_refused(write_lab):
    from accelcal.errors import AccelcalError

    with pytest.raises(AccelcalError, match="does not fit daq_delay_mismatch"):
        load_lab(write_lab(lab_text(standard("daq_delay_mismatch", 0.0, "Hz", u=1.0))))


def test_the_laser_is_not_a_comparison_and_the_fit_takes_its_points(base):
    from accelcal.methods.response import fit_model

    rec, red = base
    laser = dataclasses.replace(red, method="response/laser")
    bs = budgets(laser, load_lab(LAB))
    assert {r.quantity for b in bs for r in b.rows} <= {"Type A"}
    assert any("not of response/laser" in n for n in bs[0].notes)
    # the fit: the comparison's inputs through its points (test_response_fit_budget.py)
    bs = budgets(fit_model(red), load_lab(LAB), records=rec)
    assert "reference_sensitivity" in {r.quantity for r in bs[0].rows}


def test_the_rigs_mounting_multiplies_the_dut_by_its_factor(base):
    from accelcal.errors import AccelcalError

    rec, red = base
    moved = reduce(_record(relative_motion=(0.01, -0.02), transverse=(0.03, 0.04),
                           transverse_sensitivity=0.05))
    ratio = np.asarray(moved.estimate.values) / np.asarray(red.estimate.values)
    np.testing.assert_allclose(ratio, 1 + 0.01 - 0.02j + 0.05 * (0.03 + 0.04j), rtol=1e-10)
    stated = _record(relative_motion=(0.01, 0.0))
    assert stated.metadata["mounting"] == {"relative_motion": [0.01, 0.0],
                                           "transverse": [0.0, 0.0],
                                           "transverse_sensitivity": 0.0}
    assert "mounting" not in rec.metadata  # none: a record as before
    with pytest.raises(AccelcalError, match="magnitude below 1"):
        _record(relative_motion=(1.5, 0.0))


def test_broadband_points_get_the_budget_without_distortion():
    from accelcal.rigs.response_routes import BroadbandRig

    rec = BroadbandRig(kind="random", duration_s=2.0, sample_rate=5000.0).simulate(seed=2)
    red = reduce(rec)
    bs = budgets(red, load_lab(LAB), records=rec)
    assert len(bs) == 2 * len(red.estimate.names)
    quantities = {r.quantity for r in bs[0].rows}
    assert {"reference_sensitivity", "relative_motion", "frequency"} <= quantities
    assert "distortion" not in quantities
    assert any(n.startswith("distortion: an input of the stepped sine") for n in bs[0].notes)
