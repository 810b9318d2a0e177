"""Report sections for each test method, built from structured results.

Each function takes a reduction's result and its calibration record(s) and
returns :class:`~accelcal.report.Section` objects: coefficients with
uncertainties (the record), identifiability notes, residual plots and the
method's own figures (inline SVG through :func:`accelcal.report.figure_svg`),
and short errata notes where the published method was corrected (the full
entries are in docs/errata.md under each paper's heading).

Figures are drawn with matplotlib, imported lazily by
:func:`accelcal.plotting.new_figure`.

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014.
.. [Guan2021] Guan W., Metrology & Measurement Technology 41(3), 2021.
.. [GuanTang] Guan W., Tang L., Shaker test method of transverse sensitivity
   of inertial accelerometers.
.. [ISO16063-31] ISO 16063-31:2009 (transverse sensitivity, shaker method).
"""

import numpy as np

from accelcal.report import Figure, Section, figure_svg, format_std, format_unit, format_value
from accelcal.units import ARCSEC, DEG

ERRATA_DONG2014 = (
    ("Eqs. (15), (18), (21) and (25)-(28) carry misprinted terms (K'_IO for K'_II, missing "
    "eta and K'_F3 terms, mixed angle frames); the corrected expansions are used."),
    ("The mean head error and the mounting misalignment cannot be separated from K_O by the "
    "accelerometers alone: K_O is reported as K_O* = K_O + K_I (eta + d0)."),
    ("The first harmonic of the head error is not negligible: unless it is measured it "
    "biases K_F, K_IO and K_II by about K_I |d1|; the notes say how it was treated."),
    "Each sensor is normalised by its own fitted scale factor, not the nominal one.",
)
ERRATA_GUAN2021 = (
    ("\"Without loss of generality, b > 0\" does not hold: the asymmetry VRE is odd in b "
    "for K0' and even for K1'; the closed form used holds for either sign of the overload."),
    ("Ko and Kp are in g/g (the paper's symbol list says V/g); the fourth-order term K4 is "
    "kept."),
)
ERRATA_GUANTANG = (
    ("The lost equations (1), (3), (6)-(12), (14)-(24) are reconstructed and checked "
    "against time-domain simulation."),
    ("The drive law (4) cannot remove gravity on a vertical shaker; the static 1 g along "
    "the vibration axis is modelled (fundamental k_i |B + 2 G C|)."),
    ("The peak definition (21)-(22) of s_T depends on the amplitude; the coefficients are "
    "fitted to the w and 2w phasors instead, and the polar plot shows the fundamental "
    "(ISO 16063-31 practice)."),
    "alpha = atan2(s_p, s_o) replaces arctan(s_p / s_o), which loses the quadrant.",
)
ERRATA_SEE = "Details, checks and the code that implements each correction: docs/errata.md"


def _errata(entries, paper: str) -> tuple[str, ...]:
    return (*entries, f"{ERRATA_SEE} ({paper}).")


def _small_figure(**kwargs):
    from accelcal.plotting import new_figure

    return new_figure(**{"figsize": (5.6, 3.4), **kwargs})


def _svg(fig, title: str, caption: str) -> Figure:
    return Figure(title, figure_svg(fig), caption)


def pm(value: float, std: float) -> str:
    """``value ± std`` with the digits the uncertainty supports."""
    return f"{format_value(value, std)} ± {format_std(std)}"


# ------------------------------------------------------------------ indexing head
def head_sections(result, records, *, sensor_names, positions, truth=None) -> list[Section]:
    """Sections of an indexing-head calibration: an overview, then one per sensor.

    Parameters
    ----------
    result : accelcal.methods.dividing_head.HeadReduction
        The reduction.
    records : sequence of CalibrationRecord
        One per sensor (:func:`accelcal.calibration.head_records`).
    sensor_names : sequence of str
        Column names of the sensors.
    positions : array_like
        Nominal head angles, rad.
    truth : array_like, optional
        Simulated head error, rad, drawn beside the separated one.

    Returns
    -------
    list of Section

    References
    ----------
    .. [1] Dong2014, eq. (5) and Tables 1-2 (coefficients and their SDs).
    """
    alpha = np.asarray(positions, dtype=float) / DEG
    unit = result.sensors[0].units.get("K_F", "V")
    rows = []
    first = records[0]
    for j, coef in enumerate(first.names):
        label = "K_O*" if coef == "K_O" else coef
        row = {"coefficient": label, "unit": format_unit(first.units.get(coef, ""))}
        for name, rec in zip(sensor_names, records, strict=True):
            row[f"{rec.serial} ({name})"] = pm(rec.estimates[j], rec.std[j])
        rows.append(row)
    figures = [_head_residual_figure(result, sensor_names, alpha, unit)]
    if result.angle_error is not None:
        figures.append(_head_error_figure(result, alpha, truth))
    notes = list(result.notes)
    if result.null_space_dim is not None:
        notes.append(
            f"the unconstrained joint design has a {result.null_space_dim}-dimensional null "
            "space: the mean head error (indistinguishable from a common K_O offset) and its "
            "first harmonic (indistinguishable from K_F, K_IO, K_II offsets); the notes above "
            "say how that gauge is fixed"
        )
    overview = Section(
        title=f"Indexing head: {len(records)} sensors, method {result.method}",
        summary=(
            f"{len(records)} accelerometers on an indexing head at {alpha.size} positions, "
            f"reduced together (method {result.method}). Estimates ± standard uncertainty "
            "(1 σ); the head's angular position error is separated from the sensors' "
            "coefficients. One section per sensor follows with expanded uncertainties and "
            "correlations."
        ),
        rows=rows, notes=tuple(notes), errata=_errata(ERRATA_DONG2014, "Dong2014"),
        figures=tuple(figures),
    )
    per_sensor = [
        Section(title=f"{rec.serial}: indexing head ({name})", record=rec,
                summary=f"Sensor column {name}; model U = K_F + K_I a_i + K_O a_o + "
                        "K_IO a_i a_o + K_II a_i² (Dong2014 eq. (5)).")
        for name, rec in zip(sensor_names, records, strict=True)
    ]
    return [overview, *per_sensor]


