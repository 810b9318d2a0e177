"""Static intervals of a recording of any length, in one pass and bounded memory.

:func:`detect_static_stream` is :func:`accelcal.signal.static.detect_static`
on a recording read in blocks (:func:`accelcal.io.recordings.iter_blocks`):
the same centred moving variance, the same threshold from the initial
still period, the same runs; several threshold factors at once (the sweep
of :func:`accelcal.methods.triad.threshold.choose_factor` in one pass).

Memory is bounded by one block plus the initial still period plus one
window of samples, whatever the recording's length: the statistic of a
sample is final once the samples half a window after it have arrived, so
each block is classified as it comes, and an interval keeps only running
sums (shifted by its first sample, so raw counts with a large offset keep
their small variance). The figure keeps an envelope of the trace in at most
``2 trace_points`` buckets (each bucket's first and last sample and the extremes
of |u| and of ς: no peak is lost).

References
----------
.. [1] D. Tedaldi, A. Pretto, E. Menegatti, "A robust and easy to implement
   method for IMU calibration without external equipments", IEEE ICRA 2014,
   sec. III.
"""

from collections.abc import Iterable

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.signal.static import (
    Excluded,
    StaticIntervals,
    _runs,
    check_settings,
    init_shorter_than_window,
    initial_variance,
    no_intervals,
    variance_magnitude,
)

MAX_SETTING_SAMPLES = 1e9
"""Most samples a window or the initial still period may span (they are held in memory)."""


class _Runs:
    """Open and closed static runs of one threshold, with running sums."""

    def __init__(self, threshold: float, min_samples: float):
        self.threshold, self.min_samples = threshold, min_samples
        self.open = None  # [start, ref, s1, s2, count, t_start, t_last]
        self.found = []  # (start, stop, t_start, t_last, mean, sd)
        self.longest = 0
        self.excluded = Excluded()

    def add(self, done: int, u: np.ndarray, t: np.ndarray, stat: np.ndarray,
            exclude: np.ndarray | None = None) -> None:
        """Classify the samples ``done .. done + len(u)`` (their ς final, times ``t``).

        ``exclude``: those never static.
        """
        still = stat < self.threshold
        if exclude is not None:
            still = self.excluded.add(done, still, exclude)
        starts, stops = _runs(still)
        if self.open is not None and (not len(starts) or starts[0] > 0):
            self._close()
        n = len(u)
        lengths = stops - starts
        continued = (starts == 0) & (self.open is not None)
        keep = (lengths >= self.min_samples) | continued | (stops == n)
        if len(lengths):
            self.longest = max(self.longest, int(lengths.max()))
        for a, b in zip(starts[keep], stops[keep], strict=True):
            if not (a == 0 and self.open is not None):
                self.open = [done + int(a), u[a].copy(), np.zeros(3), np.zeros(3), 0,
                             float(t[a]), float(t[a])]
            seg = u[a:b] - self.open[1]
            # einsum: one pass over the rows (sum(axis=0) of (rows, 3) is ten times slower)
            self.open[2] += np.einsum("ij->j", seg)
            self.open[3] += np.einsum("ij,ij->j", seg, seg)
            self.open[4] += int(b - a)
            self.open[6] = float(t[b - 1])
            self.longest = max(self.longest, self.open[4])
            if b < n:
                self._close()

    def _close(self) -> None:
        start, ref, s1, s2, count, t0, t1 = self.open
        self.open = None
        if count >= self.min_samples:
            mean = ref + s1 / count
            var = np.maximum((s2 - s1 * s1 / count) / max(count - 1, 1), 0.0)
            self.found.append((start, start + count, t0, t1, mean, np.sqrt(var)))

    def finish(self) -> None:
        """Close the run open at the end of the record."""
        if self.open is not None:
            self._close()


