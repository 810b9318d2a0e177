"""``accelcal response``: simulate -> reduce -> fit, outputs, and bad input in one line."""

import json
from datetime import UTC, datetime

import numpy as np
import pytest

from accelcal.io.formats.response import ResponseRecord, read, write
from helpers.cli import refused, run_cli

STEPS = ["--frequencies", "20,80,315,630,1000"]


@pytest.fixture(scope="module")
def record(tmp_path_factory):
    from accelcal.cli import main

    path = tmp_path_factory.mktemp("resp") / "steps.csv"
    with pytest.raises(SystemExit) as exc:
        main(["response", "simulate", *STEPS, "--noise", "0", "--pole", "3000", "--delay",
              "1e-5", "--out", str(path)])
    assert exc.value.code == 0
    return path


def test_reduce_rows_in_csv_json_and_table(record, capsys):
    code, out, err = run_cli(["response", "reduce", record, "--format", "csv"], capsys)
    assert code == 0, err
    header = out.splitlines()[0].split(",")
    assert header[:6] == ["frequency_hz", "magnitude", "magnitude_u", "phase_deg", "phase_u",
                          "unit"]
    code, out, _ = run_cli(["response", "reduce", record, "--format", "json"], capsys)
    rows = json.loads(out)
    assert [r["frequency_hz"] for r in rows] == [20.0, 80.0, 315.0, 630.0, 1000.0]
    s = 2j * np.pi * 1000.0
    wn = 2 * np.pi * 600.0
    want = 1.3 * wn**2 / (s**2 + 1.2 * wn * s + wn**2) / (1 + s / (2 * np.pi * 3000)) \
        * np.exp(-s * 1e-5)
    assert rows[-1]["magnitude"] == pytest.approx(abs(want), rel=1e-12)
    assert rows[-1]["phase_deg"] == pytest.approx(np.rad2deg(np.angle(want)), abs=1e-9)
    assert rows[1]["deviation_pct"] == 0.0
    assert rows[-1]["unit"] == "V/g"
    code, out, _ = run_cli(["response", "reduce", record], capsys)
    assert code == 0
    assert "magnitude" in out


def test_fit_rows_and_plot(record, tmp_path, capsys):
    code, out, err = run_cli(["response", "fit", record, "--model", "second-order,pole,delay",
                              "--phase-at", "100", "--format", "json", "--plot", tmp_path],
                             capsys)
    assert code == 0, err
    by = {r["coefficient"]: r for r in json.loads(out)}
    assert list(by)[:5] == ["S0", "fn", "zeta", "pole", "delay"]
    assert by["fn"]["estimate"] == pytest.approx(600.0, rel=1e-9)
    assert by["zeta"]["estimate"] == pytest.approx(0.6, rel=1e-9)
    assert by["delay"]["unit"] == "s"
    assert {"f_3dB", "f_peak", "peak_dB", "phase(100 Hz)"} <= set(by)
    assert (tmp_path / "response_bode.png").is_file()


def test_reference_csv(record, tmp_path, capsys):
    ref = tmp_path / "ref.csv"
    ref.write_text("frequency_hz,magnitude,phase_deg\n10,0.2,0\n2000,0.2,0\n")
    _, out, _ = run_cli(["response", "reduce", record, "--format", "json"], capsys)
    code, twice, err = run_cli(["response", "reduce", record, "--reference", ref, "--format",
                                "json"], capsys)
    assert code == 0, err
    # the record's own reference is about 0.1 V/g: a 0.2 V/g certificate doubles the DUT's
    ratio = json.loads(twice)[0]["magnitude"] / json.loads(out)[0]["magnitude"]
    assert ratio == pytest.approx(2.0, rel=2e-3)


def test_reference_not_covering_the_band_is_refused(record, tmp_path, capsys):
    ref = tmp_path / "ref.csv"
    ref.write_text("frequency_hz,magnitude,phase_deg\n50,0.1,0\n500,0.1,0\n")
    refused(["response", "reduce", record, "--reference", ref], capsys, "covers 50-500 Hz",
            "20 Hz")


def test_too_few_periods_is_refused(tmp_path, capsys):
    path = tmp_path / "short.csv"
    code, _, err = run_cli(["response", "simulate", "--frequencies", "100", "--periods", "2",
                            "--out", path], capsys)
    assert code == 0, err
    refused(["response", "reduce", path], capsys, "2 whole period(s)", "at least 3")


def test_frequency_not_in_the_data_is_refused(record, tmp_path, capsys):
    rec = read(record)
    wrong = ResponseRecord(rec.step, np.where(rec.step == 2, 333.0, rec.frequency), rec.t,
                           rec.ref, rec.dut, rec.sample_rate_hz, metadata=rec.metadata)
    write(tmp_path / "wrong.csv", wrong)
    refused(["response", "reduce", tmp_path / "wrong.csv"], capsys, "333 Hz",
            "not found in the data")


@pytest.mark.parametrize(("args", "words"), [
    (["fit", "{rec}", "--model", "third-order"], ("second-order[,pole][,delay]",)),
    (["reduce", "{rec}", "--format", "xml"], ("--format",)),
    (["simulate", "--frequencies", "0,10", "--out", "{tmp}/x.csv"], ("--frequencies",)),
    (["simulate", "--distortion", "0.1", "--out", "{tmp}/x.csv"], ("--distortion",)),
])
def test_bad_options_one_line(record, tmp_path, capsys, args, words):
    args = [a.format(rec=record, tmp=tmp_path) for a in args]
    refused(["response", *args], capsys, *words)


