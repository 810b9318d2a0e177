"""Averaging factors (taus) of the Allan-family deviations, and how many terms each averages.

A still recording of ``n`` rate samples ``y`` (acceleration) at ``tau0 = 1/rate``
gives ``n + 1`` phase points ``x`` (``x = tau0 cumsum(y)`` with ``x_0 = 0``). A
deviation at ``tau = m tau0`` averages ``n_terms(n, m, kind)`` squared
differences of ``x`` [SP1065]_:

========  ===============================  ============================
kind      terms averaged                   largest m (at least 2 terms)
========  ===============================  ============================
adev      ``floor(n/m) - 1``   Eq. (7)     ``n // 3``
oadev     ``n + 1 - 2m``       Eq. (11)    ``(n - 1) // 2``
mdev      ``n + 2 - 3m``       Eq. (14)    ``n // 3``
hdev      ``floor(n/m) - 2``   Eq. (18)    ``n // 4``
ohdev     ``n + 1 - 3m``       Eq. (20)    ``(n - 1) // 3``
totdev    ``n - 1``            Eq. (25)    ``n // 2``
========  ===============================  ============================

Every tau needs at least :data:`MIN_TERMS` terms (one squared difference
says nothing of its own scatter; allantools drops such taus too). The total
deviation always averages ``n - 1`` terms because it extends the record by
reflection at both ends; its taus stop at half the record (``m <= n/2``,
Stable32's stop ratio 2 for TOTDEV [Riley2004s]_), beyond which the
reflected data dominate the estimate.

Tau sets (:func:`tau_grid`): ``"octave"`` (m = 1, 2, 4, 8, ...),
``"decade"`` (1, 2, 4, 10, 20, 40, 100, ..., as Stable32), ``"all"`` (every
allowed m), or a sequence of averaging factors. :func:`taus_to_m` turns
taus in seconds into averaging factors, refusing those that are not whole
multiples of ``tau0``.

References
----------
.. [SP1065] Riley W. J., Handbook of Frequency Stability Analysis, NIST
   Special Publication 1065, 2008, eqs. (7), (11), (14), (18), (20),
   (25).
.. [Riley2004s] Riley W. J., The evolution of frequency stability analysis
   software, Hamilton Technical Services, 2004, Table III (stop ratios).
"""

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.validation import check_rate, shown

KINDS = ("adev", "oadev", "mdev", "hdev", "ohdev", "totdev")
"""The deviations: Allan, overlapping Allan, modified Allan, Hadamard,
overlapping Hadamard and total deviation [SP1065]_."""

MIN_TERMS = 2
"""Fewest squared differences a deviation may average."""

SPECS = ("octave", "decade", "all")
"""Named tau sets."""


def check_kind(kind) -> str:
    """The kind, refused (``kind``) unless one of :data:`KINDS`."""
    if not isinstance(kind, str) or kind not in KINDS:
        raise AccelcalError(f"unknown deviation {shown(kind)}; use one of {', '.join(KINDS)}",
                            parameter="kind")
    return kind


def n_terms(n: int, m, kind: str) -> np.ndarray:
    """Squared differences averaged at averaging factors ``m`` of ``n`` rate samples.

    Parameters
    ----------
    n : int
        Rate samples (``n + 1`` phase points).
    m : int or array_like of int
        Averaging factors.
    kind : str
        One of :data:`KINDS`.

    Returns
    -------
    numpy.ndarray
        Terms per averaging factor (int64; may be < 1 where m is too large).
    """
    m = np.asarray(m, dtype=np.int64)
    n = int(n)
    terms = {
        "adev": lambda: n // m - 1,           # Eq. (7) [SP1065], non-overlapping
        "oadev": lambda: n + 1 - 2 * m,       # Eq. (11) [SP1065]
        "mdev": lambda: n + 2 - 3 * m,        # Eq. (14) [SP1065]
        "hdev": lambda: n // m - 2,           # Eq. (18) [SP1065], non-overlapping
        "ohdev": lambda: n + 1 - 3 * m,       # Eq. (20) [SP1065]
        "totdev": lambda: np.full_like(m, n - 1),  # Eq. (25) [SP1065]
    }[check_kind(kind)]
    return np.asarray(terms(), dtype=np.int64)


