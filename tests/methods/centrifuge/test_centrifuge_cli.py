"""``accelcal centrifuge`` (issue 14 item 4): simulate, reduce (alone, joint), plan; format."""

import json

import numpy as np
import pytest

from accelcal.io.formats import centrifuge as fmt
from accelcal.model import TERMS
from helpers.cli import run_cli


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("centrifuge")
    from accelcal.cli import main

    for args in (["centrifuge", "simulate", "--out", d / "c.csv", "--radius-error", "2e-4",
                  "--radius-sd", "1e-4", "--readings", "2", "--spinup", "1", "--seed", "4"],
                 ["tumble", "simulate", "--out", d / "t.csv", "--seed", "5"]):
        with pytest.raises(SystemExit) as exc:
            main([str(a) for a in args])
        assert exc.value.code == 0
    return d


def test_simulate_writes_steps_with_the_truth(files):
    rec = fmt.read(files / "c.csv")
    steps = rec.steps()
    assert steps.step.size == 7 * 10  # seven positions x levels 5:50:5
    assert set(rec.position_names) == {"IA-in", "IA-out", "OA-in", "OA-out", "PA-in",
                                       "PA-out", "IA-tan"}
    assert np.all(steps.count == 2)
    assert int(rec.spinup.sum()) == 70
    sim = rec.metadata["simulation"]
    assert sim["rig"]["radius_error"] == 2e-4
    assert set(sim["true_model"]) == set(TERMS)
    assert rec.survey == {"radius_error": {"value": 0.0, "sd": 1e-4}}
    np.testing.assert_allclose(steps.rate2 * 1.5 / 9.80665, steps.level, rtol=1e-12)


def test_reduce_json_rows_like_dividing_head(files, capsys):
    code, out, err = run_cli(["centrifuge", "reduce", files / "c.csv", "--format", "json"],
                             capsys)
    assert code == 0, err
    rows = json.loads(out)
    assert {"sensor", "coefficient", "estimate", "std"} <= set(rows[0])
    names = [r["coefficient"] for r in rows]
    assert {r["plain"] for r in rows} <= set(TERMS)  # as `accelcal model show` prints them
    # Kop is aliased with Ko and Kio in these positions: the rows say so in their names
    assert "Kop" not in names
    assert {"Ko-Kop", "Kio+Kop"} <= set(names)
    assert "Kop is not separable" in err
    truth = fmt.read(files / "c.csv").metadata["simulation"]["true_model"]
    k2 = next(r for r in rows if r["coefficient"] == "K2")
    assert abs(k2["estimate"] - truth["K2"]) < 5 * k2["std"]


def test_reduce_with_a_one_g_record_estimates_the_radius(files, capsys, tmp_path):
    code, out, err = run_cli(["centrifuge", "reduce", files / "c.csv", "--with", files / "t.csv",
                              "--format", "json", "--record", tmp_path / "rec.json",
                              "--serial", "ACC-9", "--plot", tmp_path / "fig"], capsys)
    assert code == 0, err
    rows = json.loads(out)
    rig = [r for r in rows if r["sensor"] == "rig"]
    assert [r["coefficient"] for r in rig] == ["radius_error"]
    assert abs(rig[0]["estimate"] - 2e-4) < 5 * rig[0]["std"]
    assert rig[0]["std"] < 1e-5  # the 1 g record fixes K1: far better than the 1e-4 survey
    record = json.loads((tmp_path / "rec.json").read_text())
    assert record["method"] == "centrifuge/joint"
    assert (tmp_path / "fig" / "centrifuge-residuals.png").exists()
    code, out, _ = run_cli(["centrifuge", "reduce", files / "c.csv", "--with", files / "t.csv",
                            "--format", "csv", "--estimate", "radius_error,arm_stretch"], capsys)
    assert code == 0
    assert "rig,arm_stretch" in out


def test_plan_json(capsys):
    code, out, err = run_cli(["centrifuge", "plan", "--levels", "5:50:5", "--positions",
                              "IA-in,IA-out,IA-tan", "--radius-sd", "1e-4", "--format", "json"],
                             capsys)
    assert code == 0, err
    doc = json.loads(out)
    k1 = next(r for r in doc["predicted"] if r["coefficient"] == "K1")
    assert k1["std"] == pytest.approx(1e-4, rel=1e-2)
    assert any("radius_error cannot be separated from K1" in s for s in doc["statements"])
    code, out, _ = run_cli(["centrifuge", "plan", "--levels", "5,20,50", "--positions",
                            "IA-in,IA-out,X=90/0/180", "--one-g-positions", "24",
                            "--estimate", "radius_error"], capsys)
    assert code == 0
    assert "radius_error" in out


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_format_round_trip(files, tmp_path, suffix):
    rec = fmt.read(files / "c.csv")
    path = tmp_path / f"c{suffix}"
    fmt.write(path, rec)
    back = fmt.read(path)
    for name in ("step", "position", "level", "rate", "output", "spinup"):
        np.testing.assert_array_equal(getattr(back, name), getattr(rec, name))
    assert back.positions == rec.positions
    assert back.survey == rec.survey
    assert back.metadata == rec.metadata


def test_format_imports_no_method_rig_or_cli():
    import subprocess
    import sys

    code = ("import sys, accelcal.io.formats.centrifuge; bad = [m for m in sys.modules if "
            "m.startswith(('accelcal.methods', 'accelcal.rigs', 'accelcal.cli'))]; print(bad)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_demo_stage(tmp_path):
    from accelcal.demo import lab
    from accelcal.methods.centrifuge import demo
    from accelcal.pipeline import run_campaign

    res = run_campaign([demo.stage("ACC-0001", lab)], tmp_path, seed=3, progress=False,
                       title="centrifuge")
    (outcome,) = res.outcomes
    red = outcome.reduction
    assert red.method == "centrifuge/joint"
    assert red.shared.names == demo.ESTIMATE
    truth = demo.RIG["radius_error"]
    assert abs(red.shared["radius_error"] - truth) < 5 * red.shared.std_of("radius_error")
    assert [r.serial for r in outcome.records] == ["ACC-0001"]
    assert "Precision centrifuge" in res.report.read_text()
