"""Where parallel work runs: Dask (``dask.distributed``), from a laptop to a cluster.

:func:`connect` gives the ``distributed.Client`` of a job, or None for this process:

* ``workers=0``: this process, no cluster;
* with no address: an embedded ``distributed.LocalCluster`` on 127.0.0.1, one single-threaded
  worker process per core (or ``workers``), closed when the job ends; its workers ignore SIGINT
  (Ctrl-C reaches the whole process group; the job's process handles it). Only where starting it
  is safe (:func:`local_cluster_unsafe`: a script's call under ``if __name__ == "__main__":``,
  a notebook, ``python -m spherekin``); elsewhere the job runs in this process, with a warning
  (once per process) that says why;
* ``scheduler="tcp://HOST:8786"``: an existing Dask cluster (``dask scheduler`` + ``dask worker``,
  spherekin installed where the workers run), unchanged; or ``client=``: a Client of the
  caller's, left open.

:func:`map_in_order` runs a function over items on a client (or here) and yields the results in
the items' order. The families of inputs (:mod:`spherekin.batch`), the box loop's chart groups
(``jobs``) and the benchmark sweeps all run through this module: one engine, no process pool of
our own. ``distributed`` is imported only when a cluster is asked for.

A job never waits in silence on a cluster that is gone: :func:`wait_any` (used by
:func:`map_in_order` and the batch engine) raises :class:`ClusterLost` when the scheduler is lost or
when there has been no worker for NO_WORKER_TIMEOUT seconds.
"""

from __future__ import annotations

import ast
import logging
import os
import sys
import threading
import time
import warnings
from contextlib import contextmanager
from typing import Callable, Iterable, Iterator

__all__ = ["QUIET_LOGS", "CONNECT_TIMEOUT", "TASKS_PER_WORKER", "NO_WORKER_TIMEOUT", "WATCH_INTERVAL", "ClusterLost",
           "connect", "map_in_order", "wait_any", "result_of", "scheduler_address", "default_workers", "n_workers", "dask_setup", "local_cluster_unsafe"]

