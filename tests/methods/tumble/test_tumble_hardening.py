"""Hardening of the tumble commands (issue 11): sizes, silently accepted input, extreme
values, seeds and the degrees of freedom of a noise estimated from the residuals."""

import json
import time

import numpy as np
import pytest

from accelcal import ErrorModel
from accelcal.errors import AccelcalError
from accelcal.io.formats import tumble as tumble_format
from accelcal.methods.tumble import identifiability, reduce_tumble
from accelcal.rigs.tumble import simulate, uniform_positions
from helpers.cli import refused, run_cli


# ------------------------------------------------------------------ sizes
@pytest.mark.parametrize("args", [
    ["tumble", "identify", "--points", "1000000000"],
    ["tumble", "simulate", "--out", "{out}", "--points", "1000000000"],
    ["tumble", "simulate", "--out", "{out}", "--repeats", "1000000000"],
])
def test_sizes_refused_before_allocating_with_the_memory_needed(args, tmp_path, capsys):
    out = tmp_path / "t.csv"
    start = time.perf_counter()
    refused([a.format(out=out) for a in args], capsys, "would need about", "GiB")
    assert time.perf_counter() - start < 5.0
    assert not out.exists()


def test_identify_is_linear_in_the_positions():
    """A million positions: the design is N x p, never N x N (seconds, tens of MB)."""
    import tracemalloc

    identifiability(uniform_positions(64), "OA")  # warm up imports
    tracemalloc.start()
    start = time.perf_counter()
    report = identifiability(uniform_positions(200_000), "OA")
    elapsed = time.perf_counter() - start
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert report.rank == 7
    assert peak < 200e6, peak  # an N x N matrix would be 320 GB; N x p is 13 MB
    assert elapsed < 20.0, elapsed


# ------------------------------------------------- silently accepted input
@pytest.mark.parametrize("args", [
    ["tumble", "identify", "--points", "1"],
    ["tumble", "identify", "--angles", "90,270"],  # a_i = 0 at both: no scale factor
    ["tumble", "identify", "--angles", "0", "--terms", "K0,K1,K2"],
])
def test_positions_that_cannot_separate_the_scale_factor_are_refused(args, capsys):
    refused(args, capsys, "cannot separate K1 from K0")


def test_two_positions_are_enough_for_bias_and_scale_factor():
    assert set(identifiability(np.radians([0.0, 180.0]), "OA").suggested_terms) >= {"K0", "K1"}


@pytest.mark.parametrize("points", [0, -3, 2.5, True])
def test_uniform_positions_refuses_a_bad_count(points):
    with pytest.raises(AccelcalError, match="integer of at least 1"):
        uniform_positions(points)


@pytest.mark.parametrize("args", [
    ["tumble", "simulate", "--out", "{out}", "--seed", "-1"],
    ["tumble", "simulate", "--out", "{out}", "--points", "0"],
    ["tumble", "simulate", "--out", "{out}", "--noise", "1e308", "--repeats", "4"],
])
def test_simulate_refuses_bad_values(args, tmp_path, capsys):
    out = tmp_path / "t.csv"
    refused([a.format(out=out) for a in args], capsys)
    assert not out.exists()


@pytest.mark.parametrize(("args", "word"), [
    (["--noise", "1e200"], "--noise"),  # finite outputs, but beyond what a file holds
    (["--start", "1e7"], "--start"),  # angles beyond what a file holds
])
def test_simulate_never_writes_what_its_reader_refuses(args, word, tmp_path, capsys):
    out = tmp_path / "t.csv"
    refused(["tumble", "simulate", "--out", out, *args], capsys, word)
    assert not out.exists()
    # at the edge: written and read back
    edge = simulate(uniform_positions(8, np.radians(9.9e5)), ErrorModel(K1=1.0), noise=1e8,
                    seed=0)
    tumble_format.write(tmp_path / "edge.csv", edge)
    assert tumble_format.read(tmp_path / "edge.csv").outputs.shape == (8, 1)


