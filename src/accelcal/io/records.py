"""Record files: columns of numbers with JSON metadata, in one CSV or Parquet file.

CSV layout (``format_version`` 1)::

    # accelcal record
    # {"format_version": 1, "kind": "vibrafuge", "units": {"t": "s", ...}, ...}
    t,static,vibrating
    0.0,1.2993,1.3012
    ...

The first line marks the file; the second holds the metadata as one line of
JSON after ``# ``; then a CSV header and the rows (blank lines are
skipped). ``kind`` names the test (``vibrafuge``, ``shaker``,
``dividing-head``, ...); each method documents the other metadata fields and
the columns it needs. ``units`` gives the unit of every column, one of
:data:`UNITS`.

A file whose name ends in ``.parquet`` is written and read as Apache Parquet
instead: the same columns (float64), and the same metadata JSON stored
under the key ``accelcal`` of the file's schema metadata.

Readers check the marker, the JSON, ``format_version``, ``kind``, the
units, the required metadata fields and columns, and that every value is a
finite number; errors name the file, the line or column, and what was
expected. The data are parsed by Arrow's CSV reader (never split into
Python strings), and what is read is bounded: a file over
:data:`MAX_RECORD_BYTES` or with more than :data:`MAX_RECORD_VALUES` values
is refused before its data are read, and the metadata is bounded as any JSON
(:mod:`accelcal.io.limits`). Writers write atomically.
"""

import json
import math
import os
import stat
from pathlib import Path

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.arrow_numbers import floats
from accelcal.io.atomic import atomic_path
from accelcal.io.limits import MAX_JSON_BYTES, check_regular_file, load_json, read_rest
from accelcal.validation import one_line, shown, shown_name

MARKER = "# accelcal record"
FORMAT_VERSION = 1

UNITS = ("s", "Hz", "deg", "rad", "arcsec", "g", "m/s^2", "V", "mV", "mA", "1", "-", "degC",
         "mT")
"""Units a record column may have: time, frequency, angles, specific force,
the output units, ``1``/``-`` for counts and indices, temperature (degC)
and magnetic field (mT)."""

MAX_RECORD_BYTES = 2**30
"""Largest record file read (1 GiB): about 50 million CSV values, which as
float64 columns take 400 MB; reading one never needs more than about three
times its size in memory."""

MAX_RECORD_VALUES = 50_000_000
"""Most values (rows times columns) a record may hold: 400 MB as float64.
Bounds Parquet files too, whose compressed size says little about it."""

_MAX_HEADER_BYTES = 64 * 1024
"""Longest column-name line of a CSV record."""

_FINITE_NUMBER = r"^\s*[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?\s*$"


def write_record(path, kind: str, metadata: dict, columns: dict[str, np.ndarray], *,
                 flush: bool = True) -> None:
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
        Equal-length 1-D columns, written in this order with full precision
        (every float reads back bit for bit).
    flush : bool
        Flush the file to the disk before it is moved into place
        (:func:`~accelcal.io.atomic.atomic_path`); False for a scratch record
        read back at once and removed.

    Raises
    ------
    AccelcalError
        For unequal column lengths, a missing or unknown unit, or a file
        that cannot be written.
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
    check_units(units, names, "record metadata")
    header = {"format_version": FORMAT_VERSION, "kind": kind, **metadata}
    if _is_parquet(path):
        _write_parquet(path, header, dict(zip(names, arrays, strict=True)), flush=flush)
        return
    preamble = f"{MARKER}\n# {json.dumps(header, allow_nan=False)}\n{','.join(names)}\n"
    with atomic_path(path, flush=flush) as tmp, open(tmp, "wb") as fh:
        fh.write(preamble.encode("utf-8"))
        if names:
            write_rows(fh, names, arrays)


def write_rows(fh, names: list[str], arrays: list[np.ndarray]) -> None:
    """Data rows of a CSV record, appended to ``fh`` (binary) by Arrow's CSV writer.

    For writers that stream a record block by block after its three header
    lines (:func:`write_record` writes them). Each float is written in its
    shortest form that reads back to the same double (``0.1``, ``1e+22``,
    ``-0.0008336632594549993``), so a record round-trips bit for bit;
    non-finite values are written ``nan``/``inf`` (and refused by the
    readers).
    """
    import pyarrow as pa
    from pyarrow import csv

    table = pa.table(dict(zip(names, arrays, strict=True)))
    csv.write_csv(table, fh, csv.WriteOptions(include_header=False, quoting_style="none"))


