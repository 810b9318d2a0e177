"""Equivalent degrees of freedom of the Allan-family variances, and chi-square intervals.

A variance estimate ``s^2`` of a power-law noise is close to
``sigma^2 chi^2_edf / edf``; the EDF depends on the noise exponent alpha
(``S_y(f) ~ f^alpha``), the averaging factor m, the record length and the
estimator. :func:`edf_greenhall` is the general algorithm of Greenhall and
Riley [GR2003]_ for every variance built from d-th differences of phase
(d = 2 Allan, d = 3 Hadamard), overlapped (stride factor S = m) or not
(S = 1), modified (filter factor F = 1) or not (F = m): four cases by
(F, alpha), each exact (a sum of at most :data:`J_MAX` squared
autocovariances) or, past :data:`J_MAX` terms, from the asymptotic Tables 1-3
of the paper. Case 4 (white PM, unmodified) is written here as the exact
finite sum it reduces to, which also covers records of ``K <= d`` strides
that the tables leave out (allantools raises ``NotImplementedError`` there).

What accelcal changes for rate samples (:func:`edf`): their phase is the
exact cumulative sum, a point-sampled integral, so the unmodified variances
of alpha <= 0 use the filter factor F = infinity at every m, which is exact
for white FM (checked against exact covariance sums in the tests), where the
paper takes F = m for ``m (d + 1) <= 100`` (phase averaged over tau0); with
F = m the EDF of white FM would be 17 % too high at m = 1 (intervals too
narrow) and up to 12 % too low at m = 4. MDEV at m = 1 is ADEV and gets
ADEV's EDF.

At short taus (``m <= 64``) of white PM, white FM and random-walk FM,
:func:`edf` takes the exact EDF of the discrete noise instead
(:mod:`~accelcal.signal.allan.exact`, ``tr(A Sigma)^2 / tr((A Sigma)^2)``):
for the random walk the algorithm's continuous model is 0.89x (OADEV) to
1.17x (OHDEV) the exact value at m = 1, and MDEV of white FM at m = 2 0.95x.
TOTDEV at m <= 2 takes the OADEV EDF, exact where it exists (Table 7's
``1.5 N/m`` is 2.2x too many at m = 1: its intervals held the truth in 0.52
of white-FM series, 0.59 of flicker-FM series).

The total variance has its own EDF, ``b N/m - c`` [SP1065]_ Table 7 (white,
flicker and random-walk FM: alpha 0, -1, -2); for white and flicker PM
(alpha 2, 1), outside that table, accelcal uses the overlapping Allan EDF:
TOTVAR averages the same overlapped second differences plus reflected ones,
so this is the conservative choice.

:func:`confidence_interval` turns a deviation and its EDF into a two-sided
interval at any confidence ``c``: ``dev sqrt(edf / chi2(1 - p/2))`` to
``dev sqrt(edf / chi2(p/2))`` with ``p = 1 - c``.

References
----------
.. [GR2003] Greenhall C. A., Riley W. J., Uncertainty of stability variances
   based on finite differences, Proc. 35th PTTI Meeting, 2003, eqs. (7)-(10),
   Tables 1-3, cases 1-4.
.. [SP1065] Riley W. J., Handbook of Frequency Stability Analysis, NIST
   Special Publication 1065, 2008, Eq. (45) (chi-square confidence
   intervals), Table 7 (TOTVAR EDF).
"""

import math

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.signal.allan.taus import check_kind
from accelcal.validation import shown

J_MAX = 100
"""Terms summed exactly before the asymptotic tables take over [GR2003]_."""

