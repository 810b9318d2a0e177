"""Joint least squares for every sensor and the head's per-position angle error.

One least-squares problem for the coefficients of all sensors and the head
error at every position, linearised in the head error, with the gauge
fixed: the mean d0 and the first harmonic (d1c, d1s) of d_alpha cannot be
separated from the coefficients by the accelerometers alone. The mean is
absorbed into ``K_O* = K_O + K_I (eta + d0)``; the first harmonic is
given, estimated from autocollimator readings (pseudo-observations), or
taken as zero (K_F, K_IO, K_II then carry its alias). An optional
Gauss-Newton iteration solves the exact (non-linearised) model.

The design's rank and null space come from :func:`accelcal.identifiability.analyse`
(:func:`identifiability`): the null space has dimension 3 for two or more
sensors not 180 deg apart, 5 for one sensor or a 0/180 pair.

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, eqs. (5), (10)-(13).
.. [DOMAIN] accelcal domain notes, section 4 (joint least squares, gauge
   freedom).
"""

import functools
from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.identifiability import Identifiability, analyse
from accelcal.io.formats.dividing_head import MAX_ANGLE_ERROR_RAD, check_positions
from accelcal.methods.dividing_head.arrow import design_identifiability, solve_arrow
from accelcal.methods.dividing_head.data import HeadData
from accelcal.methods.dividing_head.result import (
    K_O_STAR,
    angle_fields,
    first_harmonic_terms,
    head_reduction,
)
from accelcal.methods.dividing_head.single import scale_factors
from accelcal.methods.dividing_head.sizes import MAX_DENSE_POSITIONS, check_count
from accelcal.methods.dividing_head.theory import (
    COEFFICIENTS,
    angle_names,
    coefficient_units,
    psi,
)
from accelcal.resources import check_memory
from accelcal.results import Assumption, Estimate, Reduction
from accelcal.validation import shown

ZERO_ENTRY = 1e-12
"""Design entries (sines and cosines, |x| <= 1) below this are taken as zero: rounding
leaves ~1e-16 where the exact entry is 0, and an angle within 1e-12 rad of a zero of its
sine or cosine gives a column no calibration could use."""


def joint_design(alpha, phi):
    """Linearised joint design: coefficient columns and head-error columns.

    Parameters
    ----------
    alpha : numpy.ndarray, shape (n,)
        Nominal head angles, rad.
    phi : numpy.ndarray, shape (k,)
        Mount phases, rad.

    Returns
    -------
    coefficients : numpy.ndarray, shape (k n, 5 k)
        Block-diagonal ``Psi(beta_k)`` of each sensor (normalised outputs).
    head_error : numpy.ndarray, shape (k n, n)
        How the head error at each position enters: ``d_alpha cos(beta_k)``.

    References
    ----------
    .. [1] Dong2014, eqs. (10)-(13) linearised; docs/domain.md section 4
       (joint least squares).
    """
    beta = alpha[None, :] + phi[:, None]
    k, n = beta.shape
    blocks = np.zeros((k, n, 5 * k))
    for i in range(k):
        blocks[i, :, 5 * i:5 * i + 5] = psi(beta[i])
    dcols = np.cos(beta)[:, :, None] * np.eye(n)[None]  # d_alpha enters as d cos(beta)
    return blocks.reshape(k * n, 5 * k), dcols.reshape(k * n, n)


def gauge_basis(alpha, with_first_harmonic: bool):
    """The gauge directions of the head error and an orthonormal complement.

    Parameters
    ----------
    alpha : numpy.ndarray, shape (n,)
        Nominal head angles, rad.
    with_first_harmonic : bool
        Include the first harmonic (cos, sin) with the mean.

    Returns
    -------
    gauge : numpy.ndarray, shape (n, 1 or 3)
        The mean (and first-harmonic) columns the accelerometers cannot see.
    complement : numpy.ndarray, shape (n, n - 1 or n - 3)
        Orthonormal basis of the head errors the data do determine.

    References
    ----------
    .. [1] docs/domain.md section 4 (gauge freedom).
    """
    cols = [np.ones_like(alpha)]
    if with_first_harmonic:
        cols += [np.cos(alpha), np.sin(alpha)]
    c = np.stack(cols, axis=-1)
    q, _ = np.linalg.qr(c, mode="complete")
    return c, q[:, c.shape[1]:]


