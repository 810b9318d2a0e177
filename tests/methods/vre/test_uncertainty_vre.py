"""Monte Carlo uncertainty of VRE identification (accelcal.methods.vre.mc)."""

import numpy as np
import pytest

from accelcal.errors import AccelcalError
from accelcal.methods.vre import along_ia, identify, vre_columns, vre_uncertainty

TRIALS = 20_000
# Guan2021 Table 1 sized coefficients (g/g^n, K0' in g)
TRUE = {"K2": 8e-6, "K3": 1e-7, "K0_asym": 5e-6, "K1_asym": 2e-6}


def _design():
    # amplitudes away from the overloads: at A = |b| the asymmetry columns have a kink
    b, a = np.meshgrid([1.0, 2.0, 4.0], np.arange(2.5, 11.0), indexing="ij")
    return b.ravel(), a.ravel()


def _vre(b, a, coef, scale_a=1.0):
    cols = vre_columns(along_ia(b), a * scale_a)
    return sum(v * cols[k] for k, v in coef.items())


def test_formal_and_mc_agree_on_the_weighted_fit():
    # the identification is linear in the VRE with a fixed design: Gaussian VRE
    # noise propagates exactly to the formal covariance (A'WA)^-1; the Monte
    # Carlo SD agrees within 4 standard errors 4/sqrt(2 (M - 1)) = 2 %
    b, a = _design()
    rng = np.random.default_rng(1)
    u = 1e-6 * (1 + 0.1 * a)
    y = _vre(b, a, TRUE) + u * rng.standard_normal(a.size)
    fit = identify(b, a, y, u)
    mc = vre_uncertainty(fit, trials=TRIALS, seed=2)
    assert np.all(np.abs(mc.mc_std / mc.formal_std - 1) < 4 / np.sqrt(2 * (TRIALS - 1)))
    assert np.all(np.abs(mc.mc_bias) < 4 * mc.mc_std / np.sqrt(TRIALS))


def test_residual_scale_when_points_carry_no_uncertainty():
    b, a = _design()
    rng = np.random.default_rng(3)
    y = _vre(b, a, TRUE) + 2e-6 * rng.standard_normal(a.size)
    fit = identify(b, a, y, None)
    mc = vre_uncertainty(fit, trials=TRIALS, seed=2)
    assert np.all(np.abs(mc.mc_std / mc.formal_std - 1) < 4 / np.sqrt(2 * (TRIALS - 1)))


def test_amplitude_calibration_adds_the_predicted_variance():
    # K2 alone at b = 0: VRE = K2 A^2 (1 + e)^2 / 2 (Guan2021 eq. (9)), so the
    # estimate is K2 (1 + e)^2 + noise: variance formal^2 + K2^2 (4 u^2 + 2 u^4)
    a = np.arange(1.0, 11.0)
    b = np.zeros_like(a)
    u_vre = np.full(a.size, 1e-6)
    u_a = 0.02
    rng = np.random.default_rng(4)
    y = 0.5 * TRUE["K2"] * a**2 + u_vre * rng.standard_normal(a.size)
    # K1' (left out, separable through A / pi) would add its prior's Type B part,
    # which the Monte Carlo does not sample: none here
    fit = identify(b, a, y, u_vre, terms=["K2"], priors="none")
    mc = vre_uncertainty(fit, trials=TRIALS, seed=5, amplitude_sd=u_a)
    k2 = fit.estimate["K2"]
    predicted = mc.formal_std**2 + k2**2 * (4 * u_a**2 + 2 * u_a**4)
    # variance standard error ~ var sqrt(2/M) = 1 %; 4 standard errors
    np.testing.assert_allclose(mc.mc_std**2, predicted, rtol=4 * np.sqrt(2 / TRIALS), atol=0)
    assert mc.mc_std[0] > 3 * mc.formal_std[0]


def test_overload_calibration_adds_the_linearised_variance():
    # paper terms: the extra variance of each coefficient is (J u_b)^2 with J
    # the derivative of the estimates with respect to a common overload scale,
    # computed here by central differences of the closed-form VRE and the fit
    b, a = _design()
    u = np.full(a.size, 1e-8)
    y = _vre(b, a, TRUE)
    fit = identify(b, a, y, u)
    h = 1e-4
    up = identify(b, a, sum(v * vre_columns(along_ia(b * (1 + h)), a)[k]
                            for k, v in TRUE.items()), u).estimate.values
    down = identify(b, a, sum(v * vre_columns(along_ia(b * (1 - h)), a)[k]
                              for k, v in TRUE.items()), u).estimate.values
    jac = (up - down) / (2 * h)
    u_b = 0.003
    mc = vre_uncertainty(fit, trials=TRIALS, seed=6, overload_sd=u_b)
    predicted = mc.formal_std**2 + (jac * u_b) ** 2
    # 4 variance standard errors plus 2 % for the second-order terms of e_b
    np.testing.assert_allclose(mc.mc_std**2, predicted, rtol=4 * np.sqrt(2 / TRIALS) + 0.02)
    assert mc.mc_std[1] > 1.5 * mc.formal_std[1]  # K3: VRE 3/2 b A^2 K3, most sensitive to b


