"""Allan-family deviations of a still recording, with noise identification and intervals.

:func:`compute` gives the deviations of rate samples ``y`` (acceleration, in
any unit) at ``tau = m tau0``: ADEV (Eq. (7)), overlapping ADEV (Eq. (11)),
modified ADEV (Eq. (14)), Hadamard (Eq. (18)), overlapping Hadamard
(Eq. (20)) and total deviation (Eq. (25), reflection at both ends) of NIST
SP 1065 [SP1065]_, all from the phase ``x = tau0 cumsum(y - mean(y))``
(:mod:`~accelcal.signal.allan.kernels`, which says why the mean goes
first). Each tau costs O(N) vectorised work in float64 (O(N/m) for the
non-overlapping kinds) and O(N) memory; the tau set ``"all"`` (every m, up
to N/2 for OADEV) therefore costs O(N x number of taus) = O(N^2) work in
total, done tau by tau with no Python loop over samples (about 3 s per 1e4
taus of 1e5 samples for :func:`compute`; :func:`deviation` adds about 0.2 ms
per tau for the EDF). Use ``"octave"`` or ``"decade"`` for long records: 1e7
samples take under a second for the 23 octave taus of OADEV.

:func:`deviation` adds, per tau, the identified noise exponent alpha
(:mod:`~accelcal.signal.allan.identify`, or one alpha given for all
taus), the equivalent degrees of freedom of Greenhall and Riley
(:mod:`~accelcal.signal.allan.edf`) and the chi-square interval at the
requested confidence (default 0.683, Stable32's one-sigma bars), in a
:class:`Deviation`.

Bad input is refused with an :class:`~accelcal.errors.AccelcalError` of one
line. Errors about the samples name ``values`` (what the recordings layer
and the command line call them): not 1-D, non-finite (the index of the
first NaN or infinity: a gap is never averaged over), constant, too short
for the kind; ``rate`` (finite and > 0), ``kind``, ``taus``, ``confidence``
and ``alpha`` name themselves.

References
----------
.. [SP1065] Riley W. J., Handbook of Frequency Stability Analysis, NIST
   Special Publication 1065, 2008, eqs. (7), (11), (14), (18), (20), (25).
.. [GR2003] Greenhall C. A., Riley W. J., Uncertainty of stability variances
   based on finite differences, Proc. 35th PTTI Meeting, 2003.
.. [RG2004] Riley W. J., Greenhall C. A., Power law noise identification using
   the lag 1 autocorrelation, Proc. 18th EFTF, 2004.
.. [Howe2000] Howe D. A., The total deviation approach to long-term
   characterization of frequency stability, IEEE Trans. UFFC 47(5), 2000.
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.resources import check_memory
from accelcal.signal.allan.edf import check_confidence, confidence_interval, edf
from accelcal.signal.allan.identify import alpha_range, interval_alphas
from accelcal.signal.allan.kernels import phase, variance_sums
from accelcal.signal.allan.taus import (
    KINDS,
    check_kind,
    check_work,
    min_samples,
    tau_grid,
    taus_to_m,
)
from accelcal.validation import check_rate, shown

__all__ = ["KINDS", "Deviation", "compute", "deviation"]

DIVISOR = {"adev": 2.0, "oadev": 2.0, "mdev": 2.0, "totdev": 2.0, "hdev": 6.0, "ohdev": 6.0}
"""Denominator factor of each variance: 2 (Allan family, total), 6 (Hadamard)."""

MEMORY_FACTOR = 4.0
"""Arrays of N float64 held at the peak: samples, phase, and two work arrays
(MDEV) or the reflected phase (TOTDEV)."""


def check_samples(y, kind: str = "oadev") -> np.ndarray:
    """Rate samples as a 1-D float64 array, refused (``values``) when unusable.

    Parameters
    ----------
    y : array_like
        Rate samples.
    kind : str
        The deviation, for the minimum length.

    Returns
    -------
    numpy.ndarray
        The samples (float64, 1-D; the input itself when it already is).

    Raises
    ------
    AccelcalError
        Not numbers, not 1-D, too short for ``kind``, a NaN or infinity (its
        index), or a constant signal.
    """
    try:
        arr = np.asarray(y, dtype=np.float64)
    except (TypeError, ValueError):
        raise AccelcalError(f"{shown(y)} is not a series of numbers", parameter="values") from None
    if arr.ndim != 1:
        raise AccelcalError(f"give one channel (a 1-D series), not an array of shape {arr.shape}",
                            parameter="values")
    need = min_samples(kind)
    if len(arr) < need:
        raise AccelcalError(f"{len(arr)} samples are too few for {kind}: it needs at least {need}",
                            parameter="values")
    check_memory(len(arr), 1, MEMORY_FACTOR, f"the {kind} of {len(arr)} samples",
                 parameter="values", hint="use the streaming analysis for long records")
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        raise AccelcalError(f"sample {bad[0]} is {arr[bad[0]]}; remove or fill the gap first "
                            "(a gap is never averaged over)", parameter="values")
    if arr.max() == arr.min():
        raise AccelcalError("the signal is constant; a deviation of 0 says nothing",
                            parameter="values")
    return arr


def _deviations(x: np.ndarray, m: np.ndarray, kind: str, progress=None
                ) -> tuple[np.ndarray, np.ndarray]:
    sums, counts = variance_sums(x, m, kind, progress)
    scale = m.astype(float) ** 2 if kind == "mdev" else m.astype(float)
    return np.sqrt(sums / (DIVISOR[kind] * counts)) / scale, counts


def compute(y, rate: float, kind: str = "oadev", m=None):
    """Deviation of rate samples at averaging factors m.

    Parameters
    ----------
    y : array_like
        Rate samples (1-D, finite, not constant), any unit.
    rate : float
        Sample rate, Hz (``tau0 = 1/rate``).
    kind : str
        One of :data:`KINDS`.
    m : array_like of int or str, optional
        Averaging factors, or a tau set name (``"octave"``, ``"decade"``,
        ``"all"``); ``None`` is ``"octave"``
        (:func:`~accelcal.signal.allan.taus.tau_grid`).

    Returns
    -------
    tau_s, m, n_terms, dev : numpy.ndarray
        Averaging times (s), factors, squared differences averaged and
        deviations (in the unit of ``y``), one entry per factor, ascending.
    """
    kind = check_kind(kind)
    rate = check_rate(rate)
    arr = check_samples(y, kind)
    factors = tau_grid(len(arr), "octave" if m is None else m, kind=kind)
    dev, counts = _deviations(phase(arr), factors, kind)
    return factors / rate, factors, counts, dev


@dataclass(frozen=True)
class Deviation:
    """Deviations of one recording with noise type, EDF and confidence intervals.

    Parameters
    ----------
    kind : str
        One of :data:`KINDS`.
    tau : numpy.ndarray
        Averaging times, s.
    m : numpy.ndarray
        Averaging factors (``tau * rate``).
    n : numpy.ndarray
        Squared differences averaged at each tau.
    dev : numpy.ndarray
        Deviations, in ``unit``.
    alpha : numpy.ndarray
        Noise exponent (``S_y ~ f^alpha``) used for the EDF: identified, or given.
    edf : numpy.ndarray
        Equivalent degrees of freedom.
    lo, hi : numpy.ndarray
        Interval bounds at ``confidence``, in ``unit``.
    confidence : float
        Probability the intervals are stated at.
    unit : str
        Unit of the samples (and of the deviations).
    rate : float
        Sample rate, Hz.
    samples : int
        Samples in the recording.
    alpha_source : tuple of str
        Where each tau's alpha comes from: ``"identified"`` (at least 128
        block averages), ``"carried"`` (the median of the longest identified
        taus' alphas: the interval assumes the noise type does not change),
        ``"guessed"`` (no tau had enough averages: the interval is not known
        to hold) or ``"given"`` (:func:`~accelcal.signal.allan.identify.interval_alphas`).
    """

    kind: str
    tau: np.ndarray
    m: np.ndarray
    n: np.ndarray
    dev: np.ndarray
    alpha: np.ndarray
    edf: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    confidence: float
    unit: str
    rate: float
    samples: int
    alpha_source: tuple = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "alpha_source", tuple(self.alpha_source)
                           or ("identified",) * np.size(self.tau))
        for name in ("tau", "m", "n", "dev", "alpha", "edf", "lo", "hi"):
            arr = np.array(getattr(self, name))
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    def rows(self) -> list[dict]:
        """One dict per tau: ``tau_s, n, alpha, dev, dev_low, dev_high`` (the CSV columns)."""
        return [
            {"tau_s": float(t), "n": int(n), "alpha": int(a), "dev": float(d),
             "dev_low": float(lo), "dev_high": float(hi)}
            for t, n, a, d, lo, hi in zip(self.tau, self.n, self.alpha, self.dev, self.lo,
                                          self.hi, strict=True)
        ]


def _given_alpha(alpha, kind: str, count: int) -> np.ndarray:
    low, high = alpha_range(kind)
    try:
        value = float(alpha)
    except (TypeError, ValueError):
        raise AccelcalError(f"{shown(alpha)} is not a noise exponent", parameter="alpha") from None
    if value != round(value) or not low <= value <= high:
        raise AccelcalError(f"{shown(alpha)} must be an integer from {low} to {high} for {kind} "
                            "(2 white PM, 0 white FM, -1 flicker FM, -2 random walk FM)",
                            parameter="alpha")
    return np.full(count, int(value), dtype=np.int64)


def deviation(y, rate: float, *, kind: str = "oadev", taus="octave", confidence: float = 0.683,
              unit: str = "", alpha=None, force: bool = False, progress=None) -> Deviation:
    """Deviations with identified noise, EDF and chi-square intervals.

    Parameters
    ----------
    y : array_like
        Rate samples (1-D, finite, not constant), in ``unit``.
    rate : float
        Sample rate, Hz.
    kind : str
        One of :data:`KINDS`.
    taus : str or sequence of float
        ``"octave"``, ``"decade"``, ``"all"``, or averaging times in seconds
        (whole multiples of ``1/rate``).
    confidence : float
        Confidence of the intervals, in (0, 1).
    unit : str
        Unit of the samples, carried into the result.
    alpha : int, optional
        Noise exponent to use at every tau instead of identifying it. Without
        it, taus of at least 128 block averages are identified and the longer
        ones carry the median alpha of the three longest identified taus
        (:func:`~accelcal.signal.allan.identify.interval_alphas`; the result's
        ``alpha_source`` says which).
    force : bool
        Run a tau set estimated to take longer than
        :data:`~accelcal.signal.allan.taus.MAX_SECONDS` (refused otherwise,
        :func:`~accelcal.signal.allan.taus.check_work`).
    progress : callable, optional
        ``progress(done, total)`` after each tau.

    Returns
    -------
    Deviation
        One entry per tau.
    """
    kind = check_kind(kind)
    rate = check_rate(rate)
    confidence = check_confidence(confidence)
    arr = check_samples(y, kind)
    spec = taus if isinstance(taus, str) else taus_to_m(taus, rate)
    m = tau_grid(len(arr), spec, kind=kind)
    check_work(len(arr), m, kind, force=force)
    given = None if alpha is None else _given_alpha(alpha, kind, len(m))
    x = phase(arr)
    dev, counts = _deviations(x, m, kind, progress)
    if given is None:
        alphas, sources = interval_alphas(x, m, kind)
    else:
        alphas, sources = given, ("given",) * len(m)
    dof = edf(kind, alphas, m, len(arr))
    lo, hi = confidence_interval(dev, dof, confidence)
    return Deviation(kind=kind, tau=m / rate, m=m, n=counts, dev=dev, alpha=alphas, edf=dof,
                     lo=lo, hi=hi, confidence=confidence, unit=str(unit), rate=rate,
                     samples=len(arr), alpha_source=sources)
