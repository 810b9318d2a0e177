"""Welch spectra of a record cut at its gaps: the pieces' averages pooled, no segment
across a gap, the equivalent averages the sum of the pieces'."""

import numpy as np

from accelcal.signal.spectra import CrossSpectra


def test_restart_pools_the_pieces_as_their_separate_sums():
    rng = np.random.default_rng(3)
    x = rng.standard_normal(3000)
    y = np.convolve(x, [0.5, 0.3, 0.2])[:x.size] + 0.1 * rng.standard_normal(x.size)
    cut = 1700
    pooled = CrossSpectra(1000.0, 256, overlap=0.75)
    pooled.add(x[:1000], y[:1000])
    pooled.add(x[1000:cut], y[1000:cut])
    assert pooled.restart() > 0
    pooled.add(x[cut:], y[cut:])
    parts = []
    for a, b in ((0, cut), (cut, x.size)):
        one = CrossSpectra(1000.0, 256, overlap=0.75)
        one.add(x[a:b], y[a:b])
        parts.append(one.result())
    sp = pooled.result()
    assert sp.segments == sum(p.segments for p in parts)
    weighted = sum(p.gxy * p.segments for p in parts) / sp.segments
    assert np.allclose(sp.gxy, weighted, rtol=1e-10, atol=0)
    assert np.isclose(sp.n_d, sum(p.n_d for p in parts), rtol=1e-12)
    whole = CrossSpectra(1000.0, 256, overlap=0.75)
    whole.add(x, y)
    assert not np.allclose(whole.result().gxy, sp.gxy)  # the cut changed the segments


def test_a_piece_shorter_than_a_segment_holds_none():
    sp = CrossSpectra(1000.0, 256)
    sp.add(np.ones(200), np.ones(200))
    assert sp.restart() == 0
    sp.add(np.arange(300.0), np.arange(300.0))  # the 200 samples before are not used
    assert sp.segments == 1
    assert sp.samples == 500
