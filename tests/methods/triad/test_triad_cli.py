"""``accelcal triad`` (issue 12 item 5): detect, calibrate, apply, simulate."""

import json

import numpy as np
import pytest

from accelcal.io.formats import triad as triad_format
from accelcal.methods.triad.model import TriadCalibration
from helpers.cli import run_cli
from helpers.paths import REAL_IMUCAL

DATA = REAL_IMUCAL
SESSION = DATA / "example_ferraris_session.csv"
REGIONS = DATA / "example_ferraris_session_list.json"
TRUTH = TriadCalibration([0.05, -0.08, 0.12], [1.01, 0.995, 1.02], [1e-3, -2e-3, 1.5e-3])


@pytest.fixture(scope="module")
def six(tmp_path_factory):
    path = tmp_path_factory.mktemp("six") / "six.csv"
    code = _main(["triad", "simulate", "--out", path, "--still", "10", "--noise", "0.005"])
    assert code == 0
    return path


@pytest.fixture(scope="module")
def many(tmp_path_factory):
    path = tmp_path_factory.mktemp("many") / "many.csv"
    assert _main(["triad", "simulate", "--out", path, "--positions", "24", "--still", "10",
                  "--noise", "0.005", "--seed", "3"]) == 0
    return path


def _main(args) -> int:
    from accelcal.cli import main

    with pytest.raises(SystemExit) as exc:
        main([str(a) for a in args])
    return exc.value.code


def test_simulate_writes_a_record_with_its_truth(six):
    record = triad_format.read(six)
    assert [p["label"] for p in record.positions] == ["x_p", "x_a", "y_p", "y_a", "z_p", "z_a"]
    truth = TriadCalibration.from_dict(record.metadata["true_calibration"])
    assert np.allclose(truth.vector, TRUTH.vector)


def test_detect_finds_the_simulated_positions(six, tmp_path, capsys):
    code, out, _ = run_cli(["triad", "detect", six, "--init-static", "8", "--format", "json",
                            "--plot", tmp_path / "fig"], capsys)
    assert code == 0, out
    rows = json.loads(out)
    record = triad_format.read(six)
    assert len(rows) == len(record.positions)
    for row, pos in zip(rows, record.positions, strict=True):
        assert pos["start"] <= row["start_index"] < row["stop_index"] <= pos["stop"]
    assert (tmp_path / "fig" / "triad-intervals.png").exists()


def test_calibrate_known_positions_of_a_record_recovers_the_truth(six, tmp_path, capsys):
    cal_path, imucal_path = tmp_path / "cal.json", tmp_path / "imucal.json"
    code, out, err = run_cli(["triad", "calibrate", six, "--out", cal_path, "--imucal-out",
                              imucal_path, "--format", "json"], capsys)
    assert code == 0, err
    doc = json.loads(out)
    assert doc["method"] == "triad/known-orientations"
    assert doc["gravity"] == pytest.approx(9.80665)  # the record's
    assert [r["position"] for r in doc["norm_residuals"]] == ["x_p", "x_a", "y_p", "y_a",
                                                              "z_p", "z_a"]
    cal = TriadCalibration.load(cal_path)
    for row in doc["coefficients"]:
        i = ("b_x", "b_y", "b_z", "s_x", "s_y", "s_z", "a_yz", "a_zy", "a_zx").index(
            row["coefficient"])
        # within 5 standard uncertainties of the truth (the stated std covers the noise)
        assert abs(cal.vector[i] - TRUTH.vector[i]) < 5 * row["std"] + 1e-12
    assert json.loads(imucal_path.read_text())["cal_type"] == "Ferraris"


def test_calibrate_unknown_orientations_chooses_the_factor(many, tmp_path, capsys):
    code, out, err = run_cli(["triad", "calibrate", many, "--orientations", "unknown",
                              "--init-static", "8", "--out", tmp_path / "cal.json",
                              "--format", "json"], capsys)
    assert code == 0, err
    doc = json.loads(out)
    assert doc["method"] == "triad/gravity-norm"
    assert len(doc["factor_sweep"]) == 9
    best = min(r["rms_residual"] for r in doc["factor_sweep"] if r["rms_residual"] is not None)
    assert np.sqrt(np.mean([r["norm_after"] ** 2 for r in doc["norm_residuals"]])) == \
        pytest.approx(best)
    cal = TriadCalibration.load(tmp_path / "cal.json")
    std = {r["coefficient"]: r["std"] for r in doc["coefficients"]}
    for name, true, est in zip(std, TRUTH.vector, cal.vector, strict=True):
        assert abs(est - true) < 5 * std[name], name


def test_calibrate_with_a_positions_file(six, tmp_path, capsys):
    record = triad_format.read(six)
    positions = tmp_path / "up.json"
    positions.write_text(json.dumps([{"label": p["label"], "up": p["up"]}
                                     for p in record.positions]))
    plain = tmp_path / "plain.csv"  # a generic CSV: no positions in it
    np.savetxt(plain, np.column_stack([record.t, record.acc]), delimiter=",",
               header="time,X,Y,Z", comments="")
    code, out, err = run_cli(["triad", "calibrate", plain, "--columns", "X,Y,Z", "--time",
                              "time", "--unit", "m/s^2", "--gravity", "9.80665",
                              "--init-static", "8", "--positions", positions,
                              "--out", tmp_path / "cal.json", "--format", "json"], capsys)
    assert code == 0, err
    assert json.loads(out)["method"] == "triad/known-orientations"


def test_calibrate_table_and_record(six, tmp_path, capsys):
    code, out, err = run_cli(["triad", "calibrate", six, "--out", tmp_path / "cal.json",
                              "--record", tmp_path / "rec.json", "--serial", "TRIAD-1"],
                             capsys)
    assert code == 0, err
    assert "norm residual" in out
    assert "condition number" in out
    assert json.loads((tmp_path / "rec.json").read_text())["serial"] == "TRIAD-1"


