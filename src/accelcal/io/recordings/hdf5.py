r"""HDF5 recordings (and MATLAB v7.3 MAT-files, which are HDF5), read with h5py.

A channel is a dataset named by its path (``Accel/X``, without the leading
``/``): a 1-D dataset, or column ``k`` of a 2-D dataset of shape
``(samples, columns)``, named ``path[k]``. Batches read hyperslabs
(``dataset[start:stop, k]``), so memory is bounded by a batch and by the
dataset's chunks: a compressed chunk is decompressed whole, so before
anything is read the chunks one step needs (their declared shape times the
item size) are weighed against the process's memory limit
(:func:`accelcal.io.limits.memory_limit`) and refused with the figure if
they do not fit; otherwise HDF5's chunk cache is made large enough to hold
them, and the reads step along the chunks, so each chunk is decompressed
once (a small file of one 3 GB gzip chunk would otherwise be decompressed
again for every batch). A dataset's
``unit`` (or ``units``) attribute gives its unit; its other attributes, and
the root's, go into the provenance. A dataset whose storage does not cover
its shape (unwritten chunks: HDF5 would return fill values for them) is
refused, as a truncated file.

A MATLAB v7.3 MAT-file is an HDF5 file after a 512-byte header; MATLAB
stores an ``n x m`` matrix in column-major order, so HDF5 sees it transposed,
``(m, n)``: column ``k`` of the MATLAB matrix, named ``var[k]``, is row ``k``
of the dataset, and a vector (``n x 1`` or ``1 x n``) is named ``var``.
Fields of a MATLAB struct are datasets of a group (``s/field``); text
(``char``) variables and scalars go into the provenance.

References
----------
.. [HDF5] The HDF Group, "HDF5 User's Guide" (datasets, attributes,
   chunked storage) and "HDF5 File Format Specification" (signature
   ``\x89HDF\r\n\x1a\n`` at offset 0, 512, 1024, ...).
.. [MAT73] The MathWorks, "MAT-File Versions": version 7.3 MAT-files use an
   HDF5-based format; MATLAB arrays are stored column-major.
.. [h5py] A. Collette et al., h5py documentation: "Datasets" (slicing reads
   hyperslabs).
"""

import math
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

MAGIC = b"\x89HDF\r\n\x1a\n"
"""The HDF5 signature."""

MAX_OBJECTS = 10_000
"""Most groups and datasets listed in one file."""

MAX_COLUMNS = 1024
"""Most columns of a 2-D dataset listed as channels (a wider one is listed as skipped)."""

_UNIT_ATTRS = ("unit", "units", "unit_string")


def open_hdf5(path: Path, *, matlab: bool = False):
    """The channels of an HDF5 file (or a MAT v7.3 file), as a :class:`~.sources.Source`."""
    import h5py

    what = "MATLAB v7.3" if matlab else "HDF5"
    channels, where, props, skipped = {}, {}, {}, {}
    with library_errors(path.name, what), h5py.File(path, "r") as h5:
        props = json_ready(h5.attrs)
        objects = []
        h5.visititems(lambda name, obj: _collect(objects, name, obj))
        for name, ds in objects:
            if not isinstance(ds, h5py.Dataset):
                continue
            _add(ds, name, path.name, matlab=matlab,
                 found=(channels, where, props, skipped))
    if not channels:
        raise AccelcalError(f"{shown_name(path.name)}: the {what} file has no numeric "
                            "dataset to read as a channel")
    properties = {"attributes": props} if props else {}
    if skipped:
        properties["not channels"] = skipped
    return Source(path, "mat" if matlab else "hdf5", tuple(channels), channels=channels,
                  properties=properties, locations=where, backend="hdf5")


def _collect(objects: list, name: str, obj):
    if len(objects) >= MAX_OBJECTS:
        raise AccelcalError(f"the file holds more than {MAX_OBJECTS} groups and datasets")
    objects.append((name, obj))


def _add(ds, name: str, file_name: str, *, matlab: bool, found: tuple) -> None:
    channels, where, props, skipped = found
    attrs = dict(ds.attrs)
    cls = attrs.pop("MATLAB_class", b"")
    cls = cls.decode("ascii", "replace") if isinstance(cls, bytes) else str(cls)
    shape = ds.shape
    if matlab and cls == "char" and ds.size <= 4096:
        props[name] = "".join(map(chr, np.asarray(ds[()]).reshape(-1, order="F")
                                  .astype(np.uint32) % 0x110000))
        return
    if shape is None or ds.dtype.kind not in "biuf" or len(shape) > 2 or ds.size == 0:
        skipped[name] = f"{ds.dtype} of shape {list(shape or ())}"
        return
    if ds.size == 1:
        props[name] = json_ready({"v": ds[()]})["v"]
        return
    _check_storage(ds, name, file_name)
    unit = next((attrs[a] for a in _UNIT_ATTRS if a in attrs), None)
    unit = unit.decode("utf-8", "replace") if isinstance(unit, bytes) else unit
    info = {"unit": unit if isinstance(unit, str) else None, "dtype": str(ds.dtype),
            "properties": json_ready({k: v for k, v in attrs.items() if k not in _UNIT_ATTRS})}
    if len(shape) == 1 or (matlab and 1 in shape):
        channels[name] = ChannelInfo(length=max(shape), **info)
        where[name] = (name, None, matlab and len(shape) == 2 and shape[0] == 1)
        return
    samples, cols = (shape[1], shape[0]) if matlab else shape
    if cols > MAX_COLUMNS:
        skipped[name] = f"{cols} columns of {samples} samples (more than {MAX_COLUMNS})"
        return
    for k in range(cols):
        channels[column_name(name, k)] = ChannelInfo(length=samples, **info)
        where[column_name(name, k)] = (name, k, matlab)


