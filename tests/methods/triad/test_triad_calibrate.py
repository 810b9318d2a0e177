"""Triad calibration routes (issue 12): exact recovery, derivatives, covariance, refusals, MC.

Independent routes: finite differences of the RQ split and of the
observation models; the covariance of the known-orientation route against
the Gauss-Newton covariance of the full readings model (a different
linearisation) and against simulation; Monte Carlo through the engine.
"""

import numpy as np
import pytest

from accelcal.errors import AccelcalError
from accelcal.methods.triad import (
    GAUGE,
    KNOWN_METHOD,
    PARAMS,
    UNKNOWN_METHOD,
    TriadCalibration,
    calibrate_known,
    calibrate_unknown,
    calibration_of,
    norm_residuals,
    plan,
    report_text,
    triad_uncertainty,
)
from accelcal.methods.triad.forward import known_model, norm_model
from accelcal.methods.triad.split import rq_split, split_jacobian
from accelcal.methods.triad.unknown import distinct_orientations
from accelcal.rigs.triad import random_directions, six_positions

G = 9.80665


def truth(rng, unit="counts", quadratic=False):
    if unit == "counts":
        bias, scale = rng.uniform(-500, 500, 3), rng.uniform(5.8e-4, 6.2e-4, 3)
    else:
        bias, scale = rng.uniform(-0.2, 0.2, 3), rng.uniform(0.97, 1.03, 3)
    q = rng.uniform(-5e-4, 5e-4, 3) if quadratic else None
    return TriadCalibration(bias, scale, rng.uniform(-3e-3, 3e-3, 3), q, unit)


def fd_jacobian(f, x, h):
    cols = []
    for i in range(x.size):
        dx = np.zeros_like(x)
        dx[i] = h[i]
        cols.append((f(x + dx) - f(x - dx)) / (2 * h[i]))
    return np.stack(cols, axis=-1)


# ------------------------------------------------------------------- known orientations
@pytest.mark.parametrize("quadratic", [False, True])
def test_known_noise_free_exact(quadratic):
    rng = np.random.default_rng(1)
    cal = truth(rng, quadratic=quadratic)
    up = np.vstack([six_positions(), random_directions(12, rng)])
    red = calibrate_known(cal.readings(G * up), up, G, input_unit="counts", quadratic=quadratic)
    # rounding of 1e3-count readings through a well-conditioned fit: 1e-12 relative
    np.testing.assert_allclose(red.estimate.values, cal.vector, rtol=1e-9, atol=1e-12)
    assert (red.family, red.method) == ("triad", KNOWN_METHOD)
    assert red.dof == red.estimate.dof == 3 * 18 - (15 if quadratic else 12)
    assert red.shared.names == GAUGE
    assert np.abs(red.shared.values).max() < 1e-12
    assert np.isfinite(red.identifiability.condition_number)
    np.testing.assert_allclose(red.observations["norm_after"], 0.0, atol=1e-11)
    assert np.isnan(red.observations["norm_before"]).all()  # counts: no residual before
    back = calibration_of(red)
    np.testing.assert_array_equal(back.vector, red.estimate.values)


def test_rq_split_derivative_matches_finite_differences():
    rng = np.random.default_rng(2)
    cal = truth(rng, "m/s^2")
    from scipy.spatial.transform import Rotation

    q = Rotation.from_rotvec(rng.normal(0, 0.3, 3)).as_matrix()
    a = np.linalg.inv(cal.matrix) @ q
    s, ang, rot, _ = rq_split(a)
    np.testing.assert_allclose(s, cal.scale, rtol=1e-14)
    np.testing.assert_allclose(ang, cal.angles, atol=1e-15)
    np.testing.assert_allclose(rot, q, atol=1e-14)

    def f(x):
        s2, ang2, rot2, _ = rq_split(x.reshape(3, 3))
        w = Rotation.from_matrix(rot2 @ rot.T).as_rotvec()  # left perturbation angle
        return np.concatenate([s2, ang2, w])

    num = fd_jacobian(f, a.ravel(), np.full(9, 1e-6))
    # central differences: truncation ~h^2 * 3rd derivative (~1e-12), rounding ~eps/h (1e-10)
    np.testing.assert_allclose(split_jacobian(a), num, rtol=0, atol=1e-8)


