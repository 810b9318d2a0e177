"""Bad centrifuge input (issue 14 item 6): one line, exit status 2, nothing half-written."""

import numpy as np
import pytest

from accelcal.defaults import default_model
from accelcal.io.formats import centrifuge as fmt
from accelcal.rigs.centrifuge import simulate
from helpers.cli import refused


def _write(path, **changes):
    rec = simulate(default_model(), ("IA-in", "IA-out", "IA-tan"), (5.0, 20.0, 50.0),
                   readings=3, spinup=1, seed=1)
    fields = {**rec.__dict__, **changes}
    fmt.write(path, type(rec)(**fields))
    return path


def test_one_level_only(tmp_path, capsys):
    rec = simulate(default_model(), ("IA-in", "IA-out"), (20.0,), seed=1)
    fmt.write(tmp_path / "c.csv", rec)
    refused(["centrifuge", "reduce", tmp_path / "c.csv"], capsys, "--levels", "one level only")


def test_all_positions_alike(tmp_path, capsys):
    rec = simulate(default_model(), ("IA-in", {"name": "again", "angles_deg": [0, 0, 0]}),
                   (5.0, 20.0, 50.0), seed=1)
    fmt.write(tmp_path / "c.csv", rec)
    refused(["centrifuge", "reduce", tmp_path / "c.csv"], capsys, "--positions",
            "same orientation")


def test_rates_that_disagree_with_radius_and_levels(tmp_path, capsys):
    rec = simulate(default_model(), ("IA-in", "IA-out"), (5.0, 20.0, 50.0), seed=1)
    path = tmp_path / "c.csv"
    fmt.write(path, type(rec)(**{**rec.__dict__, "radius_m": 1.2}))  # stated radius wrong
    refused(["centrifuge", "reduce", path], capsys, "step 0", "not the stated level")


def test_a_spin_up_segment_inside_a_step(tmp_path, capsys):
    rec = simulate(default_model(), ("IA-in", "IA-out"), (5.0, 20.0, 50.0), readings=3,
                   spinup=1, seed=1)
    spin = rec.spinup.copy()
    spin[2] = 1.0  # a reading between steady readings of step 0
    path = tmp_path / "c.csv"
    fmt.write(path, type(rec)(**{**rec.__dict__, "spinup": spin}))
    refused(["centrifuge", "reduce", path], capsys, "spin-up reading (row 2)")


def test_steps_mixing_positions(tmp_path, capsys):
    rec = simulate(default_model(), ("IA-in", "IA-out"), (5.0, 20.0), seed=1)
    pos = rec.position.copy()
    pos[0] = 1.0
    path = tmp_path / "c.csv"
    fmt.write(path, type(rec)(**{**rec.__dict__, "position": pos,
                                 "step": np.zeros(rec.step.size)}))
    refused(["centrifuge", "reduce", path], capsys, "different positions")


@pytest.mark.parametrize(("args", "words"), [
    (["--with", "{c}"], ("--with", "not a 1 g record")),
    (["--sensor", "U1"], ("--sensor goes with --with",)),
    (["--terms", "K0,K2"], ("--terms", "K1")),
    (["--terms", "K1,Kxx"], ("--terms", "Kxx")),
    (["--estimate", "radius_error"], ("--estimate", "cannot be separated from K1")),
    (["--estimate", "wheel"], ("--estimate", "not a rig error")),
    (["--sigma", "-1"], ("--sigma",)),
])
def test_reduce_options(tmp_path, capsys, args, words):
    path = _write(tmp_path / "c.csv")
    refused(["centrifuge", "reduce", path, *[a.replace("{c}", str(path)) for a in args]],
            capsys, *words)


@pytest.mark.parametrize(("args", "words"), [
    (["--levels", "20"], ("--levels",)),
    (["--positions", "IA-in,IA-in"], ("--positions", "repeat")),
    (["--positions", "IA-sideways"], ("--positions", "IA-sideways")),
    (["--positions", "X=1/2"], ("--positions", "YAW/PITCH/ROLL")),
    (["--noise", "0"], ("--noise",)),
    (["--one-g-positions", "-1"], ("--one-g-positions",)),
])
def test_plan_options(capsys, args, words):
    base = {"--levels": "5:50:5", "--positions": "IA-in,IA-out"}
    for k in range(0, len(args), 2):
        base[args[k]] = args[k + 1]
    refused(["centrifuge", "plan", *[x for kv in base.items() for x in kv]], capsys, *words)


@pytest.mark.parametrize(("args", "words"), [
    (["--radius", "0"], ("--radius",)), (["--tilt", "1"], ("--tilt",)),
    (["--misalignment", "-1"], ("--misalignment",)), (["--levels", "0,10"], ("--levels",)),
    (["--readings", "0"], ("--readings",)), (["--noise", "1e12"], ("--noise",)),
    (["--radius-sd", "2"], ("--radius-sd",)),
])
def test_simulate_options(tmp_path, capsys, args, words):
    out = tmp_path / "c.csv"
    refused(["centrifuge", "simulate", "--out", out, *args], capsys, *words)
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []
