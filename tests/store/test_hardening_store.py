"""Hardening of the records store and the command line around it (issue 11)."""

import dataclasses
import os
import sqlite3
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from accelcal import AccelcalError
from accelcal.montecarlo import run as run_study
from accelcal.store import Store
from helpers.cli import assert_one_line_error, run
from helpers.records import make_record


def test_a_file_that_is_not_a_database_exits_2(capsys, tmp_path):
    junk = tmp_path / "notes.txt"
    junk.write_text("not a database at all\n" * 50)
    for command in (["records", "list"], ["records", "history", "SN-1"],
                    ["records", "stats", "SN-1"]):
        code, _, err = run(capsys, *command, "--db", junk)
        assert_one_line_error(code, err, "file is not a database", str(junk))
    rec = tmp_path / "r.json"
    make_record().save(rec)
    code, _, err = run(capsys, "records", "add", rec, "--db", junk)
    assert_one_line_error(code, err, "file is not a database")
    assert junk.read_text() == "not a database at all\n" * 50


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="no /proc")
@pytest.mark.parametrize("db", ["/proc/accelcal.sqlite", "/proc/accelcal-nope/s.sqlite"])
def test_records_add_to_an_unwritable_location_exits_2(capsys, tmp_path, db):
    rec = tmp_path / "r.json"
    make_record().save(rec)
    code, _, err = run(capsys, "records", "add", rec, "--db", db)
    assert_one_line_error(code, err, db.rsplit("/", 1)[0])
    assert not Path(db).exists()


def test_a_store_directory_is_refused(capsys, tmp_path):
    rec = tmp_path / "r.json"
    make_record().save(rec)
    code, _, err = run(capsys, "records", "add", rec, "--db", tmp_path)
    assert_one_line_error(code, err, "is a directory")


def _full_disk(monkeypatch):
    """Make every new SQLite connection see a full disk (one page and no more)."""
    import accelcal.store

    connect = accelcal.store._sqlite_on_connect

    def full(dbapi_conn, record):
        connect(dbapi_conn, record)
        dbapi_conn.execute("PRAGMA max_page_count=1")

    monkeypatch.setattr(accelcal.store, "_sqlite_on_connect", full)


def test_a_store_that_fails_to_initialise_leaves_no_file(capsys, tmp_path, monkeypatch):
    db = tmp_path / "new.sqlite"
    rec = tmp_path / "r.json"
    make_record().save(rec)
    _full_disk(monkeypatch)
    code, _, err = run(capsys, "records", "add", rec, "--db", db)
    assert_one_line_error(code, err, "database or disk is full")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json"]


def test_a_failing_existing_store_is_kept(tmp_path, monkeypatch):
    db = tmp_path / "old.sqlite"
    Store(db).add(make_record())
    _full_disk(monkeypatch)
    big = dataclasses.replace(make_record(serial="SN-2"), notes=("x" * 100_000,))
    with pytest.raises(AccelcalError, match=r"cannot write to the records store .*disk is full"):
        Store(db).add(big)
    monkeypatch.undo()
    assert [r["serial"] for r in Store(db, readonly=True).calibrations()] == ["SN-1"]


def test_readonly_store_opens_sqlite_read_only(tmp_path):
    db = tmp_path / "s.sqlite"
    Store(db).add(make_record())
    store = Store(db, readonly=True)
    with store.engine.connect() as conn:
        raw = conn.connection.dbapi_connection
        with pytest.raises(sqlite3.OperationalError, match="readonly"):
            raw.execute("CREATE TABLE x (y)")
    assert [r["serial"] for r in store.calibrations()] == ["SN-1"]
    with pytest.raises(AccelcalError, match="read-only"):
        store.add(make_record(serial="SN-2"))


def test_reading_a_missing_store_creates_nothing(capsys, tmp_path):
    db = tmp_path / "sub" / "s.sqlite"
    code, out, _ = run(capsys, "records", "list", "--db", db)
    assert code == 0
    assert "no calibration" in out
    code, _, err = run(capsys, "records", "history", "SN-1", "--db", db)
    assert_one_line_error(code, err, "no calibration of serial 'SN-1'")
    assert not (tmp_path / "sub").exists()
    assert Store(db, readonly=True).schema_version == 0


