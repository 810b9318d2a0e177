"""How a recording will be read: its columns, units, scales, time or rate (:class:`Plan`).

:func:`make_plan` opens the file's header (never its body) and settles,
before a sample is read, everything the reading needs, refusing what does
not fit:

- the channels exist (a missing one is named with those the file has), and
  in a binary file they, and the time channel, have equal lengths (else
  every length is named);
- each channel's unit is known: given (``unit``, ``units``), carried by the
  file (a TDMS ``unit_string``, an HDF5 ``unit`` attribute), or the
  format's; a unit given that contradicts the file's is refused unless a
  scale converts it;
- the rate is given, stated by the file (TDMS ``wf_increment``: every
  channel must agree, and so must a rate given), or comes from the time
  column.

References
----------
.. [TDMS] National Instruments, "TDMS File Format Internal Structure"
   (``wf_increment``, ``unit_string``).
.. [GUM] JCGM 100:2008, sec. 3.4.2 (the conditions of a measurement are
   recorded with the data: the provenance).
"""

from dataclasses import dataclass
from pathlib import Path

from accelcal.errors import AccelcalError
from accelcal.io.recordings.options import (
    CHANNEL_UNITS,
    TIME_UNITS,
    UNITS,
    InputOptions,
    file_unit,
)
from accelcal.io.recordings.sources import (
    IMU_TK_NAMES,
    IMUCAL_COLUMNS,
    IMUCAL_LABELS,
    Source,
    open_source,
)
from accelcal.validation import shown, shown_name

RATE_RTOL = 1e-6
"""Relative difference between two statements of a rate (a file's and a given one, or two
channels') beyond which they disagree: far above the rounding of a stored increment."""


@dataclass(frozen=True)
class Plan:
    """What to read from a source and how (see :func:`make_plan`)."""

    source: Source
    channels: tuple[str, ...]
    units: tuple[str, ...]
    scales: tuple[float | None, ...]
    time: str | None
    time_factor: float
    rate: float | None
    label: str | None
    refuse_gaps: bool = False

    @property
    def unit(self) -> str:
        """The channels' unit (``mixed`` when they have different ones)."""
        return self.units[0] if len(set(self.units)) == 1 else "mixed"


def make_plan(path, options: InputOptions, channels: int | None, need_rate: bool,
              what: str) -> Plan:
    """Open ``path`` and settle how to read it (see the module docstring)."""
    source = open_source(path, options.input_format, options.delimiter)
    fmt, meta, name = source.input_format, source.metadata, shown_name(Path(path).name)
    cols = options.columns or _default_columns(source)
    if channels is not None and len(cols) != channels:
        raise AccelcalError(f"a {what} needs {channels} column(s); got {len(cols)} "
                            f"({shown(','.join(cols))})", parameter="columns")
    time = options.time
    if time is None and options.rate is None:
        if fmt == "imu_tk":
            time = IMU_TK_NAMES[0]
        elif fmt == "record" and "t" in source.names and "rate" not in meta:
            time = "t"
    for col in (*cols, *((time,) if time else ())):
        if col not in source.names:
            which = "time column" if col == time else "column"
            raise AccelcalError(
                f"{name} has no {which} {shown_name(col)}; its columns are "
                f"{shown(', '.join(source.names), 200)} (give the names with "
                f"{'time' if col == time else 'columns'}=...)",
                parameter="time" if col == time else "columns")
    _check_lengths(source, (*cols, *((time,) if time else ())), name)
    units = tuple(_unit(source, options, c, cols, name) for c in cols)
    scales = tuple((options.scales or {}).get(c, options.scale) for c in cols)
    rate = _rate(source, options, cols, time, name)
    if need_rate and rate is None and time is None:
        raise AccelcalError(f"{name} has no time column; give the sample rate in Hz or the "
                            "name of the time column", parameter="rate")
    label = IMUCAL_LABELS if fmt == "imucal" and IMUCAL_LABELS in source.names else None
    return Plan(source, tuple(cols), units, scales, time, TIME_UNITS[options.time_unit],
                None if rate is None else float(rate), label, options.refuse_gaps)


