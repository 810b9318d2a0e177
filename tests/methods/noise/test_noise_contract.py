"""The IEEE 952 noise fit under the reduction contract (helpers/contract.py) and coverage harness.

A random still accelerometer: white noise N of 50-200 ug/sqrt(Hz) and an
acceleration random walk K whose line crosses N's at tau_c = 2-5 s, 2^15
samples at 100 Hz (328 s: the random walk dominates the last six octaves);
N and K fitted (terms N, K). Noise-free data are the model's own Allan
deviation curve (no samples), which the fit must return to rounding.
B is not in the contract: its standard uncertainty leaves out the
correlation of the flicker floor between taus and is optimistic
(``tests/methods/noise/test_noise_fit.py::test_b_uncertainty_is_documented_optimistic``,
docs/noise.md).
"""

import math

import numpy as np
import pytest

from accelcal.methods.noise.fit import fit, fit_deviation, model_avar
from accelcal.rigs.noise import simulate_blocks
from helpers.contract import ReductionContract

RATE = 100.0
SAMPLES = 2**15
TERMS = ("N", "K")


def _model_deviation(coefs):
    from accelcal.signal.allan.deviations import Deviation
    from accelcal.signal.allan.edf import edf
    from accelcal.signal.allan.taus import tau_grid

    m = tau_grid(SAMPLES, "octave")
    tau = m / RATE
    dev = np.sqrt(model_avar(coefs, tau))
    alpha = np.where(tau < 3.0, 0, -2)
    e = edf("oadev", alpha, m, SAMPLES)
    return Deviation("oadev", tau, m, SAMPLES - 2 * m + 1, dev, alpha, e, dev, dev, 0.683,
                     "g", RATE, SAMPLES)


class TestContract(ReductionContract):
    def truth(self, rng):
        n = rng.uniform(50e-6, 200e-6)
        crossover = rng.uniform(2.0, 5.0)  # N^2 / tau = K^2 tau / 3 at tau_c
        return {"N": n, "K": math.sqrt(3.0) * n / crossover}

    def simulate(self, truth, rng, noisy):
        if not noisy:
            return _model_deviation(truth)
        seed = int(rng.integers(2**31))
        return next(simulate_blocks(**truth, rate=RATE, duration=SAMPLES / RATE, seed=seed,
                                    block=SAMPLES))

    def reduce(self, data):
        if isinstance(data, np.ndarray):
            return fit(data, RATE, terms=TERMS, unit="g")
        return fit_deviation(data, terms=TERMS)

    def expected(self, truth):
        return [dict(truth)]

    def noise_free_tolerance(self, name, value):
        # the re-weighting stops at 1e-10 relative change of C = value^2: 1e-9 of the value
        return 1e-9 * abs(value) + 1e-15


@pytest.mark.slow
def test_white_noise_sd_ratio_is_honest_over_more_seeds():
    # The coverage table's N (seeds 0-399) reads SD ratio 0.869 +- 0.032: those seeds'
    # fluctuation plus the Birge widening, not a covariance that is wrong. Measured: seeds
    # 400-1199 give 1.007 +- 0.025 (coverage 0.953), the 1200 pooled 0.961 +- 0.020 (0.959),
    # 0.988 without the widening of the 5.7 % of fits whose chi^2 rejects the model; and a
    # fixed truth with weights at the truth 1.02 +- 0.02 over 1200 series (docs/coverage.md).
    from helpers import coverage as harness

    res = harness.coverage(TestContract(), seeds=range(400, 1200))
    assert not res.failures, res.failures[:3]
    for c in res.coefficients.values():
        lo, hi = harness.sd_ratio_band(c)
        assert lo <= c.sd_ratio <= hi, (c.coefficient, c.sd_ratio, c.sd_ratio_se)
        lo, hi = harness.coverage_band(c.experiments)
        assert lo <= c.coverage <= hi, (c.coefficient, c.coverage)
