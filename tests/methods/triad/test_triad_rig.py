"""The triad rig and the ``triad`` record format (issue 12).

The rig's static intervals are checked against the model directly, its
motions against the kinematics (the norm of the specific force departs
from g only by the lever-arm acceleration); the format by round trips and
by one-line refusals of malformed files.
"""

import json
import subprocess
import sys

import numpy as np
import pytest

from accelcal.errors import AccelcalError
from accelcal.io.formats import KINDS
from accelcal.io.formats import triad as triad_format
from accelcal.io.records import write_record
from accelcal.methods.triad import TriadCalibration
from accelcal.rigs.triad import random_directions, simulate, six_positions

G = 9.80665
CAL = TriadCalibration([300.0, -200.0, 50.0], [6e-4, 6.1e-4, 5.9e-4], [2e-3, -1e-3, 5e-4],
                       input_unit="counts")


def test_static_intervals_are_the_model_and_layout():
    rec = simulate(CAL, six_positions(), rate=50.0, dwell=2.0, motion=1.0, still=10.0)
    assert rec.labels == ["x_p", "x_a", "y_p", "y_a", "z_p", "z_a"]
    starts = [p["start"] for p in rec.positions]
    stops = [p["stop"] for p in rec.positions]
    # still + first dwell, then (motion, dwell) per further position
    assert starts == [0, 650, 800, 950, 1100, 1250]
    assert stops == [600, 750, 900, 1050, 1200, 1350]
    assert rec.acc.shape == (1350, 3)
    np.testing.assert_allclose(np.diff(rec.t), 1 / 50.0, rtol=1e-12)
    for p in rec.positions:
        want = CAL.readings(G * np.asarray(p["up"]))
        block = rec.acc[p["start"]:p["stop"]]
        np.testing.assert_allclose(block, np.tile(want, (len(block), 1)), rtol=0, atol=1e-9)
    means, counts = rec.interval_means()
    np.testing.assert_allclose(means, CAL.readings(G * rec.up), rtol=0, atol=1e-9)
    assert counts.tolist() == [600, 100, 100, 100, 100, 100]
    assert rec.metadata["simulated"] is True
    assert rec.metadata["true_calibration"] == CAL.to_dict()


def test_motion_is_a_smooth_rotation_with_lever_arm_acceleration():
    rec = simulate(CAL, six_positions(), rate=200.0, dwell=1.0, motion=2.0, still=1.0,
                   lever_arm=(0.0, 0.0, 0.0))
    a = CAL.apply(rec.acc)
    # without a lever arm a pure rotation keeps |f| = g at every sample
    np.testing.assert_allclose(np.linalg.norm(a, axis=1), G, rtol=1e-12)
    moving = np.ones(len(a), bool)
    for p in rec.positions:
        moving[p["start"]:p["stop"]] = False
    # the direction changes continuously: steps below 2 * max rate / fs (quintic peak 1.875 x)
    step = np.linalg.norm(np.diff(a / G, axis=0), axis=1)
    assert step.max() < 2 * 1.875 * np.pi / 2.0 / 200.0
    with_arm = simulate(CAL, six_positions(), rate=200.0, dwell=1.0, motion=2.0, still=1.0)
    dev = np.abs(np.linalg.norm(CAL.apply(with_arm.acc), axis=1) - G)
    assert dev[~moving].max() < 1e-9
    assert dev[moving].max() > 1e-3  # the motion shows in the norm


def test_repeated_direction_gets_a_wiggle_and_random_directions_are_seeded():
    rec = simulate(CAL, np.vstack([six_positions()[:1]] * 2), rate=100.0, dwell=1.0,
                   motion=1.0, still=0.0)
    mid = rec.acc[100:200]
    assert np.ptp(mid, axis=0).max() > 10  # counts: a 20 deg tilt is ~500 counts
    a = simulate(CAL, 10, noise_sd=3.0, seed=4)
    b = simulate(CAL, 10, noise_sd=3.0, seed=4)
    np.testing.assert_array_equal(a.acc, b.acc)
    assert a.metadata["seed"] == 4
    assert a.labels[0] == "P1"
    resid = a.acc[:3000] - CAL.readings(G * a.up[0])
    # 9000 noise draws: the SD of the sample SD is 0.75 %
    assert resid.std() == pytest.approx(3.0, rel=0.03)
    np.testing.assert_allclose(np.linalg.norm(random_directions(5, np.random.default_rng(1)),
                                              axis=1), 1.0)


@pytest.mark.parametrize(("kwargs", "parameter"),
                         [({"up": np.ones((3, 3))}, "up"), ({"up": 0}, "up"),
                          ({"up": np.ones((3, 2))}, "up"), ({"rate": 0.0}, "rate"),
                          ({"dwell": -1.0}, "dwell"), ({"motion": float("nan")}, "motion"),
                          ({"still": -1.0}, "still"), ({"noise_sd": -1.0}, "noise_sd"),
                          ({"gravity": 1.0}, "gravity"), ({"seed": -1}, "seed"),
                          ({"lever_arm": (1, 2)}, "lever_arm"), ({"labels": ["a"]}, "labels"),
                          ({"rate": 1e9}, "rate")])
