"""Step records: files of kind ``steps`` and their data type :class:`StepRecord`.

A record file (see :mod:`accelcal.io.records`) of kind ``steps`` holds an
acceptance test of one accelerometer in which the input is held at a
sequence of values (dwells) and the output recorded at each: the threshold
and resolution tests (small increments about a set point), the
hysteresis cycle (0 -> +1 g -> 0 -> -1 g -> 0), the input-range test (a
centrifuge's ladder of inputs up to and past full scale, with zero-input
dwells before and after the overload) and the turn-on test (dwells at
+1 g and -1 g through each of several turn-ons). One row per sample.
Columns:

``t`` (s)
    Time of the sample.
``input`` (g) and/or ``angle`` (deg)
    The applied acceleration along the input axis, or the indexing head's
    angle from the input axis horizontal (the input is then
    ``sin(angle)`` g, the local gravity taken as 1 g); at least one of them.
    A dwell is a run of rows with the same input.
``output`` (output unit)
    The accelerometer's output.
``turn_on`` (``1`` or ``-``: an index; turn-on tests only, required there)
    The turn-on (power cycle) the sample belongs to, 1, 2, ...; a dwell
    ends where it changes.
``field_x``, ``field_y``, ``field_z`` (mT; magnetic tests only, required there)
    The magnetic field the Helmholtz coils apply along the sensor's IA (x),
    PA (y) and OA (z); a dwell ends where one of them changes.

Metadata fields: ``test`` (``"threshold"``, ``"resolution"``,
``"hysteresis"``, ``"range"``, ``"turn-on"`` or ``"magnetic"``), ``output_unit`` and
``scale_factor`` (output unit per g, the nominal scale factor the 50 % rule
predicts the output change with) are required; ``rail`` (output unit,
optional, range tests) is the output's clipping level (amplifier or DAQ
rail) where known. The simulator adds ``simulated``, ``seed``, the truth
(threshold, resolution, hysteresis, range, turn-on values) and the step size; the laboratory fields
``serial``, ``operator``, ``date``, ``local_gravity`` are optional
(:mod:`accelcal.io.lab_metadata`).

The simulator is :mod:`accelcal.rigs.acceptance`; the reductions are in
:mod:`accelcal.methods.acceptance`.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, threshold, resolution and hysteresis tests
   of linear single-axis nongyroscopic accelerometers.
.. [DOMAIN] accelcal domain notes, section 12.
"""

import dataclasses
from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.formats import ImportLayout
from accelcal.io.lab_metadata import LabInfo, check_lab_metadata
from accelcal.io.records import read_record, write_record
from accelcal.units import OUTPUT_UNITS
from accelcal.validation import shown

KIND = "steps"
"""Record-file kind of step (threshold, resolution, hysteresis) tests."""

IMPORT = ImportLayout(time=True)
"""How ``accelcal import`` makes this kind from a recording (a time column ``t``)."""

TESTS = ("threshold", "resolution", "hysteresis", "range", "turn-on", "magnetic")
"""The tests a step record holds (metadata ``test``)."""

MAX_INPUT_G = 100.0
"""Largest magnitude of an input read, g."""

MAX_FIELD_MT = 1e3
"""Largest magnitude of an applied magnetic field read, mT."""

FIELD_COLUMNS = ("field_x", "field_y", "field_z")
"""The magnetic field's columns (mT), along the IA, PA and OA."""

MAX_OUTPUT = 1e9
"""Largest magnitude of an output read."""

_RESERVED = ("format_version", "kind", "units", "test", "output_unit", "scale_factor")


