"""Sizes of indexing-head computations: the dense limit and counts.

The reductions of measured data are linear in the number of readings; only
what is inherently ``n x n`` (the full covariance of ``n`` per-position
head errors) is formed, up to :data:`MAX_DENSE_POSITIONS` positions, and
beyond it each position's standard uncertainty is kept instead. Memory is
estimated before allocating with
:func:`accelcal.resources.check_memory` (the dense Monte Carlo
operators, studies and simulations).
"""

from accelcal.errors import AccelcalError

MAX_DENSE_POSITIONS = 1000
"""Most positions for which the head error's full covariance (n x n) is formed: 8 MB at
1000 positions. Above it a reduction keeps each position's standard uncertainty
(``observations['d_alpha_std']``) and the coefficients' covariance only."""


def check_count(value, what: str, minimum: int, *, parameter: str) -> int:
    """An integer >= ``minimum`` (a bool or a non-integer is refused)."""
    if isinstance(value, bool) or int(value) != value or value < minimum:
        raise AccelcalError(f"{what} must be an integer >= {minimum}, got {value!r}",
                            parameter=parameter)
    return int(value)
