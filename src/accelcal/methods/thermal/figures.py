"""Figures of a thermal reduction, read from the Reduction's fields only.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, thermal sensitivity plots (coefficient
   against temperature).
"""

import numpy as np

_SCALE = {"K0": (1e6, "µg"), "K2": (1e6, "µg/g²"), "Ko": (1e6, "µrad"), "Kp": (1e6, "µrad")}


def figures(reduction, **context) -> list:
    """The thermal figures: ``(stem, title, matplotlib figure, caption)``.

    Parameters
    ----------
    reduction : accelcal.results.Reduction
        A thermal reduction (observations and coefficients of
        :func:`~accelcal.methods.thermal.reduce_thermal`).
    **context
        Not used.

    Returns
    -------
    list of tuple
        ``thermal-coefficients`` (each term against temperature, the fitted
        polynomial and its 95 % band), ``thermal-hysteresis`` (the bias
        against temperature in test order), ``thermal-residuals`` (residual
        after compensation) and, with a warm-up, ``thermal-warmup``.
    """
    out = [_coefficients(reduction), _hysteresis(reduction), _residuals(reduction)]
    if "warmup_t" in reduction.observations:
        out.append(_warmup(reduction))
    return out


def _bases(reduction) -> list[str]:
    return list(reduction.provenance.get("orders", {}))


def _scale(reduction, base: str) -> tuple[float, str]:
    """Factor and unit to plot a term's change (K1 in ppm of K1 at T0)."""
    if base == "K1":
        return 1e6 / reduction.estimate["K1"], "ppm"
    return _SCALE[base]


def _curve(reduction, base: str, dt):
    """The polynomial of ``base`` at ``dt`` (K1 in output unit per g) and its SD."""
    est = reduction.estimate
    order = reduction.provenance["orders"][base]
    names = [base, *(f"{base}_T{k}" for k in range(1, order + 1))]
    idx = [est.names.index(n) for n in names]
    c, cov = est.values[idx], est.covariance[np.ix_(idx, idx)]
    g = np.vander(dt, order + 1, increasing=True)
    if base == "K1":  # K1 (1 + sum K1_Tk dT^k): gradient by the chain rule
        g = np.column_stack([g @ np.r_[1.0, c[1:]], c[0] * g[:, 1:]])
        return g[:, 0] * c[0], np.sqrt(np.einsum("ij,jk,ik->i", g, cov, g))
    return g @ c, np.sqrt(np.einsum("ij,jk,ik->i", g, cov, g))


def _coefficients(reduction):
    from accelcal.calibration import coverage_factor
    from accelcal.plotting import new_figure

    obs, bases = reduction.observations, _bases(reduction)
    t0 = reduction.provenance["reference_degC"]
    temp, dirs = obs["temperature"], obs["direction"]
    grid = np.linspace(temp.min(), temp.max(), 200)
    k = coverage_factor(reduction.dof)
    fig = new_figure(figsize=(6.4, 2.2 * len(bases) + 0.6))
    axes = np.atleast_1d(fig.subplots(len(bases), 1, sharex=True))
    for ax, b in zip(axes, bases, strict=True):
        f, unit = _scale(reduction, b)
        ref = reduction.estimate[b]
        y, s = _curve(reduction, b, grid - t0)
        ax.fill_between(grid, (y - k * s - ref) * f, (y + k * s - ref) * f, color="C0",
                        alpha=0.25, lw=0, label=f"fit ± {k:.3g} SD")
        ax.plot(grid, (y - ref) * f, "C0-", lw=1.2)
        for d, mark, label in ((1, "^", "heating"), (-1, "v", "cooling"), (0, "o", "turn-on")):
            m = dirs == d
            if m.any():
                ax.errorbar(temp[m], (obs[b][m] - ref) * f, yerr=k * obs[f"{b}_std"][m] * abs(f),
                            fmt=mark, ms=5, capsize=2, label=label)
        ax.set_ylabel(f"{b} − {b}(T0) ({unit})")
        ax.grid(True, lw=0.4, color="0.85")
    axes[0].legend(loc="best", fontsize="small")
    axes[-1].set_xlabel("sensor temperature (°C)")
    caption = (f"Each term per plateau (tumble estimate ± {k:.3g} SD) against the sensor "
               f"temperature, relative to its value at T0 = {t0:g} °C, with the fitted "
               "polynomial and its band (K1 in ppm).")
    return "thermal-coefficients", "Coefficients against temperature", fig, caption


