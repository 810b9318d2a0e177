"""Report sections built from a :class:`~accelcal.results.Reduction`, for every method.

:func:`reduction_sections` turns any reduction and its calibration records
into an overview (coefficients of every sensor with standard uncertainties,
in the raw unit and in engineering units; the method's figures; notes built
from the reduction's fields; the paper's errata) and one section per
sensor (its record: expanded uncertainties, correlations, inputs). What is
method-specific (figures, title, summary, errata) comes from the method's
package through :data:`accelcal.methods.REGISTRY`; nothing reads note text.

References
----------
.. [GUM] JCGM 100:2008, sec. 7.2 (reporting uncertainty).
.. [IEEE1293] IEEE Std 1293-2018, definitions of repeatability and drift.
"""

import numpy as np

from accelcal.formatting import (
    format_engineering,
    format_std,
    format_unit,
    format_value,
    pm,
    pm_polar,
)
from accelcal.report import Figure, Section, figure_svg

ERRATA_SEE = "Details, checks and the code that implements each correction: docs/errata.md"


def reduction_sections(reduction, records, *, unavailable: str = "", **context
                       ) -> list[Section]:
    """Sections of one reduction: an overview, then one per sensor.

    The one road to a report: the demo's campaign (:mod:`accelcal.pipeline`)
    calls it with the reduction it made, ``accelcal report`` with the
    reduction rebuilt from the record files
    (:func:`accelcal.report.rebuild.rebuild`).

    Parameters
    ----------
    reduction : accelcal.results.Reduction
    records : sequence of CalibrationRecord or None
        One per sensor (:meth:`~accelcal.results.Reduction.to_records`);
        None for a sensor whose record is not reported (it keeps its column
        in the overview, under its sensor name, and gets no section).
    unavailable : str
        Why the reduction cannot draw its figures (a reduction rebuilt from
        records alone); shown as the first note, and no figure is drawn.
    **context
        Passed to the method's figures (e.g. ``truth``: a simulated head
        error drawn beside the separated one).

    Returns
    -------
    list of Section
    """
    from accelcal.methods import errata_of
    from accelcal.outputs import describe

    text = _report_text(reduction, rebuilt_from_records=bool(unavailable))
    figures = () if unavailable else tuple(
        Figure(title, figure_svg(fig), caption)
        for _stem, title, fig, caption in reduction.figures(**context))
    errata = errata_of(reduction)
    if errata:
        errata = (*errata, f"{ERRATA_SEE} ({text.paper})." if text.paper else f"{ERRATA_SEE}.")
    notes = tuple(dict.fromkeys([*([unavailable] if unavailable else []), *describe(reduction)]))
    overview = Section(
        title=text.title, summary=text.summary, rows=overview_rows(reduction, records),
        notes=notes, errata=errata, figures=figures,
    )
    if reduction.n_sensors == 1 and records[0] is not None:
        return [Section(title=f"{records[0].serial}: {text.title}", record=records[0],
                        summary=text.summary, rows=overview.rows, notes=overview.notes,
                        errata=errata, figures=figures)]
    per_sensor = [_sensor_section(name, rec, text)
                  for name, rec in zip(reduction.sensor_names, records, strict=True)
                  if rec is not None]
    return [overview, *per_sensor]


def _sensor_section(name: str, record, text) -> Section:
    """One sensor's section of a several-sensor reduction (in the report's appendix)."""
    column = name != record.serial  # a reduction rebuilt from records names sensors by serial
    return Section(title=f"{record.serial}: {text.title}" + (f" ({name})" if column else ""),
                   record=record, appendix=True,
                   summary=((f"Sensor column {name}. " if column else "")
                            + text.sensor_summary).strip())


def _report_text(reduction, *, rebuilt_from_records: bool):
    """The method's title and summary, or a plain one for a reduction rebuilt from records.

    A method's summary describes the set-up from the reduction's observations
    and assumptions (positions, plateaus, rate), which records do not hold:
    a reduction rebuilt from them alone gets the method's name and paper
    (:mod:`accelcal.catalog`) and says where its numbers come from.
    """
    from accelcal.methods import ReportText, report_text_of

    if not rebuilt_from_records:
        return report_text_of(reduction)
    from accelcal.catalog import method

    try:
        found = method(reduction.family)
    except KeyError:
        return ReportText(title=f"calibration by {reduction.method}", summary="")
    return ReportText(
        title=f"{found.title[:1].upper()}{found.title[1:]} ({reduction.method})",
        summary=("Reported from the calibration record(s) alone: the description of the "
                 "set-up and the figures need the test's input files (see the first note)."),
        paper=found.paper)


