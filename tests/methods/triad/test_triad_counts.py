"""Raw ADC counts with a mid-scale offset in both triad routes, and the unit of every reader.

A simulated 16-bit triad (offset about 32768 counts, about 2000 counts per g, quantised to
whole counts, 3 counts of white noise per sample) is calibrated by the gravity norm (random
orientations, detected intervals) and by known orientations (an imucal session in counts,
``--unit counts``); both recover the true calibration within their stated uncertainty. Before,
the gravity-norm route counted orientations on the raw means (all within a degree of the
offset's direction: "1 distinct orientation"), and imucal sessions could only be m/s^2.
"""

import json

import numpy as np
import pytest
from scipy.stats import t as student

from accelcal.errors import AccelcalError
from accelcal.io.recordings import InputOptions
from accelcal.methods.triad.lab import run
from accelcal.methods.triad.model import TriadCalibration
from accelcal.methods.triad.unknown import calibrate_unknown, distinct_orientations
from accelcal.rigs.triad import simulate, six_positions
from helpers.cli import refused, run_cli

G = 9.80665
PER_G = 2000.0
TRUTH = TriadCalibration([32768 + 150, 32768 - 220, 32768 + 90],
                         [G / PER_G * 1.01, G / PER_G * 0.99, G / PER_G * 1.005],
                         [1e-3, -2e-3, 1.5e-3], input_unit="counts")
NOISE = 3.0  # counts per sample


def _record(up, seed):
    rec = simulate(TRUTH, up, rate=100.0, dwell=4.0, motion=2.0, still=30.0, noise_sd=NOISE,
                   seed=seed, gravity=G)
    return rec, np.round(rec.acc)  # whole counts


@pytest.fixture(scope="module")
def random_csv(tmp_path_factory):
    rec, acc = _record(30, 1)
    path = tmp_path_factory.mktemp("counts") / "counts.csv"
    np.savetxt(path, np.column_stack([rec.t, acc]), delimiter=",", header="t,ax,ay,az",
               comments="", fmt="%.6f")
    return path


@pytest.fixture(scope="module")
def imucal_counts(tmp_path_factory):
    rec, acc = _record(six_positions(), 2)
    part = np.full(len(acc), "", dtype=object)
    for p in rec.positions:
        part[p["start"]:p["stop"]] = p["label"]
    path = tmp_path_factory.mktemp("imucal") / "session.csv"
    lines = ["n_samples,acc_x,acc_y,acc_z,part"]
    lines += [f"{k},{int(a[0])},{int(a[1])},{int(a[2])},{lab}"
              for k, (a, lab) in enumerate(zip(acc, part, strict=True))]
    path.write_text("\n".join(lines) + "\n")
    return path


def _within(red, truth, k=4.0):
    """Every parameter within k stated SDs (Student's t at the reduction's dof) of the truth."""
    est = red.estimate
    factor = k if red.dof == 0 else k * student.ppf(0.9772, red.dof) / 2.0
    err = np.abs(est.values[:9] - truth.vector[:9]) / est.std[:9]
    assert np.all(err < factor), dict(zip(est.names, err.round(2), strict=True))


def test_offset_means_count_as_their_orientations_once_the_offset_is_removed():
    rng = np.random.default_rng(0)
    up = rng.standard_normal((20, 3))
    up /= np.linalg.norm(up, axis=1)[:, None]
    means = TRUTH.readings(G * up)
    assert distinct_orientations(means, 10) < 9  # all within a few degrees of the offset
    red = calibrate_unknown(means + rng.standard_normal(means.shape) * 0.1, G,
                            input_unit="counts")
    assert np.allclose(red.estimate.values[:3], TRUTH.bias, atol=1.0)  # counts


def test_gravity_norm_route_on_a_16_bit_recording(random_csv):
    lab = run(random_csv, options=InputOptions(time="t", unit="counts", columns=("ax", "ay",
                                                                                 "az")),
              gravity=G, orientations="unknown")
    assert lab.reduction.method == "triad/gravity-norm"
    assert len(lab.reduction.provenance["labels"]) >= 25
    _within(lab.reduction, TRUTH)
    assert np.abs(lab.reduction.observations["norm_after"]).max() < 0.01  # m/s^2


