"""Clipped samples: runs of a recording stuck at its extreme value or at a known rail.

An amplifier or a DAQ that saturates holds its output at the rail: the
recording shows runs of samples all at one value, the largest (or the
smallest) of the recording. A sample is *clipped* when it lies in a run of
at least ``min_run`` consecutive samples within ``tolerance`` of a rail;
the rails are given (the amplifier's or ADC's limits) or taken as the
recording's maximum and minimum. A noisy signal reaches its extreme once,
so a single sample at the maximum is not a clip; a quantised signal can
repeat its extreme a few times by chance, which ``min_run`` guards against.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, input range and saturation.
.. [Hansler2004] E. Hansler and G. Schmidt, Acoustic Echo and Noise Control,
   Wiley 2004, 6.1 (clipping detection by runs at the amplitude limits).
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError

MIN_RUN = 3
"""Fewest consecutive samples at a rail that make a clip."""


@dataclass(frozen=True)
class Clipping:
    """The clipped samples of a recording.

    Attributes
    ----------
    mask : numpy.ndarray of bool
        True for each clipped sample.
    runs : tuple of (int, int, float)
        ``(start, stop, rail)`` of each clipped run (``stop`` exclusive).
    rails : tuple of float
        The low and high rails looked at.
    """

    mask: np.ndarray
    runs: tuple
    rails: tuple

    @property
    def count(self) -> int:
        """Number of clipped samples."""
        return int(self.mask.sum())

    @property
    def fraction(self) -> float:
        """Fraction of the samples that are clipped."""
        return self.count / self.mask.size if self.mask.size else 0.0


def _runs(flag: np.ndarray):
    """``(start, stop)`` of each run of True in ``flag``."""
    edges = np.diff(np.r_[0, flag.astype(np.int8), 0])
    return zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True)


def clipped(x, *, rails=None, min_run: int = MIN_RUN, tolerance: float = 0.0) -> Clipping:
    """Find the clipped samples of ``x`` (module docs).

    Parameters
    ----------
    x : array_like, shape (n,)
        The recording (any unit).
    rails : (float, float), optional
        The low and high clipping levels; default the minimum and maximum of
        ``x``. Either may be None (that side is not looked at).
    min_run : int
        Fewest consecutive samples at a rail that make a clip.
    tolerance : float
        How close to a rail a sample counts as at it (same unit as ``x``;
        0: exactly at it, as a DAQ's saturated code is).

    Returns
    -------
    Clipping

    Raises
    ------
    AccelcalError
        For a recording with non-finite values, ``min_run < 2`` or a
        negative tolerance.
    """
    x = np.asarray(x, dtype=float).reshape(-1)
    if not np.all(np.isfinite(x)):
        raise AccelcalError("a recording looked at for clipping must be finite numbers")
    if not (isinstance(min_run, int | np.integer) and min_run >= 2):
        raise AccelcalError(f"min_run must be a whole number >= 2, not {min_run!r:.20}")
    if not tolerance >= 0.0:
        raise AccelcalError("the clipping tolerance must be >= 0")
    if rails is None:
        rails = (float(x.min()), float(x.max())) if x.size else (None, None)
    mask = np.zeros(x.size, dtype=bool)
    runs = []
    for k, (rail, beyond) in enumerate(zip(rails, (np.less_equal, np.greater_equal),
                                           strict=True)):
        if rail is None or (k and rail == rails[0]):
            continue
        at = beyond(x, rail + (tolerance if beyond is np.less_equal else -tolerance))
        for start, stop in _runs(at):
            if stop - start >= min_run:
                mask[start:stop] = True
                runs.append((int(start), int(stop), float(rail)))
    return Clipping(mask=mask, runs=tuple(sorted(runs)), rails=tuple(rails))


__all__ = ["MIN_RUN", "Clipping", "clipped"]