#: Log level of an embedded cluster's scheduler and workers. Reason: at shutdown (the end of a job,
#: Ctrl-C) they log lost heartbeats and closed streams at ERROR level, which say nothing about the
#: job; a failure that matters reaches the job as the exception of a task (a worker that dies: KilledWorker).
QUIET_LOGS = logging.CRITICAL
#: Where an embedded cluster's scheduler serves HTTP (health, metrics; the dashboard when bokeh is
#: installed): loopback only, on a free port. Reason: the default, port 8787 on every interface, is
#: taken by any other Dask cluster running on the machine (a warning, then another port anyway).
HTTP_ADDRESS = "127.0.0.1:0"
#: Seconds to wait for a scheduler given by address before saying it cannot be reached.
CONNECT_TIMEOUT = 10.0
#: Tasks in flight per worker (:func:`map_in_order`, the batch engine). Reason: 2 keep a worker busy
#: while its next task travels; 4 also absorb uneven tasks, and the results held back for input
#: order stay a few tasks per worker.
TASKS_PER_WORKER = 4
#: Seconds a job waits while its cluster has no worker at all before it stops (:class:`ClusterLost`).
#: Reason: a worker that dies is replaced within seconds where anything replaces it (a nanny, a
#: LocalCluster, an adaptive or batch-system cluster starting one); a cluster with no worker for 30 s
#: is down for this job, and waiting on in silence only hides that: what is finished is written, and
#: the job is resumed once workers are back. (Three times CONNECT_TIMEOUT, the wait for a first worker
#: at start-up, as a worker restarting mid-job also has to import numpy and spherekin again.)
NO_WORKER_TIMEOUT = 30.0
#: Seconds between two looks at the cluster while a job waits for its tasks (:func:`wait_any`).
#: Reason: one look is one small scheduler call (~1 ms); once a second costs nothing and sees a
#: cluster without workers within a second of NO_WORKER_TIMEOUT.
WATCH_INTERVAL = 1.0
#: Dask settings of an embedded cluster's workers. Reason: Dask's nanny starts every worker with
#: MALLOC_TRIM_THRESHOLD_=65536 (``distributed.nanny.pre-spawn-environ``, to hand memory back to the OS);
#: setting it at all turns off glibc's adaptive mmap threshold, so every array of the engine over 128 KiB is
#: mapped and unmapped afresh: measured (issue 42 item 2; 1,024 general_3rrr inputs in chunks of 256, one
#: worker, CPU time, two runs each) 5.9-6.3 s with it against 3.0-3.1 s without and 2.6-2.8 s in this process.
#: A chunk's arrays are a few MB, freed at its end: nothing for trimming to win. None unsets the variable.
WORKER_CONFIG = {"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}
#: The reason a job first ran in this process instead of on a local cluster (empty: none yet). The
#: warning that says so is given once per process: the later jobs of a script run here for the same reason.
_IN_PROCESS_SAID: list[str] = []


class ClusterLost(RuntimeError):
    """The cluster of a job cannot go on: its scheduler is lost, or it has had no worker for
    NO_WORKER_TIMEOUT seconds. The message says which, with the scheduler's address; ``back`` is
    what must come back before the job can go on ("the scheduler is", "workers are")."""

    def __init__(self, message: str, back: str):
        super().__init__(message)
        self.back = back


def default_workers() -> int:
    """Worker processes of an embedded cluster: the cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:                  # not on Linux
        return os.cpu_count() or 1


def n_workers(client) -> int:
    """Workers of ``client`` (0 for None: this process)."""
    return max(1, len(client.scheduler_info().get("workers", {}))) if client is not None else 0


def dask_setup(worker=None) -> None:
    """Run by every worker of an embedded cluster as it starts (Dask's ``preload`` of this module):
    ignore SIGINT. Ctrl-C in a terminal reaches the whole process group; the job's process handles it
    (cancels, writes what is done, closes the cluster), and the workers would only print tracebacks."""
    import signal

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def local_cluster_unsafe() -> str | None:
    """Why an embedded local cluster must not be started from here, or None when it may.

    Its worker processes are started by ``multiprocessing`` with Dask's
    ``distributed.worker.multiprocessing-method`` ("spawn" by default, or "forkserver"): each first
    runs the main script (or ``python -m`` module) again, as ``__mp_main__``. A script that starts
    the job from its top-level code, not under ``if __name__ == "__main__":``, would start it again
    in every worker, and the workers fail ("Nanny failed to start"). So it is safe when nothing is
    run again: the "fork" method; a ``__main__`` without ``__file__`` (the interactive interpreter,
    Jupyter, ``python -c``); a package's or zip's ``__main__`` (``python -m spherekin``), which
    multiprocessing skips; or when the main module's top-level frame (in the main thread's stack,
    also for a call from another thread) is at a line inside an ``if __name__ == "__main__":``
    block (either operand order; the ``spherekin`` console script is one). Unsafe, as we cannot
    tell: a frozen executable (its workers start the program itself), a main file that cannot be
    read or parsed, a call not made from the main module's top-level code (an atexit handler, the
    prompt of ``python -i``). A caller there gets a cluster with ``scheduler=`` or ``client=``.
    """
    import dask

    if dask.config.get("distributed.worker.multiprocessing-method", "spawn") == "fork":
        return None
    if getattr(sys, "frozen", False):
        return "this is a frozen executable, whose worker processes would start the program again"
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    name = getattr(getattr(main, "__spec__", None), "name", None) or ""
    if path is None or name == "__main__" or name.endswith(".__main__"):
        return None
    path = os.path.abspath(path)
    frame = sys._getframe() if threading.current_thread() is threading.main_thread() \
        else sys._current_frames().get(threading.main_thread().ident)
    while frame is not None and not (frame.f_globals is vars(main) and frame.f_code.co_name == "<module>"
                                     and os.path.abspath(frame.f_code.co_filename) == path):
        frame = frame.f_back
    if frame is None:
        return f"the call is not made from the top-level code of {path}, which its worker processes would run again"
    try:
        with open(path, "rb") as f:
            tree = ast.parse(f.read(), path)
    except (OSError, SyntaxError, ValueError) as exc:
        return f"its worker processes would run {path} again, which cannot be read ({exc})"
    line = frame.f_lineno                   # of the statement running: the one that starts this job
    for node in ast.walk(tree):             # an `if` whose test is __name__ == "__main__", either order
        if (isinstance(node, ast.If) and isinstance(t := node.test, ast.Compare) and len(t.ops) == 1
                and isinstance(t.ops[0], ast.Eq)
                and {ast.dump(t.left), ast.dump(t.comparators[0])} == {ast.dump(ast.Name("__name__", ast.Load())),
                                                                       ast.dump(ast.Constant("__main__"))}
                and node.body[0].lineno <= line <= node.body[-1].end_lineno):
            return None
    return (f"its worker processes would run {path} again, and its line {line}, which starts this job, "
            f'is not under `if __name__ == "__main__":`')


def _caller_stacklevel() -> int:
    """The ``stacklevel`` of warnings.warn, called from here, that names the caller's first frame
    outside spherekin (and contextlib): the line of the user's code that started the job."""
    import contextlib

    skip = (os.path.dirname(os.path.abspath(__file__)) + os.sep, os.path.abspath(contextlib.__file__))
    frame, level = sys._getframe(1), 1
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(skip):
        frame, level = frame.f_back, level + 1
    return level


