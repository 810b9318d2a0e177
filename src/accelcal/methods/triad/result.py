"""The :class:`~accelcal.results.Reduction` of a triad calibration (both routes).

Fields set (docs/triad.md lists them):

- ``sensors[0]``: the :data:`~accelcal.methods.triad.model.PARAMS` (and
  ``q_x, q_y, q_z`` with quadratic terms), their covariance, the residuals
  (readings, input unit, for known orientations; norm residuals, m/s^2, for
  the gravity norm) and their degrees of freedom;
- ``shared`` (known orientations): the gauge, the rotation vector
  ``rot_x, rot_y, rot_z`` (rad) of the fixture-to-body rotation, with the
  covariance of its small left perturbation;
- ``dof``: degrees of freedom of the noise variance (0 when given);
- ``identifiability``: of the weighted Jacobian at the solution (its
  condition number is the one reported);
- ``observations``: ``means`` (n, 3), ``means_sd`` (n, 3: the SD of each
  mean, input unit, given or at the residual level), ``norm_before``, ``norm_after`` (n,),
  m/s^2 (``norm_before`` NaN for a raw input unit), ``up`` (n, 3, known
  orientations), ``rotation`` (3 x 3 body-to-fixture, known orientations);
- ``provenance``: ``input_unit``, ``positions``, ``labels``, ``gravity``,
  ``quadratic``, ``counts`` (when given).

References
----------
.. [Tedaldi2014] Tedaldi D., Pretto A., Menegatti E., ICRA 2014.
"""

import numpy as np

from accelcal.io.recordings.options import ACCELERATION_UNITS
from accelcal.methods.triad.common import FAMILY, norm_residuals, spread_text
from accelcal.methods.triad.model import PARAMS, QUADRATIC, TriadCalibration, units_of
from accelcal.results import Estimate, Reduction

GAUGE = ("rot_x", "rot_y", "rot_z")
"""Names of the gauge angles of a known-orientation calibration (rad)."""


def build_reduction(*, method, values, covariance, quadratic, gauge, unit, residuals, dof,
                    given, ident, assumptions, means, gravity, labels, up=None, rotation=None,
                    counts=None, means_sd=None) -> Reduction:
    """Assemble a triad Reduction (keyword arguments as computed by the two routes)."""
    p = 12 if quadratic else 9
    names = PARAMS + (QUADRATIC if quadratic else ())
    units = units_of(unit, quadratic)
    cal = TriadCalibration.from_vector(values[:p], unit)
    before = norm_residuals(means, gravity, input_unit=unit)
    after = norm_residuals(means, gravity, cal)
    est = Estimate(names=names, values=values[:p], covariance=covariance[:p, :p], units=units,
                   method=method, residuals=residuals, dof=dof,
                   provenance={"input_unit": unit, "positions": int(means.shape[0])})
    shared = None
    observations = {"means": means, "means_sd": means_sd, "norm_before": before,
                    "norm_after": after}
    if gauge:
        from scipy.spatial.transform import Rotation

        rotvec = Rotation.from_matrix(rotation.T).as_rotvec()
        shared = Estimate(names=GAUGE, values=rotvec, covariance=covariance[p:, p:],
                          units=dict.fromkeys(GAUGE, "rad"), method=method)
        observations.update(up=up, rotation=rotation)
    provenance = {"input_unit": unit, "positions": int(means.shape[0]), "labels": list(labels),
                  "gravity": float(gravity), "quadratic": bool(quadratic)}
    if counts is not None:
        provenance["counts"] = [float(c) for c in np.asarray(counts, dtype=float)]
    notes = []
    gaps = spread_text(up if up is not None else
                       TriadCalibration.from_vector(values[:p], unit).apply(means))
    if gaps:
        notes.append(f"{gaps}: the design leans on the other positions (condition number "
                     f"{ident.condition_number:.3g}); add positions to spread them")
    rms = float(np.sqrt(np.mean(after**2)))
    notes.append(f"norm residual |a| - g after calibration: RMS {rms:.3g} m/s^2 over "
                 f"{means.shape[0]} positions")
    return Reduction(
        family=FAMILY, method=method, sensors=(est,), shared=shared,
        covariance=covariance if gauge else None, dof=0 if given else int(dof),
        identifiability=ident, assumptions=tuple(assumptions), observations=observations,
        quantities=quantities_of(unit), nominal=nominal_of(unit), provenance=provenance,
        notes=tuple(notes))


def quantities_of(unit: str) -> dict:
    """Engineering quantities of the parameters.

    The angles are misalignments; in an acceleration unit the biases are
    biases (µg) and the scale factors scales (ppm).
    """
    out = dict.fromkeys(PARAMS[6:], "misalignment")
    if unit in ACCELERATION_UNITS:
        out |= dict.fromkeys(PARAMS[:3], "bias") | dict.fromkeys(PARAMS[3:6], "scale")
    return out


def nominal_of(unit: str) -> dict:
    """Nominal scale factors (m/s^2 per input unit) where the input unit is an acceleration.

    The scale factors' engineering value is their ppm deviation from it.
    """
    if unit not in ACCELERATION_UNITS:
        return {}
    return dict.fromkeys(PARAMS[3:6], ACCELERATION_UNITS[unit])
