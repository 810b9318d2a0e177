"""Thermal records: files of kind ``thermal`` and their data type :class:`ThermalRecord`.

A record file (see :mod:`accelcal.io.records`) of kind ``thermal`` holds a
thermal-chamber test of one accelerometer, one row per reading. Columns:

``t`` (s)
    Time of the reading from turn-on.
``phase`` (-)
    0 warm-up (after turn-on, at a fixed position), 1 soak (at a plateau,
    fixed position), 2 tumble (the multipoint tumble of a plateau).
``plateau`` (-)
    Index of the plateau (0, 1, ...) in the order of ``setpoints_degC``;
    -1 during warm-up.
``angle`` (deg)
    Position of the tumble (rotation about ``rotation_axis``).
``output`` (output unit)
    The accelerometer's output.
``temperature`` (degC)
    The sensor's own temperature (its temperature sensor, or the chamber's
    when it has none).
``chamber`` (degC, optional)
    The chamber's air temperature.

Metadata fields: ``rotation_axis`` (``"OA"`` or ``"PA"``), ``output_unit``,
``setpoints_degC`` (the chamber setpoint of each plateau, in test order)
and ``start_degC`` (the temperature at turn-on) are required; they say
whether each plateau was reached by heating (up) or cooling (down). The
simulator adds ``simulated``, ``seed``, ``true_model`` and the rig's
settings; the laboratory fields ``serial``, ``operator``, ``date``,
``local_gravity`` are optional (:mod:`accelcal.io.lab_metadata`).

The simulator is :mod:`accelcal.rigs.thermal`; the reduction
:func:`accelcal.methods.thermal.reduce_thermal`.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, thermal tests (plateaus, soak, test at
   each temperature) and test report contents.
"""

from dataclasses import dataclass, field

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.formats import ImportLayout
from accelcal.io.lab_metadata import LabInfo, check_lab_metadata
from accelcal.io.records import read_record, write_record
from accelcal.terms import MAX_TEMPERATURE_DEGC, MIN_TEMPERATURE_DEGC
from accelcal.units import OUTPUT_UNITS
from accelcal.validation import shown

KIND = "thermal"
"""Record-file kind of thermal-chamber tests."""

IMPORT = ImportLayout()
"""How ``accelcal import`` makes this kind from a recording."""

AXES = ("OA", "PA")
PHASES = {"warm-up": 0, "soak": 1, "tumble": 2}
"""Phase codes of the ``phase`` column."""

MAX_TIME_S = 1e9
"""Largest time of a reading, s (31 years): a larger one is a corrupt cell, and sums
and products of times stay within the float range."""

MAX_OUTPUT = 1e9
"""Largest magnitude of an output read (as a tumble record's)."""

_RESERVED = ("format_version", "kind", "units", "rotation_axis", "output_unit", "setpoints_degC",
             "start_degC")
_COLUMNS = ("t", "phase", "plateau", "angle", "output", "temperature")


