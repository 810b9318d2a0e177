"""Self-contained HTML calibration reports.

A report is built from structured results, never from printed text: one
:class:`Section` per calibration or study, each with its calibration record
(coefficients with standard and expanded uncertainties, covariance as
correlations), notes (identifiability, assumptions), errata notes where a
paper's method was corrected, and figures embedded as inline SVG. A complex
coefficient (a frequency response's sensitivity) shows its magnitude and
phase, each with its standard and expanded uncertainty, and its real and
imaginary parts; its correlations are those of the real and imaginary parts. The page
has no script and no external resource, so it reads offline and prints as
it shows. Every string that came from a user (serial, operator, file names,
notes) is HTML-escaped by the template engine (jinja2 autoescaping).

The page reads as a calibration is read: first a summary table (per serial
number the key coefficients in field units with their expanded
uncertainty, :mod:`accelcal.report.summary`), then one section per test
with one estimate table, its figures and notes, then an appendix: each
sensor's own record of a several-sensor test (coefficients with standard
and expanded uncertainties, correlations), the corrections to the published
methods, and the uncertainty budgets when they are given. Numbers never
wrap inside a cell; dates read ``2026-11-26 14:03 UTC``; the page prints
on A4 with its figures whole.
"""

import datetime as dt
import io
from dataclasses import dataclass, field

import numpy as np

from accelcal.formatting import (
    format_correlation,
    format_date,
    format_std,
    format_text,
    format_unit,
    format_value,
)
from accelcal.io.atomic import write_text_atomic
from accelcal.polar import real_names


@dataclass(frozen=True)
class Figure:
    """A figure for the report: inline SVG text and a caption."""

    title: str
    svg: str
    caption: str = ""


@dataclass(frozen=True)
class Section:
    """One part of a report.

    Parameters
    ----------
    title : str
        Heading.
    record : CalibrationRecord, optional
        The calibration it reports: coefficients table and correlations.
    summary : str
        A sentence or two on the method and the set-up.
    rows : list of dict, optional
        An extra table (e.g. a study's RMS errors), rendered as given.
    notes : tuple of str
        Identifiability, assumptions and caveats.
    errata : tuple of str
        Where the implemented method departs from the paper it comes from
        (shown in the appendix, once per method).
    figures : tuple of Figure
    appendix : bool
        A detail of a section before it (one sensor's record of a
        several-sensor test): shown in the appendix.
    """

    title: str
    record: object | None = None
    summary: str = ""
    rows: list[dict] | None = None
    notes: tuple[str, ...] = ()
    errata: tuple[str, ...] = ()
    figures: tuple[Figure, ...] = field(default_factory=tuple)
    appendix: bool = False


def figure_svg(fig) -> str:
    """A matplotlib figure as SVG text for inline embedding (no XML prologue).

    Log axes are labelled in plain text (:func:`accelcal.plotting.ticks.plain_log_labels`),
    linear axes without offset notation (:func:`accelcal.plotting.ticks.no_offset`).
    """
    from accelcal.plotting.ticks import no_offset, plain_log_labels

    plain_log_labels(fig)
    no_offset(fig)
    buf = io.StringIO()
    fig.savefig(buf, format="svg", metadata={"Date": None})  # no time stamp: reproducible
    text = buf.getvalue()
    return text[text.index("<svg"):]


def render_report(sections, *, title: str, subtitle: str = "", generated: str | None = None,
                  budgets=None) -> str:
    """The report as one HTML document.

    Parameters
    ----------
    sections : sequence of Section
    title, subtitle : str
        Heading of the page (escaped).
    generated : str, optional
        Date shown as the generation time; defaults to now (UTC).
    budgets : dict, optional
        Uncertainty budgets, ``(serial, method) -> list of budget objects``
        as ``accelcal budget --format json`` writes them: their U and k go
        into the summary and their rows into the appendix
        (:func:`accelcal.report.summary.budget_views`). Without them U is
        2 standard uncertainties and there is no budget annex.
    """
    import jinja2

    from accelcal import __version__
    from accelcal.report.summary import COVERAGE, GROUPS, budget_views, summary_rows

    env = jinja2.Environment(
        loader=jinja2.PackageLoader("accelcal.report", "templates"),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
    )
    env.filters["value"] = format_value
    env.filters["std"] = format_std
    env.filters["unit"] = format_unit
    env.filters["corr"] = format_correlation
    env.filters["text"] = format_text
    template = env.get_template("report.html.j2")
    main = [s for s in sections if not s.appendix]
    views = [_view(s, str(i)) for i, s in enumerate(main, 1)]
    shown = {n for v in views for n in v["all_notes"]}
    details = [_view(s, f"A.{i}", shown=shown)
               for i, s in enumerate((s for s in sections if s.appendix), 1)]
    errata = {}
    for v in views:
        if v["errata"]:
            errata.setdefault(tuple(v["errata"]), v)
    records, refs, number = [], [], 0
    for s in sections:  # an appendix section details the main section before it
        number += not s.appendix
        if s.record is not None:
            records.append(s.record)
            refs.append(str(number))
    return template.render(
        title=title,
        subtitle=format_text(subtitle),
        generated=format_date(generated or dt.datetime.now(dt.UTC).isoformat(timespec="seconds")),
        version=__version__,
        summary=summary_rows(records, budgets, refs), groups=GROUPS, coverage=f"{COVERAGE:g}",
        sections=views, details=details,
        errata=[{"title": v["title"], "anchor": v["anchor"], "notes": list(e)}
                for e, v in errata.items()],
        budgets=budget_views(budgets),
    )