def _head_residual_figure(result, names, alpha, unit) -> Figure:
    resid = result.residuals()
    fig = _small_figure()
    ax = fig.add_subplot()
    for i, name in enumerate(names):
        ax.plot(alpha, resid[i] * 1e6, marker="o", ms=3, lw=1, label=name)
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.set_xlabel("nominal head angle (deg)")
    ax.set_ylabel(f"residual (µ{unit})")
    ax.legend(fontsize="small", ncols=min(4, len(names)))
    ax.grid(alpha=0.3)
    rms = np.sqrt(np.mean(resid**2, axis=-1)) * 1e6
    return _svg(fig, "Residuals",
                f"Output minus fitted model per sensor; RMS {', '.join(f'{r:.2g}' for r in rms)}"
                f" µ{unit}.")


def _head_error_figure(result, alpha, truth) -> Figure:
    est = result.angle_error.values / ARCSEC
    sd = result.angle_error.std / ARCSEC
    fig = _small_figure()
    ax = fig.add_subplot()
    ax.errorbar(alpha, est, yerr=sd, marker="o", ms=3, capsize=2, lw=1, label="separated")
    caption = "Head angular position error separated from the outputs (error bars 1 σ)"
    if truth is not None:
        t = np.asarray(truth, dtype=float)
        rad = alpha * DEG
        given = any(note.startswith("first harmonic given") for note in result.notes)
        cols = [np.ones_like(rad)] if given else [np.ones_like(rad), np.cos(rad), np.sin(rad)]
        c = np.stack(cols, axis=-1)
        t = t - c @ np.linalg.lstsq(c, t, rcond=None)[0]
        ax.plot(alpha, t / ARCSEC, "k--", lw=1, label="simulated (gauge removed)")
        caption += "; dashed: the simulated error without the gauge no method can see"
    ax.set_xlabel("nominal head angle (deg)")
    ax.set_ylabel("head angle error (arcsec)")
    ax.legend(fontsize="small")
    ax.grid(alpha=0.3)
    return _svg(fig, "Head angle error", caption + ".")


# ------------------------------------------------------------------------- VRE
def vre_section(fit, record, measurement) -> Section:
    """Section of a VRE identification (vibrafuge).

    Parameters
    ----------
    fit : accelcal.methods.vre.VreFit
    record : CalibrationRecord
        :func:`accelcal.calibration.vre_record` of ``fit``.
    measurement : accelcal.methods.vre_records.VreMeasurement
        The measured VRE (overloads, amplitudes, values, uncertainties) the
        fit used, in the same order.

    References
    ----------
    .. [1] Guan2021, eqs. (9), (21), (24).
    """
    vre = np.asarray(measurement.vre)
    u = np.asarray(measurement.uncertainty)
    fitted = vre - np.asarray(fit.estimate.residuals)
    b = np.asarray(measurement.overload)[:, 0]
    amp = np.asarray(measurement.amplitude)
    fig = _small_figure()
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
    measured = _svg(fig, "Measured and fitted VRE",
                    "Points: measured VRE with k = 2 error bars; lines: the fitted model.")
    fig = _small_figure()
    ax = fig.add_subplot()
    z = np.divide(vre - fitted, u, out=np.zeros_like(vre), where=u > 0)
    ax.stem(np.arange(vre.size), z, basefmt="0.5")
    ax.axhspan(-2, 2, color="0.9", zorder=0)
    ax.set_xlabel("test point")
    ax.set_ylabel("normalised residual (1 = 1 σ)")
    ax.grid(alpha=0.3)
    residuals = _svg(fig, "Residuals",
                     "Measured minus fitted VRE divided by each point's standard uncertainty; "
                     "grey band ±2.")
    notes = [(f"{vre.size} test points (overload, amplitude); the VRE of each is the "
             "whole-period mean vibrating minus static, divided by the scale factor")]
    return Section(
        title=f"{record.serial}: vibration rectification (vibrafuge)", record=record,
        summary=("Vibration rectification error under overload b along IA and sinusoidal "
                 "vibration of amplitude A; coefficients by weighted least squares "
                 "(Guan2021, asymmetry included)."),
        notes=tuple(notes), errata=_errata(ERRATA_GUAN2021, "Guan2021"),
        figures=(measured, residuals),
    )