def identifiability(positions, mounts, sensors=None) -> Identifiability:
    """Rank and null space of the unconstrained joint design (linearised).

    Parameters
    ----------
    positions, mounts : array_like
        Nominal head angles ``(n,)`` and mount phases ``(K,)``, rad.
    sensors : sequence of str, optional
        Sensor names for the coefficient labels (default ``U1``, ...).

    Returns
    -------
    accelcal.identifiability.Identifiability
        Names ``"<sensor> <coefficient>"`` (normalised coefficients) then
        ``d_alpha[j]``; :func:`null_space_dim` gives the gauge's dimension.

    References
    ----------
    .. [1] [DOMAIN] section 4, joint least squares: null space 3 or 5.
    """
    alpha = np.asarray(positions, dtype=float).reshape(-1)
    phi = np.asarray(mounts, dtype=float).reshape(-1)
    check_positions(alpha)
    labels = tuple(sensors) if sensors else tuple(f"U{k + 1}" for k in range(phi.size))
    return _identifiability(alpha.tobytes(), phi.tobytes(), labels)


@functools.lru_cache(maxsize=16)
def _identifiability(alpha: bytes, phi: bytes, labels: tuple) -> Identifiability:
    """:func:`identifiability` of one design, computed once (every reduction of it asks).

    O(n) time and memory (:func:`~accelcal.methods.dividing_head.arrow.design_identifiability`).
    Entries are products of sines and cosines of angles known to ~1e-15 rad: below
    ZERO_ENTRY they are rounded zeros (cos 90 deg = 6e-17), which column equilibration
    would otherwise inflate to a unit column (a head error no sensor sees, e.g. at
    90 deg with mounts 0/180, would look observable).
    """
    alpha, phi = np.frombuffer(alpha), np.frombuffer(phi)
    beta = alpha[None, :] + phi[:, None]
    names = (*(f"{s} {c}" for s in labels for c in COEFFICIENTS), *angle_names(alpha.size))
    ident = design_identifiability(psi(beta), np.cos(beta), names, ZERO_ENTRY)
    ident.null_space.setflags(write=False)  # shared by every caller of the cache
    return ident


def null_space_dim(ident: Identifiability) -> int:
    """Dimension of the joint design's null space: unknowns minus rank (3 or 5)."""
    return len(ident.names) - ident.rank


@dataclass(frozen=True)
class JointOperator:
    """Dense linear operators of the gauge-constrained joint least squares (Monte Carlo paths).

    Quadratic in the number of positions: :func:`joint` (the reduction of
    measured data) solves the same problem with
    :func:`~accelcal.methods.dividing_head.arrow.solve_arrow` in linear time.

    Unknowns are the normalised coefficients of every sensor and the head
    error ``d = C g + Z z``, where ``C = [1, cos a, sin a]`` carries the
    gauge values ``g = (d0, d1c, d1s)`` and ``Z`` spans the rest.

    Attributes
    ----------
    pinv : numpy.ndarray, shape (5K + n - 3, K n)
        Unknowns ``[x, z]`` from data (with g = 0).
    gauge : numpy.ndarray, shape (5K + n, 3)
        d[x, d]/dg: add ``gauge @ g`` for non-zero gauge values.
    resid : numpy.ndarray, shape (K n, K n)
        Residual projector.
    cov_unit : numpy.ndarray, shape (5K + n, 5K + n)
        ``T (A'A)^-1 T'`` with T mapping ``[x, z]`` to ``[x, d]``.
    to_full : numpy.ndarray, shape (5K + n, 5K + n - 3)
        T.
    dof : int
        Residual degrees of freedom.
    """

    pinv: np.ndarray
    gauge: np.ndarray
    resid: np.ndarray
    cov_unit: np.ndarray
    to_full: np.ndarray
    dof: int

    @classmethod
    def build(cls, positions, mounts) -> "JointOperator":
        """Operators for any positions and mounts that make the problem identifiable.

        Raises
        ------
        AccelcalError
            If the constrained design is rank deficient (one sensor, a 0/180
            pair, too few positions) or leaves no residual degree of freedom.

        References
        ----------
        .. [1] [DOMAIN] section 4, joint least squares.
        """
        alpha = np.asarray(positions, dtype=float)
        phi = np.asarray(mounts, dtype=float)
        k, n = phi.size, alpha.size
        size = k * n + 5 * k + n
        check_memory(size, size, 4, f"the dense joint operators of {n} positions x {k} "
                     "sensors (Monte Carlo paths)",
                     hint="the formal uncertainty (linear in the readings) has no such limit")
        a, dcols = joint_design(alpha, phi)
        c, z = gauge_basis(alpha, True)
        red = np.concatenate([a, dcols @ z], axis=1)
        p = red.shape[1]
        if red.shape[0] <= p:
            raise AccelcalError(
                f"method joint: {k} sensors x {n} positions = {red.shape[0]} readings for "
                f"{p} unknowns leave no degree of freedom; add positions or sensors"
            )
        q, r = np.linalg.qr(red)
        if analyse(r, [f"x{i}" for i in range(p)]).rank < p:  # R: red's singular values
            raise AccelcalError(
                f"method joint: the design is not identifiable (null space dimension "
                f"{null_space_dim(identifiability(alpha, phi))}, 3 removable by the gauge); "
                "use two or more sensors not 180 deg apart"
            )
        rinv = np.linalg.inv(r)
        pinv = rinv @ q.T
        to_full = np.zeros((5 * k + n, p))
        to_full[:5 * k, :5 * k] = np.eye(5 * k)
        to_full[5 * k:, 5 * k:] = z
        gauge = np.zeros((5 * k + n, 3))
        gauge[:, :] = -to_full @ pinv @ (dcols @ c)
        gauge[5 * k:] += c
        resid = np.eye(k * n) - red @ pinv
        cov_unit = to_full @ (rinv @ rinv.T) @ to_full.T
        return cls(pinv, gauge, resid, cov_unit, to_full, red.shape[0] - p)