def test_simulated_records_give_simulated_calibration_records(tmp_path, capsys):
    """`tumble simulate` marks its file; a calibration record made from it says so (tumble
    reduce has no --record: the record is made from Python, as the demo does)."""
    from accelcal.calibration import lab_info

    path = tmp_path / "t.csv"
    code, _, err = run_cli(["tumble", "simulate", "--out", path, "--seed", "2"], capsys)
    assert code == 0, err
    record = tumble_format.read(path)
    assert record.metadata["simulated"] is True
    assert record.lab.simulated
    code, _, err = run_cli(["tumble", "reduce", path, "--format", "json"], capsys)
    assert code == 0, err
    red = reduce_tumble(record.angles_rad, record.outputs[:, 0],
                        rotation_axis=record.rotation_axis, output_unit=record.output_unit)
    (cal,) = red.to_records(lab_info([path], serial="SN-1"), input_files=[path])
    assert cal.simulated
    assert json.loads(cal.to_json())["simulated"] is True


# ------------------------------------------------------------- extreme values
@pytest.mark.parametrize(("column", "value"), [("output", "1e308"), ("output", "-1e308"),
                                               ("angle", "1e308"), ("output", "1e200")])
@pytest.mark.parametrize("sigma", [[], ["--sigma", "1e-5"]])
def test_extreme_cells_give_one_line(column, value, sigma, tmp_path, capsys):
    path = tmp_path / "t.csv"
    assert run_cli(["tumble", "simulate", "--out", path, "--seed", "1"], capsys)[0] == 0
    lines = path.read_text().splitlines()
    names = lines[2].split(",")
    cells = lines[5].split(",")
    cells[names.index(column)] = value
    lines[5] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    refused(["tumble", "reduce", path, "--format", "json", *sigma], capsys,
            "beyond any physical value")


def test_a_reduction_never_carries_infinite_uncertainties():
    theta = uniform_positions(12)
    noise = np.random.default_rng(1).normal(0.0, 1e-3, 12)
    y = 1e170 * (np.cos(theta) + noise)  # residuals square beyond the float range
    with pytest.raises(AccelcalError, match="not finite"):
        reduce_tumble(theta, y)


# --------------------------------------------------- degrees of freedom
def test_few_dof_are_reported_and_warned(tmp_path, capsys):
    model = ErrorModel(K1=1.2, K0=1e-4, K2=2e-5)
    record = simulate(uniform_positions(8), model, noise=2e-5, seed=3)
    red = reduce_tumble(record.angles_rad, record.outputs[:, 0])
    assert red.dof == red.estimate.dof == 1  # 8 positions, 7 terms
    few = red.assumption("few_dof")
    assert few.value == 1
    assert "k = 14" in few.text
    assert "fewer than 10" in few.text
    assert few.text in red.estimate.notes
    # the noise given: no variance estimated, Reduction.dof 0, no warning
    given = reduce_tumble(record.angles_rad, record.outputs[:, 0], sigma=2e-5)
    assert given.dof == 0
    assert given.estimate.dof == 1  # still the residual degrees of freedom
    assert "few_dof" not in {a.name for a in given.assumptions}
    # 24 positions: 17 dof, no warning
    many = simulate(uniform_positions(24), model, noise=2e-5, seed=3)
    red24 = reduce_tumble(many.angles_rad, many.outputs[:, 0])
    assert red24.dof == 17
    assert "few_dof" not in {a.name for a in red24.assumptions}
    # the CLI: the dof column and the note
    path = tmp_path / "t8.csv"
    tumble_format.write(path, record)
    code, out, err = run_cli(["tumble", "reduce", path, "--format", "json"], capsys)
    assert code == 0
    assert {row["dof"] for row in json.loads(out)} == {1}
    assert "note: noise SD estimated from only 1 degree(s) of freedom" in err