@pytest.mark.slow
def test_coverage_with_amplitude_calibration_uncertainty():
    # repeat the experiment: each has its own amplitude calibration error and
    # noise; the MC interval covers the true coefficients at 95 %, the formal
    # one (noise only) does not cover K2
    b, a = _design()
    u = np.full(a.size, 3e-7)
    u_a = 0.01
    experiments = 200
    rng = np.random.default_rng(7)
    scale = 1 + u_a * rng.standard_normal((experiments, 1))
    data = _vre(b, a, TRUE, scale) + u * rng.standard_normal((experiments, a.size))
    truth = np.array(list(TRUE.values()))
    inside_mc, inside_formal = [], []
    for y in data:  # each Monte Carlo run is vectorised over its trials
        fit = identify(b, a, y, u)
        mc = vre_uncertainty(fit, trials=1000, seed=1, amplitude_sd=u_a)
        inside_mc.append((mc.ci_low <= truth) & (truth <= mc.ci_high))
        inside_formal.append(np.abs(fit.estimate.values - truth) <= 1.959964 * mc.formal_std)
    tol = 3 * np.sqrt(0.95 * 0.05 / experiments)  # binomial, 200 experiments
    rate = np.mean(inside_mc, axis=0)
    assert np.all(np.abs(rate - 0.95) < tol + 0.01), rate  # + quantile error of 1000 trials
    assert np.mean(inside_formal, axis=0)[0] < 0.6


def test_unidentifiable_and_fixed_terms():
    # a single overload: K2 and K3 cannot be separated (Guan2021 eq. (9))
    a = np.arange(2.0, 11.0)
    b = np.full(a.size, 2.0)
    u = np.full(a.size, 1e-7)
    rng = np.random.default_rng(8)
    y = _vre(b, a, {**TRUE, "K4": 1e-9}) + u * rng.standard_normal(a.size)
    fit = identify(b, a, y, u, fixed={"K4": 1e-9})
    mc = vre_uncertainty(fit, trials=2000, seed=0)
    bad = [fit.estimate.names.index(n) for n in fit.unidentified()]
    assert bad
    assert np.isnan(mc.mc_std[bad]).all()
    good = [i for i in range(len(mc.names)) if i not in bad]
    assert np.all(np.abs(mc.mc_std[good] / mc.formal_std[good] - 1) < 4 / np.sqrt(2 * 1999))


def test_bad_calibration_uncertainty():
    b, a = _design()
    y = _vre(b, a, TRUE)
    fit = identify(b, a, y, np.full(a.size, 1e-7))
    with pytest.raises(AccelcalError, match="amplitude"):
        vre_uncertainty(fit, trials=10, seed=0, amplitude_sd=-0.1)


def test_monte_carlo_draws_the_priors_of_the_terms_left_out():
    # two vibration directions: the cross-axis terms are separable but not fitted, and the
    # default priors bound them (Type B); the Monte Carlo draws them in every trial, so its
    # SD is the formal one with the Type B (the fit is linear: within 4 standard errors)
    import accelcal
    from accelcal.methods.vre import VRE_TERMS

    b = np.repeat([1.0, 2.0, 4.0], 6)
    a = np.tile(np.arange(5.0, 11.0), 3)
    two = np.vstack([np.tile([1.0, 0.0, 0.0], (9, 1)), np.tile([1.0, 0.3, 0.2], (9, 1))])
    model = accelcal.default_model()
    cols = vre_columns(along_ia(b), a, two)
    y = sum(getattr(model, t) * cols[t] for t in VRE_TERMS)
    fit = identify(b, a, y, np.full(18, 1e-7), direction=two)
    bare = identify(b, a, y, np.full(18, 1e-7), direction=two, priors="none")
    assert {p.name for p in fit.priors} == {"Koo", "Kpp", "Kio", "Kip", "Kop"}
    trials = 4000
    mc = vre_uncertainty(fit, trials=trials, seed=3)
    mc0 = vre_uncertainty(bare, trials=trials, seed=3)
    band = 4 / np.sqrt(2 * (trials - 1))
    assert np.all(np.abs(mc.mc_std / fit.estimate.std - 1) < band), mc.mc_std / fit.estimate.std
    assert np.all(np.abs(mc0.mc_std / bare.estimate.std - 1) < band)
    assert np.all(mc.mc_std > 3 * mc0.mc_std)
    assert any("priors" in text for text in mc.inputs)