def overview_rows(reduction, records) -> list[dict]:
    """Coefficient x sensor table: ``value ± std``, the first field unit below it.

    The sensors' own sections show every field unit (e.g. arcsec beside µrad);
    a coefficient the engineering table does not convert gets its field unit
    from :func:`accelcal.report.units.field_values`. A complex coefficient
    shows ``magnitude ± std ∠ phase ± std°``.
    """
    from accelcal.outputs import reduction_rows

    rows = reduction_rows(reduction)
    first = reduction.sensors[0]
    names = [*(first.label(n) for n in first.names), *reduction.fixed]
    table = []
    for coef in names:
        unit = next((r["unit"] for r in rows if r["coefficient"] == coef), "")
        row = {"coefficient": coef, "unit": format_unit(unit)}
        for sensor, rec in zip(reduction.sensor_names, records, strict=True):
            r = next((r for r in rows if r["sensor"] == sensor and r["coefficient"] == coef),
                     None)
            if r is None:
                continue
            head = _column(sensor, rec) if reduction.n_sensors > 1 else "estimate ± σ"
            if r["status"] == "not identifiable":
                row[head] = "not identifiable"
                continue
            if "phase_deg" in r and r["status"] == "fitted":  # complex: magnitude and phase
                cell = pm_polar(r["magnitude"], r["magnitude_std"], r["phase_deg"],
                                r["phase_std_deg"])
            else:
                cell = pm(r["estimate"], r["std"]) if r["status"] == "fitted" else \
                    f"{r['estimate']:.6g} (fixed)"
            eng = _field_text(reduction, r)
            row[head] = f"{cell}\n({eng})" if eng and r["status"] == "fitted" else cell
        table.append(row)
    return table


def _field_text(reduction, row) -> str:
    """A reduction row's first field unit: its engineering unit, else the report's own.

    The report's own: :func:`accelcal.report.units.field_values`.
    """
    from accelcal.report.units import field_values

    if row["engineering"]:
        return format_engineering(row["engineering"][:1])
    if "phase_deg" in row:
        return ""
    k = list(reduction.sensor_names).index(row["sensor"]) if reduction.sensor_names else 0
    found = field_values(row.get("plain", row["coefficient"]), row["estimate"], row["std"],
                         row["unit"], scale_factor=reduction.scale_factor(k))
    return found[0].text()


def _column(sensor: str, record) -> str:
    """An overview column's heading: serial number and sensor column, as far as known."""
    if record is None or record.serial == sensor:
        return sensor
    return f"{record.serial} ({sensor})"


# --------------------------------------------------------------------- history
def coefficient_stats(rows) -> list:
    """Repeatability and drift of each (method, plain coefficient) of history ``rows``.

    :func:`accelcal.store.stats.summarise` of :meth:`~accelcal.store.Store.history`
    rows with each row under its ``coefficient`` (the plain name): a
    coefficient recorded under another name from some calibration on is one
    coefficient (:mod:`accelcal.store.history`).
    """
    from accelcal.store.stats import summarise

    calibrations = list(dict.fromkeys((r["id"], r["date"], r["method"]) for r in rows))
    coefficients = [(r["id"], r["coefficient"], r["unit"], r["estimate"],
                     None if not np.isfinite(r["std"]) else r["std"]) for r in rows]
    return summarise(calibrations, coefficients)