# Table 1 [GR2003]: (a0, a1) of modified variances, keyed (alpha, d)
TABLE1 = {
    (2, 1): (2 / 3, 1 / 3), (2, 2): (7 / 9, 1 / 2), (2, 3): (22 / 25, 2 / 3),
    (1, 1): (0.840, 0.345), (1, 2): (0.997, 0.616), (1, 3): (1.141, 0.843),
    (0, 1): (1.079, 0.368), (0, 2): (1.033, 0.607), (0, 3): (1.184, 0.848),
    (-1, 2): (1.048, 0.534), (-1, 3): (1.180, 0.816),
    (-2, 2): (1.302, 0.535), (-2, 3): (1.175, 0.777),
    (-3, 3): (1.194, 0.703), (-4, 3): (1.489, 0.702),
}
# Table 2 [GR2003]: (a0, a1) of unmodified variances, keyed (alpha, d); the white PM
# row (3/2, 1/2), (35/18, 1), (231/100, 3/2) is the closed form of _white_pm
TABLE2 = {
    (1, 1): (78.6, 25.2), (1, 2): (790.0, 410.0), (1, 3): (9950.0, 6520.0),
    (0, 1): (2 / 3, 1 / 6), (0, 2): (2 / 3, 1 / 3), (0, 3): (7 / 9, 1 / 2),
    (-1, 2): (0.852, 0.375), (-1, 3): (0.997, 0.617),
    (-2, 2): (1.079, 0.368), (-2, 3): (1.033, 0.607),
    (-3, 3): (1.053, 0.553), (-4, 3): (1.302, 0.535),
}
# Table 3 [GR2003]: (b0, b1) of unmodified variances, flicker PM, keyed d
TABLE3 = {1: (6.0, 4.0), 2: (15.23, 12.0), 3: (47.8, 40.0)}

TOTDEV_BC = {0: (1.50, 0.0), -1: (1.17, 0.22), -2: (0.93, 0.36)}
"""(b, c) of the TOTVAR EDF ``b N/m - c`` by alpha [SP1065]_ Table 7."""

DIFFERENCES = {"adev": 2, "oadev": 2, "mdev": 2, "totdev": 2, "hdev": 3, "ohdev": 3}
"""Order d of the phase differences of each kind."""


def _sw(t: np.ndarray, alpha: int) -> np.ndarray:
    """Eq. (7) [GR2003]: the generalised autocovariance kernel of x for alpha.

    ``|t|^(3 - alpha)`` for even alpha, ``t^(3 - alpha) ln|t|`` for odd
    alpha. The paper's signs are left out: every EDF is a ratio of squares
    of kernels of one alpha and one filter, so they cancel.
    """
    a = np.abs(t)
    if alpha % 2 == 0:
        return a ** (3 - alpha)
    with np.errstate(divide="ignore", invalid="ignore"):
        logs = np.where(a > 0, np.log(np.where(a > 0, a, 1.0)), 0.0)
    return a ** (3 - alpha) * logs


def _sx(t: np.ndarray, f: float, alpha: int) -> np.ndarray:
    """Eq. (8) [GR2003]: the kernel after the averaging filter of factor F."""
    if math.isinf(f):
        return _sw(t, alpha + 2)
    return f * f * (2.0 * _sw(t, alpha) - _sw(t - 1.0 / f, alpha) - _sw(t + 1.0 / f, alpha))


def _sz(t, f: float, alpha: int, d: int) -> np.ndarray:
    """Eq. (9) [GR2003]: the kernel after d-th differences at lag m (t in units of m)."""
    ks = np.arange(-d, d + 1)
    coef = np.array([(-1) ** abs(k) * math.comb(2 * d, d + k) for k in ks], dtype=float)
    t = np.atleast_1d(np.asarray(t, dtype=float))
    return _sx(t[:, None] + ks, f, alpha) @ coef


def _basic_sum(j: int, big_m: float, s: float, f: float, *, alpha: int, d: int) -> float:
    """Eq. (10) [GR2003]: ``sz(0)^2 + (1 - J/M) sz(J/S)^2 + 2 sum (1 - j/M) sz(j/S)^2``."""
    lags = np.arange(1, int(j), dtype=float)
    z = _sz(np.concatenate([[0.0], lags / s, [j / s]]), f, alpha, d) ** 2
    return float(z[0] + (1.0 - j / big_m) * z[-1] + 2.0 * np.sum((1.0 - lags / big_m) * z[1:-1]))


def _normalised_sum(j: int, big_m: float, s: float, f: float, *, alpha: int, d: int) -> float:
    """1/edf as ``BasicSum / (sz(0)^2 M)`` (cases 1 and 2 [GR2003])."""
    return _basic_sum(j, big_m, s, f, alpha=alpha, d=d) / (float(_sz(0.0, f, alpha, d)[0]) ** 2
                                                           * big_m)


