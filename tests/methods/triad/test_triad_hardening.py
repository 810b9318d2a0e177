"""Bad input to ``accelcal triad`` (issue 12 item 7): exit 2, one line, nothing written."""

import json

import numpy as np
import pytest

from accelcal.io.formats import triad as triad_format
from accelcal.methods.triad.model import TriadCalibration
from accelcal.rigs.triad import simulate, six_positions
from helpers.cli import refused

TRUTH = TriadCalibration([0.05, -0.08, 0.12], [1.01, 0.995, 1.02], [1e-3, -2e-3, 1.5e-3])


@pytest.fixture(scope="module")
def record(tmp_path_factory):
    path = tmp_path_factory.mktemp("rec") / "six.csv"
    triad_format.write(path, simulate(TRUTH, six_positions(), still=10.0, noise_sd=0.005,
                                      seed=1))
    return path


@pytest.fixture(scope="module")
def plain(tmp_path_factory, record):
    """The record as a generic CSV (time, X, Y, Z), as text lines to spoil."""
    rec = triad_format.read(record)
    return ["time,X,Y,Z"] + [f"{t!r},{a!r},{b!r},{c!r}" for t, (a, b, c)
                             in zip(rec.t.tolist(), rec.acc.tolist(), strict=True)]


GENERIC = ["--columns", "X,Y,Z", "--time", "time", "--unit", "m/s^2", "--gravity", "9.80665"]


def _write(tmp_path, lines, name="in.csv"):
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def _outputs(tmp_path):
    return [tmp_path / "cal.json", tmp_path / "imucal.json"]


def _calibrate(src, tmp_path, *extra):
    out, imu = _outputs(tmp_path)
    return ["triad", "calibrate", src, *extra, "--out", out, "--imucal-out", imu]


def _nothing_written(tmp_path):
    assert not any(p.exists() for p in _outputs(tmp_path))
    assert not list(tmp_path.glob("*.tmp*"))


def test_no_still_period(record, tmp_path, capsys):
    refused(_calibrate(record, tmp_path, "--orientations", "unknown", "--init-static",
                       "1e5"), capsys, "no still period at the start", "--init-static")
    _nothing_written(tmp_path)


def test_a_still_period_that_moves(record, tmp_path, capsys):
    # the first position lasts 15 s: 30 s reach into the motion to the second
    refused(["triad", "detect", record, "--init-static", "30"], capsys,
            "no still period at the start", "times more")


def test_no_intervals_found(record, tmp_path, capsys):
    err = refused(["triad", "detect", record, "--init-static", "8", "--min-length", "1000"],
                  capsys, "no static intervals found", "threshold", "longest still run")
    assert "--min-length" in err


@pytest.mark.parametrize(("extra", "words"), [
    (["--columns", "A,B,C"], ["has no column", "A"]),
    (["--columns", "X,Y"], ["needs 3 column"]),
    (["--time", "when"], ["has no time column", "when"]),
])
def test_columns_missing(plain, tmp_path, capsys, extra, words):
    src = _write(tmp_path, plain)
    args = list(GENERIC)
    for flag, value in zip(extra[::2], extra[1::2], strict=True):
        args[args.index(flag) + 1] = value
    refused(_calibrate(src, tmp_path, *args), capsys, *words)
    _nothing_written(tmp_path)


def test_wrong_unit(plain, tmp_path, capsys):
    src = _write(tmp_path, plain)
    args = list(GENERIC)
    args[args.index("--unit") + 1] = "furlongs"
    refused(_calibrate(src, tmp_path, *args), capsys, "--unit", "furlongs")
    _nothing_written(tmp_path)


def test_a_unit_the_calibration_does_not_map(plain, tmp_path, capsys):
    src = _write(tmp_path, plain)
    cal = TriadCalibration([0.0] * 3, [1.0] * 3, [0.0] * 3, input_unit="counts")
    cal.save(tmp_path / "counts.json")
    out = tmp_path / "out.csv"
    refused(["triad", "apply", src, "--calibration", tmp_path / "counts.json", "--columns",
             "X,Y,Z", "--time", "time", "--unit", "V", "--out", out], capsys,
            "maps counts", "in V")
    assert not out.exists()


def test_nan_samples(plain, tmp_path, capsys):
    lines = list(plain)
    t, x, _, z = lines[500].split(",")
    lines[500] = f"{t},{x},,{z}"
    src = _write(tmp_path, lines)
    refused(_calibrate(src, tmp_path, *GENERIC), capsys, "column Y", "data row 500")
    _nothing_written(tmp_path)
    cal = tmp_path / "good.json"
    TRUTH.save(cal)
    out = tmp_path / "out.csv"
    refused(["triad", "apply", src, "--calibration", cal, "--columns", "X,Y,Z", "--time",
             "time", "--out", out], capsys, "data row 500")
    assert not out.exists()


