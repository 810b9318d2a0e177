"""The records store's tables, indexes and migrations, and SQLite connection settings.

Schema versions:

1. ``schema_info``, ``calibrations``, ``coefficients``.
2. ``calibrations.simulated``.
3. Indexes for the queries of ``records list``, ``history`` and ``stats``:
   ``calibrations (date)`` for the whole list in date order,
   ``calibrations (serial, date)`` and ``calibrations (serial, method, date)``
   for one serial number (with or without ``--method``) in date order, and
   ``coefficients (calibration_id, id)`` for the coefficients of each
   calibration in their order. The single-column ``calibrations (serial)``
   index of schemas 1-2 is dropped: ``(serial, date)`` serves its look-ups.
4. ``coefficients.estimate_re`` and ``coefficients.estimate_im`` (nullable):
   the real and imaginary parts of a complex coefficient (a frequency
   response's sensitivity), NULL for a real one. A complex coefficient's
   ``estimate`` and ``std`` are its magnitude and the magnitude's standard
   uncertainty, so ``history`` and ``stats`` follow the magnitude; its full
   covariance is in ``record_json``.
5. ``journal``: one entry per record, in the order the records were stored
   (``seq`` 1, 2, ...): the record's id, serial number, method and date (so
   that a record deleted outside accelcal can still be named), when it was
   stored (``stored_at``, UTC; NULL for records stored before schema 5), the
   correction it is (``supersedes``, ``who``, ``why``; NULL otherwise), the
   SHA-256 of its content (``content_hash``) and the hash chaining the entry
   to the previous one (``chain_hash``) (:mod:`accelcal.store.chain`). The
   migration journals the records of an older store in id order, hashing
   them as they are then.

A column added to ``calibrations`` or ``coefficients`` by a later schema joins
the records' content hash by being listed in
:data:`accelcal.store.chain.CALIBRATION_FIELDS` or ``COEFFICIENT_FIELDS``;
records stored before it (NULL there) keep their hashes, so the migration
need not rehash them.

A store whose file holds other tables and not accelcal's (another
application's SQLite database) is refused, never migrated; so is a
``schema_info`` table with other than one row or a version that is not an
integer.
"""

SCHEMA_VERSION = 5

INDEXES = {
    "calibrations": {
        "ix_calibrations_date": ("date",),
        "ix_calibrations_serial_date": ("serial", "date"),
        "ix_calibrations_serial_method_date": ("serial", "method", "date"),
    },
    "coefficients": {
        "ix_coefficients_calibration_id_id": ("calibration_id", "id"),
    },
}
"""Table -> index name -> columns: the indexes of schema 3."""

JOURNAL_INDEXES = {
    "ix_journal_calibration_id": ("calibration_id",),
    "ix_journal_supersedes": ("supersedes",),
}
"""Index name -> columns: the indexes of the ``journal`` table (schema 5)."""

WRITE_LOCK = 1293836
"""PostgreSQL advisory lock key serialising migrations and additions to one store."""

OURS = frozenset({"schema_info", "calibrations"})
"""Tables every accelcal store has: an SQLite file with tables and not these is not a store."""

_OLD_INDEXES = ("ix_calibrations_serial", "ix_coefficients_calibration_id")
"""Indexes of schemas 1-2 that the schema-3 indexes make redundant."""


def tables(sa) -> dict:
    """The SQLAlchemy tables of the current schema (``metadata`` holds them all)."""
    meta = sa.MetaData()
    out = {
        "metadata": meta,
        "schema_info": sa.Table(
            "schema_info", meta, sa.Column("version", sa.Integer, nullable=False)
        ),
        "calibrations": sa.Table(
            "calibrations", meta,
            sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
            sa.Column("uid", sa.String(64), nullable=False, unique=True),
            sa.Column("serial", sa.String(200), nullable=False),
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
                      nullable=False),
            sa.Column("name", sa.String(100), nullable=False),
            sa.Column("unit", sa.String(40), nullable=False),
            sa.Column("estimate", sa.Float, nullable=False),
            sa.Column("std", sa.Float, nullable=True),
            sa.Column("estimate_re", sa.Float, nullable=True),
            sa.Column("estimate_im", sa.Float, nullable=True),
        ),
        "journal": sa.Table(
            "journal", meta,
            sa.Column("seq", sa.Integer, primary_key=True, autoincrement=False),
            sa.Column("calibration_id", sa.Integer, nullable=False),
            sa.Column("serial", sa.String(200), nullable=False),
            sa.Column("method", sa.String(200), nullable=False),
            sa.Column("date", sa.String(40), nullable=False),
            sa.Column("stored_at", sa.String(40), nullable=True),
            sa.Column("supersedes", sa.Integer, nullable=True),
            sa.Column("who", sa.String(200), nullable=True),
            sa.Column("why", sa.Text, nullable=True),
            sa.Column("content_hash", sa.String(64), nullable=False),
            sa.Column("chain_hash", sa.String(64), nullable=False),
        ),
    }
    for table, indexes in INDEXES.items():
        for name, columns in indexes.items():
            sa.Index(name, *(out[table].c[c] for c in columns))
    for name, columns in JOURNAL_INDEXES.items():
        sa.Index(name, *(out["journal"].c[c] for c in columns))
    return out


