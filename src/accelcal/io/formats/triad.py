"""Triad records: files of kind ``triad`` and their data type :class:`TriadRecord`.

A record file (see :mod:`accelcal.io.records`) of kind ``triad`` holds a
recording of an accelerometer triad turned through static positions, one
row per sample. Columns:

``t`` (s)
    Sample time from the first sample, strictly increasing.
``acc_x``, ``acc_y``, ``acc_z`` (the input unit)
    The three raw outputs. Their column unit is the input unit where the
    record container knows it (m/s^2, g, V, mV) and ``1`` otherwise (counts,
    mg, ug); the metadata's ``input_unit`` is the unit either way.

Metadata fields: ``input_unit`` (required: m/s^2, g, mg, ug, counts, V,
mV) and the optional ``positions`` (a list of ``{"label", "up", "start",
"stop"}``: a static position's label, its unit gravity-opposing direction
in the fixture frame, and its sample range, ``stop`` exclusive), ``gravity``
(m/s^2 used to simulate or the site's value), ``true_calibration`` (the
simulated triad's calibration, accelcal's JSON form), ``noise_sd``,
``seed``, ``rate`` (Hz), and the laboratory fields ``serial``,
``operator``, ``date``, ``local_gravity``, ``simulated``
(:mod:`accelcal.io.lab_metadata`; the simulator writes ``"simulated": true``).

The simulator (:mod:`accelcal.rigs.triad`) produces a :class:`TriadRecord`;
the triad method reduces the intervals of one.

References
----------
.. [Tedaldi2014] Tedaldi D., Pretto A., Menegatti E., ICRA 2014 (static
   intervals separated by motions; an initial still period).
"""

from dataclasses import dataclass, field

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.formats import ImportLayout
from accelcal.io.lab_metadata import LabInfo, check_lab_metadata
from accelcal.io.recordings.options import UNITS as INPUT_UNITS
from accelcal.io.records import UNITS as RECORD_UNITS
from accelcal.io.records import read_record, write_record
from accelcal.physics.gravity import GRAVITY_RANGE
from accelcal.validation import check_label, is_finite_number, shown

KIND = "triad"
"""Record-file kind of triad records."""

IMPORT = ImportLayout(time=True, stream=True, outputs="input", states=("rate", "input_unit"))
"""How ``accelcal import`` makes this kind from a recording."""

COLUMNS = ("t", "acc_x", "acc_y", "acc_z")
"""Columns of a triad record, in order."""

_RESERVED = ("format_version", "kind", "units", "input_unit", "positions")

MAX_VALUE = 1e12
"""Largest magnitude of an output read (any input unit: 32-bit counts are 4e9): a larger
value is a corrupt cell, and sums of squares of a record stay within the float range."""

UP_TOL = 0.01
"""Largest departure of a position's ``up`` norm from 1 accepted."""


def column_unit(input_unit: str) -> str:
    """The record-column unit of outputs in ``input_unit`` (``1`` where the container has none)."""
    return input_unit if input_unit in RECORD_UNITS else "1"


@dataclass(frozen=True)
class TriadRecord:
    """A triad recording with (optionally) its static positions.

    Attributes
    ----------
    t : numpy.ndarray, shape (n,)
        Sample times, s.
    acc : numpy.ndarray, shape (n, 3)
        Raw outputs, ``input_unit``.
    input_unit : str
    positions : tuple of dict
        ``{"label": str, "up": [x, y, z], "start": int, "stop": int}`` per
        static position (empty when not known).
    metadata : dict
        The file's other metadata (``gravity``, ``true_calibration``,
        ``noise_sd``, ``seed``, ``rate``, laboratory fields), JSON-ready.
    """

    t: np.ndarray
    acc: np.ndarray
    input_unit: str
    positions: tuple = ()
    metadata: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        t = np.array(self.t, dtype=float)
        acc = np.array(self.acc, dtype=float)
        if t.ndim != 1 or acc.shape != (t.size, 3):
            raise AccelcalError(f"a triad record needs t of shape (n,) and acc of shape (n, 3); "
                                f"got {t.shape} and {acc.shape}")
        for a in (t, acc):
            a.setflags(write=False)
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "acc", acc)
        object.__setattr__(self, "positions", tuple(self.positions))

    @property
    def up(self) -> np.ndarray:
        """The positions' gravity-opposing directions, shape (k, 3)."""
        return np.array([p["up"] for p in self.positions], dtype=float).reshape(-1, 3)

    @property
    def labels(self) -> list[str]:
        """The positions' labels."""
        return [p["label"] for p in self.positions]

    def interval_means(self) -> tuple[np.ndarray, np.ndarray]:
        """Mean outputs ``(k, 3)`` and sample counts ``(k,)`` of the positions' ranges."""
        means = np.array([self.acc[p["start"]:p["stop"]].mean(axis=0) for p in self.positions])
        counts = np.array([p["stop"] - p["start"] for p in self.positions], dtype=float)
        return means.reshape(-1, 3), counts

    @property
    def lab(self) -> LabInfo:
        """The laboratory metadata (serial, operator, date, local gravity)."""
        return check_lab_metadata(self.metadata, "triad record")


