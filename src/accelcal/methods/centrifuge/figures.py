"""Figures of a centrifuge reduction, read from the Reduction's fields only.

References
----------
.. [IEEE836] IEEE Std 836-2009, Recommended Practice for Precision Centrifuge
   Testing of Linear Accelerometers (output against level, residuals).
"""

import numpy as np


def figures(reduction, **context) -> list:
    """The centrifuge's figures: ``(stem, title, matplotlib figure, caption)``.

    Parameters
    ----------
    reduction : accelcal.results.Reduction
        A centrifuge reduction (observations ``level``, ``position``,
        ``outputs``, ``fitted``; provenance ``positions``).
    **context
        Not used.

    Returns
    -------
    list of tuple
        ``centrifuge-output`` (output less its linear part K1 (K0 + a_i) per
        position against level, with the fitted model) and
        ``centrifuge-residuals`` (observed minus fitted against level), both
        in µg: the output divided by the fitted scale factor K1.
    """
    return [_output_figure(reduction), _residuals_figure(reduction)]


def _groups(reduction):
    obs = reduction.observations
    names = reduction.provenance.get("positions", [])
    pos = obs["position"].astype(int)
    for k in np.unique(pos):
        sel = pos == k
        order = np.argsort(obs["level"][sel])
        label = names[k] if k < len(names) else f"position {k}"
        yield label, sel, order


def _to_ug(reduction) -> tuple[float, str]:
    """Factor from the output unit to µg (1e6 / K1, K1 in output unit per g) and the unit.

    Without a finite K1 the output stays in its own unit (factor 1).
    """
    k1 = reduction.scale_factor(0)
    if k1 is None or not np.isfinite(k1) or k1 == 0:
        return 1.0, reduction.provenance.get("output_unit", "")
    return 1e6 / k1, "µg"


def _output_figure(reduction):
    from accelcal.plotting import new_figure

    obs = reduction.observations
    to_ug, unit = _to_ug(reduction)
    fig = new_figure(figsize=(6.4, 4.4))
    ax = fig.subplots()
    # the straight line through the fitted values is removed so that the nonlinearity shows
    for label, sel, order in _groups(reduction):
        lev, y, f = obs["level"][sel][order], obs["outputs"][sel][order], obs["fitted"][sel][order]
        base = np.polyval(np.polyfit(lev, f, 1), lev) if lev.size > 1 else f
        line, = ax.plot(lev, (y - base) * to_ug, "o", ms=4, label=label)
        ax.plot(lev, (f - base) * to_ug, "-", lw=1, color=line.get_color())
    ax.set_xlabel("level (g)")
    ax.set_ylabel(f"output less its straight line ({unit})")
    ax.legend(loc="best", fontsize="small")
    caption = ("Centrifuge step means per position against the level (points) with the fitted "
               "model (lines), each less the straight line through the fitted values: what "
               "remains is the nonlinearity (K2, K3, K4, cross-coupling); output divided by "
               "K1.")
    return "centrifuge-output", "Output against level", fig, caption


def _residuals_figure(reduction):
    from accelcal.plotting import new_figure

    obs = reduction.observations
    to_ug, unit = _to_ug(reduction)
    fig = new_figure(figsize=(6.4, 3.6))
    ax = fig.subplots()
    ax.axhline(0.0, color="0.6", lw=0.8)
    for label, sel, order in _groups(reduction):
        r = (obs["outputs"] - obs["fitted"])[sel][order] * to_ug
        ax.plot(obs["level"][sel][order], r, "o-", ms=3, lw=0.8, label=label)
    ax.set_xlabel("level (g)")
    ax.set_ylabel(f"residual ({unit})")
    ax.legend(loc="best", fontsize="small")
    caption = (f"Residuals (observed minus fitted step means, divided by K1) against level, "
               f"per position; {reduction.method}.")
    return "centrifuge-residuals", "Residuals", fig, caption
