"""Recordings read whole (:func:`read_recording`) or streamed in blocks (:func:`iter_blocks`).

Both take the same :class:`~accelcal.io.recordings.options.InputOptions` and
apply the same checks to every block, so a recording that streams without
error also reads whole without error, and the other way round:

- the channels' columns exist and have equal lengths, their units are known
  and agree with the file's (:mod:`~accelcal.io.recordings.plan`);
- every sample is a finite number (the first NaN or empty cell is named by
  column and data row; accelcal never averages over a gap);
- the time column, when there is one, is finite and strictly increasing
  (the first row where it goes backwards or repeats is named), and with
  ``refuse_gaps`` has no gap (:mod:`~accelcal.io.recordings.checks`).

Values are the file's numbers times the channel's scale, in the channel's
unit. Times are returned in seconds from the first sample. The rate is the
one given, the file's (TDMS ``wf_increment``), or 1 / the median sample
interval of the time column (of the first block, when streaming). The
file's SHA-256, its channels' properties and how it was read go into the
provenance.

References
----------
.. [GUM] JCGM 100:2008, sec. 3.4.2 (the measurand's conditions are recorded
   with the data: here, the file's identity and how it was read).
"""

import copy
import hashlib
import itertools
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.recordings.checks import (
    GAP_FACTOR,
    check_finite_time,
    check_gaps,
    check_time,
    check_values,
    regions,
)
from accelcal.io.recordings.options import TIME_UNITS, InputOptions, to_si_factor
from accelcal.io.recordings.plan import Plan, make_plan
from accelcal.io.recordings.repairs import Repairs, TimeRepair
from accelcal.validation import check_rate, shown_name

DEFAULT_BLOCK_ROWS = 1 << 20
"""Rows per block when streaming (1 Mi rows: 24 MiB for three float64 channels)."""


@dataclass(frozen=True)
class Recording:
    """A recording read whole.

    Attributes
    ----------
    values : numpy.ndarray
        Samples, shape ``(n, k)``, float64, in :attr:`unit`.
    channels : tuple of str
        The columns the ``k`` channels came from.
    unit : str
        Unit of the values (:data:`~accelcal.io.recordings.options.UNITS`), or
        ``mixed`` when the channels have units of their own (:attr:`units`).
    rate : float or None
        Sample rate, Hz (given, the file's, or from the time column); None when neither.
    time : numpy.ndarray or None
        Time of each sample in seconds from the first, when the file has a time column.
    labels : numpy.ndarray or None
        Per-sample labels (imucal's ``part`` column), or None.
    regions : dict
        Label -> ``(start, stop)`` sample range (stop exclusive), from a regions file.
    metadata : dict
        An accelcal record's metadata (empty for other files).
    provenance : dict
        The file, its SHA-256, its format, its properties and how it was read.
    units : tuple of str
        Each channel's unit (empty: all in :attr:`unit`).
    repairs : Repairs
        What was found in the time column and done about it, and the segments
        (:mod:`~accelcal.io.recordings.repairs`).
    """

    values: np.ndarray
    channels: tuple[str, ...]
    unit: str
    rate: float | None
    time: np.ndarray | None = None
    labels: np.ndarray | None = None
    regions: dict = field(default_factory=dict)
    metadata: dict = field(default_factory=dict)
    provenance: dict = field(default_factory=dict)
    units: tuple[str, ...] = ()
    repairs: Repairs = field(default_factory=Repairs)

    @property
    def samples(self) -> int:
        """Number of samples."""
        return self.values.shape[0]

    def in_si(self) -> np.ndarray:
        """The values in m/s^2 (an AccelcalError for counts, V, mV or a temperature)."""
        units = self.units or (self.unit,) * len(self.channels)
        return self.values * np.array([to_si_factor(u) for u in units])

    def gaps(self) -> np.ndarray:
        """Rows after which the time jumps by more than 1.5 nominal sample intervals."""
        if self.time is None or self.rate is None or self.samples < 2:
            return np.empty(0, dtype=int)
        return np.flatnonzero(np.diff(self.time) > GAP_FACTOR / self.rate)


@dataclass(frozen=True)
class Block:
    """One block of a streamed recording.

    ``values`` (rows, k), its first row ``start``, ``time`` (seconds from the
    recording's first sample) or None, ``labels`` or None.
    """

    values: np.ndarray
    start: int
    time: np.ndarray | None = None
    labels: np.ndarray | None = None


