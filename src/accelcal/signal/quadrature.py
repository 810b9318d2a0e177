"""Homodyne interferometer quadrature signals: Heydemann's ellipse correction and the phase.

A homodyne interferometer gives two signals in quadrature whose errors
(offsets ``p, q``, unequal amplitudes ``a, b``, a quadrature error ``e``)
turn the Lissajous circle into an ellipse [Heydemann1981]_::

    I = a cos(phi) + p,     Q = b sin(phi + e) + q.

:func:`fit_ellipse` fits the conic ``A I^2 + B Q^2 + C I Q + D I + E Q = 1``
by linear least squares and turns it into ``p, q, a, b, e``: the centre
solves ``[2A C; C 2B] [p q]' = -[D E]'``; with ``K = 1 - F(p, q)`` (``F`` the
conic's left side at the centre) the centred conic ``A x^2 + B y^2 + C x y =
K`` is ``x^2/a^2 + y^2/b^2 - 2 sin(e) x y / (a b) = cos^2(e)``, so that
``sin e = -C / (2 sqrt(A B))``, ``a = sqrt(K / A) / cos e``, ``b = sqrt(K / B) /
cos e``. :func:`phase` corrects the signals and unwraps::

    cos(phi) = (I - p) / a,   sin(phi) = ((Q - q) / b - cos(phi) sin e) / cos e.

References
----------
.. [Heydemann1981] Heydemann P. L. M., "Determination and correction of
   quadrature fringe measurement errors in interferometers", Appl. Opt.
   20(19), 1981, p. 3382-3384.
.. [ISO16063-11] ISO 16063-11:1999, annex A (method 3, sine approximation).
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError

MIN_CONDITION = 1e-6
"""Least ratio of the conic design's smallest singular value to its largest."""


@dataclass(frozen=True)
class Ellipse:
    """The quadrature signals' errors: offsets ``p, q``, amplitudes ``a, b``, error ``e`` (rad)."""

    p: float
    q: float
    a: float
    b: float
    e: float


def fit_ellipse(i_sig, q_sig, *, where: str = "quadrature signals") -> Ellipse:
    """Heydemann's least-squares ellipse through the points ``(I, Q)``.

    Raises
    ------
    AccelcalError
        For points that do not trace an ellipse (too short an arc, no
        motion, a degenerate conic).
    """
    x, y = np.asarray(i_sig, float), np.asarray(q_sig, float)
    # centred and scaled for conditioning; undone below
    cx, cy = float(np.mean(x)), float(np.mean(y))
    sc = float(np.sqrt(np.mean((x - cx) ** 2 + (y - cy) ** 2)))
    if not (sc > 0 and np.isfinite(sc)):
        raise AccelcalError(f"{where}: no motion (the signals are constant)")
    u, v = (x - cx) / sc, (y - cy) / sc
    design = np.stack([u * u, v * v, u * v, u, v], axis=1)
    coef, _, rank, sv = np.linalg.lstsq(design, np.ones(u.size), rcond=None)
    if rank < 5 or sv[-1] < MIN_CONDITION * sv[0]:
        raise AccelcalError(f"{where}: the points do not determine an ellipse (they lie on "
                            "a line or a short arc: no quadrature, or too little motion)")
    big_a, big_b, big_c, big_d, big_e = coef
    det = 4 * big_a * big_b - big_c**2
    if not (big_a > 0 and big_b > 0 and det > 0):
        raise AccelcalError(f"{where}: the points do not trace an ellipse (too little "
                            "motion for a fringe, or no quadrature)")
    p, q = np.linalg.solve([[2 * big_a, big_c], [big_c, 2 * big_b]], [-big_d, -big_e])
    k = 1.0 - (big_a * p * p + big_b * q * q + big_c * p * q + big_d * p + big_e * q)
    sin_e = -big_c / (2 * np.sqrt(big_a * big_b))
    if not (k > 0 and abs(sin_e) < 1):
        raise AccelcalError(f"{where}: the fitted conic is not an ellipse")
    cos_e = np.sqrt(1 - sin_e**2)
    return Ellipse(p=cx + sc * p, q=cy + sc * q, a=sc * np.sqrt(k / big_a) / cos_e,
                   b=sc * np.sqrt(k / big_b) / cos_e, e=float(np.arcsin(sin_e)))


def phase(i_sig, q_sig, ellipse: Ellipse) -> np.ndarray:
    """The corrected, unwrapped interference phase ``phi``, rad."""
    c = (np.asarray(i_sig, float) - ellipse.p) / ellipse.a
    s = ((np.asarray(q_sig, float) - ellipse.q) / ellipse.b - c * np.sin(ellipse.e)) / \
        np.cos(ellipse.e)
    return np.unwrap(np.arctan2(s, c))
