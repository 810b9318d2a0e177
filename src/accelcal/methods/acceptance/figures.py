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
        departure from the scale-factor line on each leg) for a cycle.
    """
    if reduction.provenance.get("test") == "hysteresis":
        return [_loop(reduction)]
    return [_steps(reduction)]


def _steps(reduction):
    import matplotlib.pyplot as plt

    obs, test = reduction.observations, reduction.provenance["test"]
    size = obs["size"] * 1e6
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    ax.errorbar(size, obs["response"], yerr=1.96 * obs["response_std"], fmt="o", capsize=3,
                label="response (95 %)")
    ax.axhline(0.5, color="C3", ls="--", label="50 % rule")
    decided = reduction.value(test) * 1e6
    ax.axvline(decided, color="C2", ls=":", label=f"{test} {decided:.3g} µg")
    ax.set_xlabel("input increment (µg)")
    ax.set_ylabel("output change / predicted change")
    ax.legend(loc="best")
    fig.tight_layout()
    caption = (f"Mean output change per predicted change for each increment about "
               f"{reduction.provenance['set_point_g']:.3g} g; the {test} is the smallest "
               "increment reaching 50 % (error probability "
               f"{reduction.value('error_probability'):.2g}).")
    return ("acceptance-steps", f"{test.capitalize()}: step response", fig, caption)


def _loop(reduction):
    import matplotlib.pyplot as plt

    obs, k1 = reduction.observations, reduction.provenance["scale_factor"]
    a, m, d = obs["dwell_input"], obs["dwell_mean"], obs["dwell_direction"]
    dev = m / k1 - a
    dev = (dev - np.mean(dev)) * 1e6
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    ax.plot(a, dev, color="0.7", lw=0.8)
    for sign, label, marker in ((1.0, "increasing input", "^"), (-1.0, "decreasing input", "v")):
        sel = d == sign
        ax.errorbar(a[sel], dev[sel], yerr=1.96e6 * obs["dwell_se"][sel] / abs(k1),
                    fmt=marker, capsize=2, label=label)
    ax.set_xlabel("input (g)")
    ax.set_ylabel("output / K1 − input, about its mean (µg)")
    ax.legend(loc="best")
    fig.tight_layout()
    caption = ("The output's departure from the scale-factor line at each dwell of the cycle "
               "0 → +1 g → 0 → −1 g → 0 (95 % intervals); the hysteresis at a point is the "
               "decreasing leg minus the increasing one.")
    return ("acceptance-hysteresis", "Hysteresis loop", fig, caption)
