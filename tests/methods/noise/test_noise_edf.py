"""Equivalent degrees of freedom and chi-square intervals of the deviations (issue 13).

Independent routes: allantools.edf_greenhall (the same published algorithm,
Greenhall & Riley, PTTI 2003) on a grid; exact covariance sums of the
estimators for white FM and white PM rate samples; the asymptotic tables of
the paper against long exact sums; Monte Carlo over simulated records.
"""

import itertools
import math

import allantools
import numpy as np
import pytest
from scipy.stats import chi2

from accelcal import AccelcalError
from accelcal.signal.allan.edf import (
    TABLE1,
    TABLE2,
    TABLE3,
    _normalised_sum,
    _white_pm,
    confidence_interval,
    edf,
    edf_greenhall,
    edf_totdev,
)
from accelcal.signal.allan.kernels import phase, variance_sums
from helpers.noise import isserlis_edf

GRID = [
    (alpha, d, m, n, overlapping, modified)
    for alpha, d, m, n, overlapping, modified in itertools.product(
        [2, 1, 0, -1, -2, -3], [2, 3], [1, 2, 3, 8, 16, 33, 64, 256, 2000],
        [40, 100, 1000, 10_000, 1_000_000], [False, True], [False, True])
    if alpha + 2 * d > 1 and n > (1 if modified else 0) + m * d + m
]


def test_greenhall_algorithm_matches_allantools_on_a_grid():
    compared = 0
    for alpha, d, m, n, overlapping, modified in GRID:
        try:
            ref = allantools.edf_greenhall(alpha, d, m, n, overlapping=overlapping,
                                           modified=modified)
        except (NotImplementedError, AssertionError):
            # allantools stops at white PM with K <= d strides (checked below against exact
            # sums) and at alpha -3, d 3 in its tables
            assert (alpha == 2 and not modified) or alpha == -3
            continue
        ours = edf_greenhall(alpha, d, m, n, overlapping=overlapping, modified=modified)
        # the same sums of at most 100 terms: rounding only
        assert ours == pytest.approx(ref, rel=1e-12)
        compared += 1
    assert compared > 1000




def _y_weights(kind: str, m: int) -> np.ndarray:
    """Weights on the rate samples of one term (d-th difference of m-sample sums)."""
    d = 3 if kind in ("hdev", "ohdev") else 2
    box = np.repeat([(-1) ** (d - 1 - k) * math.comb(d - 1, k) for k in range(d)], m)
    return box.astype(float)


@pytest.mark.parametrize("kind", ["adev", "oadev", "hdev", "ohdev"])
@pytest.mark.parametrize("m", [1, 2, 4, 16, 40])
def test_white_fm_rate_samples_match_exact_sums(kind, m):
    """White FM: the samples themselves are i.i.d.; with F = infinity (rate samples) the
    algorithm is exact at every m (paper's F = m is off by up to 17 %)."""
    n = 600
    overlapping = kind in ("oadev", "ohdev")
    terms = int(variance_sums(phase(np.arange(n, dtype=float)), np.array([m]), kind)[1][0])
    exact = isserlis_edf(_y_weights(kind, m), terms, 1 if overlapping else m)
    # up to J_MAX = 100 Basic Sum terms the algorithm is exact (rounding only); past
    # them (overlapped, (d + 1) m > 100) it uses Table 2, printed to 3 figures
    d = 3 if kind in ("hdev", "ohdev") else 2
    rel = 1e-3 if overlapping and (d + 1) * m > 100 else 1e-9
    assert edf(kind, [0], [m], n)[0] == pytest.approx(exact, rel=rel)
    if m == 1:  # MDEV at m = 1 is ADEV (overlapped): same EDF
        assert edf("mdev", [0], [1], n)[0] == pytest.approx(edf("oadev", [0], [1], n)[0])


@pytest.mark.parametrize(("kind", "n", "m"), [
    *[(kind, 600, m) for kind in ("adev", "oadev", "hdev", "ohdev") for m in (1, 7)],
    ("adev", 48, 16), ("oadev", 64, 20), ("oadev", 48, 16),   # adev M = 2; oadev K = 2
    ("hdev", 32, 8), ("ohdev", 64, 20), ("adev", 32, 8),      # hdev M = 2, ohdev K = 1
])
def test_white_pm_case_4_matches_exact_sums(kind, n, m):
    """White PM: the phase points are i.i.d.; each term is a binomial d-th difference at
    lag m. Covers K <= d (e.g. HDEV of 2 terms), where allantools raises."""
    d = 3 if kind in ("hdev", "ohdev") else 2
    overlapping = kind in ("oadev", "ohdev")
    counts = variance_sums(phase(np.arange(n, dtype=float)), np.array([m]), kind)[1]
    assert counts[0] >= 2
    weights = np.zeros(d * m + 1)
    weights[::m] = [(-1) ** k * math.comb(d, k) for k in range(d + 1)]
    exact = isserlis_edf(weights, int(counts[0]), 1 if overlapping else m)
    assert edf(kind, [2], [m], n)[0] == pytest.approx(exact, rel=1e-12)


@pytest.mark.parametrize("d", [1, 2, 3])
def test_white_pm_closed_form_is_the_papers_table_2_row(d):
    """Table 2 [GR2003], alpha = 2: a0 = C(4d, 2d) / C(2d, d)^2, a1 = d / 2
    (3/2, 1/2; 35/18, 1; 231/100, 3/2); 1/edf = (a0 - a1/r) / M for K > d."""
    a0, a1 = {1: (3 / 2, 1 / 2), 2: (35 / 18, 1.0), 3: (231 / 100, 3 / 2)}[d]
    assert math.comb(4 * d, 2 * d) / math.comb(2 * d, d) ** 2 == pytest.approx(a0)
    for big_m, r in [(50.0, 50.0), (500.0, 25.0), (40.0, 4.5)]:
        assert _white_pm(d, big_m, r) == pytest.approx((a0 - a1 / r) / big_m, rel=1e-12)