@dataclass(frozen=True)
class StepRecord:
    """The samples of a step test, one per row (see the module docs).

    Attributes
    ----------
    t, input, output : numpy.ndarray, shape (n,)
        Time (s), applied acceleration (g) and output (output unit).
    test : {"threshold", "resolution", "hysteresis"}
    output_unit : str
        One of :data:`accelcal.units.OUTPUT_UNITS`.
    scale_factor : float
        Nominal scale factor, output unit per g.
    angle : numpy.ndarray or None
        The indexing head's angle, deg, where the record has it.
    turn_on : numpy.ndarray or None
        The turn-on of each sample (1, 2, ...): turn-on tests only.
    field : numpy.ndarray or None, shape (n, 3)
        The applied magnetic field along the IA, PA, OA, mT: magnetic tests only.
    metadata : dict
        The file's other metadata (JSON-ready).
    """

    t: np.ndarray
    input: np.ndarray
    output: np.ndarray
    test: str
    output_unit: str
    scale_factor: float
    angle: np.ndarray | None = None
    turn_on: np.ndarray | None = None
    field: np.ndarray | None = None
    metadata: dict = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        cols = {n: np.array(getattr(self, n), dtype=float).reshape(-1)
                for n in ("t", "input", "output")}
        if self.angle is not None:
            cols["angle"] = np.array(self.angle, dtype=float).reshape(-1)
        if self.turn_on is not None:
            cols["turn_on"] = np.array(self.turn_on, dtype=float).reshape(-1)
        if self.field is not None:
            field = np.array(self.field, dtype=float).reshape(-1, 3)
            cols |= {name: field[:, j] for j, name in enumerate(FIELD_COLUMNS)}
        if len({c.size for c in cols.values()}) != 1:
            raise AccelcalError("a step record's columns must have equal lengths")
        _check(cols, "step record", self.test, self.output_unit, self.scale_factor)
        if self.field is not None:
            field = np.column_stack([cols.pop(name) for name in FIELD_COLUMNS])
            field.setflags(write=False)
            object.__setattr__(self, "field", field)
        for name, arr in cols.items():
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "scale_factor", float(self.scale_factor))

    @property
    def lab(self) -> LabInfo:
        """The laboratory metadata (serial, operator, date, local gravity)."""
        return check_lab_metadata(self.metadata, "step record")

    def dwells(self) -> np.ndarray:
        """Start index of each dwell (a run of rows with one input, turn-on, field), then ``n``."""
        moved = np.diff(self.input) != 0.0
        if self.turn_on is not None:
            moved |= np.diff(self.turn_on) != 0.0
        if self.field is not None:
            moved |= np.any(np.diff(self.field, axis=0) != 0.0, axis=1)
        change = np.flatnonzero(moved) + 1
        return np.r_[0, change, self.input.size]


def _check(cols: dict, where, test, output_unit, scale_factor) -> None:
    """Metadata known, values finite and in range, time increasing."""
    if test not in TESTS:
        raise AccelcalError(f"{where}: metadata test {shown(test)} is not one of "
                            f"{', '.join(TESTS)}")
    if output_unit not in OUTPUT_UNITS:
        raise AccelcalError(f"{where}: metadata output_unit {shown(output_unit)} is not one of "
                            f"{', '.join(OUTPUT_UNITS)}")
    if (isinstance(scale_factor, bool) or not isinstance(scale_factor, int | float)
            or not np.isfinite(scale_factor) or scale_factor == 0.0):
        raise AccelcalError(f"{where}: metadata scale_factor {shown(scale_factor)} must be a "
                            "finite non-zero number (output unit per g)")
    limits = {"input": MAX_INPUT_G, "output": MAX_OUTPUT, "t": 1e9,
              **{name: MAX_FIELD_MT for name in FIELD_COLUMNS if name in cols}}
    for name, limit in limits.items():
        c = cols[name]
        if c.size and not np.abs(c).max() <= limit:
            raise AccelcalError(f"{where}: column {name} has a value beyond {limit:g} or not "
                                "a number; is the file corrupt?")
    if not np.all(np.diff(cols["t"]) > 0):
        raise AccelcalError(f"{where}: column t must increase strictly from row to row")
    if (test == "magnetic") != all(name in cols for name in FIELD_COLUMNS):
        raise AccelcalError(f"{where}: a magnetic test, and only it, needs the columns "
                            f"{', '.join(FIELD_COLUMNS)} (the applied field, mT)")
    turn_on = cols.get("turn_on")
    if (test == "turn-on") != (turn_on is not None):
        raise AccelcalError(f"{where}: a turn-on test, and only it, needs a column turn_on "
                            "(the turn-on of each sample: 1, 2, ...)")
    if turn_on is not None and turn_on.size and not (
            np.all(turn_on == np.round(turn_on)) and turn_on.min() >= 1
            and np.all(np.diff(turn_on) >= 0) and turn_on.max() <= 1e6):
        raise AccelcalError(f"{where}: column turn_on must hold whole numbers 1, 2, ... that "
                            "do not decrease")