def test_known_model_jacobian_matches_finite_differences():
    rng = np.random.default_rng(3)
    cal = truth(rng, quadratic=True)
    x = np.concatenate([cal.vector, rng.normal(0, 1e-3, 3)])
    force = G * random_directions(8, rng)
    from scipy.spatial.transform import Rotation

    rot = Rotation.from_rotvec(rng.normal(0, 0.3, 3)).as_matrix()
    _, jac = known_model(x, rot, force, True)
    h = np.maximum(np.abs(x), 1e-3) * 1e-6
    h[12:] = 1e-5  # rad: rounding of 1e4-count readings (1e-12) / h stays below 1e-7
    num = fd_jacobian(lambda v: known_model(v, rot, force, True)[0], x, h)
    # omega enters through Rodrigues at omega != 0, where -[a_b]x is exact to O(omega): compare
    # the parameter columns tightly and the omega columns to 1e-3 relative
    scale = np.abs(num).max(axis=(0, 1))
    np.testing.assert_allclose(jac[..., :12], num[..., :12], rtol=0, atol=1e-7 * scale[:12].max())
    np.testing.assert_allclose(jac[..., 12:], num[..., 12:], rtol=0, atol=2e-3 * scale[12:].max())
    x[12:] = 0.0
    _, jac0 = known_model(x, rot, force, True)
    num0 = fd_jacobian(lambda v: known_model(v, rot, force, True)[0], x, h)
    np.testing.assert_allclose(jac0[..., 12:], num0[..., 12:], rtol=0,
                               atol=1e-7 * scale[12:].max())


def _known_design():
    """Twelve known orientations of a random triad: its clean readings and the SD (counts)."""
    rng = np.random.default_rng(4)
    cal = truth(rng)
    up = np.vstack([six_positions(), random_directions(6, rng)])
    return rng, up, cal.readings(G * up), 2.0  # counts, SD of an interval mean


def test_known_covariance_two_ways():
    """RQ-propagated covariance = Gauss-Newton covariance of the readings model (the
    simulation, the third way, is the slow test below)."""
    _, up, clean, sd = _known_design()
    red = calibrate_known(clean, up, G, input_unit="counts", noise_sd=sd)
    assert red.dof == 0
    x = np.concatenate([red.estimate.values, np.zeros(3)])
    _, jac = known_model(x, red.observations["rotation"].T, G * up, False)
    jw = jac.reshape(-1, 12) / sd
    gn = np.linalg.inv(jw.T @ jw)
    np.testing.assert_allclose(red.covariance, gn, rtol=1e-6,
                               atol=1e-9 * np.sqrt(np.outer(np.diag(gn), np.diag(gn))).max())


@pytest.mark.slow
def test_known_covariance_matches_simulation():
    """The propagated SDs against the scatter of 3000 simulated calibrations."""
    rng, up, clean, sd = _known_design()
    red = calibrate_known(clean, up, G, input_unit="counts", noise_sd=sd)
    m = 3000
    est = np.array([calibrate_known(clean + sd * rng.standard_normal(clean.shape), up, G,
                                    input_unit="counts", noise_sd=sd).estimate.values
                    for _ in range(m)])
    ratio = est.std(axis=0, ddof=1) / red.estimate.std
    # SD of a sample SD from m draws: 1/sqrt(2(m-1)) = 1.3 %; 4 of them, plus the
    # second-order nonlinearity of the split (relative ~1e-3 at these noise levels)
    assert np.abs(ratio - 1.0).max() < 4 / np.sqrt(2 * (m - 1)) + 0.005, ratio


def test_known_residual_variance_and_counts_weights():
    rng = np.random.default_rng(5)
    cal = truth(rng)
    up = np.vstack([six_positions(), six_positions()])
    counts = np.array([100, 400] * 6, dtype=float)
    clean = cal.readings(G * up)
    noisy = clean + 3.0 / np.sqrt(counts)[:, None] * rng.standard_normal(clean.shape)
    red = calibrate_known(noisy, up, G, input_unit="counts", counts=counts)
    assert red.dof == 3 * 12 - 12
    assert red.assumed("noise") == "residuals"
    assert red.assumed("weights") == "counts"
    assert red.provenance["counts"] == counts.tolist()
    sd = red.observations["means_sd"]
    np.testing.assert_allclose(sd[1] / sd[0], 0.5)  # SD of a mean of 4x the samples


