"""Before/after an environment: the simulated pair of calibrations and its comparison."""

import json
import math

import numpy as np
import pytest

from accelcal.errors import AccelcalError
from accelcal.methods.acceptance import compare
from accelcal.methods.acceptance.environment import simulate_pair as simulate_environment
from accelcal.rigs.acceptance_env import parse_shift
from helpers.cli import refused, run_cli

LEVEL = 0.05


def test_parse_shift_units_and_bad_input():
    assert parse_shift("K0=30ug, K1=50ppm,K2=-2mg") == pytest.approx(
        {"K0": 30e-6, "K1": 50e-6, "K2": -2e-3})
    assert parse_shift("") == {}
    for bad in ("K9=1ug", "K1=3ug", "K0=5ppm", "K0=xug", "K0=1", "K0=1g"):
        with pytest.raises(AccelcalError):
            parse_shift(bad)


def test_pair_is_one_serial_two_dates_and_the_truth_in_the_notes():
    before, after = simulate_environment(parse_shift("K0=30ug"), serial="SN-9", seed=2)
    assert before.serial == after.serial == "SN-9"
    assert before.method == after.method == "tumble/fourier"
    assert before.date < after.date
    assert before.simulated
    assert after.simulated
    assert before.dof
    assert after.dof
    assert any("true shift" in n and "K0=3e-05" in n for n in after.notes)
    # independent noise: the two calibrations differ even where nothing shifted
    i = before.names.index("K3")
    assert before.estimates[i] != after.estimates[i]


def _rows(shift, seed):
    before, after = simulate_environment(shift, seed=seed)
    return {r["quantity"]: r for r in compare(before, after)}


def test_noise_free_shift_is_recovered():
    """Almost no noise: the shift found is the shift applied."""
    before, after = simulate_environment(parse_shift("K0=30ug,K1=50ppm"), noise=1e-9, seed=1)
    rows = {r["quantity"]: r for r in compare(before, after)}
    assert rows["K0+Kpp"]["estimate"] == pytest.approx(30.0, abs=0.01)
    assert rows["K0+Kpp"]["unit"] == "ug"
    assert rows["K1"]["estimate"] == pytest.approx(50.0, abs=0.01)
    assert rows["K1"]["unit"] == "ppm"


def test_cli_end_to_end_detects_five_combined_sd(tmp_path, capsys):
    u = _rows({}, 0)
    shift = f"K0={5 * u['K0+Kpp']['std']:.3f}ug,K1={5 * u['K1']['std']:.3f}ppm"
    out = tmp_path / "env.json"
    code, text, err = run_cli(["acceptance", "simulate", "--test", "environment", "--shift",
                               shift, "--out", out, "--seed", "7"], capsys)
    assert code == 0, err
    before, after = tmp_path / "env-before.json", tmp_path / "env-after.json"
    assert str(before) in text
    assert str(after) in text
    code, text, err = run_cli(["acceptance", "compare", before, after, "--format", "json"],
                              capsys)
    assert code == 0, err
    rows = {r["quantity"]: r for r in json.loads(text)}
    for name in ("K0+Kpp", "K1"):
        assert rows[name]["statistic"] == "t"
        assert rows[name]["p"] < LEVEL
        assert rows[name]["exceeds"] is True
    assert rows["K3"]["estimate"] == pytest.approx(0.0, abs=5 * rows["K3"]["std"])


def test_cli_environment_bad_input(tmp_path, capsys):
    out = tmp_path / "env.json"
    refused(["acceptance", "simulate", "--test", "environment", "--shift", "K9=1ug",
             "--out", out], capsys, "K9")
    refused(["acceptance", "simulate", "--test", "environment", "--shift", "K1=1ug",
             "--out", out], capsys, "ppm")
    refused(["acceptance", "simulate", "--test", "environment", "--out",
             tmp_path / "missing" / "env.json"], capsys, "does not exist")
    refused(["acceptance", "reduce", out, "--test", "environment"], capsys, "environment")


@pytest.mark.slow
def test_false_alarm_rate_equals_the_level_and_power_at_five_sd():
    """400 unshifted pairs: p < 0.05 in 5 % of them (binomial 3 SD); 5 SD shifts: found."""
    n = 400
    alarms = {"K0+Kpp": 0, "K1": 0}
    for seed in range(n):
        rows = _rows({}, seed)
        for name in alarms:
            alarms[name] += rows[name]["p"] < LEVEL
    band = 3 * math.sqrt(LEVEL * (1 - LEVEL) / n)
    for name, count in alarms.items():
        assert abs(count / n - LEVEL) < band, (name, count / n)
    u = _rows({}, 0)
    shift = {"K0": 5 * u["K0+Kpp"]["std"] * 1e-6, "K1": 5 * u["K1"]["std"] * 1e-6}
    found = np.array([[r["p"] < LEVEL for r in (rows["K0+Kpp"], rows["K1"])]
                      for rows in (_rows(shift, 1000 + s) for s in range(100))])
    assert found.mean(axis=0).min() >= 0.97
