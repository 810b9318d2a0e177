"""The ``accelcal vre`` command group: its command-line contract, end to end."""

import csv
import io
import json
import subprocess
import sys

import numpy as np
import pytest

from accelcal import ErrorModel
from accelcal.cli import main
from accelcal.methods.vre import vre_table

PAPER_ARGS = ["--K2", "7.87e-6", "--K3", "1.19e-7", "--K0-asym", "2.26e-6", "--K1-asym",
              "1.45e-6", "--overload", "1,2,4", "--amplitude", "5:10:1"]
PAPER = ErrorModel(K2=7.87e-6, K3=1.19e-7, K0_asym=2.26e-6, K1_asym=1.45e-6)
HEADER = "overload_g,amplitude_g,dU1_g,dU2_g,dU_g,r"


def run(args, capsys):
    try:
        main(args)
        code = 0
    except SystemExit as exc:
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def test_table_csv_contract(capsys):
    """Guan2021 Table 1 grid as CSV: exact header, one row per pair, full precision."""
    code, out, _ = run(["vre", "table", *PAPER_ARGS, "--format", "csv"], capsys)
    assert code == 0
    lines = out.splitlines()
    assert lines[0] == HEADER
    rows = list(csv.DictReader(io.StringIO(out)))
    assert len(rows) == 18
    assert [(float(r["overload_g"]), float(r["amplitude_g"])) for r in rows] == [
        (b, a) for b in (1.0, 2.0, 4.0) for a in (5.0, 6.0, 7.0, 8.0, 9.0, 10.0)]
    t = vre_table(PAPER, [1, 2, 4], np.arange(5, 11.0))
    for key, col in (("dU1_g", t.du1), ("dU2_g", t.du2), ("dU_g", t.du), ("r", t.r)):
        np.testing.assert_array_equal([float(r[key]) for r in rows], col.ravel())
    # r is a fraction: below 1 % (Guan2021's claim, which holds)
    assert max(abs(float(r["r"])) for r in rows) < 0.01


def test_table_json_and_table_formats(capsys):
    code, out, _ = run(["vre", "table", *PAPER_ARGS, "--format", "json"], capsys)
    assert code == 0
    data = json.loads(out)
    assert len(data) == 18
    assert all(list(d) == HEADER.split(",") for d in data)
    code, out, _ = run(["vre", "table", *PAPER_ARGS, "--format", "table"], capsys)
    assert code == 0
    assert "dU2" in out
    assert "r = dU2/dU" in out
    assert len(out.splitlines()) > 18


def test_options_override_the_model_file(tmp_path, capsys):
    path = tmp_path / "m.json"
    ErrorModel(K2=1.0, K3=1.0, K0_asym=1.0, K1_asym=1.0, K4=1e-9).save(path)
    code, out, _ = run(["vre", "table", "--model", str(path), *PAPER_ARGS, "--format", "json"],
                       capsys)
    assert code == 0
    data = json.loads(out)
    t = vre_table(PAPER.replace(K4=1e-9), [1, 2, 4], np.arange(5, 11.0))
    np.testing.assert_array_equal([d["dU_g"] for d in data], t.du.ravel())


def test_zero_total_gives_null_r_in_json(capsys):
    code, out, _ = run(["vre", "table", "--overload", "-2,0", "--amplitude", "0,3",
                        "--format", "json"], capsys)
    assert code == 0
    data = json.loads(out)
    assert data[0]["r"] is None  # A = 0: no VRE at all
    assert data[1]["dU2_g"] > 0  # b = -2, A = 3 > |b|


