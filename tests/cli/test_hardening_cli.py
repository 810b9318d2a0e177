"""Hardening found by the fuzzers (issue 11): huge numbers, unbounded messages, special files.

Special files are always made inside the test's temporary directory: FIFOs,
and (when the tests run as root) private device nodes like /dev/full and
/dev/zero. Nothing here writes to, or next to, the system's devices.
"""

import contextlib
import json
import os
import signal
import stat
import warnings
from pathlib import Path

import numpy as np
import pytest

from accelcal import AccelcalError, default_model
from accelcal.calibration import record_paths, save_records
from accelcal.io import limits
from accelcal.io.atomic import write_text_atomic
from accelcal.io.calibration_record import CalibrationRecord
from accelcal.io.lab_metadata import read_metadata
from accelcal.io.records import read_record, write_record
from accelcal.model import ErrorModel
from accelcal.store import Store
from accelcal.validation import MAX_MESSAGE_LENGTH
from helpers.cli import assert_one_line_error, leftovers, run
from helpers.paths import EXAMPLES, FIXTURES
from helpers.records import make_record

HEAD = EXAMPLES / "indexing_head.csv"


@contextlib.contextmanager
def deadline(seconds: float = 10.0):
    """Fail instead of hanging: a blocked open() of a FIFO is interrupted by the alarm."""

    def alarm(signum, frame):
        raise TimeoutError(f"no answer within {seconds} s")

    old = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def fifo(tmp_path: Path, name: str = "fifo") -> Path:
    path = tmp_path / name
    os.mkfifo(path)
    return path


def device(tmp_path: Path, name: str = "full", minor: int = 7) -> Path:
    """A private character device node (1, minor): /dev/full's (7) or /dev/zero's (5)."""
    path = tmp_path / name
    try:
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, minor))
    except (OSError, AttributeError):
        pytest.skip("cannot make device nodes here (not root)")
    return path


