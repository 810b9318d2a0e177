"""``accelcal import`` and ``accelcal inspect`` (issue 17): DAQ files made into records.

Each record is read back by its kind's own reader and compared with what
the DAQ file holds (values exactly, or through the stated unit factor to
1e-15 relative: one multiplication); broken inputs exit 2 with one line and
leave nothing behind.
"""

import hashlib
import json
import tracemalloc

import numpy as np
import pytest

from accelcal.units import STANDARD_GRAVITY
from helpers.cli import refused, run_cli
from helpers.daq_files import RATE, signals, write_hdf5, write_mat5, write_mat73, write_tdms
from helpers.paths import EXAMPLES

XYZ = "acc_x=Accel/X,acc_y=Accel/Y,acc_z=Accel/Z"


def _tdms(tmp_path, **kw):
    acc, temp = signals()
    path = tmp_path / "run.tdms"
    write_tdms(path, acc, temp, **kw)
    return path, acc, temp


def test_tdms_to_a_noise_record(tmp_path, capsys):
    from accelcal.io.formats.noise import read

    path, acc, temp = _tdms(tmp_path)
    out = tmp_path / "still.parquet"
    code, stdout, _ = run_cli(["import", path, "--channels", XYZ, "--kind", "noise", "--serial",
                               "SN-7", "--temperature", "case=Temp/Case", "--out", out,
                               "--format", "json"], capsys)
    assert code == 0
    assert json.loads(stdout)[0]["samples"] == acc.shape[0]
    rec = read(out)
    np.testing.assert_array_equal(rec.values, acc)
    assert (rec.rate, rec.unit, rec.channels) == (RATE, "g", ("acc_x", "acc_y", "acc_z"))
    prov = rec.metadata["provenance"]
    assert rec.metadata["serial"] == "SN-7"
    assert prov["channel_map"]["acc_y"] == "Accel/Y"
    assert prov["start_time"].startswith("2026-11-23T08:00")
    case = prov["temperature_degC"]["case"]  # the mean by an independent route: numpy's
    assert case["mean"] == pytest.approx(np.mean(temp), rel=1e-12)
    assert (case["min"], case["max"]) == (temp.min(), temp.max())


def test_mapping_file_and_command_line_override(tmp_path, capsys):
    from accelcal.io.formats.triad import read

    acc, temp = signals()
    path = tmp_path / "run.h5"
    write_hdf5(path, acc * STANDARD_GRAVITY, temp, unit="m/s^2")
    mapping = tmp_path / "bench3.toml"
    mapping.write_text('input_format = "hdf5"\nkind = "triad"\ntime = "daq/t"\n'
                       '[channels]\nacc_x = "daq/acc[0]"\nacc_y = "daq/acc[1]"\n'
                       'acc_z = "daq/acc[2]"\n[metadata]\nserial = "SN-1"\noperator = "A. Lab"\n')
    out = tmp_path / "triad.csv"
    code, _, err = run_cli(["import", path, "--mapping", mapping, "--serial", "SN-2", "--out",
                            out], capsys)
    assert code == 0, err
    rec = read(out)
    np.testing.assert_allclose(rec.acc, acc * STANDARD_GRAVITY, rtol=1e-15, atol=0)
    np.testing.assert_allclose(rec.t, np.arange(acc.shape[0]) / RATE, rtol=1e-12, atol=1e-15)
    assert rec.input_unit == "m/s^2"
    assert (rec.metadata["serial"], rec.metadata["operator"]) == ("SN-2", "A. Lab")


def test_json_mapping_v5_mat_to_a_tumble_record(tmp_path, capsys):
    import scipy.io

    from accelcal.io.formats.tumble import read

    angles = np.repeat(np.arange(0.0, 360.0, 30.0), 4)
    output = np.sin(np.radians(angles)) * 2.5 + 0.01
    path = tmp_path / "tumble.mat"
    scipy.io.savemat(path, {"pos": angles[:, None], "v": output[:, None] * 1e3})
    mapping = tmp_path / "tumble.json"
    mapping.write_text(json.dumps({
        "kind": "tumble", "unit": "mV",
        "channels": {"angle": {"channel": "pos", "unit": "deg"}, "output": "v"},
        "metadata": {"rotation_axis": "OA"}}))
    out = tmp_path / "tumble.csv"
    code, _, err = run_cli(["import", path, "--mapping", mapping, "--out", out], capsys)
    assert code == 0, err
    rec = read(out)
    assert rec.output_unit == "mV"
    assert rec.repeats == 4
    np.testing.assert_allclose(np.degrees(rec.angles_rad), np.arange(0.0, 360.0, 30.0))
    np.testing.assert_allclose(rec.outputs[:, 0], output[::4] * 1e3, rtol=1e-15)


