"""The indexing head's unestimated terms: aliases that predict the error, Type B that bounds it."""

import dataclasses
import json

import numpy as np
import pytest

import accelcal
from accelcal.cli import main
from accelcal.io.formats.dividing_head import write_head_record
from accelcal.methods.dividing_head import HeadData, reduce, single
from accelcal.methods.dividing_head.unestimated import EQUAL
from accelcal.rigs.dividing_head import DividingHeadRig, simulate

METHODS = ("single", "four", "joint")


def _data(**terms):
    """Noise-free data of the default accelerometer with only ``terms`` of K3, K0', K1', Koo."""
    off = dict.fromkeys(("K3", "K0_asym", "K1_asym", "Koo"), 0.0)
    model = dataclasses.replace(accelcal.default_model(), **{**off, **terms})
    # start at 7.5 deg: no position has a_i = 0, so K0'/2 has a known sign everywhere
    rig = DividingHeadRig.uniform(24, (model,) * 4, noise=0.0)
    rig = dataclasses.replace(rig, positions=rig.positions + np.radians(7.5))
    run = simulate(rig, None)
    return HeadData.build(rig.positions, run.outputs, rig.mounts), model


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("term", ["K3", "K0_asym", "K1_asym"])
def test_aliases_predict_the_error_of_each_term(method, term):
    # with no prior the aliases state how much the term moves each row per unit: times
    # the term's true value they are the error of every row (first order, every sensor)
    model = accelcal.default_model()
    value = getattr(model, term)
    data, _ = _data(**{term: value})
    clean, _ = _data()
    red = reduce(data, method, priors="none")
    base = reduce(clean, method, priors="none")
    for k in range(4):
        est = red.sensors[k]
        for name in est.names:
            row = est.label(name)
            moved = sum(a.sensitivity * value for a in red.aliases
                        if a.sensor == k and a.row == row and a.term.split("[")[0] == term)
            err = est[name] - base.sensors[k][name]
            assert abs(err - moved) <= 1e-3 * abs(moved) + 1e-12, (k, row, err, moved)
    # K0' and K3 move K_I, and visibly (> 0.1 uV/g), which the Type A SD misses
    if term in ("K0_asym", "K3"):
        assert any(a.row == "K_I" and abs(a.sensitivity * value) > 1e-7 for a in red.aliases
                   if a.term == term)


@pytest.mark.parametrize("sensor_terms", [None, "independent", "equal"])
@pytest.mark.parametrize("method", METHODS)
def test_default_priors_add_their_itemised_type_b(method, sensor_terms):
    data, _ = _data(K3=1e-7, K0_asym=2e-6, K1_asym=1e-6)
    plain = reduce(data, method, priors="none")
    red = reduce(data, method, sensor_terms=sensor_terms)
    # independent (the default): no part for the sensors' terms equal; equal: K_I gets one
    has_equal = any(c.input == EQUAL for c in red.type_b)
    assert has_equal is (sensor_terms == "equal")
    assert any(f"sensor terms {sensor_terms or 'independent'}:" in n for n in red.notes)
    assert not plain.type_b
    assert plain.aliases
    assert {p.name for p in red.priors} >= {"K3", "K0_asym", "K1_asym"}
    for k, (a, b) in enumerate(zip(plain.sensors, red.sensors, strict=True)):
        for name in a.names:
            row = a.label(name)
            parts = [c for c in red.type_b if c.sensor == k and c.row == row]
            # the sensors' terms equal (worst sign) or independent: the larger variance
            equal = sum(c.contribution**2 for c in parts if c.input == EQUAL)
            indep = sum(c.contribution**2 for c in parts if c.input != EQUAL)
            np.testing.assert_allclose(b.std_of(name)**2 - a.std_of(name)**2, indep + equal,
                                       rtol=1e-6, atol=1e-24)
    k_i = [c for c in red.type_b if c.sensor == 0 and c.row == "K_I" and c.input == "K0_asym"]
    assert k_i
    assert k_i[0].source == "default"
    # K0' bound: twice the default magnitude, rectangular: u = 2 a / sqrt 3
    assert k_i[0].u == pytest.approx(2 * accelcal.default_model().K0_asym / np.sqrt(3))


def test_positions_where_a_i_is_zero_carry_k0_of_unknown_sign():
    data, _ = _data(K0_asym=2e-6)
    at_zero = HeadData.build(data.positions - np.radians(7.5), data.outputs, data.mounts)
    red = reduce(at_zero, "single")
    terms = {c.input for c in red.type_b if c.sensor == 0}
    assert {"K0_asym@0deg", "K0_asym@180deg"} <= terms
    assert not any("@" in c.input for c in reduce(data, "single").type_b)


@pytest.mark.parametrize("method", ["four", "joint"])
def test_sensor_terms_equal_bound_k_i_through_the_shared_head_error(method):
    # the separated head error moves each sensor's K_I with every sensor's K0': taken equal
    # (in the worst sign) the four add linearly, independent in quadrature, so the stated SD
    # of K_I with equal terms is larger (by 1.27x here; at most 2x: four alike sensors, one sign)
    data, _ = _data(K0_asym=2e-6)
    indep = reduce(data, method)
    equal = reduce(data, method, sensor_terms="equal")
    plain = reduce(data, method, priors="none")
    for a, b, c in zip(indep.sensors, equal.sensors, plain.sensors, strict=True):
        type_b = [np.sqrt(e.std_of("K_I") ** 2 - c.std_of("K_I") ** 2) for e in (a, b)]
        assert 1.1 * type_b[0] < type_b[1] <= 2.0 * type_b[0] * (1 + 1e-9)
    with pytest.raises(accelcal.AccelcalError, match="sensor terms") as exc:
        reduce(data, method, sensor_terms="alike")
    assert exc.value.parameter == "sensor_terms"


