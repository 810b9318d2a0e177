"""Gaps in the time column of a record made of steps or plateaus, refused or repaired.

A record of a stepped test (a response record's frequency steps, a thermal
record's soaks and tumbles) holds runs of rows that belong together: the
rows of one step, one plateau, one tumble position. Its time column may jump
*between* runs (the test moved on; the rows before and after belong to
different runs): that is harmless, and never looked at. A jump *inside* a
run (a step of the time column over
:data:`~accelcal.io.recordings.checks.GAP_FACTOR` nominal intervals while
the run's keys stay the same) is a gap: samples are missing, and a method
that takes the run's samples as consecutive would be wrong. Following
``gaps`` (the ``--gaps`` option of the commands that read recordings):

- ``refuse`` (default): one line naming the file, the run and the data row;
- ``split``: the run is cut at its gaps and one piece kept (``keep``: the
  ``last``, where a soak has settled, or the ``longest``, for a fit over
  consecutive samples); the other rows are left out;
- ``fill``: the missing samples (at most ``max_fill`` per gap) are linear
  interpolations of the rows either side, on the nominal grid (refused
  where a method's signal is not linear between samples: ``fillable``).

What was found and done is returned as the dict of
:meth:`accelcal.io.recordings.repairs.Repairs.to_dict` (built here: this module
is a leaf of the io floor, which the recordings' checks take
:data:`GAP_FACTOR` from).

References
----------
.. [IEEE1057] IEEE Std 1057-2017, sec. 4.1 (a record is a sequence of samples
   at a nominal sampling interval: a gap breaks it).
"""

import math

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.validation import shown, shown_name

GAP_FACTOR = 1.5
"""A step of the time column over this many nominal intervals is a gap (records and
recordings alike: :mod:`accelcal.io.recordings.checks` takes it from here, so that
reading a record does not load the recordings layer)."""

KEEP = ("last", "longest")
"""Which piece of a run cut at its gaps is kept."""


def check_gap_options(gaps: str, max_fill: int) -> None:
    """Refuse an unknown ``gaps`` or a ``max_fill`` that is not 1 to 1,000,000 samples."""
    if gaps not in ("refuse", "split", "fill"):
        raise AccelcalError(f"gaps {shown(gaps)} is not known; use refuse, split or fill",
                            parameter="gaps")
    if isinstance(max_fill, bool) or not isinstance(max_fill, int | np.integer) or not (
            1 <= max_fill <= 1_000_000):
        raise AccelcalError(f"max_fill {shown(max_fill)} must be a whole number of samples, "
                            "1 to 1000000", parameter="max_fill")