@pytest.mark.parametrize(("excitation", "method", "extra"), [
    ("random", "response/broadband", ["--duration", "2", "--sample-rate", "5000"]),
    ("laser", "response/laser", ["--frequencies", "400,1600", "--periods", "5"]),
    ("gravity", "response/gravity", ["--frequencies", "0.5,2"])])
def test_simulate_and_reduce_each_route(tmp_path, capsys, excitation, method, extra):
    path = tmp_path / f"{excitation}.csv"
    code, _, err = run_cli(["response", "simulate", "--excitation", excitation, *extra,
                            "--out", path], capsys)
    assert code == 0, err
    assert read(path).excitation == excitation
    code, out, err = run_cli(["response", "reduce", path, "--format", "json"], capsys)
    assert code == 0, err
    rows = json.loads(out)
    assert rows
    assert all(r["unit"] == "V/g" for r in rows)
    code, out, err = run_cli(["response", "reduce", path, "--method", method.split("/")[1]],
                             capsys)
    assert code == 0, err
    assert method in out


def test_route_refusals_in_one_line(record, tmp_path, capsys):
    refused(["response", "reduce", record, "--method", "laser"], capsys, "laser records")
    refused(["response", "reduce", record, "--method", "fourier"], capsys, "not one of")
    refused(["response", "reduce", record, "--segment", "512"], capsys, "does not apply")
    refused(["response", "simulate", "--excitation", "chirp", "--out", tmp_path / "x.csv"],
            capsys, "--excitation")
    refused(["response", "plan", "--method", "laser"], capsys, "not one of")
    refused(["response", "plan", "--snr", "-100"], capsys, "snr")


@pytest.mark.parametrize(("excitation", "option", "value"), [
    ("gravity", "--amplitude", "2"), ("gravity", "--gain-ratio", "1.01"),
    ("gravity", "--daq-delay", "1e-5"), ("gravity", "--distortion", "0.01,0"),
    ("laser", "--amplitude", "2"), ("random", "--distortion", "0.01,0")])
def test_simulate_refuses_an_option_its_route_ignores(excitation, option, value, tmp_path,
                                                      capsys):
    out = tmp_path / "x.csv"
    refused(["response", "simulate", "--excitation", excitation, option, value, "--out", out],
            capsys, f"{option} does not apply to --excitation {excitation}")
    assert not out.exists()


def test_gravity_tie_in_the_title(tmp_path, capsys):
    path = tmp_path / "g.csv"
    run_cli(["response", "simulate", "--excitation", "gravity", "--frequencies", "0.5,1",
             "--noise", "0", "--out", path], capsys)
    code, out, err = run_cli(["response", "reduce", path, "--static-scale-factor",
                              "1.3,1e-6"], capsys)
    assert code == 0, err
    assert "static scale factor - 1 =" in out
    assert "ppm" in out


def test_plan_rows(capsys):
    code, out, err = run_cli(["response", "plan", "--frequencies", "10,1000", "--snr", "40",
                              "--magnitude-u", "0.01", "--format", "json"], capsys)
    assert code == 0, err
    rows = json.loads(out)
    assert [r["frequency_hz"] for r in rows] == [10.0, 1000.0]
    # 1 / (snr sqrt(n)) per channel, two channels: n = 2 / (100^2 1e-4^2) = 2e4 samples
    assert rows[1]["samples"] == pytest.approx(2e4, rel=0.01)
    assert all(r["magnitude_u_pct"] <= 0.01 for r in rows)
    code, out, err = run_cli(["response", "plan", "--method", "broadband", "--snr", "20",
                              "--magnitude-u", "1", "--format", "json"], capsys)
    (row,) = json.loads(out)
    assert row["n_d"] >= 50
    assert row["magnitude_u_pct"] <= 1.0


@pytest.mark.slow  # the certificate reduces the record again for its budgets: ~3 s
def test_records_of_the_response_and_its_fit_make_a_certificate(record, tmp_path, capsys):
    from helpers.certificates import LAB

    refused(["response", "reduce", record, "--record", tmp_path / "none.json"], capsys,
            "--serial")  # a simulated record names no serial: say so, write nothing
    assert not (tmp_path / "none.json").exists()
    refused(["response", "fit", record, "--serial", "FR-2"], capsys, "--record")
    comparison, fit = tmp_path / "cmp.json", tmp_path / "fit.json"
    code, _, err = run_cli(["response", "reduce", record, "--record", comparison, "--serial",
                            "FR-2", "--format", "csv"], capsys)
    assert code == 0, err
    assert f"wrote {comparison}" in err
    code, _, err = run_cli(["response", "fit", record, "--record", fit, "--serial", "FR-2"],
                           capsys)
    assert code == 0, err
    out = tmp_path / "c.json"
    issued = datetime.now(UTC).date().isoformat()  # the records are dated today
    code, stdout, err = run_cli(["certificate", comparison, fit, "--lab", LAB, "--out",
                                 tmp_path / "c.html", "--json", out, "--issued", issued,
                                 "--phase-at", "80,315"], capsys)
    assert code == 0, err
    assert "FR-2" in stdout
    (item,) = json.loads(out.read_text(encoding="utf-8"))["items"]
    assert [p["frequency_hz"] for p in item["response"][0]["points"]] == [20, 80, 315, 630,
                                                                           1000]
    assert [a["frequency_hz"] for a in item["response_models"][0]["at"]] == [80, 315]
    assert {r["coefficient"] for r in item["results"]} == {"S0", "fn", "zeta", "f_3dB"}
    refused(["certificate", comparison, "--lab", LAB, "--out", tmp_path / "d.html",
             "--phase-at", "-5"], capsys, "--phase-at")
    assert not (tmp_path / "d.html").exists()
