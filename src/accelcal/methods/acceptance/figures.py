"""Figures of an acceptance reduction, read from the Reduction's fields only.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, threshold, resolution and hysteresis tests.
"""

import numpy as np


def figures(reduction, **context) -> list:
    """The acceptance figures: ``(stem, title, matplotlib figure, caption)``.

    Parameters
    ----------
    reduction : accelcal.results.Reduction
        An acceptance reduction (:func:`~accelcal.methods.acceptance.reduce`).
    **context
        Not used.

    Returns
    -------
    list of tuple
        ``acceptance-steps`` (the response to each increment with its 95 %
        interval, the 50 % line and the decided increment) for a threshold
        or resolution test; ``acceptance-hysteresis`` (the loop: the output's
        departure from the scale-factor line on each leg) for a cycle;
        ``acceptance-range`` (the nonlinearity against the input, the limit
        and the range, clipped dwells marked) for a range test;
        ``acceptance-turn-on`` (bias and scale factor per turn-on with 95 %
        intervals and the mean +- one repeatability) for a turn-on test;
        ``acceptance-magnetic`` (the output against the field along each
        axis with the fitted slopes) for a magnetic test.
    """
    test = reduction.provenance.get("test")
    if test == "hysteresis":
        return [_loop(reduction)]
    if test == "range":
        return [_range(reduction)]
    if test == "turn-on":
        return [_turn_on(reduction)]
    if test == "magnetic":
        return [_magnetic(reduction)]
    return [_steps(reduction)]


def _steps(reduction):
    from accelcal.plotting import new_figure

    obs, test = reduction.observations, reduction.provenance["test"]
    size = obs["size"] * 1e6
    fig = new_figure(figsize=(6.4, 4.0))
    ax = fig.subplots()
    ax.errorbar(size, obs["response"], yerr=1.96 * obs["response_std"], fmt="o", capsize=3,
                label="response (95 %)")
    ax.axhline(0.5, color="C3", ls="--", label="50 % rule")
    decided = reduction.value(test) * 1e6
    ax.axvline(decided, color="C2", ls=":", label=f"{test} {decided:.3g} µg")
    ax.set_xlabel("input increment (µg)")
    ax.set_ylabel("output change / predicted change (ratio)")
    ax.legend(loc="best")
    caption = (f"Mean output change per predicted change for each increment about "
               f"{reduction.provenance['set_point_g']:.3g} g; the {test} is the smallest "
               "increment reaching 50 % (error probability "
               f"{reduction.value('error_probability'):.2g}).")
    return ("acceptance-steps", f"{test.capitalize()}: step response", fig, caption)


def _loop(reduction):
    from accelcal.plotting import new_figure

    obs, k1 = reduction.observations, reduction.provenance["scale_factor"]
    a, m, d = obs["dwell_input"], obs["dwell_mean"], obs["dwell_direction"]
    dev = m / k1 - a
    dev = (dev - np.mean(dev)) * 1e6
    fig = new_figure(figsize=(6.4, 4.0))
    ax = fig.subplots()
    ax.plot(a, dev, color="0.7", lw=0.8)
    for sign, label, marker in ((1.0, "increasing input", "^"), (-1.0, "decreasing input", "v")):
        sel = d == sign
        ax.errorbar(a[sel], dev[sel], yerr=1.96e6 * obs["dwell_se"][sel] / abs(k1),
                    fmt=marker, capsize=2, label=label)
    ax.set_xlabel("input (g)")
    ax.set_ylabel("output / K1 − input, about its mean (µg)")
    ax.legend(loc="best")
    caption = ("The output's departure from the scale-factor line at each dwell of the cycle "
               "0 → +1 g → 0 → −1 g → 0 (95 % intervals); the hysteresis at a point is the "
               "decreasing leg minus the increasing one.")
    return ("acceptance-hysteresis", "Hysteresis loop", fig, caption)


