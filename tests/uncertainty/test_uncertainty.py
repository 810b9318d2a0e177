"""GUM-S1 Monte Carlo uncertainty (accelcal.uncertainty) on linear-Gaussian and Type-B cases.

Reference results: for a linear least-squares reduction ``x = P y`` with
data noise N(0, s^2 I) the propagated distribution is Gaussian with
covariance ``s^2 (A'A)^-1`` (JCGM 101:2008, 9.2-9.3 additive models);
a common offset rectangular on [-c, c] adds ``c^2/3`` to the intercept's
variance (JCGM 101:2008, 6.4.2).
"""

from dataclasses import dataclass

import numpy as np
import pytest

from accelcal.errors import AccelcalError
from accelcal.uncertainty import McUncertainty, check_options, interval_keys, propagate

X = np.linspace(-1.0, 1.0, 12)
DESIGN = np.stack([np.ones_like(X), X], axis=1)
PINV = np.linalg.pinv(DESIGN)
SIGMA = 0.3
TRIALS = 20_000


@dataclass(frozen=True)
class LineSampler:
    """Errors of a straight-line fit: noise N(0, sigma) plus a common offset U(low, high)."""

    sigma: float
    low: float = 0.0
    high: float = 0.0

    def draw(self, rng, n):
        offset = rng.uniform(self.low, self.high, (n, 1)) if self.high > self.low else 0.0
        return offset + self.sigma * rng.standard_normal((n, X.size))

    def __call__(self, rng, n):
        return self.draw(rng, n) @ PINV.T


def _formal():
    return SIGMA * np.sqrt(np.diag(np.linalg.inv(DESIGN.T @ DESIGN)))


def test_formal_and_mc_agree_on_a_linear_gaussian_fit():
    formal = _formal()
    mc = propagate(LineSampler(SIGMA), [1.0, 2.0], formal, names=["a", "b"], trials=TRIALS,
                   seed=7)
    # relative standard error of a sample SD of Gaussian draws: 1/sqrt(2 (M - 1)) = 0.5 %;
    # 4 standard errors (2.0 %) bound a correct implementation's deviation.
    ratio = mc.mc_std / formal
    assert np.all(np.abs(ratio - 1.0) < 4 * mc.mc_std_error / formal)
    # mean error 0 within 4 standard errors of a mean
    assert np.all(np.abs(mc.mc_bias) < 4 * formal / np.sqrt(TRIALS))
    # the symmetric 95 % interval of a Gaussian is +-1.959964 sd; quantiles of 2e4 draws
    # carry ~1.2 % relative error on the half width (GUM-S1 7.9): allow 5 %.
    half = (mc.ci_high - mc.ci_low) / 2
    np.testing.assert_allclose(half, 1.959964 * formal, rtol=0.05, atol=0)
    np.testing.assert_allclose((mc.ci_high + mc.ci_low) / 2, [1.0, 2.0], rtol=0,
                               atol=0.1 * formal.max())


def test_type_b_offset_adds_its_predicted_variance_to_the_intercept_only():
    c = 0.5
    formal = _formal()
    mc = propagate(LineSampler(SIGMA, -c, c), [0.0, 0.0], formal, names=["a", "b"],
                   trials=TRIALS, seed=3)
    predicted = np.array([formal[0] ** 2 + c**2 / 3, formal[1] ** 2])  # GUM-S1 6.4.2
    # sample variance standard error ~ var sqrt(2/M) (1 % here); 4 standard errors
    np.testing.assert_allclose(mc.mc_std**2, predicted, rtol=4 * np.sqrt(2 / TRIALS), atol=0)
    assert mc.mc_std[0] > 1.5 * formal[0]


def _coverage(sampler, truth, experiments, rng, *, shortest=False):
    """Empirical coverage of the MC interval over simulated experiments (vectorised).

    The errors of a linear reduction do not depend on the data, so one Monte
    Carlo run gives the interval offsets of every experiment.
    """
    data = DESIGN @ truth + sampler.draw(rng, experiments)
    estimates = data @ PINV.T
    mc = propagate(sampler, [0.0, 0.0], _formal(), names=["a", "b"], trials=TRIALS, seed=11,
                   shortest=shortest)
    low = estimates + mc.ci_low  # the estimate of experiment e replaces 0
    high = estimates + mc.ci_high
    return ((low <= truth) & (truth <= high)).mean(axis=0), estimates


@pytest.mark.parametrize(("low", "high", "shortest"),
                         [(0.0, 0.0, False), (-0.6, 0.6, False), (0.0, 1.2, False),
                          (0.0, 1.2, True)])