_READ_ONLY_READER = textwrap.dedent(
    """
    import os, sys
    from accelcal.cli import main
    import accelcal.cli.app, accelcal.cli.records, accelcal.store

    def call(*args):
        try:
            main(list(args))
        except SystemExit as exc:
            return exc.code

    # Load every lazily imported module first: after the switch to another user the
    # interpreter's own library may be unreadable.
    warm = sys.argv[2]
    for command in ("list", "history", "stats"):
        call("records", command, *(["SN-1"] if command != "list" else []), "--db", warm,
             "--format", "json")
    if os.getuid() == 0:
        os.setgid(65534)
        os.setuid(65534)
    codes = [call("records", command, *(["SN-1"] if command != "list" else []), "--db",
                  sys.argv[1], "--format", "csv") for command in ("list", "history", "stats")]
    print("codes", codes, file=sys.stderr)
    """
)


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX permissions")
def test_a_store_on_read_only_media_can_be_read(tmp_path):
    # A read-only directory holding a read-only store in write-ahead-log mode: SQLite can
    # make neither a journal nor its shared-memory file there. Run as another user when
    # root (permission bits do not stop root).
    media = Path(os.environ.get("TMPDIR", "/tmp")) / f"accelcal-ro-{os.getpid()}"
    media.mkdir()
    try:
        db, warm = media / "store.sqlite", tmp_path / "warm.sqlite"
        for path in (db, warm):
            with Store(path) as store:
                store.add(make_record())
                store.add(make_record(date="2026-02-01T00:00:00+00:00", shift=1e-6))
        before = sorted(p.name for p in media.iterdir())
        db.chmod(0o444)
        media.chmod(0o555)
        proc = subprocess.run([sys.executable, "-c", _READ_ONLY_READER, str(db), str(warm)],
                              capture_output=True, text=True, timeout=120, check=False)
        assert "codes [0, 0, 0]" in proc.stderr, proc.stderr[-2000:]
        assert proc.stdout.count("SN-1") >= 2
        assert sorted(p.name for p in media.iterdir()) == before  # no journal, no -shm
    finally:
        media.chmod(0o755)
        for path in media.iterdir():
            path.unlink()
        media.rmdir()


def test_over_long_serials_give_one_line(capsys, tmp_path):
    db = tmp_path / "s.sqlite"
    Store(db).add(make_record())
    serial = "S" * 1_000_000
    code, _, err = run(capsys, "records", "history", serial, "--db", db, "--plot", tmp_path)
    assert_one_line_error(code, err, "serial number 'SSS", "longer than 200 characters")
    code, _, err = run(capsys, "records", "list", "--serial", "a\nb", "--db", db)
    assert_one_line_error(code, err, "control character")
    assert list(tmp_path.glob("history-*")) == []


def test_history_plot_names_files_safely(capsys, tmp_path):
    db = tmp_path / "s.sqlite"
    Store(db).add(make_record(serial="SN 1:2*?"))
    code, _, _ = run(capsys, "records", "history", "SN 1:2*?", "--db", db, "--plot",
                     tmp_path / "fig")
    assert code == 0
    assert sorted(p.name for p in (tmp_path / "fig").iterdir()) == [
        "history-SN_1_2__.png", "history-SN_1_2__.svg"]


@pytest.mark.parametrize("address", ["notaurl", "http://host:8786", "tcp://host:99999", "host:"])
def test_scheduler_addresses_are_checked_before_any_work(address):
    calls = []

    def simulate(rng, n):
        calls.append(n)
        return rng.normal(size=(n, 1))

    with pytest.raises(AccelcalError) as info:
        run_study(simulate, 10, names=["x"], seed=1, scheduler=address)
    assert info.value.parameter == "scheduler"
    assert info.value.message_for().startswith("--scheduler: ")
    assert "tcp://host:port" in str(info.value)
    assert calls == []
