"""Messy recordings: gaps, NaN runs, duplicated and backwards rows, jitter; each option's
result against a hand computation, every refusal one line with exit status 2."""

import csv
import io
import json

import numpy as np
import pytest

from accelcal.errors import AccelcalError
from accelcal.io.recordings import InputOptions, read_recording
from helpers.cli import refused, run_cli

RATE = 100.0


def _csv(path, t, *cols):
    lines = ["t," + ",".join(f"c{k}" for k in range(len(cols)))]
    for i, ti in enumerate(t):
        lines.append(f"{ti:.6f}," + ",".join("" if np.isnan(c[i]) else repr(float(c[i]))
                                              for c in cols))
    path.write_text("\n".join(lines) + "\n")
    return path


def _read(path, **opts):
    return read_recording(path, InputOptions(time="t", columns=("c0",), unit="g", **opts),
                          channels=1)


def _hand_oadev(segments, m):
    """OADEV at factor m from the m-sample averages of each segment, pooled (by hand)."""
    total, count = 0.0, 0
    for y in segments:
        if len(y) < 2 * m:
            continue  # too short for this tau: contributes nothing
        avg = np.convolve(y, np.ones(m) / m, mode="valid")
        d = avg[m:] - avg[:-m]
        total += float(np.sum(d**2))
        count += d.size
    return np.sqrt(total / (2 * count)), count


def test_allan_deviation_over_gaps_is_the_pooled_sums_of_the_segments(tmp_path, capsys):
    # three segments (400, 5 and 300 samples) with gaps of 20 and 7 samples; allantools
    # has no gap support to compare with: the reference is the definition, by hand
    rng = np.random.default_rng(7)
    y = rng.normal(size=732) + np.linspace(0, 3, 732)
    keep = np.ones(732, dtype=bool)
    keep[400:420] = keep[425:432] = False
    t = np.arange(732) / RATE
    path = _csv(tmp_path / "gap.csv", t[keep], y[keep])
    code, out, err = run_cli(["noise", "adev", path, "--column", "c0", "--time", "t", "--unit",
                              "g", "--gaps", "split", "--taus", "0.01,0.02,0.04",
                              "--format", "csv"], capsys)
    assert code == 0, err
    rows = list(csv.DictReader(io.StringIO(out)))
    segments = [y[:400], y[420:425], y[432:]]
    for row, m in zip(rows, (1, 2, 4), strict=True):
        dev, count = _hand_oadev(segments, m)
        assert int(row["n"]) == count
        assert float(row["dev"]) == pytest.approx(dev, rel=1e-9)
    assert "note: 2 gaps (data rows 401, 406): split into segments" in err
    assert "3 segments (samples 0-400, 400-405, 405-705)" in err
    # averaging over the gap as if it were not there gives another number
    whole, _ = _hand_oadev([y[keep]], 4)
    assert float(rows[2]["dev"]) != pytest.approx(whole, rel=1e-3)


def test_gaps_are_refused_by_default_and_split_for_psd_and_mdev(tmp_path, capsys):
    t = np.r_[np.arange(50), np.arange(60, 110)] / RATE
    path = _csv(tmp_path / "gap.csv", t, np.sin(t * 7))
    base = ["noise", "adev", path, "--column", "c0", "--time", "t", "--unit", "g"]
    refused(base, capsys, "gap of 0.11 s before data row 51")
    refused([*base, "--gaps", "split", "--kind", "mdev"], capsys, "--gaps fill")
    refused(["noise", "psd", path, "--column", "c0", "--time", "t", "--unit", "g",
             "--gaps", "split"], capsys, "consecutive samples")
    refused([*base, "--gaps", "bridge"], capsys, "refuse, split or fill")


