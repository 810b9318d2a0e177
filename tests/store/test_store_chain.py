"""Tamper evidence: the journal's hash chain, records verify, corrections that supersede.

SQLite always; PostgreSQL when ACCELCAL_TEST_POSTGRES_URL names a server.
"""

import subprocess
import sys
import textwrap

import pytest
import sqlalchemy as sa

from accelcal import AccelcalError
from accelcal.store import SCHEMA_VERSION, Store, verify_chain
from accelcal.store.chain import GENESIS, content_hash
from helpers.paths import TESTS
from helpers.records import make_record, records


def _sql(db, *statements):
    """Run SQL on a store as another program would (no accelcal)."""
    engine = sa.create_engine(db if "://" in db else f"sqlite:///{db}")
    with engine.begin() as conn:
        for statement in statements:
            conn.execute(sa.text(statement))
    engine.dispose()


def _journal(db):
    engine = sa.create_engine(db if "://" in db else f"sqlite:///{db}")
    with engine.connect() as conn:
        rows = [dict(r._mapping) for r in conn.execute(sa.text(
            "SELECT * FROM journal ORDER BY seq"))]
    engine.dispose()
    return rows


def test_a_store_written_by_accelcal_verifies(db):
    with Store(db) as store:
        store.add(make_record(serial="A"))
        store.add_many(records(3, serial="B", start=1))
        report = store.verify()
    assert report.verified
    assert report.findings == ()
    assert report.records == 4
    assert report.head != GENESIS
    assert len(report.head) == 64
    assert report.status_line() == "chain verified: yes (4 records)"
    assert verify_chain(db) == report  # the function a report or certificate calls
    journal = _journal(db)
    assert [e["seq"] for e in journal] == [1, 2, 3, 4]
    assert all(e["stored_at"] and e["supersedes"] is None for e in journal)
    assert journal[-1]["chain_hash"] == report.head
    if "://" not in db:
        assert report.integrity == "ok"  # PRAGMA integrity_check
    else:
        assert report.integrity == "not run"


def test_verify_names_every_record_changed_inserted_or_deleted(db):
    with Store(db) as store:
        ids = store.add_many(records(5))
        assert store.verify().verified
    deleted = store.calibrations()[3]
    _sql(db,
         f"UPDATE coefficients SET estimate = estimate * 1.0001 WHERE calibration_id = {ids[1]}",
         f"UPDATE calibrations SET date = '2026-06-01T00:00:00.000000+00:00' "
         f"WHERE id = {ids[2]}",
         f"DELETE FROM coefficients WHERE calibration_id = {ids[3]}",
         f"DELETE FROM calibrations WHERE id = {ids[3]}",
         "INSERT INTO calibrations (uid, serial, method, date, software, record_json, simulated)"
         " VALUES ('" + "f" * 64 + "', 'FORGED', 'dividing-head/joint', "
         "'2026-02-01T00:00:00.000000+00:00', 'x', '{}', FALSE)")
    report = verify_chain(db)
    assert not report.verified
    found = {(f.kind, f.serial) if f.kind == "inserted" else (f.kind, f.id)
             for f in report.findings}
    assert found == {("changed", ids[1]), ("changed", ids[2]), ("deleted", ids[3]),
                     ("inserted", "FORGED")}
    gone = next(f for f in report.findings if f.kind == "deleted")
    assert (gone.serial, gone.method, gone.date) == (deleted["serial"], deleted["method"],
                                                     deleted["date"])
    assert "record" in gone.line()
    assert deleted["date"] in gone.line()
    assert report.status_line().startswith("chain verified: no (5 records; 4 finding(s)")


def test_journal_entries_changed_or_removed_break_the_chain(db):
    with Store(db) as store:
        store.add_many(records(4))
    _sql(db, "UPDATE journal SET serial = 'OTHER' WHERE seq = 2")
    report = verify_chain(db)
    assert [(f.kind, f.id) for f in report.findings] == [("journal", 2)]
    _sql(db, "DELETE FROM journal WHERE seq = 3")
    kinds = sorted(f.kind for f in verify_chain(db).findings)
    # entry 3 missing from the chain, and its record no longer journalled
    assert kinds == ["inserted", "journal", "journal"]
    assert any("journal entries 3 missing" in f.detail for f in verify_chain(db).findings)


def test_a_removed_coefficient_row_or_a_stray_one_is_found(db):
    with Store(db) as store:
        ids = store.add_many(records(2))
    _sql(db, f"DELETE FROM coefficients WHERE calibration_id = {ids[0]} AND name = 'K_O'")
    stray = []
    if "://" not in db:  # SQLite clients do not enforce foreign keys unless asked
        _sql(db, "INSERT INTO coefficients (calibration_id, name, unit, estimate) "
             "VALUES (99999, 'K_X', 'V', 1.0)")
        stray = [("inserted", None)]
    report = verify_chain(db)
    assert [(f.kind, f.id) for f in report.findings] == [("changed", ids[0]), *stray]


