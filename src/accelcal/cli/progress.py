"""A progress bar for long command-line computations, shown only when they are long.

:class:`DelayedProgress` is a ``progress(done, total)`` callable (the form
:func:`accelcal.montecarlo.run` calls) that stays silent for the first
``delay`` seconds and then draws a rich progress bar on standard error, if
standard error is a terminal. When it is not (a pipe, a log file, a batch
job), a run still going after :data:`accelcal.work.PROGRESS_AFTER_S` prints
a plain line every :data:`PLAIN_EVERY_S` seconds (``accelcal: progress:
Monte Carlo trials: 40,960 of 1,000,000 (4.1 %), 12 s elapsed, about 4.7 min
left``). Short runs see nothing; a run that fails clears its bar, so the
error message stands alone.
"""

import sys
import time

PLAIN_EVERY_S = 10.0
"""Seconds between two plain progress lines (standard error not a terminal)."""


class DelayedProgress:
    """Context manager and ``progress(done, total)`` callable.

    Parameters
    ----------
    description : str
        Label in front of the bar.
    delay : float
        Seconds of silence before the bar appears, s.
    force : bool
        Draw even when standard error is not a terminal.
    """

    def __init__(self, description: str, delay: float = 2.0, *, force: bool = False):
        self.description = description
        self.delay = delay
        self.force = force
        self._start = time.monotonic()
        self._bar = None
        self._task = None
        self._plain = False
        self._last_line = -float("inf")

    def __enter__(self) -> "DelayedProgress":
        self._start = time.monotonic()
        return self

    def __call__(self, done: int, total: int) -> None:
        """Record that ``done`` of ``total`` units are complete."""
        if self._plain:
            self._line(done, total)
            return
        if self._bar is None:
            if time.monotonic() - self._start < self.delay:
                return
            if not self._open(total):
                self._plain = True
                self._line(done, total)
                return
        self._bar.update(self._task, completed=done, total=total)

    def _open(self, total: int) -> bool:
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        console = Console(stderr=True)
        if not (console.is_terminal or self.force):
            return False  # not a terminal: plain lines instead (see _line)
        self._bar = Progress(
            TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
            TimeElapsedColumn(), TextColumn("eta"), TimeRemainingColumn(),
            console=console, transient=False,
        )
        self._bar.start()
        self._task = self._bar.add_task(self.description, total=total)
        return True

    def _line(self, done: int, total: int) -> None:
        """One plain progress line, when the run is long and the last line is old enough."""
        from accelcal.work import PROGRESS_AFTER_S, shown_seconds

        now = time.monotonic()
        elapsed = now - self._start
        if elapsed < max(self.delay, PROGRESS_AFTER_S) or now - self._last_line < PLAIN_EVERY_S:
            return
        self._last_line = now
        share = done / total if total else 0.0
        left = f", about {shown_seconds(elapsed * (1 / share - 1))} left" if share > 0 else ""
        print(f"accelcal: progress: {self.description}: {done:,} of {total:,} "
              f"({100 * share:.1f} %), {shown_seconds(elapsed)} elapsed{left}",
              file=sys.stderr, flush=True)

    def __exit__(self, exc_type, *exc) -> None:
        if self._bar is not None:
            if exc_type is not None:  # an error follows: clear the bar, leave its line alone
                self._bar.live.transient = True
            self._bar.stop()
