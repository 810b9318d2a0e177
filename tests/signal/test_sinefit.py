"""Sine fits (IEEE 1057 three- and four-parameter) against scipy and Monte Carlo."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import curve_fit

from accelcal.errors import AccelcalError
from accelcal.signal.sinefit import HarmonicFit, sine_fit3, sine_fit4

FS = 2000.0


def _signal(t, amp, phase, dc, f, *, a2=0.0, p2=0.0):
    return (amp * np.sin(2 * np.pi * f * t + phase) + dc
            + a2 * np.sin(4 * np.pi * f * t + p2))


@settings(max_examples=40, deadline=None)
@given(
    amp=st.floats(1e-3, 1e3),
    phase=st.floats(-np.pi, np.pi),
    dc=st.floats(-10, 10),
    f=st.floats(20.0, 300.0),
    periods=st.floats(1.0, 7.5),
    t0=st.floats(0.0, 0.1),
)
def test_three_parameter_fit_is_exact_without_noise(*, amp, phase, dc, f, periods, t0):
    # Any phase, whole or partial periods, any start time: the least-squares
    # solution of a noise-free sine is the sine itself; rounding only, so
    # 1e-9 relative to the amplitude (conditioning of short partial records).
    n = int(np.ceil(periods * FS / f))
    t = t0 + np.arange(n) / FS
    r = sine_fit3(_signal(t, amp, phase, dc, f), FS, f, t0=t0)
    scale = amp + abs(dc)
    assert abs(r.amplitude - amp) <= 1e-9 * scale
    assert abs(r.dc - dc) <= 1e-9 * scale
    # phasor convention: A sin(wt + phi) <-> P = A exp(i(phi - pi/2))
    p = amp * np.exp(1j * (phase - np.pi / 2))
    assert abs(r.phasors[0] - p) <= 1e-9 * scale


def test_dc_w_2w_phasors_and_leading_axes():
    f, n = 50.0, 400
    t = np.arange(n) / FS
    amps = np.array([[1.0, 2.0], [3.0, 4.0]])
    y = _signal(t, amps[..., None], 0.4, 0.7, f, a2=0.25, p2=-1.0)
    fit = HarmonicFit(n, FS, f, harmonics=2)
    r = fit(y)
    assert r.phasors.shape == (2, 2, 2)
    # noise-free: exact to rounding (1e-13 relative to the largest amplitude 4)
    np.testing.assert_allclose(r.amplitude, amps, rtol=0, atol=4e-13)
    np.testing.assert_allclose(np.abs(r.phasors[..., 1]), 0.25, rtol=0, atol=4e-13)
    np.testing.assert_allclose(np.angle(r.phasors[..., 1]), -1.0 - np.pi / 2, atol=1e-11)
    np.testing.assert_allclose(r.dc, 0.7, rtol=0, atol=4e-13)


def test_three_parameter_fit_matches_curve_fit_on_noisy_records():
    # Both minimise the same sum of squares; curve_fit iterates to its own
    # tolerance, so agreement to 1e-7 relative on the amplitude is expected.
    rng = np.random.default_rng(11)
    f, n = 37.0, 333  # partial last period
    t = np.arange(n) / FS
    y = _signal(t, 1.7, 0.9, -0.2, f) + rng.normal(0, 0.05, n)
    r = sine_fit3(y, FS, f)

    def model(tt, a, b, c):
        return a * np.cos(2 * np.pi * f * tt) + b * np.sin(2 * np.pi * f * tt) + c

    popt, pcov = curve_fit(model, t, y, p0=[0.0, 1.0, 0.0])
    np.testing.assert_allclose(r.parameters[[1, 2, 0]], popt, rtol=1e-7, atol=1e-9)
    # and the covariance is the same s^2 (D'D)^-1
    np.testing.assert_allclose(r.covariance[np.ix_([1, 2, 0], [1, 2, 0])], pcov, rtol=1e-5)


def test_amplitude_std_matches_monte_carlo_scatter():
    rng = np.random.default_rng(5)
    f, n, sigma, trials = 40.0, 250, 0.1, 4000
    t = np.arange(n) / FS
    y = _signal(t, 1.0, 0.3, 0.0, f) + rng.normal(0, sigma, (trials, n))
    r = sine_fit3(y, FS, f)
    # 4000 trials: the sample standard deviation is within ~5 % (3 sigma of
    # its 1.1 % relative error) of the true one.
    assert np.std(r.amplitude) == pytest.approx(np.mean(r.amplitude_std), rel=0.05)
    # whole periods: var(A) ~ 2 sigma^2 / n (IEEE 1057 sec. 4.1.3.1 analysis)
    assert np.mean(r.amplitude_std) == pytest.approx(sigma * np.sqrt(2 / n), rel=0.03)
    assert np.mean(r.residual_std) == pytest.approx(sigma, rel=0.01)


def test_four_parameter_fit_recovers_frequency():
    f, n = 51.37, 1000
    t = np.arange(n) / FS
    y = _signal(t, 2.0, 0.3, 0.5, f)
    r = sine_fit4(y, FS)
    # noise-free: Gauss-Newton converges to the exact frequency (1e-9 relative)
    assert r.frequency == pytest.approx(f, rel=1e-9)
    assert float(r.amplitude) == pytest.approx(2.0, rel=1e-9)
    assert float(r.phase) == pytest.approx(0.3, abs=1e-8)


def test_four_parameter_fit_matches_curve_fit_with_noise_vectorised():
    rng = np.random.default_rng(3)
    n = 800
    t = np.arange(n) / FS
    freqs = np.array([48.0, 52.5, 61.2])
    y = 1.5 * np.sin(2 * np.pi * freqs[:, None] * t + 0.2) + rng.normal(0, 0.02, (3, n))
    r = sine_fit4(y, FS)

    def model(tt, c, a, b, f):
        return c + a * np.cos(2 * np.pi * f * tt) + b * np.sin(2 * np.pi * f * tt)

    for k in range(3):
        p0 = [0, r.parameters[k, 1], r.parameters[k, 2], freqs[k]]
        popt, pcov = curve_fit(model, t, y[k], p0=p0)
        # same least-squares problem: agreement far inside the uncertainty
        assert r.frequency[k] == pytest.approx(popt[3], abs=0.01 * np.sqrt(pcov[3, 3]))
        assert np.sqrt(r.cov_unit[k, 3, 3]) * r.residual_std[k] == pytest.approx(
            np.sqrt(pcov[3, 3]), rel=1e-3)


def test_errors_are_clear():
    with pytest.raises(AccelcalError, match="shorter than one period"):
        HarmonicFit(30, FS, 50.0)
    with pytest.raises(AccelcalError, match="Nyquist"):
        HarmonicFit(400, FS, 600.0, harmonics=2)
    with pytest.raises(AccelcalError, match="expects 400"):
        HarmonicFit(400, FS, 50.0)(np.zeros(399))
    with pytest.raises(AccelcalError, match="positive"):
        HarmonicFit(400, -1.0, 50.0)


@pytest.mark.parametrize("noise", [0.0, 1e-7, 1e-3, 0.3])
def test_residual_std_matches_direct_residuals(noise):
    # The fast r'r identity (noisy records) and the direct fallback (nearly
    # noise-free ones) both agree with residuals computed explicitly.
    n, fs, f = 4000, 2000.0, 37.0
    rng = np.random.default_rng(8)
    t = np.arange(n) / fs
    y = 0.2 + 1.5 * np.sin(2 * np.pi * f * t + rng.uniform(0, 6, (5, 1)))
    y = y + rng.normal(0, noise, (5, n))
    fit = HarmonicFit(n, fs, f)
    res = fit(y)
    direct = y - res.parameters @ fit.design.T
    expected = np.sqrt((direct**2).sum(axis=-1) / res.dof)
    # Noisy: the identity's rounding is ~1e-17 y'y, far below 1e-9 of r'r.
    # Noise-free: residuals are rounding (~1e-15 of the signal).
    np.testing.assert_allclose(res.residual_std, expected, rtol=1e-6, atol=1e-14)
