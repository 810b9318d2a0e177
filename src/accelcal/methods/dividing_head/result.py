"""The indexing-head reductions' :class:`~accelcal.results.Reduction`, and their assumptions.

Every head reduction returns a Reduction of family ``dividing-head`` and
method ``dividing-head/<single|four|joint|tumble>`` (the method string of
its calibration records). Its fields:

* ``sensors``: per sensor K_F, K_I, K_O (= K_O*), K_IO, K_II in the output
  unit, with covariance, residuals (output unit) and degrees of freedom;
* ``shared``: the per-position head angle error ``d_alpha[j]``, rad
  (``four`` and ``joint``, up to
  :data:`~accelcal.methods.dividing_head.sizes.MAX_DENSE_POSITIONS`
  positions; beyond, its n x n covariance is not formed and the values and
  standard uncertainties are ``observations['d_alpha']`` and
  ``observations['d_alpha_std']``);
* ``covariance``: the full covariance of ``[coefficients of every sensor,
  angle errors]`` (``joint``; ``four`` with the propagated covariance;
  beyond ``MAX_DENSE_POSITIONS`` positions the coefficients' only);
* ``identifiability``: of the unconstrained joint design (``four`` and
  ``joint``); its null space (``len(names) - rank``: 3 for two or more
  sensors not 180 deg apart, 5 otherwise) is the gauge of the head error;
* ``observations``: ``positions`` and ``mounts`` (rad), and the
  ``autocollimator`` readings (rad) where used;
* ``models``: per sensor :meth:`ErrorModel.from_dong2014` of the estimates,
  with sigma the residual SD (pooled over the sensors for ``joint``, whose
  degrees of freedom they share);
* ``assumptions`` (names): ``first_harmonic`` (``"given"``,
  ``"estimated"`` or ``"zero"``), ``first_harmonic_value`` and
  ``first_harmonic_sd`` (rad), ``k_o_star`` (K_O is K_O*), ``mean_error``
  (rad, ``joint``), ``covariance`` (``"paper"`` or ``"propagated"``,
  ``four``), ``autocollimator_sd`` (rad), ``gauss_newton`` (``"converged"``
  or ``"stopped"``).

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, eq. (5).
.. [DOMAIN] accelcal domain notes, section 4, steps 5-6.
"""

import dataclasses
import math

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.formats.dividing_head import MAX_ANGLE_ERROR_RAD
from accelcal.methods.dividing_head.sizes import MAX_DENSE_POSITIONS
from accelcal.methods.dividing_head.theory import FAMILY, FIRST_ORDER_NOTE, angle_names
from accelcal.results import Assumption, Estimate, Reduction

K_O_STAR = Assumption("k_o_star", True, "", FIRST_ORDER_NOTE)
"""K_O is reported as K_O* = K_O + K_I (eta + d0) by every head reduction."""


CROSS_LABELS = {"K_F": "K_F+K_OO", "K_II": "K_II-K_OO"}
"""Row names of the coefficients the cross-axis nonlinearity K_OO = K_I Koo enters: no
rotation about PA separates it (a_i = sin, a_o = cos)."""


def head_reduction(data, method: str, sensors, *, pooled_sigma: bool = False,
                   observations=None, **fields) -> Reduction:
    """The Reduction of a head reduction ``method`` of ``data`` with per-sensor ``sensors``.

    ``fields`` are further :class:`~accelcal.results.Reduction` fields
    (shared, covariance, dof, identifiability, assumptions, provenance,
    notes). The models' sigma is each sensor's residual SD, or with
    ``pooled_sigma`` all residuals over the shared degrees of freedom.

    References
    ----------
    .. [1] Dong2014, eq. (5) (coefficient definitions).
    """
    from accelcal.model import ErrorModel

    # Every head reduction turns the sensors about PA: a_i^2 + a_o^2 = 1 at every position,
    # so K_F carries K_OO = K_I Koo and K_II carries -K_OO; the rows say so.
    sensors = tuple(dataclasses.replace(e, labels={**CROSS_LABELS, **e.labels})
                    if "K_F" in e.names else e for e in sensors)
    check_finite(sensors, fields.get("shared"), observations)
    if pooled_sigma:
        dof = sensors[0].dof
        rss = float(np.sum(np.stack([e.residuals for e in sensors]) ** 2))
        sigmas = [float(np.sqrt(rss / dof)) if dof else 0.0] * len(sensors)
    else:
        sigmas = [e.residual_sigma() for e in sensors]
    models = tuple(
        ErrorModel.from_dong2014(  # Eq. (5) [Dong2014]
            *(float(e[c]) for c in ("K_F", "K_I", "K_O", "K_IO", "K_II")),
            output_unit=data.output_unit, sigma=s if math.isfinite(s) else 0.0,
        )
        for e, s in zip(sensors, sigmas, strict=True)
    )
    obs = {"positions": data.positions, "mounts": data.mounts, **(observations or {})}
    provenance = {"method": method, "positions": int(data.positions.size),
                  "sensors": data.n_sensors, "repeats": int(data.repeats),
                  "output_unit": data.output_unit, **fields.pop("provenance", {})}
    return Reduction(family=FAMILY, method=f"{FAMILY}/{method}", sensors=sensors,
                     sensor_names=data.sensors, observations=obs, models=models,
                     nominal={"K_I": data.nominal_scale_factors}
                     if data.nominal_scale_factors else {},
                     provenance=provenance, **fields)


