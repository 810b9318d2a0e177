"""Figures of a noise fit: the deviation with its bars and fitted terms, and the PSD.

:func:`figures` draws a :class:`~accelcal.results.Reduction` of family
``"noise"`` from its fields only: the overlapping Allan deviation on log-log
axes with the intervals at the stated confidence as error bars, the fitted
curve and one line per fitted term (its own Allan deviation); and, when the
reduction holds a spectrum, the one-sided Welch PSD with each term's level
(:func:`accelcal.methods.noise.psd.levels`), drawn from each frequency bin's
envelope (:func:`accelcal.plotting.decimate.envelope_indices`). matplotlib
is imported only when a figure is drawn.

References
----------
.. [IEEE952] IEEE Std 952-1997, Annex C, Fig. C.2 (the sigma-tau plot with
   the slopes of the terms).
.. [Riley2008] Riley W. J., NIST SP 1065, 2008, sec. 5.3 (error bars).
"""

import numpy as np

from accelcal.plotting import new_figure
from accelcal.plotting.decimate import envelope_indices

STYLES = {"Q": ("tab:purple", "Q  (slope -1)"), "N": ("tab:blue", "N  (slope -1/2)"),
          "B": ("tab:green", "B  (floor 0.664 B)"), "K": ("tab:orange", "K  (slope +1/2)"),
          "R": ("tab:red", "R  (slope +1)")}


def figures(reduction, **context) -> list[tuple]:
    """The deviation plot and (when the reduction has one) the PSD plot.

    Parameters
    ----------
    reduction : accelcal.results.Reduction
        From :func:`accelcal.methods.noise.fit.fit_deviation`.
    **context
        ``truth`` (dict of true coefficients) draws them dashed beside the fit.

    Returns
    -------
    list of (str, str, matplotlib.figure.Figure, str)
        ``noise_adev`` and ``noise_psd``.

    References
    ----------
    .. [1] IEEE952 Annex C; Riley2008 sec. 5.3.
    """
    from accelcal.methods.noise.fit import model_avar

    if reduction.method == "noise/run-to-run":
        return [_runs_figure(reduction)]
    obs = reduction.observations
    est = reduction.estimate
    unit = reduction.provenance.get("unit", "")
    tau, dev = np.asarray(obs["tau"]), np.asarray(obs["dev"])
    lo, hi = np.asarray(obs["dev_low"]), np.asarray(obs["dev_high"])
    fig = new_figure(figsize=(6.0, 4.2))
    ax = fig.add_subplot()
    ax.errorbar(tau, dev, yerr=[dev - lo, hi - dev], fmt="o", ms=3, color="k", capsize=2,
                label="overlapping ADEV")
    grid = np.geomspace(tau[0], tau[-1], 200)
    values = {k: v for k, v in est.as_dict().items() if k in STYLES}
    gof = reduction.assumed("goodness_of_fit")
    label = "fit" if gof is None else (
        f"fit: χ² = {gof[0]:.3g} on {gof[1]} dof"
        + ("" if reduction.assumed("model_fits", True) else " (model does not fit)"))
    ax.plot(grid, np.sqrt(model_avar(values, grid)), "-", color="0.3", lw=1.5, label=label)
    for name, value in values.items():
        if value > 0:
            color, label = STYLES[name]
            ax.plot(grid, np.sqrt(model_avar({name: value}, grid)), "--", color=color, lw=1,
                    label=f"{label} = {value:.3g}")
    truth = context.get("truth")
    if truth:
        ax.plot(grid, np.sqrt(model_avar(truth, grid)), ":", color="tab:gray", lw=1,
                label="simulated truth")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(0.5 * lo.min(), 2 * hi.max())
    ax.set_xlabel("averaging time τ (s)")
    ax.set_ylabel(f"Allan deviation ({unit})")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize="small")
    conf = reduction.assumed("confidence", 0.683)
    out = [("noise_adev", "Allan deviation and IEEE 952 fit", fig,
            (f"Points: overlapping Allan deviation with {conf:.1%} intervals (EDF of the "
            "identified noise); solid: the fitted sum; dashed: each term."))]
    if "psd" in obs:
        out.append(_psd_figure(reduction, values, unit))
    return out


def _psd_figure(reduction, values, unit):
    from accelcal.methods.noise.psd import levels

    obs = reduction.observations
    f, p = np.asarray(obs["psd_frequency"]), np.asarray(obs["psd"])
    keep = f > 0
    f, p = f[keep], p[keep]
    rate = float(reduction.provenance.get("rate_hz", 2 * f.max()))
    lines = levels(values, f, rate)
    # the spectrum and the levels drawn from the same points: every bin's envelope
    drawn = envelope_indices(f, np.column_stack([p, *lines.values()]), log=True)
    fig = new_figure(figsize=(6.0, 4.2))
    ax = fig.add_subplot()
    ax.loglog(f[drawn], p[drawn], color="k", lw=0.6, label="Welch PSD (one-sided)")
    for name, line in lines.items():
        color, label = STYLES[name]
        ax.loglog(f[drawn], line[drawn], "--", color=color, lw=1, label=label.split("(")[0])
    ax.set_ylim(0.1 * p.min(), 10 * p.max())
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel(f"PSD ({unit}²/Hz)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize="small")
    return ("noise_psd", "Power spectral density", fig,
            ("One-sided Welch PSD; dashed: the fitted terms' levels (white 2 N², flicker "
            "B²/(π f), random walk 2 K²/(2π f)²)."))


def deviation_figure(dev):
    """A :class:`~accelcal.signal.allan.deviations.Deviation` on log-log axes with its bars."""
    fig = new_figure(figsize=(6.0, 4.2))
    ax = fig.add_subplot()
    d = np.asarray(dev.dev)
    ax.errorbar(dev.tau, d, yerr=[d - dev.lo, dev.hi - d], fmt="o", ms=3, color="k", capsize=2)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("averaging time τ (s)")
    ax.set_ylabel(f"{dev.kind} ({dev.unit})")
    ax.set_title(f"{dev.kind}, {dev.confidence:.1%} intervals", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    return fig


def _runs_figure(reduction):
    obs = reduction.observations
    unit = reduction.provenance.get("unit", "")
    k = np.arange(1, len(obs["run_bias"]) + 1)
    fig = new_figure(figsize=(6.0, 3.6))
    ax = fig.add_subplot()
    ax.errorbar(k, obs["run_bias"], yerr=obs["run_B"], fmt="o", capsize=3,
                label="run mean ± in-run B")
    ax.axhline(float(np.mean(obs["run_bias"])), color="0.5", lw=0.8)
    ax.set_xlabel("run (turn-on)")
    ax.set_ylabel(f"bias ({unit})")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small")
    return ("noise_runs", "Turn-on to turn-on bias", fig,
            ("Each run's mean with its in-run bias instability B as a bar: the scatter of the "
            "means is the turn-on repeatability."))