def test_plot_writes_the_three_figures(tmp_path, capsys):
    code, out, err = run(["vre", "table", *PAPER_ARGS, "--format", "csv", "--plot",
                          str(tmp_path / "fig")], capsys)
    assert code == 0
    assert out.splitlines()[0] == HEADER  # stdout stays clean CSV
    for stem in ("vre_du2", "vre_du1", "vre_r"):
        for ext in ("png", "svg"):
            f = tmp_path / "fig" / f"{stem}.{ext}"
            assert f.stat().st_size > 1000
            assert str(f) in err
    assert (tmp_path / "fig" / "vre_r.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_simulate_reduce_fit_workflow(tmp_path, capsys):
    model = tmp_path / "m.json"
    PAPER.replace(K1=1.3, sigma=1e-6).save(model)
    rec = tmp_path / "grid.csv"
    code, _, err = run(["vre", "simulate", "--model", str(model), "--out", str(rec),
                        "--duration", "0.4", "--seed", "11"], capsys)
    assert code == 0
    assert rec.exists()
    assert "18 points" in err
    code, out, _ = run(["vre", "reduce", str(rec), "--model", str(model), "--format", "json"],
                       capsys)
    assert code == 0
    rows = json.loads(out)
    assert len(rows) == 18
    assert max(abs(r["z"]) for r in rows) < 4.5
    code, out, _ = run(["vre", "fit", str(rec), "--format", "json"], capsys)
    assert code == 0
    doc = json.loads(out)
    est = {r["coefficient"]: r for r in doc["coefficients"]}
    for name in ("K2", "K3", "K0_asym", "K1_asym"):
        assert abs(est[name]["estimate"] - getattr(PAPER, name)) < 4.5 * est[name]["std"]
    # one overload only: K2, K3 reported as not identifiable, the combination given
    rec1 = tmp_path / "one.csv"
    run(["vre", "simulate", "--model", str(model), "--out", str(rec1), "--overload", "2",
         "--noise", "0"], capsys)
    code, out, err = run(["vre", "fit", str(rec1), "--format", "csv"], capsys)
    assert code == 0
    assert "K2,nan,nan,g/g^2,not identifiable" in out
    assert "K2 + 6 K3" in err


def test_fit_combines_files(tmp_path, capsys):
    """Two single-overload files separate K2 and K3, which neither does alone."""
    model = tmp_path / "m.json"
    PAPER.save(model)
    files = []
    for b in ("1", "4"):
        files.append(str(tmp_path / f"b{b}.csv"))
        run(["vre", "simulate", "--model", str(model), "--out", files[-1], "--overload", b,
             "--noise", "0", "--duration", "0.1"], capsys)
    code, out, _ = run(["vre", "fit", *files, "--format", "json"], capsys)
    assert code == 0
    est = {r["coefficient"]: r["estimate"] for r in json.loads(out)["coefficients"]}
    assert est["K2"] == pytest.approx(PAPER.K2, rel=1e-7)
    assert est["K3"] == pytest.approx(PAPER.K3, rel=1e-6)


def test_unwritable_plot_directory_exit_2(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("")
    code, _out, err = run(["vre", "table", "--plot", str(blocker / "sub")], capsys)
    assert code == 2
    assert err.startswith("accelcal: error: ")
    assert str(blocker / "sub") in err
    assert err.count("\n") == 1


def test_negative_overload_option_is_accepted(capsys):
    code, out, _ = run(["vre", "table", "--overload", "-2", "--amplitude", "3",
                        "--format", "csv"], capsys)
    assert code == 0
    assert out.splitlines()[1].startswith("-2.0,3.0,")


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["vre", "table", "--amplitude", "-1"], "--amplitude: -1 g is negative"),
        (["vre", "table", "--overload", "nan"], "not finite"),
        (["vre", "table", "--K2", "inf"], "not finite"),
        (["vre", "table", "--amplitude", ""], "empty"),
        (["vre", "table", "--amplitude", "5:10"], "not a range"),
        (["vre", "table", "--amplitude", "10:5:1"], "empty"),
        (["vre", "table", "--format", "xml"], "xml"),
        (["vre", "simulate", "--out", "x.csv", "--frequency", "4000"], "Nyquist"),
        (["vre", "fit", "nofile.csv"], "not found"),
        (["vre", "fit", "nofile.csv", "--terms", "K2,,K3"], "empty name"),
    ],
)
def test_bad_input_one_line_exit_2(args, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, _out, err = run(args, capsys)
    assert code == 2
    assert err.startswith("accelcal: error:")
    assert err.count("\n") == 1
    assert message in err
    assert "Traceback" not in err
    assert not (tmp_path / "x.csv").exists()


def test_short_record_and_unequal_rates_exit_2(tmp_path, capsys):
    short = tmp_path / "short.csv"
    code, _, _ = run(["vre", "simulate", "--out", str(short), "--overload", "1",
                      "--amplitude", "5", "--duration", "0.01", "--frequency", "50"], capsys)
    assert code == 0
    code, _, err = run(["vre", "reduce", str(short)], capsys)
    assert code == 2
    assert "shorter than one period" in err
    assert err.count("\n") == 1
    rec = tmp_path / "r.csv"
    run(["vre", "simulate", "--out", str(rec), "--overload", "1,2", "--amplitude", "5",
         "--duration", "0.1", "--sample-rate", "1000"], capsys)
    lines = rec.read_text().splitlines()
    body = [line.split(",") for line in lines[3:]]
    for k, cells in enumerate(body[100:]):
        cells[1] = repr(k / 999.0)
    rec.write_text("\n".join(lines[:3] + [",".join(c) for c in body]) + "\n")
    code, _, err = run(["vre", "fit", str(rec)], capsys)
    assert code == 2
    assert "unequal sample rates" in err
    assert err.count("\n") == 1


def test_console_script_end_to_end(tmp_path):
    """The installed command, as a user runs it."""
    proc = subprocess.run(
        [sys.executable, "-c", "from accelcal.cli import main; main()", "vre", "table",
         *PAPER_ARGS, "--format", "csv"],
        capture_output=True, text=True, check=False, timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[0] == HEADER
    bad = subprocess.run(
        [sys.executable, "-c", "from accelcal.cli import main; main()", "vre", "table",
         "--amplitude", "-5"],
        capture_output=True, text=True, check=False, timeout=120,
    )
    assert bad.returncode == 2
    assert bad.stderr.count("\n") == 1
    assert "Traceback" not in bad.stderr
