"""Input range, clipping and overload recovery; turn-on repeatability (rigs, reductions, CLI)."""

import numpy as np
import pytest

from accelcal.errors import AccelcalError
from accelcal.io.formats import acceptance as steps_format
from accelcal.methods import acceptance
from accelcal.rigs.acceptance_runs import simulate_range, simulate_turn_on
from helpers.cli import run_cli


@pytest.fixture(scope="module")
def range_record():
    return simulate_range(seed=4, dwell=2.0, rate=20.0)


def test_noise_free_range_is_recovered_within_its_interpolation_uncertainty():
    red = acceptance.reduce(simulate_range(seed=0, noise=0.0, rate=2.0, dwell=2.0))
    neg, pos = simulate_range(seed=0, noise=0.0, rate=2.0, dwell=2.0).metadata["true_range_g"]
    assert abs(red.value("range_pos") - pos) < 2 * red.std("range_pos")
    assert abs(red.value("range_neg") + neg) < 2 * red.std("range_neg")
    assert red.value("overload_shift") == pytest.approx(20e-6, abs=1e-12)
    assert red.value("bias_before") == pytest.approx(1e-3 / 0.2, rel=1e-9)


def test_clipping_is_found_at_the_rail_and_the_shift_tested(range_record):
    red = acceptance.reduce(range_record)
    dwell = 40  # samples per dwell
    above = np.abs(0.2 * np.asarray(range_record.input)) > 9.5 * 0.9  # clipped dwells only
    assert red.value("clipped_samples") > 0
    assert red.value("clipped_samples") % dwell == 0
    assert red.value("clipped_samples") <= above.sum()
    assert any("after the overload" in n for n in red.estimate.notes)
    rows = {r["quantity"]: r for r in acceptance.quantity_rows(red)}
    assert rows["input range (+)"]["unit"] == "g"
    assert rows["overload bias shift"]["estimate"] == pytest.approx(20.0, abs=5 * rows[
        "overload bias shift"]["std"])


def test_a_range_test_without_rest_after_the_overload_is_refused(range_record):
    n = range_record.t.size - 40
    cut = steps_format.StepRecord(t=range_record.t[:n], input=range_record.input[:n],
                                  output=range_record.output[:n], test="range",
                                  output_unit="V", scale_factor=0.2)
    with pytest.raises(AccelcalError, match="before the first and after"):
        acceptance.reduce(cut)


def test_a_ladder_below_the_knee_brackets_no_range():
    with pytest.raises(AccelcalError, match="not bracketed"):
        acceptance.reduce(simulate_range(seed=1, inputs=(1.0, 2.0, 5.0, 10.0), rate=2.0,
                                         dwell=2.0))


def test_turn_on_spread_is_the_spread_of_the_turn_ons():
    rec = simulate_turn_on(seed=5, noise=1e-11, dwell=1.0, rate=10.0, turn_ons=5)
    red = acceptance.reduce(rec)
    truth = np.asarray(rec.metadata["true_bias_g"])
    t_mid = 3.95  # the bias is stated at the mean of the dwells' mid-times (0.45 ... 7.45 s)
    np.testing.assert_allclose(red.observations["bias"], truth + 10e-6 * t_mid / 3600,
                               atol=1e-10)
    assert red.value("bias_repeatability") == pytest.approx(np.std(truth, ddof=1), rel=1e-3)
    k = np.asarray(rec.metadata["true_scale_factor"])
    assert red.value("scale_repeatability") == pytest.approx(np.std(k / k.mean(), ddof=1),
                                                             rel=1e-3)
    assert red.value("drift") * 3600 == pytest.approx(10e-6, rel=1e-2)
    low, high = red.provenance["bias_interval_g"]
    assert low < red.value("bias_repeatability") < high
    rows = acceptance.quantity_rows(red)
    assert rows[0]["quantity"] == "bias repeatability"
    assert rows[0]["low"] == pytest.approx(low * 1e6)


def test_fewer_than_three_turn_ons_exit_2(tmp_path, capsys):
    path = tmp_path / "two.csv"
    steps_format.write(path, simulate_turn_on(seed=1, turn_ons=2, dwell=1.0))
    code, _, err = run_cli(["acceptance", "reduce", path], capsys)
    assert code == 2
    assert "at least 3" in err
    assert len(err.strip().splitlines()) == 1


def test_cli_simulates_and_reduces_range_with_a_spec(tmp_path, capsys):
    path, spec = tmp_path / "range.csv", tmp_path / "spec.toml"
    spec.write_text('document = "S-1"\n[[limit]]\nquantity = "input range"\nlower = 31\n'
                    'unit = "g"\n')
    code, _, _ = run_cli(["acceptance", "simulate", "--test", "range", "--dwell", "2",
                          "--rate", "20", "--out", path], capsys)
    assert code == 0
    code, out, _ = run_cli(["acceptance", "reduce", path, "--format", "csv", "--spec", spec],
                           capsys)
    assert code == 0
    lines = out.splitlines()
    assert lines[0].endswith("lower,upper,limit_unit,decision,risk")
    decisions = {line.split(",")[0]: line.split(",")[-2] for line in lines[1:]}
    assert decisions["input range (+)"] == "accept"
    assert decisions["input range (-)"] == "reject"
    assert decisions["clipped samples"] == ""


def test_range_and_turn_on_figures(range_record):
    for red, stem in ((acceptance.reduce(range_record), "acceptance-range"),
                      (acceptance.reduce(simulate_turn_on(seed=2, dwell=1.0, turn_ons=4)),
                       "acceptance-turn-on")):
        ((got, _, fig, caption),) = red.figures()
        assert got == stem
        assert caption
        if stem == "acceptance-range":  # the clipped dwells are marked
            labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
            assert "clipped samples in the dwell" in labels


def test_a_turn_on_recording_imports_with_its_turn_on_column(tmp_path):
    from accelcal.io.recordings.kinds import layout
    from accelcal.io.records import write_record

    got = layout("steps", {"input": "A", "output": "U", "turn_on": "N"},
                 {"A": "g", "U": "V", "N": "-"}, 10.0)
    assert got.units["turn_on"] == "-"
    assert got.metadata["output_unit"] == "V"
    rec = simulate_turn_on(seed=1, turn_ons=3, dwell=1.0)
    write_record(tmp_path / "imported.csv", "steps",
                 {"units": {"t": "s", "input": "g", "output": "g", "turn_on": "-"},
                  "test": "turn-on", "output_unit": "g", "scale_factor": 1.0},
                 {"t": rec.t, "input": rec.input, "output": rec.output, "turn_on": rec.turn_on})
    back = steps_format.read(tmp_path / "imported.csv")
    np.testing.assert_array_equal(back.turn_on, rec.turn_on)
    assert acceptance.reduce(back).provenance["turn_ons"] == 3