def test_v73_mat_to_a_shaker_record_converts_the_reference_to_g(tmp_path, capsys):
    from accelcal.io.formats.shaker import read_records

    acc, temp = signals()
    path = tmp_path / "shaker.mat"
    write_mat73(path, np.column_stack([acc[:, 0] * STANDARD_GRAVITY, acc[:, 1], acc[:, 2]]),
                temp)
    mapping = tmp_path / "shaker.toml"
    mapping.write_text(
        'kind = "shaker"\nrate = 1000.0\nunit = "V"\n[channels]\n'
        'ref = { channel = "data[0]", unit = "m/s^2" }\nu = "data[1]"\n'
        '[metadata]\nfrequency_hz = 40.0\nangle_deg = 0.0\namplitude_g = 1.0\ngravity_g = 0.0\n')
    out = tmp_path / "shaker_000.csv"
    code, _, err = run_cli(["import", path, "--mapping", mapping, "--out", out], capsys)
    assert code == 0, err
    (rec,) = read_records(out)
    np.testing.assert_allclose(rec.ref[0], acc[:, 0], rtol=1e-15)
    np.testing.assert_array_equal(rec.u[0], acc[:, 1])
    np.testing.assert_allclose(rec.t, np.arange(acc.shape[0]) / RATE, rtol=1e-15)
    assert rec.output_unit == "V"


def test_csv_to_a_vibrafuge_record_restarts_time_at_each_point(tmp_path, capsys):
    import pandas as pd

    from accelcal.io.formats.vibrafuge import read_vibrafuge

    n = 400
    rng = np.random.default_rng(2)
    df = pd.DataFrame({"pt": np.repeat([0, 1], n), "s": rng.normal(1, 1e-3, 2 * n),
                       "v": rng.normal(1, 1e-3, 2 * n)})
    path = tmp_path / "vib.csv"
    df.to_csv(path, index=False)
    meta = {"frequency_hz": 50.0, "scale_factor": 1.0, "direction": [1, 0, 0],
            "points": [{"overload_g": [5, 0, 0], "amplitude_g": 2.0}] * 2}
    mapping = tmp_path / "vib.json"
    mapping.write_text(json.dumps({
        "kind": "vibrafuge", "rate": 2000.0, "unit": "V", "metadata": meta,
        "channels": {"point": {"channel": "pt", "unit": "-"}, "static": "s",
                     "vibrating": "v"}}))
    out = tmp_path / "vib.parquet"
    code, _, err = run_cli(["import", path, "--mapping", mapping, "--out", out,
                            "--block-rows", "1000"], capsys)
    assert code == 0, err
    run = read_vibrafuge(out)
    np.testing.assert_array_equal(run.static, df.s.to_numpy().reshape(2, n))
    assert run.sample_rate == 2000.0


def test_inspect_lists_channels(tmp_path, capsys):
    path, acc, _ = _tdms(tmp_path)
    code, out, _ = run_cli(["inspect", path, "--format", "json"], capsys)
    assert code == 0
    found = json.loads(out)
    by_name = {c["name"]: c for c in found["channels"]}
    assert set(by_name) == {"Accel/X", "Accel/Y", "Accel/Z", "Temp/Case"}
    assert by_name["Accel/Z"]["length"] == acc.shape[0]
    assert by_name["Accel/Z"]["rate_hz"] == pytest.approx(RATE)
    assert by_name["Temp/Case"]["unit"] == "Deg C"
    code, out, _ = run_cli(["inspect", path], capsys)
    assert "Accel/X" in out
    assert "bench 3" in out
    csv = tmp_path / "a.csv"
    csv.write_text("t;x\n" + "".join(f"{i};{i * 2}\n" for i in range(37)))
    code, out, _ = run_cli(["inspect", csv, "--delimiter", ";", "--format", "json"], capsys)
    assert [c["length"] for c in json.loads(out)["channels"]] == [37, 37]


def _nothing_left(tmp_path, out):
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


