"""Budgets as text: a table per budget, CSV (one line per row) or JSON.

:func:`render_budgets` is what ``accelcal budget`` prints and what the demo
shows of one budget; the columns are GUM's budget table (DOMAIN section 11).
"""

import csv
import io
import json
import math

COLUMNS = ("quantity", "estimate", "u", "unit", "distribution", "sensitivity", "contribution",
           "dof", "share")
"""The columns of a budget's rows (GUM's table: DOMAIN section 11)."""


def _cell(value, digits: int = 4) -> str:
    if isinstance(value, str):
        return value
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "n/a"
    if isinstance(value, float) and math.isinf(value):
        return "inf"
    return f"{value:.{digits}g}"


def _unit(text: str) -> str:
    from accelcal.formatting import format_unit

    if text.startswith("u") and text[1:2] in ("V", "m"):
        text = "µ" + text[1:]
    return format_unit(text) if text else ""


def render_budgets(budgets, fmt: str) -> str:
    """The budgets as ``table`` (one rich table each), ``csv`` (one line per row) or ``json``.

    JSON: a list of :meth:`Budget.as_dict`. CSV: each row with its
    budget's ``serial, coefficient, coefficient_unit, value, u_c, nu_eff,
    k, U`` in front.
    """
    if fmt == "json":
        return json.dumps([b.as_dict() for b in budgets], indent=2, allow_nan=False) + "\n"
    if fmt == "csv":
        head = ("serial", "coefficient", "coefficient_unit", "value", "u_c", "nu_eff", "k", "U")
        rows = [(b.serial, b.coefficient, b.unit, b.estimate, b.u_c, b.nu_eff, b.k, b.U,
                 *(r.as_dict()[c] for c in COLUMNS)) for b in budgets for r in b.rows]
        return csv_text((*head, *COLUMNS), rows)
    return "".join(_table(b) for b in budgets)


def _table(b) -> str:
    from rich.console import Console
    from rich.table import Table

    unit = _unit(b.unit)
    title = f"{b.serial} {b.coefficient} = {_cell(b.estimate, 7)} {unit}"
    relative = next((n for n in b.notes if n.startswith(f"{b.coefficient} = ")), None)
    if relative is not None:  # a scale factor without a nominal: its budget in ppm of itself
        title = f"{b.serial} {relative.split(';', 1)[0]} (budget in {unit} of the estimate)"
    table = Table(title=title, show_lines=False)
    for c in COLUMNS:
        table.add_column(c, justify="left" if c in ("quantity", "unit", "distribution")
                         else "right")
    for r in b.rows:
        table.add_row(r.quantity, _cell(r.estimate, 7), _cell(r.u), _unit(r.unit),
                      r.distribution, _cell(r.sensitivity), f"{_cell(r.contribution)} {unit}",
                      _cell(r.dof, 3), f"{100 * r.share:.1f} %")
    buf = io.StringIO()
    console = Console(file=buf, width=160, force_terminal=False, color_system=None)
    console.print(table)
    nu = "inf" if not math.isfinite(b.nu_eff) else f"{b.nu_eff:.0f}"
    lines = [f"u_c = {_cell(b.u_c, 3)} {unit}, nu_eff = {nu}, k = {b.k:.3f}, "
             f"U = {_cell(b.U, 3)} {unit} (95.45 %)"
             + ("; input correlations enter u_c" if b.correlated else "")]
    if b.check is not None:
        c = b.check
        verdict = "validated" if c.validated else "NOT validated"
        lines.append(f"Monte Carlo ({c.trials} trials, {c.model} model): 95.45 % interval "
                     f"[{_cell(c.mc_low, 7)}, {_cell(c.mc_high, 7)}] {unit}; GUM "
                     f"[{_cell(c.gum_low, 7)}, {_cell(c.gum_high, 7)}]; d_low = "
                     f"{_cell(c.d_low, 2)}, d_high = {_cell(c.d_high, 2)}, delta = "
                     f"{_cell(c.delta, 2)}: GUM {verdict} (JCGM 101 sec. 8)")
        if c.s_low is not None:
            lines.append(f"Monte Carlo endpoints' numerical standard deviations {_cell(c.s_low, 2)}"
                         f", {_cell(c.s_high, 2)} {unit}: "
                         + ("stable at the tolerance (JCGM 101 7.9)" if c.stabilised else
                            "NOT stable at the tolerance: give more --trials (JCGM 101 7.9)"))
    lines += [f"note: {n}" for n in b.notes]
    return buf.getvalue() + "\n".join(lines) + "\n\n"


def csv_text(names, rows) -> str:
    """CSV of ``rows`` under ``names``: floats by ``repr`` (``nan`` for NaN and None)."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(names)
    writer.writerows([_csv_cell(v) for v in row] for row in rows)
    return buf.getvalue()


def _csv_cell(value) -> str:
    if hasattr(value, "item"):  # a numpy scalar
        value = value.item()
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "nan"
    return repr(value) if isinstance(value, float) else str(value)
