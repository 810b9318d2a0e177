"""Monte Carlo engine: seeded blocks, bounded memory, streaming statistics.

A study is a picklable callable ``simulate(rng, n) -> ndarray (n, p)`` that
draws ``n`` trials from the generator and returns ``p`` outputs per trial
(for instance the estimation errors of every coefficient by every method).
The engine

- splits the trials into **seed blocks** of fixed size; block ``b`` draws
  from its own generator, ``PCG64(SeedSequence(seed, spawn_key=(b,)))``, so
  a trial's random numbers depend only on the seed and its block;
- reduces every block to streaming statistics (count, mean, centred second
  moments: the full covariance, or only the variances when
  ``covariance=False``) and merges them **in block order** (Chan et al.) as
  they arrive, so the result is bit-identical whatever the number of blocks
  per task, the number of workers or the order in which they finish;
- streams a block when the study also has ``pieces(rng, n)`` yielding
  arrays ``(t, p)`` of consecutive trials (the same trials, in order): each
  piece's moments are taken while it is in cache and merged in trial order,
  so a block's outputs are never held whole;
- keeps, when asked, a deterministic thinning of the trials (every
  ``stride``-th trial by global index, at most ``max_kept``) for quantiles
  and coverage intervals;
- runs in-process, on a Dask local cluster (``workers=N``) or on an existing
  Dask scheduler (``scheduler=ADDRESS``), with the same code path for every
  block.

Memory is bounded by one task's blocks at a time per worker:
``blocks_per_task * block_size * (numbers drawn per trial + p) * 8`` bytes,
plus ``max_kept * p * 8`` bytes for quantiles, plus the moments of the tasks
finished out of order (``p * p * 8`` bytes each, at most one per task in
flight), whatever the trial count. Each task runs with ``blas_threads`` BLAS
threads (one by default: a study's matrix products are small, and BLAS
threads would only compete with the workers for the cores).

References
----------
.. [GUM-S1] JCGM 101:2008, Evaluation of measurement data, Supplement 1:
   Propagation of distributions using a Monte Carlo method, sec. 7.
.. [Chan1982] Chan T. F., Golub G. H., LeVeque R. J., Updating formulae and a
   pairwise algorithm for computing sample variances, Stanford CS-79-773, 1979.
.. [NumPySeed] NumPy, "Parallel random number generation" (SeedSequence spawning).
"""

import functools
import os
import re
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.validation import shown

DEFAULT_BLOCK_SIZE = 4096
DEFAULT_MAX_KEPT = 2**17
SCHEDULER_TIMEOUT_S = 10.0
"""Seconds to wait for a Dask scheduler to answer before giving up."""

MAX_TIMEOUT_S = 86400.0
"""Longest wait for a Dask scheduler accepted, seconds (one day): a scheduler that
has not answered by then will not."""

MAX_TRIALS = 10**15
"""Most trials of one run. Trials stream in blocks, so memory is bounded for any
count; at a million trials a second (a fast study) 1e15 trials take 30 years, so a
larger count can only be a mistake."""

WORKERS_PER_CPU = 8
"""Most local Dask worker processes per CPU (:func:`max_workers`): each is a
Python process of its own (about 100 MB); beyond a few per CPU they only queue
for the same CPUs and memory."""
_SCHEDULER = re.compile(
    r"(?:(?:tcp|tls|ws|wss|ucx)://)?(?:\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):(?P<port>\d{1,5})"
)


