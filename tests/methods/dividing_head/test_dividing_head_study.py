"""Monte Carlo study of the indexing-head methods: formal SD against actual scatter."""

import json
import time

import numpy as np
import pytest

from accelcal.cli import main
from accelcal.errors import AccelcalError
from accelcal.methods.dividing_head import (
    COEFFICIENTS,
    STUDY_METHODS,
    SUB_BLOCK,
    HeadData,
    HeadStudy,
    SensorBank,
    four,
    joint,
    run_study,
    single,
)
from accelcal.methods.dividing_head.study_bank import sin_cos_small
from accelcal.model import ErrorModel
from accelcal.montecarlo import block_generator
from accelcal.rigs.dividing_head import (
    DONG2014_FIRST_HARMONIC,
    DONG2014_NOISE_V,
    AngleErrorProfile,
    DividingHeadRig,
    dong2014_models,
    simulate,
)
from accelcal.units import ARCSEC


def _rig(h1=DONG2014_FIRST_HARMONIC, half_width=2 * ARCSEC, **kw):
    return DividingHeadRig.uniform(
        24, dong2014_models(4), angle_error=AngleErrorProfile.uniform(half_width),
        first_harmonic=h1, noise=DONG2014_NOISE_V, **kw,
    )


def _table(result):
    return {(r["method"], r["coefficient"]): r for r in result.rows()}


def test_joint_known_h1_formal_sd_matches_monte_carlo_scatter():
    """Where the model is right (joint, h1 known) the mean formal SD equals the RMS error.
    4000 trials x 4 sensors: the RMS has relative SE ~ 1/sqrt(2*16000) = 0.6 %, the mean of s
    is biased low by c4(55 dof) ~ 0.5 %; tolerance 4 %."""
    res = run_study(_rig(), 4000, seed=11, h1_sd=5e-7)
    m = res.methods.index("joint_known_h1")
    np.testing.assert_allclose(res.rms_error[m], res.mean_formal_sd[m], rtol=0.04)


def test_study_shows_where_formal_sds_understate():
    res = _table(run_study(_rig(), 2000, seed=12))
    # first harmonic of Dong2014's size, not given: K_F, K_IO, K_II biased ~ K_I * 1.5e-5
    for c in ("K_F", "K_IO", "K_II"):
        for method in ("four_unknown_h1", "joint_unknown_h1", "single"):
            row = res[(method, c)]
            assert row["rms_error"] > 4 * row["mean_formal_sd"], (method, c)
        assert res[("joint_known_h1", c)]["rms_error"] < 1.1 * \
            res[("joint_known_h1", c)]["mean_formal_sd"]
    # the four-sensor method's formal SD is the propagated one (the paper's step 7 ignored
    # the noise of the separated head error and was 1.3-1.9x too small): it now agrees with
    # the scatter (2000 trials x 4 sensors: RMS relative SE ~0.8 %; estimated variances with
    # ~9-19 effective dof: E[s] a few % low; tolerance 10 %)
    for c in COEFFICIENTS:
        row = res[("four_known_h1", c)]
        assert 0.9 < row["rms_error"] / row["mean_formal_sd"] < 1.1, c
    # four/joint improve on single by removing harmonics >= 2 (paper's Tables 1-2 claim)
    assert res[("joint_known_h1", "K_F")]["rms_error"] < \
        0.2 * res[("single", "K_F")]["rms_error"]


def test_study_is_reproducible_and_bit_identical_for_any_chunk():
    """Seed blocks of 64 trials, 11 blocks (the last partial): chunks of 1, 3 and all blocks
    give the very same numbers; another seed gives others."""
    rig = _rig(repeats=2)
    a, b, c = (run_study(rig, 700, seed=3, block_size=64, chunk=chunk)
               for chunk in (None, 150, 5000))
    for other in (b, c):
        np.testing.assert_array_equal(a.rms_error, other.rms_error)
        np.testing.assert_array_equal(a.mean_formal_sd, other.mean_formal_sd)
    d = run_study(rig, 700, seed=4, block_size=64)
    assert not np.allclose(a.rms_error, d.rms_error, rtol=1e-6)
    assert a.methods == STUDY_METHODS


