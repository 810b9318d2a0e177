"""`accelcal records`: add, list, history (with plot), stats; errors."""

import json

import pytest

from accelcal.cli import main
from helpers.records import make_record


def run(capsys, *args):
    with pytest.raises(SystemExit) as info:
        main(list(args))
    out, err = capsys.readouterr()
    return info.value.code, out, err


def test_records_workflow(capsys, tmp_path):
    db = str(tmp_path / "store.sqlite")
    files = []
    for month in (1, 2, 3):
        path = tmp_path / f"rec{month}.json"
        make_record(date=f"2026-{month:02d}-01T00:00:00+00:00", shift=month * 1e-6).save(path)
        files.append(str(path))
    code, out, _ = run(capsys, "records", "add", *files, "--db", db)
    assert code == 0
    assert out.count("added") == 3
    code, out, _ = run(capsys, "records", "list", "--db", db, "--format", "json")
    assert [r["serial"] for r in json.loads(out)] == ["SN-1"] * 3
    code, out, _ = run(capsys, "records", "history", "SN-1", "--db", db, "--format", "csv",
                         "--plot", str(tmp_path / "fig"))
    assert code == 0
    assert out.splitlines()[0] == "id,date,method,name,unit,estimate,std,superseded_by"
    assert len(out.splitlines()) == 1 + 9
    assert (tmp_path / "fig" / "history-SN-1.png").stat().st_size > 1000
    assert (tmp_path / "fig" / "history-SN-1.svg").exists()
    code, out, _ = run(capsys, "records", "stats", "SN-1", "--db", db, "--format", "json")
    stats = {s["name"]: s for s in json.loads(out)}
    assert stats["K_I"]["n"] == 3
    assert stats["K_I"]["method"] == "dividing-head/joint"
    assert stats["K_I"]["repeatability"] == pytest.approx(1e-6, rel=1e-9)
    other = tmp_path / "single.json"
    make_record(date="2026-04-01T00:00:00+00:00", method="dividing-head/single").save(other)
    run(capsys, "records", "add", str(other), "--db", db)
    code, out, _ = run(capsys, "records", "stats", "SN-1", "--db", db, "--format", "json",
                       "--method", "dividing-head/joint")
    assert code == 0
    assert [s["n"] for s in json.loads(out)] == [3, 3, 3]
    code, out, _ = run(capsys, "records", "history", "SN-1", "--db", db, "--format", "json",
                       "--method", "dividing-head/single")
    assert {r["method"] for r in json.loads(out)} == {"dividing-head/single"}
    code, _, err = run(capsys, "records", "stats", "SN-1", "--db", db, "--method", "tumble")
    assert code == 2
    assert "by method 'tumble'" in err


@pytest.mark.parametrize("fmt", ["csv", "json", "table"])
def test_history_and_list_output_is_the_rows_rendered(capsys, tmp_path, fmt):
    # records history and list write their columns straight to CSV (no row dicts): every
    # format must still be exactly what rendering the store's rows gives.
    from accelcal.cli.common import render
    from accelcal.io.calibration_record import CalibrationRecord
    from accelcal.store import Store
    from helpers.paths import FIXTURES

    db = str(tmp_path / "store.sqlite")
    with Store(db) as store:
        store.add(CalibrationRecord.load(FIXTURES / "calibration_record_v1.json"))  # a NaN std
        store.add(make_record(serial="SN-0042", date="2026-01-01T00:00:00+00:00"))
        rows = store.history("SN-0042")
        calibrations = store.calibrations()
    code, out, _ = run(capsys, "records", "history", "SN-0042", "--db", db, "--format", fmt)
    assert code == 0
    assert out == render(rows, fmt, title="Coefficient history of SN-0042")
    if fmt == "csv":
        assert out.splitlines()[5].endswith(",nan")
    code, out, _ = run(capsys, "records", "list", "--db", db, "--format", fmt)
    assert code == 0
    assert out == render(calibrations, fmt, title="Calibrations")
    assert [c["simulated"] for c in calibrations] == [False, False]
    if fmt != "table":  # an empty store lists as before (the table says so in words)
        empty = str(tmp_path / "empty.sqlite")
        Store(empty).close()
        code, out, _ = run(capsys, "records", "list", "--db", empty, "--format", fmt)
        assert (code, out) == (0, render([], fmt))


def test_records_errors_exit_2(capsys, tmp_path):
    db = str(tmp_path / "store.sqlite")
    good = tmp_path / "good.json"
    make_record().save(good)
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    code, _, err = run(capsys, "records", "add", str(good), str(bad), "--db", db)
    assert code == 2
    assert "bad.json: missing key(s)" in err
    code, out, _ = run(capsys, "records", "list", "--db", db)
    assert "no calibration" in out  # validation happens before any write
    code, _, err = run(capsys, "records", "history", "NOPE", "--db", db)
    assert code == 2
    assert "no calibration of serial 'NOPE'" in err
    run(capsys, "records", "add", str(good), "--db", db)
    code, _, err = run(capsys, "records", "add", str(good), "--db", db)
    assert code == 2
    assert "already in the store" in err
