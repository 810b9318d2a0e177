"""Figures of a tumble reduction, read from the Reduction's fields only.

Each figure is computed here once and used both by
:meth:`accelcal.results.Reduction.plot` and by the report.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, annex on multipoint tumble analysis.
"""

import numpy as np


def figures(reduction, **context) -> list:
    """The tumble's figures: ``(stem, title, matplotlib figure, caption)``.

    Parameters
    ----------
    reduction : accelcal.results.Reduction
        A tumble reduction (observations ``angles``, ``outputs``, ``fitted``
        and, for uniform positions, ``harmonics``, ``fourier_A``,
        ``fourier_B``).
    **context
        Not used (the tumble needs nothing beyond the reduction).

    Returns
    -------
    list of tuple
    """
    out = [_residuals_figure(reduction)]
    if "fourier_A" in reduction.observations:
        out.append(_harmonics_figure(reduction))
    return out


def _residuals_figure(reduction):
    from accelcal.plotting import new_figure

    obs = reduction.observations
    est = reduction.estimate
    unit = reduction.provenance.get("output_unit", "")
    deg = np.degrees(np.mod(obs["angles"], 2 * np.pi))
    order = np.argsort(deg)
    fig = new_figure(figsize=(6.4, 4.4))
    top, bottom = fig.subplots(2, 1, sharex=True, height_ratios=(2, 1))
    top.plot(deg[order], obs["outputs"][order], "o", ms=4, label="output")
    top.plot(deg[order], obs["fitted"][order], "-", lw=1, label="fitted model")
    top.set_ylabel(f"output ({unit})")
    top.legend(loc="best", fontsize="small")
    bottom.axhline(0.0, color="0.6", lw=0.8)
    bottom.plot(deg[order], np.asarray(est.residuals)[order], "o-", ms=3, lw=0.8)
    bottom.set_xlabel("position θ (deg)")
    bottom.set_ylabel(f"residual ({unit})")
    axis = reduction.assumed("rotation_axis", "")
    caption = (f"Outputs at the {deg.size} positions of the tumble about {axis} with the "
               f"fitted model, and the residuals (observed minus fitted); "
               f"{reduction.assumed('route', '')} route.")
    return "tumble-residuals", "Outputs and residuals", fig, caption


def _harmonics_figure(reduction):
    from accelcal.plotting import new_figure

    obs = reduction.observations
    k = obs["harmonics"].astype(int)
    unit = reduction.provenance.get("output_unit", "")
    fig = new_figure(figsize=(6.4, 3.4))
    ax = fig.subplots()
    width = 0.38
    a, b = np.abs(obs["fourier_A"]), np.abs(obs["fourier_B"])
    ax.bar(k - width / 2, np.where(a > 0, a, np.nan), width, label="|A_k|")
    ax.bar(k + width / 2, np.where(b > 0, b, np.nan), width, label="|B_k|")
    ax.set_yscale("log")
    ax.set_xticks(k)
    ax.set_xlabel("harmonic k")
    ax.set_ylabel(f"amplitude ({unit})")
    ax.legend(loc="best", fontsize="small")
    caption = ("Discrete Fourier amplitudes of the outputs (uniform positions): A_0 the mean, "
               "A_k and B_k the cos and sin amplitudes the IEEE 1293 relations map to the "
               "coefficients (B at the Nyquist harmonic is 0 by definition).")
    return "tumble-harmonics", "Fourier amplitudes", fig, caption