@pytest.mark.parametrize(
    ("up", "match"),
    [(np.eye(3), r"3 position\(s\) given; at least 5 .* no position with x down, y down, z down"),
     (np.vstack([np.eye(3), np.eye(3)[:2]]), "not all in one plane; no position with x down"),
     (np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0.6, 0.8, 0], [-0.8, 0.6, 0.0]]),
      "no position with z up, z down")])
def test_known_refuses_badly_spread_positions(up, match):
    means = TriadCalibration([0, 0, 0], [1, 1, 1], [0, 0, 0]).readings(G * up)
    with pytest.raises(AccelcalError, match=match) as exc:
        calibrate_known(means, up, G)
    assert exc.value.parameter == "up"
    assert "\n" not in str(exc.value)


@pytest.mark.parametrize(("kwargs", "parameter"),
                         [({"up": np.full((6, 3), 2.0)}, "up"), ({"gravity": 1.0}, "gravity"),
                          ({"means": np.full((6, 3), np.nan)}, "means"),
                          ({"counts": [1, 2]}, "counts"), ({"noise_sd": -1.0}, "noise_sd"),
                          ({"labels": ["a"]}, "labels"), ({"input_unit": "N"}, "input_unit")])
def test_known_bad_inputs(kwargs, parameter):
    args = {"means": six_positions() * G, "up": six_positions(), "gravity": G, **kwargs}
    with pytest.raises(AccelcalError) as exc:
        calibrate_known(args.pop("means"), args.pop("up"), args.pop("gravity"), **args)
    assert exc.value.parameter == parameter


# ------------------------------------------------------------------ unknown orientations
def test_norm_model_jacobian_matches_finite_differences():
    rng = np.random.default_rng(6)
    cal = truth(rng, quadratic=True)
    means = cal.readings(G * random_directions(15, rng)) + rng.normal(0, 50, (15, 3))
    for quadratic in (False, True):
        x = cal.vector if quadratic else cal.vector[:9]
        _, jac = norm_model(x, means, G, quadratic)
        h = np.maximum(np.abs(x), 1e-4) * 1e-6
        num = fd_jacobian(lambda v, q=quadratic: norm_model(v, means, G, q)[0], x, h)
        np.testing.assert_allclose(jac, num, rtol=1e-6, atol=1e-9 * np.abs(num).max())


@pytest.mark.parametrize(("unit", "quadratic"), [("counts", False), ("m/s^2", False),
                                                 ("counts", True)])
def test_unknown_noise_free_exact(unit, quadratic):
    rng = np.random.default_rng(7)
    cal = truth(rng, unit, quadratic)
    up = random_directions(40 if quadratic else 24, rng)
    red = calibrate_unknown(cal.readings(G * up), G, input_unit=unit, quadratic=quadratic)
    np.testing.assert_allclose(red.estimate.values, cal.vector, rtol=1e-9, atol=1e-12)
    assert (red.family, red.method) == ("triad", UNKNOWN_METHOD)
    assert red.dof == len(up) - (12 if quadratic else 9)
    assert red.shared is None
    assert red.estimate.residuals.shape == (len(up),)
    if unit == "m/s^2":
        np.testing.assert_allclose(red.observations["norm_before"],
                                   np.linalg.norm(red.observations["means"], axis=1) - G)


def test_unknown_positive_polarity_and_initial():
    rng = np.random.default_rng(8)
    cal = truth(rng)
    means = cal.readings(G * random_directions(20, rng))
    flipped = TriadCalibration(cal.bias, cal.scale * [1, -1, 1], cal.angles, None, "counts")
    red = calibrate_unknown(means, G, input_unit="counts", initial=flipped)
    np.testing.assert_allclose(red.estimate.values, cal.vector, rtol=1e-9, atol=1e-12)
    with pytest.raises(AccelcalError) as exc:
        calibrate_unknown(means, G, initial=flipped)
    assert exc.value.parameter == "initial"


def test_unknown_covariance_against_monte_carlo():
    rng = np.random.default_rng(9)
    cal = truth(rng)
    means = cal.readings(G * random_directions(25, rng)) + rng.normal(0, 1.0, (25, 3))
    red = calibrate_unknown(means, G, input_unit="counts")
    m = 1500
    mc = triad_uncertainty(red, trials=m, seed=3)
    # relative SE of an MC SD: 1/sqrt(2(m-1)) = 1.8 %; 4 SE plus 1 % for the
    # second-order terms of the nonlinear fit
    assert np.abs(mc.mc_std / red.estimate.std - 1).max() < 4 / np.sqrt(2 * (m - 1)) + 0.01
    assert np.abs(mc.mc_bias / red.estimate.std).max() < 0.2


