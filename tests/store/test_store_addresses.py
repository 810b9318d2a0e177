"""Store addresses taken literally, foreign SQLite files left alone, write-ahead logs read."""

import hashlib
import os
import shutil
import sqlite3
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from accelcal import AccelcalError
from accelcal.store import Store
from accelcal.store import location as loc
from helpers.cli import assert_one_line_error, run
from helpers.records import make_record, records


@pytest.mark.parametrize("name", ["st%41ore.sqlite", "st?ore.sqlite", "st#o%2Fre&x=1.sqlite"])
def test_a_path_is_taken_literally(capsys, tmp_path, monkeypatch, name):
    monkeypatch.chdir(tmp_path)
    rec = tmp_path / "r.json"
    make_record().save(rec)
    code, _, err = run(capsys, "records", "add", rec, "--db", name)
    assert code == 0, err
    assert sorted(p.name for p in tmp_path.iterdir() if "sqlite" in p.name) == [name]
    code, out, _ = run(capsys, "records", "list", "--db", name, "--format", "csv")
    assert code == 0
    assert out.count("SN-1") == 1  # the record added is the one listed
    monkeypatch.setenv("ACCELCAL_DB", name)
    with Store(readonly=True) as store:
        assert len(store.calibrations()) == 1


@pytest.mark.parametrize("value", [" ", "\t\n"])
def test_a_blank_address_is_refused(capsys, tmp_path, monkeypatch, value):
    monkeypatch.chdir(tmp_path)
    rec = tmp_path / "r.json"
    make_record().save(rec)
    code, _, err = run(capsys, "records", "add", rec, "--db", value)
    assert_one_line_error(code, err, "is blank")
    monkeypatch.setenv("ACCELCAL_DB", value)
    code, _, err = run(capsys, "records", "add", rec)
    assert_one_line_error(code, err, "($ACCELCAL_DB)", "is blank")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json"]


def test_a_tilde_is_the_home_directory(capsys, tmp_path, monkeypatch):
    home, work = tmp_path / "home", tmp_path / "work"
    home.mkdir()
    work.mkdir()
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.chdir(work)
    rec = tmp_path / "r.json"
    make_record().save(rec)
    monkeypatch.setenv("ACCELCAL_DB", "~")
    code, _, err = run(capsys, "records", "add", rec)
    assert_one_line_error(code, err, f"{home} is a directory")
    code, _, err = run(capsys, "records", "add", rec, "--db", "~/s.sqlite")
    assert code == 0, err
    assert (home / "s.sqlite").is_file()
    assert list(work.iterdir()) == []


@pytest.mark.parametrize("value", ["file:x.db", "sqlite:x.db", "FILE:x.db?mode=ro",
                                   "postgresql:db"])
def test_a_scheme_without_slashes_is_refused(capsys, tmp_path, monkeypatch, value):
    monkeypatch.chdir(tmp_path)
    rec = tmp_path / "r.json"
    make_record().save(rec)
    for args, env in (([], value), (["--db", value], None)):
        if env is not None:
            monkeypatch.setenv("ACCELCAL_DB", env)
        code, _, err = run(capsys, "records", "add", rec, *args)
        assert_one_line_error(code, err, "neither a path nor a URL", "sqlite:///records.sqlite")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json"]


def test_an_sqlite_url_still_works_and_a_colon_in_a_name_is_a_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with Store(f"sqlite:///{tmp_path / 'u.sqlite'}") as store:
        store.add(make_record())
    with Store("lab:2026.sqlite") as store:  # not a scheme: a file name with a colon
        store.add(make_record())
    assert sorted(p.name for p in tmp_path.iterdir() if p.suffix == ".sqlite") == [
        "lab:2026.sqlite", "u.sqlite"]


def test_a_symlink_loop_is_one_line(capsys, tmp_path):
    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(tmp_path / "a")
    for command in (["list"], ["add", str(tmp_path / "r.json")]):
        make_record().save(tmp_path / "r.json")
        code, _, err = run(capsys, "records", *command, "--db", tmp_path / "a")
        assert_one_line_error(code, err, "a loop of symbolic links")


def _foreign(path: Path) -> str:
    conn = sqlite3.connect(path)
    conn.execute("CREATE TABLE notes (id INTEGER PRIMARY KEY, text TEXT)")
    conn.execute("INSERT INTO notes (text) VALUES ('keep me')")
    conn.commit()
    conn.close()
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_another_applications_database_is_never_modified(capsys, tmp_path):
    db = tmp_path / "other.sqlite"
    digest = _foreign(db)
    rec = tmp_path / "r.json"
    make_record().save(rec)
    for command in (["add", rec], ["list"], ["history", "SN-1"], ["verify"]):
        code, _, err = run(capsys, "records", *command, "--db", db)
        assert_one_line_error(code, err, "not an accelcal records store (its tables: notes)")
    with pytest.raises(AccelcalError, match="never modifies it"):
        Store(db)
    assert hashlib.sha256(db.read_bytes()).hexdigest() == digest
    assert sorted(p.name for p in tmp_path.iterdir()) == ["other.sqlite", "r.json"]


