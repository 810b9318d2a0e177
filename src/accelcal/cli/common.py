"""Helpers shared by the command modules: value grids, model loading, output.

Kept free of numpy at import time; numpy is imported inside the functions.
"""

import csv
import io
import json
import math
import re
import sys
from collections.abc import Sequence
from pathlib import Path

from accelcal.errors import AccelcalError
from accelcal.validation import shown

FORMATS = ("table", "csv", "json")

MAX_GRID_VALUES = 100_000
"""Most values a list or range option may give: far more rows than a table is
read for, yet evaluated and printed in seconds by every command that takes a
grid; a range such as 0:1e12:1 would never end."""

_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_RANGE = re.compile(rf"^\s*({_NUMBER})\s*:\s*({_NUMBER})\s*:\s*({_NUMBER})\s*$")


def parse_number(text: str, what: str) -> float:
    """Parse one finite number; ``what`` names the option in the error."""
    try:
        value = float(text)
    except ValueError:
        raise AccelcalError(f"{what}: {shown(text.strip())} is not a number") from None
    if not math.isfinite(value):
        raise AccelcalError(f"{what}: {shown(text.strip())} is not finite; give a finite number")
    return value


def parse_grid(text: str, what: str) -> list[float]:
    """Parse a list of values: ``1,2,4``, a range ``start:stop:step``, or both.

    A range includes ``stop`` when it falls on the grid (within 1e-9 of a
    step); values are computed as ``start + k * step`` (no accumulated
    rounding). Items are comma separated and may mix numbers and ranges.

    Raises
    ------
    AccelcalError
        For an empty list, a malformed item, a zero step, a step pointing away
        from ``stop``, a non-finite value, or more than :data:`MAX_GRID_VALUES`
        values; the message names ``what``.
    """
    items = [item.strip() for item in text.split(",")]
    if not text.strip() or any(not item for item in items):
        raise AccelcalError(
            f"{what}: {shown(text)} is empty or has an empty item; give numbers or "
            "start:stop:step ranges separated by commas"
        )
    values: list[float] = []
    for item in items:
        if ":" not in item:
            values.append(parse_number(item, what))
            continue
        match = _RANGE.match(item)
        if not match:
            raise AccelcalError(
                f"{what}: {shown(item)} is not a range start:stop:step (e.g. 5:10:1)")
        start, stop, step = (parse_number(g, f"{what}: range {shown(item)}")
                             for g in match.groups())
        if step == 0.0:
            raise AccelcalError(f"{what}: range {shown(item)} has a zero step")
        span = (stop - start) / step
        if span < -1e-9:
            raise AccelcalError(
                f"{what}: range {shown(item)} is empty (the step goes away from stop)"
            )
        count = math.floor(span + 1e-9) + 1 if math.isfinite(span) else math.inf
        if count > MAX_GRID_VALUES - len(values):
            raise AccelcalError(
                f"{what}: range {shown(item)} gives {count:,} values; at most "
                f"{MAX_GRID_VALUES:,} are allowed, give a larger step"
            )
        values.extend(start + k * step for k in range(count))
    if len(values) > MAX_GRID_VALUES:
        raise AccelcalError(
            f"{what}: {len(values):,} values; at most {MAX_GRID_VALUES:,} are allowed")
    return values


def load_model(path: Path | None):
    """The model in ``path``, or the embedded default when ``path`` is None."""
    from accelcal.defaults import default_model
    from accelcal.model import ErrorModel

    return default_model() if path is None else ErrorModel.load(path)


def check_writable(path: Path | None) -> None:
    """Refuse an output that cannot be written before any work is done.

    The writer's own check (:func:`accelcal.io.atomic.check_output`): a
    missing directory, a path that is not a regular file, a name the
    system refuses (too long, a loop of links, no permission).
    """
    from accelcal.io.atomic import check_output

    if path is not None:
        check_output(path)


def check_format(fmt: str) -> str:
    """Validate an output format name."""
    if fmt not in FORMATS:
        raise AccelcalError(f"--format {shown(fmt)} is not one of {', '.join(FORMATS)}")
    return fmt


def render(
    rows: Sequence[dict],
    fmt: str,
    *,
    title: str | None = None,
    headers: dict[str, str] | None = None,
) -> str:
    """Render rows (dicts with the same keys) as CSV, JSON or a readable table.

    CSV and JSON keep full precision (shortest round-trip repr). The table
    is for people: 7 significant digits, except that an ``estimate`` with its
    ``std`` keeps every digit down to a tenth of that uncertainty, which
    shows with two significant digits (:mod:`accelcal.formatting`, GUM
    7.2.6); units with powers and µ; and a reduction's engineering units
    (the ``engineering`` list, in CSV as ``eng_estimate, eng_std, eng_unit``
    of the first unit) as one column, e.g. ``-9.5 ± 0.68 µrad; -1.97 ± 0.14
    arcsec``. A NaN (a quantity that could not be determined) is ``null`` in
    JSON, ``nan`` in CSV and ``n/a`` in the table. ``headers`` relabels
    columns in the table only (e.g. to add units); CSV and JSON keys stay
    machine names.
    """
    check_format(fmt)
    if fmt == "json":
        rows_json = [{k: _json_value(v) for k, v in r.items()} for r in rows]
        return json.dumps(rows_json, indent=2, allow_nan=False) + "\n"
    columns = [c for c in (rows[0] if rows else []) if not isinstance(rows[0][c], list)]
    if fmt == "csv":
        return csv_text({c: [r[c] for r in rows] for c in columns})
    from rich.console import Console
    from rich.table import Table

    if rows and "engineering" in rows[0]:
        columns = [c for c in columns if c not in _ENGINEERING_COLUMNS] + ["engineering"]
    table = Table(title=title, show_lines=False)
    for c in columns:
        label = "engineering units (1 σ)" if c == "engineering" else c
        table.add_column((headers or {}).get(c, label), justify="right")
    for r in rows:
        table.add_row(*[_table_cell(r[c], r.get(_STD_OF.get(c, "")), c) for c in columns])
    buf = io.StringIO()
    Console(file=buf, width=200, force_terminal=False, color_system=None).print(table)
    return buf.getvalue()


