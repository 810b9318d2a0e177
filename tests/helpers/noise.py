"""Noise series and exact EDF shared by the noise tests and the interval harness."""

import numpy as np


def powerlaw(alpha: int, n: int, rng) -> np.ndarray:
    """Rate noise with S_y(f) ~ f^alpha: white, its difference (white PM), its sum (random
    walk FM), or for flicker (alpha = +-1) the fractional filter of Kasdin & Walter (1992),
    h_k = h_{k-1} (k - 1 - alpha/2) / k, applied to white noise."""
    if alpha == 0:
        return rng.normal(size=n)
    if alpha == 2:
        return np.diff(rng.normal(size=n + 1))
    if alpha == -2:
        return np.cumsum(rng.normal(size=n))
    k = np.arange(1, n)
    h = np.concatenate([[1.0], np.cumprod((k - 1 - alpha / 2.0) / k)])
    size = 2 * n  # linear, not circular, convolution
    return np.fft.irfft(np.fft.rfft(rng.normal(size=n), size) * np.fft.rfft(h, size), size)[:n]


def isserlis_edf(weights: np.ndarray, terms: int, stride: int) -> float:
    """EDF = 2 E[v]^2 / Var[v] of the mean v of ``terms`` squared linear combinations
    (``weights``, shifted by ``stride``) of i.i.d. Gaussian values: the Isserlis theorem
    gives Var = (2 / M^2) sum_{i,j} cov(i, j)^2."""
    span = len(weights)

    def cov(shift):
        return float(weights[shift:] @ weights[:span - shift]) if shift < span else 0.0

    total = sum((terms - abs(q)) * cov(abs(q) * stride) ** 2 for q in range(1 - terms, terms))
    return terms**2 * cov(0) ** 2 / total