def test_the_imucal_session_calibrates_and_applies_both_ways(tmp_path, capsys):
    import pandas as pd

    cal_path, imucal_path = tmp_path / "cal.json", tmp_path / "imucal.json"
    code, _, err = run_cli(["triad", "calibrate", SESSION, "--rate", "102.4", "--regions",
                            REGIONS, "--gravity", "9.81", "--out", cal_path, "--imucal-out",
                            imucal_path], capsys)
    assert code == 0, err
    outs = {}
    for name, path in (("accelcal", cal_path), ("imucal", imucal_path)):
        outs[name] = tmp_path / f"{name}.csv"
        code, _, err = run_cli(["triad", "apply", SESSION, "--calibration", path,
                                "--out", outs[name]], capsys)
        assert code == 0, err
    raw = pd.read_csv(SESSION)
    ours, theirs = pd.read_csv(outs["accelcal"]), pd.read_csv(outs["imucal"])
    assert list(ours.columns) == list(raw.columns)  # order kept, acc_* replaced
    assert len(ours) == len(raw)
    assert (ours["n_samples"] == raw["n_samples"]).all()
    assert np.array_equal(ours[["gyr_x", "gyr_y", "gyr_z"]], raw[["gyr_x", "gyr_y", "gyr_z"]])
    acc = ["acc_x", "acc_y", "acc_z"]
    assert np.allclose(ours[acc], theirs[acc], rtol=0, atol=1e-12)
    cal = TriadCalibration.load(cal_path)
    assert np.allclose(ours[acc], cal.apply(raw[acc].to_numpy(), frame="reference"),
                       rtol=0, atol=1e-12)


def test_apply_keeps_every_row_and_column_and_converts_units(tmp_path, capsys):
    rng = np.random.default_rng(5)
    n = 2500
    t = np.arange(n) / 100.0
    u = rng.normal(0.0, 1.0, (n, 3))
    src = tmp_path / "in.csv"
    with src.open("w") as fh:
        fh.write("time;note;X;Y;Z;temp\n")
        for k in range(n):
            fh.write(f"{float(t[k])!r};n{k % 7};{float(u[k, 0])!r};{float(u[k, 1])!r};"
                     f"{float(u[k, 2])!r};{20 + k}\n")
    cal = TriadCalibration([0.1, -0.2, 0.05], [9.8, 9.7, 9.9], [1e-3, 2e-3, -1e-3],
                           input_unit="g")
    cal.save(tmp_path / "cal.json")
    out = tmp_path / "out.csv"
    code, _, err = run_cli(["triad", "apply", src, "--calibration", tmp_path / "cal.json",
                            "--columns", "X,Y,Z", "--time", "time", "--delimiter", ";",
                            "--unit", "mg", "--output-unit", "g", "--out", out], capsys)
    assert code == 0, err
    import pandas as pd

    got = pd.read_csv(out)
    assert list(got.columns) == ["time", "note", "acc_x", "acc_y", "acc_z", "temp"]
    assert len(got) == n
    assert np.array_equal(got["time"], t)
    assert (got["note"] == [f"n{k % 7}" for k in range(n)]).all()
    expected = cal.apply(u * 1e-3) / 9.80665  # mg -> the calibration's g; m/s^2 -> g_n
    assert np.allclose(got[["acc_x", "acc_y", "acc_z"]], expected, rtol=1e-14, atol=1e-15)


def test_calibrate_with_monte_carlo_uncertainty(six, tmp_path, capsys):
    code, out, err = run_cli(["triad", "calibrate", six, "--out", tmp_path / "cal.json",
                              "--uncertainty", "mc", "--trials", "400", "--format", "json"],
                             capsys)
    assert code == 0, err
    for row in json.loads(out)["coefficients"]:
        # 400 trials: relative SE of an SD 1/sqrt(798) = 3.5 %; allow 6 SE either way
        assert row["mc_std"] == pytest.approx(row["std"], rel=0.25)


def test_calibrate_plots_the_intervals_and_the_method_figures(many, tmp_path, capsys):
    code, _, err = run_cli(["triad", "calibrate", many, "--orientations", "unknown",
                            "--init-static", "8", "--factor", "3",
                            "--out", tmp_path / "cal.json", "--plot", tmp_path / "figs"], capsys)
    assert code == 0, err
    names = {p.name for p in (tmp_path / "figs").iterdir()}
    assert "triad-intervals.png" in names
    assert len(names) > 2


def test_plan_six_positions_matches_the_closed_form(capsys):
    # Six positions: each bias is the mean of six readings (sd sigma_m / sqrt 6), each scale
    # factor the difference of two (relative sd sigma_m / (sqrt 2 g)), sigma_m = sigma/sqrt(N)
    code, out, err = run_cli(["triad", "plan", "--noise", "0.02", "--samples", "400",
                              "--format", "json"], capsys)
    assert code == 0, err
    doc = json.loads(out)
    assert (doc["rank"], doc["unknowns"], doc["missing_directions"]) == (12, 12, [])
    sd = {row["parameter"]: row["predicted_sd"] for row in doc["parameters"]}
    sigma_m = 0.02 / 20
    assert sd["b_x"] == pytest.approx(sigma_m / np.sqrt(6), rel=1e-12)
    assert sd["s_y"] == pytest.approx(sigma_m / (np.sqrt(2) * 9.80665), rel=1e-12)
    code, out, err = run_cli(["triad", "plan", "--orientations", "unknown", "--format",
                              "json"], capsys)
    assert code == 0, err
    assert json.loads(out)["rank"] < 9  # six axis directions: the norm cannot fix the angles
