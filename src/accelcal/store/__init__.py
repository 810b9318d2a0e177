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
parts beside; its full covariance is in the record's JSON). Listing reads
only the columns it shows, and :meth:`Store.stats` reads the columns of its
statistics once.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, definitions of repeatability (run-to-run
   spread under the same conditions) and of drift.
"""

import contextlib
import math
from collections.abc import Iterable, Sequence
from pathlib import Path

from accelcal.errors import AccelcalError
from accelcal.io.calibration_record import CalibrationRecord
from accelcal.method_ids import ALIASES, spellings
from accelcal.store.location import (
    DEFAULT_DB_ENV,
    check_sqlite_path,
    connect_readonly,
    default_url,
    prepare_sqlite_file,
    remove_sqlite_files,
    store_exists,
    store_url,
)
from accelcal.store.rows import (
    calibration_row,
    coefficient_rows,
    former_uids,
    labels,
    none_added,
    what,
)
from accelcal.store.schema import SCHEMA_VERSION, migrate, stored_version
from accelcal.store.schema import sqlite_on_begin as _sqlite_on_begin
from accelcal.store.schema import sqlite_on_connect as _sqlite_on_connect
from accelcal.store.schema import tables as _tables
from accelcal.store.stats import CoefficientStats, summarise
from accelcal.validation import check_label, shown, shown_path

__all__ = ["DEFAULT_DB_ENV", "SCHEMA_VERSION", "CoefficientStats", "Store", "default_url"]

_CHUNK = 500
"""Values per ``IN (...)`` look-up: far below every database's parameter limit."""


