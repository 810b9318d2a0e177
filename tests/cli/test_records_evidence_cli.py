"""``records verify``, ``records supersede`` and the chain's line in ``report --history``."""

import json

import sqlalchemy as sa

from helpers.cli import assert_one_line_error, run
from helpers.records import make_record, records


def _files(tmp_path, recs):
    paths = []
    for i, rec in enumerate(recs):
        paths.append(tmp_path / f"r{i}.json")
        rec.save(paths[-1])
    return paths


def test_verify_exits_0_on_a_clean_store_and_1_naming_each_tampered_record(capsys, tmp_path):
    db = str(tmp_path / "s.sqlite")
    code, out, _ = run(capsys, "records", "verify", "--db", db)  # no store yet: nothing wrong
    assert (code, out.splitlines()[1]) == (0, "chain verified: yes (0 records)")
    code, _, err = run(capsys, "records", "add", *_files(tmp_path, records(4)), "--db", db)
    assert code == 0, err
    code, out, _ = run(capsys, "records", "verify", "--db", db)
    assert code == 0
    assert out.splitlines()[:2] == ["integrity check: ok", "chain verified: yes (4 records)"]
    assert out.splitlines()[2].startswith("head: ")
    engine = sa.create_engine(f"sqlite:///{db}")
    with engine.begin() as conn:
        conn.execute(sa.text("UPDATE coefficients SET estimate = 1.3 WHERE calibration_id = 2 "
                             "AND name = 'K_I'"))
        conn.execute(sa.text("DELETE FROM coefficients WHERE calibration_id = 4"))
        conn.execute(sa.text("DELETE FROM calibrations WHERE id = 4"))
    engine.dispose()
    code, out, _ = run(capsys, "records", "verify", "--db", db)
    assert code == 1
    lines = out.splitlines()
    assert lines[0].startswith("changed: record 2 (serial SN-1, dividing-head/joint, "
                               "2026-01-02T00:00:00.000000+00:00)")
    assert lines[1].startswith("deleted: record 4 (serial SN-1, dividing-head/joint, "
                               "2026-01-04T00:00:00.000000+00:00)")
    assert lines[3].startswith("chain verified: no (3 records; 2 finding(s)")
    code, out, _ = run(capsys, "records", "verify", "--db", db, "--format", "json")
    doc = json.loads(out)
    assert code == 1
    assert (doc["verified"], doc["records"], doc["integrity"]) == (False, 3, "ok")
    assert [(f["kind"], f["id"]) for f in doc["findings"]] == [("changed", 2), ("deleted", 4)]
    code, _, err = run(capsys, "records", "verify", "--db", db, "--format", "csv")
    assert_one_line_error(code, err, "--format must be table or json")


def test_supersede_adds_a_correction_that_history_marks(capsys, tmp_path):
    db = str(tmp_path / "s.sqlite")
    first, second = _files(tmp_path, records(2))
    run(capsys, "records", "add", first, second, "--db", db)
    fixed = tmp_path / "fixed.json"
    make_record(shift=3e-7, date="2026-01-01T00:00:00+00:00", operator="B").save(fixed)
    code, out, err = run(capsys, "records", "supersede", "1", "--by", fixed, "--who",
                         "A. Tester", "--why", "wrong reference voltage", "--db", db)
    assert code == 0, err
    assert out == f"added {fixed} as record 3 (serial SN-1), superseding record 1\n"
    code, out, _ = run(capsys, "records", "history", "SN-1", "--db", db, "--format", "json")
    marks = {(r["id"], r["superseded_by"]) for r in json.loads(out)}
    assert marks == {(1, 3), (2, None), (3, None)}
    code, out, _ = run(capsys, "records", "stats", "SN-1", "--db", db, "--format", "json")
    assert {r["n"] for r in json.loads(out)} == {2}
    code, _, err = run(capsys, "records", "supersede", "1", "--by", fixed, "--who", "A",
                       "--why", "again", "--db", db)
    assert_one_line_error(code, err, "record 1 is already superseded by record 3")
    code, _, err = run(capsys, "records", "supersede", "2", "--by", fixed, "--who", " ",
                       "--why", "x", "--db", db)
    assert_one_line_error(code, err, "who is blank")
    code, out, _ = run(capsys, "records", "verify", "--db", db)
    assert code == 0
    assert "chain verified: yes (3 records)" in out


def test_records_add_refuses_dates_it_cannot_keep(capsys, tmp_path):
    db = str(tmp_path / "s.sqlite")
    for date in ("0001-01-01T00:00:00+00:00", "9999-12-31T23:59:59-05:00"):
        (path,) = _files(tmp_path, [make_record(date=date)])
        code, _, err = run(capsys, "records", "add", path, "--db", db)
        assert_one_line_error(code, err, "outside 1900-01-01 .. 2199-12-31")


def test_report_history_prints_and_writes_the_chain_status(capsys, tmp_path):
    db = str(tmp_path / "s.sqlite")
    paths = _files(tmp_path, records(3))
    run(capsys, "records", "add", *paths, "--db", db)
    out = tmp_path / "r.html"
    code, stdout, err = run(capsys, "report", paths[0], "--out", out, "--history", "--db", db)
    assert code == 0, err
    assert "chain verified: yes (3 records)" in stdout
    html = out.read_text()
    assert "chain verified: yes (3 records)" in html
    assert ("Records: record files (not from a store); the history&#39;s store: chain verified: "
            "yes (3 records).") in html  # under the heading, besides the history section
    code, _, err = run(capsys, "report", paths[0], "--out", out)
    assert code == 0, err
    assert "Records: not from a store" in out.read_text()
    code, _, err = run(capsys, "report", paths[0], "--out", out, "--skip-bad")
    assert_one_line_error(code, err, "--skip-bad goes with --history")


def test_corrections_are_listed_with_who_when_and_why(capsys, tmp_path):
    db = str(tmp_path / "s.sqlite")
    (first,) = _files(tmp_path, records(1))
    code, out, _ = run(capsys, "records", "corrections", "--db", db)
    assert code == 0
    assert out == "the store holds no correction\n"
    run(capsys, "records", "add", first, "--db", db)
    fixed = tmp_path / "fixed.json"
    make_record(shift=3e-7, date="2026-01-01T00:00:00+00:00", operator="B").save(fixed)
    run(capsys, "records", "supersede", "1", "--by", fixed, "--who", "A. Tester", "--why",
        "wrong reference voltage", "--db", db)
    _, out, _ = run(capsys, "records", "corrections", "--db", db, "--format", "json")
    (row,) = json.loads(out)
    assert (row["id"], row["supersedes"], row["who"], row["why"]) == (
        2, 1, "A. Tester", "wrong reference voltage")
    assert row["stored_at"].endswith("+00:00")
    _, out, _ = run(capsys, "records", "history", "SN-1", "--db", db)
    assert out.splitlines()[-1].startswith("record 2 supersedes record 1: by A. Tester on ")
    assert out.splitlines()[-1].endswith("because wrong reference voltage")
