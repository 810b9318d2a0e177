"""Noise records: files of kind ``noise`` (still recordings) and their type :class:`NoiseRecord`.

A record file (see :mod:`accelcal.io.records`) of kind ``noise`` holds a
still recording of one or more channels sampled at a constant rate, one row
per sample. Columns: one per channel (default ``acc``), in the record's
unit. Metadata fields:

``rate`` (Hz, required)
    The sample rate (rows are consecutive samples: no time column).
``unit`` (required)
    Unit of the samples: ``g``, ``m/s^2``, ``V`` or ``mV`` (``counts``
    stored with the column unit ``1``).
``true`` (informative)
    The coefficients a simulation used: ``N``, ``B``, ``K``, ``Q``, ``R``,
    ``bias`` (in the unit, IEEE 952 units: N unit sqrt(s), B unit, K
    unit/sqrt(s), Q unit s, R unit/s).
``simulated``, ``seed``, ``b_range`` (informative), and the laboratory
fields ``serial``, ``operator``, ``date`` (:mod:`accelcal.io.lab_metadata`).

Long records are Parquet (``.parquet``): :func:`write_blocks` writes one row
group per block, so neither writing nor streaming them back
(:func:`accelcal.io.recordings.iter_blocks`, ``input_format="record"``) holds
more than a block. :func:`read` reads a record whole (bounded by
:data:`accelcal.io.records.MAX_RECORD_VALUES`); the noise method streams.

The simulator is :mod:`accelcal.rigs.noise`; the method,
:mod:`accelcal.methods.noise`.

References
----------
.. [IEEE952] IEEE Std 952-1997, Annex C (the noise terms and their units).
"""

import json
from dataclasses import dataclass, field

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.atomic import atomic_path
from accelcal.io.formats import ImportLayout
from accelcal.io.lab_metadata import LabInfo, check_lab_metadata
from accelcal.io.records import FORMAT_VERSION, MARKER, read_record, write_record, write_rows
from accelcal.validation import shown

KIND = "noise"
"""Record-file kind of still (noise) recordings."""

IMPORT = ImportLayout(stream=True, outputs="recorded", fixed_names=False, states=("rate", "unit"))
"""How ``accelcal import`` makes this kind from a recording."""

RECORD_UNITS = {"g": "g", "m/s^2": "m/s^2", "V": "V", "mV": "mV", "counts": "1"}
"""Sample unit -> column unit of the record file."""

_RESERVED = ("format_version", "kind", "units", "rate", "unit")

MAX_VALUE = 1e12
"""Largest magnitude of a sample (any unit, counts included): far beyond any
accelerometer's output, and small enough that the cumulative sums and squares of
1e10 samples stay within the float range. A larger value is a corrupt cell."""


def check_values(values, start: int, where) -> None:
    """Refuse a sample beyond :data:`MAX_VALUE` (naming its data row, 1-based from ``start``)."""
    big = np.flatnonzero(~(np.abs(values) <= MAX_VALUE))
    if big.size:
        raise AccelcalError(
            f"{where}: data row {start + int(big[0]) + 1} = {values.flat[big[0]]:.6g} is beyond "
            f"any physical value (magnitude up to {MAX_VALUE:g}); is the file corrupt?",
            parameter="values")


@dataclass(frozen=True)
class NoiseRecord:
    """A still recording sampled at a constant rate.

    Attributes
    ----------
    values : numpy.ndarray, shape (n, k)
        Samples of ``k`` channels, in ``unit``.
    rate : float
        Sample rate, Hz.
    unit : str
        Unit of the samples (a key of :data:`RECORD_UNITS`).
    channels : tuple of str
        Column names.
    metadata : dict
        The file's other metadata (``true``, ``seed``, ``simulated``,
        laboratory fields), JSON-ready.
    """

    values: np.ndarray
    rate: float
    unit: str
    channels: tuple[str, ...] = ("acc",)
    metadata: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        values = np.array(self.values, dtype=float)
        if values.ndim == 1:
            values = values[:, None]
        channels = tuple(self.channels)
        if values.ndim != 2 or values.shape[1] != len(channels):
            raise AccelcalError(f"a noise record needs values of shape (n, {len(channels)}) "
                                f"for channels {channels}; got {np.shape(self.values)}")
        check_header(self.rate, self.unit, "noise record")
        values.setflags(write=False)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "channels", channels)

    @property
    def samples(self) -> int:
        """Number of samples."""
        return self.values.shape[0]

    @property
    def lab(self) -> LabInfo:
        """The laboratory metadata (serial, operator, date)."""
        return check_lab_metadata(self.metadata, "noise record")


