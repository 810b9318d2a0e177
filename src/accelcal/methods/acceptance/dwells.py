"""Dwell means of a step record and their standard errors (a pooled white-noise scatter).

A dwell is a run of samples at one input (:meth:`StepRecord.dwells
<accelcal.io.formats.acceptance.StepRecord.dwells>`). Its mean output, after
the first ``settle`` seconds, estimates the output at that input; its
standard error is ``s / sqrt(n)``, ``s`` the scatter about the dwell means
pooled over every dwell (``sum(n_k - 1)`` degrees of freedom), which
assumes white noise within a dwell (dwells long against the noise's
correlation time: docs/acceptance.md).

References
----------
.. [GUM] JCGM 100:2008, 4.2 (Type A evaluation: the experimental standard
   deviation of the mean).
"""

from dataclasses import dataclass
from itertools import pairwise

import numpy as np

from accelcal.errors import AccelcalError

MIN_SAMPLES = 3
"""Fewest samples a dwell may keep after the settling time."""


@dataclass(frozen=True)
class Dwells:
    """The dwells of a record, in test order.

    Attributes
    ----------
    input : numpy.ndarray
        Applied acceleration of each dwell, g.
    mean, se : numpy.ndarray
        Mean output and its standard error, output unit.
    kept : numpy.ndarray
        Time of each dwell used after the settling time (samples times the
        median interval), s.
    sigma : float
        The pooled scatter of one sample, output unit.
    dof : int
        Its degrees of freedom.
    """

    input: np.ndarray
    mean: np.ndarray
    se: np.ndarray
    kept: np.ndarray
    sigma: float
    dof: int

    @property
    def direction(self) -> np.ndarray:
        """+1 for a dwell reached by increasing input, -1 by decreasing, 0 for the first."""
        return np.r_[0.0, np.sign(np.diff(self.input))]


def dwell_means(record, settle: float = 0.0, pool=None) -> Dwells:
    """The dwells of ``record`` with the first ``settle`` s of each dropped.

    ``pool`` (optional, a boolean per dwell) selects the dwells whose scatter
    is pooled into ``sigma`` (e.g. leaving out dwells with clipped samples,
    whose scatter the clipping removes); by default every dwell's.

    Raises
    ------
    AccelcalError
        When a dwell keeps fewer than :data:`MIN_SAMPLES` samples.
    """
    if not settle >= 0.0:
        raise AccelcalError("the settling time must be >= 0 s", parameter="settle")
    edges = record.dwells()
    dt = float(np.median(np.diff(record.t))) if record.t.size > 1 else 0.0
    inputs, means, counts, ss = [], [], [], 0.0
    for k, (lo, hi) in enumerate(pairwise(edges)):
        keep = record.t[lo:hi] >= record.t[lo] + settle
        y = record.output[lo:hi][keep]
        if y.size < MIN_SAMPLES:
            raise AccelcalError(
                f"dwell {k + 1} (input {record.input[lo]:.6g} g) keeps {y.size} samples after "
                f"the settling time: a step must dwell long enough for at least {MIN_SAMPLES} "
                "to estimate the noise and decide")
        inputs.append(record.input[lo])
        means.append(y.mean())
        counts.append(y.size)
        if pool is None or pool[k]:
            ss += float(np.sum((y - y.mean()) ** 2))
    counts = np.asarray(counts, dtype=float)
    dof = int(np.sum((counts - 1) if pool is None else (counts - 1)[np.asarray(pool, bool)]))
    if dof < 1:
        raise AccelcalError("no dwell left to estimate the noise from")
    sigma = float(np.sqrt(ss / dof))
    return Dwells(input=np.asarray(inputs), mean=np.asarray(means),
                  se=sigma / np.sqrt(counts), kept=counts * dt,
                  sigma=sigma, dof=dof)
