"""The input options of every command that reads a lab's recording.

Each option is a module-level typer Option that commands declare as a
default (``columns: str | None = COLUMNS``), so every command spells and
documents them alike; :func:`input_options` turns their values into one
:class:`~accelcal.io.recordings.InputOptions` (which checks them). The
library names the Python parameters in its errors; the CLI shows the
option (``--time-unit`` for ``time_unit``).
"""

from pathlib import Path

import typer

INPUT_FORMAT = typer.Option(
    "auto", "--input-format",
    help="auto, csv, parquet, imucal (acc_x,acc_y,acc_z with a 'part' column or --regions; "
         "m/s^2 unless --unit says otherwise, e.g. counts for a raw session), imu_tk "
         "('t x y z' rows separated by spaces), record (an accelcal record), tdms (NI, "
         "channels group/channel), hdf5 (datasets by path, path[k] for a "
         "column) or mat (MATLAB v5 or v7.3, var[k] for a column); auto tells them apart "
         "from the file's first bytes.")
COLUMNS = typer.Option(
    None, "--columns",
    help="The channels' columns, in order, separated by commas (e.g. X,Y,Z); default: "
         "acc_x,acc_y,acc_z (imucal, triad records) or x,y,z (imu_tk).")
COLUMN = typer.Option(
    None, "--column", help="The channel's column (default: the record's own channel).")
TIME = typer.Option(
    None, "--time", help="Name of the time column (strictly increasing); or give --rate.")
TIME_UNIT = typer.Option("s", "--time-unit", help="Unit of the time column: s, ms, us or ns.")
RATE = typer.Option(None, "--rate", help="Sample rate in Hz, for files without a time column.")
UNIT = typer.Option(
    None, "--unit",
    help="Unit of the values: counts, V, mV (raw outputs) or m/s^2, g, mg, ug; required for "
         "files that do not state it (records, TDMS unit_string and HDF5 unit attributes "
         "say theirs; imucal sessions are taken as m/s^2 unless given: a raw session in ADC "
         "counts needs --unit counts); with --scale, the unit of file value x scale.")
SCALE = typer.Option(
    None, "--scale",
    help="File value x scale = value in --unit (e.g. counts to g: the g per count).")
DELIMITER = typer.Option(
    None, "--delimiter", help="Field delimiter of a CSV file (one character; default ',').")
REGIONS = typer.Option(
    None, "--regions",
    help="An imucal regions JSON ({\"x_p\": {\"start\": i, \"end\": j}, ...}, end exclusive) "
         "labelling sample ranges.")

GAPS = typer.Option(
    "refuse", "--gaps",
    help="At a gap in the time column (a step over 1.5 sample intervals) or a row with an "
         "empty or NaN cell: refuse (default), split (segments, listed in notes) or fill "
         "(linear interpolation of at most --max-fill samples, flagged).")
MAX_FILL = typer.Option(5, "--max-fill", help="Most missing samples one gap may have to be "
                                              "filled with --gaps fill.")
SORT = typer.Option(False, "--sort", help="Sort rows whose time goes backwards (refused "
                                          "otherwise, with the row).")
JITTER_TOL = typer.Option(
    None, "--jitter-tol",
    help="Largest step off the nominal sample interval, as a fraction of it (e.g. 0.05); "
         "a step further off is refused, or resampled with --resample. Default: not checked.")
RESAMPLE = typer.Option(False, "--resample",
                        help="With --jitter-tol: interpolate the channels linearly onto the "
                             "uniform grid of the rate.")

RAILS = typer.Option(
    None, "--rails",
    help="The clipping levels LOW,HIGH (in --unit, after --scale; e.g. the ADC's range): "
         "runs of 3 or more samples at or beyond one are clipped: refused, or left out "
         "with --gaps split. triad: left out of the static intervals and the fit; there "
         "the default is auto (runs of 10 or more identical samples at a channel's "
         "extreme), none to look for no clipping.")


def input_options(*, input_format: str = "auto", columns: str | None = None,
                  column: str | None = None, time: str | None = None, time_unit: str = "s",
                  rate: float | None = None, unit: str | None = None,
                  delimiter: str | None = None, regions: Path | None = None,
                  scale: float | None = None, gaps: str = "refuse", max_fill: int = 5,
                  sort: bool = False, jitter_tol: float | None = None,
                  resample: bool = False, rails: str | None = None):
    """The :class:`~accelcal.io.recordings.InputOptions` of a command's input options.

    ``columns`` is a comma-separated list; ``column`` a single name (commands
    reading one channel); give at most one of them. ``gaps`` to ``resample``:
    the repairs of a messy time column (:mod:`accelcal.io.recordings.repairs`).
    """
    from accelcal.errors import AccelcalError
    from accelcal.io.recordings import InputOptions

    if columns is not None and column is not None:
        raise AccelcalError("give either --columns or --column, not both", parameter="columns")
    names = None
    if columns is not None:
        names = tuple(c.strip() for c in columns.split(","))
    elif column is not None:
        names = (column.strip(),)
    if delimiter == "\\t":
        delimiter = "\t"
    return InputOptions(input_format=input_format, columns=names, time=time,
                        time_unit=time_unit, rate=rate, unit=unit, delimiter=delimiter,
                        regions=regions, scale=scale, gaps=gaps, max_fill=max_fill, sort=sort,
                        jitter_tol=jitter_tol, resample=resample,
                        rails=None if rails is None else parse_rails(rails))


def repair_options(gaps: str = "refuse", max_fill: int = 5, sort: bool = False,
                   jitter_tol: float | None = None, resample: bool = False) -> dict:
    """The values of :data:`GAPS` to :data:`RESAMPLE` as :class:`InputOptions` keywords.

    Every command that reads a recording declares those options and passes
    their values through here (a record's reader takes ``gaps`` and ``max_fill``).
    """
    return {"gaps": gaps, "max_fill": max_fill, "sort": sort, "jitter_tol": jitter_tol,
            "resample": resample}


def parse_rails(text: str):
    """``LOW,HIGH`` as two numbers (checked by InputOptions)."""
    from accelcal.errors import AccelcalError

    try:
        return tuple(float(v) for v in text.split(","))
    except ValueError:
        raise AccelcalError(f"--rails {text!r}: give LOW,HIGH, e.g. -2,2",
                            parameter="rails") from None


def static_rails(text: str | None):
    """``--rails`` of a command that leaves clipped samples out (triad).

    ``"auto"`` when not given or ``auto``, None for ``none``, else ``LOW,HIGH``.
    """
    if text is None or text.strip().lower() == "auto":
        return "auto"
    if text.strip().lower() == "none":
        return None
    return parse_rails(text)


def print_repairs(repairs) -> None:
    """Print what was found in a recording and done about it, as ``note:`` lines."""
    import sys

    for line in repairs.notes():
        print(line, file=sys.stderr)


def print_reduction_repairs(reduction) -> None:
    """Print the repairs of the record a reduction read (its provenance's), as notes."""
    from accelcal.io.recordings.repairs import Repairs

    found = (reduction.provenance or {}).get("repairs")
    if found:
        print_repairs(Repairs.from_dict(found))
