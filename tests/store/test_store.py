"""Calibration records and the records store (SQLite always; PostgreSQL when a server is given)."""

import json
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from accelcal import AccelcalError, default_model
from accelcal.io.calibration_record import CalibrationRecord
from accelcal.store import SCHEMA_VERSION, Store
from helpers.paths import FIXTURES, TESTS
from helpers.records import make_record


def test_record_round_trip_and_expanded_uncertainty(tmp_path):
    data = tmp_path / "positions.csv"
    data.write_text("angle,u\n0,1\n")
    rec = make_record(input_files=[data], model=default_model(), operator="A. Tester")
    path = tmp_path / "rec.json"
    rec.save(path)
    back = CalibrationRecord.load(path)
    np.testing.assert_array_equal(back.estimates, rec.estimates)
    np.testing.assert_array_equal(back.covariance, rec.covariance)
    assert back.model == default_model()
    assert back.inputs["positions.csv"].startswith("sha256:")
    assert back.inputs == rec.inputs
    np.testing.assert_allclose(back.expanded, 2 * np.sqrt([1e-12, 4e-12, 9e-12]), rtol=1e-15)
    doc = json.loads(path.read_text())
    assert doc["coefficients"][1] == {
        "name": "K_I", "unit": "V/g", "estimate": 1.2993698, "std": 2e-6, "expanded": 4e-6,
    }


def test_version_1_fixture_still_reads():
    rec = CalibrationRecord.load(FIXTURES / "calibration_record_v1.json")
    assert rec.serial == "SN-0042"
    assert rec.names == ("K_F", "K_I", "K_O", "K_IO", "K_II")
    assert rec.std[1] == pytest.approx(8.0e-7, rel=1e-12)
    assert np.isnan(rec.covariance[4, 4])  # null in the file: not identified


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"extra": 1}, "unknown key\\(s\\) 'extra'"),
        ({"format_version": 3}, "format_version 3 is not supported"),
        ({"kind": "x"}, "kind is 'x'"),
        ({"serial": ""}, "serial must be a non-empty string"),
        ({"date": "yesterday"}, "date 'yesterday' is not ISO 8601"),
        ({"coefficients": []}, "coefficients must be a non-empty list"),
        ({"covariance": [[1.0]]}, "need estimates"),
    ],
)
def test_bad_records_are_refused(tmp_path, change, message):
    doc = json.loads((FIXTURES / "calibration_record_v1.json").read_text())
    doc.update(change)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(AccelcalError, match=message) as info:
        CalibrationRecord.load(path)
    assert str(path) in str(info.value)


def test_history_columns_are_the_history_by_column(db):
    # The columnar form (records history --format csv) holds the same values in the same
    # order as the rows, NaN where a coefficient was not identified.
    store = Store(db)
    store.add(CalibrationRecord.load(FIXTURES / "calibration_record_v1.json"))
    for month in (1, 2):
        store.add(make_record(serial="SN-0042", date=f"2026-{month:02d}-01T00:00:00+00:00"))
    rows = store.history("SN-0042")
    columns = store.history_columns("SN-0042")
    assert list(columns) == list(rows[0])
    for name, values in columns.items():
        assert len(values) == len(rows) == 5 + 2 * 3
        expected = [r[name] for r in rows]
        if name == "std":
            assert np.array_equal(values, expected, equal_nan=True)
            assert np.isnan(values).sum() == 1
        else:
            assert values == expected, name
    only = store.history_columns("SN-0042", "dividing-head/joint")
    assert set(only["method"]) == {"dividing-head/joint"}
    with pytest.raises(AccelcalError, match="no calibration of serial 'SN-9'"):
        store.history_columns("SN-9")


def test_store_add_list_history_stats(db):
    store = Store(db)
    assert store.schema_version == SCHEMA_VERSION
    for month, shift in zip((1, 2, 3, 4), (0.0, 1e-6, 2e-6, 3e-6), strict=True):
        store.add(make_record(date=f"2026-{month:02d}-01T00:00:00+00:00", shift=shift))
    store.add(make_record(serial="SN-2"))
    assert [r["serial"] for r in store.calibrations()].count("SN-1") == 4
    assert len(store.calibrations("SN-2")) == 1
    hist = store.history("SN-1")
    assert len(hist) == 12
    k_f = [r["estimate"] for r in hist if r["name"] == "K_F"]
    assert k_f == pytest.approx([-8.3e-4 + s for s in (0.0, 1e-6, 2e-6, 3e-6)], rel=1e-14)
    stats = {s.name: s for s in store.stats("SN-1")}
    # Four equally spaced shifts of 1e-6: sample SD = 1e-6 * sqrt(5/3).
    assert stats["K_F"].repeatability == pytest.approx(1e-6 * np.sqrt(5 / 3), rel=1e-9)
    assert stats["K_F"].mean_std == pytest.approx(1e-6, rel=1e-12)
    # One step per month: 1e-6 per (days in the month) -> about 1.2e-5 per year.
    days = np.array([0, 31, 59, 90])
    slope = np.polyfit(days / 365.25, [0, 1e-6, 2e-6, 3e-6], 1)[0]
    assert stats["K_F"].drift_per_year == pytest.approx(slope, rel=1e-9)
    assert np.isfinite(stats["K_F"].drift_std)
    rec = store.record(store.calibrations("SN-2")[0]["id"])
    assert rec.serial == "SN-2"