def write_report(path, sections, **kwargs) -> None:
    """Render the report and write it atomically to ``path``."""
    write_text_atomic(path, render_report(sections, **kwargs))


PRIOR_NOTE = "taken as zero"
"""Notes on the terms a reduction leaves out (:mod:`accelcal.aliasing`) contain this:
they are listed apart, folded, under the section's other notes."""


def _view(section: Section, number: str, *, shown=frozenset()) -> dict:
    """What the template needs of a section (plain values only).

    ``shown`` are notes already printed in a main section: an appendix
    section repeats none of them.
    """
    from accelcal.report.units import record_field_values

    view = {
        "number": number, "anchor": f"s{number}", "title": section.title,
        "summary": format_text(section.summary), "rows": section.rows or [],
        "columns": list(section.rows[0]) if section.rows else [],
        "errata": [format_text(e) for e in section.errata],
        "figures": [{"title": f.title, "svg": f.svg, "caption": format_text(f.caption)}
                    for f in section.figures],
        "record": None,
    }
    rec = section.record
    record_notes = list(rec.notes) if rec is not None else []
    notes = [n for n in dict.fromkeys(format_text(n) for n in [*section.notes, *record_notes])
             if n not in shown]
    view["all_notes"] = notes
    view["notes"] = [n for n in notes if PRIOR_NOTE not in n]
    view["priors"] = [n for n in notes if PRIOR_NOTE in n]
    if rec is not None:
        std = rec.std
        sd = np.sqrt(np.diag(rec.covariance)) if rec.is_complex else std  # of Re, Im
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = rec.covariance / np.outer(sd, sd)
        fields = record_field_values(rec)
        view["record"] = {
            "serial": rec.serial, "method": rec.method, "date": format_date(rec.date),
            "operator": rec.operator, "software": rec.software,
            "coverage_factor": rec.coverage_factor, "inputs": dict(rec.inputs),
            "dof": rec.dof, "simulated": rec.simulated,
            "notes": list(rec.notes),
            "coefficients": _complex_coefficients(rec) if rec.is_complex else [
                {"name": n, "unit": rec.units.get(n, ""), "estimate": float(v),
                 "std": float(s), "expanded": float(u), "type_b": rec.type_b.get(n),
                 "engineering": [f.text() for f in fv], "polar": None}
                for n, v, s, u, fv in zip(rec.names, rec.estimates, std, rec.expanded, fields,
                                          strict=True)
            ],
            "type_b": bool(rec.type_b) and not rec.is_complex,
            "correlation": corr.tolist() if len(corr) <= 10 else None,
            "names": list(real_names(rec.names) if rec.is_complex else rec.names),
        }
    return view


def _complex_coefficients(rec) -> list[dict]:
    """A complex record's coefficients: magnitude and phase (deg) with uncertainties.

    ``estimate``, ``std`` and ``expanded`` are the magnitude's; ``polar``
    adds the phase's and the real and imaginary parts.
    """
    pol, k = rec.polar(), rec.coverage_factor
    return [
        {"name": n, "unit": rec.units.get(n, ""), "estimate": float(m), "std": float(s),
         "expanded": float(k * s), "engineering": [],
         "polar": {"phase": float(np.degrees(ph)), "phase_std": float(np.degrees(phs)),
                   "phase_expanded": float(np.degrees(k * phs)),
                   "real": float(v.real), "imag": float(v.imag)}}
        for n, v, m, s, ph, phs in zip(rec.names, rec.estimates, pol.magnitude,
                                       pol.magnitude_std, pol.phase, pol.phase_std, strict=True)
    ]
