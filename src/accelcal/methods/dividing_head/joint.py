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
from accelcal.io.formats.dividing_head import check_positions
from accelcal.methods.dividing_head.data import HeadData
from accelcal.methods.dividing_head.result import (
    K_O_STAR,
    first_harmonic_terms,
    head_reduction,
)
from accelcal.methods.dividing_head.single import scale_factors
from accelcal.methods.dividing_head.theory import (
    COEFFICIENTS,
    angle_names,
    coefficient_units,
    psi,
)
from accelcal.results import Assumption, Estimate, Reduction

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
    """:func:`identifiability` of one design, computed once (every reduction of it asks)."""
    alpha, phi = np.frombuffer(alpha), np.frombuffer(phi)
    a, dcols = joint_design(alpha, phi)
    design = np.concatenate([a, dcols], axis=1)
    # Entries are products of sines and cosines of angles known to ~1e-15 rad: below
    # ZERO_ENTRY they are rounded zeros (cos 90 deg = 6e-17), which column equilibration
    # would otherwise inflate to a unit column (a head error no sensor sees, e.g. at
    # 90 deg with mounts 0/180, would look observable).
    design[np.abs(design) < ZERO_ENTRY] = 0.0
    names = (*(f"{s} {c}" for s in labels for c in COEFFICIENTS), *angle_names(alpha.size))
    ident = analyse(design, names)
    ident.null_space.setflags(write=False)  # shared by every caller of the cache
    return ident


def null_space_dim(ident: Identifiability) -> int:
    """Dimension of the joint design's null space: unknowns minus rank (3 or 5)."""
    return len(ident.names) - ident.rank


@dataclass(frozen=True)
class JointOperator:
    """Linear operators of the gauge-constrained joint least squares.

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
        Gauss-Newton iteration limit.

    Returns
    -------
    Reduction
        Method ``dividing-head/joint``: per-sensor coefficients, the
        per-position angle errors (``shared``), the full covariance, the
        identifiability of the unconstrained design, and assumptions
        ``first_harmonic`` (given, estimated or zero), ``mean_error``,
        ``autocollimator_sd`` and ``gauss_newton`` where they apply.

    References
    ----------
    .. [1] [DOMAIN] section 4, joint least squares; Dong2014 eq. (5).
    """
    alpha, phi = data.positions, data.mounts
    k, n = phi.size, alpha.size
    op = JointOperator.build(alpha, phi)
    ident = identifiability(alpha, phi, data.sensors)
    k_i = scale_factors(data)  # Step 0 [DOMAIN]
    u = (data.outputs / k_i[:, None]).reshape(-1)
    h1, h1_cov, assumptions = first_harmonic_terms(first_harmonic, first_harmonic_sd)
    g = np.array([float(mean_error), *h1])
    theta = op.to_full @ (op.pinv @ u) + op.gauge @ g
    resid = op.resid @ u
    s2 = float(resid @ resid) / op.dof
    cov = s2 * op.cov_unit + op.gauge[:, 1:] @ h1_cov @ op.gauge[:, 1:].T
    dof = op.dof
    observations = {}
    if autocollimator is not None:
        theta, cov, extra, sigma = _with_autocollimator(
            data, u=u, g=g, h1_fixed=first_harmonic is not None, readings=autocollimator,
            sd=autocollimator_sd, s2=s2,
        )
        if first_harmonic is not None:
            cov = cov + op.gauge[:, 1:] @ h1_cov @ op.gauge[:, 1:].T
        a, dcols = joint_design(alpha, phi)
        resid = u - a @ theta[:5 * k] - dcols @ theta[5 * k:]
        assumptions = (*assumptions, extra)
        observations["autocollimator"] = np.asarray(autocollimator, dtype=float).reshape(-1)
    scale = np.concatenate([np.repeat(k_i, 5), np.ones(n)])
    theta = theta * scale
    cov = cov * np.outer(scale, scale)
    resid_v = resid.reshape(k, n) * k_i[:, None]
    if gauss_newton:
        pseudo = None
        if autocollimator is not None:
            pseudo = (np.asarray(autocollimator, dtype=float).reshape(-1),
                      float(autocollimator_sd), sigma)
        theta, cov, resid_v, dof, gn = _gauss_newton(
            data, theta, g, h1_cov=h1_cov, op=op, max_iterations=max_iterations,
            h1_fixed=autocollimator is None or first_harmonic is not None, pseudo=pseudo,
        )
        assumptions = (*assumptions, gn)
    if autocollimator is not None and first_harmonic is None:
        assumptions = _estimated_first_harmonic(alpha, theta[5 * k:], assumptions)
    units = coefficient_units(data.output_unit)
    sensors = tuple(
        Estimate(COEFFICIENTS, theta[5 * i:5 * i + 5], cov[5 * i:5 * i + 5, 5 * i:5 * i + 5],
                 units, "joint", residuals=resid_v[i], dof=dof)
        for i in range(k)
    )
    names = angle_names(n)
    angle = Estimate(names, theta[5 * k:], cov[5 * k:, 5 * k:], dict.fromkeys(names, "rad"),
                     "joint", dof=dof)
    assumptions = (*assumptions, K_O_STAR,
                   Assumption("mean_error", float(mean_error), "rad"))
    return head_reduction(
        data, "joint", sensors, pooled_sigma=True, shared=angle, covariance=cov, dof=dof,
        identifiability=ident, assumptions=assumptions, observations=observations,
        provenance={"gauss_newton": bool(gauss_newton), "max_iterations": int(max_iterations)},
    )


