"""Figures for indexing-head reductions: residuals and separated head error versus position.

matplotlib is imported inside the functions only (through
:func:`accelcal.plotting.new_figure`).

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014.
"""

import numpy as np

from accelcal.plotting import new_figure, save_figure
from accelcal.units import ARCSEC, DEG


def plot_reduction(result, directory, *, sensor_names=None, positions=None, truth=None):
    """Write ``dividing_head_residuals`` and, when estimated, ``dividing_head_angle_error``.

    Parameters
    ----------
    result : accelcal.methods.dividing_head.HeadReduction
        The reduction.
    directory : path-like
        Output directory (created if needed).
    sensor_names : sequence of str, optional
        Legend labels.
    positions : array_like, optional
        Nominal head angles, rad (x axis); default 0 .. n-1.
    truth : array_like, optional
        The true head error, rad (simulated records), drawn for comparison
        after removing its mean and, unless the method was given it, its
        first harmonic (the gauge no method can see).

    Returns
    -------
    list of pathlib.Path
        The files written.
    """
    resid = result.residuals()
    k, n = resid.shape
    x = np.arange(n) if positions is None else np.asarray(positions) / DEG
    names = sensor_names or [f"U{i + 1}" for i in range(k)]
    fig = new_figure()
    ax = fig.add_subplot()
    for i in range(k):
        ax.plot(x, resid[i] * 1e6, marker="o", ms=3, label=names[i])
    ax.set_xlabel("nominal head angle (deg)" if positions is not None else "position")
    ax.set_ylabel("residual (µ" + result.sensors[0].units.get("K_F", "V") + ")")
    ax.set_title(f"Residuals, method {result.method}")
    ax.legend(fontsize="small")
    paths = save_figure(fig, directory, "dividing_head_residuals")
    if result.angle_error is None:
        return paths
    est = result.angle_error.values
    sd = result.angle_error.std
    fig = new_figure()
    ax = fig.add_subplot()
    ax.errorbar(x, est / ARCSEC, yerr=sd / ARCSEC, marker="o", ms=3, capsize=2,
                label=f"estimated ({result.method})")
    if truth is not None:
        t = np.asarray(truth, dtype=float)
        alpha = x * DEG if positions is not None else 2 * np.pi * np.arange(n) / n
        given = any(note.startswith("first harmonic given") for note in result.notes)
        cols = [np.ones(n)] if given else [np.ones(n), np.cos(alpha), np.sin(alpha)]
        c = np.stack(cols, axis=-1)
        t = t - c @ np.linalg.lstsq(c, t, rcond=None)[0]
        ax.plot(x, t / ARCSEC, "k--", label="true (gauge removed)")
    ax.set_xlabel("nominal head angle (deg)" if positions is not None else "position")
    ax.set_ylabel("head angle error (arcsec)")
    ax.set_title("Separated head angular position error")
    ax.legend(fontsize="small")
    return paths + save_figure(fig, directory, "dividing_head_angle_error")
