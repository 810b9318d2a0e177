"""Warm-up after turn-on: time constant and settled output of ``y = c + a exp(-t/tau)``.

At a fixed position after turn-on the bias settles as
``K0(t) = K0_inf + (K0_0 - K0_inf) exp(-t/tau)`` [DOMAIN 8], so the output is ::

    y(t) = c + a exp(-t / tau) + e,   e ~ N(0, s^2)                  # Eq. (4) [DOMAIN]

fitted by nonlinear least squares: for each tau of a logarithmic grid
(from the reading interval to ten times the record) the model is linear in
``(c, a)`` (variable projection [Golub1973]); the best grid point starts a
Levenberg-Marquardt refinement of ``(c, a, tau)``. The covariance is
``s^2 (J'J)^-1`` at the solution, ``s^2`` from the residuals with ``n - 3``
degrees of freedom (first order; the exponential is close to linear in tau
when the record spans a few tau, as it should).

References
----------
.. [Golub1973] Golub G. H., Pereyra V., The differentiation of
   pseudo-inverses and nonlinear least squares problems whose variables
   separate, SIAM J. Numer. Anal. 10(2), 1973.
.. [DOMAIN] accelcal domain notes, section 8 (warm-up).
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError

SIGNIFICANT = 3.0
"""A transient smaller than this many standard uncertainties is not reported (its time
constant would be noise)."""


@dataclass(frozen=True)
class WarmupFit:
    """The warm-up fit (output unit and seconds).

    Attributes
    ----------
    values : numpy.ndarray
        ``(c, a, tau)``: settled output, amplitude (output at turn-on minus
        settled) and time constant, s.
    covariance : numpy.ndarray, shape (3, 3)
    dof : int
        ``n - 3``.
    fitted, residuals : numpy.ndarray, shape (n,)
    """

    values: np.ndarray
    covariance: np.ndarray
    dof: int
    fitted: np.ndarray
    residuals: np.ndarray


def _model(p, t):
    return p[0] + p[1] * np.exp(-t / p[2])


def _jacobian(p, t):
    e = np.exp(-t / p[2])
    return np.column_stack([np.ones_like(t), e, p[1] * t * e / p[2] ** 2])


def fit_warmup(t, y) -> WarmupFit:
    """Fit Eq. (4) to the warm-up readings.

    Parameters
    ----------
    t : array_like, shape (n,)
        Time from turn-on, s (so ``a`` is the change from turn-on).
    y : array_like, shape (n,)
        Output, any unit.

    Returns
    -------
    WarmupFit

    Raises
    ------
    AccelcalError
        For fewer than 6 readings, or a record that does not show the
        transient (the best time constant at the edge of the grid: shorter
        than the reading interval or longer than the record; or an amplitude
        within :data:`SIGNIFICANT` standard uncertainties of zero).

    References
    ----------
    .. [1] Golub and Pereyra 1973; DOMAIN section 8.
    """
    from scipy.optimize import least_squares

    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    if t.size < 6:
        raise AccelcalError(f"the warm-up has {t.size} readings; fitting its time constant "
                            "needs at least 6")
    span, dt = t[-1] - t[0], t[1] - t[0]
    taus = np.geomspace(dt, 10.0 * span, 80)
    rss = []
    for tau in taus:
        A = np.column_stack([np.ones_like(t), np.exp(-t / tau)])
        coef, *_ = np.linalg.lstsq(A, y, rcond=None)
        rss.append(np.sum((y - A @ coef) ** 2))
    best = int(np.argmin(rss))
    if best in (0, taus.size - 1):
        raise AccelcalError("the warm-up readings do not show an exponential settling (its "
                            "time constant would be outside the reading interval to ten times "
                            "the record); record the warm-up longer or more often")
    A = np.column_stack([np.ones_like(t), np.exp(-t / taus[best])])
    start = np.r_[np.linalg.lstsq(A, y, rcond=None)[0], taus[best]]
    sol = least_squares(lambda p: _model(p, t) - y, start, jac=lambda p: _jacobian(p, t),
                        method="lm", x_scale="jac")
    p = sol.x
    resid = y - _model(p, t)
    dof = t.size - 3
    J = _jacobian(p, t)
    norms = np.linalg.norm(J, axis=0)
    inv = np.linalg.pinv((J / norms).T @ (J / norms)) / np.outer(norms, norms)
    cov = inv * np.sum(resid**2) / dof
    if not (np.isfinite(p).all() and p[2] > 0 and np.isfinite(cov).all()):
        raise AccelcalError("the warm-up fit did not converge; check the warm-up readings")
    if abs(p[1]) < SIGNIFICANT * np.sqrt(cov[1, 1]):
        raise AccelcalError(f"the warm-up transient ({p[1]:.3g}) is within {SIGNIFICANT:g} "
                            "standard uncertainties of zero: its time constant is not "
                            "determined by these readings")
    return WarmupFit(values=p, covariance=cov, dof=dof, fitted=y - resid, residuals=resid)
