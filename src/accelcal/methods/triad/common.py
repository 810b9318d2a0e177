"""What both calibration routes share: input checks, weights, coverage of directions, results.

References
----------
.. [Tedaldi2014] Tedaldi D., Pretto A., Menegatti E., ICRA 2014, sec. III-IV.
.. [GUM] JCGM 100:2008, G.3 (degrees of freedom of a variance from residuals).
"""

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.methods.triad.model import (
    PARAMS,
    QUADRATIC,
    TriadCalibration,
    input_units,
    nominal_factor,
)
from accelcal.results import Assumption
from accelcal.validation import shown

FAMILY = "triad"
"""The family of every triad reduction (key of :data:`accelcal.methods.REGISTRY`)."""

COVERED_COS = 0.5
"""A direction counts as visited when some position's gravity-opposing direction is
within 60 deg of it (cosine above 0.5)."""

MAX_POSITIONS = 1_000_000
"""Most positions accepted (a static-position calibration has tens)."""


def check_means(means, name: str = "means") -> np.ndarray:
    """Interval means ``(n, 3)``, finite, at least one row and at most :data:`MAX_POSITIONS`."""
    try:
        arr = np.array(means, dtype=float)
    except (TypeError, ValueError):
        raise AccelcalError("must be an array of numbers of shape (n, 3)",
                            parameter=name) from None
    if arr.ndim != 2 or arr.shape[1] != 3 or arr.shape[0] == 0:
        raise AccelcalError(f"must have shape (n, 3) with n >= 1 positions, got {arr.shape}",
                            parameter=name)
    if arr.shape[0] > MAX_POSITIONS:
        raise AccelcalError(f"{arr.shape[0]} positions is more than the {MAX_POSITIONS} a "
                            "static calibration can have; give interval means", parameter=name)
    bad = np.flatnonzero(~np.isfinite(arr).all(axis=1))
    if bad.size:
        raise AccelcalError(f"row {int(bad[0])} is not finite", parameter=name)
    return arr


def check_unit(unit) -> str:
    """An input unit of :func:`accelcal.methods.triad.model.input_units`."""
    if unit not in input_units():
        raise AccelcalError(f"{shown(unit)} is not a known unit; use one of "
                            + ", ".join(input_units()), parameter="input_unit")
    return unit


def check_labels(labels, n: int) -> list[str]:
    """One label per position (default ``P1``..``Pn``)."""
    if labels is None:
        return [f"P{k + 1}" for k in range(n)]
    out = [str(x) for x in labels]
    if len(out) != n:
        raise AccelcalError(f"{len(out)} labels for {n} positions", parameter="labels")
    return out


def relative_sd(n: int, counts) -> np.ndarray:
    """Relative SD of each interval mean, ``sqrt(mean(c) / c_k)`` (ones without counts).

    An interval mean of ``c`` samples of white noise has variance ``sigma^2 / c``.
    """
    if counts is None:
        return np.ones(n)
    try:
        c = np.array(counts, dtype=float)
    except (TypeError, ValueError):
        raise AccelcalError("must be sample counts (numbers)", parameter="counts") from None
    if c.shape != (n,) or not np.isfinite(c).all() or (c <= 0).any():
        raise AccelcalError(f"must be {n} positive sample counts, one per position",
                            parameter="counts")
    return np.sqrt(c.mean() / c)


def check_noise(noise_sd, n: int) -> np.ndarray | None:
    """SD of each interval mean per axis ``(n, 3)``, input unit (None when not given)."""
    if noise_sd is None:
        return None
    try:
        sd = np.array(noise_sd, dtype=float)
    except (TypeError, ValueError):
        raise AccelcalError("must be a number or an array of SDs", parameter="noise_sd") from None
    try:
        sd = np.broadcast_to(sd if sd.ndim != 1 or sd.size == 3 else sd[:, None], (n, 3))
    except ValueError:
        raise AccelcalError(f"must be one SD, one per axis (3), one per position ({n}) or "
                            f"({n}, 3); got shape {np.shape(noise_sd)}",
                            parameter="noise_sd") from None
    if not np.isfinite(sd).all() or (sd <= 0).any():
        raise AccelcalError("must be finite and positive (SD of an interval mean, input unit)",
                            parameter="noise_sd")
    return np.array(sd)