def test_asymptotic_tables_agree_with_long_exact_sums():
    """Tables 1-3 [GR2003] are fits of 1/edf for r = M/S -> infinity: against the exact
    Basic Sum with J = (d+1) m terms at m = 120, r = 40, they agree to the 3 figures
    printed (1e-3) and Table 3's b0 + b1 ln m fit to 1e-2."""
    m, r = 120, 40.0
    for (alpha, d), (a0, a1) in TABLE1.items():
        exact = _normalised_sum((d + 1) * m, r * m, m, 1.0, alpha=alpha, d=d)
        assert exact == pytest.approx((a0 - a1 / r) / r, rel=1e-3)
    for (alpha, d), (a0, a1) in TABLE2.items():
        if alpha == 1:
            b0, b1 = TABLE3[d]
            exact = _normalised_sum((d + 1) * m, r * m, m, float(m), alpha=1, d=d)
            table = (a0 - a1 / r) / ((b0 + b1 * math.log(m)) ** 2 * r)
            assert exact == pytest.approx(table, rel=1e-2)
        else:
            exact = _normalised_sum((d + 1) * m, r * m, m, math.inf, alpha=alpha, d=d)
            assert exact == pytest.approx((a0 - a1 / r) / r, rel=1e-3)


def _simulate(noise: str, trials: int, n: int, rng) -> np.ndarray:
    if noise == "white PM":
        return np.diff(rng.normal(size=(trials, n + 1)), axis=1)
    if noise == "white FM":
        return rng.normal(size=(trials, n))
    return np.cumsum(rng.normal(size=(trials, n)), axis=1)  # random walk FM


@pytest.mark.slow
@pytest.mark.parametrize(("noise", "alpha", "kind", "n", "m"), [
    ("white PM", 2, "hdev", 32, 8),       # 2 terms, K = 2 <= d = 3
    ("white PM", 2, "oadev", 64, 20),     # K = 2 <= d = 2
    ("white FM", 0, "oadev", 256, 16),
    ("white FM", 0, "mdev", 256, 16),
    ("white FM", 0, "totdev", 256, 32),   # SP 1065 Table 7: 1.5 N/m
    ("random walk FM", -2, "oadev", 256, 32),
    ("random walk FM", -2, "ohdev", 256, 16),
    ("random walk FM", -2, "totdev", 256, 32),
])
def test_edf_matches_monte_carlo(noise, alpha, kind, n, m):
    """EDF = 2 E[s^2]^2 / Var[s^2] over 4000 simulated records. Relative SE of the
    Monte Carlo EDF ~ sqrt(2/T + 12/(edf T)) (variance of a sample variance with the
    kurtosis of chi^2/edf); 4 SE, plus 5 % for the SP 1065 TOTVAR fits and for the
    discrete random walk (cumsum of white noise) against the continuous model."""
    trials = 4000
    rng = np.random.default_rng(1992 + n + m)
    sums = np.array([variance_sums(phase(y), np.array([m]), kind)[0][0]
                     for y in _simulate(noise, trials, n, rng)])
    mc = 2 * sums.mean() ** 2 / sums.var(ddof=1)
    stated = edf(kind, [alpha], [m], n)[0]
    tol = 4 * math.sqrt(2 / trials + 12 / (stated * trials))
    tol += 0.05 if (kind == "totdev" or alpha == -2) else 0.0
    assert mc == pytest.approx(stated, rel=tol)


def test_totdev_edf_is_sp1065_table_7():
    assert edf_totdev(0, 10, 1000) == pytest.approx(150.0)
    assert edf_totdev(-1, 10, 1000) == pytest.approx(1.17 * 100 - 0.22)
    assert edf_totdev(-2, 10, 1000) == pytest.approx(0.93 * 100 - 0.36)
    # white and flicker PM: the overlapping Allan EDF (conservative)
    assert edf("totdev", [2, 1], [10, 10], 1000) == pytest.approx(edf("oadev", [2, 1], [10, 10],
                                                                      1000))


def test_confidence_interval():
    dev = np.array([1.0, 2.0, 0.5])
    nu = np.array([3.0, 40.0, 1000.0])
    lo, hi = confidence_interval(dev, nu, 0.683)
    for k in range(3):
        ref = allantools.confidence_interval(dev[k], nu[k], ci=0.683)
        assert (lo[k], hi[k]) == pytest.approx(ref, rel=1e-12)
    # definition: P(chi2 > edf dev^2 / lo^2) = P(chi2 < edf dev^2 / hi^2) = (1 - c) / 2
    lo95, hi95 = confidence_interval(dev, nu, 0.95)
    assert chi2.sf(nu * (dev / lo95) ** 2, nu) == pytest.approx(0.025)
    assert chi2.cdf(nu * (dev / hi95) ** 2, nu) == pytest.approx(0.025)
    assert np.all(lo95 < lo)
    assert np.all(hi95 > hi)
    for bad in (0.0, 1.0, float("nan"), "x"):
        with pytest.raises(AccelcalError) as err:
            confidence_interval(dev, nu, bad)
        assert err.value.parameter == "confidence"


def test_divergent_noise_is_refused():
    with pytest.raises(AccelcalError, match="too divergent") as err:
        edf_greenhall(-3, 2, 4, 100, overlapping=True, modified=False)
    assert err.value.parameter == "alpha"