def joint(
    data: HeadData,
    *,
    first_harmonic=None,
    first_harmonic_sd=0.0,
    mean_error: float = 0.0,
    autocollimator=None,
    autocollimator_sd: float | None = None,
    gauss_newton: bool = False,
    max_iterations: int = 20,
) -> Reduction:
    """Joint least squares for all sensors and per-position head errors.

    Time and memory are linear in the number of readings
    (:func:`~accelcal.methods.dividing_head.arrow.solve_arrow`).

    Parameters
    ----------
    data : HeadData
        Any positions, two or more sensors not 180 deg apart.
    first_harmonic : (float, float), optional
        Gauge value of the first harmonic (d1c, d1s), rad (zero when not given).
    first_harmonic_sd : float or (float, float)
        Its standard uncertainty (or, without it, a systematic bound), rad.
    mean_error : float
        Gauge value of the mean head error, rad (K_O* absorbs the difference).
    autocollimator : array_like, optional
        Measured head errors at each position, rad, used relative to their
        mean as pseudo-observations. Without ``first_harmonic`` they also
        determine the first harmonic.
    autocollimator_sd : float, optional
        Standard uncertainty of each autocollimator reading, rad (required
        with ``autocollimator``).
    gauss_newton : bool
        Iterate on the exact model (no linearisation): removes the
        second-order residual of the linear solution. Autocollimator
        readings enter the iteration as the same pseudo-observations.
    max_iterations : int
        Gauss-Newton iteration limit (>= 1).

    Returns
    -------
    Reduction
        Method ``dividing-head/joint``: per-sensor coefficients, the
        per-position angle errors (``shared`` up to
        :data:`~accelcal.methods.dividing_head.sizes.MAX_DENSE_POSITIONS`
        positions, else ``observations['d_alpha']``, ``['d_alpha_std']``),
        the covariance (full, or the coefficients' beyond that size), the
        identifiability of the unconstrained design, and assumptions
        ``first_harmonic`` (given, estimated or zero), ``mean_error``,
        ``autocollimator_sd`` and ``gauss_newton`` where they apply.

    References
    ----------
    .. [1] [DOMAIN] section 4, joint least squares; Dong2014 eq. (5).
    """
    alpha, phi = data.positions, data.mounts
    k, n = phi.size, alpha.size
    if not np.isfinite(mean_error) or abs(mean_error) > MAX_ANGLE_ERROR_RAD:
        raise AccelcalError(f"must be a finite angle within +-{MAX_ANGLE_ERROR_RAD:.4g} rad "
                            f"(1 deg), got {shown(mean_error)}", parameter="mean_error")
    if gauss_newton:
        check_count(max_iterations, "the iteration limit", 1, parameter="max_iterations")
    ident = _check_design(alpha, phi, data.sensors)
    k_i = scale_factors(data)  # Step 0 [DOMAIN]
    u = data.outputs / k_i[:, None]
    h1, h1_cov, assumptions = first_harmonic_terms(first_harmonic, first_harmonic_sd)
    g = np.array([float(mean_error), *h1])
    beta = data.angles()
    a, b = psi(beta), np.cos(beta)
    c3 = gauge_columns(alpha, True)
    names = [f"x{i}" for i in range(5 * k)]
    # the solution and its sensitivity to the first harmonic's gauge value (two more columns)
    y = np.stack([u - b * (c3 @ g), b * c3[:, 1], b * c3[:, 2]], axis=-1)
    sol = solve_arrow(a, b, y, c3, names=names)
    x, d = sol.x[:, 0], sol.d[:, 0] + c3 @ g
    gauge = (-sol.x[:, 1:], c3[:, 1:] - sol.d[:, 1:])  # d[x, d]/d(d1c, d1s)
    resid = u - np.einsum("knp,kp->kn", a, x.reshape(k, 5)) - b * d
    dof = k * n - (5 * k + n - 3)
    s2 = float(np.sum(resid**2)) / dof
    h1_term = gauge
    observations = {}
    if autocollimator is not None:
        readings = _readings(autocollimator, autocollimator_sd, n)
        sigma = np.sqrt(s2) if s2 > 0 else float(autocollimator_sd)
        cg = gauge_columns(alpha, first_harmonic is not None)
        gc = g[:cg.shape[1]]
        prior = (sigma / autocollimator_sd, _free_part(readings, cg)[:, None])
        sol = solve_arrow(a, b, (u - b * (cg @ gc))[..., None], cg, prior=prior, names=names)
        x, d = sol.x[:, 0], sol.d[:, 0] + cg @ gc
        resid = u - np.einsum("knp,kp->kn", a, x.reshape(k, 5)) - b * d
        s2 = sigma**2  # the pseudo rows fix the scale: data rows weighted by 1/sigma
        h1_term = gauge if first_harmonic is not None else None
        text = (f"autocollimator readings used as pseudo-observations "
                f"(sd {autocollimator_sd:.3g} rad)")
        assumptions = (*assumptions, Assumption("autocollimator_sd", float(autocollimator_sd),
                                                "rad", text))
        observations["autocollimator"] = readings
    dense = n <= MAX_DENSE_POSITIONS
    xscale = np.repeat(k_i, 5)
    theta_x, resid_v = x * xscale, resid * k_i[:, None]
    if gauss_newton:
        pseudo = None if autocollimator is None else (readings, float(autocollimator_sd), sigma)
        h1_fixed = autocollimator is None or first_harmonic is not None
        theta_x, d, resid_v, sol, s2, gn = _gauss_newton(
            data, theta_x, d, g, max_iterations=max_iterations, h1_fixed=h1_fixed,
            pseudo=pseudo, dof=dof)
        h1_term = gauge if h1_fixed else None
        assumptions = (*assumptions, gn)
        xscale = np.ones(5 * k)  # the iteration's unknowns are in the output unit
    cov_x, cov_xd, cov_d = _covariances(sol, s2, h1_term, h1_cov, xscale=xscale, k_i=k_i,
                                        dense=dense)
    if autocollimator is not None and first_harmonic is None:
        assumptions = _estimated_first_harmonic(alpha, d, assumptions)
    units = coefficient_units(data.output_unit)
    sensors = tuple(
        Estimate(COEFFICIENTS, theta_x[5 * i:5 * i + 5], cov_x[5 * i:5 * i + 5, 5 * i:5 * i + 5],
                 units, "joint", residuals=resid_v[i], dof=dof)
        for i in range(k)
    )
    shared, extra, notes = angle_fields(d, cov_d, "joint", "covariance of the joint solution")
    full = np.block([[cov_x, cov_xd], [cov_xd.T, cov_d]]) if dense else cov_x
    assumptions = (*assumptions, K_O_STAR,
                   Assumption("mean_error", float(mean_error), "rad"))
    if shared is not None:
        shared = Estimate(shared.names, shared.values, shared.covariance, shared.units, "joint",
                          dof=dof)
    return head_reduction(
        data, "joint", sensors, pooled_sigma=True, shared=shared, covariance=full, dof=dof,
        identifiability=ident, assumptions=assumptions, observations={**observations, **extra},
        notes=notes,
        provenance={"gauss_newton": bool(gauss_newton), "max_iterations": int(max_iterations)},
    )


