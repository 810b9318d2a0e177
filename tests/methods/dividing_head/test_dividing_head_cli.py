"""``accelcal dividing-head``: simulate, reduce, study; record files; bad input exits 2."""

import json

import numpy as np
import pytest

from accelcal.cli import main
from accelcal.io.formats.dividing_head import read_head_record, write_head_record
from accelcal.methods.dividing_head import COEFFICIENTS, HeadData


def _run(args, capsys):
    with pytest.raises(SystemExit) as exc:
        main(args)
    out, err = capsys.readouterr()
    return exc.value.code, out, err


@pytest.fixture
def record(tmp_path, capsys):
    path = tmp_path / "head.csv"
    code, out, _ = _run(["dividing-head", "simulate", "--positions", "24", "--mounts",
                         "0,90,180,270", "--angle-error", "harmonics:2c=5arcsec,3s=1arcsec",
                         "--first-harmonic", "1.5e-5,-1.9e-6", "--noise", "0", "--seed", "1",
                         "--out", str(path)], capsys)
    assert code == 0
    assert "wrote" in out
    return path


def test_simulate_writes_truth_and_reduce_json_contract(record, capsys):
    rec = read_head_record(record)
    assert rec.outputs.shape == (1, 4, 24)
    assert len(rec.simulation["angle_error_rad"]) == 24
    models = rec.true_models()
    code, out, _ = _run(["dividing-head", "reduce", str(record), "--method", "joint",
                         "--first-harmonic", "1.5e-5,-1.9e-6", "--format", "json"], capsys)
    assert code == 0
    rows = json.loads(out)
    # the columns of before, then the generic rows' additions (unit, status, dof, eng_*)
    assert all(list(r)[:4] == ["sensor", "coefficient", "estimate", "std"] for r in rows)
    assert [r["plain"] for r in rows[:5]] == list(COEFFICIENTS)
    # about PA, K_F and K_II carry the cross-axis nonlinearity: the rows say so
    assert [r["coefficient"] for r in rows[:5]] == ["K_F+K_OO", "K_I", "K_O", "K_IO",
                                                    "K_II-K_OO"]
    by = {(r["sensor"], r["plain"]): r["estimate"] for r in rows}
    for k, m in enumerate(models):
        truth = m.to_dong2014()
        for c in ("K_F", "K_I", "K_IO", "K_II"):  # K_O is K_O* (eta = 0, d0 = 0 here)
            assert by[(f"U{k + 1}", c)] == pytest.approx(truth[c], abs=2e-9)  # second order


@pytest.mark.parametrize("method", ["single", "four", "joint", "tumble"])
@pytest.mark.parametrize("fmt", ["csv", "table"])
def test_reduce_every_method_and_format(record, capsys, method, fmt):
    if method == "tumble":
        tumble = pytest.importorskip("accelcal.methods.tumble")
        if not hasattr(tumble, "reduce_tumble"):
            pytest.skip("tumble reduction not available")
    code, out, _ = _run(["dividing-head", "reduce", str(record), "--method", method,
                         "--format", fmt], capsys)
    assert code == 0
    if fmt == "csv":
        assert out.splitlines()[0].startswith("sensor,coefficient,estimate,std,")
        assert len(out.splitlines()) == 1 + 20


def test_study_json_contract(capsys):
    code, out, _ = _run(["dividing-head", "study", "--trials", "300", "--angle-error",
                         "uniform:2arcsec", "--first-harmonic", "1.5e-5,-1.9e-6",
                         "--format", "json"], capsys)
    assert code == 0
    rows = json.loads(out)
    assert {r["method"] for r in rows} == {"single", "four_unknown_h1", "four_known_h1",
                                           "joint_unknown_h1", "joint_known_h1"}
    assert all(set(r) == {"method", "coefficient", "rms_error", "mean_formal_sd"} for r in rows)


def test_plot_option_writes_figures(record, tmp_path, capsys):
    code, _, _ = _run(["dividing-head", "reduce", str(record), "--method", "four",
                       "--format", "csv", "--plot", str(tmp_path / "fig")], capsys)
    assert code == 0
    names = sorted(p.name for p in (tmp_path / "fig").iterdir())
    assert names == ["dividing_head_angle_error.png", "dividing_head_angle_error.svg",
                     "dividing_head_residuals.png", "dividing_head_residuals.svg"]


