"""Messy time columns, found and repaired only as the user says, block by block.

A lab's recording may hold what a record may not: missing samples (a gap in
the time column, or a run of empty or NaN cells), duplicated rows, times
that go backwards, and jitter of the sample clock. :class:`TimeRepair`
looks at each block of a recording as it is read and, following the
:class:`~accelcal.io.recordings.options.InputOptions`:

- **missing values** (a row with an empty or NaN cell): refused with the
  column and row (``gaps="refuse"``, as before), or the row is dropped and
  the hole it leaves is a gap, split or filled as below;
- **duplicated rows** (the same time twice): identical rows are dropped;
  rows that differ at one time are refused (no one can tell which is right);
- **backwards times**: refused with the row, or, with ``sort``, the rows of
  the block are sorted by time (a step back beyond the block before is
  refused: a stream cannot reach back);
- **gaps** (a step over :data:`~accelcal.io.recordings.checks.GAP_FACTOR`
  nominal intervals): ``refuse``; ``split`` (the rows are kept and the
  recording is cut into segments at each gap: :attr:`Repairs.segments`); or
  ``fill`` (the missing samples, at most ``max_fill`` per gap, are linear
  interpolations of the samples either side, and flagged);
- **jitter** (a step off the nominal interval by more than ``jitter_tol``
  of it): refused, or with ``resample`` every channel is linearly
  interpolated onto the uniform grid ``k / rate`` from the first sample;
- **clipped samples** (with ``rails``: runs of :data:`MIN_RUN` or more at or
  beyond a rail, found within a block): refused, or left out with
  ``gaps="split"`` (never filled); a triad calibration finds them itself and
  leaves them out of its static intervals
  (:class:`accelcal.signal.clipping.ClipFinder`).

Nothing is repaired silently: every finding is counted, with its first rows
(data rows of the file, 1-based after the header), in a :class:`Repairs`
that goes into the provenance and is printed by the commands as ``note:``
lines.

References
----------
.. [IEEE1057] IEEE Std 1057-2017, sec. 4.1 (a record is a sequence of samples
   at a nominal sampling interval).
.. [IEEE952] IEEE Std 952-1997, annex C (Allan variance from sums of squared
   differences; with gaps, only differences within a segment are summed).
"""

from dataclasses import dataclass, field

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.recordings.checks import GAP_FACTOR
from accelcal.validation import shown_name

GAPS = ("refuse", "split", "fill")
"""What to do at a gap: refuse it, split the recording into segments, fill it."""

MAX_FILL = 5
"""Default largest number of missing samples one gap may have to be filled."""

MIN_RUN = 3
"""Fewest consecutive samples at a rail that make a clip (as :mod:`accelcal.signal.clipping`)."""

FIRST = 5
"""How many positions of each finding are kept."""


@dataclass
class Finding:
    """One kind of thing found: how many, where first (data rows), and what was done."""

    what: str
    action: str
    count: int = 0
    rows: list = field(default_factory=list)

    def to_dict(self) -> dict:
        """JSON-ready."""
        return {"found": self.what, "count": self.count, "first_rows": list(self.rows),
                "action": self.action}

    def note(self) -> str:
        """One line: what, how many, where first, what was done."""
        where = ", ".join(str(r) for r in self.rows)
        more = ", ..." if len(self.rows) == FIRST and self.count > FIRST else ""
        return f"{self.count} {self.what} (data rows {where}{more}): {self.action}"


@dataclass
class Repairs:
    """What was found in a recording and what was done about it.

    ``findings`` in the order first met; ``segments``: ``(start, stop)``
    sample ranges (stop exclusive) of the samples read, cut at gaps when
    they were split (one segment otherwise).
    """

    findings: dict = field(default_factory=dict)
    segments: list = field(default_factory=list)

    def add(self, what: str, action: str, rows, count: int | None = None) -> None:
        """Count ``rows`` (data rows of the file) as ``what``, done ``action``.

        ``count``: how many were found, when not one per row.
        """
        rows = [int(r) for r in np.atleast_1d(rows)]
        if not rows:
            return
        item = self.findings.setdefault(what, Finding(what, action))
        item.count += len(rows) if count is None else int(count)
        item.rows.extend(rows[:FIRST - len(item.rows)] if len(item.rows) < FIRST else [])

    def to_dict(self) -> dict:
        """JSON-ready: the findings, and the segments when there are several."""
        out = {"found": [f.to_dict() for f in self.findings.values()]}
        if len(self.segments) > 1:
            out["segments"] = [list(s) for s in self.segments]
        return out

    @classmethod
    def from_dict(cls, doc: dict) -> "Repairs":
        """The :class:`Repairs` of :meth:`to_dict` (a record's provenance)."""
        out = cls()
        for f in doc.get("found", []):
            out.findings[f["found"]] = Finding(f["found"], f["action"], f["count"],
                                               list(f["first_rows"]))
        out.segments = [tuple(s) for s in doc.get("segments", [])]
        return out

    def notes(self) -> list[str]:
        """``note:`` lines for a command's standard error."""
        lines = [f"note: {f.note()}" for f in self.findings.values()]
        if len(self.segments) > 1:
            lines.append(f"note: {len(self.segments)} segments (samples "
                         + ", ".join(f"{a}-{b}" for a, b in self.segments[:FIRST])
                         + (", ..." if len(self.segments) > FIRST else "") + ")")
        return lines

    def __bool__(self) -> bool:
        return bool(self.findings) or len(self.segments) > 1


