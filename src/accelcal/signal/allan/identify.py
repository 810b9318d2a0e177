"""Power-law noise identification per tau: lag-1 autocorrelation, B1 ratio for short series.

The exponent alpha of the rate-noise spectrum ``S_y(f) ~ f^alpha`` sets the
EDF, hence the confidence interval, of every deviation. For each averaging
factor m the rate samples are averaged in blocks of m (``z_k``, ``n_avg =
floor(N/m)`` of them, read off the phase as ``(x[(k+1)m] - x[km]) / m``), and:

* ``n_avg >= ACF_MIN_POINTS`` (30): the lag-1 autocorrelation method of Riley
  and Greenhall [RG2004]_ as Stable32 and allantools apply it to frequency
  data: remove a linear trend, then difference ``z`` until
  ``delta = r1 / (1 + r1) < 0.25`` (``d`` differences, at most 2, or 3 for
  the Hadamard kinds); ``alpha = -round(2 delta) - 2 d``.
* ``B1_MIN_POINTS <= n_avg < 30``: the B1 ratio of Barnes [Barnes1969]_,
  ``B1 = s^2(z) / AVAR(tau)`` (sample variance of the block averages over
  their non-overlapping Allan variance), compared with its expectation
  ``B1(n_avg, mu)`` for ``mu = -2..2``; the nearest on a log scale (boundaries
  at geometric means) gives mu, hence alpha = -mu - 1 for mu >= -1. For mu =
  -2 (white or flicker PM) the ratio ``R(m) = MVAR / AVAR`` decides, against
  its white-PM value 1/m and its flicker-PM value [SP1065]_ (at m = 1 it
  cannot: white PM is taken).
* fewer than ``B1_MIN_POINTS`` (8) averages (the last taus of a record): the
  tau takes the alpha of the next shorter tau (white FM, 0, if there is
  none). B1 tells too little there: with two averages it is 1 whatever the
  noise; in 2000 simulated white-FM series it names white FM in 26 % of
  series of 4 averages (no better than a guess among five), 43 % of 8, 68 %
  of 16 and 85 % of 29.

The result is clipped to the exponents the kind converges for and its EDF
covers: -2..2 (Allan kinds, total), -4..2 (Hadamard kinds).

References
----------
.. [RG2004] Riley W. J., Greenhall C. A., Power law noise identification using
   the lag 1 autocorrelation, Proc. 18th EFTF, 2004, Eq. (2) (lag-1
   autocorrelation) and the identification rule.
.. [Barnes1969] Barnes J. A., Tables of bias functions, B1 and B2, for
   variances based on finite samples of processes with power law spectral
   densities, NBS Technical Note 375, 1969.
.. [SP1065] Riley W. J., Handbook of Frequency Stability Analysis, NIST
   Special Publication 1065, 2008 (noise identification; R(n) = MVAR/AVAR).
"""

import math

import numpy as np

from accelcal.signal.allan.kernels import lag_sumsq, mdev_sumsq_bounded, one_blas_thread
from accelcal.signal.allan.taus import check_kind

ACF_MIN_POINTS = 30
"""Fewest block averages for the lag-1 autocorrelation method [RG2004]_."""

B1_MIN_POINTS = 8
"""Fewest block averages for the B1 ratio (below: the shorter tau's alpha)."""

MUS = (-2, -1, 0, 1, 2)
"""Exponents mu of ``AVAR ~ tau^mu`` the B1 ratio tells apart."""


def alpha_range(kind: str) -> tuple[int, int]:
    """Exponents alpha a kind converges for: (-4, 2) Hadamard, (-2, 2) otherwise."""
    return (-4, 2) if check_kind(kind) in ("hdev", "ohdev") else (-2, 2)


def lag1_autocorrelation(z: np.ndarray) -> float:
    """Lag-1 autocorrelation ``r1`` of a series (Eq. (2) [RG2004]_); 0 for a constant series."""
    c = z - np.mean(z)
    den = float(np.dot(c, c))
    return float(np.dot(c[:-1], c[1:])) / den if den > 0 else 0.0  # Eq. (2) [RG2004]


