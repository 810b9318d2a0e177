"""Sine fits to sampled records: three-parameter (known frequency) and four-parameter.

A record ``y(t_n)``, ``t_n = t0 + n / fs``, is modelled as a constant plus
harmonics ``k = 1..H`` of a frequency ``f``::

    y(t) = c + sum_k [a_k cos(k w t) + b_k sin(k w t)],   w = 2 pi f.

At a known frequency this is linear in ``(c, a_1, b_1, ..., a_H, b_H)``:
:class:`HarmonicFit` solves its normal equations from the design's sums
(:mod:`accelcal.signal.blocksums`: O(sqrt(n)) set-up, never the n x p
design), once per time base, for any number of records (leading axes) in
a few passes over the samples. With ``H = 1`` this is the three-parameter
fit of IEEE Std 1057; :func:`sine_fit4` adds the frequency as a fourth
parameter (Gauss-Newton, as in IEEE Std 1057 sec. 4.1.3.3).

Phasors use the convention ``a cos(k w t) + b sin(k w t) = Re(P exp(i k w t))``,
``P = a - i b``: a signal ``A sin(w t + phi)`` has ``P = A exp(i (phi - pi/2))``.
The DC term is ``c``; ``P_1`` is the w phasor and ``P_2`` the 2w phasor.

References
----------
.. [IEEE1057] IEEE Std 1057-2017, Standard for Digitizing Waveform Recorders,
   sec. 4.1.3.1 (three-parameter fit) and 4.1.3.3 (four-parameter fit).
"""

from dataclasses import dataclass
from fractions import Fraction
from functools import lru_cache

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.signal.blocksums import BlockSums
from accelcal.signal.periods import check_sampling


@dataclass(frozen=True)
class HarmonicResult:
    """Result of a harmonic fit, one per leading index of the records.

    Attributes
    ----------
    dc : numpy.ndarray
        Constant term ``c``, shape ``(...)``.
    phasors : numpy.ndarray
        Complex phasors ``P_k = a_k - i b_k`` for ``k = 1..H``, shape ``(..., H)``.
    residual_std : numpy.ndarray
        Residual standard deviation ``sqrt(r'r / (n - p))``, shape ``(...)``.
    cov_unit : numpy.ndarray
        ``(D'D)^-1`` of the design, shape ``(p, p)``, parameters ordered
        ``(c, a_1, b_1, ..., a_H, b_H)``; the covariance of one record's
        parameters is ``residual_std**2 * cov_unit``.
    samples : int
        Samples per record.
    dof : int
        Residual degrees of freedom ``n - p``.
    frequency : numpy.ndarray or float
        Frequency of the fit, Hz (fitted by :func:`sine_fit4`).

    References
    ----------
    .. [1] IEEE Std 1057-2017, sec. 4.1.3.
    """

    dc: np.ndarray
    phasors: np.ndarray
    residual_std: np.ndarray
    cov_unit: np.ndarray
    samples: int
    dof: int
    frequency: np.ndarray | float

    @property
    def amplitude(self) -> np.ndarray:
        """Amplitude ``|P_1|`` of the fundamental."""
        return np.abs(self.phasors[..., 0])

    @property
    def phase(self) -> np.ndarray:
        """Phase ``phi`` of the fundamental written as ``A sin(w t + phi)``, rad."""
        return np.angle(self.phasors[..., 0]) + np.pi / 2

    @property
    def parameters(self) -> np.ndarray:
        """Real parameters ``(c, a_1, b_1, ..., a_H, b_H)``, shape ``(..., p)``."""
        ab = np.stack([self.phasors.real, -self.phasors.imag], axis=-1)
        return np.concatenate([self.dc[..., None], ab.reshape(*ab.shape[:-2], -1)], axis=-1)

    @property
    def covariance(self) -> np.ndarray:
        """Covariance of :attr:`parameters`, shape ``(..., p, p)``."""
        s2 = np.asarray(self.residual_std) ** 2
        return s2[..., None, None] * self.cov_unit

    @property
    def amplitude_std(self) -> np.ndarray:
        """Standard uncertainty of :attr:`amplitude` (first-order propagation)."""
        a, b = self.phasors[..., 0].real, -self.phasors[..., 0].imag
        amp = np.hypot(a, b)
        c = self.cov_unit
        safe = np.where(amp > 0, amp, 1.0)
        var_unit = (a**2 * c[1, 1] + b**2 * c[2, 2] + 2 * a * b * c[1, 2]) / safe**2
        var_unit = np.where(amp > 0, var_unit, 0.5 * (c[1, 1] + c[2, 2]))
        return self.residual_std * np.sqrt(var_unit)


