"""``accelcal thermal``: simulate -> reduce -> compensate, outputs and files (issue 15 item 5)."""

import json

import numpy as np
import pytest

from accelcal import ErrorModel
from accelcal.io.calibration_record import CalibrationRecord
from accelcal.methods.thermal import Compensation
from helpers.cli import run_cli

SMALL = ["--setpoints", "-30,0,30,60,15,-15", "--points", "12", "--dwell", "30",
         "--warmup", "1800"]


@pytest.fixture(scope="module")
def record(tmp_path_factory):
    path = tmp_path_factory.mktemp("th") / "th.csv"
    from accelcal.cli import main

    with pytest.raises(SystemExit) as exc:
        main(["thermal", "simulate", "--out", str(path), "--seed", "4", *SMALL])
    assert exc.value.code == 0
    return path


def test_reduce_json_rows_and_files(record, tmp_path, capsys):
    comp, model, rec = tmp_path / "c.json", tmp_path / "m.json", tmp_path / "r.json"
    code, out, err = run_cli(["thermal", "reduce", record, "--order", "1", "--format", "json",
                              "--compensation", comp, "--model-out", model, "--record", rec,
                              "--serial", "SN-9"], capsys)
    assert code == 0, err
    rows = json.loads(out)
    names = [r["coefficient"] for r in rows]
    assert names[:3] == ["K0+Kpp", "K0_T1", "K0_hyst"]  # the tumble's K0 is K0 + Kpp
    assert rows[0]["plain"] == "K0"
    assert {"K1", "K1_T1", "K1_hyst", "warmup_tau", "warmup_amplitude"} <= set(names)
    assert all({"coefficient", "estimate", "std"} <= set(r) for r in rows)
    by = {r["coefficient"]: r for r in rows}
    assert by["K0_T1"]["eng_unit"] == "ug/degC"
    assert by["K1_T1"]["eng_unit"] == "ppm/degC"
    # the simulated truth: default accelerometer, bias TC 8 ug/degC, scale TC -25 ppm/degC
    # (second-order terms too, so order 1 is biased by them: a loose check only)
    assert by["K0_T1"]["eng_estimate"] == pytest.approx(8.0, abs=1.0)
    assert by["K1_T1"]["eng_estimate"] == pytest.approx(-25.0, abs=2.0)
    c = Compensation.load(comp)
    m = ErrorModel.load(model)
    assert Compensation.from_model(m, description=f"from {record.name}") == c
    assert c.coefficients["K0_T1"] == by["K0_T1"]["estimate"]
    r = CalibrationRecord.load(rec)
    assert r.serial == "SN-9"
    assert r.model == m
    assert r.simulated


def test_reduce_table_and_auto_order(record, capsys):
    code, out, _ = run_cli(["thermal", "reduce", record], capsys)
    assert code == 0
    assert "K0_T1" in out
    assert "F-test" in out
    assert "residual of K0 after compensation" in out


def test_compensate_streams_one_row_per_input_row(record, tmp_path, capsys):
    comp, out = tmp_path / "c.json", tmp_path / "out.csv"
    run_cli(["thermal", "reduce", record, "--order", "2", "--compensation", comp], capsys)
    code, _, err = run_cli(["thermal", "compensate", record, "--model", comp, "--out", out,
                            "--allow-extrapolation"], capsys)
    assert code == 0, err
    from accelcal.io.formats import thermal as thermal_format

    rec = thermal_format.read(record)
    lines = out.read_text().splitlines()
    assert lines[0] == "time_s,output,temperature_degC,a_i_g,extrapolated"
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    assert data.shape == (rec.t.size, 5)
    c = Compensation.load(comp)
    a, flag = c.apply(rec.output, rec.temperature, allow_extrapolation=True)
    np.testing.assert_array_equal(data[:, 3], a)
    np.testing.assert_array_equal(data[:, 4], flag)
    # at the tumble's 0 deg position, the compensated value is ~ 1 g (a_i = cos 0) within
    # the residual after compensation (tens of ug) and the noise (~15 ug)
    zero = (rec.phase == 2) & (rec.angle_rad == 0.0)
    assert np.abs(data[zero, 3] - 1.0).max() < 3e-4
