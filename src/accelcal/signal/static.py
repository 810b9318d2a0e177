"""Static intervals of a recording: where a multi-axis sensor is held still.

The detector is Tedaldi's [1]_ (sec. III): over a centred window of
``t_w`` seconds, the variance of each axis is computed; the statistic is
the magnitude of the vector of the three variances,

    ς(t) = sqrt(var_x(t)^2 + var_y(t)^2 + var_z(t)^2)        # Eq. (9) [Tedaldi2014]

(the per-axis variances, not the variance of |u|: a slow rotation keeps |u|
near g and would pass for still). The threshold is ``factor`` times the
same magnitude computed over the whole initial still period of
``init_static`` seconds; a sample is static when ς is below it, and runs of
static samples longer than ``min_length`` seconds are the intervals.
Because the window is centred, a detected interval ends about half a
window before the motion starts: its bounds are inside the true hold,
within half a window.

The moving variances come from cumulative sums restarted every block of
a few windows (:data:`BLOCK_WINDOWS`), each block shifted by its first
sample (O(n), no loop over samples; the rounding error of a window is that
of summing a few ``w`` small deviations, not ``n`` large values), so a
recording in raw counts with a large offset keeps its small noise variance.

:func:`accelcal.methods.triad.threshold.choose_factor` sweeps the factor
by the residual of a triad calibration ([1]_ sec. III).

References
----------
.. [1] D. Tedaldi, A. Pretto, E. Menegatti, "A robust and easy to implement
   method for IMU calibration without external equipments", IEEE ICRA 2014,
   pp. 3042-3049.
.. [2] imu_tk (A. Pretto), ``staticIntervalsDetector`` and the threshold
   sweep of ``MultiPosCalibration`` (reference implementation of [1]).
"""

from dataclasses import dataclass, field

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.plotting.decimate import BINS, envelope_indices

STILL_RATIO = 4.0
"""Largest ratio of the initial period's variance magnitude to the median of
its 1-window magnitudes for the period to count as still. White noise gives
about 1 (both estimate the same variance); a motion inside the period adds
the change of the mean to the whole-period variance only, by orders of
magnitude (a tilt of a few degrees moves the mean by ~1 m/s^2 against a
noise SD of ~0.01 m/s^2). 4 leaves room for slow drift of the bias."""

@dataclass(frozen=True)
class StaticIntervals:
    """Static intervals found in a recording (sample ranges ``start:stop``).

    Attributes
    ----------
    start, stop, counts : numpy.ndarray
        First and one-past-last sample index of each interval, and its samples.
    times : numpy.ndarray
        Start and stop times of each interval in seconds, shape ``(k, 2)``.
    means, noise_sd : numpy.ndarray
        Mean and SD of one sample of each axis in each interval, ``(k, 3)``.
    threshold, init_variance : float
        Threshold on ς, and ς of the initial still period (input unit squared).
    settings : dict
        ``init_static, window, factor, min_length`` (s, s, 1, s) and ``rate`` (Hz).
    statistic : numpy.ndarray
        ς of every sample (for the figure); ``unit``: the values' unit.
    trace : tuple, optional
        ``(time, |u|)`` of the samples ``statistic`` holds, where those are a
        thinned subset (a streamed recording: :mod:`accelcal.signal.static_stream`).
    """

    start: np.ndarray
    stop: np.ndarray
    times: np.ndarray
    means: np.ndarray
    noise_sd: np.ndarray
    counts: np.ndarray
    threshold: float
    init_variance: float
    settings: dict
    statistic: np.ndarray = field(repr=False)
    unit: str = ""
    trace: tuple | None = field(default=None, repr=False)
    excluded: dict = field(default_factory=dict)
    """With samples excluded (clipped): ``samples`` excluded where the statistic was
    still, ``cut`` intervals cut around them, ``dropped`` intervals left too short
    (:meth:`Excluded.counts`)."""

    def __len__(self) -> int:
        return len(self.start)

    @property
    def lengths(self) -> np.ndarray:
        """Length of each interval, seconds (samples / rate)."""
        return self.counts / self.settings["rate"]

    def rows(self) -> list[dict]:
        """One row per interval: times, length, samples, means and noise SD per axis."""
        rows = []
        for k in range(len(self)):
            row = {"interval": k + 1, "start_s": float(self.times[k, 0]),
                   "stop_s": float(self.times[k, 1]), "length_s": float(self.lengths[k]),
                   "start_index": int(self.start[k]), "stop_index": int(self.stop[k]),
                   "samples": int(self.counts[k])}
            row.update({f"mean_{a}": float(v) for a, v in zip("xyz", self.means[k], strict=True)})
            row.update({f"sd_{a}": float(v) for a, v in zip("xyz", self.noise_sd[k], strict=True)})
            row["unit"] = self.unit
            rows.append(row)
        return rows


