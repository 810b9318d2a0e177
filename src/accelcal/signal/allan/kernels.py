"""Sums of squared phase differences: the O(N)-per-tau kernels of the deviations.

Rate samples ``y`` (acceleration) become phase ``x`` through a cumulative sum
(:func:`phase`); every deviation of [SP1065]_ is then a mean of squared
finite differences of ``x`` at lag ``m``:

* ``adev``/``hdev``: second/third differences of ``x[::m]`` (non-overlapping,
  O(N/m));
* ``oadev``/``ohdev``: second/third differences at lag m from every start
  sample, O(N), computed in cache-sized chunks (``x[i+2m] - 2 x[i+m] + x[i]``
  from three offset slices, no array of N temporaries);
* ``mdev``: second differences at lag m of the phase's moving sums over m
  samples, carried from factor to factor along m's binary digits (one
  addition per octave, :class:`MovingSums`), or, for a factor far from the
  previous one, the second differences ``d_i`` at lag m and their moving
  sums over m samples through one cumulative sum; O(N) either way, and
  neither takes third differences of a doubly cumulated phase (whose
  rounding errors would grow with N^1.5, not stay at the size of the terms);
* ``totdev``: the phase extended by odd reflection about both end points
  (``x*_{1-j} = 2 x_1 - x_{1+j}``, ``x*_{N+j} = 2 x_N - x_{N-j}``), then
  centred second differences at every interior point, O(N).

Phase is kept in units of ``tau0 * y`` (``x = cumsum(y - mean(y))``, no
``tau0`` factor): a deviation of ``y`` at ``tau = m tau0`` is then
``sqrt(sum / (2 n)) / m`` (``/ m**2`` for MDEV, ``6 n`` for the Hadamard
kinds), free of ``tau0``.

Why the mean is subtracted first: a still accelerometer reads its bias plus
gravity (up to 9.8 m/s^2) while its noise is 1e-5 m/s^2 or less. The
cumulative sum of the raw samples grows to ``N * mean`` (1e8 for 1e7
samples at 1 g) and each phase value carries a rounding error of about
``1e-16 * 1e8 = 1e-8``, comparable with the second differences themselves
at short tau. Without the mean the phase is a random walk of size
``sqrt(N) * noise`` and its rounding error is 1e-13 of the differences. A
constant offset does not change any deviation (every kernel annihilates a
linear phase, the reflections of TOTDEV included), so removing it is exact.

References
----------
.. [SP1065] Riley W. J., Handbook of Frequency Stability Analysis, NIST
   Special Publication 1065, 2008, eqs. (7), (11), (14), (18), (20), (25).
.. [Howe2000] Howe D. A., The total deviation approach to long-term
   characterization of frequency stability, IEEE Trans. UFFC 47(5), 2000.
"""

import functools

import numpy as np

CHUNK = 1 << 15
"""Samples per chunk of the overlapping kernels (256 KiB of float64: stays in cache)."""


@functools.cache
def _blas():
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


def one_blas_thread():
    """Context in which BLAS (the ``np.dot`` of the kernels) runs on one thread.

    Each chunk's dot product is ~10 us of work: OpenBLAS splits it across its
    threads, which then wait on each other whenever another process holds a
    core; an octave OADEV of 1e7 samples took 4-8 s that way on a busy
    2-core machine instead of 0.45 s. One thread is as fast on an idle
    machine (the kernels are bound by memory bandwidth). ~25 us per use.
    """
    return _blas().limit(limits=1, user_api="blas")


def phase(y: np.ndarray) -> np.ndarray:
    """Phase of rate samples in units of ``tau0 * y``: ``x[0] = 0``, ``x[k] = sum(y[:k] - mean)``.

    Parameters
    ----------
    y : numpy.ndarray
        Rate samples, 1-D float64, finite.

    Returns
    -------
    numpy.ndarray
        ``len(y) + 1`` phase points (float64).
    """
    x = np.empty(len(y) + 1)
    x[0] = 0.0
    mean = float(np.mean(y))
    step = 32 * CHUNK  # the mean is subtracted block by block: no copy of y
    for a in range(0, len(y), step):
        block = y[a:a + step] - mean
        out = x[a + 1:a + 1 + len(block)]
        np.cumsum(block, out=out)
        out += x[a]
    return x


