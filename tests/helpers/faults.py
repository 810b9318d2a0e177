"""The fault tier's runner: ``accelcal`` in a child process, under limits, killed, checked.

Each run is a real process (``python -m accelcal``) so that signals, resource
limits and kills act as they do on a user's machine; its temporary directory
(``TMPDIR``) is the test's own, so leftovers there are seen.
"""

import os
import re
import resource
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

LEFTOVER = re.compile(r"accelcal-\d+-[0-9a-f]{12}|accelcal-import|accelcal-phase")
"""A name accelcal gives its temporaries (this version's, and the older names)."""

EXIT = {signal.SIGINT: 130, signal.SIGTERM: 143, signal.SIGHUP: 129}
"""Exit status of a run ended by each signal it handles."""


@dataclass
class Run:
    """One finished run."""

    args: list
    code: int
    out: str
    err: str
    seconds: float

    @property
    def traceback(self) -> bool:
        """Whether standard error holds a traceback (never allowed)."""
        return "Traceback" in self.err

    def one_line_error(self) -> bool:
        """Exit status 2 and a single ``accelcal: error:`` line."""
        lines = self.err.strip().splitlines()
        return self.code == 2 and len(lines) == 1 and lines[0].startswith("accelcal: error: ")


def environment(tmpdir: Path) -> dict:
    """The environment of a run: this one's, with ``TMPDIR`` the test's."""
    tmpdir.mkdir(parents=True, exist_ok=True)
    return {**os.environ, "TMPDIR": str(tmpdir)}


def _limits(address_space=None, file_size=None):
    def apply():
        # as a terminal's command: a run started in the background (nohup, &) would
        # inherit SIGHUP or SIGINT ignored, and accelcal keeps an ignored signal ignored
        for sig in (signal.SIGINT, signal.SIGHUP):
            signal.signal(sig, signal.SIG_DFL)
        if address_space is not None:
            resource.setrlimit(resource.RLIMIT_AS, (address_space, address_space))
        if file_size is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (file_size, file_size))
    return apply


def start(args, *, cwd: Path, tmpdir: Path, address_space=None, file_size=None,
          group: bool = False) -> subprocess.Popen:
    """Start ``accelcal ARGS`` (a new session with ``group``: its own process group)."""
    return subprocess.Popen(
        [sys.executable, "-m", "accelcal", *map(str, args)], cwd=cwd,
        env=environment(tmpdir), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=_limits(address_space, file_size),  # noqa: PLW1509 (no threads here)
        start_new_session=group)


def run(args, *, cwd: Path, tmpdir: Path, timeout: float = 180, **limits) -> Run:
    """Run ``accelcal ARGS`` to its end."""
    began = time.monotonic()
    proc = start(args, cwd=cwd, tmpdir=tmpdir, **limits)
    out, err = proc.communicate(timeout=timeout)
    return Run(list(args), proc.returncode, out, err, time.monotonic() - began)


def kill_after(args, delay: float, sig: int, *, cwd: Path, tmpdir: Path, group=False,
               timeout: float = 60) -> tuple[Run, float]:
    """Run ``accelcal ARGS``, send ``sig`` after ``delay`` s.

    Returns the run and the seconds from the signal to the end (None when the
    run had ended before the signal was due).
    """
    began = time.monotonic()
    proc = start(args, cwd=cwd, tmpdir=tmpdir, group=group)
    try:
        proc.wait(timeout=delay)
        sent = None
    except subprocess.TimeoutExpired:
        if group:
            os.killpg(proc.pid, sig)
        else:
            proc.send_signal(sig)
        sent = time.monotonic()
    out, err = proc.communicate(timeout=timeout)
    ended = time.monotonic()
    return (Run(list(args), proc.returncode, out, err, ended - began),
            None if sent is None else ended - sent)


def leftovers(*directories: Path) -> list[str]:
    """Names of accelcal's temporaries left in ``directories`` (recursively)."""
    found = []
    for directory in directories:
        for root, dirs, files in os.walk(directory):
            found += [os.path.join(root, n) for n in dirs + files if LEFTOVER.search(n)]
    return found
