"""A gap inside a response record's step: refused by default with the hint, cut with
--gaps split (the step's longest piece of consecutive samples kept), never filled; a jump
between steps is harmless."""

import csv
import dataclasses
import io

import numpy as np
import pytest

from accelcal.io.formats import response as response_format
from helpers.cli import refused, run_cli


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    from accelcal.cli import main

    folder = tmp_path_factory.mktemp("gap")
    path = folder / "steps.csv"
    with pytest.raises(SystemExit) as exc:
        main(["response", "simulate", "--frequencies", "80,315", "--periods", "40", "--noise",
              "0", "--out", str(path)])
    assert exc.value.code == 0
    rec = response_format.read(path)
    first = rec.steps[0]
    keep = np.ones(rec.t.size, dtype=bool)
    keep[first.start + 100:first.start + 105] = False  # five samples lost early in step 0
    # the steps' times jump (the test moved on): shift step 1 on by a second
    t = np.where(rec.step == rec.step[-1], rec.t + 1.0, rec.t)
    gapped = dataclasses.replace(
        rec, **{c: getattr(rec, c)[keep] for c in ("step", "frequency", "ref", "dut")},
        t=t[keep], quadrature=None if rec.quadrature is None else rec.quadrature[keep])
    out = folder / "gapped.csv"
    response_format.write(out, gapped)
    between = folder / "between.csv"
    response_format.write(between, dataclasses.replace(rec, t=t))
    return path, out, between, first.start + 101


def _rows(out):
    return list(csv.DictReader(io.StringIO(out)))


def test_a_gap_inside_a_step_is_refused_with_the_hint(records, capsys):
    _, gapped, between, row = records
    refused(["response", "reduce", gapped], capsys, "inside step step 0", f"data row {row}",
            "about 5 samples missing", "--gaps split", "--gaps fill does not apply")
    refused(["response", "reduce", gapped, "--gaps", "fill"], capsys, "not linear")
    code, _, err = run_cli(["response", "reduce", between, "--format", "csv"], capsys)
    assert code == 0, err  # a jump between steps is no gap
    assert "note:" not in err


def test_split_keeps_the_steps_longest_piece(records, capsys):
    path, gapped, _, row = records
    code, whole, _ = run_cli(["response", "reduce", path, "--format", "csv"], capsys)
    assert code == 0
    code, out, err = run_cli(["response", "reduce", gapped, "--gaps", "split", "--format",
                              "csv"], capsys)
    assert code == 0, err
    assert (f"note: 1 gaps inside a step (data rows {row}): the step cut at the gap, its "
            "longest piece kept") in err
    assert "note: 100 rows of a step cut at a gap (data rows 1, 2" in err
    for a, b in zip(_rows(whole), _rows(out), strict=True):  # noise-free: the same response
        assert float(b["magnitude"]) == pytest.approx(float(a["magnitude"]), rel=1e-6)
        assert float(b["phase_deg"]) == pytest.approx(float(a["phase_deg"]), abs=1e-4)
    code, out, err = run_cli(["response", "fit", gapped, "--gaps", "split"], capsys)
    assert code == 0, err
    assert "gaps inside a step" in err