def _estimated_first_harmonic(alpha, d, assumptions) -> tuple:
    """Replace the first-harmonic assumptions by the one the autocollimator readings gave."""
    c = np.stack([np.ones_like(alpha), np.cos(alpha), np.sin(alpha)], axis=-1)
    h1 = np.linalg.lstsq(c, d, rcond=None)[0][1:]
    kept = tuple(a for a in assumptions if not a.name.startswith("first_harmonic"))
    text = (f"first harmonic of the head error estimated from the autocollimator readings: "
            f"d1c = {h1[0]:.6g} rad, d1s = {h1[1]:.6g} rad")
    return (Assumption("first_harmonic", "estimated", "", text),
            Assumption("first_harmonic_value", (float(h1[0]), float(h1[1])), "rad"), *kept)


def _with_autocollimator(data, *, u, g, h1_fixed, readings, sd, s2):
    """Weighted joint fit with autocollimator pseudo-observations on the free part of d.

    Returns the estimates, their covariance, the ``autocollimator_sd`` assumption,
    and the noise ``sigma`` of
    the normalised readings that weighs the data rows against the readings.
    """
    alpha, phi = data.positions, data.mounts
    k, n = phi.size, alpha.size
    r = np.asarray(readings, dtype=float).reshape(-1)
    if r.size != n or not np.isfinite(r).all():
        raise AccelcalError(
            f"need {n} finite readings (one per position), got {r.size}",
            parameter="autocollimator",
        )
    if sd is None or not np.isfinite(sd) or sd <= 0:
        raise AccelcalError("autocollimator readings need their standard uncertainty (> 0 rad)",
                            parameter="autocollimator_sd")
    a, dcols = joint_design(alpha, phi)
    c, z = gauge_basis(alpha, h1_fixed)
    gc = g[: c.shape[1]]
    sigma = np.sqrt(s2) if s2 > 0 else sd
    design = np.concatenate([
        np.concatenate([a, dcols @ z], axis=1) / sigma,
        np.concatenate([np.zeros((z.shape[1], 5 * k)), np.eye(z.shape[1])], axis=1) / sd,
    ])
    # z = Z' r has covariance sd^2 I and no dependence on the readings' zero.
    y = np.concatenate([(u - dcols @ (c @ gc)) / sigma, (z.T @ r) / sd])
    q, rr = np.linalg.qr(design)
    sol = np.linalg.solve(rr, q.T @ y)
    rinv = np.linalg.inv(rr)
    to_full = np.zeros((5 * k + n, design.shape[1]))
    to_full[:5 * k, :5 * k] = np.eye(5 * k)
    to_full[5 * k:, 5 * k:] = z
    theta = to_full @ sol
    theta[5 * k:] += c @ gc
    cov = to_full @ (rinv @ rinv.T) @ to_full.T
    text = f"autocollimator readings used as pseudo-observations (sd {sd:.3g} rad)"
    return theta, cov, Assumption("autocollimator_sd", float(sd), "rad", text), sigma


