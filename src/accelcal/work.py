"""Bounded work: a run's time, memory and disk estimated before it starts, refused past a bound.

Every option that sets how much work a run does (Monte Carlo trials, taus,
samples = rate x duration, positions, points, steps) goes through one check
before any work: :func:`estimate` turns a count of units into seconds,
bytes of memory and bytes written, from a per-unit cost measured once on a
2-core machine (the constants below, or a cost the caller times on the
run's own first task), and :func:`check` compares them with the stated
bounds:

- time: :data:`MAX_SECONDS` (one hour; a caller may state a shorter bound):
  refused with the estimate, unless ``force`` (``--force`` on the command
  line): a long run is allowed, only not by mistake;
- memory: :data:`~accelcal.resources.MEMORY_SHARE` of the memory this
  process can take (:func:`accelcal.io.limits.memory_limit`: its
  ``RLIMIT_AS``, its cgroup's ``memory.max``, the machine's
  ``MemAvailable``): refused even with ``force``, which cannot make memory;
- disk: the free space of the directory written to: refused even with
  ``force`` (the write would end in ENOSPC).

A run estimated to take over :data:`PROGRESS_AFTER_S` shows progress on
standard error (:class:`accelcal.cli.progress.DelayedProgress`).

The in-memory simulators (``tumble``, ``dividing-head``, ``triad``,
``thermal``, ``centrifuge``, ``vre``, ``response`` and ``acceptance
simulate``) check their sample count with :func:`simulated` where they size
their arrays, at the cost per sample measured for that simulator
(:data:`SECONDS_PER_SAMPLE_SIMULATED`); the command line's ``--force``
reaches them through :func:`forcing`, so a simulator's signature does not
carry it.
"""

import contextlib
import contextvars
import math
import shutil
from dataclasses import dataclass
from pathlib import Path

from accelcal.errors import AccelcalError

MAX_SECONDS = 3600.0
"""Longest estimated run accepted without ``force``, s (one hour)."""

PROGRESS_AFTER_S = 10.0
"""Runs estimated (or found) to take longer show progress on standard error, s."""

SECONDS_PER_SAMPLE_STREAMED = {"csv": 6.5e-7, "parquet": 4.2e-7}
"""Time to simulate and write one sample of a streamed record, by output format, s:
``noise simulate`` of 2e7 samples with white noise, bias instability and random walk
took 13 s as CSV and 8.4 s as Parquet on 2 cores (2026-11)."""

BYTES_PER_SAMPLE_STREAMED = {"csv": 23.0, "parquet": 8.0}
"""Bytes one sample of a streamed record takes on disk, by output format: the same
run wrote 457 MB of CSV (a double's ``repr`` and its newline) and 161 MB of Parquet."""

SECONDS_PER_SAMPLE_SIMULATED = {
    "response": 1.0e-6, "triad": 8.0e-7, "vre": 9.0e-7, "tumble": 3.0e-7,
    "dividing-head": 3.3e-7, "centrifuge": 2.0e-5, "thermal": 3.0e-6, "acceptance": 5.1e-7,
}
"""Time to simulate and write one sample (one row of the record: a reading, a step, a
sample of every channel) by simulator, s: ``accelcal <family> simulate`` runs written as
CSV on 2 cores (2026-11), their wall time less the 0.9 s start-up divided by the samples
the simulator counts: response (stepped, ``--sample-rate 100000 --periods 240``: 4.89e6
samples, 6.1 s; ``--periods 2400``, 4.9e7 samples, took 42 s), triad (``--rate 1000
--dwell 500``: 3.04e6, 3.3 s), vre (``--sample-rate 100000 --duration 10``: 1.8e7, 16.7 s),
tumble (``--points 100000 --repeats 10``: 1e6, 1.2 s), dividing-head (``--positions
100000 --repeats 10``: 4e6 readings of the 4 sensors, 2.2 s), centrifuge (``--readings
10000``: 7e5 readings, 14.8 s; ``--readings 30000``: 2.1e6, 39 s), thermal (``--step
0.1``: 5.83e5 steps, 2.7 s), acceptance (``--rate 10000 --dwell 10``: 5.5e6, 3.7 s)."""

_FORCED = contextvars.ContextVar("accelcal_work_forced", default=False)
"""Whether the command running asked for ``--force`` (see :func:`forcing`)."""

_ANNOUNCE = contextvars.ContextVar("accelcal_work_announce", default=None)
"""Where :func:`simulated` tells of a long run (see :func:`forcing`), or None."""


@contextlib.contextmanager
def forcing(force: bool, announce=None):
    """Within the block, :func:`check` runs past the time bound when ``force`` is true.

    The command line wraps a simulator's call in it with its ``--force``; the
    simulators then call :func:`simulated` where they size their work.
    ``announce(estimate)``, when given, is called for a run estimated over
    :data:`PROGRESS_AFTER_S` (the command line prints the estimate: most of a
    simulator's time is in whole-array steps and the record's write, which
    have no loop to report progress from).
    """
    tokens = _FORCED.set(bool(force)), _ANNOUNCE.set(announce)
    try:
        yield
    finally:
        _FORCED.reset(tokens[0])
        _ANNOUNCE.reset(tokens[1])


