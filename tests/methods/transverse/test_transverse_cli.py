"""`accelcal transverse`: the sweep contract, simulate/analyze/fit, record files, bad input."""

import csv
import io
import json

import numpy as np
import pytest

from accelcal.cli import main
from accelcal.io.formats.shaker import read_records, write_records
from accelcal.io.records import read_record, write_record
from accelcal.methods import transverse as tr
from accelcal.model import ErrorModel
from accelcal.rigs.shaker import ShakerRig


def run(capsys, *args):
    with pytest.raises(SystemExit) as info:
        main([str(a) for a in args])
    out, err = capsys.readouterr()
    return info.value.code, out, err


@pytest.fixture
def model_file(tmp_path):
    path = tmp_path / "m.json"
    tr.GUANTANG_FIG4.save(path)
    return path


def test_sweep_csv_contract(capsys, model_file):
    code, out, _ = run(capsys, "transverse", "sweep", "--model", model_file, "--amplitude",
                       "1,5,20,50", "--angles", "0:355:5", "--estimator", "peak", "--gravity",
                       "0", "--format", "csv")
    assert code == 0
    rows = list(csv.DictReader(io.StringIO(out)))
    assert out.splitlines()[0] == "amplitude_g,angle_deg,sT,sT_rel"
    assert len(rows) == 4 * 72
    amp = np.array([float(r["amplitude_g"]) for r in rows])
    ang = np.array([float(r["angle_deg"]) for r in rows])
    sT = np.array([float(r["sT"]) for r in rows])
    rel = np.array([float(r["sT_rel"]) for r in rows])
    th = np.deg2rad(ang[:72])
    for a in (1.0, 5.0, 20.0, 50.0):
        # the closed form of the peak definition; where the extreme lies inside
        # the period the samples (default 160 Hz at 10240 Hz) miss it by at most
        # K1 |C| (dx/2)^2 / A_v, dx = A_v w / fs (see test_transverse_closed)
        cf = tr.closed_form_sT(tr.GUANTANG_FIG4, th, a, "peak")
        dx = a * 2 * np.pi * 160.0 / 10240.0
        bound = 1000.0 * np.abs(tr.cross_axis_C(th, tr.GUANTANG_FIG4)) * (dx / 2) ** 2 / a
        assert np.all(np.abs(sT[amp == a] - cf) <= bound + 1e-12 * cf.max())
    # sT in mV/g, sT_rel a fraction of s_I = 1000.055 mV/g (GuanTang eq. (25))
    np.testing.assert_allclose(rel, sT / 1000.055, rtol=1e-12)


def test_sweep_json_same_keys_and_symmetric_axial(capsys, model_file):
    code, out, _ = run(capsys, "transverse", "sweep", "--model", model_file, "--amplitude", "5",
                       "--angles", "0:90:30", "--estimator", "fundamental", "--format", "json",
                       "--axial", "symmetric")
    assert code == 0
    data = json.loads(out)
    assert [list(d) for d in data] == [["amplitude_g", "angle_deg", "sT", "sT_rel"]] * 4
    b = 1000.0 * np.abs(tr.cross_axis_B(np.deg2rad([0, 30, 60, 90]), tr.GUANTANG_FIG4))
    np.testing.assert_allclose([d["sT"] for d in data], b, rtol=1e-12)
    np.testing.assert_allclose([d["sT_rel"] for d in data], b / 1000.0, rtol=1e-12)


def test_sweep_summary_and_gravity(capsys, model_file):
    code, out, _ = run(capsys, "transverse", "sweep", "--model", model_file, "--amplitude",
                       "1,50", "--estimator", "peak", "--summary", "--format", "csv")
    assert code == 0
    rows = list(csv.DictReader(io.StringIO(out)))
    assert [r["amplitude_g"] for r in rows] == ["1.0", "50.0"]
    assert rows[1]["local_maxima"] == "4"  # GuanTang section 4: four local maxima
    assert float(rows[0]["S_Tmin"]) > 0
    for key in ("S_Tmax", "theta_max_deg", "S_Tmin", "theta_min_deg", "estimator"):
        assert key in rows[0]
    code, out, _ = run(capsys, "transverse", "sweep", "--model", model_file, "--amplitude", "5",
                       "--angles", "0,90", "--gravity", "1", "--format", "json")
    data = json.loads(out)
    th = np.deg2rad([0, 90])
    expected = 1000.0 * np.abs(tr.cross_axis_B(th, tr.GUANTANG_FIG4)
                               + 2 * tr.cross_axis_C(th, tr.GUANTANG_FIG4))
    np.testing.assert_allclose([d["sT"] for d in data], expected, rtol=1e-12)