def detrended_lag1(z: np.ndarray) -> float:
    """Lag-1 autocorrelation of ``z`` less its least-squares straight line, in one pass.

    Equal to ``lag1_autocorrelation(z - (a + b t))`` but without forming the
    detrended series: with ``c = z - mean(z)``, ``t`` centred on the middle
    sample and ``b = t'c / t't``, the residual ``e = c - b t`` has
    ``sum e_i e_(i+1) = sum c_i c_(i+1) - b sum (c_i t_(i+1) + t_i c_(i+1))
    + b^2 sum t_i t_(i+1)`` and ``sum e_i^2 = c'c - b^2 t't`` (dot products
    of views of ``c``; ``t_(i+1) = t_i + 1``).
    """
    n = len(z)
    c = z - np.mean(z)
    t0 = -(n - 1) / 2.0
    idx = np.arange(n, dtype=float)
    tc = float(np.dot(idx, c))                     # t'c (sum c = 0, so the offset t0 drops)
    tt = n * (n * n - 1.0) / 12.0                   # t't of centred 0..n-1
    b = tc / tt if tt > 0 else 0.0
    cc = float(np.dot(c, c))
    den = cc - b * tc                               # e'e = c'c - b^2 t't
    if den <= 0.0 or n < 2:
        return 0.0
    lag = float(np.dot(c[:-1], c[1:]))
    # sum c_i t_(i+1) + t_i c_(i+1) over i < n-1, with t_i = t0 + i
    head = float(np.dot(idx[:n - 1], c[1:])) + t0 * float(np.sum(c[1:]))
    tail = float(np.dot(idx[1:n], c[:-1])) + t0 * float(np.sum(c[:-1]))
    m = n - 1
    tlag = m * t0 * (t0 + 1.0) + (2.0 * t0 + 1.0) * (m - 1) * m / 2.0 \
        + (m - 1) * m * (2.0 * m - 1) / 6.0         # sum t_i t_(i+1), i = 0..n-2
    num = lag - b * (head + tail) + b * b * tlag
    return num / den  # Eq. (2) [RG2004] on the detrended series


def acf_alpha(z: np.ndarray, dmax: int) -> tuple[int, float, int]:
    """Lag-1 autocorrelation noise identification of rate data [RG2004]_.

    Parameters
    ----------
    z : numpy.ndarray
        Rate samples (or their block averages), at least
        :data:`ACF_MIN_POINTS`.
    dmax : int
        Most differences taken (2 Allan, 3 Hadamard).

    Returns
    -------
    alpha_int, alpha, d : int, float, int
        Integer exponent, its unrounded estimate ``-2 (delta + d)`` and the
        differences taken.
    """
    z = np.asarray(z, dtype=float)
    r1 = detrended_lag1(z)                          # the linear trend removed first [RG2004]
    d = 0
    while True:
        delta = r1 / (1.0 + r1) if r1 > -1.0 else -1.0      # [RG2004]
        if delta < 0.25 or d >= dmax:
            return int(-np.round(2.0 * delta)) - 2 * d, -2.0 * (delta + d), d  # [RG2004]
        z = np.diff(z)
        d += 1
        r1 = lag1_autocorrelation(z)


def b1_theory(n: int, mu: int) -> float:
    """Expected B1 ratio of ``n`` averages for ``AVAR ~ tau^mu`` [Barnes1969]_."""
    if mu == 2:
        return n * (n + 1.0) / 6.0
    if mu == 1:
        return n / 2.0
    if mu == 0:
        return n * math.log(n) / (2.0 * (n - 1.0) * math.log(2.0))
    if mu == -1:
        return 1.0
    if mu == -2:
        return (n * n - 1.0) / (1.5 * n * (n - 1.0))
    return n * (1.0 - n**mu) / (2.0 * (n - 1.0) * (1.0 - 2.0**mu))  # general mu


def b1_mu(z: np.ndarray) -> int:
    """Exponent mu whose expected B1 lies nearest (log scale) to the B1 ratio of ``z``."""
    n = len(z)
    ratio = np.var(z, ddof=1) / (0.5 * np.mean(np.diff(z) ** 2))
    theory = np.array([b1_theory(n, mu) for mu in MUS])
    bounds = np.sqrt(theory[:-1] * theory[1:])
    return MUS[int(np.searchsorted(bounds, ratio))]


def rn_flicker_pm(m: int) -> float:
    """``MVAR / AVAR`` for flicker PM at factor m, bandwidth ``f_h = 1/(2 tau0)`` [SP1065]_."""
    avar = (1.038 + 3.0 * math.log(2.0 * math.pi * 0.5 * m)) / (4.0 * math.pi**2)
    mvar = 3.0 * math.log(256.0 / 27.0) / (8.0 * math.pi**2)
    return mvar / avar


def rn_alpha(x: np.ndarray, m: int) -> int:
    """White (2) or flicker (1) PM from ``R(m) = MVAR / AVAR`` at factor m [SP1065]_."""
    if m == 1:
        return 2
    msum, mcount = mdev_sumsq_bounded(x, m)  # bounded memory: x may be a streamed memmap
    acount = len(x) - 2 * m
    asum = lag_sumsq(x, 0, acount, m, 2)
    ratio = (msum / mcount / m**2) / (asum / acount)
    return 2 if ratio < math.sqrt(rn_flicker_pm(m) / m) else 1


