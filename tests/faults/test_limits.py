"""Commands under limits: memory bombs under RLIMIT_AS, file-size limits, unwritable places,
long names, a locked store, Ctrl-C at start-up, during a CSV read and to Dask workers.

Every case runs ``accelcal`` in a child process and asserts one line (exit
status 2, or the signal's), no traceback, no output under the final name and
no temporary left.
"""

import os
import signal

import pytest

from helpers.bombs import check_small, hdf5_chunk_bomb, mat5_bomb
from helpers.faults import kill_after, leftovers, run

pytestmark = pytest.mark.faults

GiB = 2**30
ADDRESS_SPACE = 2 * GiB
"""The address-space limit the bombs run under (``ulimit -v``)."""


@pytest.fixture
def dirs(tmp_path):
    work, tmpdir = tmp_path / "out", tmp_path / "tmp"
    work.mkdir()
    tmpdir.mkdir()
    return work, tmpdir


def _refused(result, *words):
    assert not result.traceback, result.err
    assert result.one_line_error(), (result.code, result.err)
    for word in words:
        assert word in result.err, result.err


# -- memory bombs ---------------------------------------------------------------------------

def test_hdf5_one_gzip_chunk_of_400m_doubles_is_refused_with_the_figure(dirs):
    work, tmpdir = dirs
    bomb = work / "bomb.h5"
    hdf5_chunk_bomb(bomb, 400_000_000)
    check_small(bomb)
    result = run(["import", bomb, "--kind", "noise", "--channels", "acc=x", "--rate", "100",
                  "--out", work / "o.parquet"], cwd=work, tmpdir=tmpdir,
                 address_space=ADDRESS_SPACE)
    _refused(result, "GiB", "chunks")
    assert result.seconds < 60
    assert not (work / "o.parquet").exists()
    assert leftovers(work, tmpdir) == []


def test_hdf5_chunk_that_fits_is_read_once_within_the_limit(dirs):
    """A 160 MB chunk under the 2 GiB limit: imported, each chunk decompressed once."""
    work, tmpdir = dirs
    bomb = work / "chunk.h5"
    hdf5_chunk_bomb(bomb, 20_000_000)
    result = run(["import", bomb, "--kind", "noise", "--channels", "acc=x", "--rate", "100",
                  "--out", work / "o.parquet"], cwd=work, tmpdir=tmpdir,
                 address_space=ADDRESS_SPACE)
    assert result.code == 0, result.err
    assert result.seconds < 90
    assert (work / "o.parquet").stat().st_size > 0


def test_mat5_of_2e8_compressed_zeros_is_refused_by_its_declared_size(dirs):
    work, tmpdir = dirs
    bomb = work / "zeros.mat"
    mat5_bomb(bomb, 200_000_000, 1)
    check_small(bomb)
    result = run(["import", bomb, "--kind", "noise", "--channels", "acc=data", "--rate", "100",
                  "--unit", "g", "--out", work / "o.csv"], cwd=work, tmpdir=tmpdir,
                 address_space=ADDRESS_SPACE)
    _refused(result, "GiB", "2e+08")
    assert result.seconds < 60
    assert not (work / "o.csv").exists()


def test_mat5_of_two_by_three_million_inspects_in_bounded_memory(dirs):
    work, tmpdir = dirs
    bomb = work / "wide.mat"
    mat5_bomb(bomb, 2, 3_000_000)
    check_small(bomb, 2**20)
    result = run(["inspect", bomb, "--format", "json"], cwd=work, tmpdir=tmpdir,
                 address_space=ADDRESS_SPACE)
    _refused(result, "no numeric vector or matrix")
    assert result.seconds < 30


# -- file-size limits and unwritable places -------------------------------------------------

def test_import_staging_under_a_file_size_limit(dirs, inputs):
    work, tmpdir = dirs
    result = run(["import", inputs / "t.csv", "--kind", "noise", "--channels", "acc=acc_x",
                  "--out", work / "o.csv"], cwd=work, tmpdir=tmpdir, file_size=2**20)
    _refused(result, "o.csv", "file-size limit")
    assert os.listdir(work) == []


