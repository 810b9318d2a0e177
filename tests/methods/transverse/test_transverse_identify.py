"""Identification of k_o, k_p, k_oo, k_pp, k_op from shaker records (contract tests)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from accelcal.errors import AccelcalError
from accelcal.methods import transverse as tr
from accelcal.model import ErrorModel
from accelcal.rigs.shaker import ShakerRig

THETA = np.deg2rad(np.arange(0.0, 360.0, 30.0))
NAMES = ("Ko", "Kp", "Koo", "Kpp", "Kop")
RIG = {"frequency": 160.0, "sample_rate": 10240.0, "periods": 4.0}

coef = st.floats(-3e-4, 3e-4)
quad = st.floats(-5e-5, 5e-5)


def _truth(ko, kp, koo, kpp, kop, **other):
    return ErrorModel.from_guantang(k_i=1000.0, k_0=4e-5, k_o=ko, k_p=kp, k_oo=koo, k_pp=kpp,
                                    k_op=kop, output_unit="mV", **other)


@settings(max_examples=20, deadline=None)
@given(ko=coef, kp=coef, koo=quad, kpp=quad, kop=quad,
       route=st.sampled_from(["2w", "dc", "both"]), gravity=st.sampled_from([0.0, 1.0]),
       amp=st.sampled_from([2.0, 5.0, 20.0]), phase=st.floats(-np.pi, np.pi),
       periods=st.sampled_from([4.0, 3.37]))
def test_contract_noise_free_recovers_truth(*, ko, kp, koo, kpp, kop, route, gravity, amp, phase,
                                            periods):
    truth = _truth(ko, kp, koo, kpp, kop)
    rig = ShakerRig(amplitude=amp, gravity=gravity, phase=phase, rest=True,
                    **{**RIG, "periods": periods})
    red = tr.identify(rig.simulate(truth, THETA), route=route)
    est = red.estimate
    assert est.names == NAMES
    assert red.method == est.method == f"transverse/{route}"
    assert red.family == "transverse"
    # noise-free: exact to rounding of the sine fits; output ~ k_i * 50 * A_v^2 * 5e-5
    # mV against coefficients ~1e-4: absolute 1e-12 on each coefficient
    np.testing.assert_allclose(est.values, [ko, kp, koo, kpp, kop], rtol=0, atol=1e-12)


@settings(max_examples=10, deadline=None)
@given(ko=coef, kp=coef, koo=quad, kpp=quad, kop=quad, ratio=st.floats(0.005, 0.1),
       direction=st.floats(0.3, 2.8), tphase=st.floats(-np.pi, np.pi))
def test_shaker_transverse_motion_is_separated(*, ko, kp, koo, kpp, kop, ratio, direction,
                                               tphase):
    # the shaker moves also across its axis, partly along IA (which the sensor
    # sees at full scale factor); the reference channels measure the motion
    truth = _truth(ko, kp, koo, kpp, kop, k_io=2e-5, k_ip=-1e-5, k_ii=8e-6, k_iii=1e-6)
    rig = ShakerRig(amplitude=5.0, gravity=1.0, transverse_ratio=ratio,
                    transverse_direction=direction, transverse_phase=tphase,
                    measure_transverse=True, **RIG)
    rec = rig.simulate(truth, THETA)
    base = truth.replace(Ko=0.0, Kp=0.0, Koo=0.0, Kpp=0.0, Kop=0.0)
    est = tr.identify(rec, route="2w", base=base).estimate
    np.testing.assert_allclose(est.values, [ko, kp, koo, kpp, kop], rtol=0, atol=1e-12)
    # without the measured motion (its IA part is >= 0.29 of it) the result is
    # wrong by far more than rounding
    blind = ShakerRig(amplitude=5.0, gravity=1.0, transverse_ratio=ratio,
                      transverse_direction=direction, transverse_phase=tphase, **RIG)
    est_blind = tr.identify(blind.simulate(truth, THETA), route="2w", base=base).estimate
    assert np.max(np.abs(est_blind.values - est.values)) > 1e-9


def test_covariance_matches_monte_carlo_scatter():
    truth = _truth(2e-4, -1e-4, 3e-5, -2e-5, 1e-5).replace(sigma=2e-5)
    rig = ShakerRig(amplitude=3.0, gravity=1.0, rest=True, **RIG)
    trials = 300
    rec = rig.simulate(truth, THETA, rng=np.random.default_rng(99), trials=trials)
    for route in ("2w", "dc"):
        values, cov = tr.identify_arrays(rec, route=route)
        scatter = values.std(axis=0, ddof=1)
        stated = np.sqrt(np.diagonal(cov, axis1=-2, axis2=-1)).mean(axis=0)
        # 300 trials: the sample std has a 4.1 % relative standard error; 20 %
        # is about 5 of them
        np.testing.assert_allclose(scatter, stated, rtol=0.2)
        # unbiased: mean within 5 standard errors of the truth
        err = values.mean(axis=0) - np.array([2e-4, -1e-4, 3e-5, -2e-5, 1e-5])
        assert np.all(np.abs(err) < 5 * stated / np.sqrt(trials))
    # the single-record Estimate carries the same covariance
    one = rig.simulate(truth, THETA, rng=np.random.default_rng(1))
    est = tr.identify(one, route="dc").estimate
    v1, c1 = tr.identify_arrays(one, route="dc")
    np.testing.assert_allclose(est.values, v1, rtol=1e-9, atol=1e-18)
    np.testing.assert_allclose(est.covariance, c1, rtol=1e-9)
    assert est.units["Ko"] == "g/g"
    assert est.units["Koo"] == "g/g^2"


def test_w_route_needs_gravity_for_second_order_terms():
    truth = _truth(2e-4, -1e-4, 3e-5, -2e-5, 1e-5)
    rec0 = ShakerRig(amplitude=5.0, **RIG).simulate(truth, THETA)
    with pytest.raises(AccelcalError, match="rank"):
        tr.identify(rec0, route="w")
    est = tr.identify(rec0, route="w", terms=("Ko", "Kp")).estimate
    np.testing.assert_allclose(est.values, [2e-4, -1e-4], rtol=0, atol=1e-12)
    rec1 = ShakerRig(amplitude=5.0, gravity=1.0, **RIG).simulate(truth, THETA)
    np.testing.assert_allclose(tr.identify(rec1, route="w").estimate.values,
                               [2e-4, -1e-4, 3e-5, -2e-5, 1e-5], rtol=0, atol=1e-12)


def test_identification_errors():
    truth = _truth(2e-4, -1e-4, 3e-5, -2e-5, 1e-5)
    rec = ShakerRig(amplitude=5.0, **RIG).simulate(truth, THETA[:2])
    with pytest.raises(AccelcalError, match="at least 3"):
        tr.identify(rec)
    rec = ShakerRig(amplitude=5.0, **RIG).simulate(truth, THETA)
    with pytest.raises(AccelcalError, match="u_rest"):
        tr.identify(rec, route="dc")
    with pytest.raises(AccelcalError, match="terms to fit"):
        tr.identify(rec, terms=("Kxx",))
    with pytest.raises(AccelcalError, match="route"):
        tr.identify(rec, route="3w")
