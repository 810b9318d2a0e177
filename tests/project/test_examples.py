"""examples/data: the committed example files are what examples/make_data.py writes, and work."""

import importlib.util
import json
import re
import shlex

import numpy as np
import pytest

from accelcal.cli import main
from accelcal.defaults import default_model
from accelcal.io.calibration_record import CalibrationRecord
from accelcal.io.formats.dividing_head import read_head_record
from accelcal.io.formats.shaker import read_records
from accelcal.io.formats.vibrafuge import read_vibrafuge
from accelcal.io.records import read_record
from accelcal.model import ErrorModel
from helpers.paths import ROOT

DATA = ROOT / "examples" / "data"


def _make_data():
    spec = importlib.util.spec_from_file_location("make_data", ROOT / "examples" / "make_data.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def regenerated(tmp_path_factory):
    out = tmp_path_factory.mktemp("examples")
    return out, _make_data().make(out)


RTOL = 1e-9
"""Relative agreement of a regenerated number with the committed one.

Text (metadata, column names, keys, strings) must agree exactly, numbers to
``RTOL`` on the scale of their column (CSV, Parquet) or array (JSON): another
BLAS changes least-squares results and simulated noise in their last digits
(measured: 3e-13 of the scale, so 2e-10 relative on a noise sample near a zero
crossing and 0.1 on a 1e-29 covariance entry that is rounding beside 1e-12
variances), while any change to the physics or the seeds moves them far more
than 1e-9."""


def _close(new, old, where):
    """``new`` agrees with ``old``: numbers to RTOL of the largest of them, text exactly."""
    try:
        a, b = np.asarray(new, dtype=float), np.asarray(old, dtype=float)
    except (TypeError, ValueError):  # text cells (labels, units): exactly
        assert list(new) == list(old), where
        return
    assert a.shape == b.shape, where
    scale = float(np.max(np.abs(b), initial=0.0))
    np.testing.assert_allclose(a, b, rtol=RTOL, atol=RTOL * scale, err_msg=where)


def _csv_close(new: str, old: str, where):
    """A record file: comment lines and column names exactly, each column's numbers close."""
    new_lines, old_lines = new.splitlines(), old.splitlines()
    assert len(new_lines) == len(old_lines), where
    head = next(i for i, line in enumerate(old_lines) if not line.startswith("#")) + 1
    assert new_lines[:head] == old_lines[:head], where
    new_rows = [line.split(",") for line in new_lines[head:]]
    old_rows = [line.split(",") for line in old_lines[head:]]
    assert [len(r) for r in new_rows] == [len(r) for r in old_rows], where
    columns = zip(zip(*new_rows, strict=True), zip(*old_rows, strict=True), strict=True)
    for col, (a, b) in enumerate(columns):
        _close(a, b, f"{where}, column {old_lines[head - 1].split(',')[col]}")


def _json_close(new, old, where):
    """Documents: the same keys and strings, numbers (arrays as a whole) close."""
    if isinstance(old, dict):
        assert isinstance(new, dict), where
        assert new.keys() == old.keys(), where
        for key in old:
            _json_close(new[key], old[key], f"{where}.{key}")
    elif isinstance(old, list) and old and _numeric(old):
        _close(new, old, where)
    elif isinstance(old, list):
        assert isinstance(new, list), where
        assert len(new) == len(old), where
        for i, (a, b) in enumerate(zip(new, old, strict=True)):
            _json_close(a, b, f"{where}[{i}]")
    elif isinstance(old, float):
        assert isinstance(new, float), where
        _close([new], [old], where)
    else:  # strings, integers, booleans, null: exactly
        assert new == old, where


def _numeric(value) -> bool:
    if isinstance(value, list):
        return all(_numeric(v) for v in value)
    return isinstance(value, int | float) and not isinstance(value, bool)


def test_committed_examples_are_what_the_script_writes(regenerated):
    out, written = regenerated
    names = sorted(str(p.relative_to(out)) for p in written)
    committed = sorted(str(p.relative_to(DATA)) for p in DATA.rglob("*") if p.is_file())
    assert names == committed
    for rel in names:
        new, old = out / rel, DATA / rel
        if rel.endswith(".parquet"):  # compare contents: bytes name the writer's version
            meta_new, cols_new = read_record(new, "dividing-head")
            meta_old, cols_old = read_record(old, "dividing-head")
            assert meta_new == meta_old
            assert cols_new.keys() == cols_old.keys()
            for key in cols_new:
                _close(cols_new[key], cols_old[key], f"{rel}, column {key}")
        elif rel.endswith(".json"):
            a, b = json.loads(new.read_text()), json.loads(old.read_text())
            if rel == "calibration_record.json":  # all but the software version
                a.pop("software")
                b.pop("software")
            _json_close(a, b, rel)
        elif rel.endswith(".csv"):
            _csv_close(new.read_text(), old.read_text(), rel)
        else:
            assert new.read_bytes() == old.read_bytes(), rel


def test_the_comparison_tells_rounding_from_a_change():
    # Rounding of another BLAS passes; a change in the 9th digit, in a text cell, or in a
    # near-zero entry on the scale of its array fails.
    head = "# accelcal record\n# {}\nt,acc\n"
    _csv_close(head + "0,1.0000000000001\n1,-1e-17\n", head + "0,1.0\n1,2e-17\n", "ok")
    with pytest.raises(AssertionError):
        _csv_close(head + "0,1.00000001\n", head + "0,1.0\n", "9th digit")
    with pytest.raises(AssertionError):
        _csv_close(head.replace("acc", "acc_x") + "0,1.0\n", head + "0,1.0\n", "header")
    _json_close({"cov": [[1e-12, 8e-30], [9e-30, 1e-12]], "unit": "g"},
                {"cov": [[1e-12, 9e-30], [8e-30, 1e-12]], "unit": "g"}, "ok")
    with pytest.raises(AssertionError):
        _json_close({"cov": [[1e-12, 1e-20]]}, {"cov": [[1e-12, 0.0]]}, "off-diagonal")
    with pytest.raises(AssertionError):
        _json_close({"unit": "V", "n": 3}, {"unit": "V", "n": 4}, "integer")


def test_example_files_read_with_their_laboratory_metadata():
    csv, pq = read_head_record(DATA / "indexing_head.csv"), \
        read_head_record(DATA / "indexing_head.parquet")
    np.testing.assert_array_equal(csv.outputs, pq.outputs)
    assert csv.sensors == ("U1", "U2", "U3", "U4")
    (sweep,) = read_records(DATA / "shaker")
    assert sweep.theta.size == 12
    assert sweep.metadata["serial"] == "ACC-0001"
    assert sweep.metadata["local_gravity"] == pytest.approx(9.80122)
    run = read_vibrafuge(DATA / "vibrafuge.csv")
    assert run.points == 9
    assert ErrorModel.load(DATA / "model.json") == default_model()
    record = CalibrationRecord.load(DATA / "calibration_record.json")
    assert record.serial == "ACC-0001"
    assert record.names == ("K_F+K_OO", "K_I", "K_O", "K_IO", "K_II-K_OO")  # combinations
    assert record.plain == {"K_F+K_OO": "K_F", "K_II-K_OO": "K_II"}
    assert record.date == "2026-11-20T09:30:00+00:00"


def test_the_documented_commands_run_on_the_examples(tmp_path, monkeypatch, capsys):
    # The sh block of docs/data-formats.md "Example files", run as written.
    text = (ROOT / "docs" / "data-formats.md").read_text(encoding="utf-8")
    block = text[text.index("### Example files"):]
    commands = re.search(r"```sh\n(.*?)```", block, re.DOTALL).group(1).strip().splitlines()
    assert len(commands) == 4
    monkeypatch.chdir(tmp_path)
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    for line in commands:
        argv = shlex.split(line)
        assert argv[0] == "accelcal"
        with pytest.raises(SystemExit) as exc:
            main(argv[1:])
        assert exc.value.code == 0, capsys.readouterr().err
    html = (tmp_path / "report.html").read_text(encoding="utf-8")
    assert html.count('<table class="coef">') == 3
    assert "ACC-0001" in html
