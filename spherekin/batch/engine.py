"""The engine of a batch: chunks of inputs solved on Dask workers, each with the problem compiled once.

Where a job runs (:func:`connect`): a job a cluster would not speed up (:func:`in_process_max_inputs` of
the machine's cores: ~1,250 inputs on 2 cores, any job on 1), or ``workers=0``, in this process, no
cluster; otherwise where :func:`spherekin.cluster.connect` says:
an embedded local cluster (only where that is safe, else this process with a warning:
:func:`spherekin.cluster.local_cluster_unsafe`), an existing one by ``scheduler`` address, or the
caller's ``client``.

How: the mechanism and the strategy go to every worker once, as a worker plugin
(:class:`CompiledProblem`) that compiles the problem when the worker starts it; then every task is
a chunk of consecutive inputs, solved with ``Problem.solve_many`` and turned into rows of the
results table on the worker (:func:`spherekin.batch.rows.report_table`: columns, no pandas). At most
TASKS_PER_WORKER chunks per worker are in flight, so the inputs and results held at any time are
bounded whatever the job's size. Each finished chunk goes to the sink (a file or memory) as it
arrives, or, for a sink that needs input order (CSV), as soon as every earlier chunk is there. The
rows of an input do not depend on where or with what else it was solved, so the table is the same,
row for row, for any number of workers.

Ctrl-C (KeyboardInterrupt) stops the job: the chunks in flight are cancelled, every finished chunk
that can be written is written, and the summary says how far it got (``interrupted``). A cluster
that cannot go on (its scheduler lost, or no worker for NO_WORKER_TIMEOUT seconds) stops it the same
way, with :class:`~spherekin.cluster.ClusterLost`: what was lost, what is kept, and ``--resume``.

The worker plugin is named per run (the job's token, a random part, and the client's id), and
unregistered when the run ends, however it ends; one left behind by a client that was killed (no
``finally`` runs then) is unregistered by the next run on that scheduler, as its client is gone.
"""

from __future__ import annotations

import hashlib
import math
import pickle
import time
from collections import deque
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Callable, Iterator, Mapping

import numpy as np

from ..cluster import connect as cluster_connect
from ..cluster import TASKS_PER_WORKER, ClusterLost, default_workers, n_workers, result_of, scheduler_address, wait_any
from ..problem import DEFAULT_CHUNK
from .rows import report_table

__all__ = ["IN_PROCESS_MAX_INPUTS", "in_process_max_inputs", "CHUNK_INPUTS", "Job", "RunSummary",
           "CompiledProblem", "solve_chunk", "default_chunk_size", "chunks", "connect", "run"]

#: Seconds an embedded cluster adds to a job before its workers solve anything, and seconds per input of
#: the engine in this process. Measured on the 2-core machine (benchmarks/bench_crossover.py --sizes 250 500
#: 1000 2000 4000, 2026-11-29, general_3rrr over its full ranges, whole calls, medians of 3; benchmarks/README.md):
#: least-squares lines in process -0.06 s + 2.7 ms an input, on 2 workers 1.32 s + 1.6 ms an input.
CLUSTER_START_S = 1.38
IN_PROCESS_INPUT_S = 2.7e-3
#: The share of the ideal speed-up a worker gives (transfer, scheduling, the rows made on the worker):
#: 2.7 ms / (2 x 1.6 ms), same measurement. Below one worker's worth (one core) a cluster never pays.
WORKER_EFFICIENCY = 0.84


def in_process_max_inputs(workers: int) -> float:
    """The largest job that runs faster in this process than on an embedded cluster of ``workers`` workers
    (the cores this process may use): a cluster costs CLUSTER_START_S and then solves
    ``workers * WORKER_EFFICIENCY`` times as fast, so it pays from N = start / (t (1 - 1 / speed-up)), t =
    IN_PROCESS_INPUT_S; never (inf) when the speed-up is at most 1 (one core). 2 workers: ~1,250 inputs (the
    measured lines cross at 1,194); 8: ~600, where the start cost, measured with 2, is the least certain part."""
    speedup = workers * WORKER_EFFICIENCY
    if speedup <= 1.0:
        return math.inf
    return CLUSTER_START_S / (IN_PROCESS_INPUT_S * (1.0 - 1.0 / speedup))


#: Jobs of at most this many inputs run in this process on the 2-core machine the constants were measured
#: on (:func:`in_process_max_inputs` of 2). Issue 42 item 2: the cluster's workers ran ~2x slower than this
#: process until their malloc setting was fixed (spherekin.cluster.WORKER_CONFIG), and 2,000 was measured then.
IN_PROCESS_MAX_INPUTS = int(in_process_max_inputs(2))
#: Inputs per task, at most (and per chunk of a job in this process): the chunk
#: ``Problem.solve_many`` solves as one array program (:data:`spherekin.problem.DEFAULT_CHUNK`).
#: Reason: the engine's throughput levels off there (benchmarks/README.md), a Dask task's ~1 ms of
#: scheduling and transfer is then well below 1%, and a chunk (2-7 ms an input) still finishes in
#: about a second: progress stays live, Ctrl-C is quick, and a resumed job redoes little.
CHUNK_INPUTS = DEFAULT_CHUNK