def test_time_going_backwards(plain, tmp_path, capsys):
    lines = list(plain)
    lines[800], lines[801] = lines[801], lines[800]
    src = _write(tmp_path, lines)
    refused(_calibrate(src, tmp_path, *GENERIC), capsys, "goes backwards")
    _nothing_written(tmp_path)


def test_too_few_positions(tmp_path, capsys):
    path = tmp_path / "three.csv"
    triad_format.write(path, simulate(TRUTH, six_positions()[[0, 2, 4]], still=10.0,
                                      noise_sd=0.005, seed=2))
    refused(_calibrate(path, tmp_path), capsys, "3 position(s) given", "x down")
    _nothing_written(tmp_path)


def test_six_orientations_do_not_make_a_gravity_norm_calibration(tmp_path, capsys):
    path = tmp_path / "six.csv"
    triad_format.write(path, simulate(TRUTH, six_positions(), still=10.0, noise_sd=0.005,
                                      seed=3))
    refused(_calibrate(path, tmp_path, "--orientations", "unknown", "--init-static", "8",
                       "--factor", "2"), capsys, "6 position(s) given", "at least")
    _nothing_written(tmp_path)


def test_a_positions_file_of_the_wrong_length(plain, tmp_path, capsys):
    src = _write(tmp_path, plain)
    positions = tmp_path / "up.json"
    positions.write_text(json.dumps([[0, 0, 1], [1, 0, 0]]))
    refused(_calibrate(src, tmp_path, *GENERIC, "--init-static", "8", "--positions",
                       positions), capsys, "2 up vectors for the 6 static intervals")
    _nothing_written(tmp_path)


@pytest.mark.parametrize(("extra", "words"), [
    (["--orientations", "known"], ["--orientations", "known needs"]),
    (["--orientations", "sideways"], ["sideways"]),
    (["--format", "csv"], ["--format csv"]),
    (["--quadratic"], ["--imucal-out", "quadratic"]),
    (["--gravity", "9.8", "--latitude", "45"], ["--gravity", "either gravity or latitude"]),
])
def test_inconsistent_options(plain, tmp_path, capsys, extra, words):
    src = _write(tmp_path, plain)
    refused(_calibrate(src, tmp_path, *GENERIC, *extra), capsys, *words)
    _nothing_written(tmp_path)


def test_no_gravity_for_a_generic_file(plain, tmp_path, capsys):
    src = _write(tmp_path, plain)
    args = GENERIC[:-2]  # without --gravity
    refused(_calibrate(src, tmp_path, *args), capsys, "--gravity", "local gravity", "latitude")
    _nothing_written(tmp_path)


@pytest.mark.parametrize("where", ["missing/cal.json", "dir"])
def test_unwritable_out(record, tmp_path, capsys, where):
    (tmp_path / "dir").mkdir()
    imu = tmp_path / "imucal.json"
    refused(["triad", "calibrate", record, "--out", tmp_path / where, "--imucal-out", imu],
            capsys, "cannot write")
    assert not imu.exists()
    assert not (tmp_path / "missing").exists()


def test_unwritable_apply_out(record, tmp_path, capsys):
    TRUTH.save(tmp_path / "cal.json")
    refused(["triad", "apply", record, "--calibration", tmp_path / "cal.json", "--out",
             tmp_path / "missing" / "out.csv"], capsys, "cannot write")


def test_a_calibration_that_is_not_one(record, tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"hello": 1}))
    out = tmp_path / "out.csv"
    refused(["triad", "apply", record, "--calibration", bad, "--out", out], capsys,
            "not an accelcal triad calibration")
    assert not out.exists()


def test_simulate_refuses_bad_positions(tmp_path, capsys):
    out = tmp_path / "s.csv"
    refused(["triad", "simulate", "--out", out, "--positions", "lots"], capsys, "--positions")
    refused(["triad", "simulate", "--out", out, "--positions", "9" * 30], capsys)
    assert not out.exists()


def test_detect_refuses_a_moving_recording_without_intervals(tmp_path, capsys):
    rng = np.random.default_rng(0)
    t = np.arange(3000) / 100.0
    acc = np.column_stack([np.sin(t), np.cos(t), 0 * t]) * 9.8 + rng.normal(0, 0.01, (3000, 3))
    acc[:300] = np.array([0, 9.8, 0]) + rng.normal(0, 0.01, (300, 3))
    lines = ["time,X,Y,Z"] + [f"{a!r},{b!r},{c!r},{d!r}" for a, (b, c, d)
                              in zip(t.tolist(), acc.tolist(), strict=True)]
    src = _write(tmp_path, lines)
    refused(["triad", "detect", src, *GENERIC[:6], "--init-static", "2", "--min-length",
             "5"], capsys, "no static intervals found")
