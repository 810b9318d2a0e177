"""Welch auto- and cross-spectra of two channels, accumulated block by block.

:class:`CrossSpectra` takes a two-channel recording in blocks of any size
(:meth:`CrossSpectra.add`) and keeps only the running sums of the
segments' periodograms and the samples of the one segment not yet
complete, so its memory is bounded by a segment and a block whatever the
recording's length (an hour of two channels at 5 kHz streams in a few MB).
Its sums are those of :func:`scipy.signal.csd` and :func:`scipy.signal.welch`
on the whole record with the same segment, overlap and window (Hann by
default, each segment's mean removed): the same estimate, to rounding.

From them, the H1 estimator of the transfer function from ``x`` to ``y``
and the coherence::

    H1 = G_xy / G_xx,     gamma^2 = |G_xy|^2 / (G_xx G_yy),

and the normalized random errors of ``|H1|`` and of its phase (rad) for
``n_d`` averages [BP2010]_ (eq. 9.90 and 9.52)::

    e_r(|H1|) = sqrt(1 - gamma^2) / (|gamma| sqrt(2 n_d)),    sd(phase) ~ e_r(|H1|).

With overlapping segments the averages are not independent: ``n_d`` is the
equivalent number of independent ones (Welch's variance ratio of the
window at that overlap [Welch1967]_, ``n_d = K`` without overlap).

References
----------
.. [BP2010] Bendat J. S., Piersol A. G., Random Data: Analysis and
   Measurement Procedures, 4th ed., Wiley, 2010, sec. 9.2.3 (random errors of
   frequency response estimates) and 11.5 (Welch's procedure).
.. [Welch1967] Welch P. D., "The use of fast Fourier transform for the
   estimation of power spectra", IEEE Trans. Audio Electroacoust. 15(2),
   1967, p. 70-73 (variance of overlapped averages).
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError

MIN_SEGMENT = 16
"""Fewest samples per segment."""


@dataclass(frozen=True)
class Spectra:
    """Welch spectra of two channels ``x`` (input) and ``y`` (output).

    Attributes
    ----------
    frequency : numpy.ndarray
        Bin frequencies, Hz.
    gxx, gyy : numpy.ndarray
        One-sided auto-spectral densities, unit^2/Hz.
    gxy : numpy.ndarray of complex
        One-sided cross-spectral density ``conj(X) Y``.
    segments : int
        Segments averaged.
    n_d : float
        Equivalent number of independent averages.
    """

    frequency: np.ndarray
    gxx: np.ndarray
    gyy: np.ndarray
    gxy: np.ndarray
    segments: int
    n_d: float

    @property
    def h1(self) -> np.ndarray:
        """The H1 estimate ``G_xy / G_xx`` (NaN where ``G_xx`` is 0)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(self.gxx > 0, self.gxy / np.where(self.gxx > 0, self.gxx, 1.0),
                            np.nan)

    @property
    def coherence(self) -> np.ndarray:
        """Ordinary coherence ``gamma^2`` (0 where either channel is empty)."""
        den = self.gxx * self.gyy
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(den > 0, np.abs(self.gxy) ** 2 / np.where(den > 0, den, 1.0), 0.0)

    def random_error(self) -> np.ndarray:
        """Normalized random error of ``|H1|`` (and sd of its phase, rad) [BP2010]_."""
        g2 = np.clip(self.coherence, 0.0, 1.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(g2 > 0, np.sqrt((1.0 - g2) / (2.0 * self.n_d * g2)), np.inf)


def equivalent_averages(segments: int, window: np.ndarray, step: int) -> float:
    """Equivalent independent averages of ``segments`` overlapped ones [Welch1967]_.

    ``K / (1 + 2 sum_j (1 - j/K) rho(j)^2)`` with ``rho(j)`` the correlation
    of the window with itself shifted by ``j`` steps.
    """
    n = window.size
    w2 = np.sum(window**2)
    total = 1.0
    for j in range(1, segments):
        shift = j * step
        if shift >= n:
            break
        rho = np.sum(window[:n - shift] * window[shift:]) / w2
        total += 2.0 * (1.0 - j / segments) * rho**2
    return float(segments / total)


class CrossSpectra:
    """Welch spectra of two channels fed block by block (bounded memory).

    Parameters
    ----------
    fs : float
        Sample rate, Hz.
    nperseg : int
        Samples per segment.
    overlap : float
        Fraction of a segment shared with the next, in ``[0, 1)`` (0.5 by default).
    window : str
        A :func:`scipy.signal.get_window` name.

    References
    ----------
    .. [1] Bendat and Piersol (2010), sec. 11.5.
    """

    def __init__(self, fs: float, nperseg: int, *, overlap: float = 0.5,
                 window: str = "hann") -> None:
        from scipy.signal import get_window

        if not (np.isfinite(fs) and fs > 0):
            raise AccelcalError(f"must be a positive rate, got {fs!r}", parameter="fs")
        if int(nperseg) != nperseg or nperseg < MIN_SEGMENT:
            raise AccelcalError(f"must be a whole number of samples >= {MIN_SEGMENT}, got "
                                f"{nperseg!r}", parameter="nperseg")
        if not 0.0 <= overlap < 1.0:
            raise AccelcalError(f"must be in [0, 1), got {overlap!r}", parameter="overlap")
        self.fs, self.nperseg = float(fs), int(nperseg)
        self.step = self.nperseg - int(np.floor(overlap * self.nperseg))
        self.window = get_window(window, self.nperseg)
        self.scale = 1.0 / (self.fs * np.sum(self.window**2))
        bins = self.nperseg // 2 + 1
        self._xx, self._yy = np.zeros(bins), np.zeros(bins)
        self._xy = np.zeros(bins, complex)
        self._tail = np.empty((2, 0))
        self.segments = 0
        self.samples = 0

    def add(self, x, y) -> None:
        """Add the next samples of both channels (equal lengths)."""
        x, y = np.asarray(x, float).reshape(-1), np.asarray(y, float).reshape(-1)
        if x.size != y.size:
            raise AccelcalError("the two channels of a block must have equal lengths")
        self.samples += x.size
        data = np.concatenate([self._tail, np.stack([x, y])], axis=1)
        count = 0 if data.shape[1] < self.nperseg else \
            (data.shape[1] - self.nperseg) // self.step + 1
        if count:
            idx = np.arange(self.nperseg)[None, :] + self.step * np.arange(count)[:, None]
            for chunk in np.array_split(np.arange(count), max(1, count // 256)):
                seg = data[:, idx[chunk]]
                seg = seg - seg.mean(axis=2, keepdims=True)
                spec = np.fft.rfft(seg * self.window, axis=2)
                self._xx += np.sum(np.abs(spec[0]) ** 2, axis=0)
                self._yy += np.sum(np.abs(spec[1]) ** 2, axis=0)
                self._xy += np.sum(np.conj(spec[0]) * spec[1], axis=0)
        self.segments += count
        self._tail = data[:, count * self.step:].copy()

    def result(self) -> Spectra:
        """The averaged one-sided spectra of what has been added.

        Raises
        ------
        AccelcalError
            Before one whole segment.
        """
        if self.segments == 0:
            raise AccelcalError(f"{self.samples} samples hold no whole segment of "
                                f"{self.nperseg}: a longer record or shorter segments")
        one_sided = np.full(self._xx.size, 2.0)
        one_sided[0] = 1.0
        if self.nperseg % 2 == 0:
            one_sided[-1] = 1.0
        k = self.scale * one_sided / self.segments
        return Spectra(np.fft.rfftfreq(self.nperseg, 1.0 / self.fs), k * self._xx,
                       k * self._yy, k * self._xy, self.segments,
                       equivalent_averages(self.segments, self.window, self.step))