def joint_noise_variance(data: HeadData) -> float:
    """Variance of the normalised readings from the linear joint fit without readings (r'r/dof).

    Linear in the number of readings.
    """
    alpha, phi = data.positions, data.mounts
    k, n = phi.size, alpha.size
    _check_design(alpha, phi, data.sensors)
    u = data.outputs / scale_factors(data)[:, None]
    beta = data.angles()
    a, b = psi(beta), np.cos(beta)
    sol = solve_arrow(a, b, u[..., None], gauge_columns(alpha, True))
    resid = u - np.einsum("knp,kp->kn", a, sol.x[:, 0].reshape(k, 5)) - b * sol.d[:, 0]
    return float(np.sum(resid**2)) / (k * n - (5 * k + n - 3))


def gauge_columns(alpha, with_first_harmonic: bool) -> np.ndarray:
    """The gauge directions of the head error: ``[1]`` or ``[1, cos a, sin a]``, ``(n, 1 | 3)``."""
    cols = [np.ones_like(alpha)]
    if with_first_harmonic:
        cols += [np.cos(alpha), np.sin(alpha)]
    return np.stack(cols, axis=-1)


def _check_design(alpha, phi, sensors) -> Identifiability:
    """The design's identifiability; refuse one without degrees of freedom or not identifiable."""
    k, n = phi.size, alpha.size
    p = 5 * k + n - 3
    if k * n <= p:
        raise AccelcalError(
            f"method joint: {k} sensors x {n} positions = {k * n} readings for "
            f"{p} unknowns leave no degree of freedom; add positions or sensors"
        )
    ident = identifiability(alpha, phi, sensors)
    if null_space_dim(ident) > 3:
        raise AccelcalError(
            f"method joint: the design is not identifiable (null space dimension "
            f"{null_space_dim(ident)}, 3 removable by the gauge); "
            "use two or more sensors not 180 deg apart"
        )
    return ident


