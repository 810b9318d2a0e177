"""A full disk, a file-size limit and a read-only file system on the main write paths.

A tmpfs or a loop device of a few kilobytes needs privileges a test cannot
count on, so the failure is made where the atomic writer meets the system
(:mod:`accelcal.io.atomic`): the flush to disk (where a full disk or a
file-size limit is reported) or the rename into place (where a read-only
file system is) raises the ``OSError`` the kernel would. Every path: one
line naming the output, exit status 2, no traceback, nothing left behind,
no output under its final name.
"""

import errno
import os

import pytest

from accelcal.io import atomic
from helpers.cli import run_cli
from helpers.paths import EXAMPLES

pytestmark = pytest.mark.faults

FAILURES = {
    "ENOSPC": (errno.ENOSPC, "_flush_to_disk"),
    "EFBIG": (errno.EFBIG, "_flush_to_disk"),
    "EROFS": (errno.EROFS, "replace"),
}

WRITERS = {
    "csv": lambda d: ["triad", "simulate", "--seed", "1", "--dwell", "20", "--out", d / "o.csv"],
    "parquet": lambda d: ["noise", "simulate", "--rate", "100", "--duration", "10", "--N",
                          "1e-5", "--out", d / "o.parquet"],
    "json": lambda d: ["triad", "calibrate", EXAMPLES / "triad.csv", "--out", d / "o.json"],
    "html report": lambda d: ["report", EXAMPLES / "calibration_record.json", "--out",
                              d / "o.html"],
}


def _fail(monkeypatch, code: int, where: str):
    def raising(*args, **kwargs):
        raise OSError(code, os.strerror(code), str(args[0]))

    if where == "replace":
        real = os.replace

        def replace(src, dst, *args, **kwargs):
            if ".tmp" in str(src) or "accelcal-" in str(src):
                raising(src)
            return real(src, dst, *args, **kwargs)

        monkeypatch.setattr(atomic.os, "replace", replace)
    else:
        monkeypatch.setattr(atomic, where, raising)


@pytest.mark.parametrize("failure", list(FAILURES))
@pytest.mark.parametrize("writer", list(WRITERS))
def test_a_failed_write_is_one_line_and_leaves_nothing(writer, failure, monkeypatch, tmp_path,
                                                       capsys):
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    code_no, where = FAILURES[failure]
    _fail(monkeypatch, code_no, where)
    code, _, err = run_cli(WRITERS[writer](out_dir), capsys)
    lines = [line for line in err.splitlines()
             if line.strip() and not line.startswith(("note:", "accelcal: note:", "warning:"))]
    assert code == 2, err
    assert "Traceback" not in err
    assert len(lines) == 1, err
    assert lines[0].startswith("accelcal: error: ")
    assert "o." in lines[0]  # names the output
    assert sorted(p.name for p in out_dir.iterdir()) == []  # no temporary, no output


def test_certificate_on_a_full_disk_leaves_nothing(monkeypatch, tmp_path, capsys):
    from helpers.certificates import LAB, write_inputs

    (tmp_path / "in").mkdir()
    paths = write_inputs(tmp_path / "in")
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    _fail(monkeypatch, errno.ENOSPC, "_flush_to_disk")
    code, _, err = run_cli(["certificate", *paths, "--lab", LAB, "--out", out_dir / "c.html",
                            "--json", out_dir / "c.json", "--issued", "2026-11-26"], capsys)
    assert code == 2, err
    assert "Traceback" not in err
    assert err.strip().splitlines()[-1].startswith("accelcal: error: ")
    assert sorted(p.name for p in out_dir.iterdir()) == []


def test_store_add_under_a_file_size_limit_keeps_what_was_committed(tmp_path):
    """SQLite's own writes under RLIMIT_FSIZE (EFBIG, as a full disk would fail them): the
    add is one line and exit 2; the records committed before are all there, the chain holds."""
    from helpers.faults import run
    from helpers.records import records

    work, tmpdir = tmp_path / "w", tmp_path / "t"
    work.mkdir()
    paths = []
    for i, rec in enumerate(records(40)):
        paths.append(work / f"r{i}.json")
        rec.save(paths[-1])
    db = work / "s.sqlite"
    first = run(["records", "add", paths[0], "--db", db], cwd=work, tmpdir=tmpdir)
    assert first.code == 0, first.err
    size = db.stat().st_size
    full = run(["records", "add", *paths[1:], "--db", db], cwd=work, tmpdir=tmpdir,
               file_size=size)
    assert full.one_line_error(), full.err
    assert "s.sqlite" in full.err
    check = run(["records", "verify", "--db", db], cwd=work, tmpdir=tmpdir)
    assert check.code == 0, check.out + check.err
    assert "chain verified: yes (1 record)" in check.out
    new = run(["records", "add", paths[0], "--db", work / "new.sqlite"], cwd=work,
              tmpdir=tmpdir, file_size=4096)
    assert new.one_line_error(), new.err
    assert sorted(p.name for p in work.iterdir() if "new.sqlite" in p.name) == []