def write(path, data: StepRecord) -> None:
    """Write a step record file (atomically; CSV, or Parquet for ``.parquet``)."""
    units = {"t": "s", "input": "g", "output": data.output_unit}
    columns = {"t": data.t, "input": data.input, "output": data.output}
    if data.angle is not None:
        units["angle"] = "deg"
        columns["angle"] = data.angle
    if data.turn_on is not None:
        units["turn_on"] = "1"
        columns["turn_on"] = data.turn_on
    if data.field is not None:
        for j, name in enumerate(FIELD_COLUMNS):
            units[name] = "mT"
            columns[name] = data.field[:, j]
    meta = {"units": units, "test": data.test, "output_unit": data.output_unit,
            "scale_factor": data.scale_factor,
            **{k: v for k, v in data.metadata.items() if k not in _RESERVED}}
    write_record(path, KIND, meta, columns)


def read(path, *, gaps: str = "refuse", max_fill: int = 5) -> StepRecord:
    """Read and validate a step record file.

    ``gaps``, ``max_fill``: a jump of the time column inside a dwell (the
    same input, or angle, and turn-on flag either side) is a gap, refused,
    cut (the dwell's last piece kept: it settles at its end) or filled
    (:func:`accelcal.io.record_gaps.repair_gaps`); a jump between dwells is
    harmless. What was done is in ``metadata["repairs"]``.

    Raises
    ------
    AccelcalError
        Naming the file: see :func:`accelcal.io.records.read_record`; an
        unknown test or output unit, a missing or zero scale factor, neither
        an input nor an angle column, values out of range, time not
        increasing, malformed laboratory metadata.
    """
    from accelcal.io.record_gaps import repair_gaps

    meta, cols = read_record(path, KIND,
                             required_metadata=("test", "output_unit", "scale_factor"),
                             required_columns=("t", "output"))
    keys = [c for c in ("input", "angle", "turn_on") if c in cols]
    cols, repairs = repair_gaps(cols, where=path, keys=keys, gaps=gaps, max_fill=max_fill,
                                keep="last", what="dwell")
    if repairs:
        meta = {**meta, "repairs": repairs}
    units = meta["units"]
    if units["output"] != meta["output_unit"]:
        raise AccelcalError(f"{path}: the output column's unit {shown(units['output'])} is not "
                            f"metadata output_unit {shown(meta['output_unit'])}")
    for name, unit in (("input", "g"), ("angle", "deg"), ("t", "s"), ("turn_on", "1"),
                       *((name, "mT") for name in FIELD_COLUMNS)):
        if name in cols and units[name] != unit and not (name == "turn_on" and units[name] == "-"):
            raise AccelcalError(f"{path}: column {name} must be in {unit}, not "
                                f"{shown(units[name])}")
    angle = cols.get("angle")
    if "input" in cols:
        applied = cols["input"]
    elif angle is not None:
        applied = np.sin(np.radians(angle))
    else:
        raise AccelcalError(f"{path}: a step record needs an input column (g) or an angle "
                            "column (deg)")
    check_lab_metadata(meta, path)
    field = (np.column_stack([cols[name] for name in FIELD_COLUMNS])
             if all(name in cols for name in FIELD_COLUMNS) else None)
    if field is None and any(name in cols for name in FIELD_COLUMNS):
        raise AccelcalError(f"{path}: a magnetic test needs all three columns "
                            f"{', '.join(FIELD_COLUMNS)} (mT)")
    try:
        return StepRecord(t=cols["t"], input=applied, output=cols["output"], test=meta["test"],
                          output_unit=meta["output_unit"], scale_factor=meta["scale_factor"],
                          angle=angle, turn_on=cols.get("turn_on"), field=field,
                          metadata={k: v for k, v in meta.items() if k not in _RESERVED})
    except AccelcalError as exc:
        raise AccelcalError(f"{path}: {exc.message.removeprefix('step record: ')}") from None
