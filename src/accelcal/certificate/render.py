"""The certificate laid out for people: HTML (jinja2, autoescaped) and PDF (WeasyPrint).

The HTML has one page of results per serial number (a frequency
response's table per frequency, its model's phases and its Bode figure,
:mod:`accelcal.certificate.figure`, among them), then one annex page of
budgets per serial number; each page carries a footer ``Page x of y``. In
print, and so in the PDF, those footers give way to the CSS paged-media
counters (``@page { @bottom-center { content: "Page " counter(page) " of "
counter(pages) } }``) [CSSPAGE]_, which count the pages the annex really
takes.

References
----------
.. [CSSPAGE] W3C, CSS Paged Media Module Level 3 (page-margin boxes, the
   ``page`` and ``pages`` counters).
"""

import math

from accelcal.engineering import QUANTITIES
from accelcal.errors import AccelcalError
from accelcal.formatting import format_std, format_unit, format_value


def _dof(x) -> str:
    if x == "inf" or (isinstance(x, float) and math.isinf(x)):
        return "∞"
    return f"{x:.3g}" if x < 100 else f"{x:.0f}"


def _k(k: float) -> str:
    return f"{k:.2f}"


def _result_view(r: dict) -> dict:
    """One results row: in the field's unit when there is one, else the record's."""
    route = r["method"].partition("/")[2] or r["method"]
    if r["engineering"]:
        e = r["engineering"][0]
        also = "; ".join(f"{format_value(x['estimate'], x['U'] / 2 or None)} ± "
                         f"{format_std(x['U'])} {format_unit(x['unit'])}"
                         for x in r["engineering"][1:])
        raw = (f"{format_value(r['estimate'], r['u_c'] or None)} ± {format_std(r['U'])} "
               f"{format_unit(r['unit'])}")
        name = (r["plain"] if r["plain"] == r["coefficient"]
                else f"{r['plain']} ({r['coefficient']})")
        if e["unit"] == "ppm" and QUANTITIES.get(r["plain"]) == "scale":
            name += ", deviation from nominal"  # the value itself is in "also"
        return {"name": name, "route": route,
                "value": format_value(e["estimate"], e["u"] or None), "U": format_std(e["U"]),
                "unit": format_unit(e["unit"]), "k": _k(r["k"]),
                "also": "; ".join(x for x in (also, raw) if x)}
    rel = r["relative"]
    return {"name": r["plain"] if r["plain"] == r["coefficient"]
            else f"{r['plain']} ({r['coefficient']})", "route": route,
            "value": format_value(r["estimate"], r["u_c"] or None), "U": format_std(r["U"]),
            "unit": format_unit(r["unit"]) or "1", "k": _k(r["k"]),
            "also": "" if rel is None else f"U = {format_std(rel['U'])} ppm of the value"}


def _limit(x, infinite: str) -> str:
    return infinite if x is None else f"{x:g}"


def _conformity_view(s: dict) -> dict:
    unit = format_unit(s["unit"])
    lo, hi = s["acceptance"]
    return {"quantity": s["quantity"],
            "value": f"{format_value(s['estimate'], s['u'] or None)} ± {format_std(s['U'])} "
                     f"{unit}",
            "tolerance": f"{_limit(s['lower'], '−∞')} … {_limit(s['upper'], '+∞')} {unit}",
            "zone": (f"{'−∞' if lo is None else format_value(lo, s['u'] or None)} … "
                     f"{'+∞' if hi is None else format_value(hi, s['u'] or None)}"),
            "guard": f"{format_std(s['guard']) if s['guard'] else '0'} {unit}",
            "risk": (f"false reject {s['conforming']:.2g}" if s["outcome"] == "reject"
                     else f"false accept {s['false_accept_risk']:.2g}"),
            "statement": s["statement"],
            "css": {"accept": "conforms", "reject": "fails"}.get(s["outcome"], "inconclusive")}


def _budget_view(b: dict) -> dict:
    unit = format_unit(b["unit"])
    return {
        "title": f"{b['coefficient']} ({b['method']}) = "
                 f"{format_value(b['estimate'], b['u_c'] or None)} {unit}",
        "unit": unit, "u_c": format_std(b["u_c"]), "nu_eff": _dof(b["nu_eff"]),
        "k": _k(b["k"]), "U": format_std(b["U"]), "correlated": b["correlated"],
        "rows": [{"quantity": r["quantity"],
                  "estimate": format_value(r["estimate"], r["u"] or None),
                  "u": format_std(r["u"]), "unit": format_unit(r["unit"]),
                  "distribution": r["distribution"], "sensitivity": f"{r['sensitivity']:.4g}",
                  "contribution": format_std(r["contribution"]), "dof": _dof(r["dof"]),
                  "share": f"{100 * r['share']:.1f} %"} for r in b["rows"]],
    }


