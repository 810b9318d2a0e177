"""Welch spectra accumulated block by block: scipy's estimate, the random error, bounded memory.

- the sums equal :func:`scipy.signal.csd` and :func:`scipy.signal.welch` on the
  whole record (same segment, overlap, window, mean removed), whatever the
  block sizes, to rounding;
- the random error of ``|H1|`` and of its phase from the coherence and the
  equivalent averages (Bendat and Piersol) against the scatter of H1 over
  seeds, for a filter written out here (``scipy.signal.lfilter``);
- with little noise and a delay, the window's leakage: the plain H1's
  magnitude scatters far less than its coherence says (the leakage falls on
  the phase), the spectra conditioned on the window's derivative scatter as
  their partial coherence says, in magnitude and phase alike, and
  neighbouring bins' errors correlate as the overlapped kernels say;
- memory: feeding ten times more blocks does not raise the peak.
"""

import tracemalloc

import numpy as np
import pytest
from scipy import signal

from accelcal.errors import AccelcalError
from accelcal.signal.spectra import CrossSpectra, equivalent_averages

FS = 1000.0
B, A = signal.butter(2, 0.2)


def _pair(rng, n, noise=0.3):
    x = rng.normal(size=n)
    return x, signal.lfilter(B, A, x) + noise * rng.normal(size=n)


@pytest.mark.parametrize("overlap", [0.0, 0.5, 0.75])
def test_block_sums_are_scipys_welch_whatever_the_blocks(overlap):
    rng = np.random.default_rng(1)
    x, y = _pair(rng, 50_003)
    n = 512
    acc = CrossSpectra(FS, n, overlap=overlap)
    start = 0
    for size in rng.integers(1, 9000, size=100):
        acc.add(x[start:start + size], y[start:start + size])
        start += size
    acc.add(x[start:], y[start:])
    sp = acc.result()
    kw = {"nperseg": n, "noverlap": int(overlap * n)}
    _, pxy = signal.csd(x, y, FS, **kw)
    _, pxx = signal.welch(x, FS, **kw)
    _, pyy = signal.welch(y, FS, **kw)
    assert np.max(np.abs(sp.gxy - pxy)) < 1e-12 * np.max(np.abs(pxy))
    assert np.max(np.abs(sp.gxx - pxx)) < 1e-12 * np.max(pxx)
    assert np.max(np.abs(sp.gyy - pyy)) < 1e-12 * np.max(pyy)
    assert sp.segments == (x.size - n) // (n - int(overlap * n)) + 1


def test_equivalent_averages():
    w = signal.get_window("hann", 256)
    assert equivalent_averages(10, w, 256) == 10.0  # no overlap: independent
    # half overlap of a Hann window: correlation 1/6 between neighbours (Welch 1967)
    k = 1000
    assert equivalent_averages(k, w, 128) == pytest.approx(k / (1 + 2 / 36), rel=1e-3)


def test_random_error_of_h1_matches_its_scatter():
    rng = np.random.default_rng(7)
    f = np.fft.rfftfreq(512, 1 / FS)
    _, h = signal.freqz(B, A, worN=f, fs=FS)
    band = slice(10, 100)
    mags, phases, stated = [], [], []
    for _ in range(40):
        acc = CrossSpectra(FS, 512, overlap=0.75)
        acc.add(*_pair(rng, 20480))
        sp = acc.result()
        mags.append(np.abs(sp.h1[band]) / np.abs(h[band]) - 1)
        phases.append(np.angle(sp.h1[band] / h[band]))
        stated.append(sp.random_error()[band])
    stated = np.mean(stated, axis=0)
    # 40 draws: the ratio of SDs is known to about 1/sqrt(2 * 40) = 11 % per bin; averaged
    # over 90 bins (correlated neighbours), to a few %
    assert np.mean(np.std(mags, axis=0) / stated) == pytest.approx(1.0, abs=0.06)
    assert np.mean(np.std(phases, axis=0) / stated) == pytest.approx(1.0, abs=0.06)


def test_conditioned_spectra_state_the_scatter_of_magnitude_and_phase():
    from accelcal.methods.response.broadband import bin_correlation

    rng = np.random.default_rng(11)
    f = np.fft.rfftfreq(512, 1 / FS)
    delay = 2  # samples, beside the filter's own group delay (about 2.5 at low frequencies)
    _, h = signal.freqz(B, A, worN=f, fs=FS)
    h = h * np.exp(-2j * np.pi * f * delay / FS)
    band = slice(10, 100)
    plain, cond, step = [], [], None
    for _ in range(30):
        x = rng.normal(size=20480 + delay)
        y = signal.lfilter(B, A, x)[:-delay] + 0.003 * rng.normal(size=20480)
        acc = CrossSpectra(FS, 512, overlap=0.75)
        acc.add(x[delay:], y)
        sp = acc.result()
        step, segments = acc.step, sp.segments
        for out, s in ((plain, sp), (cond, sp.conditioned())):
            err = s.h1[band] / h[band]
            out.append((np.abs(err) - 1, np.angle(err), s.random_error()[band]))
    (m1, p1, s1), (m2, p2, s2) = (np.transpose(np.asarray(o), (1, 0, 2)) for o in (plain, cond))
    s1, s2 = np.sqrt(np.mean(s1**2, axis=0)), np.sqrt(np.mean(s2**2, axis=0))
    # 30 draws: a ratio of SDs to about 13 % per bin, a few % over the 90 bins
    assert np.mean(np.std(m1, axis=0) / s1) < 0.6  # the plain H1 overstates the magnitude's
    assert np.mean(np.std(p1, axis=0) / s1) == pytest.approx(1.0, abs=0.08)
    assert np.mean(np.std(m2, axis=0) / s2) == pytest.approx(1.0, abs=0.08)
    assert np.mean(np.std(p2, axis=0) / s2) == pytest.approx(1.0, abs=0.08)
    assert np.median(s2 / s1) < 0.3  # the leakage was most of the plain H1's stated error
    # neighbouring bins: 0.49 at lag 1 for Hann at 3/4 overlap (0.44 without overlap)
    z = (m2 - m2.mean(axis=0)) / s2
    lag1 = np.mean(z[:, :-1] * z[:, 1:]) / np.mean(z**2)
    want = bin_correlation(signal.get_window("hann", 512), step, segments)[1]
    assert want == pytest.approx(0.49, abs=0.005)
    assert lag1 == pytest.approx(want, abs=0.06)


def _peak(blocks):
    rng = np.random.default_rng(3)
    acc = CrossSpectra(FS, 1024)
    x, y = _pair(rng, 20000)
    tracemalloc.start()
    for _ in range(blocks):
        acc.add(x, y)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak, acc


def test_memory_does_not_grow_with_the_record():
    small, _ = _peak(3)
    large, acc = _peak(30)
    assert acc.samples == 600_000
    assert large < 1.5 * small


def test_refusals():
    with pytest.raises(AccelcalError, match="whole number"):
        CrossSpectra(FS, 8)
    acc = CrossSpectra(FS, 64)
    acc.add(np.zeros(10), np.zeros(10))
    with pytest.raises(AccelcalError, match="no whole segment"):
        acc.result()
    with pytest.raises(AccelcalError, match="equal lengths"):
        acc.add(np.zeros(10), np.zeros(9))
