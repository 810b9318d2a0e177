"""``accelcal acceptance``: simulate -> reduce, rows, figures and one-line refusals."""

import json

import numpy as np
import pytest

from accelcal.io.formats import acceptance as steps_format
from helpers.cli import refused, run_cli


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    from accelcal.cli import main

    base = tmp_path_factory.mktemp("acc")
    out = {}
    for test in ("threshold", "resolution", "hysteresis"):
        out[test] = base / f"{test}.csv"
        with pytest.raises(SystemExit) as exc:
            main(["acceptance", "simulate", "--test", test, "--seed", "3", "--out",
                  str(out[test])])
        assert exc.value.code == 0
    return out


@pytest.mark.parametrize("test", ["threshold", "resolution"])
def test_reduce_gives_the_true_increment_in_ug(files, test, capsys):
    code, out, err = run_cli(["acceptance", "reduce", files[test], "--format", "json"], capsys)
    assert code == 0, err
    rows = json.loads(out)
    assert all(set(r) == {"quantity", "estimate", "std", "unit"} for r in rows)
    by = {r["quantity"]: r for r in rows}
    truth = steps_format.read(files[test]).metadata[f"true_{test}_g"] * 1e6
    assert by[test]["unit"] == "ug"
    assert by[test]["estimate"] == pytest.approx(truth, rel=1e-9)
    assert 0 <= by["error_probability"]["estimate"] < 0.05
    assert by["recommended_dwell"]["unit"] == "s"
    assert sum(q.startswith("response to") for q in by) == 9
    if test == "resolution":  # also as a fraction of the 0.5 g input at 30 deg
        assert by["resolution / input"]["unit"] == "ppm"
        assert by["resolution / input"]["estimate"] == pytest.approx(2 * truth, rel=1e-9)


def test_hysteresis_rows_per_point_and_figures(files, tmp_path, capsys):
    code, out, err = run_cli(["acceptance", "reduce", files["hysteresis"], "--format", "csv",
                              "--plot", tmp_path], capsys)
    assert code == 0, err
    lines = out.strip().splitlines()
    assert lines[0] == "quantity,estimate,std,unit"
    assert len(lines) == 1 + 11  # the points of a 15 deg cycle but the turning points
    mid = next(line for line in lines if line.startswith("hysteresis at +0 g"))
    value, std = (float(v) for v in mid.split(",")[1:3])
    assert abs(value - 20.0) < 5 * std  # the simulated 20 ug far from the turning points
    assert (tmp_path / "acceptance-hysteresis.png").is_file()


def test_threshold_figure_and_table(files, tmp_path, capsys):
    code, out, _ = run_cli(["acceptance", "reduce", files["threshold"], "--plot", tmp_path],
                           capsys)
    assert code == 0
    assert "threshold" in out
    assert (tmp_path / "acceptance-steps.svg").is_file()


def test_short_dwells_are_refused_with_the_dwell_that_decides(tmp_path, capsys):
    path = tmp_path / "short.csv"
    code, _, _ = run_cli(["acceptance", "simulate", "--dwell", "0.5", "--noise", "30",
                          "--out", path], capsys)
    assert code == 0
    err = refused(["acceptance", "reduce", path], capsys, "do not dwell long enough",
                  "dwell at least")
    assert "probability" in err


def test_too_few_samples_per_dwell_are_refused(files, capsys):
    refused(["acceptance", "reduce", files["threshold"], "--settle", "9.9"], capsys,
            "keeps 1 samples", "at least 3")