@dataclass(frozen=True)
class Job:
    """What every worker needs: the mechanism and the strategy keywords of :func:`spherekin.compile`."""

    mechanism: object
    strategy: tuple[tuple[str, object], ...]

    @classmethod
    def of(cls, mechanism, strategy: Mapping) -> "Job":
        return cls(mechanism, tuple(sorted(strategy.items())))

    def compile(self):
        from ..problem import compile as compile_problem

        return compile_problem(self.mechanism, **dict(self.strategy))

    @property
    def token(self) -> str:
        """The job's name: the same mechanism and strategy give the same one (the first part of its
        worker plugin's name, :class:`CompiledProblem`)."""
        return "spherekin-" + hashlib.sha1(pickle.dumps((self.mechanism, self.strategy))).hexdigest()[:16]


@dataclass(frozen=True)
class RunSummary:
    """How a job ended: ``total`` inputs, ``skipped`` (finished by an earlier run, resumed), ``solved``
    now, ``written`` rows, ``workers`` (0: in this process), ``seconds``, whether it was
    ``interrupted`` (Ctrl-C), and ``note``: what a resume repaired in the output ("" if nothing)."""

    total: int
    skipped: int
    solved: int
    written: int
    workers: int
    seconds: float
    interrupted: bool = False
    note: str = ""

    @property
    def complete(self) -> bool:
        return self.skipped + self.solved == self.total


def __getattr__(name):
    if name == "CompiledProblem":          # distributed is imported only for a job on a cluster (.plugin)
        from .plugin import CompiledProblem

        return CompiledProblem
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def solve_chunk(plugin_name: str, first: int, rows: np.ndarray):
    """The task: the results table of inputs ``first ... first + len(rows) - 1`` on this worker."""
    from distributed import get_worker

    problem = get_worker().plugins[plugin_name].problem
    return report_table(problem.mechanism, problem.solve_many(rows), first, rows)


def default_chunk_size(n_inputs: int, workers: int) -> int:
    """Inputs per chunk of a job of ``n_inputs`` on ``workers`` Dask workers (0: in this process).

    On workers, small enough to give each worker TASKS_PER_WORKER tasks (all of them busy), at most
    CHUNK_INPUTS. In this process there is nobody to share the work with: CHUNK_INPUTS, so a small
    job is one chunk (one Parquet part, not one part per input)."""
    if not workers:
        return CHUNK_INPUTS
    return max(1, min(CHUNK_INPUTS, math.ceil(n_inputs / (workers * TASKS_PER_WORKER))))


def chunks(todo: np.ndarray, size: int) -> list[tuple[int, int]]:
    """[first, end) ranges of at most ``size`` consecutive inputs covering the True entries of ``todo``."""
    out = []
    idx = np.flatnonzero(todo)
    if not len(idx):
        return out
    breaks = np.flatnonzero(np.diff(idx) != 1) + 1
    for run_ in np.split(idx, breaks):
        lo, hi = int(run_[0]), int(run_[-1]) + 1
        out += [(a, min(a + size, hi)) for a in range(lo, hi, size)]
    return out


@contextmanager
def connect(n_inputs: int, *, client=None, scheduler: str | None = None,
            workers: int | None = None) -> Iterator[object | None]:
    """The Dask client a job of ``n_inputs`` runs on (None: in this process, for ``workers=0`` or, with no
    cluster asked for, a job a cluster of this machine's cores would not speed up:
    :func:`in_process_max_inputs`); see :func:`spherekin.cluster.connect`."""
    small = workers is None and client is None and scheduler is None and \
        n_inputs <= in_process_max_inputs(default_workers())
    with cluster_connect(client=client, scheduler=scheduler, workers=0 if small else workers) as c:
        yield c