class _Trace:
    """The figure's trace of |u| and ς, streamed: an envelope in at most 2 ``points`` buckets.

    Buckets are ``step`` consecutive samples (``step`` a power of two,
    doubling as the record grows, neighbouring buckets merged). Each keeps
    the samples where |u| and where ς take their least and greatest value
    (the earliest, on ties) and its first and last sample: the M4
    aggregation [Jugel2014] of both curves, so no peak is lost. What is kept
    depends on the samples alone, never on the blocks they came in. O(n)
    time, memory one block plus the buckets.

    References
    ----------
    .. [Jugel2014] Jugel U., Jerzak Z., Hackenbroich G., Markl V., M4: a
       visualization-oriented time series data aggregation, PVLDB 7(10), 2014.
    """

    def __init__(self, points: int):
        self.points, self.step = max(int(points), 1), 1
        self.first_bucket = 0  # bucket number (sample // step) of row 0; the rest follow on
        self.idx = np.empty((0, 6), dtype=np.int64)  # first, last, min/max |u|, min/max ς
        self.val = np.empty((0, 6, 3))  # time, |u| and ς of each of those samples

    def add(self, first: int, t: np.ndarray, u: np.ndarray, stat: np.ndarray) -> None:
        """Add samples ``first, first + 1, ...`` (times ``t``, values ``u``, statistic ``stat``).

        The samples are finite: NaN marks only the padding that aligns the
        block with the buckets.
        """
        n = len(t)
        if not n:
            return
        step, lead = self.step, first % self.step
        nb = -(-(lead + n) // step)
        values = np.full((nb * step, 3), np.nan)
        values[lead:lead + n] = np.column_stack([t, np.linalg.norm(u, axis=1), stat])
        values = values.reshape(nb, step, 3)
        edge_first, edge_last = np.zeros(nb, np.intp), np.full(nb, step - 1, np.intp)
        edge_first[0], edge_last[-1] = lead, lead + n - 1 - (nb - 1) * step
        rows = np.stack([edge_first, edge_last,
                         *(best(values[..., c], axis=1) for c in (1, 2)
                           for best in (np.nanargmin, np.nanargmax))],
                        axis=1)  # (nb, 6) positions within each bucket
        idx = first - lead + np.arange(nb)[:, None] * step + rows
        val = np.take_along_axis(values, rows[..., None], axis=1)
        if not len(self.idx):
            self.first_bucket = (first - lead) // step
        elif self.first_bucket + len(self.idx) - 1 == (first - lead) // step:  # continues
            i0, v0 = _merge(self.idx[-1:], self.val[-1:], idx[:1], val[:1])
            self.idx[-1], self.val[-1] = i0[0], v0[0]
            idx, val = idx[1:], val[1:]
        self.idx = np.concatenate([self.idx, idx])
        self.val = np.concatenate([self.val, val])
        while len(self.idx) > 2 * self.points:
            self._halve()

    def _halve(self) -> None:
        """Double ``step``: merge each pair of buckets that now share a number."""
        self.step *= 2
        count = len(self.idx)
        head = self.first_bucket % 2  # an odd first bucket stands alone
        tail = (count - head) % 2  # so may the last one
        pairs = slice(head, count - tail)
        merged_idx, merged_val = _merge(self.idx[pairs][0::2], self.val[pairs][0::2],
                                        self.idx[pairs][1::2], self.val[pairs][1::2])
        self.idx = np.concatenate([self.idx[:head], merged_idx, self.idx[count - tail:]])
        self.val = np.concatenate([self.val[:head], merged_val, self.val[count - tail:]])
        self.first_bucket //= 2

    def arrays(self):
        """Time, |u| and ς of the kept samples, in sample order (each sample once)."""
        if not len(self.idx):
            return (np.empty(0),) * 3
        _, keep = np.unique(self.idx.ravel(), return_index=True)
        values = self.val.reshape(-1, 3)[keep]
        return values[:, 0], values[:, 1], values[:, 2]


def _merge(idx_a, val_a, idx_b, val_b):
    """Candidate sets of adjacent buckets ``a`` (earlier) and ``b`` merged, row by row."""
    idx, val = idx_a.copy(), val_a.copy()
    idx[:, 1], val[:, 1] = idx_b[:, 1], val_b[:, 1]  # the last sample is b's
    for slot, column, later_wins in ((2, 1, np.less), (3, 1, np.greater),
                                     (4, 2, np.less), (5, 2, np.greater)):
        take = later_wins(val_b[:, slot, column], val_a[:, slot, column])  # ties: a's
        idx[take, slot], val[take, slot] = idx_b[take, slot], val_b[take, slot]
    return idx, val


def detect_static_stream(blocks: Iterable, rate: float, *, init_static: float = 30.0,
                         window: float = 1.0, factors=(2.0,), min_length: float = 2.0,
                         unit: str = "", trace_points: int = 20_000,
                         progress=None, exclude=None) -> list[StaticIntervals]:
    """Static intervals of a recording streamed in blocks, for each threshold factor.

    Parameters
    ----------
    blocks : iterable
        Consecutive blocks with ``values`` (rows, 3) and ``time`` (seconds from
        the first sample, or None for index / rate), as
        :func:`accelcal.io.recordings.iter_blocks` yields them.
    rate : float
        Sample rate, Hz.
    init_static, window, min_length : float
        As for :func:`accelcal.signal.static.detect_static`, seconds.
    factors : sequence of float
        Threshold factors; one result per factor.
    unit : str
        Unit of the values (for the tables).
    trace_points : int
        Buckets of the trace's envelope kept for the figure (at most twice
        this; up to 6 samples each); 0 keeps no trace (no figure: the
        results' ``statistic`` is empty and ``trace`` None).
    progress : callable, optional
        ``progress(samples_done)`` after each block.
    exclude : callable, optional
        ``exclude(values)``: the samples of each block that are never static
        (clipped: :class:`accelcal.signal.clipping.ClipFinder`), as
        :func:`~accelcal.signal.static.detect_static`'s ``exclude``.

    Returns
    -------
    list of StaticIntervals
        In the order of ``factors``; ``statistic`` and ``trace`` thinned.

    Raises
    ------
    AccelcalError
        As :func:`~accelcal.signal.static.detect_static` (the same messages);
        "no static intervals found" only when no factor finds one.
    """
    factors = [float(k) for k in factors]
    if not factors:
        raise AccelcalError("give at least one factor", parameter="factors")
    for k in factors:
        check_settings(rate=rate, window=window, factor=k, init_static=init_static,
                       min_length=min_length)
    for name, seconds in (("window", window), ("init_static", init_static)):
        if not seconds * rate <= MAX_SETTING_SAMPLES:  # checked before rounding: no overflow
            raise AccelcalError(f"{seconds:g} s is {seconds * rate:.3g} samples at {rate:g} Hz, "
                                f"more than {MAX_SETTING_SAMPLES:.0e}; give a shorter one",
                                parameter=name)
    w, n_init = round(window * rate), round(init_static * rate)
    half = w // 2
    if w < 3:
        raise AccelcalError(f"{window:g} s is {w} samples at {rate:g} Hz; the window needs "
                            "at least 3 samples", parameter="window")
    if n_init < w:
        raise init_shorter_than_window(init_static, window)
    buf, tbuf, buf_start, done = np.empty((0, 3)), np.empty(0), 0, 0
    mbuf = None if exclude is None else np.empty(0, dtype=bool)
    runs, trace = None, (_Trace(trace_points) if trace_points else None)
    for block in blocks:
        t = (block.start + np.arange(len(block.values))) / rate if block.time is None \
            else block.time
        buf, tbuf = np.concatenate([buf, block.values]), np.concatenate([tbuf, t])
        if mbuf is not None:
            mbuf = np.concatenate([mbuf, exclude(block.values)])
        end = buf_start + len(buf)
        if runs is None:
            if end < n_init + w:
                continue  # the initial period and one window after it, before classifying
            runs = _start(buf, n_init=n_init, w=w, init_static=init_static, window=window,
                          factors=factors, min_samples=min_length * rate)
        hi = end - (w - half) + 1  # samples whose windows are complete
        if hi > done:
            done = _classify(buf, tbuf, buf_start=buf_start, done=done, hi=hi, w=w, runs=runs,
                             trace=trace, mbuf=mbuf)
            keep = max(done - half, buf_start) - buf_start
            buf, tbuf, buf_start = buf[keep:], tbuf[keep:], buf_start + keep
            mbuf = None if mbuf is None else mbuf[keep:]
        if progress is not None:
            progress(end)
    end = buf_start + len(buf)
    if runs is None:
        if end < n_init:
            raise AccelcalError(
                f"no still period at the start: {init_static:g} s is longer than the record "
                f"({end / rate:.4g} s); give a shorter one", parameter="init_static")
        if w > end:
            raise AccelcalError(f"{window:g} s is {w} samples at {rate:g} Hz; the window needs "
                                f"3 samples to {end} (the record)", parameter="window")
        runs = _start(buf, n_init=n_init, w=w, init_static=init_static, window=window,
                      factors=factors, min_samples=min_length * rate)
    if end > done:
        _classify(buf, tbuf, buf_start=buf_start, done=done, hi=end, w=w, runs=runs,
                  trace=trace, mbuf=mbuf)
    return _results(runs, factors, rate=rate, init_static=init_static, window=window,
                    min_length=min_length, unit=unit, trace=trace, end=end,
                    excluding=exclude is not None)


def _start(buf, *, n_init, w, init_static, window, factors, min_samples):
    stat = variance_magnitude(buf[:n_init + w], w)
    init = initial_variance(buf[:n_init], stat[:n_init], w, init_static, window)
    return [(init, _Runs(k * init, max(min_samples, 2))) for k in factors]


def _classify(buf, tbuf, *, buf_start, done, hi, w, runs, trace, mbuf=None) -> int:
    """Classify samples ``done .. hi`` (global) of the buffer; return ``hi``."""
    stat = variance_magnitude(buf, w)  # Eq. (9) [Tedaldi2014]
    a, b = done - buf_start, hi - buf_start
    for _, r in runs:
        r.add(done, buf[a:b], tbuf[a:b], stat[a:b], None if mbuf is None else mbuf[a:b])
    if trace is not None:
        trace.add(done, tbuf[a:b], buf[a:b], stat[a:b])
    return hi


def _results(runs, factors, *, rate, init_static, window, min_length, unit, trace, end,
             excluding=False):
    t, norm, stat = trace.arrays() if trace is not None else (None, None, np.empty(0))
    out, longest, dropped = [], 0, 0
    for k, (init, r) in zip(factors, runs, strict=True):
        r.finish()
        longest = max(longest, r.longest)
        counted = r.excluded.counts([f[0] for f in r.found], r.min_samples, end) \
            if excluding else {}
        dropped = max(dropped, counted.get("dropped", 0))
        if not r.found:
            out.append(None)
            continue
        start, stop, t0, t1, means, sd = (np.array(c) for c in zip(*r.found, strict=True))
        settings = {"init_static": float(init_static), "window": float(window),
                    "factor": k, "min_length": float(min_length), "rate": float(rate)}
        out.append(StaticIntervals(
            start=start, stop=stop, times=np.column_stack([t0, t1]),
            means=means, noise_sd=sd, counts=stop - start, threshold=r.threshold,
            init_variance=init, settings=settings, statistic=stat, unit=unit,
            trace=None if trace is None else (t, norm), excluded=counted))
    if all(o is None for o in out):
        raise no_intervals(longest / rate, min_length=min_length, factor=factors[0],
                           init=runs[0][0], window=window, dropped=dropped)
    return out
