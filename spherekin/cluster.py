"""Where parallel work runs: Dask (``dask.distributed``), from a laptop to a cluster.

:func:`connect` gives the ``distributed.Client`` of a job, or None for this process:

* ``workers=0``: this process, no cluster;
* with no address: an embedded ``distributed.LocalCluster`` on 127.0.0.1, one single-threaded
  worker process per core (or ``workers``), closed when the job ends; its workers ignore SIGINT
  (Ctrl-C reaches the whole process group; the job's process handles it);
* ``scheduler="tcp://HOST:8786"``: an existing Dask cluster (``dask scheduler`` + ``dask worker``,
  spherekin installed where the workers run), unchanged; or ``client=``: a Client of the
  caller's, left open.

:func:`map_in_order` runs a function over items on a client (or here) and yields the results in
the items' order. The families of inputs (:mod:`spherekin.batch`), the box loop's chart groups
(``jobs``) and the benchmark sweeps all run through this module: one engine, no process pool of
our own. ``distributed`` is imported only when a cluster is asked for.
"""

from __future__ import annotations

import logging
import os
from contextlib import contextmanager
from typing import Callable, Iterable, Iterator

__all__ = ["QUIET_LOGS", "CONNECT_TIMEOUT", "TASKS_PER_WORKER", "connect", "map_in_order", "default_workers", "n_workers", "dask_setup"]

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
    import threading

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


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
    from distributed import Client, LocalCluster

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
    try:
        yield c
    finally:
        c.close()


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
    pending: deque = deque()
    nxt = 0
    try:
        while nxt < len(items) or pending:
            while nxt < len(items) and len(pending) < window:
                pending.append(client.submit(fn, items[nxt], pure=False))
                nxt += 1
            yield pending.popleft().result()
    finally:
        if pending:
            client.cancel(list(pending))
