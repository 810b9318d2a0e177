"""A lab's recordings as input: DAQ files (TDMS, HDF5, MAT, CSV, Parquet), imucal, imu_tk, records.

- :mod:`~accelcal.io.recordings.options`: :class:`InputOptions` (format,
  columns, time column or rate, unit and scale, per-channel units, delimiter,
  regions) and the units;
- :mod:`~accelcal.io.recordings.sources`: what a file is and its columns in
  batches (Arrow's CSV and Parquet readers, pandas' C engine), with one
  module per binary format: :mod:`~accelcal.io.recordings.tdms` (npTDMS),
  :mod:`~accelcal.io.recordings.hdf5` (h5py; MAT v7.3 too),
  :mod:`~accelcal.io.recordings.matlab` (MAT v5, scipy.io);
- :mod:`~accelcal.io.recordings.plan`, :mod:`~accelcal.io.recordings.checks`:
  what is read and the checks every block passes;
- :mod:`~accelcal.io.recordings.read`: :func:`read_recording` (whole) and
  :func:`iter_blocks` (streamed; :func:`open_stream` gives the provenance and rate first),
  with the same checks;
- :mod:`~accelcal.io.recordings.convert`, :mod:`~accelcal.io.recordings.kinds`,
  :mod:`~accelcal.io.recordings.mapping`: a recording made into a record file
  of a kind (``accelcal import``), and the mapping file of a DAQ layout;
- :mod:`~accelcal.io.recordings.inventory`: what a file holds (``accelcal inspect``).

Every method that reduces a lab's own recording reads it through here, and
the command line's input options (``accelcal.cli.input_options``) map onto
:class:`InputOptions` one to one.
"""

from accelcal.io.recordings.options import (
    ACCELERATION_UNITS,
    CHANNEL_UNITS,
    INPUT_FORMATS,
    RAW_UNITS,
    TEMPERATURE_UNITS,
    TIME_UNITS,
    UNITS,
    InputOptions,
)
from accelcal.io.recordings.read import (
    Block,
    Recording,
    Stream,
    describe,
    iter_blocks,
    open_stream,
    read_recording,
    sha256,
)

__all__ = [
    "ACCELERATION_UNITS",
    "CHANNEL_UNITS",
    "INPUT_FORMATS",
    "RAW_UNITS",
    "TEMPERATURE_UNITS",
    "TIME_UNITS",
    "UNITS",
    "Block",
    "InputOptions",
    "Recording",
    "Stream",
    "describe",
    "iter_blocks",
    "open_stream",
    "read_recording",
    "sha256",
]
