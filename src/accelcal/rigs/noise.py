"""Still recordings of an accelerometer with the IEEE 952 noise terms, of known coefficients.

:func:`simulate` returns a :class:`~accelcal.io.formats.noise.NoiseRecord`;
:func:`simulate_blocks` yields the same samples block by block (the state of
every generator carried across blocks), so a record of 1e8 samples is
written to Parquet in bounded memory (:func:`accelcal.io.formats.noise.write_blocks`).
The samples are, at ``tau0 = 1 / rate`` (seconds) and sample ``i``::

    y_i = bias + N / sqrt(tau0) w_i                       white (velocity random walk)
          + Q / tau0 (u_{i+1} - u_i)                      quantisation (white phase, differenced)
          + sum_j g_{j,i}                                 bias instability (Gauss-Markov sum)
          + K sqrt(tau0) sum_{k <= i} v_k                 acceleration random walk
          + R i tau0                                      ramp

with ``w, u, v`` independent standard normal sequences. The Allan variances
they give (IEEE 952 Annex C, Eq. (C.1)-(C.5) [IEEE952]_)::

    3 Q^2 / tau^2,   N^2 / tau,   (2 ln 2 / pi) B^2,   K^2 tau / 3,   R^2 tau^2 / 2

exactly for Q, N and R; the sampled random walk adds ``K^2 tau0^2 / (6 tau)``
(a white-noise share, ``(2 m^2 + 1) / (2 m^2)`` of ``K^2 tau / 3`` at
``tau = m tau0``, derived in ``tests/methods/noise/test_noise_rig.py``).

Bias instability model (stated)
    A sum of first-order Gauss-Markov (AR(1)) processes with correlation
    times ``T_j`` two per decade from ``T_min`` to ``T_max``, equal
    variances ``v``: their spectrum is 1/f between ``1 / (2 pi T_max)`` and
    ``1 / (2 pi T_min)``. One process of variance ``v`` and correlation time
    ``T`` has ``AVAR(tau) = v (2x - 3 + 4 e^-x - e^-2x) / x^2``, ``x = tau / T``
    (:func:`gauss_markov_avar`). ``v`` is calibrated so that the mean Allan
    variance over log-spaced taus of the flat range equals
    ``(2 ln 2 / pi) B^2`` (ADEV floor 0.664 B); ``T_min = tau_lo / 15`` and
    ``T_max = 5 tau_hi``, and between ``tau_lo`` and ``tau_hi`` the Allan
    variance stays within 5 % of the floor (``B_RANGE_RIPPLE``; 2.5 % in
    deviation). Defaults: ``tau_lo = 30 tau0``, ``tau_hi`` the duration.

References
----------
.. [IEEE952] IEEE Std 952-1997, Specification Format Guide and Test Procedure
   for Single-Axis Interferometric Fiber Optic Gyros, Annex C (Allan variance
   of the noise terms).
.. [ElSheimy2008] El-Sheimy N., Hou H., Niu X., Analysis and modeling of
   inertial sensors using Allan variance, IEEE Trans. Instrum. Meas. 57(1),
   2008, 140-149 (Gauss-Markov bias model).
.. [Riley2008] Riley W. J., Handbook of Frequency Stability Analysis, NIST
   Special Publication 1065, 2008 (noise simulation).
"""

import math

import numpy as np

from accelcal.errors import AccelcalError

TERMS = ("Q", "N", "B", "K", "R")
"""The IEEE 952 terms, in order of the power of tau (-2 .. 2)."""

B_RANGE_RIPPLE = 0.05
"""Largest relative departure of the Gauss-Markov sum's Allan variance from the floor
``(2 ln 2 / pi) B^2`` between ``tau_lo`` and ``tau_hi`` (checked in the tests)."""

PER_DECADE = 2
"""Gauss-Markov processes per decade of correlation time."""

DEFAULT_BLOCK = 1_000_000
"""Samples per generated block."""

MAX_TERM = 1e9
"""Largest size of the samples one term may make (1000x below the largest value a
noise record holds, :data:`accelcal.io.formats.noise.MAX_VALUE`, for the tails)."""

MAX_SAMPLES = 10**10
"""Most samples a simulation may have (an hour at 2.7 MHz, or 115 days at 1 kHz)."""


