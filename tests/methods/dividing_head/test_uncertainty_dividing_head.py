"""Monte Carlo uncertainty of indexing-head reductions (accelcal.methods.dividing_head.mc)."""

import pickle

import numpy as np
import pytest

from accelcal.errors import AccelcalError
from accelcal.methods.dividing_head import (
    COEFFICIENTS,
    HeadData,
    HeadSampler,
    JointOperator,
    four,
    head_uncertainty,
    noise_levels,
    psi,
    reduce,
    scale_factors,
)
from accelcal.rigs.dividing_head import (
    AngleErrorProfile,
    DividingHeadRig,
    dong2014_models,
    simulate,
)
from accelcal.units import ARCSEC

NOISE = 2.8e-6  # V, Dong2014 Table 1 column U
TRIALS = 20_000


def _rig(**kwargs):
    return DividingHeadRig.uniform(24, dong2014_models(4), noise=NOISE, **kwargs)


def _data(rig, seed):
    run = simulate(rig, seed)
    return HeadData.build(rig.positions, run.outputs, rig.mounts)


def _truth(rig):
    return np.array([[m.to_dong2014()[c] for c in COEFFICIENTS] for m in rig.models])


@pytest.mark.parametrize(("method", "options"), [("single", {}), ("joint", {}),
                                                  ("four", {"covariance": "propagated"})])
def test_formal_and_mc_agree_without_angle_error(method, options):
    # Linear-Gaussian apart from the normalisation by the fitted K_I (relative
    # effect ~ noise / K_I ~ 2e-6): MC and formal SDs must agree within the
    # Monte Carlo standard error 1/sqrt(2 (M - 1)) = 0.5 %; 4 standard errors.
    # The four-sensor method's propagated covariance and the Monte Carlo
    # sampler use the same per-sensor noise estimate, by independent routes.
    rig = _rig()
    data = _data(rig, 1)
    # the Monte Carlo draws noise only: compare the formal noise (Type A) part, no priors
    result = reduce(data, method, priors="none", **options)
    mc = head_uncertainty(data, result, trials=TRIALS, seed=3)
    ratio = mc.mc_std / mc.formal_std
    assert np.all(np.abs(ratio - 1) < 4 / np.sqrt(2 * (TRIALS - 1))), ratio
    assert np.all(np.abs(mc.mc_bias) < 4 * mc.mc_std / np.sqrt(TRIALS))


def test_noise_free_reduction_is_reproduced_exactly():
    # the sampler re-reduces data drawn from the fitted model: without noise
    # and angle error every method returns the fitted values (rounding only)
    rig = _rig()
    data = _data(rig, 2)
    for method in ("single", "four", "joint"):
        result = reduce(data, method)
        coef = np.stack([e.values for e in result.sensors])
        sampler = HeadSampler(data.positions, data.mounts, coef, np.zeros(4), method)
        err = sampler(np.random.default_rng(0), 3)
        # K_I ~ 1.3 V/g: rounding of a 24-point fit ~1e-15 V
        np.testing.assert_allclose(err, 0.0, rtol=0, atol=1e-13)


def test_angle_error_level_adds_the_predicted_variance_single():
    # A rectangular head error within +-L at each position enters U linearly
    # through dU/dd = K_I cos(g) - K_O sin(g) + K_IO cos(2g) + K_II sin(2g)
    # (derivative of Dong2014 eq. (5)); its variance is L^2/3 per position
    # (GUM-S1 6.4.2). K_O* absorbs the mean error (DOMAIN step 6).
    level = 2.0 * ARCSEC
    rig = _rig()
    data = _data(rig, 4)
    result = reduce(data, "single", priors="none")  # noise and head error only, as the MC
    coef = np.stack([e.values for e in result.sensors])
    beta = data.angles()
    h = 1e-6
    slope = (psi(beta + h) @ coef[:, :, None] - psi(beta - h) @ coef[:, :, None])[..., 0] / (2 * h)
    pinv = np.linalg.pinv(psi(beta))  # (K, 5, n)
    jac = pinv * slope[:, None, :]  # d estimate / d d_n
    jac[:, 2, :] -= coef[:, 1, None] / beta.shape[1]  # minus d(K_O*)/d d_n
    extra = (level**2 / 3) * (jac**2).sum(axis=-1)
    mc = head_uncertainty(data, result, trials=TRIALS, seed=5, angle_error_level=level)
    predicted = mc.formal_std**2 + extra.reshape(-1)
    # variance standard error ~ var sqrt(2/M) = 1 %; 4.5 standard errors
    np.testing.assert_allclose(mc.mc_std**2, predicted, rtol=4.5 * np.sqrt(2 / TRIALS), atol=0)
    assert np.all(mc.mc_std[[0, 3, 4]] > 1.5 * mc.formal_std[[0, 3, 4]])


