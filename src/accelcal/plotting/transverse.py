"""Polar plots of transverse sensitivity (GuanTang Figs. 3-4, ISO 16063-31 style).

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

from accelcal.plotting import new_figure, save_figure


def _closed(theta, values):
    order = np.argsort(np.mod(theta, 2 * np.pi))
    th = np.mod(theta, 2 * np.pi)[order]
    v = np.asarray(values)[order]
    return np.append(th, th[0] + 2 * np.pi), np.append(v, v[0])


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
        ax = fig.add_subplot(nrows, ncols, k + 1, projection="polar")
        th, v = _closed(sw.theta, np.asarray(sw.sT) * scale)
        is_linear = linear is not None and sw is linear
        ax.plot(th, v, color="tab:red" if is_linear else "tab:blue", lw=1.5)
        ax.set_ylim(0, max(float(np.max(v)) * 1.08, 1e-300))
        ax.tick_params(labelsize=7)
        head = ("linear model (figure of eight)" if is_linear
                else f"A_v = {sw.amplitude:g} g")
        ax.set_title(f"{head}\n{sw.estimator}, s_T in {label}", fontsize=9)
    if len(sweeps) > 1:
        ax = fig.add_subplot(nrows, ncols, len(panels) + 1, projection="polar")
        for sw in sweeps:
            th, v = _closed(sw.theta, np.asarray(sw.sT) * scale)
            ax.plot(th, v, lw=1.2, label=f"{sw.amplitude:g} g")
        ax.tick_params(labelsize=7)
        ax.legend(fontsize=7, loc="lower left", bbox_to_anchor=(0.95, 0.0))
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
    parameters are :data:`accelcal.methods.transverse.GUANTANG_FIG4` (the
    paper's Table 1 was lost; they satisfy s_I = 1000.055 mV/g, eq. (25)).

    Returns
    -------
    list of pathlib.Path
        The PNG and SVG written.
    """
    from accelcal.methods.transverse import GUANTANG_FIG4, figure4_linear, sweep

    theta = np.deg2rad(np.arange(0.0, 360.0, 5.0))
    sweeps = sweep(GUANTANG_FIG4, (1.0, 5.0, 20.0, 50.0), theta, "peak")
    lin = sweep(figure4_linear(), (1.0,), theta, "peak")[0]
    return save_polar(
        sweeps, directory, linear=lin, stem=stem, unit="mV/g",
        title="Transverse sensitivity (peak definition), GuanTang Fig. 4 parameters",
    )