def test_known_mc_agrees_with_propagated():
    rng = np.random.default_rng(10)
    cal = truth(rng)
    up = np.vstack([six_positions(), random_directions(6, rng)])
    means = cal.readings(G * up) + rng.normal(0, 1.0, (12, 3))
    red = calibrate_known(means, up, G, input_unit="counts")
    m = 2000
    mc = triad_uncertainty(red, trials=m, seed=4)
    assert np.abs(mc.mc_std / red.estimate.std - 1).max() < 4 / np.sqrt(2 * (m - 1)) + 0.005


def test_unknown_refusals():
    cal = TriadCalibration([0, 0, 0], [1, 1, 1], [0, 0, 0])
    rng = np.random.default_rng(11)
    with pytest.raises(AccelcalError, match=r"^means: 8 position\(s\) given; .*at least 10"):
        calibrate_unknown(cal.readings(G * random_directions(8, rng)), G)
    with pytest.raises(AccelcalError, match="at least 13"):
        calibrate_unknown(cal.readings(G * random_directions(12, rng)), G, quadratic=True)
    calibrate_unknown(cal.readings(G * random_directions(9, rng)), G, noise_sd=0.01)
    # only the six axis directions (repeated): six orientations cannot fix nine parameters
    up = np.vstack([six_positions(), six_positions()])
    with pytest.raises(AccelcalError, match="12 positions given but only 6 distinct") as exc:
        calibrate_unknown(cal.readings(G * up), G)
    assert "\n" not in str(exc.value)
    # the six directions tilted a little (as a hand-held session holds them) and repeated:
    # still six orientations (the fit would run off to spurious angles, as it did on the
    # real imucal session's detected intervals)
    tilt = six_positions() + rng.normal(0, 0.02, (6, 3))
    tilt = np.repeat(tilt / np.linalg.norm(tilt, axis=1, keepdims=True), 3, axis=0)
    tilt += rng.normal(0, 1e-3, tilt.shape)  # within 3 deg of each other
    with pytest.raises(AccelcalError, match="18 positions given but only 6 distinct"):
        calibrate_unknown(cal.readings(G * tilt), G)
    # nine directions kept apart by more than 3 deg pass the count (the design check follows)
    assert distinct_orientations(random_directions(40, rng), 10) == 10
    # ten directions made of the six axes and (x+y+z)/sqrt(3) three times: 7 distinct
    seven = np.vstack([six_positions(), np.repeat(np.ones((1, 3)) / np.sqrt(3), 4, axis=0)])
    assert distinct_orientations(seven, 10) == 7
    # a hemisphere of x up: x down missing, named
    d = random_directions(30, rng)
    d[:, 0] = np.abs(d[:, 0]) + 0.5
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    red = calibrate_unknown(cal.readings(G * d), G)
    assert any(n.startswith("no position with x down:") for n in red.notes), red.notes


def test_plan_states_what_positions_determine():
    assert plan(six_positions()).ok
    assert not plan(six_positions(), route="unknown").ok
    assert plan(six_positions(), route="unknown").identifiability.unidentifiable == (
        "a_yz", "a_zy", "a_zx")
    d = random_directions(30, np.random.default_rng(12))
    assert plan(d, route="unknown", quadratic=True).ok


# ------------------------------------------------------------------------------ outputs
def test_norm_residuals_before_after_and_report(tmp_path):
    rng = np.random.default_rng(13)
    cal = truth(rng, "m/s^2")
    up = random_directions(20, rng)
    means = cal.readings(G * up)
    np.testing.assert_allclose(norm_residuals(means, G, cal), 0.0, atol=1e-13)
    np.testing.assert_allclose(norm_residuals(means / G, G, input_unit="g"),
                               np.linalg.norm(means, axis=1) - G, atol=1e-13)
    assert np.isnan(norm_residuals(means, G, input_unit="V")).all()
    red = calibrate_unknown(means + rng.normal(0, 1e-3, means.shape), G,
                            labels=[f"L{k}" for k in range(20)])
    stems = [f[0] for f in red.figures()] if _registered() else []
    from accelcal.methods.triad import figures

    figs = figures(red)
    assert [f[0] for f in figs] == ["triad-norm-residuals", "triad-positions"]
    assert stems in ([], [f[0] for f in figs])
    text = report_text(red)
    assert "20 static positions" in text.summary
    assert red.provenance["labels"][3] == "L3"
    known = calibrate_known(means, up, G)
    assert [f[0] for f in figures(known)] == ["triad-norm-residuals", "triad-positions"]
    assert "known orientation" in report_text(known).summary


