"""MATLAB MAT-file recordings: version 5 (scipy.io) and version 7.3 (HDF5, h5py).

A channel is a numeric variable: a vector (``n x 1`` or ``1 x n``) named by
the variable, or column ``k`` of an ``n x m`` matrix (samples down the
rows, as MATLAB's DAQ toolbox returns them), named ``var[k]``. Scalars and
short text variables (``Fs``, a sensor name) are listed as properties and go
into the provenance, so a user can see the rate a file states and give it.

Version 7.3 files are HDF5 and stream like any HDF5 file
(:mod:`accelcal.io.recordings.hdf5`, which undoes MATLAB's column-major
storage). Version 5 files cannot be sliced: :func:`scipy.io.loadmat` reads
the wanted variables **whole** (only those: others are skipped), so a v5
file is bounded by :data:`MAX_MAT5_BYTES` and by the memory the machine
has to spare; a long recording should be saved with ``save -v7.3``.

References
----------
.. [MAT] The MathWorks, "MAT-File Format" (level 5 MAT-file: 128-byte header
   starting ``MATLAB 5.0 MAT-file``, data elements) and "MAT-File Versions"
   (version 7.3: HDF5 after a 512-byte header ``MATLAB 7.3 MAT-file``).
.. [scipy] SciPy documentation, ``scipy.io.loadmat`` and ``scipy.io.whosmat``.
"""

from collections.abc import Iterator
from pathlib import Path

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.recordings.channels import (
    ChannelInfo,
    Source,
    column_name,
    json_ready,
    library_errors,
    numeric,
)
from accelcal.validation import shown_name

MAGIC_V5 = b"MATLAB 5.0 MAT-file"
MAGIC_V73 = b"MATLAB 7.3 MAT-file"
HDF5_OFFSET = 512
"""Where the HDF5 signature of a v7.3 MAT-file is (after MATLAB's header)."""

MAX_MAT5_BYTES = 2**30
"""Largest v5 MAT-file read (1 GiB): a v5 file is read whole (save long ones with -v7.3)."""

MAX_PROPERTY_ELEMENTS = 16
"""Numeric variables with at most this many elements are properties, not channels."""

MAX_ELEMENTS = 100_000
"""Most top-level variables of a v5 MAT-file walked."""

MI_COMPRESSED = 15
"""Data type of a zlib-compressed element (not padded to 8 bytes) [MAT]."""

_NUMERIC = ("double", "single", "int8", "uint8", "int16", "uint16", "int32", "uint32",
            "int64", "uint64")


def open_mat(path: Path, head: bytes):
    """The variables of a MAT-file, as a :class:`~.sources.Source` (v7.3: through HDF5)."""
    from accelcal.io.recordings.hdf5 import MAGIC, open_hdf5

    if head.startswith(MAGIC_V73) and head[HDF5_OFFSET:HDF5_OFFSET + 8] == MAGIC:
        return open_hdf5(path, matlab=True)
    if not head.startswith(MAGIC_V5):
        raise AccelcalError(f"{shown_name(path.name)} is not a MATLAB v5 or v7.3 MAT-file (its "
                            "header does not start 'MATLAB 5.0 MAT-file' or 'MATLAB 7.3 "
                            "MAT-file' with HDF5 after it); save it with -v7 or -v7.3",
                            parameter="input_format")
    return _open_v5(path)


def _open_v5(path: Path):
    import scipy.io

    size = path.stat().st_size
    if size > MAX_MAT5_BYTES:
        raise AccelcalError(f"{shown_name(path.name)}: {size / 2**20:.0f} MiB; a v5 MAT-file is "
                            f"read whole and is read up to {MAX_MAT5_BYTES // 2**20} MiB: save "
                            "a long recording with save -v7.3 (HDF5, streamed)")
    _check_elements(path, size)
    channels, where, small, skipped = {}, {}, [], {}
    with library_errors(path.name, "MATLAB v5"):
        listing = scipy.io.whosmat(path)
        for name, shape, cls in listing:
            numel = int(np.prod(shape)) if shape else 0
            if (cls == "char" and numel <= 200) or (cls in _NUMERIC
                                                    and 0 < numel <= MAX_PROPERTY_ELEMENTS):
                small.append(name)
            elif cls in _NUMERIC and len(shape) == 2 and numel:
                _add(name, shape, cls, (channels, where, skipped))
            else:
                skipped[name] = f"{cls} of shape {list(shape)}"
        props = _small(path, small)
    if not channels:
        raise AccelcalError(f"{shown_name(path.name)}: the MAT-file has no numeric vector or "
                            "matrix to read as a channel")
    properties = {"variables": props} if props else {}
    if skipped:
        properties["not channels"] = skipped
    return Source(path, "mat", tuple(channels), channels=channels, properties=properties,
                  locations=where, backend="mat5")


