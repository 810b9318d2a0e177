"""One coefficient across its renaming in a serial number's history.

A row that estimates a combination the design cannot separate is recorded
under the combination's name (``K_F+K_OO``, ``K0+Kpp``:
:func:`accelcal.identifiability.combination_name`). Calibrations stored
before the rows were so named hold the plain name (``K_F``, ``K0``): both
estimate the same quantity, the older name only said less. The history
groups them under the plain coefficient (the ``coefficient`` column of
:meth:`accelcal.store.Store.history`) and states where the recorded name
changes (:func:`renamings`), so that a repeatability or a drift is taken
across the change and the reader sees it.
"""

from dataclasses import dataclass


@dataclass(frozen=True)
class Renaming:
    """A coefficient recorded under another name from one calibration on.

    Attributes
    ----------
    method : str
        The calibration method (ids of today).
    coefficient : str
        The plain coefficient.
    before, after : str
        The recorded names before and from this calibration.
    date : str
        Date of the first calibration recorded as ``after``.
    id : int
        Its calibration id in the store.
    """

    method: str
    coefficient: str
    before: str
    after: str
    date: str
    id: int

    def text(self) -> str:
        """One sentence for the user."""
        return (f"{self.coefficient} ({self.method}) is recorded as {self.after} from "
                f"{self.date[:10]} (calibration {self.id}) on, as {self.before} before: the "
                f"same coefficient, {_why(self.before, self.after)}")


def _why(before: str, after: str) -> str:
    if after != before and after.startswith(before):
        return f"the newer name states the terms it includes ({after[len(before):]})"
    if before.startswith(after):
        return f"the older name stated the terms it included ({before[len(after):]})"
    return "named differently"


def renamings(rows) -> list[Renaming]:
    """Every change of the recorded name of a (method, coefficient), in date order.

    Parameters
    ----------
    rows : list of dict or dict of list
        :meth:`~accelcal.store.Store.history` rows or
        :meth:`~accelcal.store.Store.history_columns` columns (date order).

    Returns
    -------
    list of Renaming
    """
    if isinstance(rows, dict):
        # a long history (300k rows) without a renaming: found from its distinct names
        if rows["name"] == rows["coefficient"]:
            return []  # every row under its plain name
        seen = set(zip(rows["method"], rows["coefficient"], rows["name"], strict=True))
        if len(seen) == len({(m, c) for m, c, _ in seen}):
            return []
        keys = ("id", "date", "method", "name", "coefficient")
        items = zip(*(rows[k] for k in keys), strict=True)
    else:
        items = ((r["id"], r["date"], r["method"], r["name"], r["coefficient"]) for r in rows)
    last: dict[tuple[str, str], str] = {}
    out = []
    for cal_id, date, method, name, coefficient in items:
        key = (method, coefficient)
        before = last.get(key)
        if before is not None and before != name:
            out.append(Renaming(method, coefficient, before, name, str(date), int(cal_id)))
        last[key] = name
    return out


def plain_names():
    """``name -> plain coefficient`` (:func:`accelcal.identifiability.plain_name`), cached.

    A history repeats a handful of names over many rows.
    """
    from functools import lru_cache

    from accelcal.identifiability import plain_name

    return lru_cache(maxsize=None)(plain_name)