class HarmonicFit:
    """Least-squares fit of DC and harmonics 1..H at a known frequency.

    Everything that depends on the time base alone is computed once, in
    O(sqrt(n)) time and memory (never the n x p design,
    :class:`~accelcal.signal.blocksums.BlockSums`): fitting a stack of
    records is then a few passes over the samples (the weighted sums
    ``D'y`` and the sums of squares), and the normal equations
    ``(D'D) x = D'y`` of p unknowns. Records need not span whole periods,
    but must span at least one. Reuse one fit for records of one time base
    (:func:`sine_fit3` keeps the last few).

    When a whole number of periods spans ``q`` samples (coherent sampling,
    which IEEE 1057 recommends: ``f q / fs`` an integer, to within 1e-12 rad
    of phase accumulated over the record), the record is first folded: its
    blocks of ``q`` samples are summed, one pass over the samples, and the
    sums are taken over the ``q`` folded samples.

    Parameters
    ----------
    samples : int
        Samples per record, ``n``.
    fs : float
        Sample rate, Hz.
    f : float
        Frequency of the fundamental, Hz (below fs / (2 H)).
    harmonics : int
        Highest harmonic ``H`` fitted (1 gives the IEEE 1057 three-parameter fit).
    t0 : float
        Time of the first sample, s (phasors refer to t = 0).
    what : str
        Name used in error messages.

    Raises
    ------
    AccelcalError
        For a non-positive rate or frequency, a harmonic at or above the
        Nyquist frequency, or a record shorter than one period.

    References
    ----------
    .. [1] IEEE Std 1057-2017, sec. 4.1.3.1, three-parameter sine fit.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(100) / 1000.0
    >>> fit = HarmonicFit(100, 1000.0, 50.0)
    >>> r = fit(2.0 * np.sin(2 * np.pi * 50.0 * t + 0.3) + 0.5)
    >>> round(float(r.amplitude), 12), round(float(r.dc), 12), round(float(r.phase), 12)
    (2.0, 0.5, 0.3)
    """

    def __init__(
        self, samples: int, fs: float, f: float, *, harmonics: int = 1, t0: float = 0.0,
        what: str = "record",
    ) -> None:
        samples = int(samples)
        harmonics = int(harmonics)
        check_sampling(samples, fs, f, harmonics=harmonics, what=what)
        self.samples, self.fs, self.f, self.harmonics = samples, float(fs), float(f), harmonics
        p = 1 + 2 * harmonics
        if samples <= p:
            raise AccelcalError(f"{what}: {samples} samples are too few for {p} parameters")
        ratio = Fraction(self.f) / Fraction(self.fs)  # cycles per sample, exact
        start = float((Fraction(self.f) * Fraction(float(t0))) % 1)
        self.fold = _fold_period(samples, ratio, harmonics)
        self._sums = BlockSums(self.fold or samples, ratio, start, harmonics)
        if self.fold:  # Sec. 4.1.3.1 [IEEE1057]: D'D of the whole folds and the rest
            folds, rest = divmod(samples, self.fold)
            self.gram = folds * self._sums.gram(self.fold) + self._sums.gram(rest)
        else:
            self.gram = self._sums.gram(samples)
        cov = np.linalg.inv(self.gram)
        self.cov_unit = 0.5 * (cov + cov.T)
        for shared in (self.gram, self.cov_unit):  # shared by every result of this fit
            shared.setflags(write=False)

    @property
    def design(self) -> np.ndarray:
        """The ``n x p`` design matrix, built on request (the fit never forms it)."""
        if not self.fold:
            return self._sums.design(self.samples)
        folds, rest = divmod(self.samples, self.fold)
        one = self._sums.design(self.fold)
        return np.concatenate([np.tile(one, (folds, 1)), one[:rest]])

    def __call__(self, y) -> HarmonicResult:
        """Fit records ``y`` of shape ``(..., n)``; see :class:`HarmonicResult`."""
        y = np.asarray(y, dtype=float)
        if y.shape[-1:] != (self.samples,):
            raise AccelcalError(
                f"record has {y.shape[-1] if y.ndim else 0} samples, the fit expects "
                f"{self.samples}"
            )
        x = self._sums.sums(self._folded(y)) @ self.cov_unit  # x = (D'D)^-1 D'y
        dof = self.samples - self.cov_unit.shape[0]
        s = np.sqrt(self._residual_sum_of_squares(y, x) / dof)
        ab = x[..., 1:].reshape(*x.shape[:-1], self.harmonics, 2)
        return HarmonicResult(
            dc=x[..., 0], phasors=ab[..., 0] - 1j * ab[..., 1], residual_std=s,
            cov_unit=self.cov_unit, samples=self.samples, dof=dof, frequency=self.f,
        )

    def _folded(self, y: np.ndarray) -> np.ndarray:
        """The records summed over whole folds (the rest added to the first samples)."""
        if not self.fold:
            return y
        folds, rest = divmod(self.samples, self.fold)
        head = y[..., : folds * self.fold].reshape(*y.shape[:-1], folds, self.fold)
        out = head.sum(axis=-2)
        out[..., :rest] += y[..., folds * self.fold:]
        return out

    def _residual_sum_of_squares(self, y: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Residual sum of squares r'r of every record, in one more pass over the samples.

        At the least-squares solution r'r = y'y - x'(D'D)x, which needs only
        y'y besides the fit. The difference cancels when the residual is tiny
        beside the signal: its rounding error is at most about sqrt(n) eps y'y
        (measured: 1e-17 y'y at n = 1e5). Records with r'r below
        1e3 sqrt(n) eps y'y, where that bound could exceed 1e-3 of r'r, get
        their residuals computed directly, exact to rounding; only nearly
        noise-free records (noise below ~1e-5 of the signal) pay the extra
        passes.
        """
        # einsum, not a batched matmul: BLAS would thread a (1 x n)(n x 1) product, and
        # on a busy machine its threads cost 50x the pass itself (a 20-step campaign)
        yy = np.einsum("...n,...n->...", y, y)
        rss = yy - np.einsum("...i,ij,...j->...", x, self.gram, x)
        close = rss <= 1e3 * np.sqrt(self.samples) * np.finfo(float).eps * yy
        if np.any(close):
            resid = y[close] - x[close] @ self.design.T
            rss = np.array(rss, copy=True)
            rss[close] = np.einsum("...n,...n->...", resid, resid)
        return np.maximum(rss, 0.0)


FIT_CACHE = 8
"""Fits (time bases) :func:`sine_fit3` keeps for records that share one, each O(sqrt(n))."""


@lru_cache(maxsize=FIT_CACHE)
def _cached_fit(samples: int, fs: float, f: float, harmonics: int, t0: float) -> HarmonicFit:
    return HarmonicFit(samples, fs, f, harmonics=harmonics, t0=t0)


def sine_fit3(y, fs: float, f: float, *, harmonics: int = 1, t0: float = 0.0) -> HarmonicResult:
    """Three-parameter sine fit at a known frequency (plus optional harmonics).

    Convenience wrapper of :class:`HarmonicFit` for records ``y`` of shape
    ``(..., n)``. The last :data:`FIT_CACHE` time bases (samples, rate,
    frequency, harmonics, start) are kept, so calls on records of one time
    base share one fit.

    References
    ----------
    .. [1] IEEE Std 1057-2017, sec. 4.1.3.1.
    """
    y = np.asarray(y, dtype=float)
    n = y.shape[-1] if y.ndim else 0
    try:
        fit = _cached_fit(int(n), float(fs), float(f), int(harmonics), float(t0))
    except TypeError:  # an unhashable argument: fit without the cache (same errors)
        fit = HarmonicFit(n, fs, f, harmonics=harmonics, t0=t0)
    return fit(y)


def sine_fit4(
    y, fs: float, f0: float | None = None, *, t0: float = 0.0, max_iter: int = 30,
    rtol: float = 1e-13,
) -> HarmonicResult:
    """Four-parameter sine fit: amplitude, phase, offset and frequency.

    Gauss-Newton iterations on ``(c, a, b, f)`` from a three-parameter fit
    at the starting frequency, vectorised over the leading axes (each record
    keeps its own frequency). Without ``f0`` the start is the largest DFT
    bin refined by parabolic interpolation of the log magnitude.

    Parameters
    ----------
    y : array_like, shape (..., n)
        Records; at least a few periods give a well-determined frequency.
    fs : float
        Sample rate, Hz.
    f0 : float, optional
        Starting frequency, Hz.
    t0 : float
        Time of the first sample, s.
    max_iter : int
        Maximum Gauss-Newton iterations.
    rtol : float
        Stop when every relative frequency step is below this.

    Returns
    -------
    HarmonicResult
        With ``frequency`` of shape ``(...)`` and ``cov_unit`` of shape
        ``(..., 4, 4)`` ordered ``(c, a, b, f)``.

    Raises
    ------
    AccelcalError
        If the iteration does not converge (too few periods, or no sine).

    References
    ----------
    .. [1] IEEE Std 1057-2017, sec. 4.1.3.3, four-parameter sine fit.
    """
    y = np.asarray(y, dtype=float)
    n = y.shape[-1]
    if f0 is None:
        f0 = _dft_peak(y, fs)
    f = np.broadcast_to(np.asarray(f0, dtype=float), y.shape[:-1]).copy()
    check_sampling(n, fs, float(np.max(f)), what="record")
    t = t0 + np.arange(n) / fs
    for _ in range(max_iter):
        x, d4, _ = _four_parameter_step(y, t, f)
        resid = y - np.einsum("...np,...p->...n", d4[..., :3], x)
        ntn = np.swapaxes(d4, -1, -2) @ d4
        # Sec. 4.1.3.3 [IEEE1057]: Gauss-Newton step of the frequency
        step = np.linalg.solve(ntn, np.swapaxes(d4, -1, -2) @ resid[..., None])[..., 3, 0]
        f = f + step
        if np.all(np.abs(step) <= rtol * np.abs(f)):
            break
    else:
        raise AccelcalError(
            f"four-parameter sine fit did not converge in {max_iter} iterations; record more "
            "periods or give a starting frequency"
        )
    x, d4, resid = _four_parameter_step(y, t, f)
    dof = n - 4
    sd = np.sqrt(np.einsum("...n,...n->...", resid, resid) / dof)
    cov_unit = np.linalg.inv(np.swapaxes(d4, -1, -2) @ d4)
    a, b = x[..., 1], x[..., 2]
    return HarmonicResult(
        dc=x[..., 0], phasors=(a - 1j * b)[..., None], residual_std=sd, cov_unit=cov_unit,
        samples=n, dof=dof, frequency=f if f.ndim else float(f),
    )


def _four_parameter_step(y, t, f):
    """Three-parameter fit at frequencies ``f`` (...,) and the four-parameter Jacobian."""
    wt = 2 * np.pi * f[..., None] * t
    c, s = np.cos(wt), np.sin(wt)
    d3 = np.stack([np.ones_like(c), c, s], axis=-1)
    d3t = np.swapaxes(d3, -1, -2)
    x = np.linalg.solve(d3t @ d3, d3t @ y[..., None])[..., 0]
    a, b = x[..., 1:2], x[..., 2:3]
    dfcol = 2 * np.pi * t * (-a * s + b * c)  # d/df of a cos(wt) + b sin(wt)
    resid = y - np.einsum("...np,...p->...n", d3, x)
    return x, np.concatenate([d3, dfcol[..., None]], axis=-1), resid


FOLD_PHASE_RTOL = 1e-12
"""Largest phase (rad) a fold may miss over a record and still count as whole periods."""

MAX_FOLD = 2**16
"""Longest fold, samples."""


def _fold_period(samples: int, ratio: Fraction, harmonics: int) -> int:
    """Samples spanning whole periods (coherent sampling), or 0 when none fits twice.

    ``q`` is the denominator of the best approximation of ``f / fs`` with
    ``q`` at most :data:`MAX_FOLD` and half the record; it counts when the
    phase it misses, accumulated over the record at the highest harmonic, is
    below :data:`FOLD_PHASE_RTOL`. It is lengthened to a multiple of at
    least 1024 samples where the record allows (long rows sum faster).
    """
    q = ratio.limit_denominator(max(1, min(MAX_FOLD, samples // 2))).denominator
    missed = float(abs(ratio * q - round(ratio * q)))
    if q > samples // 2 or missed * 2 * np.pi * harmonics * samples / q > FOLD_PHASE_RTOL:
        return 0
    return q * max(1, min(-(-1024 // q), samples // (2 * q), MAX_FOLD // q))


def _dft_peak(y, fs):
    n = y.shape[-1]
    spec = np.abs(np.fft.rfft(y - y.mean(axis=-1, keepdims=True), axis=-1))
    k = np.clip(np.argmax(spec[..., 1:], axis=-1) + 1, 1, spec.shape[-1] - 2)
    idx = k[..., None] + np.array([-1, 0, 1])
    lm = np.log(np.take_along_axis(spec, idx, axis=-1) + 1e-300)
    den = lm[..., 0] - 2 * lm[..., 1] + lm[..., 2]
    delta = np.where(den != 0, 0.5 * (lm[..., 0] - lm[..., 2]) / np.where(den != 0, den, 1), 0.0)
    return (k + delta) * fs / n
