"""Record files: columns of numbers with JSON metadata, in one CSV or Parquet file.

CSV layout (``format_version`` 1)::

    # accelcal record
    # {"format_version": 1, "kind": "vibrafuge", "units": {"t": "s", ...}, ...}
    t,static,vibrating
    0.0,1.2993,1.3012
    ...

The first line marks the file; the second holds the metadata as one line of
JSON after ``# ``; then a CSV header and the rows. ``kind`` names the test
(``vibrafuge``, ``shaker``, ``dividing-head``, ...); each method documents
the other metadata fields and the columns it needs. ``units`` gives the unit
of every column.

A file whose name ends in ``.parquet`` is written and read as Apache Parquet
instead: the same columns (float64), and the same metadata JSON stored
under the key ``accelcal`` of the file's schema metadata.

Readers check the marker, the JSON, ``format_version``, ``kind``, the
required metadata fields and columns, and that every value is a finite
number; errors name the file, the line or column, and what was expected.
Writers write atomically.
"""

import json
import math
from pathlib import Path

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.atomic import atomic_path

MARKER = "# accelcal record"
FORMAT_VERSION = 1


def write_record(path, kind: str, metadata: dict, columns: dict[str, np.ndarray]) -> None:
    """Write a record file atomically.

    Parameters
    ----------
    path : path-like
        File to write.
    kind : str
        The test the record belongs to.
    metadata : dict
        JSON-serialisable metadata; must include ``units`` for every column.
    columns : dict of str to array_like
        Equal-length 1-D columns, written in this order with full precision.

    Raises
    ------
    AccelcalError
        For unequal column lengths or a missing unit.
    """
    names = list(columns)
    arrays = [np.asarray(columns[n], dtype=float).reshape(-1) for n in names]
    lengths = {a.size for a in arrays}
    if len(lengths) > 1:
        raise AccelcalError(f"record columns have different lengths: {sorted(lengths)}")
    units = metadata.get("units", {})
    missing = [n for n in names if n not in units]
    if missing:
        raise AccelcalError(f"record metadata gives no unit for column(s) {', '.join(missing)}")
    header = {"format_version": FORMAT_VERSION, "kind": kind, **metadata}
    if _is_parquet(path):
        _write_parquet(path, header, dict(zip(names, arrays, strict=True)))
        return
    table = np.column_stack(arrays) if arrays else np.empty((0, 0))
    with atomic_path(path) as tmp, open(tmp, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(MARKER + "\n")
        fh.write("# " + json.dumps(header, allow_nan=False) + "\n")
        fh.write(",".join(names) + "\n")
        np.savetxt(fh, table, delimiter=",", fmt="%.17g")


def read_record(
    path, kind: str, *, required_metadata=(), required_columns=()
) -> tuple[dict, dict[str, np.ndarray]]:
    """Read and validate a record file.

    Parameters
    ----------
    path : path-like
        File to read.
    kind : str
        Expected ``kind``.
    required_metadata : iterable of str
        Metadata fields that must be present.
    required_columns : iterable of str
        Columns that must be present.

    Returns
    -------
    metadata : dict
        The metadata (with ``format_version`` and ``kind``).
    columns : dict of str to numpy.ndarray
        Every column as float64.

    Raises
    ------
    AccelcalError
        Naming the file and what is wrong.
    """
    path = Path(path)
    if _is_parquet(path):
        meta, names, data = _read_parquet(path)
    else:
        meta, names, data = _read_csv(path)
    version = meta.get("format_version")
    if version != FORMAT_VERSION:
        raise AccelcalError(
            f"{path}: format_version {version!r} is not supported (expected {FORMAT_VERSION})"
        )
    if meta.get("kind") != kind:
        raise AccelcalError(f"{path}: kind is {meta.get('kind')!r}, expected {kind!r}")
    missing = [k for k in required_metadata if k not in meta]
    if missing:
        raise AccelcalError(f"{path}: metadata lacks {', '.join(missing)}")
    missing = [c for c in required_columns if c not in names]
    if missing:
        raise AccelcalError(
            f"{path}: missing column(s) {', '.join(missing)}; found {', '.join(names) or 'none'}"
        )
    return meta, {n: data[:, i].copy() for i, n in enumerate(names)}


def _read_csv(path: Path) -> tuple[dict, list[str], np.ndarray]:
    """Metadata, column names and data of a CSV record (structure checks only)."""
    try:
        with open(path, encoding="utf-8") as fh:
            marker = fh.readline().rstrip("\r\n")
            meta_line = fh.readline().rstrip("\r\n")
            header_line = fh.readline().rstrip("\r\n")
            body = fh.read()
    except FileNotFoundError:
        raise AccelcalError(f"record file {path} not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise AccelcalError(f"cannot read record file {path}: {exc}") from None
    if marker != MARKER:
        raise AccelcalError(f"{path}: line 1 should be {MARKER!r}; is this an accelcal record?")
    if not meta_line.startswith("# "):
        raise AccelcalError(f"{path}: line 2 should be '# ' followed by the JSON metadata")
    meta = parse_metadata(meta_line[2:], f"{path}: line 2 metadata")
    names = [n.strip() for n in header_line.split(",")] if header_line.strip() else []
    _check_names(names, f"{path}: line 3 column names {header_line!r}")
    rows = [line for line in body.splitlines() if line.strip()]
    if not rows:
        raise AccelcalError(f"{path}: the record has no data rows")
    try:
        data = np.array(",".join(rows).split(","), dtype=float).reshape(len(rows), len(names))
        ok = bool(np.isfinite(data).all())
    except ValueError:
        ok = False
    if not ok:
        _raise_first_bad_cell(path, rows, names)
    return meta, names, data


def _read_parquet(path: Path) -> tuple[dict, list[str], np.ndarray]:
    """Metadata, column names and data of a Parquet record."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        table = pq.read_table(path)
    except FileNotFoundError:
        raise AccelcalError(f"record file {path} not found") from None
    except (OSError, pa.ArrowException) as exc:
        raise AccelcalError(f"cannot read Parquet record {path}: {exc}") from None
    raw = (table.schema.metadata or {}).get(b"accelcal")
    if raw is None:
        raise AccelcalError(f"{path}: no 'accelcal' metadata in the Parquet schema")
    meta = parse_metadata(raw.decode("utf-8", "replace"), f"{path}: Parquet metadata")
    names = list(table.column_names)
    _check_names(names, f"{path}: column names {names!r}")
    if table.num_rows == 0:
        raise AccelcalError(f"{path}: the record has no data rows")
    data = np.empty((table.num_rows, len(names)))
    for i, name in enumerate(names):
        column = table.column(i)
        if not (pa.types.is_floating(column.type) or pa.types.is_integer(column.type)):
            raise AccelcalError(f"{path}: column {name} has type {column.type}, expected numbers")
        if column.null_count:
            raise AccelcalError(f"{path}: column {name} has {column.null_count} missing values")
        data[:, i] = column.to_numpy()
        bad = np.flatnonzero(~np.isfinite(data[:, i]))
        if bad.size:
            raise AccelcalError(f"{path}: row {bad[0]}, column {name}: value is not finite")
    return meta, names, data


def _write_parquet(path, header: dict, columns: dict[str, np.ndarray]) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.table(columns).replace_schema_metadata(
        {"accelcal": json.dumps(header, allow_nan=False)}
    )
    with atomic_path(path) as tmp:
        pq.write_table(table, tmp)


def _is_parquet(path) -> bool:
    return Path(path).suffix.lower() == ".parquet"


def parse_metadata(text: str, where: str) -> dict:
    """Parse a record's metadata JSON (a JSON object); errors name ``where``."""
    try:
        meta = json.loads(text, parse_constant=_no_constant)
    except ValueError as exc:
        raise AccelcalError(f"{where} is not valid JSON ({exc})") from None
    if not isinstance(meta, dict):
        raise AccelcalError(f"{where} must be a JSON object")
    return meta


def _check_names(names: list[str], where: str) -> None:
    if len(set(names)) != len(names) or any(not n for n in names):
        raise AccelcalError(f"{where} are empty or repeated")


def _raise_first_bad_cell(path, rows, names) -> None:
    """Find and report the first malformed row or cell (slow path, errors only)."""
    for r, line in enumerate(rows):
        cells = line.split(",")
        if len(cells) != len(names):
            raise AccelcalError(
                f"{path}: line {r + 4} has {len(cells)} values, expected {len(names)}"
            )
        for c, cell in enumerate(cells):
            try:
                value = float(cell)
            except ValueError:
                raise AccelcalError(
                    f"{path}: line {r + 4}, column {names[c]}: {cell.strip()!r} is not a number"
                ) from None
            if not math.isfinite(value):
                raise AccelcalError(
                    f"{path}: line {r + 4}, column {names[c]}: {cell.strip()!r} is not finite"
                )
    raise AccelcalError(f"{path}: the data rows could not be read")  # pragma: no cover


def _no_constant(name: str):
    raise ValueError(f"{name} is not allowed")
