"""A progress bar for long command-line computations, shown only when they are long.

:class:`DelayedProgress` is a ``progress(done, total)`` callable (the form
:func:`accelcal.montecarlo.run` calls) that stays silent for the first
``delay`` seconds and then draws a rich progress bar on standard error, if
standard error is a terminal. Short runs, pipes and tests see nothing; a
run that fails clears its bar, so the error message stands alone.
"""

import time


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

    def __enter__(self) -> "DelayedProgress":
        self._start = time.monotonic()
        return self

    def __call__(self, done: int, total: int) -> None:
        """Record that ``done`` of ``total`` units are complete."""
        if self._bar is None:
            if time.monotonic() - self._start < self.delay:
                return
            if not self._open(total):
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
            self.delay = float("inf")  # not a terminal: stay quiet for good
            return False
        self._bar = Progress(
            TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
            TimeElapsedColumn(), TextColumn("eta"), TimeRemainingColumn(),
            console=console, transient=False,
        )
        self._bar.start()
        self._task = self._bar.add_task(self.description, total=total)
        return True

    def __exit__(self, exc_type, *exc) -> None:
        if self._bar is not None:
            if exc_type is not None:  # an error follows: clear the bar, leave its line alone
                self._bar.live.transient = True
            self._bar.stop()
