"""Figures of the vibration rectification error: Guan2021 Figs. 2, 3 and 4.

One curve per overload b against the vibration amplitude A: the asymmetry
VRE dU2 (Fig. 2), the even-order VRE dU1 (Fig. 3) and the relative error
r = dU2 / (dU1 + dU2) (Fig. 4). matplotlib is imported only when a figure
is drawn.

References
----------
.. [Guan2021] Guan W., Metrology & Measurement Technology 41(3), 2021,
   Figs. 2-4, eqs. (9), (21), (25).
"""

from pathlib import Path

from accelcal.plotting import new_figure, save_figure

FIGURES = {
    "vre_du2": ("dU2", 1e6, "asymmetry VRE ΔU2 (µg)",
                "VRE from asymmetry (Guan2021 Fig. 2, eq. 21)"),
    "vre_du1": ("dU1", 1e6, "even-order VRE ΔU1 (µg)",
                "VRE from K2, K3 (Guan2021 Fig. 3, eq. 9)"),
    "vre_r": ("r", 100.0, "relative error r = ΔU2/ΔU (%)",
              "Relative error from asymmetry (Guan2021 Fig. 4, eq. 25)"),
}
"""File stem -> (quantity, scale, axis label, title)."""


def plot_vre_table(table, directory) -> list[Path]:
    """Draw the three figures of a :class:`accelcal.methods.vre.VreTable`.

    Parameters
    ----------
    table : accelcal.methods.vre.VreTable
        dU1, dU2, r over overloads (rows) and amplitudes (columns).
    directory : path-like
        Where ``vre_du2``, ``vre_du1`` and ``vre_r`` are written, each as
        PNG and SVG.

    Returns
    -------
    list of pathlib.Path
        The files written.

    References
    ----------
    .. [1] Guan2021, Figs. 2-4.
    """
    data = {"dU1": table.du1, "dU2": table.du2, "r": table.r}
    paths: list[Path] = []
    markers = "osD^v<>ph*"
    for stem, (key, scale, label, title) in FIGURES.items():
        fig = new_figure()
        ax = fig.add_subplot()
        for k in range(table.overload.shape[0]):
            ax.plot(table.amplitude[k], data[key][k] * scale, marker=markers[k % len(markers)],
                    label=f"b = {table.overload[k, 0]:g} g")
        ax.axhline(0.0, color="0.6", linewidth=0.8, zorder=0)
        ax.set_xlabel("vibration amplitude A (g)")
        ax.set_ylabel(label)
        ax.set_title(title, fontsize=10)
        ax.grid(True, alpha=0.3)
        ax.legend(title="overload")
        paths += save_figure(fig, directory, stem)
    return paths
