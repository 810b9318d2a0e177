"""Transverse sensitivity: closed forms (DOMAIN section 3) against time-domain simulation."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

from accelcal.errors import AccelcalError
from accelcal.methods import transverse as tr
from accelcal.model import ErrorModel
from accelcal.rigs.shaker import LinearModel, ShakerRig

THETA = np.deg2rad(np.arange(0.0, 360.0, 5.0))
AMPS = (1.0, 5.0, 20.0, 50.0)
# fs/f = 64 (a multiple of 4) with phase 0: samples hit a_v = +-A_v exactly,
# so the sampled peak equals the continuous one where the extreme is at an end.
RIG = {"frequency": 160.0, "sample_rate": 10240.0, "periods": 4.0}

# Cross-axis terms of navigation-grade size, no bias: with k_0 = 0 the extreme
# of |u_T| over a period is always at a_v = +-A_v (DOMAIN section 3), so the
# peak closed form is exact on this sample grid.
INERTIAL = ErrorModel.from_guantang(k_i=1000.0, k_o=2e-4, k_p=-1e-4, k_oo=3e-5, k_pp=-2e-5,
                                    k_op=1e-5, output_unit="mV")


def _sim(sensor, amp, estimator, gravity=0.0, theta=THETA, **rig):
    rec = ShakerRig(amplitude=amp, gravity=gravity, **{**RIG, **rig}).simulate(sensor, theta)
    return tr.estimate_sT(rec, estimator, s_I=tr.axial_sensitivity(sensor))


@pytest.mark.parametrize("estimator", tr.ESTIMATORS)
@pytest.mark.parametrize("amp", AMPS)
def test_linear_model_gives_figure_of_eight_for_every_estimator(estimator, amp):
    lin = LinearModel(s_i=1000.0, s_o=-0.2, s_p=0.2)  # zeros at 45, 225 deg
    sw = _sim(lin, amp, estimator)
    expected = tr.linear_sT(THETA, lin)
    # independent route: the defining sum |s_o sin + s_p cos| (GuanTang eq. (7));
    # 1e-12 relative to the maximum: rounding of the sampled sine and the fit.
    np.testing.assert_allclose(expected, np.abs(-0.2 * np.sin(THETA) + 0.2 * np.cos(THETA)),
                               rtol=0, atol=1e-14)
    np.testing.assert_allclose(sw.sT, expected, rtol=0, atol=1e-12 * expected.max())
    assert sw.estimator == estimator
    assert sw.summary()["local_maxima"] == 2
    assert sw.summary()["S_Tmin"] < 1e-12 * expected.max()


@pytest.mark.parametrize(
    ("estimator", "gravity"), [("peak", 0.0), ("fundamental", 0.0), ("fundamental", 1.0)]
)
@pytest.mark.parametrize("amp", AMPS)
def test_inertial_closed_form_matches_simulation(estimator, amp, gravity):
    # (half-p2p, and peak under gravity, can have an extreme inside the
    # period, off the sample grid: see test_interior_extreme_within_sampling_bound)
    sw = _sim(INERTIAL, amp, estimator, gravity)
    cf = tr.closed_form_sT(INERTIAL, THETA, amp, estimator, gravity=gravity)
    # noise-free, extremes on the sample grid: rounding only (1e-12 relative)
    np.testing.assert_allclose(sw.sT, cf, rtol=0, atol=1e-12 * cf.max())


@pytest.mark.parametrize("estimator", ["peak", "half-p2p"])
def test_without_second_order_terms_half_p2p_is_the_figure_of_eight(estimator):
    # C = 0: u_T = k_i (k_0 + a_v B) is linear in a_v, so half-p2p removes k_0
    # and gives k_i |B| exactly; peak gives k_i (|k_0|/A_v + |B|) (DOMAIN section 3)
    m = INERTIAL.replace(Koo=0.0, Kpp=0.0, Kop=0.0, K0=4e-5)
    b = 1000.0 * np.abs(tr.cross_axis_B(THETA, m))
    for amp in AMPS:
        sw = _sim(m, amp, estimator)
        expected = b if estimator == "half-p2p" else b + 1000.0 * 4e-5 / amp
        np.testing.assert_allclose(sw.sT, expected, rtol=0, atol=1e-12 * expected.max())
        cf = tr.closed_form_sT(m, THETA, amp, estimator)
        np.testing.assert_allclose(cf, expected, rtol=0, atol=1e-12 * expected.max())


def test_fundamental_is_ki_abs_B_independent_of_amplitude():
    b = tr.cross_axis_B(THETA, INERTIAL)
    curves = [_sim(INERTIAL, a, "fundamental").sT for a in AMPS]
    for c in curves:
        np.testing.assert_allclose(c, 1000.0 * np.abs(b), rtol=0, atol=1e-12 * 1000 * 2.3e-4)
    ext = tr.fundamental_extremes(INERTIAL)
    fine = np.deg2rad(np.arange(0, 180, 0.01))
    dense = 1000.0 * np.abs(tr.cross_axis_B(fine, INERTIAL))
    assert ext["S_Tmax"] == pytest.approx(dense.max(), rel=1e-8)
    assert ext["theta_max_deg"] == pytest.approx(np.rad2deg(fine[np.argmax(dense)]), abs=0.01)


def test_fundamental_with_gravity_is_ki_abs_B_plus_2gC():
    b, c = tr.cross_axis_B(THETA, INERTIAL), tr.cross_axis_C(THETA, INERTIAL)
    expected = 1000.0 * np.abs(b + 2 * 1.0 * c)
    for amp in AMPS:
        sw = _sim(INERTIAL, amp, "fundamental", gravity=1.0)
        np.testing.assert_allclose(sw.sT, expected, rtol=0, atol=1e-12 * expected.max())
    # and it differs from the gravity-free figure of eight by far more than rounding
    assert np.max(np.abs(expected - 1000.0 * np.abs(b))) > 1e-3 * expected.max()


def test_peak_depends_on_amplitude_with_nonzero_minimum():
    model = tr.GUANTANG_FIG4  # k_0 != 0, as in the paper
    mins, maxima = [], []
    for amp in AMPS:
        s = _sim(model, amp, "peak", periods=8.0).summary()
        mins.append(s["S_Tmin"])
        maxima.append(s["local_maxima"])
    assert min(mins) > 0.01  # mV/g: k_0 and the a_v^2 term keep it off zero
    assert len(set(np.round(mins, 6))) == len(AMPS)  # changes with A_v
    # GuanTang section 4, inference 1: four local maxima (at the larger amplitudes)
    assert maxima[-1] == 4


def test_C_second_harmonic_form_eq24():
    # Eq. (24) [GuanTang]: C = (koo+kpp)/2 + (kpp-koo)/2 cos 2t + kop/2 sin 2t
    m = INERTIAL
    c2 = ((m.Koo + m.Kpp) / 2 + (m.Kpp - m.Koo) / 2 * np.cos(2 * THETA)
          + m.Kop / 2 * np.sin(2 * THETA))
    np.testing.assert_allclose(tr.cross_axis_C(THETA, m), c2, rtol=0, atol=1e-19)


@settings(max_examples=15, deadline=None)
@given(theta=st.floats(0, 2 * np.pi), gravity=st.sampled_from([0.0, 1.0]),
       amp=st.floats(0.5, 60.0))
def test_fundamental_closed_form_by_quadrature(theta, gravity, amp):
    # Independent route: Fourier coefficient of the model's output over one
    # period by adaptive quadrature (scipy), no sampling, no sine fit.
    m = tr.GUANTANG_FIG4

    def u(t, trig):
        a = gravity + amp * np.sin(t)
        return float(m.output(0.0, a * np.sin(theta), a * np.cos(theta))) * trig(t)

    a1 = quad(u, 0, 2 * np.pi, args=(np.sin,), epsabs=1e-11, epsrel=1e-10, limit=200)[0] / np.pi
    b1 = quad(u, 0, 2 * np.pi, args=(np.cos,), epsabs=1e-11, epsrel=1e-10, limit=200)[0] / np.pi
    cf = tr.closed_form_sT(m, np.array([theta]), amp, "fundamental", gravity=gravity)[0]
    # quadrature error 1e-10 relative on an integrand of size ~K1 (k_0 + B A + C A^2)
    assert np.hypot(a1, b1) / amp == pytest.approx(cf, rel=1e-8, abs=1e-9)


def test_interior_extreme_within_sampling_bound():
    # With gravity (or a bias) the extreme of u_T can lie inside the period,
    # where samples need not fall. The sampled value is below the continuous
    # one by at most K1 |C| (dx/2)^2 / A_v, dx = A_v w / fs the largest step in a_v.
    for amp, est, g in [(1.0, "peak", 1.0), (5.0, "peak", 1.0), (1.0, "half-p2p", 0.0),
                        (5.0, "half-p2p", 1.0), (50.0, "half-p2p", 0.0)]:
        sw = _sim(tr.GUANTANG_FIG4, amp, est, gravity=g)
        cf = tr.closed_form_sT(tr.GUANTANG_FIG4, THETA, amp, est, gravity=g)
        c = np.abs(tr.cross_axis_C(THETA, tr.GUANTANG_FIG4))
        dx = amp * 2 * np.pi * RIG["frequency"] / RIG["sample_rate"]
        bound = 1000.0 * c * (dx / 2) ** 2 / amp + 1e-12 * cf.max()
        assert np.all(cf - sw.sT >= -1e-12 * cf.max())  # sampled never exceeds it
        assert np.all(cf - sw.sT <= bound)
        assert np.max(cf - sw.sT) > 0  # the case really has an interior extreme


def test_noise_within_stated_uncertainty():
    rng = np.random.default_rng(2024)
    model = INERTIAL.replace(sigma=2e-6)
    theta = THETA[::3]
    for est in tr.ESTIMATORS:
        rec = ShakerRig(amplitude=5.0, **RIG).simulate(model, theta, rng=rng)
        sw = tr.estimate_sT(rec, est, s_I=tr.axial_sensitivity(model))
        cf = tr.closed_form_sT(model, theta, 5.0, est)
        err = np.abs(sw.sT - cf)
        if est == "fundamental":
            # Gaussian standard uncertainty: all of 24 within 4 std (p ~ 1e-3)
            assert np.all(err <= 4 * sw.sT_std)
        else:
            # the stated bound: expected extreme of the noise plus one std
            assert np.all(err <= sw.sT_std)


def test_fundamental_std_matches_monte_carlo():
    rng = np.random.default_rng(7)
    model = INERTIAL.replace(sigma=5e-6)
    theta = THETA[::6]
    rec = ShakerRig(amplitude=2.0, **RIG).simulate(model, theta, rng=rng, trials=2000)
    sw = tr.estimate_sT(rec, "fundamental", s_I=1000.0)
    scatter = sw.sT.std(axis=0)
    stated = sw.sT_std.mean(axis=0)
    # 2000 trials: sample std within 8 % (5 sigma of 1.6 %), where the
    # amplitude is large against the noise (|B| away from its zeros)
    big = tr.closed_form_sT(model, theta, 2.0, "fundamental") > 10 * stated
    np.testing.assert_allclose(scatter[big], stated[big], rtol=0.08)


def test_axial_sensitivity_definitions():
    # GuanTang eq. (25): s_I = k_i (k_0 + 1 + k_ii + k_iii) = 1000.055 mV/g
    assert tr.axial_sensitivity(tr.GUANTANG_FIG4) == pytest.approx(1000.055, rel=1e-13)
    # symmetric: k_i (1 + k_iii) (DOMAIN section 3)
    m = tr.GUANTANG_FIG4.replace(K3=3e-6)
    assert tr.axial_sensitivity(m, "symmetric") == pytest.approx(1000.0 * (1 + 3e-6), rel=1e-13)
    with pytest.raises(AccelcalError, match="axial definition"):
        tr.axial_sensitivity(m, "eq19")


def test_linear_alpha_quadrant_when_s_o_negative():
    # the paper's alpha = arctan(s_p/s_o) is off by pi for s_o < 0; |sin| hides
    # it for s_T, but the angle of the maximum must be right
    lin = LinearModel(s_i=1.0, s_o=-1.0, s_p=0.0)
    assert tr.linear_sT(np.pi / 2, lin) == pytest.approx(1.0)
    assert tr.linear_sT(0.0, lin) == pytest.approx(0.0, abs=1e-15)  # sin(pi) rounding


@pytest.mark.parametrize(
    ("angles", "minimum", "match"),
    [([0, 360], 1, "one full turn"), ([-10, 355], 1, "one full turn"), ([400], 1, "full turn"),
     ([0, 10], 3, "at least 3"), ([5, 365 - 360, 10], 1, "repeat")],
)
def test_angle_validation(angles, minimum, match):
    with pytest.raises(AccelcalError, match=match):
        tr.check_angles(angles, minimum=minimum)


def test_bad_records():
    rig = ShakerRig(amplitude=0.0, **RIG)
    rec = rig.simulate(INERTIAL, THETA[:4])
    with pytest.raises(AccelcalError, match="reference amplitude is zero"):
        tr.estimate_sT(rec, "fundamental", s_I=1000.0)
    with pytest.raises(AccelcalError, match="shorter than one period"):
        ShakerRig(amplitude=1.0, periods=0.5)
    with pytest.raises(AccelcalError, match="estimator"):
        tr.closed_form_sT(INERTIAL, THETA, 1.0, "rms")
    from dataclasses import replace

    good = ShakerRig(amplitude=1.0, **RIG).simulate(INERTIAL, THETA[:4])
    with pytest.raises(AccelcalError, match="equal length"):
        replace(good, u=good.u[:, :-3])


def test_unknown_frequency_four_parameter_fit():
    # the shaker runs at 160.37 Hz while the records say 160 Hz: the
    # three-parameter fit at the wrong frequency is biased; fitting the
    # frequency to the reference first (IEEE 1057 four-parameter) restores
    # the closed form (noise-free; 1e-9 relative, the frequency's convergence)
    from dataclasses import replace

    rec = ShakerRig(amplitude=5.0, frequency=160.37, sample_rate=10240.0,
                    periods=8.0).simulate(INERTIAL, THETA)
    wrong = replace(rec, frequency=160.0)
    cf = tr.closed_form_sT(INERTIAL, THETA, 5.0, "fundamental")
    biased = tr.estimate_sT(wrong, "fundamental", s_I=1000.0).sT
    assert np.max(np.abs(biased - cf)) > 2e-6 * cf.max()  # small: the ratio cancels most
    fixed = tr.with_fitted_frequency(wrong)
    assert fixed.frequency == pytest.approx(160.37, rel=1e-12)
    sw = tr.estimate_sT(fixed, "fundamental", s_I=1000.0)
    np.testing.assert_allclose(sw.sT, cf, rtol=0, atol=1e-9 * cf.max())
