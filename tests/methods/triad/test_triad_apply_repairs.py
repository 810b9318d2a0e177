"""``accelcal triad apply`` takes the repair options of the other triad commands: a messy
recording (rows backwards, a duplicated row, a gap, a clipped run) is refused with the row
by default, and repaired only as asked, every repair listed as a note; the repaired rows are
written as t and the calibrated channels."""

import csv

import numpy as np
import pytest

from accelcal.methods.triad.model import TriadCalibration
from helpers.cli import refused, run_cli


@pytest.fixture
def messy(tmp_path):
    cal = tmp_path / "cal.json"
    TriadCalibration([0.01, -0.02, 0.005], [1.01, 0.99, 1.02], [1e-3, 2e-3, -1e-3],
                     input_unit="g").save(cal)
    t = np.delete(np.arange(40) * 0.01, [10, 11])  # two samples missing before data row 11
    z = np.where((t > 0.245) & (t < 0.275), 2.0, 1.0)  # three samples at the rail 2 g
    rows = [f"{x:.2f},L{i},0.1,-0.2,{v:g}" for i, (x, v) in enumerate(zip(t, z, strict=True))]
    rows.insert(20, rows[20])  # data row 22 repeats row 21
    rows[30], rows[31] = rows[31], rows[30]  # data row 32 goes backwards
    src = tmp_path / "lab.csv"
    src.write_text("t,label,X,Y,Z\n" + "\n".join(rows) + "\n")
    return src, cal, tmp_path / "out.csv"


def _args(messy, *extra):
    src, cal, out = messy
    return ["triad", "apply", src, "--calibration", cal, "--columns", "X,Y,Z", "--time", "t",
            "--out", out, *extra]


def test_a_messy_recording_is_refused_by_default(messy, capsys):
    refused(_args(messy), capsys, "goes backwards at data row 32", "--sort")
    refused(_args(messy, "--sort", "--rails=-2,2"), capsys, "clipped", "data row",
            "--gaps split")
    assert not messy[2].exists()


def test_repairs_are_written_and_noted(messy, capsys):
    code, _, err = run_cli(_args(messy, "--sort", "--gaps", "fill", "--max-fill", "2"),
                           capsys)
    assert code == 0, err
    assert "note: 1 rows out of time order (data rows 32): sorted by time" in err
    assert "note: 1 duplicated rows (same time, same values) (data rows 22): dropped" in err
    assert "note: 2 samples filled in the gaps before (data rows 11)" in err
    rows = list(csv.reader(messy[2].read_text().splitlines()))
    assert rows[0] == ["t", "acc_x", "acc_y", "acc_z"]
    t = np.array([float(r[0]) for r in rows[1:]])
    assert t.size == 40  # 38 samples, the duplicate dropped, 2 filled
    assert np.allclose(np.diff(t), 0.01, rtol=0, atol=1e-9)  # in order, no gap
    cal = TriadCalibration.load(messy[1])
    expected = cal.apply(np.array([[0.1, -0.2, 1.0]]))
    got = np.array([[float(x) for x in r[1:]] for r in rows[1:]])
    assert np.allclose(got[:20], expected, rtol=0, atol=1e-9)


def test_split_leaves_clipped_samples_out(messy, capsys):
    code, _, err = run_cli(_args(messy, "--sort", "--gaps", "split", "--rails=-2,2"), capsys)
    assert code == 0, err
    assert "clipped samples" in err
    rows = list(csv.reader(messy[2].read_text().splitlines()))
    z = np.array([float(r[3]) for r in rows[1:]])
    assert len(rows) - 1 == 38 - 3  # the duplicate dropped, the clipped run left out
    assert z.max() < 1.5  # no 2 g sample left (1 g reads about 1.015 calibrated)
