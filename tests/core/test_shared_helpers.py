"""Shared numerical helpers: least squares with covariance, whole-period means, record files."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from accelcal import AccelcalError
from accelcal.fitting import least_squares
from accelcal.io.records import read_record, write_record
from accelcal.results import Estimate
from accelcal.signal.periods import whole_period_mean, whole_period_samples


def test_least_squares_matches_numpy_and_textbook_covariance():
    rng = np.random.default_rng(3)
    A = rng.normal(size=(40, 4))
    y = A @ np.array([1.0, -2.0, 0.5, 3.0]) + rng.normal(0, 0.1, 40)
    est = least_squares(A, y, ["a", "b", "c", "d"], {"a": "V"}, "test")
    x_np, *_ = np.linalg.lstsq(A, y, rcond=None)
    # Same problem solved by two routes (QR vs SVD): agree to ~1e3 eps.
    np.testing.assert_allclose(est.values, x_np, rtol=1e-12, atol=1e-13)
    r = y - A @ x_np
    cov = np.linalg.inv(A.T @ A) * (r @ r) / (40 - 4)
    np.testing.assert_allclose(est.covariance, cov, rtol=1e-10)
    assert est.dof == 36
    assert est["b"] == est.values[1]
    assert est.std_of("c") == pytest.approx(np.sqrt(cov[2, 2]), rel=1e-10)
    assert est.rows()[0]["unit"] == "V"


def test_weighted_least_squares_uses_known_sigma():
    A = np.column_stack([np.ones(10), np.arange(10.0)])
    est = least_squares(A, 2 + 0.5 * np.arange(10.0), ["c", "m"], {}, "w", sigma=0.2)
    np.testing.assert_allclose(est.covariance, 0.04 * np.linalg.inv(A.T @ A), rtol=1e-12)


def test_least_squares_refuses_rank_deficiency_and_no_dof():
    A = np.column_stack([np.ones(5), 2 * np.ones(5)])
    with pytest.raises(AccelcalError, match="rank 1 < 2 unknowns"):
        least_squares(A, np.ones(5), ["a", "b"], {}, "fit")
    with pytest.raises(AccelcalError, match="no degrees of freedom"):
        least_squares(np.eye(2), np.ones(2), ["a", "b"], {}, "fit")


def test_least_squares_covariance_matches_monte_carlo():
    # Known sigma: the formal covariance must equal the scatter of estimates
    # over many noise draws (vectorised: all trials in one solve).
    rng = np.random.default_rng(11)
    t = np.linspace(0, 1, 30)
    A = np.column_stack([np.ones_like(t), t, t**2])
    est = least_squares(A, A @ [1.0, 2.0, 3.0], ["a", "b", "c"], {}, "mc", sigma=0.05)
    trials = 20000
    y = A @ np.array([1.0, 2.0, 3.0]) + rng.normal(0, 0.05, (trials, 30))
    x, *_ = np.linalg.lstsq(A, y.T, rcond=None)
    emp = np.cov(x)
    # Relative SE of a variance from 20000 samples is sqrt(2/20000) = 1 %; allow 5 %.
    np.testing.assert_allclose(np.diag(emp), np.diag(est.covariance), rtol=0.05)


def test_estimate_validates_shapes_and_is_read_only():
    with pytest.raises(ValueError, match="2 names need values of shape"):
        Estimate(("a", "b"), np.zeros(3), np.eye(2), {}, "m")
    est = Estimate(("a",), np.ones(1), np.eye(1), {}, "m")
    with pytest.raises(ValueError, match="read-only"):
        est.values[0] = 2.0


@settings(max_examples=40, deadline=None)
@given(
    phase=st.floats(0, 2 * np.pi),
    per_period=st.integers(8, 200),
    periods=st.integers(1, 20),
    extra=st.integers(0, 7),
    mean=st.floats(-10, 10),
)
def test_whole_period_mean_removes_any_phase_exactly(phase, per_period, periods, extra, mean):
    fs, f = 1000.0, 1000.0 / per_period
    n = periods * per_period + min(extra, per_period - 1)
    t = np.arange(n) / fs
    x = mean + 3.0 * np.sin(2 * np.pi * f * t + phase) + 0.2 * np.cos(4 * np.pi * f * t + phase)
    r = whole_period_mean(x, fs, f)
    assert r.samples == periods * per_period
    assert r.discarded == n - r.samples
    # Discrete orthogonality over whole periods: only rounding remains
    # (n terms of size ~3 each: n * 3 * eps).
    assert r.mean == pytest.approx(mean, abs=n * 3.2 * 2.3e-16 + 1e-15)


def test_whole_period_mean_uncertainty_matches_noise():
    rng = np.random.default_rng(5)
    fs, f, n = 2000.0, 50.0, 4000
    t = np.arange(n) / fs
    x = 1.0 + np.sin(2 * np.pi * f * t) + rng.normal(0, 1e-3, (500, n))
    r = whole_period_mean(x, fs, f)
    # Formal std = sigma / sqrt(n); the scatter of 500 means agrees within 15 %
    # (relative SE of an SD from 500 samples is 3.2 %).
    assert np.std(r.mean) == pytest.approx(1e-3 / np.sqrt(n), rel=0.15)
    assert np.mean(r.std) == pytest.approx(1e-3 / np.sqrt(n), rel=0.02)


def test_whole_period_uncertainty_ignores_a_periodic_signal_of_any_order():
    # A square wave (sgn of a sine: harmonics of every odd order) plus white
    # noise: synchronous averaging removes all of the wave, so the stated
    # uncertainty is the noise's; a fit of a few harmonics would leave most
    # of the wave's higher harmonics in the "noise" (here ~50x too large).
    rng = np.random.default_rng(6)
    fs, f, n = 1000.0, 10.0, 10_000
    t = np.arange(n) / fs
    x = 1e-3 * np.sign(np.sin(2 * np.pi * f * t + 0.3)) + rng.normal(0, 1e-6, (300, n))
    r = whole_period_mean(x, fs, f)
    # 300 records: relative SE of the mean stated SD is tiny; 3 % tolerance.
    assert np.mean(r.std) == pytest.approx(1e-6 / np.sqrt(n), rel=0.03)
    assert np.std(r.mean) == pytest.approx(1e-6 / np.sqrt(n), rel=0.15)


def test_whole_period_errors():
    with pytest.raises(AccelcalError, match="shorter than one period"):
        whole_period_samples(50, 1000.0, 10.0, what="vib")
    with pytest.raises(AccelcalError, match="Nyquist"):
        whole_period_samples(500, 100.0, 60.0)
    with pytest.raises(AccelcalError, match="no whole number of periods"):
        whole_period_samples(1000, 1000.0, 1000.0 / np.pi)
    with pytest.raises(AccelcalError, match="sample 3 is not finite"):
        whole_period_mean([0, 1, 2, np.nan, 1, 2, 3, 4], 8.0, 1.0)
    assert whole_period_samples(1000, 1000.0, 30.0) == (30, 1000)


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_record_round_trip_and_validation(tmp_path, suffix):
    path = tmp_path / f"r{suffix}"
    cols = {"t": np.arange(5) / 3.0, "u": np.array([0.1, -2e-300, 1.0, 3.5, 1 / 7])}
    write_record(path, "demo", {"units": {"t": "s", "u": "V"}, "fs": 3.0}, cols)
    meta, back = read_record(path, "demo", required_metadata=["fs"], required_columns=["u"])
    assert meta["fs"] == 3.0
    assert meta["format_version"] == 1
    for k, column in cols.items():
        np.testing.assert_array_equal(back[k], column)
    with pytest.raises(AccelcalError, match="kind is 'demo', expected 'shaker'"):
        read_record(path, "shaker")
    with pytest.raises(AccelcalError, match="metadata lacks f"):
        read_record(path, "demo", required_metadata=["f"])
    with pytest.raises(AccelcalError, match="missing column\\(s\\) ref"):
        read_record(path, "demo", required_columns=["ref"])


def test_csv_record_cell_errors_name_line_and_column(tmp_path):
    path = tmp_path / "r.csv"
    cols = {"t": np.arange(5) / 3.0, "u": np.array([0.1, -2e-300, 1.0, 3.5, 1 / 7])}
    write_record(path, "demo", {"units": {"t": "s", "u": "V"}}, cols)
    lines = path.read_text().splitlines()
    lines[5] = lines[5].split(",")[0] + ",abc"
    path.write_text("\n".join(lines))
    with pytest.raises(AccelcalError, match="line 6, column u: 'abc' is not a number"):
        read_record(path, "demo")
    lines[5] = "1.0"
    path.write_text("\n".join(lines))
    with pytest.raises(AccelcalError, match="line 6 has 1 values, expected 2"):
        read_record(path, "demo")
    with pytest.raises(AccelcalError, match="no unit for column"):
        write_record(tmp_path / "x.csv", "demo", {"units": {}}, {"t": [1.0]})
    assert not (tmp_path / "x.csv").exists()


def test_parquet_record_errors(tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    bare = tmp_path / "bare.parquet"
    pq.write_table(pa.table({"u": [1.0]}), bare)
    with pytest.raises(AccelcalError, match="no 'accelcal' metadata"):
        read_record(bare, "demo")
    meta = {"accelcal": '{"format_version": 1, "kind": "demo", "units": {"u": "V"}}'}
    nan = tmp_path / "nan.parquet"
    pq.write_table(pa.table({"u": [1.0, float("nan")]}).replace_schema_metadata(meta), nan)
    with pytest.raises(AccelcalError, match="row 1, column u: value is not finite"):
        read_record(nan, "demo")
    text = tmp_path / "text.parquet"
    pq.write_table(pa.table({"u": ["a"]}).replace_schema_metadata(meta), text)
    with pytest.raises(AccelcalError, match="column u has type string"):
        read_record(text, "demo")
    junk = tmp_path / "junk.parquet"
    junk.write_bytes(b"PAR1 not really")
    with pytest.raises(AccelcalError, match="cannot read Parquet record"):
        read_record(junk, "demo")


@pytest.mark.fuzz
@settings(max_examples=150, deadline=None)
@given(data=st.binary(max_size=400), cut=st.integers(0, 400), text=st.text(max_size=60))
def test_fuzzed_csv_records_fail_only_with_the_documented_error(tmp_path_factory, data, cut, text):
    # Start from a valid file and damage it: truncate, splice bytes or text in.
    path = tmp_path_factory.mktemp("fuzz") / "r.csv"
    write_record(path, "demo", {"units": {"t": "s", "u": "V"}},
                 {"t": np.arange(4.0), "u": np.ones(4)})
    raw = path.read_bytes()
    damaged = raw[:cut] + data + text.encode("utf-8", "replace") + raw[cut:]
    path.write_bytes(damaged)
    error = None
    try:
        meta, cols = read_record(path, "demo", required_columns=["u"])
    except AccelcalError as exc:  # the documented error, naming the file
        error = str(exc)
    if error is not None:
        assert str(path) in error
    else:
        assert meta["kind"] == "demo"
        assert all(np.isfinite(c).all() for c in cols.values())