def with_repairs(reduction, found: dict | None):
    """``reduction`` with the repairs ``found`` in its provenance and notes.

    ``found``: :meth:`Repairs.to_dict`, kept as the provenance's ``repairs``;
    the reduction itself when there were none.
    """
    if not found:
        return reduction
    import dataclasses

    return dataclasses.replace(
        reduction, provenance={**reduction.provenance, "repairs": found},
        notes=(*reduction.notes,
               *(n.removeprefix("note: ") for n in Repairs.from_dict(found).notes())))


class TimeRepair:
    """The state of the repairs across the blocks of one recording.

    Parameters
    ----------
    options : InputOptions
        ``gaps``, ``max_fill``, ``sort``, ``jitter_tol``, ``resample``.
    rate : float or None
        The nominal rate (given, or the file's); None: the median step of the
        first block.
    name, column : str
        The file and its time column, for messages.
    repairs : Repairs
        Where findings are counted.
    """

    def __init__(self, options, rate, name: str, column: str | None, repairs: Repairs):
        self.gaps, self.max_fill = options.gaps, options.max_fill
        self.sort, self.jitter_tol, self.resample = (options.sort, options.jitter_tol,
                                                     options.resample)
        self.interval = None if rate is None else 1.0 / rate
        self.rails = options.rails
        self.name, self.column, self.repairs = name, shown_name(column or "time"), repairs
        self.last_t = self.last_v = self.last_label = None
        self.out = 0          # samples yielded so far
        self.segment = 0      # first sample of the current segment
        self.grid = 0         # next grid index (resample)
        self.preset = None    # the segments a record states

    def block(self, time, values, labels, start: int):
        """The block's ``(time, values, labels)`` repaired; ``time`` None for a rate-only file."""
        timed = time is not None
        plain = (self.gaps == "refuse" and self.jitter_tol is None and self.preset is None
                 and self.rails is None)
        if plain and not timed:
            return None, values, labels  # nothing to look at: the block checks do the rest
        if plain and time.size and (self.last_t is None or time[0] > self.last_t) and (
                np.diff(time) > 0).all():
            return self._emit(timed, time, values, labels)  # in order, no duplicate
        rows = start + 1 + np.arange(values.shape[0])
        t = time if timed else (start + np.arange(values.shape[0])) * (self.interval or 1.0)
        if self.rails is not None:
            t, values, labels, rows = self._clipped(t, values, labels, rows)
        if self.gaps != "refuse":
            bad = ~np.isfinite(values).all(axis=1)
            if bad.any():
                self.repairs.add("rows with an empty or NaN cell", "dropped; the hole is "
                                 f"a gap ({self.gaps})", rows[bad])
                keep = ~bad
                t, values, rows = t[keep], values[keep], rows[keep]
                labels = None if labels is None else labels[keep]
        if timed:
            t, values, labels, rows = self._order(t, values, labels, rows)
        if t.size == 0:
            return _out(timed, t, values, labels)
        if plain:  # duplicates and order only
            return self._emit(timed, t, values, labels)
        if self.interval is None:
            full = t if self.last_t is None else np.r_[self.last_t, t]
            if full.size < 2:
                return self._emit(timed, t, values, labels)
            self.interval = float(np.median(np.diff(full)))
        steps = np.diff(t if self.last_t is None else np.r_[self.last_t, t])
        after = rows if self.last_t is not None else rows[1:]
        gap = steps > GAP_FACTOR * self.interval
        missing = np.rint(steps[gap] / self.interval).astype(int) - 1
        if gap.any() and self.gaps != "refuse":  # refused by the block checks, if at all
            self.repairs.add("gaps", "split into segments" if self.gaps == "split" else
                             "filled by linear interpolation", after[gap])
            if self.gaps == "fill":
                self._check_fill(missing, after[gap])
                self.repairs.add("samples filled in the gaps before",
                                 "linear interpolation between the samples either side "
                                 "(flagged)", after[gap], missing.sum())
        if timed and self.jitter_tol is not None:
            rel = np.abs(steps[~gap] / self.interval - 1.0)
            over = rel > self.jitter_tol
            if over.any():
                k = int(np.flatnonzero(over)[0])
                if not self.resample:
                    raise AccelcalError(
                        f"{self.name}: time column {self.column} steps {steps[~gap][k]:.9g} s "
                        f"at data row {after[~gap][k]} ({rel[k]:.3g} of the interval "
                        f"{self.interval:.9g} s off, over --jitter-tol {self.jitter_tol:g}); "
                        "give --resample to interpolate onto a uniform grid")
                self.repairs.add("jittered intervals", f"resampled onto the {1 / self.interval:.6g}"
                                 " Hz grid by linear interpolation", after[~gap][over])
        if self.resample and timed:
            return self._resample(t, values, labels, gap)
        if gap.any() and self.gaps == "fill":
            t, values, labels = self._fill(t, values, labels, gap, steps)
        elif gap.any() and self.gaps == "split":
            for pos in np.flatnonzero(gap):
                self._cut(self.out + pos + (0 if self.last_t is not None else 1))
        return self._emit(timed, t, values, labels)

    def _clipped(self, t, values, labels, rows):
        """Rows where a channel is in a run of :data:`MIN_RUN` or more at or beyond a rail."""
        low, high = self.rails
        with np.errstate(invalid="ignore"):  # a NaN is at no rail
            at = (values <= low) | (values >= high)
        clip = np.zeros(values.shape[0], dtype=bool)
        for j in range(values.shape[1]):
            edges = np.diff(np.r_[0, at[:, j].astype(np.int8), 0])
            for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1),
                            strict=True):
                if b - a >= MIN_RUN:
                    clip[a:b] = True
        if not clip.any():
            return t, values, labels, rows
        first = int(np.flatnonzero(clip)[0])
        if self.gaps != "split":
            raise AccelcalError(
                f"{self.name}: {int(clip.sum())} samples clipped at the rails {low:g}, {high:g} "
                f"from data row {rows[first]}; give --gaps split to leave them out (a clipped "
                "sample is not filled: the signal beyond the rail is unknown)")
        self.repairs.add(f"clipped samples (runs of {MIN_RUN} or more at a rail)",
                         "left out; the hole is a gap (split)", rows[clip])
        keep = ~clip
        return t[keep], values[keep], None if labels is None else labels[keep], rows[keep]

    def stated(self, segments) -> None:
        """Take the segments an accelcal record states (split on import); refused unless split."""
        if self.gaps != "split":
            raise AccelcalError(
                f"{self.name}: the record holds {len(segments)} segments (its recording was "
                "split at gaps on import); give --gaps split (deviations are pooled over "
                "segments)")
        self.preset = [(int(a), int(b)) for a, b in segments]

    def finish(self) -> None:
        """Close the last segment (or take the record's own)."""
        if self.preset:
            if self.preset[-1][1] != self.out:
                raise AccelcalError(f"{self.name}: its segments end at sample "
                                    f"{self.preset[-1][1]}, but it holds {self.out} samples")
            self.repairs.segments = list(self.preset)
            return
        self._cut(self.out)

    def _order(self, t, values, labels, rows):
        full = t if self.last_t is None else np.r_[self.last_t, t]
        steps = np.diff(full)
        back = steps < 0
        if back.any():
            k = int(np.flatnonzero(back)[0])
            row = rows[k if self.last_t is not None else k + 1]
            if not self.sort:
                raise AccelcalError(
                    f"{self.name}: time column {self.column} goes backwards at data row {row} "
                    f"({full[k + 1]:.9g} s after {full[k]:.9g} s); give --sort to sort the "
                    "rows by time")
            if self.last_t is not None and t.min() < self.last_t:
                raise AccelcalError(
                    f"{self.name}: time column {self.column} goes back at data row {row} "
                    "before the rows already read; sort the file by time")
            order = np.argsort(t, kind="stable")
            self.repairs.add("rows out of time order", "sorted by time",
                             rows[np.flatnonzero(back) + (0 if self.last_t is not None else 1)])
            t, values, rows = t[order], values[order], rows[order]
            labels = None if labels is None else labels[order]
            full = t if self.last_t is None else np.r_[self.last_t, t]
            steps = np.diff(full)
        same = np.flatnonzero(steps == 0)
        if same.size:
            fullv = values if self.last_v is None else np.vstack([self.last_v, values])
            offset = 0 if self.last_t is not None else 1
            differ = ~(fullv[same] == fullv[same + 1]).all(axis=1)
            if differ.any():
                k = int(same[differ][0])
                raise AccelcalError(
                    f"{self.name}: time column {self.column} repeats {full[k + 1]:.9g} s at "
                    f"data row {rows[k + 1 - (1 - offset)]} with different values; remove one "
                    "of the two rows")
            drop = same + 1 - (1 - offset)
            self.repairs.add("duplicated rows (same time, same values)", "dropped", rows[drop])
            keep = np.ones(t.size, dtype=bool)
            keep[drop] = False
            t, values, rows = t[keep], values[keep], rows[keep]
            labels = None if labels is None else labels[keep]
        return t, values, labels, rows

    def _check_fill(self, missing, rows) -> None:
        over = missing > self.max_fill
        if over.any():
            raise AccelcalError(
                f"{self.name}: a gap of {missing[over][0]} missing samples before data row "
                f"{rows[over][0]} is longer than --max-fill {self.max_fill}; give --gaps split "
                "or a larger --max-fill")

    def _fill(self, t, values, labels, gap, steps):
        full_t = t if self.last_t is None else np.r_[self.last_t, t]
        full_v = values if self.last_v is None else np.vstack([self.last_v, values])
        pieces_t, pieces_v, pieces_l = [], [], []
        prev = 0
        head = 0 if self.last_t is None else 1  # rows of full before the block's own
        for k in np.flatnonzero(gap):
            m = int(np.rint(steps[k] / self.interval)) - 1
            new_t = full_t[k] + (full_t[k + 1] - full_t[k]) * np.arange(1, m + 1) / (m + 1)
            frac = (np.arange(1, m + 1) / (m + 1))[:, None]
            new_v = full_v[k] + (full_v[k + 1] - full_v[k]) * frac
            cut = k + 1 - head
            pieces_t += [t[prev:cut], new_t]
            pieces_v += [values[prev:cut], new_v]
            if labels is not None:
                lab = labels[cut - 1] if cut > 0 else self.last_label
                pieces_l += [labels[prev:cut], np.repeat(np.asarray([lab]), m)]
            prev = cut
        pieces_t.append(t[prev:])
        pieces_v.append(values[prev:])
        if labels is not None:
            pieces_l.append(labels[prev:])
            labels = np.concatenate(pieces_l)
        return np.concatenate(pieces_t), np.vstack(pieces_v), labels

    def _resample(self, t, values, labels, gap):
        full_t = t if self.last_t is None else np.r_[self.last_t, t]
        full_v = values if self.last_v is None else np.vstack([self.last_v, values])
        stop = int(np.floor(full_t[-1] / self.interval + 1e-9)) + 1
        grid = np.arange(self.grid, stop) * self.interval
        if grid.size == 0:
            self.last_t, self.last_v = t[-1], values[-1]
            return grid, values[:0], None if labels is None else labels[:0]
        at = np.clip(np.searchsorted(full_t, grid, side="right") - 1, 0, full_t.size - 2)
        inside = np.ones(grid.size, dtype=bool)
        if gap.any() and full_t.size > 1 and self.gaps != "fill":  # fill: the grid spans gaps
            near = 1e-9 * self.interval  # a grid point on a sample either side of a gap is kept
            inside = (~gap[at] | np.isclose(grid, full_t[at], rtol=0, atol=near)
                      | np.isclose(grid, full_t[at + 1], rtol=0, atol=near))
            if self.gaps == "split":
                for pos in np.flatnonzero(np.diff(inside.astype(int)) == 1):
                    self._cut(self.out + int(inside[:pos + 1].sum()))
        grid = grid[inside]
        new = np.column_stack([np.interp(grid, full_t, full_v[:, j])
                               for j in range(full_v.shape[1])])
        lab = None
        if labels is not None:
            full_l = labels if self.last_label is None else np.r_[[self.last_label], labels]
            head = full_l.size - full_t.size
            lab = full_l[np.clip(np.searchsorted(full_t, grid, side="right") - 1 + head, 0,
                                 full_l.size - 1)]
        self.grid = stop
        self.last_t, self.last_v = t[-1], values[-1]
        self.last_label = None if labels is None else labels[-1]
        self.out += grid.size
        return grid, new, lab

    def _cut(self, at: int) -> None:
        if at > self.segment:
            self.repairs.segments.append((int(self.segment), int(at)))
            self.segment = at

    def _emit(self, timed, t, values, labels):
        if t.size:
            self.last_t, self.last_v = t[-1], values[-1]
            self.last_label = None if labels is None else labels[-1]
        self.out += t.size
        return _out(timed, t, values, labels)


def _out(timed, t, values, labels):
    return (t if timed else None), values, labels
