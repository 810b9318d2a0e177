r"""Overlapping Allan and Hadamard variances of a recording with gaps, pooled over its segments.

A recording split at its gaps (``--gaps split``,
:mod:`accelcal.io.recordings.repairs`) is a list of segments of consecutive
samples. The overlapping variance at averaging factor ``m`` is a mean of
squared differences of the phase ``x`` (Eq. (11), (20) of [Riley2008]);
over gaps, only the differences that lie wholly inside one segment are
taken, and their sums and counts are pooled over the segments:

.. math::

    \sigma^2(m\tau_0) = \frac{\sum_s S_s(m)}{D\, m^2 \tau_0^2 \sum_s N_s(m)},
    \quad N_s(m) = n_s + 1 - k m,

with ``S_s`` the sum of squared ``k``-th differences (``k`` = 2 for OADEV,
3 for OHDEV) of the segment's phase, ``n_s`` its samples, ``D`` the kind's
divisor (2, 6); a segment with ``N_s(m) <= 0`` (shorter than the tau)
contributes nothing. No difference straddles a gap, so a gap adds no step
to the variance (the "available differences only" treatment of missing
data discussed by [Sesia2008]; the uncertainty is taken as that of the
longest segment, which understates the degrees of freedom and so errs on
the wide side). allantools has no gap support (its issues #6 and #112).

The phase is one cumulative sum over the samples kept: a segment's
second differences do not depend on the phase's value at its start, so
the concatenated phase serves every segment.

References
----------
.. [Riley2008] Riley W. J., NIST SP 1065, 2008, eqs. (11), (20).
.. [Sesia2008] Sesia I. and Tavella P., "Estimating the Allan variance in the
   presence of long periods of missing data and outliers", Metrologia 45
   (2008) S134-S142.
"""

import numpy as np


def pooled_sums(x, m, segments, order: int):
    """Sums of squared ``order``-th phase differences and their counts, per ``m``, pooled.

    Parameters
    ----------
    x : numpy.ndarray
        The phase, ``n + 1`` points (``x[i]`` the sum of the first ``i`` samples).
    m : numpy.ndarray of int
        Averaging factors.
    segments : list of (int, int)
        ``(start, stop)`` sample ranges of consecutive samples (stop exclusive).
    order : int
        2 (OADEV) or 3 (OHDEV).

    Returns
    -------
    sums : numpy.ndarray
    counts : numpy.ndarray of int64
        Differences summed per ``m`` (0 where no segment is long enough).
    """
    from accelcal.signal.allan.kernels import lag_sumsq

    sums = np.zeros(len(m))
    counts = np.zeros(len(m), dtype=np.int64)
    for a, b in segments:
        for k, mk in enumerate(int(v) for v in m):
            c = (b - a + 1) - order * mk
            if c > 0:
                sums[k] += lag_sumsq(x, a, c, mk, order)
                counts[k] += c
    return sums, counts
