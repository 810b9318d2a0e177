"""Threshold and resolution by the 50 % rule, with the probability that the decision is wrong.

About a set point the input is stepped by increments of a ladder, each
applied and reversed several times (:mod:`accelcal.rigs.acceptance`). For
the steps i of one increment size, the response is the mean ratio of the
output change to the change the scale factor predicts,

    r = mean_i (m_i - m_(i-1)) / (K1 (a_i - a_(i-1))),

m the dwell means, a the applied inputs. The threshold (at null) or the
resolution (at a non-zero set point) is the smallest increment whose
response reaches 0.5 (DOMAIN section 12). ``r`` is linear in the dwell
means, so its standard deviation ``sigma_r`` follows exactly from their
standard errors (:mod:`~accelcal.methods.acceptance.dwells`).

The decision at an increment is between a sensor that follows the step
(r = 1) and one that sticks (r = 0), the two outcomes of stick-slip
friction; either is misjudged when the noise moves ``r`` across 0.5, with
probability ``p = Phi(-0.5 / sigma_r)``. The threshold is right when every
decision up to it is, so its error probability is ``1 - prod(1 - p_k)``
over the increments up to the threshold. ``sigma_r`` falls as the square
root of the time kept per dwell (white noise), so the dwell that brings the
error probability to ``target`` is ``T (sigma_r z / 0.5)^2`` plus the
settling time, ``z`` the normal quantile of the per-decision level
``1 - (1 - target)^(1/J)`` (Sidak), J decisions.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, threshold and resolution tests.
.. [DOMAIN] accelcal domain notes, section 12 (the 50 % rule).
"""

import numpy as np
from scipy.special import ndtr, ndtri

from accelcal.errors import AccelcalError
from accelcal.methods.acceptance.dwells import dwell_means
from accelcal.results import Assumption, Estimate, Reduction

FAMILY = "acceptance"
RULE = 0.5
"""The fraction of the predicted output change a step must reach."""
MAX_ERROR = 0.05
"""Largest error probability of the threshold decision accepted (else the dwells are too short)."""
TARGET = 1e-3
"""Error probability the recommended dwell reaches."""


def weights(inputs, scale_factor: float) -> list[tuple]:
    """Each increment size's steps as a linear form in the dwell means, sizes ascending.

    Returns ``(size, idx, coef)`` per size (g): ``idx`` the steps (dwell
    ``i`` to ``i + 1``) of that size and ``coef`` the weights that give its
    response ``r = coef . m`` from the dwell means ``m``.
    """
    da = np.diff(inputs)
    size = np.abs(da)
    keys = np.round(size / 1e-12)
    out = []
    for key in np.unique(keys[size > 0]):
        idx = np.flatnonzero(keys == key)
        coef = np.zeros(np.size(inputs))
        for i in idx:  # r = mean of (m[i+1] - m[i]) / (K1 da[i]): a linear form in the means
            w = 1.0 / (scale_factor * da[i] * idx.size)
            coef[i + 1] += w
            coef[i] -= w
        out.append((float(np.median(size[idx])), idx, coef))
    return out


def responses(dwells, scale_factor: float):
    """Increment sizes (g), responses, their SDs and step counts, sizes ascending."""
    da = np.diff(dwells.input)
    dm = np.diff(dwells.mean)
    out = []
    for size, idx, coef in weights(dwells.input, scale_factor):
        ratio = float(np.sum(dm[idx] / (scale_factor * da[idx])) / idx.size)
        sd = float(np.sqrt(np.sum((coef * dwells.se) ** 2)))
        out.append((size, ratio, sd, idx.size))
    if not out:
        raise AccelcalError("the record holds a single input: no step to decide on")
    return out


