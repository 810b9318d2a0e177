"""Tamper evidence of the records store: a hash chain over its records.

Every record stored gets an entry in the ``journal`` table (schema 5,
:mod:`accelcal.store.schema`), written in the same transaction as the
record. The entry holds the SHA-256 of the record's content
(:func:`content_hash`: every column of its ``calibrations`` row and of its
``coefficients`` rows) and a hash chaining it to the previous entry
(:func:`entry_hash`): changing, inserting or deleting a record, or an entry,
outside accelcal breaks either a content hash or the chain, and
:func:`verify` names the record.

What the chain is evidence of: a change made with other tools (an SQL
client, a script) that does not recompute every hash after it. It is not a
signature: someone who recomputes the chain with accelcal's own code, or
deletes the newest records with their entries, is not detected by the store
alone. The chain's head (:attr:`ChainReport.head`, printed by ``accelcal
records verify``) copied into a certificate or kept elsewhere closes that
gap: the head verified later must be the one copied or have it in its past.

Content of a record, hashed: the ``calibrations`` columns of
:data:`CALIBRATION_FIELDS` and the ``coefficients`` columns of
:data:`COEFFICIENT_FIELDS` (in coefficient id order), as canonical JSON, a
NULL value left out. A column added to either table later is added to the
tuple; records stored before it (NULL there) keep their hashes.
"""

import hashlib
import json
from dataclasses import dataclass, field

CALIBRATION_FIELDS = ("uid", "serial", "method", "date", "software", "simulated",
                      "record_json")
"""The ``calibrations`` columns of a record's content hash."""

COEFFICIENT_FIELDS = ("name", "unit", "estimate", "std", "estimate_re", "estimate_im")
"""The ``coefficients`` columns of a record's content hash."""

ENTRY_FIELDS = ("seq", "calibration_id", "serial", "method", "date", "stored_at",
                "supersedes", "who", "why", "content_hash")
"""The ``journal`` columns an entry's chain hash covers (beside the previous hash)."""

GENESIS = "0" * 64
"""The "previous hash" of the first entry."""

_BATCH = 1000
"""Records read per query when hashing a whole store."""