def _hysteresis(reduction):
    from accelcal.plotting import new_figure

    obs = reduction.observations
    f, unit = _scale(reduction, "K0")
    ref = reduction.estimate["K0"]
    fig = new_figure(figsize=(6.4, 4.0))
    ax = fig.subplots()
    y = (obs["K0"] - ref) * f
    ax.plot(obs["temperature"], y, "-", color="0.6", lw=0.8, zorder=1)
    for i in range(y.size - 1):
        ax.annotate("", xy=(obs["temperature"][i + 1], y[i + 1]),
                    xytext=(obs["temperature"][i], y[i]),
                    arrowprops={"arrowstyle": "->", "color": "0.5", "lw": 0.8})
    for d, color, label in ((1, "C3", "heating"), (-1, "C0", "cooling"), (0, "C2", "turn-on")):
        m = obs["direction"] == d
        if m.any():
            ax.plot(obs["temperature"][m], y[m], "o", color=color, label=label, zorder=2)
    ax.set_xlabel("sensor temperature (°C)")
    ax.set_ylabel(f"K0 − K0(T0) ({unit})")
    ax.legend(loc="best", fontsize="small")
    est = reduction.estimate
    hyst = ("" if "K0_hyst" not in est.names else
            f" Hysteresis (heating − cooling) {est['K0_hyst'] * f:.3g} ± "
            f"{est.std_of('K0_hyst') * f:.2g} {unit}.")
    caption = f"Bias per plateau in test order (arrows): the hysteresis loop.{hyst}"
    return "thermal-hysteresis", "Hysteresis loop", fig, caption


def _residuals(reduction):
    from accelcal.plotting import new_figure

    obs, bases = reduction.observations, _bases(reduction)
    fig = new_figure(figsize=(6.4, 1.8 * len(bases) + 0.6))
    axes = np.atleast_1d(fig.subplots(len(bases), 1, sharex=True))
    for ax, b in zip(axes, bases, strict=True):
        f, unit = _scale(reduction, b)
        ax.axhline(0.0, color="0.6", lw=0.8)
        ax.errorbar(obs["temperature"], obs[f"{b}_residual"] * f, yerr=obs[f"{b}_std"] * abs(f),
                    fmt="o", ms=4, capsize=2)
        ax.set_ylabel(f"{b} ({unit})")
        ax.grid(True, lw=0.4, color="0.85")
    axes[-1].set_xlabel("sensor temperature (°C)")
    caption = ("Residual after compensation per plateau: estimate minus the compensation "
               "polynomial (hysteresis not compensated), ± 1 SD of the plateau estimate.")
    return "thermal-residuals", "Residual after compensation", fig, caption


def _warmup(reduction):
    from accelcal.plotting import new_figure

    obs, est = reduction.observations, reduction.estimate
    fig = new_figure(figsize=(6.4, 3.6))
    ax = fig.subplots()
    t = obs["warmup_t"]
    # in µg from the settled output c: (y - c) / K1, c = fitted - a exp(-t/tau), a = amplitude K1
    k1 = reduction.scale_factor(0)
    c = float(np.mean(obs["warmup_fitted"]
                      - est["warmup_amplitude"] * k1 * np.exp(-t / est["warmup_tau"])))
    ax.plot(t / 60.0, (obs["warmup_output"] - c) / k1 * 1e6, ".", ms=3, label="readings")
    ax.plot(t / 60.0, (obs["warmup_fitted"] - c) / k1 * 1e6, "-", lw=1.2,
            label="a exp(−t/τ)")
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel("time from turn-on (min)")
    ax.set_ylabel("output − settled output (µg)")
    ax.legend(loc="best", fontsize="small")
    caption = (f"Warm-up at a fixed position, output less its settled value and divided by "
               f"K1: τ = {est['warmup_tau']:.4g} ± "
               f"{est.std_of('warmup_tau'):.2g} s, bias change "
               f"{est['warmup_amplitude'] * 1e6:.3g} µg, settled bias "
               f"{est['warmup_K0'] * 1e6:.4g} µg.")
    return "thermal-warmup", "Warm-up", fig, caption
