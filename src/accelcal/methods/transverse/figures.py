"""Figures of the shaker test: polar plots (GuanTang Figs. 3-4) and a reduction's figures.

:func:`figures` draws what a :class:`~accelcal.results.Reduction` of
:func:`~accelcal.methods.transverse.identification.identify` shows (the
polar plot of the fundamental s_T / s_I in mg/g, and the weighted
residuals), reading its fields only; :func:`polar_figure` and
:func:`figure4` draw sweeps (``accelcal transverse sweep --plot``).
matplotlib is imported only inside these functions (through
:func:`accelcal.plotting.new_figure`).

References
----------
.. [GuanTang] Guan W., Tang L., Shaker test method of transverse sensitivity
   of inertial accelerometers, Fig. 3 (vibration accelerometer, figure of
   eight) and Fig. 4 (inertial accelerometer at 1, 5, 20 and 50 g).
.. [ISO16063-31] ISO 16063-31:2009, polar presentation of the transverse
   sensitivity.
"""

import numpy as np

from accelcal.methods.transverse.estimators import sweep
from accelcal.methods.transverse.theory import GUANTANG_FIG4, figure4_linear
from accelcal.plotting import new_figure, save_figure


def figures(reduction, **context) -> list:
    """The figures of a shaker identification: polar plot and weighted residuals.

    Parameters
    ----------
    reduction : accelcal.results.Reduction
        A :func:`~accelcal.methods.transverse.identification.identify` result.
    **context
        Not used (the reduction holds everything drawn).

    Returns
    -------
    list of (str, str, matplotlib.figure.Figure, str)
        ``(stem, title, figure, caption)``: ``transverse_polar`` (the
        fundamental s_T / s_I against the direction angle, mg/g) and
        ``transverse_residuals``.

    References
    ----------
    .. [1] GuanTang eqs. (13), (16); ISO16063-31 (polar presentation).
    """
    obs = reduction.observations
    amplitude = reduction.assumed("amplitude")
    s_I = float(obs["s_I"])
    fig = new_figure(figsize=(4.2, 4.0))
    _panel(fig.add_subplot(projection="polar"), np.deg2rad(obs["angle_deg"]),
           1e3 * np.asarray(obs["sT"]) / abs(s_I), "tab:blue",
           f"A_v = {amplitude:g} g\nfundamental, s_T in mg/g")
    caption = (f"Fundamental s_T / s_I against the direction angle at {amplitude:g} g "
               "(ISO 16063-31 presentation), in mg/g.")
    polar = ("transverse_polar", "Transverse sensitivity", fig, caption)
    resid = np.asarray(reduction.estimate.residuals)
    fig = new_figure(figsize=(5.6, 3.4))
    ax = fig.add_subplot()
    ax.stem(np.arange(resid.size), resid, basefmt="0.5")
    ax.axhspan(-2, 2, color="0.9", zorder=0)
    ax.set_xlabel("observation (phasor component per angle)")
    ax.set_ylabel("weighted residual (1 = 1 σ)")
    ax.grid(alpha=0.3)
    caption = ("Phasor components minus fitted model, each divided by its sine-fit "
               "standard uncertainty; grey band ±2.")
    residuals = ("transverse_residuals", "Residuals", fig, caption)
    return [polar, residuals]


def _closed(theta, values):
    order = np.argsort(np.mod(theta, 2 * np.pi))
    th = np.mod(theta, 2 * np.pi)[order]
    v = np.asarray(values)[order]
    return np.append(th, th[0] + 2 * np.pi), np.append(v, v[0])


def _panel(ax, theta, values, color: str, title: str) -> None:
    """One polar panel: ``values`` against ``theta`` (rad), closed around the turn."""
    th, v = _closed(theta, values)
    ax.plot(th, v, color=color, lw=1.5)
    ax.set_ylim(0, max(float(np.max(v)) * 1.08, 1e-300))
    ax.tick_params(labelsize=7)
    ax.set_title(title, fontsize=9)