class Store:
    """A records store at a database URL or SQLite path.

    Parameters
    ----------
    db : str or path-like, optional
        SQLAlchemy URL, or a path to an SQLite file; default :func:`default_url`.
    readonly : bool
        Only read: an SQLite file is opened read-only (``mode=ro``; on
        read-only media, where SQLite cannot make its shared-memory file
        beside a write-ahead-logged store, ``immutable=1``), nothing is
        created or migrated, and a store that does not exist yet reads as
        empty. Commands that only read (``records list``, ``history``,
        ``stats``, ``report --history``) use it, so a store on read-only
        media can be read.

    Raises
    ------
    AccelcalError
        For a malformed address, a file that is not a database, a store
        that cannot be created or opened (its location unwritable, a full
        disk), or one written by a newer accelcal. A new SQLite file that
        could not be initialised is removed again.
    """

    def __init__(self, db=None, *, readonly: bool = False) -> None:
        import sqlalchemy as sa

        self.url = store_url(db)
        self.readonly = readonly
        self._absent = False
        self._old_schema = False
        try:
            sa.make_url(self.url)
        except (sa.exc.ArgumentError, ValueError):
            raise AccelcalError(
                f"the store {shown(self.url)} is neither a database URL nor a file path; give "
                "e.g. records.sqlite or postgresql+psycopg://user@host/db"
            ) from None
        created = None
        # No connection pool: a command opens the store for a few statements,
        # and every connection is closed as soon as it is released.
        if self.url.startswith("sqlite:///"):
            path = Path(self.url.removeprefix("sqlite:///"))
            check_sqlite_path(path)
            if readonly:
                self._absent = not store_exists(path)
                self.engine = sa.create_engine(
                    "sqlite://", creator=lambda: connect_readonly(path),
                    poolclass=sa.pool.NullPool,
                )
            else:
                created = path if prepare_sqlite_file(path) else None
                self.engine = sa.create_engine(
                    self.url, connect_args={"timeout": 60}, poolclass=sa.pool.NullPool
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
                        version = stored_version(conn, self._tables, self._shown_url())
                    self._absent = version == 0
                    self._old_schema = version == 1  # read as it is: no simulated column
                else:
                    migrate(self.engine, self._tables, self._shown_url())
        except AccelcalError:
            self.engine.dispose()
            if created is not None:
                remove_sqlite_files(created)
            raise

    def close(self) -> None:
        """Release the database engine."""
        self.engine.dispose()

    def __enter__(self) -> "Store":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _shown_url(self) -> str:
        import sqlalchemy as sa

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
            is already in the store or given twice, or the store when it
            cannot be written (a full disk); nothing is added then.
        """
        import sqlalchemy as sa

        records = list(records)
        if self.readonly:
            raise AccelcalError("this store was opened read-only (readonly=True); it cannot add "
                                "records")
        if not records:
            return []
        names = labels(records, sources)
        rows, uids = [], {}
        for i, record in enumerate(records):
            rows.append(calibration_row(record))
            earlier = uids.setdefault(rows[-1]["uid"], i)
            if earlier != i:
                raise AccelcalError(f"{names[i]}: the same record as {names[earlier]} "
                                    f"{what(record)}; {none_added(records)}")
        cal, coef = self._tables["calibrations"], self._tables["coefficients"]
        try:
            with self._errors("write to"), self.engine.begin() as conn:
                stored = self._first_stored(conn, rows)
                if stored is None:
                    ids = dict(conn.execute(sa.insert(cal).returning(cal.c.uid, cal.c.id),
                                            rows).all())
                    parts = any(record.is_complex for record in records)
                    conn.execute(sa.insert(coef), [
                        c for row, record in zip(rows, records, strict=True)
                        for c in coefficient_rows(ids[row["uid"]], record, parts=parts)
                    ])
        except sa.exc.IntegrityError:
            # Another writer stored one of these records meanwhile (PostgreSQL; SQLite
            # writers queue); the transaction was rolled back.
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
        import sqlalchemy as sa

        uid = self._tables["calibrations"].c.uid
        known = [(row["uid"], *former_uids(row)) for row in rows]
        every = [u for uids in known for u in uids]
        stored = set()
        for k in range(0, len(every), _CHUNK):
            chunk = every[k:k + _CHUNK]
            stored.update(conn.execute(sa.select(uid).where(uid.in_(chunk))).scalars())
        return next((i for i, uids in enumerate(known) if stored.intersection(uids)), None)

    def calibrations(self, serial: str | None = None) -> list[dict]:
        """Stored calibrations, oldest first: id, serial, method, date, software, simulated."""
        rows = self._select(self._calibrations_query(serial))
        for r in rows:
            r["simulated"] = bool(r["simulated"])
        return rows

    def calibrations_columns(self, serial: str | None = None) -> dict[str, list]:
        """:meth:`calibrations` as columns: name -> list of values, in the same order.

        No dict per row: the form for writing a long list out (``records
        list --format csv`` of a store of 100k calibrations).
        """
        query = self._calibrations_query(serial)
        columns = _columns(self._rows(query)[0], [c.name for c in query.selected_columns])
        columns["simulated"] = list(map(bool, columns["simulated"]))
        return columns

    def _calibrations_query(self, serial: str | None):
        """The query of :meth:`calibrations` (of ``serial`` only, when given)."""
        import sqlalchemy as sa

        cal = self._tables["calibrations"]
        simulated = sa.false().label("simulated") if self._old_schema else cal.c.simulated
        query = sa.select(cal.c.id, cal.c.serial, _method_today(cal), cal.c.date,
                          cal.c.software, simulated)
        if serial is not None:
            query = query.where(cal.c.serial == check_label(serial, "serial number"))
        return query.order_by(cal.c.date, cal.c.id)

    def record(self, record_id: int) -> CalibrationRecord:
        """The full record with id ``record_id``."""
        import sqlalchemy as sa

        cal = self._tables["calibrations"]
        rows = self._select(sa.select(cal.c.record_json).where(cal.c.id == record_id))
        if not rows:
            raise AccelcalError(f"no record with id {record_id} in the store")
        return CalibrationRecord.from_json(rows[0]["record_json"],
                                           source=f"store record {record_id}")

    def _history(self, serial: str, method: str | None, *what: str) -> list[list[tuple]]:
        """Rows of the calibrations of ``serial`` (by ``method``), in history order.

        ``what`` names the queries, each read in the same transaction:
        ``"history"`` (calibration id, date, method, name, unit, estimate,
        std of each coefficient), ``"calibrations"`` (id, date, method) and
        ``"coefficients"`` (calibration id, name, unit, estimate, std).

        Raises
        ------
        AccelcalError
            If the store has no calibration of ``serial`` (by ``method``).
        """
        import sqlalchemy as sa

        check_label(serial, "serial number")
        if method is not None:
            check_label(method, "method")
        cal, coef = self._tables["calibrations"], self._tables["coefficients"]
        method_today = _method_today(cal)
        columns = {
            "history": (cal.c.id, cal.c.date, method_today, coef.c.name, coef.c.unit,
                        coef.c.estimate, coef.c.std),
            "calibrations": (cal.c.id, cal.c.date, method_today),
            "coefficients": (coef.c.calibration_id, coef.c.name, coef.c.unit,
                             coef.c.estimate, coef.c.std),
        }
        queries = []
        for name in what:
            query = sa.select(*columns[name]).select_from(cal).where(cal.c.serial == serial)
            if method is not None:
                query = query.where(cal.c.method.in_(spellings(method)))
            if name == "calibrations":
                queries.append(query.order_by(cal.c.date, cal.c.id))
            else:
                queries.append(query.join(coef, coef.c.calibration_id == cal.c.id)
                               .order_by(cal.c.date, cal.c.id, coef.c.id))
        results = self._rows(*queries)
        if not all(results):
            by = f" by method {shown(method)}" if method is not None else ""
            raise AccelcalError(
                f"no calibration of serial {shown(serial)}{by} in the store; "
                "see 'accelcal records list'"
            )
        return results

    def history(self, serial: str, method: str | None = None) -> list[dict]:
        """Every coefficient of every calibration of ``serial``, oldest first.

        Parameters
        ----------
        serial : str
        method : str, optional
            Only calibrations by this method (e.g. ``dividing-head/joint``; an old id
            such as ``tumble-fourier`` selects the same records as its id today).

        Returns
        -------
        list of dict
            id, date, method, name, unit, estimate, std (NaN when unknown), and
            coefficient: the plain coefficient the row estimates (``K_F`` for a
            row recorded as ``K_F+K_OO``,
            :func:`accelcal.identifiability.plain_name`), which follows one
            coefficient across its renaming (:mod:`accelcal.store.history`).

        Raises
        ------
        AccelcalError
            If the store has no calibration of ``serial`` (by ``method``).
        """
        nan = math.nan
        plain = _plain_names()
        return [{"id": i, "date": d, "method": m, "name": n, "unit": u, "estimate": e,
                 "std": nan if s is None else s, "coefficient": plain(n)}
                for i, d, m, n, u, e, s in self._history(serial, method, "history")[0]]

    def history_columns(self, serial: str, method: str | None = None) -> dict[str, list]:
        """:meth:`history` as columns: name -> list of values, in the same order.

        No dict per row: the form for writing a long history out (``records
        history --format csv`` of a serial with 100k calibrations).
        """
        columns = _columns(self._history(serial, method, "history")[0],
                           ("id", "date", "method", "name", "unit", "estimate", "std"))
        if None in columns["std"]:
            columns["std"] = [math.nan if s is None else s for s in columns["std"]]
        plain = _plain_names()
        distinct = {n: plain(n) for n in set(columns["name"])}
        columns["coefficient"] = list(map(distinct.__getitem__, columns["name"]))
        return columns

    def stats(self, serial: str, method: str | None = None) -> list[CoefficientStats]:
        """Repeatability and drift of each coefficient of ``serial``, per method.

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
        return summarise(*self._history(serial, method, "calibrations", "coefficients"))


def _plain_names():
    """``name -> plain coefficient`` (:func:`accelcal.identifiability.plain_name`), cached.

    A history repeats a handful of names over many rows.
    """
    from functools import lru_cache

    from accelcal.identifiability import plain_name

    return lru_cache(maxsize=None)(plain_name)


def _columns(rows: list[tuple], names: Sequence[str]) -> dict[str, list]:
    """The driver's row tuples as columns, ``names[i]`` -> every row's ``i``-th value."""
    from operator import itemgetter

    return {name: list(map(itemgetter(i), rows)) for i, name in enumerate(names)}


def _method_today(cal):
    """The ``method`` column as its id today (old ids mapped by the database, one CASE)."""
    import sqlalchemy as sa

    return sa.case(ALIASES, value=cal.c.method, else_=cal.c.method).label("method")
