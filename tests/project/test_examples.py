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
                np.testing.assert_array_equal(cols_new[key], cols_old[key])
        elif rel == "calibration_record.json":  # all but the software version
            a, b = json.loads(new.read_text()), json.loads(old.read_text())
            a.pop("software")
            b.pop("software")
            assert a == b
        else:
            assert new.read_bytes() == old.read_bytes(), rel


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
    assert record.names == ("K_F", "K_I", "K_O", "K_IO", "K_II")
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
