"""The report's first table: per serial number, the key results with their expanded uncertainty.

One row per serial number; one pair of columns (estimate, ``U (k=2)``) per
group of quantities (bias, scale factor, alignment, the rest), each cell a
line per key coefficient and test, in field units
(:mod:`accelcal.report.units`). Until a calibration carries an uncertainty
budget, U is ``k`` times the standard uncertainty with ``k = 2``
(JCGM 100 sec. 6.2: about 95 % for a normal distribution). A coefficient's
group is the quantity its name says (a noise fit's B or an acceptance
test's threshold, in µg, are not a bias: they go to the rest). A budget
(``accelcal budget ... --format json``: per coefficient ``U`` and ``k``)
given for a serial and method replaces both, and the cell says its ``k``
where it differs from the column's.

References
----------
.. [GUM] JCGM 100:2008, sec. 6.2-6.3 and 7.2.3 (expanded uncertainty and
   how it is reported).
"""

from dataclasses import dataclass

from accelcal.formatting import format_std, format_text, format_unit, format_value
from accelcal.report.units import (
    FieldValue,
    coefficient_std,
    named_quantity,
    record_field_values,
)

COVERAGE = 2.0
"""Coverage factor of the summary's U when no budget gives one (k = 2, about 95 %)."""

GROUPS = (("bias", "Bias"), ("scale", "Scale factor"), ("alignment", "Alignment"),
          ("other", "Other key coefficients"))
"""The summary's column groups: key and heading."""

KEY_COEFFICIENTS = {
    "transverse": ("Ko", "Kp"),
    "vre": ("K2", "K3"),
    "noise": ("N", "B"),
    "thermal": ("K0_T1", "K1_T1"),
    "centrifuge": ("K0", "K1", "K2", "K3"),
    "triad": ("b_x", "b_y", "b_z", "s_x", "s_y", "s_z", "a_yz", "a_zy", "a_zx"),
    "acceptance": ("threshold", "range_pos", "range_neg", "bias_repeatability"),
    "response": ("S(80 Hz)", "S0", "fn", "f_3dB"),
}
"""Family -> the coefficients the summary shows (every one for a family not listed)."""

MAX_KEYS = 6
"""At most this many coefficients of a family not in :data:`KEY_COEFFICIENTS`."""


@dataclass(frozen=True)
class Line:
    """One key coefficient of one test in a summary cell."""

    coefficient: str
    test: str
    estimate: str
    expanded: str
    ref: str = ""


def summary_rows(records, budgets=None, refs=()) -> list[dict]:
    """The summary table: one row per serial number, in the order first met.

    Parameters
    ----------
    records : sequence of CalibrationRecord
    budgets : dict, optional
        ``(serial, method) -> list of budget objects`` as ``accelcal budget
        --format json`` writes them (``coefficient``, ``U``, ``k``, ...):
        where one names a coefficient, its U and k are reported.
    refs : sequence of str, optional
        Per record, the number of the report section that reports its test.

    Returns
    -------
    list of dict
        ``{"serial", "tests", "simulated", "cells"}``, ``cells`` a dict of
        :data:`GROUPS` key -> list of :class:`Line`; ``simulated`` when a
        record of the serial is of simulated data.
    """
    rows: dict = {}
    refs = list(refs) or [""] * len(records)
    for rec, ref in zip(records, refs, strict=True):
        row = rows.setdefault(rec.serial, {"serial": rec.serial, "tests": [], "simulated": False,
                                           "cells": {key: [] for key, _ in GROUPS}})
        row["simulated"] = row["simulated"] or bool(rec.simulated)
        test = _test_name(rec.method)
        row["tests"].append(test)
        budget = {b.get("coefficient"): b for b in (budgets or {}).get((rec.serial, rec.method),
                                                                      ())}
        fields = record_field_values(rec)
        stds = coefficient_std(rec)
        for i in _keys(rec):
            name = rec.names[i]
            plain = rec.plain.get(name, name)
            std = float(stds[i])
            group = _group(named_quantity(plain, rec.units.get(name, "")))
            given = budget.get(name) or budget.get(plain) or budget.get(f"{name} magnitude")
            row["cells"][group].append(_line(name, test, fields[i][0], std, given, ref,
                                             rec.units.get(name, "")))
    for row in rows.values():
        row["tests"] = list(dict.fromkeys(row["tests"]))
    return list(rows.values())


def _line(name: str, test: str, field: FieldValue, std: float, budget,  # noqa: PLR0917
          ref: str, unit: str = "") -> Line:
    """A summary line: the estimate and U in field units (U = k std, or the budget's)."""
    k, std_field = COVERAGE, field.std
    given = _budget_std(budget, field, std, unit)
    if given is not None:
        k, std_field = given
    u = k * std_field
    note = "" if k == COVERAGE else f" (k={k:.3g})"
    if field.relative:
        digits = abs(field.estimate) * std_field * 1e-6
        return Line(name, test, f"{format_value(field.estimate, digits)} "
                                f"{format_unit(field.unit)}", f"{format_std(u)} ppm{note}", ref)
    unit = format_unit(field.unit)
    return Line(name, test, f"{format_value(field.estimate, std_field)} {unit}",
                f"{format_std(u)} {unit}{note}", ref)


