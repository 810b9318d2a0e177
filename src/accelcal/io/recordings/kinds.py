"""What a record of each kind needs from a recording: columns, units, metadata, reader.

Each kind's format module declares its import layout (``IMPORT``, an
:class:`~accelcal.io.formats.ImportLayout`): whether the record has a time
column, whether it streams, how it records a sensor output's unit, which
metadata the recording states and which reader validates it. :func:`layout`
reads that declaration (this module has no branch per kind) and turns a
channel map (record column -> the recording's channel) and the channels'
units into a record of the kind:

- each column's record unit and the factor that takes the channel there
  (mg and ug to g, rad to deg; a reference accelerometer to g; a sensor
  output in m/s^2 to g where the kind wants an output unit);
- the columns the kind needs that a recording does not hold: the time ``t``
  (from the time column, or ``j / rate``; restarting where the declared
  column, a vibrafuge record's ``point``, changes);
- the metadata the recording itself states (``rate`` and ``unit``,
  ``sample_rate_hz``, ``output_unit``, a dividing head's ``sensors``); the
  rest (a shaker's ``frequency_hz``, a tumble's ``rotation_axis`` ...) comes
  from the user, and the kind's own reader checks it all.

:func:`validator` is that reader: the record written is read back with it
before it is moved into place.

References
----------
.. [SI] BIPM, The International System of Units, 9th ed., 2019 (g_n =
   9.80665 m/s^2).
"""

import importlib
import math
from dataclasses import dataclass

from accelcal.errors import AccelcalError
from accelcal.io.formats import ImportLayout
from accelcal.units import STANDARD_GRAVITY
from accelcal.validation import shown, shown_name

_ACCEL_TO_G = {"g": 1.0, "mg": 1e-3, "ug": 1e-6, "m/s^2": 1.0 / STANDARD_GRAVITY}
_TO_RECORD = {"g": ("g", 1.0), "mg": ("g", 1e-3), "ug": ("g", 1e-6), "m/s^2": ("m/s^2", 1.0),
              "V": ("V", 1.0), "mV": ("mV", 1.0), "counts": ("1", 1.0), "deg": ("deg", 1.0),
              "rad": ("deg", 180.0 / math.pi), "s": ("s", 1.0), "-": ("-", 1.0)}
_FIXED = {"t": "s", "input": "g", "angle": "deg", "angle_deg": "deg", "point": "-", "repeat": "-",
          "ref": "g", "ref_n": "g", "ref_ia": "g", "turn_on": "-"}
"""Columns whose record unit is fixed, by name (they are not the sensor's output)."""

_OUTPUT_UNITS = ("V", "mV", "mA", "g")


@dataclass(frozen=True)
class Layout:
    """How a record of ``kind`` is made from a recording's channels.

    ``columns`` (record column -> source channel, or None for a column made
    here), ``units`` (record column -> record unit), ``factors`` (record
    column -> factor from the channel's unit), and ``metadata`` the
    recording states; ``restart`` and ``stream`` as the kind declares them
    (:class:`~accelcal.io.formats.ImportLayout`).
    """

    kind: str
    columns: dict
    units: dict
    factors: dict
    metadata: dict
    restart: str = ""
    stream: bool = False


def kinds() -> tuple[str, ...]:
    """The record kinds a recording can be imported as."""
    from accelcal.io.formats import KINDS

    return tuple(sorted(KINDS))


def declared(kind: str) -> ImportLayout:
    """The import layout the kind's format module declares (its ``IMPORT``).

    Raises
    ------
    AccelcalError
        For an unknown kind.
    """
    from accelcal.io.formats import KINDS

    if kind not in KINDS:
        raise AccelcalError(f"kind {shown(kind)} is not known; use one of "
                            + ", ".join(kinds()), parameter="kind")
    return importlib.import_module(KINDS[kind]).IMPORT


def layout(kind: str, columns: dict, channel_units: dict, rate: float | None) -> Layout:
    """The record layout of ``kind`` for ``columns`` whose channels have ``channel_units``.

    Raises
    ------
    AccelcalError
        For an unknown kind, a column in a unit its kind cannot hold, or
        sensor outputs in different units.
    """
    spec = declared(kind)
    units, factors = {}, {}
    for col, source in columns.items():
        units[col], factors[col] = _record_unit(spec, kind, col, channel_units[source])
    outputs = sorted({u for c, u in units.items() if c not in _FIXED})
    if len(outputs) > 1:
        raise AccelcalError(f"the record's output columns are in different units "
                            f"({', '.join(outputs)}); a record has one output unit: give a "
                            "scale per channel to bring them to one", parameter="units")
    out = dict(columns)
    if spec.time and "t" not in columns:
        out = {"t": None, **columns}
        units["t"], factors["t"] = "s", 1.0
    sensors = [c for c in columns if c not in _FIXED]
    stated = {"rate": rate, "sample_rate_hz": rate}
    if outputs:
        stated |= {"unit": {"1": "counts"}.get(outputs[0], outputs[0]),
                   "input_unit": channel_units[columns[sensors[0]]],
                   "output_unit": outputs[0], "sensors": sensors}
    meta = {name: stated[name] for name in spec.states if name in stated}
    return Layout(kind, out, units, factors, meta, restart=spec.restart, stream=spec.stream)


def _record_unit(spec: ImportLayout, kind: str, col: str, unit: str) -> tuple[str, float]:
    fixed = _FIXED.get(col) if spec.fixed_names else None
    if fixed == "g":
        if unit not in _ACCEL_TO_G:
            raise AccelcalError(f"column {shown_name(col)} is an acceleration (g); its channel "
                                f"is in {unit}: give its unit, or a scale to g", parameter="units")
        return "g", _ACCEL_TO_G[unit]
    if fixed is not None:
        record, factor = _TO_RECORD.get(unit, (None, 1.0))
        if record != fixed:
            raise AccelcalError(f"column {shown_name(col)} must be in {fixed}; its channel is in "
                                f"{unit}", parameter="units")
        return record, factor
    if unit not in _TO_RECORD or _TO_RECORD[unit][0] in ("deg", "s", "-"):
        raise AccelcalError(f"column {shown_name(col)} holds a sensor output; its channel is in "
                            f"{unit}, not an output unit", parameter="units")
    if spec.outputs == "input":  # the input unit kept (column unit 1 where it has none)
        from accelcal.io.records import UNITS

        return (unit if unit in UNITS else "1"), 1.0
    if spec.outputs == "recorded":
        return _TO_RECORD[unit]
    if unit in _ACCEL_TO_G:
        return "g", _ACCEL_TO_G[unit]
    if unit not in _OUTPUT_UNITS:
        raise AccelcalError(f"a {kind} record's outputs are in {', '.join(_OUTPUT_UNITS)}; "
                            f"column {shown_name(col)}'s channel is in {unit}: give a scale "
                            "(file value x scale = value in the unit)", parameter="units")
    return _TO_RECORD[unit]


def validator(kind: str):
    """The kind's own reader, ``read(path)``."""
    from accelcal.io.formats import KINDS

    module = importlib.import_module(KINDS[kind])
    return getattr(module, module.IMPORT.reader)
