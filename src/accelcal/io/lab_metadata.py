"""Laboratory metadata shared by every test's record files.

Four optional metadata fields say who and what was calibrated, and where
(serial numbers and operators are checked by
:func:`accelcal.validation.check_label`: at most 200 characters, no control
characters, and no path separator in a serial number, which becomes part of
file names):

``serial``
    Serial number of the accelerometer: a string, or (for files holding
    several sensors, such as an indexing head's) a list with one string per
    sensor column, in column order.
``operator``
    Who ran the test (string).
``date``
    When the test was run: ISO 8601 date or date and time
    (``2026-11-21`` or ``2026-11-21T09:30:00+00:00``).
``local_gravity``
    Local acceleration of gravity at the test site, m/s^2 (a number between
    9.7 and 9.9), carried into calibration records' notes.

Readers call :func:`check_lab_metadata` on a file's metadata, so a malformed
field is reported with the file name before any reduction;
:func:`read_lab_metadata` reads only a file's metadata (the first lines
of a CSV record, the schema of a Parquet record) for the calibration record.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, test report contents (serial number,
   operator, date, local gravity).
"""

import datetime as dt
from dataclasses import dataclass
from pathlib import Path

from accelcal.errors import AccelcalError
from accelcal.io.limits import check_regular_file
from accelcal.physics.gravity import GRAVITY_RANGE
from accelcal.validation import check_label, is_finite_number, one_line, shown

FIELDS = ("serial", "operator", "date", "local_gravity", "simulated")
"""Metadata field names this module validates."""


@dataclass(frozen=True)
class LabInfo:
    """The laboratory metadata of a record file (every field optional).

    Attributes
    ----------
    serials : tuple of str or None
        One serial number per sensor column (one for a single-sensor file).
    operator : str
    date : str
        ISO 8601, as given.
    local_gravity : float or None
        m/s^2.
    simulated : bool
        True for data written by a simulator (metadata ``"simulated": true``):
        calibration records made from them say so.
    """

    serials: tuple[str, ...] | None = None
    operator: str = ""
    date: str = ""
    local_gravity: float | None = None
    simulated: bool = False

    def __post_init__(self) -> None:
        """Check the strings that reach file names and reports (:func:`check_label`).

        Raises
        ------
        AccelcalError
            Naming the parameter (``serial`` or ``operator``).
        """
        for serial in self.serials or ():
            check_label(serial, "serial number", file_name=True, parameter="serial")
        check_label(self.operator, "operator", parameter="operator")

    def serial(self, index: int = 0) -> str | None:
        """Serial number of sensor ``index`` (None when the file gives none)."""
        if self.serials is None:
            return None
        return self.serials[index] if len(self.serials) > 1 else self.serials[0]

    def as_metadata(self) -> dict:
        """The given fields as record-file metadata."""
        meta = {}
        if self.serials is not None:
            meta["serial"] = self.serials[0] if len(self.serials) == 1 else list(self.serials)
        if self.operator:
            meta["operator"] = self.operator
        if self.date:
            meta["date"] = self.date
        if self.local_gravity is not None:
            meta["local_gravity"] = self.local_gravity
        if self.simulated:
            meta["simulated"] = True
        return meta


def check_lab_metadata(meta: dict, path, sensors: int | None = None) -> LabInfo:
    """Validate the laboratory fields of a record's metadata.

    Parameters
    ----------
    meta : dict
        The record's metadata.
    path : path-like or str
        The file, for messages.
    sensors : int, optional
        Number of sensor columns (default 1); with several, ``serial`` must
        be a list of this length.

    Returns
    -------
    LabInfo

    Raises
    ------
    AccelcalError
        Naming the file and the field.
    """
    serials = None
    if "serial" in meta:
        value = meta["serial"]
        items = [value] if isinstance(value, str) else value
        if not isinstance(items, list) or not items or not all(
            isinstance(s, str) and s.strip() for s in items
        ):
            raise AccelcalError(
                f"{path}: metadata 'serial' must be a non-empty string or a list of non-empty "
                "strings (one per sensor column)"
            )
        count = sensors or 1
        if len(items) != count:
            raise AccelcalError(
                f"{path}: metadata 'serial' gives {len(items)} serial number(s) for {count} "
                "sensor column(s); give a list with one per sensor column, in column order"
            )
        serials = tuple(s.strip() for s in items)
    operator = meta.get("operator", "")
    if not isinstance(operator, str):
        raise AccelcalError(f"{path}: metadata 'operator' must be a string")
    date = meta.get("date", "")
    if not isinstance(date, str) or (date and _iso(date) is None):
        raise AccelcalError(
            f"{path}: metadata 'date' {shown(date)} is not an ISO 8601 date "
            "(e.g. 2026-11-21 or 2026-11-21T09:30:00+00:00)"
        )
    gravity = meta.get("local_gravity")
    if gravity is not None:
        lo, hi = GRAVITY_RANGE
        if not is_finite_number(gravity) or not lo <= gravity <= hi:
            raise AccelcalError(
                f"{path}: metadata 'local_gravity' {shown(gravity)} must be the local gravity in "
                f"m/s^2, between {lo} and {hi}"
            )
        gravity = float(gravity)
    simulated = meta.get("simulated", False)
    if not isinstance(simulated, bool):
        raise AccelcalError(f"{path}: metadata 'simulated' {shown(simulated)} must be true or "
                            "false")
    try:
        return LabInfo(serials, operator, date, gravity, simulated)
    except AccelcalError as exc:
        raise AccelcalError(f"{path}: metadata '{exc.parameter}': {exc.message}") from None


def read_lab_metadata(path, sensors: int | None = None) -> LabInfo:
    """Read and validate only the laboratory metadata of a record file.

    Parameters
    ----------
    path : path-like
        A CSV or Parquet record file.
    sensors : int, optional
        Number of sensor columns (see :func:`check_lab_metadata`).

    Raises
    ------
    AccelcalError
        For an unreadable file, malformed metadata or a malformed field.
    """
    return check_lab_metadata(read_metadata(path), path, sensors)


def read_metadata(path) -> dict:
    """The metadata of a record file, without reading its data.

    Reads the first three lines of a CSV record (each bounded, see
    :func:`accelcal.io.records.csv_preamble`) or the schema of a Parquet
    record.

    Raises
    ------
    AccelcalError
        For an unreadable file, one that is not a regular file (a FIFO, a
        device, a directory) or malformed metadata JSON.
    """
    from accelcal.io.records import csv_preamble, parquet_metadata

    path = Path(path)
    check_regular_file(path, "record file")
    if path.suffix.lower() == ".parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq

        try:
            schema = pq.read_schema(path)
        except (OSError, pa.ArrowException) as exc:
            raise AccelcalError(f"cannot read Parquet record {path}: {one_line(exc)}") from None
        return parquet_metadata(schema.metadata, path)
    try:
        with open(path, "rb") as fh:
            meta, _ = csv_preamble(fh, path)
    except OSError as exc:
        raise AccelcalError(f"cannot read record file {path}: {exc.strerror or exc}") from None
    return meta


def _iso(text: str) -> dt.datetime | None:
    try:
        return dt.datetime.fromisoformat(text)
    except ValueError:
        return None