def _default_columns(source: Source) -> tuple[str, ...]:
    if source.input_format == "imucal":
        return IMUCAL_COLUMNS
    if source.input_format == "imu_tk":
        return IMU_TK_NAMES[1:4]
    if source.input_format == "record":
        if set(IMUCAL_COLUMNS) <= set(source.names):
            return IMUCAL_COLUMNS
        return tuple(n for n in source.names if n not in ("t", "position"))
    raise AccelcalError(f"{shown_name(source.path.name)}: say which columns hold the channels "
                        f"(its columns are {shown(', '.join(source.names), 200)})",
                        parameter="columns")


def _check_lengths(source: Source, names, file_name: str) -> None:
    if not source.channels:
        return
    lengths = {n: source.channels[n].length for n in names}
    if len(set(lengths.values())) > 1:
        listed = ", ".join(f"{n} {k}" for n, k in lengths.items())
        raise AccelcalError(f"{file_name}: the channels have different lengths "
                            f"({shown(listed, 240)}); a recording's channels must be sampled "
                            "together",
                            parameter="columns")
    if not next(iter(lengths.values())):
        raise AccelcalError(f"{file_name} has no samples in {shown_name(next(iter(lengths)))}")


def _unit(source: Source, options: InputOptions, col: str, cols, file_name: str) -> str:
    given = (options.units or {}).get(col, options.unit)
    info = source.channels.get(col)
    stated = info.unit if info is not None else None
    known = file_unit(stated)
    scaled = (options.scales or {}).get(col, options.scale) is not None
    if given is None:
        if known is not None:
            return known
        if stated and stated.strip():
            raise AccelcalError(f"{file_name}: channel {shown_name(col)} is in "
                                f"{shown(stated)}, a unit accelcal does not know; give the unit "
                                "(one of " + ", ".join(CHANNEL_UNITS) + ")", parameter="unit")
        unit = _default_unit(source, cols)
        if unit is None:
            raise AccelcalError(f"{file_name}: the unit of the values is not known; give it "
                                "(one of " + ", ".join(UNITS) + ")", parameter="unit")
        return unit
    if known is not None and known != given and not scaled:
        raise AccelcalError(
            f"{file_name}: channel {shown_name(col)} is in {known} (the file says so), not "
            f"{given}; give unit {known}, or a scale that converts it (file value x scale = "
            f"value in {given})", parameter="unit")
    return given


def _default_unit(source: Source, cols) -> str | None:
    if source.input_format == "imucal":
        return "m/s^2"
    if source.input_format != "record":
        return None
    meta = source.metadata
    units = meta.get("units")
    unit = meta.get("input_unit") or meta.get("unit") or (
        units.get(cols[0]) if isinstance(units, dict) else None)
    unit = {"1": "counts", "-": "counts"}.get(unit, unit)
    return unit if isinstance(unit, str) and unit in UNITS else None


def _rate(source: Source, options: InputOptions, cols, time, file_name: str) -> float | None:
    stated = {c: source.channels[c].rate for c in cols
              if c in source.channels and source.channels[c].rate is not None}
    if len(stated) > 1 and _disagree(*stated.values()):
        listed = ", ".join(f"{c} {r:.9g} Hz" for c, r in stated.items())
        raise AccelcalError(f"{file_name}: the channels have different sample rates "
                            f"({shown(listed, 240)}); read them separately", parameter="rate")
    file_rate = next(iter(stated.values()), None)
    if options.rate is not None:
        if file_rate is not None and _disagree(options.rate, file_rate):
            raise AccelcalError(f"{file_name}: the file says the sample rate is {file_rate:.9g} "
                                f"Hz (1 / wf_increment), not {options.rate:.9g} Hz; give the "
                                "file's rate or leave it out", parameter="rate")
        return options.rate
    if source.metadata.get("rate") is not None:
        return source.metadata["rate"]
    return None if time is not None else file_rate


def _disagree(*rates: float) -> bool:
    return max(rates) - min(rates) > RATE_RTOL * max(abs(r) for r in rates)
