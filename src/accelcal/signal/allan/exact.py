"""Exact equivalent degrees of freedom of the Allan-family variances of rate samples.

Each variance estimate is a quadratic form ``v = y' A y`` of the rate
samples, a mean of ``M`` squared linear combinations ``d_k`` of them (one
per term, shifted by the stride ``s``: 1 overlapped, m not). For Gaussian
noise of covariance ``Sigma`` the equivalent degrees of freedom of ``v``
are exactly ``edf = 2 E[v]^2 / Var[v] = tr(A Sigma)^2 / tr((A Sigma)^2)``
([SP1065]_ sec. 5.3; [GR2003]_ eq. (7)). For the noises that are a finite
filter of white noise in discrete time, ``d_k = sum_j g_j w_{k s + j}`` with
``w`` white and ``g`` finite, and the trace ratio reduces to

    edf = M r(0)^2 / sum_{|q| < M} (1 - |q| / M) r(q s)^2,   r(l) = sum_j g_j g_{j+l},

with no approximation:

* white PM (alpha = 2, ``y_i = u_{i+1} - u_i``): ``g`` is the first difference of
  the term's weights;
* white FM (alpha = 0): ``g`` is the term's weights on the samples;
* random-walk FM (alpha = -2, ``y = cumsum(v)``): ``g`` is the reversed cumulative sum of the
  weights (finite because the weights of a difference sum to zero);
* random-run FM (alpha = -4, Hadamard kinds only): that sum taken twice.

These are the discrete models accelcal's simulator draws (quantisation,
white noise, random walk). The Greenhall-Riley algorithm
(:mod:`~accelcal.signal.allan.edf`) models the continuous noise: for the
random walk at m = 1 it gives 0.89x (OADEV) and 1.17x (OHDEV) the exact
value; :func:`exact_edf` replaces it at the short taus where it exists
(:data:`EXACT_M_MAX`), where the discrete and continuous models differ.
Flicker noise (alpha = +-1) is no finite filter and keeps the algorithm.

References
----------
.. [SP1065] Riley W. J., Handbook of Frequency Stability Analysis, NIST Special
   Publication 1065, 2008, sec. 5.3 (EDF = 2 E^2 / Var of a quadratic form).
.. [GR2003] Greenhall C. A., Riley W. J., Uncertainty of stability variances based
   on finite differences, Proc. 35th PTTI Meeting, 2003, eq. (7).
"""

import math

import numpy as np

EXACT_M_MAX = 64
"""Largest averaging factor given the exact EDF (past it the algorithm is within 5 %)."""

EXACT_ALPHAS = {"adev": (2, 0, -2), "oadev": (2, 0, -2), "mdev": (2, 0, -2),
                "hdev": (2, 0, -2, -4), "ohdev": (2, 0, -2, -4)}
"""Exponents with a finite discrete filter, per kind."""

ORDER = {"adev": 2, "oadev": 2, "mdev": 2, "hdev": 3, "ohdev": 3}


def term_weights(kind: str, m: int) -> np.ndarray:
    """Weights of one term on the rate samples (its d-th difference of m-sample sums)."""
    d = ORDER[kind]
    box = np.repeat([(-1.0) ** (d - 1 - k) * math.comb(d - 1, k) for k in range(d)], m)
    if kind == "mdev" and m > 1:  # moving sum over m of the second differences
        return np.convolve(np.ones(m), box)
    return box


def term_count(kind: str, m: int, n_samples: int) -> int:
    """Terms averaged at factor ``m`` in ``n_samples`` rate samples (as the kernels count)."""
    d = ORDER[kind]
    if kind in ("adev", "hdev"):
        return n_samples // m + 1 - d
    if kind == "mdev" and m > 1:
        return n_samples + 2 - 3 * m
    return n_samples + 1 - d * m


def driving_filter(kind: str, alpha: int, m: int) -> np.ndarray:
    """The filter ``g`` of one term on the white driving sequence of noise ``alpha``."""
    g = term_weights(kind, m)
    if alpha == 2:
        return np.r_[0.0, g] - np.r_[g, 0.0]
    for _ in range({0: 0, -2: 1, -4: 2}[alpha]):
        g = np.cumsum(g[::-1])[::-1]
    return g


def exact_edf(kind: str, alpha: int, m: int, n_samples: int) -> float | None:
    """Exact EDF ``tr(A Sigma)^2 / tr((A Sigma)^2)`` of ``kind`` at factor ``m``.

    Parameters
    ----------
    kind : str
        ``adev``, ``oadev``, ``mdev``, ``hdev`` or ``ohdev``.
    alpha : int
        Noise exponent.
    m : int
        Averaging factor.
    n_samples : int
        Rate samples in the record.

    Returns
    -------
    float or None
        The EDF, or None where no finite discrete model exists (flicker
        noise, TOTDEV, an exponent the kind does not take).
    """
    if alpha not in EXACT_ALPHAS.get(kind, ()):
        return None
    big_m = term_count(kind, m, n_samples)
    if big_m < 1:
        return None
    g = driving_filter(kind, alpha, m)
    r = np.correlate(g, g, mode="full")[len(g) - 1:]       # r(0), r(1), ...
    stride = 1 if kind in ("oadev", "mdev", "ohdev") else m
    q = np.arange(0, min(big_m, (len(r) - 1) // stride + 1))
    rq = r[q * stride]
    weights = np.where(q == 0, 1.0, 2.0) * (1.0 - q / big_m)
    return float(big_m * r[0] ** 2 / np.sum(weights * rq**2))   # eq. (7) [GR2003]