def test_sweep_plot_writes_png_and_svg(capsys, tmp_path, model_file):
    code, _, err = run(capsys, "transverse", "sweep", "--model", model_file, "--plot",
                       tmp_path / "plots", "--format", "csv", "--angles", "0:350:10")
    assert code == 0
    assert (tmp_path / "plots" / "transverse_polar.png").stat().st_size > 10_000
    assert (tmp_path / "plots" / "transverse_polar.svg").exists()
    assert "wrote" in err


def test_simulate_analyze_fit_round_trip(capsys, tmp_path, model_file):
    out_dir = tmp_path / "recs"
    code, out, _ = run(capsys, "transverse", "simulate", "--model", model_file, "--amplitude",
                       "5", "--angles", "0:330:30", "--gravity", "1", "--rest", "--noise",
                       "1e-6", "--seed", "3", "--transverse-ratio", "0.02",
                       "--transverse-direction", "90", "--measure-transverse", "--out", out_dir)
    assert code == 0
    assert len(list(out_dir.glob("*.csv"))) == 12
    meta, cols = read_record(next(out_dir.glob("*.csv")), "shaker")
    assert set(cols) == {"t", "ref", "u", "ref_n", "ref_ia", "u_rest"}
    assert meta["units"]["u"] == "mV"
    assert meta["units"]["ref"] == "g"
    code, out, _ = run(capsys, "transverse", "analyze", out_dir, "--estimator", "fundamental",
                       "--format", "csv")
    assert code == 0
    rows = list(csv.DictReader(io.StringIO(out)))
    assert len(rows) == 12
    th = np.deg2rad([float(r["angle_deg"]) for r in rows])
    expected = 1000.0 * np.abs(tr.cross_axis_B(th, tr.GUANTANG_FIG4)
                               + 2 * tr.cross_axis_C(th, tr.GUANTANG_FIG4))
    # 1e-6 g noise on 1024 samples: std of sT ~ 1000 * 1e-6 * sqrt(2/1024) / 5 = 9e-6 mV/g
    np.testing.assert_allclose([float(r["sT"]) for r in rows], expected, rtol=0, atol=6e-5)
    code, out, _ = run(capsys, "transverse", "fit", out_dir, "--route", "both", "--format",
                       "json")
    assert code == 0
    est = {d["coefficient"]: d for d in json.loads(out)}
    truth = tr.GUANTANG_FIG4
    for name in ("Ko", "Kp", "Koo", "Kpp", "Kop"):
        assert abs(est[name]["estimate"] - getattr(truth, name)) < 5 * est[name]["std"]
        assert est[name]["method"] == "transverse/both"


def test_one_record_file_and_python_round_trip(tmp_path):
    m = tr.GUANTANG_FIG4
    rec = ShakerRig(amplitude=2.0, periods=2.5).simulate(m, np.deg2rad([30.0]))
    write_records(rec, tmp_path / "one.csv")
    (back,) = read_records(tmp_path / "one.csv")
    np.testing.assert_array_equal(back.u, rec.u)  # %.17g round trip is exact
    np.testing.assert_array_equal(back.theta, rec.theta)
    many = ShakerRig(amplitude=2.0).simulate(m, np.deg2rad([0.0, 30.0]))
    with pytest.raises(Exception, match="one file"):
        write_records(many, tmp_path / "two.csv")
    assert not (tmp_path / "two.csv").exists()


def _bad(capsys, *args):
    code, _out, err = run(capsys, *args)
    assert code == 2
    assert err.startswith("accelcal: error: ")
    assert len(err.strip().splitlines()) == 1
    assert "Traceback" not in err
    return err


def test_bad_angles_outside_full_turn(capsys, tmp_path):
    assert "full turn" in _bad(capsys, "transverse", "sweep", "--angles", "0:360:5")
    assert "full turn" in _bad(capsys, "transverse", "sweep", "--angles", "-30,400")
    err = _bad(capsys, "transverse", "simulate", "--angles", "0:720:90", "--out", tmp_path / "x")
    assert "full turn" in err
    assert not (tmp_path / "x").exists()


