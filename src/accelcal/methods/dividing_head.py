"""Reductions of indexing-head data: single-sensor fit, four-sensor separation, joint LS.

Data: nominal head angles ``alpha`` (rad, shape ``(n,)``), sensor outputs
``U`` (volts, shape ``(K, n)``, or ``(R, K, n)`` with R repeated readings,
averaged), mount phases ``phi`` (rad, ``(K,)``). Each sensor's own angle is
``beta_k = alpha + phi_k`` and its model (Dong2014 eq. (5), a_p = 0) is ::

    U = K_F + K_I sin(g) + K_O cos(g) + K_IO sin(g) cos(g) + K_II sin(g)^2,
    g = beta + d_alpha + eta_k

with d_alpha the head's angular position error. Every method fits the
basis ``Psi(beta) = [1, sin b, cos b, sin b cos b, sin^2 b]`` per sensor.

* ``single``: each sensor alone; d_alpha biases every coefficient.
* ``four``: Dong2014's separation as corrected in [DOMAIN] section 4 (steps
  0-7): harmonics >= 2 of d_alpha are measured and removed.
* ``joint``: one least-squares problem for all sensors and all per-position
  d_alpha with gauge constraints; optional autocollimator readings and
  Gauss-Newton iteration on the exact (non-linearised) model.

Gauge: the mean d0 and the first harmonic (d1c, d1s) of d_alpha cannot be
separated from the coefficients by the accelerometers alone. The mean is
always absorbed into ``K_O* = K_O + K_I (eta_k + d0)``; the first harmonic
is either given (autocollimator) or taken as zero, which biases K_F, K_IO,
K_II by the alias of :func:`first_harmonic_alias`.

Every reduction is built from linear operators that depend only on the
positions and mounts (:class:`FourOperator`, :class:`JointOperator`), so
the Monte Carlo study applies the very same code to many trials at once.

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, eqs. (5)-(31).
.. [DOMAIN] accelcal domain notes, section 4 (corrected expansions and
   reduction steps 0-7; joint least squares).
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.results import Estimate, least_squares
from accelcal.rigs.dividing_head import check_positions

COEFFICIENTS = ("K_F", "K_I", "K_O", "K_IO", "K_II")
"""Dong2014 eq. (5) coefficient names, in the order of the basis Psi."""

METHODS = ("single", "four", "joint")

_FIRST_ORDER_NOTE = (
    "K_O is K_O* = K_O + K_I (eta + d0): misalignment and the mean head error "
    "cannot be separated from K_O by the accelerometers alone "
    "(accelcal docs/domain.md, section 4, step 6)"
)


def coefficient_units(output_unit: str = "V") -> dict[str, str]:
    """Units of the Dong2014 coefficients for outputs in ``output_unit``."""
    return {
        "K_F": output_unit, "K_I": f"{output_unit}/g", "K_O": f"{output_unit}/g",
        "K_IO": f"{output_unit}/g^2", "K_II": f"{output_unit}/g^2",
    }


def psi(beta) -> np.ndarray:
    """The basis ``[1, sin b, cos b, sin b cos b, sin^2 b]``, shape ``(..., n, 5)``.

    References
    ----------
    .. [1] Dong2014, eq. (23) (matrix Psi).
    """
    b = np.asarray(beta, dtype=float)
    s, c = np.sin(b), np.cos(b)
    return np.stack([np.ones_like(b), s, c, s * c, s * s], axis=-1)  # Eq. (23) [Dong2014]


def first_harmonic_alias(first_harmonic, mounts) -> np.ndarray:
    """What a first harmonic of the head error adds to each sensor's normalised fit.

    With ``d_alpha = d1c cos(alpha) + d1s sin(alpha)`` and sensor k at
    phase phi_k, regressing U/K_I on Psi(beta_k) returns the coefficients
    plus ``[c', 0, 0, s', -c']`` with ``c' = d1c cos phi - d1s sin phi`` and
    ``s' = d1c sin phi + d1s cos phi`` [DOMAIN step 4]. Multiply by K_I for
    volts.

    Parameters
    ----------
    first_harmonic : array_like, shape (..., 2)
        (d1c, d1s), rad.
    mounts : array_like, shape (K,)
        Mount phases, rad.

    Returns
    -------
    numpy.ndarray, shape (..., K, 5)

    References
    ----------
    .. [1] Dong2014, eqs. (25)-(26), corrected as [DOMAIN] section 4, step 4.
    """
    h = np.asarray(first_harmonic, dtype=float)
    phi = np.asarray(mounts, dtype=float)
    c1, s1 = h[..., 0, None], h[..., 1, None]
    cp = c1 * np.cos(phi) - s1 * np.sin(phi)  # c' [DOMAIN step 4]
    sp = c1 * np.sin(phi) + s1 * np.cos(phi)  # s' [DOMAIN step 4]
    zero = np.zeros_like(cp)
    return np.stack([cp, zero, zero, sp, -cp], axis=-1)  # Eq. (25)-(26) corrected [DOMAIN]


def _alias_jacobian(mounts) -> np.ndarray:
    """d(alias)/d(d1c, d1s), shape (K, 5, 2)."""
    return np.stack(
        [first_harmonic_alias([1.0, 0.0], mounts), first_harmonic_alias([0.0, 1.0], mounts)],
        axis=-1,
    )


# --------------------------------------------------------------------------- input
@dataclass(frozen=True)
class HeadData:
    """Validated indexing-head data.

    Parameters
    ----------
    positions : numpy.ndarray
        Nominal head angles, rad, shape ``(n,)``.
    outputs : numpy.ndarray
        Outputs, shape ``(K, n)`` (means over repeats).
    mounts : numpy.ndarray
        Mount phases, rad, shape ``(K,)``.
    output_unit : str
        Unit of the outputs.
    repeats : int
        Readings averaged per position.
    """

    positions: np.ndarray
    outputs: np.ndarray
    mounts: np.ndarray
    output_unit: str = "V"
    repeats: int = 1

    @classmethod
    def build(cls, positions, outputs, mounts, output_unit: str = "V") -> "HeadData":
        """Check shapes and values and average repeats.

        Raises
        ------
        AccelcalError
            For duplicated or non-finite angles, NaN readings, or a number
            of mount phases that does not match the output columns.
        """
        alpha = np.asarray(positions, dtype=float).reshape(-1)
        check_positions(alpha)
        u = np.asarray(outputs, dtype=float)
        if u.ndim == 1:
            u = u[None, :]
        if u.ndim not in (2, 3) or u.shape[-1] != alpha.size:
            raise AccelcalError(
                f"outputs of shape {u.shape} do not match {alpha.size} positions; "
                "give shape (sensors, positions) or (repeats, sensors, positions)"
            )
        if not np.isfinite(u).all():
            bad = np.argwhere(~np.isfinite(u))[0]
            raise AccelcalError(
                f"output reading at index {tuple(int(i) for i in bad)} is NaN or inf; "
                "remove or re-measure that position"
            )
        repeats = u.shape[0] if u.ndim == 3 else 1
        u = u.mean(axis=0) if u.ndim == 3 else u
        phi = np.asarray(mounts, dtype=float).reshape(-1)
        if phi.size != u.shape[0]:
            raise AccelcalError(
                f"{phi.size} mount phases given for {u.shape[0]} sensor output columns; "
                "give one mount phase per sensor column"
            )
        if not np.isfinite(phi).all():
            raise AccelcalError("mount phases contain NaN or inf")
        return cls(alpha, u, phi, output_unit, repeats)

    @property
    def n_sensors(self) -> int:
        """Number of sensors K."""
        return self.outputs.shape[0]

    def angles(self) -> np.ndarray:
        """Nominal sensor angles beta, rad, shape ``(K, n)``."""
        return self.positions[None, :] + self.mounts[:, None]


@dataclass(frozen=True)
class HeadReduction:
    """Result of an indexing-head reduction.

    Attributes
    ----------
    method : str
        ``single``, ``four``, ``joint`` or ``tumble``.
    sensors : tuple of Estimate
        Per sensor: K_F, K_I, K_O (= K_O*), K_IO, K_II in the output unit,
        with covariance and residuals (output unit).
    angle_error : Estimate or None
        Per-position head angle error estimate, rad (``four``: harmonics >= 2
        plus the given first harmonic; ``joint``: everything but the gauge).
    covariance : numpy.ndarray or None
        Full covariance of ``[coefficients of all sensors, angle errors]``
        (``joint``, and ``four`` with the propagated covariance).
    null_space_dim : int or None
        Null-space dimension of the unconstrained joint design.
    notes : tuple of str
        Assumptions and caveats.
    """

    method: str
    sensors: tuple
    angle_error: Estimate | None = None
    covariance: np.ndarray | None = None
    null_space_dim: int | None = None
    notes: tuple = ()

    def rows(self, sensor_names=None) -> list[dict]:
        """Rows ``{sensor, coefficient, estimate, std}`` for tables and files."""
        names = sensor_names or [f"U{k + 1}" for k in range(len(self.sensors))]
        return [
            {"sensor": name, "coefficient": c, "estimate": float(v), "std": float(s)}
            for name, est in zip(names, self.sensors, strict=True)
            for c, v, s in zip(est.names, est.values, est.std, strict=True)
        ]

    def residuals(self) -> np.ndarray:
        """Residuals in the output unit, shape ``(K, n)``."""
        return np.stack([e.residuals for e in self.sensors])

    def to_frame(self, sensor_names=None):
        """The rows as a pandas DataFrame indexed by sensor and coefficient (pandas lazily)."""
        import pandas as pd

        return pd.DataFrame(self.rows(sensor_names)).set_index(["sensor", "coefficient"])

    def plot(self, directory, **kwargs):
        """Write the residual and head-error figures (:mod:`accelcal.plotting.dividing_head`)."""
        from accelcal.plotting.dividing_head import plot_reduction

        return plot_reduction(self, directory, **kwargs)


# --------------------------------------------------------------------------- single
def single_operator(beta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least-squares operators of the single-sensor fit for angles ``beta`` ``(K, n)``.

    Returns
    -------
    pinv : numpy.ndarray, shape (K, 5, n)
        Estimates = pinv @ U.
    hat_residual : numpy.ndarray, shape (K, n, n)
        Residuals = hat_residual @ U.
    cov_unit : numpy.ndarray, shape (K, 5, 5)
        (Psi' Psi)^-1.
    """
    a = psi(beta)
    cov_unit = np.linalg.inv(np.swapaxes(a, -1, -2) @ a)
    pinv = cov_unit @ np.swapaxes(a, -1, -2)
    n = beta.shape[-1]
    return pinv, np.eye(n) - a @ pinv, cov_unit


def single(data: HeadData) -> HeadReduction:
    """Each sensor alone: least squares on Psi(beta_k).

    The head error enters every coefficient: harmonics 0-3 of d_alpha bias
    K_F, K_I, K_O, K_IO, K_II and the rest inflates the residual.

    Raises
    ------
    AccelcalError
        With fewer than 6 positions (5 unknowns and one degree of freedom).

    References
    ----------
    .. [1] Dong2014, section 3 and Table 2 (single-sensor method).
    """
    _need_positions(data, 6, "single")
    units = coefficient_units(data.output_unit)
    estimates = tuple(
        least_squares(psi(b), u, COEFFICIENTS, units, "single", notes=(_FIRST_ORDER_NOTE,))
        for b, u in zip(data.angles(), data.outputs, strict=True)
    )
    return HeadReduction("single", estimates, notes=(_FIRST_ORDER_NOTE,))


def scale_factors(data_or_beta, outputs=None) -> np.ndarray:
    """Each sensor's own scale factor from a single-sensor fit [DOMAIN step 0].

    Parameters
    ----------
    data_or_beta : HeadData or numpy.ndarray
        The data, or the angles beta ``(K, n)`` with ``outputs (..., K, n)``.
    outputs : numpy.ndarray, optional
        Outputs when angles are given.

    Returns
    -------
    numpy.ndarray, shape (..., K)
        The sine coefficient of the Psi fit, output unit per g.
    """
    if isinstance(data_or_beta, HeadData):
        beta, outputs = data_or_beta.angles(), data_or_beta.outputs
    else:
        beta = data_or_beta
    pinv = single_operator(beta)[0]
    k_i = np.einsum("kn,...kn->...k", pinv[:, 1, :], outputs)
    if (np.abs(k_i) == 0).any():
        raise AccelcalError("a sensor's fitted scale factor is zero; check the output columns")
    return k_i


# --------------------------------------------------------------------------- four
def _harmonics(alpha: np.ndarray, m_max: int) -> np.ndarray:
    cols = [np.ones_like(alpha)]
    for m in range(1, m_max + 1):
        cols += [np.cos(m * alpha), np.sin(m * alpha)]
    return np.stack(cols, axis=-1)


def _is_uniform(alpha: np.ndarray) -> bool:
    """True when the angles are n equally spaced positions over the circle (any start)."""
    wrapped = np.sort(np.mod(alpha - alpha[0], 2 * np.pi))
    steps = np.diff(np.append(wrapped, 2 * np.pi))
    return bool(np.allclose(steps, 2 * np.pi / alpha.size, rtol=0, atol=1e-9))


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
        if not _is_uniform(alpha):
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
        h3 = _harmonics(alpha, 3)
        p3 = np.eye(n) - h3 @ np.linalg.pinv(h3)
        d_ge4 = p3 @ wz / (0.5 * k)  # Eq. (17) [Dong2014], factor K/2 [DOMAIN]
        # Step 2: sensor 1's fit after removing d_ge4: d2, d3 directly (= 2 M(3rd) - d4 ...).
        h23 = np.stack([np.cos(2 * alpha), np.sin(2 * alpha), np.cos(3 * alpha),
                        np.sin(3 * alpha)], axis=-1)
        fit1 = np.concatenate([_harmonics(alpha, 2), h23 * cosb[0][:, None]], axis=-1)
        d23 = np.linalg.pinv(fit1)[5:] @ (eye[0] - cosb[0][:, None] * d_ge4)  # Eq. (21) [DOMAIN]
        # Step 3: d_hi = harmonics 2, 3 and >= 4 of d_alpha.
        d_hi = d_ge4 + h23 @ d23
        # Step 4: V'_k = U'_k - d_hi cos(beta_k), regressed on Psi(beta_k).
        pinv, hat_res, cov_unit = single_operator(beta)
        v = eye - cosb[:, :, None] * d_hi[None]  # Eq. (22) corrected [DOMAIN]
        coef = pinv @ v  # Eq. (24) [Dong2014]
        resid = hat_res @ v  # Eq. (29) [Dong2014]
        return cls(coef, resid, d_hi, cov_unit, _alias_jacobian(phi))

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
) -> HeadReduction:
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
        ``HeadReduction.covariance``. Both add the first-harmonic term.

    Returns
    -------
    HeadReduction

    References
    ----------
    .. [1] Dong2014, eqs. (14)-(31); corrected steps 0-7 of [DOMAIN] section 4.
    """
    if covariance not in FOUR_COVARIANCES:
        raise AccelcalError(
            f"covariance {covariance!r} is not one of {', '.join(FOUR_COVARIANCES)}"
        )
    op = FourOperator.build(data.positions, data.mounts)
    k_i = scale_factors(data)  # Step 0 [DOMAIN]
    u = (data.outputs / k_i[:, None]).reshape(-1)
    x = op.coef @ u
    resid = op.resid @ u
    n, k = data.positions.size, data.n_sensors
    h1, h1_cov, notes = _first_harmonic_terms(first_harmonic, first_harmonic_sd)
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
    notes = (*notes, _FIRST_ORDER_NOTE, cov_note)
    sensors = tuple(
        Estimate(COEFFICIENTS, k_i[j] * x[j], cov[j], units, "four",
                 residuals=k_i[j] * resid[j], dof=n - 5, notes=notes)
        for j in range(k)
    )
    angle = Estimate(_angle_names(n), d_hi, d_cov, dict.fromkeys(_angle_names(n), "rad"),
                     "four", notes=(angle_note,))
    return HeadReduction("four", sensors, angle_error=angle, covariance=full, notes=notes)


def _first_harmonic_terms(first_harmonic, sd):
    sd = np.broadcast_to(np.asarray(sd, dtype=float), (2,))
    if not (np.isfinite(sd).all() and (sd >= 0).all()):
        raise AccelcalError(f"first-harmonic uncertainty must be finite and >= 0, got {sd}")
    cov = np.diag(sd**2)
    if first_harmonic is None:
        note = ("first harmonic of the head error unknown: taken as zero; K_F, K_IO, K_II "
                "carry its alias [DOMAIN step 5]")
        if sd.any():
            note += f" (systematic uncertainty {sd[0]:.3g}, {sd[1]:.3g} rad included)"
        return np.zeros(2), cov, (note,)
    h1 = np.asarray(first_harmonic, dtype=float).reshape(-1)
    if h1.size != 2 or not np.isfinite(h1).all():
        raise AccelcalError(f"first harmonic must be two finite numbers (C, S) in rad, got {h1}")
    return h1, cov, (f"first harmonic given: d1c = {h1[0]:.6g} rad, d1s = {h1[1]:.6g} rad",)


def _angle_names(n: int) -> tuple[str, ...]:
    return tuple(f"d_alpha[{j}]" for j in range(n))


# --------------------------------------------------------------------------- joint
@dataclass(frozen=True)
class Identifiability:
    """What the joint design can separate.

    Attributes
    ----------
    n_unknowns : int
        5 per sensor plus one angle error per position.
    rank : int
        Rank of the unconstrained design.
    null_space_dim : int
        ``n_unknowns - rank``: 3 (mean and first harmonic of d_alpha) for two
        or more sensors not 180 deg apart, 5 for one sensor or a 0/180 pair.
    condition_number : float
        Of the gauge-constrained design (inf when still rank deficient).
    dof : int
        Residual degrees of freedom of the constrained problem.
    """

    n_unknowns: int
    rank: int
    null_space_dim: int
    condition_number: float
    dof: int


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


def identifiability(positions, mounts) -> Identifiability:
    """Rank, null space and conditioning of the joint design (linearised).

    References
    ----------
    .. [1] [DOMAIN] section 4, joint least squares: null space 3 or 5.
    """
    alpha = np.asarray(positions, dtype=float).reshape(-1)
    phi = np.asarray(mounts, dtype=float).reshape(-1)
    check_positions(alpha)
    a, dcols = joint_design(alpha, phi)
    full = np.concatenate([a, dcols], axis=1)
    sv = np.linalg.svd(full, compute_uv=False)
    rank = int((sv > sv[0] * max(full.shape) * np.finfo(float).eps * 10).sum())
    _c, z = gauge_basis(alpha, True)
    red = np.concatenate([a, dcols @ z], axis=1)
    svr = np.linalg.svd(red, compute_uv=False)
    full_rank = red.shape[0] >= red.shape[1] and svr[-1] > svr[0] * 1e-12
    cond = float(svr[0] / svr[-1]) if full_rank else float("inf")
    n_unknowns = full.shape[1]
    return Identifiability(n_unknowns, rank, n_unknowns - rank, cond,
                           full.shape[0] - red.shape[1])


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
        diag = np.abs(np.diag(r))
        if diag.min() <= diag.max() * 1e-10:
            info = identifiability(alpha, phi)
            raise AccelcalError(
                f"method joint: the design is not identifiable (null space dimension "
                f"{info.null_space_dim}, 3 removable by the gauge); use two or more sensors "
                "not 180 deg apart"
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
) -> HeadReduction:
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
    HeadReduction
        Per-sensor coefficients, per-position angle errors, full covariance.

    References
    ----------
    .. [1] [DOMAIN] section 4, joint least squares; Dong2014 eq. (5).
    """
    alpha, phi = data.positions, data.mounts
    k, n = phi.size, alpha.size
    op = JointOperator.build(alpha, phi)
    ident = identifiability(alpha, phi)
    k_i = scale_factors(data)  # Step 0 [DOMAIN]
    u = (data.outputs / k_i[:, None]).reshape(-1)
    h1, h1_cov, notes = _first_harmonic_terms(first_harmonic, first_harmonic_sd)
    g = np.array([float(mean_error), *h1])
    theta = op.to_full @ (op.pinv @ u) + op.gauge @ g
    resid = op.resid @ u
    s2 = float(resid @ resid) / op.dof
    cov = s2 * op.cov_unit + op.gauge[:, 1:] @ h1_cov @ op.gauge[:, 1:].T
    dof = op.dof
    if autocollimator is not None:
        theta, cov, extra, sigma = _with_autocollimator(
            data, u=u, g=g, h1_fixed=first_harmonic is not None, readings=autocollimator,
            sd=autocollimator_sd, s2=s2,
        )
        if first_harmonic is not None:
            cov = cov + op.gauge[:, 1:] @ h1_cov @ op.gauge[:, 1:].T
        a, dcols = joint_design(alpha, phi)
        resid = u - a @ theta[:5 * k] - dcols @ theta[5 * k:]
        notes = (*notes, extra)
    scale = np.concatenate([np.repeat(k_i, 5), np.ones(n)])
    theta = theta * scale
    cov = cov * np.outer(scale, scale)
    resid_v = resid.reshape(k, n) * k_i[:, None]
    if gauss_newton:
        pseudo = None
        if autocollimator is not None:
            pseudo = (np.asarray(autocollimator, dtype=float).reshape(-1),
                      float(autocollimator_sd), sigma)
        theta, cov, resid_v, dof, gn_note = _gauss_newton(
            data, theta, g, h1_cov=h1_cov, op=op, max_iterations=max_iterations,
            h1_fixed=autocollimator is None or first_harmonic is not None, pseudo=pseudo,
        )
        notes = (*notes, gn_note)
    notes = (*notes, _FIRST_ORDER_NOTE)
    units = coefficient_units(data.output_unit)
    sensors = tuple(
        Estimate(COEFFICIENTS, theta[5 * i:5 * i + 5], cov[5 * i:5 * i + 5, 5 * i:5 * i + 5],
                 units, "joint", residuals=resid_v[i], dof=dof, notes=notes)
        for i in range(k)
    )
    names = _angle_names(n)
    angle = Estimate(names, theta[5 * k:], cov[5 * k:, 5 * k:], dict.fromkeys(names, "rad"),
                     "joint", dof=dof, notes=notes)
    return HeadReduction("joint", sensors, angle_error=angle, covariance=cov,
                         null_space_dim=ident.null_space_dim, notes=notes)


