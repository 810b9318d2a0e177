"""The records store in bulk (issue 16): one transaction per batch, schema 3 and its indexes.

SQLite always; PostgreSQL when ACCELCAL_TEST_POSTGRES_URL names a server (the
``db`` fixture of tests/conftest.py).
"""

import dataclasses
import datetime as dt
import math
import subprocess
import sys
import textwrap

import numpy as np
import pytest
import sqlalchemy as sa

import accelcal.store
from accelcal import AccelcalError
from accelcal.store import SCHEMA_VERSION, Store
from accelcal.store.rows import calibration_row, coefficient_rows
from helpers.cli import refused, run_cli
from helpers.paths import TESTS
from helpers.records import make_record, records


def test_add_many_adds_all_in_order(db):
    store = Store(db)
    batch = records(5) + records(3, serial="SN-2")
    ids = store.add_many(batch)
    assert len(set(ids)) == 8
    for rid, rec in zip(ids, batch, strict=True):
        back = store.record(rid)
        assert (back.serial, back.date) == (rec.serial, rec.date)
        np.testing.assert_array_equal(back.estimates, rec.estimates)
    hist = store.history("SN-1")
    assert [r["id"] for r in hist] == [i for i in ids[:5] for _ in range(3)]
    assert [r["estimate"] for r in hist] == [float(v) for rec in batch[:5] for v in rec.estimates]
    assert store.add_many([]) == []


def test_a_stored_record_among_new_ones_adds_none_and_is_named(db):
    store = Store(db)
    old = records(1, start=10)[0]
    store.add(old)
    batch = [*records(3), old, *records(2, start=20)]
    names = [f"r{i}.json" for i in range(len(batch))]
    with pytest.raises(AccelcalError) as info:
        store.add_many(batch, sources=names)
    message = str(info.value)
    assert message.startswith("r3.json: this record (serial SN-1, 2026-01-11T00:00:00+00:00) "
                              "is already in the store")
    assert message.endswith("none of the 6 records was added")
    assert len(store.calibrations()) == 1
    with pytest.raises(AccelcalError, match=r"^record 2: the same record as record 1 "):
        store.add_many([batch[0], batch[0]])
    assert len(store.calibrations()) == 1
    with pytest.raises(AccelcalError, match="2 sources for 3 records"):
        store.add_many(batch[:3], sources=names[:2])


def _tight_disk(monkeypatch, pages):
    """Let every new SQLite connection grow the file to ``pages`` pages and no more."""
    connect = accelcal.store._sqlite_on_connect

    def tight(dbapi_conn, record):
        connect(dbapi_conn, record)
        dbapi_conn.execute(f"PRAGMA max_page_count={pages}")

    monkeypatch.setattr(accelcal.store, "_sqlite_on_connect", tight)


def test_a_batch_failing_midway_adds_none(tmp_path, monkeypatch):
    # The disk fills up while the batch is written (after its first rows): the transaction
    # is rolled back whole.
    path = tmp_path / "s.sqlite"
    Store(path).add(make_record(serial="FIRST"))
    with Store(path) as store, store.engine.connect() as conn:
        pages = conn.exec_driver_sql("PRAGMA page_count").scalar()
    _tight_disk(monkeypatch, pages + 8)  # room for a few records of the batch, not all
    with pytest.raises(AccelcalError, match=r"cannot write to the records store .*disk is full"
                       r".*; none of the 200 records was added$"):
        Store(path).add_many(records(200))
    monkeypatch.undo()
    assert [r["serial"] for r in Store(path, readonly=True).calibrations()] == ["FIRST"]
    with Store(path) as store, store.engine.connect() as conn:
        assert conn.exec_driver_sql("SELECT count(*) FROM coefficients").scalar() == 3


def test_records_add_names_the_file_and_adds_none(capsys, tmp_path):
    store = tmp_path / "s.sqlite"
    files = []
    for i, rec in enumerate(records(4)):
        files.append(tmp_path / f"cal-{i}.json")
        rec.save(files[-1])
    code, out, _ = run_cli(["records", "add", files[2], "--db", store], capsys)
    assert code == 0
    refused(["records", "add", *files, "--db", store], capsys,
            "cal-2.json: this record", "already in the store", "none of the 4 records")
    assert len(Store(store).calibrations()) == 1
    refused(["records", "add", files[0], files[1], files[0], "--db", store], capsys,
            "cal-0.json: the same record as", "none of the 3 records")
    code, out, _ = run_cli(["records", "add", files[0], files[1], files[3], "--db", store],
                           capsys)
    assert code == 0
    assert out.splitlines() == [f"added {files[k]} as record {rid} (serial SN-1)"
                                for k, rid in ((0, 2), (1, 3), (3, 4))]


