"""Figures of the vibration rectification error.

:func:`figures` draws an identification (a :class:`~accelcal.results.Reduction`
of family ``"vre"``) from its fields only: the measured VRE with the fitted
model against the amplitude, one curve per overload, and the residuals
normalised by each point's uncertainty. :func:`table_figures` draws the
paper's Figs. 2-4 from a :class:`~accelcal.methods.vre.VreTable`: one curve
per overload b against the vibration amplitude A of the asymmetry VRE dU2
(Fig. 2), the even-order VRE dU1 (Fig. 3) and the relative error
r = dU2 / (dU1 + dU2) (Fig. 4). matplotlib is imported only when a figure
is drawn (:func:`accelcal.plotting.new_figure`).

References
----------
.. [Guan2021] Guan W., Metrology & Measurement Technology 41(3), 2021,
   Figs. 2-4, eqs. (9), (21), (24), (25).
"""

import numpy as np

from accelcal.plotting import new_figure

TABLE_FIGURES = {
    "vre_du2": ("dU2", 1e6, "asymmetry VRE ΔU2 (µg)",
                "VRE from asymmetry (Guan2021 Fig. 2, eq. 21)"),
    "vre_du1": ("dU1", 1e6, "even-order VRE ΔU1 (µg)",
                "VRE from K2, K3 (Guan2021 Fig. 3, eq. 9)"),
    "vre_r": ("r", 100.0, "relative error r = ΔU2/ΔU (%)",
              "Relative error from asymmetry (Guan2021 Fig. 4, eq. 25)"),
}
"""File stem -> (quantity, scale, axis label, title) of :func:`table_figures`."""

_MARKERS = "osD^v<>ph*"


def table_figures(table) -> list[tuple]:
    """The paper's three figures of a :class:`~accelcal.methods.vre.VreTable`.

    Parameters
    ----------
    table : accelcal.methods.vre.VreTable
        dU1, dU2, r over overloads (rows) and amplitudes (columns).

    Returns
    -------
    list of (str, str, matplotlib.figure.Figure, str)
        ``(stem, title, figure, caption)`` for ``vre_du2``, ``vre_du1`` and
        ``vre_r`` (:func:`accelcal.plotting.save_figure` writes them).

    References
    ----------
    .. [1] Guan2021, Figs. 2-4.
    """
    data = {"dU1": table.du1, "dU2": table.du2, "r": table.r}
    out = []
    for stem, (key, scale, label, title) in TABLE_FIGURES.items():
        fig = new_figure()
        ax = fig.add_subplot()
        for k in range(table.overload.shape[0]):
            ax.plot(table.amplitude[k], data[key][k] * scale, marker=_MARKERS[k % len(_MARKERS)],
                    label=f"b = {table.overload[k, 0]:g} g")
        ax.axhline(0.0, color="0.6", linewidth=0.8, zorder=0)
        ax.set_xlabel("vibration amplitude A (g)")
        ax.set_ylabel(label)
        ax.set_title(title, fontsize=10)
        ax.grid(True, alpha=0.3)
        ax.legend(title="overload")
        out.append((stem, title, fig, "One curve per overload b against the amplitude A."))
    return out


def figures(reduction, **context) -> list[tuple]:
    """Measured and fitted VRE, and the normalised residuals, of an identification.

    Parameters
    ----------
    reduction : accelcal.results.Reduction
        From :func:`accelcal.methods.vre.identify`: reads its observations
        (``overload``, ``amplitude``, ``vre``, ``uncertainty`` when given) and
        residuals.
    **context
        Not used (the identification holds everything drawn).

    Returns
    -------
    list of (str, str, matplotlib.figure.Figure, str)
        ``vre_fit`` and ``vre_residuals``.

    References
    ----------
    .. [1] Guan2021, eqs. (9), (21), (24) (the model fitted).
    """
    obs = reduction.observations
    vre = np.asarray(obs["vre"])
    u = np.asarray(obs.get("uncertainty", np.zeros_like(vre)))
    fitted = vre - np.asarray(reduction.estimate.residuals)
    b = np.asarray(obs["overload"])[:, 0]
    amp = np.asarray(obs["amplitude"])
    fig = new_figure(figsize=(5.6, 3.4))
    ax = fig.add_subplot()
    for level in np.unique(b):
        sel = b == level
        order = np.argsort(amp[sel])
        line = ax.errorbar(amp[sel][order], vre[sel][order] * 1e6, yerr=2 * u[sel][order] * 1e6,
                           fmt="o", ms=4, capsize=2, label=f"b = {level:g} g")
        ax.plot(amp[sel][order], fitted[sel][order] * 1e6, "-", lw=1,
                color=line[0].get_color())
    ax.set_xlabel("vibration amplitude A (g)")
    ax.set_ylabel("VRE (µg)")
    ax.legend(fontsize="small")
    ax.grid(alpha=0.3)
    measured = ("vre_fit", "Measured and fitted VRE", fig,
                "Points: measured VRE with k = 2 error bars; lines: the fitted model.")
    fig = new_figure(figsize=(5.6, 3.4))
    ax = fig.add_subplot()
    if (u > 0).all():
        ax.stem(np.arange(vre.size), (vre - fitted) / u, basefmt="0.5")
        ax.axhspan(-2, 2, color="0.9", zorder=0)
        ax.set_ylabel("normalised residual (1 = 1 σ)")
        caption = ("Measured minus fitted VRE divided by each point's standard uncertainty; "
                   "grey band ±2.")
    else:
        ax.stem(np.arange(vre.size), (vre - fitted) * 1e6, basefmt="0.5")
        ax.set_ylabel("residual (µg)")
        caption = "Measured minus fitted VRE (the points carry no uncertainty)."
    ax.set_xlabel("test point (number)")
    ax.grid(alpha=0.3)
    return [measured, ("vre_residuals", "Residuals", fig, caption)]