def test_first_harmonic_uncertainty_propagates_through_the_alias():
    # a known first harmonic with sd s shifts K_F, K_IO, K_II by its alias
    # [c', s', -c'] (DOMAIN step 4): each gets variance s^2 K_I^2 from it
    rig = _rig()
    data = _data(rig, 6)
    sd = 1e-6
    result = four(data, first_harmonic=(0.0, 0.0), first_harmonic_sd=sd)
    mc = head_uncertainty(data, result, trials=TRIALS, seed=8, first_harmonic=(0.0, 0.0),
                          first_harmonic_sd=sd)
    base = head_uncertainty(data, four(data, first_harmonic=(0.0, 0.0)), trials=TRIALS, seed=8,
                            first_harmonic=(0.0, 0.0))
    k_i = np.repeat([e["K_I"] for e in result.sensors], 5)
    added = np.tile([1.0, 0.0, 0.0, 1.0, 1.0], 4) * (sd * k_i) ** 2
    # two independent variance estimates, each with standard error var sqrt(2/M)
    tol = 4 * np.sqrt(2 / TRIALS) * np.hypot(mc.mc_std**2, base.mc_std**2)
    assert np.all(np.abs(mc.mc_std**2 - base.mc_std**2 - added) < tol)
    assert np.all(mc.mc_std[[0, 3, 4]] > 1.2 * base.mc_std[[0, 3, 4]])


@pytest.mark.slow
def test_four_method_mc_interval_covers_where_the_formal_one_does_not():
    # Repeat a simulated 24-position, 4-sensor experiment; the paper's step-7
    # formal SD (covariance="paper") ignores the noise carried in by the separated
    # head error, so its 95 % interval under-covers; the Monte Carlo interval and
    # the default propagated covariance must cover at 95 % within a binomial
    # tolerance. Each experiment's Monte Carlo run is vectorised over its trials.
    rig = _rig()
    experiments = 150
    run = simulate(rig, 12, trials=experiments)
    truth = _truth(rig).reshape(-1)
    inside_mc, inside_formal, inside_prop = [], [], []
    for outputs in run.outputs:
        data = HeadData.build(rig.positions, outputs, rig.mounts)
        result = four(data, covariance="paper")
        mc = head_uncertainty(data, result, trials=1000, seed=1)
        inside_mc.append((mc.ci_low <= truth) & (truth <= mc.ci_high))
        est = np.concatenate([e.values for e in result.sensors])
        inside_formal.append(np.abs(est - truth) <= 1.959964 * mc.formal_std)
        prop = np.concatenate([e.std for e in four(data).sensors])
        inside_prop.append(np.abs(est - truth) <= 1.959964 * prop)
    rate_mc, rate_formal = np.mean(inside_mc), np.mean(inside_formal)
    rate_prop = np.mean(inside_prop)
    # binomial sd for 150 experiments 1.8 %; 3 sd (pooled coefficients are
    # positively correlated, so this bound is conservative), less 1.5 % for
    # the noise level estimated from 19 degrees of freedom per sensor
    tol = 3 * np.sqrt(0.95 * 0.05 / experiments)
    assert 0.95 - tol - 0.015 < rate_mc < 0.95 + tol, rate_mc
    assert rate_formal < 0.88, rate_formal
    # the default: the propagated covariance (an SD from ~9-19 dof: a little low)
    assert 0.95 - tol - 0.03 < rate_prop < 0.95 + tol, rate_prop


