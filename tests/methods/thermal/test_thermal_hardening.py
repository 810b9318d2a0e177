"""Bad input to ``accelcal thermal`` (issue 15 item 6): exit 2, one line, nothing written."""

import numpy as np
import pytest

from accelcal.io.formats import thermal as thermal_format
from helpers.cli import refused, run_cli

BASE = ["--points", "8", "--dwell", "20", "--warmup", "0"]


def _simulate(path, capsys, *args):
    code, _, err = run_cli(["thermal", "simulate", "--out", path, *BASE, *args], capsys)
    assert code == 0, err
    return path


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    from accelcal.cli import main

    path = tmp_path_factory.mktemp("h") / "th.csv"
    with pytest.raises(SystemExit):
        main(["thermal", "simulate", "--out", str(path), *BASE, "--setpoints",
              "-20,10,40,25,-5"])
    return path


def test_one_plateau(tmp_path, capsys):
    path = _simulate(tmp_path / "one.csv", capsys, "--setpoints", "40")
    refused(["thermal", "reduce", path], capsys, "1 plateau(s) with a tumble")


def test_two_plateaus_no_dof(tmp_path, capsys):
    path = _simulate(tmp_path / "two.csv", capsys, "--setpoints", "0,40")
    refused(["thermal", "reduce", path], capsys, "at least 3 plateaus")


def test_plateaus_that_never_settle(tmp_path, capsys):
    path = _simulate(tmp_path / "ns.csv", capsys, "--setpoints", "-20,20,50", "--soak", "600")
    refused(["thermal", "reduce", path], capsys, "never settled", "soak longer")


def test_order_too_high_and_bad_order(good, capsys):
    refused(["thermal", "reduce", good, "--order", "3"], capsys, "--order", "order 3 needs")
    refused(["thermal", "reduce", good, "--order", "4"], capsys, "--order")


def test_compensate_out_of_range_writes_nothing(good, tmp_path, capsys):
    comp, out = tmp_path / "c.json", tmp_path / "o.csv"
    code, _, _ = run_cli(["thermal", "reduce", good, "--order", "1", "--compensation", comp],
                         capsys)
    assert code == 0
    hot = tmp_path / "hot.csv"  # a second block-sized file is not needed: row 2 is refused
    hot.write_text("out,temperature\n1.3,20\n1.3,25\n1.3,95\n")
    refused(["thermal", "compensate", hot, "--model", comp, "--out", out, "--column", "out",
             "--temperature-unit", "degC", "--unit", "V"], capsys,
            "outside the compensation's valid range", "--allow-extrapolation", "data row 2")
    assert not out.exists()
    code, _, _ = run_cli(["thermal", "compensate", hot, "--model", comp, "--out", out,
                          "--column", "out", "--temperature-unit", "degC", "--unit", "V",
                          "--allow-extrapolation"], capsys)
    assert code == 0
    assert np.loadtxt(out, delimiter=",", skiprows=1)[:, -1].tolist() == [0.0, 0.0, 1.0]


def test_compensate_missing_temperature_column(good, tmp_path, capsys):
    comp, out = tmp_path / "c.json", tmp_path / "o.csv"
    run_cli(["thermal", "reduce", good, "--order", "1", "--compensation", comp], capsys)
    plain = tmp_path / "p.csv"
    plain.write_text("t,out\n0,1.3\n1,1.3\n")
    refused(["thermal", "compensate", plain, "--model", comp, "--out", out, "--column", "out",
             "--temperature-unit", "degC"], capsys, "no column temperature",
            "--temperature-column")
    refused(["thermal", "compensate", plain, "--model", comp, "--out", out, "--column", "out",
             "--temperature-column", "t"], capsys, "--temperature-unit")
    refused(["thermal", "compensate", plain, "--model", tmp_path / "none.json", "--out", out],
            capsys, "not found")
    assert not out.exists()


def test_compensate_model_without_temperature(good, tmp_path, capsys):
    model = tmp_path / "m.json"
    run_cli(["model", "new", "--out", model], capsys)
    refused(["thermal", "compensate", good, "--model", model, "--out", tmp_path / "o.csv"],
            capsys, "no temperature terms")


def test_simulate_bad_settings(tmp_path, capsys):
    out = tmp_path / "x.csv"
    refused(["thermal", "simulate", "--out", out, "--soak", "15"], capsys, "--soak")
    refused(["thermal", "simulate", "--out", out, "--setpoints", "-300"], capsys, "degC")
    refused(["thermal", "simulate", "--out", out, "--tau", "-1"], capsys, "--tau")
    refused(["thermal", "simulate", "--out", tmp_path / "no" / "x.csv"], capsys,
            "does not exist")
    assert not out.exists()


def test_corrupt_record(good, tmp_path, capsys):
    rec = thermal_format.read(good)
    bad = tmp_path / "bad.csv"
    thermal_format.write(bad, type(rec)(rec.t, rec.phase, rec.plateau, rec.angle_rad,
                                        rec.output, rec.temperature, rec.rotation_axis,
                                        rec.output_unit, rec.setpoints, rec.start,
                                        rec.chamber, rec.metadata))
    text = bad.read_text().splitlines()
    text[5] = text[5].replace(",", ",nan,", 1)
    bad.write_text("\n".join(text) + "\n")
    refused(["thermal", "reduce", bad], capsys, "bad.csv")
    assert np.isfinite(rec.output).all()