def test_bad_fewer_than_three_angles_for_fit(capsys, tmp_path):
    run(capsys, "transverse", "simulate", "--angles", "0,90", "--out", tmp_path / "two")
    assert "at least 3" in _bad(capsys, "transverse", "fit", tmp_path / "two")


def test_bad_record_shorter_than_a_period(capsys, tmp_path):
    err = _bad(capsys, "transverse", "simulate", "--periods", "0.5", "--out", tmp_path / "s")
    assert "shorter than one period" in err
    assert not (tmp_path / "s").exists()
    # a file holding less than a period
    t = np.arange(20) / 10240.0
    meta = {"frequency_hz": 160.0, "sample_rate_hz": 10240.0, "angle_deg": 0.0,
            "amplitude_g": 1.0, "gravity_g": 0.0, "output_unit": "mV",
            "units": {"t": "s", "ref": "g", "u": "mV"}}
    write_record(tmp_path / "short.csv", "shaker", meta,
                 {"t": t, "ref": np.sin(2 * np.pi * 160 * t), "u": 0 * t})
    err = _bad(capsys, "transverse", "analyze", tmp_path / "short.csv", "--axial-sensitivity",
               "1000")
    assert "shorter than one period" in err


def test_bad_mismatched_channel_lengths(capsys, tmp_path):
    run(capsys, "transverse", "simulate", "--angles", "0:330:30", "--out", tmp_path / "d")
    # one record cut short: files of one amplitude with different lengths
    f = sorted((tmp_path / "d").glob("*.csv"))[3]
    meta, cols = read_record(f, "shaker")
    write_record(f, "shaker", meta, {k: v[:-7] for k, v in cols.items()})
    assert "equal length" in _bad(capsys, "transverse", "analyze", tmp_path / "d")
    # a row missing a channel value inside one file
    g = sorted((tmp_path / "d").glob("*.csv"))[0]
    lines = g.read_text().splitlines()
    lines[10] = lines[10].rsplit(",", 1)[0]
    g.write_text("\n".join(lines) + "\n")
    assert "values, expected" in _bad(capsys, "transverse", "fit", tmp_path / "d")


def test_bad_zero_reference_amplitude(capsys, tmp_path):
    t = np.arange(640) / 10240.0
    meta = {"frequency_hz": 160.0, "sample_rate_hz": 10240.0, "angle_deg": 0.0,
            "amplitude_g": 1.0, "gravity_g": 0.0, "output_unit": "mV",
            "units": {"t": "s", "ref": "g", "u": "mV"}}
    write_record(tmp_path / "z.csv", "shaker", meta,
                 {"t": t, "ref": 0 * t, "u": np.sin(2 * np.pi * 160 * t)})
    err = _bad(capsys, "transverse", "analyze", tmp_path / "z.csv", "--axial-sensitivity", "1")
    assert "reference amplitude is zero" in err
    assert "positive" in _bad(capsys, "transverse", "sweep", "--amplitude", "0,5")


def test_bad_options(capsys, model_file):
    assert "estimator" in _bad(capsys, "transverse", "sweep", "--estimator", "rms")
    assert "--axial" in _bad(capsys, "transverse", "sweep", "--axial", "eq19")
    assert "only one" in _bad(capsys, "transverse", "sweep", "--paper", "--model", model_file)


def test_linear_model_option(capsys):
    code, out, _ = run(capsys, "transverse", "sweep", "--linear", "1000,0.2,-0.1", "--angles",
                       "0,90", "--amplitude", "3", "--estimator", "half-p2p", "--format", "json")
    assert code == 0
    np.testing.assert_allclose([d["sT"] for d in json.loads(out)], [0.1, 0.2], rtol=1e-12)


def test_default_model_is_used_without_options(capsys):
    code, out, _ = run(capsys, "transverse", "sweep", "--angles", "90", "--amplitude", "2",
                       "--format", "json")
    assert code == 0
    from accelcal import default_model

    m: ErrorModel = default_model()
    assert json.loads(out)[0]["sT"] == pytest.approx(abs(m.K1 * m.Ko), rel=1e-12)