def _budget_std(budget, field: FieldValue, std: float, unit: str):
    """``(k, standard uncertainty in the field's unit)`` from a budget, or None.

    A budget states U in the field's unit (``accelcal budget``: µg, µrad, ppm
    for a scale factor) or, for a method without field units, in the
    record's, or a complex coefficient's magnitude in % of it (``S(80 Hz)
    magnitude``); a budget in none of these units is not used.
    """
    if budget is None or budget.get("U") is None or budget.get("k") is None:
        return None
    k, big_u, given = float(budget["k"]), float(budget["U"]), budget.get("unit", "")
    if not (k > 0 and big_u >= 0):
        return None
    shown = format_unit(given)
    if given == "%" and str(budget.get("coefficient", "")).endswith(" magnitude"):
        return k, abs(field.estimate) * big_u / (100.0 * k)  # a complex one's, in % of it
    if (field.relative and shown == "ppm") or (not field.relative
                                                and shown == format_unit(field.unit)):
        return k, big_u / k
    if shown == format_unit(unit) and std > 0:  # in the record's unit: scale the field's std
        return k, field.std * big_u / (k * std)
    return None


def _keys(rec) -> list[int]:
    """Indices of a record's key coefficients (:data:`KEY_COEFFICIENTS`)."""
    from accelcal.report.rebuild import family_of

    plain = [rec.plain.get(n, n) for n in rec.names]
    wanted = KEY_COEFFICIENTS.get(family_of(rec.method) or "")
    if wanted is None:
        return list(range(min(len(plain), MAX_KEYS)))
    return [i for i, n in enumerate(plain) if n in wanted]


def _group(quantity: str | None) -> str:
    if quantity == "bias":
        return "bias"
    if quantity == "scale":
        return "scale"
    if quantity in ("misalignment", "transverse"):
        return "alignment"
    return "other"


def _test_name(method: str) -> str:
    """A test's short name: the method's catalog title and route (``indexing head, joint``)."""
    from accelcal.catalog import method as descriptor
    from accelcal.report.rebuild import family_of

    family = family_of(method)
    route = method.split("/", 1)[1] if "/" in method else ""
    try:
        title = descriptor(family).title if family else method
    except KeyError:
        title = family or method
    return f"{title}, {route}" if route else title



BUDGET_COLUMNS = ("quantity", "estimate", "u", "unit", "distribution", "sensitivity",
                  "contribution", "dof", "share")
"""The columns of a budget's rows (``accelcal budget --format json``), in order."""


def budget_views(budgets) -> list[dict]:
    """The budget annex: one table per coefficient of each serial and method.

    Parameters
    ----------
    budgets : dict or None
        ``(serial, method) -> list of budget objects`` (``coefficient,
        estimate, unit, u_c, nu_eff, k, U, correlated, rows``; each row
        :data:`BUDGET_COLUMNS`), as ``accelcal budget --format json`` writes
        them. None or empty: no annex.

    Returns
    -------
    list of dict
        ``{"serial", "method", "coefficients"}``; numbers formatted for the page.
    """
    views = []
    for (serial, method), items in (budgets or {}).items():
        coefficients = []
        for b in items:
            u_c = _number(b.get("u_c"))
            coefficients.append({
                "coefficient": str(b.get("coefficient", "")),
                "estimate": format_value(_number(b.get("estimate")), u_c),
                "unit": format_unit(str(b.get("unit", ""))),
                "u_c": format_std(u_c), "nu_eff": _dof(b.get("nu_eff")),
                "k": format_value(_number(b.get("k"))), "U": format_std(_number(b.get("U"))),
                "correlated": bool(b.get("correlated")),
                "rows": [[_cell(c, row.get(c)) for c in BUDGET_COLUMNS]
                         for row in b.get("rows", ())],
            })
        views.append({"serial": serial, "method": method, "coefficients": coefficients})
    return views


def _number(value) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return float("nan")


def _dof(value) -> str:
    if value is None or value == "inf" or _number(value) == float("inf"):
        return "∞"
    return f"{_number(value):.0f}"


def _cell(column: str, value) -> str:
    if column in ("quantity", "distribution"):
        return format_text(str(value if value is not None else ""))
    if column == "unit":
        return format_unit(str(value or ""))
    if column == "dof":
        return _dof(value)
    if column == "share":
        return f"{100 * _number(value):.1f} %"
    if column in ("u", "contribution"):
        return format_std(_number(value))
    return format_value(_number(value))