def test_study_is_bit_identical_on_two_dask_workers():
    """The same seed blocks evaluated in two worker processes: identical to in-process."""
    pytest.importorskip("distributed")
    rig = _rig()
    local = run_study(rig, 2000, seed=5, block_size=256, h1_sd=5e-7)
    dask2 = run_study(rig, 2000, seed=5, block_size=256, h1_sd=5e-7, workers=2, chunk=512)
    np.testing.assert_array_equal(local.rms_error, dask2.rms_error)
    np.testing.assert_array_equal(local.mean_formal_sd, dask2.mean_formal_sd)


def test_study_matches_per_trial_reductions():
    """The vectorised operators against the one-record API (per-trial loop, test only)."""
    rig = _rig()
    trials = 5
    res = run_study(rig, trials, seed=9, methods=("single", "joint_unknown_h1"))
    # regenerate the same draws: seed block 0 of the engine, in the rig's own order
    rng = block_generator(9, 0)
    d = rig.angle_errors(trials, rng)
    u = rig.outputs(d, rng).mean(axis=1)
    coef = np.array([[m.to_dong2014()[c] for c in COEFFICIENTS] for m in rig.models])
    sq = np.zeros((2, 4, 5))
    for t in range(trials):
        data = HeadData.build(rig.positions, u[t], rig.mounts)
        truth = coef.copy()
        truth[:, 2] += coef[:, 1] * d[t].mean()
        for i, r in enumerate((single(data), joint(data))):
            sq[i] += (np.array([e.values for e in r.sensors]) - truth) ** 2
    np.testing.assert_allclose(res.rms_error, np.sqrt(sq / trials), rtol=1e-9)


def test_every_method_and_formal_sd_match_per_trial_reductions():
    """All five methods, known first harmonic measured with noise (h1_sd > 0): the study's RMS
    errors and mean formal SDs against the public one-record reductions on the same draws.
    The routes differ in rounding only (QR on raw outputs vs precomputed operators on
    normalised outputs): errors ~1e-6 V from values ~1.3 V lose ~6 digits, hence rtol 1e-8."""
    rig, trials, h1_sd = _rig(), 8, 5e-7
    res = run_study(rig, trials, seed=21, h1_sd=h1_sd)
    d, noise, h1_noise = HeadStudy(rig, STUDY_METHODS, h1_sd).draw(block_generator(21, 0), trials)
    coef = np.array([[m.to_dong2014()[c] for c in COEFFICIENTS] for m in rig.models])
    sq, sd = np.zeros((5, 4, 5)), np.zeros((5, 4, 5))
    for t in range(trials):
        data = HeadData.build(rig.positions, rig.outputs(d[t])[0] + noise[t], rig.mounts)
        d1 = 2 * np.mean(d[t] * np.cos(rig.positions)), 2 * np.mean(d[t] * np.sin(rig.positions))
        h1 = (d1[0] + h1_sd * h1_noise[t, 0], d1[1] + h1_sd * h1_noise[t, 1])
        truth = coef.copy()
        truth[:, 2] += coef[:, 1] * d[t].mean()
        reductions = (single(data), four(data), four(data, first_harmonic=h1,
                      first_harmonic_sd=h1_sd), joint(data),
                      joint(data, first_harmonic=h1, first_harmonic_sd=h1_sd))
        for m, r in enumerate(reductions):
            sq[m] += (np.array([e.values for e in r.sensors]) - truth) ** 2
            sd[m] += np.array([e.std for e in r.sensors])
    np.testing.assert_allclose(res.rms_error, np.sqrt(sq / trials), rtol=1e-8)
    np.testing.assert_allclose(res.mean_formal_sd, sd / trials, rtol=1e-8)


