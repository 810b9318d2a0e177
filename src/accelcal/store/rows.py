"""Rows of the records store made from calibration records, and the words naming them."""

import hashlib
import json
import math
from collections.abc import Sequence

from accelcal.errors import AccelcalError
from accelcal.io.calibration_record import CalibrationRecord
from accelcal.method_ids import ALIASES, spellings
from accelcal.validation import shown_path


def labels(records: list, sources: Sequence[str] | None) -> list[str]:
    """What messages call each record: its source (a file name), else ``record i``."""
    if sources is None:
        return [f"record {i + 1}" for i in range(len(records))]
    if len(sources) != len(records):
        raise AccelcalError(f"{len(sources)} sources for {len(records)} records; give one "
                            "name per record", parameter="sources")
    return [shown_path(str(s)) for s in sources]


def what(record: CalibrationRecord) -> str:
    """``(serial ..., date)`` of a record, for messages."""
    return f"(serial {record.serial}, {record.date})"


def none_added(records: list) -> str:
    """The end of a message refusing a batch of records."""
    return f"none of the {len(records)} records was added"


def calibration_row(record: CalibrationRecord) -> dict:
    """The ``calibrations`` row of a record (its uid is the SHA-256 of its JSON)."""
    text = record.to_json()
    return {"uid": hashlib.sha256(text.encode()).hexdigest(), "serial": record.serial,
            "method": record.method, "simulated": bool(record.simulated),
            "date": utc(record.date), "software": record.software, "record_json": text}


def former_uids(row: dict) -> tuple[str, ...]:
    """The uids the same record had when written with an older id of its method.

    A record stored before method ids took the ``<family>/<route>`` pattern
    was hashed with its old id (``"tumble-fourier"``); read back, it carries
    the id today, so the same record added again would hash differently.
    These are the hashes of its JSON with each older spelling of the id
    (:func:`accelcal.method_ids.spellings`), which the store checks too.
    """
    today = json.dumps(row["method"])
    text = row["record_json"]
    return tuple(
        hashlib.sha256(text.replace(f'"method": {today}', f'"method": {json.dumps(old)}', 1)
                       .encode()).hexdigest()
        for old in spellings(row["method"])[1:])


def coefficient_rows(row_id: int, record: CalibrationRecord, *, parts: bool = False
                     ) -> list[dict]:
    """The ``coefficients`` rows of a record stored as calibration ``row_id``.

    A complex coefficient's ``estimate`` and ``std`` are its magnitude's and
    ``estimate_re``, ``estimate_im`` its parts (schema 4). Those two keys are
    in every row with ``parts`` (None for real coefficients: one batch's rows
    must have the same keys), and in none without it (a batch of real
    records inserts as before).
    """
    if record.is_complex:
        return [{"calibration_id": row_id, "name": n, "unit": record.units.get(n, ""),
                 "estimate": float(abs(v)), "std": None if math.isnan(s) else float(s),
                 "estimate_re": float(v.real), "estimate_im": float(v.imag)}
                for n, v, s in zip(record.names, record.estimates, record.std, strict=True)]
    rows = [{"calibration_id": row_id, "name": n, "unit": record.units.get(n, ""),
             "estimate": float(v), "std": None if math.isnan(s) else float(s)}
            for n, v, s in zip(record.names, record.estimates, record.std, strict=True)]
    if parts:
        for row in rows:
            row.update(estimate_re=None, estimate_im=None)
    return rows


def utc(date: str) -> str:
    """ISO 8601 in UTC, so that string order is time order (naive dates are taken as UTC)."""
    import datetime as dt

    moment = dt.datetime.fromisoformat(date)
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=dt.UTC)
    return moment.astimezone(dt.UTC).isoformat(timespec="microseconds")


def row_columns(rows: list[tuple], names: Sequence[str]) -> dict[str, list]:
    """The driver's row tuples as columns, ``names[i]`` -> every row's ``i``-th value."""
    from operator import itemgetter

    return {name: list(map(itemgetter(i), rows)) for i, name in enumerate(names)}


def method_today(cal):
    """The ``method`` column as its id today (old ids mapped by the database, one CASE)."""
    import sqlalchemy as sa

    return sa.case(ALIASES, value=cal.c.method, else_=cal.c.method).label("method")
