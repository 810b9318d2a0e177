"""Rows edited outside accelcal: every read names the bad row, or skips and counts it.

SQLite always; PostgreSQL when ACCELCAL_TEST_POSTGRES_URL names a server (where its
column types forbid a value, e.g. text in a float column, NaN stands in for it).
"""

import math

import pytest
import sqlalchemy as sa

from accelcal import AccelcalError
from accelcal.store import Store
from accelcal.store.checks import date_problem
from helpers.cli import assert_one_line_error, run
from helpers.records import make_record, records


def _sql(db, *statements):
    engine = sa.create_engine(db if "://" in db else f"sqlite:///{db}")
    with engine.begin() as conn:
        for statement in statements:
            conn.execute(sa.text(statement))
    engine.dispose()


def _store(db, n=3):
    with Store(db) as store:
        return store.add_many(records(n))


@pytest.mark.parametrize("readonly", [True, False])
def test_two_schema_info_rows_are_refused_on_every_open(db, readonly):
    _store(db)
    _sql(db, "INSERT INTO schema_info (version) VALUES (5)")
    with pytest.raises(AccelcalError, match="table schema_info has 2 rows, not 1"):
        Store(db, readonly=readonly)


def test_a_version_that_is_not_an_integer_is_named(tmp_path):
    db = str(tmp_path / "s.sqlite")
    _store(db)
    _sql(db, "UPDATE schema_info SET version = 'abc'")
    for readonly in (True, False):
        with pytest.raises(AccelcalError, match="table schema_info, field version: 'abc'"):
            Store(db, readonly=readonly)


def test_a_bad_date_is_named_or_skipped_by_every_read(db):
    ids = _store(db)
    _sql(db, f"UPDATE calibrations SET date = 'not-a-date' WHERE id = {ids[1]}")
    with Store(db, readonly=True) as store:
        for read in (store.calibrations, lambda: store.history("SN-1"),
                     lambda: store.stats("SN-1")):
            with pytest.raises(AccelcalError, match=(
                    f"table calibrations, id {ids[1]}, field date: 'not-a-date' is not an "
                    "ISO 8601 date")):
                read()
    with Store(db, readonly=True, skip_bad=True) as store:
        assert [r["id"] for r in store.calibrations()] == [ids[0], ids[2]]
        assert {r["id"] for r in store.history("SN-1")} == {ids[0], ids[2]}
        assert {s.n for s in store.stats("SN-1")} == {2}
        assert store.skipped == 1  # one row, counted once however often it is read


def test_a_bad_estimate_is_named_or_skipped(db):
    ids = _store(db)
    bad = "'abc'" if "://" not in db else "'NaN'"
    _sql(db, f"UPDATE coefficients SET estimate = {bad} WHERE calibration_id = {ids[2]} "
         "AND name = 'K_I'")
    with Store(db, readonly=True) as store:
        assert len(store.calibrations()) == 3  # the list does not read coefficients
        with pytest.raises(AccelcalError, match=r"table coefficients, id \d+, field estimate"):
            store.history("SN-1")
        with pytest.raises(AccelcalError, match="is not a finite number"):
            store.stats("SN-1")
    with Store(db, readonly=True, skip_bad=True) as store:
        rows = store.history("SN-1")
        assert len(rows) == 8
        assert all(math.isfinite(r["estimate"]) for r in rows)
        stats = {s.name: s.n for s in store.stats("SN-1")}
        assert stats == {"K_F": 3, "K_I": 2, "K_O": 3}
        assert store.skipped == 1