def test_noise_levels_are_unbiased_for_the_four_method():
    # E[r_k' r_k] = sum_j ||R_kj||^2 s_j^2: the mean estimated variance over
    # many data sets equals the true one (3 standard errors of the mean)
    rig = _rig()
    run = simulate(rig, 21, trials=200)
    s2 = np.array([noise_levels(HeadData.build(rig.positions, u, rig.mounts), "four") ** 2
                   for u in run.outputs])
    sem = s2.std(axis=0) / np.sqrt(len(s2))
    assert np.all(np.abs(s2.mean(axis=0) - NOISE**2) < 3.5 * sem)


def test_reproducible_and_rejects_tumble():
    rig = _rig(angle_error=AngleErrorProfile.uniform(ARCSEC))
    data = _data(rig, 9)
    result = reduce(data, "joint")
    a = head_uncertainty(data, result, trials=3000, seed=4, angle_error_level=ARCSEC)
    b = head_uncertainty(data, result, trials=3000, seed=4, angle_error_level=ARCSEC)
    np.testing.assert_array_equal(a.ci_low, b.ci_low)
    np.testing.assert_array_equal(a.mc_std, b.mc_std)
    with pytest.raises(AccelcalError, match="single, four and joint"):
        head_uncertainty(data, reduce(data, "tumble"), trials=10, seed=0)
    with pytest.raises(AccelcalError, match="angle-error level"):
        head_uncertainty(data, result, trials=10, seed=0, angle_error_level=-1.0)


def test_sampler_pickles_for_dask():
    rig = _rig()
    data = _data(rig, 10)
    result = reduce(data, "four")
    coef = np.stack([e.values for e in result.sensors])
    sampler = HeadSampler(data.positions, data.mounts, coef, np.full(4, NOISE), "four",
                          angle_error_level=ARCSEC, first_harmonic=np.zeros(2),
                          first_harmonic_sd=1e-6)
    copy = pickle.loads(pickle.dumps(sampler))
    np.testing.assert_array_equal(copy(np.random.default_rng(1), 50),
                                  sampler(np.random.default_rng(1), 50))


@pytest.mark.parametrize("first_harmonic", [None, (3e-6, -1e-6)])
def test_sampler_reduction_equals_the_joint_reduction_with_autocollimator(first_harmonic):
    # the sampler's vectorised operators against accelcal.methods.dividing_head.joint
    # on the same data (same weights): identical to rounding
    rig = _rig(angle_error=AngleErrorProfile.uniform(2 * ARCSEC))
    run = simulate(rig, 13)
    data = HeadData.build(rig.positions, run.outputs, rig.mounts)
    readings = run.d_alpha + 0.2 * ARCSEC * np.random.default_rng(0).standard_normal(24)
    options = {"first_harmonic": first_harmonic, "first_harmonic_sd": 0.0}
    result = reduce(data, "joint", autocollimator=readings, autocollimator_sd=0.2 * ARCSEC,
                    **options)
    mc = head_uncertainty(data, result, trials=10, seed=0, autocollimator_sd=0.2 * ARCSEC,
                          **options)
    assert mc.trials == 10
    op = JointOperator.build(data.positions, data.mounts)
    res = op.resid @ (data.outputs / scale_factors(data)[:, None]).reshape(-1)
    sampler = HeadSampler(data.positions, data.mounts, np.zeros((4, 5)), np.zeros(4), "joint",
                          first_harmonic=None if first_harmonic is None else
                          np.asarray(first_harmonic), autocollimator_sd=0.2 * ARCSEC,
                          weight_sigma=float(np.sqrt(res @ res / op.dof)))
    got = sampler.reduce(data.outputs[None], readings[None])[0]
    want = np.stack([e.values for e in result.sensors])
    # volts of order 1.3; QR against pseudo-inverse solutions: 1e-12 V
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


