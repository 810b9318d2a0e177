"""How to read a lab's recording: :class:`InputOptions` and the units a recording may have.

A recording is a table of samples written by a data acquisition system or
another tool (not an accelcal record file): which columns hold the channels,
where the time is (a column, or a sample rate), and the unit of the values.
accelcal never guesses a unit: a generic file must say it (``unit``), or
carry it with the channel (a TDMS ``unit_string``, an HDF5 ``unit``
attribute), and a unit given that contradicts the file's is refused.

Channels may have units of their own (``units``, e.g. a reference
accelerometer in g beside a sensor in V) and a scale (``scale``: the file's
numbers times the scale are values in the unit given, e.g. counts times
6.1e-5 g per count); a temperature channel is in ``degC`` or ``K``.

References
----------
.. [SI] BIPM, The International System of Units, 9th ed., 2019 (g_n =
   9.80665 m/s^2, a conventional value; 0 degC = 273.15 K).
"""

import math
from dataclasses import dataclass

from accelcal.errors import AccelcalError
from accelcal.units import STANDARD_GRAVITY
from accelcal.validation import check_rate, shown, shown_name

INPUT_FORMATS = ("auto", "csv", "parquet", "imucal", "imu_tk", "record", "tdms", "hdf5", "mat")
"""Formats :func:`accelcal.io.recordings.read_recording` reads: ``csv`` and ``parquet``
(any columns), ``imucal`` (imucal sessions: ``acc_x, acc_y, acc_z``, taken as
m/s^2 unless a unit is given (raw sessions hold ADC counts), labels in a
``part`` column or a regions JSON), ``imu_tk`` (whitespace-separated
``t x y z`` rows without a header), ``record`` (an accelcal record file),
``tdms`` (NI TDMS, channels ``group/channel``), ``hdf5`` (datasets by path,
``path[k]`` for column k of a 2-D dataset), ``mat`` (MATLAB v5 or v7.3
variables, ``var[k]`` for column k), and ``auto`` (chosen from the file's first
bytes)."""

TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
"""Units of a time column, in seconds."""

ACCELERATION_UNITS = {
    "m/s^2": 1.0,
    "g": STANDARD_GRAVITY,
    "mg": 1e-3 * STANDARD_GRAVITY,
    "ug": 1e-6 * STANDARD_GRAVITY,
}
"""Acceleration units and their size in m/s^2 (g: the conventional g_n, not a local gravity)."""

RAW_UNITS = ("counts", "V", "mV")
"""Units of an uncalibrated output: kept as they are (a calibration maps them)."""

UNITS = (*ACCELERATION_UNITS, *RAW_UNITS)
"""Every unit a recording's values may have."""

TEMPERATURE_UNITS = {"degC": 0.0, "K": -273.15}
"""Temperature units and the offset that takes them to degC (t_C = T_K - 273.15) [SI]."""

OTHER_UNITS = ("deg", "rad", "s", "-")
"""Units of a channel that is not a sensor output: angles (a dividing head's or a
tumble's position), times, indices (``-``: a point or repeat number)."""

CHANNEL_UNITS = (*UNITS, *TEMPERATURE_UNITS, *OTHER_UNITS)
"""Units a single channel may be given (``units``)."""

UNIT_ALIASES = {
    "m/s2": "m/s^2", "m/s²": "m/s^2", "m/s/s": "m/s^2", "m s^-2": "m/s^2", "m*s^-2": "m/s^2",
    "µg": "ug", "μg": "ug", "volt": "V", "volts": "V", "v": "V", "mv": "mV",
    "count": "counts", "cts": "counts", "lsb": "counts", "°c": "degC", "deg c": "degC",
    "degc": "degC", "c": "degC", "celsius": "degC", "kelvin": "K", "°": "deg",
    "degree": "deg", "degrees": "deg", "radian": "rad", "radians": "rad", "sec": "s",
}
"""How DAQ software spells the units (case-insensitive): NI's ``unit_string``
(``Volts``, ``m/s^2``, ``Deg C``), HDF5 ``unit`` attributes."""

def file_unit(text) -> str | None:
    """A unit as a file spells it, in accelcal's spelling; None when it is not one we know."""
    if not isinstance(text, str) or not text.strip():
        return None
    raw = text.strip()
    if raw in CHANNEL_UNITS:
        return raw
    return UNIT_ALIASES.get(raw.lower())


