"""Unknown orientations: the gravity-norm calibration (Tedaldi's multi-position method).

At rest the specific force has the magnitude of the local gravity whatever
the orientation, so the parameters minimise

    sum_k w_k^2 (|T (p_k + q ⊙ p_k^2)| - g)^2,   p_k = K (u_k - b)     # Eq. (10) [Tedaldi2014]

(Levenberg-Marquardt, :func:`scipy.optimize.least_squares`, with the
analytic Jacobian of :func:`accelcal.methods.triad.forward.norm_model`).
The norm does not see a rotation of the body frame, which the triangular
``T`` fixes (docs/triad.md), nor the polarity of an axis (``s_i -> -s_i``
with the signs of the angles it enters and of ``q_i``): scale factors come
out positive. Weights: ``w_k = 1`` or, with sample counts, proportional to
``sqrt(counts_k)``; with ``noise_sd`` the first-order SD of each residual
(:func:`~accelcal.methods.triad.forward.norm_sd`), refitted once at the
solution.

Covariance ``s^2 (J'J)^-1`` of the weighted Jacobian at the solution, with
``s^2`` the weighted residual variance on ``n - 9`` (``n - 12`` with
quadratic terms) degrees of freedom, or 1 when ``noise_sd`` is given.

Initial guess (unless given): an axis-aligned ellipsoid ``sum_i alpha_i
u_i^2 + beta_i u_i = 1`` fitted linearly (centre: the biases; semi-axes:
``g / s_i``), which holds for raw outputs with large offsets (16-bit counts
about mid-scale); when it is degenerate, a sphere about the mid-range of
the means on each axis (bias: the mid-range; scale: ``g`` over the mean
distance from it). The distinct orientations are counted on the means less
that centre, so an offset of many g does not make every mean point the same
way.

References
----------
.. [Tedaldi2014] Tedaldi D., Pretto A., Menegatti E., "A robust and easy to
   implement method for IMU calibration without external equipments", ICRA
   2014, sec. IV-A, eq. (10).
.. [More1978] More J. J., "The Levenberg-Marquardt algorithm: implementation
   and theory", Numerical Analysis, LNM 630, 1978.
"""

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.identifiability import analyse
from accelcal.methods.triad.common import (
    check_labels,
    check_means,
    check_noise,
    check_unit,
    common_assumptions,
    few_dof,
    relative_sd,
    spread_text,
)
from accelcal.methods.triad.forward import norm_model, norm_sd
from accelcal.methods.triad.frames import t_matrix
from accelcal.methods.triad.model import PARAMS, QUADRATIC, TriadCalibration
from accelcal.methods.triad.result import build_reduction
from accelcal.physics.gravity import check_gravity

METHOD = "triad/gravity-norm"
"""Method name of a gravity-norm calibration (records, store)."""


def initial_guess(means, gravity: float) -> np.ndarray:
    """Bias and scale from an axis-aligned ellipsoid fit (angles 0): 9 values."""
    u = np.asarray(means, dtype=float)
    if u.shape[0] >= 6:
        centre = u.mean(axis=0)
        spread = np.maximum(u.std(axis=0), 1e-300)
        z = (u - centre) / spread  # conditioning: the fit in standardised coordinates
        x = np.column_stack([z**2, z])
        coef, *_ = np.linalg.lstsq(x, np.ones(len(u)), rcond=None)
        alpha, beta = coef[:3], coef[3:]
        if (alpha > 0).all():
            c = 1.0 + np.sum(beta**2 / (4.0 * alpha))
            if c > 0:
                bias = centre - spread * beta / (2.0 * alpha)
                scale = gravity * np.sqrt(alpha / c) / spread
                if np.isfinite(bias).all() and np.isfinite(scale).all():
                    return np.concatenate([bias, scale, np.zeros(3)])
    centre = midrange(u)
    norm = float(np.mean(np.linalg.norm(u - centre, axis=1)))
    scale = gravity / norm if norm > 0 else 1.0
    return np.concatenate([centre, np.full(3, scale), np.zeros(3)])


def midrange(u) -> np.ndarray:
    """The mid-range of the means on each axis, ``(max + min) / 2``.

    The offset of a raw output whose positions turn each axis up and down
    (about zero for means in an acceleration unit).
    """
    u = np.asarray(u, dtype=float)
    return 0.5 * (u.max(axis=0) + u.min(axis=0))


