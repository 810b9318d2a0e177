"""Four-sensor separation of the head's angle error (Dong2014, corrected as [DOMAIN] section 4).

Steps 0-7: normalise each sensor by its own scale factor; separate the
harmonics >= 4 of the head error from V_z and harmonics 2, 3 from sensor
1; compensate every sensor and fit Psi(beta_k); remove the first-harmonic
alias when the first harmonic is given; K_O* absorbs misalignment and the
mean head error; covariance. Every step is a linear operator of the
normalised outputs (:class:`FourOperator`), built once per design, so the
Monte Carlo sampler applies the same code to many trials at once.

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
from accelcal.methods.dividing_head.joint import identifiability
from accelcal.methods.dividing_head.result import (
    K_O_STAR,
    first_harmonic_terms,
    head_reduction,
)
from accelcal.methods.dividing_head.single import scale_factors, single_operator
from accelcal.methods.dividing_head.theory import (
    COEFFICIENTS,
    alias_jacobian,
    angle_names,
    coefficient_units,
    harmonics,
    is_uniform,
)
from accelcal.results import Assumption, Estimate, Reduction


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
    operator : numpy.ndarray, shape (K, n, K, n)
        Residual operator ``R`` (sensor, position, sensor, reading).
    residuals : numpy.ndarray, shape (..., K, n)

    Returns
    -------
    numpy.ndarray, shape (..., K)

    References
    ----------
    .. [1] docs/dividing-head.md, the four-sensor covariance; Dong2014 eq. (30)
       for the single-sensor case (M diagonal, n - 5).
    """
    moments = np.einsum("kjlm,kjlm->kl", operator, operator)
    rss = np.einsum("...kn,...kn->...k", residuals, residuals)
    common = rss.sum(axis=-1) / moments.sum()
    if pooled:
        return np.broadcast_to(common[..., None], rss.shape).copy()
    s2 = np.linalg.solve(moments, rss[..., None])[..., 0]
    bad = ~(np.isfinite(s2) & (s2 >= 0)).all(axis=-1)
    return np.where(bad[..., None], common[..., None], s2)


@dataclass(frozen=True)
class FourOperator:
    """Linear operators of the corrected four-sensor reduction for one design.

    All act on normalised outputs ``U'_k = U_k / K_I,k`` flattened sensor-major
    to a vector of length ``K n``.

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
            If the positions are not equally spaced over the circle, fewer
            than 12, or the mounts do not cancel in V_z (sum exp(2 i phi) != 0).

        References
        ----------
        .. [1] Dong2014, eqs. (15)-(26), corrected as [DOMAIN] section 4,
           reduction steps 1-4.
        """
        alpha = np.asarray(positions, dtype=float)
        phi = np.asarray(mounts, dtype=float)
        n, k = alpha.size, phi.size
        if n < 12:
            raise AccelcalError(
                f"method four needs at least 12 equally spaced positions (harmonics up to 5 "
                f"of the head error are separated); got {n}"
            )
        if not is_uniform(alpha):
            raise AccelcalError(
                "method four needs equally spaced positions over the full circle; "
                "use method joint for other position sets"
            )
        if k < 2 or abs(np.exp(2j * phi).sum()) > 1e-9 * k:
            raise AccelcalError(
                "method four needs mounts whose doubled phases cancel (sum of exp(2i phi) = 0), "
                "e.g. 0,90,180,270 or 0,90 deg; use method joint for other mounts"
            )
        beta = alpha[None, :] + phi[:, None]
        cosb = np.cos(beta)
        eye = np.eye(k * n).reshape(k, n, k * n)  # eye[k] selects sensor k's outputs
        # Step 1: V_z = sum_k U'_k cos(beta_k); its harmonics >= 4 are (K/2) d_alpha.
        wz = np.einsum("kn,knm->nm", cosb, eye)  # Eq. (15) [DOMAIN]
        h3 = harmonics(alpha, 3)
        p3 = np.eye(n) - h3 @ np.linalg.pinv(h3)
        d_ge4 = p3 @ wz / (0.5 * k)  # Eq. (17) [Dong2014], factor K/2 [DOMAIN]
        # Step 2: sensor 1's fit after removing d_ge4: d2, d3 directly (= 2 M(3rd) - d4 ...).
        h23 = np.stack([np.cos(2 * alpha), np.sin(2 * alpha), np.cos(3 * alpha),
                        np.sin(3 * alpha)], axis=-1)
        fit1 = np.concatenate([harmonics(alpha, 2), h23 * cosb[0][:, None]], axis=-1)
        d23 = np.linalg.pinv(fit1)[5:] @ (eye[0] - cosb[0][:, None] * d_ge4)  # Eq. (21) [DOMAIN]
        # Step 3: d_hi = harmonics 2, 3 and >= 4 of d_alpha.
        d_hi = d_ge4 + h23 @ d23
        # Step 4: V'_k = U'_k - d_hi cos(beta_k), regressed on Psi(beta_k).
        pinv, hat_res, cov_unit = single_operator(beta)
        v = eye - cosb[:, :, None] * d_hi[None]  # Eq. (22) corrected [DOMAIN]
        coef = pinv @ v  # Eq. (24) [Dong2014]
        resid = hat_res @ v  # Eq. (29) [Dong2014]
        return cls(coef, resid, d_hi, cov_unit, alias_jacobian(phi))

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


