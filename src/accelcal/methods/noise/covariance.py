"""Covariance of overlapping Allan variance estimates at several taus, from a noise model.

The overlapping Allan variance at ``tau = m tau0`` is a quadratic form of
the samples, ``AVAR_m = (1 / 2M) sum_k z_k^2`` with ``z_k`` the difference
of two adjacent m-sample means (``M = n - 2m + 1`` of them) [Riley2008]_.
For Gaussian samples ``Cov(z^2, z'^2) = 2 Cov(z, z')^2 + 4 E z E z' Cov(z, z')``
(Isserlis), so::

    Cov(AVAR_a, AVAR_b) = 1 / (4 M_a M_b) sum_j n_ab(j) [2 g_ab(j)^2 + 4 mu_a mu_b g_ab(j)]

with ``g_ab(j) = Cov(z^a_k, z^b_{k+j})``, ``n_ab(j)`` the number of index pairs
at lag ``j`` and ``mu = R tau`` the mean of ``z`` under a ramp. Each noise
term is a filter of its own white sequence (:mod:`accelcal.rigs.noise`):
``z`` of white noise is the box difference ``h_m`` (+-1/m), of quantisation
the second difference ``(d_0 - 2 d_m + d_2m) / m``, of a random walk the
triangle ``c_k = m - |k - m|`` over m; ``g_ab`` is the sum over the terms of
the cross-correlations of the two filters. Long filters are summed into
bins of ``s`` samples (``s = 1``, exact, while ``m_a + m_b <= 2048``):
``g(s j) ~ (G_a * G_b)(j) / s`` and ``sum_j ~ s sum_j'``, a Riemann sum of
the piecewise-polynomial correlation whose relative error is O(s / m) and
which leaves out only the correlation of a filter much shorter than a bin,
itself O((m_a / m_b)^1.5) [derived in docs/noise.md]. Every pair costs an
FFT of at most ~8k points: the covariance of T taus takes O(T^2), whatever
the record's length.

The bias-instability floor (a 1/f process) is not a finite filter; its
share is added on the diagonal as an independent variance
``2 A_B (A_B + 2 A_rest) / edf`` (the point's equivalent degrees of
freedom), so the correlation it induces between taus is left out (B's
standard uncertainty is optimistic; stated in the fit's notes).

References
----------
.. [Riley2008] Riley W. J., Handbook of Frequency Stability Analysis, NIST
   SP 1065, 2008, sec. 5.2.4 (overlapping Allan variance), 5.3 (confidence).
.. [Greenhall2003] Greenhall C. A., Riley W. J., Uncertainty of stability
   variances based on finite differences, Proc. 35th PTTI, 2003 (the same
   quadratic-form route to the variance of a variance).
.. [IEEE952] IEEE Std 952-1997, Annex C.
"""

import math

import numpy as np

BIN_POINTS = 2048
"""Largest ``m_a + m_b`` summed sample by sample (exactly); beyond it filters are binned."""


def _prefix_white(i, m):
    """``sum_{i' < i} h_m(i')`` of the box difference (-1/m then +1/m, m samples each)."""
    return (-np.clip(i, 0, m) + np.clip(i - m, 0, m)) / m


def _prefix_quant(i, m):
    """Prefix sums of the quantisation filter ``(d_0 - 2 d_m + d_2m) / m``."""
    return ((i > 0).astype(float) - 2 * (i > m) + (i > 2 * m)) / m


def _prefix_walk(i, m):
    """Prefix sums of the random-walk filter ``(m - |k - m|) / m`` for ``0 <= k <= 2m``."""
    u = np.clip(i, 0, 2 * m + 1).astype(float)
    low = u * (u - 1) / 2
    t = 2 * m - u
    high = m * (m + 1) / 2 + (m - 1) * m / 2 - t * (t + 1) / 2
    return np.where(u <= m + 1, low, high) / m


_PREFIX = {"N": _prefix_white, "Q": _prefix_quant, "K": _prefix_walk}


