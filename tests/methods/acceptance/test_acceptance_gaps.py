"""A gap inside a step test's dwell: refused by default with the hint, cut (the dwell's
last, settled piece kept) or filled as told, in the notes and the reduction's provenance."""

import json

import numpy as np
import pytest

from accelcal.io.formats import acceptance as steps_format
from accelcal.io.record_gaps import repair_gaps
from helpers.cli import refused, run_cli


@pytest.fixture(scope="module")
def gapped(tmp_path_factory):
    from accelcal.cli import main

    base = tmp_path_factory.mktemp("gap")
    path = base / "threshold.csv"
    with pytest.raises(SystemExit) as exc:
        main(["acceptance", "simulate", "--test", "threshold", "--seed", "3", "--out",
              str(path)])
    assert exc.value.code == 0
    rec = steps_format.read(path)
    keep = np.ones(rec.t.size, dtype=bool)
    keep[40:43] = False  # three samples early in the first dwell
    cut = steps_format.StepRecord(t=rec.t[keep], input=rec.input[keep],
                                  output=rec.output[keep], test=rec.test,
                                  output_unit=rec.output_unit, scale_factor=rec.scale_factor,
                                  metadata=rec.metadata)
    out = base / "gapped.csv"
    steps_format.write(out, cut)
    return path, out


def test_a_gap_inside_a_dwell_is_refused_then_cut_or_filled(gapped, capsys):
    path, out = gapped
    refused(["acceptance", "reduce", out], capsys, "inside dwell", "data row 41",
            "about 3 samples missing", "--gaps split")
    code, whole, _ = run_cli(["acceptance", "reduce", path, "--format", "json"], capsys)
    assert code == 0
    for how, note in (("split", ("note: 1 gaps inside a dwell (data rows 41): the dwell cut "
                                 "at the gap, its last piece kept")),
                      ("fill", "note: 3 samples filled in the gaps inside a dwell")):
        code, text, err = run_cli(["acceptance", "reduce", out, "--gaps", how, "--format",
                                   "json"], capsys)
        assert code == 0, err
        assert note in err
        assert len(json.loads(text)) == len(json.loads(whole))


def test_fill_interpolates_on_the_grid_and_split_keeps_the_last_piece():
    t = np.r_[0.0, 1.0, 2.0, 5.0, 6.0, 10.0, 11.0]  # a gap in run 0; a jump into run 1
    run = np.r_[0, 0, 0, 0, 0, 1, 1]
    y = 2.0 * t
    filled, found = repair_gaps({"t": t, "run": run, "y": y}, where="x", keys=("run",),
                                gaps="fill")
    assert filled["t"] == pytest.approx([0, 1, 2, 3, 4, 5, 6, 10, 11])
    assert filled["y"] == pytest.approx(2.0 * filled["t"])
    assert filled["run"].tolist() == [0] * 7 + [1, 1]
    assert found["found"][0]["found"] == "gaps inside a plateau"
    assert found["found"][1]["count"] == 2  # samples filled
    cut, _ = repair_gaps({"t": t, "run": run, "y": y}, where="x", keys=("run",),
                         gaps="split")
    assert cut["t"].tolist() == [5, 6, 10, 11]  # run 0's last piece; run 1 untouched
    longest, _ = repair_gaps({"t": t, "run": run, "y": y}, where="x", keys=("run",),
                             gaps="split", keep="longest")
    assert longest["t"].tolist() == [0, 1, 2, 10, 11]
    _, none = repair_gaps({"t": t[5:], "run": run[5:], "y": y[5:]}, where="x",
                             keys=("run",))
    assert none is None