def repair_gaps(columns: dict, *, where, keys=(), time: str = "t",
                interval: float | None = None, gaps: str = "refuse",
                max_fill: int = 5, keep: str = "last", what: str = "plateau",
                fillable: str | None = None, hint: str | None = None) -> tuple:
    """The record's columns with the gaps inside its runs refused, cut or filled.

    Parameters
    ----------
    columns : dict of str to numpy.ndarray
        The record's columns (equal lengths), ``time`` among them (s).
    where : str or path-like
        The file, for messages.
    keys : sequence of str
        Columns whose values name a run (e.g. ``step``; ``phase, plateau,
        angle``): a run is a stretch of rows with the same keys.
    time : str
        The time column.
    interval : float, optional
        The nominal sample interval, s; default the median step inside runs.
    gaps : {"refuse", "split", "fill"}
        What to do with a gap inside a run (module docs).
    max_fill : int
        Most missing samples one gap may have to be filled.
    keep : {"last", "longest"}
        The piece of a cut run kept.
    what : str
        What a run is called (``plateau``, ``step``), in messages and notes.
    fillable : str, optional
        Why ``fill`` is refused for this record (None: it is allowed).
    hint : str, optional
        What to do, for a reader that offers no repair (default: the options).

    Returns
    -------
    columns : dict
        Repaired (the input itself when no gap was found).
    repairs : dict or None
        What was found and done, as ``Repairs.to_dict()`` (None when no gap
        was found).

    Raises
    ------
    AccelcalError
        One line: a gap with ``refuse``, a gap longer than ``max_fill`` or
        refused ``fill``.
    """
    check_gap_options(gaps, max_fill)
    if keep not in KEEP:
        raise AccelcalError(f"keep {shown(keep)} is not last or longest", parameter="keep")
    t = np.asarray(columns[time], dtype=float)
    if t.size < 3:
        return columns, None
    same = np.ones(t.size - 1, dtype=bool)
    for k in keys:
        same &= columns[k][1:] == columns[k][:-1]
    with np.errstate(over="ignore", invalid="ignore"):  # times near the float range
        steps = np.diff(t)
    if interval is None:
        if not same.any():
            return columns, None
        interval = float(np.median(steps[same]))
    if not (math.isfinite(interval) and interval > 0):
        return columns, None  # no regular sampling to measure a gap by: the reader's checks
    gap = same & (steps > GAP_FACTOR * interval)
    if not gap.any():
        return columns, None
    at = np.flatnonzero(gap)
    rows = at + 2  # the data row after each gap (1-based)
    with np.errstate(over="ignore", invalid="ignore"):
        ratio = np.nan_to_num(steps[gap] / interval, nan=2.0**62, posinf=2.0**62)
    missing = np.rint(np.minimum(ratio, 2.0**62)).astype(np.int64) - 1
    if gaps == "refuse" or (gaps == "fill" and fillable):
        k = int(at[0])
        run = "".join(f" {c} {columns[c][k]:g}" for c in keys)
        hint = hint or (
            f"give --gaps split (the {what} is cut at the gap, its {keep} piece kept)"
            + (f"; --gaps fill does not apply: {fillable}" if fillable else
               " or --gaps fill (at most --max-fill missing samples interpolated)"))
        between = f"a jump between {what}s is harmless, one inside a {what} is a gap: " \
            if keys else "a gap: "
        raise AccelcalError(
            f"{where}: time column {shown_name(time)} jumps {steps[k]:.6g} s (about "
            f"{missing[0]} samples missing) inside {what}{run} at data row {rows[0]}; "
            f"{between}{hint}")
    label = f"gaps inside a {what}"
    if gaps == "fill":
        over = missing > max_fill
        if over.any():
            raise AccelcalError(
                f"{where}: a gap of {missing[over][0]} missing samples before data row "
                f"{rows[over][0]} is longer than --max-fill {max_fill}; give --gaps split or "
                "a larger --max-fill")
        return _filled(columns, t, at, missing), {"found": [
            finding(label, "filled by linear interpolation on the nominal grid (flagged)",
                    rows),
            finding(f"samples filled in the gaps inside a {what}", "linear interpolation "
                    "between the rows either side", rows, int(missing.sum()))]}
    run_start = np.r_[0, np.flatnonzero(~same) + 1]
    run_stop = np.r_[run_start[1:], t.size]
    drop = np.zeros(t.size, dtype=bool)
    for a, b in zip(run_start, run_stop, strict=True):
        cuts = at[(at >= a) & (at < b - 1)] + 1
        if not cuts.size:
            continue
        bounds = np.r_[a, cuts, b]
        lengths = np.diff(bounds)
        piece = len(lengths) - 1 if keep == "last" else int(np.argmax(lengths))
        drop[a:b] = True
        drop[bounds[piece]:bounds[piece + 1]] = False
    left_out = np.flatnonzero(drop) + 1
    return {c: np.asarray(v)[~drop] for c, v in columns.items()}, {"found": [
        finding(label, f"the {what} cut at the gap, its {keep} piece kept", rows),
        finding(f"rows of a {what} cut at a gap", "left out", left_out)]}


def finding(what: str, action: str, rows, count: int | None = None) -> dict:
    """One finding as ``Repairs.to_dict()`` lists it.

    ``count`` (default: one per row) and the first five ``rows`` (data rows, 1-based).
    """
    rows = [int(r) for r in np.atleast_1d(rows)]
    return {"found": what, "count": len(rows) if count is None else int(count),
            "first_rows": rows[:5], "action": action}


def _filled(columns: dict, t, at, missing) -> dict:
    """The columns with ``missing[i]`` rows linearly interpolated after row ``at[i]``.

    A run's keys are equal either side of its gaps, so they interpolate to themselves.
    """
    index = np.arange(t.size, dtype=float)
    extra = np.concatenate([k + np.arange(1, m + 1) / (m + 1)
                            for k, m in zip(at, missing, strict=True)])
    where = np.sort(np.r_[index, extra])
    return {c: np.interp(where, index, np.asarray(v, dtype=float)) for c, v in columns.items()}


def merged(items) -> dict | None:
    """The repairs of several records, ``(name, Repairs.to_dict() or None)`` pairs, as one.

    One record's are its own; several records' findings are named with their file.
    """
    items = [(name, found) for name, found in items if found]
    if len(items) < 2:
        return items[0][1] if items else None
    return {"found": [{**f, "found": f"{f['found']} ({name})"} for name, found in items
                      for f in found.get("found", [])]}