def reduce_steps(record, *, settle: float = 0.0, max_error: float = MAX_ERROR,
                 target: float = TARGET) -> Reduction:
    """Threshold or resolution of a step record by the 50 % rule (module docs).

    Parameters
    ----------
    record : accelcal.io.formats.acceptance.StepRecord
        A ``threshold`` or ``resolution`` record.
    settle : float
        Seconds dropped at the start of each dwell.
    max_error : float
        Largest error probability of the decision accepted.
    target : float
        Error probability the recommended dwell reaches.

    Returns
    -------
    Reduction
        Family ``acceptance``, method ``acceptance/threshold`` or
        ``acceptance/resolution``; coefficients ``threshold`` or
        ``resolution`` (g; SD that of a value uniform between the increment
        below and it), ``error_probability``, ``recommended_dwell`` (s) and
        ``response_1`` ... (the response to each increment, ascending).

    Raises
    ------
    AccelcalError
        When no increment reaches 50 %, or when the decision is wrong with a
        probability above ``max_error`` (the steps do not dwell long enough
        to decide: the message gives the dwell that would).
    """
    if record.test not in ("threshold", "resolution"):
        raise AccelcalError(f"a {record.test} record is not a threshold or resolution test")
    if not (0 < max_error < 1 and 0 < target < 1):
        raise AccelcalError("max_error and target must be probabilities in (0, 1)")
    dw = dwell_means(record, settle)
    found = responses(dw, record.scale_factor)
    sizes = np.array([f[0] for f in found])
    ratio = np.array([f[1] for f in found])
    sd = np.array([f[2] for f in found])
    passed = np.flatnonzero(ratio >= RULE)
    if not passed.size:
        raise AccelcalError(f"no increment reaches {RULE:.0%} of the predicted output change "
                            f"(the largest, {sizes[-1] * 1e6:.4g} ug, gives "
                            f"{ratio[-1]:.0%}): the {record.test} is above the ladder")
    j = int(passed[0])
    p = ndtr(-RULE / sd) if np.all(sd > 0) else np.zeros(sd.size)
    p_wrong = float(1.0 - np.prod(1.0 - p[: j + 1]))
    kept = float(np.median(dw.kept))
    z = float(ndtri(1.0 - (1.0 - (1.0 - target) ** (1.0 / (j + 1)))))
    dwell = settle + kept * float(np.max((sd[: j + 1] * z / RULE) ** 2))
    if p_wrong > max_error:
        raise AccelcalError(
            f"the steps do not dwell long enough to decide: the {record.test} decision is wrong "
            f"with probability {p_wrong:.2g} > {max_error:g} (noise {dw.sigma:.3g} "
            f"{record.output_unit} per sample, {kept:g} s kept per dwell); dwell at least "
            f"{dwell:.3g} s per step")
    below = sizes[j - 1] if j else 0.0
    names = (record.test, "error_probability", "recommended_dwell",
             *(f"response_{k + 1}" for k in range(sizes.size)))
    values = np.r_[sizes[j], p_wrong, dwell, ratio]
    var = np.r_[(sizes[j] - below) ** 2 / 12.0, 0.0, 0.0, sd**2]
    units = {record.test: "g", "error_probability": "1", "recommended_dwell": "s"} | {
        f"response_{k + 1}": "1" for k in range(sizes.size)}
    method = f"{FAMILY}/{record.test}"
    notes = []
    if np.any(ratio[j:] < RULE):
        notes.append("a larger increment than the decided one falls below 50 %: "
                     f"{', '.join(f'{s * 1e6:.3g} ug' for s in sizes[j:][ratio[j:] < RULE])}")
    est = Estimate(names=names, values=values, covariance=np.diag(var), units=units,
                   method=method, dof=dw.dof, notes=tuple(notes))
    set_point = float(dw.input[0])
    return Reduction(
        family=FAMILY, method=method, sensors=(est,), dof=dw.dof,
        assumptions=(
            Assumption("rule", RULE, "", "the smallest increment whose mean output change "
                       "reaches 50 % of the change the scale factor predicts"),
            Assumption("scale_factor", record.scale_factor, f"{record.output_unit}/g",
                       f"nominal scale factor {record.scale_factor:g} {record.output_unit}/g"),
            Assumption("noise", "white", "", f"white output noise, {dw.sigma:.3g} "
                       f"{record.output_unit} per sample pooled over the dwells ({dw.dof} dof)"),
            Assumption("settle", settle, "s", f"{settle:g} s dropped at the start of each dwell"),
            Assumption("decision", "stick or follow", "",
                       "error probability of a decision between a sensor that follows a step "
                       "and one that sticks: Phi(-0.5 / sigma_r)"),
        ),
        observations={"size": sizes, "response": ratio, "response_std": sd,
                      "error": p, "dwell_input": dw.input, "dwell_mean": dw.mean,
                      "dwell_se": dw.se},
        quantities={record.test: "bias"},
        provenance={"test": record.test, "set_point_g": set_point,
                    "output_unit": record.output_unit, "scale_factor": record.scale_factor,
                    "sizes_g": sizes.tolist(), "steps": [f[3] for f in found],
                    "decided": j, "max_error": max_error, "target": target,
                    "dwell_kept_s": kept},
    )