SECONDS_PER_TERM = 4e-9
"""Time of one squared difference of an overlapping deviation, s: measured, about 3-4 s
per 1e4 taus of 1e5 samples (module :mod:`~accelcal.signal.allan.deviations`) on one core."""

SECONDS_PER_TAU = 2e-4
"""Time of each tau's own work (noise identification, EDF, interval), s (measured)."""

WORK_FACTOR = {"adev": 1.0, "oadev": 1.0, "mdev": 3.0, "hdev": 1.5, "ohdev": 1.5, "totdev": 1.5}
"""Cost of a term of each kind relative to OADEV's (MDEV's terms are sums of second
differences through two work arrays, the Hadamard ones third differences)."""

MAX_SECONDS = 60.0
"""Longest estimated computation of a tau set run without ``force``, s."""


def work_seconds(n: int, m, kind: str) -> float:
    """Estimated time of the deviation ``kind`` of ``n`` samples at averaging factors ``m``, s.

    The squared differences summed (:func:`n_terms`, O(N) per tau, O(N/m)
    for the non-overlapping kinds) times :data:`SECONDS_PER_TERM` and the
    kind's :data:`WORK_FACTOR`, plus :data:`SECONDS_PER_TAU` per tau: the tau
    set ``all`` is O(N^2). On one unloaded core; a busy machine takes longer.
    """
    terms = float(np.clip(n_terms(n, m, kind), 0, None).sum())
    return (terms * SECONDS_PER_TERM * WORK_FACTOR[check_kind(kind)]
            + np.size(m) * SECONDS_PER_TAU)


def check_work(n: int, m, kind: str, *, force: bool = False) -> float:
    """Refuse a tau set whose estimated time exceeds :data:`MAX_SECONDS` (unless ``force``).

    Returns
    -------
    float
        The estimate, s.

    Raises
    ------
    AccelcalError
        Naming ``taus`` with the estimate and the bound.
    """
    from accelcal import work

    est = work.Estimate(f"{kind} at {np.size(m):,} taus of {int(n):,} samples",
                        work_seconds(n, m, kind), basis="measured per term")
    work.check(est, force=force, parameter="taus", bound=MAX_SECONDS,
               hint="use the octave or decade tau set or fewer taus")
    return est.seconds


def max_m(n: int, kind: str) -> int:
    """Largest averaging factor of ``kind`` for ``n`` rate samples (0 when none is allowed)."""
    n = int(n)
    limit = {
        "adev": n // 3,
        "oadev": (n - 1) // 2,
        "mdev": n // 3,
        "hdev": n // 4,
        "ohdev": (n - 1) // 3,
        "totdev": n // 2 if n - 1 >= MIN_TERMS else 0,
    }[check_kind(kind)]
    return max(int(limit), 0)


def min_samples(kind: str) -> int:
    """Fewest rate samples for which ``kind`` has one tau (m = 1)."""
    return next(n for n in range(2, 16) if max_m(n, kind) >= 1)


def _named(spec: str, top: int) -> np.ndarray:
    if spec == "all":
        return np.arange(1, top + 1, dtype=np.int64)
    if spec == "octave":
        return 2 ** np.arange(top.bit_length(), dtype=np.int64)
    decades = 10 ** np.arange(len(str(top)), dtype=np.int64)
    grid = (decades[:, None] * np.array([1, 2, 4], dtype=np.int64)).ravel()
    return grid[grid <= top]