def _check_elements(path: Path, size: int) -> None:
    """Walk the top-level data elements' tags: they must end exactly at the end of the file.

    Each element starts with a tag (type, byte count; a small element packs
    both into 4 bytes and its data into the next 4) and is padded to 8 bytes
    unless compressed [MAT]. A file cut short, or with bytes after its last
    element, fails; scipy would drop a cut variable without a word.
    """
    import struct

    with open(path, "rb") as fh:
        fh.seek(126)
        order = {b"IM": "<", b"MI": ">"}.get(fh.read(2))
        if order is None:
            raise AccelcalError(f"{shown_name(path.name)}: the MAT-file header's endian "
                                "indicator is neither 'IM' nor 'MI'; is the file damaged?")
        pos = 128
        for _ in range(MAX_ELEMENTS):
            if pos >= size:
                break
            fh.seek(pos)
            tag = fh.read(8)
            kind, nbytes = struct.unpack(order + "II", tag) if len(tag) == 8 else (0, size)
            if kind >> 16:  # a small data element: tag and data in 8 bytes
                pos += 8
            else:
                pos += 8 + nbytes + (0 if kind == MI_COMPRESSED else -nbytes % 8)
        else:
            raise AccelcalError(f"{shown_name(path.name)} holds more than {MAX_ELEMENTS} "
                                "variables; is it a recording?")
    if pos != size:
        raise AccelcalError(f"{shown_name(path.name)}: its last variable ends at byte {pos}, "
                            f"the file at byte {size}; is it truncated or damaged?")


def _add(name: str, shape, cls: str, found: tuple[dict, dict, dict]) -> None:
    channels, where, skipped = found
    from accelcal.io.recordings.hdf5 import MAX_COLUMNS

    rows, cols = shape
    if 1 not in shape and cols > MAX_COLUMNS:
        skipped[name] = f"{cols} columns of {rows} samples (more than {MAX_COLUMNS})"
        return
    dtype = "float64" if cls == "double" else ("float32" if cls == "single" else cls)
    if 1 in shape:
        channels[name] = ChannelInfo(length=max(shape), dtype=dtype)
        where[name] = (name, None)
        return
    for k in range(cols):
        channels[column_name(name, k)] = ChannelInfo(length=rows, dtype=dtype)
        where[column_name(name, k)] = (name, k)


def _small(path: Path, names: list[str]) -> dict:
    import scipy.io

    if not names:
        return {}
    data = scipy.io.loadmat(path, variable_names=names, squeeze_me=True, chars_as_strings=True)
    return json_ready({n: data[n] for n in names if n in data})


def mat_batches(source, names: list[str], rows: int) -> Iterator[dict[str, np.ndarray]]:
    """The channels ``names`` of a v5 MAT-file in batches of ``rows``, from variables read whole."""
    import scipy.io

    from accelcal.resources import check_memory

    for name in names:
        numeric(source.channels[name].dtype, name, source.path.name)
    length = source.channels[names[0]].length
    variables = sorted({source.locations[n][0] for n in names})
    cells = sum(int(np.prod(_shape(source, v))) for v in variables)
    check_memory(cells, 1, 3, f"reading {shown_name(source.path.name)} (a v5 MAT-file is read "
                 "whole)", hint="save it with -v7.3 to stream it")
    with library_errors(source.path.name, "MATLAB v5"):
        data = scipy.io.loadmat(source.path, variable_names=variables, squeeze_me=False)
        arrays = {}
        for name in names:
            var, k = source.locations[name]
            value = np.asarray(data[var])
            if np.iscomplexobj(value):
                raise AccelcalError(f"{shown_name(source.path.name)}: variable "
                                    f"{shown_name(var)} is complex; a channel holds real "
                                    "samples (save the real and imaginary parts apart)")
            arrays[name] = (value.reshape(-1) if k is None else value[:, k]).astype(float)
            if arrays[name].shape != (length,):
                raise AccelcalError(f"{shown_name(source.path.name)}: variable "
                                    f"{shown_name(var)} does not have the shape its header "
                                    "gives; is the file damaged?")
    for start in range(0, length, rows):
        yield {name: a[start:start + rows] for name, a in arrays.items()}


def _shape(source, variable: str) -> tuple[int, ...]:
    names = [n for n, loc in source.locations.items() if loc[0] == variable]
    return (source.channels[names[0]].length, max(1, len(names)))