def test_record_round_trip_with_repeats_and_autocollimator(tmp_path):
    alpha = np.arange(12) * np.pi / 6
    u = np.random.default_rng(0).normal(size=(3, 2, 12))
    path = tmp_path / "r.csv"
    write_head_record(path, alpha, u, np.radians([0, 90]), autocollimator=np.zeros(12) + 1e-6,
                      autocollimator_sd=1e-7, first_harmonic=(1e-5, 0), first_harmonic_sd=1e-7)
    rec = read_head_record(path)
    np.testing.assert_array_equal(rec.outputs, u)  # %.17g round-trips exactly
    np.testing.assert_allclose(rec.positions, alpha, rtol=0, atol=1e-15)
    np.testing.assert_allclose(rec.autocollimator, 1e-6, rtol=1e-14)
    assert HeadData.from_record(rec).repeats == 3


def _edit(path, fn):
    lines = path.read_text().splitlines()
    fn(lines)
    path.write_text("\n".join(lines) + "\n")


def _set_meta(key, value):
    def fn(lines):
        meta = json.loads(lines[1][2:])
        meta[key] = value
        lines[1] = "# " + json.dumps(meta)
    return fn


@pytest.mark.parametrize(("edit", "message"), [
    (lambda lines: lines.__setitem__(5, lines[4]), "repeat the angle"),
    (lambda lines: lines.__setitem__(6, lines[6].rsplit(",", 1)[0] + ",nan"), "not finite"),
    (_set_meta("mount_phases_deg", [0, 90, 180]), "mount phases for 4 sensor columns"),
    (_set_meta("colour", "red"), "unknown metadata"),
])
def test_bad_records_exit_2(record, capsys, edit, message):
    _edit(record, edit)
    code, out, err = _run(["dividing-head", "reduce", str(record), "--method", "single"], capsys)
    assert code == 2
    assert err.startswith("accelcal: error:")
    assert message in err
    assert len(err.strip().splitlines()) == 1
    assert out == ""


@pytest.mark.parametrize(("args", "message"), [
    (["--method", "fourier"], "unknown"),
    (["--method", "four", "--format", "xml"], "--format"),
    (["--method", "single", "--first-harmonic", "1e-5"], "two values"),
    (["--method", "joint", "--covariance", "propagated"],
     "--covariance: applies to method four only"),
    (["--method", "four", "--covariance", "exact"],
     "--covariance: 'exact' is not one of paper, propagated"),
    (["--method", "four", "--gauss-newton"], "--gauss-newton: applies to method joint only"),
])
def test_bad_options_exit_2(record, capsys, args, message):
    code, _, err = _run(["dividing-head", "reduce", str(record), *args], capsys)
    assert code == 2
    assert message in err


def test_too_few_positions_exit_2_and_nothing_written(tmp_path, capsys):
    path = tmp_path / "few.csv"
    code, _, err = _run(["dividing-head", "simulate", "--positions", "5", "--out", str(path)],
                        capsys)
    assert code == 2  # no reduction could use it
    assert "--positions: must be an integer >= 6" in err
    assert not path.exists()
    alpha = np.arange(5) * 2 * np.pi / 5  # a measured file of 5 positions
    write_head_record(path, alpha, np.stack([np.sin(alpha), np.cos(alpha)]), np.radians([0, 90]))
    for method, message in (("single", "at least 6"), ("four", "at least 12"),
                            ("joint", "degree of freedom")):
        code, _, err = _run(["dividing-head", "reduce", str(path), "--method", method], capsys)
        assert code == 2, method
        assert message in err
    bad = tmp_path / "bad.csv"
    code, _, err = _run(["dividing-head", "simulate", "--angle-error", "gauss:2arcsec",
                         "--out", str(bad)], capsys)
    assert code == 2
    assert not bad.exists()
    code, _, err = _run(["dividing-head", "simulate", "--mounts", "0,90", "--model",
                         str(tmp_path / "missing.json"), "--out", str(bad)], capsys)
    assert code == 2
    assert not bad.exists()


