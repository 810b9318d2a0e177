"""A gap inside a thermal record's plateau: refused by default with the hint, cut or filled
as told, and listed in the notes and the reduction's provenance; a jump between plateaus
(every example record has them) is harmless."""

import dataclasses
import json

import numpy as np
import pytest

from accelcal.io.formats import thermal as thermal_format
from accelcal.methods import thermal
from helpers.cli import refused, run_cli
from helpers.paths import EXAMPLES


@pytest.fixture(scope="module")
def gapped(tmp_path_factory):
    """The example record with three rows missing in the middle of the soak of plateau 3."""
    rec = thermal_format.read(EXAMPLES / "thermal.csv")
    soak = np.flatnonzero((rec.phase == 1) & (rec.plateau == 3))
    keep = np.ones(rec.t.size, dtype=bool)
    keep[soak[len(soak) // 2]:soak[len(soak) // 2] + 3] = False
    fields = ("t", "phase", "plateau", "angle_rad", "output", "temperature")
    cut = dataclasses.replace(rec, **{f: getattr(rec, f)[keep] for f in fields},
                              chamber=None if rec.chamber is None else rec.chamber[keep])
    path = tmp_path_factory.mktemp("gap") / "gapped.csv"
    thermal_format.write(path, cut)
    return path, int(soak[len(soak) // 2]) + 1  # the data row after the gap (1-based)


def test_a_gap_inside_a_plateau_is_refused_with_the_hint(gapped, capsys):
    path, row = gapped
    refused(["thermal", "reduce", path], capsys, "inside plateau", f"data row {row}",
            "about 3 samples missing", "--gaps split", "--gaps fill")
    rec = thermal_format.read(EXAMPLES / "thermal.csv")  # jumps between plateaus: no gap
    assert np.diff(rec.t).max() > 10 * np.median(np.diff(rec.t))
    assert "repairs" not in rec.metadata


def test_split_cuts_the_plateau_into_the_provenance(gapped):
    path, row = gapped
    red = thermal.reduce(path, order=1, gaps="split")
    found = red.provenance["repairs"]["found"]
    assert found[0] == {"found": "gaps inside a plateau", "count": 1, "first_rows": [row],
                        "action": "the plateau cut at the gap, its last piece kept"}
    assert found[1]["found"] == "rows of a plateau cut at a gap"
    assert any("gaps inside a plateau" in n for n in red.notes)


def test_fill_interpolates_and_agrees_with_the_cut(gapped, capsys):
    path, _ = gapped
    refused(["thermal", "reduce", path, "--gaps", "fill", "--max-fill", "2"], capsys,
            "3 missing samples", "--max-fill 2")
    code, out, err = run_cli(["thermal", "reduce", path, "--order", "1", "--format", "json",
                              "--gaps", "fill", "--max-fill", "3"], capsys)
    assert code == 0, err
    assert "note: 3 samples filled in the gaps inside a plateau" in err
    filled = {r["coefficient"]: r["estimate"] for r in json.loads(out)}
    cut = thermal.reduce(path, order=1, gaps="split").rows()
    for r in cut:  # the settled window at the soak's end is untouched either way
        if r["coefficient"] in ("K0_T1", "K1_T1"):
            assert filled[r["coefficient"]] == pytest.approx(r["estimate"], rel=1e-6)


def test_compensate_maps_row_by_row_and_fills_when_told(tmp_path, capsys):
    t = np.r_[np.arange(50), np.arange(53, 100)] * 0.1  # three samples lost after row 50
    lines = ["t,output,temperature", *(f"{float(ti)!r},1.0,{20.0 + float(ti)!r}" for ti in t)]
    path = tmp_path / "rec.csv"
    path.write_text("\n".join(lines) + "\n")
    model = EXAMPLES / "thermal_compensation.json"
    base = ["thermal", "compensate", path, "--model", model, "--time", "t",
            "--temperature-unit", "degC"]
    code, _, err = run_cli([*base, "--out", tmp_path / "a.csv"], capsys)
    assert code == 0, err  # a row-by-row map: a gap is harmless
    assert f"({t.size} rows)" in err
    code, _, err = run_cli([*base, "--out", tmp_path / "b.csv", "--gaps", "fill",
                            "--max-fill", "3"], capsys)
    assert code == 0, err
    assert f"({t.size + 3} rows)" in err
    assert "note: 3 samples filled in the gaps before (data rows 51)" in err