def _with_autocollimator(data, *, u, g, h1_fixed, readings, sd, s2):
    """Weighted joint fit with autocollimator pseudo-observations on the free part of d.

    Returns the estimates, their covariance, a note, and the noise ``sigma`` of
    the normalised readings that weighs the data rows against the readings.
    """
    alpha, phi = data.positions, data.mounts
    k, n = phi.size, alpha.size
    r = np.asarray(readings, dtype=float).reshape(-1)
    if r.size != n or not np.isfinite(r).all():
        raise AccelcalError(
            f"autocollimator readings: need {n} finite values (one per position), got {r.size}"
        )
    if sd is None or not np.isfinite(sd) or sd <= 0:
        raise AccelcalError("autocollimator readings need their standard uncertainty (> 0 rad)")
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
    return (theta, cov, f"autocollimator readings used as pseudo-observations (sd {sd:.3g} rad)",
            sigma)


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
    note = "Gauss-Newton on the exact model " + ("converged" if converged else
                                                 f"stopped after {max_iterations} iterations")
    return np.concatenate([th, d]), new_cov, resid_v, dof, note


def _need_positions(data: HeadData, minimum: int, method: str) -> None:
    n = data.positions.size
    if n < minimum:
        raise AccelcalError(
            f"method {method}: {n} positions for 5 unknowns per sensor; give at least {minimum}"
        )