def test_autocollimator_readings_in_file_fix_the_first_harmonic(tmp_path, capsys):
    path = tmp_path / "ac.csv"
    code, _, _ = _run(["dividing-head", "simulate", "--angle-error", "harmonics:2c=3arcsec",
                       "--first-harmonic", "3arcsec,-1arcsec", "--noise", "0",
                       "--autocollimator-sd", "0.001", "--out", str(path)], capsys)
    assert code == 0
    models = read_head_record(path).true_models()
    rows = {}
    for extra in ([], ["--gauss-newton", "--first-harmonic", "3arcsec,-1arcsec"]):
        code, out, _ = _run(["dividing-head", "reduce", str(path), "--method", "joint",
                             "--format", "json", *extra], capsys)
        assert code == 0
        rows[bool(extra)] = {(r["sensor"], r["plain"]): r["estimate"]
                             for r in json.loads(out)}
    for k, m in enumerate(models):
        truth = m.to_dong2014()
        for c in ("K_F", "K_IO", "K_II"):
            # 24 readings with 0.001 arcsec (4.8e-9 rad) noise fix the first harmonic to
            # 4.8e-9 sqrt(2/24) = 1.4e-9 rad, i.e. 1.8e-9 V after K_I; 1e-8 V is 5 sigma
            # (second-order terms ~1e-9 V included)
            assert rows[False][(f"U{k + 1}", c)] == pytest.approx(truth[c], abs=1e-8)
            # exact model, exact first harmonic; the file's readings (noise 4.8e-9 rad) are
            # pseudo-observations weighted by sigma / sd, sigma being the linear solution's
            # second-order residual (~1e-9): they move d by <~ (sigma / sd)^2 4.8e-9 / (K n / 2)
            # ~ 1e-11 rad at most, i.e. ~1e-11 V
            assert rows[True][(f"U{k + 1}", c)] == pytest.approx(truth[c], abs=2e-11)
    # the command passes the file's readings to the iteration: the API gives the same numbers
    from accelcal.methods.dividing_head import joint
    from accelcal.units import ARCSEC

    rec = read_head_record(path)
    api = joint(HeadData.from_record(rec), first_harmonic=(3 * ARCSEC, -1 * ARCSEC),
                autocollimator=rec.autocollimator, autocollimator_sd=rec.autocollimator_sd,
                gauss_newton=True)
    for k, est in enumerate(api.sensors):
        for c, v in zip(est.names, est.values, strict=True):
            assert rows[True][(f"U{k + 1}", c)] == pytest.approx(v, rel=1e-15, abs=0)


def test_user_angle_errors_from_values_and_from_a_survey_file(tmp_path, capsys):
    from accelcal.units import ARCSEC

    survey = np.round(np.random.default_rng(3).uniform(-2, 2, 12), 3)  # arcsec
    text = "# head survey, arcsec\n" + "\n".join(
        f"{a:.3f}, {b:.3f}  # positions {2 * i}, {2 * i + 1}"
        for i, (a, b) in enumerate(survey.reshape(-1, 2)))
    (tmp_path / "survey.txt").write_text(text + "\n")
    for spec, expected in (
        (f"file:{tmp_path / 'survey.txt'}", survey * ARCSEC),
        ("values:" + ",".join(f"{v}urad" for v in range(12)), np.arange(12) * 1e-6),
    ):
        out = tmp_path / "head.csv"
        code, _, err = _run(["dividing-head", "simulate", "--positions", "12", "--angle-error",
                             spec, "--noise", "0", "--out", str(out)], capsys)
        assert code == 0, err
        applied = read_head_record(out).simulation["angle_error_rad"]
        np.testing.assert_allclose(applied, expected, rtol=1e-15, atol=0)
        out.unlink()


@pytest.mark.parametrize(("spec", "message"), [
    ("values:1,2,3", "3 angle-error values given for 12 positions"),
    ("values:1,x", "unknown angle unit 'x'"),
    ("values:1,1e999", "'1e999' is not finite"),
    ("file:{tmp}/missing.txt", "cannot read it"),
    ("file:{tmp}/bad.txt", "bad.txt, line 2: 'nan' is not finite"),
    ("file:{tmp}/empty.txt", "holds no values"),
])
def test_bad_user_angle_errors_exit_2_and_write_nothing(tmp_path, capsys, spec, message):
    (tmp_path / "bad.txt").write_text("1.0\nnan\n")
    (tmp_path / "empty.txt").write_text("# nothing\n")
    out = tmp_path / "head.csv"
    code, _, err = _run(["dividing-head", "simulate", "--positions", "12", "--angle-error",
                         spec.format(tmp=tmp_path), "--out", str(out)], capsys)
    assert code == 2
    assert message in err
    assert "Traceback" not in err
    assert not out.exists()


def test_four_propagated_covariance_option(tmp_path, capsys):
    path = tmp_path / "noisy.csv"
    code, _, _ = _run(["dividing-head", "simulate", "--noise", "2.8e-6", "--seed", "3",
                       "--out", str(path)], capsys)
    assert code == 0
    rows = {}
    for cov in ("paper", "propagated"):
        code, out, err = _run(["dividing-head", "reduce", str(path), "--method", "four",
                               "--covariance", cov, "--format", "json"], capsys)
        assert code == 0, err
        rows[cov] = json.loads(out)
    assert [r["estimate"] for r in rows["paper"]] == [r["estimate"] for r in rows["propagated"]]
    ratio = np.array([b["std"] / a["std"] for a, b in zip(rows["paper"], rows["propagated"],
                                                          strict=True)])
    assert np.median(ratio) > 1.2  # the head error's share of the noise, omitted by the paper
