"""Validation of the rows a records store gives back, and of dates entering it.

A store can be edited outside accelcal (an SQL client, another program):
every read checks each value it uses before anything is computed or drawn
from it, and names the first bad one by table, row id and field. With
``skip_bad`` the bad rows are left out and counted instead.

Dates are kept within :data:`FIRST_DATE` .. :data:`LAST_DATE` (UTC), on the
way in (:meth:`accelcal.store.Store.add_many`) and on the way out: the range the history figures
can draw, and far wider than any calibration.
"""

import datetime as dt
import math
import re
from operator import itemgetter

from accelcal.errors import AccelcalError
from accelcal.validation import shown

FIRST_DATE = "1900-01-01"
LAST_DATE = "2199-12-31"
"""The dates a store accepts (UTC, inclusive)."""

_UTC = re.compile(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(\.\d{1,6})?\+00:00")
"""A date as the store writes it (ISO 8601 in UTC)."""


def date_problem(value) -> str | None:
    """Why ``value`` is not a stored date (ISO 8601 text within the range), or None."""
    if type(value) is not str:
        return f"{shown(value)} is not a date (ISO 8601 text)"
    if _UTC.fullmatch(value):
        day = value[:10]
    else:
        try:
            moment = dt.datetime.fromisoformat(value)
        except ValueError:
            return f"{shown(value)} is not an ISO 8601 date"
        if moment.tzinfo is not None:
            try:
                moment = moment.astimezone(dt.UTC)
            except OverflowError:
                return f"{shown(value)} is outside {FIRST_DATE} .. {LAST_DATE}"
        day = moment.date().isoformat()
    if not FIRST_DATE <= day <= LAST_DATE:
        return f"{shown(value)} is outside {FIRST_DATE} .. {LAST_DATE}"
    return None


def _id(value) -> str | None:
    return None if type(value) is int else f"{shown(value)} is not an integer id"


def _label(value) -> str | None:
    if type(value) is not str:
        return f"{shown(value)} is not text"
    return None if value.strip() else "it is blank"


def _text(value) -> str | None:
    return None if type(value) is str else f"{shown(value)} is not text"


def _flag(value) -> str | None:
    return None if value in (0, 1) and type(value) in (int, bool) else \
        f"{shown(value)} is not a boolean (0 or 1)"


def _real(value) -> str | None:
    if type(value) not in (float, int) or not math.isfinite(value):
        return f"{shown(value)} is not a finite number"
    return None


def _std(value) -> str | None:
    if value is None:
        return None
    if type(value) not in (float, int) or not value >= 0 or math.isinf(value):
        return f"{shown(value)} is not a standard uncertainty (a finite number >= 0, or NULL)"
    return None


def _optional_id(value) -> str | None:
    return None if value is None else _id(value)


KINDS = {"id": _id, "label": _label, "text": _text, "date": date_problem, "flag": _flag,
         "real": _real, "std": _std, "ref": _optional_id}
"""Kind of column -> its check (value -> problem or None)."""

def _types(values) -> set:
    return set(map(type, values))


def _dates_as_stored(values) -> bool:
    """Whether every date is as the store writes them, within the range (at C speed)."""
    distinct = set(values)
    return (_types(distinct) <= {str} and all(map(_UTC.fullmatch, distinct))
            and min(distinct, default=FIRST_DATE)[:10] >= FIRST_DATE
            and max(distinct, default=LAST_DATE)[:10] <= LAST_DATE)


_FAST = {
    "id": lambda values: _types(values) <= {int},
    "label": lambda values: _types(values) <= {str} and all(map(str.strip, values)),
    "text": lambda values: _types(values) <= {str},
    "real": lambda values: _types(values) <= {float} and all(map(math.isfinite, values)),
    # filter(None, ...) drops NULLs (and zeros, which are good anyway)
    "std": lambda values: _types(values) <= {float, type(None)} and all(
        map(math.isfinite, filter(None, values))) and min(filter(None, values), default=0) >= 0,
    "date": _dates_as_stored,
}
"""Kind -> a quick test that a whole column is good (the usual case), before row by row."""


LIST_SPEC = (("id", "calibrations", 0, "id"), ("serial", "calibrations", 0, "label"),
              ("method", "calibrations", 0, "label"), ("date", "calibrations", 0, "date"),
              ("software", "calibrations", 0, "text"), ("simulated", "calibrations", 0, "flag"),
              None)
"""Checks of the columns of ``records list`` (the last, superseded_by, not checked)."""
HISTORY_COLUMNS = ("id", "date", "method", "name", "unit", "estimate", "std", "superseded_by")
"""The columns of ``records history``."""
READ_SPECS = {
    "history": (("id", "calibrations", 0, "id"), ("date", "calibrations", 0, "date"),
                ("method", "calibrations", 0, "label"), ("name", "coefficients", 8, "label"),
                ("unit", "coefficients", 8, "text"), ("estimate", "coefficients", 8, "real"),
                ("std", "coefficients", 8, "std"), None, None),
    "calibrations": (("id", "calibrations", 0, "id"), ("date", "calibrations", 0, "date"),
                     ("method", "calibrations", 0, "label")),
    "coefficients": (None, ("name", "coefficients", 5, "label"),
                     ("unit", "coefficients", 5, "text"),
                     ("estimate", "coefficients", 5, "real"),
                     ("std", "coefficients", 5, "std"), None),
}
"""Checks of the columns each read gives (:meth:`RowChecker.check`)."""


class BadRowError(AccelcalError):
    """A row of a store that fails validation (changed outside accelcal)."""


class RowChecker:
    """Checks rows read from a store; counts the rows it leaves out.

    Parameters
    ----------
    where : str
        The store, as messages name it.
    skip_bad : bool
        Leave bad rows out (counted in :attr:`skipped`) instead of refusing.
    """

    def __init__(self, where: str, *, skip_bad: bool = False) -> None:
        self.where, self.skip_bad, self._left_out = where, skip_bad, set()

    @property
    def skipped(self) -> int:
        """Bad rows left out so far (each row of a table counted once)."""
        return len(self._left_out)

    def check(self, rows: list[tuple], spec: tuple) -> list[tuple]:
        """The rows, checked column by column.

        Parameters
        ----------
        rows : list of tuple
            The database driver's rows.
        spec : tuple of (field, table, id column index, kind)
            Per column: its name, its table, the position of that table's id
            in the row, and its kind (:data:`KINDS`); None for a column not
            checked.

        Returns
        -------
        list of tuple
            ``rows``, without the bad ones when skipping.

        Raises
        ------
        BadRowError
            Naming the first bad row (table, id, field, value), unless skipping.
        """
        bad = {}
        for col, item in enumerate(spec):
            if item is None or not rows:
                continue
            name, table, at, kind = item
            values = list(map(itemgetter(col), rows))
            fast = _FAST.get(kind)
            if fast is not None and fast(values):
                continue
            check = KINDS[kind]
            # Each distinct value checked once (a date repeats in every coefficient row).
            if all(check(value) is None for value in set(values)):
                continue
            for i, value in enumerate(values):
                if i not in bad:
                    problem = check(value)
                    if problem is not None:
                        bad[i] = (table, rows[i][at], name, problem)
        if not bad:
            return rows
        if not self.skip_bad:
            first = min(bad)
            table, row_id, name, problem = bad[first]
            more = f" ({len(bad)} bad rows in all)" if len(bad) > 1 else ""
            raise BadRowError(
                f"the records store {self.where} holds a bad row: table {table}, id "
                f"{shown(row_id)}, field {name}: {problem}{more}; it was changed outside "
                "accelcal (--skip-bad leaves such rows out)")
        self._left_out.update((table, row_id) for table, row_id, _, _ in bad.values())
        return [r for i, r in enumerate(rows) if i not in bad]