def test_coverage_interval_contains_the_truth_at_the_stated_rate(low, high, shortest):
    rng = np.random.default_rng(5)
    experiments = 4000
    truth = np.array([0.7, -1.3])
    rate, estimates = _coverage(LineSampler(SIGMA, low, high), truth, experiments, rng,
                                shortest=shortest)
    # binomial: sd sqrt(0.95 0.05 / 4000) = 0.34 %; 3.5 sd plus 0.3 % for the
    # quantile error of 2e4 Monte Carlo trials
    tol = 3.5 * np.sqrt(0.95 * 0.05 / experiments) + 0.003
    assert np.all(np.abs(rate - 0.95) < tol), rate
    if high - low > 1.0:
        # the formal (noise-only) interval misses the systematic offset: under-coverage
        formal = _formal()
        inside = np.abs(estimates - truth) <= 1.959964 * formal
        assert inside.mean(axis=0)[0] < 0.95 - 10 * tol


def test_one_sided_type_b_input_shifts_the_interval_the_right_way():
    # offset uniform on [0, 1.2]: the data are high by 0.6 on average, so the
    # interval of the intercept lies below the estimate
    mc = propagate(LineSampler(SIGMA, 0.0, 1.2), [5.0, 0.0], _formal(), names=["a", "b"],
                   trials=TRIALS, seed=2)
    # symmetric about 5 - 0.6 (uniform offset convolved with Gaussian noise); the
    # quantiles' standard error is ~0.002 (GUM-S1 7.9 with density ~0.6): allow 0.01
    np.testing.assert_allclose((mc.ci_low[0] + mc.ci_high[0]) / 2, 4.4, rtol=0, atol=0.01)
    np.testing.assert_allclose(mc.mc_bias[0], 0.6, rtol=0, atol=4 * mc.mc_std[0] / np.sqrt(TRIALS))


def test_same_seed_same_result_other_seed_other_result():
    run = [propagate(LineSampler(SIGMA, -0.1, 0.1), [0.0, 1.0], _formal(), names=["a", "b"],
                     trials=5000, seed=s) for s in (4, 4, 5)]
    for name in ("mc_std", "ci_low", "ci_high", "mc_bias"):
        np.testing.assert_array_equal(getattr(run[0], name), getattr(run[1], name))
        assert not np.array_equal(getattr(run[0], name), getattr(run[2], name))
    assert run[0].trials == 5000
    assert run[0].seed == 4


def test_rows_and_columns():
    mc = propagate(LineSampler(SIGMA), [1.0, np.nan], _formal(), names=["a", "b"], trials=500,
                   seed=0, units={"a": "g"})
    rows = mc.rows()
    assert list(rows[0]) == ["coefficient", "estimate", "std", "mc_std", "ci95_low",
                             "ci95_high", "unit"]
    assert rows[0]["unit"] == "g"
    assert rows[0]["ci95_low"] < 1.0 < rows[0]["ci95_high"]
    # an unidentified coefficient (NaN estimate) has no Monte Carlo uncertainty either
    assert np.isnan(rows[1]["mc_std"])
    assert np.isnan(rows[1]["ci95_low"])
    assert interval_keys(0.99) == ("ci99_low", "ci99_high")
    assert interval_keys(0.955) == ("ci95_5_low", "ci95_5_high")
    assert isinstance(mc, McUncertainty)
    with pytest.raises(ValueError, match="read-only"):
        mc.mc_std[0] = 1.0


@pytest.mark.parametrize(
    ("kind", "trials", "seed", "match"),
    [("bogus", 10, 0, "uncertainty"), ("mc", 0, 0, "trials"), ("mc", -3, 0, "trials"),
     ("mc", 2.5, 0, "trials"), ("mc", 10, -1, "seed")],
)
def test_check_options_rejects_bad_input(kind, trials, seed, match):
    with pytest.raises(AccelcalError, match=f"^{match}: ") as info:
        check_options(kind, trials, seed)
    assert info.value.parameter == match
    assert info.value.message_for().startswith(f"--{match}: ")


def test_propagate_rejects_bad_input():
    with pytest.raises(AccelcalError, match="trials"):
        propagate(LineSampler(SIGMA), [0, 0], [1, 1], names=["a", "b"], trials=0, seed=0)
    with pytest.raises(AccelcalError, match="coverage"):
        propagate(LineSampler(SIGMA), [0, 0], [1, 1], names=["a", "b"], trials=10, seed=0,
                  coverage=1.5)
    with pytest.raises(AccelcalError, match="2 names"):
        propagate(LineSampler(SIGMA), [0, 0, 0], [1, 1], names=["a", "b"], trials=10, seed=0)
