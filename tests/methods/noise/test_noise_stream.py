"""Long records in bounded memory: the streamed phase, deviations and fit equal the in-memory ones.

The phase is built over fixed chunks at absolute positions, so the
streamed result is the same to the last bit whatever the block size, and
the same as :func:`accelcal.methods.noise.stream.deviation_of_samples` in
memory; against :func:`accelcal.signal.allan.deviations.deviation` (whose
phase subtracts the whole record's mean instead of the first chunk's) the
deviations agree to rounding (1e-9 relative: the phase's rounding at
1e5 samples is ~1e-16 x 1e5 x the noise).
"""

import os

import numpy as np
import pytest

from accelcal.errors import AccelcalError
from accelcal.io.formats import noise as noise_format
from accelcal.io.recordings import InputOptions
from accelcal.methods.noise.fit import fit
from accelcal.methods.noise.stream import (
    CHUNK,
    deviation_of_samples,
    phase_of,
    stream_deviation,
    stream_fit,
)
from accelcal.rigs.noise import simulate
from accelcal.signal.allan.deviations import deviation

RATE = 50.0


@pytest.fixture(scope="module")
def record(tmp_path_factory):
    rec = simulate(N=3e-5, B=2e-6, K=4e-7, bias=0.02, rate=RATE, duration=2 * CHUNK / RATE + 7.3,
                   seed=9)
    path = tmp_path_factory.mktemp("noise") / "still.parquet"
    noise_format.write(path, rec)
    return rec, path


def test_streamed_equals_in_memory_exactly(record, tmp_path):
    rec, path = record
    y = rec.values[:, 0]
    small, _, prov = stream_deviation(path, rows=1000, tmpdir=tmp_path)
    large, _, _ = stream_deviation(path, rows=10**7, tmpdir=tmp_path)
    memory = deviation_of_samples(y, RATE)
    for got in (small, large):
        for name in ("tau", "m", "n", "dev", "alpha", "edf", "lo", "hi"):
            np.testing.assert_array_equal(getattr(got, name), getattr(memory, name))
    assert prov["samples"] == y.size
    assert prov["mean"] == pytest.approx(np.mean(y), rel=1e-12)
    assert os.listdir(tmp_path) == []  # the temporary phase file is removed


def test_streamed_agrees_with_the_deviation_core(record):
    rec, path = record
    y = rec.values[:, 0]
    got, _, _ = stream_deviation(path, rows=4096)
    want = deviation(y, RATE)
    np.testing.assert_allclose(got.dev, want.dev, rtol=1e-9)
    np.testing.assert_array_equal(got.alpha, want.alpha)
    np.testing.assert_array_equal(got.n, want.n)


def test_phase_chunks_independent_of_blocks():
    y = np.random.default_rng(1).normal(5.0, 1.0, 3 * CHUNK + 11)
    x = phase_of(y)
    assert x.size == y.size + 1
    assert x[0] == 0.0
    np.testing.assert_allclose(np.diff(x), y - np.mean(y[:CHUNK]), atol=1e-9)


def test_stream_fit_equals_in_memory_fit(record):
    rec, path = record
    y = rec.values[:, 0]
    got = stream_fit(path, rows=3000, terms=("N", "B", "K"))
    want = fit(y, RATE, terms=("N", "B", "K"), unit="g")
    for name in ("N", "B", "K", "bias"):
        assert got.value(name) == pytest.approx(want.value(name), rel=1e-6, abs=1e-15)
    np.testing.assert_allclose(got.observations["psd"], want.observations["psd"], rtol=1e-6)
    assert got.provenance["input"]["sha256"]


def test_csv_with_time_column_and_gap(tmp_path):
    y = np.random.default_rng(2).normal(size=2000)
    t = np.arange(2000) / RATE
    good = tmp_path / "good.csv"
    np.savetxt(good, np.column_stack([t, y]), delimiter=",", header="t,acc", comments="")
    opts = InputOptions(input_format="csv", columns=("acc",), time="t", unit="g")
    dev, _, _ = stream_deviation(good, opts, rows=300)
    np.testing.assert_allclose(dev.dev, deviation(y, RATE).dev, rtol=1e-9)
    t_gap = t.copy()
    t_gap[1500:] += 1.0
    bad = tmp_path / "gap.csv"
    np.savetxt(bad, np.column_stack([t_gap, y]), delimiter=",", header="t,acc", comments="")
    with pytest.raises(AccelcalError, match="gap"):
        stream_deviation(bad, opts, rows=300)


def test_memory_kinds_refused_in_stream(record):
    _, path = record
    with pytest.raises(AccelcalError, match="memory"):
        stream_deviation(path, kind="mdev")