def _readings(readings, sd, n) -> np.ndarray:
    """Checked autocollimator readings (rad)."""
    r = np.asarray(readings, dtype=float).reshape(-1)
    if r.size != n or not np.isfinite(r).all():
        raise AccelcalError(
            f"need {n} finite readings (one per position), got {r.size}",
            parameter="autocollimator",
        )
    if np.abs(r).max() > MAX_ANGLE_ERROR_RAD:
        raise AccelcalError(f"readings beyond +-1 deg ({np.abs(r).max():.3g} rad) are not a "
                            "head's angle error; check the unit (rad)", parameter="autocollimator")
    if sd is None or not np.isfinite(sd) or sd <= 0 or sd > MAX_ANGLE_ERROR_RAD:
        raise AccelcalError("autocollimator readings need their standard uncertainty "
                            "(> 0 and at most 1 deg, in rad)", parameter="autocollimator_sd")
    return r


def _free_part(readings, c) -> np.ndarray:
    """The readings minus their least-squares part along the gauge columns ``c``."""
    return readings - c @ np.linalg.lstsq(c, readings, rcond=None)[0]


def _covariances(sol, s2, h1_term, h1_cov, *, xscale, k_i, dense):
    """Covariances of the coefficients (output unit), with the head error and of the head error.

    ``h1_term`` = (d x/d h1, d d/d h1) of the linear solution (normalised
    coefficients) or None; its coefficient rows are scaled by ``k_i``.
    """
    cov_x = s2 * sol.vx * np.outer(xscale, xscale)
    cov_d = s2 * sol.cov_d(dense=dense)
    cov_xd = -s2 * (sol.vx * xscale[:, None]) @ sol.pd.T if dense else None
    if h1_term is not None:
        gx = h1_term[0] * np.repeat(k_i, 5)[:, None]
        gd = h1_term[1]
        cov_x = cov_x + gx @ h1_cov @ gx.T
        if dense:
            cov_xd = cov_xd + gx @ h1_cov @ gd.T
            cov_d = cov_d + gd @ h1_cov @ gd.T
        else:
            cov_d = cov_d + np.einsum("ni,ij,nj->n", gd, h1_cov, gd)
    return cov_x, cov_xd, cov_d