def write(path, data: TriadRecord) -> None:
    """Write a triad record file (atomically; CSV, or Parquet for ``.parquet``)."""
    unit = column_unit(data.input_unit)
    meta = {
        "units": {"t": "s", "acc_x": unit, "acc_y": unit, "acc_z": unit},
        "input_unit": data.input_unit,
        **({"positions": [dict(p) for p in data.positions]} if data.positions else {}),
        **{k: v for k, v in data.metadata.items() if k not in _RESERVED},
    }
    write_record(path, KIND, meta, {"t": data.t, "acc_x": data.acc[:, 0],
                                    "acc_y": data.acc[:, 1], "acc_z": data.acc[:, 2]})


def read(path) -> TriadRecord:
    """Read and validate a triad record file.

    Raises
    ------
    AccelcalError
        Naming the file: see :func:`accelcal.io.records.read_record`; an
        unknown input unit or a column unit that contradicts it; time not
        strictly increasing; an output beyond :data:`MAX_VALUE`; malformed
        positions, gravity or laboratory metadata.
    """
    meta, cols = read_record(path, KIND, required_metadata=("input_unit",),
                             required_columns=COLUMNS)
    unit = meta["input_unit"]
    if unit not in INPUT_UNITS:
        raise AccelcalError(f"{path}: metadata input_unit {shown(unit)} is not one of "
                            f"{', '.join(INPUT_UNITS)}")
    for name in COLUMNS[1:]:
        if meta["units"][name] not in (unit, "1"):
            raise AccelcalError(f"{path}: column {name} is in {shown(meta['units'][name])} but "
                                f"input_unit is {shown(unit)}; make them agree")
    if meta["units"]["t"] != "s":
        raise AccelcalError(f"{path}: column t must be in s, not {shown(meta['units']['t'])}")
    check_lab_metadata(meta, path)
    t = cols["t"]
    back = np.flatnonzero(np.diff(t) <= 0)
    if back.size:
        raise AccelcalError(f"{path}: column t does not increase at row {int(back[0]) + 1} "
                            f"({t[back[0]]:.9g} then {t[back[0] + 1]:.9g} s); sort the rows")
    acc = np.column_stack([cols[c] for c in COLUMNS[1:]])
    big = np.argwhere(~(np.abs(acc) <= MAX_VALUE))
    if big.size:
        row, col = (int(x) for x in big[0])
        raise AccelcalError(f"{path}: column {COLUMNS[1 + col]} row {row} = {acc[row, col]:.6g} "
                            f"is beyond any output (magnitude up to {MAX_VALUE:g}); is the file "
                            "corrupt?")
    gravity = meta.get("gravity")
    if gravity is not None and not (is_finite_number(gravity)
                                    and GRAVITY_RANGE[0] <= gravity <= GRAVITY_RANGE[1]):
        raise AccelcalError(f"{path}: metadata gravity {shown(gravity)} must be in m/s^2, "
                            f"between {GRAVITY_RANGE[0]} and {GRAVITY_RANGE[1]}")
    positions = check_positions(meta.get("positions", []), t.size, path)
    return TriadRecord(t, acc, unit, positions,
                       {k: v for k, v in meta.items() if k not in _RESERVED})


def check_positions(positions, rows: int, where) -> tuple[dict, ...]:
    """Validate ``positions`` metadata: labels, unit ``up`` vectors, sample ranges in the file.

    Raises
    ------
    AccelcalError
        Naming ``where`` and the position.
    """
    if not isinstance(positions, list):
        raise AccelcalError(f"{where}: metadata positions must be a list of "
                            "{\"label\", \"up\", \"start\", \"stop\"} objects")
    out = []
    for k, p in enumerate(positions):
        head = f"{where}: metadata positions[{k}]"
        if not isinstance(p, dict) or not {"label", "up", "start", "stop"} <= set(p):
            raise AccelcalError(f"{head} must be an object with label, up, start, stop")
        try:
            label = check_label(p["label"], f"{head} label")
        except AccelcalError as exc:
            raise AccelcalError(str(exc)) from None
        up = p["up"]
        if not (isinstance(up, list) and len(up) == 3 and all(is_finite_number(x) for x in up)):
            raise AccelcalError(f"{head} up must be three numbers, got {shown(up)}")
        norm = float(np.linalg.norm(up))
        if abs(norm - 1.0) > UP_TOL:
            raise AccelcalError(f"{head} up has norm {norm:.6g}; give a unit vector")
        start, stop = p["start"], p["stop"]
        if not (isinstance(start, int) and isinstance(stop, int)
                and not isinstance(start, bool) and not isinstance(stop, bool)
                and 0 <= start < stop <= rows):
            raise AccelcalError(f"{head} start {shown(start)}, stop {shown(stop)} must be sample "
                                f"indices with 0 <= start < stop <= {rows} (the rows)")
        out.append({"label": label, "up": [float(x) for x in up], "start": start, "stop": stop})
    return tuple(out)
