"""Magnetic sensitivity in Helmholtz coils: rig, reduction, record file, command."""

import json

import numpy as np
import pytest
from scipy import stats

from accelcal.errors import AccelcalError
from accelcal.io.formats import acceptance as steps_format
from accelcal.methods import acceptance
from accelcal.rigs.acceptance_env import simulate_magnetic
from helpers.cli import refused, run_cli

TRUTH = np.array([20e-6, -5e-6, 8e-6])


def test_noise_free_truth_recovered():
    red = acceptance.reduce(simulate_magnetic(TRUTH, noise=1e-12, seed=0))
    assert red.method == "acceptance/magnetic"
    np.testing.assert_allclose(red.estimate.values, TRUTH, atol=1e-12)


def test_least_squares_slope_and_its_sd_against_closed_form():
    """Fields +-1, +-0.5 per axis, four zeros: slope SD = se / (K1 sqrt(sum B^2))."""
    rec = simulate_magnetic(TRUTH, scale_factor=2.0, dwell=10.0, rate=10.0, seed=3)
    red = acceptance.reduce(rec)
    se = red.observations["dwell_se"][0]
    expected = se / 2.0 / np.sqrt(2 * (1.0 + 0.25))
    np.testing.assert_allclose(red.estimate.std, expected, rtol=0.02)
    assert red.dof == 16 * 99  # 16 dwells of 100 samples, pooled
    rows = acceptance.quantity_rows(red)
    assert [r["unit"] for r in rows] == ["ug/mT"] * 3
    assert rows[0]["quantity"] == "magnetic sensitivity (x, IA)"
    assert rows[1]["estimate"] == pytest.approx(-5.0, abs=5 * rows[1]["std"])


def test_record_round_trip_and_bad_records(tmp_path):
    rec = simulate_magnetic(TRUTH, seed=1)
    path = tmp_path / "mag.csv"
    steps_format.write(path, rec)
    back = steps_format.read(path)
    np.testing.assert_array_equal(back.field, rec.field)
    assert back.test == "magnetic"
    assert back.metadata["true_sensitivity_g_per_mT"] == pytest.approx(TRUTH.tolist())
    with pytest.raises(AccelcalError, match="field_x"):
        steps_format.StepRecord(t=[0, 1, 2], input=[0, 0, 0], output=[0, 0, 0],
                                test="magnetic", output_unit="V", scale_factor=1.0)
    one_axis = simulate_magnetic(TRUTH, seed=1)
    field = np.array(one_axis.field)
    field[:, 2] = 0.0
    flat = steps_format.StepRecord(t=one_axis.t, input=one_axis.input, output=one_axis.output,
                                   test="magnetic", output_unit="V", scale_factor=1.25,
                                   field=field)
    with pytest.raises(AccelcalError, match="no field along axis z, OA"):
        acceptance.reduce(flat)


def test_cli_simulate_reduce_plot_and_bad_input(tmp_path, capsys):
    out = tmp_path / "mag.csv"
    code, _, err = run_cli(["acceptance", "simulate", "--test", "magnetic", "--out", out,
                            "--sensitivity", "20,-5,8", "--seed", "4"], capsys)
    assert code == 0, err
    code, text, err = run_cli(["acceptance", "reduce", out, "--format", "json", "--plot",
                               tmp_path / "figs"], capsys)
    assert code == 0, err
    rows = json.loads(text)
    for row, truth in zip(rows, (20.0, -5.0, 8.0), strict=True):
        assert abs(row["estimate"] - truth) < 5 * row["std"]
    assert (tmp_path / "figs" / "acceptance-magnetic.png").is_file()
    refused(["acceptance", "simulate", "--test", "magnetic", "--out", out, "--fields", "0"],
            capsys, "fields")
    refused(["acceptance", "simulate", "--test", "magnetic", "--out", out,
             "--sensitivity", "1,2"], capsys, "sensitivity")
    refused(["acceptance", "reduce", out, "--test", "threshold"], capsys, "magnetic")


@pytest.mark.slow
def test_coverage_of_the_stated_uncertainty():
    """400 runs: SD ratio near 1 and the 95 % t intervals cover 0.93-0.97 per axis."""
    n = 400
    err, std = np.empty((n, 3)), np.empty((n, 3))
    for seed in range(n):
        red = acceptance.reduce(simulate_magnetic(TRUTH, dwell=2.0, seed=seed))
        err[seed], std[seed] = red.estimate.values - TRUTH, red.estimate.std
        dof = red.dof
    k = stats.t.ppf(0.975, dof)
    covered = (np.abs(err) <= k * std).mean(axis=0)
    ratio = err.std(axis=0, ddof=1) / np.sqrt(np.mean(std**2, axis=0))
    assert np.all((covered >= 0.93) & (covered <= 0.97)), covered
    assert np.all(np.abs(ratio - 1.0) < 0.12), ratio


def test_cli_specification_limits_the_sensitivity_in_ug_per_gauss(tmp_path, capsys):
    out, spec = tmp_path / "mag.csv", tmp_path / "spec.toml"
    spec.write_text('title = "magnetic"\n[[limit]]\nquantity = "magnetic sensitivity"\n'
                    'lower = -1.0\nupper = 1.0\nunit = "ug/G"\n')
    assert run_cli(["acceptance", "simulate", "--test", "magnetic", "--out", out,
                    "--sensitivity", "20,-5,1", "--seed", "4"], capsys)[0] == 0
    code, text, err = run_cli(["acceptance", "reduce", out, "--spec", spec, "--format",
                               "json"], capsys)
    assert code == 0, err
    rows = json.loads(text)
    # 1 ug/G = 10 ug/mT: 20 ug/mT is outside, -5 and 1 ug/mT inside
    assert [r["decision"] for r in rows] == ["reject", "accept", "accept"]