def reduce(data: HeadData, method: str, **options) -> HeadReduction:
    """Run ``method`` (``single``, ``four``, ``joint`` or ``tumble``) on ``data``.

    ``options`` are passed to the method (``first_harmonic``,
    ``first_harmonic_sd``; for ``four`` also ``covariance``; for ``joint`` also ``autocollimator``,
    ``autocollimator_sd``, ``gauss_newton``). ``tumble`` uses the IEEE 1293
    multipoint Fourier reduction of :mod:`accelcal.methods.tumble` on each
    sensor, with the head axis along PA.

    Raises
    ------
    AccelcalError
        For an unknown method or options the method does not take.
    """
    if method == "single":
        _no_options(options, method)
        return single(data)
    if method == "four":
        _no_options({k: v for k, v in options.items()
                     if k not in ("first_harmonic", "first_harmonic_sd", "covariance")}, method)
        return four(data, **options)
    if method == "joint":
        return joint(data, **options)
    if method == "tumble":
        _no_options(options, method)
        return tumble(data)
    raise AccelcalError(
        f"unknown method {method!r}; choose one of single, four, joint, tumble"
    )


def _no_options(options, method):
    given = [k for k, v in options.items() if v is not None]
    if given:
        raise AccelcalError(f"method {method} does not take {', '.join(given)}")