def _integers(spec) -> np.ndarray:
    try:
        arr = np.asarray(spec, dtype=float).ravel()
    except (TypeError, ValueError):
        raise AccelcalError(f"{shown(spec)} is not octave, decade, all or a list of averaging "
                            "factors", parameter="taus") from None
    if arr.size == 0:
        raise AccelcalError("give at least one tau (or octave, decade, all)", parameter="taus")
    bad = ~np.isfinite(arr) | (arr < 1) | (arr != np.round(arr))
    if bad.any():
        raise AccelcalError(f"averaging factor {shown(arr[bad][0])} is not an integer >= 1",
                            parameter="taus")
    return np.unique(arr.astype(np.int64))


def tau_grid(n: int, spec="octave", *, kind: str = "oadev") -> np.ndarray:
    """Averaging factors m of a tau set for ``n`` rate samples.

    Parameters
    ----------
    n : int
        Rate samples in the recording.
    spec : str or sequence of int
        ``"octave"``, ``"decade"``, ``"all"``, or averaging factors
        (``tau / tau0``; seconds go through :func:`taus_to_m` first).
    kind : str
        One of :data:`KINDS`: it sets the largest m (:func:`max_m`).

    Returns
    -------
    numpy.ndarray
        Sorted unique averaging factors (int64), all with at least
        :data:`MIN_TERMS` terms.

    Raises
    ------
    AccelcalError
        ``values`` when the recording is too short for any tau of ``kind``;
        ``taus`` for an unknown name, a factor that is not an integer >= 1 or
        one too large for the recording.
    """
    kind = check_kind(kind)
    top = max_m(n, kind)
    if top < 1:
        raise AccelcalError(f"{int(n)} samples are too few for {kind}: it needs at least "
                            f"{min_samples(kind)}", parameter="values")
    if isinstance(spec, str):
        if spec not in SPECS:
            raise AccelcalError(f"unknown tau set {shown(spec)}; use octave, decade, all or a "
                                "list of taus", parameter="taus")
        return _named(spec, top)
    m = _integers(spec)
    if m[-1] > top:
        raise AccelcalError(
            f"averaging factor {m[-1]} is too long for {int(n)} samples: {kind} needs at least "
            f"{MIN_TERMS} terms, so m <= {top} (tau <= {top} tau0)", parameter="taus")
    return m


def taus_to_m(taus_s, rate: float) -> np.ndarray:
    """Averaging factors ``m = tau * rate`` of taus in seconds.

    Parameters
    ----------
    taus_s : float or sequence of float
        Averaging times, seconds; each a whole multiple of ``1/rate``
        (to 1e-9 relative, which absorbs decimal rounding such as 0.3 s at
        10 Hz).
    rate : float
        Sample rate, Hz.

    Returns
    -------
    numpy.ndarray
        Averaging factors (int64), in the order given.

    Raises
    ------
    AccelcalError
        ``taus`` for a non-finite tau, one shorter than ``1/rate`` or not a
        whole multiple of it; ``rate`` for a rate that is not finite and > 0.
    """
    rate = check_rate(rate)
    try:
        taus = np.asarray(taus_s, dtype=float).ravel()
    except (TypeError, ValueError):
        raise AccelcalError(f"{shown(taus_s)} is not a list of taus in seconds",
                            parameter="taus") from None
    if taus.size == 0:
        raise AccelcalError("give at least one tau", parameter="taus")
    for tau in taus:
        m = float(tau) * rate  # a Python float: a huge tau overflows to inf, silently
        if not np.isfinite(m):
            raise AccelcalError(f"tau {shown(tau)} s is not a usable averaging time (it must be "
                                "a finite multiple of the sample interval)", parameter="taus")
        if m < 1 - 1e-9:
            raise AccelcalError(f"tau {shown(tau)} s is shorter than the sample interval "
                                f"{1 / rate:.6g} s", parameter="taus")
        if abs(m - np.round(m)) > 1e-9 * m:
            raise AccelcalError(f"tau {tau:.6g} s is not a whole multiple of the sample interval "
                                f"{1 / rate:.6g} s; use taus of m/rate", parameter="taus")
    return np.round(taus * rate).astype(np.int64)
