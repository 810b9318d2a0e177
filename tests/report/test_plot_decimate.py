"""Envelope (M4) decimation of dense figure lines (issue 16): what is drawn is what was measured."""

import numpy as np
import pytest

from accelcal.plotting.decimate import BINS, envelope_indices


def brute_force(x, y, bins, log=False):
    """Each bin's first, last, first lowest and first highest index, by a loop over samples."""
    u = np.log(x) if log else x
    lo, hi = u.min(), u.max()
    members = {}
    for i, v in enumerate(u):
        members.setdefault(min(int((v - lo) * (bins / (hi - lo))), bins - 1), []).append(i)
    keep = set()
    for idx in members.values():
        values = [y[i] for i in idx]
        keep |= {idx[0], idx[-1], idx[int(np.argmin(values))], idx[int(np.argmax(values))]}
    return np.array(sorted(keep))


@pytest.mark.parametrize("log", [False, True])
def test_each_bin_keeps_its_first_last_min_and_max_and_nothing_else(log):
    rng = np.random.default_rng(1)
    x = np.sort(rng.uniform(0.01, 100.0, 5000)) if log else np.cumsum(rng.uniform(0, 1, 5000))
    y = rng.normal(size=x.size).cumsum()
    got = envelope_indices(x, y, 100, log=log)
    assert np.array_equal(got, brute_force(x, y, 100, log))
    assert (got[0], got[-1]) == (0, x.size - 1)
    assert got.size <= 4 * 100


def test_short_records_pass_through_unchanged():
    x = np.arange(4 * BINS, dtype=float)
    assert np.array_equal(envelope_indices(x, np.sin(x)), np.arange(x.size))
    assert np.array_equal(envelope_indices([1.0, 2.0], [3.0, 4.0], log=True), [0, 1])


def test_several_series_share_indices_that_keep_every_envelope():
    rng = np.random.default_rng(2)
    x = np.linspace(0.0, 1.0, 20_000)
    y = rng.normal(size=(x.size, 2))
    both = envelope_indices(x, y, 50)
    alone = [envelope_indices(x, y[:, k], 50) for k in range(2)]
    assert np.array_equal(both, np.union1d(*alone))
    bins = np.minimum((x * 50).astype(int), 49)
    for k in range(2):
        for fn in (np.minimum, np.maximum):
            full = fn.reduceat(y[:, k], np.flatnonzero(np.diff(bins, prepend=-1)))
            kept = fn.reduceat(y[both, k], np.flatnonzero(np.diff(bins[both], prepend=-1)))
            assert np.array_equal(full, kept)


def test_a_gap_stays_a_gap_and_log_bins_need_positive_x():
    x = np.linspace(0.0, 1.0, 10_000)
    y = np.sin(40 * x)
    y[5000:5003] = np.nan
    got = envelope_indices(x, y, 100)
    assert np.isnan(y[got]).sum() == 1
    assert (np.nanmin(y[got]), np.nanmax(y[got])) == (np.nanmin(y), np.nanmax(y))
    with pytest.raises(ValueError, match="x > 0"):
        envelope_indices(x, y, 100, log=True)


def test_the_noise_psd_is_drawn_from_its_envelope():
    import importlib

    from accelcal.methods.noise.fit import fit

    psd_figure = importlib.import_module("accelcal.methods.noise.figures")._psd_figure
    red = fit(np.random.default_rng(3).normal(size=1 << 18), 100.0, terms=("N",))
    f, p = red.observations["psd_frequency"], red.observations["psd"]
    assert f.size > 4 * BINS
    ax = psd_figure(red, {"N": red.estimate["N"]}, "g")[2].axes[0]
    welch, level = ax.get_lines()
    assert welch.get_xdata().size <= 4 * BINS
    assert welch.get_xdata().size == level.get_xdata().size
    assert (welch.get_ydata().min(), welch.get_ydata().max()) == (p[f > 0].min(), p[f > 0].max())
    assert (welch.get_xdata()[0], welch.get_xdata()[-1]) == (f[f > 0][0], f[-1])


def test_the_static_interval_figure_is_drawn_from_its_envelope():
    from accelcal.methods.triad.model import TriadCalibration
    from accelcal.rigs.triad import simulate
    from accelcal.signal.static import detect_static, figure

    truth = TriadCalibration([0.05, -0.08, 0.12], [1.01, 0.995, 1.02], [1e-3, -2e-3, 1.5e-3])
    rec = simulate(truth, 24, still=10.0, noise_sd=0.005, seed=4)
    found = detect_static(rec.acc, 100.0, init_static=8.0)
    top, bottom = figure(found, rec.acc, time=rec.t).axes
    norm = np.linalg.norm(rec.acc, axis=1)
    assert norm.size > 4 * BINS
    for line, full in ((top.lines[0], norm), (bottom.lines[0], found.statistic)):
        y = line.get_ydata()
        assert y.size <= 4 * BINS
        assert (y.min(), y.max()) == (full.min(), full.max())
        assert (line.get_xdata()[0], line.get_xdata()[-1]) == (rec.t[0], rec.t[-1])