def _gauss_newton(data, theta, g, *, h1_cov, op, max_iterations, h1_fixed=True, pseudo=None):
    """Refine the joint solution on the exact model, in the output unit.

    The model ``U_kj = Psi(beta_kj + d_j) . theta_k`` is solved by
    Gauss-Newton with ``d = C g + Z z`` (the gauge: the mean, and the first
    harmonic when ``h1_fixed``), rows weighted by 1/K_I of their sensor.
    ``pseudo = (readings, sd, sigma)`` adds the autocollimator readings as
    pseudo-observations of the free part ``Z' d`` (standard uncertainty
    ``sd``; ``sigma`` is the noise of the normalised readings, which weighs
    the two kinds of row), as in the linear solution; the covariance is
    then that of the whitened system.
    """
    alpha, phi = data.positions, data.mounts
    k, n = phi.size, alpha.size
    c, z = gauge_basis(alpha, h1_fixed)
    beta = data.angles()
    w = 1.0 / theta[1:5 * k:5]
    th = theta[:5 * k].copy()
    zz = z.T @ theta[5 * k:]
    d_fixed = c @ g[:c.shape[1]]
    m = z.shape[1]
    if pseudo is not None:
        readings, sd, sigma = pseudo
        z_meas = z.T @ readings  # independent of the readings' zero (z is orthogonal to 1)
        # pseudo rows in the units of the normalised readings: weight sigma / sd
        prior = np.concatenate([np.zeros((m, 5 * k)), np.eye(m)], axis=1) * (sigma / sd)
    converged = False
    for _ in range(max(1, int(max_iterations))):
        d = d_fixed + z @ zz
        gam = beta + d[None, :]
        p = psi(gam)  # (K, n, 5)
        t = th.reshape(k, 5)
        f = np.einsum("knp,kp->kn", p, t)
        fprime = (t[:, 1:2] * np.cos(gam) - t[:, 2:3] * np.sin(gam)
                  + t[:, 3:4] * np.cos(2 * gam) + t[:, 4:5] * np.sin(2 * gam))
        jac = np.zeros((k, n, 5 * k + m))
        for i in range(k):
            jac[i, :, 5 * i:5 * i + 5] = p[i]
        jac[:, :, 5 * k:] = fprime[:, :, None] * z[None]
        jac = (jac * w[:, None, None]).reshape(k * n, -1)
        res = ((data.outputs - f) * w[:, None]).reshape(-1)
        if pseudo is not None:
            jac = np.concatenate([jac, prior])
            res = np.concatenate([res, (z_meas - zz) * (sigma / sd)])
        step = np.linalg.lstsq(jac, res, rcond=None)[0]
        th = th + step[:5 * k]
        zz = zz + step[5 * k:]
        if np.abs(step[:5 * k] * np.repeat(w, 5)).max() < 1e-14 and \
                np.abs(step[5 * k:]).max() < 1e-14:
            converged = True
            break
    d = d_fixed + z @ zz
    gam = beta + d[None, :]
    f = np.einsum("knp,kp->kn", psi(gam), th.reshape(k, 5))
    resid_v = data.outputs - f
    res_w = (resid_v * w[:, None]).reshape(-1)
    dof = op.dof
    _q, r = np.linalg.qr(jac)
    rinv = np.linalg.inv(r)
    to_full = np.zeros((5 * k + n, jac.shape[1]))
    to_full[:5 * k, :5 * k] = np.eye(5 * k)
    to_full[5 * k:, 5 * k:] = z
    # the weighted rows are in normalised units: their variance is s2 (estimated
    # here), or sigma^2 (the linear solution's) when pseudo rows fix the scale
    s2 = float(res_w @ res_w) / dof if pseudo is None else pseudo[2] ** 2
    new_cov = s2 * to_full @ (rinv @ rinv.T) @ to_full.T
    scale = np.concatenate([np.repeat(1.0 / w, 5), np.ones(n)])
    if h1_fixed:
        # the first-harmonic term of the linear solution (same gauge sensitivity to first order)
        new_cov = new_cov + (op.gauge[:, 1:] * scale[:, None]) @ h1_cov @ \
            (op.gauge[:, 1:] * scale[:, None]).T
    text = "Gauss-Newton on the exact model " + ("converged" if converged else
                                                 f"stopped after {max_iterations} iterations")
    gn = Assumption("gauss_newton", "converged" if converged else "stopped", "", text)
    return np.concatenate([th, d]), new_cov, resid_v, dof, gn