_BULK_WRITER = textwrap.dedent(
    """
    import sys
    sys.path.insert(0, {tests!r})
    from helpers.records import records
    from accelcal import AccelcalError
    from accelcal.store import Store
    try:
        Store({db!r}).add_many(records({n}, serial={serial!r}))
    except AccelcalError as exc:
        print(exc)
        sys.exit(3)
    """
)


def test_concurrent_bulk_writers(db):
    # Distinct batches all land; two writers of the same batch: one adds it whole, the
    # other is refused whole (SQLite writers queue; PostgreSQL's unique index decides).
    Store(db)
    procs = [subprocess.Popen(
        [sys.executable, "-c", _BULK_WRITER.format(tests=str(TESTS), db=db, n=100, serial=serial)],
        stdout=subprocess.PIPE, text=True) for serial in ("W0", "W1", "SAME", "SAME")]
    outs = [p.communicate(timeout=300)[0] for p in procs]
    codes = [p.returncode for p in procs]
    assert codes[:2] == [0, 0]
    assert sorted(codes[2:]) == [0, 3], outs
    assert "is already in the store" in outs[2 + codes[2:].index(3)]
    store = Store(db)
    assert len(store.calibrations()) == 300
    for serial in ("W0", "W1", "SAME"):
        assert len(store.history(serial)) == 300


def _schema_2_store(url, batch):
    """A store as accelcal with schema 2 left it: its tables, its two indexes, its rows."""
    engine = sa.create_engine(url if "://" in url else f"sqlite:///{url}")
    meta = sa.MetaData()
    sa.Table("schema_info", meta, sa.Column("version", sa.Integer, nullable=False))
    cal = sa.Table(
        "calibrations", meta,
        sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
        sa.Column("uid", sa.String(64), nullable=False, unique=True),
        sa.Column("serial", sa.String(200), nullable=False, index=True),
        sa.Column("method", sa.String(200), nullable=False),
        sa.Column("date", sa.String(40), nullable=False),
        sa.Column("software", sa.String(100), nullable=False),
        sa.Column("record_json", sa.Text, nullable=False),
        sa.Column("simulated", sa.Boolean, nullable=False, server_default=sa.false()))
    coef = sa.Table(
        "coefficients", meta,
        sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
        sa.Column("calibration_id", sa.Integer, sa.ForeignKey("calibrations.id"),
                  nullable=False, index=True),
        sa.Column("name", sa.String(100), nullable=False),
        sa.Column("unit", sa.String(40), nullable=False),
        sa.Column("estimate", sa.Float, nullable=False),
        sa.Column("std", sa.Float, nullable=True))
    with engine.begin() as conn:
        meta.create_all(conn)
        conn.execute(sa.insert(meta.tables["schema_info"]).values(version=2))
        for rec in batch:  # one at a time, as schema 2 stores were written
            rid = conn.execute(sa.insert(cal).values(calibration_row(rec))
                               .returning(cal.c.id)).scalar_one()
            conn.execute(sa.insert(coef), coefficient_rows(rid, rec))
    engine.dispose()


def _indexes(store):
    with store.engine.connect() as conn:
        inspector = sa.inspect(conn)
        return {table: {ix["name"]: tuple(ix["column_names"])
                        for ix in inspector.get_indexes(table) if ix["name"].startswith("ix_")}
                for table in ("calibrations", "coefficients")}


def _everything(store):
    return (store.calibrations(), store.calibrations("SN-2"), store.history("SN-1"),
            store.history("SN-1", "tumble/six"), store.stats("SN-1"), store.stats("SN-2"))


def test_schema_2_store_migrates_to_3_keeping_every_record(db):
    batch = (records(7, methods=("dividing-head/joint", "tumble/six"))
             + records(2, serial="SN-2", start=3)
             + [dataclasses.replace(make_record(serial="SN-2", date="2026-03-01T08:00:00+08:00"),
                                    simulated=True)])
    _schema_2_store(db, batch)
    with Store(db, readonly=True) as store:  # read as it is, without migrating
        assert store.schema_version == 2
        before = _everything(store)
        old_indexes = _indexes(store)
    assert "ix_calibrations_serial" in old_indexes["calibrations"]
    with Store(db) as store:
        assert store.schema_version == SCHEMA_VERSION == 5
        after = _everything(store)
        indexes = _indexes(store)
    assert indexes == {
        "calibrations": {"ix_calibrations_date": ("date",),
                         "ix_calibrations_serial_date": ("serial", "date"),
                         "ix_calibrations_serial_method_date": ("serial", "method", "date")},
        "coefficients": {"ix_coefficients_calibration_id_id": ("calibration_id", "id")},
    }
    # every record kept, same ids, same order, same statistics (repr: NaN equals NaN)
    assert repr(after) == repr(before)
    assert [r["simulated"] for r in after[1]] == [False, False, True]
    assert len(after[0]) == len(batch)
    with Store(db) as store:  # a migrated store stays at the current schema and takes new records
        store.add(make_record(serial="SN-3"))
        assert store.schema_version == SCHEMA_VERSION


