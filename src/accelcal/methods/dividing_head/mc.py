"""Monte Carlo (GUM-S1) uncertainty of an indexing-head reduction of measured data.

Synthetic data sets are drawn from the fitted coefficients of every sensor
(Dong2014 eq. (5), exact, no linearisation) with

- **noise** at the residual level of each sensor (Gaussian);
- the head's **angle error**, a Type-B input: independent at each position,
  rectangular within ``+-level`` (GUM-S1 6.4.2), standard uncertainty
  ``level / sqrt(3)``;
- the **first harmonic** of the head error: when it is given (measured),
  the drawn errors' own first harmonic is replaced by the given value plus
  a Gaussian error of its standard uncertainty; when it is not given, the
  drawn errors keep their own first harmonic and ``first_harmonic_sd`` (the
  systematic bound of the formal uncertainty) adds a Gaussian first
  harmonic of that standard deviation;
- **autocollimator** readings (method ``joint``, when the record has them):
  the drawn head error plus Gaussian noise of their standard uncertainty;
- the **terms Dong2014 eq. (5) leaves out** (K3, K4, K0', K1', and K0'/2 of
  unknown sign at each position where a_i = 0), when the reduction bounded
  them by priors (``Reduction.priors``,
  :mod:`~accelcal.methods.dividing_head.unestimated`): each sensor's term
  drawn from its prior as declared (rectangular, normal or two-point),
  independently between sensors, and its output column added, so that
  the interval includes them as the formal Type B does by default. (With
  ``sensor_terms="equal"`` the formal path also takes the sensors' terms
  equal where that is larger; the Monte Carlo draws them independent, as
  the priors state them.)

Each data set is reduced by the same linear operators as the measured data
(:func:`~accelcal.methods.dividing_head.single.single_pinv`,
:class:`~accelcal.methods.dividing_head.four.FourOperator`,
:class:`~accelcal.methods.dividing_head.joint.JointOperator`), after the same
normalisation by each sensor's fitted scale factor, vectorised over trials.
The error of a trial is measured against its identifiable truth, the fitted
coefficients with ``K_O* = K_O + K_I d0`` for the trial's mean head error d0
([DOMAIN] step 6). Misalignment is not a separate input: it is part of
K_O* and no reduction models it.

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, eq. (5).
.. [DOMAIN] accelcal domain notes, section 4 (steps 0-7, joint least squares).
.. [GUM-S1] JCGM 101:2008, 6.4.2 (rectangular distribution), 7.
"""

from dataclasses import dataclass

import numpy as np

from accelcal.aliasing import Prior
from accelcal.errors import AccelcalError
from accelcal.io.formats.dividing_head import MAX_ANGLE_ERROR_RAD
from accelcal.methods.dividing_head.data import HeadData
from accelcal.methods.dividing_head.factors import FourFactors
from accelcal.methods.dividing_head.four import FourOperator, residual_noise_variances
from accelcal.methods.dividing_head.joint import (
    JointOperator,
    gauge_basis,
    joint_design,
    joint_noise_variance,
)
from accelcal.methods.dividing_head.single import scale_factors, single_pinv
from accelcal.methods.dividing_head.theory import COEFFICIENTS, method_name, psi
from accelcal.results import Reduction
from accelcal.uncertainty import McUncertainty, propagate
from accelcal.validation import shown

SAMPLER_BYTES = 2**28
"""Work memory of one batch of synthetic data sets (256 MiB)."""

SAMPLER_ARRAYS = 12
"""Arrays of ``t x K x n`` floats a batch holds at its peak (angles, the basis Psi (5),
outputs, noise, normalised outputs, products)."""

MC_METHODS = ("single", "four", "joint")
"""Reductions whose Monte Carlo uncertainty is available."""
_MC_LIST = f"{', '.join(MC_METHODS[:-1])} and {MC_METHODS[-1]}"