def moving_variance(values: np.ndarray, w: int) -> np.ndarray:
    """Variance (ddof 1) of each column over a centred window of ``w`` samples.

    Windows are cut at the ends of the record (fewer samples there). O(n),
    one column at a time, no index arrays: the samples are split in blocks
    of :data:`BLOCK_WINDOWS` windows, each shifted by its first sample, and
    the cumulative sums of the shifted values and of their squares are
    taken within each block. A full window is a difference of two sums of
    its block, or, where it runs into the next block, the tail of its block
    and the head of the next, brought to its block's shift exactly
    (``sum (y + d)^2 = sum y^2 + 2 d sum y + m d^2``): every full window
    comes from whole-array operations on the ``(blocks, L)`` sums
    (:func:`_full_windows`). The rounding error is that of summing
    :data:`BLOCK_WINDOWS` ``w`` deviations from a nearby sample, whatever
    the offset of the signal or the length of the record.

    Parameters
    ----------
    values : numpy.ndarray
        Samples, shape ``(n, m)``.
    w : int
        Window length in samples, at least 2.

    Returns
    -------
    numpy.ndarray
        Shape ``(n, m)``.
    """
    values = np.asarray(values, dtype=float)
    out = np.empty(values.shape)
    for c in range(values.shape[1]):
        out[:, c] = _column_variance(values[:, c], w)
    return out


def variance_magnitude(values: np.ndarray, w: int) -> np.ndarray:
    """ς of every sample: the norm of the columns' moving variances (Eq. (9) [1]_).

    :func:`moving_variance` one column at a time, squared and summed in
    place: the working memory is a few copies of one column, never of
    ``(n, m)`` arrays.
    """
    values = np.asarray(values, dtype=float)
    total = np.zeros(len(values))
    for c in range(values.shape[1]):
        var = _column_variance(values[:, c], w)
        np.square(var, out=var)
        total += var
    return np.sqrt(total, out=total)


def _column_variance(x: np.ndarray, w: int) -> np.ndarray:
    """:func:`moving_variance` of one column ``x`` (n,)."""
    n, half = len(x), w // 2
    out = np.empty(n)
    if n >= w:
        full = n - w + 1  # windows [lo, lo + w) with lo = 0 .. n - w
        out[half:half + full] = _full_windows(x, w)[:full]
        edges = (np.arange(half), np.arange(half + full, n))
    else:
        edges = (np.arange(n),)
    for idx in edges:
        if len(idx):
            out[idx] = _clipped_variance(x, idx, w)
    return np.maximum(out, 0.0, out=out)


BLOCK_WINDOWS = 4
"""Windows per block of :func:`moving_variance`'s shifted cumulative sums: a window that
ends inside its block is one difference of sums; only the ``w - 1`` of each block that run
into the next take the shift's correction. More would save little and sum more deviations
(a step inside a block: 16 gave 2e-9 of the variance, 4 gives 1e-10)."""


