"""The work estimate (accelcal.work): time, memory and disk bounds, and --force."""

import math

import pytest

from accelcal import work
from accelcal.errors import AccelcalError


def test_estimate_is_units_times_the_per_unit_costs():
    est = work.estimate("3e+06 samples", 3e6, 1e-6, memory_per_unit=8, disk_per_unit=23,
                        fixed_seconds=0.5)
    assert est.seconds == pytest.approx(3.5)
    assert est.memory == 24e6
    assert est.disk == 69e6
    assert not est.long
    assert work.estimate("x", 1e9, 1e-6).long  # 1000 s: progress is shown


def test_a_long_run_is_refused_with_its_estimate_and_force_runs_it():
    est = work.estimate("1e+12 trials", 1e12, 1e-5)  # 1e7 s: 116 days
    with pytest.raises(AccelcalError) as exc:
        work.check(est, parameter="trials", hint="give fewer trials")
    text = exc.value.message_for()
    for word in ("116 days", "the bound is 1 h", "--force", "give fewer trials"):
        assert word in text
    assert exc.value.parameter == "trials"
    assert work.check(est, force=True) is est
    assert work.check(work.estimate("short", 10, 1.0)) is not None  # under the bound


def test_a_caller_may_state_a_shorter_bound():
    est = work.estimate("taus", 1, 90.0)
    with pytest.raises(AccelcalError, match="the bound is 60 s"):
        work.check(est, bound=60.0)
    work.check(est)  # the default bound is an hour


def test_an_overflowing_estimate_is_refused_not_run():
    est = work.estimate("far too much", 1e308, 1e10)
    assert math.isinf(est.seconds)
    with pytest.raises(AccelcalError, match="forever"):
        work.check(est)


def test_memory_and_disk_are_refused_even_with_force(tmp_path, monkeypatch):
    from accelcal import resources

    monkeypatch.setattr(resources, "available_memory", lambda: 2**30)
    big = work.estimate("a big study", 1e9, 0.0, memory_per_unit=8)
    with pytest.raises(AccelcalError, match=r"7.45 GiB of memory.*512 MiB"):
        work.check(big, force=True)
    work.check(work.estimate("a small one", 1e6, 0.0, memory_per_unit=8))
    huge = work.estimate("a long record", 1e18, 0.0, disk_per_unit=8)
    with pytest.raises(AccelcalError, match=r"would write about .* free"):
        work.check(huge, force=True, directory=tmp_path / "new" / "dir")  # nearest parent
    work.check(huge, force=True)  # no directory: the disk is not checked


@pytest.mark.parametrize(("seconds", "text"), [
    (3.2, "3.2 s"), (42, "42 s"), (150, "2.5 min"), (3600, "1 h"), (9000, "2.5 h"),
    (3 * 86400, "3 days"), (1e7, "116 days"), (1e9, "32 years"), (1e20, "3.2e+12 years"),
])
def test_durations_are_shown_in_a_readable_unit(seconds, text):
    assert work.shown_seconds(seconds) == text
