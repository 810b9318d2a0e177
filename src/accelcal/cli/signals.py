"""Signals: Ctrl-C, SIGTERM and SIGHUP end a run the same way, with one line, at any moment.

:func:`install` (the first thing :func:`accelcal.cli.main` does) makes
SIGINT, SIGTERM and SIGHUP raise :class:`Interrupted` (a
``KeyboardInterrupt``) in the main thread, so the writers' cleanup runs
(temporary files removed, :mod:`accelcal.io.atomic`) and
:func:`accelcal.cli.main` prints one line and exits with ``128 + signal``
(130, 143, 129). Further signals while the run ends are ignored, so a
second Ctrl-C cannot break the cleanup.

Python runs a signal handler only between bytecodes of the main thread: a
main thread blocked in C (an SQLite busy wait on a locked store, a library's
long call) would not see it for a minute. A watcher thread reads the
signal numbers Python's C-level handler writes to a wake-up pipe; if the
main thread has not taken the signal within :data:`GRACE` seconds (or has
not ended :data:`ENDING` seconds after taking it), the watcher removes this
process's temporaries, prints the line and ends the process itself.

A local Dask cluster's workers are started with SIGINT and SIGHUP blocked
(:func:`accelcal.parallel.shielded_children`): the terminal sends those to
the whole process group, and the workers, stopped by the main process as it
ends, would each print a traceback. While the cluster starts, a signal is
recorded and delivered again once it has started
(:func:`accelcal.parallel.deferred_signals`), so that it can be closed; the
watcher waits for that instead of ending the process.

pyarrow's own handler, which turns a signal into a cancelled read and can
lose it, is switched off when pyarrow is first imported.

A signal taken while the main thread runs Python code called back from C
that cannot pass an exception on (a finaliser, a C library's callback)
would be printed as "Exception ignored in ..." with a traceback and lost:
the unraisable hook takes such an :class:`Interrupted` back and delivers
the signal again, to be raised at the next point that can pass it on.

References
----------
.. [signal] Python documentation, ``signal``: "Python signal handlers are
   always executed in the main Python thread ... a long-running calculation
   implemented purely in C ... may run uninterrupted"; ``set_wakeup_fd``.
.. [exit] The Open Group, Shell Command Language, 2.8.2 (a command ended by a
   signal: exit status 128 plus the signal number).
"""

import _thread
import contextlib
import os
import signal
import sys
import threading
import time

SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
"""The signals that end a run cleanly."""

GRACE = 0.8
"""Seconds the main thread has to take a signal before the watcher ends the run."""

ENDING = 10.0
"""Seconds the main thread has to end after taking a signal (its cleanup)."""

REDELIVER = 0.02
"""Seconds after a swallowed :class:`Interrupted` before its signal is delivered again."""

_taken = threading.Event()
_printed = threading.Lock()
_received: list[int] = []
_installed: list[bool] = []
_done: list[bool] = []