def run(job: Job, inputs: np.ndarray, sink, *, client=None, chunk_size: int | None = None,
        progress: Callable[[int, int], None] | None = None, problem=None) -> RunSummary:
    """Solve every input of ``inputs`` (K, A) that ``sink.done`` does not mark, writing to ``sink``.

    ``client`` None: in this process (with ``problem``, the job already compiled, when the caller has it).
    ``progress(done, total)`` after each chunk written.
    """
    t0 = time.perf_counter()
    total = len(inputs)
    skipped = int(sink.done.sum())
    workers = n_workers(client)
    if chunk_size is None:
        chunk_size = default_chunk_size(total - skipped, workers)
    elif isinstance(chunk_size, bool) or not isinstance(chunk_size, int) or chunk_size < 1:
        raise ValueError(f"chunk_size: expected a whole number >= 1, got {chunk_size!r}")
    todo = chunks(~sink.done, chunk_size)
    state = {"solved": skipped, "rows": 0}

    def emit(first, end, table):
        sink.write(first, end, table)
        state["solved"] += end - first
        state["rows"] += len(table)
        if progress is not None:
            progress(state["solved"], total)

    if progress is not None:
        progress(skipped, total)
    interrupted = False
    try:
        if client is None:
            _run_here(problem or job.compile(), inputs, todo, emit)
        else:
            _run_dask(job, inputs, todo, emit, client, workers, sink.ordered)
        sink.check_in_place(state["rows"])           # rows said written must be at the path
    except KeyboardInterrupt:
        interrupted = True
    except ClusterLost as exc:              # what was lost, then what is kept and how to finish
        path = getattr(sink, "path", None)
        kept = (f"{state['solved']} of {total} inputs ({state['rows']} rows written now) are kept in {path}; "
                f"run the same command with --resume once {exc.back} back" if path is not None
                else f"the table was held in memory: nothing is kept ({state['solved']} of {total} inputs were done)")
        raise ClusterLost(f"{exc}; {kept}", exc.back) from None
    except OSError as exc:                  # the output could not be written (disk full, its directory gone)
        path = getattr(sink, "path", None)
        raise RuntimeError(f"--out {path}: could not write ({exc.strerror or type(exc).__name__}): {state['solved']} of "
                           f"{total} inputs are kept there; free space (or restore the path) and run the same command "
                           "with --resume") from None
    finally:
        sink.close()
    return RunSummary(total, skipped, state["solved"] - skipped, state["rows"], workers,
                      time.perf_counter() - t0, interrupted, getattr(sink, "note", ""))


def _run_here(problem, inputs, todo, emit) -> None:
    for first, end in todo:
        rows = inputs[first:end]
        emit(first, end, report_table(problem.mechanism, problem.solve_many(rows), first, rows))


def _run_dask(job: Job, inputs, todo, emit, client, workers: int, ordered: bool) -> None:
    from .plugin import CompiledProblem

    try:
        address = scheduler_address(client)
        plugin = CompiledProblem(job, client.id)
        _register(client, plugin)
    except OSError as exc:                      # distributed's CommClosedError is one: the cluster went down
        raise ClusterLost(f"lost the cluster while the job was being set up ({type(exc).__name__}: "
                          f"{' '.join(str(exc).split()) or 'connection closed'})", "the scheduler is") from None
    queue = deque(todo)
    window = max(1, workers) * TASKS_PER_WORKER
    futures = {}
    held = {}                                   # finished out of order (ordered sinks)
    order = deque(todo)                         # the next chunk to write, for an ordered sink

    def submit():
        while queue and len(futures) < window:
            first, end = queue.popleft()
            fut = client.submit(solve_chunk, plugin.name, first, inputs[first:end], pure=False)
            futures[fut] = (first, end)

    try:
        submit()
        while futures:
            for fut in sorted(wait_any(client, futures, address), key=lambda f: futures[f]):
                first, end = futures.pop(fut)
                try:
                    frame = result_of(client, fut, address)
                except ClusterLost:
                    raise
                except Exception as exc:        # a solve that raised on a worker: stop, keep what is written
                    raise RuntimeError(f"inputs {first}..{end - 1}: the solve failed on a worker "
                                       f"({type(exc).__name__}: {exc})") from exc
                if not ordered:
                    emit(first, end, frame)
                else:
                    held[first] = (end, frame)
                    while order and order[0][0] in held:
                        a, _ = order.popleft()
                        b, fr = held.pop(a)
                        emit(a, b, fr)
            submit()
    finally:
        if futures:
            try:
                client.cancel(list(futures))
            except Exception:                   # a client that lost its scheduler: nothing to cancel there
                pass
        try:
            client.unregister_worker_plugin(plugin.name)
        except Exception:                       # a cluster going down with Ctrl-C: nothing left to clean
            pass


def _register(client, plugin) -> None:
    """Register ``plugin`` on ``client``'s scheduler, after unregistering every CompiledProblem there
    whose client the scheduler no longer knows (left by a client that was killed: module doc)."""

    def stale(dask_scheduler=None):             # runs on the scheduler (sent by value: spherekin need not be there)
        return [name for name in dask_scheduler.worker_plugins
                if name.startswith("spherekin-") and "@" in name
                and name.rpartition("@")[2] not in dask_scheduler.clients]

    for name in client.run_on_scheduler(stale):
        client.unregister_worker_plugin(name)
    client.register_plugin(plugin, name=plugin.name)
