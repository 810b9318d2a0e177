"""Figures of an indexing-head reduction: residuals and the separated head error.

Computed once here, from the :class:`~accelcal.results.Reduction`'s fields
only (``observations["positions"]``, residuals, ``shared``, the
``first_harmonic`` assumption), and used both by ``Reduction.plot`` (the
command line's ``--plot``) and by reports. matplotlib is imported lazily
through :func:`accelcal.plotting.new_figure`.

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014.
"""

import numpy as np

from accelcal.units import ARCSEC, DEG


def figures(reduction, *, truth=None) -> list:
    """``(stem, title, figure, caption)`` of the residuals and, when separated, the head error.

    Parameters
    ----------
    reduction : accelcal.results.Reduction
        An indexing-head reduction.
    truth : array_like, optional
        The true head error at each position, rad (simulated records),
        drawn beside the separated one after removing the gauge no method
        can see: its mean and, unless the first harmonic was given or
        estimated, its first harmonic.

    Returns
    -------
    list of tuple
        ``dividing_head_residuals`` and, for ``four`` and ``joint``,
        ``dividing_head_angle_error``.
    """
    out = [residual_figure(reduction)]
    if head_error(reduction) is not None:
        out.append(angle_error_figure(reduction, truth))
    return out


def head_error(reduction):
    """The separated head error and its standard uncertainties, rad, or None.

    From ``shared``, or (beyond
    :data:`~accelcal.methods.dividing_head.sizes.MAX_DENSE_POSITIONS`
    positions) from ``observations['d_alpha']`` and ``['d_alpha_std']``.
    """
    if reduction.shared is not None:
        return reduction.shared.values, reduction.shared.std
    if "d_alpha" in reduction.observations:
        return reduction.observations["d_alpha"], reduction.observations["d_alpha_std"]
    return None


def _figure():
    from accelcal.plotting import new_figure

    return new_figure(figsize=(5.6, 3.4))


def residual_figure(reduction) -> tuple:
    """Residuals (output minus fitted model) of every sensor against the head angle."""
    x = np.asarray(reduction.observations["positions"]) / DEG
    resid = reduction.residuals()
    unit = reduction.sensors[0].units.get("K_F", "V")
    # each sensor's residual divided by its own scale factor, in µg (its output unit otherwise)
    k1 = [reduction.scale_factor(i) for i in range(reduction.n_sensors)]
    inertial = all(k is not None and np.isfinite(k) and k != 0 for k in k1)
    if inertial:
        resid = resid / np.asarray(k1, dtype=float)[:, None]
        unit = "g"
    fig = _figure()
    ax = fig.add_subplot()
    for i, name in enumerate(reduction.sensor_names):
        ax.plot(x, resid[i] * 1e6, marker="o", ms=3, lw=1, label=name)
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.set_xlabel("nominal head angle (deg)")
    ax.set_ylabel(f"residual (µ{unit})")
    ax.legend(fontsize="small", ncols=min(4, reduction.n_sensors))
    ax.grid(alpha=0.3)
    rms = np.sqrt(np.mean(resid**2, axis=-1)) * 1e6
    caption = (f"Output minus fitted model per sensor{', divided by its K_I' if inertial else ''}"
               f"; RMS {', '.join(f'{r:.2g}' for r in rms)} µ{unit}.")
    return "dividing_head_residuals", "Residuals", fig, caption


def angle_error_figure(reduction, truth=None) -> tuple:
    """The separated head angle error with 1 sigma error bars (and the truth, gauge removed)."""
    rad = np.asarray(reduction.observations["positions"])
    x = rad / DEG
    values, std = head_error(reduction)
    est, sd = np.asarray(values) / ARCSEC, np.asarray(std) / ARCSEC
    fig = _figure()
    ax = fig.add_subplot()
    ax.errorbar(x, est, yerr=sd, marker="o", ms=3, capsize=2, lw=1, label="separated")
    caption = "Head angular position error separated from the outputs (error bars 1 σ)"
    if truth is not None:
        t = np.asarray(truth, dtype=float)
        cols = [np.ones_like(rad)]
        if reduction.assumed("first_harmonic") == "zero":
            cols += [np.cos(rad), np.sin(rad)]
        c = np.stack(cols, axis=-1)
        t = t - c @ np.linalg.lstsq(c, t, rcond=None)[0]
        ax.plot(x, t / ARCSEC, "k--", lw=1, label="simulated (gauge removed)")
        caption += "; dashed: the simulated error without the gauge no method can see"
    ax.set_xlabel("nominal head angle (deg)")
    ax.set_ylabel("head angle error (arcsec)")
    ax.legend(fontsize="small")
    ax.grid(alpha=0.3)
    return "dividing_head_angle_error", "Head angle error", fig, caption + "."
