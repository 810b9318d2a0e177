"""Hardening of files (issue 11): atomic outputs, bounded and safe readers, checked strings."""

import errno
import json
import os
import time
from pathlib import Path

import numpy as np
import pytest

from accelcal import AccelcalError, default_model
from accelcal.io import limits
from accelcal.io.atomic import atomic_path, write_text_atomic
from accelcal.io.calibration_record import CalibrationRecord
from accelcal.io.lab_metadata import LabInfo, check_lab_metadata, read_metadata
from accelcal.io.records import read_record, write_record
from accelcal.model import ErrorModel
from helpers.cli import assert_one_line_error, leftovers, run
from helpers.paths import FIXTURES
from helpers.records import make_record

DEEP = "[" * 100_000
UNITS = {"t": "s", "u": "V"}


def record_file(tmp_path, meta_json: str, name="r.csv") -> Path:
    path = tmp_path / name
    path.write_text(f"# accelcal record\n# {meta_json}\nt,u\n0,1\n1,2\n")
    return path


# --- outputs ---------------------------------------------------------------------------------

def test_output_that_is_a_directory_is_refused(tmp_path):
    target = tmp_path / "out.html"
    target.mkdir()
    with pytest.raises(AccelcalError, match=r"cannot write .*out.html: it is a directory"):
        write_text_atomic(target, "x")
    assert target.is_dir()
    assert leftovers(tmp_path) == []


def test_output_in_a_missing_directory_is_refused(tmp_path):
    with pytest.raises(AccelcalError, match=r"directory .*nope does not exist"):
        write_text_atomic(tmp_path / "nope" / "out.json", "x")


@pytest.mark.parametrize("code", [errno.ENOSPC, errno.EDQUOT, errno.EIO])
def test_full_disk_keeps_the_old_file_and_leaves_no_temp_file(tmp_path, monkeypatch, code):
    target = tmp_path / "model.json"
    target.write_text("old")

    def full(*args, **kwargs):
        raise OSError(code, os.strerror(code))

    monkeypatch.setattr("pathlib.Path.write_text", full)
    with pytest.raises(AccelcalError, match=r"cannot write .*model.json: ") as info:
        default_model().save(target)
    assert "\n" not in str(info.value)
    monkeypatch.undo()
    assert target.read_text() == "old"
    assert leftovers(tmp_path) == []


def test_a_full_disk_found_at_flush_is_reported(tmp_path, monkeypatch):
    # Delayed allocation: the write succeeds, the flush to disk finds the disk full.
    target = tmp_path / "r.csv"
    target.write_text("old")

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "fsync", full)
    with pytest.raises(AccelcalError, match="no space left on the device; free some space"):
        write_record(target, "demo", {"units": UNITS}, {"t": [0.0], "u": [1.0]})
    assert target.read_text() == "old"
    assert leftovers(tmp_path) == []


def test_a_scratch_record_is_not_flushed_and_an_imported_record_is(tmp_path, monkeypatch):
    # The import's probe record (read back at once and removed) skips the flush to disk;
    # every record that stays, the imported one included, is flushed before it appears.
    from accelcal.io.recordings import InputOptions
    from accelcal.io.recordings.convert import import_recording

    flushed = []
    monkeypatch.setattr(os, "fsync", lambda fd: flushed.append(os.fstat(fd).st_size))
    write_record(tmp_path / "s.parquet", "demo", {"units": UNITS}, {"t": [0.0], "u": [1.0]},
                 flush=False)
    assert flushed == []
    write_record(tmp_path / "k.parquet", "demo", {"units": UNITS}, {"t": [0.0], "u": [1.0]})
    assert flushed == [(tmp_path / "k.parquet").stat().st_size]
    n = 70_000  # more than the probe's 2^16 rows: the probe record is written
    src = tmp_path / "daq.csv"
    src.write_text("acc\n" + "\n".join(str(k % 7 * 1e-3) for k in range(n)) + "\n")
    flushed.clear()
    import_recording(src, InputOptions(rate=100.0, unit="g"), kind="noise",
                     channels={"acc": "acc"}, out=tmp_path / "n.parquet", rows=1 << 15)
    assert flushed == [(tmp_path / "n.parquet").stat().st_size]