def read_recording(path, options: InputOptions | None = None, *, channels: int | None = None,
                   need_rate: bool = True, what: str = "recording") -> Recording:
    """Read a recording whole.

    Parameters
    ----------
    path : path-like
        The file.
    options : InputOptions, optional
        How to read it (default: ``auto``, the format's columns).
    channels : int, optional
        Number of channels required (3 for a triad, 1 for a noise record).
    need_rate : bool
        Refuse a file with neither a time column nor a given rate.
    what : str
        What the recording is for, in messages.

    Returns
    -------
    Recording

    Raises
    ------
    AccelcalError
        One line naming the file, the column or row, and the fix.
    """
    from accelcal.resources import MEMORY_SHARE, available_memory, check_memory

    options = options or InputOptions()
    plan = make_plan(path, options, channels, need_rate, what)
    declared = _declared_rows(plan)
    if declared is not None:
        check_memory(declared, len(plan.channels) + (plan.time is not None), 3,
                     f"reading {shown_name(plan.source.path.name)} whole ({declared} rows)",
                     hint="use a command that streams it, or split the file")
    parts, times, labels = [], [], []
    limit = MEMORY_SHARE * available_memory()
    held = 0
    repairs = Repairs()
    for block in _blocks(plan, DEFAULT_BLOCK_ROWS, options, repairs):
        parts.append(block.values)
        if block.time is not None:
            times.append(block.time)
        if block.labels is not None:
            labels.append(block.labels)
        held += block.values.nbytes * 3
        if held > limit:
            raise AccelcalError(
                f"{shown_name(plan.source.path.name)} is too large to hold in memory "
                f"({sum(len(p) for p in parts)} rows read so far); use a command that streams "
                "it, or split the file")
    values = np.concatenate(parts) if parts else np.empty((0, len(plan.channels)))
    if values.shape[0] == 0:
        raise AccelcalError(f"{shown_name(plan.source.path.name)} has no samples "
                            f"(a header and no rows)")
    time = np.concatenate(times) if times else None
    rate = plan.rate
    if rate is None and time is not None:
        rate = _rate_of(time, plan)
    label_array = np.concatenate(labels) if labels else None
    spans = regions(options.regions, values.shape[0]) if options.regions else {}
    prov = provenance(plan, rate, values.shape[0])
    if repairs:
        prov["repairs"] = repairs.to_dict()
    return Recording(values, plan.channels, plan.unit, rate, time, label_array, spans,
                     plan.source.metadata, prov, plan.units if plan.unit == "mixed" else (),
                     repairs)


def iter_blocks(path, options: InputOptions | None = None, *, rows: int = DEFAULT_BLOCK_ROWS,
                channels: int | None = None, need_rate: bool = True,
                what: str = "recording", repairs: Repairs | None = None,
                order: str = "C") -> Iterator[Block]:
    """Stream a recording in blocks of at most ``rows`` rows.

    The checks of :func:`read_recording`, block by block; memory is bounded
    by one block (a v5 MAT-file excepted: it is read whole, see
    :mod:`~accelcal.io.recordings.matlab`). ``repairs``, when given, collects
    what was found and done (complete once the last block is read).
    ``order``: the memory layout of each block's ``values`` as numpy names
    it, ``"C"`` (a sample's channels side by side) or ``"F"`` (each channel's
    samples contiguous, taken column by column without a copy, as a
    columnar writer takes them); the values are the same.
    """
    _check_order(order)
    options = options or InputOptions()
    plan = make_plan(path, options, channels, need_rate, what)
    yield from _blocks(plan, rows, options, repairs, order)


class Stream:
    """A recording opened once for streaming (:func:`open_stream`).

    Its ``plan``, ``provenance`` and ``rate`` (as :func:`describe` gives
    them) and its :meth:`blocks`, read with the same settled plan (the
    file's layout is not read again).
    """

    def __init__(self, plan: Plan, options: InputOptions, provenance: dict,
                 rate: float | None, opened: tuple | None = None):
        self.plan, self.options, self.provenance, self.rate = plan, options, provenance, rate
        self._opened = opened  # (rows, repairs, order, repairs before), first block, rest

    def blocks(self, rows: int = DEFAULT_BLOCK_ROWS, *, repairs: Repairs | None = None,
               order: str = "C") -> Iterator[Block]:
        """The blocks, as :func:`iter_blocks` yields them.

        The first call with the ``rows``, ``repairs`` and ``order`` the
        stream was opened with goes on from the block read for the rate (it
        is not read twice); any other call reads the file from its start.
        """
        _check_order(order)
        opened, self._opened = self._opened, None
        if opened is not None:
            (o_rows, o_repairs, o_order, before), first, rest = opened
            if (o_rows, o_order) == (rows, order) and o_repairs is repairs:
                return itertools.chain((first,), rest)
            rest.close()
            if o_repairs is not None:  # what the unused block found is forgotten
                o_repairs.findings, o_repairs.segments = before.findings, before.segments
        return _blocks(self.plan, rows, self.options, repairs, order)