def test_an_older_store_is_journalled_when_migrated(db):
    with Store(db) as store:
        store.add_many(records(3))
        store.add(make_record(serial="C", date="2026-03-01T08:00:00+08:00"))
    # As schema 4 left a store: no journal.
    _sql(db, "DROP TABLE journal", "UPDATE schema_info SET version = 4")
    with Store(db, readonly=True) as store:
        report = store.verify()
        assert store.schema_version == 4
        assert len(store.calibrations()) == 4  # read as it is
    assert not report.chained
    assert not report.verified
    assert "no journal yet" in report.status_line()
    with Store(db) as store:  # writing migrates: existing records hashed as they are
        assert store.schema_version == SCHEMA_VERSION == 5
        store.add(make_record(serial="D"))
        report = store.verify()
    assert report.verified
    assert report.records == 5
    journal = _journal(db)
    assert [e["stored_at"] is None for e in journal] == [True] * 4 + [False]


def test_content_hash_covers_every_field_and_its_type():
    cal = {"uid": "u", "serial": "S", "method": "m", "date": "d", "software": "s",
           "simulated": 0, "record_json": "{}", "id": 7}
    coef = [{"name": "K", "unit": "V", "estimate": 1.0, "std": None}]
    base = content_hash(cal, coef)
    assert content_hash({**cal, "simulated": False, "id": 8}, coef) == base  # 0 is false
    assert content_hash(cal, [{**coef[0], "estimate_re": None}]) == base  # NULL left out
    for change in ({"serial": "T"}, {"simulated": 1}, {"record_json": "{ }"}):
        assert content_hash({**cal, **change}, coef) != base
    for change in ({"estimate": 1}, {"estimate": "1.0"}, {"std": 0.0}, {"unit": "V/g"}):
        assert content_hash(cal, [{**coef[0], **change}]) != base
    assert content_hash(cal, coef + coef) != base


def test_corrections_supersede_and_never_edit(db):
    with Store(db) as store:
        ids = store.add_many(records(3))
        before = store.record(ids[0]).to_json()
        fixed = make_record(shift=5e-7, date="2026-01-01T00:00:00+00:00",
                            operator="B. Checker")
        new = store.supersede(ids[0], fixed, who="A. Tester", why="wrong reference voltage")
        assert store.record(ids[0]).to_json() == before  # the old record is kept as it was
        marks = {r["id"]: r["superseded_by"] for r in store.calibrations()}
        assert marks == {ids[0]: new, ids[1]: None, ids[2]: None, new: None}
        history = store.history("SN-1")
        assert {r["id"]: r["superseded_by"] for r in history}[ids[0]] == new
        assert ids[0] not in {r["id"] for r in store.history("SN-1", current_only=True)}
        assert {s.n for s in store.stats("SN-1")} == {3}  # the correction counts, not both
        with pytest.raises(AccelcalError, match=f"already superseded by record {new}"):
            store.supersede(ids[0], make_record(shift=9e-7), who="A", why="again")
        with pytest.raises(AccelcalError, match="no record with id 999"):
            store.supersede(999, make_record(shift=9e-7), who="A", why="typo")
        with pytest.raises(AccelcalError, match="who is blank"):
            store.supersede(ids[1], make_record(shift=9e-7), who="  ", why="x")
        report = store.verify()
    assert report.verified
    assert report.superseded == 1
    assert report.records == 4
    entry = _journal(db)[-1]
    assert (entry["supersedes"], entry["who"], entry["why"]) == (
        ids[0], "A. Tester", "wrong reference voltage")
    _sql(db, "UPDATE journal SET why = 'no reason' WHERE seq = 4")  # the why is chained too
    assert [f.kind for f in verify_chain(db).findings] == ["journal"]


_WRITER = textwrap.dedent(
    """
    import sys
    sys.path.insert(0, {tests!r})
    from helpers.records import make_record
    from accelcal.store import Store
    store = Store({db!r})
    for i in range({n}):
        store.add(make_record(serial="W{w}", date=f"2026-01-01T00:00:{{i:02d}}+00:00"))
    """
)


@pytest.mark.faults
def test_concurrent_writers_chain_every_record(db):
    Store(db).close()
    writers, per_writer = 4, 10
    procs = [subprocess.Popen([sys.executable, "-c", _WRITER.format(
        tests=str(TESTS), db=db, n=per_writer, w=w)]) for w in range(writers)]
    assert [p.wait(timeout=120) for p in procs] == [0] * writers
    report = verify_chain(db)
    assert report.verified, [f.line() for f in report.findings]
    assert report.records == writers * per_writer
    assert [e["seq"] for e in _journal(db)] == list(range(1, writers * per_writer + 1))


_BATCHES = textwrap.dedent(
    """
    import sys
    sys.path.insert(0, {tests!r})
    from helpers.records import records
    from accelcal.store import Store
    with Store({db!r}) as store:
        for k in range(1000):
            store.add_many(records(20, serial="K", start=20 * k))
            print(k, flush=True)
    """
)


@pytest.mark.faults
def test_a_writer_killed_mid_batch_leaves_a_chain_that_verifies(db):
    Store(db).close()
    proc = subprocess.Popen([sys.executable, "-c", _BATCHES.format(tests=str(TESTS), db=db)],
                            stdout=subprocess.PIPE, text=True)
    for _ in range(3):  # killed after a few batches, most likely inside the next one
        assert proc.stdout.readline(), "the writer stopped early"
    proc.kill()
    proc.wait(timeout=60)
    proc.stdout.close()
    report = verify_chain(db)
    assert report.verified, [f.line() for f in report.findings]
    assert report.records >= 60
    assert report.records % 20 == 0  # whole batches only
    with Store(db) as store:  # the store takes records again, chained after the survivors
        store.add(make_record(serial="AFTER"))
        assert store.verify().verified