def history_section(store, serial: str, *, method: str | None = None,
                    chain: str | None = None) -> Section | None:
    """Calibration history of ``serial`` from a store (None when it has none).

    A table of the repeatability of each coefficient (sample standard
    deviation across calibrations, IEEE 1293 style, beside the mean of the
    calibrations' own standard uncertainties) and the history plot
    (estimates with k = 2 error bars against date). Calibrations superseded
    by a correction are left out of both.

    Parameters
    ----------
    store : accelcal.store.Store
    serial : str
    method : str, optional
        Only calibrations by this method (e.g. ``dividing-head/joint``).
    chain : str, optional
        The store's chain status line
        (:meth:`accelcal.store.ChainReport.status_line`), written in the
        section's summary.

    References
    ----------
    .. [1] IEEE1293, definitions of repeatability and drift.
    """
    from accelcal.errors import AccelcalError
    from accelcal.plotting.records import history_figure
    from accelcal.report.units import field_values
    from accelcal.store.checks import BadRowError
    from accelcal.store.history import renamings

    try:
        rows = store.history(serial, method, current_only=True)
    except BadRowError:
        raise
    except AccelcalError:
        return None
    stats = coefficient_stats(rows)
    changes = renamings(rows)
    recorded = {}
    for r in rows:
        names = recorded.setdefault((r["method"], r["coefficient"]), [])
        if r["name"] not in names:
            names.append(r["name"])
    several = len({s.method for s in stats}) > 1
    k1 = {(s.method, s.name): s.mean for s in stats if s.name in ("K_I", "K1")}
    table = []
    for s in stats:
        scale = next((v for (m, n), v in k1.items() if m == s.method), None)
        mean, repeat, own = (field_values(s.name, s.mean, x, s.unit, scale_factor=scale)[0]
                             for x in (s.repeatability, s.repeatability, s.mean_std))
        unit = "ppm" if repeat.relative else mean.unit
        table.append({
            **({"method": s.method} if several else {}),
            "coefficient": s.name,
            **({"recorded as": " then ".join(recorded[(s.method, s.name)])} if changes else {}),
            "unit": format_unit(s.unit), "calibrations": s.n,
            "mean": f"{format_value(mean.estimate, _digits(mean, repeat, own, s.n))} "
                    f"{format_unit(mean.unit)}",
            "repeatability (1 σ)": (f"{format_std(repeat.std)} {format_unit(unit)}" if s.n > 1
                                    else "n/a"),
            "mean own σ": (f"{format_std(own.std)} {format_unit(unit)}"
                           if np.isfinite(s.mean_std) else "n/a"),
        })
    fig = history_figure(_field_history(rows), serial)
    names = len(table)
    fig.set_size_inches(6.4, 1.25 * names + 0.9)
    n = len({r["id"] for r in rows})
    which = f" by {method}" if method else ""
    return Section(
        title=f"{serial}: calibration history{which}", rows=table,
        summary=(f"{n} stored calibration(s) of {serial}{which}. Repeatability is the spread "
                 "of the estimates across calibrations (n/a with one); compare it with the "
                 "calibrations' own standard uncertainties. 'accelcal records stats' adds the "
                 "drift per year." + "".join(f" {c.text()}." for c in changes)
                 + (f" Store: {chain}." if chain else "")),
        figures=(Figure("History", figure_svg(fig), "Each coefficient in field units against "
                        "calibration date (a scale factor as its deviation from the mean, in "
                        "ppm); error bars k = 2."),),
    )


def _digits(mean, repeat, own, n: int) -> float:
    """The uncertainty that sets a history mean's digits: the repeatability, else the own σ.

    A relative one (ppm, a scale factor's) is taken back to the mean's unit.
    """
    std = repeat.std if n > 1 else own.std
    return abs(mean.estimate) * std * 1e-6 if mean.relative else std


def _field_history(rows) -> list[dict]:
    """History rows in field units (:mod:`accelcal.report.units`), units as printed.

    An output-unit coefficient is divided by the same calibration's scale
    factor; a scale factor becomes its deviation from the mean of its
    calibrations (the history table's mean), in ppm.
    """
    from accelcal.report.units import field_values

    k1 = {(r["id"], r["method"]): r["estimate"] for r in rows if r["name"] in ("K_I", "K1")}
    means = {}
    for r in rows:
        means.setdefault((r["method"], r["name"]), []).append(r["estimate"])
    out = []
    for r in rows:
        f = field_values(r["name"], r["estimate"], r["std"], r["unit"],
                         scale_factor=k1.get((r["id"], r["method"])))[0]
        if f.relative:
            ref = float(np.mean(means[(r["method"], r["name"])]))
            out.append({**r, "name": f"{r['name']} − mean", "unit": "ppm",
                        "estimate": (r["estimate"] - ref) / ref * 1e6, "std": f.std})
        else:
            out.append({**r, "unit": format_unit(f.unit), "estimate": f.estimate, "std": f.std})
    return out
