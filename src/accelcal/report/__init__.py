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
"""

import datetime as dt
import io
from dataclasses import dataclass, field

import numpy as np

from accelcal.formatting import (
    format_correlation,
    format_engineering,
    format_std,
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
        Where the implemented method departs from the paper it comes from.
    figures : tuple of Figure
    """

    title: str
    record: object | None = None
    summary: str = ""
    rows: list[dict] | None = None
    notes: tuple[str, ...] = ()
    errata: tuple[str, ...] = ()
    figures: tuple[Figure, ...] = field(default_factory=tuple)


def figure_svg(fig) -> str:
    """A matplotlib figure as SVG text for inline embedding (no XML prologue).

    Log axes are labelled in plain text (:func:`accelcal.plotting.ticks.plain_log_labels`).
    """
    from accelcal.plotting.ticks import plain_log_labels

    plain_log_labels(fig)
    buf = io.StringIO()
    fig.savefig(buf, format="svg")
    text = buf.getvalue()
    return text[text.index("<svg"):]


def render_report(sections, *, title: str, subtitle: str = "", generated: str | None = None) -> str:
    """The report as one HTML document.

    Parameters
    ----------
    sections : sequence of Section
    title, subtitle : str
        Heading of the page (escaped).
    generated : str, optional
        Date shown as the generation time; defaults to now (UTC).
    """
    import jinja2

    from accelcal import __version__

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
    template = env.get_template("report.html.j2")
    return template.render(
        title=title,
        subtitle=subtitle,
        generated=generated or dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
        version=__version__,
        sections=[_view(s, i) for i, s in enumerate(sections, 1)],
    )


def write_report(path, sections, **kwargs) -> None:
    """Render the report and write it atomically to ``path``."""
    write_text_atomic(path, render_report(sections, **kwargs))


def _view(section: Section, number: int) -> dict:
    """What the template needs of a section (plain values only)."""
    view = {
        "number": number, "anchor": f"s{number}", "title": section.title,
        "summary": section.summary, "rows": section.rows or [],
        "columns": list(section.rows[0]) if section.rows else [],
        "notes": list(section.notes), "errata": list(section.errata),
        "figures": [{"title": f.title, "svg": f.svg, "caption": f.caption}
                    for f in section.figures],
        "record": None,
    }
    rec = section.record
    record_notes = list(rec.notes) if rec is not None else []
    view["all_notes"] = list(dict.fromkeys([*section.notes, *record_notes]))
    if rec is not None:
        std = rec.std
        k1 = _record_scale_factor(rec)
        sd = np.sqrt(np.diag(rec.covariance)) if rec.is_complex else std  # of Re, Im
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = rec.covariance / np.outer(sd, sd)
        view["record"] = {
            "serial": rec.serial, "method": rec.method, "date": rec.date,
            "operator": rec.operator, "software": rec.software,
            "coverage_factor": rec.coverage_factor, "inputs": dict(rec.inputs),
            "dof": rec.dof, "simulated": rec.simulated,
            "notes": list(rec.notes),
            "coefficients": _complex_coefficients(rec) if rec.is_complex else [
                {"name": n, "unit": rec.units.get(n, ""), "estimate": float(v),
                 "std": float(s), "expanded": float(u),
                 "engineering": engineering_text(rec.plain.get(n, n), float(v), float(s),
                                                 rec.units.get(n, ""), scale_factor=k1),
                 "polar": None}
                for n, v, s, u in zip(rec.names, rec.estimates, std, rec.expanded, strict=True)
            ],
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
         "expanded": float(k * s), "engineering": "",
         "polar": {"phase": float(np.degrees(ph)), "phase_std": float(np.degrees(phs)),
                   "phase_expanded": float(np.degrees(k * phs)),
                   "real": float(v.real), "imag": float(v.imag)}}
        for n, v, m, s, ph, phs in zip(rec.names, rec.estimates, pol.magnitude,
                                       pol.magnitude_std, pol.phase, pol.phase_std, strict=True)
    ]


def engineering_text(name, value, std, unit, *, scale_factor=None) -> str:
    """``value ± std unit`` in each engineering unit of a record's coefficient."""
    from accelcal.engineering import engineering

    return format_engineering(e.as_dict() for e in engineering(name, value, std, unit,
                                                                 scale_factor=scale_factor))


def _record_scale_factor(rec) -> float | None:
    """A record's scale factor in output unit per g: its K_I or K1, else its model's K1."""
    if rec.is_complex:
        return None
    for name in ("K_I", "K1"):
        if name in rec.names:
            return float(rec.estimates[rec.names.index(name)])
    return float(rec.model.K1) if rec.model is not None else None