@contextmanager
def connect(*, client=None, scheduler: str | None = None, workers: int | None = None) -> Iterator[object | None]:
    """The Dask client of a job, or None for this process (module doc). ValueError, before any work,
    for an address that cannot be reached, a scheduler without workers, or a bad worker count."""
    if client is not None and scheduler is not None:
        raise ValueError("client and scheduler: expected at most one of them")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 0):
        raise ValueError(f"workers: expected a whole number >= 0 (0: in this process), got {workers!r}")
    if client is not None:
        yield client
        return
    if scheduler is not None:
        with _remote(scheduler) as c:
            yield c
        return
    if workers == 0:
        yield None
        return
    unsafe = local_cluster_unsafe()
    if unsafe is not None:
        if not _IN_PROCESS_SAID:
            _IN_PROCESS_SAID.append(unsafe)
            warnings.warn(f"spherekin runs this job in this process, not on a local Dask cluster: {unsafe}. "
                          f'For the cluster, put that code under `if __name__ == "__main__":`, or pass '
                          f"scheduler= or client=.", RuntimeWarning, stacklevel=_caller_stacklevel())
        yield None
        return
    import dask
    from distributed import Client, LocalCluster

    with dask.config.set(WORKER_CONFIG):      # read by each nanny as it is made, inside LocalCluster()
        cluster = LocalCluster(n_workers=workers or default_workers(), threads_per_worker=1, processes=True,
                               host="127.0.0.1", dashboard_address=HTTP_ADDRESS, silence_logs=QUIET_LOGS,
                               preload=[__name__])
    try:
        with Client(cluster) as c:
            yield c
    finally:
        cluster.close()


@contextmanager
def _remote(address: str):
    from distributed import Client

    if not isinstance(address, str) or ":" not in address:
        raise ValueError(f"--scheduler: expected an address such as tcp://HOST:8786, got {address!r}")
    _probe(address)
    try:
        c = Client(address, timeout=CONNECT_TIMEOUT)
    except (OSError, TimeoutError, ValueError) as exc:
        raise ValueError(f"--scheduler {address}: cannot connect to a Dask scheduler there "
                         f"({type(exc).__name__}: {exc})") from None
    try:
        if not c.scheduler_info().get("workers"):
            c.wait_for_workers(1, timeout=CONNECT_TIMEOUT)
    except (OSError, TimeoutError) as exc:
        c.close()
        raise ValueError(f"--scheduler {address}: the scheduler has no workers ({exc})") from None
    # Quiet as an embedded cluster's (QUIET_LOGS): a scheduler lost mid-job makes Dask's client log
    # closed streams and its failed reconnection with tracebacks, and a fetch of a result cut by the
    # close (result_of) is reported by asyncio ("Task exception was never retrieved"); the job says
    # what happened once (ClusterLost). Dask sets the levels of both of its loggers named here.
    logs = [logging.getLogger(name) for name in ("distributed", "distributed.client", "asyncio")]
    levels = [log.level for log in logs]
    for log in logs:
        log.setLevel(QUIET_LOGS)
    try:
        yield c
    finally:
        try:
            c.close()
        finally:
            for log, level in zip(logs, levels):
                log.setLevel(level)


def _probe(address: str) -> None:
    """For a tcp:// address, one plain TCP connection first: a port nobody listens on is refused at
    once, where Dask's client would retry for CONNECT_TIMEOUT seconds before saying so."""
    import socket

    if not address.startswith("tcp://"):
        return
    host, _, port = address[len("tcp://"):].rpartition(":")
    try:
        port_number = int(port)
    except ValueError:
        raise ValueError(f"--scheduler {address}: expected tcp://HOST:PORT with a port number") from None
    try:
        socket.create_connection((host.strip("[]") or "127.0.0.1", port_number), timeout=CONNECT_TIMEOUT).close()
    except OSError as exc:
        raise ValueError(f"--scheduler {address}: cannot connect to a Dask scheduler there ({exc})") from None