def test_a_new_store_has_the_schema_3_indexes(tmp_path):
    store = Store(tmp_path / "s.sqlite")
    store.add(make_record())
    assert set(_indexes(store)["calibrations"]) == {
        "ix_calibrations_date", "ix_calibrations_serial_date",
        "ix_calibrations_serial_method_date"}


@pytest.mark.parametrize(("query", "index"), [
    ("SELECT id, date FROM calibrations ORDER BY date, id", "ix_calibrations_date"),
    ("SELECT id FROM calibrations WHERE serial = 'A' ORDER BY date, id",
     "ix_calibrations_serial_date"),
    (("SELECT c.id, k.estimate FROM calibrations c JOIN coefficients k "
      "ON k.calibration_id = c.id WHERE c.serial = 'A' AND c.method = 'm' "
      "ORDER BY c.date, c.id, k.id"), "ix_calibrations_serial_method_date"),
])
def test_sqlite_answers_the_store_queries_from_the_indexes(tmp_path, query, index):
    # The shapes of Store.calibrations, history and stats: served by an index, in index
    # order (no sort of the whole result).
    store = Store(tmp_path / "s.sqlite")
    store.add_many(records(20))
    with store.engine.connect() as conn:
        plan = " | ".join(r[-1] for r in conn.exec_driver_sql("EXPLAIN QUERY PLAN " + query))
    assert index in plan
    assert "TEMP B-TREE" not in plan
    if "JOIN" in query:
        assert "ix_coefficients_calibration_id_id" in plan


def _reference_stats(batch):
    """Repeatability and drift per (method, coefficient), straight from the records.

    An independent route: dates parsed one by one with datetime, the line fitted by
    numpy.polyfit (covariance scaled by the residuals over n - 2).
    """
    groups = {}
    for rec in sorted(batch, key=lambda r: dt.datetime.fromisoformat(r.date)):
        t = dt.datetime.fromisoformat(rec.date).timestamp() / (365.25 * 86400)
        for name, x, s in zip(rec.names, rec.estimates, rec.std, strict=True):
            groups.setdefault((rec.method, name), []).append((t, x, s))
    out = {}
    for key, rows in groups.items():
        t, x, s = (np.array(c) for c in zip(*rows, strict=True))
        slope = slope_std = math.nan
        if len(x) >= 3:
            coef, cov = np.polyfit(t - t[0], x, 1, cov=True)
            slope, slope_std = coef[0], math.sqrt(cov[0, 0])
        out[key] = (len(x), x.mean(), x.std(ddof=1), np.nanmean(s), slope, slope_std)
    return out


def test_stats_in_one_pass_match_an_independent_computation(db):
    rng = np.random.default_rng(5)
    batch = []
    for i in range(60):
        hours = rng.uniform(0, 3 * 365 * 24)
        offset = dt.timezone(dt.timedelta(hours=int(rng.integers(-11, 12))))
        date = (dt.datetime(2024, 1, 1, tzinfo=dt.UTC) + dt.timedelta(hours=hours))
        rec = make_record(date=date.astimezone(offset).isoformat(), shift=rng.normal(0, 1e-6),
                          method=("dividing-head/joint", "vre")[i % 2])
        if i % 7 == 0:  # an unknown uncertainty now and then
            cov = rec.covariance.copy()
            cov[2, 2] = math.nan
            rec = dataclasses.replace(rec, covariance=cov)
        batch.append(rec)
    store = Store(db)
    store.add_many(batch)
    expected = _reference_stats(batch)
    got = store.stats("SN-1")
    assert [(s.method, s.name) for s in got] == list(expected)  # order of first appearance
    for s in got:
        n, mean, sd, mean_std, slope, slope_std = expected[(s.method, s.name)]
        assert s.n == n
        # Same sums in another order and another parametrisation of the line: agreement to
        # rounding (1e-9 relative leaves six orders of magnitude above it).
        assert s.mean == pytest.approx(mean, rel=1e-12)
        assert s.repeatability == pytest.approx(sd, rel=1e-9)
        assert s.mean_std == pytest.approx(mean_std, rel=1e-12)
        assert s.drift_per_year == pytest.approx(slope, rel=1e-9)
        assert s.drift_std == pytest.approx(slope_std, rel=1e-9)
    hist = store.history("SN-1")
    dates = [dt.datetime.fromisoformat(r["date"]) for r in hist]
    assert dates == sorted(dates)
    assert sum(math.isnan(r["std"]) for r in hist) == len(range(0, 60, 7))
