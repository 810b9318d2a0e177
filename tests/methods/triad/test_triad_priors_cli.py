"""``triad calibrate --priors``: each axis's pendulous terms as Type B from the command line."""

import json

import numpy as np
import pytest

from accelcal.methods.triad.model import TriadCalibration
from helpers.cli import refused, run_cli

TRUTH = TriadCalibration([0.05, -0.08, 0.12], [1.01, 0.995, 1.02], [1e-3, -2e-3, 1.5e-3])
"""``triad simulate``'s default truth."""


@pytest.fixture(scope="module")
def pendulous(tmp_path_factory):
    # noise-free: six positions, every axis the embedded default accelerometer
    from accelcal.cli import main

    path = tmp_path_factory.mktemp("pend") / "six.csv"
    with pytest.raises(SystemExit) as exc:
        main([str(a) for a in ("triad", "simulate", "--out", path, "--axis-model", "default",
                               "--noise", "0", "--still", "1", "--dwell", "1", "--motion",
                               "0.5", "--rate", "10")])
    assert exc.value.code == 0
    return path


def _rows(capsys, path, tmp_path, *extra):
    code, out, err = run_cli(["triad", "calibrate", path, "--out", tmp_path / "cal.json",
                              "--format", "json", *extra], capsys)
    assert code == 0, err
    rows = json.loads(out)["coefficients"][:9]
    est = np.array([r["estimate"] for r in rows])
    std = np.array([r["std"] for r in rows])
    return est, std


def test_default_priors_intervals_hold_the_truth(pendulous, tmp_path, capsys):
    # measured: with the default priors every row within 1.31 SD; without (the triad's
    # default, none) the biases 2.9-3.3 SD off
    est, std = _rows(capsys, pendulous, tmp_path, "--priors", "default")
    assert np.all(np.abs(est - TRUTH.vector[:9]) <= 2 * std), np.abs(est - TRUTH.vector[:9]) / std
    est0, std0 = _rows(capsys, pendulous, tmp_path)
    assert np.any(np.abs(est0 - TRUTH.vector[:9]) > 2 * std0)
    assert np.all(std > std0)  # Type B added to every row the terms move (b, s)
    np.testing.assert_allclose(est, est0, rtol=1e-9, atol=1e-12)  # values untouched


def test_none_states_the_aliases_and_a_file_gives_own_priors(pendulous, tmp_path, capsys):
    record = tmp_path / "rec.json"
    code, out, err = run_cli(["triad", "calibrate", pendulous, "--out", tmp_path / "c.json",
                              "--record", record, "--serial", "T1"], capsys)
    assert code == 0, err
    assert "aliases listed" in out
    priors = tmp_path / "priors.json"
    priors.write_text(json.dumps({"K2": {"value": 1e-4, "distribution": "rectangular"},
                                  "Koo[y]": 2e-5}))
    _, std = _rows(capsys, pendulous, tmp_path, "--priors", str(priors))
    _, std_default = _rows(capsys, pendulous, tmp_path, "--priors", "default")
    assert std[0] > std_default[0]  # K2 bounded at 1e-4 g/g^2 against 1.6e-5
    _, std_items = _rows(capsys, pendulous, tmp_path, "--priors", "K2=1e-4")
    assert std_items[0] > std_default[0]


@pytest.mark.parametrize(("value", "word"), [("maybe", "priors"), ("K2=abc", "K2=abc"),
                                         ("Kxx=1e-5", "Kxx"), ("missing.json", "missing.json"),
                                         ("K2[w]=1e-5", "K2[w]"), ("K2=-1", "K2")])
def test_bad_priors_one_line(pendulous, tmp_path, capsys, value, word):
    refused(["triad", "calibrate", pendulous, "--out", tmp_path / "c.json", "--priors", value],
            capsys, word)
    assert not (tmp_path / "c.json").exists()


def test_bad_priors_file_one_line(pendulous, tmp_path, capsys):
    bad = tmp_path / "bad.json"
    for text in ("[1, 2]", "{not json", json.dumps({"K2": {"distribution": "normal"}})):
        bad.write_text(text)
        refused(["triad", "calibrate", pendulous, "--out", tmp_path / "c.json", "--priors",
                 bad], capsys, "bad.json")
