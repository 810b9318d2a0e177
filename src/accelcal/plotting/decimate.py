"""Min/max ("envelope") decimation of dense curves before they are drawn.

A line of many more points than its axes have pixel columns draws, in each
column, only the vertical span from its lowest to its highest point and its
joins to the neighbouring columns. :func:`envelope_indices` keeps, in each of
``bins`` horizontal bins, the first, last, lowest and highest point (the M4
aggregation of [Jugel2014]_), so that the decimated line draws the same
picture from at most ``4 bins`` points, in O(n) time and memory.

References
----------
.. [Jugel2014] Jugel U., Jerzak Z., Hackenbroich G., Markl V., "M4: a
   visualization-oriented time series data aggregation", Proc. VLDB
   Endowment 7(10), 797-808, 2014.
"""

import numpy as np

BINS = 1500
"""Default bins: about twice an axes' width in pixels of a saved figure (PNG at 150 dpi)."""


def envelope_indices(x, y, bins: int = BINS, *, log: bool = False) -> np.ndarray:
    """Indices of the points to draw of ``y`` against ``x``: each bin's first, last, min, max.

    Parameters
    ----------
    x : array_like, (n,)
        Abscissae, increasing (finite; > 0 with ``log``).
    y : array_like, (n,) or (n, k)
        The ordinates; the columns of a 2-D ``y`` are curves sharing ``x``,
        decimated alike: the indices keep every column's envelope.
    bins : int
        Horizontal bins, equal in ``x`` (or in ``log x``) between its least
        and greatest value; about twice the axes' width in pixels.
    log : bool
        Bins equal in ``log x`` (for a logarithmic x axis).

    Returns
    -------
    numpy.ndarray of int
        Increasing indices into ``x``: all of them when ``n <= 4 bins``,
        else at most ``(2 + 2 k) bins`` for ``k`` columns (``x`` increasing;
        ``4 bins`` for one curve) and, per bin and column, the first
        non-finite ``y``, so that a gap in a curve stays a gap.

    Raises
    ------
    ValueError
        If ``log`` and an ``x`` is not > 0.

    Notes
    -----
    The bins are runs of consecutive samples in one bin, so an ``x`` that is
    not increasing is still drawn faithfully, from more points. The least
    and greatest ``y`` of a bin are its extremes on any monotonic y scale
    (linear or logarithmic) alike; a tie keeps its first point.

    References
    ----------
    .. [1] Jugel2014, sec. 4 (M4: first, last, min and max per pixel column).
    """
    x = np.asarray(x, dtype=float)
    n = x.size
    if n <= 4 * bins:
        return np.arange(n)
    if log and not np.all(x > 0):
        raise ValueError("log binning needs every x > 0; drop the points at x <= 0 first")
    u = np.log(x) if log else x
    lo, hi = u.min(), u.max()
    which = np.minimum(((u - lo) * (bins / (hi - lo) if hi > lo else 0.0)).astype(np.intp),
                       bins - 1)
    starts = np.flatnonzero(np.r_[True, which[1:] != which[:-1]])
    run = np.repeat(np.arange(starts.size), np.diff(np.r_[starts, n]))
    keep = np.zeros(n, dtype=bool)
    keep[starts] = True
    keep[np.r_[starts[1:], n] - 1] = True
    for col in np.asarray(y, dtype=float).reshape(n, -1).T:
        low, high = np.fmin.reduceat(col, starts), np.fmax.reduceat(col, starts)
        for hit in (col == low[run], col == high[run], ~np.isfinite(col)):
            keep[_first_per_run(hit, run)] = True
    return np.flatnonzero(keep)


def _first_per_run(hit: np.ndarray, run: np.ndarray) -> np.ndarray:
    """The first index where ``hit`` is true in each run of equal ``run`` (if it has one)."""
    idx = np.flatnonzero(hit)
    return idx[np.r_[True, run[idx[1:]] != run[idx[:-1]]]] if idx.size else idx