def gauss_markov_avar(tau, variance: float, corr_time: float) -> np.ndarray:
    """Allan variance of a first-order Gauss-Markov process (continuous time).

    ``AVAR = v (2x - 3 + 4 e^-x - e^-2x) / x^2`` with ``x = tau / T``
    (from ``Var(ybar) - Cov(ybar_1, ybar_2)`` of an exponential
    autocovariance ``v e^{-|t|/T}``) [ElSheimy2008]_.

    Parameters
    ----------
    tau : array_like
        Averaging times, s.
    variance : float
        Stationary variance ``v``.
    corr_time : float
        Correlation time ``T``, s.

    Returns
    -------
    numpy.ndarray
    """
    x = np.asarray(tau, dtype=float) / corr_time
    small = x < 1e-3
    xs = np.where(small, 1.0, x)
    exact = (2 * xs - 3 + 4 * np.exp(-xs) - np.exp(-2 * xs)) / xs**2
    return variance * np.where(small, x / 3 - x**2 / 12, exact)  # series for x -> 0


def bias_model(B: float, rate: float, tau_lo: float, tau_hi: float) -> tuple[np.ndarray, float]:
    """Correlation times and common variance of the Gauss-Markov sum for a floor ``B``.

    Returns
    -------
    corr_times : numpy.ndarray
        ``T_j`` from ``tau_lo / 15`` to ``5 tau_hi``, :data:`PER_DECADE` per decade, s.
    variance : float
        Variance of each process (0 when ``B == 0``).
    """
    t_min, t_max = tau_lo / 15.0, 5.0 * tau_hi
    if not (t_min >= 1.0 / rate and t_max > t_min):
        raise AccelcalError(
            f"the bias-instability range {tau_lo:g}-{tau_hi:g} s needs tau_lo >= 15 / rate "
            f"({15.0 / rate:g} s) and tau_hi > tau_lo / 75", parameter="b_range")
    count = math.ceil(PER_DECADE * math.log10(t_max / t_min)) + 1
    corr = t_min * (t_max / t_min) ** (np.arange(count) / (count - 1))
    taus = np.geomspace(tau_lo, tau_hi, 64)
    floor = np.mean(sum(gauss_markov_avar(taus, 1.0, t) for t in corr))
    return corr, (2 * math.log(2) / math.pi) * B**2 / floor  # Eq. (C.3) [IEEE952]


def check_settings(N, B, K, Q, R, rate, duration, bias):  # noqa: PLR0917
    """Check a simulation's settings; return the number of samples (AccelcalError naming one)."""
    for name, value in (("N", N), ("B", B), ("K", K), ("Q", Q), ("R", R), ("bias", bias)):
        if not math.isfinite(value):
            raise AccelcalError(f"{name} = {value!r} is not finite", parameter=name)
        if name not in {"bias", "R"} and value < 0:
            raise AccelcalError(f"{name} = {value!r} must be >= 0", parameter=name)
    if not (math.isfinite(rate) and rate > 0):
        raise AccelcalError(f"rate = {rate!r} Hz must be positive and finite", parameter="rate")
    if not (math.isfinite(duration) and duration > 0):
        raise AccelcalError(f"duration = {duration!r} s must be positive", parameter="duration")
    n = rate * duration
    if not 4 <= n <= MAX_SAMPLES:
        raise AccelcalError(f"rate x duration = {n:.3g} samples; give 4 to {MAX_SAMPLES:.0e}",
                            parameter="duration")
    # the size of the samples each term makes (a few SDs): the record must hold them
    sizes = {"N": (N, N * math.sqrt(rate)), "B": (B, B), "K": (K, K * math.sqrt(duration)),
             "Q": (Q, Q * rate), "R": (R, abs(R) * duration), "bias": (bias, abs(bias))}
    for name, (value, size) in sizes.items():
        if not size <= MAX_TERM:
            raise AccelcalError(f"{name} = {value!r} makes samples of about {size:.3g}, beyond "
                                f"the {MAX_TERM:g} a still record holds", parameter=name)
    return round(n)


