"""What a recording holds, for a user writing a mapping: :func:`inventory` (``accelcal inspect``).

Lists every channel (its name or path as the channel map spells it), its
length, stored type, unit, rate and start time as the file states them,
and the properties the file carries. Binary files (TDMS, HDF5, MAT) say
this in their headers, which are all that is read; a CSV file's length is
counted by Arrow's reader (one column parsed, in blocks); a Parquet file's
comes from its footer.

References
----------
.. [TDMS] National Instruments, "TDMS File Format Internal Structure".
.. [HDF5] The HDF Group, "HDF5 User's Guide".
.. [MAT] The MathWorks, "MAT-File Format".
"""

from accelcal.errors import AccelcalError
from accelcal.io.recordings.read import sha256
from accelcal.io.recordings.sources import BLOCK_BYTES, Source, open_source
from accelcal.validation import one_line, shown_name


def inventory(path, input_format: str = "auto", delimiter: str | None = None) -> dict:
    """The channels and properties of a recording.

    Returns
    -------
    dict
        ``file``, ``sha256``, ``input_format``, ``channels`` (a list of
        ``{name, length, dtype, unit, rate_hz, start_time, properties}``) and
        the file's ``properties``.
    """
    from accelcal.io.recordings.options import InputOptions

    InputOptions(input_format=input_format, delimiter=delimiter)  # checks them
    source = open_source(path, input_format, delimiter)
    if source.channels:
        rows = [{"name": n, "length": i.length, "dtype": i.dtype, "unit": i.unit,
                 "rate_hz": i.rate, "start_time": i.start, "properties": i.properties}
                for n, i in source.channels.items()]
    else:
        length = _table_length(source)
        rows = [{"name": n, "length": length, "dtype": None,
                 "unit": (source.metadata.get("units") or {}).get(n)
                 if isinstance(source.metadata.get("units"), dict) else None,
                 "rate_hz": source.metadata.get("rate"), "start_time": None, "properties": {}}
                for n in source.names]
    return {"file": source.path.name, "sha256": sha256(source.path),
            "input_format": source.input_format, "channels": rows,
            "properties": source.properties or source.metadata}


def _table_length(source: Source) -> int | None:
    """Rows of a CSV, Parquet or imu_tk file (counted; None for a file Arrow cannot read)."""
    import pyarrow as pa

    try:
        if source.input_format in ("parquet", "record") and _parquet(source):
            import pyarrow.parquet as pq

            return pq.ParquetFile(source.path).metadata.num_rows
        from pyarrow import csv

        if source.input_format == "imu_tk":
            parse = csv.ParseOptions(delimiter=" ")
            read = csv.ReadOptions(autogenerate_column_names=True, block_size=BLOCK_BYTES)
            convert = csv.ConvertOptions(include_columns=["f0"],
                                         column_types={"f0": pa.string()})
        else:
            parse = csv.ParseOptions(delimiter=source.delimiter)
            read = csv.ReadOptions(skip_rows=source.skip_rows, block_size=BLOCK_BYTES)
            convert = csv.ConvertOptions(include_columns=[source.names[0]],
                                         column_types={source.names[0]: pa.string()})
        return sum(len(b) for b in csv.open_csv(source.path, read_options=read,
                                                 parse_options=parse, convert_options=convert))
    except (pa.ArrowException, OSError) as exc:
        raise AccelcalError(f"{shown_name(source.path.name)}: cannot count its rows "
                            f"({one_line(exc, 200)})") from None


def _parquet(source: Source) -> bool:
    with open(source.path, "rb") as fh:
        return fh.read(4) == b"PAR1"
