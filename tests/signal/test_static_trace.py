"""The streamed static detection's figure trace keeps every bucket's extremes (an envelope)."""

from itertools import pairwise

import numpy as np
import pytest

from accelcal.signal.static_stream import _Trace


def _stream(t, u, stat, points, blocks, *, first=0):
    trace = _Trace(points)
    edges = np.r_[0, np.sort(blocks), len(t)]
    for a, b in pairwise(edges):
        trace.add(first + a, t[a:b], u[a:b], stat[a:b])
    return trace


@pytest.mark.parametrize("first", [0, 7])
def test_the_trace_is_the_envelope_whatever_the_blocks(first):
    rng = np.random.default_rng(5)
    n, points = 50_003, 300
    t = (first + np.arange(n)) / 100.0
    u = rng.normal(0.0, 1.0, (n, 3))
    u[rng.integers(0, n, 20)] *= 50.0  # isolated spikes a thinned trace would miss
    stat = rng.lognormal(0.0, 1.0, n)
    a = _stream(t, u, stat, points, rng.integers(0, n, 40), first=first)
    b = _stream(t, u, stat, points, rng.integers(0, n, 3), first=first)
    c = _stream(t, u, stat, points, np.arange(97, n, 97), first=first)  # short blocks
    for x, y in ((a, b), (a, c)):
        assert x.step == y.step
        for got, want in zip(x.arrays(), y.arrays(), strict=True):
            np.testing.assert_array_equal(got, want)
    tt, norm, st = a.arrays()
    full = np.linalg.norm(u, axis=1)
    assert len(a.idx) <= 2 * points
    assert len(tt) <= 6 * len(a.idx)
    assert tt[0] == t[0]
    assert tt[-1] == t[-1]
    # brute force: every bucket's least and greatest |u| and ς, and its first and last sample
    sample = first + np.arange(n)
    kept = np.round(tt * 100.0).astype(int)
    for bucket in np.unique(sample // a.step):
        rows = (sample // a.step) == bucket
        mine = (kept // a.step) == bucket
        assert norm[mine].max() == full[rows].max()
        assert norm[mine].min() == full[rows].min()
        assert st[mine].max() == stat[rows].max()
        assert st[mine].min() == stat[rows].min()
        assert kept[mine].min() == sample[rows].min()
        assert kept[mine].max() == sample[rows].max()


def test_a_short_record_is_kept_whole():
    rng = np.random.default_rng(1)
    t, u, stat = np.arange(50.0), rng.normal(size=(50, 3)), rng.random(50)
    got = _stream(t, u, stat, 100, [10, 30]).arrays()
    np.testing.assert_array_equal(got[0], t)
    np.testing.assert_array_equal(got[1], np.linalg.norm(u, axis=1))
    np.testing.assert_array_equal(got[2], stat)
