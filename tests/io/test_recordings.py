"""A lab's recordings as input (accelcal.io.recordings): formats, options, checks, streaming.

Files are written here by the libraries a lab's tools use (pandas, pyarrow)
and read back; the real imucal session of tests/fixtures/real/imucal is read
as imucal writes it. Every refusal is one AccelcalError naming the file, the
column or row and the parameter to fix.
"""

import hashlib
import json

import numpy as np
import pandas as pd
import pytest

from accelcal.errors import AccelcalError
from accelcal.io.recordings import (
    InputOptions,
    describe,
    iter_blocks,
    open_stream,
    read_recording,
)
from accelcal.io.records import write_record
from accelcal.units import STANDARD_GRAVITY
from helpers.paths import REAL_IMUCAL

REAL = REAL_IMUCAL
SESSION = REAL / "example_ferraris_session.csv"
REGIONS = REAL / "example_ferraris_session_list.json"



def table(n=500, seed=0):
    rng = np.random.default_rng(seed)
    return pd.DataFrame({"time_ms": np.arange(n) * 10.0 + 1000.0,
                         "X": rng.normal(0, 1, n), "Y": rng.normal(0, 1, n),
                         "Z": rng.normal(9.8, 1, n), "temp": rng.normal(25, 1, n)})


def test_real_imucal_session_with_regions():
    rec = read_recording(SESSION, InputOptions(rate=102.4, regions=REGIONS), channels=3)
    raw = pd.read_csv(SESSION)
    assert rec.provenance["input_format"] == "imucal"
    assert rec.unit == "m/s^2"
    assert rec.channels == ("acc_x", "acc_y", "acc_z")
    np.testing.assert_array_equal(rec.values, raw[["acc_x", "acc_y", "acc_z"]].to_numpy())
    spans = json.loads(REGIONS.read_text())
    assert rec.regions == {k: (v["start"], v["end"]) for k, v in spans.items()}
    assert rec.provenance["sha256"] == hashlib.sha256(SESSION.read_bytes()).hexdigest()
    # x pointing up: the x channel reads about +g in the region imucal labels x_p
    s, e = rec.regions["x_p"]
    assert rec.values[s:e, 0].mean() == pytest.approx(9.81, abs=0.6)


def test_imucal_part_column_labels(tmp_path):
    raw = pd.read_csv(SESSION)
    spans = json.loads(REGIONS.read_text())
    part = np.full(len(raw), "", dtype=object)
    for label, span in spans.items():
        part[span["start"]:span["end"]] = label
    raw["part"] = part
    path = tmp_path / "labelled.csv"
    raw.to_csv(path, index=False)
    rec = read_recording(path, InputOptions(rate=102.4))
    assert rec.labels is not None
    assert set(np.unique(rec.labels)) == {"", *spans}
    assert (rec.labels[spans["z_a"]["start"]:spans["z_a"]["end"]] == "z_a").all()


def test_csv_columns_time_in_ms_and_delimiter(tmp_path):
    df = table()
    path = tmp_path / "daq.csv"
    df.to_csv(path, sep=";", index=False)
    opts = InputOptions(columns=("X", "Y", "Z"), time="time_ms", time_unit="ms", unit="g",
                        delimiter=";")
    rec = read_recording(path, opts, channels=3)
    np.testing.assert_allclose(rec.values, df[["X", "Y", "Z"]].to_numpy(), rtol=0, atol=0)
    np.testing.assert_allclose(rec.time, (df.time_ms - 1000.0) / 1000.0, rtol=0, atol=1e-15)
    assert rec.rate == pytest.approx(100.0, rel=1e-12)
    np.testing.assert_allclose(rec.in_si(), rec.values * STANDARD_GRAVITY, rtol=1e-15)
    assert rec.gaps().size == 0


def test_parquet_reads_as_the_csv(tmp_path):
    df = table()
    df.to_parquet(tmp_path / "daq.parquet")
    df.to_csv(tmp_path / "daq.csv", index=False)
    opts = InputOptions(columns=("X", "Y", "Z"), time="time_ms", time_unit="ms", unit="mg")
    a = read_recording(tmp_path / "daq.parquet", opts)
    b = read_recording(tmp_path / "daq.csv", opts)
    assert a.provenance["input_format"] == "parquet"
    assert b.provenance["input_format"] == "csv"
    np.testing.assert_array_equal(a.values, b.values)
    np.testing.assert_array_equal(a.time, b.time)