def content_hash(calibration: dict, coefficients: list[dict]) -> str:
    """SHA-256 of a record's stored content (hex).

    Parameters
    ----------
    calibration : dict
        The record's ``calibrations`` row (column -> value); other keys
        are ignored.
    coefficients : list of dict
        Its ``coefficients`` rows, in id order.

    Notes
    -----
    Values are hashed with their type: a number stored as text, or a real
    stored as an integer, does not hash as the number. ``simulated`` is
    hashed as a boolean when it is 0 or 1 (SQLite has no boolean). The
    record's JSON (text) enters by its own SHA-256, which spares escaping
    the long text into the canonical JSON.
    """
    cal = {k: calibration[k] for k in CALIBRATION_FIELDS if calibration.get(k) is not None}
    if type(cal.get("simulated")) is int and cal["simulated"] in (0, 1):
        cal["simulated"] = bool(cal["simulated"])
    if type(cal.get("record_json")) is str:
        cal["record_json"] = {"sha256": hashlib.sha256(cal["record_json"].encode(
            "utf-8", "surrogatepass")).hexdigest()}
    coef = [{k: c[k] for k in COEFFICIENT_FIELDS if c.get(k) is not None}
            for c in coefficients]
    text = json.dumps({"calibration": cal, "coefficients": coef}, sort_keys=True,
                      separators=(",", ":"), ensure_ascii=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()


def entry_hash(previous: str, entry: dict) -> str:
    """The chain hash of a journal entry: SHA-256 of the previous one and the entry's fields."""
    text = json.dumps([previous, *(entry.get(k) for k in ENTRY_FIELDS)],
                      separators=(",", ":"), ensure_ascii=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()


def head(conn, tables: dict) -> tuple[int, str]:
    """The last entry's ``seq`` and chain hash (0 and :data:`GENESIS` for none).

    Read inside the transaction that appends, which holds the store's write
    lock, so no other writer can append between this read and the insert.
    """
    import sqlalchemy as sa

    journal = tables["journal"]
    row = conn.execute(sa.select(journal.c.seq, journal.c.chain_hash)
                       .order_by(journal.c.seq.desc()).limit(1)).first()
    return (0, GENESIS) if row is None else (int(row[0]), row[1])


def append(conn, tables: dict, entries: list[dict]) -> None:
    """Journal records just inserted, in order, chained to the store's head.

    Parameters
    ----------
    conn : sqlalchemy.engine.Connection
        In the transaction that inserted the records, with the write lock.
    tables : dict
        :func:`accelcal.store.schema.tables`.
    entries : list of dict
        Per record: ``calibration_id``, ``serial``, ``method``, ``date``,
        ``content_hash`` and optionally ``stored_at``, ``supersedes``,
        ``who``, ``why``.
    """
    import sqlalchemy as sa

    seq, previous = head(conn, tables)
    rows = []
    for entry in entries:
        seq += 1
        row = {k: entry.get(k) for k in ENTRY_FIELDS}
        row["seq"] = seq
        row["chain_hash"] = previous = entry_hash(previous, row)
        rows.append(row)
    if rows:
        conn.execute(sa.insert(tables["journal"]), rows)


def journal_entries(rows: list[dict], ids: dict, coefficients: list[list[dict]],
                    correction: tuple | None = None) -> list[dict]:
    """The journal entries of records being stored (for :func:`append`).

    Parameters
    ----------
    rows : list of dict
        Their ``calibrations`` rows.
    ids : dict
        uid -> the id each row was given.
    coefficients : list of list of dict
        Each record's ``coefficients`` rows.
    correction : tuple, optional
        (id superseded, who, why) of a correction (one record).
    """
    import datetime as dt

    now = dt.datetime.now(dt.UTC).isoformat(timespec="microseconds")
    entries = []
    for row, coefs in zip(rows, coefficients, strict=True):
        entry = {"calibration_id": int(ids[row["uid"]]), "serial": row["serial"],
                 "method": row["method"], "date": row["date"], "stored_at": now,
                 "content_hash": content_hash(row, coefs)}
        if correction is not None:
            entry.update(zip(("supersedes", "who", "why"), correction, strict=True))
        entries.append(entry)
    return entries


def check_supersedable(conn, tables: dict, old_id: int) -> None:
    """Refuse superseding a record that is not stored, or is superseded already.

    Raises
    ------
    AccelcalError
        Naming the record, and the one superseding it already.
    """
    import sqlalchemy as sa

    from accelcal.errors import AccelcalError

    cal, journal = tables["calibrations"], tables["journal"]
    if not 0 < old_id < 2**63 or conn.execute(
            sa.select(cal.c.id).where(cal.c.id == old_id)).first() is None:
        raise AccelcalError(f"no record with id {old_id} in the store to supersede; see "
                            "'accelcal records list'")
    later = conn.execute(sa.select(journal.c.calibration_id)
                         .where(journal.c.supersedes == old_id)).scalar()
    if later is not None:
        raise AccelcalError(f"record {old_id} is already superseded by record {later}; "
                            f"supersede record {later} instead")


def corrections(conn, tables: dict, serial: str | None = None) -> list[dict]:
    """The corrections stored (of ``serial``), in the order stored.

    Each a dict: id (the correcting record), supersedes, serial, method,
    date, stored_at, who, why.
    """
    import sqlalchemy as sa

    journal = tables["journal"]
    query = sa.select(journal.c.calibration_id.label("id"), journal.c.supersedes,
                      journal.c.serial, journal.c.method, journal.c.date, journal.c.stored_at,
                      journal.c.who, journal.c.why).where(journal.c.supersedes.is_not(None))
    if serial is not None:
        query = query.where(journal.c.serial == serial)
    return [dict(r._mapping) for r in conn.execute(query.order_by(journal.c.seq))]


def stored_ids(conn, tables: dict, rows: list[dict], chunk: int = 500) -> list[int | None]:
    """The stored id of each calibration row (by its uid or a former one), or None.

    Looked up ``chunk`` uids at a time (far below every database's parameter limit).
    """
    import sqlalchemy as sa

    from accelcal.store.rows import former_uids

    cal = tables["calibrations"]
    known = [(row["uid"], *former_uids(row)) for row in rows]
    every, found = [u for uids in known for u in uids], {}
    for k in range(0, len(every), chunk):
        found.update(conn.execute(sa.select(cal.c.uid, cal.c.id).where(
            cal.c.uid.in_(every[k:k + chunk]))).all())
    return [next((int(found[u]) for u in uids if u in found), None) for uids in known]


def stored_records(conn, tables: dict):
    """Every record of a store as (``calibrations`` row, its ``coefficients`` rows), by id.

    Read in batches of :data:`_BATCH` records (a store of 100k records is
    never in memory at once).
    """
    import sqlalchemy as sa

    cal, coef = tables["calibrations"], tables["coefficients"]
    cal_columns = [cal.c.id, *(cal.c[k] for k in CALIBRATION_FIELDS)]
    coef_columns = [coef.c.calibration_id, *(coef.c[k] for k in COEFFICIENT_FIELDS)]
    last = None
    while True:
        query = sa.select(*cal_columns).order_by(cal.c.id).limit(_BATCH)
        if last is not None:
            query = query.where(cal.c.id > last)
        keys = [c.name for c in cal_columns]
        rows = [dict(zip(keys, r, strict=True))
                for r in conn.execute(query).cursor.fetchall()]  # the driver's tuples: fast
        if not rows:
            return
        ids = [r["id"] for r in rows]
        by_id = {i: [] for i in ids}
        keys = [c.name for c in coef_columns]
        for c in conn.execute(sa.select(*coef_columns).where(coef.c.calibration_id.in_(ids))
                              .order_by(coef.c.id)).cursor.fetchall():
            by_id[c[0]].append(dict(zip(keys, c, strict=True)))
        yield from ((r, by_id[r["id"]]) for r in rows)
        last = ids[-1]


def journal_existing(conn, meta) -> None:
    """Journal every record of a store migrated to schema 5, in id order."""
    tables = {"calibrations": meta.tables["calibrations"],
              "coefficients": meta.tables["coefficients"], "journal": meta.tables["journal"]}
    batch = []
    for row, coefficients in stored_records(conn, tables):
        batch.append({"calibration_id": row["id"], "serial": row["serial"],
                      "method": row["method"], "date": row["date"],
                      "content_hash": content_hash(row, coefficients)})
        if len(batch) == _BATCH:
            append(conn, tables, batch)
            batch = []
    append(conn, tables, batch)


@dataclass(frozen=True)
class Finding:
    """A record changed, inserted or deleted outside accelcal, or a broken link.

    Attributes
    ----------
    kind : str
        ``changed``, ``inserted``, ``deleted`` or ``journal`` (an entry of
        the journal itself changed or missing).
    id : int or None
        The record's id (None for entries missing from the journal).
    serial, method, date : str
        As stored (for a deleted record: as its journal entry has them).
    detail : str
        What was found.
    """

    kind: str
    id: int | None
    serial: str
    method: str
    date: str
    detail: str

    def line(self) -> str:
        """The finding on one line."""
        what = "" if self.id is None else (
            f"record {self.id} (serial {self.serial}, {self.method}, {self.date}): ")
        return f"{self.kind}: {what}{self.detail}"


@dataclass(frozen=True)
class ChainReport:
    """What :func:`verify` found.

    Attributes
    ----------
    records : int
        Records in the store.
    findings : tuple of Finding
    integrity : str
        ``ok``, what SQLite's ``PRAGMA integrity_check`` reported, or what
        stands for it on another database.
    head : str
        The last journal entry's chain hash (:data:`GENESIS` for none).
    chained : bool
        Whether the store has a journal (schema 5 or later).
    superseded : int
        Records superseded by a correction.
    """

    records: int
    findings: tuple = field(default_factory=tuple)
    integrity: str = "ok"
    head: str = GENESIS
    chained: bool = True
    superseded: int = 0

    @property
    def verified(self) -> bool:
        """Whether the chain holds, every record matches it, and the database is intact."""
        return self.chained and not self.findings and self.integrity in ("ok", "not run")

    def status_line(self) -> str:
        """``chain verified: yes (n records)``, or no and why, for reports and certificates."""
        n = f"{self.records} record{'s' * (self.records != 1)}"
        if self.verified:
            return f"chain verified: yes ({n})"
        if not self.chained:
            why = ("the store has no journal yet (written before schema 5; accelcal adds it "
                   "the next time it writes to the store)")
        elif self.findings:
            why = f"{len(self.findings)} finding(s); see 'accelcal records verify'"
        else:
            why = f"integrity check: {self.integrity}"
        return f"chain verified: no ({n}; {why})"


def report(conn, tables: dict, *, chained: bool) -> ChainReport:
    """What :meth:`accelcal.store.Store.verify` finds, on an open connection.

    Parameters
    ----------
    conn : sqlalchemy.engine.Connection
    tables : dict
        :func:`accelcal.store.schema.tables`.
    chained : bool
        Whether the store has a journal (schema 5 or later).
    """
    import sqlalchemy as sa

    integrity = "not run"
    if conn.dialect.name == "sqlite":
        lines = [str(r[0]) for r in conn.exec_driver_sql("PRAGMA integrity_check")]
        integrity = "; ".join(lines)[:300]
    if not chained:
        n = conn.execute(sa.select(sa.func.count()).select_from(
            tables["calibrations"])).scalar_one()
        return ChainReport(records=n, integrity=integrity, chained=False)
    n, superseded, top, found = _findings(conn, tables)
    return ChainReport(records=n, findings=tuple(found), integrity=integrity, head=top,
                       superseded=superseded)


def _findings(conn, tables: dict) -> tuple[int, int, str, list[Finding]]:
    """The records, superseded records, head and findings of a store with a journal."""
    import sqlalchemy as sa

    journal = tables["journal"]
    keys = (*ENTRY_FIELDS, "chain_hash")
    entries = [dict(zip(keys, r, strict=True)) for r in conn.execute(
        sa.select(*(journal.c[k] for k in keys)).order_by(journal.c.seq)).cursor.fetchall()]
    out = _chain_findings(entries)
    by_record = {}
    for entry in entries:
        by_record.setdefault(entry["calibration_id"], entry)
    n, seen = 0, set()
    for row, coefficients in stored_records(conn, tables):
        n += 1
        seen.add(row["id"])
        entry = by_record.get(row["id"])
        if entry is None:
            out.append(_finding("inserted", row, "not in the journal: stored outside accelcal"))
        elif content_hash(row, coefficients) != entry["content_hash"]:
            out.append(_finding("changed", row, "its content does not match the hash "
                                "stored with it: changed outside accelcal"))
    for entry in entries:
        if entry["calibration_id"] not in seen:
            out.append(_finding("deleted", {**entry, "id": entry["calibration_id"]},
                                "in the journal but not in the store: deleted outside "
                                "accelcal"))
    coef = tables["coefficients"]
    orphans = conn.execute(sa.select(sa.func.count()).select_from(coef).where(
        ~coef.c.calibration_id.in_(sa.select(tables["calibrations"].c.id)))).scalar_one()
    if orphans:
        out.append(Finding("inserted", None, "", "", "",
                           f"{orphans} coefficient row(s) of no stored record"))
    superseded = len({e["supersedes"] for e in entries if e["supersedes"] is not None})
    top = entries[-1]["chain_hash"] if entries else GENESIS
    return n, superseded, top, out


def _chain_findings(entries: list[dict]) -> list[Finding]:
    """Broken links: entries missing (a gap in ``seq``) or changed (their hash)."""
    out, previous, expected = [], GENESIS, 1
    for entry in entries:
        if entry["seq"] != expected:
            lost = f"{expected}" if entry["seq"] == expected + 1 else \
                f"{expected} to {entry['seq'] - 1}"
            out.append(Finding("journal", None, "", "", "", f"journal entries {lost} missing "
                               "(records deleted outside accelcal with their entries)"))
        elif entry_hash(previous, entry) != entry["chain_hash"]:
            out.append(_finding("journal", {**entry, "id": entry["calibration_id"]},
                                f"its journal entry {entry['seq']} does not match its chain "
                                "hash: the entry was changed outside accelcal"))
        previous, expected = entry["chain_hash"], entry["seq"] + 1
    return out


def _finding(kind: str, row: dict, detail: str) -> Finding:
    return Finding(kind, row["id"], str(row["serial"]), str(row["method"]), str(row["date"]),
                   detail)