def test_study_rows_and_errors():
    rig = DividingHeadRig.uniform(24, dong2014_models(2), mounts=np.radians([0, 45]),
                                  angle_error=AngleErrorProfile.uniform(ARCSEC), noise=1e-6)
    res = run_study(rig, 50, seed=1)
    assert res.methods == ("single", "joint_unknown_h1", "joint_known_h1")  # 0/45: no four
    assert len(res.notes) == 1
    assert "doubled phases" in res.notes[0]
    rows = res.rows()
    assert set(rows[0]) == {"method", "coefficient", "rms_error", "mean_formal_sd"}
    assert len(res.rows(per_sensor=True)) == 3 * 2 * 5
    with pytest.raises(AccelcalError, match="at least 2"):
        run_study(rig, 1)
    with pytest.raises(AccelcalError, match="unknown study method"):
        run_study(rig, 10, methods=("five",))


def test_simulate_trials_axis_consistent_with_study_draws():
    rig = _rig()
    run = simulate(rig, 1, trials=3)
    assert run.outputs.shape == (3, 1, 4, 24)


def test_study_outputs_match_the_rig_for_every_model_term():
    """The all-sensor outputs (angle sums, Horner, asymmetry) against DividingHeadRig.outputs
    (np.sin/np.cos of the full angle, ErrorModel.output) for a model using every term with
    a_p = 0. Differences are rounding of sin(theta + d) (a few ulp of K1 ~ 1.3 V): atol 1e-14 V."""
    model = ErrorModel(K0=1e-3, K1=1.3, K2=2e-5, K3=-3e-6, K4=4e-7, Ko=-1e-5, Koo=6e-6,
                       Kio=-7e-6, K0_asym=2e-5, K1_asym=-3e-5, Kp=9.0, Kpp=9.0, Kip=9.0,
                       Kop=9.0, output_unit="V")
    rig = DividingHeadRig.uniform(24, (model, *dong2014_models(3)), eta=[1e-4, 0, -2e-4, 0],
                                  angle_error=AngleErrorProfile.uniform(5 * ARCSEC),
                                  first_harmonic=DONG2014_FIRST_HARMONIC, noise=1e-6)
    rng = np.random.default_rng(2)
    d = rig.angle_errors(50, rng)
    noise = rng.normal(0.0, 1e-6, (50, 4, 24))
    expected = rig.outputs(d)[:, 0] + noise  # (T, K, n)
    got = SensorBank(rig.models, rig.sensor_angles() + rig.eta[:, None])(d, noise)  # (K, n, T)
    np.testing.assert_allclose(got.transpose(2, 0, 1), expected, rtol=0, atol=1e-14)


@pytest.mark.parametrize("scale", [1e-7, 1e-4, 1e-2, 0.5])
def test_small_angle_sin_cos_agree_with_numpy(scale):
    """Taylor branch (|d| <= 1e-2) and numpy branch: within 2 ulp of np.sin / np.cos."""
    d = np.random.default_rng(1).uniform(-scale, scale, (40, 24))
    s, c = sin_cos_small(d)
    np.testing.assert_array_max_ulp(s, np.sin(d), maxulp=2)
    np.testing.assert_array_max_ulp(c, np.cos(d), maxulp=2)


def test_study_across_sub_blocks_matches_rms_of_trials():
    """More than one sub-block inside a seed block: the engine's RMS of each output equals
    the RMS of the study's own per-trial outputs (rounding of the streaming moments only)."""
    rig = _rig()
    trials = SUB_BLOCK + 300
    res = run_study(rig, trials, seed=6, methods=("single", "four_known_h1"))
    study = HeadStudy(rig, ("single", "four_known_h1"), 0.0)
    values = study(block_generator(6, 0), trials)
    rms, mean = np.sqrt((values**2).mean(axis=0)), values.mean(axis=0)
    expect_rms, expect_sd = study.summarise(rms, mean)
    np.testing.assert_allclose(res.rms_error, expect_rms, rtol=1e-12)
    np.testing.assert_allclose(res.mean_formal_sd, expect_sd, rtol=1e-12)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--trials", "0"], "--trials: a study needs at least 2 trials, got 0"),
        (["--trials", "-5"], "--trials: a study needs at least 2 trials, got -5"),
        (["--trials", "10", "--workers", "0"], "--workers: must be a positive integer, got 0"),
        (["--trials", "10", "--workers", "2", "--scheduler", "tcp://127.0.0.1:9"],
         "--workers: give either workers or a scheduler, not both"),
        (["--trials", "10", "--chunk", "0"], "--chunk: must be a positive number of trials"),
        (["--trials", "10", "--timeout", "0"], "--timeout: must be a positive number of seconds"),
    ],
)
def test_study_cli_bad_input(args, message, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["dividing-head", "study", *args])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert message in err
    assert "Traceback" not in err