def test_noise_phase_file_under_a_file_size_limit(dirs, inputs):
    work, tmpdir = dirs
    result = run(["noise", "adev", inputs / "n.parquet"], cwd=work, tmpdir=tmpdir,
                 file_size=2**20)
    _refused(result, str(tmpdir), "file-size limit")
    assert os.listdir(tmpdir) == []


@pytest.mark.parametrize("command", ["triad apply", "thermal compensate", "triad simulate"])
def test_outputs_under_a_file_size_limit(dirs, inputs, command):
    work, tmpdir = dirs
    args = {"triad apply": ["triad", "apply", inputs / "t.csv", "--calibration",
                            inputs / "cal.json"],
            "thermal compensate": ["thermal", "compensate", inputs / "th.csv", "--model",
                                   inputs / "comp.json", "--column", "output",
                                   "--temperature-column", "temperature"],
            "triad simulate": ["triad", "simulate", "--dwell", "100"]}[command]
    result = run([*args, "--out", work / "o.csv"], cwd=work, tmpdir=tmpdir, file_size=64 * 1024)
    _refused(result, "o.csv")
    assert os.listdir(work) == []


@pytest.mark.parametrize("place", ["/sys", "/proc/self", "read-only"])
def test_unwritable_places_are_one_line(dirs, place):
    work, tmpdir = dirs
    if place == "read-only":
        if os.geteuid() == 0:
            pytest.skip("root writes into a read-only directory")
        place = work / "ro"
        place.mkdir(mode=0o555)
    result = run(["triad", "simulate", "--dwell", "1", "--still", "1", "--out",
                  f"{place}/x.parquet"], cwd=work, tmpdir=tmpdir)
    _refused(result, f"{place}/x.parquet")


LONG_NAME_COMMANDS = {
    "triad simulate": ["triad", "simulate", "--dwell", "1", "--still", "1", "--out", "{}.csv"],
    "thermal simulate": ["thermal", "simulate", "--setpoints", "20,30", "--out", "{}.csv"],
    "transverse simulate": ["transverse", "simulate", "--paper", "--amplitude", "5",
                            "--periods", "2", "--sample-rate", "2048", "--out", "{}"],
    "triad calibrate": ["triad", "calibrate", "{s.csv}", "--out", "{}.json"],
    "thermal reduce": ["thermal", "reduce", "{th.csv}", "--compensation", "{}.json"],
    "import": ["import", "{t.csv}", "--kind", "noise", "--channels", "acc=acc_x", "--out",
               "{}.csv"],
    "triad apply": ["triad", "apply", "{s.csv}", "--calibration", "{cal.json}", "--out",
                    "{}.csv"],
    "thermal compensate": ["thermal", "compensate", "{th.csv}", "--model", "{comp.json}",
                           "--column", "output", "--temperature-column", "temperature",
                           "--out", "{}.csv"],
}
"""The commands the issue saw fail on an output name over the file system's limit."""


def _fill(args, inputs, stem):
    return [stem + a[2:] if a.startswith("{}") else
            str(inputs / a[1:-1]) if a.startswith("{") else a for a in args]


@pytest.mark.parametrize("command", LONG_NAME_COMMANDS)
def test_output_names_over_the_limit_are_one_line(dirs, inputs, command):
    work, tmpdir = dirs
    result = run(_fill(LONG_NAME_COMMANDS[command], inputs, str(work / ("n" * 300))),
                 cwd=work, tmpdir=tmpdir)
    _refused(result, "too long")
    assert leftovers(work, tmpdir) == []


@pytest.mark.parametrize("command", ["triad simulate", "import", "triad apply"])
def test_valid_names_of_255_bytes_are_written(dirs, inputs, command):
    work, tmpdir = dirs
    stem = "v" * (255 - 4)
    result = run(_fill(LONG_NAME_COMMANDS[command], inputs, str(work / stem)), cwd=work,
                 tmpdir=tmpdir)
    assert result.code == 0, result.err
    assert os.listdir(work) == [stem + ".csv"]