def test_fill_interpolates_short_gaps_linearly_and_flags_them(tmp_path):
    t = np.r_[0, 1, 2, 5, 6] / RATE  # two samples missing before the fourth row
    path = _csv(tmp_path / "gap.csv", t, np.array([1.0, 2.0, 4.0, 10.0, 11.0]))
    rec = _read(path, gaps="fill", max_fill=2)
    np.testing.assert_allclose(rec.values[:, 0], [1, 2, 4, 6, 8, 10, 11])
    np.testing.assert_allclose(rec.time, np.arange(7) / RATE, atol=1e-12)
    found = {f["found"]: f for f in rec.provenance["repairs"]["found"]}
    assert found["samples filled in the gaps before"]["count"] == 2
    assert found["gaps"]["first_rows"] == [4]
    with pytest.raises(AccelcalError, match="gap of 2 missing samples before data row 4 is "
                                            "longer than --max-fill 1"):
        _read(path, gaps="fill", max_fill=1)


def test_a_nan_run_is_a_gap_split_or_filled(tmp_path):
    y = np.array([0.0, 1.0, np.nan, np.nan, np.nan, 5.0, 6.0])
    path = _csv(tmp_path / "nan.csv", np.arange(7) / RATE, y)
    with pytest.raises(AccelcalError, match="column c0, data row 3, is empty"):
        _read(path)
    filled = _read(path, gaps="fill", max_fill=3)
    np.testing.assert_allclose(filled.values[:, 0], np.arange(7.0))
    split = _read(path, gaps="split")
    np.testing.assert_allclose(split.values[:, 0], [0, 1, 5, 6])
    assert split.repairs.segments == [(0, 2), (2, 4)]
    nan = split.repairs.findings["rows with an empty or NaN cell"]
    assert (nan.count, nan.rows) == (3, [3, 4, 5])
    # a file without a time column (a one-column CSV skips empty lines: nan written out)
    bare = tmp_path / "bare.csv"
    bare.write_text("c0\n" + "\n".join(repr(float(v)) for v in y) + "\n")  # nan: NaN
    rec = read_recording(bare, InputOptions(columns=("c0",), unit="g", rate=RATE,
                                            gaps="fill", max_fill=3), channels=1)
    np.testing.assert_allclose(rec.values[:, 0], np.arange(7.0))


def test_duplicated_rows_dropped_when_identical_refused_when_not(tmp_path, capsys):
    t = np.array([0, 1, 2, 2, 3, 3]) / RATE
    path = _csv(tmp_path / "dup.csv", t, np.array([1.0, 2.0, 3.0, 3.0, 4.0, 4.0]))
    rec = _read(path)
    np.testing.assert_allclose(rec.values[:, 0], [1, 2, 3, 4])
    dup = rec.repairs.findings["duplicated rows (same time, same values)"]
    assert (dup.count, dup.rows) == (2, [4, 6])
    bad = _csv(tmp_path / "bad.csv", t, np.array([1.0, 2.0, 3.0, 3.5, 4.0, 4.0]))
    refused(["noise", "adev", bad, "--column", "c0", "--time", "t", "--unit", "g"], capsys,
            "data row 4 with different values")
    with pytest.raises(AccelcalError, match=r"repeats 0\.02 s at data row 4 with different"):
        _read(bad)


def test_backwards_rows_refused_with_the_row_or_sorted(tmp_path, capsys):
    t = np.array([0, 1, 3, 2, 4]) / RATE
    path = _csv(tmp_path / "back.csv", t, np.array([0.0, 1.0, 3.0, 2.0, 4.0]))
    refused(["noise", "adev", path, "--column", "c0", "--time", "t", "--unit", "g"], capsys,
            "goes backwards at data row 4", "--sort")
    rec = _read(path, sort=True)
    np.testing.assert_allclose(rec.values[:, 0], np.arange(5.0))
    assert rec.repairs.findings["rows out of time order"].rows == [4]