def _check_storage(ds, name: str, file_name: str) -> None:
    """Refuse a dataset whose written storage does not cover its shape (a truncated file)."""
    if ds.chunks is None:
        if ds.id.get_offset() is None and ds.id.get_storage_size() < ds.nbytes:
            _unwritten(name, file_name)
        return
    expected = math.prod(math.ceil(s / c) for s, c in zip(ds.shape, ds.chunks, strict=True))
    if ds.id.get_num_chunks() < expected:
        _unwritten(name, file_name)


def _unwritten(name: str, file_name: str):
    raise AccelcalError(f"{shown_name(file_name)}: dataset {shown_name(name)} is not written "
                        "to its full shape (HDF5 would give fill values for the rest); is the "
                        "file truncated?")


def hdf5_batches(source, names: list[str], rows: int) -> Iterator[dict[str, np.ndarray]]:
    """The channels ``names`` in hyperslabs of at most ``rows`` samples.

    Raises
    ------
    AccelcalError
        When the decompressed chunks one step reads (every wanted dataset's
        chunks across a chunk's length of samples) would not fit in the
        memory the process may take; the message gives the figure.
    """
    import h5py

    for name in names:
        numeric(source.channels[name].dtype, name, source.path.name)
    length = source.channels[names[0]].length
    what = "MATLAB v7.3" if source.input_format == "mat" else "HDF5"
    with library_errors(source.path.name, what), h5py.File(source.path, "r") as h5:
        cache = _chunk_cache(h5, source, names, rows)
    with library_errors(source.path.name, what), h5py.File(
            source.path, "r", rdcc_nbytes=cache, rdcc_w0=1.0, rdcc_nslots=_SLOTS) as h5:
        for start in range(0, length, rows):
            stop = min(start + rows, length)
            yield {name: _slab(h5, source.locations[name], start, stop) for name in names}


_SLOTS = 10_007
"""Hash slots of HDF5's chunk cache (a prime, as the HDF5 guide advises)."""

_CACHE_BYTES = 2**20
"""HDF5's own chunk cache (1 MiB), kept when the chunks are smaller."""


def _chunk_cache(h5, source, names: list[str], rows: int) -> int:
    """The chunk cache (bytes) that holds every chunk a batch touches, so each decompresses once.

    Refused when those chunks, plus a batch's values, exceed the share of
    the process's memory limit a computation may take.
    """
    from accelcal.io.limits import memory_limit
    from accelcal.resources import MEMORY_SHARE, shown_bytes

    chunk_bytes = 0
    for path in sorted({source.locations[n][0] for n in names}):
        ds = h5[path]
        if ds.chunks is None:
            continue
        transposed = next(loc[2] for loc in source.locations.values() if loc[0] == path)
        axis = 1 if transposed and ds.ndim == 2 else 0
        across = [math.ceil(s / c) for s, c in zip(ds.shape, ds.chunks, strict=True)]
        across[axis] = 1
        chunk_bytes += math.prod(ds.chunks) * ds.dtype.itemsize * math.prod(across)
    need = chunk_bytes + 2 * rows * len(names) * 8
    limit = MEMORY_SHARE * memory_limit()
    if need > limit:
        raise AccelcalError(
            f"{shown_name(source.path.name)}: reading it needs about {shown_bytes(need)} of "
            f"memory (its chunks decompress to {shown_bytes(chunk_bytes)}); this process can "
            f"take {shown_bytes(limit)}; rewrite the file with smaller chunks")
    return max(_CACHE_BYTES, chunk_bytes + chunk_bytes // 8)


def _slab(h5, location, start: int, stop: int) -> np.ndarray:
    path, k, transposed = location
    ds = h5[path]
    if k is None:
        data = ds[0, start:stop] if transposed else (ds[start:stop] if ds.ndim == 1
                                                     else ds[start:stop, 0])
    else:
        data = ds[k, start:stop] if transposed else ds[start:stop, k]
    return np.asarray(data, dtype=float).reshape(-1)