@dataclass(frozen=True)
class HeadSampler:
    """Picklable sampler of re-reduced synthetic indexing-head data sets.

    Parameters
    ----------
    positions, mounts : numpy.ndarray
        Head angles ``(n,)`` and mount phases ``(K,)``, rad.
    coefficients : numpy.ndarray
        Fitted ``[K_F, K_I, K_O*, K_IO, K_II]`` of each sensor, ``(K, 5)``,
        output unit.
    noise : numpy.ndarray
        Noise standard deviation of each sensor's (averaged) outputs, ``(K,)``.
    method : {"single", "four", "joint"}
        Reduction to repeat.
    angle_error_level : float
        Bound of the rectangular head angle error, rad (0: none).
    first_harmonic : numpy.ndarray or None
        Given first harmonic (d1c, d1s), rad (None: taken as zero).
    first_harmonic_sd : numpy.ndarray
        Its standard uncertainty (or systematic bound), rad, ``(2,)``.
    autocollimator_sd : float or None
        Standard uncertainty of autocollimator readings used by ``joint``, rad.
    weight_sigma : float or None
        Normalised noise level that weights the data rows against the
        autocollimator rows (the measured data's value, held fixed).
    unestimated : tuple
        ``(sensors (q,), columns (q, n), distributions (q,), values (q,))``:
        the output change per unit of each unestimated term of a sensor and
        its prior (:meth:`draw_terms`); empty: none drawn.

    Calling ``sampler(rng, t)`` returns the errors ``(t, 5 K)`` (sensor-major)
    of ``t`` re-reduced synthetic data sets.
    """

    positions: np.ndarray
    mounts: np.ndarray
    coefficients: np.ndarray
    noise: np.ndarray
    method: str
    angle_error_level: float = 0.0
    first_harmonic: np.ndarray | None = None
    first_harmonic_sd: np.ndarray | None = None
    autocollimator_sd: float | None = None
    weight_sigma: float | None = None
    unestimated: tuple = ()

    def __post_init__(self) -> None:
        if self.method not in MC_METHODS:
            raise AccelcalError(
                f"Monte Carlo uncertainty is available for methods {_MC_LIST}, "
                f"not {shown(self.method)}", parameter="method"
            )
        level = float(self.angle_error_level)
        if not np.isfinite(level) or level < 0 or level > MAX_ANGLE_ERROR_RAD:
            raise AccelcalError(f"the angle-error level must be finite, >= 0 and at most 1 deg "
                                f"({MAX_ANGLE_ERROR_RAD:.4g} rad), got {level}",
                                parameter="angle_error_level")
        sd = np.broadcast_to(np.asarray(
            0.0 if self.first_harmonic_sd is None else self.first_harmonic_sd, dtype=float), (2,))
        alpha = np.asarray(self.positions, dtype=float)
        phi = np.asarray(self.mounts, dtype=float)
        c = np.stack([np.ones_like(alpha), np.cos(alpha), np.sin(alpha)], axis=-1)
        ops = {"beta": alpha[None, :] + phi[:, None], "c1": c[:, 1:],
               "gauge_proj": np.linalg.pinv(c), "first_harmonic_sd": sd.copy()}
        ops["single_pinv"] = single_pinv(ops["beta"])[0]
        if self.method == "four":
            ops["four"] = FourOperator.build(alpha, phi)
        elif self.method == "joint":
            ops["joint"] = JointOperator.build(alpha, phi)
            if self.autocollimator_sd is not None:
                ops["autocollimator"] = _autocollimator_operator(
                    alpha, phi, self.first_harmonic is not None, self.weight_sigma,
                    self.autocollimator_sd)
        object.__setattr__(self, "angle_error_level", level)
        object.__setattr__(self, "_ops", ops)

    def head_errors(self, rng: np.random.Generator, t: int) -> np.ndarray:
        """Head angle errors of ``t`` synthetic data sets, rad, shape ``(t, n)``."""
        ops = self._ops
        n = self.positions.size
        d = (self.angle_error_level * rng.uniform(-1.0, 1.0, (t, n))
             if self.angle_error_level > 0 else np.zeros((t, n)))
        sd = ops["first_harmonic_sd"]
        h1 = sd * rng.standard_normal((t, 2)) if sd.any() else np.zeros((t, 2))
        if self.first_harmonic is not None:
            # measured first harmonic: replace the drawn one by the value given (+ its error)
            d = d - (d @ ops["gauge_proj"][1:].T) @ ops["c1"].T
            h1 = h1 + np.asarray(self.first_harmonic, dtype=float)
        return d + h1 @ ops["c1"].T

    def draw_terms(self, rng: np.random.Generator, t: int) -> np.ndarray:
        """Output changes of the unestimated terms of ``t`` data sets, ``(t, K, n)``.

        Each term from its prior: uniform within ``+-a`` (rectangular),
        ``N(0, a^2)`` (normal) or ``+-a`` with equal odds (two-point)
        [GUM-S1 6.4].
        """
        k, n = np.shape(self.coefficients)[0], self.positions.size
        out = np.zeros((t, k, n))
        if not self.unestimated:
            return out
        sensors, columns, kinds, values = self.unestimated
        draws = np.empty((t, len(sensors)))
        for j, (kind, a) in enumerate(zip(kinds, values, strict=True)):
            draws[:, j] = Prior("term", a, distribution=kind).draw(rng, t)
        for ell in np.unique(sensors):
            at = np.flatnonzero(sensors == ell)
            out[:, ell] = draws[:, at] @ columns[at]
        return out

    def __call__(self, rng: np.random.Generator, t: int) -> np.ndarray:
        """Errors of ``t`` re-reduced synthetic data sets, shape ``(t, 5 K)``.

        Trials are taken :data:`SAMPLER_BYTES` of work memory at a time (all
        at once for the usual position counts, so the random numbers come in
        the same order for any ``t`` there).
        """
        k, n = np.shape(self.coefficients)[0], self.positions.size
        step = max(1, int(SAMPLER_BYTES // (SAMPLER_ARRAYS * 8 * k * n)))
        if t <= step:
            return self._errors(rng, t)
        return np.concatenate([self._errors(rng, min(step, t - i)) for i in range(0, t, step)])

    def _errors(self, rng: np.random.Generator, t: int) -> np.ndarray:
        ops = self._ops
        coef = np.asarray(self.coefficients, dtype=float)
        k, n = coef.shape[0], self.positions.size
        d = self.head_errors(rng, t)
        gamma = ops["beta"][None] + d[:, None, :]
        u = np.einsum("tknp,kp->tkn", psi(gamma), coef)  # Eq. (5) [Dong2014], exact
        u = u + np.asarray(self.noise)[:, None] * rng.standard_normal((t, k, n))
        if self.unestimated:
            u = u + self.draw_terms(rng, t)
        readings = None
        if "autocollimator" in ops:
            readings = d + self.autocollimator_sd * rng.standard_normal((t, n))
        truth = np.broadcast_to(coef, (t, k, 5)).copy()
        d0 = d @ ops["gauge_proj"][0]
        truth[..., 2] += coef[:, 1] * d0[:, None]  # K_O* = K_O + K_I d0 [DOMAIN step 6]
        return (self.reduce(u, readings) - truth).reshape(t, 5 * k)

    def reduce(self, u: np.ndarray, readings: np.ndarray | None = None) -> np.ndarray:
        """The method's estimates for outputs ``u`` ``(t, K, n)``, shape ``(t, K, 5)``.

        The same operators and the same order of operations as
        :func:`accelcal.methods.dividing_head.reduce.reduce` (linear solution; the
        Gauss-Newton refinement changes estimates only at second order).
        """
        ops = self._ops
        pinv = ops["single_pinv"]
        if self.method == "single":
            return np.einsum("kpn,tkn->tkp", pinv, u)
        t, k, n = u.shape
        k_i = np.einsum("kn,tkn->tk", pinv[:, 1, :], u)  # Step 0 [DOMAIN]
        un = (u / k_i[..., None]).reshape(t, k * n)
        h1 = (np.zeros(2) if self.first_harmonic is None
              else np.asarray(self.first_harmonic, dtype=float))
        if self.method == "four":
            op = ops["four"]
            x = np.einsum("kpm,tm->tkp", op.coef, un) - op.alias @ h1  # Step 5 [DOMAIN]
        elif "autocollimator" in ops:
            p_u, p_r, shift = ops["autocollimator"]
            x = (un @ p_u.T + readings @ p_r.T + shift @ h1).reshape(t, k, 5)
        else:
            op = ops["joint"]
            g = np.array([0.0, *h1])
            x = (un @ op.pinv[:5 * k].T + op.gauge[:5 * k] @ g).reshape(t, k, 5)
        return x * k_i[..., None]


def _autocollimator_operator(alpha, phi, h1_fixed, sigma, sd):
    """Linear map of (normalised outputs, readings) to the joint coefficients with readings.

    The weighted design of
    :func:`accelcal.methods.dividing_head.joint.joint` with autocollimator
    pseudo-observations, for a fixed weight ``sigma`` of the data rows.
    Returns ``(P_u (5K, Kn), P_r (5K, n), shift (5K, 2))`` with
    coefficients ``P_u u + P_r r + shift h1``.
    """
    if sigma is None or not sigma > 0 or sd is None or not sd > 0:
        raise AccelcalError("autocollimator readings need a positive noise level and sd")
    k = phi.size
    a, dcols = joint_design(alpha, phi)
    c, z = gauge_basis(alpha, h1_fixed)
    design = np.concatenate([
        np.concatenate([a, dcols @ z], axis=1) / sigma,
        np.concatenate([np.zeros((z.shape[1], 5 * k)), np.eye(z.shape[1])], axis=1) / sd,
    ])
    pinv = np.linalg.pinv(design)[:5 * k]
    rows = a.shape[0]
    p_u = pinv[:, :rows] / sigma
    p_r = pinv[:, rows:] @ z.T / sd
    shift = -p_u @ dcols @ c[:, 1:] if h1_fixed else np.zeros((5 * k, 2))
    return p_u, p_r, shift


def noise_levels(data: HeadData, method: str) -> np.ndarray:
    """Noise standard deviation of each sensor at the level the residuals show, ``(K,)``.

    The residuals ``r = R u'`` of the method's linear reduction (normalised
    outputs ``u'``; for ``joint`` the fit without autocollimator readings,
    whose residual sets the reduction's own noise level) give unbiased
    variances by :func:`~accelcal.methods.dividing_head.four.residual_noise_variances`
    even where the reduction spends degrees of freedom on the head error
    (``four``: harmonics >= 2). ``joint`` pools the sensors, as its formal
    covariance does (``r'r / dof``); so do the others where the system has
    no non-negative solution.
    Scaled back by each sensor's fitted scale factor.
    """
    alpha, phi = data.positions, data.mounts
    k, n = phi.size, alpha.size
    if method == "single":
        # unnormalised: the single fit does not divide by the scale factor; M = (n - 5) I
        pinv = single_pinv(data.angles())[0]
        x = np.einsum("kpn,kn->kp", pinv, data.outputs)
        r = data.outputs - np.einsum("knp,kp->kn", psi(data.angles()), x)
        return np.sqrt(residual_noise_variances((n - 5.0) * np.eye(k), r))
    k_i = scale_factors(data)  # Step 0 [DOMAIN]
    if method == "four":
        fac = FourFactors.build(alpha, phi)
        r = fac.apply(data.outputs / k_i[:, None])[1]
        s2 = residual_noise_variances(fac.residual_moments(), r)
    else:  # pooled: the joint residual operator is a projector, sum_kl M_kl = dof
        s2 = np.full(k, joint_noise_variance(data))
    return np.sqrt(s2) * np.abs(k_i)


def head_uncertainty(
    data: HeadData,
    result: Reduction,
    *,
    trials: int,
    seed: int,
    angle_error_level: float = 0.0,
    first_harmonic=None,
    first_harmonic_sd=0.0,
    autocollimator_sd: float | None = None,
    sensor_names=None,
    shortest: bool = False,
    progress=None,
    force: bool = False,
) -> McUncertainty:
    """Monte Carlo uncertainty of an indexing-head reduction of measured data.

    Parameters
    ----------
    data : HeadData
        The measured data.
    result : Reduction
        Its reduction by ``single``, ``four`` or ``joint``.
    trials, seed : int
        Monte Carlo trials (> 0) and root seed.
    angle_error_level : float
        Bound of the head's angle error, rad (rectangular, per position).
    first_harmonic, first_harmonic_sd
        As given to the reduction (rad).
    autocollimator_sd : float, optional
        Standard uncertainty of the autocollimator readings the ``joint``
        reduction used, rad (None when it used none).
    sensor_names : sequence of str, optional
        Names of the sensors (default the reduction's).
    shortest : bool
        Shortest coverage interval instead of the symmetric one.
    progress : callable, optional
        ``progress(done, total)``.
    force : bool
        Run past the time bound (:func:`accelcal.uncertainty.propagate`).

    Returns
    -------
    McUncertainty
        Names ``"<sensor> <coefficient>"``, sensor-major, in the order of
        :meth:`Reduction.rows`.

    References
    ----------
    .. [1] JCGM 101:2008 (GUM-S1); [DOMAIN] section 4.
    """
    method = method_name(result)
    if method not in MC_METHODS:
        raise AccelcalError(
            f"Monte Carlo uncertainty is available for methods {_MC_LIST}, "
            f"not {method}", parameter="uncertainty"
        )
    coef = np.stack([e.values for e in result.sensors])
    noise = noise_levels(data, method)
    weight = None
    if autocollimator_sd is not None:
        weight = float(np.sqrt(joint_noise_variance(data)))  # the reduction's own weight
    terms = prior_columns(data, result)
    sampler = HeadSampler(
        data.positions, data.mounts, coef, noise, method,
        angle_error_level=angle_error_level,
        first_harmonic=None if first_harmonic is None else np.asarray(first_harmonic, float),
        first_harmonic_sd=first_harmonic_sd, autocollimator_sd=autocollimator_sd,
        weight_sigma=weight, unestimated=terms,
    )
    names = sensor_names or result.sensor_names
    labels = [f"{s} {c}" for s in names for c in COEFFICIENTS]
    units = {f"{s} {c}": result.sensors[0].units[c] for s in names for c in COEFFICIENTS}
    std = np.concatenate([e.std for e in result.sensors])
    inputs = [f"noise N(0, {', '.join(f'{v:.3g}' for v in noise)}) {data.output_unit}"]
    if angle_error_level > 0:
        inputs.append(f"head angle error rectangular within +-{angle_error_level:.3g} rad")
    if np.any(np.asarray(first_harmonic_sd) > 0):
        inputs.append("first harmonic Gaussian, sd "
                      f"{np.broadcast_to(np.asarray(first_harmonic_sd, float), (2,)).tolist()} rad")
    if autocollimator_sd is not None:
        inputs.append(f"autocollimator readings N(0, {autocollimator_sd:.3g}) rad")
    if terms:
        inputs.append("terms the reduction leaves out drawn from their priors, independent "
                      "between sensors: " + ", ".join(
                          f"{p.name} {p.distribution} {p.value:.3g} {p.unit}".rstrip()
                          for p in result.priors if "@" not in p.name))
    return propagate(sampler, np.concatenate([e.values for e in result.sensors]), std,
                     names=labels, trials=trials, seed=seed, units=units, shortest=shortest,
                     inputs=inputs, progress=progress, force=force)


def prior_columns(data: HeadData, result: Reduction) -> tuple:
    """The :attr:`HeadSampler.unestimated` of the terms ``result`` bounded by priors.

    The output change per unit of each term of each sensor (as the alias
    matrix takes it, :mod:`~accelcal.methods.dividing_head.unestimated`) and
    its prior from ``result.priors``; empty when the reduction propagated
    none (``priors="none"``).
    """
    from accelcal.methods.dividing_head.unestimated import TERMS, term_columns

    priors = {p.name: p for p in result.priors}
    if not priors:
        return ()
    found = dict(priors)
    chosen = [(k, priors[t], z) for k, (t, z) in term_columns(data, result, found,
                                                            tuple(t for t in TERMS if t in priors),
                                                            False) if t in priors]
    if not chosen:
        return ()
    return (np.array([k for k, _, _ in chosen], dtype=int),
            np.array([z for _, _, z in chosen], dtype=float),
            tuple(p.distribution for _, p, _ in chosen),
            np.array([p.value for _, p, _ in chosen], dtype=float))