def test_jitter_beyond_the_tolerance_refused_or_resampled(tmp_path, capsys):
    t = np.array([0.0, 1.0, 2.3, 3.0, 4.0, 5.0]) / RATE  # one step 30 % long, one 30 % short
    y = np.array([0.0, 1.0, 2.0, 4.0, 3.0, 5.0])
    path = _csv(tmp_path / "jit.csv", t, y)
    refused(["noise", "adev", path, "--column", "c0", "--time", "t", "--unit", "g",
             "--jitter-tol", "0.1"], capsys, "data row 3", "--resample")
    assert _read(path, jitter_tol=0.4).samples == 6  # within the tolerance: as read
    rec = _read(path, jitter_tol=0.1, resample=True)
    grid = np.arange(6) / RATE
    np.testing.assert_allclose(rec.time, grid, atol=1e-12)
    np.testing.assert_allclose(rec.values[:, 0], np.interp(grid, t, y))
    assert rec.repairs.findings["jittered intervals"].count == 2
    refused(["noise", "adev", path, "--column", "c0", "--time", "t", "--unit", "g",
             "--resample"], capsys, "jitter")


def test_repairs_go_into_the_record_and_a_split_record_reads_back_as_segments(tmp_path,
                                                                               capsys):
    rng = np.random.default_rng(3)
    y = rng.normal(size=600)
    keep = np.ones(600, dtype=bool)
    keep[250:262] = False
    path = _csv(tmp_path / "gap.csv", np.arange(600)[keep] / RATE, y[keep])
    out = tmp_path / "rec.parquet"
    code, _, err = run_cli(["import", path, "--kind", "noise", "--channels", "a=c0", "--time",
                            "t", "--unit", "g", "--gaps", "split", "--out", out], capsys)
    assert code == 0, err
    assert "note: 2 segments (samples 0-250, 250-588)" in err
    import pyarrow.parquet as pq

    header = json.loads(pq.read_schema(out).metadata[b"accelcal"])
    repairs = header["provenance"]["repairs"]
    assert repairs["segments"] == [[0, 250], [250, 588]]
    assert repairs["found"][0] == {"found": "gaps", "count": 1, "first_rows": [251],
                                   "action": "split into segments"}
    refused(["noise", "adev", out], capsys, "2 segments", "--gaps split")
    code, text, err = run_cli(["noise", "adev", out, "--gaps", "split", "--taus", "0.02",
                               "--format", "csv"], capsys)
    assert code == 0, err
    row = next(csv.DictReader(io.StringIO(text)))
    dev, count = _hand_oadev([y[:250], y[262:]], 2)
    assert (int(row["n"]), float(row["dev"])) == (count, pytest.approx(dev, rel=1e-9))


def test_triad_refuses_a_split_and_reports_a_fill(tmp_path, capsys):
    t = np.r_[np.arange(300), np.arange(302, 600)] / RATE
    noise = np.random.default_rng(5).normal(0, 0.01, (3, t.size))
    path = _csv(tmp_path / "tri.csv", t, noise[0], noise[1], 9.81 + noise[2])
    base = ["triad", "detect", path, "--columns", "c0,c1,c2", "--time", "t", "--unit",
            "m/s^2"]
    refused([*base, "--gaps", "split"], capsys, "static intervals need consecutive samples")
    code, _, err = run_cli([*base, "--gaps", "fill", "--init-static", "1"], capsys)
    assert code == 0, err
    assert "note: 2 samples filled in the gaps before (data rows 301): linear" in err, err


@pytest.mark.parametrize(("args", "words"), [
    (["--max-fill", "0"], ["max_fill"]),
    (["--jitter-tol", "0.7"], ["below 0.5"]),
])
def test_bad_repair_options_are_one_line(tmp_path, capsys, args, words):
    path = _csv(tmp_path / "ok.csv", np.arange(10) / RATE, np.arange(10.0))
    refused(["noise", "adev", path, "--column", "c0", "--time", "t", "--unit", "g", *args],
            capsys, *words)