@dataclass(frozen=True)
class InputOptions:
    """How to read a recording.

    Parameters
    ----------
    input_format : str
        One of :data:`INPUT_FORMATS`.
    columns : tuple of str, optional
        The channels' column names, in order (e.g. ``("X", "Y", "Z")``,
        ``("Accel/X", ...)`` for TDMS, ``("data[0]", ...)`` for a matrix); default:
        the format's (``acc_x, acc_y, acc_z`` for imucal, columns 2-4 of an
        imu_tk file, the record's own columns).
    time : str, optional
        Name of the time column (an imu_tk file's first column is its time).
    time_unit : str
        Unit of the time column, one of :data:`TIME_UNITS`.
    rate : float, optional
        Sample rate in Hz, for files without a time column (a TDMS channel's
        ``wf_increment`` gives it; a rate given must agree with it).
    unit : str, optional
        Unit of the values, one of :data:`UNITS`; required for files that do not
        carry it (csv, parquet, imu_tk, mat; records say theirs; imucal
        sessions state none and are taken as m/s^2 unless it is given).
    delimiter : str, optional
        Field delimiter of a CSV file (one character; default ``,``).
    regions : path-like, optional
        An imucal regions JSON (``{"x_p": {"start": i, "end": j}, ...}``,
        ``end`` exclusive) labelling sample ranges.
    scale : float, optional
        The file's numbers times ``scale`` are values in ``unit`` (counts to g,
        or V to g through a sensitivity); default 1.
    units : dict, optional
        Column -> unit (one of :data:`CHANNEL_UNITS`), for channels whose unit
        differs from ``unit``.
    scales : dict, optional
        Column -> scale, for channels whose scale differs from ``scale``.
    refuse_gaps : bool
        Refuse a time column with a gap (a step over 1.5 nominal intervals):
        for records that hold consecutive samples at one rate.
    gaps : str
        At a gap or a row with an empty or NaN cell: ``refuse`` (default),
        ``split`` (segments) or ``fill`` (linear interpolation of at most
        ``max_fill`` samples, flagged); see :mod:`~accelcal.io.recordings.repairs`.
    max_fill : int
        Most missing samples one gap may have to be filled (``gaps="fill"``).
    sort : bool
        Sort rows whose time goes backwards (refused otherwise).
    jitter_tol : float, optional
        Largest step off the nominal interval, relative to it; a step further
        off is refused, or resampled with ``resample``. None: not checked.
    resample : bool
        Interpolate the channels linearly onto the uniform grid ``k / rate``
        when the jitter exceeds ``jitter_tol``.
    rails : (float, float), optional
        The low and high clipping levels (in ``unit``, after ``scale``): runs
        of 3 or more samples at or beyond one are clipped, refused or (with
        ``gaps="split"``) left out; a triad calibration
        (:func:`accelcal.methods.triad.lab.run`) leaves them out of its static
        intervals instead.
    """

    input_format: str = "auto"
    columns: tuple[str, ...] | None = None
    time: str | None = None
    time_unit: str = "s"
    rate: float | None = None
    unit: str | None = None
    delimiter: str | None = None
    regions: object = None
    scale: float | None = None
    units: dict | None = None
    scales: dict | None = None
    refuse_gaps: bool = False
    gaps: str = "refuse"
    max_fill: int = 5
    sort: bool = False
    jitter_tol: float | None = None
    resample: bool = False
    rails: tuple[float, float] | None = None

    @property
    def repairing(self) -> bool:
        """Whether an option asks for a repair (any but the defaults)."""
        return (self.gaps != "refuse" or self.sort or self.jitter_tol is not None
                or self.resample or self.rails is not None)

    def __post_init__(self) -> None:
        check_repairs(self)
        if self.input_format not in INPUT_FORMATS:
            raise AccelcalError(
                f"input format {shown(self.input_format)} is not known; use one of "
                + ", ".join(INPUT_FORMATS), parameter="input_format")
        if self.columns is not None:
            cols = tuple(self.columns)
            if not cols or any(not isinstance(c, str) or not c.strip() for c in cols):
                raise AccelcalError("columns must be non-empty names separated by commas, "
                                    "e.g. X,Y,Z", parameter="columns")
            if len(set(cols)) != len(cols):
                raise AccelcalError(f"columns {shown(','.join(cols))} name a column twice",
                                    parameter="columns")
            object.__setattr__(self, "columns", cols)
        if self.time_unit not in TIME_UNITS:
            raise AccelcalError(f"time unit {shown(self.time_unit)} is not known; use one of "
                                + ", ".join(TIME_UNITS), parameter="time_unit")
        if self.unit is not None and self.unit not in UNITS:
            raise AccelcalError(f"unit {shown(self.unit)} is not known; use one of "
                                + ", ".join(UNITS), parameter="unit")
        if self.rate is not None:
            check_rate(self.rate)
            if self.time is not None:
                raise AccelcalError("give either a time column or a sample rate, not both",
                                    parameter="rate")
        if self.delimiter is not None and (len(self.delimiter) != 1
                                           or self.delimiter in "\r\n\"'"):
            raise AccelcalError(f"delimiter {shown(self.delimiter)} must be one character "
                                "other than a quote or a line break (e.g. ';' or a tab)",
                                parameter="delimiter")
        if self.scale is not None:
            object.__setattr__(self, "scale", check_scale(self.scale, "scale"))
        for name in ("units", "scales"):
            if getattr(self, name) is not None and not isinstance(getattr(self, name), dict):
                raise AccelcalError(f"{name} must map column names to values", parameter=name)
        for col, unit in (self.units or {}).items():
            if unit not in CHANNEL_UNITS:
                raise AccelcalError(f"unit {shown(unit)} of column {shown_name(col)} is not "
                                    "known; use one of " + ", ".join(CHANNEL_UNITS),
                                    parameter="units")
        object.__setattr__(self, "scales", {col: check_scale(s, "scales")
                                            for col, s in (self.scales or {}).items()} or None)


