"""The indexing-head reductions' :class:`~accelcal.results.Reduction`, and their assumptions.

Every head reduction returns a Reduction of family ``dividing-head`` and
method ``dividing-head/<single|four|joint|tumble>`` (the method string of
its calibration records). Its fields:

* ``sensors``: per sensor K_F, K_I, K_O (= K_O*), K_IO, K_II in the output
  unit, with covariance, residuals (output unit) and degrees of freedom;
* ``shared``: the per-position head angle error ``d_alpha[j]``, rad
  (``four`` and ``joint``);
* ``covariance``: the full covariance of ``[coefficients of every sensor,
  angle errors]`` (``joint``; ``four`` with the propagated covariance);
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

import math

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.methods.dividing_head.theory import FAMILY, FIRST_ORDER_NOTE
from accelcal.results import Assumption, Reduction

K_O_STAR = Assumption("k_o_star", True, "", FIRST_ORDER_NOTE)
"""K_O is reported as K_O* = K_O + K_I (eta + d0) by every head reduction."""


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

    sensors = tuple(sensors)
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
    if not (np.isfinite(sd).all() and (sd >= 0).all()):
        raise AccelcalError(f"must be finite and >= 0, got {sd}", parameter="first_harmonic_sd")
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
    if h1.size != 2 or not np.isfinite(h1).all():
        raise AccelcalError(
            f"the first harmonic must be two finite numbers (C, S) in rad, got {h1}",
            parameter="first_harmonic",
        )
    text = f"first harmonic given: d1c = {h1[0]:.6g} rad, d1s = {h1[1]:.6g} rad"
    return h1, cov, (Assumption("first_harmonic", "given", "", text),
                     Assumption("first_harmonic_value", (float(h1[0]), float(h1[1])), "rad"),
                     sd_assumption)
