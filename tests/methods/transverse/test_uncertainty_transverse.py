"""Monte Carlo uncertainty of the shaker identification (accelcal.methods.transverse.mc)."""

from dataclasses import replace

import numpy as np
import pytest

from accelcal.errors import AccelcalError
from accelcal.methods.transverse import GUANTANG_FIG4, identify, transverse_uncertainty
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
    red = identify(records, route=route)
    mc = transverse_uncertainty(records, red, trials=TRIALS, seed=2)
    assert np.all(np.abs(mc.mc_std / mc.formal_std - 1) < 4 / np.sqrt(2 * (TRIALS - 1)))
    assert np.all(np.abs(mc.mc_bias) < 4 * mc.mc_std / np.sqrt(TRIALS))


def test_noise_free_records_reproduce_the_estimate():
    records = _records(0, noise=0.0)
    red = identify(records)
    est = red.estimate
    np.testing.assert_allclose(est.values, [GUANTANG_FIG4.Ko, GUANTANG_FIG4.Kp,
                                            GUANTANG_FIG4.Koo, GUANTANG_FIG4.Kpp,
                                            GUANTANG_FIG4.Kop], rtol=1e-9, atol=1e-15)
    mc = transverse_uncertainty(records, red, trials=100, seed=0)
    # rounding-level weights: the propagated error stays at rounding level
    assert np.all(mc.mc_std < 1e-9 * np.abs(est.values))


def test_reference_calibration_adds_the_predicted_variance():
    # No gravity, route 2w: k_o, k_p enter the w phasor as k_i k_o P_v, and
    # k_oo.. the 2w phasor as k_i k_oo P_v^2 / 2 (GuanTang eq. (13)); a
    # reference reading low by 1 + e gives k_o (1 + e) and k_oo (1 + e)^2:
    # extra variance k_o^2 u^2 and k_oo^2 (4 u^2 + 2 u^4).
    records = _records(3, noise=1e-5)
    red = identify(records)
    est = red.estimate
    u_ref = 0.01
    mc = transverse_uncertainty(records, red, trials=TRIALS, seed=4, reference_sd=u_ref)
    factor = np.array([u_ref**2] * 2 + [4 * u_ref**2 + 2 * u_ref**4] * 3)
    predicted = mc.formal_std**2 + est.values**2 * factor
    # variance standard error ~ var sqrt(2/M) = 1 %; 4 standard errors
    np.testing.assert_allclose(mc.mc_std**2, predicted, rtol=4 * np.sqrt(2 / TRIALS), atol=0)
    assert np.all(mc.mc_std[:4] > 2 * mc.formal_std[:4])


@pytest.mark.slow
def test_coverage_with_reference_channel_noise():
    # A noisy measured transverse motion: ref_ia enters the w phasor with the
    # known coefficient 1 (times K1), so its noise is as large in the output
    # as the output's own. The identification's weights carry it (first
    # order); the Monte Carlo propagates every reference channel through the
    # full response. Both 95 % intervals cover at 95 %; without the IA
    # channel's share the formal interval of k_o, k_p would cover < 60 %.
    experiments = 120
    stacked = _records(5, trials=experiments, ref_noise=2e-3, measure_transverse=True,
                       transverse_ratio=0.02)
    truth = np.array([getattr(GUANTANG_FIG4, t) for t in TERMS])
    inside_mc, inside_formal, ratio = [], [], []
    for i in range(experiments):  # each Monte Carlo run is vectorised over its trials
        records = _one(stacked, i)
        red = identify(records)
        est = red.estimate
        mc = transverse_uncertainty(records, red, trials=1000, seed=i)
        inside_mc.append((mc.ci_low <= truth) & (truth <= mc.ci_high))
        inside_formal.append(np.abs(est.values - truth) <= 1.959964 * est.std)
        ratio.append(mc.mc_std / mc.formal_std)
    # binomial sd for 120 experiments 2.0 %: 3 sd, plus 1 % for the quantile
    # error of 1000 trials
    tol = 3 * np.sqrt(0.95 * 0.05 / experiments) + 0.01
    for inside in (inside_mc, inside_formal):
        rate = np.mean(inside, axis=0)
        assert np.all(np.abs(rate - 0.95) < tol), rate
    # the neglected share (reference noise times |k_o| ~ 1e-3) is far below the
    # 1000-trial SD's standard error 1/sqrt(2 * 999) = 2.2 %; mean of 120: 0.2 %
    np.testing.assert_allclose(np.mean(ratio, axis=0), 1.0, atol=4 * 0.022 / np.sqrt(120))


def test_weights_without_the_reference_share_understate_k_o():
    # The reference channel's share is what the formal covariance needed: the
    # weights of the output alone give an SD of k_o several times too small.
    from accelcal.methods.transverse import observation_covariance, record_phasors

    records = _one(_records(5, trials=1, ref_noise=2e-3, measure_transverse=True,
                            transverse_ratio=0.02), 0)
    ph = record_phasors(records)
    k1 = records.scale_factor
    full = observation_covariance(records, ph, "2w", k1)
    alone = observation_covariance(records, ph, "2w", k1, reference=False)
    # w components: output noise 1e-4 g and IA reference noise 2e-3 g (times K1)
    ratio = full[:, 0, 0] / alone[:, 0, 0]
    s_u = ph["u"].residual_std / k1
    np.testing.assert_allclose(ratio, 1 + (ph["ref_ia"].residual_std / s_u) ** 2, rtol=1e-12)
    assert np.all(ratio > 100)
    np.testing.assert_array_equal(full[:, 2:, 2:], alone[:, 2:, 2:])  # 2w untouched


def test_reproducible_and_bad_input():
    records = _records(6)
    red = identify(records)
    a = transverse_uncertainty(records, red, trials=2000, seed=9, reference_sd=0.01)
    b = transverse_uncertainty(records, red, trials=2000, seed=9, reference_sd=0.01)
    np.testing.assert_array_equal(a.ci_high, b.ci_high)
    with pytest.raises(AccelcalError, match="reference"):
        transverse_uncertainty(records, red, trials=10, seed=0, reference_sd=-1)
    with pytest.raises(AccelcalError, match="not a shaker identification"):
        transverse_uncertainty(records, replace(red, family="vre"), trials=10, seed=0)


def test_monte_carlo_draws_the_priors_of_the_terms_left_out():
    # the shaker's own motion along IA brings the a_i terms to the output; the fit bounds
    # them by their default priors (Type B) and the Monte Carlo draws them in every trial:
    # its SD is the formal one with the Type B (linear in the drawn terms, within 5 % at
    # 2000 trials); with priors none it is the noise's alone
    import accelcal

    rig = ShakerRig(amplitude=5.0, gravity=1.0, rest=True, frequency=160.0,
                    sample_rate=10240.0, periods=4.0, noise=1e-5, transverse_ratio=0.05,
                    transverse_direction=np.pi / 2, transverse_phase=0.3,
                    measure_transverse=True)
    records = rig.simulate(accelcal.default_model(), THETA, rng=np.random.default_rng(3))
    red = identify(records, route="2w")
    bare = identify(records, route="2w", priors="none")
    assert red.priors
    mc = transverse_uncertainty(records, red, trials=2000, seed=1)
    mc0 = transverse_uncertainty(records, bare, trials=2000, seed=1)
    np.testing.assert_allclose(mc.mc_std, red.estimate.std, rtol=0.05)
    np.testing.assert_allclose(mc0.mc_std, bare.estimate.std, rtol=0.05)
    assert np.any(mc.mc_std > 3 * mc0.mc_std)
    assert any("priors" in text for text in mc.inputs)
