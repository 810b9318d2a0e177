"""The comparison's budget covers the truth: y +- U over simulated campaigns (slow).

Each campaign is the rig at its default settings (11 steps from 10 Hz to
1.25 kHz, 20 periods at 20 kHz, 0.1 mV of noise, the default DUT) with every
influence quantity of examples/lab.toml drawn from the distribution the lab
file states: the reference's true sensitivity and phase off its certificate
by one normal draw of the table's U / 2 (common to the table, as the budget's
interpolated U assumes), the DAQ's gain and delay mismatch (the record states
none), the DUT's transverse sensitivity, its temperature and temperature
coefficient and the generator's frequency error, common to the campaign; the
transverse motion and the relative motion (each component) and the
distortion (each harmonic), drawn for each step. Each point's magnitude and
phase budget (the lab file, the records re-read) then gives ``U``; the truth
is the DUT's transfer function at the stated frequency and the lab's
temperature.
"""

import dataclasses

import numpy as np
import pytest

from accelcal.budget import budgets
from accelcal.budget.lab import load_lab
from accelcal.methods.response import reduce
from accelcal.rigs.shaker_response import DutResponse, ResponseRig, default_reference
from helpers.paths import ROOT

LAB = ROOT / "examples" / "lab.toml"
TRIALS = 300
SEED = 20261126


def _draw(std, rng, size=None):
    """Draws of a lab standard (value + error of its distribution), in its own unit."""
    a = {"rectangular": np.sqrt(3.0), "normal": None}[std.distribution]
    if a is None:
        return std.value + std.u * rng.standard_normal(size)
    return std.value + std.u * a * rng.uniform(-1.0, 1.0, size)


def campaign(lab, reference, rng):
    """One simulated campaign: its records (stating the certificate) and the DUT's truth.

    The transverse and relative motion and the distortion change with
    frequency (the shaker's and the mounting's modes): each step has its own
    draw, a record of its own; the rest is common to the campaign.
    """
    s = lab.standards
    e_mag, e_phase = rng.standard_normal(2)
    true_ref = dataclasses.replace(
        reference,
        magnitude=tuple(m + e_mag * u / 2 for m, u in zip(reference.magnitude,
                                                           reference.magnitude_U, strict=True)),
        phase_deg=tuple(p + e_phase * u / 2 for p, u in zip(reference.phase_deg,
                                                            reference.phase_U, strict=True)))
    s_t = _draw(s["transverse_sensitivity"], rng) / 100.0
    dt = _draw(s["sensor_temperature"], rng) - 23.0
    alpha = _draw(s["sensitivity_tc"], rng) * 1e-6
    gain = _draw(s["daq_gain_mismatch"], rng) * 1e-6
    delay = _draw(s["daq_delay_mismatch"], rng) * 1e-9
    df = _draw(s["frequency"], rng) * 1e-6
    nominal = DutResponse()
    warm = dataclasses.replace(nominal, S0=nominal.S0 * (1 + alpha * dt))
    records = []
    for f in ResponseRig().frequencies:
        motion = {q: _draw(s[q], rng, 2) / 100.0 for q in ("transverse_motion",
                                                             "relative_motion")}
        rig = ResponseRig(reference=true_ref, gain_ratio=1.0 + gain, delay_s=delay,
                          distortion=tuple(np.abs(_draw(s["distortion"], rng, 2)) / 100.0),
                          transverse=tuple(motion["transverse_motion"]),
                          transverse_sensitivity=s_t,
                          relative_motion=tuple(motion["relative_motion"]),
                          frequencies=(f * (1 + df),))
        rec = rig.simulate(warm, seed=rng)
        records.append(dataclasses.replace(
            rec, frequency=np.full(rec.frequency.size, f), metadata={
                **rec.metadata, "reference": reference.to_dict(),
                "daq": {"gain_ratio": 1.0, "delay_s": 0.0}}))
    return records, nominal


def coverage(reference, trials=TRIALS, seed=SEED):
    """Per point and trial: (error / u_c, |error| <= U) of magnitude (%) and phase (deg)."""
    lab = load_lab(LAB)
    rng = np.random.default_rng(seed)
    out = {"magnitude": ([], []), "phase": ([], [])}
    for _ in range(trials):
        rec, dut = campaign(lab, reference, rng)  # the step records
        red = reduce(rec)
        f = np.asarray(red.observations["frequency_hz"])
        truth = dut(f)
        by = {b.coefficient: b for b in budgets(red, lab, records=rec)}
        for name, value, true in zip(red.estimate.names, red.estimate.values, truth,
                                     strict=True):
            errors = {"magnitude": (abs(value) / abs(true) - 1) * 100,
                      "phase": np.rad2deg(np.angle(value / true))}
            for part, err in errors.items():
                b = by[f"{name} {part}"]
                out[part][0].append(err / b.u_c)
                out[part][1].append(abs(err) <= b.U)
    return {part: (float(np.std(z)), float(np.mean(hit))) for part, (z, hit) in out.items()}


PRIMARY = dataclasses.replace(  # a reference calibrated by laser to 0.1 % and 0.1 deg (k = 2)
    default_reference(), magnitude_U=tuple(m * 0.001 for m in default_reference().magnitude),
    phase_U=tuple(0.1 for _ in default_reference().phase_U))


@pytest.mark.slow
def test_budget_covers_the_truth_at_the_default_settings():
    """The default reference (U = 0.5 %, 0.5 deg) dominates: a near-normal output."""
    result = coverage(default_reference())
    print(f"\n{TRIALS} campaigns x 11 points, seed {SEED}: " + "; ".join(
        f"{part}: SD ratio {sd:.3f}, coverage {cov:.3f}" for part, (sd, cov) in result.items()))
    for part, (sd, cov) in result.items():
        assert 0.93 <= cov <= 0.97, (part, cov)
        assert 0.9 <= sd <= 1.1, (part, sd)


@pytest.mark.slow
def test_budget_covers_the_truth_with_a_primary_reference():
    """A reference of 0.1 %, 0.1 deg: the motions and the delay mismatch weigh.

    The relative motion's rectangular input is then half the magnitude's
    variance and the transverse motion's an eighth: ``k = 2`` on a sum so
    near a uniform one may over-cover (a uniform's 95.45 % interval is
    ``1.65 u``), as ``--check mc`` shows: the coverage is allowed to 0.99;
    the SD ratio stays near 1.
    """
    trials = 200
    result = coverage(PRIMARY, trials=trials)
    print(f"\n{trials} campaigns x 11 points, seed {SEED}: " + "; ".join(
        f"{part}: SD ratio {sd:.3f}, coverage {cov:.3f}" for part, (sd, cov) in result.items()))
    for part, (sd, cov) in result.items():
        assert 0.93 <= cov <= 0.99, (part, cov)
        assert 0.9 <= sd <= 1.1, (part, sd)
