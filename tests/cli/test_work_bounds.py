"""Every option that sets work is estimated and refused past its bound, with the
figure and --force; --force runs it (the bounds are lowered here so that the runs
stay short: the estimate is what is tested, not an hour of work)."""

import pytest

from accelcal import work
from helpers.cli import refused, run_cli
from helpers.paths import EXAMPLES


@pytest.fixture
def tiny_bound(monkeypatch):
    """An hour becomes a nanosecond: any run with a second task is 'too long'."""
    monkeypatch.setattr(work, "MAX_SECONDS", 1e-9)


def test_absurd_trials_are_refused_with_the_estimate(capsys):
    err = refused(["vre", "fit", EXAMPLES / "vibrafuge.csv", "--uncertainty", "mc", "--trials",
                   "1000000000000"], capsys,
                  "--trials", "1,000,000,000,000 trials would take about", "the bound is 1 h",
                  "--force")
    assert "years" in err or "days" in err


def test_mc_uncertainty_trials_bounded_and_forced(tiny_bound, capsys):
    # Two tasks of the engine: the first is timed, the second is "too long".
    args = ["vre", "fit", EXAMPLES / "vibrafuge.csv", "--uncertainty", "mc", "--trials",
            "16385", "--format", "json"]
    refused(args, capsys, "--trials", "16,385 trials would take", "--force")
    code, out, err = run_cli([*args, "--force"], capsys)
    assert code == 0, err
    assert "mc_std" in out


def test_study_trials_bounded_and_forced(tiny_bound, capsys):
    args = ["dividing-head", "study", "--trials", "32769", "--positions", "8", "--format",
            "json"]
    refused(args, capsys, "--trials", "32,769 trials would take", "--force")
    code, out, err = run_cli([*args, "--force"], capsys)
    assert code == 0, err
    assert "rms_error" in out


def test_taus_bounded_and_forced(monkeypatch, capsys):
    from accelcal.signal.allan import taus

    monkeypatch.setattr(taus, "MAX_SECONDS", 1e-9)
    args = ["noise", "adev", EXAMPLES / "still.csv", "--taus", "decade", "--format", "json"]
    refused(args, capsys, "--taus", "taus of", "the bound is", "--force")
    code, _, err = run_cli([*args, "--force"], capsys)
    assert code == 0, err


def test_simulated_samples_bounded_by_time_and_disk(tiny_bound, tmp_path, capsys):
    out = tmp_path / "n.csv"
    args = ["noise", "simulate", "--out", out, "--rate", "100", "--duration", "10", "--N",
            "1e-5"]
    refused(args, capsys, "--duration", "1e+03 samples of CSV would take", "--force")
    assert not out.exists()
    code, _, err = run_cli([*args, "--force"], capsys)
    assert code == 0, err
    assert out.exists()
    # Far more than any disk: refused with the figure, --force or not.
    refused(["noise", "simulate", "--out", tmp_path / "big.csv", "--rate", "1e6", "--duration",
             "1e4", "--force"], capsys, "--duration", "1e+10 samples of CSV would write about",
            "free")


def test_a_long_run_prints_plain_progress_lines_off_a_terminal(monkeypatch, capsys):
    """Standard error not a terminal (a pipe, a log): after 10 s, a line every 10 s."""
    from types import SimpleNamespace

    from accelcal.cli import progress as module

    now = [0.0]
    monkeypatch.setattr(module, "time", SimpleNamespace(monotonic=lambda: now[0]))
    with module.DelayedProgress("Monte Carlo trials") as bar:
        for t, done in [(1, 10), (9, 90), (12, 120), (15, 150), (23, 230)]:
            now[0] = t
            bar(done, 1000)
    lines = capsys.readouterr().err.splitlines()
    assert lines == [
        ("accelcal: progress: Monte Carlo trials: 120 of 1,000 (12.0 %), 12 s elapsed, "
        "about 88 s left"),
        ("accelcal: progress: Monte Carlo trials: 230 of 1,000 (23.0 %), 23 s elapsed, "
        "about 77 s left"),
    ]