class Interrupted(KeyboardInterrupt):
    """A run ended by a signal: SIGINT, SIGTERM or SIGHUP (``signum``)."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


def exit_status(signum: int) -> int:
    """The exit status of a run ended by ``signum``: 128 plus its number."""
    return 128 + int(signum)


def finish(signum: int) -> None:
    """Print the one line of a run ended by ``signum`` (once per process)."""
    if _printed.acquire(blocking=False):
        name = signal.Signals(signum).name
        what = "interrupted" if signum == signal.SIGINT else f"stopped by {name}"
        with contextlib.suppress(OSError, ValueError):
            sys.stderr.write(f"accelcal: {what}; nothing was left half-written\n")
            sys.stderr.flush()


def received() -> int | None:
    """The first ending signal received, or None."""
    return _received[0] if _received else None


def install() -> None:
    """Handle SIGINT, SIGTERM and SIGHUP in the main thread, with the watcher behind.

    Once per process (a program calling :func:`accelcal.cli.main` many times
    gets one watcher).
    """
    _done.clear()  # a new run (a program may call accelcal.cli.main many times)
    if _installed or threading.current_thread() is not threading.main_thread():
        return
    _installed.append(True)
    for sig in SIGNALS:
        with contextlib.suppress(OSError, ValueError):
            if signal.getsignal(sig) is not signal.SIG_IGN:  # nohup: stays ignored
                signal.signal(sig, _handler)
    read_end, write_end = os.pipe()
    os.set_blocking(write_end, False)
    try:
        signal.set_wakeup_fd(write_end, warn_on_full_buffer=False)
    except ValueError:
        os.close(read_end)
        os.close(write_end)
        return
    threading.Thread(target=_watch, args=(read_end,), daemon=True,
                     name="accelcal-signals").start()
    sys.unraisablehook = _unraisable(sys.unraisablehook)
    _quiet_arrow()


def done() -> None:
    """The run's work is over (its outputs written): a signal now ends the process at once.

    As the interpreter exits, an :class:`Interrupted` raised in an exit
    handler would be swallowed there, and its signal, delivered again, would
    come too late: the run would exit 0 although a signal came. From here
    on a signal ends the process by the signal's default action (the shell
    sees it killed by the signal; its outputs, standard output flushed here, are whole).
    """
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    _done.append(True)


def _handler(signum, frame):
    if _received:
        return  # the run is ending: its cleanup is not interrupted
    if _done:
        signal.signal(signum, signal.SIG_DFL)
        os.kill(os.getpid(), signum)
        return
    _received.append(signum)
    _taken.set()
    raise Interrupted(signum)


def _unraisable(previous):
    """An unraisable hook that delivers a swallowed :class:`Interrupted` again."""

    def hook(args):
        if not isinstance(args.exc_value, Interrupted):
            previous(args)
            return
        signum = args.exc_value.signum
        _received.clear()  # the handler raises again when the signal comes back
        # from another thread, a moment later: a signal raised now would be taken inside
        # this hook (and a Thread's start() waits, where the handler would run)
        _thread.start_new_thread(_deliver, (signum,))

    return hook


def _deliver(signum: int) -> None:
    time.sleep(REDELIVER)
    os.kill(os.getpid(), signum)


def _watch(read_end: int) -> None:
    while True:
        try:
            data = os.read(read_end, 64)
        except OSError:
            return
        ending = [s for s in data if s in SIGNALS]
        if not ending:
            continue
        waited = 0.0
        while not _taken.wait(GRACE):
            if _done:  # the main thread ends the process by the signal (see done)
                break
            waited += GRACE
            # a handler standing in for ours (accelcal.parallel.deferred_signals, while a
            # cluster starts) delivers the signal again soon: wait for it, within ENDING
            if signal.getsignal(ending[0]) is _handler or waited >= ENDING:
                _force(ending[0])
        threading.Event().wait(ENDING)
        _force(received() or ending[0])


def _force(signum: int) -> None:
    """End the process from the watcher: remove the temporaries, one line, the exit status."""
    from accelcal.io.atomic import remove_live

    with contextlib.suppress(Exception):
        remove_live()
    with contextlib.suppress(Exception):
        import multiprocessing

        for child in multiprocessing.active_children():
            child.terminate()
    finish(signum)
    os._exit(exit_status(signum))


def _quiet_arrow() -> None:
    """Switch pyarrow's signal handling off once it is imported (now, or when it is)."""
    if "pyarrow" in sys.modules:
        sys.modules["pyarrow"].enable_signal_handlers(False)
        return
    sys.meta_path.insert(0, _ArrowFinder())


class _ArrowFinder:
    """A meta-path finder that lets pyarrow load, then switches its signal handling off."""

    def find_spec(self, name, path=None, target=None):
        if name != "pyarrow":
            return None
        import importlib.util

        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(name)
        if spec is None or spec.loader is None:
            return spec
        load = spec.loader.exec_module

        def exec_module(module):
            load(module)
            module.enable_signal_handlers(False)

        spec.loader.exec_module = exec_module
        return spec
