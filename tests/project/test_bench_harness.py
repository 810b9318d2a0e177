"""The benchmark harness (benchmarks/common.py): interleaving, medians, the "under load" flag."""

import importlib.util
import subprocess
import sys
import time
from pathlib import Path

import pytest

from helpers.paths import ROOT


@pytest.fixture(scope="module")
def common():
    spec = importlib.util.spec_from_file_location("bench_common", ROOT / "benchmarks/common.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_runs_are_interleaved_and_need_five_repeats(common):
    order = []
    runs = common.interleaved({"a": lambda: order.append("a"), "b": lambda: order.append("b")},
                              repeats=5)
    assert order == ["a", "b"] * 5
    assert [len(v) for v in runs.values()] == [5, 5]
    with pytest.raises(ValueError, match="5 repeats"):
        common.interleaved({"a": lambda: None}, repeats=4)


def test_others_cpu_is_the_machines_busy_time_less_our_own(common, monkeypatch):
    # Machine busy 3 s and this process (with its ended children) 1 s during a 2 s run:
    # others took 2 s of CPU over 2 s, one core.
    clock = {"busy": 100.0, "own": 10.0, "wall": 0.0}

    def work():
        clock.update(busy=clock["busy"] + 3.0, own=clock["own"] + 1.0, wall=clock["wall"] + 2.0)

    monkeypatch.setattr(common, "_busy_seconds", lambda: clock["busy"])
    monkeypatch.setattr(common, "_own_seconds", lambda: clock["own"])
    monkeypatch.setattr(common.time, "perf_counter", lambda: clock["wall"])
    monkeypatch.setattr(common, "cpus", lambda: 2)
    detail = {}
    runs = common.interleaved({"x": work}, repeats=5, detail=detail)
    assert detail["x"].others == [pytest.approx(2.0)] * 5  # CPU seconds per run
    row = common.figures(runs, detail)[0]
    assert row.others == pytest.approx(1.0)
    assert row.flagged  # 0.5 of a core per core > 0.25
    # only our own work: nothing flagged, whatever the (lagging) load average says
    clock_own = {"busy": 0.0, "own": 0.0, "wall": 0.0}

    def own_work():
        clock_own.update(busy=clock_own["busy"] + 2.0, own=clock_own["own"] + 2.0,
                         wall=clock_own["wall"] + 2.0)

    monkeypatch.setattr(common, "_busy_seconds", lambda: clock_own["busy"])
    monkeypatch.setattr(common, "_own_seconds", lambda: clock_own["own"])
    monkeypatch.setattr(common.time, "perf_counter", lambda: clock_own["wall"])
    monkeypatch.setattr(common.os, "getloadavg", lambda: (5.0, 5.0, 5.0))
    detail = {}
    runs = common.interleaved({"x": own_work}, repeats=5, detail=detail)
    row = common.figures(runs, detail)[0]
    assert row.others == 0.0
    assert not row.flagged
    assert row.load == 5.0
    assert "| 5.00 | 0.00 | no |" in common.markdown([row], "t")


def test_runs_too_short_for_the_ticks_take_the_sessions_share(common):
    runs = common.Runs(wall=[0.002] * 5, cpu=[0.002] * 5, load=[0.0] * 5,
                       others=[0.01, 0.0, 0.0, 0.01, 0.0], session_others=0.1)
    assert runs.others_cores() == 0.1  # 10 ms ticks over 10 ms of runs mean nothing
    runs.wall = [0.4] * 5
    assert runs.others_cores() == pytest.approx(0.02 / 2.0)
    runs.others[0] = None
    assert runs.others_cores() is None


@pytest.mark.skipif(not Path("/proc/stat").exists(), reason="needs /proc/stat (Linux)")
def test_a_spinning_process_beside_the_runs_is_seen(common):
    spinner = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        time.sleep(0.3)
        detail = {}
        runs = common.interleaved({"sleep": lambda: time.sleep(0.2)}, repeats=5, detail=detail)
    finally:
        spinner.kill()
        spinner.wait()
    row = common.figures(runs, detail)[0]
    assert row.others > 0.5  # about one core, the spinner's


def test_a_docs_section_is_replaced_in_place(common, tmp_path):
    path = tmp_path / "b.md"
    path.write_text("# B\n\n<!-- bench:x -->\nold\n<!-- /bench:x -->\n\ntail\n")
    common.write_section("x", "new", path)
    common.write_section("y", "other", path)
    text = path.read_text()
    assert "old" not in text
    assert "<!-- bench:x -->\nnew\n<!-- /bench:x -->" in text
    assert text.index("tail") < text.index("<!-- bench:y -->")


def test_child_json_runs_a_fresh_interpreter_and_parses_its_printout(common, tmp_path):
    code = ("import json, sys; "
            "print(json.dumps({'args': sys.argv[1:], 'numpy': 'numpy' in sys.modules}))")
    assert common.child_json(code, 3, tmp_path) == {"args": ["3", str(tmp_path)],
                                                   "numpy": False}
    with pytest.raises(subprocess.CalledProcessError):
        common.child_json("raise SystemExit(3)")


def test_machine_records_the_reference_loop(common):
    info = common.machine()
    assert 0 < info["speed"] < 60
    assert "reference loop (1e+06 Python additions)" in common.describe(info)
