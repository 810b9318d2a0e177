"""The clipped-sample detector: runs at a rail or at the recording's extremes."""

import numpy as np
import pytest

from accelcal.errors import AccelcalError
from accelcal.signal.clipping import clipped


def test_runs_at_the_extremes_are_clipped_and_a_lone_peak_is_not():
    rng = np.random.default_rng(1)
    x = rng.normal(0.0, 1.0, 1000)
    x[100:110] = 5.0
    x[500:504] = -5.0
    x[700] = 5.0  # a lone sample at the maximum: not a run
    found = clipped(x)
    assert found.count == 14
    assert found.runs == ((100, 110, 5.0), (500, 504, -5.0))
    assert not found.mask[700]


def test_a_noisy_unclipped_recording_has_none():
    x = np.random.default_rng(2).normal(0.0, 1.0, 10_000)
    assert clipped(x).count == 0


def test_known_rails_and_tolerance():
    x = np.r_[np.zeros(5), np.full(4, 9.499), np.zeros(5), np.full(2, 9.5)]
    assert clipped(x, rails=(-9.5, 9.5)).count == 0
    assert clipped(x, rails=(-9.5, 9.5), tolerance=0.01).count == 4
    assert clipped(x, rails=(None, 9.5), tolerance=0.01, min_run=2).count == 6


def test_bad_arguments_are_refused():
    with pytest.raises(AccelcalError):
        clipped([1.0, np.nan])
    with pytest.raises(AccelcalError):
        clipped([1.0, 2.0], min_run=1)