def _registered() -> bool:
    from accelcal.methods import REGISTRY

    return "triad" in REGISTRY


def test_demo_stage_runs(tmp_path):
    from accelcal.demo import lab
    from accelcal.methods.triad.demo import stage

    st = stage("TRIAD-1", lab)
    path = st.simulate(tmp_path, "2026-01-02", np.random.SeedSequence(1))
    outcomes = st.reduce(path)
    assert [o.tag for o in outcomes] == ["triad-norm", "triad-known"]
    for o in outcomes:
        assert o.records[0].serial == "TRIAD-1"
        assert o.reduction.estimate["s_x"] == pytest.approx(5.98e-4, rel=1e-3)


@pytest.mark.parametrize("route", ["known", "unknown"])
def test_plan_predicts_the_stated_uncertainties(route):
    # A nominal triad (the plan's linearisation point) and noise given: the stated SDs of a
    # calibration are the plan's prediction exactly (same Jacobian; 1e-9 covers the
    # solution's departure from the nominal point, ~1e-12 with noise-free means)
    rng = np.random.default_rng(4)
    up = six_positions() if route == "known" else random_directions(30, rng)
    cal = TriadCalibration([0, 0, 0], [1, 1, 1], [0, 0, 0])
    sigma, samples = 0.02, 400
    means = cal.readings(G * up)
    counts = np.full(len(up), samples)
    if route == "known":
        red = calibrate_known(means, up, G, noise_sd=sigma / np.sqrt(samples))
    else:
        red = calibrate_unknown(means, G, noise_sd=sigma / np.sqrt(samples), counts=counts)
    predicted = plan(up, route=route, gravity=G).predicted_sd(sigma, samples)
    est = red.sensors[0]
    for name in PARAMS:
        assert est.std_of(name) == pytest.approx(predicted[name], rel=1e-9), name


def test_plan_refuses_to_predict_for_a_deficient_design():
    p = plan(six_positions(), route="unknown")
    assert not p.ok
    with pytest.raises(AccelcalError, match="no uncertainty can be predicted"):
        p.predicted_sd(0.01, 100)
    with pytest.raises(AccelcalError) as exc:
        plan(six_positions()).predicted_sd(float("nan"), 100)
    assert exc.value.parameter == "noise_sd"


def test_engineering_units_of_a_triad_in_m_s2():
    # a bias of 0.0980665 m/s^2 is 10,000 ug; a scale factor of 1.0001 (m/s^2)/(m/s^2) is
    # 100 ppm above its nominal 1; in counts no engineering unit is claimed for either
    rng = np.random.default_rng(8)
    up = np.vstack([six_positions(), random_directions(12, rng)])
    cal = TriadCalibration([0.0980665, 0, 0], [1.0001, 1, 1], [1e-3, 0, 0])
    red = calibrate_known(cal.readings(G * up), up, G, noise_sd=1e-4)
    rows = {r["coefficient"]: r for r in red.rows()}
    assert rows["b_x"]["eng_unit"] == "ug"
    assert rows["b_x"]["eng_estimate"] == pytest.approx(1e4, rel=1e-9)
    assert rows["b_x"]["eng_std"] == pytest.approx(rows["b_x"]["std"] / G * 1e6, rel=1e-12)
    assert rows["s_x"]["eng_unit"] == "ppm"
    assert rows["s_x"]["eng_estimate"] == pytest.approx(100.0, rel=1e-6)
    assert rows["a_yz"]["eng_unit"] == "urad"
    counts = TriadCalibration([300, 0, 0], [6e-4, 6e-4, 6e-4], [0, 0, 0], input_unit="counts")
    red = calibrate_known(counts.readings(G * up), up, G, input_unit="counts", noise_sd=1.0)
    rows = {r["coefficient"]: r for r in red.rows()}
    assert rows["b_x"]["eng_unit"] == ""
    assert rows["s_x"]["eng_unit"] == ""