def test_imu_tk_whitespace_rows(tmp_path):
    rng = np.random.default_rng(3)
    data = np.column_stack([np.arange(200) * 0.01, rng.normal(0, 3000, (200, 3))])
    lines = ["  ".join(f"{v:.9g}" for v in row) if k % 2 else "\t".join(f"{v:.9g}" for v in row)
             for k, row in enumerate(data)]
    path = tmp_path / "xsens_acc.mat"
    path.write_text("\n".join(lines) + "\n")
    rec = read_recording(path, InputOptions(unit="counts"))
    assert rec.provenance["input_format"] == "imu_tk"
    np.testing.assert_allclose(rec.values, data[:, 1:], rtol=1e-8)
    assert rec.rate == pytest.approx(100.0, rel=1e-9)
    with pytest.raises(AccelcalError, match="not an acceleration"):
        rec.in_si()


def test_streamed_blocks_equal_the_whole(tmp_path):
    df = table(n=1003)
    path = tmp_path / "daq.csv"
    df.to_csv(path, index=False)
    opts = InputOptions(columns=("X", "Y", "Z"), time="time_ms", time_unit="ms", unit="g")
    whole = read_recording(path, opts)
    blocks = list(iter_blocks(path, opts, rows=100))
    assert [b.start for b in blocks] == list(range(0, 1003, 100))
    np.testing.assert_array_equal(np.concatenate([b.values for b in blocks]), whole.values)
    np.testing.assert_array_equal(np.concatenate([b.time for b in blocks]), whole.time)
    prov, rate = describe(path, opts)
    assert rate == whole.rate
    assert prov["sha256"] == whole.provenance["sha256"]


def test_blocks_in_column_order_and_an_opened_stream_give_the_same_values(tmp_path):
    df = table(n=1003)
    path = tmp_path / "daq.csv"
    df.to_csv(path, index=False)
    opts = InputOptions(columns=("X", "Y", "Z"), time="time_ms", time_unit="ms", unit="g",
                        scale=2.0)
    rows_first = list(iter_blocks(path, opts, rows=100))
    stream = open_stream(path, opts, digest=False)
    columns_first = list(stream.blocks(100, order="F"))
    assert [b.start for b in columns_first] == [b.start for b in rows_first]
    for a, b in zip(rows_first, columns_first, strict=True):
        assert a.values.flags.c_contiguous
        assert b.values.flags.f_contiguous
        np.testing.assert_array_equal(b.values, a.values)
        np.testing.assert_array_equal(b.time, a.time)
    assert (stream.provenance, stream.rate) == describe(path, opts, digest=False)
    with pytest.raises(ValueError, match="order"):
        next(iter_blocks(path, opts, order="A"))


def test_accelcal_record_is_read_with_its_metadata(tmp_path):
    t = np.arange(50) / 200.0
    path = tmp_path / "triad.csv"
    write_record(path, "triad", {"units": {"t": "s", "acc_x": "V", "acc_y": "V", "acc_z": "V"},
                                 "input_unit": "V"},
                 {"t": t, "acc_x": t, "acc_y": 2 * t, "acc_z": 3 * t})
    rec = read_recording(path)
    assert rec.provenance["input_format"] == "record"
    assert rec.metadata["kind"] == "triad"
    assert rec.unit == "V"
    assert rec.rate == pytest.approx(200.0)
    np.testing.assert_allclose(rec.values[:, 2], 3 * t)