def test_methods_are_never_pooled(db):
    # Two joint calibrations 1e-6 apart and two single-sensor ones offset by
    # 1e-4 (e.g. a first-harmonic alias): pooled, the repeatability of K_F
    # would be ~6e-5; per method it is the run-to-run spread of each.
    store = Store(db)
    for month, shift in ((1, 0.0), (2, 1e-6)):
        store.add(make_record(date=f"2026-{month:02d}-01T00:00:00+00:00", shift=shift))
    for month, shift in ((3, 1e-4), (4, 1e-4 + 2e-6)):
        store.add(make_record(date=f"2026-{month:02d}-01T00:00:00+00:00", shift=shift,
                              method="dividing-head/single"))
    stats = {(s.method, s.name): s for s in store.stats("SN-1")}
    assert len(stats) == 6
    assert stats[("dividing-head/joint", "K_F")].repeatability == pytest.approx(
        1e-6 / np.sqrt(2), rel=1e-6)
    assert stats[("dividing-head/single", "K_F")].repeatability == pytest.approx(
        2e-6 / np.sqrt(2), rel=1e-6)
    # two calibrations: no drift (a slope through two points has no uncertainty)
    assert np.isnan(stats[("dividing-head/joint", "K_F")].drift_per_year)
    only = store.stats("SN-1", "dividing-head/single")
    assert {s.method for s in only} == {"dividing-head/single"}
    assert len(only) == 3
    hist = store.history("SN-1", "dividing-head/joint")
    assert len(hist) == 6
    assert {r["method"] for r in hist} == {"dividing-head/joint"}
    with pytest.raises(AccelcalError, match="no calibration of serial 'SN-1' by method 'vre'"):
        store.history("SN-1", "vre")


def test_store_refuses_duplicates_and_unknown_serials(db):
    store = Store(db)
    store.add(make_record())
    with pytest.raises(AccelcalError, match="already in the store"):
        store.add(make_record())
    with pytest.raises(AccelcalError, match="no calibration of serial 'SN-9'"):
        store.history("SN-9")
    assert len(store.calibrations()) == 1


def test_dates_sort_by_time_across_offsets(db):
    store = Store(db)
    store.add(make_record(date="2026-01-01T10:00:00+08:00", shift=1e-6))  # 02:00 UTC
    store.add(make_record(date="2026-01-01T03:00:00+00:00", shift=2e-6))
    assert [r["estimate"] for r in store.history("SN-1") if r["name"] == "K_F"] == pytest.approx(
        [-8.3e-4 + 1e-6, -8.3e-4 + 2e-6], rel=1e-14
    )


def test_newer_schema_is_refused(db):
    store = Store(db)
    import sqlalchemy as sa

    with store.engine.begin() as conn:
        conn.execute(sa.text("UPDATE schema_info SET version = 99"))
    with pytest.raises(AccelcalError, match="schema version 99, newer than this accelcal"):
        Store(db)


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


def test_concurrent_writers_lose_nothing(db):
    Store(db)  # create the schema first
    writers, per_writer = 4, 15
    procs = [
        subprocess.Popen([sys.executable, "-c", _WRITER.format(
            tests=str(TESTS), db=db, n=per_writer, w=w)])
        for w in range(writers)
    ]
    assert [p.wait(timeout=120) for p in procs] == [0] * writers
    store = Store(db)
    assert len(store.calibrations()) == writers * per_writer
    for w in range(writers):
        assert len(store.history(f"W{w}")) == 3 * per_writer


_KILLED = textwrap.dedent(
    """
    import os, signal, sys
    import sqlalchemy as sa
    sys.path.insert(0, {tests!r})
    from accelcal.store import Store
    store = Store({db!r})
    cal = store._tables["calibrations"]
    with store.engine.begin() as conn:
        conn.execute(sa.insert(cal).values(uid="x" * 64, serial="KILLED", method="m",
                                           date="2026-01-01", software="s", record_json="{{}}"))
        os.kill(os.getpid(), signal.SIGKILL)
    """
)


def test_killed_writer_leaves_store_consistent(db):
    store = Store(db)
    store.add(make_record())
    proc = subprocess.run([sys.executable, "-c", _KILLED.format(
        tests=str(TESTS), db=db)], check=False)
    assert proc.returncode == -9
    store = Store(db)
    assert [r["serial"] for r in store.calibrations()] == ["SN-1"]
    store.add(make_record(serial="SN-after"))
    assert len(store.calibrations()) == 2


def test_store_addresses_paths_urls_and_the_environment(tmp_path, monkeypatch):
    monkeypatch.setenv("ACCELCAL_DB", str(tmp_path / "env.sqlite"))
    with Store() as store:  # a plain path in the environment is an SQLite file
        store.add(make_record())
    assert (tmp_path / "env.sqlite").exists()
    with pytest.raises(AccelcalError, match="neither a database URL nor a file path"):
        Store("postgresql+psycopg://user@host:notaport/db")
    with pytest.raises(AccelcalError, match="cannot use the store nosuchdialect://"):
        Store("nosuchdialect://x/y")
