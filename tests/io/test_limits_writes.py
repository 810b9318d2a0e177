"""The process's memory limit, the writer's temporaries and the small input faults of issue 29.

Fast checks, in process: the fault tier (tests/faults) runs the commands
under real limits, signals and kills.
"""

import os
import stat
import subprocess
import sys

import numpy as np
import pytest

from accelcal.errors import AccelcalError
from accelcal.io import atomic, limits
from helpers import daq_files
from helpers.cli import refused, run_cli


def test_memory_limit_is_the_least_of_the_three(monkeypatch):
    monkeypatch.setattr(limits, "_address_space_headroom", lambda: 3 * 2**30)
    monkeypatch.setattr(limits, "_cgroup_headroom", lambda: 2 * 2**30)
    monkeypatch.setattr(limits, "_machine_available", lambda: 5 * 2**30)
    assert limits.memory_limit() == 2 * 2**30
    monkeypatch.setattr(limits, "_cgroup_headroom", lambda: None)
    assert limits.memory_limit() == 3 * 2**30
    monkeypatch.setattr(limits, "_address_space_headroom", lambda: None)
    monkeypatch.setattr(limits, "_machine_available", lambda: None)
    assert limits.memory_limit() == limits.NO_LIMIT


def test_memory_limit_sees_rlimit_as():
    """Under a 2 GiB address-space limit the headroom is below 2 GiB, whatever the machine has."""
    code = ("import resource; resource.setrlimit(resource.RLIMIT_AS, (2**31, 2**31)); "
            "from accelcal.io.limits import memory_limit; print(memory_limit())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert 0 < int(out) < 2**31


def test_cgroup_room_reads_v2_and_v1_files(tmp_path):
    (tmp_path / "memory.max").write_text("1073741824\n")
    (tmp_path / "memory.current").write_text("73741824\n")
    assert limits._cgroup_room(tmp_path / "memory.max", tmp_path / "memory.current") == 10**9
    (tmp_path / "memory.max").write_text("max\n")
    assert limits._cgroup_room(tmp_path / "memory.max", tmp_path / "memory.current") is None
    assert limits._cgroup_dirs(tmp_path, "/a/b") == [tmp_path / "a" / "b", tmp_path / "a",
                                                    tmp_path]


def test_temp_names_fit_the_name_limit_and_carry_the_pid(tmp_path):
    for length in (1, 200, 238, 255):
        name = "a" * (length - 4) + ".csv" if length > 4 else "a"
        tmp = atomic.temp_name(name, directory=tmp_path)
        assert len(os.fsencode(tmp)) <= 255
        assert f".accelcal-{os.getpid()}-" in tmp
        assert atomic._OURS.match(tmp)


def test_a_valid_255_byte_name_is_written(tmp_path):
    target = tmp_path / ("b" * 251 + ".txt")
    atomic.write_text_atomic(target, "whole\n")
    assert target.read_text() == "whole\n"
    assert sorted(os.listdir(tmp_path)) == [target.name]


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_sweep_removes_the_temporaries_of_dead_processes_only(tmp_path):
    dead = _dead_pid()
    stale = tmp_path / f".out.csv.accelcal-{dead}-0123456789ab.tmp"
    stale_dir = tmp_path / f".import.accelcal-{dead}-0123456789ab"
    live = tmp_path / f".out.csv.accelcal-{os.getppid()}-0123456789ab.tmp"
    users = [tmp_path / f"accelcal-{dead}-report.csv", tmp_path / "out.csv",
             tmp_path / f".out.csv.{'c' * 12}.tmp"]
    for path in (stale, live, *users):
        path.write_text("x")
    stale_dir.mkdir()
    (stale_dir / "out.csv").write_text("half")
    assert atomic.sweep(tmp_path) == 2
    assert not stale.exists()
    assert not stale_dir.exists()
    assert live.exists()
    assert all(p.exists() for p in users)


@pytest.mark.parametrize("name", ["/proc/self/x.parquet", "x" * 300 + ".csv"])
def test_write_failures_are_one_line_naming_the_path(tmp_path, capsys, name):
    out = name if name.startswith("/") else tmp_path / name
    err = refused(["triad", "simulate", "--out", out, "--dwell", "1", "--still", "1"], capsys,
                  "cannot write")
    assert str(out)[:20] in err


def test_shaker_record_directory_respects_the_umask(tmp_path):
    old = os.umask(0o022)
    try:
        out = tmp_path / "recs"
        from accelcal.cli import main

        with pytest.raises(SystemExit) as exc:
            main(["transverse", "simulate", "--out", str(out), "--paper", "--amplitude", "5",
                  "--periods", "2", "--sample-rate", "2048"])
        assert exc.value.code == 0
        assert stat.S_IMODE(out.stat().st_mode) == 0o755
        assert not [p for p in os.listdir(tmp_path) if "accelcal-" in p]
    finally:
        os.umask(old)


def test_tdms_rate_below_the_floor_is_refused(tmp_path, capsys, monkeypatch):
    acc, temp = daq_files.signals(200)
    monkeypatch.setattr(daq_files, "RATE", 1e-300)
    daq_files.write_tdms(tmp_path / "x.tdms", acc, temp)
    refused(["inspect", tmp_path / "x.tdms"], capsys, "wf_increment", "1e-06")


def test_damaged_tdms_prints_only_the_line(tmp_path, capfd):
    acc, temp = daq_files.signals(1200)
    daq_files.write_tdms(tmp_path / "ok.tdms", acc, temp)
    data = (tmp_path / "ok.tdms").read_bytes()
    (tmp_path / "cut.tdms").write_bytes(data[:-5000])
    from accelcal.cli import main

    with pytest.raises(SystemExit) as exc:
        main(["inspect", str(tmp_path / "cut.tdms")])
    err = capfd.readouterr().err
    assert exc.value.code == 2
    assert err.count("\n") == 1
    assert "truncated or damaged" in err
    assert "WARNING" not in err


def test_complex_mat_variable_is_refused(tmp_path, capsys):
    import scipy.io

    acc, _ = daq_files.signals(300)
    scipy.io.savemat(tmp_path / "c.mat", {"data": acc + 1j * acc})
    refused(["import", tmp_path / "c.mat", "--kind", "noise", "--channels", "acc=data[0]",
             "--unit", "g", "--rate", "100", "--out", tmp_path / "o.csv"], capsys, "complex")
    assert not (tmp_path / "o.csv").exists()


def test_wide_mat_matrix_is_not_three_million_channels(tmp_path, capsys):
    import scipy.io

    scipy.io.savemat(tmp_path / "w.mat", {"data": np.zeros((2, 5000)), "v": np.ones(50)},
                     do_compression=True)
    code, out, _ = run_cli(["inspect", tmp_path / "w.mat", "--format", "json"], capsys)
    assert code == 0
    assert "5000 columns" in out
    assert "data[4999]" not in out


@pytest.mark.parametrize(("text", "words"), [
    ('kind = "noise"\nrate = true\n[channels]\nacc = "x"\n', ("rate must be a number",)),
    ('kind = "noise"\nrate = 10.0\n[channels]\nacc = { channel = "x", scale = false }\n',
     ("scale must be a number",)),
    ("x = " + "[" * 20000 + "]" * 20000 + "\n", ("nests deeper",)),
])
def test_mapping_file_faults_are_one_line(tmp_path, capsys, text, words):
    (tmp_path / "m.toml").write_text(text)
    (tmp_path / "r.csv").write_text("x\n1\n2\n")
    refused(["import", tmp_path / "r.csv", "--mapping", tmp_path / "m.toml", "--out",
             tmp_path / "o.csv"], capsys, *words)


def test_check_rate_refuses_a_boolean():
    from accelcal.validation import check_rate

    with pytest.raises(AccelcalError, match="sample rate"):
        check_rate(True)
    assert check_rate(1) == 1.0


def test_taus_all_is_refused_with_its_estimate():
    from accelcal.signal.allan.deviations import deviation
    from accelcal.signal.allan.taus import MAX_SECONDS, tau_grid, work_seconds

    n = 360_000
    assert work_seconds(n, tau_grid(n, "all", kind="mdev"), "mdev") > MAX_SECONDS
    assert work_seconds(n, tau_grid(n, "octave", kind="mdev"), "mdev") < 1
    y = np.random.default_rng(0).normal(size=n)
    took = r"would take about [\d.,e+]+ (s|min|h|days|years) "
    with pytest.raises(AccelcalError, match=took) as exc:
        deviation(y, 100.0, kind="mdev", taus="all")
    assert exc.value.parameter == "taus"