def read_record(
    path, kind: str, *, required_metadata=(), required_columns=()
) -> tuple[dict, dict[str, np.ndarray]]:
    """Read and validate a record file.

    Parameters
    ----------
    path : path-like
        File to read (at most :data:`MAX_RECORD_BYTES`, at most
        :data:`MAX_RECORD_VALUES` values).
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
    meta, columns = _read_parquet(path) if _is_parquet(path) else _read_csv(path)
    names = list(columns)
    version = meta.get("format_version")
    if isinstance(version, bool) or version != FORMAT_VERSION:
        raise AccelcalError(
            f"{path}: format_version {shown(version)} is not supported (expected {FORMAT_VERSION})"
        )
    if meta.get("kind") != kind:
        raise AccelcalError(f"{path}: kind is {shown(meta.get('kind'))}, expected {kind!r}")
    check_units(meta.get("units"), names, f"{path}: metadata")
    missing = [k for k in required_metadata if k not in meta]
    if missing:
        raise AccelcalError(f"{path}: metadata lacks {', '.join(missing)}")
    missing = [c for c in required_columns if c not in names]
    if missing:
        raise AccelcalError(
            f"{path}: missing column(s) {', '.join(missing)}; found "
            f"{shown_name(', '.join(names), 200) if names else 'none'}"
        )
    return meta, columns


def check_units(units, names, where: str) -> None:
    """Check a record's ``units``: an object giving every column one of :data:`UNITS`.

    Raises
    ------
    AccelcalError
        Naming ``where``, the field and the column.
    """
    if not isinstance(units, dict):
        raise AccelcalError(
            f"{where} 'units' must be an object giving the unit of every column, "
            f"got {shown(units)}"
        )
    for name in names:
        if name not in units:
            raise AccelcalError(f"{where} 'units' gives no unit for column {shown_name(name)}")
        if not isinstance(units[name], str) or units[name] not in UNITS:
            raise AccelcalError(
                f"{where} 'units' of column {shown_name(name)} is {shown(units[name])}, not one of "
                f"{', '.join(UNITS)}"
            )


def parse_metadata(text: str, where: str) -> dict:
    """Parse a record's metadata JSON (a JSON object, bounded); errors name ``where``."""
    meta = load_json(text, where)
    if not isinstance(meta, dict):
        raise AccelcalError(f"{where} must be a JSON object")
    return meta


def csv_preamble(fh, path) -> tuple[dict, str]:
    """The metadata and the column-name line of a CSV record open in binary mode.

    Reads the first three lines only, each bounded (the metadata line by
    :data:`~accelcal.io.limits.MAX_JSON_BYTES`), and leaves ``fh`` at the
    first data row.

    Raises
    ------
    AccelcalError
        For a missing marker, a malformed or over-long line.
    """
    marker = fh.readline(len(MARKER) + 2)
    if marker.rstrip(b"\r\n") != MARKER.encode():
        raise AccelcalError(f"{path}: line 1 should be {MARKER!r}; is this an accelcal record?")
    meta_line = _line(fh, path, 2, MAX_JSON_BYTES + 4)
    if not meta_line.startswith("# "):
        raise AccelcalError(f"{path}: line 2 should be '# ' followed by the JSON metadata")
    meta = parse_metadata(meta_line[2:], f"{path}: line 2 metadata")
    return meta, _line(fh, path, 3, _MAX_HEADER_BYTES)


def parquet_metadata(schema_metadata, path) -> dict:
    """The metadata of a Parquet record from its schema's key-value metadata."""
    raw = (schema_metadata or {}).get(b"accelcal")
    if raw is None:
        raise AccelcalError(f"{path}: no 'accelcal' metadata in the Parquet schema")
    return parse_metadata(raw.decode("utf-8", "replace"), f"{path}: Parquet metadata")


def _read_csv(path: Path) -> tuple[dict, dict[str, np.ndarray]]:
    """Metadata and columns of a CSV record (structure checks only)."""
    check_regular_file(path, "record file")
    try:
        with open(path, "rb") as fh:
            _check_size(fh, path)
            meta, header_line = csv_preamble(fh, path)
            body = read_rest(fh, MAX_RECORD_BYTES)
    except FileNotFoundError:
        raise AccelcalError(f"record file {path} not found") from None
    except OSError as exc:
        raise AccelcalError(f"cannot read record file {path}: {exc.strerror or exc}") from None
    if body is None:
        raise AccelcalError(f"{path}: larger than the {MAX_RECORD_BYTES // 2**20} MiB a record "
                            "file may have; is it the right file?")
    if not header_line.strip():
        raise AccelcalError(f"{path}: line 3 should hold the column names, comma separated")
    names = [n.strip() for n in header_line.split(",")]
    _check_names(names, f"{path}: line 3 column names {shown(header_line)}")
    if not body or body.isspace():  # (no stripped copy of the body)
        raise AccelcalError(f"{path}: the record has no data rows")
    # Values are at most the separators plus one, so at most the bytes plus one: only a
    # body of MAX_RECORD_VALUES bytes or more can hold too many (then they are counted).
    if (len(body) >= MAX_RECORD_VALUES
            and body.count(b",") + body.count(b"\n") + 1 > MAX_RECORD_VALUES):
        raise AccelcalError(f"{path}: more than {MAX_RECORD_VALUES} values; split the record")
    return meta, _parse_rows(body, names, path)