def test_signs_where_a_i_is_zero_independent_by_default():
    # the two zeros of a_i of a sensor (beta = 0, pi): with a misalignment larger than the
    # head error the signs are opposite and cancel in K_F; with a larger head error they
    # may be equal and add: taken independent, K_F's part from the pair is the quadrature
    # sum of the two (half the variance of their worst-sign sum, which "equal" states)
    data, _ = _data(K0_asym=2e-6)
    at_zero = HeadData.build(data.positions - np.radians(7.5), data.outputs, data.mounts)
    for sensor_terms, share in (("independent", 0.5), ("equal", 1.0)):
        red = reduce(at_zero, "tumble", sensor_terms=sensor_terms)
        pair = [c.contribution for c in red.type_b
                if c.sensor == 0 and c.row.startswith("K_F") and "@" in c.input]
        assert len(pair) == 2
        bare = reduce(at_zero, "tumble", priors="none").sensors[0]
        rest = [c.contribution for c in red.type_b if c.sensor == 0
                and c.row.startswith("K_F") and "@" not in c.input and c.input != EQUAL]
        stated = red.sensors[0].std_of("K_F") ** 2 - bare.std_of("K_F") ** 2 - sum(
            x**2 for x in rest)
        assert stated == pytest.approx(share * sum(pair) ** 2, rel=1e-6)


def test_direct_method_call_has_no_type_b():
    # the per-method functions stay the bare reductions; reduce() adds the Type B
    data, _ = _data(K0_asym=2e-6)
    assert single(data).type_b == ()
    assert reduce(data, "single").type_b


def test_cli_priors_option(tmp_path, capsys):
    model = accelcal.default_model()
    rig = DividingHeadRig.uniform(24, (model,) * 4, noise=1e-6)
    run = simulate(rig, 1)
    path = tmp_path / "h.csv"
    write_head_record(path, rig.positions, run.outputs, rig.mounts)
    with pytest.raises(SystemExit) as exc:
        main(["dividing-head", "reduce", str(path), "--method", "single", "--priors", "maybe"])
    _out, err = capsys.readouterr()
    assert exc.value.code == 2
    assert "maybe" in err
    assert "default" in err
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    for choice in ("default", "none"):
        with pytest.raises(SystemExit) as exc:
            main(["dividing-head", "reduce", str(path), "--method", "single", "--priors",
                  choice, "--format", "json"])
        assert exc.value.code == 0
        capsys.readouterr()
    with pytest.raises(SystemExit) as exc:
        main(["dividing-head", "reduce", str(path), "--sensor-terms", "alike"])
    _out, err = capsys.readouterr()
    assert exc.value.code == 2
    assert "alike" in err
    assert "independent" in err
    assert len(err.strip().splitlines()) == 1
    stds = {}
    for choice in ("independent", "equal"):
        with pytest.raises(SystemExit) as exc:
            main(["dividing-head", "reduce", str(path), "--method", "four", "--sensor-terms",
                  choice, "--format", "json"])
        assert exc.value.code == 0
        out = json.loads(capsys.readouterr().out)
        rows = out["rows"] if isinstance(out, dict) else out
        stds[choice] = [r["std"] for r in rows if r["coefficient"] == "K_I"]
    assert len(stds["equal"]) == 4
    assert all(e > 1.1 * i for e, i in zip(stds["equal"], stds["independent"], strict=True))


@pytest.mark.parametrize(("method", "options"), [
    ("single", {}), ("four", {}), ("four", {"first_harmonic": (1e-5, -2e-5)}),
    ("joint", {}), ("joint", {"first_harmonic": (1e-5, -2e-5), "mean_error": 1e-5}),
    ("tumble", {})])
def test_linear_response_equals_central_differences(method, options):
    # the alias matrix from the reductions' linear response (one batched product or solve)
    # is the derivative the central differences approximate to ~1e-8 relative (STEP^2 of
    # the normalisation by the fitted K_I); positions at a_i = 0 included
    from accelcal.methods.dividing_head import four, joint
    from accelcal.methods.dividing_head.reduce import tumble
    from accelcal.methods.dividing_head.response import response
    from accelcal.methods.dividing_head.unestimated import TERMS, central_differences, term_columns

    rig = DividingHeadRig.uniform(24, (accelcal.default_model(),) * 4, noise=1e-6)
    data = HeadData.build(rig.positions, simulate(rig, 3).outputs, rig.mounts)
    run = {"single": single, "four": four, "joint": joint, "tumble": tumble}[method]
    red = run(data, **options)
    changes = [(k, z) for k, (_, z) in term_columns(data, red, {}, () if method == "tumble"
                                                 else TERMS, False)]
    assert len(changes) == (8 if method == "tumble" else 24)
    fast = response(method, data, red, options)(changes)
    slow = central_differences(data, lambda d: run(d, **options), changes)
    assert fast.shape == slow.shape == (20, len(changes))
    scale = np.max(np.abs(slow))
    assert scale > 0.1
    np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-7 * scale)


def test_joint_with_autocollimator_falls_back_to_central_differences():
    from accelcal.methods.dividing_head.response import response

    data, _ = _data(K3=1e-7)
    assert response("joint", data, None, {"autocollimator": np.zeros(24)}) is None
    assert response("joint", data, None, {"gauss_newton": True}) is None
