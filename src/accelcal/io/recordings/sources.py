r"""What a recording file is, and its columns in batches (Arrow's and pandas' C readers).

:func:`open_source` looks at a file's first bytes (never its whole body) to
tell its format when asked for ``auto`` and to list its columns;
:func:`batches` then yields the wanted columns in batches of a bounded
number of rows, parsed by pyarrow (CSV, Parquet, accelcal records) or
pandas' C engine (imu_tk's whitespace-separated rows), never line by line
in Python. Binary files are read by their own modules: NI TDMS
(:mod:`.tdms`), HDF5 (:mod:`.hdf5`) and MATLAB MAT-files (:mod:`.matlab`),
told apart by their magic bytes: ``TDSm``, ``\x89HDF``, ``MATLAB 5.0
MAT-file``, ``MATLAB 7.3 MAT-file`` with HDF5 at offset 512.

References
----------
.. [Arrow] Apache Arrow, ``pyarrow.csv.open_csv`` (streaming CSV reader) and
   ``pyarrow.parquet.ParquetFile.iter_batches``.
.. [imu_tk] A. Pretto, imu_tk: ``importAsciiData`` reads ``t x y z`` rows
   separated by white space.
.. [TDMS] National Instruments, "TDMS File Format Internal Structure".
.. [HDF5] The HDF Group, "HDF5 File Format Specification" (the signature).
.. [MAT] The MathWorks, "MAT-File Format" (the 128-byte header).
"""

import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.arrow_numbers import floats
from accelcal.io.limits import check_regular_file
from accelcal.io.recordings.channels import Source
from accelcal.validation import MAX_LABEL_LENGTH, one_line, shown, shown_name

MARKER = "# accelcal record"
PARQUET_MAGIC = b"PAR1"
IMUCAL_COLUMNS = ("acc_x", "acc_y", "acc_z")
IMUCAL_LABELS = "part"
IMU_TK_NAMES = ("t", "x", "y", "z")
"""Names given to the first columns of an imu_tk file (it has no header)."""

MAX_HEADER_BYTES = 64 * 1024
"""Longest first line (column names) read to tell a file's format."""

BLOCK_BYTES = 1 << 22
"""Bytes Arrow's CSV reader parses at a time (4 MiB)."""

_NUMBER = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")


def open_source(path, input_format: str, delimiter: str | None) -> Source:
    """Tell the format of ``path`` (when ``auto``) and list its columns.

    Raises
    ------
    AccelcalError
        For a missing, special or empty file, or one whose first line cannot
        be read as the format asked for.
    """
    path = Path(path)
    check_regular_file(path, "recording")
    try:
        with open(path, "rb") as fh:
            head = fh.read(MAX_HEADER_BYTES + 1)
    except OSError as exc:
        raise AccelcalError(f"cannot read the recording {shown_name(path.name)}: "
                            f"{exc.strerror or exc.__class__.__name__}") from None
    if not head:
        raise AccelcalError(f"{shown_name(path.name)} is empty: no samples to read")
    if input_format == "auto":
        input_format = _sniff(head, path)
    if input_format in ("tdms", "hdf5", "mat"):
        return _binary_source(path, input_format, head)
    if input_format == "parquet" or (input_format == "record" and head[:4] == PARQUET_MAGIC):
        return _parquet_source(path, input_format)
    text_lines = head.split(b"\n")
    if len(text_lines) < 2 and len(head) > MAX_HEADER_BYTES:
        raise AccelcalError(f"{shown_name(path.name)}: the first line is longer than "
                            f"{MAX_HEADER_BYTES} bytes; is it a text table?")
    first = _decode(text_lines[0], path)
    if input_format == "record":
        return _record_source(path, head)
    if input_format == "imu_tk":
        fields = first.split()
        if not fields or not all(_NUMBER.match(f) for f in fields) or len(fields) < 4:
            raise AccelcalError(f"{shown_name(path.name)} is not an imu_tk file: its first line "
                                f"{shown(first)} is not 't x y z' numbers separated by spaces")
        names = IMU_TK_NAMES + tuple(f"c{k}" for k in range(4, len(fields)))
        return Source(path, "imu_tk", names)
    delim = delimiter or ","
    names = tuple(n.strip().strip('"').strip() for n in first.rstrip("\r").split(delim))
    if not any(names) or all(_NUMBER.match(n) for n in names):
        raise AccelcalError(f"{shown_name(path.name)}: the first line {shown(first)} is not a "
                            "header of column names; a CSV recording needs one")
    return Source(path, input_format, names, delim)