def _magnetic(reduction):
    from accelcal.methods.acceptance.magnetic import AXIS_LABELS, NAMES
    from accelcal.plotting import new_figure

    obs, k1 = reduction.observations, reduction.provenance["scale_factor"]
    field, mean = obs["dwell_field"], obs["dwell_mean"]
    dev = (mean - obs["intercept"]) / k1 * 1e6
    fig = new_figure(figsize=(6.4, 4.0))
    ax = fig.subplots()
    for j, name in enumerate(NAMES):
        sel = np.all(np.delete(field, j, axis=1) == 0.0, axis=1) & (field[:, j] != 0.0)
        sel |= np.all(field == 0.0, axis=1)
        b = field[sel, j]
        ax.errorbar(b, dev[sel], yerr=1.96e6 * obs["dwell_se"][sel] / abs(k1), fmt="o",
                    color=f"C{j}", capsize=2, label=f"{AXIS_LABELS[name]}: "
                    f"{reduction.value(name) * 1e6:.3g} ± {reduction.std(name) * 1e6:.2g} µg/mT")
        line = np.array([b.min(), b.max()])
        ax.plot(line, reduction.value(name) * 1e6 * line, color=f"C{j}", lw=0.8)
    ax.set_xlabel("field along the axis (mT)")
    ax.set_ylabel("output / K1 − zero-field output (µg)")
    ax.legend(loc="best")
    caption = ("The dwell means (95 % intervals) against the field applied along each axis, "
               "with the least-squares slopes: the magnetic sensitivity per axis.")
    return ("acceptance-magnetic", "Magnetic sensitivity", fig, caption)


def _range(reduction):
    from accelcal.plotting import new_figure

    obs, prov = reduction.observations, reduction.provenance
    a, m = obs["dwell_input"], obs["dwell_mean"]
    ref = np.maximum.accumulate(np.where(a == 0.0, np.arange(a.size), 0))
    k1 = prov["line_scale_factor"]
    on = a != 0.0
    n = (m[on] - m[ref][on] - k1 * a[on]) / (k1 * a[on])
    clip = np.asarray(obs["dwell_clipped"], dtype=bool)[on]
    fig = new_figure(figsize=(6.4, 4.0))
    ax = fig.subplots()
    ax.semilogy(np.abs(a[on])[~clip & (a[on] > 0)], np.abs(n)[~clip & (a[on] > 0)], "^",
                label="positive input")
    ax.semilogy(np.abs(a[on])[~clip & (a[on] < 0)], np.abs(n)[~clip & (a[on] < 0)], "v",
                label="negative input")
    if clip.any():
        ax.semilogy(np.abs(a[on])[clip], np.abs(n)[clip], "x", color="C3", ms=8,
                    label="clipped samples in the dwell")
    ax.axhline(prov["limit"], color="C3", ls="--", label=f"limit {prov['limit']:g}")
    for name, ls in (("range_pos", ":"), ("range_neg", "-.")):
        if name in reduction.estimate.names:
            ax.axvline(reduction.value(name), color="C2", ls=ls,
                       label=f"range {'+' if name == 'range_pos' else '−'}"
                             f"{reduction.value(name):.4g} g")
    ax.set_xlabel("|input| (g)")
    ax.set_ylabel("|nonlinearity| / input (ratio)")
    ax.legend(loc="best", fontsize="small")
    caption = ("The output's departure from the straight line, relative to the input, at "
               "each dwell of the ladder; the input range is where it leaves the limit; "
               "dwells with clipped samples are marked with crosses.")
    return ("acceptance-range", "Input range and saturation", fig, caption)


def _turn_on(reduction):
    from accelcal.plotting import new_figure

    obs = reduction.observations
    j = obs["turn_on"]
    bias = obs["bias"] * 1e6
    scale = (obs["scale"] / obs["scale"].mean() - 1.0) * 1e6
    fig = new_figure(figsize=(6.4, 5.2))
    axes = fig.subplots(2, 1, sharex=True)
    for ax, y, u, label, name in (
            (axes[0], bias, obs["bias_std"] * 1e6, "bias (µg)", "bias_repeatability"),
            (axes[1], scale, obs["scale_std"] / obs["scale"].mean() * 1e6,
             "scale factor − mean (ppm)", "scale_repeatability")):
        ax.errorbar(j, y, yerr=1.96 * u, fmt="o", capsize=3)
        s = reduction.value(name) * 1e6
        ax.axhline(y.mean(), color="C2")
        ax.axhspan(y.mean() - s, y.mean() + s, color="C2", alpha=0.15, label=f"±1 SD {s:.3g}")
        ax.set_ylabel(label)
        ax.legend(loc="best", fontsize="small")
    axes[1].set_xlabel("turn-on (number)")
    caption = ("Bias and scale factor at each turn-on (95 % intervals of each turn-on's "
               "measurement) with the mean and the turn-on-to-turn-on standard deviation.")
    return ("acceptance-turn-on", "Turn-on repeatability", fig, caption)
