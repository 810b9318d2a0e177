"""The Bode figure of a frequency response: magnitude and phase, their bands, the model.

:func:`figures` draws a Reduction of family ``"response"`` from its fields
only: the measured points (a stepped-sine comparison's coefficients, or the
points a model fit kept in its observations) with bands of two standard
uncertainties of magnitude and phase (:meth:`accelcal.results.Estimate.polar`),
and the fitted transfer function (a model fit's own, or one passed as
``fit=``), evaluated by :func:`scipy.signal.freqs`. matplotlib is imported
only when a figure is drawn.

References
----------
.. [ISO16063-21] ISO 16063-21:2003 (magnitude and phase against frequency).
"""

import numpy as np

from accelcal.plotting import new_figure


def _points(reduction):
    """Frequencies, magnitudes, phases (deg) and their SDs of the measured points."""
    from accelcal.polar import polar

    obs = reduction.observations
    f = np.asarray(obs["frequency_hz"], dtype=float)
    if "response" in obs:  # a model fit keeps the points it fitted
        pol = polar(np.asarray(obs["response"]), np.asarray(obs["covariance"]))
        unit = reduction.provenance.get("unit", "")
    else:
        pol = reduction.estimate.polar()
        unit = next(iter(reduction.estimate.units.values()))
    return f, pol.magnitude, pol.magnitude_std, np.rad2deg(pol.phase), \
        np.rad2deg(pol.phase_std), unit


def figures(reduction, **context) -> list[tuple]:
    """The Bode figure.

    Parameters
    ----------
    reduction : accelcal.results.Reduction
        A stepped-sine comparison (``response/comparison``) or a model fit
        (``response/model-fit``).
    **context
        ``fit``: a model-fit Reduction to draw over a comparison's points.

    Returns
    -------
    list of (str, str, matplotlib.figure.Figure, str)
        ``response_bode``.
    """
    from accelcal.methods.response.model import METHOD as FIT
    from accelcal.methods.response.model import evaluate

    f, mag, u_mag, phase, u_phase, unit = _points(reduction)
    fit = reduction if reduction.method == FIT else context.get("fit")
    fig = new_figure(figsize=(6.4, 5.6))
    ax_m, ax_p = fig.subplots(2, 1, sharex=True)
    ax_m.fill_between(f, mag - 2 * u_mag, mag + 2 * u_mag, color="tab:blue", alpha=0.25,
                      lw=0, label="±2 u")
    ax_m.plot(f, mag, "o", ms=3, color="k", label="measured")
    ax_p.fill_between(f, phase - 2 * u_phase, phase + 2 * u_phase, color="tab:blue",
                      alpha=0.25, lw=0)
    ax_p.plot(f, phase, "o", ms=3, color="k")
    if fit is not None:
        grid = np.geomspace(f.min(), f.max(), 400)
        est = fit.estimate
        model = evaluate(np.asarray(est.values, float), est.names, grid)
        draw_model(ax_m, ax_p, grid, model, f"fit: {fit.assumed('model')}")
    finish_axes(ax_m, ax_p, unit)
    return [("response_bode", "Frequency response (Bode)", fig,
             ("Points: the DUT's complex sensitivity at each step; bands: two standard "
              "uncertainties of magnitude and phase; line: the fitted transfer function."))]


def draw_model(ax_m, ax_p, grid, response, label: str) -> None:
    """The model's curve, ``response`` (complex) at ``grid`` (Hz), on both axes."""
    ax_m.plot(grid, np.abs(response), "-", color="tab:red", lw=1, label=label)
    ax_p.plot(grid, np.rad2deg(np.unwrap(np.angle(response))), "-", color="tab:red", lw=1)


def finish_axes(ax_m, ax_p, unit: str) -> None:
    """A Bode figure's axes: log frequency, labels with units, grids, the legend."""
    ax_m.set_xscale("log")
    ax_m.set_ylabel(f"magnitude ({unit})")
    ax_p.set_ylabel("phase (deg)")
    ax_p.set_xlabel("frequency (Hz)")
    for ax in (ax_m, ax_p):
        ax.grid(True, which="both", alpha=0.3)
    ax_m.legend(fontsize="small")
