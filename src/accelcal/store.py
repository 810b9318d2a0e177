"""The records store: every calibration of every serial number, in a database.

An SQLite file by default (embedded, nothing to start); PostgreSQL (or any
SQLAlchemy URL) with ``--db postgresql+psycopg://user@host/db``. Each
:meth:`Store.add` is one transaction, so concurrent writers lose nothing and a
killed writer leaves no partial record. The schema carries a version in the
``schema_info`` table; opening a store applies the migrations it lacks, and
refuses a store written by a newer accelcal.

Tables (schema version 1):

- ``calibrations``: one row per record: ``uid`` (SHA-256 of the record's
  JSON, unique, so the same record is stored once), ``serial``, ``method``,
  ``date``, ``software``, ``record_json``.
- ``coefficients``: one row per coefficient of a record: ``calibration_id``,
  ``name``, ``unit``, ``estimate``, ``std``.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, definitions of repeatability (run-to-run
   spread under the same conditions) and of drift.
"""

import contextlib
import hashlib
import math
import os
import stat
import urllib.parse
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.calibration_record import CalibrationRecord
from accelcal.io.limits import check_label, file_type, shown, shown_path

SCHEMA_VERSION = 2
DEFAULT_DB_ENV = "ACCELCAL_DB"


def default_url() -> str:
    """The default store: ``$ACCELCAL_DB``, else an SQLite file in the user data directory.

    The data directory is ``$XDG_DATA_HOME/accelcal`` (``~/.local/share/accelcal``
    when unset).
    """
    if os.environ.get(DEFAULT_DB_ENV):
        return _url(os.environ[DEFAULT_DB_ENV])
    base = Path(os.environ.get("XDG_DATA_HOME") or Path.home() / ".local" / "share")
    return f"sqlite:///{base / 'accelcal' / 'records.sqlite'}"


def _url(db: str | os.PathLike | None) -> str:
    """A database URL from a URL, an SQLite file path, or None (the default store)."""
    if db is None:
        return default_url()
    text = os.fspath(db)
    if "://" in text:
        return text
    try:
        return f"sqlite:///{Path(text).resolve()}"
    except (OSError, ValueError) as exc:
        raise AccelcalError(f"the store path {shown(text)} cannot be used: {exc}") from None


def _check_sqlite_path(path: Path) -> None:
    """Refuse an SQLite store path that exists and is not a regular file.

    Checked before SQLite opens it: SQLite would block for ever on a FIFO,
    and beside a device such as ``/dev/zero`` it would make its journal
    (``/dev/zero-journal``) and find an empty database.

    Raises
    ------
    AccelcalError
        Naming the path and what it is (a directory, a FIFO, a device).
    """
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        return
    except OSError as exc:
        raise AccelcalError(
            f"cannot use the records store {shown_path(path)}: {exc.strerror or exc}") from None
    if stat.S_ISDIR(mode):
        raise AccelcalError(
            f"the records store {shown_path(path)} is a directory; give a file name")
    if not stat.S_ISREG(mode):
        raise AccelcalError(
            f"the records store {shown_path(path)} is {file_type(mode)}, not a regular file; "
            "give an SQLite file (new or existing) or a database URL")


def _prepare_sqlite_file(path: Path) -> bool:
    """Make the directory of an SQLite store; return whether the file is new.

    Raises
    ------
    AccelcalError
        If ``path`` is a directory or its directory cannot be made.
    """
    try:
        if path.is_dir():
            raise AccelcalError(
                f"the records store {shown_path(path)} is a directory; give a file name")
        new = not path.exists()
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise AccelcalError(
            f"cannot create the records store {shown_path(path)}: {exc.strerror or exc}; "
            "choose a writable location"
        ) from None
    return new


def _exists(path: Path) -> bool:
    """Whether an SQLite store file exists (an unusable path is refused)."""
    try:
        return path.exists()
    except OSError as exc:
        raise AccelcalError(
            f"cannot read the records store {shown_path(path)}: {exc.strerror or exc}") from None