def map_in_order(client, fn: Callable, items: Iterable) -> Iterator:
    """``fn(item)`` for every item, yielded in the items' order: on ``client``'s workers (at most
    TASKS_PER_WORKER tasks in flight per worker), or here when ``client`` is None. A task that
    raises re-raises here; leaving the loop early (an error, Ctrl-C) cancels what is in flight."""
    items = list(items)
    if client is None:
        for item in items:
            yield fn(item)
        return
    from collections import deque

    window = max(1, n_workers(client)) * TASKS_PER_WORKER
    address = scheduler_address(client)
    pending: deque = deque()
    nxt = 0
    try:
        while nxt < len(items) or pending:
            while nxt < len(items) and len(pending) < window:
                pending.append(client.submit(fn, items[nxt], pure=False))
                nxt += 1
            while pending[0].status == "pending":
                wait_any(client, [pending[0]], address)
            yield result_of(client, pending.popleft(), address)
    finally:
        if pending and client.status == "running":
            client.cancel(list(pending))


def scheduler_address(client) -> str:
    """The address of ``client``'s scheduler (for the messages of :class:`ClusterLost`)."""
    return client.scheduler_info().get("address") or str(getattr(client.scheduler, "address", "?"))


def result_of(client, future, address: str):
    """``future.result()`` (a future :func:`wait_any` gave): the task's value, or its error raised
    here. ClusterLost when it is not the task's error but a scheduler lost meanwhile (the future
    cancelled, or its result's transfer cut: an OSError), or when the result was lost with the
    worker that held it and no worker is left to compute it again (as in :func:`wait_any`)."""
    since = None                            # when the cluster was first seen without a worker
    while True:
        try:
            return future.result(timeout=WATCH_INTERVAL)
        except TimeoutError:                # a result lost with its worker, being computed again
            since = _watch(client, address, since)
        except Exception as exc:
            if future.status != "error" and (client.status != "running" or isinstance(exc, OSError)):
                raise ClusterLost(f"lost the scheduler at {address}", "the scheduler is") from None
            raise


def wait_any(client, futures, address: str) -> set:
    """The futures of ``futures`` (of ``client``, not empty) that are finished (a result, an error
    or cancelled), waiting until there is at least one. ClusterLost instead when ``client`` has lost
    its scheduler (at ``address``: the futures are cancelled then), or when the cluster has had no
    worker for NO_WORKER_TIMEOUT seconds (its tasks would wait for ever): a task's own error is the
    caller's, from :func:`result_of`."""
    from distributed import wait
    from distributed.client import FIRST_COMPLETED, FuturesCancelledError

    futures = list(futures)
    since = None                            # when the cluster was first seen without a worker
    while True:
        try:
            with client.as_current():       # distributed.wait waits on the current client
                done, _ = wait(futures, timeout=WATCH_INTERVAL, return_when=FIRST_COMPLETED)
            done = {f for f in done if f.done()}    # not "lost" (a result to be computed again)
            if done:
                return done
        except TimeoutError:                # none finished yet: look at the cluster
            pass
        except FuturesCancelledError:       # cancelled: by the lost scheduler, or as the caller's error
            if client.status != "running":
                raise ClusterLost(f"lost the scheduler at {address}", "the scheduler is") from None
            return {f for f in futures if f.status != "pending"}
        since = _watch(client, address, since)


def _watch(client, address: str, since: float | None) -> float | None:
    """One look at the cluster of a job waiting for a result: ClusterLost when ``client`` has lost
    its scheduler, or when it has had no worker since ``since`` (time.monotonic; None: it had one
    at the last look) for NO_WORKER_TIMEOUT seconds; else the new ``since``."""
    if client.status != "running":
        raise ClusterLost(f"lost the scheduler at {address}", "the scheduler is")
    if client.scheduler_info(n_workers=1).get("workers"):     # one is enough: a small reply
        return None
    now = time.monotonic()
    since = now if since is None else since
    if now - since >= NO_WORKER_TIMEOUT:
        raise ClusterLost(f"the workers of {address} are gone (none for {NO_WORKER_TIMEOUT:g} s)", "workers are")
    return since