def open_stream(path, options: InputOptions | None = None, *, channels: int | None = None,
                need_rate: bool = True, what: str = "recording", digest: bool = True,
                rows: int = DEFAULT_BLOCK_ROWS, repairs: Repairs | None = None,
                order: str = "C") -> Stream:
    """Open a recording for streaming: its provenance and rate, then its blocks.

    The parameters are those of :func:`describe` (the rate is read from a
    first block of ``rows`` rows when the file has a time column and no
    stated rate); :meth:`Stream.blocks` then streams it as
    :func:`iter_blocks` does, with the same checks. That first block is
    read with ``repairs`` and ``order`` and kept for the stream's first
    :meth:`~Stream.blocks` with the same ``rows``, ``repairs`` and ``order``.
    """
    _check_order(order)
    options = options or InputOptions()
    plan = make_plan(path, options, channels, need_rate, what)
    rate, opened = plan.rate, None
    if rate is None and plan.time is not None:
        before = copy.deepcopy(repairs)
        blocks = _blocks(plan, rows, options, repairs, order)
        first = next(blocks, None)
        if first is None or first.time is None or first.time.size < 2:
            raise AccelcalError(f"{shown_name(plan.source.path.name)}: too few samples to "
                                "tell the sample rate from the time column", parameter="rate")
        rate = _rate_of(first.time, plan)
        opened = ((rows, repairs, order, before), first, blocks)
    return Stream(plan, options, provenance(plan, rate, None, digest=digest), rate, opened)


def describe(path, options: InputOptions | None = None, *, channels: int | None = None,
             need_rate: bool = True, what: str = "recording",
             digest: bool = True, rows: int = DEFAULT_BLOCK_ROWS) -> tuple[dict, float | None]:
    """The provenance of a streamed recording and its rate, read from its first block.

    ``digest=False`` leaves out the SHA-256 (a read of the whole file), for
    callers that need only the columns, units and rate. ``rows``: the
    block's rows (give the stream's own, so that the rate is that of the
    stream's first block and no larger block is held than the stream holds).
    """
    stream = open_stream(path, options, channels=channels, need_rate=need_rate, what=what,
                         digest=digest, rows=rows)
    return stream.provenance, stream.rate


def _check_order(order: str) -> None:
    if order not in ("C", "F"):
        raise ValueError(f"order must be 'C' or 'F', not {order!r}")


def provenance(plan: Plan, rate: float | None, samples: int | None, *,
               digest: bool = True) -> dict:
    """What a record says about the recording it was reduced from (``sha256`` with ``digest``)."""
    source = plan.source
    out = {
        "file": source.path.name,
        **({"sha256": sha256(source.path)} if digest else {}),
        "input_format": source.input_format,
        "columns": list(plan.channels),
        "unit": plan.unit,
    }
    if plan.unit == "mixed":
        out["units"] = dict(zip(plan.channels, plan.units, strict=True))
    if any(s is not None for s in plan.scales):
        out["scales"] = {c: s for c, s in zip(plan.channels, plan.scales, strict=True)
                         if s is not None}
    if plan.time is not None:
        out |= {"time_column": plan.time, "time_unit": _time_unit_name(plan.time_factor)}
    if rate is not None:
        out["rate_hz"] = float(rate)
    if samples is not None:
        out["samples"] = int(samples)
    if source.channels:
        out["channels"] = {c: _channel(source.channels[c])
                           for c in (*plan.channels, *((plan.time,) if plan.time else ()))}
        starts = {info["start_time"] for info in out["channels"].values() if "start_time" in info}
        if len(starts) == 1:
            out["start_time"] = starts.pop()
    if source.properties:
        out["properties"] = source.properties
    return out