def four(
    data: HeadData,
    *,
    first_harmonic=None,
    first_harmonic_sd=0.0,
    covariance: str = "paper",
) -> Reduction:
    """Four-sensor separation of the head's angle error, as corrected in [DOMAIN].

    Steps: 0 normalise each sensor by its own scale factor; 1 harmonics >= 4
    of d_alpha from V_z; 2 harmonics 2, 3 from sensor 1; 3-4 compensate
    each sensor and fit Psi(beta_k); 5 remove the first-harmonic alias if
    d1 is given; 6 K_O* = K_O + K_I (eta + d0); 7 covariance, scaled back
    by K_I.

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
    covariance : {"paper", "propagated"}
        ``paper``: step 7, ``s^2 (Psi' Psi)^-1`` per sensor from its own
        residuals (Dong2014 eq. (31)); it omits the noise that the separated
        head error carries into every sensor's fit and understates the
        scatter (about 1.4 times for four sensors at 24 positions).
        ``propagated``: the readings' noise (each sensor's variance estimated
        without bias from all residuals, :func:`residual_noise_variances`)
        propagated exactly through the linear steps 1-5, with the
        covariances between sensors and with the head error in
        ``Reduction.covariance``. Both add the first-harmonic term.

    Returns
    -------
    Reduction
        Method ``dividing-head/four``: per-sensor coefficients (output unit),
        the separated head error (harmonics >= 2, plus the first harmonic
        when given) as ``shared``, the identifiability of the joint design,
        and assumptions ``first_harmonic`` and ``covariance``.

    References
    ----------
    .. [1] Dong2014, eqs. (14)-(31); corrected steps 0-7 of [DOMAIN] section 4.
    """
    if covariance not in FOUR_COVARIANCES:
        raise AccelcalError(
            f"{covariance!r} is not one of {', '.join(FOUR_COVARIANCES)}", parameter="covariance"
        )
    op = FourOperator.build(data.positions, data.mounts)
    k_i = scale_factors(data)  # Step 0 [DOMAIN]
    u = (data.outputs / k_i[:, None]).reshape(-1)
    x = op.coef @ u
    resid = op.resid @ u
    n, k = data.positions.size, data.n_sensors
    h1, h1_cov, h1_assumptions = first_harmonic_terms(first_harmonic, first_harmonic_sd)
    x = x - op.alias @ h1  # Step 5 [DOMAIN]; Eq. (27)-(28) corrected
    c1 = np.stack([np.cos(data.positions), np.sin(data.positions)], axis=-1)
    d_hi = op.angle @ u
    if first_harmonic is not None:
        d_hi = d_hi + c1 @ h1
    # first-harmonic part of [coefficients (volts), head error]: -alias h1 and, when given, +c1 h1
    h1_map = np.concatenate([-(op.alias * k_i[:, None, None]).reshape(5 * k, 2),
                             c1 if first_harmonic is not None else np.zeros((n, 2))])
    full = None
    if covariance == "paper":
        s2 = np.einsum("kn,kn->k", resid, resid) / (n - 5)  # Eq. (30) [Dong2014]
        cov = s2[:, None, None] * op.cov_unit  # Eq. (31) [Dong2014]
        cov = cov + op.alias @ h1_cov @ np.swapaxes(op.alias, -1, -2)
        cov = k_i[:, None, None] ** 2 * cov
        d_cov = float(s2.mean()) * op.angle @ op.angle.T + h1_map[5 * k:] @ h1_cov @ \
            h1_map[5 * k:].T
        cov_note = ("covariance from each sensor's residual variance (Dong2014 eq. (31)); it "
                    "omits the noise carried in by the separated head error (1.3-1.5x too "
                    "small for four sensors at 24 positions; covariance='propagated')")
        angle_note = "covariance from the pooled residual variance"
    else:
        scale = np.concatenate([np.repeat(k_i, 5), np.ones(n)])
        full = op.propagated_covariance(op.noise_variances(resid)) * np.outer(scale, scale)
        full = full + h1_map @ h1_cov @ h1_map.T
        cov = np.stack([full[5 * j:5 * j + 5, 5 * j:5 * j + 5] for j in range(k)])
        d_cov = full[5 * k:, 5 * k:]
        cov_note = angle_note = ("covariance propagated from the readings' noise through every "
                                 "step (head error's share included)")
    units = coefficient_units(data.output_unit)
    sensors = tuple(
        Estimate(COEFFICIENTS, k_i[j] * x[j], cov[j], units, "four",
                 residuals=k_i[j] * resid[j], dof=n - 5)
        for j in range(k)
    )
    names = angle_names(n)
    angle = Estimate(names, d_hi, d_cov, dict.fromkeys(names, "rad"), "four",
                     notes=(angle_note,))
    assumptions = (*h1_assumptions, K_O_STAR, Assumption("covariance", covariance, "", cov_note))
    return head_reduction(
        data, "four", sensors, shared=angle, covariance=full, dof=n - 5,
        identifiability=identifiability(data.positions, data.mounts, data.sensors),
        assumptions=assumptions, provenance={"covariance": covariance},
    )
