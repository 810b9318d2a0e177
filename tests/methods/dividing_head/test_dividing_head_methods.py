"""Indexing-head reductions (Dong2014, corrected as DOMAIN section 4): single, four, joint."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from accelcal.errors import AccelcalError
from accelcal.methods.dividing_head import (
    COEFFICIENTS,
    FourOperator,
    HeadData,
    JointOperator,
    first_harmonic_alias,
    four,
    identifiability,
    joint,
    null_space_dim,
    psi,
    reduce,
    residual_noise_variances,
    scale_factors,
    single,
)
from accelcal.model import ErrorModel
from accelcal.rigs.dividing_head import (
    DONG2014_FIRST_HARMONIC,
    AngleErrorProfile,
    DividingHeadRig,
    dong2014_models,
    simulate,
    uniform_positions,
)
from accelcal.units import ARCSEC, DEG

MODELS = dong2014_models(4)
HIGH = AngleErrorProfile.harmonics({
    (2, "c"): 3 * ARCSEC, (2, "s"): -2 * ARCSEC, (3, "c"): 1 * ARCSEC, (3, "s"): 1.5 * ARCSEC,
    (4, "c"): 1 * ARCSEC, (5, "s"): 0.7 * ARCSEC, (7, "c"): 0.5 * ARCSEC, (11, "s"): 0.3 * ARCSEC,
})
ETA = np.array([1.0, -2.0, 0.5, 3.0]) * ARCSEC


def _truth(models, eta, d0=0.0):
    """First-order identifiable truth: K_O* = K_O + K_I (eta + d0) [DOMAIN step 6]."""
    t = np.array([[m.to_dong2014()[c] for c in COEFFICIENTS] for m in models])
    t[:, 2] += t[:, 1] * (eta + d0)
    return t


def _exact_truth(model, shift):
    """Coefficients of U(beta + shift) in the basis Psi(beta): a constant rotation is exactly
    absorbed by the five coefficients; computed by least squares on 64 dense angles."""
    b = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    u = model.output(np.sin(b + shift), np.cos(b + shift), 0.0)
    return np.linalg.lstsq(psi(b), u, rcond=None)[0]


def _estimates(result):
    return np.array([e.values for e in result.sensors])


def _run(*, profile=HIGH, first_harmonic=(0.0, 0.0), eta=ETA, n=24, mounts=None, models=MODELS):
    rig = DividingHeadRig.uniform(n, models, angle_error=profile, eta=eta,
                                  first_harmonic=first_harmonic, mounts=mounts)
    run = simulate(rig)
    return rig, run, HeadData.build(rig.positions, run.outputs, rig.mounts)


def _second_order_bound(rig, run, data, pinv_rows):
    """Bound on the coefficient error left by the linearisation, output unit.

    Per normalised reading the neglected terms are at most
        e = (1 + |delta|) (eps^2 / 2 + eps (|K'_O| + |K'_IO| + |K'_II|)) + |delta| eps,
    eps = max|d_alpha| + |eta_k|, delta = K_I / K_I,fit - 1 (step-0 normalisation error):
    Taylor remainders of sin, and first-order terms of cos, sin cos, sin^2 (derivatives <= 1).
    A linear estimator with rows p moves by at most ||p||_1 max(e); times K_I,fit for volts.
    """
    k_fit = scale_factors(data)
    t = _truth(rig.models, rig.eta)
    delta = np.abs(t[:, 1] / k_fit - 1)
    eps = np.abs(run.d_alpha).max() + np.abs(rig.eta)
    small = (np.abs(t[:, 2]) + np.abs(t[:, 3]) + np.abs(t[:, 4])) / t[:, 1]
    e = (1 + delta) * (eps**2 / 2 + eps * small) + delta * eps
    gain = np.abs(pinv_rows).sum(axis=-1)  # (K, 5)
    return k_fit[:, None] * gain * e.max()


# ---------------------------------------------------------------- simulator
def test_simulator_matches_dong2014_mount_equations():
    # Dong2014 eqs. (1)-(4): sensor 2 feels a_i = cos(a+d), a_o = -sin(a+d), etc.
    rig, run, _ = _run(eta=np.zeros(4))
    a = rig.positions + run.d_alpha
    inputs = [(np.sin(a), np.cos(a)), (np.cos(a), -np.sin(a)),
              (-np.sin(a), -np.cos(a)), (-np.cos(a), np.sin(a))]
    for k, (ai, ao) in enumerate(inputs):
        np.testing.assert_allclose(run.outputs[0, k], MODELS[k].output(ai, ao, 0.0),
                                   rtol=0, atol=1e-14)  # ~10 ulp of a 6 rad angle, times K_I


def test_simulator_noise_and_trials_shape_and_seed():
    rig = DividingHeadRig.uniform(12, MODELS[:2], angle_error=AngleErrorProfile.uniform(ARCSEC),
                                  noise=1e-6, repeats=3)
    a = simulate(rig, 5, trials=7)
    b = simulate(rig, 5, trials=7)
    assert a.outputs.shape == (7, 3, 2, 12)
    assert a.d_alpha.shape == (7, 12)
    np.testing.assert_array_equal(a.outputs, b.outputs)
    assert np.abs(a.d_alpha).max() <= ARCSEC
    # repeats see the same head error: differences are noise only (sd sqrt(2) 1e-6)
    diff = a.outputs[:, 0] - a.outputs[:, 1]
    assert 0.8e-6 * np.sqrt(2) < diff.std() < 1.2e-6 * np.sqrt(2)


# ------------------------------------------------------ corrected expansions
def _dft(y, m):
    n = y.size
    a = np.arange(n) * 2 * np.pi / n
    if m == 0:
        return y.mean(), 0.0
    return 2 * np.mean(y * np.cos(m * a)), 2 * np.mean(y * np.sin(m * a))


def test_corrected_vz_expansion_eq15():
    """V_z = sum U'_k cos(alpha + phi_k) against the corrected eq. (15) [DOMAIN], by DFT of
    exact simulated outputs. Amplitudes ~1e-6 make second-order terms ~1e-12 (tolerance 1e-10)."""
    rng = np.random.default_rng(3)
    c = rng.normal(0, 1e-5, (4, 4))  # K'_F, K'_O, K'_IO, K'_II per sensor (normalised)
    dk = rng.normal(0, 1e-5, 4)
    eta = rng.normal(0, 2e-6, 4)
    d = {(m, cs): rng.normal(0, 2e-6) for m in range(7) for cs in "cs" if (m, cs) != (0, "s")}
    models = [ErrorModel.from_dong2014(K_F=c[k, 0], K_I=1 + dk[k], K_O=c[k, 1], K_IO=c[k, 2],
                                       K_II=c[k, 3]) for k in range(4)]
    rig = DividingHeadRig.uniform(24, models, angle_error=AngleErrorProfile.harmonics(d), eta=eta)
    u = simulate(rig).outputs[0]  # U' with K_I,nom = 1
    vz = (u * np.cos(rig.sensor_angles())).sum(axis=0)
    F, Ko, IO, II = c.T
    expected = {
        0: (0.5 * (Ko + eta).sum() + 2 * d[(0, "c")], 0.0),
        1: (F[0] - F[2] + (IO[1] - IO[3]) / 4 + (II[0] - II[2]) / 4 + 2 * d[(1, "c")],
            -F[1] + F[3] + (IO[0] - IO[2]) / 4 + (II[3] - II[1]) / 4 + 2 * d[(1, "s")]),
        2: (0.5 * (Ko[0] - Ko[1] + Ko[2] - Ko[3]) + 0.5 * (eta[0] - eta[1] + eta[2] - eta[3])
            + 2 * d[(2, "c")],
            0.5 * (dk[0] - dk[1] + dk[2] - dk[3]) + 2 * d[(2, "s")]),
        3: ((IO[3] - IO[1]) / 4 - (II[0] - II[2]) / 4 + 2 * d[(3, "c")],
            (IO[0] - IO[2]) / 4 - (II[1] - II[3]) / 4 + 2 * d[(3, "s")]),
    }
    for m in range(7):
        want = expected[m] if m in expected else (2 * d[(m, "c")], 2 * d[(m, "s")])  # >= 4
        np.testing.assert_allclose(_dft(vz, m), want, rtol=0, atol=1e-10)
    # The printed eq. (15) DC term 4 (d0 + sum eta) is wrong by far more than that tolerance.
    assert abs(_dft(vz, 0)[0] - (0.5 * Ko.sum() + 4 * (d[(0, "c")] + eta.sum()))) > 1e-8


def test_corrected_sensor1_expansion_eq18():
    """U'_1 Fourier series against the corrected eq. (18)/(21) [DOMAIN]; tolerance as above."""
    rng = np.random.default_rng(4)
    kf, ko, kio, kii = rng.normal(0, 1e-5, 4)
    dk, eta = 2e-5, 1e-6
    d = {(m, cs): rng.normal(0, 2e-6) for m in range(7) for cs in "cs" if (m, cs) != (0, "s")}
    model = ErrorModel.from_dong2014(K_F=kf, K_I=1 + dk, K_O=ko, K_IO=kio, K_II=kii)
    rig = DividingHeadRig.uniform(24, [model], angle_error=AngleErrorProfile.harmonics(d),
                                  eta=[eta])
    u = simulate(rig).outputs[0, 0]
    np.testing.assert_allclose(_dft(u, 0)[0], kf + kii / 2 + d[(1, "c")] / 2, atol=1e-10)
    np.testing.assert_allclose(_dft(u, 1), (ko + eta + d[(0, "c")] + d[(2, "c")] / 2,
                                            1 + dk + d[(2, "s")] / 2), atol=1e-10)
    np.testing.assert_allclose(_dft(u, 2), ((-kii + d[(1, "c")] + d[(3, "c")]) / 2,
                                            (kio + d[(1, "s")] + d[(3, "s")]) / 2), atol=1e-10)
    for m in (3, 4, 5):
        np.testing.assert_allclose(
            _dft(u, m), ((d[(m - 1, "c")] + d[(m + 1, "c")]) / 2,
                         (d[(m - 1, "s")] + d[(m + 1, "s")]) / 2), atol=1e-10)


# ---------------------------------------------- recovery, harmonics >= 2 only
@pytest.mark.parametrize("method", ["four", "joint"])
def test_noise_free_high_harmonics_recovered_to_second_order(method):
    rig, run, data = _run()
    truth = _truth(MODELS, ETA)
    if method == "four":
        res = four(data)
        rows = FourOperator.build(rig.positions, rig.mounts).coef
    else:
        res = joint(data)
        op = JointOperator.build(rig.positions, rig.mounts)
        rows = (op.to_full @ op.pinv)[:20].reshape(4, 5, -1)
    err = np.abs(_estimates(res) - truth)
    bound = _second_order_bound(rig, run, data, rows)
    assert (err <= bound).all(), (err / bound).max()
    # For arcsecond errors the bound itself is of order 1e-9 V (DOMAIN step 0).
    assert bound.max() < 3e-8
    assert err.max() < 2e-9
    # The single-sensor fit is off by first-order amounts, far outside that bound.
    err_single = np.abs(_estimates(single(data)) - truth)
    assert err_single.max() > 1e3 * err.max()
    assert (err_single[:, [0, 1, 2, 3, 4]].max(axis=0) > 1e-6).all()


def test_gauss_newton_joint_removes_second_order_residual():
    _rig, run, data = _run(first_harmonic=DONG2014_FIRST_HARMONIC)
    res = joint(data, first_harmonic=DONG2014_FIRST_HARMONIC, gauss_newton=True)
    exact = np.array([_exact_truth(m, e) for m, e in zip(MODELS, ETA, strict=True)])
    # noise-free exact model: only rounding remains (coefficients ~1 V; 1e-13 = ~500 ulp)
    np.testing.assert_allclose(_estimates(res), exact, rtol=0, atol=1e-13)
    np.testing.assert_allclose(res.shared.values, run.d_alpha, rtol=0, atol=1e-13)
    linear = joint(data, first_harmonic=DONG2014_FIRST_HARMONIC)
    assert np.abs(_estimates(linear) - exact).max() > 1e-11  # the linear one is not exact
    assert res.assumed("gauss_newton") == "converged"


# ---------------------------------------------------------- first harmonic
@pytest.mark.parametrize("reducer", [four, joint])
def test_first_harmonic_given_is_recovered_and_unknown_gives_predicted_alias(reducer):
    h1 = DONG2014_FIRST_HARMONIC
    rig, _, data = _run(first_harmonic=h1)
    truth = _truth(MODELS, ETA)
    known = _estimates(reducer(data, first_harmonic=h1))
    assert np.abs(known - truth).max() < 2e-9  # second order, as above
    unknown = _estimates(reducer(data))
    alias = first_harmonic_alias(h1, rig.mounts) * truth[:, 1:2]  # [DOMAIN step 4]
    np.testing.assert_allclose(unknown - truth, alias, rtol=0, atol=2e-9)
    assert np.abs(alias).max() > 1.9e-5  # K_I d1c = 1.3 * 1.5e-5: not negligible


def test_dong2014_table1_known_minus_unknown_is_the_gauge_alias():
    """Dong2014 Table 1: B_w (h1 unknown) - B_z (h1 known) must equal the alias with the
    paper's h1 = (1.50e-5, -1.9e-6) rad. Tolerance: half a unit in the last printed digit of
    each of the two values, plus the 2-digit rounding of h1 (0.05e-6 rad * K_I)."""
    table = {  # (B_z, B_w) as printed, K_F, K_IO, K_II per sensor
        0: {"K_F": ("-8.336e-4", "-8.142e-4"), "K_IO": ("-2.849e-5", "-3.093e-5"),
            "K_II": ("3.91e-6", "-1.552e-5")},
        1: {"K_F": ("-4.133e-3", "-4.131e-3"), "K_IO": ("7.93e-6", "2.774e-5"),
            "K_II": ("1.573e-5", "1.325e-5")},
        2: {"K_F": ("-9.2e-4", "-9.397e-4"), "K_IO": ("-1.905e-5", "-1.661e-5"),
            "K_II": ("7.41e-6", "2.682e-5")},
        3: {"K_F": ("-1.2999e-3", "-1.3e-3"), "K_IO": ("-9.327e-6", "-2.877e-5"),
            "K_II": ("2.48e-6", "4.92e-6")},
    }
    k_i = [1.2993698, 1.3245304, 1.297999, 1.29999]
    alias = first_harmonic_alias(DONG2014_FIRST_HARMONIC, np.radians([0, 90, 180, 270]))

    def half_ulp(text):
        mant, exp = text.split("e")
        decimals = len(mant.split(".")[1]) if "." in mant else 0
        return 0.5 * 10.0 ** (int(exp) - decimals)

    for k, entries in table.items():
        for name, (bz, bw) in entries.items():
            i = COEFFICIENTS.index(name)
            tol = half_ulp(bz) + half_ulp(bw) + 0.05e-6 * k_i[k]
            assert abs((float(bw) - float(bz)) - alias[k, i] * k_i[k]) <= tol, (k, name)


# ------------------------------------------------------------- identifiability
@pytest.mark.parametrize(("mounts", "dim"), [
    ([0], 5), ([0, 180], 5), ([0, 90], 3), ([0, 45], 3), ([0, 90, 180], 3),
    ([0, 90, 180, 270], 3), ([0, 120, 240], 3), ([0, 180, 30], 3),
])
def test_joint_null_space_dimension(mounts, dim):
    assert null_space_dim(identifiability(uniform_positions(24), np.radians(mounts))) == dim


@settings(max_examples=25, deadline=None)
@given(st.lists(st.integers(0, 23), min_size=2, max_size=5), st.integers(12, 30))
def test_null_space_is_three_unless_all_sensors_are_on_one_line(steps, n):
    # phases on a 15 deg grid so that exact 0/180 (and equal) mounts occur
    phi = np.radians(15.0 * np.array(steps))
    on_line = all(s % 12 == steps[0] % 12 for s in steps)
    rng = np.random.default_rng(n)
    alpha = np.sort(rng.uniform(0, 2 * np.pi, n))
    if np.diff(np.append(alpha, alpha[0] + 2 * np.pi)).min() < 1e-3:
        return
    info = identifiability(alpha, phi)
    if on_line:
        assert null_space_dim(info) == 5
    else:
        assert null_space_dim(info) == 3


def test_single_sensor_joint_refused():
    _, _, data = _run(models=MODELS[:1], eta=ETA[:1], mounts=[0.0])
    with pytest.raises(AccelcalError, match=r"not identifiable|no degree"):
        joint(data)


# ------------------------------------------------------- non-uniform, autocollimator
def test_joint_on_non_uniform_positions_and_three_sensors():
    rng = np.random.default_rng(7)
    alpha = np.sort(rng.uniform(0, 2 * np.pi, 19))
    models = MODELS[:3]
    rig = DividingHeadRig(alpha, models, mounts=np.radians([0, 100, 230]),
                          angle_error=AngleErrorProfile.harmonics({(2, "c"): 2 * ARCSEC,
                                                                  (6, "s"): 1 * ARCSEC}))
    run = simulate(rig)
    data = HeadData.build(alpha, run.outputs, rig.mounts)
    res = joint(data)
    # non-uniform positions: the gauge is the LS mean and first harmonic of d over them
    c = np.stack([np.ones_like(alpha), np.cos(alpha), np.sin(alpha)], -1)
    g = np.linalg.lstsq(c, run.d_alpha, rcond=None)[0]
    truth = _truth(models, 0.0, g[0]) + first_harmonic_alias(g[1:], rig.mounts) * \
        np.array([m.K1 for m in models])[:, None]
    np.testing.assert_allclose(_estimates(res), truth, rtol=0, atol=2e-9)
    with pytest.raises(AccelcalError, match="equally spaced"):
        four(data)


def test_joint_with_autocollimator_readings_recovers_first_harmonic():
    h1 = DONG2014_FIRST_HARMONIC
    _rig, run, data = _run(first_harmonic=h1)
    res = joint(data, autocollimator=run.d_alpha + 1e-3, autocollimator_sd=5e-7)
    truth = _truth(MODELS, ETA)
    np.testing.assert_allclose(_estimates(res), truth, rtol=0, atol=2e-9)
    std = np.array([e.std for e in res.sensors])
    assert np.isfinite(std).all()


# ------------------------------------------------------------------- errors
def test_bad_inputs_raise_clear_errors():
    rig, run, _ = _run()
    alpha = rig.positions.copy()
    with pytest.raises(AccelcalError, match="repeat the angle"):
        HeadData.build(np.r_[alpha[:-1], alpha[0]], run.outputs, rig.mounts)
    bad = run.outputs.copy()
    bad[0, 1, 3] = np.nan
    with pytest.raises(AccelcalError, match="NaN"):
        HeadData.build(alpha, bad, rig.mounts)
    with pytest.raises(AccelcalError, match="mount phases"):
        HeadData.build(alpha, run.outputs, rig.mounts[:3])
    few = HeadData.build(alpha[:5], run.outputs[..., :5], rig.mounts)
    with pytest.raises(AccelcalError, match="at least 6"):
        single(few)
    with pytest.raises(AccelcalError, match="at least 12"):
        four(few)
    with pytest.raises(AccelcalError, match="unknown method"):
        reduce(few, "fourier")
    data = HeadData.build(alpha, run.outputs, rig.mounts)
    with pytest.raises(AccelcalError, match="doubled phases"):
        four(HeadData.build(alpha, run.outputs[:, :3], rig.mounts[:3]))
    with pytest.raises(AccelcalError, match="first harmonic"):
        four(data, first_harmonic=(1.0, np.nan))


def test_formal_sd_of_first_harmonic_term_is_added():
    """Step 7: with h1 known to sd u, var(K_F) grows by (K_I u)^2 for sensor 1 (c' = d1c)."""
    _, _, data = _run()
    a = four(data, first_harmonic=(0.0, 0.0))
    b = four(data, first_harmonic=(0.0, 0.0), first_harmonic_sd=5e-7)
    k_i = scale_factors(data)[0]  # step-0 scale factor, which scales the covariance
    np.testing.assert_allclose(b.sensors[0].std_of("K_F") ** 2 - a.sensors[0].std_of("K_F") ** 2,
                               (k_i * 5e-7) ** 2, rtol=1e-9)


def test_tumble_path_on_the_head():
    tumble = pytest.importorskip("accelcal.methods.tumble")
    if not hasattr(tumble, "reduce_tumble"):
        pytest.skip("accelcal.methods.tumble.reduce_tumble not available")
    _rig, _, data = _run(profile=AngleErrorProfile(), eta=np.zeros(4))
    res = reduce(data, "tumble")
    truth = _truth(MODELS, np.zeros(4))
    # exact data without head error: the IEEE Fourier reduction recovers each coefficient
    np.testing.assert_allclose(_estimates(res), truth, rtol=0, atol=1e-12)


def test_repeats_are_averaged():
    rig = DividingHeadRig.uniform(24, MODELS, noise=1e-6, repeats=4)
    run = simulate(rig, 1)
    data = HeadData.build(rig.positions, run.outputs, rig.mounts)
    assert data.repeats == 4
    np.testing.assert_allclose(data.outputs, run.outputs.mean(axis=0))
    assert DEG > 0


@settings(max_examples=15, deadline=None)
@given(
    coef=st.lists(st.floats(-5e-5, 5e-5), min_size=16, max_size=16),
    scale=st.lists(st.floats(0.5, 2.0), min_size=4, max_size=4),
    harm=st.lists(st.floats(-3.0, 3.0), min_size=8, max_size=8),
    n=st.sampled_from([12, 16, 24, 36]),
)
def test_property_four_and_joint_recover_random_truth(coef, scale, harm, n):
    """Random sensors, random harmonics 2-5 (arcsec), several n: both methods are within the
    stated second-order bound of the first-order truth."""
    c = np.reshape(coef, (4, 4))
    models = [ErrorModel.from_dong2014(K_F=c[k, 0], K_I=scale[k], K_O=c[k, 1], K_IO=c[k, 2],
                                       K_II=c[k, 3]) for k in range(4)]
    terms = {(m, cs): harm[2 * (m - 2) + i] * ARCSEC
             for m in range(2, 6) for i, cs in enumerate("cs")}
    rig, run, data = _run(profile=AngleErrorProfile.harmonics(terms), n=n, models=models)
    truth = _truth(models, ETA)
    op = JointOperator.build(rig.positions, rig.mounts)
    for res, rows in ((four(data), FourOperator.build(rig.positions, rig.mounts).coef),
                      (joint(data), (op.to_full @ op.pinv)[:20].reshape(4, 5, -1))):
        err = np.abs(_estimates(res) - truth)
        assert (err <= _second_order_bound(rig, run, data, rows)).all()


def test_joint_angle_error_covariance_matches_scatter():
    """Per-position head-error estimates: formal SD (s^2 times the unit covariance) against
    the scatter over 3000 noisy trials, vectorised with the joint operator. Relative SE of an
    RMS over 3000 trials ~1.3 %; tolerance 6 % per position."""
    rig = DividingHeadRig.uniform(24, MODELS, angle_error=AngleErrorProfile.uniform(2 * ARCSEC),
                                  noise=2e-6)
    sim = simulate(rig, 21, trials=3000)
    u = sim.outputs[:, 0]
    k_i = scale_factors(rig.sensor_angles(), u)
    un = (u / k_i[..., None]).reshape(3000, -1)
    op = JointOperator.build(rig.positions, rig.mounts)
    est = (un @ op.pinv.T) @ op.to_full.T
    d_hat = est[:, 20:]
    c = np.stack([np.ones(24), np.cos(rig.positions), np.sin(rig.positions)], -1)
    d_true = sim.d_alpha - sim.d_alpha @ np.linalg.pinv(c).T @ c.T  # gauge removed
    rms = np.sqrt(((d_hat - d_true) ** 2).mean(axis=0))
    s2 = ((un @ op.resid.T) ** 2).sum(-1) / op.dof
    formal = np.sqrt(s2.mean() * np.diag(op.cov_unit)[20:])
    np.testing.assert_allclose(rms, formal, rtol=0.06)


def test_result_frame_and_plot(tmp_path):
    _rig, run, data = _run()
    res = joint(data)
    frame = res.to_frame()
    assert len(frame) == 20
    assert {"estimate", "std"} <= set(frame.columns)
    assert frame.loc[("U1", "K_I"), "estimate"] == pytest.approx(MODELS[0].K1, rel=1e-8)
    paths = res.plot(tmp_path, truth=run.d_alpha)
    assert {p.name for p in paths} == {"dividing_head_residuals.png",
                                       "dividing_head_residuals.svg",
                                       "dividing_head_angle_error.png",
                                       "dividing_head_angle_error.svg"}


# Head errors of harmonics >= 2 only (fixed) and a known first harmonic: the
# scatter of `four` is then the readings' noise alone.
_FIXED_HEAD = AngleErrorProfile.harmonics({(2, "c"): 3 * ARCSEC, (3, "s"): ARCSEC,
                                           (5, "c"): 0.7 * ARCSEC})
_H1 = (1e-5, -2e-6)


def _four_trials(noise, trials, seed, covariance):
    rig = DividingHeadRig.uniform(24, MODELS, angle_error=_FIXED_HEAD, first_harmonic=_H1,
                                  noise=noise)
    sim = simulate(rig, seed, trials=trials)
    out = [four(HeadData.build(rig.positions, sim.outputs[t], rig.mounts), first_harmonic=_H1,
                covariance=covariance) for t in range(trials)]
    return rig, sim, out


@pytest.mark.slow
def test_four_propagated_covariance_is_exact_for_the_linear_method():
    """Unequal noise per sensor (1-5 uV): the covariance propagated with the true variances
    against the scatter of 3000 reductions. An SD from 3000 trials has a relative standard
    error 1/sqrt(2 x 2999) = 1.3 %; tolerance 4 of them. The paper's step-7 SDs fall short
    (< 0.8 of the scatter for every coefficient of sensors 1, 2 and 4)."""
    noise = np.array([2.8e-6, 1.0e-6, 5.0e-6, 2.0e-6])
    trials = 3000
    rig, sim, out = _four_trials(noise, trials, 4, "paper")
    est = np.array([[e.values for e in r.sensors] for r in out])
    scatter = est.std(axis=0, ddof=1)
    k_i = scale_factors(HeadData.build(rig.positions, sim.outputs[0], rig.mounts))
    op = FourOperator.build(rig.positions, rig.mounts)
    full = op.propagated_covariance((noise / k_i) ** 2)
    sd = np.sqrt(np.diag(full)[:20]).reshape(4, 5) * k_i[:, None]
    np.testing.assert_allclose(sd / scatter, 1.0, atol=4 / np.sqrt(2 * (trials - 1)))
    paper = np.mean([[e.std for e in r.sensors] for r in out], axis=0)
    assert np.all((paper / scatter)[[0, 1, 3]] < 0.8)


@pytest.mark.slow
def test_four_propagated_sds_match_the_scatter():
    """Equal noise 2.8 uV (Dong2014 Table 1), variances estimated from each data set
    (unbiased: test_uncertainty_dividing_head.py). The propagated SDs are 0.93-1.05
    of the scatter of 3000 reductions: an SD from an estimated variance averages a little
    low (sensor 1 carries the most contaminated residual, ~9 degrees of freedom:
    E[s]/sigma ~ 0.97), plus 4 standard errors (1.3 % each) of the scatter."""
    _rig, _sim, out = _four_trials(2.8e-6, 3000, 5, "propagated")
    est = np.array([[e.values for e in r.sensors] for r in out])
    ratio = np.mean([[e.std for e in r.sensors] for r in out], axis=0) / est.std(axis=0, ddof=1)
    assert np.all((ratio > 0.93) & (ratio < 1.05)), ratio


def test_residual_noise_variances_pool_without_a_non_negative_solution():
    # two sensors, residual operator with cross terms: M = [[2, 1], [1, 2]]
    op = np.zeros((2, 1, 2, 1))
    op[0, 0, 0, 0] = op[1, 0, 1, 0] = np.sqrt(2.0)
    op[0, 0, 1, 0] = op[1, 0, 0, 0] = 1.0
    r = np.array([[[np.sqrt(3.0)], [np.sqrt(3.0)]],   # |r|^2 = (3, 3): s^2 = (1, 1)
                  [[np.sqrt(1.0)], [np.sqrt(5.0)]]])  # (1, 5): s^2 = (-1, 3) -> pooled 1
    np.testing.assert_allclose(residual_noise_variances(op, r), [[1, 1], [1, 1]], rtol=1e-14)
    np.testing.assert_allclose(residual_noise_variances(op, r[1], pooled=False), [1, 1])
    np.testing.assert_allclose(residual_noise_variances(op, r[0], pooled=True), [1, 1])


def test_four_propagated_result_is_consistent():
    rig, sim, out = _four_trials(2.8e-6, 1, 6, "propagated")
    r = out[0]
    data = HeadData.build(rig.positions, sim.outputs[0], rig.mounts)
    paper = four(data, first_harmonic=_H1, first_harmonic_sd=(5e-7, 5e-7), covariance="paper")
    prop = four(data, first_harmonic=_H1, first_harmonic_sd=(5e-7, 5e-7))  # the default
    assert paper.covariance is None
    assert prop.covariance.shape == (20 + 24, 20 + 24)
    np.testing.assert_array_equal(_estimates(prop), _estimates(paper))  # same estimates
    for k, e in enumerate(prop.sensors):
        np.testing.assert_array_equal(e.covariance, prop.covariance[5 * k:5 * k + 5,
                                                                    5 * k:5 * k + 5])
    np.testing.assert_array_equal(prop.shared.covariance, prop.covariance[20:, 20:])
    # the first-harmonic term is the same in both: remove it and compare what is left
    without = four(data, first_harmonic=_H1, covariance="propagated")
    extra = prop.covariance - without.covariance
    h1_part = paper.sensors[0].covariance - \
        four(data, first_harmonic=_H1, covariance="paper").sensors[0].covariance
    np.testing.assert_allclose(extra[:5, :5], h1_part, rtol=1e-9, atol=1e-30)
    assert np.all(np.linalg.eigvalsh(prop.covariance) > -1e-12 * np.abs(prop.covariance).max())
    assert r.assumed("covariance") == "propagated"
    with pytest.raises(AccelcalError, match="covariance: 'exact' is not one of paper, propagated"):
        four(data, covariance="exact")


def test_gauss_newton_with_autocollimator_readings():
    """Noise-free exact model, first harmonic not given: the readings (offset by an arbitrary
    zero) fix it, and the iteration removes the linear solution's second-order residual
    (1e-13: rounding, as without readings). With noise the covariance is the linear one to
    first order: the Jacobians differ by O(d_alpha + eta) ~ 1e-5 relative."""
    h1 = DONG2014_FIRST_HARMONIC
    _rig, run, data = _run(first_harmonic=h1)
    readings = run.d_alpha + 1e-3
    res = joint(data, autocollimator=readings, autocollimator_sd=5e-7, gauss_newton=True)
    exact = np.array([_exact_truth(m, e) for m, e in zip(MODELS, ETA, strict=True)])
    np.testing.assert_allclose(_estimates(res), exact, rtol=0, atol=1e-13)
    np.testing.assert_allclose(res.shared.values, run.d_alpha, rtol=0, atol=1e-13)
    linear = joint(data, autocollimator=readings, autocollimator_sd=5e-7)
    assert np.abs(_estimates(linear) - exact).max() > 1e-11
    assert res.assumed("gauss_newton") == "converged"

    rig = DividingHeadRig.uniform(24, MODELS, angle_error=HIGH, eta=ETA, first_harmonic=h1,
                                  noise=2.8e-6)
    sim = simulate(rig, 8)
    noisy = HeadData.build(rig.positions, sim.outputs, rig.mounts)
    kwargs = {"autocollimator": sim.d_alpha, "autocollimator_sd": 2e-7}
    gn = joint(noisy, gauss_newton=True, **kwargs)
    lin = joint(noisy, **kwargs)
    np.testing.assert_allclose(gn.covariance, lin.covariance, rtol=0,
                               atol=1e-4 * np.abs(lin.covariance).max())
    np.testing.assert_allclose(np.diag(gn.covariance), np.diag(lin.covariance), rtol=1e-3)