def run_quiet(capsys, *args):
    """:func:`run` with warnings turned into errors: a RuntimeWarning fails the test."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with deadline(60):
            return run(capsys, *args)


# --- R1: huge JSON integers --------------------------------------------------------------------

def test_huge_json_integers_are_refused_once_for_every_reader(tmp_path):
    with pytest.raises(AccelcalError, match=r"integer 9999.* has 400 digits; at most 30"):
        limits.load_json('{"a": ' + "9" * 400 + "}", "x")
    assert limits.load_json("[-" + "9" * 30 + "]", "x") == [-float("9" * 30)]
    assert limits.load_json("[123, -4]", "x") == [123, -4]
    assert isinstance(limits.load_json(str(2**63), "x"), float)  # numpy-safe
    assert isinstance(limits.load_json(str(2**63 - 1), "x"), int)
    # in a calibration record, a model file, CSV and Parquet metadata
    doc = json.loads((FIXTURES / "calibration_record_v1.json").read_text())
    text = json.dumps(doc).replace('"coverage_factor": 2.0', '"coverage_factor": ' + "9" * 400)
    with pytest.raises(AccelcalError, match="has 400 digits"):
        CalibrationRecord.from_json(text)
    with pytest.raises(AccelcalError, match="has 400 digits"):
        ErrorModel.from_json('{"format_version": 1, "kind": "accelcal.ErrorModel", '
                             '"output_unit": "V", "coefficients": {"K1": ' + "9" * 400 + "}}")
    for name in ("r.csv", "r.parquet"):
        path = tmp_path / name
        write_record(path, "demo", {"units": {"t": "s"}, "big": 1}, {"t": np.arange(3.0)})
        if name.endswith(".csv"):
            path.write_text(path.read_text().replace('"big": 1', '"big": ' + "9" * 400))
        else:
            import pyarrow.parquet as pq

            table = pq.read_table(path)
            meta = table.schema.metadata[b"accelcal"].decode().replace('"big": 1',
                                                                       '"big": ' + "9" * 400)
            pq.write_table(table.replace_schema_metadata({"accelcal": meta}), path)
        for read in (lambda p: read_record(p, "demo"), read_metadata):
            with pytest.raises(AccelcalError, match="has 400 digits"):
                read(path)


def test_a_head_record_with_a_huge_integer_in_metadata_gives_one_line(tmp_path, capsys):
    text = HEAD.read_text()
    path = tmp_path / "head.csv"
    path.write_text(text.replace('"output_unit": "V"', '"output_unit": "V", "local_gravity": '
                                 + "9" * 400, 1))
    code, _, err = run(capsys, "dividing-head", "reduce", path)
    assert_one_line_error(code, err, "has 400 digits")
    # within the digit bound but beyond int64: decoded as a float, checked as a number
    path.write_text(text.replace('"mount_phases_deg": [', '"mount_phases_deg": ['
                                 + "9" * 25 + ", ", 1))
    code, _, err = run(capsys, "dividing-head", "reduce", path)
    assert_one_line_error(code, err, "mount phases for")


# --- R2/C5: values quoted shortened; the CLI's backstop ----------------------------------------

@pytest.mark.parametrize("args", [
    ["model", "eval", "--ai", "x" * 100_000],
    ["model", "eval", "--ai", "1:2:" + "x" * 100_000],
    ["model", "new", "--out", "{tmp}/m.json", "--set", "1," * 200_000],
    ["model", "new", "--out", "{tmp}/m.json", "--set", "K" * 100_000 + "=1"],
    ["model", "new", "--out", "{tmp}/m.json", "--output-unit", "x" * 100_000],
    ["dividing-head", "simulate", "--out", "{tmp}/h.csv", "--angle-error", "x" * 100_000],
    ["dividing-head", "simulate", "--out", "{tmp}/h.csv", "--first-harmonic", "1," * 200_000],
    ["dividing-head", "simulate", "--out", "{tmp}/h.csv", "--mounts", "x" * 100_000],
    ["dividing-head", "reduce", str(HEAD), "--angle-error-level", "x" * 100_000],
    ["dividing-head", "simulate", "--out", "{tmp}/h.csv", "--angle-error",
     "harmonics:2c=" + "x" * 100_000],
])
def test_long_values_are_quoted_shortened(capsys, tmp_path, args):
    code, _, err = run(capsys, *(a.format(tmp=tmp_path) for a in args))
    assert_one_line_error(code, err)
    assert len(err) < 400, err[:200]


def test_the_cli_clips_any_message(capsys, monkeypatch):
    from accelcal.cli import model as model_cli

    def loud(path):
        raise AccelcalError("start " + "y" * 1_000_000 + "\nend")

    monkeypatch.setattr(model_cli, "load_model", loud)
    code, _, err = run(capsys, "model", "show")
    assert_one_line_error(code, err, "start yyy", " ... ", "yyy end")
    assert len(err) <= len("accelcal: error: \n") + MAX_MESSAGE_LENGTH


def test_long_cells_and_column_names_are_quoted_shortened(tmp_path):
    path = tmp_path / "r.csv"
    write_record(path, "demo", {"units": {"t": "s"}}, {"t": np.arange(3.0)})
    path.write_text(path.read_text() + "x" * 1_000_000 + "\n")
    with pytest.raises(AccelcalError) as info:
        read_record(path, "demo")
    assert "is not a number" in str(info.value)
    assert len(str(info.value)) < 300
    name = "c" * 10_000
    with pytest.raises(AccelcalError) as info:
        write_record(tmp_path / "n.csv", "demo", {"units": {name: "furlong"}},
                     {name: np.arange(3.0)})
    assert len(str(info.value)) < 400


def test_long_term_names_are_quoted_shortened():
    name = "K" * 1_000_000
    doc = {"format_version": 1, "kind": "accelcal.ErrorModel", "output_unit": "V",
           "coefficients": {"K1": 1.0, name: 1.0}}
    for make in (lambda: ErrorModel.from_json(json.dumps(doc)),
                 lambda: ErrorModel.from_json(json.dumps({**doc, "units": {name: "g"}})),
                 lambda: ErrorModel.from_terms({name: 1.0}),
                 lambda: ErrorModel.from_guantang(**{name: 1.0})):
        with pytest.raises(AccelcalError, match="unknown term 'KKK") as info:
            make()
        assert len(str(info.value)) < 400
    with pytest.raises(AccelcalError, match="did you mean K2"):
        ErrorModel.from_terms({"k2": 1.0})


# --- R3: Parquet errors on one line ------------------------------------------------------------

def test_parquet_read_errors_are_one_line(tmp_path):
    path = tmp_path / "r.parquet"
    write_record(path, "demo", {"units": {"t": "s"}}, {"t": np.arange(100.0)})
    data = path.read_bytes()
    for bad in (data[: len(data) // 2], b"PAR1" + b"\x00" * 100 + data[-8:],
                data[:-12] + data[-8:]):
        path.write_bytes(bad)
        for read in (lambda p: read_record(p, "demo"), read_metadata):
            with pytest.raises(AccelcalError) as info:
                read(path)
            assert "\n" not in str(info.value)
            assert len(str(info.value)) < 600


# --- R4: covariance a covariance -----------------------------------------------------------------

@pytest.mark.parametrize(("covariance", "message"), [
    ([[1.0, 1e308, 0.0], [1e308, 1.0, 0.0], [0.0, 0.0, 1.0]], "correlation beyond"),
    ([[1.0, 0.5, 0.0], [0.4, 1.0, 0.0], [0.0, 0.0, 1.0]], "not symmetric"),
    ([[1.0, 1e308, 0.0], [-1e308, 1.0, 0.0], [0.0, 0.0, 1.0]], "not symmetric"),
    ([[1.0, np.nan, 0.0], [0.5, 1.0, 0.0], [0.0, 0.0, 1.0]], "not symmetric"),
    ([[0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 1.0]], "correlation beyond"),
    ([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]], "negative variances"),
])
def test_a_covariance_no_uncertainties_can_have_is_refused(covariance, message, capsys,
                                                           tmp_path):
    rec = make_record()
    with pytest.raises(AccelcalError, match=message):
        CalibrationRecord(**{**rec.__dict__, "covariance": np.array(covariance)})
    doc = json.loads(rec.to_json())
    doc["covariance"] = [[None if np.isnan(x) else x for x in row] for row in covariance]
    path = tmp_path / "r.json"
    path.write_text(json.dumps(doc))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        code, _, err = run(capsys, "report", path, "--out", tmp_path / "r.html")
    assert_one_line_error(code, err, message)
    assert not (tmp_path / "r.html").exists()


def test_rounding_and_unknown_entries_pass_the_covariance_checks():
    rec = make_record()
    cov = np.array([[4.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]])  # correlation 1
    cov[0, 1] *= 1 + 1e-12
    cov[1, 0] *= 1 - 1e-12
    CalibrationRecord(**{**rec.__dict__, "covariance": cov})
    unknown = np.array([[np.nan, np.nan, 0.0], [np.nan, 1.0, 0.3], [0.0, 0.3, 1.0]])
    CalibrationRecord(**{**rec.__dict__, "covariance": unknown})
    fixed = np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])  # a fixed term
    CalibrationRecord(**{**rec.__dict__, "covariance": fixed})
    CalibrationRecord.load(EXAMPLES / "calibration_record.json")
    CalibrationRecord.load(FIXTURES / "calibration_record_v1.json")


# --- C1: the atomic writer never replaces a special file ----------------------------------------

def test_the_atomic_writer_refuses_special_files(tmp_path):
    targets = [fifo(tmp_path)]
    link = tmp_path / "link"
    link.symlink_to(targets[0])
    targets.append(link)
    with contextlib.suppress(pytest.skip.Exception):
        targets.append(device(tmp_path))
    for target in targets:
        with pytest.raises(AccelcalError, match=r"cannot write .*: it is (a FIFO|a character "
                                                r"device).*not a regular file"):
            write_text_atomic(target, "x")
    assert fifo_is(tmp_path / "fifo")
    assert link.is_symlink()
    assert leftovers(tmp_path) == []
    # a link to a regular file is replaced by the new file (the target is kept)
    real = tmp_path / "real.txt"
    real.write_text("old")
    good = tmp_path / "good"
    good.symlink_to(real)
    write_text_atomic(good, "new")
    assert good.read_text() == "new"
    assert real.read_text() == "old"


def fifo_is(path: Path) -> bool:
    return stat.S_ISFIFO(os.lstat(path).st_mode)


@pytest.mark.parametrize("args", [
    ["model", "new", "--out", "{special}"],
    ["dividing-head", "simulate", "--out", "{special}"],
    ["dividing-head", "reduce", str(HEAD), "--record", "{special}"],
    ["report", str(EXAMPLES / "calibration_record.json"), "--out", "{special}"],
])
def test_commands_never_replace_a_fifo_or_a_device(capsys, tmp_path, args):
    specials = [fifo(tmp_path)]
    with contextlib.suppress(pytest.skip.Exception):
        specials.append(device(tmp_path))
    for special in specials:
        with deadline(60):
            code, _, err = run(capsys, *(a.format(special=special) for a in args))
        assert_one_line_error(code, err, "not a regular file")
        mode = os.lstat(special).st_mode
        assert stat.S_ISFIFO(mode) or stat.S_ISCHR(mode)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(s.name for s in specials)


# --- C2: several records' names ----------------------------------------------------------------

def test_record_paths_refuse_what_is_not_a_file_name(tmp_path):
    for bad in ("", ".", "..", str(tmp_path), f"{tmp_path}/"):
        with pytest.raises(AccelcalError, match=r"not a file name|a directory") as info:
            record_paths(bad, 4)
        assert info.value.parameter == "record"
    special = fifo(tmp_path, "cal-2.json")
    with pytest.raises(AccelcalError, match=r"cal-2\.json is a FIFO"):
        record_paths(tmp_path / "cal.json", 4)
    assert record_paths(tmp_path / "cal.json", 1) == [tmp_path / "cal.json"]
    special.unlink()
    with pytest.raises(AccelcalError, match="not a file name"):
        save_records([make_record()], "")


@pytest.mark.parametrize("record", ["{tmp}", "", "{tmp}/fifo"])
def test_reduce_record_to_a_directory_or_a_special_file_writes_nothing(capsys, tmp_path,
                                                                        record):
    fifo(tmp_path)
    before = sorted(p.name for p in tmp_path.parent.iterdir())
    with deadline(60):
        code, _, err = run(capsys, "dividing-head", "reduce", HEAD,
                           f"--record={record.format(tmp=tmp_path)}")
    assert_one_line_error(code, err, "--record:")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fifo"]
    assert sorted(p.name for p in tmp_path.parent.iterdir()) == before


# --- C3/C4: no reader opens a FIFO or a device ---------------------------------------------------

def test_every_reader_refuses_a_fifo_at_once(tmp_path):
    from accelcal.io.formats.dividing_head import read_head_record
    from accelcal.io.lab_metadata import read_lab_metadata

    readers = [ErrorModel.load, CalibrationRecord.load, read_head_record, read_metadata,
               read_lab_metadata, lambda p: read_record(p, "demo")]
    for name in ("f.csv", "f.parquet", "f.json"):
        path = fifo(tmp_path, name)
        for read in readers:
            with deadline(), pytest.raises(AccelcalError, match=r"is a FIFO .*not a regular file"):
                read(path)
    with pytest.raises(AccelcalError, match="is a directory, not a regular file"):
        read_record(tmp_path, "demo")
    with pytest.raises(AccelcalError, match="NUL character"):
        ErrorModel.load("a\x00b")
    with pytest.raises(AccelcalError, match="not found"):
        ErrorModel.load(tmp_path / "missing.json")


@pytest.mark.parametrize("args", [
    ["model", "show", "{fifo}"],
    ["model", "eval", "--ai", "1", "--model", "{fifo}"],
    ["report", "{fifo}", "--out", "{tmp}/r.html"],
    ["records", "add", "{fifo}", "--db", "{tmp}/s.sqlite"],
    ["dividing-head", "reduce", "{fifo}"],
    ["dividing-head", "simulate", "--out", "{tmp}/h.csv", "--model", "{fifo}", "--mounts", "0"],
    ["dividing-head", "simulate", "--out", "{tmp}/h.csv", "--angle-error", "file:{fifo}"],
    ["records", "list", "--db", "{fifo}"],
    ["records", "history", "ACC-0001", "--db", "{fifo}"],
    ["records", "stats", "ACC-0001", "--db", "{fifo}"],
    ["records", "add", str(EXAMPLES / "calibration_record.json"), "--db", "{fifo}"],
    ["report", str(EXAMPLES / "calibration_record.json"), "--out", "{tmp}/r.html", "--history",
     "--db", "{fifo}"],
])
def test_commands_refuse_a_fifo_input_at_once(capsys, tmp_path, args):
    path = fifo(tmp_path)
    with deadline(60):
        code, _, err = run(capsys, *(a.format(fifo=path, tmp=tmp_path) for a in args))
    assert_one_line_error(code, err, "is a FIFO (named pipe), not a regular file")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fifo"]


def test_a_store_that_is_a_device_is_refused_before_sqlite_opens_it(capsys, tmp_path):
    zero = device(tmp_path, "zero", 5)
    link = tmp_path / "link"
    link.symlink_to(zero)
    for db in (zero, link, f"sqlite:///{zero}"):
        for readonly in (False, True):
            with pytest.raises(AccelcalError, match="is a character device, not a regular file"):
                Store(db, readonly=readonly)
        code, _, err = run(capsys, "records", "list", "--db", db)
        assert_one_line_error(code, err, "character device")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link", "zero"]  # no zero-journal


# --- C6/C7: studies and the Monte Carlo engine ---------------------------------------------------

@pytest.mark.parametrize(("args", "needle"), [
    (["--trials", "9" * 30], "--trials: about 1e29 trials would run for more than 30 years"),
    (["--trials", "2", "--h1-sd", "1e308"], "--h1-sd: must be a standard deviation"),
    (["--trials", "2", "--h1-sd", "-1"], "--h1-sd: must be a standard deviation"),
    (["--trials", "2", "--workers", "1000000000000"], "--workers: 1000000000000 worker"),
    (["--trials", "2", "--workers", "9" * 30], "--workers: about 1e29 worker"),
    (["--trials", "2", "--timeout", "inf"], "--timeout: must be a positive number of seconds"),
    (["--trials", "2", "--timeout", "1e400"], "--timeout: must be a positive number"),
    (["--trials", "2", "--timeout", "86401"], "at most 86400 (one day)"),
    (["--trials", "2", "--timeout", "0"], "--timeout: must be a positive number"),
    (["--trials", "2", "--mounts", "1e308"], "--mounts: mount phases must be angles within"),
    (["--trials", "2", "--noise", "1e308"], "--noise: standard deviation 1e+308 is beyond"),
])
def test_study_options_out_of_range_exit_2_at_once(capsys, args, needle):
    code, _, err = run_quiet(capsys, "dividing-head", "study", *args)
    assert_one_line_error(code, err, needle)


def test_the_engine_bounds_trials_workers_and_timeout():
    from accelcal import montecarlo

    def simulate(rng, n):
        return rng.standard_normal((n, 1))

    for kwargs, needle in (({"trials": montecarlo.MAX_TRIALS + 1}, "trials: "),
                           ({"trials": 10, "workers": montecarlo.max_workers() + 1},
                            "workers: "),
                           ({"trials": 10, "timeout": float("inf")}, "timeout: "),
                           ({"trials": 10, "timeout": True}, "timeout: ")):
        with pytest.raises(AccelcalError, match=needle):
            montecarlo.run(simulate, names=["x"], seed=0, **kwargs)
    assert montecarlo.max_workers() >= montecarlo.WORKERS_PER_CPU
    assert montecarlo.run(simulate, 10, names=["x"], seed=0, timeout=86400).trials == 10


# --- C8: no RuntimeWarning for extreme values -------------------------------------------------

@pytest.mark.parametrize(("args", "needle"), [
    (["model", "eval", "--ai", "1e308"], "specific force a_i of 1e+308 g is beyond the 1e+06 g"),
    (["model", "eval", "--ai", "1", "--ao", "1e308"], "specific force a_o of 1e+308 g"),
    (["model", "eval", "--ai", "1", "--ap", "-1e308"], "specific force a_p of 1e+308 g"),
    (["dividing-head", "simulate", "--out", "{tmp}/h.csv", "--noise", "1e308"],
     "--noise: standard deviation 1e+308 is beyond"),
    (["dividing-head", "simulate", "--out", "{tmp}/h.csv", "--mounts", "0,90,180,1e308"],
     "--mounts: mount phases must be angles within +-360 deg"),
])
def test_extreme_values_give_one_line_and_no_warning(capsys, tmp_path, args, needle):
    code, _, err = run_quiet(capsys, *(a.format(tmp=tmp_path) for a in args))
    assert_one_line_error(code, err, needle)
    assert list(tmp_path.iterdir()) == []


def test_a_model_output_that_overflows_is_refused():
    model = default_model().replace(K4=1e300)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(AccelcalError, match="output overflows"):
            model.output(1e3)
        with pytest.raises(AccelcalError, match="output overflows"):
            ErrorModel(K1=1e308).output(10.0)
    assert float(model.output_g(1.0)) == pytest.approx(float(default_model().output_g(1.0))
                                                       + 1e300, rel=1e-12)


# --- C9: the demo checks its store first; no progress bar before an error ----------------------

@pytest.mark.parametrize("kind", ["directory", "not a database", "fifo"])
def test_demo_checks_the_store_before_simulating(capsys, tmp_path, kind):
    db = tmp_path / "db"
    if kind == "directory":
        db.mkdir()
    elif kind == "fifo":
        fifo(tmp_path, "db")
    else:
        db.write_text("{}")
    with deadline(60):
        code, _, err = run(capsys, "demo", "--out", tmp_path / "demo", "--seed", "1", "--db", db)
    assert_one_line_error(code, err, "records store")
    assert list((tmp_path / "demo" / "data").iterdir()) == []  # nothing simulated


def test_progress_steps_print_nothing_when_a_step_fails(capsys):
    from accelcal.pipeline import _Steps

    def boom():
        raise AccelcalError("boom")

    def failing_run():
        with _Steps(["one", "two"], True) as step:
            step(lambda: None)
            step(boom)

    with pytest.raises(AccelcalError, match="boom"):
        failing_run()
    assert capsys.readouterr().err == ""
    with _Steps(["one", "two"], True) as step:
        step(lambda: None)
        step(lambda: None)
    assert "two" in capsys.readouterr().err
