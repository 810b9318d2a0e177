"""Static-interval detection of a triad recording (issue 12 item 2, Tedaldi 2014 sec. III)."""

import time

import numpy as np
import pytest

from accelcal.errors import AccelcalError
from accelcal.signal.static import detect_static, figure, moving_variance, variance_magnitude

G = 9.80665


def recording(ups, *, hold=6.0, move=2.0, init=10.0, rate=100.0, noise=0.01, offset=0.0,
              seed=0):
    """A triad held at ``ups`` (unit vectors) in turn, turning along great circles between them.

    Returns the samples and the true hold ranges (start, stop) in samples; the first hold
    lasts ``init`` seconds (the still period at the start).
    """
    rng = np.random.default_rng(seed)
    parts, holds, n = [], [], 0
    ups = [np.asarray(u, float) / np.linalg.norm(u) for u in ups]
    for k, up in enumerate(ups):
        m = round((init if k == 0 else hold) * rate)
        parts.append(np.tile(G * up, (m, 1)))
        holds.append((n, n + m))
        n += m
        if k + 1 < len(ups):
            nxt = ups[k + 1]
            m = round(move * rate)
            s = 0.5 - 0.5 * np.cos(np.pi * np.arange(1, m + 1) / (m + 1))  # smooth start/stop
            path = (1 - s)[:, None] * up + s[:, None] * nxt + 0.3 * np.sin(np.pi * s)[:, None]
            parts.append(G * path / np.linalg.norm(path, axis=1, keepdims=True))
            n += m
    u = np.concatenate(parts) + offset + rng.normal(0.0, noise, (n, 3))
    return u, holds


UPS = [(0, 0, 1), (1, 0, 0), (0, 1, 0), (-1, 0, 0), (0, -1, 0), (0, 0, -1), (1, 1, 1),
       (-1, 1, -1), (1, -1, 1)]


@pytest.mark.parametrize(("rate", "window"), [(100.0, 1.0), (250.0, 2.0), (102.4, 1.0)])
def test_intervals_are_recovered_within_the_window(rate, window):
    u, holds = recording(UPS, rate=rate)
    found = detect_static(u, rate, init_static=8.0, window=window, unit="m/s^2")
    assert len(found) == len(holds)
    w = window * rate
    for (a, b), start, stop in zip(holds, found.start, found.stop, strict=True):
        # the centred window sees the motion half a window early; bounds stay inside the hold
        assert a <= start <= a + w
        assert b - w <= stop <= b
    # means: the true vector within 5 standard errors of the mean (noise 0.01, >= 400 samples)
    true = np.array([G * np.asarray(v) / np.linalg.norm(v) for v in UPS])
    se = 0.01 / np.sqrt(found.counts)[:, None]
    assert np.all(np.abs(found.means - true) < 5 * se)
    # noise SD: relative error of an SD from m samples is 1/sqrt(2(m-1)) < 4 %: allow 15 %
    assert np.allclose(found.noise_sd, 0.01, rtol=0.15)
    assert np.allclose(found.times[:, 0], found.start / rate)
    assert np.allclose(found.lengths, found.counts / rate)


def test_the_time_column_gives_the_times():
    u, _ = recording(UPS[:4])
    t = 5.0 + np.arange(len(u)) / 100.0
    found = detect_static(u, 100.0, init_static=8.0, time=t)
    assert np.allclose(found.times[:, 0], t[found.start])
    assert np.allclose(found.times[:, 1], t[found.stop - 1])


def test_rows_report_times_lengths_means_and_noise():
    u, _ = recording(UPS[:3])
    found = detect_static(u, 100.0, init_static=8.0, unit="m/s^2")
    rows = found.rows()
    assert [r["interval"] for r in rows] == [1, 2, 3]
    assert {"start_s", "stop_s", "length_s", "samples", "mean_x", "mean_y", "mean_z", "sd_x",
            "sd_y", "sd_z", "unit"} <= set(rows[0])
    assert rows[1]["mean_x"] == pytest.approx(G, abs=0.01)
    assert rows[0]["length_s"] == pytest.approx(rows[0]["samples"] / 100.0)


