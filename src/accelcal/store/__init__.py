"""The records store: every calibration of every serial number, in a database.

An SQLite file by default (embedded, nothing to start); PostgreSQL (or any
SQLAlchemy URL) with ``--db postgresql+psycopg://user@host/db``. Each
:meth:`Store.add` and each :meth:`Store.add_many` is one transaction, so
concurrent writers lose nothing, a killed writer leaves no partial record,
and a batch that fails adds none of its records. The schema carries a
version in the ``schema_info`` table; opening a store for writing applies
the migrations it lacks (:mod:`accelcal.store.schema`), opening it
read-only reads it as it is, and a store written by a newer accelcal is
refused.

Tables (:mod:`accelcal.store.schema`): ``calibrations``, one row per record
(``uid``, the SHA-256 of the record's JSON, unique, so the same record is
stored once; ``serial``, ``method``, ``date`` in UTC, ``software``,
``record_json``, ``simulated``) and ``coefficients``, one row per
coefficient (a complex one as its magnitude, with its real and imaginary
parts beside; its full covariance is in the record's JSON). Listing and
:meth:`Store.stats` read only the columns they show, once.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, definitions of repeatability (run-to-run
   spread under the same conditions) and of drift.
"""

import contextlib
import math
from collections.abc import Iterable, Sequence

from accelcal.errors import AccelcalError
from accelcal.io.calibration_record import CalibrationRecord
from accelcal.method_ids import spellings
from accelcal.store import chain
from accelcal.store.chain import ChainReport
from accelcal.store.checks import HISTORY_COLUMNS, LIST_SPEC, READ_SPECS, RowChecker, date_problem
from accelcal.store.history import plain_names
from accelcal.store.location import (
    DEFAULT_DB_ENV,
    ReadonlyFile,
    check_sqlite_path,
    check_sqlite_tables,
    default_url,
    prepare_sqlite_file,
    remove_sqlite_files,
    store_address,
    store_exists,
)
from accelcal.store.location import connect as connect_sqlite
from accelcal.store.rows import (
    calibration_row,
    coefficient_rows,
    labels,
    method_today,
    none_added,
    row_columns,
    what,
)
from accelcal.store.schema import SCHEMA_VERSION, WRITE_LOCK, migrate, stored_version
from accelcal.store.schema import sqlite_on_begin as _sqlite_on_begin
from accelcal.store.schema import sqlite_on_connect as _sqlite_on_connect
from accelcal.store.schema import tables as _tables
from accelcal.store.stats import CoefficientStats, summarise
from accelcal.validation import check_label, shown, shown_path

__all__ = ["DEFAULT_DB_ENV", "SCHEMA_VERSION", "ChainReport", "CoefficientStats", "Store",
           "default_url", "verify_chain"]

