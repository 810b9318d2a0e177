"""The blockwise sine fit (issue 16): same answers as curve_fit and the explicit design.

Behaviour only; the timing (within a few reads of the array) lives in
benchmarks/reduce.py.
"""

import numpy as np
import pytest
from scipy.optimize import curve_fit

from accelcal.signal import sinefit
from accelcal.signal.sinefit import HarmonicFit, sine_fit3


def _explicit_design(n, fs, f, harmonics, t0):
    t = t0 + np.arange(n) / fs
    cols = [np.ones(n)]
    for k in range(1, harmonics + 1):
        cols += [np.cos(2 * np.pi * k * f * t), np.sin(2 * np.pi * k * f * t)]
    return np.stack(cols, axis=1)


@pytest.mark.parametrize(("fs", "f", "n", "t0", "coherent"), [
    (20_000.0, 137.0, 200_000, 0.0, True),        # 137 periods in 20000 samples: folded
    (20_000.0, 137.1234, 200_003, 0.25, False),   # no short whole number of periods
    (2000.0, 51.37, 123_457, 1.5, False),
])
def test_agrees_with_curve_fit_to_1e_10(fs, f, n, t0, coherent):
    rng = np.random.default_rng(4)
    t = t0 + np.arange(n) / fs
    y = 0.1 + 1.3 * np.sin(2 * np.pi * f * t + 0.7) + rng.normal(0, 1e-3, n)
    r = sine_fit3(y, fs, f, t0=t0)
    assert bool(HarmonicFit(n, fs, f, t0=t0).fold) is coherent

    def model(tt, c, a, b):
        return c + a * np.cos(2 * np.pi * f * tt) + b * np.sin(2 * np.pi * f * tt)

    # A linear model: Levenberg-Marquardt converges to the least-squares
    # solution to rounding with tight tolerances; both then carry only the
    # rounding of the design's phases (~eps 2 pi f t ~ 1e-12 rad here).
    popt, pcov = curve_fit(model, t, y, p0=(0.0, 0.0, 1.0), xtol=1e-15, ftol=1e-15, gtol=1e-15)
    scale = np.max(np.abs(popt))
    np.testing.assert_allclose(r.parameters, popt, rtol=0, atol=1e-10 * scale)
    # same covariance s^2 (D'D)^-1 (curve_fit's Jacobian is finite-difference: 1e-5 of
    # the variances; the covariances are ~0 for whole periods)
    np.testing.assert_allclose(r.covariance, pcov, rtol=0, atol=1e-5 * np.max(np.diag(pcov)))


@pytest.mark.parametrize(("fs", "f", "n", "harmonics", "t0"), [
    (20_000.0, 137.0, 50_017, 2, 0.3),   # folded, with a partial last fold
    (2000.0, 37.0, 333, 1, 0.0),         # one block
    (1000.0, 147.2435727, 25_310, 2, 0.06),  # rotated blocks and a partial block
])
def test_design_and_normal_matrix_match_the_explicit_design(fs, f, n, harmonics, t0):
    fit = HarmonicFit(n, fs, f, harmonics=harmonics, t0=t0)
    d = _explicit_design(n, fs, f, harmonics, t0)
    # The explicit design's phases 2 pi k f t carry a few eps of rounding relative to their
    # size (1e-11 rad at 4.6e4 rad); the blockwise one reduces them to [0, 1) cycles first.
    largest_phase = 2 * np.pi * harmonics * f * (t0 + n / fs)
    np.testing.assert_allclose(fit.design, d, rtol=0, atol=8 * np.finfo(float).eps * largest_phase)
    # sums of n terms of size 1: rounding ~ sqrt(n) eps each way, far below 1e-12 n
    np.testing.assert_allclose(fit.gram, d.T @ d, rtol=0, atol=1e-12 * n)
    y = np.random.default_rng(1).normal(size=(2, 3, n))
    np.testing.assert_allclose(fit._sums.sums(fit._folded(y)), y @ d, rtol=0, atol=1e-9)


def test_fit_keeps_no_per_sample_arrays():
    # O(sqrt(n)) set-up: nothing of n elements is kept (the design is built on request).
    n = 4_000_000
    fit = HarmonicFit(n, 10_000.0, 13.1234567)
    kept = [v for v in vars(fit._sums).values() if isinstance(v, np.ndarray)]
    kept += [fit.gram, fit.cov_unit]
    assert max(a.size for a in kept) < 20 * np.sqrt(n)


def test_records_of_one_time_base_share_one_fit():
    sinefit._cached_fit.cache_clear()
    t = np.arange(4000) / 2000.0
    for phase in (0.1, 0.2, 0.3):
        r = sine_fit3(np.sin(2 * np.pi * 50.0 * t + phase), 2000.0, 50.0)
        assert float(r.phase) == pytest.approx(phase, abs=1e-12)
    info = sinefit._cached_fit.cache_info()
    assert (info.hits, info.misses) == (2, 1)
    with pytest.raises(ValueError, match="read-only"):
        r.cov_unit[0, 0] = 1.0  # shared with the cached fit: not writable


def test_leading_axes_and_non_contiguous_records_match_one_by_one():
    rng = np.random.default_rng(2)
    n, fs, f = 10_001, 5000.0, 61.3
    y = rng.normal(size=(3, 2 * n))[:, ::2] + np.sin(2 * np.pi * f * np.arange(n) / fs)
    fit = HarmonicFit(n, fs, f, harmonics=2)
    together = fit(y)
    for i in range(3):
        one = fit(np.ascontiguousarray(y[i]))
        np.testing.assert_allclose(together.parameters[i], one.parameters, rtol=1e-13)
        np.testing.assert_allclose(together.residual_std[i], one.residual_std, rtol=1e-12)
