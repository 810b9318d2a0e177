"""Are the stated uncertainties of the range and turn-on reductions honest? (slow tier)

Range: the noise part of the input range's uncertainty against the spread
about the noise-free reduction (the quantity on the ladder); the overload
bias shift against the rig's. Turn-on: the 95 % chi-square intervals of the
turn-on-to-turn-on standard deviations against the rig's population values;
the in-run drift's t interval. Figures in docs/coverage.md.
"""

import numpy as np
import pytest
from scipy.special import stdtrit

from accelcal.methods.acceptance import reduce
from accelcal.rigs.acceptance_runs import simulate_range, simulate_turn_on

N = 200
BAND = (0.91, 0.985)


@pytest.mark.slow
def test_range_and_overload_shift_uncertainties_cover():
    kw = {"dwell": 2.0, "rate": 20.0, "noise": 2e-5}
    ref = reduce(simulate_range(seed=0, **{**kw, "noise": 0.0}))
    truth = np.array([ref.value("range_pos"), ref.value("range_neg")])
    err, u, shift = [], [], []
    for seed in range(N):
        red = reduce(simulate_range(seed=seed, **kw))
        err.append([red.value("range_pos"), red.value("range_neg")] - truth)
        u.append(red.provenance["range_u_noise_g"])
        shift.append((red.value("overload_shift") - 20e-6) / red.std("overload_shift"))
    err, u, shift = np.array(err), np.array(u), np.array(shift)
    ratio = err.std(axis=0) / np.sqrt((u**2).mean(axis=0))
    assert np.all((ratio > 0.85) & (ratio < 1.15)), ratio
    cover = np.mean(np.abs(err) <= 1.96 * u, axis=0)
    assert np.all((cover > BAND[0]) & (cover < BAND[1])), cover
    assert BAND[0] < np.mean(np.abs(shift) <= 1.96) < BAND[1]


@pytest.mark.slow
def test_turn_on_intervals_cover_the_population_spread():
    bias, scale, drift = [], [], []
    for seed in range(N):
        red = reduce(simulate_turn_on(seed=seed, dwell=10.0))
        lo, hi = red.provenance["bias_interval_g"]
        bias.append(lo <= 15e-6 <= hi)
        lo, hi = red.provenance["scale_interval"]
        scale.append(lo <= 30e-6 <= hi)
        k = stdtrit(red.dof, 0.975)
        drift.append(abs(red.value("drift") * 3600 - 10e-6) <= k * red.std("drift") * 3600)
    for name, hits in (("bias", bias), ("scale", scale), ("drift", drift)):
        assert BAND[0] < np.mean(hits) < BAND[1], (name, np.mean(hits))
