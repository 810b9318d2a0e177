"""A lab's recording converted into an accelcal record file of one kind (``accelcal import``).

:func:`import_recording` opens the recording once
(:func:`~accelcal.io.recordings.open_stream`) and streams it one block at a
time, each channel's samples contiguous (``order="F"``: a column in the
record's unit is handed to the writer without a copy), into a record of the kind asked for
(:mod:`~accelcal.io.recordings.kinds`): Parquet when the name ends in
``.parquet``, one row group per block, written with
:class:`pyarrow.parquet.ParquetWriter`; otherwise the CSV record layout,
written block by block by Arrow's CSV writer. Memory is bounded by one
block (``rows`` samples of every channel, a few copies of them) whatever the
recording's length.

The record's metadata carries the provenance: the file's name, SHA-256,
format, channel map, units, scales, rate, the file's and the channels'
properties, and for temperature channels their mean, minimum and maximum
in degC (read in a first pass over those channels only). The record is
written to a staging file beside the target, read back with the kind's
own reader (a stream kind's long record: its first block with the reader,
the whole by streaming it), and moved into place only when valid
(:func:`accelcal.io.atomic.atomic_path`): nothing half-written is ever left.

References
----------
.. [Parquet] Apache Parquet file format (row groups); Apache Arrow,
   ``pyarrow.parquet.ParquetWriter``.
.. [GUM] JCGM 100:2008, sec. 3.4.2 (a measurement's conditions are recorded
   with its data).
"""

import contextlib
import dataclasses
import json
import os
import threading
from pathlib import Path

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.recordings.kinds import Layout, declared, layout, validator
from accelcal.io.recordings.options import TEMPERATURE_UNITS, InputOptions
from accelcal.io.recordings.read import DEFAULT_BLOCK_ROWS, describe, iter_blocks, open_stream
from accelcal.io.recordings.repairs import Repairs
from accelcal.validation import check_label, shown, shown_name, shown_path

RESERVED = ("format_version", "kind", "units", "provenance")
"""Metadata keys the import writes itself."""


def import_recording(path, options: InputOptions, *, kind: str, channels: dict, out,
                     metadata: dict | None = None, temperature: dict | None = None,
                     rows: int = DEFAULT_BLOCK_ROWS, progress=None) -> dict:
    """Convert a recording into a record file of ``kind``, validated before it appears.

    Parameters
    ----------
    path : path-like
        The recording (any format :func:`~accelcal.io.recordings.read_recording` reads).
    options : InputOptions
        How to read it (its ``columns`` are replaced by the channel map's).
    kind : str
        Record kind (:func:`~accelcal.io.recordings.kinds.kinds`).
    channels : dict
        Record column -> the recording's channel (``{"acc_x": "Accel/X"}``).
    out : path-like
        The record file to write (``.parquet``: Parquet; else CSV).
    metadata : dict, optional
        The kind's metadata that a recording does not state (``serial``,
        ``operator``, ``frequency_hz``, ``rotation_axis`` ...).
    temperature : dict, optional
        Name -> temperature channel (unit ``degC`` or ``K``), summarised in the provenance.
    rows : int
        Samples per block (the memory bound).
    progress : callable, optional
        ``progress(done, total)`` after each block (samples).

    Returns
    -------
    dict
        ``record``, ``kind``, ``samples``, ``columns``, the ``provenance`` written
        and ``statistics``: each column's whole-period ``mean`` and ``sd`` (one
        sample, ddof 1), accumulated in the same pass.

    Raises
    ------
    AccelcalError
        One line, for a bad recording, map or metadata, or a record its kind's
        reader refuses (nothing is written then).
    """
    out = Path(out)
    channels, temperature = _check_map(channels, "channels"), _check_map(temperature or {},
                                                                        "temperature")
    metadata = _check_metadata(metadata or {})
    if not out.parent.is_dir():
        raise AccelcalError(f"cannot write {shown_path(out)}: directory "
                            f"{shown_path(out.parent)} does not exist", parameter="out")
    if out.name in ("", ".", "..") or out.is_dir():
        raise AccelcalError(f"{shown_path(out)} is a directory; give the record's file name",
                            parameter="out")
    if not 1 <= rows <= MAX_BLOCK_ROWS:
        raise AccelcalError(f"{rows} rows per block: give 1 to {MAX_BLOCK_ROWS}",
                            parameter="rows")
    spec = declared(kind)
    timed = spec.stream or spec.time
    opts = dataclasses.replace(options, columns=tuple(channels.values()), refuse_gaps=timed)
    repairs = Repairs()
    stream = open_stream(path, opts, need_rate=timed, what=f"{kind} record", digest=False,
                         repairs=repairs, order="F")  # the rate's block is the stream's first
    digest = _Digest(path)  # read on another core while the record is written
    prov, rate = dict(stream.provenance), stream.rate
    prov = {"file": prov.pop("file"), "sha256": None, **prov}

    def complete() -> None:
        prov["sha256"] = digest.result()
    source_units = prov.get("units") or dict.fromkeys(channels.values(), prov["unit"])
    plan = layout(kind, channels, source_units, rate)
    prov["channel_map"] = channels
    if temperature:
        prov["temperature_degC"] = _temperatures(path, options, temperature, rows)
    meta = _merge(plan.metadata, metadata)
    header = {"format_version": 1, "kind": kind, **meta, "units": plan.units,
              "provenance": prov}
    from accelcal.io.atomic import atomic_path, check_output, temp_directory, write_error

    check_output(out)
    try:
        with temp_directory(out.parent, "import") as stage:
            staged = stage / out.name
            samples, stats, first = _write(staged, header, plan,
                                           stream.blocks(rows, repairs=repairs, order="F"),
                                           rate=rate, progress=progress,
                                           infos=prov.get("channels", {}), complete=complete)
            if repairs:  # known at the end: written again with them in the provenance
                prov["repairs"] = repairs.to_dict()
                samples, stats, first = _write(staged, header, plan,
                                               stream.blocks(rows, order="F"),
                                               rate=rate, progress=progress,
                                               infos=prov.get("channels", {}),
                                               complete=complete)
            _validate(staged, out, plan, samples, rows, first=first)
            with atomic_path(out) as tmp:
                os.replace(staged, tmp)
    except OSError as exc:
        raise write_error(out, exc) from None
    return {"record": str(out), "kind": kind, "samples": samples, "columns": list(plan.columns),
            "statistics": stats,
            "provenance": prov}


