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
window at that overlap [Welch1967]_, ``n_d = K`` without overlap). A record
cut at its gaps is averaged over the segments of its pieces
(:meth:`CrossSpectra.restart`: no segment spans a gap), and ``n_d`` is the
sum of the pieces' own (segments of different pieces do not overlap).

Those errors are the output noise's. A system whose impulse response lasts
``tau`` also leaks [AS2009]_: a segment of ``y`` holds the response to ``x`` from up to
``tau`` before the segment, weighed by the window shifted by the lag, so that
to first order in ``tau / T`` (``T`` the segment), with ``Z_k`` the DFT of
segment ``k`` of ``x`` under the window's derivative ``w'`` (per sample),
``omega`` in rad per sample::

    Y_k = H X_k + i (dH / d omega) Z_k + N_k,

a random error of H1, ``i H' sum conj(X_k) Z_k / sum |X_k|^2``, that the
coherence counts as noise (it lowers ``gamma^2``) but that is not circular:
where the squared windows overlap to a constant (Hann at 3/4) its real part
nearly cancels and it falls on the phase, so that the magnitude's scatter is
well below the stated one (``tests/signal/test_spectra.py``: 0.4 of it for a
filter and a delay). :meth:`Spectra.conditioned` takes ``Z``
as a second input of the two-input model [BP2010]_ (sec. 7.2): the spectra
conditioned on ``z``::

    G_ij.z = G_ij - G_iz G_zj / G_zz,

whose H1 ``G_xy.z / G_xx.z`` is the response to ``x`` with the leakage term
fitted out, and whose coherence (the partial coherence of ``x`` and ``y``)
and random error are the output noise's alone, with one average spent on
``z`` (``n_d - 1``; the multiple-input errors of [BP2010]_ sec. 9.3).

References
----------
.. [BP2010] Bendat J. S., Piersol A. G., Random Data: Analysis and
   Measurement Procedures, 4th ed., Wiley, 2010, sec. 7.2 (two-input models,
   conditioned spectra, partial coherence), 9.2.3 and 9.3 (random errors of
   frequency response estimates, single and multiple input) and 11.5
   (Welch's procedure).
.. [Welch1967] Welch P. D., "The use of fast Fourier transform for the
   estimation of power spectra", IEEE Trans. Audio Electroacoust. 15(2),
   1967, p. 70-73 (variance of overlapped averages).
.. [AS2009] Antoni J., Schoukens J., "Optimal settings for measuring
   frequency response functions with weighted overlapped segment averaging",
   IEEE Trans. Instrum. Meas. 58(9), 2009, p. 3276-3287 (leakage errors of
   H1 from overlapped windowed segments); Schoukens J., Rolain Y., Pintelon
   R., "Leakage reduction in frequency-response function measurements",
   IEEE Trans. Instrum. Meas. 55(6), 2006, p. 2286-2291 (leakage as a smooth
   term, removed by a Taylor series).
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
    gzz : numpy.ndarray
        Auto-spectrum of ``z``, ``x`` under the window's derivative (zeros
        where the window has none, as a boxcar).
    gxz, gzy : numpy.ndarray of complex
        Cross-spectra ``conj(X) Z`` and ``conj(Z) Y``.
    """

    frequency: np.ndarray
    gxx: np.ndarray
    gyy: np.ndarray
    gxy: np.ndarray
    segments: int
    n_d: float
    gzz: np.ndarray
    gxz: np.ndarray
    gzy: np.ndarray

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

    def conditioned(self) -> "Spectra":
        """The spectra of ``x`` and ``y`` conditioned on ``z``, the leakage input [BP2010]_.

        ``G_ij.z = G_ij - G_iz G_zj / G_zz`` (unchanged where ``G_zz`` is 0),
        ``n_d`` one less: their :attr:`h1` is the response with the window's
        leakage fitted out, their :attr:`coherence` the partial coherence and
        their :meth:`random_error` the output noise's (module docstring).
        """
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = np.where(self.gzz > 0, 1.0 / np.where(self.gzz > 0, self.gzz, 1.0), 0.0)
        zero = np.zeros_like(self.gzz)
        return Spectra(self.frequency,
                       np.maximum(self.gxx - np.abs(self.gxz) ** 2 * inv, 0.0),
                       np.maximum(self.gyy - np.abs(self.gzy) ** 2 * inv, 0.0),
                       self.gxy - self.gxz * self.gzy * inv, self.segments,
                       max(self.n_d - 1.0, 1.0), zero, zero.astype(complex),
                       zero.astype(complex))


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
        # the window's derivative per sample, centred (the window is DFT-even: periodic)
        self.slope = (np.roll(self.window, -1) - np.roll(self.window, 1)) / 2.0
        self.scale = 1.0 / (self.fs * np.sum(self.window**2))
        bins = self.nperseg // 2 + 1
        self._xx, self._yy = np.zeros(bins), np.zeros(bins)
        self._xy = np.zeros(bins, complex)
        self._zz, self._xz, self._zy = np.zeros(bins), np.zeros(bins, complex), \
            np.zeros(bins, complex)
        self._tail = np.empty((2, 0))
        self._pieces = []  # segments of each piece closed by :meth:`restart`
        self.segments = 0
        self.samples = 0

    def restart(self) -> int:
        """Close the record's current piece (a gap follows it); the next samples start anew.

        The samples not yet in a whole segment are dropped (no segment spans
        a gap), and the pieces' averages are pooled: the sums go on, and
        ``n_d`` is the sum of each piece's equivalent averages.

        Returns
        -------
        int
            The whole segments the piece closed held (0: it was shorter than
            a segment, and none of its samples were used).
        """
        held = self.segments - sum(self._pieces)
        self._pieces.append(held)
        self._tail = np.empty((2, 0))
        return held

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
                z = np.fft.rfft(seg[0] * self.slope, axis=1)
                self._xx += np.sum(np.abs(spec[0]) ** 2, axis=0)
                self._yy += np.sum(np.abs(spec[1]) ** 2, axis=0)
                self._xy += np.sum(np.conj(spec[0]) * spec[1], axis=0)
                self._zz += np.sum(np.abs(z) ** 2, axis=0)
                self._xz += np.sum(np.conj(spec[0]) * z, axis=0)
                self._zy += np.sum(np.conj(z) * spec[1], axis=0)
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
        pieces = [*self._pieces, self.segments - sum(self._pieces)]
        n_d = sum(equivalent_averages(m, self.window, self.step) for m in pieces if m)
        return Spectra(np.fft.rfftfreq(self.nperseg, 1.0 / self.fs), k * self._xx,
                       k * self._yy, k * self._xy, self.segments, float(n_d),
                       k * self._zz, k * self._xz, k * self._zy)