def test_an_empty_file_becomes_a_store(tmp_path):
    db = tmp_path / "empty.sqlite"
    db.touch()
    with Store(db, readonly=True) as store:
        assert store.calibrations() == []
    with Store(db) as store:
        store.add(make_record())
        assert store.verify().verified


def _wal_copy(tmp_path: Path, n: int) -> tuple[Path, Path]:
    """A store of ``n`` committed records, copied with its write-ahead log and no -shm."""
    src = tmp_path / "src"
    src.mkdir()
    db = src / "s.sqlite"
    Store(db).add(make_record())
    hold = sqlite3.connect(db)  # keeps the log from being checkpointed away
    hold.execute("SELECT count(*) FROM calibrations").fetchone()
    with Store(db) as store:
        store.add_many(records(n - 1, start=1))
    copy = tmp_path / "copy"
    copy.mkdir()
    for name in ("s.sqlite", "s.sqlite-wal"):
        shutil.copyfile(src / name, copy / name)
    hold.close()
    assert (copy / "s.sqlite-wal").stat().st_size > 0
    return db, copy / "s.sqlite"


_WAL_READER = textwrap.dedent(
    """
    import os, sys
    from accelcal.cli import main
    import accelcal.cli.app, accelcal.cli.records, accelcal.store

    def call(*args):
        try:
            main(list(args))
        except SystemExit as exc:
            return exc.code

    call("records", "list", "--db", sys.argv[2], "--format", "json")  # load every module
    call("records", "verify", "--db", sys.argv[2])
    if os.getuid() == 0:
        os.setgid(65534)
        os.setuid(65534)
    print("codes", [call("records", "list", "--db", sys.argv[1], "--format", "csv"),
                    call("records", "verify", "--db", sys.argv[1])], file=sys.stderr)
    """
)


@pytest.mark.faults
@pytest.mark.skipif(sys.platform == "win32", reason="POSIX permissions")
def test_a_read_only_copy_with_a_log_and_no_shm_lists_every_record(tmp_path):
    # Read-only media holding a store and its -wal but no -shm: SQLite cannot read the
    # log read-only there; with immutable=1 it would list 1 of the 6 committed records.
    media = Path(os.environ.get("TMPDIR", "/tmp")) / f"accelcal-wal-{os.getpid()}"
    media.mkdir()
    try:
        warm, copy = _wal_copy(tmp_path, 6)
        for name in ("s.sqlite", "s.sqlite-wal"):
            shutil.copyfile(copy.parent / name, media / name)
            (media / name).chmod(0o444)
        media.chmod(0o555)
        before = set(Path(os.environ.get("TMPDIR", "/tmp")).glob("accelcal-store-*"))
        proc = subprocess.run([sys.executable, "-c", _WAL_READER, str(media / "s.sqlite"),
                               str(warm)], capture_output=True, text=True, timeout=120,
                              check=False)
        assert "codes [0, 0]" in proc.stderr, proc.stderr[-2000:]
        listed = proc.stdout.split("chain verified")[0]
        assert listed.count("SN-1") == 6
        assert "chain verified: yes (6 records)" in proc.stdout
        assert sorted(p.name for p in media.iterdir()) == ["s.sqlite", "s.sqlite-wal"]
        after = set(Path(os.environ.get("TMPDIR", "/tmp")).glob("accelcal-store-*"))
        assert after == before  # the temporary copy is removed
    finally:
        media.chmod(0o755)
        shutil.rmtree(media)


def test_a_log_that_cannot_be_copied_is_refused_not_hidden(tmp_path, monkeypatch):
    _, copy = _wal_copy(tmp_path, 3)

    def unopenable(_path):
        raise sqlite3.OperationalError("unable to open database file")

    def full(*_args):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(loc.ReadonlyFile, "_probe", staticmethod(unopenable))
    monkeypatch.setattr(loc.shutil, "copyfile", full)
    with pytest.raises(AccelcalError, match=r"write-ahead log s\.sqlite-wal holds transactions"
                       ) as exc:
        Store(copy, readonly=True)
    assert "No space left on device" in str(exc.value)
    monkeypatch.undo()
    monkeypatch.setattr(loc.ReadonlyFile, "_probe", staticmethod(unopenable))
    with Store(copy, readonly=True) as store:  # the log copied and read: every record
        assert len(store.calibrations()) == 3
        assert store._file.copy is not None
        where = Path(store._file.copy)
    assert not where.exists()
