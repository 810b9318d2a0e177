"""Monte Carlo tasks on Dask: a local cluster of worker processes, or a scheduler's.

:func:`run_dask` is :func:`accelcal.montecarlo.run`'s engine when it is given
``workers`` or a ``scheduler``: a bounded window of tasks in flight, results
merged in order. A local cluster's workers are started with the
terminal's Ctrl-C and hang-up blocked (:func:`shielded_children`), and log
critical errors only, so that a run ended by Ctrl-C, even while the cluster
starts, prints one line and leaves no process behind.

References
----------
.. [dask] Dask.distributed documentation: ``LocalCluster``, ``Client.submit``,
   ``as_completed``.
.. [signal] POSIX ``execve``: signals set to be ignored stay ignored, the
   signal mask is kept.
"""

import contextlib
import itertools
import logging
import os
import signal
import threading
import warnings

from accelcal.errors import AccelcalError

DASK_WINDOW = 64
"""Tasks in flight at once on Dask workers (a few per worker on any cluster accelcal
targets; it bounds the memory of futures and of results merged in order)."""


def run_dask(spec, tasks, merger, *, workers, scheduler, timeout, first=0):
    """Evaluate ``tasks[first:]`` with ``spec`` on Dask; merge each result into ``merger``."""
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise AccelcalError(
            "running on several workers needs Dask: pip install 'accelcal[dask]'"
        ) from None
    with contextlib.ExitStack() as stack:
        if scheduler is not None:
            try:
                client = Client(scheduler, timeout=f"{timeout}s")
            except (OSError, TimeoutError) as exc:
                raise AccelcalError(
                    f"the Dask scheduler at {scheduler} did not answer within "
                    f"{timeout:g} s ({type(exc).__name__}); check the address "
                    "and that 'dask scheduler' is running there"
                ) from None
        else:
            client = Client(stack.enter_context(local_cluster(workers)))
        with client:
            # A bounded window of tasks in flight: memory (futures, and results
            # waiting for their predecessors) stays constant for any trial count.
            queue = itertools.islice(enumerate(tasks), first, None)
            index = {}
            running = as_completed()
            for i, blocks in itertools.islice(queue, DASK_WINDOW):
                future = client.submit(spec, blocks, pure=False)
                index[future.key] = i
                running.add(future)
            for future in running:
                merger.add(index.pop(future.key), future.result())
                future.release()
                following = next(queue, None)
                if following is not None:
                    nxt = client.submit(spec, following[1], pure=False)
                    index[nxt.key] = following[0]
                    running.add(nxt)


@contextlib.contextmanager
def local_cluster(workers: int):
    """A Dask local cluster of ``workers`` processes (one thread each), closed on leaving.

    The workers log critical errors only (a cluster stopped by Ctrl-C would
    print a warning per cancelled task; read from the environment when each
    worker process imports distributed) and leave the terminal's Ctrl-C to
    this process (:func:`shielded_children`), which takes one that comes
    while the cluster starts once it has started (:func:`deferred_signals`)
    and then ends the workers at once. Its ``scheduler_address`` serves several
    runs in turn (:func:`accelcal.montecarlo.run` with ``scheduler=``).
    """
    try:
        from distributed import LocalCluster
    except ImportError:
        raise AccelcalError(
            "running on several workers needs Dask: pip install 'accelcal[dask]'"
        ) from None
    os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", "critical")
    # and so does this process's scheduler (a task cancelled as the run ends)
    logging.getLogger("distributed").setLevel(logging.CRITICAL)
    with shielded_children():
        cluster = None
        try:
            with deferred_signals(), warnings.catch_warnings():
                # the scheduler's HTTP server moves off a port in use, with a warning
                warnings.filterwarnings("ignore", message="Port .* is already in use")
                cluster = LocalCluster(n_workers=workers, threads_per_worker=1,
                                       processes=True, dashboard_address=None)
            yield cluster
        except KeyboardInterrupt:
            if cluster is not None:  # the run ends: its workers' results are not wanted
                _stop_workers()
            raise
        finally:
            if cluster is not None:
                cluster.close()


def _stop_workers() -> None:
    """End this process's worker processes at once (an interrupted run: no graceful close)."""
    import multiprocessing

    for child in multiprocessing.active_children():
        child.terminate()


@contextlib.contextmanager
def shielded_children():
    """Processes started in the block have SIGINT and SIGHUP blocked.

    A terminal's Ctrl-C (and hang-up) goes to every process of its group:
    the workers of a local cluster would each end with a traceback. A
    blocked signal stays blocked across ``exec``, so the workers leave the
    signals to the main process, which stops the cluster as it ends. The
    signals are blocked in the thread that starts each process (Dask starts
    its workers from its own threads), just while it starts it
    (``multiprocessing.util.spawnv_passfds``); the main process keeps taking
    them (:func:`deferred_signals` holds one back while the cluster starts).
    """
    import multiprocessing.util as mp_util

    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    spawn = mp_util.spawnv_passfds

    def shielded_spawn(path, args, passfds):
        mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGHUP})
        try:
            return spawn(path, args, passfds)
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)

    mp_util.spawnv_passfds = shielded_spawn
    try:
        yield
    finally:
        mp_util.spawnv_passfds = spawn


@contextlib.contextmanager
def deferred_signals():
    """SIGINT, SIGTERM and SIGHUP taken in the block are delivered again as it ends.

    A local cluster's start (a few seconds) interrupted half-way would be
    lost with its workers running, and Dask's own clean-up at exit would fail
    with a traceback; a signal in the block is recorded and raised again once
    the cluster exists and can be closed. A signal the process ignores stays
    ignored. (A handler that watches for signals not taken, as the command
    line's does, sees that this one stands in for it.)
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    got = []

    def record(signum, frame):
        got.append(signum)

    saved = {}
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        if signal.getsignal(sig) not in (signal.SIG_IGN, None):
            saved[sig] = signal.signal(sig, record)
    try:
        yield
    finally:
        for sig, handler in saved.items():
            signal.signal(sig, handler)
        if got:
            signal.raise_signal(got[0])