@pytest.mark.parametrize(("args", "words"), [
    (["--channels", "acc_x=Accel/X,acc_y=Accel/Q"], ["--channels", "no column Accel/Q"]),
    (["--channels", XYZ, "--unit", "V"], ["--unit", "not V"]),
    (["--channels", XYZ, "--rate", "250"], ["--rate", "1000 Hz"]),
    (["--channels", "acc_x"], ["--channels", "column=channel"]),
    (["--channels", XYZ, "--kind", "tumble"], ["tumble record would not be valid",
                                                "rotation_axis"]),
    (["--channels", "angle=Accel/X,output=Accel/Y", "--kind", "tumble"],
     ["angle must be in deg", "is in g"]),
    (["--channels", XYZ, "--kind", "ferris-wheel"], ["--kind", "not known"]),
])
def test_bad_imports_exit_2_and_write_nothing(tmp_path, capsys, args, words):
    path, *_ = _tdms(tmp_path)
    out = tmp_path / "rec.parquet"
    refused(["import", path, "--out", out, "--kind", "noise", *args], capsys, *words)
    _nothing_left(tmp_path, out)


def test_gap_and_truncation_exit_2(tmp_path, capsys):
    acc, temp = signals()
    path = tmp_path / "gap.h5"
    write_hdf5(path, acc, temp, t=np.r_[np.arange(600), np.arange(700, 1300)] / RATE)
    out = tmp_path / "rec.parquet"
    refused(["import", path, "--channels", "x=daq/acc[0]", "--time", "daq/t", "--kind", "noise",
             "--out", out], capsys, "jumps from", "data row 601")
    _nothing_left(tmp_path, out)
    mat = tmp_path / "cut.mat"
    write_mat5(mat, acc, temp)
    mat.write_bytes(mat.read_bytes()[:-100])
    refused(["import", mat, "--channels", "x=data[0]", "--rate", "1000", "--unit", "g",
             "--kind", "noise", "--out", out], capsys, "truncated")
    _nothing_left(tmp_path, out)


def _import_traced(tmp_path, n: int, rows: int) -> tuple[int, list]:
    """Import ``n`` x 4 samples from HDF5 in blocks of ``rows``: (peak bytes, progress)."""
    import h5py

    from accelcal.io.recordings import InputOptions
    from accelcal.io.recordings.convert import import_recording

    path = tmp_path / f"long{n}.h5"
    with h5py.File(path, "w") as h5:
        ds = h5.create_dataset("acc", shape=(n, 4), dtype="f8", chunks=(rows, 4))
        for s in range(0, n, rows):
            ds[s:s + rows] = np.arange(s, s + rows)[:, None] + np.arange(4) / 8
        ds.attrs["unit"] = "mV"
    seen = []
    tracemalloc.start()
    try:
        import_recording(path, InputOptions(rate=RATE), kind="noise",
                         channels={f"c{k}": f"acc[{k}]" for k in range(4)},
                         out=tmp_path / f"long{n}.parquet", rows=rows,
                         progress=lambda done, total: seen.append((done, total)))
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return peak, seen