def test_known_route_on_an_imucal_session_in_counts(imucal_counts):
    lab = run(imucal_counts, options=InputOptions(input_format="imucal", rate=100.0,
                                                  unit="counts"), gravity=G)
    red = lab.reduction
    assert red.method == "triad/known-orientations"
    assert red.provenance["input_unit"] == "counts"
    _within(red, TRUTH)


def test_the_cli_takes_unit_and_scale_for_an_imucal_session(imucal_counts, tmp_path, capsys):
    out = tmp_path / "cal.json"
    base = ["triad", "calibrate", imucal_counts, "--input-format", "imucal", "--rate", "100",
            "--gravity", str(G), "--format", "json", "--out", out]
    code, out_text, err = run_cli([*base, "--unit", "counts"], capsys)
    assert code == 0, err
    bias = {r["coefficient"]: r["estimate"] for r in json.loads(out_text)["coefficients"]}
    assert bias["b_x"] == pytest.approx(TRUTH.bias[0], abs=1.0)
    # the file's numbers times the scale are counts: a 16-bit word holding 15-bit data
    code, out_text, err = run_cli([*base, "--unit", "counts", "--scale", "0.5"], capsys)
    assert code == 0, err
    half = {r["coefficient"]: r["estimate"] for r in json.loads(out_text)["coefficients"]}
    assert half["b_x"] == pytest.approx(TRUTH.bias[0] / 2, abs=0.5)
    assert half["s_x"] == pytest.approx(2 * TRUTH.scale[0], rel=1e-3)


def test_counts_taken_for_m_s2_are_refused_naming_the_unit(imucal_counts, tmp_path, capsys):
    refused(["triad", "calibrate", imucal_counts, "--input-format", "imucal", "--rate", "100",
             "--gravity", str(G), "--out", tmp_path / "cal.json"], capsys, "--unit", "counts")
    with pytest.raises(AccelcalError) as exc:
        run(imucal_counts, options=InputOptions(input_format="imucal", rate=100.0), gravity=G)
    assert exc.value.parameter == "unit"


def test_detect_takes_the_scale(random_csv, capsys):
    base = ["triad", "detect", random_csv, "--time", "t", "--columns", "ax,ay,az", "--unit",
            "counts", "--format", "json"]
    one = json.loads(run_cli(base, capsys)[1])
    two = json.loads(run_cli([*base, "--scale", "2"], capsys)[1])
    assert len(one) == len(two) >= 25
    assert two[0]["mean_x"] == pytest.approx(2 * one[0]["mean_x"], rel=1e-9)


def test_apply_corrects_an_imucal_session_in_counts(imucal_counts, tmp_path, capsys):
    cal, out = tmp_path / "cal.json", tmp_path / "out.csv"
    code, _, err = run_cli(["triad", "calibrate", imucal_counts, "--input-format", "imucal",
                            "--rate", "100", "--gravity", str(G), "--unit", "counts", "--out",
                            cal], capsys)
    assert code == 0, err
    base = ["triad", "apply", imucal_counts, "--input-format", "imucal", "--calibration", cal,
            "--out", out]
    refused(base, capsys, "--unit counts")  # the session is taken as m/s^2 unless told
    code, _, err = run_cli([*base, "--unit", "counts"], capsys)
    assert code == 0, err
    rows = np.genfromtxt(out, delimiter=",", names=True, dtype=None, encoding="utf-8")
    still = rows["part"] == "z_p"
    acc = np.column_stack([rows["acc_x"], rows["acc_y"], rows["acc_z"]])[still].mean(axis=0)
    assert np.linalg.norm(acc) == pytest.approx(G, abs=0.01)
    assert acc[2] == pytest.approx(G, abs=0.01)
