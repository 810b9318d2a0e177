"""``accelcal certificate --db``: the records looked up in a store and its chain verified."""

import json
import sqlite3

from helpers.certificates import LAB, write_inputs
from helpers.cli import assert_one_line_error, run_cli


def _issue(paths, tmp_path, capsys, *extra):
    return run_cli(["certificate", *paths, "--lab", LAB, "--out", tmp_path / "c.html",
                    "--json", tmp_path / "c.json", "--issued", "2026-11-26", *extra], capsys)


def _chain(tmp_path) -> str:
    return json.loads((tmp_path / "c.json").read_text(encoding="utf-8"))["records_chain"]


def test_records_in_an_intact_store_are_stated_verified(tmp_path, capsys):
    paths = write_inputs(tmp_path)
    db = tmp_path / "s.sqlite"
    code, _, err = run_cli(["records", "add", *paths, "--db", db], capsys)
    assert code == 0, err
    code, _, err = _issue(paths, tmp_path, capsys, "--db", db)
    assert code == 0, err
    chain = _chain(tmp_path)
    assert chain.startswith(f"verified in store {db} (2 records, chain intact; records 1, 2")
    assert "chain intact" in (tmp_path / "c.html").read_text(encoding="utf-8")


def test_a_record_not_in_the_store_refuses_unless_allowed(tmp_path, capsys):
    paths = write_inputs(tmp_path)
    db = tmp_path / "s.sqlite"
    code, _, err = run_cli(["records", "add", paths[0], "--db", db], capsys)
    assert code == 0, err
    code, _, err = _issue(paths, tmp_path, capsys, "--db", db)
    assert_one_line_error(code, err, "not found in store", paths[1].name, "SN-2",
                          "--allow-unverified")
    assert not (tmp_path / "c.html").exists()
    code, _, err = _issue(paths, tmp_path, capsys, "--db", db, "--allow-unverified")
    assert code == 0, err
    assert _chain(tmp_path).startswith("NOT verified: not found in store")


def test_a_broken_chain_refuses_unless_allowed(tmp_path, capsys):
    paths = write_inputs(tmp_path)
    db = tmp_path / "s.sqlite"
    code, _, err = run_cli(["records", "add", *paths, "--db", db], capsys)
    assert code == 0, err
    with sqlite3.connect(db) as conn:  # a coefficient changed outside accelcal
        conn.execute("UPDATE coefficients SET estimate = estimate * 1.0001 "
                     "WHERE calibration_id = 2")
    conn.close()
    code, _, err = _issue(paths, tmp_path, capsys, "--db", db)
    assert_one_line_error(code, err, "NOT verified", "chain verified: no", "finding",
                          "--allow-unverified")
    code, _, err = _issue(paths, tmp_path, capsys, "--db", db, "--allow-unverified")
    assert code == 0, err
    assert "chain verified: no" in _chain(tmp_path)


def test_without_db_the_certificate_says_record_files(tmp_path, capsys):
    paths = write_inputs(tmp_path)
    code, _, err = _issue(paths, tmp_path, capsys)
    assert code == 0, err
    assert _chain(tmp_path).startswith("not from a store")