class Store:
    """A records store at a database URL or SQLite path.

    Parameters
    ----------
    db : str or path-like, optional
        A database URL with an explicit scheme (``sqlite:///records.sqlite``,
        ``postgresql+psycopg://user@host/db``), or a path to an SQLite file
        taken literally (``%`` and ``?`` are characters of its name, ``~`` the
        home directory); default :func:`default_url`.
    readonly : bool
        Only read: an SQLite file is opened read-only (``mode=ro``; on
        read-only media, where SQLite cannot make its shared-memory file
        beside a write-ahead-logged store, ``immutable=1``, or a temporary
        copy of the store and its log when the log holds transactions),
        nothing is created or migrated, and a store that does not exist yet
        reads as empty. Commands that only read (``records list``,
        ``history``, ``stats``, ``verify``, ``report --history``) use it, so
        a store on read-only media can be read.
    skip_bad : bool
        Leave out rows that fail validation (changed outside accelcal),
        counting them in :attr:`skipped`, instead of refusing the read.

    Raises
    ------
    AccelcalError
        For a malformed address, a file that is not a database or is another
        application's database, a store that cannot be created or opened
        (its location unwritable, a full disk), a damaged ``schema_info``,
        or one written by a newer accelcal. A new SQLite file that could not
        be initialised is removed again.
    """

    def __init__(self, db=None, *, readonly: bool = False, skip_bad: bool = False) -> None:
        import sqlalchemy as sa

        self.url, self.path = store_address(db)
        self.readonly = readonly
        self._absent = False
        self._version = SCHEMA_VERSION
        self._file = None
        if self.path is None:
            try:
                sa.make_url(self.url)
            except (sa.exc.ArgumentError, ValueError):
                raise AccelcalError(
                    f"the store {shown(self.url)} is neither a database URL nor a file path; "
                    "give e.g. records.sqlite or postgresql+psycopg://user@host/db"
                ) from None
        self.checker = RowChecker(self._shown_url(), skip_bad=skip_bad)
        created = None
        # No connection pool: a command opens the store for a few statements,
        # and every connection is closed as soon as it is released.
        if self.path is not None:
            check_sqlite_path(self.path)
            if readonly:
                self._absent = not store_exists(self.path)
                if not self._absent:
                    self._file = ReadonlyFile(self.path, self._shown_url())
                self.engine = sa.create_engine(
                    "sqlite://", creator=self._connect_readonly, poolclass=sa.pool.NullPool,
                )
            else:
                check_sqlite_tables(self.path, self._shown_url())
                created = self.path if prepare_sqlite_file(self.path) else None
                path = self.path
                self.engine = sa.create_engine(
                    "sqlite://", creator=lambda: connect_sqlite(path),
                    poolclass=sa.pool.NullPool,
                )
                sa.event.listen(self.engine, "connect", _sqlite_on_connect)
                sa.event.listen(self.engine, "begin", _sqlite_on_begin)
        else:
            try:
                self.engine = sa.create_engine(self.url, poolclass=sa.pool.NullPool)
            except (sa.exc.NoSuchModuleError, ImportError) as exc:
                raise AccelcalError(
                    f"cannot use the store {self._shown_url()}: {exc}; for PostgreSQL install "
                    "'accelcal[postgresql]' and use postgresql+psycopg://..."
                ) from None
        self._tables = _tables(sa)
        if self._absent:
            return
        try:
            with self._errors("open"):
                if readonly:
                    with self.engine.connect() as conn:
                        self._version = stored_version(conn, self._tables, self._shown_url())
                    self._absent = self._version == 0
                else:
                    migrate(self.engine, self._tables, self._shown_url())
        except AccelcalError:
            self.close()
            if created is not None:
                remove_sqlite_files(created)
            raise

    def _connect_readonly(self):
        """A read-only connection to the SQLite file (the engine's creator)."""
        return self._file.connect()

    @property
    def skipped(self) -> int:
        """Bad rows left out by the reads so far (with ``skip_bad``)."""
        return self.checker.skipped

    def close(self) -> None:
        """Release the database engine (and a temporary copy read in its place)."""
        if getattr(self, "engine", None) is not None:
            self.engine.dispose()
        if self._file is not None:
            self._file.close()

    def __enter__(self) -> "Store":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def shown(self) -> str:
        """The store as messages show it: its path, or its URL without the password."""
        return self._shown_url()

    def _shown_url(self) -> str:
        import sqlalchemy as sa

        if self.path is not None:
            return shown_path(self.path)
        return shown_path(sa.make_url(self.url).render_as_string(hide_password=True))

    @contextlib.contextmanager
    def _errors(self, action: str):
        """Turn a database failure into an AccelcalError naming the store (one line)."""
        import sqlalchemy as sa

        try:
            yield
        except sa.exc.IntegrityError:
            raise
        except sa.exc.DBAPIError as exc:
            reason = " ".join(str(exc.orig).split()) or type(exc.orig).__name__
            raise AccelcalError(
                f"cannot {action} the records store {self._shown_url()}: {reason}"
            ) from None

    def _rows(self, *queries) -> list[list[tuple]]:
        """The rows of read queries, in one transaction (none from an absent store).

        Rows are the database driver's tuples, fetched at once (no per-row
        processing: a boolean may come as 0 or 1).
        """
        if self._absent:
            return [[] for _ in queries]
        with self._errors("read"), self.engine.connect() as conn:
            return [conn.execute(query).cursor.fetchall() for query in queries]

    def _select(self, query) -> list[dict]:
        """The rows of a read query as dicts."""
        keys = [c.name for c in query.selected_columns]
        return [dict(zip(keys, r, strict=True)) for r in self._rows(query)[0]]

    @property
    def schema_version(self) -> int:
        """The store's schema version (0 for a store that does not exist yet)."""
        import sqlalchemy as sa

        rows = self._select(sa.select(self._tables["schema_info"].c.version))
        return rows[0]["version"] if rows else 0

    def add(self, record: CalibrationRecord) -> int:
        """Add a record in one transaction; return its id.

        Raises
        ------
        AccelcalError
            If the same record (same content) is already stored.
        """
        return self.add_many([record])[0]

    def add_many(self, records: Iterable[CalibrationRecord], *,
                 sources: Sequence[str] | None = None) -> list[int]:
        """Add records in one transaction: all of them, or none; return their ids.

        Each record is journalled and chained (:mod:`accelcal.store.chain`)
        in the same transaction, which holds the store's write lock from its
        start (SQLite ``BEGIN IMMEDIATE``, a PostgreSQL advisory lock), so
        concurrent writers chain their records one after the other.

        Parameters
        ----------
        records : iterable of CalibrationRecord
        sources : sequence of str, optional
            What to call each record in messages (e.g. its file name);
            default ``record 1``, ``record 2``, ...

        Returns
        -------
        list of int
            The id of each record, in the order given.

        Raises
        ------
        AccelcalError
            Naming the record (its source, serial number and date) when it
            is already in the store or given twice, or dated outside
            1900-01-01 .. 2199-12-31, or the store when it cannot be written
            (a full disk); nothing is added then.
        """
        return self._add(list(records), sources, None)

    def supersede(self, old_id: int, record: CalibrationRecord, *, who: str, why: str,
                  source: str | None = None) -> int:
        """Store ``record`` as the correction of record ``old_id``; return its id.

        The old record stays as it was (nothing is edited in place); the new
        one's journal entry names the record it supersedes, who made the
        correction and why, and when it was stored. ``records history``
        marks the old record, and statistics and reports use the new one.

        Raises
        ------
        AccelcalError
            If ``old_id`` is not stored or is superseded already (naming the
            record superseding it), if ``who`` or ``why`` is blank, or for
            the reasons of :meth:`add_many`.
        """
        for value, name in ((who, "who"), (why, "why")):
            check_label(value, name, limit=2000)
            if not value.strip():
                raise AccelcalError(f"{name} is blank: a correction says who made it and why")
        correction = (int(old_id), who, why)
        return self._add([record], None if source is None else [source], correction)[0]

    def _add(self, records: list[CalibrationRecord], sources: Sequence[str] | None,
             correction: tuple | None) -> list[int]:
        """Add records (one correction, with ``correction`` = (old id, who, why))."""
        import sqlalchemy as sa

        if self.readonly:
            raise AccelcalError("this store was opened read-only (readonly=True); it cannot add "
                                "records")
        if not records:
            return []
        names = labels(records, sources)
        rows, uids = [], {}
        for i, record in enumerate(records):
            problem = date_problem(record.date)
            if problem is not None:
                batch = f"; {none_added(records)}" if len(records) > 1 else ""
                raise AccelcalError(f"{names[i]} (serial {record.serial}): the date {problem} "
                                    f"(UTC), the dates a records store keeps{batch}")
            rows.append(calibration_row(record))
            earlier = uids.setdefault(rows[-1]["uid"], i)
            if earlier != i:
                raise AccelcalError(f"{names[i]}: the same record as {names[earlier]} "
                                    f"{what(record)}; {none_added(records)}")
        cal, coef = self._tables["calibrations"], self._tables["coefficients"]
        try:
            with self._errors("write to"), self.engine.begin() as conn:
                if conn.dialect.name == "postgresql":
                    conn.execute(sa.text(f"SELECT pg_advisory_xact_lock({WRITE_LOCK})"))
                if correction is not None:
                    chain.check_supersedable(conn, self._tables, correction[0])
                stored = self._first_stored(conn, rows)
                if stored is None:
                    ids = dict(conn.execute(sa.insert(cal).returning(cal.c.uid, cal.c.id),
                                            rows).all())
                    parts = any(record.is_complex for record in records)
                    per_record = [coefficient_rows(ids[row["uid"]], record, parts=parts)
                                  for row, record in zip(rows, records, strict=True)]
                    conn.execute(sa.insert(coef), [c for cs in per_record for c in cs])
                    entries = chain.journal_entries(rows, ids, per_record, correction)
                    chain.append(conn, self._tables, entries)
        except sa.exc.IntegrityError:
            # Another writer stored one of these records meanwhile (a database without
            # the write lock); the transaction was rolled back.
            with self._errors("read"), self.engine.connect() as conn:
                stored = self._first_stored(conn, rows)
            if stored is None:
                raise AccelcalError(f"the store refused the records; {none_added(records)}"
                                    ) from None
        except AccelcalError as exc:
            if len(records) == 1:
                raise
            raise AccelcalError(f"{exc}; {none_added(records)}") from None
        if stored is not None:
            record = f"this record {what(records[stored])} is already in the store"
            if len(records) == 1:
                raise AccelcalError(record)
            raise AccelcalError(f"{names[stored]}: {record}; {none_added(records)}")
        return [int(ids[row["uid"]]) for row in rows]

    def _first_stored(self, conn, rows: list[dict]) -> int | None:
        """Index of the first of ``rows`` whose record is in the store already, or None."""
        ids = chain.stored_ids(conn, self._tables, rows)
        return next((i for i, stored in enumerate(ids) if stored is not None), None)

    def stored_ids(self, records: Sequence[CalibrationRecord]) -> list[int | None]:
        """The stored id of each record, by its content hash (uid); None where not stored."""
        if self._absent:
            return [None] * len(records)
        with self._errors("read"), self.engine.connect() as conn:
            return chain.stored_ids(conn, self._tables, [calibration_row(r) for r in records])

    def calibrations(self, serial: str | None = None) -> list[dict]:
        """Stored calibrations, oldest first.

        Each a dict: id, serial, method, date, software, simulated and
        superseded_by (the id of the record correcting it, or None).
        """
        columns = self.calibrations_columns(serial)
        return [dict(zip(columns, values, strict=True))
                for values in zip(*columns.values(), strict=True)]

    def calibrations_columns(self, serial: str | None = None) -> dict[str, list]:
        """:meth:`calibrations` as columns: name -> list of values, in the same order.

        No dict per row: the form for writing a long list out (``records
        list --format csv`` of a store of 100k calibrations).
        """
        query = self._calibrations_query(serial)
        rows = self.checker.check(self._rows(query)[0], LIST_SPEC)
        columns = row_columns(rows, [c.name for c in query.selected_columns])
        columns["simulated"] = list(map(bool, columns["simulated"]))
        return columns

    def _calibrations_query(self, serial: str | None):
        """The query of :meth:`calibrations` (of ``serial`` only, when given)."""
        import sqlalchemy as sa

        cal = self._tables["calibrations"]
        simulated = sa.false().label("simulated") if self._version == 1 else cal.c.simulated
        query = sa.select(cal.c.id, cal.c.serial, method_today(cal), cal.c.date,
                          cal.c.software, simulated, self._superseded_by())
        if serial is not None:
            query = query.where(cal.c.serial == check_label(serial, "serial number"))
        return query.order_by(cal.c.date, cal.c.id)

    def _superseded_by(self):
        """The column of the id of the record superseding each calibration (NULL if none)."""
        import sqlalchemy as sa

        if self._version < 5:
            return sa.null().label("superseded_by")
        cal, journal = self._tables["calibrations"], self._tables["journal"]
        return (sa.select(journal.c.calibration_id).where(journal.c.supersedes == cal.c.id)
                .order_by(journal.c.seq).limit(1).scalar_subquery().label("superseded_by"))

    def record(self, record_id: int) -> CalibrationRecord:
        """The full record with id ``record_id``."""
        import sqlalchemy as sa

        cal = self._tables["calibrations"]
        rows = self._select(sa.select(cal.c.record_json).where(cal.c.id == record_id))
        if not rows:
            raise AccelcalError(f"no record with id {record_id} in the store")
        return CalibrationRecord.from_json(rows[0]["record_json"],
                                           source=f"store record {record_id}")

    def _history(self, serial: str, method: str | None, *what: str,
                 current_only: bool = False) -> list[list[tuple]]:
        """Rows of the calibrations of ``serial`` (by ``method``), in history order, checked.

        ``what`` names the queries, each read in the same transaction:
        ``"history"`` (calibration id, date, method, name, unit, estimate,
        std of each coefficient, the id superseding the calibration, the
        coefficient's id), ``"calibrations"`` (id, date, method) and
        ``"coefficients"`` (calibration id, name, unit, estimate, std,
        coefficient id). With ``current_only``, superseded calibrations are
        left out.

        Raises
        ------
        AccelcalError
            If the store has no calibration of ``serial`` (by ``method``), or
            a bad row (without ``skip_bad``).
        """
        import sqlalchemy as sa

        check_label(serial, "serial number")
        if method is not None:
            check_label(method, "method")
        cal, coef = self._tables["calibrations"], self._tables["coefficients"]
        method_now = method_today(cal)
        columns = {
            "history": (cal.c.id, cal.c.date, method_now, coef.c.name, coef.c.unit,
                        coef.c.estimate, coef.c.std, self._superseded_by(), coef.c.id),
            "calibrations": (cal.c.id, cal.c.date, method_now),
            "coefficients": (coef.c.calibration_id, coef.c.name, coef.c.unit,
                             coef.c.estimate, coef.c.std, coef.c.id),
        }
        queries = []
        for name in what:
            query = sa.select(*columns[name]).select_from(cal).where(cal.c.serial == serial)
            if method is not None:
                query = query.where(cal.c.method.in_(spellings(method)))
            if current_only and self._version >= 5:
                journal = self._tables["journal"]
                query = query.where(cal.c.id.not_in(  # NOT IN: one look-up table, built once
                    sa.select(journal.c.supersedes).where(journal.c.supersedes.is_not(None))))
            if name == "calibrations":
                queries.append(query.order_by(cal.c.date, cal.c.id))
            else:
                queries.append(query.join(coef, coef.c.calibration_id == cal.c.id)
                               .order_by(cal.c.date, cal.c.id, coef.c.id))
        results = [self.checker.check(rows, READ_SPECS[name])
                   for name, rows in zip(what, self._rows(*queries), strict=True)]
        if not all(results):
            by = f" by method {shown(method)}" if method is not None else ""
            raise AccelcalError(
                f"no calibration of serial {shown(serial)}{by} in the store; "
                "see 'accelcal records list'"
            )
        return results

    def history(self, serial: str, method: str | None = None, *,
                current_only: bool = False) -> list[dict]:
        """Every coefficient of every calibration of ``serial``, oldest first.

        Parameters
        ----------
        serial : str
        method : str, optional
            Only calibrations by this method (e.g. ``dividing-head/joint``; an old id
            such as ``tumble-fourier`` selects the same records as its id today).
        current_only : bool
            Leave out calibrations superseded by a correction.

        Returns
        -------
        list of dict
            id, date, method, name, unit, estimate, std (NaN when unknown),
            superseded_by (the id of the record correcting the calibration,
            or None), and coefficient: the plain coefficient the row estimates
            (``K_F`` for a row recorded as ``K_F+K_OO``,
            :func:`accelcal.identifiability.plain_name`), which follows one
            coefficient across its renaming (:mod:`accelcal.store.history`).

        Raises
        ------
        AccelcalError
            If the store has no calibration of ``serial`` (by ``method``), or
            a bad row (without ``skip_bad``).
        """
        nan = math.nan
        plain = plain_names()
        return [{"id": i, "date": d, "method": m, "name": n, "unit": u, "estimate": e,
                 "std": nan if s is None else s, "superseded_by": by, "coefficient": plain(n)}
                for i, d, m, n, u, e, s, by, _ in self._history(
                    serial, method, "history", current_only=current_only)[0]]

    def history_columns(self, serial: str, method: str | None = None) -> dict[str, list]:
        """:meth:`history` as columns: name -> list of values, in the same order.

        No dict per row: the form for writing a long history out (``records
        history --format csv`` of a serial with 100k calibrations).
        """
        columns = row_columns(self._history(serial, method, "history")[0], HISTORY_COLUMNS)
        if None in columns["std"]:
            columns["std"] = [math.nan if s is None else s for s in columns["std"]]
        plain = plain_names()
        distinct = {n: plain(n) for n in set(columns["name"])}
        columns["coefficient"] = list(map(distinct.__getitem__, columns["name"]))
        return columns

    def stats(self, serial: str, method: str | None = None) -> list[CoefficientStats]:
        """Repeatability and drift of each coefficient of ``serial``, per method.

        Calibrations superseded by a correction are left out (the correction
        counts in their place).

        Parameters
        ----------
        serial : str
        method : str, optional
            Only calibrations by this method.

        Returns
        -------
        list of CoefficientStats
            One per (method, coefficient), in order of first appearance.

        References
        ----------
        .. [1] IEEE Std 1293-2018, definitions of repeatability and drift.
        """
        return summarise(*self._history(serial, method, "calibrations", "coefficients",
                                        current_only=True))

    def corrections(self, serial: str | None = None) -> list[dict]:
        """Corrections of ``serial`` (all without): :func:`accelcal.store.chain.corrections`."""
        if self._absent or self._version < 5:
            return []
        with self._errors("read"), self.engine.connect() as conn:
            return chain.corrections(conn, self._tables, serial)

    def verify(self) -> ChainReport:
        """Check the records against the journal's hash chain, and the database itself.

        Every record changed, inserted or deleted outside accelcal, every
        broken link, and SQLite's ``PRAGMA integrity_check`` (on PostgreSQL
        ``not run``: the chain and the count of records against the journal
        are checked): :func:`accelcal.store.chain.report`.
        """
        if self._absent:
            return ChainReport(records=0)
        with self._errors("read"), self.engine.connect() as conn:
            return chain.report(conn, self._tables, chained=self._version >= 5)


def verify_chain(db=None) -> ChainReport:
    """Verify the hash chain of the store at ``db`` (read-only); see :meth:`Store.verify`.

    ``verify_chain(db).status_line()`` is the line a report or certificate
    prints: ``chain verified: yes (12 records)``.
    """
    with Store(db, readonly=True) as store:
        return store.verify()
