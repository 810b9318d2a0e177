"""The checks every block of a recording passes: finite samples, increasing time, no gap.

Each names the file, the column and the data row (1-based, after the
header), so a user can find the sample in the file; and the regions file
of an imucal session is checked against the samples read.

References
----------
.. [IEEE1057] IEEE Std 1057-2017, sec. 4.1 (a record is a sequence of samples
   at a nominal sampling interval: a gap breaks it).
"""

from pathlib import Path

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.limits import load_json, read_bounded
from accelcal.io.record_gaps import GAP_FACTOR
from accelcal.validation import shown, shown_name

MAX_REGIONS_BYTES = 1 << 20
"""Largest regions JSON read (1 MiB)."""



def check_values(values: np.ndarray, channels, start: int, name: str) -> None:
    """Refuse the first sample that is empty, NaN or infinite (by column and data row).

    The block's sum is NaN or infinite when a sample is, so a block of finite
    samples passes in one pass that makes no array; the samples are searched
    only then (a sum that overflows finds none, and the block passes).
    """
    with np.errstate(over="ignore", invalid="ignore"):
        if np.isfinite(np.add.reduce(values, axis=None)):
            return
    bad = ~np.isfinite(values)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise AccelcalError(
            f"{name}: column {shown_name(channels[col])}, data row {start + row + 1}, "
            "is empty or not a finite number; remove or fill the gap (accelcal does not "
            "average over missing samples)")


def check_gaps(time: np.ndarray, last, start: int, *, interval: float, name: str,
               column: str) -> None:
    """Refuse a step of the time column over :data:`GAP_FACTOR` nominal ``interval`` s."""
    full = time if last is None else np.concatenate(([last], time))
    steps = np.diff(full)
    over = np.flatnonzero(steps > GAP_FACTOR * interval)
    if over.size:
        k = int(over[0])
        row = start + k + (1 if last is None else 0)
        raise AccelcalError(
            f"{name}: time column {shown_name(column)} jumps from {full[k]:.9g} s to "
            f"{full[k + 1]:.9g} s at data row {row + 1} (about {steps[k] / interval - 1:.0f} "
            f"missing samples at {1 / interval:.6g} Hz); a record needs consecutive samples: "
            "split the file at the gap")


def check_finite_time(raw: np.ndarray, start: int, name: str, column: str) -> None:
    """Refuse the first time that is empty or not finite (by data row)."""
    bad = ~np.isfinite(raw)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise AccelcalError(f"{name}: time column {shown_name(column)}, data row "
                            f"{start + row + 1}, is empty or not a finite number")


def check_time(time: np.ndarray, last, start: int, name: str, column: str) -> None:
    """Refuse a time that does not follow the previous one (``last``, from the block before)."""
    check_finite_time(time, start, name, column)
    full = time if last is None else np.concatenate(([last], time))
    steps = np.diff(full)
    if (steps <= 0).any():
        k = int(np.flatnonzero(steps <= 0)[0])
        row = start + k + (1 if last is None else 0)
        verb = "repeats" if steps[k] == 0 else "goes backwards"
        raise AccelcalError(
            f"{name}: time column {shown_name(column)} {verb} at data row {row + 1} "
            f"({full[k + 1]:.9g} s after {full[k]:.9g} s); times must increase")


def regions(path, samples: int) -> dict:
    """Read an imucal regions JSON: label -> (start, stop) within the ``samples`` read."""
    name = shown_name(Path(path).name)
    try:
        data = load_json(read_bounded(path, MAX_REGIONS_BYTES, "regions file").decode("utf-8"),
                         f"regions file {name}")
    except (OSError, UnicodeDecodeError) as exc:
        raise AccelcalError(f"cannot read regions file {name}: {exc.__class__.__name__}",
                            parameter="regions") from None
    if not isinstance(data, dict) or not data:
        raise AccelcalError(f"regions file {name} must hold an object "
                            '{"label": {"start": i, "end": j}, ...}', parameter="regions")
    out = {}
    for label, span in data.items():
        ok = (isinstance(span, dict) and all(isinstance(span.get(k), int)
                                             and not isinstance(span.get(k), bool)
                                             for k in ("start", "end")))
        if not ok or not 0 <= span["start"] < span["end"] <= samples:
            raise AccelcalError(
                f"regions file {name}: region {shown(label)} must be "
                f'{{"start": i, "end": j}} with 0 <= i < j <= {samples} (the samples read)',
                parameter="regions")
        out[str(label)] = (span["start"], span["end"])
    return out