@pytest.mark.parametrize(("body", "opts", "match", "param"), [
    ("a,b\n1,2\n", {"columns": ("a", "c"), "unit": "g", "rate": 1.0}, "no column c", "columns"),
    ("a,b\n1,2\n,3\n", {"columns": ("a", "b"), "unit": "g", "rate": 1.0},
     "column a, data row 2", None),
    ("a,b\n1,2\nnan,3\n", {"columns": ("a", "b"), "unit": "g", "rate": 1.0},
     "data row 2", None),
    ("t,a\n0,1\n2,1\n1,1\n", {"columns": ("a",), "unit": "g", "time": "t"},
     "goes backwards at data row 3", None),
    ("t,a\n0,1\n1,1\n1,2\n", {"columns": ("a",), "unit": "g", "time": "t"},
     "repeats 1 s at data row 3 with different values", None),
    ("a,b\n1,2\n", {"columns": ("a", "b"), "rate": 1.0}, "unit of the values", "unit"),
    ("a,b\n1,2\n", {"columns": ("a", "b"), "unit": "g"}, "sample rate", "rate"),
    ("a,b\n1,2\n", {"columns": ("a", "b"), "unit": "g", "time": "z"}, "no time column z", "time"),
    ("a,b\n", {"columns": ("a", "b"), "unit": "g", "rate": 1.0}, "no samples", None),
    ("", {"columns": ("a",), "unit": "g", "rate": 1.0}, "is empty", None),
    ("1,2\n3,4\n", {"columns": ("a",), "unit": "g", "rate": 1.0}, "not a header", None),
    ("a,b\n1,x\n", {"columns": ("a", "b"), "unit": "g", "rate": 1.0}, "b", None),
    ("a,b\n1,2\n", {"unit": "g", "rate": 1.0}, "say which columns", "columns"),
])
def test_bad_tables_are_refused_in_one_line(tmp_path, body, opts, match, param):
    path = tmp_path / "bad.csv"
    path.write_text(body)
    with pytest.raises(AccelcalError, match=match) as info:
        read_recording(path, InputOptions(input_format="csv", **opts))
    assert "\n" not in str(info.value)
    assert info.value.parameter == param


@pytest.mark.parametrize(("opts", "param"), [
    ({"input_format": "xls"}, "input_format"),
    ({"unit": "furlong"}, "unit"),
    ({"time_unit": "h"}, "time_unit"),
    ({"rate": 0.0}, "rate"),
    ({"rate": float("nan")}, "rate"),
    ({"rate": 10.0, "time": "t"}, "rate"),
    ({"delimiter": ";;"}, "delimiter"),
    ({"columns": ("a", "a")}, "columns"),
    ({"columns": ("a", " ")}, "columns"),
])
def test_bad_options_name_their_parameter(opts, param):
    with pytest.raises(AccelcalError) as info:
        InputOptions(**opts)
    assert info.value.parameter == param


def test_channel_count_and_binary_files(tmp_path):
    path = tmp_path / "two.csv"
    path.write_text("a,b\n1,2\n")
    with pytest.raises(AccelcalError, match="needs 3 column") as info:
        read_recording(path, InputOptions(columns=("a", "b"), unit="g", rate=1.0), channels=3)
    assert info.value.parameter == "columns"
    binary = tmp_path / "bin.csv"
    binary.write_bytes(b"\xff\xfe\x00garbage\n")
    with pytest.raises(AccelcalError, match=r"not UTF-8|not a text table"):
        read_recording(binary, InputOptions(columns=("a",), unit="g", rate=1.0))
    with pytest.raises(AccelcalError, match="not a readable Parquet"):
        read_recording(binary, InputOptions(input_format="parquet", columns=("a",), unit="g",
                                            rate=1.0))


@pytest.mark.parametrize(("regions", "match"), [
    ({"x_p": {"start": 5, "end": 2}}, "0 <= i < j"),
    ({"x_p": {"start": 0, "end": 10**9}}, "0 <= i < j"),
    ({"x_p": [0, 10]}, "must be"),
    ([], "must hold an object"),
])
def test_bad_regions_are_refused(tmp_path, regions, match):
    path = tmp_path / "regions.json"
    path.write_text(json.dumps(regions))
    with pytest.raises(AccelcalError, match=match) as info:
        read_recording(SESSION, InputOptions(rate=102.4, regions=path))
    assert info.value.parameter == "regions"


def test_time_that_overflows_is_refused(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("t,a,b,c\n-1e308,1,2,3\n1e308,1,2,3\n")
    with pytest.raises(AccelcalError, match="data row 2, is empty or not a finite"):
        read_recording(path, InputOptions(columns=("a", "b", "c"), time="t", unit="g"))


def test_the_finite_check_passes_a_sum_that_overflows_and_finds_a_nan_among_large_values():
    from accelcal.io.recordings.checks import check_values

    large = np.full((20, 2), 1e308)  # finite samples whose sum overflows
    check_values(large, ("a", "b"), 0, "f.csv")
    large[13, 1] = np.nan
    with pytest.raises(AccelcalError, match=r"column b, data row 14,"):
        check_values(large, ("a", "b"), 0, "f.csv")
    pair = np.array([[np.inf, 1.0], [-np.inf, 1.0]])  # the sum is NaN: searched, found
    with pytest.raises(AccelcalError, match=r"column a, data row 1,"):
        check_values(pair, ("a", "b"), 0, "f.csv")