def noise_alphas(x: np.ndarray, m_values, kind: str) -> np.ndarray:
    """Identified noise exponent alpha at each averaging factor (module rules).

    Parameters
    ----------
    x : numpy.ndarray
        Phase of the rate samples (:func:`~accelcal.signal.allan.kernels.phase`).
    m_values : array_like of int
        Averaging factors, ascending.
    kind : str
        The deviation (sets the differences allowed and the clipping).

    Returns
    -------
    numpy.ndarray
        Integer alpha per factor. Time O(N/m) per factor (O(N) where R(m)
        is needed).
    """
    low, high = alpha_range(kind)
    dmax = 3 if low == -4 else 2
    out = np.empty(len(m_values), dtype=np.int64)
    previous = 0
    for k, m in enumerate(int(v) for v in m_values):
        z = np.diff(x[::m]) / m
        if len(z) >= ACF_MIN_POINTS:
            alpha = acf_alpha(z, dmax)[0]
        elif len(z) >= B1_MIN_POINTS:
            mu = b1_mu(z)
            alpha = rn_alpha(x, m) if mu == -2 else -mu - 1
        else:
            alpha = previous
        out[k] = previous = min(max(alpha, low), high)
    return out


RELIABLE_POINTS = 128
"""Fewest block averages at which a tau's own identification sets its interval.

Below them the lag-1 autocorrelation and the B1 ratio name the wrong noise
too often for the interval to hold: in 1000 white-FM series of 4096
samples the identification was right in 99 % at 128 averages, 91 % at 64,
79 % at 32 (B1: 67 % at 16, 47 % at 8), and the 68.3 % intervals held the
truth in only 0.57-0.64 of series at those taus."""

POOLED_TAUS = 3
"""Reliable taus (the longest ones) whose identified alphas are pooled, by median."""

ID_AVERAGES = 1 << 16
"""Most block averages a tau's identification reads (the record's start).

The lag-1 autocorrelation of n averages has a standard deviation of about
1/sqrt(n) (0.004 at 65,536), sixty times below the 0.25 steps of delta the
rule decides between, so reading more changes no decision that is not a tie;
without the cap the identification at short taus reads the whole record and
took 85 % of a deviation's time on a million samples."""


def interval_alphas(x: np.ndarray, m_values, kind: str, *,
                    cap: int = ID_AVERAGES) -> tuple[np.ndarray, tuple[str, ...]]:
    """Noise exponent per tau for the intervals, and where each one comes from.

    Taus with at least :data:`RELIABLE_POINTS` block averages are identified
    by :func:`noise_alphas` (``"identified"``); the longer taus take the
    median of the alphas identified at the :data:`POOLED_TAUS` longest
    reliable taus (``"carried"``): their interval then assumes the noise
    type does not change past the last reliable tau, which is what a
    user must check (the deviation's slope). A record with no reliable tau
    (fewer than 128 samples) keeps the per-tau rules of :func:`noise_alphas`
    (``"guessed"``: the intervals are not known to hold).

    Parameters
    ----------
    x : numpy.ndarray
        Phase of the rate samples.
    m_values : array_like of int
        Averaging factors, ascending.
    kind : str
        The deviation.
    cap : int
        Identify each reliable tau on at most ``cap`` averages (the record's
        start; :data:`ID_AVERAGES`).

    Returns
    -------
    alphas : numpy.ndarray
        Integer alpha per factor.
    sources : tuple of str
        ``"identified"``, ``"carried"`` or ``"guessed"`` per factor.
    """
    with one_blas_thread():  # the dot products of short series: see one_blas_thread
        return _interval_alphas(x, np.asarray(m_values, dtype=np.int64), kind, cap)


def _interval_alphas(x, m, kind, cap):
    n = len(x) - 1
    reliable = n // np.maximum(m, 1) >= RELIABLE_POINTS
    if not reliable.any():
        return noise_alphas(x, m, kind), ("guessed",) * m.size
    low, high = alpha_range(kind)
    dmax = 3 if low == -4 else 2
    alphas = np.empty(m.size, dtype=np.int64)
    for k in np.flatnonzero(reliable):  # >= 128 averages: the lag-1 ACF rule
        mk = int(m[k])
        z = np.diff(np.asarray(x[:min(n, mk * cap) + 1:mk])) / mk  # cap + 1 phase points read
        alphas[k] = min(max(acf_alpha(z, dmax)[0], low), high)
    pooled = alphas[np.flatnonzero(reliable)[-POOLED_TAUS:]]
    alphas[~reliable] = int(np.round(np.median(pooled)))
    return alphas, tuple("identified" if r else "carried" for r in reliable)
