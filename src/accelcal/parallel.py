"""Monte Carlo tasks on Dask: a local cluster of worker processes, or a scheduler's.

:func:`run_dask` is :func:`accelcal.montecarlo.run`'s engine when it is given
``workers`` or a ``scheduler``: a bounded window of tasks in flight, results
merged in order. A local cluster's workers are started ignoring the
terminal's Ctrl-C and hang-up (:func:`shielded_children`), and log critical
errors only, so that a run ended by Ctrl-C prints one line.

References
----------
.. [dask] Dask.distributed documentation: ``LocalCluster``, ``Client.submit``,
   ``as_completed``.
.. [signal] POSIX ``execve``: signals set to be ignored stay ignored, the
   signal mask is kept.
"""

import contextlib
import itertools
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
    worker process imports distributed) and ignore the terminal's Ctrl-C
    (:func:`shielded_children`). Its ``scheduler_address`` serves several
    runs in turn (:func:`accelcal.montecarlo.run` with ``scheduler=``).
    """
    try:
        from distributed import LocalCluster
    except ImportError:
        raise AccelcalError(
            "running on several workers needs Dask: pip install 'accelcal[dask]'"
        ) from None
    os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", "critical")
    with shielded_children(), warnings.catch_warnings():
        # the scheduler's HTTP server moves off a port in use, with a warning
        warnings.filterwarnings("ignore", message="Port .* is already in use")
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
    try:
        yield cluster
    finally:
        cluster.close()


@contextlib.contextmanager
def shielded_children():
    """Processes started in the block ignore SIGINT and have SIGHUP blocked.

    A terminal's Ctrl-C (and hang-up) goes to every process of its group:
    the workers of a local cluster would each end with a traceback. An
    ignored signal stays ignored across ``exec`` (and Python then installs
    no handler of its own for SIGINT), a blocked one stays blocked (Python
    unblocks SIGINT at start-up, so it is ignored instead); the workers
    leave the signals to the main process, which stops the cluster as it
    ends. The main process itself ignores Ctrl-C while the block runs (the
    cluster's start, a few seconds), and takes it again after.
    """
    if (not hasattr(signal, "pthread_sigmask")
            or threading.current_thread() is not threading.main_thread()):
        yield
        return
    saved = signal.getsignal(signal.SIGINT)
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGHUP})
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, saved)
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