def _conditions(c: dict) -> str:
    env = c["conditions"]["environment"]
    parts = []
    if "temperature_degC" in env:
        tol = env.get("temperature_tolerance_degC")
        parts.append(f"temperature {env['temperature_degC']} °C"
                     + (f" ± {tol} °C" if tol is not None else ""))
    if "humidity_percent" in env:
        parts.append(f"relative humidity {env['humidity_percent']} %")
    g = c["conditions"]["local_gravity"]
    if g is not None:
        parts.append(f"local gravity {format_value(g['value'], g['u'] or None)} m/s² "
                     f"(u = {format_std(g['u'])} m/s²)")
    return "; ".join(parts) or "not stated"


def _point_view(p: dict) -> dict:
    """One row of a frequency response's table (magnitude, deviation, phase with U and k)."""
    dev = p["deviation_u"]
    return {"f": f"{p['frequency_hz']:g}" + (f" ({p['amplitude_g']:g} g)"
                                              if p["amplitude_g"] is not None else ""),
            "magnitude": format_value(p["magnitude"], p["magnitude_u"] or None),
            "magnitude_U": format_std(p["magnitude_U"]), "magnitude_k": _k(p["magnitude_k"]),
            "deviation": format_value(p["deviation_pct"], dev or None),
            "deviation_U": "" if dev is None else (format_std(p["deviation_U"])
                                                   if p["deviation_U"] else "0"),
            "deviation_db": f"{p['deviation_db']:.3f}",
            "phase": format_value(p["phase_deg"], p["phase_u"] or None),
            "phase_U": format_std(p["phase_U"]), "phase_k": _k(p["phase_k"])}


def _response_view(item: dict) -> dict | None:
    """A serial's frequency responses: tables, the model's phases, the Bode figure (or None)."""
    curves, models = item.get("response", []), item.get("response_models", [])
    if not curves and not models:
        return None
    from accelcal.certificate.figure import bode_uri

    return {
        "curves": [{"route": c["route"], "method": c["method"],
                    "unit": format_unit(c["unit"]),
                    "reference": f"{c['reference_frequency_hz']:g}",
                    "rows": [_point_view(p) for p in c["points"]]} for c in curves],
        "models": [{"model": m["model"], "method": m["method"],
                    "rows": [{"f": f"{a['frequency_hz']:g}",
                              "phase": format_value(a["phase_deg"], a["phase_u"] or None),
                              "phase_U": format_std(a["phase_U"]), "phase_k": _k(a["phase_k"]),
                              "delay": format_value(1e3 * a["group_delay_s"],
                                                    1e3 * a["group_delay_u"] or None),
                              "delay_U": format_std(1e3 * a["group_delay_U"]),
                              "delay_k": _k(a["group_delay_k"])} for a in m["at"]]}
                   for m in models],
        "bode": bode_uri(curves, models),
    }


def pages(c: dict) -> list[dict]:
    """The pages of the certificate: results per serial, then the budgets per serial."""
    out = []
    for item in c["items"]:
        page = {"kind": "results", "item": item,
                "results": [_result_view(r) for r in item["results"]],
                "conformity": [_conformity_view(r["conformity"]) for r in item["results"]
                               if r["conformity"] is not None],
                "response": _response_view(item)}
        page["conformity"] += [_conformity_view(p["conformity"])
                               for curve in item.get("response", []) for p in curve["points"]
                               if p["conformity"] is not None]
        out.append(page)
    for item in c["items"]:
        budgets = [_budget_view(b) for b in c["budgets"] if b["serial"] == item["serial"]]
        if budgets:
            out.append({"kind": "annex", "serial": item["serial"], "budgets": budgets})
    return out


def render_html(c: dict) -> str:
    """The certificate's HTML (self-contained, every text escaped)."""
    import jinja2

    env = jinja2.Environment(
        loader=jinja2.PackageLoader("accelcal.certificate", "templates"),
        autoescape=True, undefined=jinja2.StrictUndefined, trim_blocks=True,
        lstrip_blocks=True)
    return env.get_template("certificate.html.j2").render(
        c=c, pages=pages(c), conditions=_conditions(c))


def _weasyprint():
    """WeasyPrint, or an :class:`AccelcalError` saying what is missing."""
    try:
        import weasyprint
    except ImportError:
        raise AccelcalError("PDF output needs WeasyPrint: pip install 'accelcal[pdf]'",
                            parameter="pdf") from None
    except OSError as exc:  # installed, but the system's Pango cannot be loaded
        raise AccelcalError(f"WeasyPrint cannot load its system libraries (Pango): {exc}",
                            parameter="pdf") from None
    return weasyprint


def pdf_available() -> bool:
    """True when :func:`write_pdf` can print (WeasyPrint and its libraries load)."""
    try:
        _weasyprint()
    except AccelcalError:
        return False
    return True


def write_pdf(html: str, path) -> None:
    """Print the HTML to a PDF file with WeasyPrint (the ``pdf`` extra)."""
    weasyprint = _weasyprint()
    from accelcal.io.atomic import atomic_path

    with atomic_path(path) as tmp:
        weasyprint.HTML(string=html).write_pdf(tmp)
