"""Monte Carlo (GUM-S1) uncertainty of cross-axis coefficients identified on a shaker.

The identification (:func:`accelcal.methods.transverse.identification.identify`) regresses
the output's DC, w and 2w components on regressors built from the
reference channels' phasors. Synthetic observations are drawn, per
direction angle, from the fitted coefficients (plus the model's fixed
terms) with

- the **output noise**: Gaussian with the covariance of the output's sine
  fit (from its residuals);
- the **reference-channel noise**: the reference phasors' own sine-fit
  covariance, through the full response (the identification's weights
  carry only the input-axis channel's share, to first order);
- the **reference accelerometer's calibration** (Type B): every reference
  phasor (along the vibration, and the transverse and IA channels when
  present) scaled by a common ``1 + e``, ``e ~ N(0, u_ref)``;
- the **terms the identification leaves out** that it bounded by priors
  (``Reduction.priors``): each drawn from its prior as declared and its
  observation columns (at the measured phasors) added, so that the
  interval includes them as the formal Type B does.

Each set is reduced by the identification's whitened least-squares
operator, vectorised over trials, at the phasor level (the sine fits are
linear, so this is the record-level reduction without re-fitting the
samples).

References
----------
.. [GuanTang] Guan W., Tang L., Shaker test method of transverse sensitivity
   of inertial accelerometers, eqs. (13), (16), (24) as in docs/domain.md section 3.
.. [ISO16063-31] ISO 16063-31:2009 (reference accelerometer along the vibration).
.. [GUM-S1] JCGM 101:2008, sections 5-7.
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.formats.shaker import ShakerRecords
from accelcal.methods.transverse.estimators import record_phasors
from accelcal.methods.transverse.identification import (
    FIT_TERMS,
    check_route,
    observation_columns,
    observation_covariance,
    regressors,
)
from accelcal.results import Reduction
from accelcal.uncertainty import McUncertainty, propagate

_REFS = ("ref", "ref_n", "ref_ia")


@dataclass(frozen=True)
class TransverseSampler:
    """Picklable sampler of re-identified synthetic shaker observations.

    Parameters
    ----------
    theta : numpy.ndarray
        Direction angles, rad, ``(m,)``.
    gravity : float
        Static specific force along the vibration, g.
    phasors : dict
        Measured w phasors of the reference channels (``ref`` and, when
        present, ``ref_n``, ``ref_ia``), ``(m,)`` complex, g.
    phasor_chol : dict
        Cholesky factors of their (a1, b1) covariances, ``(m, 2, 2)``.
    values : dict
        Every model term's coefficient (fitted and fixed), g/g^n.
    terms : tuple of str
        Fitted terms.
    route : str
        Components used (:data:`accelcal.methods.transverse.identification.ROUTES`).
    scale_factor : float
        K1, output unit per g.
    chol : numpy.ndarray
        Cholesky factors of the identification's weights per angle, ``(m, q, q)``.
    noise_chol : numpy.ndarray
        Cholesky factors of the output noise's covariance per angle, ``(m, q, q)``
        (the weights less the reference channel's share, drawn separately).
    operator : numpy.ndarray
        Whitened least-squares operator, ``(p, m q)``.
    reference_sd : float
        Relative standard uncertainty of the reference calibration (fraction).
    priors : tuple of Prior
        Priors of terms left out, drawn in every trial.
    prior_columns : numpy.ndarray or None
        Their observation columns at the measured phasors, output unit per
        unit term, ``(len(priors), m, q)``.

    Calling ``sampler(rng, t)`` returns the errors ``(t, p)``.
    """

    theta: np.ndarray
    gravity: float
    phasors: dict
    phasor_chol: dict
    values: dict
    terms: tuple
    route: str
    scale_factor: float
    chol: np.ndarray
    noise_chol: np.ndarray
    operator: np.ndarray
    reference_sd: float = 0.0
    priors: tuple = ()
    prior_columns: np.ndarray | None = None

    def response(self, phasors: dict) -> np.ndarray:
        """The output's observations per angle for reference phasors ``phasors``, ``(..., m, q)``.

        ``[dc shift], a1, b1, [a2, b2]`` of the output in its unit, for every
        term of ``values`` and the input-axis motion.
        """
        zero = np.zeros_like(phasors["ref"])
        reg = regressors(self.theta, phasors["ref"], phasors.get("ref_n", zero),
                         phasors.get("ref_ia", zero), self.gravity)  # [GuanTang] (13)
        total = observation_columns(reg, "Ki", self.route)  # a_i enters with coefficient 1
        for term, value in self.values.items():
            if value != 0.0:
                total = total + value * observation_columns(reg, term, self.route)
        return self.scale_factor * total

    def __call__(self, rng: np.random.Generator, t: int) -> np.ndarray:
        """Errors of ``t`` re-identified synthetic observation sets, shape ``(t, p)``."""
        m = self.theta.size
        scale = 1.0 + self.reference_sd * rng.standard_normal((t, 1))
        drawn = {}
        for name in _REFS:
            if name in self.phasors:
                ab = np.einsum("mij,tmj->tmi", self.phasor_chol[name],
                               rng.standard_normal((t, m, 2)))
                drawn[name] = (self.phasors[name] + ab[..., 0] - 1j * ab[..., 1]) * scale
        shift = self.response(drawn) - self.response(self.phasors)  # (t, m, q)
        q = self.chol.shape[-1]
        noise = np.einsum("mij,tmj->tmi", self.noise_chol, rng.standard_normal((t, m, q)))
        if self.priors:
            draws = np.stack([p.draw(rng, t) for p in self.priors], axis=1)
            shift = shift + np.einsum("tp,pmq->tmq", draws, self.prior_columns)
        white = np.linalg.solve(self.chol, (shift + noise)[..., None])[..., 0]
        return white.reshape(t, m * q) @ self.operator.T


def transverse_uncertainty(
    records: ShakerRecords,
    reduction: Reduction,
    *,
    trials: int,
    seed: int,
    reference_sd: float = 0.0,
    shortest: bool = False,
    progress=None,
    force: bool = False,
) -> McUncertainty:
    """Monte Carlo uncertainty of :func:`~accelcal.methods.transverse.identification.identify`.

    Parameters
    ----------
    records : ShakerRecords
        The records identified (one amplitude, ``(m, n)``).
    reduction : Reduction
        Their identification; its ``route`` and ``scale_factor`` assumptions
        and its ``fixed`` terms are those the synthetic observations use.
    trials, seed : int
        Monte Carlo trials (> 0) and root seed.
    reference_sd : float
        Relative standard uncertainty of the reference accelerometer's
        calibration (fraction, e.g. 0.005 for 0.5 %).
    shortest : bool
        Shortest coverage interval instead of the symmetric one.
    progress : callable, optional
        ``progress(done, total)``.
    force : bool
        Run past the time bound (:func:`accelcal.uncertainty.propagate`).

    Returns
    -------
    McUncertainty

    Raises
    ------
    AccelcalError
        For a negative reference uncertainty or a reduction that is not a
        shaker identification.

    References
    ----------
    .. [1] JCGM 101:2008 (GUM-S1); GuanTang eq. (13); docs/domain.md section 3.
    """
    if not np.isfinite(reference_sd) or reference_sd < 0:
        raise AccelcalError(
            f"reference calibration uncertainty {reference_sd} must be a finite fraction >= 0",
            parameter="reference_sd",
        )
    if reduction.family != "transverse":
        raise AccelcalError(f"a {reduction.family} reduction is not a shaker identification; "
                            "give the result of identify", parameter="reduction")
    route = reduction.assumed("route")
    check_route(route)
    k1 = float(reduction.assumed("scale_factor"))
    estimate = reduction.estimate
    terms = estimate.names
    ph = record_phasors(records)
    phasors = {n: ph[n].phasors[..., 0] for n in _REFS if n in ph}
    # a noise-free reference has a zero covariance: the tiny ridge keeps it factorable
    phasor_chol = {n: np.linalg.cholesky(ph[n].covariance[..., 1:3, 1:3] + 1e-300 * np.eye(2))
                   for n in phasors}
    values = {t: float(reduction.fixed.get(t, 0.0)) for t in FIT_TERMS if t != "Ki"}
    values.update(dict(zip(terms, estimate.values.tolist(), strict=True)))
    chol = np.linalg.cholesky(observation_covariance(records, ph, route, k1))
    noise_chol = np.linalg.cholesky(observation_covariance(records, ph, route, k1,
                                                           reference=False))
    zero = np.zeros_like(phasors["ref"])
    reg = regressors(records.theta, phasors["ref"], phasors.get("ref_n", zero),
                     phasors.get("ref_ia", zero), records.gravity)
    # (m, q, p)
    design = k1 * np.stack([observation_columns(reg, t, route) for t in terms], axis=-1)
    white = np.linalg.solve(chol[:, None], np.moveaxis(design, -1, 1)[..., None])[..., 0]
    dw = np.moveaxis(white, 1, -1).reshape(-1, len(terms))
    operator = np.linalg.pinv(dw)
    priors = tuple(p for p in reduction.priors if p.name in FIT_TERMS)
    prior_columns = (k1 * np.stack([observation_columns(reg, p.name, route) for p in priors])
                     if priors else None)
    sampler = TransverseSampler(records.theta, float(records.gravity), phasors, phasor_chol,
                                values, tuple(terms), route, float(k1), chol, noise_chol,
                                operator, float(reference_sd), priors, prior_columns)
    inputs = ["output noise (sine-fit covariance)", "reference-channel noise (sine fit)"]
    if reference_sd > 0:
        inputs.append(f"reference calibration N(0, {reference_sd:.3g}) relative")
    if priors:
        inputs.append("terms left out drawn from their priors: " + ", ".join(
            f"{p.name} {p.distribution} {p.value:.3g} {p.unit}".rstrip() for p in priors))
    return propagate(sampler, estimate.values, estimate.std, names=terms, trials=trials,
                     seed=seed, units=dict(estimate.units), shortest=shortest, inputs=inputs,
                     progress=progress, force=force)