def test_other_bad_fields_are_named(tmp_path):
    db = str(tmp_path / "s.sqlite")
    ids = _store(db)
    cases = [
        (f"UPDATE calibrations SET serial = '  ' WHERE id = {ids[0]}",
         "field serial: it is blank"),
        (f"UPDATE calibrations SET software = x'00ff' WHERE id = {ids[0]}",
         "field software: .* is not text"),
        (f"UPDATE calibrations SET simulated = 7 WHERE id = {ids[0]}", "field simulated: 7"),
        (f"UPDATE calibrations SET date = '0001-01-01T00:00:00+00:00' WHERE id = {ids[0]}",
         "is outside 1900-01-01 .. 2199-12-31"),
        (f"UPDATE calibrations SET date = '9999-12-31T23:00:00-05:00' WHERE id = {ids[0]}",
         "is outside 1900-01-01 .. 2199-12-31"),
    ]
    for statement, message in cases:
        _sql(db, "DROP TABLE IF EXISTS keep", "CREATE TABLE keep AS SELECT * FROM calibrations",
             statement)
        with Store(db, readonly=True) as store, pytest.raises(AccelcalError, match=message):
            store.calibrations()
        _sql(db, "DELETE FROM calibrations", "INSERT INTO calibrations SELECT * FROM keep")
    _sql(db, "DROP TABLE keep", "UPDATE coefficients SET std = -1 WHERE id = 1")
    with Store(db, readonly=True) as store, pytest.raises(AccelcalError,
                                                          match="id 1, field std: -1"):
        store.history("SN-1")


@pytest.mark.parametrize("date", ["0001-01-01T00:00:00+00:00", "9999-12-31T23:00:00-05:00",
                                  "0001-01-01T00:00:00+05:00", "1899-12-31T23:59:59+00:00"])
def test_dates_outside_the_range_are_refused_on_entry(db, date):
    with Store(db) as store:
        with pytest.raises(AccelcalError, match=r"outside 1900-01-01 \.\. 2199-12-31"):
            store.add(make_record(date=date))
        with pytest.raises(AccelcalError, match="none of the 2 records was added"):
            store.add_many([make_record(serial="OK"), make_record(date=date)])
        assert store.calibrations() == []


def test_date_problem_accepts_the_range_and_offsets():
    assert date_problem("1900-01-01T00:00:00+00:00") is None
    assert date_problem("2199-12-31T23:59:59.999999+00:00") is None
    assert date_problem("2200-01-01T01:00:00+02:00") is None  # 2199-12-31T23:00 UTC
    assert date_problem("2026-01-01") is None
    assert "outside" in date_problem("2200-01-01T00:00:00+00:00")
    assert "not a date" in date_problem(20260101)


def test_records_commands_name_the_bad_row_or_skip_it(capsys, tmp_path):
    db = str(tmp_path / "s.sqlite")
    ids = _store(db)
    _sql(db, f"UPDATE calibrations SET date = 'not-a-date' WHERE id = {ids[0]}",
         f"UPDATE coefficients SET estimate = 'abc' WHERE calibration_id = {ids[1]} "
         "AND name = 'K_F'")
    for command in (["list"], ["history", "SN-1"], ["stats", "SN-1"]):
        code, _, err = run(capsys, "records", *command, "--db", db)
        assert_one_line_error(code, err, "bad row: table ", "--skip-bad")
        code, out, err = run(capsys, "records", *command, "--db", db, "--skip-bad",
                             "--format", "json")
        assert code == 0, err
        assert err == ("skipped 1 bad row\n" if command == ["list"] else
                       "skipped 2 bad rows\n")
        assert "not-a-date" not in out


@pytest.mark.faults
def test_report_history_names_a_bad_row_or_skips_it(capsys, tmp_path):
    db = str(tmp_path / "s.sqlite")
    rec = tmp_path / "r.json"
    make_record(date="2026-05-01T00:00:00+00:00").save(rec)
    ids = _store(db)
    _sql(db, f"UPDATE calibrations SET date = '0001-01-01T00:00:00+00:00' WHERE id = {ids[0]}")
    out = tmp_path / "r.html"
    code, _, err = run(capsys, "report", rec, "--out", out, "--history", "--db", db)
    assert_one_line_error(code, err, f"table calibrations, id {ids[0]}, field date")
    assert not out.exists()
    code, stdout, err = run(capsys, "report", rec, "--out", out, "--history", "--db", db,
                            "--skip-bad")
    assert code == 0, err
    assert "skipped 1 bad row" in err
    assert "chain verified: no (3 records; 1 finding(s)" in stdout  # the edit is found too
    assert "chain verified: no" in out.read_text()
