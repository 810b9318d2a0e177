"""One-sided power spectral density (Welch) and the IEEE 952 noise levels drawn on it.

:func:`welch_psd` is :func:`scipy.signal.welch` (Hann window, 50 % overlap,
mean removed per segment, density scaling, one-sided);
:class:`WelchAccumulator` gives the same numbers from blocks of samples
(the segments straddling block ends included), so a long record streams.

Levels of the terms on a *one-sided* PSD ``S(f)`` in unit^2/Hz (twice the
two-sided density IEEE 952 Annex C writes, Table C.1 [IEEE952]_), each
derived from ``AVAR = 2 int_0^inf S(f) sin^4(pi f tau) / (pi f tau)^2 df``
[Riley2008]_ and checked against the term's Allan variance:

=====  ==========================  =====================================
term   one-sided S(f)              check
=====  ==========================  =====================================
Q      2 (2 pi f)^2 Q^2 tau0       white phase: AVAR = 3 h2 f_h / (4 pi^2 tau^2), f_h = 1/(2 tau0)
N      2 N^2                       white: AVAR = h0 / (2 tau) = N^2 / tau
B      B^2 / (pi f)                flicker: AVAR = 2 ln 2 h_-1
K      2 K^2 / (2 pi f)^2          random walk: AVAR = (2 pi^2 / 3) h_-2 tau
R      2 R^2 / (2 pi f)^3          ramp (IEEE 952's two-sided R^2/(2 pi f)^3, doubled)
=====  ==========================  =====================================

So white noise of SD ``sigma`` at ``fs`` Hz has ``N = sigma / sqrt(fs)`` and a
one-sided Welch level ``2 sigma^2 / fs = 2 N^2`` (the variance spread over
0..fs/2), tested in ``tests/methods/noise/test_noise_fit.py``.

References
----------
.. [IEEE952] IEEE Std 952-1997, Annex C, Table C.1 (PSD and Allan variance
   of each term).
.. [Riley2008] Riley W. J., NIST SP 1065, 2008, sec. 6 (power-law noise,
   h_alpha and the Allan variance).
.. [Welch1967] Welch P. D., The use of fast Fourier transform for the
   estimation of power spectra, IEEE Trans. Audio Electroacoust. 15(2), 1967.
"""

import math

import numpy as np

MAX_SEGMENT = 1 << 16
"""Longest Welch segment (samples): 32k frequencies, resolution rate / 65536."""


def segment_length(n: int) -> int:
    """Welch segment for ``n`` samples: a power of two near n / 16, 256 to :data:`MAX_SEGMENT`."""
    if n <= 256:
        return int(n)
    return int(min(MAX_SEGMENT, max(256, 1 << int(math.log2(n / 16)))))


def welch_psd(y, rate: float, nperseg: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """One-sided PSD of samples by Welch's method (:func:`scipy.signal.welch`).

    Parameters
    ----------
    y : array_like, shape (n,)
        Samples, in unit.
    rate : float
        Sample rate, Hz.
    nperseg : int, optional
        Segment length (default :func:`segment_length`).

    Returns
    -------
    frequency : numpy.ndarray
        Hz, from 0 to rate / 2.
    psd : numpy.ndarray
        unit^2 / Hz, one-sided.
    """
    from scipy.signal import welch

    y = np.asarray(y, dtype=float).reshape(-1)
    return welch(y, fs=rate, window="hann", nperseg=nperseg or segment_length(y.size),
                 detrend="constant", scaling="density")


class WelchAccumulator:
    """Welch's one-sided PSD from consecutive blocks (same result as :func:`welch_psd`).

    Parameters
    ----------
    rate : float
        Sample rate, Hz.
    nperseg : int
        Segment length (50 % overlap, Hann window).
    """

    def __init__(self, rate: float, nperseg: int):
        from scipy.signal import get_window

        self.rate = float(rate)
        self.nperseg = int(nperseg)
        self.step = self.nperseg - self.nperseg // 2
        self.window = get_window("hann", self.nperseg)
        self._tail = np.empty(0)
        self._sum = np.zeros(self.nperseg // 2 + 1)
        self._count = 0

    def add(self, block) -> None:
        """Take the next samples (any length)."""
        data = np.concatenate((self._tail, np.asarray(block, dtype=float).reshape(-1)))
        count = (data.size - self.nperseg) // self.step + 1 if data.size >= self.nperseg else 0
        if count > 0:
            idx = np.arange(count)[:, None] * self.step + np.arange(self.nperseg)
            for a in range(0, count, 64):  # 64 segments at a time: bounded memory
                seg = data[idx[a:a + 64]]
                seg = (seg - seg.mean(axis=1, keepdims=True)) * self.window
                self._sum += np.sum(np.abs(np.fft.rfft(seg, axis=1)) ** 2, axis=0)
            self._count += count
        self._tail = data[count * self.step:]

    def result(self) -> tuple[np.ndarray, np.ndarray]:
        """``(frequency, psd)`` of the blocks taken so far (segments that ended)."""
        if self._count == 0:
            raise ValueError("fewer samples than one Welch segment")
        psd = self._sum / self._count / (self.rate * np.sum(self.window**2))
        psd[1:] *= 2.0  # one-sided: every bin but DC (and Nyquist for an even segment)
        if self.nperseg % 2 == 0:
            psd[-1] /= 2.0
        return np.fft.rfftfreq(self.nperseg, 1.0 / self.rate), psd


def levels(coefs: dict, frequency, rate: float) -> dict[str, np.ndarray]:
    """One-sided PSD of each term at ``frequency`` (the table above), unit^2/Hz.

    Parameters
    ----------
    coefs : dict
        Term -> value (IEEE 952 units; absent or zero terms are left out).
    frequency : array_like
        Hz (> 0 for B, K, R).
    rate : float
        Sample rate, Hz (sets tau0 of the quantisation level).
    """
    f = np.asarray(frequency, dtype=float)
    w = 2 * math.pi * f
    with np.errstate(divide="ignore"):
        shapes = {"Q": lambda v: 2 * w**2 * v**2 / rate, "N": lambda v: 2 * v**2 + 0 * f,
                  "B": lambda v: v**2 / (math.pi * f), "K": lambda v: 2 * v**2 / w**2,
                  "R": lambda v: 2 * v**2 / w**3}
        return {t: shapes[t](v) for t, v in coefs.items() if t in shapes and v > 0}