def _parse_rows(body: bytes, names: list[str], path) -> dict[str, np.ndarray]:
    """The data rows as float64 columns, parsed by Arrow; errors name line and column."""
    import pyarrow as pa
    from pyarrow import csv

    try:
        table = csv.read_csv(pa.py_buffer(body), read_options=csv.ReadOptions(column_names=names),
                             parse_options=_parse_options(),
                             convert_options=_convert_options(names, pa.float64()))
    except pa.ArrowInvalid:
        _raise_first_bad_cell(body, names, path)
    if table.num_rows == 0:
        raise AccelcalError(f"{path}: the record has no data rows")
    columns = {n: floats(table.column(i)) for i, n in enumerate(names)}
    bad = np.flatnonzero(~np.logical_and.reduce([np.isfinite(c) for c in columns.values()]))
    if bad.size:
        row = int(bad[0])
        column = next(i for i, c in enumerate(columns.values()) if not np.isfinite(c[row]))
        line, cells = _row_text(body, _lines(body), row)
        raise AccelcalError(
            f"{path}: line {line}, column {shown_name(names[column])}: {shown(cells[column])} is "
            "not finite"
        )
    return columns


def _raise_first_bad_cell(body: bytes, names: list[str], path) -> None:
    """Report the first row with a wrong number of values or a cell that is not a number.

    The error path, vectorised too: values are counted per line from the
    positions of the commas, then the rows are read again as raw bytes and
    every column is matched against the number syntax at once.
    """
    import pyarrow as pa
    import pyarrow.compute as pc
    from pyarrow import csv

    lines = _lines(body)
    starts, lengths, numbers = lines
    commas = np.flatnonzero(np.frombuffer(body, dtype=np.uint8) == ord(","))
    values = np.searchsorted(commas, starts + lengths) - np.searchsorted(commas, starts) + 1
    wrong = np.flatnonzero(values != len(names))
    if wrong.size:
        raise AccelcalError(f"{path}: line {numbers[wrong[0]]} has {values[wrong[0]]} values, "
                            f"expected {len(names)}")
    try:
        table = csv.read_csv(pa.py_buffer(body), read_options=csv.ReadOptions(column_names=names),
                             parse_options=_parse_options(),
                             convert_options=_convert_options(names, pa.binary()))
    except pa.ArrowInvalid as exc:
        raise AccelcalError(f"{path}: the data rows could not be read ({one_line(exc)})"
                            ) from None
    first = None
    for i, name in enumerate(names):
        ok = pc.match_substring_regex(table.column(i), _FINITE_NUMBER).to_numpy(
            zero_copy_only=False)
        bad = np.flatnonzero(~ok)
        if bad.size and (first is None or bad[0] < first[0]):
            first = (int(bad[0]), i, name)
    if first is None:  # pragma: no cover - Arrow refused what the number syntax accepts
        raise AccelcalError(f"{path}: the data rows could not be read")
    row, column, name = first
    line, cells = _row_text(body, lines, row)
    cell = cells[column]
    try:
        problem = "is not a number" if math.isfinite(float(cell)) else "is not finite"
    except ValueError:
        problem = "is not a number"
    raise AccelcalError(f"{path}: line {line}, column {shown_name(name)}: {shown(cell)} {problem}")


