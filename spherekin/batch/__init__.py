"""Families of inputs: many actuator inputs of one mechanism solved at once, on Dask.

``solve_many(mechanism, inputs)`` returns the results table (pandas, one row per solution, see
:mod:`spherekin.batch.rows`) of every input; ``solve_to_file(mechanism, inputs, out)`` writes it to
a Parquet dataset or CSV file as it is computed (``resume=True`` completes a partial one);
``assembly_map(mechanism, x, y, fixed)`` counts the solutions over a 2-D grid (:class:`AssemblyMap`);
``branch_map(mechanism, grid, joint=...)``: the branches and circuits of a one-input mechanism
(:class:`BranchMap`, :mod:`spherekin.batch.branches`).
``mechanism``: a SphericalMechanism or the path of a mechanism file (as for :func:`spherekin.solve`).
Inputs: an array (K, A) in radians, a DataFrame with a column per actuated joint, or an
:class:`InputSet` (:func:`grid_inputs`, :func:`read_inputs_csv`). Where it runs: ``client`` (a
``distributed.Client``), ``scheduler`` (an address), or an embedded local cluster of ``workers``
processes (one per core by default; in this process for a handful of inputs), see
:mod:`spherekin.batch.engine`. The strategy keywords are those of :func:`spherekin.compile`.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Callable, Mapping, Sequence

from .inputs import GridAxis, InputSet, array_inputs, grid_inputs, read_inputs_csv

if TYPE_CHECKING:                 # the map's type, for annotations (maps.py is imported when a map is made)
    from .maps import AssemblyMap

__all__ = ["solve_many", "solve_to_file", "prepare_to_file", "run_to_file", "FileJob", "assembly_map", "AssemblyMap", "branch_map", "BranchMap", "GridAxis", "InputSet", "grid_inputs",
           "read_inputs_csv", "read_results", "RunSummary"]


#: The names this package gives from its other modules, imported when first asked for: reading a
#: path (``spherekin track``) needs only :mod:`.inputs`, and the sinks' locks and fingerprints
#: (socket, hashlib, json, ...), the branch maps and the engine cost every such process ~15 ms.
LAZY = {"BranchMap": "branches", "branch_map": "branches", "AssemblyMap": "maps", "MAP_COLUMNS": "maps",
        "aggregate": "maps", "read_results": "sinks", "RunSummary": "engine"}


def __getattr__(name):
    if name in LAZY:
        import importlib

        return getattr(importlib.import_module(f"{__name__}.{LAZY[name]}"), name)
    raise AttributeError(f"module 'spherekin.batch' has no attribute {name!r}")


def _prepare(mechanism, inputs, strategy):
    """The checked inputs and the job (the strategy compiled once here: a bad name fails now)."""
    from ..problem import as_mechanism   # the pipeline: imported when a job runs, not with this package
    from .engine import Job

    mechanism = as_mechanism(mechanism)
    inputs = array_inputs(mechanism, inputs)
    job = Job.of(mechanism, strategy)
    job.compile()
    return mechanism, inputs, job


def solve_many(mechanism, inputs, *, client=None, scheduler: str | None = None, workers: int | None = None,
               chunk_size: int | None = None, progress: Callable[[int, int], None] | None = None, **strategy):
    """The results table (a pandas DataFrame, :mod:`spherekin.batch.rows`) of every input, ordered by input.

    Held in memory: for a large family use :func:`solve_to_file`. Ctrl-C raises KeyboardInterrupt
    (nothing is returned); ``progress(done, total)`` is called after each chunk.
    """
    from .engine import connect, run
    from .sinks import MemorySink

    mechanism, inputs, job = _prepare(mechanism, inputs, strategy)
    sink = MemorySink(mechanism, inputs.values)
    with connect(len(inputs), client=client, scheduler=scheduler, workers=workers) as c:
        summary = run(job, inputs.values, sink, client=c, chunk_size=chunk_size, progress=progress)
    if summary.interrupted:
        raise KeyboardInterrupt
    return sink.frame()


@dataclasses.dataclass(frozen=True)
class FileJob:
    """A family to solve into a file, every part checked once (:func:`prepare_to_file`): the mechanism,
    the inputs (an :class:`InputSet`), the engine's :class:`~spherekin.batch.engine.Job` and the problem
    it compiled (the strategy checked), the output ``path`` (checked: writable, not another writer's),
    whether to ``resume`` it, and the ``fingerprint`` the output records (checked against it on resume).
    :func:`run_to_file` runs it and neither checks nor compiles it again (but on the workers)."""

    mechanism: object
    inputs: InputSet
    job: object
    problem: object
    path: object
    resume: bool
    fingerprint: object


def prepare_to_file(mechanism, inputs, out, *, resume: bool = False, overwrite: bool = False, **strategy) -> FileJob:
    """Every check of :func:`solve_to_file` before any work, in the order a reader fixes them: the mechanism,
    the inputs, the output path, the strategy (compiled once here), then on ``resume`` the output's
    fingerprint (another job's output is refused before a cluster starts). Returns a :class:`FileJob`."""
    from ..problem import as_mechanism   # the pipeline: imported when a job runs, not with this package
    from .engine import Job
    from .fingerprint import Fingerprint, describe_inputs, strategy_of
    from .sinks import check_fingerprints, check_output_path

    mechanism = as_mechanism(mechanism)
    inputs = array_inputs(mechanism, inputs)
    path = check_output_path(out, resume, overwrite)
    job = Job.of(mechanism, strategy)
    problem = job.compile()
    fingerprint = Fingerprint.of(mechanism, inputs.values, strategy_of(problem), describe_inputs(inputs))
    if resume:
        check_fingerprints(path, fingerprint)
    return FileJob(mechanism, inputs, job, problem, path, bool(resume), fingerprint)


def run_to_file(job: FileJob, *, client=None, scheduler: str | None = None, workers: int | None = None,
                chunk_size: int | None = None, progress: Callable[[int, int], None] | None = None):
    """Run a checked :class:`FileJob` (:func:`prepare_to_file`): every input it does not hold yet solved
    and written to its path as chunks finish; returns the :class:`~spherekin.batch.engine.RunSummary`."""
    from .engine import connect, run
    from .sinks import open_sink

    with connect(len(job.inputs), client=client, scheduler=scheduler, workers=workers) as c:
        with open_sink(job.path, job.mechanism, job.inputs.values, job.resume, job.fingerprint) as sink:   # the output's lock, released on any exit
            return run(job.job, job.inputs.values, sink, client=c, chunk_size=chunk_size, progress=progress,
                       problem=job.problem)


def solve_to_file(mechanism, inputs, out, *, resume: bool = False, overwrite: bool = False, client=None,
                  scheduler: str | None = None, workers: int | None = None, chunk_size: int | None = None,
                  progress: Callable[[int, int], None] | None = None, **strategy):
    """Solve every input and write the results table to ``out`` (.parquet: a dataset directory;
    .csv) as chunks finish; returns the :class:`~spherekin.batch.engine.RunSummary`.

    Everything (inputs, strategy, the output path, the scheduler) is checked before the first solve.
    With ``resume`` only the inputs ``out`` does not hold yet are solved, after checking that ``out``
    was written by this job (mechanism, inputs, strategy, version: its fingerprint) and that its rows
    are whole (:mod:`spherekin.batch.sinks`); ``overwrite`` replaces it.
    On Ctrl-C the finished chunks stay written and the summary says ``interrupted``.
    ``run_to_file(prepare_to_file(...))``: the command line checks first, then runs the checked job.
    """
    return run_to_file(prepare_to_file(mechanism, inputs, out, resume=resume, overwrite=overwrite, **strategy),
                       client=client, scheduler=scheduler, workers=workers, chunk_size=chunk_size, progress=progress)


def assembly_map(mechanism, x: GridAxis | str, y: GridAxis | str, fixed: Mapping[str, float] | Sequence[str] = (),
                 *, out=None, resume: bool = False, overwrite: bool = False, client=None,
                 scheduler: str | None = None, workers: int | None = None, chunk_size: int | None = None,
                 progress: Callable[[int, int], None] | None = None, singular_tol: float | None = None,
                 singular_max_boxes: int | None = None, **strategy) -> AssemblyMap:
    """The assembly-mode map over the grid ``x`` by ``y`` (GridAxis or "name=lo:hi:n"), the other
    actuated joints at ``fixed`` (name -> radians, or "name=value"); with ``out`` the results table
    is also written there (and ``resume`` completes it). Ctrl-C raises KeyboardInterrupt.

    ``singular_tol`` (radians; None: not computed): also the certified parallel-singular set of the
    map's plane (:func:`spherekin.singular` over the grid's ranges, cells no wider than singular_tol,
    ``singular_max_boxes`` its box cap), in :attr:`AssemblyMap.singular_set`. Not to be confused with
    the map's ``singular`` counts (entries the solver flagged singular) nor its ``measure``."""
    from ..problem import as_mechanism
    from ..singularities import check_singular_tol, singular
    from ..results import CrossCheck
    from .maps import aggregate, grid_cross_check

    mechanism = as_mechanism(mechanism)
    inputs = grid_inputs(mechanism, [x, y], fixed)
    x, y = inputs.axes
    sset = None
    if singular_tol is not None:     # checked and computed before the map: its errors come before any long work
        singular_tol = check_singular_tol(singular_tol, "singular_tol")
        _prepare(mechanism, inputs, strategy)          # the map's strategy checked too (milliseconds)
        caps = {} if singular_max_boxes is None else {"max_boxes": singular_max_boxes}
        sset = singular(mechanism, (x.name, x.values[0], x.values[-1]), (y.name, y.values[0], y.values[-1]),
                        inputs.fixed, tol=singular_tol, **caps)
    elif singular_max_boxes is not None:
        raise ValueError("singular_max_boxes: only with singular_tol (the singular set's cell width)")
    frame = _map_frame(mechanism, inputs, out, resume, overwrite, client, scheduler, workers, chunk_size,
                       progress, strategy)
    amap = aggregate(frame, x, y, inputs.fixed, mechanism.name, singular_set=sset)
    if sset is not None and sset.stopped is None:
        # the set held against the map's proven counts (issue 40 item 3): a count change between two grid
        # neighbours with no cell between them proves the cover wrong; not where a passive range can end an
        # assembly (a count change with no singularity) or the map's solve applies ranges the set does not
        ranged = [n for n in mechanism.passive if mechanism.joint(n).range is not None]
        check = (CrossCheck(skipped=f"passive joint ranges ({', '.join(ranged)}): a count also changes where an "
                                    "assembly leaves its range") if ranged else grid_cross_check(amap, sset))
        amap = dataclasses.replace(amap, singular_set=dataclasses.replace(
            sset, cross_check=check, complete=sset.complete and not check.disagreements))
    return amap


def _map_frame(mechanism, inputs, out, resume, overwrite, client, scheduler, workers, chunk_size, progress, strategy):
    """The results table of a map's grid (in memory, or written to ``out`` and read back)."""
    from ..core.columns import TOLERANCE_COLUMNS
    from .maps import MAP_COLUMNS
    from .sinks import read_results

    if out is None:
        frame = solve_many(mechanism, inputs, client=client, scheduler=scheduler, workers=workers,
                           chunk_size=chunk_size, progress=progress, **strategy)
    else:
        summary = solve_to_file(mechanism, inputs, out, resume=resume, overwrite=overwrite, client=client,
                                scheduler=scheduler, workers=workers, chunk_size=chunk_size, progress=progress,
                                **strategy)
        if summary.interrupted:
            raise KeyboardInterrupt
        if summary.note:                        # a repaired resume: said, as the CLI's batch says it
            import warnings

            warnings.warn(summary.note, UserWarning, stacklevel=2)
        frame = read_results(out, columns=MAP_COLUMNS + (TOLERANCE_COLUMNS if mechanism.tolerances is not None else ()))
    return frame
