"""``accelcal triad apply`` writes CSV quoted as every other accelcal CSV: only where needed."""

import csv
import io

import numpy as np
import pytest

from accelcal.cli import main
from accelcal.methods.triad.model import TriadCalibration


def run(args, capsys) -> None:
    with pytest.raises(SystemExit) as exc:
        main([str(a) for a in args])
    _, err = capsys.readouterr()
    assert exc.value.code == 0, err


@pytest.fixture
def calibration(tmp_path):
    path = tmp_path / "cal.json"
    TriadCalibration([0.01, -0.02, 0.005], [1.01, 0.99, 1.02], [1e-3, 2e-3, -1e-3],
                     input_unit="g").save(path)
    return path


def test_copied_and_calibrated_columns_are_quoted_alike(tmp_path, calibration, capsys):
    src, out = tmp_path / "lab.csv", tmp_path / "out.csv"
    src.write_text('t,label,X,Y,Z\n0,a,0,0,1\n0.005,b b,0.01,0,1\n0.01,"c,d",0,0.02,1\n'
                   '0.015,"say ""hi""",0,0,0.98\n')
    run(["triad", "apply", src, "--calibration", calibration, "--columns", "X,Y,Z",
         "--time", "t", "--out", out], capsys)
    lines = out.read_text().splitlines()
    assert lines[0] == "t,label,acc_x,acc_y,acc_z"
    assert [ln.split(",")[:2] for ln in lines[1:3]] == [["0", "a"], ["0.005", "b b"]]
    assert lines[3].startswith('0.01,"c,d",')
    assert lines[4].startswith('0.015,"say ""hi""",')
    rows = list(csv.reader(io.StringIO(out.read_text())))
    assert [r[1] for r in rows[1:]] == ["a", "b b", "c,d", 'say "hi"']
    assert '"' not in "".join(ln.split(",", 2)[2] for ln in lines[1:3])
    expected = TriadCalibration.load(calibration).apply(
        np.array([[0, 0, 1], [0.01, 0, 1], [0, 0.02, 1], [0, 0, 0.98]], dtype=float))
    got = np.array([[float(x) for x in r[-3:]] for r in rows[1:]])
    assert np.allclose(got, expected, rtol=0, atol=1e-14)


def test_a_record_gives_a_file_without_quotes(tmp_path, capsys):
    triad, cal, out = tmp_path / "triad.csv", tmp_path / "cal.json", tmp_path / "out.csv"
    run(["triad", "simulate", "--positions", "six", "--out", triad], capsys)
    run(["triad", "calibrate", triad, "--out", cal], capsys)
    run(["triad", "apply", triad, "--calibration", cal, "--out", out], capsys)
    text = out.read_text()
    assert '"' not in text
    assert text.splitlines()[0] == "t,acc_x,acc_y,acc_z"


def test_blocks_with_and_without_quoting_write_what_the_csv_module_writes():
    import pyarrow as pa

    from accelcal.methods.triad.imucal import _write_rows

    plain = pa.table({"t": ["0", "0.5"], "note": ["a", None], "x": [0.1, -2.5e-300]})
    quoted = pa.table({"t": ["1", "1.5"], "note": ["x\ny", 'q"'], "x": [1e22, float("nan")]})
    sink = io.BytesIO()
    for table in (plain, quoted):
        _write_rows(sink, table)
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    for table in (plain, quoted):
        writer.writerows(zip(*(c.to_pylist() for c in table.columns), strict=True))
    assert list(csv.reader(io.StringIO(sink.getvalue().decode()))) == list(
        csv.reader(io.StringIO(buf.getvalue())))
    assert sink.getvalue().decode().startswith("0,a,0.1\n0.5,,")