def positive_polarity(values: np.ndarray, quadratic: bool) -> np.ndarray:
    """The equivalent parameters with every scale factor positive (same norms)."""
    d = np.sign(values[3:6])
    t = t_matrix(values[6:9])
    t = d[:, None] * t * d[None, :]
    out = values.copy()
    out[3:6] = d * values[3:6]
    out[6:9] = (-t[0, 1], t[0, 2], -t[1, 2])
    if quadratic:
        out[9:12] = d * values[9:12]
    return out


DISTINCT_DEG = 3.0
"""Directions of interval means closer than this (degrees) are one orientation: a
position held twice, or split by a pause, adds samples, not a constraint on the 9
parameters (the nominal directions of a raw triad are within a few tenths of a
degree of the calibrated ones, far below 3)."""


def calibrate_unknown(means, gravity, *, input_unit="m/s^2", quadratic=False, labels=None,
                      counts=None, noise_sd=None, initial=None):
    """Calibrate a triad from interval means at unknown, well-spread orientations.

    Parameters
    ----------
    means : array_like, shape (n, 3)
        Interval means of the raw output, ``input_unit``.
    gravity : float
        Local gravity, m/s^2.
    input_unit : str
        Unit of ``means``.
    quadratic : bool
        Fit the per-axis quadratic terms too (needs many orientations).
    labels : sequence of str, optional
        Position labels.
    counts : array_like, shape (n,), optional
        Samples averaged in each mean (weights).
    noise_sd : float or array_like, optional
        SD of an interval mean, input unit (scalar, (3,), (n,) or (n, 3));
        the covariance then uses it (dof 0).
    initial : TriadCalibration, optional
        Starting point (default: :func:`initial_guess`).

    Returns
    -------
    Reduction
        Family ``"triad"``, method :data:`METHOD` (fields:
        :mod:`accelcal.methods.triad.result`).

    Raises
    ------
    AccelcalError
        Fewer than 9 (12) positions, no degree of freedom without
        ``noise_sd``, orientations that do not determine the model (naming
        the directions no position visits), or a fit that does not converge.

    References
    ----------
    .. [1] Tedaldi2014 sec. IV-A, eq. (10).
    """
    u = check_means(means)
    n = u.shape[0]
    g = check_gravity(gravity)
    unit = check_unit(input_unit)
    names_labels = check_labels(labels, n)
    noise = check_noise(noise_sd, n)
    rel = relative_sd(n, counts)
    names = PARAMS + (QUADRATIC if quadratic else ())
    p = len(names)
    given = noise is not None
    if n < p or (n == p and not given):
        raise AccelcalError(
            f"{n} position(s) given; the gravity-norm calibration needs at least "
            f"{p if given else p + 1} ({p} parameters"
            f"{'' if given else ' and one residual degree of freedom'}); "
            "12-40 well-spread orientations in practice", parameter="means")
    x0 = _start(initial, u, g, quadratic, unit)
    _check_distinct(u - x0[0:3], p)
    _check_design(x0, u, g, quadratic, rel, names=names)
    x, sd = estimate_unknown(u, g, quadratic, rel, noise, x0=x0)
    r, jac = norm_model(x, u, g, quadratic)
    jw = jac / sd[:, None]
    ident = analyse(jw, names)
    if not ident.full_rank:
        _refuse_spread(n, x, u, ident)
    dof = n - p
    var = 1.0 if given else float(np.sum((r / sd) ** 2) / dof)
    cov = var * np.linalg.inv(jw.T @ jw)
    assumptions = common_assumptions(g, noise, counts, quadratic, unit) + few_dof(dof, given)
    return build_reduction(
        method=METHOD, values=x, covariance=cov, quadratic=quadratic, gauge=False, unit=unit,
        residuals=r, dof=dof, given=given, ident=ident, assumptions=assumptions, means=u,
        gravity=g, labels=names_labels, counts=counts,
        means_sd=noise if given else means_noise(x, u, rel, var, quadratic))


def estimate_unknown(u, g, quadratic: bool, rel, noise, *, x0):
    """The estimates alone (no checks): values with positive scales, and residual SDs.

    Used by :func:`calibrate_unknown` and the Monte Carlo.
    """
    x = _fit(x0, u, g, quadratic, rel)
    sd = rel
    if noise is not None:
        sd = norm_sd(x, u, noise, quadratic)
        x = _fit(x, u, g, quadratic, sd)
        sd = norm_sd(x, u, noise, quadratic)
    return positive_polarity(x, quadratic), sd