def _white_pm(d: int, big_m: float, r: float) -> float:
    """Case 4 [GR2003] (alpha = 2, F = m) as its exact sum: 1/edf.

    White phase noise: the d-th differences at lag m are correlated only at
    separations k S (|k| <= d) with coefficient
    ``rho_k = (-1)^k C(2d, d+k) / C(2d, d)``; so
    ``1/edf = (1/M) sum_{|k| < min(K, d+1)} (1 - |k|/r) rho_k^2``, K = ceil(r).
    For K > d this is the paper's ``(a0 - a1/r)/M`` with
    ``a0 = C(4d, 2d)/C(2d, d)^2`` and ``a1 = d/2``.
    """
    top = min(math.ceil(r), d + 1)
    ks = np.arange(1 - top, top)
    rho = np.array([math.comb(2 * d, d + int(k)) for k in ks]) / math.comb(2 * d, d)
    return float(np.sum((1.0 - np.abs(ks) / r) * rho**2)) / big_m


def edf_greenhall(alpha: int, d: int, m: int, n_phase: int, *, overlapping: bool,
                  modified: bool, rate_samples: bool = False) -> float:
    """EDF of a variance of d-th phase differences [GR2003]_.

    Parameters
    ----------
    alpha : int
        Noise exponent of ``S_y(f) ~ f^alpha``, -4..2, with ``alpha + 2d > 1``.
    d : int
        Order of the phase differences (1, 2 Allan, 3 Hadamard).
    m : int
        Averaging factor.
    n_phase : int
        Phase points (rate samples + 1).
    overlapping : bool
        Stride tau0 (S = m) instead of tau (S = 1).
    modified : bool
        Modified variance (F = 1) instead of unmodified (F = m).
    rate_samples : bool
        The phase is the cumulative sum of rate samples (point values of the
        integral of y): for alpha <= 0 and unmodified variances the filter
        factor is then F = infinity at every m, which is exact, instead of
        the paper's F = m for ``m (d + 1) <= 100`` (phase averaged over
        tau0), which misstates the EDF of white FM rate samples by +17 % at
        m = 1 to -12 % at m = 4. False reproduces the paper (and allantools).

    Returns
    -------
    float
        Equivalent degrees of freedom.
    """
    if not (-4 <= alpha <= 2 and alpha + 2 * d > 1):
        raise AccelcalError(f"alpha {alpha} is outside -4..2 or too divergent for d = {d}",
                            parameter="alpha")
    f = 1.0 if modified else float(m)
    s = float(m) if overlapping else 1.0
    length = m / f + m * d                                  # L [GR2003]
    big_m = 1.0 + math.floor(s * (n_phase - length) / m)   # M, number of terms
    j = min(big_m, (d + 1) * s)
    r = big_m / s
    if modified:  # case 1
        if j <= J_MAX:
            inv = _normalised_sum(j, big_m, s, 1.0, alpha=alpha, d=d)
        elif r > d + 1:
            a0, a1 = TABLE1[(alpha, d)]
            inv = (a0 - a1 / r) / r
        else:
            inv = _normalised_sum(J_MAX, J_MAX, J_MAX / r, 1.0, alpha=alpha, d=d)
    elif alpha <= 0:  # case 2
        if j <= J_MAX:
            fp = float(m) if m * (d + 1) <= J_MAX and not rate_samples else math.inf
            inv = _normalised_sum(j, big_m, s, fp, alpha=alpha, d=d)
        elif r > d + 1:
            a0, a1 = TABLE2[(alpha, d)]
            inv = (a0 - a1 / r) / r
        else:
            inv = _normalised_sum(J_MAX, J_MAX, J_MAX / r, math.inf, alpha=alpha, d=d)
    elif alpha == 1:  # case 3
        b0, b1 = TABLE3[d]
        scale = (b0 + b1 * math.log(m)) ** 2
        if j <= J_MAX:  # F = m, accurate for m < 1e6 (second differences of t^2 ln|t|)
            inv = _normalised_sum(j, big_m, s, float(m), alpha=1, d=d)
        elif r > d + 1:
            a0, a1 = TABLE2[(1, d)]
            inv = (a0 - a1 / r) / (scale * r)
        else:
            mp = J_MAX / r
            inv = _basic_sum(J_MAX, J_MAX, mp, mp, alpha=1, d=d) / (scale * J_MAX)
    else:  # case 4, alpha = 2
        inv = _white_pm(d, big_m, r)
    return 1.0 / float(inv)


