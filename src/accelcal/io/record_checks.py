"""Checks of a calibration record's optional blocks: the kept budgets and the Type B parts.

:mod:`accelcal.io.calibration_record` calls them while validating a record.
"""

import math

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.validation import is_finite_number, shown_name

_BUDGET_KEYS = {"lab", "standards", "budgets"}
_BUDGET_ENTRY_KEYS = {"coefficient", "estimate", "unit", "u_c", "nu_eff", "k", "U", "rows"}
_BUDGET_ROW_KEYS = {"quantity", "estimate", "u", "unit", "distribution", "sensitivity",
                    "contribution", "dof", "share"}


def check_budget_block(block, fail) -> None:
    """Check the shape of a record's ``budget`` block (module docs)."""
    if not isinstance(block, dict) or set(block) != _BUDGET_KEYS:
        raise fail(f"budget must be an object with exactly the keys {sorted(_BUDGET_KEYS)}")
    lab = block["lab"]
    if not (isinstance(lab, dict) and isinstance(lab.get("sha256"), str)
            and all(isinstance(lab.get(k, ""), str) for k in ("path", "name"))):
        raise fail("budget.lab must be an object with the lab file's sha256, path and name")
    standards = block["standards"]
    if not (isinstance(standards, list) and all(
            isinstance(s, dict) and isinstance(s.get("quantity"), str) for s in standards)):
        raise fail("budget.standards must be a list of objects with a quantity")
    budgets = block["budgets"]
    if not (isinstance(budgets, list) and all(budget_entry_ok(b) for b in budgets)):
        raise fail(f"budget.budgets must be a list of objects with the keys "
                   f"{sorted(_BUDGET_ENTRY_KEYS)}: finite numbers (nu_eff may be \"inf\"), "
                   f"rows with the keys {sorted(_BUDGET_ROW_KEYS)}")


def budget_entry_ok(b) -> bool:
    """True for a budget object of the shape :meth:`Budget.as_dict` writes."""
    def number(x, inf=False):
        return is_finite_number(x) or (inf and x == "inf")

    return (isinstance(b, dict) and set(b) >= _BUDGET_ENTRY_KEYS
            and isinstance(b["coefficient"], str) and isinstance(b["unit"], str)
            and all(number(b[k]) for k in ("estimate", "u_c", "k", "U"))
            and number(b["nu_eff"], inf=True) and isinstance(b["rows"], list)
            and all(isinstance(r, dict) and set(r) >= _BUDGET_ROW_KEYS
                    and isinstance(r["quantity"], str) and isinstance(r["unit"], str)
                    and all(number(r[k]) for k in ("estimate", "u", "sensitivity",
                                                   "contribution", "share"))
                    and (r["dof"] is None or number(r["dof"], inf=True))
                    for r in b["rows"]))



TYPE_B_RTOL = 1e-6
"""Slack of a row's Type B over its whole standard uncertainty (rounding of the JSON)."""


def check_type_b(type_b, names, cov, complex_: bool) -> dict:
    """``type_b`` as row name -> float, each a row's, finite, >= 0 and within its ``std``.

    Raises
    ------
    AccelcalError
        Naming the row at fault.
    """
    out = {}
    for name, value in dict(type_b or {}).items():
        if name not in names:
            raise AccelcalError(f"calibration record: type_b of {shown_name(name)}, which is "
                                "not a coefficient of the record")
        u = float(value)
        if not (math.isfinite(u) and u >= 0):
            raise AccelcalError(f"calibration record: type_b of {shown_name(name)} must be a "
                                f"finite number >= 0, got {value!r}")
        i = names.index(name)
        var = cov[2 * i, 2 * i] + cov[2 * i + 1, 2 * i + 1] if complex_ else cov[i, i]
        if np.isfinite(var) and u > (1 + TYPE_B_RTOL) * math.sqrt(var) + 1e-300:
            raise AccelcalError(f"calibration record: the Type B of {shown_name(name)} "
                                f"({u:.6g}) exceeds its standard uncertainty "
                                f"({math.sqrt(var):.6g}), of which it is a part")
        out[name] = u
    return out