def _full_windows(x: np.ndarray, w: int) -> np.ndarray:
    """Variance of the windows ``x[lo:lo + w]``, ``lo = 0, 1, ...``: keep the first ``n - w + 1``.

    The rest run into padding and are to be dropped. Block ``b`` (``L`` samples, a multiple
    of ``w``) holds its samples less its first one, ``ref_b``; ``S`` and ``Q`` are the
    cumulative sums of the shifted values and of their squares within each block. A window
    starting ``r`` samples into block ``b`` is ``S_b[r + w] - S_b[r]`` (``Q`` alike) when it
    ends in the block; otherwise it takes the tail of block ``b`` and ``j = r + w - L``
    samples of block ``b + 1``, whose shift differs by ``d_b = ref_{b+1} - ref_b``:

        s1 = S_b[L] - S_b[r] + S_{b+1}[j] + j d_b
        s2 = Q_b[L] - Q_b[r] + Q_{b+1}[j] + d_b (2 S_{b+1}[j] + j d_b)
        var = (s2 - s1^2 / w) / (w - 1)
    """
    n = len(x)
    size = w * max(1, min(BLOCK_WINDOWS, n // w))  # L
    blocks = n // size + 1  # blocks * L > n: every whole window starts in a block but the last
    whole = (n // size) * size
    ref = np.empty(blocks)
    ref[:-1] = x[:whole:size]
    ref[-1] = x[whole] if whole < n else x[n - 1]
    y = np.empty((blocks, size))
    np.subtract(x[:whole].reshape(-1, size), ref[:-1, None], out=y[:-1])
    y[-1, :n - whole] = x[whole:] - ref[-1]
    y[-1, n - whole:] = x[n - 1] - ref[-1]  # padding
    s = np.empty((blocks, size + 1))
    s[:, 0] = 0.0
    np.cumsum(y, axis=1, out=s[:, 1:])
    np.square(y, out=y)
    q = np.empty((blocks, size + 1))
    q[:, 0] = 0.0
    np.cumsum(y, axis=1, out=q[:, 1:])
    del y
    out = np.empty((blocks, size))
    inside = size - w + 1  # windows that end in their block: r = 0 .. L - w
    s1 = s[:, w:] - s[:, :inside]
    np.subtract(q[:, w:], q[:, :inside], out=out[:, :inside])
    np.square(s1, out=s1)
    s1 *= 1.0 / w
    out[:, :inside] -= s1
    if w > 1 and blocks > 1:  # the others: r = L - w + 1 .. L - 1, j = 1 .. w - 1
        d = (ref[1:] - ref[:-1])[:, None]
        head = s[1:, 1:w]  # S_{b+1}[j]
        h = np.arange(1, w, dtype=float) * d  # j d
        h += head  # the head's sum in block b's shift
        s1 = s[:-1, size:] - s[:-1, inside:size]
        s1 += h
        h += head
        h *= d  # d (2 S_{b+1}[j] + j d)
        s2 = q[:-1, size:] - q[:-1, inside:size]
        s2 += q[1:, 1:w]
        s2 += h
        np.square(s1, out=s1)
        s1 *= 1.0 / w
        np.subtract(s2, s1, out=out[:-1, inside:])
    out *= 1.0 / (w - 1)
    return out.reshape(-1)


def _clipped_variance(x: np.ndarray, idx: np.ndarray, w: int) -> np.ndarray:
    """Variance of the windows of samples ``idx`` (consecutive), cut at the record's ends."""
    n, half = len(x), w // 2
    lo = np.clip(idx - half, 0, n)
    hi = np.clip(idx - half + w, 0, n)
    a = int(lo[0])
    seg = x[a:int(hi[-1])] - x[a]  # at most w + len(idx) samples, shifted by the first
    s1 = np.concatenate(([0.0], np.cumsum(seg)))
    s2 = np.concatenate(([0.0], np.cumsum(seg * seg)))
    count = (hi - lo).astype(float)
    sum1 = s1[hi - a] - s1[lo - a]
    sum2 = s2[hi - a] - s2[lo - a]
    return (sum2 - sum1 * sum1 / count) / np.maximum(count - 1.0, 1.0)


def detect_static(values, rate: float, *, init_static: float = 30.0, window: float = 1.0,
                  factor: float = 2.0, min_length: float = 2.0, time=None,
                  unit: str = "", exclude=None) -> StaticIntervals:
    """Find the static intervals of a triad recording (Tedaldi's detector).

    Parameters
    ----------
    values : array_like
        Samples of the three axes, shape ``(n, 3)``, any unit.
    rate : float
        Sample rate, Hz.
    init_static : float
        Length of the still period at the start, seconds (Tedaldi: 30-50 s).
    window : float
        Window ``t_w`` of the moving variance, seconds (1-2 s).
    factor : float
        Threshold as a multiple of the initial period's ς (> 0).
    min_length : float
        Shortest interval kept, seconds.
    time : array_like, optional
        Time of each sample, seconds (default: index / rate).
    unit : str
        Unit of ``values`` (for the tables).
    exclude : array_like of bool, optional
        Samples that are never static (clipped: :class:`accelcal.signal.clipping.ClipFinder`):
        an interval is cut around them, and a piece shorter than ``min_length``
        dropped (counted in ``excluded``).

    Returns
    -------
    StaticIntervals

    Raises
    ------
    AccelcalError
        "no still period at the start" when ``init_static`` is longer than
        the record, shorter than the window, or the period moves; "no
        static intervals found" (with the threshold and the longest still
        run) when no run is long enough; bad shapes or settings.
    """
    u = np.asarray(values, dtype=float)
    if u.ndim != 2 or u.shape[1] != 3 or len(u) < 3:
        raise AccelcalError(f"need samples of three axes, shape (n, 3); got {u.shape}",
                            parameter="values")
    if not np.isfinite(u).all():
        raise AccelcalError("samples contain NaN or infinite values", parameter="values")
    check_settings(rate=rate, window=window, factor=factor, init_static=init_static,
                   min_length=min_length)
    n = len(u)
    duration = n / rate
    w = round(min(window * rate, n + 1.0))
    if w < 3 or w > n:
        raise AccelcalError(
            f"{window:g} s is {w} samples at {rate:g} Hz; the window needs 3 samples to "
            f"{n} (the record)", parameter="window")
    n_init = round(min(init_static * rate, n + 1.0))
    if n_init > n:
        raise AccelcalError(
            f"no still period at the start: {init_static:g} s is longer than the record "
            f"({duration:.4g} s); give a shorter one", parameter="init_static")
    if n_init < w:
        raise init_shorter_than_window(init_static, window)
    stat = variance_magnitude(u, w)  # Eq. (9) [Tedaldi2014]
    init = initial_variance(u[:n_init], stat[:n_init], w, init_static, window)
    threshold = factor * init
    still, excluded = stat < threshold, None
    if exclude is not None:
        excluded = Excluded()
        still = excluded.add(0, still, np.asarray(exclude, dtype=bool).reshape(n))
    starts, stops = _runs(still)
    longest = float((stops - starts).max()) / rate if len(starts) else 0.0
    keep = (stops - starts) >= max(min_length * rate, 2)
    starts, stops = starts[keep], stops[keep]
    counted = {} if excluded is None else excluded.counts(starts, max(min_length * rate, 2), n)
    if not len(starts):
        raise no_intervals(longest, min_length=min_length, factor=factor, init=init,
                           window=window, dropped=counted.get("dropped", 0))
    t = np.arange(n) / rate if time is None else np.asarray(time, dtype=float)
    means = np.array([u[a:b].mean(axis=0) for a, b in zip(starts, stops, strict=True)])
    sd = np.array([u[a:b].std(axis=0, ddof=1) for a, b in zip(starts, stops, strict=True)])
    settings = {"init_static": float(init_static), "window": float(window),
                "factor": float(factor), "min_length": float(min_length), "rate": float(rate)}
    return StaticIntervals(
        start=starts, stop=stops, times=np.column_stack([t[starts], t[stops - 1]]),
        means=means, noise_sd=sd, counts=stops - starts, threshold=threshold,
        init_variance=init, settings=settings, statistic=stat, unit=unit, excluded=counted)


class Excluded:
    """Still runs that hold excluded samples, counted as a recording streams by.

    :meth:`add` takes each chunk's still flags and excluded samples and
    returns the flags without them; :meth:`counts` compares the still runs
    that held an excluded sample with the intervals kept: a run of at least
    the shortest interval is *cut* when a piece of it was kept, else
    *dropped*.
    """

    def __init__(self):
        self.open = None  # [start, holds an excluded sample] of the run open at the chunk's end
        self.hit = []  # (start, stop) of the closed still runs with an excluded sample
        self.samples = 0

    def add(self, done: int, still: np.ndarray, exclude: np.ndarray) -> np.ndarray:
        """Samples ``done .. done + len(still)``: ``still`` without the ``exclude`` ones."""
        if exclude.shape != still.shape:
            raise AccelcalError(f"exclude has {exclude.shape[0]} samples, the recording "
                                f"{still.shape[0]}", parameter="exclude")
        self.samples += int((still & exclude).sum())
        starts, stops = _runs(still)
        if self.open is not None and (not len(starts) or starts[0] > 0):
            self._close(done)
        held = np.r_[0, np.cumsum(exclude)]
        hits = held[stops] > held[starts]
        for k in range(len(starts)):
            if k == 0 and starts[0] == 0 and self.open is not None:
                self.open[1] |= bool(hits[0])
            elif hits[k] or stops[k] == len(still):
                self.open = [done + int(starts[k]), bool(hits[k])]
            else:
                continue
            if stops[k] < len(still):
                self._close(done + int(stops[k]))
        return still & ~exclude

    def _close(self, stop: int) -> None:
        start, hit = self.open
        self.open = None
        if hit:
            self.hit.append((start, stop))

    def counts(self, starts, min_samples: float, end: int) -> dict:
        """``samples``, ``cut`` and ``dropped``; ``cut_at``, ``dropped_at``: first samples.

        The first samples of the first five runs cut and dropped; the
        intervals kept start at ``starts``, the recording ends at ``end``.
        """
        if self.open is not None:
            self._close(end)
        starts = np.sort(np.asarray(starts))
        long = [(a, b) for a, b in self.hit if b - a >= min_samples]
        kept = [bool(np.searchsorted(starts, b) > np.searchsorted(starts, a)) for a, b in long]
        cut = [a for (a, _), k in zip(long, kept, strict=True) if k]
        dropped = [a for (a, _), k in zip(long, kept, strict=True) if not k]
        return {"samples": self.samples, "cut": len(cut), "dropped": len(dropped),
                "cut_at": cut[:5], "dropped_at": dropped[:5]}


def initial_variance(u_init: np.ndarray, stat_init: np.ndarray, w: int, init_static: float,
                     window: float) -> float:
    """ς of the initial still period, refused when the period is not still.

    Parameters
    ----------
    u_init : numpy.ndarray
        The period's samples, ``(n_init, 3)``.
    stat_init : numpy.ndarray
        ς of the same samples (final: their windows complete where the record allows).
    w : int
        Window, samples.
    init_static, window : float
        The settings, seconds (for the messages).
    """
    n_init = len(u_init)
    init = float(np.linalg.norm(np.var(u_init, axis=0, ddof=1)))
    quiet = float(np.median(stat_init[w // 2:n_init - w // 2] if n_init > w else stat_init))
    if not np.ptp(u_init, axis=0).any():
        raise AccelcalError(
            "no still period at the start: the first samples are all equal (no noise), so a "
            "threshold relative to their variance is 0; is the signal quantised or synthetic?",
            parameter="init_static")
    if init > STILL_RATIO * quiet:
        raise AccelcalError(
            f"no still period at the start: the first {init_static:g} s vary "
            f"{init / max(quiet, 1e-300):.3g} times more than their quietest {window:g} s "
            f"windows (a still period: under {STILL_RATIO:g}); give a shorter one that "
            "ends before the first motion", parameter="init_static")
    return init


def init_shorter_than_window(init_static: float, window: float) -> AccelcalError:
    """The error of an initial still period shorter than the window."""
    return AccelcalError(
        f"no still period at the start: {init_static:g} s is shorter than the window "
        f"({window:g} s); give a longer one or a shorter window", parameter="init_static")


def no_intervals(longest: float, *, min_length: float, factor: float, init: float,
                 window: float, dropped: int = 0) -> AccelcalError:
    """The error of a detection that kept no interval.

    ``longest``: the longest run, s; ``dropped``: intervals left too short by
    excluded (clipped) samples.
    """
    clip = (f"; {dropped} interval(s) were dropped for clipped samples (too short without "
            "them)" if dropped else "")
    return AccelcalError(
        f"no static intervals found: the longest still run is {longest:.3g} s, below "
        f"min_length {min_length:g} s (threshold {factor * init:.3g} = {factor:g} x "
        f"{init:.3g} of the initial period, window {window:g} s){clip}; lower min_length, "
        "raise the factor or hold the positions longer", parameter="min_length")


def check_settings(**settings) -> None:
    """Refuse a detection setting that is not a finite number > 0 (``min_length`` >= 0)."""
    for name, value in settings.items():
        sign = ">=" if name == "min_length" else ">"
        if not (np.isfinite(value) and (value > 0 or (sign == ">=" and value == 0))):
            raise AccelcalError(f"{value!r} must be a finite number {sign} 0", parameter=name)


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and stop indices of the runs of True in ``mask``."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)


def figure(intervals: StaticIntervals, values=None, *, time=None, bins: int = BINS):
    """The signal norm with the static intervals shaded, and ς with its threshold.

    Parameters
    ----------
    intervals : StaticIntervals
        From :func:`detect_static` on ``values``, or streamed (its ``trace``).
    values : array_like, optional
        The samples, ``(n, 3)``; None for intervals that carry their trace.
    time : array_like, optional
        Time of each sample, seconds (default: index / rate).
    bins : int
        Horizontal bins of each curve's envelope: the points drawn are each
        bin's first, last, least and greatest
        (:func:`accelcal.plotting.decimate.envelope_indices`).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from accelcal.formatting import format_unit, unit_squared
    from accelcal.plotting import new_figure

    if values is None:
        t, norm = intervals.trace
        stat = intervals.statistic
    else:
        u = np.asarray(values, dtype=float)
        t = np.arange(len(u)) / intervals.settings["rate"] if time is None else np.asarray(time)
        norm, stat = np.linalg.norm(u, axis=1), intervals.statistic
    stat = np.maximum(stat, 1e-300)
    drawn = [envelope_indices(t, y, bins) for y in (norm, stat)]
    fig = new_figure(figsize=(8.0, 5.0))
    top, bottom = fig.subplots(2, 1, sharex=True)
    top.plot(t[drawn[0]], norm[drawn[0]], lw=0.6, color="k")
    unit = format_unit(intervals.unit) if intervals.unit else "input unit"
    top.set_ylabel(f"|u| ({unit})")
    bottom.semilogy(t[drawn[1]], stat[drawn[1]], lw=0.6)
    bottom.axhline(intervals.threshold, color="r", lw=0.8,
                   label=f"threshold ({intervals.settings['factor']:g} x initial)")
    squared = format_unit(unit_squared(intervals.unit)) if intervals.unit else "input unit²"
    bottom.set(ylabel=f"ς, variance magnitude ({squared})", xlabel="time (s)")
    bottom.legend(loc="upper right", fontsize="small")
    for a, b in intervals.times:
        for ax in (top, bottom):
            ax.axvspan(a, b, color="tab:green", alpha=0.25, lw=0)
    top.set_title(f"{len(intervals)} static intervals")
    return fig