def _binary_source(path: Path, input_format: str, head: bytes) -> Source:
    from accelcal.io.recordings import hdf5, matlab, tdms

    if input_format == "tdms":
        if not head.startswith(tdms.MAGIC):
            raise AccelcalError(f"{shown_name(path.name)} is not a TDMS file (it does not start "
                                "with 'TDSm')", parameter="input_format")
        return tdms.open_tdms(path)
    if input_format == "hdf5":
        if not (head.startswith(hdf5.MAGIC) or _mat73(head)):
            raise AccelcalError(f"{shown_name(path.name)} is not an HDF5 file (no HDF5 "
                                "signature at its start)", parameter="input_format")
        return hdf5.open_hdf5(path, matlab=_mat73(head))
    return matlab.open_mat(path, head)


def _mat73(head: bytes) -> bool:
    from accelcal.io.recordings import hdf5, matlab

    return (head.startswith(matlab.MAGIC_V73)
            and head[matlab.HDF5_OFFSET:matlab.HDF5_OFFSET + 8] == hdf5.MAGIC)


def _sniff(head: bytes, path: Path) -> str:
    from accelcal.io.recordings import hdf5, matlab, tdms

    if head.startswith(tdms.MAGIC):
        return "tdms"
    if head.startswith((matlab.MAGIC_V5, matlab.MAGIC_V73)):
        return "mat"
    if head.startswith(hdf5.MAGIC):
        return "hdf5"
    if head[:4] == PARQUET_MAGIC:
        return "parquet"
    if head.startswith(MARKER.encode()):
        return "record"
    first = _decode(head.split(b"\n")[0], path).strip()
    fields = first.split()
    if len(fields) >= 4 and all(_NUMBER.match(f) for f in fields):
        return "imu_tk"
    names = {n.strip().strip('"') for n in first.split(",")}
    return "imucal" if set(IMUCAL_COLUMNS) <= names else "csv"


def _decode(line: bytes, path: Path) -> str:
    try:
        return line.decode("utf-8").lstrip("\ufeff").rstrip("\r")
    except UnicodeDecodeError:
        raise AccelcalError(f"{shown_name(path.name)} is not a text table (its first line is "
                            "not UTF-8); give input_format parquet for a Parquet file",
                            parameter="input_format") from None


def _record_source(path: Path, head: bytes) -> Source:
    from accelcal.io.records import parse_metadata

    lines = head.split(b"\n")
    if not head.startswith(MARKER.encode()) or len(lines) < 3:
        raise AccelcalError(f"{shown_name(path.name)} is not an accelcal record file "
                            f"(its first line is not {MARKER!r})", parameter="input_format")
    meta_line = _decode(lines[1], path)
    if not meta_line.startswith("# "):
        raise AccelcalError(f"{shown_name(path.name)}, line 2: the metadata line must start "
                            "with '# '")
    metadata = parse_metadata(meta_line[2:], f"{shown_name(path.name)}, line 2")
    names = tuple(n.strip() for n in _decode(lines[2], path).split(","))
    return Source(path, "record", names, ",", skip_rows=2, metadata=metadata)


def _parquet_source(path: Path, input_format: str) -> Source:
    import pyarrow as pa
    import pyarrow.parquet as pq

    from accelcal.io.records import parquet_metadata

    try:
        schema = pq.read_schema(path)
    except (pa.ArrowException, OSError) as exc:
        raise AccelcalError(f"{shown_name(path.name)} is not a readable Parquet file: "
                            f"{one_line(exc, 200)}") from None
    metadata = {}
    if input_format == "record" or (schema.metadata and b"accelcal" in schema.metadata):
        metadata = parquet_metadata(schema.metadata, path)
        input_format = "record"
    return Source(path, input_format, tuple(schema.names), metadata=metadata)


def batches(source: Source, numeric: list[str], text: list[str], rows: int
            ) -> Iterator[dict[str, np.ndarray]]:
    """The columns ``numeric`` (float64) and ``text`` (str) in batches of at most ``rows`` rows.

    Cells that are empty or not numbers in a numeric column raise an
    AccelcalError naming the column (NaN cells are returned as NaN: the
    caller says where).
    """
    if source.input_format == "imu_tk":
        yield from _imu_tk_batches(source, numeric, rows)
        return
    if source.backend != "table":
        yield from _binary_batches(source, numeric, rows)
        return
    import pyarrow as pa

    try:
        for batch in _arrow_batches(source, numeric, text, rows):
            out = {}
            for name in numeric:
                col = batch.column(name)
                if not (pa.types.is_floating(col.type) or pa.types.is_integer(col.type)
                        or pa.types.is_null(col.type)):
                    raise AccelcalError(f"{shown_name(source.path.name)}: column "
                                        f"{shown_name(name)} holds {col.type}, not numbers")
                out[name] = floats(col)
            for name in text:
                out[name] = _labels(batch.column(name).cast(pa.string()), name, source)
            yield out
    except (pa.ArrowException, OSError) as exc:
        raise AccelcalError(f"{shown_name(source.path.name)}: {one_line(exc, 240)}") from None