def polar_figure(sweeps, *, linear=None, title: str | None = None, scale: float = 1.0,
                 unit: str | None = None):
    """Polar plots of s_T(theta), one panel per amplitude, the linear model beside them.

    Parameters
    ----------
    sweeps : list of accelcal.methods.transverse.TransverseSweep
        One per amplitude (noise-free or measured).
    linear : TransverseSweep, optional
        The linear (vibration accelerometer) model's figure of eight, drawn in
        its own panel.
    title : str, optional
        Figure title.
    scale : float
        Factor applied to s_T for display (e.g. 1000 to show mV/g from V/g).
    unit : str, optional
        Unit label of the displayed s_T (default: the sweeps' unit per g).

    Returns
    -------
    matplotlib.figure.Figure

    References
    ----------
    .. [1] GuanTang, Figs. 3-4; ISO 16063-31 polar presentation.
    """
    panels = list(sweeps) + ([linear] if linear is not None else [])
    n = len(panels) + (1 if len(sweeps) > 1 else 0)
    ncols = min(3, n)
    nrows = int(np.ceil(n / ncols))
    fig = new_figure(figsize=(4.2 * ncols, 4.0 * nrows + 0.4))
    label = unit or f"{panels[0].unit}/g"
    for k, sw in enumerate(panels):
        is_linear = linear is not None and sw is linear
        head = ("linear model (figure of eight)" if is_linear
                else f"A_v = {sw.amplitude:g} g")
        _panel(fig.add_subplot(nrows, ncols, k + 1, projection="polar"), sw.theta,
               np.asarray(sw.sT) * scale, "tab:red" if is_linear else "tab:blue",
               f"{head}\n{sw.estimator}, s_T in {label}")
    if len(sweeps) > 1:
        ax = fig.add_subplot(nrows, ncols, len(panels) + 1, projection="polar")
        for sw in sweeps:
            th, v = _closed(sw.theta, np.asarray(sw.sT) * scale)
            ax.plot(th, v, lw=1.2, label=f"{sw.amplitude:g} g")
        ax.tick_params(labelsize=7)
        ax.legend(fontsize=8, loc="lower left", bbox_to_anchor=(0.95, 0.0))
        ax.set_title(f"all amplitudes\n{sweeps[0].estimator}, s_T in {label}", fontsize=9)
    if title:
        fig.suptitle(title, fontsize=11)
    return fig


def save_polar(sweeps, directory, *, linear=None, stem: str = "transverse_polar",
               title: str | None = None, scale: float = 1.0, unit: str | None = None):
    """Draw :func:`polar_figure` and write ``stem.png`` and ``stem.svg`` in ``directory``."""
    fig = polar_figure(sweeps, linear=linear, title=title, scale=scale, unit=unit)
    return save_figure(fig, directory, stem)


def figure4(directory, *, stem: str = "guantang_fig4"):
    """Reproduce GuanTang Fig. 4 with the plausible parameter set of Table 1.

    Peak estimator (the paper's eqs. (21)-(22)), amplitudes 1, 5, 20, 50 g,
    angles every 5 deg, no gravity (the paper's idealised set-up), s_T in
    mV/g; the linear model's figure of eight (Fig. 3) beside them. The
    parameters are :data:`accelcal.methods.transverse.theory.GUANTANG_FIG4` (the
    paper's Table 1 was lost; they satisfy s_I = 1000.055 mV/g, eq. (25)).

    Returns
    -------
    list of pathlib.Path
        The PNG and SVG written.
    """
    theta = np.deg2rad(np.arange(0.0, 360.0, 5.0))
    sweeps = sweep(GUANTANG_FIG4, (1.0, 5.0, 20.0, 50.0), theta, "peak")
    lin = sweep(figure4_linear(), (1.0,), theta, "peak")[0]
    return save_polar(
        sweeps, directory, linear=lin, stem=stem, unit="mV/g",
        title="Transverse sensitivity (peak definition), GuanTang Fig. 4 parameters",
    )