def _check_map(mapping, what: str) -> dict:
    if not isinstance(mapping, dict) or (what == "channels" and not mapping):
        raise AccelcalError(f"{what} must map record columns to the recording's channels, e.g. "
                            "acc_x=Accel/X,acc_y=Accel/Y", parameter=what)
    for col, source in mapping.items():
        check_label(col, f"{what} column", parameter=what)
        if not col.strip() or "," in col or not isinstance(source, str) or not source.strip():
            raise AccelcalError(f"{what}: {shown(col)} = {shown(source)} is not a record column "
                                "= channel pair", parameter=what)
    if len(set(mapping.values())) != len(mapping):
        raise AccelcalError(f"{what} map a channel to two columns", parameter=what)
    return {str(k).strip(): v.strip() for k, v in mapping.items()}


def _check_metadata(metadata: dict) -> dict:
    if not isinstance(metadata, dict):
        raise AccelcalError("metadata must be a table of fields (serial, operator, ...)",
                            parameter="metadata")
    reserved = [k for k in metadata if k in RESERVED]
    if reserved:
        raise AccelcalError(f"metadata field(s) {', '.join(reserved)} are written by the import "
                            "itself", parameter="metadata")
    try:
        json.dumps(metadata, allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise AccelcalError(f"metadata is not JSON-ready: {exc}", parameter="metadata") from None
    return metadata


def _merge(stated: dict, given: dict) -> dict:
    """The recording's own metadata and the user's; a contradiction is refused."""
    for key, value in stated.items():
        if key in given and given[key] != value:
            raise AccelcalError(f"metadata {key} = {shown(given[key])} contradicts the "
                                f"recording ({shown(value)}); leave it out", parameter="metadata")
    return {**given, **stated}


def _temperatures(path, options: InputOptions, temperature: dict, rows: int) -> dict:
    opts = dataclasses.replace(options, columns=tuple(temperature.values()), unit=None,
                               scale=None, refuse_gaps=False)
    prov, _ = describe(path, opts, need_rate=False, digest=False)
    units = prov.get("units") or dict.fromkeys(temperature.values(), prov["unit"])
    for name, source in temperature.items():
        if units[source] not in TEMPERATURE_UNITS:
            raise AccelcalError(f"temperature {shown_name(name)}: channel {shown_name(source)} is "
                                f"in {units[source]}, not degC or K", parameter="temperature")
    offset = np.array([TEMPERATURE_UNITS[units[s]] for s in temperature.values()])
    total, low, high, n = 0.0, np.inf, -np.inf, 0
    for block in iter_blocks(path, opts, rows=rows, need_rate=False):
        celsius = block.values + offset
        total = total + celsius.sum(axis=0)
        low, high = np.minimum(low, celsius.min(axis=0)), np.maximum(high, celsius.max(axis=0))
        n += celsius.shape[0]
    return {name: {"channel": src, "mean": float(total[k] / n), "min": float(low[k]),
                   "max": float(high[k]), "file_unit": units[src]}
            for k, (name, src) in enumerate(temperature.items())}


def _columns(plan: Layout, block, rate, state: dict) -> dict:
    """The record's columns of one block (the record units, the made columns)."""
    sources = [s for s in plan.columns.values() if s is not None]
    out = {}
    for col, source in plan.columns.items():
        if source is not None:
            column = block.values[:, sources.index(source)]
            # a factor of 1 changes no value: the block's column is taken as it is (a
            # contiguous view of an "F" block, which Arrow takes without a copy)
            out[col] = (np.ascontiguousarray(column) if plan.factors[col] == 1.0
                        else column * plan.factors[col])
    if "t" in plan.columns and plan.columns["t"] is None:
        n = block.values.shape[0]
        row = block.start + np.arange(n)
        if plan.restart and plan.restart in out:
            row = row - _point_starts(out[plan.restart], block.start, state)
            out["t"] = row / rate
        else:
            out["t"] = block.time if block.time is not None else row / rate
    return {c: out[c] for c in plan.columns}


def _point_starts(point: np.ndarray, start: int, state: dict) -> np.ndarray:
    """The first row of each sample's point (points are contiguous), carried across blocks."""
    rows = start + np.arange(point.size)
    new = np.ones(point.size, dtype=bool)
    new[1:] = point[1:] != point[:-1]
    if state.get("point") is not None:
        new[0] = point[0] != state["point"]
    firsts = np.where(new, rows, -1)
    firsts[0] = firsts[0] if new[0] else state.get("first", 0)
    firsts = np.maximum.accumulate(firsts)
    state["point"], state["first"] = point[-1], int(firsts[-1])
    return firsts


def _write(staged: Path, header: dict, plan: Layout, blocks, *, rate, progress, infos,
           complete):
    """Write the record; return its samples, its columns' statistics and its first rows.

    The first rows (at most :data:`PROBE_ROWS`, copied) are what :func:`_validate` gives a
    long stream record's reader. ``complete()`` completes ``header`` (the source's
    digest): before the first row of a CSV record, after the last of a Parquet one
    (:func:`_writer`).
    """
    import pyarrow as pa

    names = list(plan.columns)
    schema = pa.schema([(c, pa.float64()) for c in names],
                       metadata={"accelcal": json.dumps(header, allow_nan=False)})
    lengths = {i.get("length") for i in infos.values()}
    total = lengths.pop() if len(lengths) == 1 else None
    done, state, sums, first = 0, {}, _Sums(), None
    with _writer(staged, schema, header, complete) as write:
        for block in blocks:
            cols = _columns(plan, block, rate, state)
            write(pa.table(cols, schema=schema))
            if first is None:
                first = {c: v[:PROBE_ROWS].copy() for c, v in cols.items()}
            sums.add(cols)
            done += block.values.shape[0]
            if progress is not None:
                progress(done, max(done, total or done))
    if not done:
        raise AccelcalError("the recording has no samples")
    return done, sums.result(), first


_SUM_CHUNK = 1 << 15
"""Samples of a column shifted at a time by :class:`_Sums` (256 KiB: stays in cache)."""


class _Sums:
    """Whole-period mean and SD (ddof 1) of each column, in one pass.

    Sums of the values shifted by each column's first value, so a large
    offset keeps a small SD exact.
    """

    def __init__(self):
        self.ref, self.s1, self.s2, self.n = {}, {}, {}, 0

    def add(self, cols: dict) -> None:
        for name, col in cols.items():
            x = np.asarray(col, dtype=float)
            if name not in self.ref:
                self.ref[name], self.s1[name], self.s2[name] = float(x[0]), 0.0, 0.0
            with np.errstate(over="ignore", invalid="ignore"):  # the reader refuses such values
                for a in range(0, len(x), _SUM_CHUNK):  # shifted in cache-sized pieces
                    d = x[a:a + _SUM_CHUNK] - self.ref[name]
                    self.s1[name] += float(d.sum())
                    self.s2[name] += float(np.einsum("i,i->", d, d))  # no BLAS threads
        self.n += len(next(iter(cols.values())))

    def result(self) -> dict:
        out = {}
        for name, ref in self.ref.items():
            s1, s2, n = self.s1[name], self.s2[name], self.n
            var = max(s2 - s1 * s1 / n, 0.0) / max(n - 1, 1)
            out[name] = {"mean": ref + s1 / n, "sd": var**0.5}
        return out


MAX_BLOCK_ROWS = 1 << 26
"""Most rows per block (64 Mi: 2 GiB of float64 for four channels)."""


@contextlib.contextmanager
def _writer(path: Path, schema, header: dict, complete):
    """Yield ``write(table)``: Parquet row groups, or CSV rows after the record's header.

    A Parquet record's header is the footer's: ``complete()`` is called after the last
    row group and the completed header replaces the one the writer was opened with
    (``add_key_value_metadata``; the Arrow schema is not stored beside it, where it
    would carry the first header: the columns are plain float64). A CSV record's header
    is its first lines: ``complete()`` is called before they are written.
    """
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    from accelcal.io.records import MARKER, parquet_options

    if path.suffix.lower() == ".parquet":
        with pq.ParquetWriter(path, schema, store_schema=False,
                              **parquet_options(schema)) as sink:
            yield sink.write_table
            complete()
            sink.add_key_value_metadata({"accelcal": json.dumps(header, allow_nan=False)})
        return
    complete()
    with open(path, "wb") as fh:
        fh.write(f"{MARKER}\n# {json.dumps(header, allow_nan=False)}\n"
                 f"{','.join(schema.names)}\n".encode())
        bare = schema.remove_metadata()
        with pacsv.CSVWriter(fh, bare, write_options=pacsv.WriteOptions(
                include_header=False)) as sink:
            yield lambda table: sink.write_table(table.replace_schema_metadata(None))


class _Digest:
    """The SHA-256 of a file, read in a thread (``hashlib`` releases the GIL as it hashes)."""

    def __init__(self, path):
        from accelcal.io.recordings.read import sha256

        self._value, self._error = None, None

        def run():
            try:
                self._value = sha256(path)
            except OSError as exc:  # raised by result(), in the caller's thread
                self._error = exc

        self._thread = threading.Thread(target=run, name="sha256", daemon=True)
        self._thread.start()

    def result(self) -> str:
        """The hex digest, once the whole file is read."""
        self._thread.join()
        if self._error is not None:
            raise self._error
        return self._value


PROBE_ROWS = 1 << 16
"""Rows of the probe record through which a long stream record's reader checks it."""


def _validate(staged: Path, out: Path, plan: Layout, samples: int, rows: int, *,
              first: dict) -> None:
    """Read the staged record back with its kind's reader; errors name ``out``.

    A stream kind's record longer than :data:`PROBE_ROWS`: its metadata is
    read back from the staged file (a Parquet footer, a CSV record's header),
    the reader reads a probe record of that metadata and the record's
    ``first`` rows (as written), and the rows the file holds are counted from
    the footer or, for a CSV record, by streaming it back through
    :func:`~accelcal.io.recordings.iter_blocks`: no second read of a
    Parquet record's samples, the memory one block. Other kinds are read
    whole by their reader, as their methods read them.
    """
    from accelcal.io.records import MAX_RECORD_VALUES

    values = samples * len(plan.columns)
    try:
        if plan.stream and samples > PROBE_ROWS:
            _validate_long(staged, plan, samples, rows, first)
        elif values <= MAX_RECORD_VALUES:
            validator(plan.kind)(staged)
        else:
            raise AccelcalError(f"a {plan.kind} record holds at most {MAX_RECORD_VALUES} "
                                f"values; this one would hold {values}: split the recording")
    except AccelcalError as exc:
        text = str(exc).replace(str(staged), str(out)).replace(staged.name, out.name)
        raise AccelcalError(f"the {plan.kind} record would not be valid: {text}") from None


def _validate_long(staged: Path, plan: Layout, samples: int, rows: int, first: dict) -> None:
    from accelcal.io.recordings.sources import open_source
    from accelcal.io.records import write_record

    meta = open_source(staged, "record", None).metadata
    # a short name beside the staged record (its own name may take a file name's 255 bytes)
    probe = staged.with_name(("p" if staged.stem != "p" else "q") + staged.suffix)
    write_record(probe, plan.kind, {k: v for k, v in meta.items()
                                    if k not in ("format_version", "kind")}, first,
                 flush=False)  # a scratch file, read at once and removed
    validator(plan.kind)(probe)
    probe.unlink()
    if staged.suffix.lower() == ".parquet":
        from accelcal.io.recordings.sources import parquet_rows

        read = parquet_rows(staged)
    else:
        opts = InputOptions(input_format="record", columns=tuple(plan.columns))
        read = sum(b.values.shape[0] for b in iter_blocks(staged, opts, rows=rows,
                                                           need_rate=False))
    if read != samples:
        raise AccelcalError(f"{read} samples read back of {samples} written")