def first_harmonic_terms(first_harmonic, sd):
    """The first harmonic used, its covariance, and the assumptions that describe it.

    Returns
    -------
    h1 : numpy.ndarray, shape (2,)
        (d1c, d1s), rad (zero when not given).
    cov : numpy.ndarray, shape (2, 2)
        ``diag(sd^2)``.
    assumptions : tuple of Assumption
        ``first_harmonic`` (``"given"`` or ``"zero"``), ``first_harmonic_value``
        and ``first_harmonic_sd``.

    Raises
    ------
    AccelcalError
        For a non-finite or negative ``sd``, or a first harmonic that is not
        two finite numbers.
    """
    sd = np.broadcast_to(np.asarray(sd, dtype=float), (2,))
    if not (np.isfinite(sd).all() and (sd >= 0).all() and (sd <= MAX_ANGLE_ERROR_RAD).all()):
        raise AccelcalError(f"must be finite, >= 0 and at most 1 deg ({MAX_ANGLE_ERROR_RAD:.4g} "
                            f"rad), got {sd}", parameter="first_harmonic_sd")
    cov = np.diag(sd**2)
    sd_assumption = Assumption("first_harmonic_sd", (float(sd[0]), float(sd[1])), "rad")
    if first_harmonic is None:
        text = ("first harmonic of the head error unknown: taken as zero; K_F, K_IO, K_II "
                "carry its alias [DOMAIN step 5]")
        if sd.any():
            text += f" (systematic uncertainty {sd[0]:.3g}, {sd[1]:.3g} rad included)"
        return np.zeros(2), cov, (Assumption("first_harmonic", "zero", "", text),
                                  Assumption("first_harmonic_value", (0.0, 0.0), "rad"),
                                  sd_assumption)
    h1 = np.asarray(first_harmonic, dtype=float).reshape(-1)
    if h1.size != 2 or not np.isfinite(h1).all() or np.hypot(*h1) > MAX_ANGLE_ERROR_RAD:
        raise AccelcalError(
            f"the first harmonic must be two finite numbers (C, S) in rad of amplitude at most "
            f"1 deg, got {h1}", parameter="first_harmonic",
        )
    text = f"first harmonic given: d1c = {h1[0]:.6g} rad, d1s = {h1[1]:.6g} rad"
    return h1, cov, (Assumption("first_harmonic", "given", "", text),
                     Assumption("first_harmonic_value", (float(h1[0]), float(h1[1])), "rad"),
                     sd_assumption)


def angle_fields(values, covariance, method: str, note: str):
    """The separated head error as Reduction fields: ``(shared, observations, notes)``.

    With a dense ``covariance`` (n x n) it is the ``shared`` Estimate; with
    its diagonal only (more than ``MAX_DENSE_POSITIONS`` positions) the
    values and standard uncertainties go to ``observations`` (``d_alpha``,
    ``d_alpha_std``, rad) and a note says so.
    """
    names = angle_names(values.size)
    if np.ndim(covariance) == 2:
        return Estimate(names, values, covariance, dict.fromkeys(names, "rad"), method,
                        notes=(note,)), {}, ()
    text = (f"head angle error at {values.size} positions: values and standard uncertainties "
            f"in observations d_alpha and d_alpha_std (rad); {note}; their {values.size} x "
            f"{values.size} covariance is not formed above {MAX_DENSE_POSITIONS} positions")
    return None, {"d_alpha": values, "d_alpha_std": np.sqrt(np.maximum(covariance, 0.0))}, \
        (text,)


def check_finite(sensors, shared, observations) -> None:
    """Refuse a reduction whose estimates or uncertainties are not finite numbers.

    Readings or metadata of non-physical magnitude (1e308 V, a 1e308 rad
    first-harmonic uncertainty) overflow; nothing non-finite may be printed
    or stored as if valid.

    Raises
    ------
    AccelcalError
        Naming what overflowed.
    """
    for est in (*sensors, *((shared,) if shared is not None else ())):
        # NaN covariance marks a term a reduction does not report (tumble); inf never
        if not np.isfinite(est.values).all() or np.isinf(est.covariance).any() or (
                est.residuals is not None and not np.isfinite(est.residuals).all()):
            raise AccelcalError(
                "the estimates or their uncertainties overflow (not finite): the readings, "
                "scale factors or uncertainties given are of non-physical magnitude; check "
                "the record's values and units"
            )
    for name, value in (observations or {}).items():
        if not isinstance(value, str) and not np.isfinite(np.asarray(value, dtype=float)).all():
            raise AccelcalError(f"the reduction's {name} overflow (not finite): the inputs are "
                                "of non-physical magnitude; check their values and units")
