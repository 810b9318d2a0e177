"""The stepped-sine comparison against independent routes, and its stated uncertainty.

- the closed form of the simulated system: a noise-free record (with an extra
  pole, a delay, the DAQ's mismatch and the shaker's distortion) gives the
  DUT's transfer function at every step to rounding;
- a time-domain simulation: the DUT channel made by ``scipy.signal.lsim`` of
  the transfer function written out here (not the rig's closed form),
  driven by the same sine, its transient discarded;
- a modest Monte Carlo (slow): the stated uncertainties of magnitude and
  phase of each step, and of fn and zeta of the fit, against the scatter.
"""

import numpy as np
import pytest
from scipy import signal

from accelcal.io.formats.response import ResponseRecord, read, write
from accelcal.methods.response import fit_model, reduce, reduce_stepped, response_rows
from accelcal.rigs.shaker_response import (
    DutResponse,
    ReferenceTable,
    default_reference,
    simulate,
)


def _closed(f, s0, fn, zeta, *, pole=None, delay=0.0):
    """The DUT's sensitivity, written out: s = i w."""
    s = 2j * np.pi * np.asarray(f)
    wn = 2 * np.pi * fn
    h = s0 * wn**2 / (s**2 + 2 * zeta * wn * s + wn**2)
    if pole is not None:
        h = h / (1 + s / (2 * np.pi * pole))
    return h * np.exp(-s * delay)


def test_noise_free_record_gives_the_transfer_function_to_rounding(tmp_path):
    dut = DutResponse(S0=1.3, fn_hz=700.0, zeta=0.45, pole_hz=2500.0, delay_s=3e-5)
    rec = simulate(dut, noise=0.0, gain_ratio=1.02, delay_s=4e-6, distortion=(0.03, 0.01),
                   seed=0)
    write(tmp_path / "r.csv", rec)
    red = reduce(tmp_path / "r.csv")
    f = red.observations["frequency_hz"]
    want = _closed(f, 1.3, 700.0, 0.45, pole=2500.0, delay=3e-5)
    got = red.estimate.values
    assert np.max(np.abs(got - want) / np.abs(want)) < 1e-12
    assert red.estimate.names[3] == "S(80 Hz)"
    assert red.estimate.units["S(80 Hz)"] == "V/g"
    rows = response_rows(red)
    at80 = next(r for r in rows if r["frequency_hz"] == 80.0)
    assert at80["deviation_pct"] == 0.0
    assert at80["deviation_db"] == 0.0
    top = rows[-1]
    ratio = abs(want[-1]) / abs(want[3])
    assert top["deviation_pct"] == pytest.approx(100 * (ratio - 1), rel=1e-10)
    assert top["deviation_db"] == pytest.approx(20 * np.log10(ratio), rel=1e-10)
    assert top["phase_deg"] == pytest.approx(np.rad2deg(np.angle(want[-1])), abs=1e-9)


def test_without_the_daq_correction_the_mismatch_shows():
    rec = simulate(DutResponse(), noise=0.0, gain_ratio=1.02, delay_s=4e-6, seed=0)
    meta = {k: v for k, v in rec.metadata.items() if k != "daq"}
    plain = ResponseRecord(rec.step, rec.frequency, rec.t, rec.ref, rec.dut,
                           rec.sample_rate_hz, metadata=meta)
    red = reduce_stepped(plain)
    f = red.observations["frequency_hz"]
    want = DutResponse()(f) * 1.02 * np.exp(-2j * np.pi * f * 4e-6)
    assert np.max(np.abs(red.estimate.values - want) / np.abs(want)) < 1e-12


def test_time_domain_simulation_by_lsim():
    """The DUT channel from scipy.signal.lsim of the written-out transfer function."""
    s0, fn, zeta, delay = 1.1, 800.0, 0.5, 2e-5
    wn = 2 * np.pi * fn
    system = signal.lti([s0 * wn**2], [1.0, 2 * zeta * wn, wn**2])
    table = default_reference()
    fs, fine, settle = 20000.0, 50, 0.02
    cols = {k: [] for k in ("step", "frequency", "t", "ref", "dut")}
    freqs = (40.0, 315.0, 1000.0)
    for k, f in enumerate(freqs):
        n_settle, n = round(settle * fs), round(10 * fs / f)
        t_fine = np.arange((n_settle + n) * fine) / (fs * fine)
        acc = np.sin(2 * np.pi * f * (t_fine - delay)) * (t_fine >= delay)
        _, out, _ = signal.lsim(system, acc, t_fine)
        t = t_fine[::fine][n_settle:]
        sref = table.sensitivity(f)[0]
        cols["ref"].append(abs(sref) * np.sin(2 * np.pi * f * t + np.angle(sref)))
        cols["dut"].append(out[::fine][n_settle:])
        cols["t"].append(t)
        cols["step"].append(np.full(n, k))
        cols["frequency"].append(np.full(n, f))
    rec = ResponseRecord(**{c: np.concatenate(v) for c, v in cols.items()}, sample_rate_hz=fs)
    red = reduce_stepped(rec, table)
    want = _closed(freqs, s0, fn, zeta, delay=delay)
    # lsim interpolates the input linearly between its samples (1 MHz here): an error of
    # about (w dt)^2 / 12 relative, below 4e-6 at 1 kHz.
    assert np.max(np.abs(red.estimate.values - want) / np.abs(want)) < 2e-5


def test_a_given_reference_table_replaces_the_records_own():
    rec = simulate(DutResponse(), noise=0.0, seed=0)
    ref = default_reference()
    doubled = ReferenceTable(ref.frequency_hz, tuple(2 * m for m in ref.magnitude),
                             ref.phase_deg)
    a, b = reduce_stepped(rec), reduce_stepped(rec, doubled)
    np.testing.assert_allclose(b.estimate.values, 2 * a.estimate.values, rtol=1e-13)
    assert b.assumed("reference") == "given"


def test_csv_and_parquet_round_trip(tmp_path):
    rec = simulate(DutResponse(), noise=1e-4, seed=3, frequencies=(20.0, 200.0))
    for name in ("r.csv", "r.parquet"):
        write(tmp_path / name, rec)
        back = read(tmp_path / name)
        np.testing.assert_array_equal(back.dut, rec.dut)
        assert back.metadata["true"] == rec.metadata["true"]
        assert [s.stop - s.start for s in back.steps] == [s.stop - s.start for s in rec.steps]


@pytest.mark.slow
def test_stated_uncertainty_covers_magnitude_phase_fn_zeta():
    """200 noisy records of one DUT: the scatter against the mean stated SD, and coverage."""
    dut = DutResponse(S0=1.3, fn_hz=600.0, zeta=0.6)
    runs = 200
    z_mag, z_phase, z_fit = [], [], []
    for seed in range(runs):
        red = reduce_stepped(simulate(dut, noise=2e-3, seed=seed))
        f = red.observations["frequency_hz"]
        pol = red.estimate.polar()
        want = dut(f)
        z_mag.append((pol.magnitude - np.abs(want)) / pol.magnitude_std)
        z_phase.append(np.angle(np.exp(1j * (pol.phase - np.angle(want)))) / pol.phase_std)
        fit = fit_model(red)
        z_fit.append([(fit.value(n) - v) / fit.std(n) for n, v in (("fn", 600.0),
                                                                    ("zeta", 0.6))])
    for z in (np.ravel(z_mag), np.ravel(z_phase), *np.transpose(z_fit)):
        assert 0.85 < np.std(z) < 1.15
        assert 0.92 < np.mean(np.abs(z) < 1.96) < 0.98