def missing_directions(directions) -> list[str]:
    """The body directions (``x up`` ... ``z down``) no position comes within 60 deg of.

    ``directions`` are the gravity-opposing unit vectors of the positions in
    the sensor (or fixture) frame: ``x up`` means the x axis pointing up,
    the x output reading about +g.
    """
    d = np.asarray(directions, dtype=float)
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    out = []
    for i, axis in enumerate("xyz"):
        for sign, word in ((1.0, "up"), (-1.0, "down")):
            if not (sign * d[:, i] > COVERED_COS).any():
                out.append(f"{axis} {word}")
    return out


def spread_text(directions) -> str:
    """``no position with x down, z up`` (or '' when every axis direction is visited)."""
    miss = missing_directions(directions)
    return f"no position with {', '.join(miss)}" if miss else ""


def norm_residuals(means, gravity, calibration: TriadCalibration | None = None, *,
                   input_unit: str = "m/s^2") -> np.ndarray:
    """``|a_k| - g`` per position, m/s^2.

    With ``calibration``: ``a_k`` its specific force. Without: the nominal
    conversion of ``input_unit`` (1 for m/s^2, g_n = 9.80665 for g, ...);
    for a raw unit (counts, V, mV) there is no specific force before
    calibration and the residuals are NaN.

    References
    ----------
    .. [1] DOMAIN section 6 (the residual to report, before and after).
    """
    u = check_means(means)
    if calibration is not None:
        a = calibration.apply(u)
    else:
        factor = nominal_factor(check_unit(input_unit))
        if factor is None:
            return np.full(u.shape[0], np.nan)
        a = u * factor
    return np.linalg.norm(a, axis=1) - float(gravity)


def calibration_of(reduction) -> TriadCalibration:
    """The :class:`TriadCalibration` a triad reduction estimated.

    Known orientations carry the fixture rotation (observation
    ``rotation``: body to fixture) as the calibration's gauge rotation.
    """
    est = reduction.estimate
    names = PARAMS + (QUADRATIC if QUADRATIC[0] in est.names else ())
    values = [est[n] for n in names]
    rot = reduction.observations.get("rotation")
    return TriadCalibration.from_vector(values, reduction.provenance["input_unit"], rot)


def common_assumptions(gravity: float, noise: np.ndarray | None, counts, quadratic: bool,
                       unit: str) -> list[Assumption]:
    """Assumptions both routes state: gravity, noise, weights, quadratic terms."""
    out = [Assumption("gravity", float(gravity), "m/s^2",
                      f"local gravity {gravity:.7g} m/s^2 (given, or WGS84 normal gravity)")]
    if noise is None:
        out.append(Assumption("noise", "residuals", "",
                              "noise of the interval means estimated from the residuals"))
    else:
        out.append(Assumption("noise", "given", "", "noise SD of the interval means given"))
        out.append(Assumption("noise_sd", tuple(float(x) for x in noise.mean(axis=0)), unit,
                              "given SD of an interval mean per axis (mean over positions)"))
    out.append(Assumption("weights", "counts" if counts is not None else "equal", "",
                          "interval means weighted by their sample counts" if counts is not None
                          else "interval means weighted equally"))
    out.append(Assumption("quadratic", bool(quadratic), "",
                          "per-axis quadratic terms q fitted" if quadratic
                          else "linear model: quadratic terms taken as zero"))
    return out


def few_dof(dof: int, given: bool) -> list[Assumption]:
    """The ``few_dof`` assumption when the noise comes from fewer than FEW_DOF dof."""
    from accelcal.calibration import FEW_DOF

    if given or dof >= FEW_DOF:
        return []
    return [Assumption("few_dof", int(dof), "", (
        f"noise estimated from only {dof} degree(s) of freedom (fewer than {FEW_DOF}): "
        "intervals need Student's t; add positions or give the noise SD"))]