def lag_sumsq(x: np.ndarray, start: int, count: int, m: int, order: int) -> float:
    """Sum of squared ``order``-th differences of ``x`` at lag ``m`` from ``count`` start points.

    ``sum_{i < count} (Delta_m^order x[start + i])^2``, with
    ``Delta_m^2 x[i] = x[i+2m] - 2 x[i+m] + x[i]`` and
    ``Delta_m^3 x[i] = x[i+3m] - 3 x[i+2m] + 3 x[i+m] - x[i]``; O(count)
    time, O(:data:`CHUNK`) extra memory.
    """
    size = min(CHUNK, count)
    buffers = (np.empty(size), np.empty(size) if order == 3 else None)
    with one_blas_thread():
        return _chunked(x, start, start + count, m, order, buffers=buffers)


def _chunked(x, start, stop, m, order, *, buffers) -> float:
    w, u = buffers
    total = 0.0
    for a in range(start, stop, CHUNK):
        b = min(a + CHUNK, stop)
        wv = w[:b - a]
        if order == 2:  # Eq. (11) [SP1065]: x[i+2m] - 2 x[i+m] + x[i]
            np.subtract(x[a + 2 * m:b + 2 * m], x[a + m:b + m], out=wv)
            np.subtract(wv, x[a + m:b + m], out=wv)
            np.add(wv, x[a:b], out=wv)
        else:  # Eq. (20) [SP1065]: x[i+3m] - 3 x[i+2m] + 3 x[i+m] - x[i]
            uv = u[:b - a]
            np.subtract(x[a + 2 * m:b + 2 * m], x[a + m:b + m], out=uv)
            uv *= 3.0
            np.subtract(x[a + 3 * m:b + 3 * m], x[a:b], out=wv)
            np.subtract(wv, uv, out=wv)
        total += float(np.dot(wv, wv))
    return total


def nonoverlapping_sumsq(x: np.ndarray, m: int, order: int) -> tuple[float, int]:
    """Sum of squared ``order``-th differences of ``x[::m]`` and their number (Eqs. (7), (18)).

    The differences at lag 1 of the strided view, in chunks (no copy of the
    record: at m = 1 a whole-array ``np.diff`` allocated two arrays of the
    record's size).
    """
    v = x[::m]
    count = len(v) - order
    return (lag_sumsq(v, 0, count, 1, order) if count > 0 else 0.0), max(count, 0)


def mdev_sumsq(x: np.ndarray, m: int, work: tuple[np.ndarray, np.ndarray]) -> tuple[float, int]:
    """Sum of squared MDEV terms at factor ``m`` and their number (Eq. (14) [SP1065]).

    The term at ``j`` is ``sum_{i=j}^{j+m-1} (x[i+2m] - 2 x[i+m] + x[i])``:
    the moving sum over ``m`` of the second differences, taken as
    differences of their cumulative sum. ``work`` is two float64 buffers of
    ``len(x) + 1`` samples, reused across taus.
    """
    d_buf, c_buf = work
    n2 = len(x) - 2 * m
    d = d_buf[:n2]
    np.subtract(x[2 * m:], x[m:m + n2], out=d)
    np.subtract(d, x[m:m + n2], out=d)
    np.add(d, x[:n2], out=d)
    c = c_buf[:n2 + 1]
    c[0] = 0.0
    np.cumsum(d, out=c[1:])
    n = n2 + 1 - m
    v = d_buf[:n]
    np.subtract(c[m:], c[:n], out=v)  # Eq. (14) [SP1065] inner sum over i = j..j+m-1
    return float(np.dot(v, v)), n


CHAIN_PASSES = 8
"""Most passes over the phase (one addition each) that :class:`MovingSums` may take to reach
the next MDEV factor; a factor further away takes :func:`mdev_sumsq` (a cumulative sum, the
cost of about eight passes)."""