def _estimated_first_harmonic(alpha, d, assumptions) -> tuple:
    """Replace the first-harmonic assumptions by the one the autocollimator readings gave."""
    c = np.stack([np.ones_like(alpha), np.cos(alpha), np.sin(alpha)], axis=-1)
    h1 = np.linalg.lstsq(c, d, rcond=None)[0][1:]
    kept = tuple(a for a in assumptions if not a.name.startswith("first_harmonic"))
    text = (f"first harmonic of the head error estimated from the autocollimator readings: "
            f"d1c = {h1[0]:.6g} rad, d1s = {h1[1]:.6g} rad")
    return (Assumption("first_harmonic", "estimated", "", text),
            Assumption("first_harmonic_value", (float(h1[0]), float(h1[1])), "rad"), *kept)


def _gauss_newton(data, theta_x, d, g, *, max_iterations, h1_fixed, pseudo, dof):
    """Refine the joint solution on the exact model, in the output unit.

    The model ``U_kj = Psi(beta_kj + d_j) . theta_k`` is solved by
    Gauss-Newton with the step of ``d`` orthogonal to the gauge (the mean,
    and the first harmonic when ``h1_fixed``), rows weighted by 1/K_I of
    their sensor. ``pseudo = (readings, sd, sigma)`` adds the autocollimator
    readings as pseudo-observations of the free part of ``d`` (standard
    uncertainty ``sd``; ``sigma`` is the noise of the normalised readings,
    which weighs the two kinds of row), as in the linear solution; the
    covariance is then that of the whitened system.

    Returns
    -------
    theta_x, d, residuals (output unit), the last step's solution (its
    covariance factors), the variance ``s2`` of the weighted rows, and the
    ``gauss_newton`` assumption.
    """
    alpha = data.positions
    k = data.n_sensors
    cg = gauge_columns(alpha, h1_fixed)
    d_fixed = cg @ g[:cg.shape[1]]
    beta = data.angles()
    w = 1.0 / theta_x[1::5]
    th, d = theta_x.copy(), d.copy()
    target = None if pseudo is None else _free_part(pseudo[0], cg)
    names = [f"x{i}" for i in range(5 * k)]
    converged = False
    for _ in range(int(max_iterations)):
        gam = beta + d[None, :]
        t = th.reshape(k, 5)
        a = psi(gam)
        f = np.einsum("knp,kp->kn", a, t)
        fprime = (t[:, 1:2] * np.cos(gam) - t[:, 2:3] * np.sin(gam)
                  + t[:, 3:4] * np.cos(2 * gam) + t[:, 4:5] * np.sin(2 * gam))
        res = (data.outputs - f) * w[:, None]
        prior = None if pseudo is None else \
            (pseudo[2] / pseudo[1], (target - (d - d_fixed))[:, None])
        sol = solve_arrow(a * w[:, None, None], fprime * w[:, None], res[..., None], cg,
                          prior=prior, names=names)
        th = th + sol.x[:, 0]
        d = d + sol.d[:, 0]
        if np.abs(sol.x[:, 0] * np.repeat(w, 5)).max() < 1e-14 and \
                np.abs(sol.d[:, 0]).max() < 1e-14:
            converged = True
            break
    gam = beta + d[None, :]
    resid_v = data.outputs - np.einsum("knp,kp->kn", psi(gam), th.reshape(k, 5))
    res_w = resid_v * w[:, None]
    # the weighted rows are in normalised units: their variance is s2 (estimated
    # here), or sigma^2 (the linear solution's) when pseudo rows fix the scale
    s2 = float(np.sum(res_w**2)) / dof if pseudo is None else pseudo[2] ** 2
    text = "Gauss-Newton on the exact model " + ("converged" if converged else
                                                 f"stopped after {max_iterations} iterations")
    gn = Assumption("gauss_newton", "converged" if converged else "stopped", "", text)
    return th, d, resid_v, sol, s2, gn