def test_unwritable_directory_is_reported(tmp_path, monkeypatch):
    real_open = os.open

    def denied(path, flags, *args, **kwargs):
        if flags & os.O_CREAT:
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return real_open(path, flags, *args, **kwargs)

    monkeypatch.setattr(os, "open", denied)
    with pytest.raises(AccelcalError, match="permission denied; choose a location you can write"):
        write_text_atomic(tmp_path / "x.json", "x")
    monkeypatch.undo()
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="no /proc")
def test_output_under_proc_is_refused(capsys):
    code, _, err = run(capsys, "model", "new", "--out", "/proc/accelcal-test.json")
    assert_one_line_error(code, err, "cannot write /proc/accelcal-test.json")


def test_command_output_to_a_directory_exits_2(capsys, tmp_path):
    code, _, err = run(capsys, "model", "new", "--out", tmp_path)
    assert_one_line_error(code, err, "it is a directory")
    rec = tmp_path / "r.json"
    make_record().save(rec)
    code, _, err = run(capsys, "report", rec, "--out", tmp_path)
    assert_one_line_error(code, err, "it is a directory")


@pytest.mark.parametrize(("umask", "mode"), [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_new_files_respect_the_umask(tmp_path, umask, mode):
    old = os.umask(umask)
    try:
        write_text_atomic(tmp_path / "a.txt", "x")
        write_record(tmp_path / "r.parquet", "demo", {"units": UNITS}, {"t": [0.0], "u": [1.0]})
        with atomic_path(tmp_path / "b.bin") as tmp:
            tmp.write_bytes(b"x")
    finally:
        os.umask(old)
    for name in ("a.txt", "r.parquet", "b.bin"):
        assert (tmp_path / name).stat().st_mode & 0o777 == mode, name


def test_a_replaced_file_keeps_its_permissions(tmp_path):
    target = tmp_path / "a.txt"
    target.write_text("old")
    target.chmod(0o640)
    write_text_atomic(target, "new")
    assert target.read_text() == "new"
    assert target.stat().st_mode & 0o777 == 0o640


# --- JSON ------------------------------------------------------------------------------------

def test_json_depth_ignores_brackets_in_strings():
    assert limits.json_depth('{"a": "[[[[{{", "b": [[1], {"c": "\\"]]"}]}') == 3
    assert limits.load_json('{"a": "[[[["}', "x") == {"a": "[[[["}


@pytest.mark.parametrize(("text", "message"), [
    (DEEP, "nests deeper than 64 levels"),
    ('{"a": NaN}', "NaN is not allowed"),
    ('{"a": -Infinity}', "-Infinity is not allowed"),
    ('{"a": 1e400}', "1e400 is not allowed"),
    ('{"a": ' + "9" * 5000 + "}", "x:"),
    ("{not json", r"not valid JSON \(line 1, column 2"),
])
def test_safe_json_loader_refuses(text, message):
    with pytest.raises(AccelcalError, match=message):
        limits.load_json(text, "x")


def test_deeply_nested_json_in_csv_and_parquet_metadata(tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    csv = record_file(tmp_path, DEEP)
    parquet = tmp_path / "r.parquet"
    pq.write_table(pa.table({"u": [1.0]}).replace_schema_metadata({"accelcal": DEEP}), parquet)
    for path in (csv, parquet):
        with pytest.raises(AccelcalError, match="nests deeper than 64"):
            read_record(path, "demo")
        with pytest.raises(AccelcalError, match="nests deeper than 64"):
            read_metadata(path)


def test_deeply_nested_json_in_model_files_and_calibration_records(tmp_path, capsys):
    model = tmp_path / "m.json"
    model.write_text(DEEP)
    with pytest.raises(AccelcalError, match="nests deeper"):
        ErrorModel.load(model)
    record = tmp_path / "r.json"
    record.write_text('{"model": ' + DEEP)
    with pytest.raises(AccelcalError, match="nests deeper"):
        CalibrationRecord.load(record)
    code, _, err = run(capsys, "records", "add", record, "--db", tmp_path / "s.sqlite")
    assert_one_line_error(code, err, "nests deeper")
    assert not (tmp_path / "s.sqlite").exists()


# --- bounded readers -------------------------------------------------------------------------

def test_readers_end_at_once_on_dev_zero(capsys):
    # read only: a device is refused before it is opened (issue 11, C3)
    start = time.perf_counter()
    code, _, err = run(capsys, "model", "show", "/dev/zero")
    assert_one_line_error(code, err, "/dev/zero is a character device, not a regular file")
    for read in (CalibrationRecord.load, lambda p: read_record(p, "demo"), read_metadata):
        with pytest.raises(AccelcalError, match="a character device, not a regular file"):
            read("/dev/zero")
    assert time.perf_counter() - start < 10


def test_oversized_files_are_refused_before_reading(tmp_path, monkeypatch):
    path = tmp_path / "r.csv"
    write_record(path, "demo", {"units": UNITS}, {"t": np.arange(50.0), "u": np.ones(50)})
    monkeypatch.setattr("accelcal.io.records.MAX_RECORD_BYTES", 100)
    with pytest.raises(AccelcalError, match="larger than the 0 MiB a record file may have"):
        read_record(path, "demo")
    monkeypatch.undo()
    monkeypatch.setattr("accelcal.io.records.MAX_RECORD_VALUES", 99)
    with pytest.raises(AccelcalError, match="more than 99 values"):
        read_record(path, "demo")
    parquet = tmp_path / "r.parquet"
    write_record(parquet, "demo", {"units": UNITS}, {"t": np.arange(50.0), "u": np.ones(50)})
    with pytest.raises(AccelcalError, match="more than 99 values"):
        read_record(parquet, "demo")
    model = tmp_path / "m.json"
    default_model().save(model)
    monkeypatch.setattr("accelcal.io.model_file.MAX_JSON_BYTES", 10)
    with pytest.raises(AccelcalError, match="larger than 10 bytes"):
        ErrorModel.load(model)


def test_an_over_long_metadata_line_is_refused(tmp_path, monkeypatch):
    monkeypatch.setattr("accelcal.io.records.MAX_JSON_BYTES", 40)
    path = record_file(tmp_path, json.dumps({"format_version": 1, "kind": "demo",
                                             "units": UNITS, "pad": "x" * 100}))
    with pytest.raises(AccelcalError, match="line 2 is longer than 44 bytes"):
        read_record(path, "demo")


def test_csv_rows_are_parsed_by_arrow_not_split_in_python(tmp_path):
    # Python strings per row or cell would take several times the file's size (tracemalloc
    # sees Python objects and numpy arrays, not Arrow's own buffers).
    import tracemalloc

    small, path = tmp_path / "small.csv", tmp_path / "r.csv"
    write_record(small, "demo", {"units": UNITS}, {"t": [0.0], "u": [1.0]})
    read_record(small, "demo")  # imports pyarrow outside the measurement
    n = 200_000
    write_record(path, "demo", {"units": UNITS}, {"t": np.arange(n) / 3, "u": np.ones(n)})
    tracemalloc.start()
    try:
        _, cols = read_record(path, "demo")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    np.testing.assert_array_equal(cols["t"], np.arange(n) / 3)
    # the file's bytes and the float64 columns (about as large): 2x; Python strings: 11x
    assert peak < 3 * path.stat().st_size, (peak, path.stat().st_size)


@pytest.mark.parametrize(("body", "message"), [
    ("0,1\n\n2\n", "line 6 has 1 values, expected 2"),
    ("0,1\n\n2,abc\n", "line 6, column u: 'abc' is not a number"),
    ("0,1\r\n\r\n2,inf\r\n", "line 6, column u: 'inf' is not finite"),
    ("0,1\n2,1e999\n", "line 5, column u: '1e999' is not finite"),
    ("0,1\n2,NA\n", "line 5, column u: 'NA' is not a number"),
    ("0,1\n2,\n", "line 5, column u: '' is not a number"),
    ("0,1\n2,\xff\n", "line 5, column u: '\ufffd' is not a number"),
    ("0,1,\n", "line 4 has 3 values, expected 2"),
    ("\n\n", "the record has no data rows"),
])
def test_csv_errors_name_the_file_line_and_column(tmp_path, body, message):
    path = tmp_path / "r.csv"
    meta = json.dumps({"format_version": 1, "kind": "demo", "units": UNITS})
    head = f"# accelcal record\n# {meta}\nt,u\n"
    path.write_bytes(head.encode() + body.encode("latin-1"))
    with pytest.raises(AccelcalError, match=message) as info:
        read_record(path, "demo")
    assert str(info.value).startswith(str(path))


def test_csv_cells_may_carry_spaces_and_blank_lines(tmp_path):
    path = tmp_path / "r.csv"
    head = json.dumps({"format_version": 1, "kind": "demo", "units": UNITS})
    path.write_text(f"# accelcal record\n# {head}\n t , u \n 0, 1.5 \n\n+.5,-2e-3\n")
    _, cols = read_record(path, "demo")
    assert cols["t"].tolist() == [0.0, 0.5]
    assert cols["u"].tolist() == [1.5, -2e-3]


# --- units and format_version ----------------------------------------------------------------

@pytest.mark.parametrize("units", [None, "x", -1, [], {"t": None, "u": "V"}, {"t": "x", "u": "V"},
                                   {"t": -1, "u": "V"}, {"t": [], "u": "V"}, {"u": "V"}])
@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_record_units_are_checked(tmp_path, units, suffix):
    import pyarrow as pa
    import pyarrow.parquet as pq

    meta = json.dumps({"format_version": 1, "kind": "demo", "units": units})
    if suffix == ".csv":
        path = record_file(tmp_path, meta)
    else:
        path = tmp_path / "r.parquet"
        table = pa.table({"t": [0.0], "u": [1.0]}).replace_schema_metadata({"accelcal": meta})
        pq.write_table(table, path)
    with pytest.raises(AccelcalError, match="metadata 'units'"):
        read_record(path, "demo")


def test_writers_refuse_unknown_units(tmp_path):
    with pytest.raises(AccelcalError, match="'units' of column u is 'volts'"):
        write_record(tmp_path / "r.csv", "demo", {"units": {"t": "s", "u": "volts"}},
                     {"t": [0.0], "u": [1.0]})
    assert list(tmp_path.iterdir()) == []


def test_boolean_format_version_is_refused(tmp_path):
    path = record_file(tmp_path, json.dumps({"format_version": True, "kind": "demo",
                                             "units": UNITS}))
    with pytest.raises(AccelcalError, match="format_version true is not supported"):
        read_record(path, "demo")


@pytest.mark.parametrize(("change", "message"), [
    ({"format_version": True}, "format_version true is not supported"),
    ({"coverage_factor": True}, "coverage_factor must be a finite number"),
    ({"covariance": [[True]]}, "covariance must be a square list"),
    ({"notes": [1]}, "notes must be a list of strings"),
    ({"inputs": {"a.csv": 1}}, "inputs must map file names to hashes"),
    ({"serial": "SN/1"}, "contains a path separator"),
    ({"serial": "x" * 300}, "is longer than 200 characters"),
    ({"operator": "a\nb"}, "contains a control character"),
    ({"method": "m\x1b[31m"}, "contains a control character"),
])
def test_calibration_record_fields_are_checked(tmp_path, change, message):
    doc = json.loads((FIXTURES / "calibration_record_v1.json").read_text())
    doc.update(change)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(AccelcalError, match=message) as info:
        CalibrationRecord.load(path)
    assert len(str(info.value)) < 400


@pytest.mark.parametrize(("key", "value"), [("estimate", "1.5"), ("std", True),
                                            ("name", 3), ("unit", None)])
def test_coefficient_fields_are_typed(tmp_path, key, value):
    doc = json.loads((FIXTURES / "calibration_record_v1.json").read_text())
    doc["coefficients"][0][key] = value
    with pytest.raises(AccelcalError, match=rf"coefficients\[0\]\.{key} must be"):
        CalibrationRecord.from_json(json.dumps(doc))


def test_infinite_uncertainties_are_never_recorded():
    rec = make_record()
    with pytest.raises(AccelcalError, match="covariance has infinite entries"):
        CalibrationRecord(**{**rec.__dict__, "covariance": np.diag([1.0, np.inf, 1.0])})


def test_lab_gravity_refuses_booleans_and_huge_integers():
    for gravity in (True, 10**400):
        with pytest.raises(AccelcalError, match="metadata 'local_gravity'"):
            check_lab_metadata({"local_gravity": gravity}, "f.csv")


# --- user strings ----------------------------------------------------------------------------

@pytest.mark.parametrize(("meta", "message"), [
    ({"serial": "x" * 1_000_000}, "metadata 'serial': serial number 'xxx"),
    ({"serial": "A/B"}, "contains a path separator"),
    ({"serial": "A\\B"}, "contains a path separator"),
    ({"serial": ["A", "B\u202e"]}, "contains a control character"),
    ({"operator": "Ann\r\nEve"}, "metadata 'operator': operator 'Ann"),
    ({"operator": "o" * 201}, "longer than 200"),
])
def test_lab_strings_are_bounded_and_sanitised(meta, message):
    sensors = len(meta["serial"]) if isinstance(meta.get("serial"), list) else None
    with pytest.raises(AccelcalError, match=message) as info:
        check_lab_metadata(meta, "f.csv", sensors)
    assert str(info.value).startswith("f.csv: ")
    assert len(str(info.value)) < 300


def test_lab_info_from_options_names_the_parameter():
    with pytest.raises(AccelcalError) as info:
        LabInfo(("S" * 1000,))
    assert info.value.parameter == "serial"
    assert info.value.message_for().startswith("--serial: serial number")
    assert LabInfo(("SN 1.2_a-b",), "J. Smith / Lab 3").operator == "J. Smith / Lab 3"


def test_report_titles_and_strings_stay_escaped(tmp_path, capsys):
    rec = tmp_path / "r.json"
    make_record(serial="<b>SN&1", operator='"><img src=x onerror=alert(1)>').save(rec)
    out = tmp_path / "r.html"
    code, _, _ = run(capsys, "report", rec, "--out", out, "--title", "<i>T</i>")
    assert code == 0
    html = out.read_text()
    assert "<img" not in html
    assert "<b>SN" not in html
    assert "<i>T" not in html
    assert "&lt;b&gt;SN&amp;1" in html


def test_history_figure_draws_strings_as_plain_text(tmp_path):
    from accelcal.plotting import save_figure
    from accelcal.plotting.records import history_figure

    rows = [{"id": 1, "date": "2026-01-01T00:00:00+00:00", "method": "m$\\frac{", "name": "K$_",
             "unit": "V$", "estimate": 1.0, "std": 0.1}]
    paths = save_figure(history_figure(rows, "SN-$\\unknown{"), tmp_path, "h")
    assert all(p.stat().st_size > 0 for p in paths)


def test_grids_are_bounded(capsys):
    start = time.perf_counter()
    code, _, err = run(capsys, "model", "eval", "--ai", "0:1e12:1")
    assert_one_line_error(code, err, "--ai: range '0:1e12:1' gives 1,000,000,000,001 values")
    code, _, err = run(capsys, "model", "eval", "--ai", "0:1e400:1")
    assert_one_line_error(code, err, "is not finite")
    code, _, err = run(capsys, "model", "eval", "--ai", "-1e308:1e308:1e-300")
    assert_one_line_error(code, err, "at most 100,000 are allowed")
    assert time.perf_counter() - start < 10
