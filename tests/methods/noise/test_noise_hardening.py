"""Bad input to ``accelcal noise`` exits with status 2 and one line, and writes nothing.

Too short for the taus asked, a gap or time going backwards, a NaN (a gap
is refused, never averaged over: accelcal does not fill or skip samples),
a constant signal, a missing rate, bad options.
"""

import numpy as np
import pytest

from helpers.cli import refused


def _csv(path, columns, header):
    np.savetxt(path, np.column_stack(columns), delimiter=",", header=header, comments="")
    return path


@pytest.fixture
def files(tmp_path):
    rng = np.random.default_rng(0)
    y = rng.normal(size=1000)
    t = np.arange(1000) / 10.0
    gap = t.copy()
    gap[600:] += 5.0
    back = t.copy()
    back[500] = back[498]
    nan = y.copy()
    nan[321] = np.nan
    return {
        "good": _csv(tmp_path / "good.csv", [y], "acc"),
        "short": _csv(tmp_path / "short.csv", [y[:3]], "acc"),
        "gap": _csv(tmp_path / "gap.csv", [gap, y], "t,acc"),
        "back": _csv(tmp_path / "back.csv", [back, y], "t,acc"),
        "nan": _csv(tmp_path / "nan.csv", [y, nan], "x,acc"),
        "constant": _csv(tmp_path / "constant.csv", [np.full(1000, 0.5)], "acc"),
    }


RATE = ["--column", "acc", "--rate", "10", "--unit", "g"]
TIME = ["--column", "acc", "--time", "t", "--unit", "g"]


@pytest.mark.parametrize("command", ["adev", "fit", "psd"])
@pytest.mark.parametrize(("name", "opts", "words"), [
    ("short", RATE, ["samples"]),
    ("gap", TIME, ["gap"]),
    ("back", TIME, ["backwards"]),
    ("nan", RATE, ["acc", "gap"]),
    ("constant", RATE, ["constant"]),
    ("good", ["--column", "acc", "--unit", "g"], ["rate"]),
])
def test_bad_recordings(files, capsys, command, name, opts, words):  # noqa: PLR0917
    refused(["noise", command, files[name], *opts], capsys, *words)


@pytest.mark.parametrize(("name", "opts", "words"), [
    ("gap", TIME, ["gap"]),
    ("nan", RATE, ["acc"]),
    ("constant", RATE, ["constant"]),
])
def test_bad_recordings_in_memory_kinds(files, capsys, name, opts, words):
    refused(["noise", "adev", files[name], "--kind", "mdev", *opts], capsys, *words)


@pytest.mark.parametrize(("extra", "words"), [
    (["--taus", "1000"], ["--taus", "too long"]),
    (["--taus", "0.05"], ["--taus"]),
    (["--kind", "xdev"], ["--kind"]),
    (["--confidence", "1.5"], ["--confidence"]),
    (["--format", "xml"], ["--format"]),
])
def test_bad_adev_options(files, capsys, extra, words):
    refused(["noise", "adev", files["good"], *RATE, *extra], capsys, *words)


def test_fit_options(files, capsys):
    refused(["noise", "fit", files["good"], *RATE, "--terms", "N,X"], capsys, "--terms")
    refused(["noise", "fit", files["good"], *RATE, "--format", "csv"], capsys, "--format")
    refused(["noise", "fit", files["good"], *RATE, "--taus", "0.1,0.2", "--terms", "Q,N,B,K,R"],
            capsys, "--terms")


@pytest.mark.parametrize(("extra", "words"), [
    (["--N", "-1"], ["N"]),
    (["--N", "nan"], ["N"]),
    (["--duration", "0"], ["--duration"]),
    (["--duration", "1e13"], ["--duration"]),
    (["--unit", "furlong"], ["unit"]),
])
def test_bad_simulate(tmp_path, capsys, extra, words):
    out = tmp_path / "x.parquet"
    args = ["noise", "simulate", "--rate", "10", "--duration", "10", "--out", out]
    refused([*args, *extra], capsys, *words)
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []
