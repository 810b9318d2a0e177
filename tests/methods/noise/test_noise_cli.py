"""``accelcal noise``: adev, fit, psd, simulate and stability on the command line."""

import csv
import io
import json

import numpy as np
import pytest

from accelcal.io.formats import noise as noise_format
from helpers.cli import run_cli


@pytest.fixture
def still(tmp_path, capsys):
    path = tmp_path / "still.parquet"
    code, out, err = run_cli(["noise", "simulate", "--N", "2e-5", "--B", "3e-6", "--K", "2e-7",
                              "--rate", "100", "--duration", "400", "--seed", "4",
                              "--serial", "SN-7", "--out", path], capsys)
    assert code == 0, err
    assert "40000 samples" in out
    return path


def test_simulate_writes_a_parquet_noise_record(still):
    rec = noise_format.read(still)
    assert rec.samples == 40000
    assert rec.rate == 100.0
    assert rec.unit == "g"
    assert rec.metadata["true"]["N"] == 2e-5
    assert rec.metadata["serial"] == "SN-7"
    assert still.read_bytes()[:4] == b"PAR1"


def test_adev_csv_header_and_values(still, capsys):
    code, out, err = run_cli(["noise", "adev", still, "--format", "csv"], capsys)
    assert code == 0, err
    rows = list(csv.reader(io.StringIO(out)))
    assert rows[0] == ["tau_s", "n", "alpha", "dev", "dev_low", "dev_high"]
    first = [float(v) for v in rows[1]]
    assert first[0] == 0.01
    assert first[1] == 39999
    assert first[4] < first[3] < first[5]
    # white noise at tau0: ADEV = N / sqrt(tau0) = 2e-4 g (to a few %)
    assert first[3] == pytest.approx(2e-4, rel=0.03)


def test_adev_other_kinds_and_taus(still, capsys, tmp_path):
    code, out, err = run_cli(["noise", "adev", still, "--kind", "mdev", "--taus", "0.1,1,10",
                              "--format", "json", "--plot", tmp_path / "fig"], capsys)
    assert code == 0, err
    rows = json.loads(out)
    assert [r["tau_s"] for r in rows] == [0.1, 1.0, 10.0]
    assert (tmp_path / "fig" / "noise_mdev.png").exists()


def test_fit_json_keys_and_units(still, capsys, tmp_path):
    code, out, err = run_cli(["noise", "fit", still, "--terms", "N,B,K", "--format", "json",
                              "--plot", tmp_path / "fig"], capsys)
    assert code == 0, err
    doc = json.loads(out)
    assert doc["unit"] == "g"
    for t in ("N", "B", "K"):
        assert f"{t}_std" in doc
        assert doc[f"{t}_std"] > 0
    assert "Q" not in doc
    assert abs(doc["N"] - 2e-5) < 4 * doc["N_std"]
    units = [r["unit"] for r in doc["navigation"]["N"]]
    assert units == ["ug/sqrt(Hz)", "(m/s)/sqrt(h)"]
    assert doc["navigation"]["N"][0]["value"] == pytest.approx(doc["N"] * 1e6)
    assert (tmp_path / "fig" / "noise_adev.svg").exists()
    assert (tmp_path / "fig" / "noise_psd.svg").exists()


def test_psd_csv(still, capsys):
    code, out, err = run_cli(["noise", "psd", still, "--terms", "N", "--format", "csv"], capsys)
    assert code == 0, err
    rows = list(csv.DictReader(io.StringIO(out)))
    assert list(rows[0]) == ["frequency_hz", "psd", "level_N"]
    level = float(rows[0]["level_N"])
    assert level == pytest.approx(2 * (2e-5) ** 2, rel=0.02)  # one-sided 2 N^2
    assert np.median([float(r["psd"]) for r in rows]) == pytest.approx(level, rel=0.15)


def test_records_store_and_stability(tmp_path, capsys):
    db = tmp_path / "records.sqlite"
    for seed in range(3):
        path = tmp_path / f"run{seed}.csv"
        code, _, err = run_cli(["noise", "simulate", "--N", "2e-5", "--B", "3e-6",
                                "--bias", str(1e-4 * seed), "--rate", "50", "--duration", "200",
                                "--seed", seed, "--serial", "SN-9", "--out", path], capsys)
        assert code == 0, err
        rec = tmp_path / f"run{seed}.json"
        code, _, err = run_cli(["noise", "fit", path, "--terms", "N,B", "--record", rec], capsys)
        assert code == 0, err
        code, _, err = run_cli(["records", "add", rec, "--db", db], capsys)
        assert code == 0, err
    code, out, err = run_cli(["noise", "stability", "--serial", "SN-9", "--db", db,
                              "--format", "json"], capsys)
    assert code == 0, err
    rows = {r["coefficient"]: r for r in json.loads(out)}
    # the run means are 0, 1e-4, 2e-4 g plus noise: their SD is ~1e-4 g, 2 dof
    assert rows["bias_repeatability"]["estimate"] == pytest.approx(1e-4, rel=0.1)
    assert rows["bias_repeatability"]["dof"] == 2
    assert rows["B_in_run"]["estimate"] > 0


def test_fit_record_needs_serial_for_a_plain_csv(tmp_path, capsys):
    path = tmp_path / "plain.csv"
    y = np.random.default_rng(0).normal(size=5000)
    np.savetxt(path, y, header="acc", comments="")
    code, _, err = run_cli(["noise", "fit", path, "--column", "acc", "--rate", "10", "--unit",
                            "g", "--record", tmp_path / "r.json"], capsys)
    assert code == 2
    assert "--serial" in err
    code, _, err = run_cli(["noise", "fit", path, "--column", "acc", "--rate", "10", "--unit",
                            "g", "--record", tmp_path / "r.json", "--serial", "X1"], capsys)
    assert code == 0, err
    assert json.loads((tmp_path / "r.json").read_text())["serial"] == "X1"
