"""What a recording says about itself: :class:`Source`, :class:`ChannelInfo` and helpers.

:func:`~.sources.open_source` opens any recording as a :class:`Source` (its
format, columns and metadata); the binary readers build theirs here too,
below the module that dispatches to them, so that no reader imports it back.

TDMS, HDF5 and MATLAB files name their channels (``group/channel``, a
dataset's path, a variable) and carry properties with them (a unit, an
increment, a start time, free text). Each reader (:mod:`.tdms`,
:mod:`.hdf5`, :mod:`.matlab`) lists them as :class:`ChannelInfo`; the
properties are made JSON-ready and bounded here (:func:`json_ready`) so that
they go into a record's provenance whatever a file holds.

References
----------
.. [TDMS] National Instruments, "TDMS File Format Internal Structure" (channel
   properties ``wf_increment``, ``wf_start_time``, ``unit_string``).
.. [HDF5] The HDF Group, "HDF5 User's Guide": datasets and attributes.
"""

import contextlib
import datetime as dt
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.validation import one_line, shown_name

MAX_PROPERTIES = 64
"""Most properties of one channel (or of the file) kept in the provenance."""

MAX_PROPERTY_CHARS = 200
"""Longest text of one property kept (longer ones are cut, marked with '...')."""

MAX_PROPERTY_VALUES = 16
"""Most numbers of an array-valued property kept (longer ones: their size only)."""


@dataclass(frozen=True)
class ChannelInfo:
    """One channel of a binary recording.

    Attributes
    ----------
    length : int
        Samples.
    unit : str or None
        The unit as the file spells it (TDMS ``unit_string``, an HDF5 ``unit``
        attribute), or None.
    rate : float or None
        Sample rate from the file (1 / TDMS ``wf_increment``), Hz.
    start : str or None
        Time of the first sample (TDMS ``wf_start_time``), ISO 8601.
    properties : dict
        The channel's other properties, JSON-ready.
    dtype : str
        The stored type (``float64``, ``int16``, ...).
    """

    length: int
    unit: str | None = None
    rate: float | None = None
    start: str | None = None
    properties: dict = field(default_factory=dict)
    dtype: str = "float64"


@dataclass(frozen=True)
class Source:
    """A recording file: its format, columns and (for accelcal records) metadata.

    Binary files (``backend`` ``tdms``, ``hdf5``, ``mat5``) also give each
    channel's :class:`ChannelInfo` (``channels``), where it is
    stored (``locations``) and the file's JSON-ready ``properties``.
    """

    path: Path
    input_format: str
    names: tuple[str, ...]
    delimiter: str = ","
    skip_rows: int = 0
    metadata: dict = field(default_factory=dict)
    channels: dict = field(default_factory=dict)
    properties: dict = field(default_factory=dict)
    locations: dict = field(default_factory=dict)
    backend: str = "table"


def json_ready(properties) -> dict:
    """Properties (a mapping) as a bounded JSON-ready dict: numbers, text, short lists."""
    out = {}
    for k, (key, value) in enumerate(dict(properties).items()):
        if k >= MAX_PROPERTIES:
            out["..."] = f"{len(properties) - MAX_PROPERTIES} more properties not kept"
            break
        out[_text(key)] = _value(value)
    return out


def _text(value) -> str:
    if isinstance(value, bytes):
        value = value.decode("utf-8", "replace")
    return one_line(str(value), MAX_PROPERTY_CHARS).replace("\x00", "")


def _value(value):
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    if isinstance(value, bool | np.bool_):
        return bool(value)
    if isinstance(value, int | np.integer):
        return int(value) if abs(int(value)) < 2**53 else str(int(value))
    if isinstance(value, float | np.floating):
        return float(value) if math.isfinite(value) else str(float(value))
    if isinstance(value, np.datetime64 | dt.datetime):
        return iso_time(value)
    if isinstance(value, np.ndarray | list | tuple):
        arr = np.asarray(value)
        if arr.size > MAX_PROPERTY_VALUES or arr.dtype.kind not in "biufSUO":
            return f"array of shape {list(arr.shape)}, {arr.dtype}"
        return [_value(v) for v in arr.reshape(-1)]
    return _text(value)


def iso_time(value) -> str | None:
    """A time stamp (numpy datetime64 or datetime) as ISO 8601 text, or None."""
    try:
        if isinstance(value, np.datetime64):
            if np.isnat(value):
                return None
            return str(np.datetime_as_string(value.astype("datetime64[us]"), unit="us"))
        return value.isoformat()
    except (ValueError, TypeError, OverflowError):
        return None


def numeric(dtype, name: str, file_name: str) -> None:
    """Refuse a channel whose stored type is not numbers (text, complex, compound)."""
    if np.dtype(dtype).kind not in "biuf":
        raise AccelcalError(f"{shown_name(file_name)}: channel {shown_name(name)} holds "
                            f"{np.dtype(dtype)}, not real numbers", parameter="columns")


def column_name(base: str, k: int) -> str:
    """The name of column ``k`` of a 2-D dataset or matrix: ``base[k]``."""
    return f"{base}[{k}]"


@contextlib.contextmanager
def library_errors(file_name: str, what: str):
    """Turn what a file library raises on a corrupt file into one AccelcalError line.

    npTDMS, h5py and scipy.io raise many types on damaged bytes (ValueError,
    KeyError, OSError, struct.error, EOFError, even MemoryError for a length
    field flipped to a huge value): the file is damaged whichever it is.
    AccelcalError passes unchanged.
    """
    try:
        yield
    except AccelcalError:
        raise
    except Exception as exc:  # the docstring says why
        raise AccelcalError(f"{shown_name(file_name)} is not a readable {what} file "
                            f"({type(exc).__name__}: {one_line(exc, 160)}); is it truncated "
                            "or damaged?") from None
