"""``noise fit --export kalibr|ros``: the IMU noise YAML visual-inertial estimators read.

Read back with a YAML parser (PyYAML): the keys of Kalibr's imu.yaml, N and K
converted to SI (m/s^2/sqrt(Hz), m/s^3/sqrt(Hz)) from the fit, the record's
rate as update_rate, the inflation advice in a comment (issue 28, item 4).
"""

import json

import pytest
import yaml

from accelcal.methods.noise import fit
from accelcal.methods.noise.export import noise_yaml
from accelcal.rigs.noise import simulate
from accelcal.units import STANDARD_GRAVITY
from helpers.cli import run_cli


@pytest.fixture
def still(tmp_path, capsys):
    path = tmp_path / "still.parquet"
    code, _, err = run_cli(["noise", "simulate", "--N", "2e-5", "--K", "2e-6", "--rate", "200",
                            "--duration", "600", "--seed", "5", "--unit", "g", "--out",
                            str(path)], capsys)
    assert code == 0, err
    return path


@pytest.mark.parametrize("layout", ["kalibr", "ros"])
def test_export_reads_back_in_si(still, tmp_path, capsys, layout):
    out = tmp_path / "imu.yaml"
    code, text, err = run_cli(["noise", "fit", str(still), "--format", "json", "--export",
                               layout, "--export-out", str(out)], capsys)
    assert code == 0, err
    doc = json.loads(text)
    data = yaml.safe_load(out.read_text())
    if layout == "ros":
        data = data["imu0"]
    assert data["accelerometer_noise_density"] == pytest.approx(doc["N"] * STANDARD_GRAVITY,
                                                                rel=1e-6)
    assert data["accelerometer_random_walk"] == pytest.approx(doc["K"] * STANDARD_GRAVITY,
                                                              rel=1e-6)
    assert data["update_rate"] == pytest.approx(200.0)
    assert data["rostopic"] == "/imu0"
    # the simulated truth, 2e-5 g sqrt(s), in m/s^2/sqrt(Hz)
    assert data["accelerometer_noise_density"] == pytest.approx(2e-5 * STANDARD_GRAVITY,
                                                                rel=0.02)
    assert "inflat" in out.read_text()


def test_export_refuses_what_it_cannot_write(still, tmp_path, capsys):
    out = str(tmp_path / "x.yaml")
    for args, word in [(["--export", "vins", "--export-out", out], "kalibr, ros"),
                       (["--export", "kalibr"], "--export-out"),
                       (["--export", "kalibr", "--export-out", out, "--terms", "N,B"], "N and K")]:
        code, _, err = run_cli(["noise", "fit", str(still), *args], capsys)
        assert code == 2
        assert word in err
        assert "Traceback" not in err
    rec = simulate(N=2e-5, K=4e-7, rate=50.0, duration=120.0, seed=2, unit="V")
    red = fit(rec.values[:, 0], rec.rate, terms="N,K", unit="V", psd=False)
    with pytest.raises(Exception, match="no SI value"):
        noise_yaml(red)