def _binary_batches(source: Source, numeric: list[str], rows: int):
    from accelcal.io.recordings import hdf5, matlab, tdms

    reader = {"tdms": tdms.tdms_batches, "hdf5": hdf5.hdf5_batches,
              "mat5": matlab.mat_batches}[source.backend]
    yield from reader(source, numeric, rows)


def _labels(column, name: str, source: Source) -> np.ndarray:
    """A text column as a numpy str array.

    A label longer than MAX_LABEL_LENGTH is refused: a fixed-width array of
    one huge label would take rows x its length.
    """
    import pyarrow.compute as pc

    longest = pc.max(pc.utf8_length(column)).as_py() or 0
    if longest > MAX_LABEL_LENGTH:
        raise AccelcalError(f"{shown_name(source.path.name)}: column {shown_name(name)} holds a "
                            f"label of {longest} characters; labels are at most "
                            f"{MAX_LABEL_LENGTH}")
    return np.asarray(column.fill_null("").to_pylist(), dtype=str)


def _arrow_batches(source: Source, numeric: list[str], text: list[str], rows: int):
    import pyarrow as pa

    if source.path.suffix.lower() in (".parquet", ".pq") or _is_parquet(source.path):
        import pyarrow.parquet as pq

        # pre_buffer off: on, Arrow caches every column chunk it has read (the whole file)
        with pq.ParquetFile(source.path, pre_buffer=False) as parquet:
            _check_column_chunks(parquet, numeric + text, source.path)
            yield from parquet.iter_batches(batch_size=rows, columns=numeric + text)
        return
    from pyarrow import csv

    types = {n: pa.float64() for n in numeric} | {n: pa.string() for n in text}
    reader = csv.open_csv(
        source.path,
        read_options=csv.ReadOptions(skip_rows=source.skip_rows, block_size=BLOCK_BYTES),
        parse_options=csv.ParseOptions(delimiter=source.delimiter),
        convert_options=csv.ConvertOptions(include_columns=numeric + text, column_types=types,
                                           strings_can_be_null=False))
    pending = []
    for batch in reader:
        pending.append(batch)
        if sum(len(b) for b in pending) >= rows:
            table = pa.Table.from_batches(pending)
            yield from table.to_batches(max_chunksize=rows)
            pending = []
    if pending:
        yield from pa.Table.from_batches(pending).to_batches(max_chunksize=rows)


def parquet_rows(path: Path) -> int | None:
    """The rows a Parquet file's footer declares (None if it cannot be read)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        return pq.read_metadata(path).num_rows
    except (pa.ArrowException, OSError):
        return None


def _check_column_chunks(parquet, columns: list[str], path: Path) -> None:
    """Refuse a file whose column chunks decompress to more than the process may take.

    A column chunk's uncompressed size is in the footer [Arrow]; a page is
    decompressed whole, and a chunk may be one page, so a small file of
    compressed zeros can declare gigabytes.
    """
    from accelcal.io.limits import memory_limit
    from accelcal.resources import MEMORY_SHARE, shown_bytes

    meta = parquet.metadata
    wanted = [k for k in range(meta.num_columns)
              if meta.schema.column(k).path.split(".")[0] in columns]
    largest = max((sum(meta.row_group(g).column(k).total_uncompressed_size for k in wanted)
                   for g in range(meta.num_row_groups)), default=0)
    limit = MEMORY_SHARE * memory_limit()
    if largest > limit:
        raise AccelcalError(f"{shown_name(path.name)}: a row group's columns decompress to "
                            f"{shown_bytes(largest)}; this process can take "
                            f"{shown_bytes(limit)}; rewrite it with smaller row groups")


def _is_parquet(path: Path) -> bool:
    with open(path, "rb") as fh:
        return fh.read(4) == PARQUET_MAGIC


def _imu_tk_batches(source: Source, numeric: list[str], rows: int):
    import pandas as pd

    index = [source.names.index(n) for n in numeric]
    try:
        with pd.read_csv(source.path, sep=r"\s+", header=None, comment="#", usecols=index,
                         dtype=float, chunksize=rows, engine="c") as reader:
            for chunk in reader:
                yield {name: chunk[i].to_numpy(dtype=float)
                       for name, i in zip(numeric, index, strict=True)}
    except (ValueError, pd.errors.ParserError) as exc:
        raise AccelcalError(f"{shown_name(source.path.name)}: not an imu_tk table of numbers: "
                            f"{one_line(exc, 200)}") from None