def _lines(body: bytes) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Start, length (without the line end) and file line number of every non-blank data row."""
    raw = np.frombuffer(body, dtype=np.uint8)
    ends = np.append(np.flatnonzero(raw == ord("\n")), raw.size)
    starts = np.concatenate(([0], ends[:-1] + 1))
    lengths = ends - starts
    lengths -= (lengths > 0) & (raw[np.maximum(ends - 1, 0)] == ord("\r"))
    keep = np.flatnonzero(lengths > 0)
    return starts[keep], lengths[keep], keep + 4


def _row_text(body: bytes, lines, row: int) -> tuple[int, list[str]]:
    """File line number and cells of data row ``row`` (0-based, blank lines skipped)."""
    starts, lengths, numbers = lines
    text = body[starts[row]:starts[row] + lengths[row]].decode("utf-8", "replace")
    return int(numbers[row]), [c.strip() for c in text.split(",")]


def _parse_options():
    from pyarrow import csv

    return csv.ParseOptions(quote_char=False, double_quote=False, escape_char=False,
                            newlines_in_values=False, ignore_empty_lines=True)


def _convert_options(names, type_):
    from pyarrow import csv

    return csv.ConvertOptions(column_types=dict.fromkeys(names, type_), null_values=[],
                              strings_can_be_null=False, quoted_strings_can_be_null=False)


def _read_parquet(path: Path) -> tuple[dict, dict[str, np.ndarray]]:
    """Metadata and columns of a Parquet record."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    check_regular_file(path, "record file")
    try:
        with open(path, "rb") as fh:
            _check_size(fh, path)
            parquet = pq.ParquetFile(fh)
            meta = parquet_metadata(parquet.schema_arrow.metadata, path)
            names = list(parquet.schema_arrow.names)
            if parquet.metadata.num_rows * len(names) > MAX_RECORD_VALUES:
                raise AccelcalError(
                    f"{path}: more than {MAX_RECORD_VALUES} values; split the record")
            table = parquet.read()
    except FileNotFoundError:
        raise AccelcalError(f"record file {path} not found") from None
    except (OSError, pa.ArrowException) as exc:
        raise AccelcalError(f"cannot read Parquet record {path}: {one_line(exc)}") from None
    _check_names(names, f"{path}: column names {shown(names)}")
    if table.num_rows == 0:
        raise AccelcalError(f"{path}: the record has no data rows")
    columns = {}
    for i, name in enumerate(names):
        column = table.column(i)
        if not (pa.types.is_floating(column.type) or pa.types.is_integer(column.type)):
            raise AccelcalError(f"{path}: column {shown_name(name)} has type "
                                f"{one_line(column.type, 80)}, expected numbers")
        if column.null_count:
            raise AccelcalError(f"{path}: column {shown_name(name)} has {column.null_count} "
                                "missing values")
        columns[name] = floats(column)
        bad = np.flatnonzero(~np.isfinite(columns[name]))
        if bad.size:
            raise AccelcalError(
                f"{path}: row {bad[0]}, column {shown_name(name)}: value is not finite")
    return meta, columns


PARQUET_CODEC = "lz4"
"""Compression of the Parquet records accelcal writes.

Noise-like float channels barely compress, so the codec is chosen for speed
(on such channels LZ4 costs a few per cent of the write; it is kept because
raw ADC counts stored as float64, and time columns, do compress);
dictionary encoding, pyarrow's default, spent most of an import's write on
float columns whose values never repeat (``benchmarks/import.py`` times the
import beside one read of the same file)."""

PARQUET_BATCH = 1 << 16
"""Values the Parquet writer encodes at a time (pyarrow's default, 1,024, spent a tenth
of a float record's write on per-batch work; a page may exceed its 1 MiB target by up
to one batch, 512 KiB of float64)."""


def parquet_options(schema) -> dict:
    """Writer options of a record's Parquet file: no dictionary on float channels, LZ4.

    A dictionary only pays on columns of few distinct values (a point index,
    text); float samples get none (:data:`PARQUET_CODEC`). Values are
    encoded :data:`PARQUET_BATCH` at a time. Column statistics (each row
    group's minimum and maximum) are kept: a reader that selects a time
    range skips row groups by them.
    """
    import pyarrow as pa

    keep = [f.name for f in schema if not pa.types.is_floating(f.type)]
    return {"use_dictionary": keep or False, "compression": PARQUET_CODEC,
            "write_batch_size": PARQUET_BATCH}


def _write_parquet(path, header: dict, columns: dict[str, np.ndarray], *,
                   flush: bool = True) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.table(columns).replace_schema_metadata(
        {"accelcal": json.dumps(header, allow_nan=False)}
    )
    with atomic_path(path, flush=flush) as tmp:
        pq.write_table(table, tmp, **parquet_options(table.schema))


def _is_parquet(path) -> bool:
    return Path(path).suffix.lower() == ".parquet"


def _check_size(fh, path) -> None:
    """Refuse a regular file over :data:`MAX_RECORD_BYTES` before reading it."""
    info = os.fstat(fh.fileno())
    if stat.S_ISREG(info.st_mode) and info.st_size > MAX_RECORD_BYTES:
        raise AccelcalError(
            f"{path}: {info.st_size / 2**20:.0f} MiB is larger than the "
            f"{MAX_RECORD_BYTES // 2**20} MiB a record file may have; split the record"
        )


def _line(fh, path, number: int, limit: int) -> str:
    """Line ``number`` of a binary file, at most ``limit`` bytes, as text without its end."""
    raw = fh.readline(limit + 1)
    if len(raw) > limit:
        raise AccelcalError(f"{path}: line {number} is longer than {limit} bytes")
    try:
        return raw.decode("utf-8").rstrip("\r\n")
    except UnicodeDecodeError:
        raise AccelcalError(f"{path}: line {number} is not UTF-8 text") from None


def _check_names(names: list[str], where: str) -> None:
    if len(set(names)) != len(names) or any(not n for n in names):
        raise AccelcalError(f"{where} are empty or repeated")