def test_rig_bad_input(kwargs, parameter):
    args = {"up": six_positions(), **kwargs}
    with pytest.raises(AccelcalError) as exc:
        simulate(CAL, args.pop("up"), **args)
    assert exc.value.parameter == parameter


# ----------------------------------------------------------------------------- format
@pytest.mark.parametrize(("suffix", "unit"), [(".csv", "counts"), (".parquet", "counts"),
                                              (".csv", "g"), (".csv", "mg")])
def test_format_round_trip(tmp_path, suffix, unit):
    cal = TriadCalibration(CAL.bias, CAL.scale, CAL.angles, input_unit=unit)
    rec = simulate(cal, six_positions(), rate=20.0, dwell=1.0, motion=1.0, still=2.0,
                   noise_sd=1.0, seed=1)
    rec = type(rec)(rec.t, rec.acc, rec.input_unit, rec.positions,
                    {**rec.metadata, "serial": "SN-9"})
    path = tmp_path / f"t{suffix}"
    triad_format.write(path, rec)
    back = triad_format.read(path)
    np.testing.assert_array_equal(back.acc, rec.acc)
    np.testing.assert_array_equal(back.t, rec.t)
    assert back.input_unit == unit
    assert back.positions == rec.positions
    assert back.metadata == rec.metadata
    assert back.lab.serial() == "SN-9"
    assert KINDS["triad"] == "accelcal.io.formats.triad"


def _write(path, meta=None, t=(0.0, 0.1, 0.2), acc=None, units=None):
    acc = np.zeros((len(t), 3)) if acc is None else np.asarray(acc)
    units = units or {"t": "s", "acc_x": "1", "acc_y": "1", "acc_z": "1"}
    write_record(path, "triad", {"units": units, "input_unit": "counts", **(meta or {})},
                 {"t": t, "acc_x": acc[:, 0], "acc_y": acc[:, 1], "acc_z": acc[:, 2]})


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({"meta": {"input_unit": "furlong"}}, "input_unit 'furlong' is not one of"),
     ({"t": (0.0, 0.2, 0.1)}, "column t does not increase at row 2"),
     ({"units": {"t": "s", "acc_x": "V", "acc_y": "1", "acc_z": "1"}},
      "column acc_x is in 'V' but input_unit is 'counts'"),
     ({"units": {"t": "Hz", "acc_x": "1", "acc_y": "1", "acc_z": "1"}}, "column t must be in s"),
     ({"acc": [[0, 0, 0], [2e12, 0, 0], [0, 0, 0]]}, "acc_x row 1 = 2e.12 is beyond"),
     ({"meta": {"gravity": 1.0}}, "gravity 1.0 must be in m/s"),
     ({"meta": {"positions": {"a": 1}}}, "positions must be a list"),
     ({"meta": {"positions": [{"label": "a", "up": [1, 0, 0], "start": 0}]}},
      r"positions\[0\] must be an object with label"),
     ({"meta": {"positions": [{"label": "a", "up": [2, 0, 0], "start": 0, "stop": 1}]}},
      "up has norm 2"),
     ({"meta": {"positions": [{"label": "a", "up": [1, 0, 0], "start": 2, "stop": 9}]}},
      "start 2, stop 9 must be sample indices"),
     ({"meta": {"positions": [{"label": "a\nb", "up": [1, 0, 0], "start": 0, "stop": 1}]}},
      "control character"),
     ({"meta": {"serial": ""}}, "metadata 'serial'")])
def test_format_refuses_malformed_files(tmp_path, kwargs, match):
    path = tmp_path / "bad.csv"
    _write(path, **kwargs)
    with pytest.raises(AccelcalError, match=match) as exc:
        triad_format.read(path)
    assert "\n" not in str(exc.value)


def test_format_requires_columns_and_unit(tmp_path):
    path = tmp_path / "r.csv"
    write_record(path, "triad", {"units": {"t": "s", "acc_x": "1"}, "input_unit": "counts"},
                 {"t": [0.0, 1.0], "acc_x": [0.0, 1.0]})
    with pytest.raises(AccelcalError, match="acc_y"):
        triad_format.read(path)
    write_record(path, "triad", {"units": {"t": "s"}}, {"t": [0.0, 1.0]})
    with pytest.raises(AccelcalError, match="input_unit"):
        triad_format.read(path)
    text = path.read_text().splitlines()
    assert json.loads(text[1][2:])["kind"] == "triad"


def test_format_imports_no_method_rig_or_cli():
    code = ("import sys, accelcal.io.formats.triad; "
            "bad = [m for m in sys.modules if m.startswith(('accelcal.methods', 'accelcal.rigs', "
            "'accelcal.cli'))]; print(bad)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