def _channel(info) -> dict:
    out = {"length": info.length, "dtype": info.dtype}
    if info.unit is not None:
        out["file_unit"] = info.unit
    if info.rate is not None:
        out["file_rate_hz"] = info.rate
    if info.start is not None:
        out["start_time"] = info.start
    if info.properties:
        out["properties"] = info.properties
    return out


def sha256(path) -> str:
    """The SHA-256 of a file, read in 1 MiB chunks."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        while chunk := fh.read(1 << 20):
            digest.update(chunk)
    return digest.hexdigest()


def _time_unit_name(factor: float) -> str:
    return next(k for k, v in TIME_UNITS.items() if v == factor)


def _declared_rows(plan: Plan) -> int | None:
    """The rows the file declares for the plan's channels, before reading any (None: not known).

    A binary file's channel lengths (TDMS segment metadata, HDF5 and MAT
    shapes), a Parquet file's row count from its footer; a text table
    declares nothing.
    """
    source = plan.source
    if source.channels:
        return max(source.channels[c].length for c in plan.channels if c in source.channels)
    if source.input_format in ("parquet", "record") and source.skip_rows == 0:
        from accelcal.io.recordings.sources import parquet_rows

        return parquet_rows(source.path)
    return None


def _blocks(plan: Plan, rows: int, options: InputOptions | None = None,
            repairs: Repairs | None = None, order: str = "C") -> Iterator[Block]:
    from accelcal.io.recordings.sources import batches

    name = shown_name(plan.source.path.name)
    fixer = TimeRepair(options or InputOptions(), plan.rate, name, plan.time,
                       Repairs() if repairs is None else repairs)
    strict = fixer.gaps == "refuse"  # NaN cells refused here, not dropped by the repair
    stated = ((plan.source.metadata or {}).get("provenance") or {}).get("repairs", {})
    if len(stated.get("segments", ())) > 1:
        fixer.stated(stated["segments"])
    numeric = list(plan.channels) + ([plan.time] if plan.time else [])
    text = [plan.label] if plan.label else []
    scale = (None if all(s is None for s in plan.scales)
             else np.array([1.0 if s is None else s for s in plan.scales]))
    start, t0, last, interval, read = 0, None, None, None, 0
    for batch in batches(plan.source, numeric, text, rows):
        values = _stack([batch[c] for c in plan.channels], order)
        first, read = read, read + values.shape[0]
        if strict:
            check_values(values, plan.channels, first, name)
        if scale is not None:
            with np.errstate(over="ignore"):  # an overflow is caught as a non-finite value
                values = values * scale
            if strict:
                check_values(values, plan.channels, first, f"{name} (times the scale)")
        time = None
        if plan.time:
            raw = batch[plan.time]
            check_finite_time(raw, first, name, plan.time)
            if t0 is None and raw.size:
                t0 = raw[0]
            with np.errstate(over="ignore"):  # an overflow is caught as a non-finite time
                time = (raw - t0) * plan.time_factor
        labels = batch[plan.label] if plan.label else None
        if plan.time or plan.rate:
            time, values, labels = fixer.block(time, values, labels, first)
        if plan.time:
            check_time(time, last, start, name, plan.time)
            if plan.refuse_gaps and strict and time.size:
                if interval is None:
                    interval = 1.0 / plan.rate if plan.rate else _median_step(time, last)
                if interval is not None:
                    check_gaps(time, last, start, interval=interval, name=name,
                               column=plan.time)
            if time.size:
                last = time[-1]
        if not values.shape[0]:
            continue
        yield Block(values, start, time, labels)
        start += values.shape[0]
    fixer.finish()


def _stack(columns: list[np.ndarray], order: str) -> np.ndarray:
    """The channels' columns as one ``(rows, k)`` float64 array in the memory ``order``."""
    if order == "C":
        return np.column_stack(columns)
    out = np.empty((columns[0].shape[0], len(columns)), np.result_type(*columns), order="F")
    for k, column in enumerate(columns):
        out[:, k] = column  # a contiguous copy per channel
    return out


def _median_step(time: np.ndarray, last) -> float | None:
    full = time if last is None else np.concatenate(([last], time))
    return float(np.median(np.diff(full))) if full.size > 1 else None


def _rate_of(time: np.ndarray, plan: Plan) -> float:
    if time.size < 2:
        raise AccelcalError(f"{shown_name(plan.source.path.name)}: one sample cannot tell the "
                            "sample rate; give the rate", parameter="rate")
    return check_rate(1.0 / float(np.median(np.diff(time))))