def edf_totdev(alpha: int, m: int, n_samples: int) -> float:
    """EDF of the total variance: ``b N/m - c`` for alpha 0, -1, -2 [SP1065]_ Table 7.

    For alpha 2 or 1 (outside the table) the overlapping Allan EDF
    (:func:`edf_greenhall`), a conservative choice (see the module notes).
    """
    if alpha in TOTDEV_BC:
        b, c = TOTDEV_BC[alpha]
        return b * n_samples / m - c                       # Table 7 [SP1065]
    return edf_greenhall(alpha, 2, m, n_samples + 1, overlapping=True, modified=False,
                         rate_samples=True)


def edf(kind: str, alpha, m, n_samples: int) -> np.ndarray:
    """EDF of ``kind`` at each averaging factor for identified exponents ``alpha``.

    Parameters
    ----------
    kind : str
        ``adev``, ``oadev``, ``mdev``, ``hdev``, ``ohdev`` or ``totdev``.
    alpha : array_like of int
        Noise exponent per averaging factor.
    m : array_like of int
        Averaging factors.
    n_samples : int
        Rate samples of the record (``n_samples + 1`` phase points).

    Returns
    -------
    numpy.ndarray
        EDF per averaging factor; O(J_MAX) work each (O(m^2) at most for
        the exact EDF of :func:`~accelcal.signal.allan.exact.exact_edf`,
        used for white PM, white FM and random-walk FM at ``m <= EXACT_M_MAX``).
    """
    from accelcal.signal.allan.exact import EXACT_M_MAX, exact_edf

    kind = check_kind(kind)
    alpha = np.broadcast_to(np.asarray(alpha, dtype=np.int64), np.shape(m))
    out = np.empty(np.shape(m))
    for k, (a, mm) in enumerate(zip(alpha.tolist(), np.asarray(m).tolist(), strict=True)):
        if kind == "totdev":  # at m <= 2 TOTVAR is OAVAR but for 2 reflected terms
            exact = None
            if mm <= 2:
                exact = exact_edf("oadev", a, mm, n_samples) or edf_greenhall(
                    a, 2, mm, n_samples + 1, overlapping=True, modified=False,
                    rate_samples=True)
        else:
            exact = exact_edf(kind, a, mm, n_samples) if mm <= EXACT_M_MAX else None
        if exact is not None:  # the discrete noise's own EDF (module notes)
            out[k] = exact
        elif kind == "totdev":
            out[k] = edf_totdev(a, mm, n_samples)
        else:  # MDEV at m = 1 is the Allan deviation (one phase sample per average)
            modified = kind == "mdev" and mm > 1
            out[k] = edf_greenhall(a, DIFFERENCES[kind], mm, n_samples + 1,
                                   overlapping=kind in ("oadev", "mdev", "ohdev"),
                                   modified=modified, rate_samples=True)
    return out


def check_confidence(confidence) -> float:
    """The confidence level as a float, refused (``confidence``) unless in (0, 1)."""
    try:
        value = float(confidence)
    except (TypeError, ValueError):
        raise AccelcalError(f"{shown(confidence)} is not a confidence level",
                            parameter="confidence") from None
    if not 0.0 < value < 1.0:
        raise AccelcalError(f"{shown(confidence)} must lie strictly between 0 and 1 "
                            "(0.683 for one sigma, 0.95)", parameter="confidence")
    return value


def confidence_interval(dev, edf_values, confidence: float = 0.683):
    """Two-sided chi-square interval of a deviation with EDF ``edf_values``.

    Parameters
    ----------
    dev : array_like
        Deviations.
    edf_values : array_like
        Their equivalent degrees of freedom (> 0).
    confidence : float
        Probability that the interval holds the true deviation, in (0, 1);
        0.683 as Stable32's one-sigma bars.

    Returns
    -------
    low, high : numpy.ndarray
        ``dev sqrt(edf / chi2_{1-p/2}(edf))`` and ``dev sqrt(edf / chi2_{p/2}(edf))``,
        ``p = 1 - confidence``.
    """
    from scipy.special import gammaincinv  # chi2.ppf(q, nu) = 2 P^-1(nu/2, q): no scipy.stats

    p = 1.0 - check_confidence(confidence)
    dev = np.asarray(dev, dtype=float)
    nu = np.asarray(edf_values, dtype=float)
    low = dev * np.sqrt(nu / (2.0 * gammaincinv(nu / 2.0, 1.0 - p / 2.0)))  # Eq. (45) [SP1065]
    high = dev * np.sqrt(nu / (2.0 * gammaincinv(nu / 2.0, p / 2.0)))       # Eq. (45) [SP1065]
    return low, high