# -- interrupts -----------------------------------------------------------------------------

def test_a_locked_store_cancels_within_a_second(dirs, inputs):
    import sqlite3
    import time

    work, tmpdir = dirs
    db = work / "store.sqlite"
    assert run(["records", "add", inputs / "rec.json", "--db", db], cwd=work,
               tmpdir=tmpdir).code == 0
    lock = sqlite3.connect(db, isolation_level=None)
    lock.execute("BEGIN EXCLUSIVE")
    try:
        began = time.monotonic()
        result, ending = kill_after(["records", "add", inputs / "rec.json", "--db", db], 6.0,
                                    signal.SIGINT, cwd=work, tmpdir=tmpdir)
    finally:
        lock.execute("ROLLBACK")
        lock.close()
    assert ending is not None, (time.monotonic() - began, result.err)
    assert ending < 1.5, ending
    assert result.code == 130, result.err
    assert not result.traceback


@pytest.mark.parametrize("delay", [0.15, 0.4, 0.8])
def test_ctrl_c_at_start_up_is_one_line(dirs, delay):
    work, tmpdir = dirs
    result, ending = kill_after(["triad", "simulate", "--out", work / "o.csv"], delay,
                                signal.SIGINT, cwd=work, tmpdir=tmpdir)
    assert not result.traceback, result.err
    if ending is None or result.code == -signal.SIGINT:
        # the run had finished first (a quiet machine), or the signal came as the process
        # exited, its handlers gone, and the default action ended it: the output is whole
        assert result.code in (0, -signal.SIGINT), result.err
        assert "wrote" in result.out
        assert (work / "o.csv").exists()
        return
    assert result.code == 130, result.err
    assert not (work / "o.csv").exists()


@pytest.mark.parametrize("delay", [1.0, 1.6, 2.2, 2.8])
def test_ctrl_c_during_a_csv_read_is_never_lost(dirs, inputs, delay):
    work, tmpdir = dirs
    result, ending = kill_after(["noise", "adev", inputs / "t.csv", "--column", "acc_x",
                                 "--format", "csv"], delay, signal.SIGINT, cwd=work,
                                tmpdir=tmpdir)
    assert not result.traceback, result.err
    if ending is not None:  # the signal came while it ran: never a success
        # (-SIGINT: it came as the process exited after its work, its handlers gone)
        assert result.code in (130, -signal.SIGINT), (delay, result.code, result.err)


@pytest.mark.parametrize("delay", [0.1, 0.7, 1.5, 2.5, 3.5, 5.0, 8.0])
def test_ctrl_c_to_dask_workers_is_one_line(dirs, delay):
    """One Ctrl-C to the terminal's process group, from start-up to the run on the workers.

    The workers are started with SIGINT blocked (they leave it to the main
    process); a Ctrl-C while the cluster starts is taken once it has
    started, and the cluster closed. Whatever the moment: one line, exit
    status 130, no traceback (of the main process or a worker), and no
    process of the run left behind.
    """
    import subprocess
    import time

    from helpers.faults import start

    work, tmpdir = dirs
    proc = start(["dividing-head", "study", "--trials", "20000000", "--workers", "2"],
                 cwd=work, tmpdir=tmpdir, group=True)
    try:
        try:
            proc.wait(timeout=delay)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert "Traceback" not in err, err
    assert proc.returncode == 130, err
    assert err.strip().splitlines() == ["accelcal: interrupted; nothing was left half-written"]
    for _ in range(40):  # no worker outlives the run (their exit is reaped within seconds)
        try:
            os.killpg(proc.pid, 0)
        except ProcessLookupError:
            break
        time.sleep(0.25)
    else:
        pytest.fail("a process of the run's group is left 10 s after it ended")