def check_header(rate, unit, where) -> None:
    """Check a noise record's ``rate`` (positive, finite) and ``unit``."""
    ok = isinstance(rate, int | float) and not isinstance(rate, bool) and 0 < rate < 1e10
    if not ok:
        raise AccelcalError(f"{where}: rate {shown(rate)} must be a positive number of Hz")
    if not isinstance(unit, str) or unit not in RECORD_UNITS:
        raise AccelcalError(f"{where}: unit {shown(unit)} is not one of "
                            f"{', '.join(RECORD_UNITS)}")


def _header(rate, unit, channels, metadata) -> dict:
    check_header(rate, unit, "noise record")
    return {"units": dict.fromkeys(channels, RECORD_UNITS[unit]), "rate": float(rate),
            "unit": unit, **{k: v for k, v in metadata.items() if k not in _RESERVED}}


def write(path, data: NoiseRecord) -> None:
    """Write a noise record file (atomically; CSV, or Parquet for ``.parquet``)."""
    write_record(path, KIND, _header(data.rate, data.unit, data.channels, data.metadata),
                 {c: data.values[:, k] for k, c in enumerate(data.channels)})


def write_blocks(path, blocks, *, rate: float, unit: str, channels=("acc",),
                 metadata=None, progress=None, total=None) -> int:
    """Write a noise record from blocks of samples, holding one block at a time.

    Parameters
    ----------
    path : path-like
        ``.parquet`` (one row group per block) or CSV.
    blocks : iterable of numpy.ndarray
        Consecutive blocks, shape ``(rows,)`` or ``(rows, k)``.
    rate, unit, channels, metadata
        As :class:`NoiseRecord`.
    progress : callable, optional
        ``progress(done, total)`` after each block (rows).
    total : int, optional
        Total rows, for ``progress``.

    Returns
    -------
    int
        Rows written.
    """
    channels = tuple(channels)
    header = {"format_version": FORMAT_VERSION, "kind": KIND,
              **_header(rate, unit, channels, metadata or {})}
    text = json.dumps(header, allow_nan=False)
    parquet = str(path).lower().endswith(".parquet")
    done = 0
    with atomic_path(path) as tmp:
        if parquet:
            import pyarrow as pa
            import pyarrow.parquet as pq

            schema = pa.schema([(c, pa.float64()) for c in channels],
                               metadata={"accelcal": text})
            from accelcal.io.records import parquet_options

            with pq.ParquetWriter(tmp, schema, **parquet_options(schema)) as writer:
                for block in blocks:
                    arr = np.asarray(block, dtype=float).reshape(len(block), -1)
                    writer.write_table(pa.table({c: arr[:, k] for k, c in enumerate(channels)},
                                                schema=schema))
                    done += arr.shape[0]
                    if progress:
                        progress(done, total or done)
        else:
            with open(tmp, "wb") as fh:
                fh.write((MARKER + "\n# " + text + "\n" + ",".join(channels) + "\n").encode())
                for block in blocks:
                    arr = np.asarray(block, dtype=float).reshape(len(block), -1)
                    write_rows(fh, list(channels), list(arr.T))
                    done += arr.shape[0]
                    if progress:
                        progress(done, total or done)
    return done


def read(path) -> NoiseRecord:
    """Read and validate a noise record file whole.

    Raises
    ------
    AccelcalError
        Naming the file: see :func:`accelcal.io.records.read_record`; a bad
        rate or unit; malformed laboratory metadata.
    """
    meta, cols = read_record(path, KIND, required_metadata=("rate", "unit"))
    check_header(meta["rate"], meta["unit"], path)
    check_lab_metadata(meta, path)
    channels = tuple(cols)
    for c in channels:
        check_values(cols[c], 0, f"{path}: column {c}")
    return NoiseRecord(values=np.column_stack([cols[c] for c in channels]), rate=meta["rate"],
                       unit=meta["unit"], channels=channels,
                       metadata={k: v for k, v in meta.items() if k not in _RESERVED})