def emit(rows: Sequence[dict], fmt: str, **kwargs) -> None:
    """Render rows and write them to standard output."""
    sys.stdout.write(render(rows, fmt, **kwargs))


def emit_columns(columns: dict[str, Sequence], fmt: str, **kwargs) -> None:
    """:func:`emit` of a table held by columns (name -> values, all of one length).

    CSV is formatted straight from the columns (:func:`csv_text`), with no
    row dicts; the other formats (and an empty table) render the rows the
    columns make.
    """
    if fmt == "csv" and any(map(len, columns.values())):
        sys.stdout.write(csv_text(columns))
        return
    emit(rows_of(columns), fmt, **kwargs)


def rows_of(columns: dict[str, Sequence]) -> list[dict]:
    """The rows (dicts) of a table held by columns."""
    names = list(columns)
    return [dict(zip(names, values, strict=True)) for values in zip(*columns.values(), strict=True)]


def _plain(value):
    if hasattr(value, "item"):
        value = value.item()
    if isinstance(value, float) and math.isnan(value):
        return None
    return value


_QUOTED = re.compile(r'[,"\r\n]')
"""A character that makes the csv module quote a field (minimal quoting, ``,`` and ``\n``)."""


def csv_text(columns: dict[str, Sequence]) -> str:
    """CSV text of a table held by columns, byte for byte what ``csv.writer`` gives.

    Column by column: a column of plain floats, ints or strings (no
    character needing quotes) is formatted by C-level ``map`` (``repr`` of
    a float is its shortest round-trip text, ``nan`` for NaN, as
    :func:`_csv_cell`); anything else goes through the csv module
    (:func:`_csv_per_cell`). Some 300,000 rows (``records history`` of a
    long-lived serial) format in a fraction of the per-cell path's time.
    """
    names = list(columns)
    texts = []
    for values in columns.values():
        kinds = set(map(type, values))
        if kinds <= {float, int}:
            texts.append(map(repr, values))
        elif kinds == {str} and _plain_strings(set(values)):
            texts.append(values)
        else:
            texts = None
            break
    if texts is None or len(names) < 2 or not _plain_strings(set(names)):
        return _csv_per_cell(names, zip(*columns.values(), strict=True))
    lines = [",".join(names), *map(",".join, zip(*texts, strict=True))]
    return "\n".join(lines) + "\n"


def _plain_strings(distinct: set) -> bool:
    """Whether strings go into CSV as they are: none empty, none needing quotes."""
    return "" not in distinct and not _QUOTED.search("".join(distinct))


def _csv_per_cell(names: Sequence[str], rows) -> str:
    """CSV text through the csv module, cell by cell (:func:`_csv_cell`); rows of values."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(names)
    for values in rows:
        writer.writerow([_csv_cell(v) for v in values])
    return buf.getvalue()


def _csv_cell(value) -> str:
    kind = type(value)
    if kind is float:  # the common cases first: no per-cell attribute look-ups
        return "nan" if math.isnan(value) else repr(value)
    if kind is str:
        return value
    value = _plain(value)
    if value is None:
        return "nan"
    return repr(value) if isinstance(value, float) else str(value)


_STD_OF = {"estimate": "std", "eng_estimate": "eng_std"}
_ENGINEERING_COLUMNS = ("eng_estimate", "eng_std", "eng_unit")
_STD_COLUMNS = ("std", "eng_std", "type_a", "type_b")
"""Columns of standard uncertainties (or their Type A and Type B parts): two significant
digits in a table."""


def _json_value(value):
    if isinstance(value, list):
        return [_json_value(v) for v in value]
    if isinstance(value, dict):
        return {k: _json_value(v) for k, v in value.items()}
    return _plain(value)


def _table_cell(value, std=None, column: str = "") -> str:
    from accelcal.formatting import format_engineering, format_std, format_unit, format_value

    if column == "engineering":
        return format_engineering(value)
    value = _plain(value)
    if value is None:
        return "n/a"
    if column in ("unit", "eng_unit") and isinstance(value, str):
        return format_unit(value)
    if isinstance(value, float):
        if column in _STD_COLUMNS and math.isfinite(value) and value > 0:
            return format_std(value)
        std = _plain(std)
        if isinstance(std, float) and std > 0:
            return format_value(value, std)
        return f"{value:.7g}"
    return str(value)
