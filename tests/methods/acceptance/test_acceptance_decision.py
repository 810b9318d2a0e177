"""The 50 % decision's stated error probability against its rate in simulation.

Increments of 2, 6 and 30 arcsec at null (9.7, 29 and 145 ug) on a sensor
whose stick-slip break-away is 15 ug: it sticks at the first, follows the
others. The noise (35 ug per sample, 10 samples per dwell) makes the
responses' SD about 0.9 and 0.3 at the first two, so each decision is wrong
often enough to count: Phi(-0.5/0.9) ~ 0.29, Phi(-0.5/0.3) ~ 0.05.
"""

import numpy as np

from accelcal.methods.acceptance import reduce_steps
from accelcal.rigs.acceptance import simulate

RUNS = 1500
TRUTH = np.array([0.0, 1.0, 1.0])


def _run(seed: int, dwell: float = 1.0):
    rec = simulate("threshold", increments=(2.0, 6.0, 30.0), breakaway=15e-6, noise=35e-6,
                   dwell=dwell, rate=10.0, seed=seed)
    return rec, reduce_steps(rec, max_error=0.999)


def test_each_decision_is_wrong_at_the_rate_it_states():
    wrong, stated, thr_wrong, thr_stated = np.zeros(3), np.zeros(3), 0, 0.0
    for seed in range(RUNS):
        rec, red = _run(seed)
        response, p = red.observations["response"], red.observations["error"]
        wrong += (response >= 0.5) != (TRUTH >= 0.5)
        stated += p
        thr_wrong += not np.isclose(red.value("threshold"), rec.metadata["true_threshold_g"],
                                    rtol=1e-9)
        thr_stated += red.value("error_probability")
    wrong, stated = wrong / RUNS, stated / RUNS
    assert 0.2 < stated[0] < 0.4  # the design's regime
    assert 0.02 < stated[1] < 0.1
    for rate, p in zip(wrong, stated, strict=True):
        # four binomial standard errors of the observed rate
        assert abs(rate - p) <= 4.0 * np.sqrt(max(p * (1 - p), 1e-4) / RUNS) + 1e-3, (rate, p)
    p = thr_stated / RUNS
    assert abs(thr_wrong / RUNS - p) <= 4.0 * np.sqrt(p * (1 - p) / RUNS), (thr_wrong, p)


def test_the_recommended_dwell_makes_the_decision_reliable():
    _, red = _run(0)
    dwell = red.value("recommended_dwell")
    assert dwell > 10.0  # the 1 s dwells are far too short for an error rate of 1e-3
    rec, longer = _run(1, dwell=dwell)
    assert longer.value("error_probability") < 3e-3
    assert np.isclose(longer.value("threshold"), rec.metadata["true_threshold_g"], rtol=1e-9)