def _every_term_data(rng, head_error):
    """Four sensors with every term eq. (5) leaves out at the default magnitudes, random signs."""
    import accelcal
    from accelcal.model import ErrorModel
    from helpers.contract import default_terms

    models = []
    for _ in range(4):
        k_i = rng.uniform(1.2, 1.4)
        models.append(ErrorModel(
            K1=k_i, K0=rng.normal(0, 1e-3) / k_i, Ko=rng.normal(0, 1e-5) / k_i,
            Kio=rng.normal(0, 2e-5) / k_i, K2=rng.normal(0, 2e-5) / k_i,
            **default_terms(accelcal.default_model(), rng, ("K3", "Koo", "K0_asym", "K1_asym"))))
    terms = {(m, cs): rng.normal(0, 1.0) * ARCSEC for m in range(2, 6) for cs in "cs"}
    profile = AngleErrorProfile.harmonics(terms) if head_error else AngleErrorProfile()
    rig = DividingHeadRig.uniform(24, tuple(models), angle_error=profile, noise=NOISE)
    data = _data(rig, rng)
    # the rows K_F+K_OO and K_II-K_OO by the truth of the combination
    want = np.array([[m.K1 * (m.K0 + m.Koo), m.K1, m.K1 * m.Ko, m.K1 * m.Kio,
                      m.K1 * (m.K2 - m.Koo)] for m in models]).ravel()
    return data, want


def test_monte_carlo_draws_the_priors_of_the_terms_left_out():
    # each trial adds every sensor's K3, K0', K1' (and K0'/2 of unknown sign where a_i = 0)
    # drawn from the reduction's priors: the Monte Carlo SD of K_I then carries K0''s share
    # as the formal Type B does; with priors none it is the noise's alone
    from accelcal.methods.dividing_head.mc import prior_columns

    data, _ = _every_term_data(np.random.default_rng(5), False)
    red = reduce(data, "single")
    sensors, columns, kinds, values = prior_columns(data, red)
    assert set(kinds) == {"rectangular"}
    assert columns.shape == (len(sensors), 24)
    assert values.min() > 0
    assert len(sensors) == 4 * 3 + 8  # K3, K0', K1' per sensor and two zeros of a_i each
    bare = reduce(data, "single", priors="none")
    assert prior_columns(data, bare) == ()
    mc = head_uncertainty(data, red, trials=2000, seed=1)
    mc0 = head_uncertainty(data, bare, trials=2000, seed=1)
    k_i = [i for i, n in enumerate(mc.names) if n.endswith(" K_I")]
    assert np.all(mc.mc_std[k_i] > 2.5 * mc0.mc_std[k_i])
    # independent draws: the formal SD without the sensors-equal excess, within 5 % (MC error
    # 1.6 % at 2000 trials; the formal Type B is first order, exact for single)
    indep = np.sqrt(np.concatenate([e.std for e in bare.sensors]) ** 2 + np.array(
        [sum(c.contribution ** 2 for c in red.type_b if c.sensor == k and c.row == row
             and c.input != "sensors' terms equal")
         for k, est in enumerate(red.sensors) for row in (est.label(n) for n in est.names)]))
    np.testing.assert_allclose(mc.mc_std, indep, rtol=0.05)
    assert any("priors" in text for text in mc.inputs)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["single", "four", "joint"])
def test_monte_carlo_intervals_cover_every_term_truths(method):
    # every-term truths (the default accelerometer's K3, Koo, K0', K1' with random signs):
    # the 95 % Monte Carlo interval covers each row's truth 0.93-0.99 of the time pooled
    # over rows (K_I, dominated by K0''s prior of twice the truth, is conservative); a row's
    # own coverage at least 0.90: the noise level is plugged in from ~19 residual dof per
    # sensor (a Gaussian interval with that plug-in covers ~0.935), minus 2 binomial SEs.
    # Without the priors K_I covers 0.36 (single) and 0.62 (four), measured: the drawn priors
    # are what makes the interval hold.
    runs, hits = 100, []
    for seed in range(runs):
        rng = np.random.default_rng(1000 + seed)
        data, want = _every_term_data(rng, method != "single")
        mc = head_uncertainty(data, reduce(data, method), trials=1000, seed=seed)
        hits.append((mc.ci_low <= want) & (want <= mc.ci_high))
    per_row = np.array(hits).reshape(runs, 4, 5).mean(axis=(0, 1))
    assert 0.93 <= np.mean(hits) <= 0.99, per_row
    assert np.all(per_row >= 0.90), per_row