def _remove_sqlite_files(path: Path) -> None:
    """Remove an SQLite file this process created, with its journal files."""
    for suffix in ("", "-journal", "-wal", "-shm"):
        with contextlib.suppress(OSError):
            os.unlink(f"{path}{suffix}")


def _connect_readonly(path: Path):
    """A read-only SQLite connection to ``path``.

    ``mode=ro`` first; where SQLite cannot read that way because it cannot
    create the shared-memory file of a write-ahead-logged store (read-only
    media), ``immutable=1``: nothing can change such a store while it is read.
    """
    import sqlite3

    uri = f"file:{urllib.parse.quote(str(path))}?mode=ro"
    conn = sqlite3.connect(uri, uri=True, timeout=60)
    try:
        conn.execute("SELECT count(*) FROM sqlite_master").fetchone()
    except sqlite3.OperationalError as exc:
        conn.close()
        if "readonly" not in str(exc) and "unable to open" not in str(exc):
            raise
        conn = sqlite3.connect(uri + "&immutable=1", uri=True, timeout=60)
    return conn


@dataclass(frozen=True)
class CoefficientStats:
    """Repeatability and drift of one coefficient across calibrations.

    Attributes
    ----------
    method : str
        Calibration method; coefficients of different methods (or different
        tests: a VRE fit's K2 is not a tumble's K2) are never pooled.
    name, unit : str
    n : int
        Calibrations.
    mean : float
    repeatability : float
        Sample standard deviation across calibrations (run-to-run).
    mean_std : float
        Mean of the calibrations' own standard uncertainties; a repeatability
        well above it means the coefficient moves more than each calibration
        claims.
    drift_per_year : float
        Slope of a straight-line fit against the calibration dates (NaN with
        fewer than 3 calibrations).
    drift_std : float
        Standard uncertainty of the slope (NaN with fewer than 3 calibrations).
    """

    method: str
    name: str
    unit: str
    n: int
    mean: float
    repeatability: float
    mean_std: float
    drift_per_year: float
    drift_std: float


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

        self.url = _url(db)
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
            _check_sqlite_path(path)
            if readonly:
                self._absent = not _exists(path)
                self.engine = sa.create_engine(
                    "sqlite://", creator=lambda: _connect_readonly(path),
                    poolclass=sa.pool.NullPool,
                )
            else:
                created = path if _prepare_sqlite_file(path) else None
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
                        version = self._version(conn)
                    self._absent = version == 0
                    self._old_schema = version == 1  # read as it is: no simulated column
                else:
                    self._migrate()
        except AccelcalError:
            self.engine.dispose()
            if created is not None:
                _remove_sqlite_files(created)
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

    def _version(self, conn) -> int:
        """The schema version of the store (0 for none); refuses a newer one."""
        import sqlalchemy as sa

        if not sa.inspect(conn).has_table("schema_info"):
            return 0
        info = self._tables["schema_info"]
        version = conn.execute(sa.select(info.c.version)).scalar_one_or_none() or 0
        if version > SCHEMA_VERSION:
            raise AccelcalError(
                f"the records store {self._shown_url()} has schema version {version}, "
                f"newer than this accelcal ({SCHEMA_VERSION}); upgrade accelcal"
            )
        return version

    def _migrate(self) -> None:
        import sqlalchemy as sa

        meta, info = self._tables["metadata"], self._tables["schema_info"]
        with self.engine.begin() as conn:
            if conn.dialect.name == "postgresql":
                # Serialise concurrent first opens of the same database.
                conn.execute(sa.text("SELECT pg_advisory_xact_lock(1293836)"))
            for target in range(self._version(conn) + 1, SCHEMA_VERSION + 1):
                _MIGRATIONS[target](conn, meta)
                conn.execute(sa.delete(info))
                conn.execute(sa.insert(info).values(version=target))

    def _select(self, query) -> list[dict]:
        """The rows of a read query (none from a store that does not exist yet)."""
        if self._absent:
            return []
        with self._errors("read"), self.engine.connect() as conn:
            return [dict(r) for r in conn.execute(query).mappings().all()]

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
        import sqlalchemy as sa

        text = record.to_json()
        uid = hashlib.sha256(text.encode()).hexdigest()
        cal, coef = self._tables["calibrations"], self._tables["coefficients"]
        if self.readonly:
            raise AccelcalError("this store was opened read-only (readonly=True); it cannot add "
                                "records")
        try:
            with self._errors("write to"), self.engine.begin() as conn:
                row_id = conn.execute(
                    sa.insert(cal).values(
                        uid=uid, serial=record.serial, method=record.method,
                        simulated=bool(record.simulated),
                        date=_utc(record.date),
                        software=record.software, record_json=text,
                    ).returning(cal.c.id)
                ).scalar_one()
                conn.execute(sa.insert(coef), [
                    {"calibration_id": row_id, "name": n, "unit": record.units.get(n, ""),
                     "estimate": float(v), "std": None if math.isnan(s) else float(s)}
                    for n, v, s in zip(record.names, record.estimates, record.std, strict=True)
                ])
        except sa.exc.IntegrityError:
            raise AccelcalError(
                f"this record (serial {record.serial}, {record.date}) is already in the store"
            ) from None
        return int(row_id)

    def calibrations(self, serial: str | None = None) -> list[dict]:
        """Stored calibrations, oldest first: id, serial, method, date, software, simulated."""
        import sqlalchemy as sa

        cal = self._tables["calibrations"]
        simulated = sa.false().label("simulated") if self._old_schema else cal.c.simulated
        query = sa.select(cal.c.id, cal.c.serial, cal.c.method, cal.c.date, cal.c.software,
                          simulated)
        if serial is not None:
            query = query.where(cal.c.serial == check_label(serial, "serial number"))
        return self._select(query.order_by(cal.c.date, cal.c.id))

    def record(self, record_id: int) -> CalibrationRecord:
        """The full record with id ``record_id``."""
        import sqlalchemy as sa

        cal = self._tables["calibrations"]
        rows = self._select(sa.select(cal.c.record_json).where(cal.c.id == record_id))
        if not rows:
            raise AccelcalError(f"no record with id {record_id} in the store")
        return CalibrationRecord.from_json(rows[0]["record_json"],
                                           source=f"store record {record_id}")

    def history(self, serial: str, method: str | None = None) -> list[dict]:
        """Every coefficient of every calibration of ``serial``, oldest first.

        Parameters
        ----------
        serial : str
        method : str, optional
            Only calibrations by this method (e.g. ``dividing-head/joint``).

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
        query = (
            sa.select(cal.c.id, cal.c.date, cal.c.method, coef.c.name, coef.c.unit,
                      coef.c.estimate, coef.c.std)
            .join(coef, coef.c.calibration_id == cal.c.id)
            .where(cal.c.serial == serial)
            .order_by(cal.c.date, cal.c.id, coef.c.id)
        )
        if method is not None:
            query = query.where(cal.c.method == method)
        rows = self._select(query)
        if not rows:
            by = f" by method {shown(method)}" if method is not None else ""
            raise AccelcalError(
                f"no calibration of serial {shown(serial)}{by} in the store; "
                "see 'accelcal records list'"
            )
        for r in rows:
            r["std"] = math.nan if r["std"] is None else r["std"]
        return rows

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
        import datetime as dt

        groups: dict[tuple[str, str], list[dict]] = {}
        for r in self.history(serial, method):
            groups.setdefault((r["method"], r["name"]), []).append(r)
        out = []
        for (meth, name), rows in groups.items():
            x = np.array([r["estimate"] for r in rows])
            s = np.array([r["std"] for r in rows])
            t = np.array([dt.datetime.fromisoformat(r["date"]).timestamp() for r in rows])
            years = (t - t.min()) / (365.25 * 86400.0)
            slope, slope_std = _drift(years, x)
            out.append(CoefficientStats(
                method=meth, name=name, unit=rows[0]["unit"], n=len(x), mean=float(x.mean()),
                repeatability=float(x.std(ddof=1)) if len(x) > 1 else math.nan,
                mean_std=float(np.nanmean(s)) if np.isfinite(s).any() else math.nan,
                drift_per_year=slope, drift_std=slope_std,
            ))
        return out


def _utc(date: str) -> str:
    """ISO 8601 in UTC, so that string order is time order (naive dates are taken as UTC)."""
    import datetime as dt

    moment = dt.datetime.fromisoformat(date)
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=dt.UTC)
    return moment.astimezone(dt.UTC).isoformat(timespec="microseconds")


def _drift(years: np.ndarray, x: np.ndarray) -> tuple[float, float]:
    """Least-squares slope of x against time and its standard uncertainty.

    NaN for fewer than three calibrations at distinct dates: a slope through
    two points has no uncertainty to judge it by (two calibrations minutes
    apart would give a meaningless "drift per year").
    """
    if len(x) < 3 or np.unique(years).size < 2:
        return math.nan, math.nan
    A = np.column_stack([np.ones_like(years), years])
    coef, *_ = np.linalg.lstsq(A, x, rcond=None)
    resid = x - A @ coef
    cov = np.linalg.inv(A.T @ A) * (resid @ resid) / (len(x) - 2)
    return float(coef[1]), float(np.sqrt(cov[1, 1]))


def _tables(sa) -> dict:
    meta = sa.MetaData()
    return {
        "metadata": meta,
        "schema_info": sa.Table(
            "schema_info", meta, sa.Column("version", sa.Integer, nullable=False)
        ),
        "calibrations": sa.Table(
            "calibrations", meta,
            sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
            sa.Column("uid", sa.String(64), nullable=False, unique=True),
            sa.Column("serial", sa.String(200), nullable=False, index=True),
            sa.Column("method", sa.String(200), nullable=False),
            sa.Column("date", sa.String(40), nullable=False),
            sa.Column("software", sa.String(100), nullable=False),
            sa.Column("record_json", sa.Text, nullable=False),
            sa.Column("simulated", sa.Boolean, nullable=False, server_default=sa.false()),
        ),
        "coefficients": sa.Table(
            "coefficients", meta,
            sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
            sa.Column("calibration_id", sa.Integer, sa.ForeignKey("calibrations.id"),
                      nullable=False, index=True),
            sa.Column("name", sa.String(100), nullable=False),
            sa.Column("unit", sa.String(40), nullable=False),
            sa.Column("estimate", sa.Float, nullable=False),
            sa.Column("std", sa.Float, nullable=True),
        ),
    }


def _migrate_to_1(conn, meta) -> None:
    """Schema 1: schema_info, calibrations, coefficients.

    A new store gets the later schemas' columns at once; their migrations
    then find them.
    """
    meta.create_all(conn)


def _migrate_to_2(conn, meta) -> None:
    """Schema 2: ``calibrations.simulated`` (records made from simulated data).

    A store of schema 1 gains the column, false for its records, which said
    nothing of their data's origin (records written before it).
    """
    import sqlalchemy as sa

    columns = {c["name"] for c in sa.inspect(conn).get_columns("calibrations")}
    if "simulated" not in columns:
        conn.execute(sa.text(
            "ALTER TABLE calibrations ADD COLUMN simulated BOOLEAN NOT NULL DEFAULT FALSE"))


_MIGRATIONS = {1: _migrate_to_1, 2: _migrate_to_2}
"""Schema version -> function bringing the previous version to it."""


def _sqlite_on_connect(dbapi_conn, _record) -> None:
    # Let SQLAlchemy emit BEGIN itself (pysqlite's implicit transactions are
    # off), and use write-ahead logging so readers never block the writer.
    dbapi_conn.isolation_level = None
    dbapi_conn.execute("PRAGMA journal_mode=WAL")
    dbapi_conn.execute("PRAGMA foreign_keys=ON")


def _sqlite_on_begin(conn) -> None:
    # Take the write lock at the start of every transaction, so concurrent
    # writers queue (busy timeout) instead of failing on lock upgrade.
    conn.exec_driver_sql("BEGIN IMMEDIATE")