def means_noise(x, u, rel, var: float, quadratic: bool) -> np.ndarray:
    """SD of the interval means (n, 3) at the residual level, equal on the three axes.

    The weighted residual variance ``var`` is that of ``r_k / rel_k``; a mean
    with SD ``c rel_k`` on every axis gives ``Var r_k = c^2 rel_k^2 h_k^2``
    (``h_k = norm_sd`` at unit SD), so ``c^2 = var / mean(h_k^2)``.
    """
    h = norm_sd(x, u, np.ones_like(u), quadratic)
    c = np.sqrt(var / np.mean(h**2))
    return np.repeat((c * rel)[:, None], 3, axis=1)


def _start(initial, u, g, quadratic, unit) -> np.ndarray:
    if initial is None:
        x0 = initial_guess(u, g)
    else:
        if not isinstance(initial, TriadCalibration):
            raise AccelcalError("must be a TriadCalibration", parameter="initial")
        if initial.input_unit != unit:
            raise AccelcalError(f"is in {initial.input_unit}, the means in {unit}",
                                parameter="initial")
        x0 = initial.vector[:9]
    if quadratic:
        q0 = np.zeros(3) if initial is None or initial.quadratic is None else initial.quadratic
        x0 = np.concatenate([x0, q0])
    return x0


def distinct_orientations(u, limit: int, *, degrees: float = DISTINCT_DEG) -> int:
    """How many of the means' directions differ by more than ``degrees``, up to ``limit``.

    Repeats of one position add samples, not orientations. Greedy: a
    direction joins the first kept one within ``degrees``, else is kept.
    Linear in the positions (at most ``limit`` kept directions). ``u`` must
    be free of offsets (a raw output less its bias estimate): the directions
    of means about a mid-scale offset all point near the offset's. A zero
    vector counts as a direction of its own.
    """
    u = np.asarray(u, dtype=float)
    norm = np.linalg.norm(u, axis=1)
    d = u / np.where(norm > 0, norm, 1.0)[:, None]
    cos = np.cos(np.radians(degrees))
    kept = d[:1]
    for row in d[1:]:
        if len(kept) >= limit:
            break
        if not (kept @ row > cos).any():
            kept = np.vstack([kept, row])
    return len(kept)


def _check_distinct(u, p: int) -> None:
    found = distinct_orientations(u, p + 1)
    if found < p:
        raise AccelcalError(
            f"{u.shape[0]} positions given but only {found} distinct orientations (repeats "
            f"within {DISTINCT_DEG:g} deg count once); |a| = g at {found} orientations cannot "
            f"determine {p} parameters: add orientations tilted between the axes (12-40 in "
            "practice), or calibrate by known orientations", parameter="means")


def _check_design(x0, u, g, quadratic, sd, *, names) -> None:
    _, jac = norm_model(x0, u, g, quadratic)
    ident = analyse(jac / sd[:, None], names)
    if not ident.full_rank:
        _refuse_spread(u.shape[0], x0, u, ident)


def _refuse_spread(n: int, x, u, ident) -> None:
    directions = (u - x[0:3]) * x[3:6]
    gaps = spread_text(directions)
    p = len(ident.names)
    raise AccelcalError(
        f"{n} positions given, but their orientations do not determine "
        f"{', '.join(ident.unidentifiable)} (rank {ident.rank} of {p})"
        + (" (the quadratic terms need many orientations spread over +-1 g on each axis)"
           if p > 9 else "")
        + (f"; {gaps}" if gaps else "; the orientations lie too close to one plane, cone or "
           "the axes alone")
        + "; add positions with each axis up and down and tilted between axes",
        parameter="means")


def _fit(x0, u, g, quadratic, sd) -> np.ndarray:
    from scipy.optimize import least_squares

    def fun(x):
        return norm_model(x, u, g, quadratic)[0] / sd

    def jac(x):
        return norm_model(x, u, g, quadratic)[1] / sd[:, None]

    sol = least_squares(fun, x0, jac=jac, method="lm", x_scale="jac", xtol=1e-15, ftol=1e-15,
                        gtol=1e-15, max_nfev=2000)
    if sol.status <= 0 or not np.isfinite(sol.x).all():
        raise AccelcalError(
            f"the gravity-norm fit did not converge ({sol.message}); check the unit and that the "
            "intervals are static, or give an initial calibration", parameter="means")
    return sol.x
