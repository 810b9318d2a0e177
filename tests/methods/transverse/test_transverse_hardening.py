"""Hardening of the transverse commands (issue 11): sizes, silently accepted input,
extreme values in shaker files, seeds, and the coverage of the default uncertainties."""

import json
import time

import numpy as np
import pytest

from accelcal.defaults import default_model
from accelcal.errors import AccelcalError
from accelcal.methods.transverse import check_angles, identify
from accelcal.rigs.shaker import ShakerRig
from helpers.cli import refused, run_cli


@pytest.mark.parametrize("args", [
    ["--sample-rate", "1e12"], ["--periods", "1e9"], ["--angles", "0:355:5", "--periods", "2e7"],
])
def test_sizes_refused_before_allocating_with_the_memory_needed(args, tmp_path, capsys):
    out = tmp_path / "records"
    start = time.perf_counter()
    refused(["transverse", "simulate", "--out", out, *args], capsys, "would need about")
    assert time.perf_counter() - start < 5.0
    assert not out.exists()


def test_stacked_trials_are_checked_too():
    rig = ShakerRig(amplitude=5.0, periods=1000.0)
    with pytest.raises(AccelcalError, match="would need about"):
        rig.simulate(default_model(), np.zeros(12), rng=np.random.default_rng(0), trials=10**9)


@pytest.mark.parametrize(("args", "words"), [
    (["--seed", "-1"], ["--seed", "integer >= 0"]),
    (["--angles", "-30"], ["-30 deg", "330 deg"]),
    (["--angles", "0,360"], ["360 deg", "0 deg"]),
    (["--transverse-ratio", "-1"], ["--transverse-ratio", "negative"]),
    (["--amplitude", "1e200"], ["--amplitude", "1e+06 g"]),
    (["--noise", "1e308"], ["--noise"]),
    (["--gravity", "-1e200"], ["--gravity", "1e+06 g"]),
    (["--transverse-ratio", "1e200"], ["--transverse-ratio", "1e+06 g"]),
    (["--amplitude", "9e5", "--gravity", "2e5"], ["--amplitude", "peak specific force"]),
    (["--ref-noise", "1e200"], ["--ref-noise"]),
    (["--sample-rate", "2e9", "--frequency", "1e8", "--periods", "1"], ["--sample-rate"]),
])
def test_simulate_refuses_non_physical_values(args, words, tmp_path, capsys):
    out = tmp_path / "records"
    refused(["transverse", "simulate", "--out", out, *args], capsys, *words)
    assert not out.exists()


@pytest.mark.parametrize("args", [["--amplitude", "1e200"], ["--gravity", "1e200"]])
def test_specific_forces_are_checked_by_the_rig_naming_its_options(args, tmp_path, capsys):
    """Not by the model, whose inputs a_i, a_o, a_p are options of `model eval` only."""
    for command in (["transverse", "simulate", "--out", tmp_path / "r"],
                    ["transverse", "sweep", "--angles", "0,90"]):
        err = refused([*command, *args], capsys, args[0])
        for model_input in ("--ai", "--ao", "--ap", "a_i", "a_o", "a_p"):
            assert model_input not in err, err
    with pytest.raises(AccelcalError, match="amplitude") as exc:
        ShakerRig(amplitude=2e6)
    assert exc.value.parameter == "amplitude"


def test_simulated_records_give_simulated_calibration_records(tmp_path, capsys):
    from accelcal.io.formats.shaker import read_records

    data, rec = tmp_path / "shaker", tmp_path / "cal.json"
    code, _, err = run_cli(["transverse", "simulate", "--out", data, "--seed", "3"], capsys)
    assert code == 0, err
    assert read_records(data)[0].metadata["simulated"] is True
    code, _, err = run_cli(["transverse", "fit", data, "--record", rec, "--serial", "SN-1"],
                           capsys)
    assert code == 0, err
    doc = json.loads(rec.read_text())
    assert doc["simulated"] is True
    assert any("simulated data" in n for n in doc["notes"])


def test_sweep_checks_the_seed_even_without_noise(capsys):
    refused(["transverse", "sweep", "--seed", "-1"], capsys, "--seed")


def test_angles_are_directions_in_one_turn():
    np.testing.assert_allclose(check_angles([0, 90, 359.5]), np.radians([0, 90, 359.5]))
    with pytest.raises(AccelcalError, match="the direction 330 deg"):
        check_angles([-30])


@pytest.fixture
def records(tmp_path, capsys):
    out = tmp_path / "records"
    code, _, err = run_cli(["transverse", "simulate", "--out", out, "--seed", "1", "--gravity",
                            "1", "--rest", "--measure-transverse", "--periods", "4"], capsys)
    assert code == 0, err
    return out


def _mutate(path, *, key=None, column=None, value=1e308):
    lines = path.read_text().splitlines()
    if key is not None:
        meta = json.loads(lines[1][2:])
        meta[key] = value
        lines[1] = "# " + json.dumps(meta)
    else:
        names = lines[2].split(",")
        cells = lines[7].split(",")
        cells[names.index(column)] = repr(value)
        lines[7] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize("where", [
    {"key": "gravity_g"}, {"key": "amplitude_g"}, {"key": "scale_factor"},
    {"key": "frequency_hz"}, {"key": "scale_factor", "value": 1e-300},
    {"column": "u"}, {"column": "ref"}, {"column": "u_rest"}, {"column": "ref_ia"},
    {"column": "u", "value": -1e308},
])
@pytest.mark.parametrize("command", [["analyze"], ["fit"], ["fit", "--route", "both"]])
def test_extreme_values_in_a_shaker_file_give_one_line(records, where, command, capsys):
    _mutate(sorted(records.glob("*.csv"))[1], **where)
    refused(["transverse", *command, records, "--format", "json"], capsys,
            "beyond any physical value")


def test_identify_never_returns_non_finite_results():
    rig = ShakerRig(amplitude=5.0, periods=4.0, noise=1e-6)
    rec = rig.simulate(default_model(), np.radians(np.arange(0.0, 360.0, 30.0)),
                       rng=np.random.default_rng(2))
    from dataclasses import replace

    with pytest.raises(AccelcalError, match="not finite"):
        identify(replace(rec, u=rec.u * 1e160))


# ------------------------------------------------------------------ coverage
@pytest.mark.slow
def test_default_settings_cover_95_percent():
    """`transverse simulate` + `transverse fit` at their defaults, 400 experiments: the stated
    95 % interval (k = 1.96; the weights come from sine fits with ~2,000 dof each) covers
    0.93-0.97 of the true values, widened by 1.5 standard errors of the coverage (0.011).

    Measured (1,000 experiments through the record files): Ko 0.957, Kp 0.957, Koo 0.960,
    Kpp 0.951, Kop 0.955; SD of the z-scores 0.96-1.01."""
    model = default_model()
    theta = np.radians(np.arange(0.0, 331.0, 30.0))
    names = ("Ko", "Kp", "Koo", "Kpp", "Kop")
    rig = ShakerRig(amplitude=5.0)  # the CLI's defaults: 160 Hz, 10240 Hz, 16 periods
    z = {n: [] for n in names}
    for seed in range(400):
        red = identify(rig.simulate(model, theta, rng=np.random.default_rng(seed)))
        for n in names:
            z[n].append((red.value(n) - getattr(model, n)) / red.estimate.std_of(n))
    for n in names:
        cover = np.mean(np.abs(z[n]) <= 1.96)
        assert 0.914 <= cover <= 0.986, (n, cover)
        assert 0.85 <= np.std(z[n], ddof=1) <= 1.15, n
