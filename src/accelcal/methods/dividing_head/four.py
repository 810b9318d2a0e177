"""Four-sensor separation of the head's angle error (Dong2014, corrected as [DOMAIN] section 4).

Steps 0-7: normalise each sensor by its own scale factor; separate the
harmonics >= 4 of the head error from V_z and harmonics 2, 3 from sensor
1; compensate every sensor and fit Psi(beta_k); remove the first-harmonic
alias when the first harmonic is given; K_O* absorbs misalignment and the
mean head error; covariance. Every step is linear in the normalised
outputs: :class:`~accelcal.methods.dividing_head.factors.FourFactors` holds
the steps as factors linear in the number of positions (the reduction of
measured data), :class:`FourOperator` their dense ``(K n)``-column form for
the Monte Carlo paths, which apply it to many trials at once.

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, eqs. (14)-(31).
.. [DOMAIN] accelcal domain notes, section 4 (corrected expansions and
   reduction steps 0-7).
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.methods.dividing_head.data import HeadData
from accelcal.methods.dividing_head.factors import FourFactors
from accelcal.methods.dividing_head.joint import identifiability
from accelcal.methods.dividing_head.result import (
    K_O_STAR,
    angle_fields,
    first_harmonic_terms,
    head_reduction,
)
from accelcal.methods.dividing_head.single import scale_factors
from accelcal.methods.dividing_head.sizes import MAX_DENSE_POSITIONS
from accelcal.methods.dividing_head.theory import COEFFICIENTS, coefficient_units
from accelcal.resources import check_memory
from accelcal.results import Assumption, Estimate, Reduction
from accelcal.validation import shown


def residual_noise_variances(operator: np.ndarray, residuals: np.ndarray, *,
                             pooled: bool = False) -> np.ndarray:
    """Unbiased noise variance of each sensor from the residuals of a linear reduction.

    For residuals ``r = R u`` of independent readings with variance ``s_l^2``
    on sensor l, ``E|r_k|^2 = sum_l M_kl s_l^2`` with ``M_kl = ||R_kl||_F^2``;
    solving that K x K system gives unbiased ``s^2`` even where the
    reduction spends degrees of freedom on the head error. One pooled
    variance ``sum_k |r_k|^2 / sum_kl M_kl`` is returned for every sensor
    when ``pooled`` or where the system has no non-negative solution (a
    quiet sensor's own share of its residual can be small).

    Parameters
    ----------
    operator : numpy.ndarray, shape (K, n, K, n) or (K, K)
        Residual operator ``R`` (sensor, position, sensor, reading), or
        directly its moments ``M`` (:meth:`FourFactors.residual_moments`).
    residuals : numpy.ndarray, shape (..., K, n)

    Returns
    -------
    numpy.ndarray, shape (..., K)

    References
    ----------
    .. [1] docs/dividing-head.md, the four-sensor covariance; Dong2014 eq. (30)
       for the single-sensor case (M diagonal, n - 5).
    """
    moments = operator if operator.ndim == 2 else \
        np.einsum("kjlm,kjlm->kl", operator, operator)
    rss = np.einsum("...kn,...kn->...k", residuals, residuals)
    common = rss.sum(axis=-1) / moments.sum()
    if pooled:
        return np.broadcast_to(common[..., None], rss.shape).copy()
    s2 = np.linalg.solve(moments, rss[..., None])[..., 0]
    bad = ~(np.isfinite(s2) & (s2 >= 0)).all(axis=-1)
    return np.where(bad[..., None], common[..., None], s2)


@dataclass(frozen=True)
class FourOperator:
    """Dense linear operators of the corrected four-sensor reduction for one design.

    All act on normalised outputs ``U'_k = U_k / K_I,k`` flattened sensor-major
    to a vector of length ``K n``; formed from :class:`FourFactors` for the
    Monte Carlo paths (quadratic in n: the reduction of measured data uses
    the factors).

    Attributes
    ----------
    coef : numpy.ndarray, shape (K, 5, K n)
        Step-4 estimates ``[K'_F + c', 1 + dK, K'_O*, K'_IO + s', K'_II - c']``.
    resid : numpy.ndarray, shape (K, n, K n)
        Step-4 residuals of each sensor.
    angle : numpy.ndarray, shape (n, K n)
        d_hi: harmonics >= 2 of the head error at each position.
    cov_unit : numpy.ndarray, shape (K, 5, 5)
        (Psi_k' Psi_k)^-1 for step 7.
    alias : numpy.ndarray, shape (K, 5, 2)
        d(estimates)/d(d1c, d1s): subtract ``alias @ h1`` when h1 is known.
    """

    coef: np.ndarray
    resid: np.ndarray
    angle: np.ndarray
    cov_unit: np.ndarray
    alias: np.ndarray

    @classmethod
    def build(cls, positions, mounts) -> "FourOperator":
        """Operators for ``positions`` (uniform, n >= 12) and balanced ``mounts``.

        Raises
        ------
        AccelcalError
            As :meth:`FourFactors.build`, or when the ``(K n)^2`` operators
            would not fit in memory.
        """
        k, n = np.size(mounts), np.size(positions)
        check_memory(k * n, k * n, 3 + 1 / k, f"the dense four-sensor operators of {n} "
                     f"positions x {k} sensors (Monte Carlo paths)",
                     hint="the formal uncertainty (linear in the readings) has no such limit")
        fac = FourFactors.build(positions, mounts)
        coef, resid, angle = fac.dense()
        return cls(coef, resid, angle, fac.cov_unit, fac.alias)

    def noise_variances(self, residuals: np.ndarray) -> np.ndarray:
        """Noise variance of each sensor's normalised outputs from the step-4 residuals.

        See :func:`residual_noise_variances` (each sensor's residual carries
        every sensor's noise through the separated head error).

        Parameters
        ----------
        residuals : numpy.ndarray, shape (..., K, n)

        Returns
        -------
        numpy.ndarray, shape (..., K)
        """
        k, n = self.resid.shape[:2]
        return residual_noise_variances(self.resid.reshape(k, n, k, n), residuals)

    def propagated_covariance(self, variances: np.ndarray) -> np.ndarray:
        """Covariance of ``[step-4 estimates of all sensors, d_hi]`` from the readings' noise.

        Every step is linear in the normalised outputs, so with independent
        noise of variance ``variances[l]`` on sensor l's readings the
        covariance is ``L diag(v) L'`` with ``L = [coef; angle]``: exact for
        the linear method, including the noise carried into each sensor's
        fit by the separated head error (which step 7 of [DOMAIN] omits).

        Returns
        -------
        numpy.ndarray, shape (5 K + n, 5 K + n)
        """
        k, n = self.resid.shape[:2]
        lin = np.concatenate([self.coef.reshape(5 * k, k * n), self.angle])
        return (lin * np.repeat(variances, n)) @ lin.T


FOUR_COVARIANCES = ("paper", "propagated")
"""Covariances of :func:`four` (default ``propagated``)."""

PAPER_COVARIANCE_TEXT = (
    "covariance 'paper': Dong2014 eq. (31), each sensor's residual variance times "
    "(Psi' Psi)^-1; it omits the noise the separated head error carries into every "
    "sensor's fit and is optimistic: its SDs are 1.3-1.9x too small, covering the 95 % "
    "interval 0.65-0.87 of the time instead of 0.95 (docs/dividing-head.md; the default "
    "covariance='propagated' covers 0.90-0.955)"
)


def four(
    data: HeadData,
    *,
    first_harmonic=None,
    first_harmonic_sd=0.0,
    covariance: str = "propagated",
) -> Reduction:
    """Four-sensor separation of the head's angle error, as corrected in [DOMAIN].

    Steps: 0 normalise each sensor by its own scale factor; 1 harmonics >= 4
    of d_alpha from V_z; 2 harmonics 2, 3 from sensor 1; 3-4 compensate
    each sensor and fit Psi(beta_k); 5 remove the first-harmonic alias if
    d1 is given; 6 K_O* = K_O + K_I (eta + d0); 7 covariance, scaled back
    by K_I. Time and memory are linear in the number of readings
    (:class:`FourFactors`).

    Parameters
    ----------
    data : HeadData
        Uniform positions (n >= 12), balanced mounts (e.g. 0, 90, 180, 270 deg).
    first_harmonic : (float, float), optional
        The head's first harmonic (d1c, d1s), rad, e.g. from an
        autocollimator. Without it d1 is taken as zero and K_F, K_IO, K_II
        carry the alias of :func:`first_harmonic_alias`.
    first_harmonic_sd : float or (float, float)
        Standard uncertainty of (d1c, d1s), rad. With ``first_harmonic`` it
        is the measurement's uncertainty; without it, a bound on the
        neglected first harmonic carried as a systematic uncertainty.
    covariance : {"propagated", "paper"}
        ``propagated`` (default): the readings' noise (each sensor's
        variance estimated without bias from all residuals,
        :func:`residual_noise_variances`) propagated exactly through the
        linear steps 1-5, with the covariances between sensors (and, up to
        :data:`~accelcal.methods.dividing_head.sizes.MAX_DENSE_POSITIONS`
        positions, with the head error) in ``Reduction.covariance``.
        ``paper``: step 7, ``s^2 (Psi' Psi)^-1`` per sensor from its own
        residuals (Dong2014 eq. (31)); optimistic: it omits the noise that
        the separated head error carries into every sensor's fit (SDs
        1.3-1.9x too small, 95 % coverage 0.65-0.87; the assumption
        ``covariance`` says so). Both add the first-harmonic term.

    Returns
    -------
    Reduction
        Method ``dividing-head/four``: per-sensor coefficients (output unit),
        the separated head error (harmonics >= 2, plus the first harmonic
        when given) as ``shared`` (up to ``MAX_DENSE_POSITIONS`` positions;
        beyond, ``observations['d_alpha']`` and ``['d_alpha_std']``), the
        identifiability of the joint design, and assumptions
        ``first_harmonic`` and ``covariance``.

    References
    ----------
    .. [1] Dong2014, eqs. (14)-(31); corrected steps 0-7 of [DOMAIN] section 4.
    """
    if covariance not in FOUR_COVARIANCES:
        raise AccelcalError(
            f"{shown(covariance)} is not one of {', '.join(FOUR_COVARIANCES)}",
            parameter="covariance")
    fac = FourFactors.build(data.positions, data.mounts)
    k_i = scale_factors(data)  # Step 0 [DOMAIN]
    u = data.outputs / k_i[:, None]
    x, resid, d_hi = fac.apply(u)
    n, k = data.positions.size, data.n_sensors
    dense = n <= MAX_DENSE_POSITIONS
    h1, h1_cov, h1_assumptions = first_harmonic_terms(first_harmonic, first_harmonic_sd)
    x = x - fac.alias @ h1  # Step 5 [DOMAIN]; Eq. (27)-(28) corrected
    c1 = np.stack([np.cos(data.positions), np.sin(data.positions)], axis=-1)
    if first_harmonic is not None:
        d_hi = d_hi + c1 @ h1
    # first-harmonic part of [coefficients (volts), head error]: -alias h1 and, when given, +c1 h1
    h1_x = -(fac.alias * k_i[:, None, None]).reshape(5 * k, 2)
    h1_d = c1 if first_harmonic is not None else np.zeros((n, 2))
    if covariance == "paper":
        s2 = np.einsum("kn,kn->k", resid, resid) / (n - 5)  # Eq. (30) [Dong2014]
        blocks = s2[:, None, None] * fac.cov_unit  # Eq. (31) [Dong2014]
        cov_x = np.zeros((5 * k, 5 * k))
        for j in range(k):
            cov_x[5 * j:5 * j + 5, 5 * j:5 * j + 5] = blocks[j]
        variances = np.full(k, float(s2.mean()))
        cov_note = PAPER_COVARIANCE_TEXT
        angle_note = "covariance from the pooled residual variance"
    else:
        variances = residual_noise_variances(fac.residual_moments(), resid)
        cov_x = fac.coefficient_covariance(variances)
        cov_note = angle_note = ("covariance propagated from the readings' noise through every "
                                 "step (head error's share included)")
    cov_d, cov_xd = fac.angle_covariance(variances, dense=dense)
    scale = np.repeat(k_i, 5)
    cov_x = cov_x * np.outer(scale, scale) + h1_x @ h1_cov @ h1_x.T
    full = None
    if dense:
        cov_d = cov_d + h1_d @ h1_cov @ h1_d.T
        if covariance == "propagated":
            cov_xd = cov_xd * scale[:, None] + h1_x @ h1_cov @ h1_d.T
            full = np.block([[cov_x, cov_xd], [cov_xd.T, cov_d]])
    else:
        cov_d = cov_d + np.einsum("ni,ij,nj->n", h1_d, h1_cov, h1_d)
        if covariance == "propagated":
            full = cov_x
    cov = np.stack([cov_x[5 * j:5 * j + 5, 5 * j:5 * j + 5] for j in range(k)])
    units = coefficient_units(data.output_unit)
    sensors = tuple(
        Estimate(COEFFICIENTS, k_i[j] * x[j], cov[j], units, "four",
                 residuals=k_i[j] * resid[j], dof=n - 5)
        for j in range(k)
    )
    assumptions = (*h1_assumptions, K_O_STAR, Assumption("covariance", covariance, "", cov_note))
    shared, observations, notes = angle_fields(d_hi, cov_d, "four", angle_note)
    return head_reduction(
        data, "four", sensors, shared=shared, covariance=full, dof=n - 5,
        identifiability=identifiability(data.positions, data.mounts, data.sensors),
        assumptions=assumptions, provenance={"covariance": covariance},
        observations=observations, notes=notes,
    )
