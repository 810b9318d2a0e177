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
``w`` samples, each block shifted by its first sample (O(n), no loop over
samples; the rounding error of a window is that of summing ``w`` small
deviations, not ``n`` large values), so a recording in raw counts with a
large offset keeps its small noise variance.

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

    Windows are cut at the ends of the record (fewer samples there). O(n):
    the samples are split in blocks of ``w``, each shifted by its first
    sample; window sums are differences of cumulative sums within a block,
    and a window spanning two blocks is brought to the first block's shift
    exactly (``sum (y + d)^2 = sum y^2 + 2 d sum y + m d^2``). The rounding
    error is that of summing ``w`` deviations from a nearby sample, whatever
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
    n, m = values.shape
    half = w // 2
    idx = np.arange(n)
    lo = np.clip(idx - half, 0, n)
    hi = np.clip(idx - half + w, 0, n)
    blocks = n // w + 2
    padded = np.zeros((blocks * w, m))
    padded[:n] = values
    padded = padded.reshape(blocks, w, m)
    ref = padded[:, 0].copy()
    y = padded - ref[:, None]
    s1 = np.zeros((blocks, w + 1, m))
    s2 = np.zeros((blocks, w + 1, m))
    np.cumsum(y, axis=1, out=s1[:, 1:])
    np.cumsum(y * y, axis=1, out=s2[:, 1:])
    bl, bh = lo // w, hi // w
    span = (bh > bl)[:, None]
    end_l = np.where(bh > bl, w, hi % w)
    n_h = np.where(span, (hi % w)[:, None], 0).astype(float)
    d = ref[bh] - ref[bl]
    part1_h = np.where(span, s1[bh, hi % w], 0.0)
    sum1 = s1[bl, end_l] - s1[bl, lo % w] + part1_h + n_h * d
    sum2 = (s2[bl, end_l] - s2[bl, lo % w] + np.where(span, s2[bh, hi % w], 0.0)
            + 2.0 * d * part1_h + n_h * d * d)
    count = (hi - lo)[:, None].astype(float)
    var = (sum2 - sum1 * sum1 / count) / np.maximum(count - 1.0, 1.0)
    return np.maximum(var, 0.0)


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
    stat = np.linalg.norm(moving_variance(u, w), axis=1)  # Eq. (9) [Tedaldi2014]
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