def _migrate_to_1(conn, meta) -> None:
    """Schema 1: schema_info, calibrations, coefficients.

    A new store gets the later schemas' columns and indexes at once; their
    migrations then find them.
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


def _migrate_to_3(conn, meta) -> None:
    """Schema 3: the indexes of :data:`INDEXES`; the redundant older ones dropped.

    Every record is kept; only indexes change.
    """
    import sqlalchemy as sa

    for table in INDEXES:
        for index in meta.tables[table].indexes:
            index.create(conn, checkfirst=True)
    for name in _OLD_INDEXES:
        conn.execute(sa.text(f"DROP INDEX IF EXISTS {name}"))


def _migrate_to_4(conn, meta) -> None:
    """Schema 4: ``coefficients.estimate_re`` and ``estimate_im`` (complex coefficients).

    A store of schema 3 gains both columns, NULL for its records (all real).
    """
    import sqlalchemy as sa

    columns = {c["name"] for c in sa.inspect(conn).get_columns("coefficients")}
    for name in ("estimate_re", "estimate_im"):
        if name not in columns:
            conn.execute(sa.text(f"ALTER TABLE coefficients ADD COLUMN {name} FLOAT"))


def _migrate_to_5(conn, meta) -> None:
    """Schema 5: the ``journal`` (tamper evidence), its entries for the records stored.

    Each record stored so far gets its entry, in id order, hashed as it is
    now (``stored_at`` NULL: the time it was stored is not known). Records
    changed before this migration cannot be told from the others.
    """
    from accelcal.store.chain import journal_existing

    meta.tables["journal"].create(conn, checkfirst=True)
    journal_existing(conn, meta)


MIGRATIONS = {1: _migrate_to_1, 2: _migrate_to_2, 3: _migrate_to_3, 4: _migrate_to_4,
              5: _migrate_to_5}
"""Schema version -> function bringing the previous version to it."""


def refuse_foreign(names: set[str], where: str) -> None:
    """Refuse an SQLite database whose tables (``names``) are not a records store's.

    Raises
    ------
    AccelcalError
        When it has tables and not those of :data:`OURS`: another
        application's database, which accelcal must never modify.
    """
    from accelcal.errors import AccelcalError

    if names and not names >= OURS:
        listed = ", ".join(sorted(names)[:5]) + (", ..." if len(names) > 5 else "")
        raise AccelcalError(
            f"{where} is an SQLite database but not an accelcal records store (its tables: "
            f"{listed}); accelcal never modifies it: give a new or empty file")


def stored_version(conn, tables_: dict, where: str) -> int:
    """The schema version of a store (0 for none); refuses a newer one.

    Parameters
    ----------
    conn : sqlalchemy.engine.Connection
    tables_ : dict
        :func:`tables`.
    where : str
        The store, as messages name it.

    Raises
    ------
    AccelcalError
        If the store was written by a newer accelcal, is another
        application's SQLite database, or its ``schema_info`` is damaged
        (other than one row, a version that is not a positive integer).
    """
    import sqlalchemy as sa

    from accelcal.errors import AccelcalError
    from accelcal.validation import shown

    names = set(sa.inspect(conn).get_table_names())
    if conn.dialect.name == "sqlite":
        refuse_foreign(names, where)
    if "schema_info" not in names:
        return 0
    info = tables_["schema_info"]
    rows = conn.execute(sa.select(info.c.version)).all()
    if len(rows) != 1:
        raise AccelcalError(
            f"the records store {where} is damaged: table schema_info has {len(rows)} rows, "
            "not 1; it was changed outside accelcal ('accelcal records verify' checks the rest)")
    version = rows[0][0]
    if type(version) is not int or version < 1:
        raise AccelcalError(
            f"the records store {where} is damaged: table schema_info, field version: "
            f"{shown(version)} is not a schema version (a positive integer)")
    if version > SCHEMA_VERSION:
        raise AccelcalError(
            f"the records store {where} has schema version {version}, newer than this "
            f"accelcal ({SCHEMA_VERSION}); upgrade accelcal"
        )
    return version


def migrate(engine, tables_: dict, where: str) -> None:
    """Bring a store to :data:`SCHEMA_VERSION` in one transaction (creating a new one)."""
    import sqlalchemy as sa

    meta, info = tables_["metadata"], tables_["schema_info"]
    with engine.begin() as conn:
        if conn.dialect.name == "postgresql":
            # Serialise concurrent first opens of the same database.
            conn.execute(sa.text(f"SELECT pg_advisory_xact_lock({WRITE_LOCK})"))
        for target in range(stored_version(conn, tables_, where) + 1, SCHEMA_VERSION + 1):
            MIGRATIONS[target](conn, meta)
            conn.execute(sa.delete(info))
            conn.execute(sa.insert(info).values(version=target))


def sqlite_on_connect(dbapi_conn, _record) -> None:
    """Settings of every SQLite connection a writable store makes."""
    # Let SQLAlchemy emit BEGIN itself (pysqlite's implicit transactions are
    # off), and use write-ahead logging so readers never block the writer.
    dbapi_conn.isolation_level = None
    dbapi_conn.execute("PRAGMA journal_mode=WAL")
    dbapi_conn.execute("PRAGMA foreign_keys=ON")


def sqlite_on_begin(conn) -> None:
    """Take the write lock at the start of every transaction.

    Concurrent writers then queue (busy timeout) instead of failing on lock
    upgrade.
    """
    conn.exec_driver_sql("BEGIN IMMEDIATE")