def block_generator(seed: int, block: int) -> np.random.Generator:
    """The generator of seed block ``block`` of a study seeded with ``seed``."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(block,))))


@dataclass(frozen=True)
class _Moments:
    """Streaming moments of a set of trials.

    ``m2`` is the centred second-moment matrix ``(p, p)``, or only its
    diagonal ``(p,)`` when the covariance is not wanted. ``kept`` holds the
    thinned samples (a fresh array, never a view of a block's outputs, so a
    block's memory is released once its moments are taken).
    """

    n: int
    mean: np.ndarray
    m2: np.ndarray
    kept: np.ndarray

    @classmethod
    def of(cls, values: np.ndarray, first_index: int, stride: int, full: bool) -> "_Moments":
        if not full and values.flags.f_contiguous and values.size:
            # Trials contiguous for each output (a study filling ``(p, n)`` and returning
            # its transpose): sums and sums of squares along each output.
            mean, m2 = _output_moments(values.T)
        else:
            mean = values.mean(axis=0)
            centred = values - mean
            m2 = centred.T @ centred if full else np.einsum("ij,ij->j", centred, centred)
        if stride:
            kept = values[(-first_index) % stride :: stride].copy()
        else:
            kept = np.empty((0, values.shape[1]))
        return cls(len(values), mean, m2, kept)

    def merged(self, other: "_Moments") -> "_Moments":
        # Pairwise update of mean and M2 [Chan1982].
        n = self.n + other.n
        delta = other.mean - self.mean
        mean = self.mean + delta * (other.n / n)
        cross = np.outer(delta, delta) if self.m2.ndim == 2 else delta * delta
        m2 = self.m2 + other.m2 + cross * (self.n * other.n / n)
        kept = np.concatenate([self.kept, other.kept]) if len(other.kept) else self.kept
        return _Moments(n, mean, m2, kept)


_LOSSY = 1024.0
"""Cancellation allowed in ``sum x^2 - n mean^2`` (10 bits); rows that would lose more are
centred first (:func:`_output_moments`)."""


def _output_moments(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and centred sum of squares of each row of ``rows`` ``(p, n)`` (C-contiguous).

    One read for the sums and one for the sums of squares, ``m2 = sum x^2 -
    sum x * mean``; a row where that difference would lose more than 10 bits
    (``m2 < sum x^2 / 1024``: a mean large against the scatter) is centred
    and summed again (two-pass), so every ``m2`` keeps at least 42 bits.
    Deterministic for given values.
    """
    n = rows.shape[1]
    total = np.add.reduce(rows, axis=1)
    mean = total / n
    squares = np.einsum("ij,ij->i", rows, rows)
    m2 = squares - total * mean
    lossy = np.flatnonzero(~(m2 * _LOSSY >= squares))
    if lossy.size:
        centred = rows[lossy] - mean[lossy, None]
        m2[lossy] = np.einsum("ij,ij->i", centred, centred)
    return mean, m2


@dataclass(frozen=True)
class MonteCarloResult:
    """Statistics of a Monte Carlo study's outputs.

    Attributes
    ----------
    names : tuple of str
        Output names.
    trials : int
        Number of trials.
    mean, rms, std : numpy.ndarray
        Mean, root mean square (about zero) and standard deviation of each
        output, shape ``(p,)``.
    covariance : numpy.ndarray
        Sample covariance (divisor ``trials - 1``), shape ``(p, p)``; only
        the diagonal when the study ran with ``covariance=False`` (the
        off-diagonal entries are then NaN: not computed).
    samples : numpy.ndarray
        The kept (thinned) trials, shape ``(k, p)``, for quantiles; empty when
        none were kept.
    seed, block_size : int
        What the result depends on, besides the study itself.
    """

    names: tuple[str, ...]
    trials: int
    mean: np.ndarray
    rms: np.ndarray
    std: np.ndarray
    covariance: np.ndarray
    samples: np.ndarray
    seed: int
    block_size: int

    def quantiles(self, q) -> np.ndarray:
        """Quantiles ``q`` of each output from the kept samples, shape ``(len(q), p)``."""
        if len(self.samples) == 0:
            raise AccelcalError("no samples were kept; run the study with keep_samples=True")
        return np.quantile(self.samples, np.asarray(q, dtype=float), axis=0)

    def coverage_interval(self, p: float = 0.95, *, shortest: bool = False) -> np.ndarray:
        """Coverage interval of probability ``p`` for each output, shape ``(p, 2)``.

        Probabilistically symmetric by default; ``shortest=True`` gives the
        shortest interval [GUM-S1, 7.7].
        """
        if not 0.0 < p < 1.0:
            raise AccelcalError(f"coverage probability {p} must be between 0 and 1")
        if not shortest:
            return self.quantiles([(1 - p) / 2, (1 + p) / 2]).T
        if len(self.samples) == 0:
            raise AccelcalError("no samples were kept; run the study with keep_samples=True")
        x = np.sort(self.samples, axis=0)
        m = len(x)
        width = int(np.ceil(p * m))
        if width >= m:
            return np.stack([x[0], x[-1]], axis=1)
        spans = x[width:] - x[: m - width]
        best = np.argmin(spans, axis=0)
        cols = np.arange(x.shape[1])
        return np.stack([x[best, cols], x[best + width, cols]], axis=1)


def run(
    simulate: Callable[[np.random.Generator, int], np.ndarray],
    trials: int,
    *,
    names: Sequence[str],
    seed: int,
    block_size: int = DEFAULT_BLOCK_SIZE,
    blocks_per_task: int = 4,
    keep_samples: bool = False,
    max_kept: int = DEFAULT_MAX_KEPT,
    covariance: bool = True,
    blas_threads: int | None = 1,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Callable[[int, int], None] | None = None,
    timeout: float = SCHEDULER_TIMEOUT_S,
    max_seconds: float | None = None,
) -> MonteCarloResult:
    """Run a Monte Carlo study.

    Parameters
    ----------
    simulate : callable
        ``simulate(rng, n)`` returns an array ``(n, p)``: ``p`` outputs for
        each of ``n`` trials drawn from ``rng``. Must be picklable for Dask
        (a module-level function or an instance of a module-level class).
        When it has a method ``pieces(rng, n)`` the engine calls that instead:
        it yields arrays ``(t, p)`` of consecutive trials, ``n`` in all, each
        consumed before the next is asked for (it may reuse one buffer).
    trials : int
        Number of trials (1 ... :data:`MAX_TRIALS`).
    names : sequence of str
        Names of the ``p`` outputs.
    seed : int
        Root seed (>= 0). Same seed and block size, same result.
    block_size : int
        Trials per seed block. Part of the study's identity: changing it
        changes which random numbers each trial gets.
    blocks_per_task : int
        Seed blocks evaluated per task (scheduling granularity); does not
        change the result.
    keep_samples : bool
        Keep a deterministic thinning of at most ``max_kept`` trials for
        quantiles and coverage intervals.
    max_kept : int
        Most trials kept when ``keep_samples``.
    covariance : bool
        Accumulate the full covariance of the outputs (``p * p`` work per
        trial); with False only the variances (enough for mean, RMS and
        standard deviation).
    blas_threads : int or None
        BLAS threads while a task evaluates its blocks (None: leave as is).
    workers : int, optional
        Start a Dask local cluster with this many worker processes (at most
        :func:`max_workers`).
    scheduler : str, optional
        Address of an existing Dask scheduler: ``host:port``, or with a
        scheme ``tcp``, ``tls``, ``ws``, ``wss`` or ``ucx`` (``tcp://host:8786``).
    progress : callable, optional
        ``progress(done, total)`` called as trials complete.
    timeout : float
        Seconds to wait for ``scheduler`` to answer.
    max_seconds : float, optional
        Refuse a run (not on a ``scheduler``) estimated to take longer: the
        first task is timed here, in this process, and the estimate is its
        time times the tasks left, shared by the ``workers``. None: no bound.

    Returns
    -------
    MonteCarloResult

    Raises
    ------
    AccelcalError
        For a non-positive trial count or sizes, more than
        :data:`MAX_TRIALS` trials, more than :func:`max_workers` workers,
        both ``workers`` and ``scheduler``, a malformed ``scheduler``
        address, a ``timeout`` that is not positive or over
        :data:`MAX_TIMEOUT_S`, an output of the wrong shape, Dask not
        installed, or a scheduler that does not answer within ``timeout``
        seconds.
    """
    check_trials(trials)
    _check_positive_int("block_size", block_size)
    _check_positive_int("blocks_per_task", blocks_per_task)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise AccelcalError(f"{_shown_repr(seed)} must be a non-negative integer",
                            parameter="seed")
    check_parallel(workers, scheduler, timeout)
    names = tuple(names)
    n_blocks = -(-trials // block_size)
    stride = max(1, -(-trials // max_kept)) if keep_samples else 0
    tasks = _Tasks(n_blocks, blocks_per_task)
    spec = _BlockSpec(
        simulate, int(seed), trials, block_size, len(names), stride, covariance, blas_threads
    )
    merger = _InOrder(len(tasks), progress, trials)
    first = 0
    if max_seconds is not None and scheduler is None:
        start = time.monotonic()
        timed = spec(tasks[0])
        _check_time((time.monotonic() - start) * (len(tasks) - 1) / (workers or 1),
                    trials, min(trials, block_size * blocks_per_task), max_seconds)
        merger.add(0, timed)  # progress only once the run is accepted
        first = 1
    if workers is None and scheduler is None:
        for index in range(first, len(tasks)):
            merger.add(index, spec(tasks[index]))
    elif first < len(tasks):
        from accelcal.parallel import run_dask

        run_dask(spec, tasks, merger, workers=workers, scheduler=scheduler, timeout=timeout,
                 first=first)
    total = merger.total
    diag = np.diag(total.m2) if total.m2.ndim == 2 else total.m2
    var = diag / total.n
    if total.n < 2:
        cov = np.full((len(names), len(names)), np.nan)
    elif total.m2.ndim == 2:
        cov = total.m2 / (total.n - 1)
    else:
        cov = np.full((len(names), len(names)), np.nan)
        np.fill_diagonal(cov, diag / (total.n - 1))
    return MonteCarloResult(
        names=names,
        trials=total.n,
        mean=total.mean,
        rms=np.sqrt(total.mean**2 + var),
        std=np.sqrt(np.diag(cov)) if total.n > 1 else np.full(len(names), np.nan),
        covariance=cov,
        samples=total.kept,
        seed=int(seed),
        block_size=block_size,
    )


@dataclass(frozen=True)
class _BlockSpec:
    """Everything a task needs to evaluate its seed blocks (picklable)."""

    simulate: Callable
    seed: int
    trials: int
    block_size: int
    p: int
    stride: int
    full_covariance: bool
    blas_threads: int | None

    def __call__(self, blocks: range) -> list[_Moments]:
        if self.blas_threads is None:
            return self._evaluate(blocks)
        with _blas_controller().limit(limits=self.blas_threads, user_api="blas"):
            return self._evaluate(blocks)

    def _evaluate(self, blocks: range) -> list[_Moments]:
        out = []
        for b in blocks:
            first = b * self.block_size
            n = min(self.block_size, self.trials - first)
            rng = block_generator(self.seed, b)
            pieces = getattr(self.simulate, "pieces", None)
            if pieces is None:
                out.append(self._moments(self.simulate(rng, n), n, first))
                continue
            # A streaming study: the moments of each piece while it is in cache, merged
            # in trial order (the same order on every worker: bit-identical results).
            total, done = None, 0
            for piece in pieces(rng, n):
                t = len(piece)
                if not 0 < t <= n - done:
                    raise AccelcalError(f"the study returned a piece of {t} trials after "
                                        f"{done}; expected {n} trials in all")
                m = self._moments(piece, t, first + done)
                total = m if total is None else total.merged(m)
                done += t
            if done != n:
                raise AccelcalError(f"the study returned {done} trials; expected {n}")
            out.append(total)
        return out

    def _moments(self, values, n: int, first: int) -> _Moments:
        values = np.asarray(values, dtype=float)
        if values.shape != (n, self.p):
            raise AccelcalError(
                f"the study returned shape {values.shape} for {n} trials; "
                f"expected ({n}, {self.p})"
            )
        return _Moments.of(values, first, self.stride, self.full_covariance)


@functools.cache
def _blas_controller():
    """The process's threadpoolctl controller (finding the libraries once, not per task)."""
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


class _InOrder:
    """Merge task results in task (hence block) order as they arrive.

    Results that arrive early wait in ``pending`` until their predecessors
    are merged, so memory holds only the out-of-order window, and the merge
    order (hence every bit of the result) never depends on arrival order.
    """

    def __init__(self, n_tasks: int, progress, trials: int) -> None:
        self.pending: dict[int, list[_Moments]] = {}
        self.next = 0
        self.n_tasks = n_tasks
        self.total: _Moments | None = None
        self.done = 0
        self.progress = progress
        self.trials = trials

    def add(self, index: int, moments: list[_Moments]) -> None:
        self.pending[index] = moments
        self.done += sum(m.n for m in moments)
        while self.next in self.pending:
            for m in self.pending.pop(self.next):
                self.total = m if self.total is None else self.total.merged(m)
            self.next += 1
        if self.progress is not None:
            self.progress(self.done, self.trials)





class _Tasks(Sequence):
    """The tasks' block ranges, made on demand: O(1) memory for any trial count."""

    def __init__(self, n_blocks: int, per_task: int) -> None:
        self.n_blocks, self.per_task = n_blocks, per_task

    def __len__(self) -> int:
        return (self.n_blocks + self.per_task - 1) // self.per_task

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(len(self)))]
        if not 0 <= i < len(self):
            raise IndexError(i)
        start = i * self.per_task
        return range(start, min(start + self.per_task, self.n_blocks))


def _check_time(seconds: float, trials: int, timed: int, bound: float) -> None:
    from accelcal import work

    work.check(work.Estimate(f"{trials:,} trials", seconds,
                             basis=f"the rest, from the first {timed:,}, timed"),
               parameter="trials", bound=bound,
               hint="give fewer trials or more workers")


def check_trials(trials) -> None:
    """Refuse a trial count that is not an integer in 1 ... :data:`MAX_TRIALS`.

    Raises
    ------
    AccelcalError
        Naming the parameter ``trials``.
    """
    _check_positive_int("trials", trials)
    if trials > MAX_TRIALS:
        raise AccelcalError(
            f"{_shown_int(trials)} trials would run for more than 30 years even at a million "
            f"trials a second; give at most {MAX_TRIALS:.0e}", parameter="trials")


def max_workers() -> int:
    """Most local Dask worker processes: :data:`WORKERS_PER_CPU` per CPU this process may use."""
    try:
        cpus = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cpus = os.cpu_count() or 1
    return WORKERS_PER_CPU * max(cpus, 1)


def check_parallel(workers, scheduler, timeout) -> None:
    """Check the options of a parallel run (see :func:`run`), before any work.

    ``workers`` a positive integer of at most :func:`max_workers`, not with
    ``scheduler``; ``scheduler`` a Dask address; ``timeout`` a number of
    seconds, positive and at most :data:`MAX_TIMEOUT_S`.

    Raises
    ------
    AccelcalError
        Naming the parameter at fault.
    """
    if workers is not None and scheduler is not None:
        raise AccelcalError("give either workers or a scheduler, not both",
                            parameter="workers")
    if workers is not None:
        _check_positive_int("workers", workers)
        if workers > max_workers():
            raise AccelcalError(
                f"{_shown_int(workers)} worker processes is more than this machine can run "
                f"usefully; give at most {max_workers()} ({WORKERS_PER_CPU} per CPU)",
                parameter="workers")
    if scheduler is not None:
        _check_scheduler(scheduler)
    if (isinstance(timeout, bool) or not isinstance(timeout, (int, float, np.integer,
                                                               np.floating))
            or not 0 < timeout <= MAX_TIMEOUT_S):
        raise AccelcalError(
            f"must be a positive number of seconds, at most {MAX_TIMEOUT_S:g} (one day), got "
            f"{_shown_repr(timeout)}", parameter="timeout")


def _shown_int(value) -> str:
    """An integer for a message: in full up to 20 digits, else as a power of ten."""
    text = str(value)
    return text if len(text) <= 20 else f"about 1e{len(text) - 1}"


def _shown_repr(value) -> str:
    text = repr(value)
    return text if len(text) <= 40 else f"{text[:40]}..."


def _check_scheduler(address) -> None:
    """Refuse what is not a Dask scheduler address (``[tcp|tls|ws|wss|ucx://]host:port``)."""
    match = isinstance(address, str) and _SCHEDULER.fullmatch(address)
    if not match or not 0 < int(match["port"]) < 65536:
        raise AccelcalError(
            f"{shown(address)} is not a Dask scheduler address; give host:port or "
            "tcp://host:port (e.g. tcp://10.0.0.5:8786)", parameter="scheduler",
        )


def _check_positive_int(name: str, value) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value <= 0:
        raise AccelcalError(f"must be a positive integer, got {_shown_repr(value)}",
                            parameter=name)
