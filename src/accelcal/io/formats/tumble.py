"""Tumble records: files of kind ``tumble`` and their data type :class:`TumbleRecord`.

A record file (see :mod:`accelcal.io.records`) of kind ``tumble`` holds the
readings of a multipoint tumble, one row per reading. Columns:

``angle`` (deg)
    Position of the reading. Rows with the same angle are repeated
    readings of one position; every position must have the same number.
``output`` (output unit)
    The accelerometer's output.

Metadata fields: ``rotation_axis`` (``"OA"`` or ``"PA"``) and
``output_unit`` (required), and the informative ``noise_sd`` (output unit),
``seed`` and ``true_model`` (the simulated model's terms) that the simulator
writes, and the optional laboratory fields ``serial``, ``operator``,
``date``, ``local_gravity`` and ``simulated`` (:mod:`accelcal.io.lab_metadata`;
the simulator writes ``"simulated": true``).

The simulator (:mod:`accelcal.rigs.tumble`) produces a
:class:`TumbleRecord`; the tumble method
(:func:`accelcal.methods.tumble.reduce_tumble`) reduces one.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, multipoint tumble test and test report
   contents.
"""

from dataclasses import dataclass, field

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.formats import ImportLayout
from accelcal.io.lab_metadata import LabInfo, check_lab_metadata
from accelcal.io.records import read_record, write_record
from accelcal.units import OUTPUT_UNITS
from accelcal.validation import shown

KIND = "tumble"
"""Record-file kind of tumble records."""

IMPORT = ImportLayout()
"""How ``accelcal import`` makes this kind from a recording."""

AXES = ("OA", "PA")
"""Rotation axes a tumble record may give."""

_RESERVED = ("format_version", "kind", "units", "rotation_axis", "output_unit")

MAX_OUTPUT = 1e9
"""Largest magnitude of an output read (any output unit: V, mV, mA, g): far beyond
any accelerometer, and small enough that squares and sums of a record stay within
the float range. A larger value is a corrupt cell, not a reading."""

MAX_ANGLE = 1e6
"""Largest magnitude of an angle read, deg (2,800 turns; its rounding stays below
1e-9 deg, far inside the tolerance that tells positions apart)."""


@dataclass(frozen=True)
class TumbleRecord:
    """The readings of a multipoint tumble.

    Attributes
    ----------
    angles_rad : numpy.ndarray, shape (N,)
        The positions, rad.
    outputs : numpy.ndarray, shape (N, R)
        R readings at each position, in ``output_unit``.
    rotation_axis : {"OA", "PA"}
        Axis the accelerometer was turned about.
    output_unit : {"V", "mV", "mA", "g"}
        Unit of the outputs.
    metadata : dict
        The file's other metadata (``noise_sd``, ``seed``, ``true_model``,
        laboratory fields, ...), JSON-ready.
    """

    angles_rad: np.ndarray
    outputs: np.ndarray
    rotation_axis: str
    output_unit: str
    metadata: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        angles = np.array(self.angles_rad, dtype=float)
        outputs = np.array(self.outputs, dtype=float)
        if outputs.ndim == 1:
            outputs = outputs[:, None]
        if angles.ndim != 1 or outputs.ndim != 2 or outputs.shape[0] != angles.size:
            raise AccelcalError(
                f"a tumble record needs angles of shape (N,) and outputs of shape (N, R); "
                f"got {angles.shape} and {np.shape(self.outputs)}"
            )
        for a in (angles, outputs):
            a.setflags(write=False)
        object.__setattr__(self, "angles_rad", angles)
        object.__setattr__(self, "outputs", outputs)

    @property
    def repeats(self) -> int:
        """Readings per position (R)."""
        return self.outputs.shape[1]

    @property
    def lab(self) -> LabInfo:
        """The laboratory metadata (serial, operator, date, local gravity)."""
        return check_lab_metadata(self.metadata, "tumble record")


def write(path, data: TumbleRecord) -> None:
    """Write a tumble record file (atomically; CSV, or Parquet for ``.parquet``).

    Rows are in position order, the R readings of a position together;
    angles are written in degrees.

    Parameters
    ----------
    path : path-like
    data : TumbleRecord
    """
    meta = {
        "units": {"angle": "deg", "output": data.output_unit},
        "rotation_axis": data.rotation_axis,
        "output_unit": data.output_unit,
        **{k: v for k, v in data.metadata.items() if k not in _RESERVED},
    }
    columns = {"angle": np.repeat(np.degrees(data.angles_rad), data.repeats),
               "output": data.outputs.reshape(-1)}
    write_record(path, KIND, meta, columns)


def read(path) -> TumbleRecord:
    """Read and validate a tumble record file.

    Rows with the same angle are the repeated readings of one position;
    positions come out in increasing angle, each with its readings in file
    order.

    Returns
    -------
    TumbleRecord

    Raises
    ------
    AccelcalError
        Naming the file: see :func:`accelcal.io.records.read_record`; an
        unknown rotation axis or output unit; malformed laboratory metadata;
        an angle or output beyond :data:`MAX_ANGLE` or :data:`MAX_OUTPUT`;
        positions with different numbers of readings.
    """
    meta, cols = read_record(
        path,
        KIND,
        required_metadata=("rotation_axis", "output_unit"),
        required_columns=("angle", "output"),
    )
    if meta["rotation_axis"] not in AXES:
        raise AccelcalError(f"{path}: metadata rotation_axis {shown(meta['rotation_axis'])} is not "
                            f"one of {', '.join(AXES)}")
    if meta["output_unit"] not in OUTPUT_UNITS:
        raise AccelcalError(f"{path}: metadata output_unit {shown(meta['output_unit'])} is not "
                            f"one of {', '.join(OUTPUT_UNITS)}")
    check_lab_metadata(meta, path)
    for name, limit, unit in (("angle", MAX_ANGLE, " deg"), ("output", MAX_OUTPUT, "")):
        big = np.flatnonzero(~(np.abs(cols[name]) <= limit))
        if big.size:
            raise AccelcalError(
                f"{path}: column {name} row {int(big[0])} = {cols[name][big[0]]:.6g} is beyond "
                f"any physical value (magnitude up to {limit:g}{unit}); is the file corrupt?")
    angles, outputs = _group(path, cols["angle"], cols["output"])
    return TumbleRecord(
        angles_rad=np.radians(angles), outputs=outputs, rotation_axis=meta["rotation_axis"],
        output_unit=meta["output_unit"],
        metadata={k: v for k, v in meta.items() if k not in _RESERVED},
    )


def _group(path, angle_deg, output):
    """Rows with the same angle are repeated readings: (angles, outputs (N, R))."""
    angles, inverse, counts = np.unique(angle_deg, return_inverse=True, return_counts=True)
    if counts.min() != counts.max():
        raise AccelcalError(
            f"{path}: positions have different numbers of repeated readings "
            f"({counts.min()} to {counts.max()}); give the same number at every angle"
        )
    order = np.argsort(inverse, kind="stable")
    return angles, output[order].reshape(angles.size, int(counts[0]))