class MovingSums:
    """Moving sums of the phase, ``A_a[j] = x[j] + ... + x[j+a-1]``, carried from factor to factor.

    The MDEV term at factor ``m`` is a second difference of ``A_m`` at lag ``m``
    (Eq. (14) [SP1065]: ``sum_{i=j}^{j+m-1} (x[i+2m] - 2 x[i+m] + x[i]) =
    A_m[j+2m] - 2 A_m[j+m] + A_m[j]``), and ``A`` follows the binary digits of
    ``m``: ``A_{2a}[j] = A_a[j] + A_a[j+a]`` and ``A_{a+1}[j] = A_a[j] + x[j+a]``,
    one vectorised addition each (``A_1 = x``). Octave factors double ``a``
    each time: one addition per tau and no cumulative sum (a cumulative sum
    is sequential, about eight additions' time). The sums are of at most
    ``m`` phase points, added pairwise as the doublings go: their rounding
    errors are those of the phase values (times about log2 m), never those
    of a cumulated phase.
    ``work`` is two float64 buffers of ``len(x)`` samples (ping-pong).
    """

    def __init__(self, x: np.ndarray, work: tuple[np.ndarray, np.ndarray]):
        self.x, self.work = x, work
        self.a, self.sums, self.spare = 1, x, 0

    def passes(self, m: int) -> int:
        """Additions to reach factor ``m`` from the current one (or from ``A_1``)."""
        return min(_steps(self.a, m), _steps(1, m))

    def reach(self, m: int) -> np.ndarray:
        """``A_m`` (its first ``len(x) - m + 1`` values are valid)."""
        if _steps(1, m) < _steps(self.a, m):
            self.a, self.sums = 1, self.x
        shift = m.bit_length() - self.a.bit_length()
        for bit in reversed(range(shift)):
            self._add(double=True)  # A_{2a}
            if (m >> bit) & 1:
                self._add(double=False)  # A_{a + 1}: the next phase point
        return self.sums

    def reset(self) -> None:
        """Back to ``A_1 = x`` (the buffers were used for something else)."""
        self.a, self.sums = 1, self.x

    def _add(self, *, double: bool) -> None:
        """``A_a`` plus ``A_a`` (double) or ``x`` shifted by ``a``, into the spare buffer."""
        other, step = (self.sums, self.a) if double else (self.x, 1)
        n = len(self.x) - (self.a + step) + 1
        out = self.work[self.spare][:n]
        np.add(self.sums[:n], other[self.a:self.a + n], out=out)
        self.sums, self.spare, self.a = out, 1 - self.spare, self.a + step


def _steps(a: int, m: int) -> int:
    """Additions from ``A_a`` to ``A_m`` along ``m``'s binary digits (huge: ``a`` does not lead)."""
    shift = m.bit_length() - a.bit_length()
    if shift < 0 or (m >> shift) != a:
        return 1 << 30
    return shift + bin(m & ((1 << shift) - 1)).count("1")


def mdev_sumsq_bounded(x, m: int, chunk: int = CHUNK) -> tuple[float, int]:
    """:func:`mdev_sumsq` in memory bounded by ``chunk`` samples (``x`` may be a memmap).

    The inner sums ``v_j = sum_{i=j}^{j+m-1} d_i`` (``d_i`` the second
    differences at lag m) follow ``v_{j+1} = v_j + d_{j+m} - d_j``: each chunk
    of ``j`` needs ``d`` on two windows of the chunk's length, i.e. four
    slices of ``x``, so the work arrays never exceed ``chunk`` samples.
    """
    def second(a: int, b: int) -> np.ndarray:
        return (np.asarray(x[a + 2 * m:b + 2 * m]) - 2.0 * np.asarray(x[a + m:b + m])
                + np.asarray(x[a:b]))

    n = len(x) - 3 * m + 1
    v0 = 0.0
    for a in range(0, m, chunk):
        v0 += float(np.sum(second(a, min(a + chunk, m))))
    total = 0.0
    for a in range(0, n, chunk):
        b = min(a + chunk, n)
        step = second(a + m, b + m - 1) - second(a, b - 1) if b - a > 1 else np.empty(0)
        v = v0 + np.concatenate(([0.0], np.cumsum(step)))
        total += float(np.dot(v, v))
        if b < n:
            v0 = v[-1] + float(second(b - 1 + m, b + m)[0] - second(b - 1, b)[0])
    return total, n