def test_study_cli_unreachable_scheduler_fails_within_timeout(capsys):
    pytest.importorskip("distributed")
    start = time.monotonic()
    with pytest.raises(SystemExit) as exc:
        main(["dividing-head", "study", "--trials", "10", "--scheduler", "tcp://127.0.0.1:9",
              "--timeout", "1"])
    assert exc.value.code == 2
    assert "did not answer within 1 s" in capsys.readouterr().err
    assert time.monotonic() - start < 15  # the stated 1 s, plus client teardown slack


def test_study_cli_json_contract(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["dividing-head", "study", "--trials", "300", "--seed", "2", "--format", "json"])
    assert exc.value.code == 0
    rows = json.loads(capsys.readouterr().out)
    assert {r["method"] for r in rows} == set(STUDY_METHODS)
    assert all(set(r) == {"method", "coefficient", "rms_error", "mean_formal_sd"} for r in rows)
    expect = _table(run_study(_rig(h1=(0.0, 0.0)), 300, seed=2))
    for r in rows:
        assert r["rms_error"] == expect[(r["method"], r["coefficient"])]["rms_error"]



def test_progress_bar_only_after_delay_and_on_a_terminal(capsys):
    from accelcal.cli.progress import DelayedProgress

    with DelayedProgress("trials", delay=0.0, force=True) as bar:
        bar(5, 10)
        bar(10, 10)
    assert "10/10" in capsys.readouterr().err
    with DelayedProgress("trials", delay=0.0) as quiet:  # stderr is not a terminal here
        quiet(10, 10)
    with DelayedProgress("trials", delay=60.0, force=True) as later:  # a short run
        later(10, 10)
    assert capsys.readouterr().err == ""


def _all_terms_rig(half_width=5 * ARCSEC):
    model = ErrorModel(K0=1e-3, K1=1.3, K2=2e-5, K3=-3e-6, K4=4e-7, Ko=-1e-5, Koo=6e-6,
                       Kio=-7e-6, K0_asym=2e-5, K1_asym=-3e-5, Kp=9.0, Kpp=9.0, Kip=9.0,
                       Kop=9.0, output_unit="V")
    return DividingHeadRig.uniform(24, (model, *dong2014_models(3)), eta=[1e-4, 0, -2e-4, 0],
                                   angle_error=AngleErrorProfile.uniform(half_width),
                                   first_harmonic=DONG2014_FIRST_HARMONIC, noise=1e-6)


@pytest.mark.parametrize("half_width", [5 * ARCSEC, 3600 * ARCSEC])
def test_taylor_outputs_match_the_rig_for_every_model_term(half_width):
    """SensorBank.outputs (Taylor series in d when |d| is small enough, else the exact
    evaluation) against DividingHeadRig.outputs, every model term: atol 1e-14 V."""
    rig = _all_terms_rig(half_width)
    rng = np.random.default_rng(3)
    d = rig.angle_errors(50, rng)
    noise = rng.normal(0.0, 1e-6, (50, 4, 24))
    bank = SensorBank(rig.models, rig.sensor_angles() + rig.eta[:, None])
    order = bank.taylor_order(float(np.max(np.abs(d))))
    assert (order is None) == (half_width > 5 * ARCSEC)
    expected = rig.outputs(d)[:, 0] + noise  # (T, K, n)
    got = bank.outputs(d, noise)  # (K, n, T)
    np.testing.assert_allclose(got.transpose(2, 0, 1), expected, rtol=0, atol=1e-14)