def test_long_recording_streams_in_bounded_memory(tmp_path):
    """0.6 M and 1.2 M samples x 4 channels (19 and 38 MB as float64) in blocks of 50,000 rows.

    A first import of a few blocks loads every module an import uses (their code and tables
    are not the recording's memory); then the peak is that of a few blocks (1.6 MB each) and
    of the first rows' probe of the record's check, whatever the recording's length.
    """
    n, rows = 1_200_000, 50_000
    _import_traced(tmp_path, 4 * rows, rows)
    half, _ = _import_traced(tmp_path, n // 2, rows)
    peak, seen = _import_traced(tmp_path, n, rows)
    whole = n * 4 * 8
    assert peak < whole / 3, peak  # never the whole 38 MB
    # flat in the length: memory growing with it would add half the whole (19 MB) between
    # the two; measured 0-2.1 MB (a block or so, as threads and the collector time it)
    assert peak - half < whole / 8, (half, peak)
    assert seen[-1] == (n, n)
    assert [d for d, _ in seen] == list(range(rows, n + 1, rows))
    import pyarrow.parquet as pq

    table = pq.read_table(tmp_path / f"long{n}.parquet")
    assert table.num_rows == n
    assert table.column("c3")[n - 1].as_py() == n - 1 + 3 / 8


def test_dividing_head_import_reduces_as_the_record_it_came_from(tmp_path, capsys):
    # The example indexing-head record's table, as a DAQ would write it (no accelcal header),
    # imported with a mapping file: the reduction of the import equals that of the original
    # (the values pass through unchanged: one factor of 1 for V and deg)

    examples = EXAMPLES
    lines = (examples / "indexing_head.csv").read_text().splitlines()
    daq = tmp_path / "head_daq.csv"
    daq.write_text("\n".join(lines[2:]) + "\n")
    meta = json.loads(lines[1][2:])
    mapping = tmp_path / "head.json"
    mapping.write_text(json.dumps({
        "kind": "dividing-head", "unit": "V",
        "channels": {"angle_deg": {"channel": "angle_deg", "unit": "deg"},
                     **{s: s for s in meta["sensors"]}},
        "metadata": {k: v for k, v in meta.items()
                     if k not in ("format_version", "kind", "units", "sensors")}}))
    out = tmp_path / "head.csv"
    code, _, err = run_cli(["import", daq, "--mapping", mapping, "--out", out], capsys)
    assert code == 0, err
    args = ["--format", "json", "--method", "four"]
    code, imported, err = run_cli(["dividing-head", "reduce", out, *args], capsys)
    assert code == 0, err
    code, original, err = run_cli(["dividing-head", "reduce", examples / "indexing_head.csv",
                                   *args], capsys)
    assert code == 0, err
    assert json.loads(imported) == json.loads(original)


def test_import_prints_whole_period_means_and_sds(tmp_path, capsys):
    # one pass, in blocks of 1,000 rows: the means and SDs of the whole record equal numpy's
    # on the values read back (shifted sums: 1e-12 relative on an offset of 1e4 x the SD)
    import pandas as pd

    rng = np.random.default_rng(7)
    n = 5_500
    df = pd.DataFrame({"X": 100.0 + rng.normal(0, 0.01, n), "Y": rng.normal(0, 1.0, n),
                       "Z": -50.0 + rng.normal(0, 0.1, n)})
    src = tmp_path / "daq.csv"
    df.to_csv(src, index=False)
    out = tmp_path / "triad.csv"
    code, text, err = run_cli(["import", src, "--kind", "triad", "--channels",
                               "acc_x=X,acc_y=Y,acc_z=Z", "--rate", "100", "--unit", "g",
                               "--block-rows", "1000", "--out", out, "--format", "json"],
                              capsys)
    assert code == 0, err
    (row,) = json.loads(text)
    for col, name in (("acc_x", "X"), ("acc_y", "Y"), ("acc_z", "Z")):
        values = df[name].to_numpy()
        assert row[f"mean_{col}"] == pytest.approx(values.mean(), rel=1e-12)
        assert row[f"sd_{col}"] == pytest.approx(values.std(ddof=1), rel=1e-10)


@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
def test_long_stream_record_is_checked_by_a_probe_and_its_row_count(tmp_path, monkeypatch,
                                                                      suffix):
    """A noise record longer than the probe: the reader checks the probe's rows, the count
    of rows comes from the Parquet footer (no second read of the samples) or, for a CSV
    record, from streaming it back; a count that disagrees refuses the record."""
    from accelcal.errors import AccelcalError
    from accelcal.io.formats.noise import read
    from accelcal.io.recordings import InputOptions, sources
    from accelcal.io.recordings.convert import PROBE_ROWS, import_recording

    n = PROBE_ROWS + 1234
    acc, temp = signals(n)
    path = tmp_path / "run.tdms"
    write_tdms(path, acc, temp)
    out = tmp_path / f"p{suffix}"  # the probe beside it takes another name
    channels = {"x": "Accel/X", "y": "Accel/Y", "z": "Accel/Z"}
    done = import_recording(path, InputOptions(), kind="noise", channels=channels, out=out,
                            rows=20_000)
    assert done["samples"] == n
    rec = read(out)
    np.testing.assert_array_equal(rec.values, acc)
    # the digest, read in a thread, is in the header: a CSV record's first lines, a Parquet
    # record's footer (written after the last row group)
    digest = hashlib.sha256(path.read_bytes()).hexdigest()
    assert done["provenance"]["sha256"] == digest
    assert rec.metadata["provenance"]["sha256"] == digest
    assert list(rec.metadata["provenance"])[:2] == ["file", "sha256"]
    if suffix == ".parquet":  # the footer is what is counted
        monkeypatch.setattr(sources, "parquet_rows", lambda p: n - 1)
        with pytest.raises(AccelcalError, match=f"{n - 1} samples read back of {n} written"):
            import_recording(path, InputOptions(), kind="noise", channels=channels,
                             out=tmp_path / "again.parquet", rows=20_000)
        assert not (tmp_path / "again.parquet").exists()