# ------------------------------------------------------------------ transverse
def transverse_section(estimate, record, records, *, s_I: float | None = None) -> Section:
    """Section of a transverse (cross-axis) identification on a shaker.

    Parameters
    ----------
    estimate : accelcal.results.Estimate
        :func:`accelcal.methods.transverse.identify` result.
    record : CalibrationRecord
        :func:`accelcal.calibration.transverse_record` of it.
    records : accelcal.rigs.shaker.ShakerRecords
        The records it came from (one amplitude, several angles).
    s_I : float, optional
        Axial sensitivity for the polar plot (output unit per g); default
        the records' ``axial_sensitivity`` (eq20) or scale factor.

    References
    ----------
    .. [1] GuanTang eqs. (13), (16); ISO16063-31 (polar presentation).
    """
    from accelcal.methods.transverse import estimate_sT
    from accelcal.plotting.transverse import polar_figure

    if s_I is None:
        s_I = records.metadata.get("axial_sensitivity", {}).get("eq20") or records.scale_factor
    figures = []
    if s_I:
        sweep = estimate_sT(records, "fundamental", s_I=float(s_I))
        fig = polar_figure([sweep], title=None, scale=1e3 / abs(float(s_I)), unit="mg/g")
        fig.set_size_inches(4.2, 4.0)
        figures.append(_svg(fig, "Transverse sensitivity",
                            f"Fundamental s_T / s_I against the direction angle at "
                            f"{records.amplitude:g} g (ISO 16063-31 presentation), in mg/g."))
    resid = np.asarray(estimate.residuals)
    fig = _small_figure()
    ax = fig.add_subplot()
    ax.stem(np.arange(resid.size), resid, basefmt="0.5")
    ax.axhspan(-2, 2, color="0.9", zorder=0)
    ax.set_xlabel("observation (phasor component per angle)")
    ax.set_ylabel("weighted residual (1 = 1 σ)")
    ax.grid(alpha=0.3)
    figures.append(_svg(fig, "Residuals",
                        "Phasor components minus fitted model, each divided by its sine-fit "
                        "standard uncertainty; grey band ±2."))
    return Section(
        title=f"{record.serial}: transverse sensitivity (shaker, {records.amplitude:g} g)",
        record=record,
        summary=(f"Sinusoidal vibration of {records.amplitude:g} g at "
                 f"{records.frequency:g} Hz along {records.theta.size} directions in the "
                 "transverse plane; cross-axis coefficients from the w and 2w phasors "
                 "(GuanTang, identification beyond the paper)."),
        errata=_errata(ERRATA_GUANTANG, "GuanTang"), figures=tuple(figures),
    )


# --------------------------------------------------------------------- history
def history_section(store, serial: str, *, method: str | None = None) -> Section | None:
    """Calibration history of ``serial`` from a store (None when it has none).

    A table of the repeatability of each coefficient (sample standard
    deviation across calibrations, IEEE 1293 style, beside the mean of the
    calibrations' own standard uncertainties) and the history plot
    (estimates with k = 2 error bars against date).

    Parameters
    ----------
    store : accelcal.store.Store
    serial : str
    method : str, optional
        Only calibrations by this method (e.g. ``dividing-head/joint``).

    References
    ----------
    .. [1] IEEE1293, definitions of repeatability and drift.
    """
    from accelcal.errors import AccelcalError
    from accelcal.plotting.records import history_figure

    try:
        rows = store.history(serial, method)
        stats = store.stats(serial, method)
    except AccelcalError:
        return None
    several = len({s.method for s in stats}) > 1
    table = [{
        **({"method": s.method} if several else {}),
        "coefficient": s.name, "unit": format_unit(s.unit), "calibrations": s.n,
        "mean": s.mean,
        "repeatability (1 σ)": s.repeatability if s.n > 1 else "n/a",
        "mean own σ": s.mean_std if np.isfinite(s.mean_std) else "n/a",
    } for s in stats]
    fig = history_figure(rows, serial)
    names = len(table)
    fig.set_size_inches(6.4, 1.25 * names + 0.9)
    n = len({r["id"] for r in rows})
    which = f" by {method}" if method else ""
    return Section(
        title=f"{serial}: calibration history{which}", rows=table,
        summary=(f"{n} stored calibration(s) of {serial}{which}. Repeatability is the spread "
                 "of the estimates across calibrations (n/a with one); compare it with the "
                 "calibrations' own standard uncertainties. 'accelcal records stats' adds the "
                 "drift per year."),
        figures=(_svg(fig, "History", "Each coefficient against calibration date; error bars "
                      "k = 2."),),
    )
