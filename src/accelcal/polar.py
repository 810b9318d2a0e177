"""Complex estimates: the real 2n representation, magnitude and phase with uncertainties.

A complex estimate ``x = (x_1, ..., x_p)`` (a frequency response's
sensitivity at ``p`` frequencies, DOMAIN.md section 10) carries its
uncertainty as the covariance of the stacked real vector

    ``[Re x_1, Im x_1, Re x_2, Im x_2, ..., Re x_p, Im x_p]``

of shape ``(2p, 2p)``: the "real 2n" representation of GUM Supplement 2
[JCGM102]_ (sec. 6.2.1.3; [Hall2004]_, [Ridler2002]_). The 2x2 diagonal
block of coefficient ``k`` is the covariance of its real and imaginary
parts; the off-diagonal blocks hold the correlations between
coefficients. Nothing is lost: any linear (or linearised) function of the
coefficients gets its exact first-order covariance from it.

People read a complex coefficient as magnitude and phase. Their standard
uncertainties follow from the 2x2 block ``V`` by the law of propagation of
uncertainty to first order (GUM 5.1.2, [JCGM102]_ sec. 6.2.1.3 and 9.3)
with ``a = Re x``, ``b = Im x``, ``r = |x|``::

    u^2(r)   = (a^2 V_aa + 2 a b V_ab + b^2 V_bb) / r^2
    u^2(phi) = (b^2 V_aa - 2 a b V_ab + a^2 V_bb) / r^4      (rad^2)

The linearisation holds while the uncertainty region is small against
``r`` (``u / r`` of a few percent, as for a calibrated sensitivity); both
are undefined (NaN) at ``r = 0``, where the phase has no meaning.

References
----------
.. [JCGM102] JCGM 102:2011, Evaluation of measurement data - Supplement 2 to
   the GUM: Extension to any number of output quantities, secs. 6.2.1.3
   (law of propagation for a vector output) and 9.3 (the example of a
   co-ordinate transformation: a complex quantity's real and imaginary
   parts to its magnitude and phase).
.. [Hall2004] Hall B. D., On the propagation of uncertainty in
   complex-valued quantities, Metrologia 41 (2004) 173-177.
.. [Ridler2002] Ridler N. M., Salter M. J., An approach to the treatment of
   uncertainty in complex S-parameter measurements, Metrologia 39 (2002)
   295-302.
"""

from typing import NamedTuple

import numpy as np


class Polar(NamedTuple):
    """Magnitude and phase of complex estimates with their standard uncertainties.

    Every field is an array of shape ``(p,)``; phases in radians, in
    ``(-pi, pi]``.
    """

    magnitude: np.ndarray
    magnitude_std: np.ndarray
    phase: np.ndarray
    phase_std: np.ndarray


def is_complex(values) -> bool:
    """True for an array of complex dtype."""
    return np.asarray(values).dtype.kind == "c"


def blocks(covariance) -> np.ndarray:
    """The 2x2 covariance blocks of the coefficients, shape ``(p, 2, 2)``.

    ``covariance`` is the ``(2p, 2p)`` covariance of ``[Re x_1, Im x_1, ...]``.
    """
    cov = np.asarray(covariance, dtype=float)
    p = cov.shape[0] // 2
    k = np.arange(p)
    return cov.reshape(p, 2, p, 2)[k, :, k, :]


def polar(values, covariance) -> Polar:
    """Magnitude, phase and their first-order standard uncertainties.

    Parameters
    ----------
    values : array_like of complex, shape (p,)
    covariance : array_like, shape (2p, 2p)
        Covariance of ``[Re x_1, Im x_1, ..., Re x_p, Im x_p]``.

    Returns
    -------
    Polar
        NaN uncertainties where ``|x| = 0`` or the block is unknown (NaN).

    References
    ----------
    .. [1] JCGM 102:2011 secs. 6.2.1.3 and 9.3.
    """
    x = np.asarray(values, dtype=complex)
    v = blocks(covariance)
    a, b = x.real, x.imag
    vaa, vab, vbb = v[:, 0, 0], v[:, 0, 1], v[:, 1, 1]
    r2 = a * a + b * b
    with np.errstate(invalid="ignore", divide="ignore"):
        u_r2 = (a * a * vaa + 2 * a * b * vab + b * b * vbb) / r2
        u_phi2 = (b * b * vaa - 2 * a * b * vab + a * a * vbb) / (r2 * r2)
        # Rounding may leave a tiny negative value where the block is singular.
        return Polar(np.abs(x), np.sqrt(np.maximum(u_r2, 0.0)), np.angle(x),
                     np.sqrt(np.maximum(u_phi2, 0.0)))


def stacked_index(indices) -> list[int]:
    """Rows of the ``(2p, 2p)`` covariance of the coefficients at ``indices``."""
    return [i for k in indices for i in (2 * k, 2 * k + 1)]


def real_names(names) -> tuple[str, ...]:
    """Labels of the stacked real vector: ``Re(x1), Im(x1), Re(x2), ...``."""
    return tuple(label for n in names for label in (f"Re({n})", f"Im({n})"))
