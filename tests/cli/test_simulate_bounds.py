"""Every simulate command estimates its run from its sample count and the simulator's
measured cost per sample, refuses past the time bound with the figure, and runs with
--force (the bound is lowered so that the runs stay short: the estimate is tested)."""

import pytest

from accelcal import work
from helpers.cli import refused, run_cli


@pytest.fixture
def tiny_bound(monkeypatch):
    """An hour becomes a picosecond: any simulation is 'too long'."""
    monkeypatch.setattr(work, "MAX_SECONDS", 1e-12)


# (command and small options, the option named, the estimate's words)
FAMILIES = [
    (["response", "simulate", "--frequencies", "100,200", "--periods", "4"], "--periods",
     "2 steps of 4 periods"),
    (["response", "simulate", "--excitation", "random", "--duration", "1"], "--duration",
     "a random record of 1 s"),
    (["triad", "simulate", "--dwell", "1", "--still", "1", "--motion", "1"], "--rate",
     "a triad recording at 100 Hz"),
    (["vre", "simulate", "--overload", "1", "--amplitude", "5", "--duration", "0.1"],
     "--duration", "1 vibrafuge points of 0.1 s"),
    (["tumble", "simulate", "--points", "8"], "--points", "8 tumble positions x 1 readings"),
    (["dividing-head", "simulate", "--positions", "8"], "--positions",
     "8 positions x 4 sensors"),
    (["centrifuge", "simulate", "--levels", "5,10"], "--readings", "steps of 1 readings"),
    (["thermal", "simulate", "--setpoints", "20,30", "--soak", "60", "--warmup", "60",
      "--points", "4", "--dwell", "10"], "--step", "the thermal programme"),
    (["acceptance", "simulate", "--dwell", "1"], "--dwell", "the threshold test at 10 Hz"),
]


@pytest.mark.usefixtures("tiny_bound")
@pytest.mark.parametrize("family", FAMILIES, ids=[" ".join(f[0][:3]) for f in FAMILIES])
def test_each_simulator_is_bounded_and_forced(tmp_path, capsys, family):
    args, option, what = family
    out = tmp_path / "x.csv"
    refused([*args, "--out", out], capsys, option, what, "samples) would take about",
            "s per sample of", "the bound is", "--force")
    assert not out.exists()
    code, _, err = run_cli([*args, "--out", out, "--force"], capsys)
    assert code == 0, err
    assert out.exists()


def test_an_absurd_simulation_is_refused_in_days_and_passes_forced():
    with pytest.raises(work.AccelcalError, match=r"1e\+12 samples.*(days|years).*--force"):
        work.simulated("centrifuge", "absurd steps", 1e12, parameter="readings")
    with work.forcing(True):
        est = work.simulated("centrifuge", "absurd steps", 1e12, parameter="readings")
    assert est.seconds == pytest.approx(1e12 * work.SECONDS_PER_SAMPLE_SIMULATED["centrifuge"])
    assert est.long
    with pytest.raises(work.AccelcalError):  # forcing ends with its block
        work.simulated("centrifuge", "absurd steps", 1e12)


def test_the_default_run_of_each_simulator_is_within_the_bound():
    # The estimates of the measured runs are seconds, far from the hour.
    for family, cost in work.SECONDS_PER_SAMPLE_SIMULATED.items():
        assert work.simulated(family, "a run", 1e6).seconds == pytest.approx(1e6 * cost)
        assert cost * 1e6 < 60


def test_a_long_simulation_is_announced_with_its_estimate(monkeypatch, tmp_path, capsys):
    monkeypatch.setattr(work, "PROGRESS_AFTER_S", 0.0)  # every run is 'long'
    code, _, err = run_cli(["tumble", "simulate", "--points", "8", "--out",
                            tmp_path / "t.csv"], capsys)
    assert code == 0, err
    assert "accelcal: progress: 8 tumble positions x 1 readings (8 samples): about" in err
    monkeypatch.setattr(work, "PROGRESS_AFTER_S", 10.0)
    code, _, err = run_cli(["tumble", "simulate", "--points", "8", "--out",
                            tmp_path / "v.csv"], capsys)
    assert code == 0, err
    assert "progress" not in err  # a short run says nothing


def test_stepped_response_reports_each_step():
    from accelcal.rigs.shaker_response import ResponseRig

    seen = []
    rig = ResponseRig(frequencies=(100.0, 200.0, 400.0), periods=2, sample_rate=5000.0)
    rig.simulate(progress=lambda done, total: seen.append((done, total)))
    assert seen == [(1, 3), (2, 3), (3, 3)]