def tumble(data: HeadData) -> HeadReduction:
    """Per-sensor IEEE 1293 multipoint reduction, mapped to Dong2014 coefficients.

    Calls :func:`accelcal.methods.tumble.reduce_tumble` with
    ``rotation_axis="PA"`` on each sensor's angles beta_k and converts the
    accelcal terms to K_F = K1 K0, K_I = K1, K_O = K1 Ko, K_IO = K1 Kio,
    K_II = K1 K2 (covariance by the Jacobian of that map).

    References
    ----------
    .. [1] IEEE1293 multipoint tumble; [DOMAIN] section 5.
    """
    from accelcal.methods import tumble as tumble_module

    units = coefficient_units(data.output_unit)
    sensors = []
    notes: list[str] = []
    for b, u in zip(data.angles(), data.outputs, strict=True):
        res = tumble_module.reduce_tumble(b, u, rotation_axis="PA", output_unit=data.output_unit)
        est = res.estimate
        values, cov = _terms_to_dong2014(est)
        resid = est.residuals if est.residuals is not None and \
            np.shape(est.residuals) == u.shape else u - psi(b) @ values
        sensors.append(Estimate(COEFFICIENTS, values, cov, units, "tumble", residuals=resid,
                                dof=est.dof, notes=tuple(est.notes)))
        notes.extend(n for n in est.notes if n not in notes)
    return HeadReduction("tumble", tuple(sensors), notes=tuple(notes))


def _terms_to_dong2014(est: Estimate):
    """Map an accelcal-term estimate (K0, K1, Ko, Kio, K2) to Dong2014 volts with covariance."""
    def get(name):
        return est[name] if name in est.names else 0.0
    k1 = get("K1")
    if k1 == 0.0:
        raise AccelcalError("the tumble reduction returned no scale factor K1")
    src = ("K0", "K1", "Ko", "Kio", "K2")
    values = np.array([k1 * get("K0"), k1, k1 * get("Ko"), k1 * get("Kio"), k1 * get("K2")])
    jac = np.zeros((5, len(est.names)))
    for row, name in ((0, "K0"), (2, "Ko"), (3, "Kio"), (4, "K2")):
        if name in est.names:
            jac[row, est.names.index(name)] = k1
            jac[row, est.names.index("K1")] += get(name)
    jac[1, est.names.index("K1")] = 1.0
    cov = jac @ np.asarray(est.covariance) @ jac.T
    missing = [s for s in src if s not in est.names]
    if missing:
        cov[[src.index(m) for m in missing], :] = np.nan
        cov[:, [src.index(m) for m in missing]] = np.nan
    return values, cov