def test_moving_variance_matches_the_direct_variance_with_a_large_offset():
    """Independent route: np.var of every window. A raw-count offset of 1e5 with a noise of
    0.01 would lose every digit in plain cumulative sums of squares (1e10 x 1e-16 x n);
    the blocked, shifted sums keep 1e-9 relative."""
    rng = np.random.default_rng(1)
    x = rng.normal(0.0, 0.01, (3000, 3)) + np.array([1e5, -3e4, 7.0])
    x[1700:] += [3.0, 1.0, -2.0]  # a step: windows across it
    for w in (3, 50, 51, 400):
        half = w // 2
        direct = np.array([x[max(i - half, 0):min(i - half + w, len(x))].var(axis=0, ddof=1)
                           for i in range(len(x))])
        assert np.allclose(moving_variance(x, w), direct, rtol=1e-9, atol=0)


def _direct_variance(x, w):
    half = w // 2
    return np.array([x[max(i - half, 0):min(i - half + w, len(x))].var(axis=0, ddof=1)
                     for i in range(len(x))])


@pytest.mark.parametrize("w", [3, 4, 7, 50])
def test_moving_variance_of_records_about_a_window_long(w):
    """Record lengths around the window and its multiples (no whole window, one, a block
    and a sample, whole blocks): every window, clipped or whole, as np.var gives it."""
    rng = np.random.default_rng(3)
    for n in sorted({2, w - 1, w, w + 1, 2 * w - 1, 2 * w, 2 * w + 1, 3 * w + w // 2}):
        if n < 2:
            continue
        x = rng.normal(0.0, 0.01, (n, 3)) + np.array([3e4, -7.0, 0.5])
        x[n // 2:] += [0.5, -0.2, 1.0]
        assert np.allclose(moving_variance(x, w), _direct_variance(x, w), rtol=1e-9, atol=0)


def test_variance_magnitude_is_the_norm_in_a_few_columns_of_memory():
    """ς one column at a time: the norm of the moving variances, with a working memory of
    about nine columns (the former (n, 3) index and sum arrays took about forty)."""
    import tracemalloc

    x = np.random.default_rng(4).normal(0.0, 0.01, (200_000, 3)) + np.array([0.0, 0.0, G])
    expected = np.linalg.norm(moving_variance(x, 1000), axis=1)
    tracemalloc.start()
    try:
        stat = variance_magnitude(x, 1000)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    np.testing.assert_allclose(stat, expected, rtol=1e-12)
    assert peak < 12 * len(x) * 8, peak / (len(x) * 8)


def test_detection_is_linear_in_samples():
    """1e6 samples (2.8 h at 100 Hz) in seconds: cumulative sums, no loop over samples.
    Measured ~1 s on one loaded core; 15 s would mean a loop over samples."""
    u = np.random.default_rng(2).normal(0.0, 0.01, (1_000_000, 3)) + np.array([0.0, 0.0, G])
    start = time.perf_counter()
    found = detect_static(u, 100.0, init_static=30.0)
    assert time.perf_counter() - start < 15.0
    assert len(found) >= 1


def test_raw_counts_with_an_offset_are_detected_alike():
    u, _ = recording(UPS[:5])
    counts = u * 1000.0 + 32768.0  # a 16-bit ADC's offset
    a = detect_static(u, 100.0, init_static=8.0)
    b = detect_static(counts, 100.0, init_static=8.0)
    assert np.array_equal(a.start, b.start)
    assert np.array_equal(a.stop, b.stop)


# --------------------------------------------------------------------- refusals
def test_init_static_longer_than_the_record_is_refused():
    u, _ = recording(UPS[:2])
    with pytest.raises(AccelcalError, match=r"no still period at the start: .* longer than"):
        detect_static(u, 100.0, init_static=1e4)


def test_a_moving_initial_period_is_refused():
    u, _ = recording(UPS[:3], init=3.0)
    with pytest.raises(AccelcalError, match=r"no still period at the start: .* times more"):
        detect_static(u, 100.0, init_static=6.0)


def test_no_intervals_names_the_threshold_and_the_longest_run():
    u, _ = recording(UPS[:3], hold=1.5)
    with pytest.raises(AccelcalError, match="no static intervals found") as exc:
        detect_static(u, 100.0, init_static=1.0, window=0.5, min_length=30.0)
    assert "threshold" in str(exc.value)
    assert "longest still run is" in str(exc.value)


@pytest.mark.parametrize(("kwargs", "word"), [
    ({"window": 0.01}, "window"),
    ({"window": float("nan")}, "window"),
    ({"factor": 0.0}, "factor"),
    ({"min_length": -1.0}, "min_length"),
    ({"init_static": 0.5, "window": 1.0}, "shorter than the window"),
])
def test_bad_settings_are_refused(kwargs, word):
    u, _ = recording(UPS[:2])
    with pytest.raises(AccelcalError, match=word):
        detect_static(u, 100.0, **{"init_static": 8.0, **kwargs})


def test_bad_samples_are_refused():
    u, _ = recording(UPS[:2])
    with pytest.raises(AccelcalError, match=r"shape \(n, 3\)"):
        detect_static(u[:, :2], 100.0, init_static=8.0)
    u[50, 1] = np.nan
    with pytest.raises(AccelcalError, match="NaN"):
        detect_static(u, 100.0, init_static=8.0)


def test_noise_free_samples_are_refused():
    u = np.tile([0.0, 0.0, G], (2000, 1))
    with pytest.raises(AccelcalError, match=r"no still period at the start: .* all equal"):
        detect_static(u, 100.0, init_static=5.0)


def test_figure_shades_every_interval():
    u, _ = recording(UPS[:4])
    found = detect_static(u, 100.0, init_static=8.0, unit="m/s^2")
    fig = figure(found, u)
    top, bottom = fig.axes
    assert len(top.patches) == len(found) == len(bottom.patches)
    assert bottom.lines[1].get_ydata()[0] == pytest.approx(found.threshold)


# ------------------------------------------------------------ choice of the threshold factor
def test_choose_factor_keeps_the_smallest_residual_and_recovers_the_truth():
    """Tedaldi sec. III on a simulated triad (rigs.triad): 24 random orientations."""
    from accelcal.methods.triad.model import TriadCalibration
    from accelcal.methods.triad.threshold import choose_factor
    from accelcal.rigs.triad import simulate

    truth = TriadCalibration([0.05, -0.08, 0.12], [1.01, 0.995, 1.02], [1e-3, -2e-3, 1.5e-3])
    rec = simulate(truth, 24, still=10.0, noise_sd=0.005, seed=4)
    choice = choose_factor(rec.acc, 100.0, 9.80665, init_static=8.0)
    rms = [r["rms_residual"] for r in choice.rows]
    assert [r["factor"] for r in choice.rows] == [float(k) for k in range(2, 11)]
    assert choice.factor == choice.rows[int(np.nanargmin(rms))]["factor"]
    assert len(choice.intervals) == 24
    est = choice.reduction.estimate
    for name, true in zip(est.names, truth.vector, strict=True):
        assert abs(est[name] - true) < 5 * est.std_of(name), name


def test_choose_factor_refuses_when_no_factor_calibrates():
    from accelcal.methods.triad.threshold import choose_factor

    u, _ = recording(UPS[:4])  # four orientations: too few for nine parameters
    with pytest.raises(AccelcalError, match=r"no threshold factor .*most intervals found: 4\)"):
        choose_factor(u, 100.0, G, init_static=8.0)


# ------------------------------------------------------------------ streamed detection
def _blocks(u, rows, time=None):
    from accelcal.io.recordings import Block

    for a in range(0, len(u), rows):
        yield Block(u[a:a + rows], a, None if time is None else time[a:a + rows])


@pytest.mark.parametrize("rows", [97, 1000, 4096, 10**7])
def test_streamed_detection_equals_the_whole_record(rows):
    # the same intervals (bounds exactly: a threshold tie at rounding level has probability
    # ~0), means to 1e-9 of the noise (the running sums are shifted by the run's first
    # sample, as the whole-record detector shifts its windows), for any block length,
    # including blocks shorter than the window (100 samples) and one block for all
    from accelcal.signal.static_stream import detect_static_stream

    u, _ = recording(UPS, offset=1.0e5, noise=3.0)
    t = 5.0 + np.arange(len(u)) / 100.0  # a time column that does not start at 0
    whole = detect_static(u, 100.0, init_static=8.0, factor=3.0, time=t)
    (streamed,) = detect_static_stream(_blocks(u, rows, t), 100.0, init_static=8.0,
                                       factors=(3.0,))
    np.testing.assert_array_equal(streamed.start, whole.start)
    np.testing.assert_array_equal(streamed.stop, whole.stop)
    np.testing.assert_array_equal(streamed.times, whole.times)
    np.testing.assert_allclose(streamed.means, whole.means, rtol=0, atol=3.0 * 1e-9)
    np.testing.assert_allclose(streamed.noise_sd, whole.noise_sd, rtol=1e-9)
    assert streamed.threshold == pytest.approx(whole.threshold, rel=1e-12)


def test_several_factors_in_one_pass_equal_one_pass_each():
    from accelcal.signal.static_stream import detect_static_stream

    u, _ = recording(UPS)
    found = detect_static_stream(_blocks(u, 500), 100.0, init_static=8.0, factors=(2, 5, 9))
    for k, one in zip((2, 5, 9), found, strict=True):
        whole = detect_static(u, 100.0, init_static=8.0, factor=k)
        np.testing.assert_array_equal(one.start, whole.start)
        np.testing.assert_array_equal(one.stop, whole.stop)


def test_streamed_detection_memory_does_not_grow_with_the_record():
    # a recording 8x longer takes the same peak (blocks of 2,000 rows; the trace keeps at most
    # 2 x 2,000 points): a whole-record detector would take 8x
    import tracemalloc

    from accelcal.signal.static_stream import detect_static_stream

    def peak(repeats):
        u, _ = recording(UPS[:4], init=10.0)
        still = u[:1000]
        def gen():
            from accelcal.io.recordings import Block

            start = 0
            for block in (u, *([still] * repeats)):
                for a in range(0, len(block), 2000):
                    yield Block(block[a:a + 2000], start, None)
                    start += len(block[a:a + 2000])
        tracemalloc.start()
        detect_static_stream(gen(), 100.0, init_static=8.0, trace_points=2000)
        out = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        return out

    small, large = peak(40), peak(320)  # 40,000 and 320,000 more still samples
    assert large < 1.3 * small, (small, large)


def test_streamed_detection_without_a_trace_finds_the_same_intervals():
    # trace_points=0 (no figure): no envelope kept, the intervals those of the traced run
    from accelcal.signal.static_stream import detect_static_stream

    u, _ = recording(UPS)
    (traced,) = detect_static_stream(_blocks(u, 700), 100.0, init_static=8.0)
    (bare,) = detect_static_stream(_blocks(u, 700), 100.0, init_static=8.0, trace_points=0)
    assert traced.trace is not None
    assert len(traced.statistic)
    assert bare.trace is None
    assert bare.statistic.size == 0
    np.testing.assert_array_equal(bare.start, traced.start)
    np.testing.assert_array_equal(bare.stop, traced.stop)
    np.testing.assert_array_equal(bare.means, traced.means)


def test_streamed_detection_refuses_as_the_whole_record_does():
    from accelcal.signal.static_stream import detect_static_stream

    u, _ = recording(UPS)
    with pytest.raises(AccelcalError, match="longer than the record") as exc:
        detect_static_stream(_blocks(u[:500], 100), 100.0, init_static=8.0)
    assert exc.value.parameter == "init_static"
    with pytest.raises(AccelcalError, match="no static intervals found"):
        detect_static_stream(_blocks(u, 1000), 100.0, init_static=8.0, min_length=60.0)
    moving = u[900:]  # starts in motion
    with pytest.raises(AccelcalError, match="no still period at the start"):
        detect_static_stream(_blocks(moving, 1000), 100.0, init_static=8.0)
