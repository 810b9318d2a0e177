"""Hysteresis: the output at one input approached from decreasing and from increasing input.

The indexing head runs the cycle 0 -> +1 g -> 0 -> -1 g -> 0, one dwell
per input point (:mod:`accelcal.rigs.acceptance`). At every point visited
on both a decreasing and an increasing leg, the hysteresis is

    H = (mean of the decreasing-leg dwell means - mean of the increasing-leg
         dwell means) / K1   (g),

with the standard deviation from the dwell means' standard errors
(:mod:`~accelcal.methods.acceptance.dwells`; the two legs' noise is
independent). The turning points (+1 g, -1 g) are reached from one side
only and have none; the first dwell, reached from no direction, is not used.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, hysteresis test.
.. [DOMAIN] accelcal domain notes, section 12.
"""

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.methods.acceptance.dwells import dwell_means
from accelcal.methods.acceptance.steps import FAMILY
from accelcal.results import Assumption, Estimate, Reduction

METHOD = f"{FAMILY}/hysteresis"
_LEGS = (1.0, -1.0, 1.0)
_WORD = {1.0: "up", -1.0: "down"}


def legs(direction: np.ndarray) -> list[float]:
    """The directions of the successive legs (+1 increasing, -1 decreasing)."""
    moving = direction[direction != 0]
    return [float(d) for k, d in enumerate(moving) if k == 0 or d != moving[k - 1]]


def _leg_mean(dw, sel) -> tuple[float, float]:
    """Mean of the selected dwell means and its variance."""
    return float(dw.mean[sel].mean()), float(np.sum(dw.se[sel] ** 2) / sel.sum() ** 2)


def reduce_hysteresis(record, *, settle: float = 0.0) -> Reduction:
    """Hysteresis at each input point of a cycle (module docs).

    Returns
    -------
    Reduction
        Family ``acceptance``, method ``acceptance/hysteresis``;
        coefficients ``hysteresis_1`` ... (g), one per input point in
        ascending input (the points in ``provenance["points_g"]``).

    Raises
    ------
    AccelcalError
        For a record that is not a hysteresis test, or a cycle with missing
        legs (it must go up to a positive input, down to a negative one and
        up again).
    """
    if record.test != "hysteresis":
        raise AccelcalError(f"a {record.test} record is not a hysteresis test")
    dw = dwell_means(record, settle)
    direction = dw.direction
    found = legs(direction)
    if found != list(_LEGS) or not (dw.input.max() > 0 > dw.input.min()):
        raise AccelcalError(
            "a hysteresis cycle goes 0 -> +1 g -> 0 -> -1 g -> 0 (legs up, down, up, through "
            f"positive and negative inputs); this record's legs are "
            f"{', '.join(_WORD[d] for d in found) or 'none'} from {dw.input.min():.3g} to "
            f"{dw.input.max():.3g} g: a leg is missing")
    k1 = record.scale_factor
    points, values, var = [], [], []
    for a in np.unique(dw.input):
        at = dw.input == a
        up, down = at & (direction > 0), at & (direction < 0)
        if not (up.any() and down.any()):
            continue
        (m_d, v_d), (m_u, v_u) = _leg_mean(dw, down), _leg_mean(dw, up)
        points.append(float(a) + 0.0)
        values.append((m_d - m_u) / k1)
        var.append((v_d + v_u) / k1**2)
    if not points:
        raise AccelcalError("no input point of the cycle is visited on both a decreasing and "
                            "an increasing leg: give the same angles on every leg")
    names = tuple(f"hysteresis_{k + 1}" for k in range(len(points)))
    est = Estimate(names=names, values=np.asarray(values), covariance=np.diag(var),
                   units=dict.fromkeys(names, "g"), method=METHOD, dof=dw.dof)
    return Reduction(
        family=FAMILY, method=METHOD, sensors=(est,), dof=dw.dof,
        assumptions=(
            Assumption("scale_factor", k1, f"{record.output_unit}/g",
                       f"nominal scale factor {k1:g} {record.output_unit}/g"),
            Assumption("noise", "white", "", f"white output noise, {dw.sigma:.3g} "
                       f"{record.output_unit} per sample pooled over the dwells ({dw.dof} dof)"),
            Assumption("settle", settle, "s", f"{settle:g} s dropped at the start of each dwell"),
        ),
        observations={"dwell_input": dw.input, "dwell_mean": dw.mean, "dwell_se": dw.se,
                      "dwell_direction": direction, "points": np.asarray(points)},
        quantities=dict.fromkeys(names, "bias"),
        provenance={"test": "hysteresis", "output_unit": record.output_unit,
                    "scale_factor": k1, "points_g": points},
    )