def check_repairs(options) -> None:
    """Check the repair options of an :class:`InputOptions` (one line each)."""
    if options.gaps not in ("refuse", "split", "fill"):
        raise AccelcalError(f"gaps {shown(options.gaps)} is not known; use refuse, split or "
                            "fill", parameter="gaps")
    fill = options.max_fill
    if isinstance(fill, bool) or not isinstance(fill, int) or not 1 <= fill <= 1_000_000:
        raise AccelcalError(f"max_fill {shown(fill)} must be a whole number of samples, "
                            "1 to 1000000", parameter="max_fill")
    tol = options.jitter_tol
    if tol is not None and (isinstance(tol, bool) or not isinstance(tol, (int, float))
                            or not 0 < tol < 0.5):
        raise AccelcalError(f"jitter_tol {shown(tol)} must be a fraction of the sample "
                            "interval above 0 and below 0.5 (a step over 1.5 intervals "
                            "is a gap)", parameter="jitter_tol")
    if options.rails is not None:
        try:
            low, high = (float(v) for v in options.rails)
        except (TypeError, ValueError):
            low = high = math.nan
        if not (math.isfinite(low) and math.isfinite(high) and low < high):
            raise AccelcalError(f"rails {shown(options.rails)} must be two finite numbers, "
                                "low below high (e.g. -2,2)", parameter="rails")
        object.__setattr__(options, "rails", (low, high))
    if options.resample and tol is None:
        raise AccelcalError("resample needs jitter_tol (the jitter that makes a resample)",
                            parameter="resample")


SCALE_RANGE = (1e-15, 1e15)
"""Smallest and largest magnitude of a scale: a 32-bit ADC's counts to g are ~1e-9; far
beyond either end the scaled values leave the range where a fit's arithmetic holds
(5e-324 makes every sample a subnormal number)."""


def check_scale(value, parameter: str) -> float:
    """Check a scale (finite, non-zero, magnitude within :data:`SCALE_RANGE`).

    The file's numbers times it are values in the unit.
    """
    try:
        scale = float(value)
    except (TypeError, ValueError, OverflowError):
        scale = math.nan
    low, high = SCALE_RANGE
    if isinstance(value, bool) or not (math.isfinite(scale) and low <= abs(scale) <= high):
        raise AccelcalError(f"scale {shown(value)} must be a finite number of magnitude "
                            f"{low:g} to {high:g} (the file's values times it are values in "
                            "the unit)", parameter=parameter)
    return scale


def to_si_factor(unit: str) -> float:
    """The factor from ``unit`` to m/s^2; an AccelcalError for a raw unit."""
    try:
        return ACCELERATION_UNITS[unit]
    except KeyError:
        raise AccelcalError(
            f"values in {unit} are not an acceleration: a calibration maps them; give values in "
            "one of " + ", ".join(ACCELERATION_UNITS) + " for this", parameter="unit") from None