def test_resampling_across_a_gap_fills_or_splits_as_told(tmp_path):
    t = np.array([0.0, 1.2, 2.0, 3.0, 7.0, 8.0, 9.0]) / RATE  # jitter at row 2, gap before row 5
    y = np.array([0.0, 1.0, 2.0, 3.0, 7.5, 8.0, 9.0])
    path = _csv(tmp_path / "jg.csv", t, y)
    grid = np.arange(10) / RATE
    filled = _read(path, gaps="fill", max_fill=3, jitter_tol=0.1, resample=True)
    np.testing.assert_allclose(filled.values[:, 0], np.interp(grid, t, y))
    split = _read(path, gaps="split", jitter_tol=0.1, resample=True)
    kept = np.r_[0:4, 7:10]  # no grid point inside the gap
    np.testing.assert_allclose(split.time, grid[kept], atol=1e-12)
    np.testing.assert_allclose(split.values[:, 0], np.interp(grid[kept], t, y))
    assert split.repairs.segments == [(0, 4), (4, 7)]


def test_clipped_runs_refused_or_left_out_of_the_allan_deviation(tmp_path, capsys):
    rng = np.random.default_rng(11)
    y = rng.normal(0, 0.3, 500)
    y[200:230] = 1.5  # saturated at the high rail for 30 samples
    y[300] = 1.5      # one sample at the rail: noise, not a clip
    path = _csv(tmp_path / "clip.csv", np.arange(500) / RATE, y)
    base = ["noise", "adev", path, "--column", "c0", "--time", "t", "--unit", "g",
            "--rails", "-1.5,1.5"]
    refused(base, capsys, "30 samples clipped", "data row 201", "--gaps split")
    refused([*base, "--gaps", "fill"], capsys, "not filled")
    code, out, err = run_cli([*base, "--gaps", "split", "--taus", "0.02", "--format", "csv"],
                             capsys)
    assert code == 0, err
    row = next(csv.DictReader(io.StringIO(out)))
    dev, count = _hand_oadev([y[:200], y[230:]], 2)
    assert (int(row["n"]), float(row["dev"])) == (count, pytest.approx(dev, rel=1e-9))
    assert "note: 30 clipped samples (runs of 3 or more at a rail) (data rows 201, 202" in err
    refused([*base[:-2], "--rails", "2,1"], capsys, "low below high")


def test_an_opened_stream_goes_on_from_its_rate_block_and_forgets_it_when_read_anew(
        tmp_path, monkeypatch):
    from accelcal.io.recordings import open_stream, sources
    from accelcal.io.recordings.repairs import Repairs

    t = np.array([0, 1, 2, 2, 3, 3, 4, 5, 6, 7]) / RATE  # rows 4 and 6 repeat the row before
    path = _csv(tmp_path / "dup.csv", t, np.array([1, 2, 3, 3, 4, 4, 5, 6, 7, 8.0]))
    opts = InputOptions(time="t", columns=("c0",), unit="g")
    whole = _read(path)
    batches, read = sources.batches, []

    def counted(*args, **kwargs):
        for batch in batches(*args, **kwargs):
            read.append(len(batch["t"]))
            yield batch

    monkeypatch.setattr(sources, "batches", counted)
    repairs = Repairs()
    stream = open_stream(path, opts, rows=4, repairs=repairs, order="F")
    assert stream.rate == pytest.approx(RATE)
    values = np.concatenate([b.values for b in stream.blocks(4, repairs=repairs, order="F")])
    np.testing.assert_array_equal(values, whole.values)
    assert read == [4, 4, 2]  # the rate's block is the stream's first: each row read once
    assert repairs.to_dict() == whole.repairs.to_dict()
    repairs, read[:] = Repairs(), []
    stream = open_stream(path, opts, rows=4, repairs=repairs)
    values = np.concatenate([b.values for b in stream.blocks(3, repairs=repairs)])
    np.testing.assert_array_equal(values, whole.values)
    assert read == [4, 3, 3, 3, 1]  # other blocks: read anew from the start
    dup = repairs.findings["duplicated rows (same time, same values)"]
    assert (dup.count, dup.rows) == (2, [4, 6])  # not counted twice
