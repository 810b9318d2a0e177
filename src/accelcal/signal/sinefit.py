"""Sine fits to sampled records: three-parameter (known frequency) and four-parameter.

A record ``y(t_n)``, ``t_n = t0 + n / fs``, is modelled as a constant plus
harmonics ``k = 1..H`` of a frequency ``f``::

    y(t) = c + sum_k [a_k cos(k w t) + b_k sin(k w t)],   w = 2 pi f.

At a known frequency this is linear in ``(c, a_1, b_1, ..., a_H, b_H)``, so
the least-squares solution is one fixed matrix, the pseudo-inverse of the
design, applied to the samples: :class:`HarmonicFit` computes it once per
record length and applies it to any number of records (leading axes) with a
single matrix product. With ``H = 1`` this is the three-parameter fit of
IEEE Std 1057; :func:`sine_fit4` adds the frequency as a fourth parameter
(Gauss-Newton, as in IEEE Std 1057 sec. 4.1.3.3).

Phasors use the convention ``a cos(k w t) + b sin(k w t) = Re(P exp(i k w t))``,
``P = a - i b``: a signal ``A sin(w t + phi)`` has ``P = A exp(i (phi - pi/2))``.
The DC term is ``c``; ``P_1`` is the w phasor and ``P_2`` the 2w phasor.

References
----------
.. [IEEE1057] IEEE Std 1057-2017, Standard for Digitizing Waveform Recorders,
   sec. 4.1.3.1 (three-parameter fit) and 4.1.3.3 (four-parameter fit).
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
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

    The design matrix and its pseudo-inverse are computed once; fitting a
    stack of records is then one matrix product over the samples, so the
    cost is that of reading the data. Records need not span whole periods
    (the pseudo-inverse accounts for the non-orthogonal columns), but must
    span at least one period.

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
        t = float(t0) + np.arange(samples) / self.fs
        self.design = _design(t, self.f, harmonics)  # Sec. 4.1.3.1 [IEEE1057]
        p = self.design.shape[1]
        if samples <= p:
            raise AccelcalError(f"{what}: {samples} samples are too few for {p} parameters")
        q, r = np.linalg.qr(self.design)
        rinv = np.linalg.inv(r)
        # x = R^-1 Q' y: the least-squares operator, precomputed once.
        self.operator = rinv @ q.T
        self.cov_unit = rinv @ rinv.T
        self.gram = self.design.T @ self.design

    def __call__(self, y) -> HarmonicResult:
        """Fit records ``y`` of shape ``(..., n)``; see :class:`HarmonicResult`."""
        y = np.asarray(y, dtype=float)
        if y.shape[-1:] != (self.samples,):
            raise AccelcalError(
                f"record has {y.shape[-1] if y.ndim else 0} samples, the fit expects "
                f"{self.samples}"
            )
        x = y @ self.operator.T
        dof = self.samples - self.design.shape[1]
        s = np.sqrt(self._residual_sum_of_squares(y, x) / dof)
        ab = x[..., 1:].reshape(*x.shape[:-1], self.harmonics, 2)
        return HarmonicResult(
            dc=x[..., 0], phasors=ab[..., 0] - 1j * ab[..., 1], residual_std=s,
            cov_unit=self.cov_unit, samples=self.samples, dof=dof, frequency=self.f,
        )


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
        yy = np.einsum("...n,...n->...", y, y)
        rss = yy - np.einsum("...i,ij,...j->...", x, self.gram, x)
        close = rss <= 1e3 * np.sqrt(self.samples) * np.finfo(float).eps * yy
        if np.any(close):
            resid = y[close] - x[close] @ self.design.T
            rss = np.array(rss, copy=True)
            rss[close] = np.einsum("...n,...n->...", resid, resid)
        return np.maximum(rss, 0.0)


def sine_fit3(y, fs: float, f: float, *, harmonics: int = 1, t0: float = 0.0) -> HarmonicResult:
    """Three-parameter sine fit at a known frequency (plus optional harmonics).

    Convenience wrapper of :class:`HarmonicFit` for records ``y`` of shape
    ``(..., n)``.

    References
    ----------
    .. [1] IEEE Std 1057-2017, sec. 4.1.3.1.
    """
    y = np.asarray(y, dtype=float)
    return HarmonicFit(y.shape[-1], fs, f, harmonics=harmonics, t0=t0)(y)


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


def _design(t, f, harmonics):
    cols = [np.ones_like(t)]
    for k in range(1, harmonics + 1):
        wt = 2 * np.pi * k * f * t
        cols += [np.cos(wt), np.sin(wt)]
    return np.stack(cols, axis=-1)


def _dft_peak(y, fs):
    n = y.shape[-1]
    spec = np.abs(np.fft.rfft(y - y.mean(axis=-1, keepdims=True), axis=-1))
    k = np.clip(np.argmax(spec[..., 1:], axis=-1) + 1, 1, spec.shape[-1] - 2)
    idx = k[..., None] + np.array([-1, 0, 1])
    lm = np.log(np.take_along_axis(spec, idx, axis=-1) + 1e-300)
    den = lm[..., 0] - 2 * lm[..., 1] + lm[..., 2]
    delta = np.where(den != 0, 0.5 * (lm[..., 0] - lm[..., 2]) / np.where(den != 0, den, 1), 0.0)
    return (k + delta) * fs / n