def test_study_with_large_head_errors_matches_per_trial_reductions():
    """Head errors too large for the Taylor series (exact evaluation), mounts off their
    nominal angles: the study against the one-record reductions."""
    rig = DividingHeadRig.uniform(24, dong2014_models(4), eta=[1e-4, 0, -2e-4, 3e-4],
                                  angle_error=AngleErrorProfile.uniform(1800 * ARCSEC),
                                  first_harmonic=DONG2014_FIRST_HARMONIC, noise=1e-6)
    study = HeadStudy(rig, ("single",), 0.0)
    assert study.sensors.taylor_order(float(np.max(np.abs(
        study.draw(block_generator(4, 0), 6)[0])))) is None
    trials = 6
    res = run_study(rig, trials, seed=4, methods=("single", "joint_unknown_h1"))
    d, noise, _ = HeadStudy(rig, STUDY_METHODS, 0.0).draw(block_generator(4, 0), trials)
    coef = np.array([[m.to_dong2014()[c] for c in COEFFICIENTS] for m in rig.models])
    sq = np.zeros((2, 4, 5))
    for t in range(trials):
        data = HeadData.build(rig.positions, rig.outputs(d[t])[0] + noise[t], rig.mounts)
        truth = coef.copy()
        truth[:, 2] += coef[:, 1] * (rig.eta + d[t].mean())
        for i, r in enumerate((single(data), joint(data))):
            sq[i] += (np.array([e.values for e in r.sensors]) - truth) ** 2
    np.testing.assert_allclose(res.rms_error, np.sqrt(sq / trials), rtol=1e-8)


@pytest.mark.skipif(np.finfo(np.longdouble).eps >= np.finfo(float).eps,
                    reason="needs an extended-precision long double")
def test_single_errors_match_an_extended_precision_reference():
    """The study's single-fit errors against the same fit done in long double (outputs from
    sin/cos in long double, least squares refined against Psi): the study never rounds at
    the outputs' magnitude, so its errors (~1e-6 V) are exact to ~1e-17 V."""
    rig, trials = _rig(), 64
    study = HeadStudy(rig, ("single",), 0.0)
    values = study(block_generator(5, 0), trials)[:, :20].reshape(trials, 4, 5)
    d, noise, _ = study.draw(block_generator(5, 0), trials)
    ld = np.longdouble
    gamma = (rig.sensor_angles() + rig.eta[:, None]).astype(ld)[None] + d[:, None, :].astype(ld)
    s, c = np.sin(gamma), np.cos(gamma)
    u = np.stack([ld(m.K1) * (ld(m.K0) + s[:, k] * (1 + s[:, k] * ld(m.K2))
                              + c[:, k] * (ld(m.Ko) + ld(m.Koo) * c[:, k] + ld(m.Kio) * s[:, k]))
                  for k, m in enumerate(rig.models)], axis=1) + noise
    sb, cb = np.sin(rig.sensor_angles().astype(ld)), np.cos(rig.sensor_angles().astype(ld))
    design = np.stack([np.ones_like(sb), sb, cb, sb * cb, sb * sb], axis=-1)  # (K, n, 5)
    op = study.single_op[:, :5].astype(ld)
    x = np.einsum("kij,tkj->tki", op, u)
    for _ in range(3):
        x += np.einsum("kij,tkj->tki", op, u - np.einsum("kji,tki->tkj", design, x))
    coef = np.array([[m.to_dong2014()[c] for c in COEFFICIENTS] for m in rig.models])
    truth = np.broadcast_to(coef, x.shape).astype(ld).copy()
    d0 = (study.gauge_proj[0] @ d.T.astype(ld))[:, None]  # (T, 1)
    truth[:, :, 2] += coef[:, 1] * (rig.eta + d0)
    np.testing.assert_allclose(values, (x - truth).astype(float), rtol=0, atol=1e-17)
