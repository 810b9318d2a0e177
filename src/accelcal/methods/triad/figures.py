"""Figures of a triad calibration, read from the Reduction's fields only.

References
----------
.. [Tedaldi2014] Tedaldi D., Pretto A., Menegatti E., ICRA 2014 (norm
   residuals before and after calibration).
"""

import numpy as np


def figures(reduction, **context) -> list:
    """The triad's figures: ``(stem, title, matplotlib figure, caption)``.

    Parameters
    ----------
    reduction : accelcal.results.Reduction
        A triad calibration (observations ``means``, ``norm_before``,
        ``norm_after`` and, for known orientations, ``up``).
    **context
        ``intervals`` (:class:`accelcal.signal.static.StaticIntervals`), with
        ``values`` (the recording's samples, (n, 3)) and optionally ``time``
        (s): the recording with its static intervals shaded, first.

    Returns
    -------
    list of tuple
        ``triad-intervals`` (with ``intervals``), ``triad-norm-residuals``
        (|a| - g per position, before and after) and ``triad-positions``
        (the positions' gravity directions).
    """
    out = []
    if context.get("intervals") is not None:
        from accelcal.signal.static import figure

        found = context["intervals"]
        out.append(("triad-intervals", "Static intervals",
                    figure(found, context["values"], time=context.get("time")),
                    (f"The recording's norm with the {len(found)} static intervals detected "
                    "(shaded) and the moving-variance statistic against its threshold.")))
    return [*out, _residuals_figure(reduction), _positions_figure(reduction)]


def _labels(reduction, n: int) -> list[str]:
    labels = reduction.provenance.get("labels") or []
    return list(labels) if len(labels) == n else [f"P{k + 1}" for k in range(n)]


def _residuals_figure(reduction):
    from accelcal.plotting import new_figure

    obs = reduction.observations
    before, after = obs["norm_before"], obs["norm_after"]
    n = after.size
    k = np.arange(n)
    fig = new_figure(figsize=(max(6.4, 0.25 * n + 2.0), 4.0))
    ax = fig.subplots()
    ax.axhline(0.0, color="0.6", lw=0.8)
    if np.isfinite(before).any():
        ax.plot(k, before * 1e3, "o", ms=4, label="before (nominal unit conversion)")
    ax.plot(k, after * 1e3, "s", ms=4, label="after calibration")
    ax.set_xticks(k)
    ax.set_xticklabels(_labels(reduction, n), rotation=90 if n > 12 else 0, fontsize="small")
    ax.set_xlabel("position")
    ax.set_ylabel("|a| − g (mm/s²)")
    ax.legend(loc="best", fontsize="small")
    g = reduction.provenance.get("gravity", float("nan"))
    raw = "" if np.isfinite(before).any() else (
        " The input unit is raw, so there is no residual before calibration.")
    caption = (f"Norm residual |a| − g per static position (g = {g:.7g} m/s²), before and after "
               f"calibration; RMS after {np.sqrt(np.mean(after**2)) * 1e3:.3g} mm/s².{raw}")
    return "triad-norm-residuals", "Norm residuals per position", fig, caption


def _directions(reduction) -> tuple[np.ndarray, str]:
    obs = reduction.observations
    if "up" in obs:
        return np.asarray(obs["up"]), "given up directions (fixture frame)"
    from accelcal.methods.triad.common import calibration_of

    a = calibration_of(reduction).apply(obs["means"])
    return a / np.linalg.norm(a, axis=1)[:, None], "calibrated directions (body frame)"


def _positions_figure(reduction):
    from accelcal.plotting import new_figure

    d, what = _directions(reduction)
    az = np.degrees(np.arctan2(d[:, 1], d[:, 0]))
    el = np.degrees(np.arcsin(np.clip(d[:, 2], -1.0, 1.0)))
    fig = new_figure(figsize=(6.4, 3.8))
    ax = fig.subplots()
    ax.plot(az, el, "o", ms=5)
    for x, y, label in zip(az, el, _labels(reduction, len(d)), strict=True):
        ax.annotate(label, (x, y), textcoords="offset points", xytext=(3, 3), fontsize="small")
    ax.set_xlim(-185, 185)
    ax.set_ylim(-95, 95)
    ax.set_xticks(np.arange(-180, 181, 90))
    ax.set_yticks(np.arange(-90, 91, 45))
    ax.set_xlabel("azimuth of up, atan2(y, x) (deg)")
    ax.set_ylabel("elevation of up above x-y (deg)")
    ax.grid(True, lw=0.4, color="0.85")
    caption = (f"Gravity-opposing direction of each of the {len(d)} positions, {what}: "
               "azimuth in the x-y plane and elevation towards z. A calibration needs every "
               "axis both up and down (elevation ±90 deg for z; azimuth 0, ±180 deg for x; "
               "±90 deg for y).")
    return "triad-positions", "Position directions", fig, caption