def _binned(term: str, m: int, s: int) -> np.ndarray:
    """Sums over bins of ``s`` samples of a term's unit filter at ``m`` (support 0..2m)."""
    edges = np.arange(0, 2 * m + 1 + s, s)
    return np.diff(_PREFIX[term](edges, m))


def _amplitudes(coefs: dict, tau0: float) -> dict:
    """Scale of each term's white input (:mod:`accelcal.rigs.noise`)."""
    return {"N": coefs.get("N", 0.0) / math.sqrt(tau0), "Q": coefs.get("Q", 0.0) / tau0,
            "K": coefs.get("K", 0.0) * math.sqrt(tau0)}


def _pair_sums(ma: int, mb: int, Ma: int, Mb: int, amp: dict) -> tuple[float, float]:
    """``sum_j n(j) g(j)^2`` and ``sum_j n(j) g(j)`` for one pair of taus."""
    s = max(1, (ma + mb) // BIN_POINTS)
    terms = [t for t, a in amp.items() if a != 0.0]
    if not terms:
        return 0.0, 0.0
    ga = [amp[t] * _binned(t, ma, s) for t in terms]
    gb = [amp[t] * _binned(t, mb, s) for t in terms]
    la, lb = ga[0].size, gb[0].size
    size = 1 << math.ceil(math.log2(la + lb))
    spec = sum(np.fft.rfft(a, size) * np.conj(np.fft.rfft(b, size))
               for a, b in zip(ga, gb, strict=True))
    full = np.fft.irfft(spec, size) / s
    # lags j' = -(lb - 1) .. la - 1 (circular layout of the correlation)
    gamma = np.concatenate((full[size - (lb - 1):], full[:la])) if lb > 1 else full[:la]
    lag = s * np.arange(-(lb - 1), la)
    count = np.maximum(0, np.minimum(Ma, Mb - lag) - np.maximum(0, -lag)).astype(float)
    return s * float(np.sum(count * gamma**2)), s * float(np.sum(count * gamma))


def avar_covariance(m, n: int, rate: float, coefs: dict) -> np.ndarray:
    """Covariance matrix of the overlapping Allan variances at ``m`` under a noise model.

    Parameters
    ----------
    m : array_like of int
        Averaging factors (``tau = m / rate``), each ``<= (n - 1) / 2``.
    n : int
        Samples in the record.
    rate : float
        Sample rate, Hz.
    coefs : dict
        ``Q, N, K, R`` (IEEE 952 units, missing = 0); ``B`` is handled by
        :func:`bias_diagonal`.

    Returns
    -------
    numpy.ndarray, shape (T, T)
        In the squared unit of the Allan variance (unit^4).

    References
    ----------
    .. [1] Riley2008 sec. 5.2.4; Isserlis' theorem for Gaussian fourth moments.
    """
    m = np.asarray(m, dtype=np.int64)
    tau0 = 1.0 / rate
    amp = _amplitudes(coefs, tau0)
    mu = coefs.get("R", 0.0) * m * tau0  # Eq. (C.5): z = R tau under a ramp [IEEE952]
    count = n - 2 * m + 1
    out = np.zeros((m.size, m.size))
    for a in range(m.size):
        for b in range(a, m.size):
            s2, s1 = _pair_sums(int(m[a]), int(m[b]), int(count[a]), int(count[b]), amp)
            out[a, b] = out[b, a] = (2 * s2 + 4 * mu[a] * mu[b] * s1) / (
                4.0 * count[a] * count[b])
    return out


def bias_diagonal(avar_b: float, avar_rest, edf) -> np.ndarray:
    """Variance added by the bias-instability floor at each tau (independent across taus).

    ``2 A_B (A_B + 2 A_rest) / edf``: the chi-square variance ``2 A^2 / edf``
    of the total less that of the rest, to first order in the cross term.
    """
    rest = np.asarray(avar_rest, dtype=float)
    return 2.0 * avar_b * (avar_b + 2.0 * rest) / np.asarray(edf, dtype=float)
