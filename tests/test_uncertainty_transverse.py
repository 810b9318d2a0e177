"""Monte Carlo uncertainty of the shaker identification (accelcal.methods.transverse_mc)."""

from dataclasses import replace

import numpy as np
import pytest

from accelcal.errors import AccelcalError
from accelcal.methods.transverse import GUANTANG_FIG4, identify
from accelcal.methods.transverse_mc import transverse_uncertainty
from accelcal.rigs.shaker import ShakerRig

THETA = np.deg2rad(np.arange(0.0, 360.0, 30.0))
TRIALS = 20_000
TERMS = ("Ko", "Kp", "Koo", "Kpp", "Kop")


def _records(seed, trials=None, **rig):
    settings = {"amplitude": 5.0, "noise": 1e-4, "periods": 8.0, "sample_rate": 5120.0, **rig}
    return ShakerRig(**settings).simulate(GUANTANG_FIG4, THETA,
                                          rng=np.random.default_rng(seed), trials=trials)


def _one(records, i):
    """Experiment ``i`` of stacked records."""
    fields = {n: getattr(records, n)[i] for n in ("ref", "u", "ref_n", "ref_ia", "u_rest")
              if getattr(records, n) is not None}
    return replace(records, **fields)


@pytest.mark.parametrize(("route", "rig"), [("2w", {}), ("dc", {"rest": True}),
                                            ("both", {"rest": True, "gravity": 1.0})])
def test_formal_and_mc_agree_without_reference_noise(route, rig):
    # output noise only: the identification is linear in the phasors, whose
    # covariance it uses as weights, so the formal covariance is exact; the
    # Monte Carlo SD agrees within 4 standard errors 4/sqrt(2 (M - 1)) = 2 %
    records = _records(1, **rig)
    est = identify(records, route=route)
    mc = transverse_uncertainty(records, est, route=route, trials=TRIALS, seed=2)
    assert np.all(np.abs(mc.mc_std / mc.formal_std - 1) < 4 / np.sqrt(2 * (TRIALS - 1)))
    assert np.all(np.abs(mc.mc_bias) < 4 * mc.mc_std / np.sqrt(TRIALS))


def test_noise_free_records_reproduce_the_estimate():
    records = _records(0, noise=0.0)
    est = identify(records)
    np.testing.assert_allclose(est.values, [GUANTANG_FIG4.Ko, GUANTANG_FIG4.Kp,
                                            GUANTANG_FIG4.Koo, GUANTANG_FIG4.Kpp,
                                            GUANTANG_FIG4.Kop], rtol=1e-9, atol=1e-15)
    mc = transverse_uncertainty(records, est, route="2w", trials=100, seed=0)
    # rounding-level weights: the propagated error stays at rounding level
    assert np.all(mc.mc_std < 1e-9 * np.abs(est.values))


def test_reference_calibration_adds_the_predicted_variance():
    # No gravity, route 2w: k_o, k_p enter the w phasor as k_i k_o P_v, and
    # k_oo.. the 2w phasor as k_i k_oo P_v^2 / 2 (GuanTang eq. (13)); a
    # reference reading low by 1 + e gives k_o (1 + e) and k_oo (1 + e)^2:
    # extra variance k_o^2 u^2 and k_oo^2 (4 u^2 + 2 u^4).
    records = _records(3, noise=1e-5)
    est = identify(records)
    u_ref = 0.01
    mc = transverse_uncertainty(records, est, route="2w", trials=TRIALS, seed=4,
                                reference_sd=u_ref)
    factor = np.array([u_ref**2] * 2 + [4 * u_ref**2 + 2 * u_ref**4] * 3)
    predicted = mc.formal_std**2 + est.values**2 * factor
    # variance standard error ~ var sqrt(2/M) = 1 %; 4 standard errors
    np.testing.assert_allclose(mc.mc_std**2, predicted, rtol=4 * np.sqrt(2 / TRIALS), atol=0)
    assert np.all(mc.mc_std[:4] > 2 * mc.formal_std[:4])


def test_coverage_with_reference_channel_noise():
    # The identification takes the reference channels as exact. With a noisy
    # measured transverse motion (ref_ia enters the w phasor with coefficient
    # 1) the formal interval of k_o, k_p under-covers badly; the Monte Carlo
    # interval, which propagates the reference noise, covers at 95 %.
    experiments = 120
    stacked = _records(5, trials=experiments, ref_noise=2e-3, measure_transverse=True,
                       transverse_ratio=0.02)
    truth = np.array([getattr(GUANTANG_FIG4, t) for t in TERMS])
    inside_mc, inside_formal = [], []
    for i in range(experiments):  # each Monte Carlo run is vectorised over its trials
        records = _one(stacked, i)
        est = identify(records)
        mc = transverse_uncertainty(records, est, route="2w", trials=1000, seed=1)
        inside_mc.append((mc.ci_low <= truth) & (truth <= mc.ci_high))
        inside_formal.append(np.abs(est.values - truth) <= 1.959964 * est.std)
    # binomial sd for 120 experiments 2.0 %: 3 sd, plus 1 % for the quantile
    # error of 1000 trials
    tol = 3 * np.sqrt(0.95 * 0.05 / experiments) + 0.01
    rate = np.mean(inside_mc, axis=0)
    assert np.all(np.abs(rate - 0.95) < tol), rate
    assert np.mean(inside_formal, axis=0)[:2].max() < 0.6


def test_reproducible_and_bad_input():
    records = _records(6)
    est = identify(records)
    a = transverse_uncertainty(records, est, route="2w", trials=2000, seed=9, reference_sd=0.01)
    b = transverse_uncertainty(records, est, route="2w", trials=2000, seed=9, reference_sd=0.01)
    np.testing.assert_array_equal(a.ci_high, b.ci_high)
    with pytest.raises(AccelcalError, match="reference"):
        transverse_uncertainty(records, est, route="2w", trials=10, seed=0, reference_sd=-1)
    with pytest.raises(AccelcalError, match="route"):
        transverse_uncertainty(records, est, route="3w", trials=10, seed=0)