def simulated(family: str, what: str, samples: float, *, parameter: str | None = None,
              hint: str = "") -> "Estimate":
    """Check a simulation of ``samples`` samples by ``family``'s cost; return its estimate.

    Refused past :data:`MAX_SECONDS` unless inside :func:`forcing` (``--force``);
    a long run is announced to :func:`forcing`'s ``announce``.
    """
    est = check(estimate(f"{what} ({float(samples):.3g} samples)", samples,
                         SECONDS_PER_SAMPLE_SIMULATED[family],
                         basis=f"{SECONDS_PER_SAMPLE_SIMULATED[family]:.2g} s per sample "
                               f"of {family} simulate"),
                parameter=parameter, hint=hint)
    announce = _ANNOUNCE.get()
    if est.long and announce is not None:
        announce(est)
    return est


@dataclass(frozen=True)
class Estimate:
    """What a run is expected to take.

    Attributes
    ----------
    what : str
        The work, for messages (``"1e+12 Monte Carlo trials"``).
    seconds : float
        Estimated run time, s.
    memory : float
        Estimated peak memory, bytes (0: not estimated here).
    disk : float
        Estimated bytes written (0: none).
    basis : str
        Where the per-unit cost comes from (``"timed on the first 32,768"``).
    """

    what: str
    seconds: float
    memory: float = 0.0
    disk: float = 0.0
    basis: str = ""

    @property
    def long(self) -> bool:
        """True when the run should show progress (over :data:`PROGRESS_AFTER_S`)."""
        return not self.seconds <= PROGRESS_AFTER_S


def estimate(what: str, units: float, seconds_per_unit: float, *,
             memory_per_unit: float = 0.0, disk_per_unit: float = 0.0,
             fixed_seconds: float = 0.0, basis: str = "") -> Estimate:
    """The estimate of ``units`` units of work at the given per-unit costs.

    ``units`` may be a float (a product of user values, taken before any
    rounding or allocation); an overflow gives an infinite estimate, which
    every bound refuses.
    """
    units = float(units)
    return Estimate(what, units * seconds_per_unit + fixed_seconds, units * memory_per_unit,
                    units * disk_per_unit, basis)


def shown_seconds(seconds: float) -> str:
    """A duration for people: ``40 s``, ``12 min``, ``3.2 h``, ``45 days``, ``2e+06 years``."""
    if not math.isfinite(seconds):
        return "forever"
    for unit, size in (("years", 365.25 * 86400), ("days", 86400.0), ("h", 3600.0),
                       ("min", 60.0)):
        if seconds >= 2 * size or (unit == "h" and seconds >= size):
            value = seconds / size
            if value < 100:
                return f"{value:.2g} {unit}"
            return f"{value:,.0f} {unit}" if value < 1e6 else f"{value:.1e} {unit}"
    return f"{seconds:.2g} s" if seconds < 10 else f"{seconds:.0f} s"


def check(est: Estimate, *, force: bool = False, parameter: str | None = None,
          hint: str = "", bound: float | None = None, directory=None) -> Estimate:
    """Refuse ``est`` when it exceeds a bound; return it otherwise.

    Parameters
    ----------
    est : Estimate
    force : bool
        Run past the time bound (not past the memory or the free disk); also
        true inside :func:`forcing`.
    parameter : str, optional
        The parameter (option) that sets the work, named in the error.
    hint : str
        How to make the run smaller (``"give fewer trials"``).
    bound : float, optional
        The time bound, s (:data:`MAX_SECONDS` unless the caller states less).
    directory : path, optional
        Where the output goes: its free space bounds ``est.disk``.

    Raises
    ------
    AccelcalError
        Naming ``parameter``, the estimate and the bound.
    """
    from accelcal.resources import MEMORY_SHARE, available_memory, shown_bytes

    force = force or _FORCED.get()
    bound = MAX_SECONDS if bound is None else bound
    basis = f" ({est.basis})" if est.basis else ""
    shrink = f"{hint}, or" if hint else "shrink it, or"
    if est.memory:
        room = MEMORY_SHARE * available_memory()
        if not est.memory <= room:
            raise AccelcalError(
                f"{est.what} would need about {shown_bytes(est.memory)} of memory{basis}; "
                f"this process can take {shown_bytes(room)}: {hint or 'shrink it'}",
                parameter=parameter)
    if est.disk and directory is not None:
        free = _free_bytes(directory)
        if free is not None and not est.disk <= free:
            raise AccelcalError(
                f"{est.what} would write about {shown_bytes(est.disk)}; {directory} has "
                f"{shown_bytes(free)} free: {hint or 'shrink it'}", parameter=parameter)
    if not est.seconds <= bound and not force:
        raise AccelcalError(
            f"{est.what} would take about {shown_seconds(est.seconds)}{basis}; the bound is "
            f"{shown_seconds(bound)}: {shrink} --force to run it anyway", parameter=parameter)
    return est


def _free_bytes(directory) -> float | None:
    """Free bytes for an unprivileged writer in ``directory`` (or its nearest existing parent)."""
    path = Path(directory)
    for candidate in (path, *path.parents):
        try:
            return float(shutil.disk_usage(candidate).free)
        except OSError:
            continue
    return None