def test_a_cycle_with_a_missing_leg_is_refused(files, tmp_path, capsys):
    rec = steps_format.read(files["hysteresis"])
    keep = rec.input >= 0.0  # the cycle never goes negative: the down and up legs below 0 lost
    cut = steps_format.StepRecord(t=rec.t[keep], input=rec.input[keep],
                                  output=rec.output[keep], test="hysteresis",
                                  output_unit=rec.output_unit, scale_factor=rec.scale_factor)
    steps_format.write(tmp_path / "cut.csv", cut)
    # the dwells at 0 either side of the lost legs join: their time jump is a gap
    refused(["acceptance", "reduce", tmp_path / "cut.csv"], capsys, "inside dwell input 0",
            "--gaps split")
    refused(["acceptance", "reduce", tmp_path / "cut.csv", "--gaps", "split"], capsys,
            "a leg is missing")


def test_wrong_test_and_options_are_refused(files, capsys):
    refused(["acceptance", "reduce", files["threshold"], "--test", "hysteresis"], capsys,
            "threshold test, not hysteresis")
    refused(["acceptance", "reduce", files["threshold"], "--test", "range"], capsys,
            "threshold test, not range")
    refused(["acceptance", "simulate", "--test", "shock", "--out", "x.csv"], capsys, "--test")


def test_an_angle_only_recording_reads_as_sin_of_the_angle(files, tmp_path):
    rec = steps_format.read(files["threshold"])
    from accelcal.io.records import write_record

    write_record(tmp_path / "angle.csv", "steps",
                 {"units": {"t": "s", "angle": "deg", "output": "g"}, "test": "threshold",
                  "output_unit": "g", "scale_factor": 1.0},
                 {"t": rec.t, "angle": rec.angle, "output": rec.output})
    back = steps_format.read(tmp_path / "angle.csv")
    np.testing.assert_allclose(back.input, rec.input, rtol=1e-12, atol=1e-15)


def test_import_layout_keeps_the_input_in_g_and_the_output_in_its_unit():
    from accelcal.io.recordings.kinds import layout

    got = layout("steps", {"input": "A", "output": "U"}, {"A": "mg", "U": "V"}, 10.0)
    assert got.units == {"input": "g", "output": "V", "t": "s"}
    assert got.factors["input"] == 1e-3
    assert got.metadata == {"output_unit": "V"}


def test_a_lab_recording_imports_as_steps_and_reduces(files, tmp_path, capsys):
    rec = steps_format.read(files["threshold"])
    lab = tmp_path / "lab.csv"
    np.savetxt(lab, np.c_[rec.t, rec.angle, 2.5 * rec.output], delimiter=",",
               header="time,tilt,volts", comments="", fmt="%.17g")
    mapping = tmp_path / "steps.toml"
    mapping.write_text('kind = "steps"\ntime = "time"\nunit = "V"\n[channels]\n'
                       'angle = { channel = "tilt", unit = "deg" }\noutput = "volts"\n'
                       '[metadata]\ntest = "threshold"\nscale_factor = 2.5\n')
    code, _, err = run_cli(["import", lab, "--mapping", mapping, "--out", tmp_path / "s.csv"],
                           capsys)
    assert code == 0, err
    code, out, err = run_cli(["acceptance", "reduce", tmp_path / "s.csv", "--format", "json"],
                             capsys)
    assert code == 0, err
    got = json.loads(out)[0]
    assert got["quantity"] == "threshold"
    assert got["estimate"] == pytest.approx(rec.metadata["true_threshold_g"] * 1e6, rel=1e-6)


@pytest.mark.parametrize("test", ["resolution", "hysteresis"])
def test_the_python_path_gives_the_rows_of_the_command(files, test, capsys):
    from accelcal.methods import acceptance

    rows = acceptance.quantity_rows(acceptance.reduce(files[test], settle=1.0))
    code, out, err = run_cli(["acceptance", "reduce", files[test], "--settle", "1",
                              "--format", "json"], capsys)
    assert code == 0, err
    printed = json.loads(out)
    assert [r["quantity"] for r in printed] == [r["quantity"] for r in rows]
    np.testing.assert_allclose([r["estimate"] for r in printed], [r["estimate"] for r in rows],
                               rtol=1e-12)