def simulate_blocks(*, N=0.0, B=0.0, K=0.0, Q=0.0, R=0.0, rate, duration, seed=0,
                    bias=0.0, b_range=None, block=DEFAULT_BLOCK):
    """The samples of :func:`simulate`, block by block (bounded memory).

    Parameters
    ----------
    N, B, K, Q, R, rate, duration, seed, bias, b_range
        As :func:`simulate`.
    block : int
        Samples per block.

    Yields
    ------
    numpy.ndarray
        Consecutive blocks of samples (the last may be shorter).
    """
    from scipy.signal import lfilter

    from accelcal.resources import generator

    n = check_settings(N, B, K, Q, R, rate, duration, bias)
    rng = generator(seed)
    tau0 = 1.0 / rate
    corr, var = np.empty(0), 0.0
    if B > 0:
        lo, hi = b_range or (30.0 * tau0, duration)
        corr, var = bias_model(B, rate, lo, hi)
    phi = np.exp(-tau0 / corr)
    gm_state = rng.standard_normal(corr.size) * math.sqrt(var)  # stationary start
    u_prev = rng.standard_normal()
    rw = 0.0
    start = 0
    while start < n:
        size = min(int(block), n - start)
        y = np.full(size, float(bias))
        if N > 0:
            y += N / math.sqrt(tau0) * rng.standard_normal(size)  # Eq. (C.2) [IEEE952]
        if Q > 0:
            u = np.concatenate(([u_prev], rng.standard_normal(size)))
            y += Q / tau0 * np.diff(u)  # Eq. (C.1): white phase noise differenced
            u_prev = u[-1]
        for j in range(corr.size):
            e = rng.standard_normal(size) * math.sqrt(var * (1 - phi[j] ** 2))
            g, _ = lfilter([1.0], [1.0, -phi[j]], e, zi=[phi[j] * gm_state[j]])
            y += g
            gm_state[j] = g[-1]
        if K > 0:
            walk = rw + K * math.sqrt(tau0) * np.cumsum(rng.standard_normal(size))
            y += walk  # Eq. (C.4)
            rw = float(walk[-1])
        if R != 0:
            y += R * tau0 * np.arange(start, start + size)  # Eq. (C.5)
        yield y
        start += size


def simulate(*, N=0.0, B=0.0, K=0.0, Q=0.0, R=0.0, rate, duration, seed=0, bias=0.0,
             unit="g", b_range=None, channel="acc"):
    """A simulated still recording with known IEEE 952 noise coefficients.

    Parameters
    ----------
    N : float
        White noise (velocity random walk), ``unit * sqrt(s)`` (= unit/sqrt(Hz)).
    B : float
        Bias instability, ``unit`` (ADEV floor 0.664 B over ``b_range``).
    K : float
        Acceleration random walk, ``unit / sqrt(s)``.
    Q : float
        Quantisation, ``unit * s``.
    R : float
        Ramp, ``unit / s``.
    rate : float
        Sample rate, Hz.
    duration : float
        Length, s.
    seed : int, numpy.random.SeedSequence or numpy.random.Generator
        Seed of the random generator (an int is written into the metadata).
    bias : float
        Constant added, ``unit``.
    unit : str
        Unit of the samples (a record unit: ``g``, ``m/s^2``, ``V``, ...).
    b_range : (float, float), optional
        ``(tau_lo, tau_hi)``, s, where the Allan variance of the bias
        instability is flat to :data:`B_RANGE_RIPPLE`; default
        ``(30 / rate, duration)``.
    channel : str
        Column name.

    Returns
    -------
    accelcal.io.formats.noise.NoiseRecord
        Samples ``(n, 1)``; metadata ``true`` (the coefficients), ``seed``,
        ``simulated``.

    Raises
    ------
    AccelcalError
        For negative or non-finite coefficients, a bad rate or duration, or
        a record that would not fit in memory (use :func:`simulate_blocks`).
    """
    from accelcal.io.formats.noise import NoiseRecord
    from accelcal.resources import check_memory

    n = check_settings(N, B, K, Q, R, rate, duration, bias)
    check_memory(n, 1, 3, "the simulated recording", parameter="duration",
                 hint="stream it in blocks (simulate_blocks) to a Parquet record")
    y = np.concatenate(list(simulate_blocks(N=N, B=B, K=K, Q=Q, R=R, rate=rate,
                                            duration=duration, seed=seed, bias=bias,
                                            b_range=b_range)))
    return NoiseRecord(values=y[:, None], rate=rate, unit=unit, channels=(channel,),
                       metadata=truth_metadata(N=N, B=B, K=K, Q=Q, R=R, bias=bias, seed=seed,
                                               b_range=b_range))


def truth_metadata(*, N, B, K, Q, R, bias, seed, b_range) -> dict:
    """The metadata a simulated record carries: ``true``, ``seed``, ``simulated``."""
    meta = {"true": {"N": N, "B": B, "K": K, "Q": Q, "R": R, "bias": bias},
            "seed": int(seed) if isinstance(seed, int | np.integer) else None,
            "simulated": True}
    if b_range is not None:
        meta["b_range"] = [float(b_range[0]), float(b_range[1])]
    return meta
