"""Whole periods of a sampled sinusoidal record, and their mean.

A record sampled at ``fs`` of a vibration at ``f`` covers whole periods
exactly when the number of samples used, ``M``, spans an integer number of
periods ``k``: ``M = k fs / f``. Over such a span the sampled mean of every
harmonic of ``f`` below the Nyquist limit is zero whatever the starting
phase, so the whole-period mean removes the vibration exactly.

References
----------
.. [IEEE1057] IEEE Std 1057-2017, Standard for Digitizing Waveform
   Recorders, sec. 4.1 (record length, coherent sampling).
"""

import math
from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError

RATIO_TOL = 1e-6
"""Tolerance, in samples, for k fs / f to count as a whole number of samples."""


@dataclass(frozen=True)
class PeriodMean:
    """Whole-period mean of a record with its standard uncertainty.

    Attributes
    ----------
    mean : float or numpy.ndarray
        Mean over the whole periods used (one per leading index).
    std : float or numpy.ndarray
        Standard uncertainty of the mean for white noise: the residual
        standard deviation after removing the periodic signal, over sqrt(M).
        When the sampled phases repeat within the span (``fs / f`` rational),
        the periodic signal of every harmonic order is removed by synchronous
        averaging; otherwise harmonics 0..H of ``f`` are removed by a fit.
    periods : int
        Whole periods used.
    samples : int
        Samples used (``periods * fs / f``).
    discarded : int
        Samples of the record left out at its end (a partial period).
    """

    mean: np.ndarray | float
    std: np.ndarray | float
    periods: int
    samples: int
    discarded: int


def check_sampling(
    samples: int, fs: float, f: float, *, harmonics: int = 1, what: str = "record"
) -> None:
    """Check that a record can carry ``harmonics`` of ``f``: rates, Nyquist, one period.

    Raises
    ------
    AccelcalError
        For a non-positive or non-finite sample rate or frequency, a
        harmonic at or above the Nyquist frequency, or fewer samples than one
        period; the message says how to fix it.
    """
    if not (np.isfinite(fs) and fs > 0):
        raise AccelcalError(f"{what}: sample rate {fs} Hz must be positive and finite")
    if not (np.isfinite(f) and f > 0):
        raise AccelcalError(f"{what}: frequency {f} Hz must be positive and finite")
    if 2 * harmonics * f >= fs:
        which = f"harmonic {harmonics} of {f} Hz" if harmonics > 1 else f"frequency {f} Hz"
        raise AccelcalError(
            f"{what}: {which} is not below the Nyquist frequency {fs / 2} Hz; "
            "raise the sample rate"
        )
    per_period = fs / f
    if samples < per_period * (1 - 1e-9):
        raise AccelcalError(
            f"{what}: {samples} samples is shorter than one period of {f} Hz at {fs} Hz "
            f"({per_period:g} samples); record at least one whole period"
        )


def whole_period_samples(
    n_samples: int, fs: float, f: float, *, what: str = "record"
) -> tuple[int, int]:
    """The longest whole-period span of a record: ``(periods, samples)``.

    Parameters
    ----------
    n_samples : int
        Samples in the record.
    fs : float
        Sample rate, Hz.
    f : float
        Vibration frequency, Hz.
    what : str
        Name of the record, used in error messages.

    Raises
    ------
    AccelcalError
        If the record is shorter than one period, or no whole number of
        periods within it is a whole number of samples (``fs / f`` is not a
        ratio of small integers); the message says how to fix it.
    """
    check_sampling(n_samples, fs, f, what=what)
    per_period = fs / f
    max_periods = max(1, int(np.floor(n_samples / per_period + 1e-9)))
    k = np.arange(max_periods, 0, -1)
    span = k * per_period
    ok = np.abs(span - np.round(span)) <= RATIO_TOL
    if not ok.any():
        raise AccelcalError(
            f"{what}: no whole number of periods of {f} Hz within {n_samples} samples at "
            f"{fs} Hz is a whole number of samples (fs/f = {per_period!r}); choose fs/f "
            "rational with a small denominator, or record more periods"
        )
    periods = int(k[ok][0])
    return periods, int(np.round(periods * per_period))


def whole_period_mean(
    record, fs: float, f: float, *, harmonics: int = 3, what: str = "record"
) -> PeriodMean:
    """Mean of a record over its longest whole-period span, with uncertainty.

    The record need not start at phase zero. Samples after the last whole
    period are discarded (and counted in the result).

    Parameters
    ----------
    record : array_like, shape (..., n)
        Samples; leading axes are independent records of the same length.
    fs, f : float
        Sample rate and vibration frequency, Hz.
    harmonics : int
        Harmonics of ``f`` removed before estimating the noise level when the
        sampled phases do not repeat within the span (the mean is unaffected
        by this choice).
    what : str
        Name of the record for error messages.

    Returns
    -------
    PeriodMean

    Raises
    ------
    AccelcalError
        For non-finite samples, or a record without a whole-period span.
    """
    x = np.asarray(record, dtype=float)
    if x.ndim == 0 or x.shape[-1] == 0:
        raise AccelcalError(f"{what}: the record is empty")
    if not np.isfinite(x).all():
        bad = int(np.flatnonzero(~np.isfinite(x.reshape(-1)))[0])
        raise AccelcalError(f"{what}: sample {bad} is not finite; remove or repair it")
    periods, m = whole_period_samples(x.shape[-1], fs, f, what=what)
    used = x[..., :m]
    mean = used.mean(axis=-1)
    s = _synchronous_residual_std(used, periods)
    if s is None:
        s = _harmonic_residual_std(used, fs, f, harmonics, what)
    std = s / np.sqrt(m)
    if x.ndim == 1:
        mean, std = float(mean), float(std)
    return PeriodMean(mean=mean, std=std, periods=periods, samples=m, discarded=x.shape[-1] - m)


def _synchronous_residual_std(used: np.ndarray, periods: int) -> np.ndarray | None:
    """Noise SD after subtracting the mean of each sampled phase across its repeats.

    Over a span of ``m`` samples and ``k`` periods the sampled phases repeat
    every ``q = m / gcd(m, k)`` samples. Subtracting each phase's mean over
    its ``R = m / q`` repeats removes the periodic signal of every harmonic
    order (a sign term has all of them), leaving the noise with ``m - q``
    degrees of freedom. None when the phases do not repeat (``R < 2``).
    """
    m = used.shape[-1]
    q = m // math.gcd(m, periods)
    repeats = m // q
    if repeats < 2:
        return None
    folded = used.reshape(*used.shape[:-1], repeats, q)
    resid = folded - folded.mean(axis=-2, keepdims=True)
    return np.sqrt((resid**2).sum(axis=(-2, -1)) / (m - q))


def _harmonic_residual_std(used, fs, f, harmonics, what) -> np.ndarray:
    """Noise SD after a least-squares fit of harmonics 0..H of ``f``."""
    m = used.shape[-1]
    h = max(0, min(int(harmonics), (m - 2) // 2))
    t = np.arange(m) / fs
    cols = [np.ones(m)]
    for k in range(1, h + 1):
        cols += [np.cos(2 * np.pi * k * f * t), np.sin(2 * np.pi * k * f * t)]
    design = np.stack(cols, axis=1)
    dof = m - design.shape[1]
    if dof < 1:
        raise AccelcalError(f"{what}: {m} samples are too few to estimate the noise level")
    coef, *_ = np.linalg.lstsq(design, used.reshape(-1, m).T, rcond=None)
    resid = used.reshape(-1, m).T - design @ coef
    return np.sqrt((resid**2).sum(axis=0) / dof).reshape(used.shape[:-1])