def reflected(x: np.ndarray, pad: int) -> np.ndarray:
    """Phase extended by ``pad`` points of odd reflection at each end (TOTDEV, Eq. (25) [SP1065]).

    ``x*_{1-j} = 2 x_1 - x_{1+j}`` and ``x*_{N+j} = 2 x_N - x_{N-j}``
    (1-based, ``j = 1..pad``, ``pad <= N - 2``); ``x`` sits at
    ``[pad, pad + N)`` of the result.
    """
    out = np.empty(len(x) + 2 * pad)
    out[pad:pad + len(x)] = x
    out[:pad] = 2.0 * x[0] - x[pad:0:-1]
    out[pad + len(x):] = 2.0 * x[-1] - x[-2:-2 - pad:-1]
    return out


def variance_sums(x: np.ndarray, m_values: np.ndarray, kind: str, progress=None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Sums of squared terms and numbers of terms of ``kind`` at every averaging factor.

    Parameters
    ----------
    x : numpy.ndarray
        Phase from :func:`phase` (``N + 1`` points).
    m_values : numpy.ndarray
        Averaging factors, each allowed for ``kind``
        (:func:`~accelcal.signal.allan.taus.tau_grid`).
    kind : str
        ``adev``, ``oadev``, ``mdev``, ``hdev``, ``ohdev`` or ``totdev``.
    progress : callable, optional
        ``progress(done, total)``, called after each factor.

    Returns
    -------
    sums, counts : numpy.ndarray
        Per averaging factor. Time O(N) per factor (O(N/m) for the
        non-overlapping kinds); memory O(N) at most (two work arrays for
        MDEV, the reflected phase for TOTDEV).
    """
    sums = np.empty(len(m_values))
    counts = np.empty(len(m_values), dtype=np.int64)
    with one_blas_thread():
        _fill(x, np.asarray(m_values), kind, (sums, counts), progress)
    return sums, counts


def _fill(x, m_values, kind, out, progress) -> None:
    sums, counts = out
    npts = len(x)
    work = (np.empty(npts + 1), np.empty(npts + 1)) if kind == "mdev" else None
    chain = MovingSums(x, work) if kind == "mdev" else None
    chunk = (np.empty(min(CHUNK, npts)), None) if kind == "mdev" else None
    pad = int(max(m_values)) if kind == "totdev" else 0
    ext = reflected(x, pad) if kind == "totdev" else None
    for k, m in enumerate(int(v) for v in m_values):
        if kind == "adev":
            sums[k], counts[k] = nonoverlapping_sumsq(x, m, 2)
        elif kind == "hdev":
            sums[k], counts[k] = nonoverlapping_sumsq(x, m, 3)
        elif kind == "oadev":
            counts[k] = npts - 2 * m
            sums[k] = lag_sumsq(x, 0, counts[k], m, 2)
        elif kind == "ohdev":
            counts[k] = npts - 3 * m
            sums[k] = lag_sumsq(x, 0, counts[k], m, 3)
        elif kind == "mdev" and chain.passes(m) <= CHAIN_PASSES:
            counts[k] = npts - 3 * m + 1  # Eq. (14) [SP1065]: second differences of A_m
            sums[k] = _chunked(chain.reach(m), 0, counts[k], m, 2, buffers=chunk)
        elif kind == "mdev":
            sums[k], counts[k] = mdev_sumsq(x, m, work)
            chain.reset()
        else:  # totdev: centred second differences at the interior points 1..N-2
            counts[k] = npts - 2
            sums[k] = lag_sumsq(ext, pad + 1 - m, counts[k], m, 2)
        if progress:
            progress(k + 1, len(m_values))
