"""NI TDMS recordings, read with npTDMS in streaming mode.

A TDMS file holds groups of channels; a channel is named ``group/channel``
here. The file is opened with :meth:`nptdms.TdmsFile.open`, which reads the
segments' metadata only, and each batch reads a slice of every wanted
channel (``channel[start:stop]``), so memory is bounded by a batch whatever
the file's length. DAQmx scaling stored in the file is applied by npTDMS.

A channel's properties give its sample rate (1 / ``wf_increment``), the time
of its first sample (``wf_start_time``) and its unit (``unit_string``); the
others go, JSON-ready, into the provenance, with the file's and the groups'
properties.

References
----------
.. [TDMS] National Instruments, "TDMS File Format Internal Structure"
   (segments, lead-in ``TDSm``, channel properties ``wf_increment``,
   ``wf_start_time``, ``unit_string``).
.. [npTDMS] A. Reeve et al., npTDMS documentation: "Reading TDMS files"
   (``TdmsFile.open``, streaming reads of channel slices).
"""

import contextlib
import logging
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.recordings.channels import (
    ChannelInfo,
    Source,
    iso_time,
    json_ready,
    library_errors,
    numeric,
)
from accelcal.validation import MAX_RATE_HZ, MIN_RATE_HZ, one_line, shown_name

MAGIC = b"TDSm"
"""First bytes of a TDMS file's lead-in (``TDSh`` starts an index file)."""

_OWN = ("wf_increment", "wf_start_time", "unit_string")


def open_tdms(path: Path):
    """The channels of a TDMS file and its properties, as a :class:`~.sources.Source`."""
    from nptdms import TdmsFile

    channels, groups = {}, {}
    size = path.stat().st_size
    with (_damage(path.name), library_errors(path.name, "TDMS"), open(path, "rb") as fh,
          TdmsFile.open(fh) as tdms):  # our file object: npTDMS leaks its own on errors
        file_props = json_ready(tdms.properties)
        for group in tdms.groups():
            if group.properties:
                groups[group.name] = json_ready(group.properties)
            for channel in group.channels():
                name = f"{group.name}/{channel.name}"
                channels[name] = _info(channel, name, size, path.name)
    if not channels:
        raise AccelcalError(f"{shown_name(path.name)}: the TDMS file has no channels")
    properties = {"file": file_props} if file_props else {}
    if groups:
        properties["groups"] = groups
    return Source(path, "tdms", tuple(channels), channels=channels, properties=properties,
                  backend="tdms")


class _Warnings(logging.Handler):
    def __init__(self):
        super().__init__(logging.WARNING)
        self.messages = []

    def emit(self, record):
        self.messages.append(record.getMessage())


@contextlib.contextmanager
def _damage(file_name: str):
    """Refuse a file npTDMS reads with a warning: it logs, then reads what it can [npTDMS].

    A TDMS file cut short (a last segment with less data than its lead-in
    says) or otherwise damaged would be read shorter without a word. The
    warnings npTDMS would print on standard error are silenced meanwhile:
    the first one is quoted, shortened, in the one-line error.
    """
    from nptdms.log import log_manager

    handler = _Warnings()
    log = logging.getLogger("nptdms")
    log.addHandler(handler)
    console = log_manager.console_handler  # npTDMS prints its warnings (raw bytes and all)
    level = console.level
    console.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        log.removeHandler(handler)
        console.setLevel(level)
    if handler.messages:
        raise AccelcalError(f"{shown_name(file_name)} is truncated or damaged (npTDMS: "
                            f"{one_line(handler.messages[0], 160)})")


def _info(channel, name: str, size: int, file_name: str) -> ChannelInfo:
    props = dict(channel.properties)
    length = len(channel)
    dtype = channel.dtype if channel.dtype is not None else np.dtype(float)
    if length and np.dtype(dtype).kind in "biuf" and length * np.dtype(dtype).itemsize > size:
        raise AccelcalError(f"{shown_name(file_name)}: channel {shown_name(name)} claims "
                            f"{length} values, more than the file's {size} bytes hold; is it "
                            "truncated or damaged?")
    increment = props.get("wf_increment")
    rate = None
    if isinstance(increment, int | float | np.number) and not isinstance(increment, bool):
        increment = float(increment)
        rate = 1.0 / increment if np.isfinite(increment) and increment > 0 else None
        if rate is not None and not MIN_RATE_HZ <= rate <= MAX_RATE_HZ:
            raise AccelcalError(f"{shown_name(file_name)}: channel {shown_name(name)} has "
                                f"wf_increment {increment:g} s, a sample rate of {rate:g} Hz; "
                                f"a rate must be from {MIN_RATE_HZ:g} to {MAX_RATE_HZ:g} Hz")
    unit = props.get("unit_string")
    return ChannelInfo(length=length, unit=unit if isinstance(unit, str) else None, rate=rate,
                       start=iso_time(props["wf_start_time"]) if "wf_start_time" in props
                       else None,
                       properties=json_ready({k: v for k, v in props.items() if k not in _OWN}),
                       dtype=str(np.dtype(dtype)) if np.dtype(dtype).kind in "biuf"
                       else str(dtype))


def tdms_batches(source, names: list[str], rows: int) -> Iterator[dict[str, np.ndarray]]:
    """The channels ``names`` of a TDMS file in slices of at most ``rows`` samples."""
    from nptdms import TdmsFile

    for name in names:
        numeric(source.channels[name].dtype, name, source.path.name)
    length = source.channels[names[0]].length
    with (_damage(source.path.name), library_errors(source.path.name, "TDMS"),
          open(source.path, "rb") as fh, TdmsFile.open(fh) as tdms):
        handles = {}
        for group in tdms.groups():
            for channel in group.channels():
                key = f"{group.name}/{channel.name}"
                if key in names:
                    handles[key] = channel
        for start in range(0, length, rows):
            stop = min(start + rows, length)
            out = {}
            for name in names:
                data = np.asarray(handles[name][start:stop], dtype=float)
                if data.shape != (stop - start,):
                    raise AccelcalError(f"{shown_name(source.path.name)}: channel "
                                        f"{shown_name(name)} gave {data.size} values for "
                                        f"samples {start}:{stop}; is the file truncated?")
                out[name] = data
            yield out