@dataclass(frozen=True)
class ThermalRecord:
    """The readings of a thermal-chamber test, one per row (see the module docs).

    Attributes
    ----------
    t, phase, plateau, angle_rad, output, temperature : numpy.ndarray, shape (n,)
        The columns (angle in rad; phase and plateau as integers).
    chamber : numpy.ndarray or None
        The chamber's temperature, degC.
    rotation_axis : {"OA", "PA"}
    output_unit : {"V", "mV", "mA", "g"}
    setpoints : tuple of float
        Chamber setpoint of each plateau, degC, in test order.
    start : float
        Temperature at turn-on, degC.
    metadata : dict
        The file's other metadata (JSON-ready).
    """

    t: np.ndarray
    phase: np.ndarray
    plateau: np.ndarray
    angle_rad: np.ndarray
    output: np.ndarray
    temperature: np.ndarray
    rotation_axis: str
    output_unit: str
    setpoints: tuple
    start: float
    chamber: np.ndarray | None = None
    metadata: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        cols = {n: np.array(getattr(self, n), dtype=float).reshape(-1)
                for n in ("t", "angle_rad", "output", "temperature")}
        for n in ("phase", "plateau"):
            cols[n] = np.asarray(getattr(self, n), dtype=float).reshape(-1)
        if self.chamber is not None:
            cols["chamber"] = np.array(self.chamber, dtype=float).reshape(-1)
        if len({c.size for c in cols.values()}) != 1:
            raise AccelcalError("a thermal record's columns must have equal lengths")
        _check(cols, "thermal record", tuple(self.setpoints), self.start)
        for n in ("phase", "plateau"):
            cols[n] = cols[n].astype(int)
        for name, arr in cols.items():
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "setpoints", tuple(float(s) for s in self.setpoints))
        object.__setattr__(self, "start", float(self.start))

    @property
    def lab(self) -> LabInfo:
        """The laboratory metadata (serial, operator, date, local gravity)."""
        return check_lab_metadata(self.metadata, "thermal record")

    def directions(self) -> np.ndarray:
        """+1 for a plateau reached by heating, -1 by cooling, 0 before any change."""
        steps = np.sign(np.diff(np.r_[self.start, self.setpoints]))
        out = np.zeros(len(self.setpoints), dtype=int)
        last = 0
        for j, s in enumerate(steps):
            last = int(s) if s else last
            out[j] = last
        return out

    def rows(self, phase: str, plateau: int | None = None) -> np.ndarray:
        """Indices of the rows of ``phase`` (and ``plateau``), in time order."""
        mask = self.phase == PHASES[phase]
        if plateau is not None:
            mask &= self.plateau == plateau
        idx = np.flatnonzero(mask)
        return idx[np.argsort(self.t[idx], kind="stable")]

    def tumble(self, plateau: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Angles (N,) rad, outputs (N, R) and temperatures (N, R) of a plateau's tumble.

        Rows with the same angle are repeated readings (in time order).

        Raises
        ------
        AccelcalError
            When positions have different numbers of readings.
        """
        idx = self.rows("tumble", plateau)
        angles, inverse, counts = np.unique(self.angle_rad[idx], return_inverse=True,
                                            return_counts=True)
        if counts.size and counts.min() != counts.max():
            raise AccelcalError(
                f"plateau {plateau}: the tumble positions have different numbers of readings "
                f"({counts.min()} to {counts.max()}); give the same number at every angle")
        order = idx[np.argsort(inverse, kind="stable")]
        shape = (angles.size, int(counts[0]) if counts.size else 0)
        return angles, self.output[order].reshape(shape), self.temperature[order].reshape(shape)


def _check(cols: dict, where, setpoints: tuple, start) -> None:
    """Values in range, phases and plateaus known, time increasing."""
    for name in ("temperature", "chamber"):
        if name in cols and cols[name].size and not (
                cols[name].min() >= MIN_TEMPERATURE_DEGC
                and cols[name].max() <= MAX_TEMPERATURE_DEGC):
            raise AccelcalError(f"{where}: column {name} has a value outside "
                                f"{MIN_TEMPERATURE_DEGC:g} to {MAX_TEMPERATURE_DEGC:g} degC")
    if cols["output"].size and not np.abs(cols["output"]).max() <= MAX_OUTPUT:
        raise AccelcalError(f"{where}: column output has a value beyond {MAX_OUTPUT:g}; is the "
                            "file corrupt?")
    if not np.all(np.isin(cols["phase"], list(PHASES.values()))):
        raise AccelcalError(f"{where}: column phase must hold 0 (warm-up), 1 (soak) or 2 "
                            "(tumble)")
    plateau = cols["plateau"]
    ok = (plateau == np.round(plateau)) & (plateau >= -1) & (plateau < len(setpoints))
    ok &= (plateau == -1) == (cols["phase"] == 0)
    if not ok.all():
        raise AccelcalError(f"{where}: column plateau must be -1 in warm-up rows and else an "
                            f"index 0..{len(setpoints) - 1} of setpoints_degC (row "
                            f"{int(np.flatnonzero(~ok)[0])})")
    if cols["t"].size and not np.abs(cols["t"]).max() <= MAX_TIME_S:
        raise AccelcalError(f"{where}: column t has a time beyond {MAX_TIME_S:g} s (31 years); "
                            "is the column in seconds?")
    if not np.all(np.diff(cols["t"]) > 0):
        raise AccelcalError(f"{where}: column t must increase strictly from row to row")
    if not (np.isfinite(np.r_[start, setpoints]).all() and len(setpoints) >= 1):
        raise AccelcalError(f"{where}: setpoints_degC and start_degC must be finite degC")


def write(path, data: ThermalRecord) -> None:
    """Write a thermal record file (atomically; CSV, or Parquet for ``.parquet``)."""
    units = {"t": "s", "phase": "-", "plateau": "-", "angle": "deg",
             "output": data.output_unit, "temperature": "degC"}
    columns = {"t": data.t, "phase": data.phase, "plateau": data.plateau,
               "angle": np.degrees(data.angle_rad), "output": data.output,
               "temperature": data.temperature}
    if data.chamber is not None:
        units["chamber"] = "degC"
        columns["chamber"] = data.chamber
    meta = {"units": units, "rotation_axis": data.rotation_axis,
            "output_unit": data.output_unit, "setpoints_degC": list(data.setpoints),
            "start_degC": data.start,
            **{k: v for k, v in data.metadata.items() if k not in _RESERVED}}
    write_record(path, KIND, meta, columns)


def read(path, *, gaps: str = "refuse", max_fill: int = 5) -> ThermalRecord:
    """Read and validate a thermal record file.

    ``gaps``, ``max_fill``: a jump of the time column inside a warm-up, a
    soak or one tumble position (the same phase, plateau and angle either
    side) is a gap, refused, cut (the plateau's last piece kept: a soak
    settles at its end) or filled (:func:`accelcal.io.record_gaps.repair_gaps`);
    a jump between them is harmless. What was done is in ``metadata["repairs"]``.

    Raises
    ------
    AccelcalError
        Naming the file: see :func:`accelcal.io.records.read_record`; an
        unknown axis or output unit, malformed setpoints, a column with a
        temperature below absolute zero, unknown phase or plateau codes,
        time not increasing, a gap, malformed laboratory metadata.
    """
    from accelcal.io.record_gaps import repair_gaps

    meta, cols = read_record(path, KIND,
                             required_metadata=("rotation_axis", "output_unit", "setpoints_degC",
                                                "start_degC"),
                             required_columns=_COLUMNS)
    cols, repairs = repair_gaps(cols, where=path, keys=("phase", "plateau", "angle"),
                                gaps=gaps, max_fill=max_fill, keep="last", what="plateau")
    if repairs:
        meta = {**meta, "repairs": repairs}
    if meta["rotation_axis"] not in AXES:
        raise AccelcalError(f"{path}: metadata rotation_axis {shown(meta['rotation_axis'])} is "
                            f"not one of {', '.join(AXES)}")
    if meta["output_unit"] not in OUTPUT_UNITS or meta["units"]["output"] != meta["output_unit"]:
        raise AccelcalError(f"{path}: metadata output_unit {shown(meta['output_unit'])} must be "
                            f"one of {', '.join(OUTPUT_UNITS)} and the output column's unit")
    for name in ("temperature", "chamber"):
        if name in cols and meta["units"][name] != "degC":
            raise AccelcalError(f"{path}: column {name} must be in degC, not "
                                f"{shown(meta['units'][name])}")
    setpoints, start = meta["setpoints_degC"], meta["start_degC"]
    if not (isinstance(setpoints, list) and setpoints and all(
            isinstance(v, int | float) and not isinstance(v, bool) for v in setpoints)
            and isinstance(start, int | float) and not isinstance(start, bool)):
        raise AccelcalError(f"{path}: metadata setpoints_degC must be a non-empty list of "
                            "numbers (degC) and start_degC a number")
    check_lab_metadata(meta, path)
    _check(cols, path, tuple(setpoints), start)
    return ThermalRecord(
        t=cols["t"], phase=cols["phase"], plateau=cols["plateau"],
        angle_rad=np.radians(cols["angle"]), output=cols["output"],
        temperature=cols["temperature"], rotation_axis=meta["rotation_axis"],
        output_unit=meta["output_unit"], setpoints=tuple(setpoints), start=start,
        chamber=cols.get("chamber"),
        metadata={k: v for k, v in meta.items() if k not in _RESERVED})
