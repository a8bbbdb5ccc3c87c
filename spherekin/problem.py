"""The solve pipeline: a mechanism compiled once, then solved for one input or for many.

``problem = compile(mechanism, formulation=..., pruner=..., ...)`` does once what does not depend
on the actuator inputs: the strategy checks, the unknowns and their ranges, and the system of
equations chosen from :data:`spherekin.systems.SYSTEMS`, compiled: for the platform system
(:mod:`spherekin.systems.platform`), Eq. (1)'s control-point tensors on the four quaternion charts
and the pruner (for the LP pruners, the compiled LP models); for the loop system
(:mod:`spherekin.systems.loops`, also every platform problem's fallback), the loop builder, whose
pruner (and its LP model) is built at its first use, once per chart layout, and kept. Then
``problem.solve(inputs)`` and ``problem.solve_many(rows)`` run, per input:

1. the search (:mod:`spherekin.search.boxloop`): the box loop of Section 4 on the platform formulation,
   or on the loop equations (Eq. 2) in a parameterization and formulation of their own;
2. the trust layer (:func:`spherekin.trust.solutions.finalize`): polishing, certification, statuses and
   the count;
3. the report (:class:`spherekin.results.SolveReport`).

``spherekin.solve(mechanism, inputs, ...)`` is ``compile(mechanism, ...).solve(inputs)``.

System ``"auto"`` with formulation ``"auto"`` (the defaults) is the first system of the registry
that accepts the mechanism and strategy: the platform system when it applies (three R-R-R legs with
one joint of each actuated; the tan-half parameterization asked for; isolation on), else
the loop system in formulation ``"halves"``; ``settings.system`` says which, ``settings.declined``
why the faster ones did not accept. When the platform search cannot isolate every root (next to a parallel
singularity its Jacobian is singular; a cap), the input is solved again with the loop equations
(``settings.fallback`` says why): everything issue 13 built for the edge (cluster resolution,
refined searches, continua) works on those.
"""

from __future__ import annotations

import dataclasses
import os
import time
import warnings
from dataclasses import dataclass
import math
from typing import Callable, Mapping

import numpy as np

from .core.angles import RANGE_TOL, check_turn, in_range, in_range_many, into_range
from .core.groups import pad_by_owner
from .mechanism.io import load_mechanism
from .mechanism.model import SphericalMechanism
from .search.formulations import FORMULATIONS
from .systems import (AUTO, LOOP_FORMULATION, ON_CAP_CHOICES, ON_CAP_COVER, ON_CAP_RAISE, SYSTEMS, Strategy, choose,
                      system_choices)
from .systems.loops import CompiledLoops, Loops
from .systems.platform import CompiledPlatform, Platform
from .results import (EmptyReason, SearchLimit, SearchReport, Settings, SolveReport, SolverStats,
                      EMPTY_INCONSISTENT, EMPTY_OUTSIDE_RANGES, EMPTY_OUTSIDE_WORKSPACE)
from .trust.solutions import count_summary, finalize_many, is_proven
from .search.boxloop import (DEFAULT_MAX_BOXES, DEFAULT_PARAMETERIZATION, DEFAULT_PRUNER, DEFAULT_TOL, SolverLimitError,
                     check_strategy, clusters_in_range_many, partial_report, search_platform, search_platform_many,
                     SearchInterrupted)
from .search.parameterizations import stack_chart_sets

__all__ = ["DEFAULT_FORMULATION", "DEFAULT_SYSTEM", "LOOP_FORMULATION", "PIPELINE_FORMULATIONS", "formulation_choices",
           "system_choices", "resolve_system", "CONTINUUM_TOL", "REFINE_FACTOR",
           "REFINE_MIN_TOL", "REFINE_MAX_BOXES", "POSE_MATCH", "REPR_NAME_CHARS", "Strategy", "Problem", "compile",
           "solve", "disagreement", "as_mechanism", "inverse_kinematics", "DEFAULT_CHUNK", "CappedSearchWarning",
           "ON_CAP_CHOICES"]

#: The default: the platform formulation where it applies, else :data:`LOOP_FORMULATION`.
DEFAULT_FORMULATION = "auto"
#: The default: the first system of :data:`spherekin.systems.SYSTEMS` that accepts the mechanism.
DEFAULT_SYSTEM = AUTO
#: The formulations a solve accepts beyond the registered loop formulations (FORMULATIONS).
PIPELINE_FORMULATIONS = ("auto", "platform")


class CappedSearchWarning(UserWarning):
    """A solve's search reached ``max_boxes`` at the tolerance asked for and the solution set was covered
    at :data:`CONTINUUM_TOL` instead (``on_cap="cover"``): the count is not proven; the report's
    ``settings.tol`` is the covering's, ``settings.limit`` says what was asked and what stopped it."""


def formulation_choices() -> tuple[str, ...]:
    """Every formulation a solve accepts by name: "auto", "platform" and the registered loop formulations."""
    return (*PIPELINE_FORMULATIONS, *FORMULATIONS)


#: Longest mechanism name ``repr(problem)`` shows (longer ones are cut with "..."). Reason: keeps the
#: repr on one line of ~200 characters whatever the file calls its mechanism.
REPR_NAME_CHARS = 60


def as_mechanism(mechanism) -> SphericalMechanism:
    """``mechanism`` itself when it is a :class:`~spherekin.mechanism.SphericalMechanism`, else the
    mechanism of the file at that path (str or ``os.PathLike``, docs/mechanism-format.md); the one
    place every Python entry point (:func:`solve`, :func:`compile`, :mod:`spherekin.batch`) resolves it."""
    if isinstance(mechanism, SphericalMechanism):
        return mechanism
    if isinstance(mechanism, (str, os.PathLike)):
        return load_mechanism(mechanism)
    raise ValueError(f"mechanism: expected a SphericalMechanism or a path to a .toml file, "
                     f"got {type(mechanism).__name__}")


#: Inputs :meth:`Problem.solve_many` solves as one array program. Reason: measured
#: (benchmarks/bench_engine.py) the throughput per input levels off past ~100 inputs a chunk (the
#: fixed cost of each box-loop iteration is then spread thin), and a chunk of 256 holds at most a
#: few MB of boxes.
DEFAULT_CHUNK = 256
#: Tolerance (radians) of the covering run when a solve hits a cap (a continuum of solutions): a
#: curve of length ~2 pi is covered by ~1e3 boxes of this size, well within the default cap, and
#: the boxes are fine enough to show its shape and estimate its dimension.
CONTINUUM_TOL = 1e-2
#: A cluster that :mod:`spherekin.trust.solutions` cannot resolve at tol (two roots closer than the
#: boxes can separate, next to a fold) is searched again, its hull only, at tol * REFINE_FACTOR,
#: down to REFINE_MIN_TOL: roots 1e-5 apart separate at 1e-6, ~1e-8 apart (within ~1e-16 of a
#: singular input) at 1e-10; below that, Krawczyk tests are swamped by rounding.
REFINE_FACTOR = 1e-2
REFINE_MIN_TOL = 1e-10
#: Box cap of one refined search. Reason: a hull that holds separable roots is resolved in a few
#: thousand boxes; a search that needs more is at the singular input itself (roots not separable
#: at any tol worth paying for), and the cluster is then reported as unresolved.
REFINE_MAX_BOXES = 20_000
#: A root of the platform search and a finalized solution are the same assembly when their poses
#: agree to this (largest entry). Reason: both are Newton/Gauss-Newton limits accurate to ~1e-14 away
#: from parallel singularities (near one, the platform search does not isolate the roots and this
#: check is not reached), and distinct assemblies closer than 1e-8 occur only next to one.
POSE_MATCH = 1e-8
#: Two roots of the platform search are one (found from two overlapping charts, or on the face of
#: two boxes) when their poses agree to this. Reason: Newton limits of one root agree to ~1e-15;
#: two distinct roots this close could not be told apart by any float64 test downstream either.
DUPLICATE_POSE = 1e-12


@dataclass(frozen=True, eq=False)
class Problem:
    """A mechanism compiled for one strategy: call :meth:`solve` or :meth:`solve_many`.

    ``names``: the passive unknowns (order of every solution's angles); ``ranges``: their joint
    ranges (None: the full circle); ``system``: the name of the system that solves it (in
    :data:`spherekin.systems.SYSTEMS`); ``platform``: the compiled platform system, or None;
    ``loops``: the compiled loop system (the platform's fallback too); ``declined``: (name, reason)
    of every system before ``system`` in the registry's order that "auto" passed over (empty when
    a system or formulation was asked for by name).
    """

    mechanism: object
    strategy: Strategy
    names: tuple
    ranges: Mapping
    system: str
    platform: CompiledPlatform | None
    loops: CompiledLoops
    declined: tuple = ()

    @property
    def not_platform(self) -> str | None:
        """Why "auto" passed over the platform system (None when it did not)."""
        return dict(self.declined).get(Platform.name)

    @property
    def loop_pruners(self) -> dict:
        """The loop equations' pruners, built on first use once per chart layout and kept for every
        input (:func:`spherekin.search.boxloop.pruner_for`)."""
        return self.loops.pruners

    def __repr__(self) -> str:
        """One line: the mechanism's name and size and the strategy (not the whole mechanism)."""
        st = self.strategy
        name = self.mechanism.name or "unnamed mechanism"
        if len(name) > REPR_NAME_CHARS:
            name = name[:REPR_NAME_CHARS - 3] + "..."
        backend = f" ({st.lp_backend})" if st.lp_backend else ""
        how = "platform" if self.platform is not None else f"{st.formulation}, {st.parameterization}"
        return (f"Problem({name!r}, {len(self.mechanism.joints)} joints, {len(self.names)} unknowns; "
                f"{how}, pruner {st.pruner}{backend}, tol {st.tol:g})")

    def strategy_keywords(self) -> dict:
        """The keywords of :func:`compile` that make this problem's strategy (for another mechanism)."""
        st = self.strategy
        return dict(formulation=st.formulation if not self.declined else DEFAULT_FORMULATION,
                    pruner=st.pruner, lp_backend=st.lp_backend, parameterization=st.parameterization, tol=st.tol,
                    isolate=st.isolate, jobs=st.jobs, max_boxes=st.max_boxes, max_depth=st.max_depth,
                    on_cap=st.on_cap)

    # ------------------------------------------------------------------ one input

    def solve(self, inputs, *, progress: Callable[[dict], None] | None = None,
              trace: Callable[[dict], None] | None = None) -> SolveReport:
        """Every assembly at actuator ``inputs`` (radians, one per actuated joint) inside the joint
        ranges: polished, certified and classified (see :func:`spherekin.solve`). ``trace`` (loop
        formulations only, ``jobs=1``) records every batch of boxes for experiments. A report
        without solutions (and no cap or Ctrl-C) says why in ``empty_reason`` (:meth:`explain_empty`)."""
        values = self.mechanism.check_inputs(inputs)
        if trace is None and self.strategy.jobs == 1:
            report = self._solve_chunk([values], progress)[0]     # the engine, on a chunk of one
        else:
            report = self._solve(values, progress, trace)
        return self._explained(report, values)

    def _explained(self, report: SolveReport, values) -> SolveReport:
        """``report`` with ``empty_reason`` set where it has no solution (and no cap or Ctrl-C)."""
        if not report.solutions and report.settings.limit is None:
            report = dataclasses.replace(report, empty_reason=self.explain_empty(values))
        return report

    def solve_alone(self, inputs) -> SolveReport:
        """The engine's reference: the report of ``inputs`` (radians, one per actuated joint) from a box
        loop of its own, one input at a time (the pipeline :meth:`solve_many` batches; slower). The
        same answer as :meth:`solve`: counts, statuses, evidence, fallbacks, angles to rounding."""
        values = self.mechanism.check_inputs(inputs)
        return self._explained(self._solve(values, None, None), values)

    def explain_empty(self, inputs) -> EmptyReason:
        """Why the solve at ``inputs`` (radians, one per actuated joint) finds no assembly in the
        joint ranges: assemblies exist with the passive joints' ranges lifted (one more solve, of
        the mechanism without them), or none at all (inconsistent inputs of a redundantly actuated
        mechanism, or inputs outside the workspace). Meaningful for inputs whose solve is empty."""
        values = self.mechanism.check_inputs(inputs)
        mech = self.mechanism
        limited = tuple(j.name for j in mech.joints if j.range is not None and not j.actuated)
        if limited:
            free = compile(mech.without_ranges(limited), **self.strategy_keywords())
            found = free._solve(values, None, None)
            if found.solutions:
                return EmptyReason(EMPTY_OUTSIDE_RANGES, limited, len(found.solutions))
        # more closure equations than unknowns: a redundantly actuated mechanism
        kind = EMPTY_INCONSISTENT if len(mech.loop_unknowns) < 3 * len(mech.loop_geometry) else EMPTY_OUTSIDE_WORKSPACE
        return EmptyReason(kind, limited, 0)

    def _solve(self, values, progress, trace) -> SolveReport:
        """The report of checked ``values`` (without :meth:`explain_empty`), one input on its own: with
        a ``trace``, with ``jobs`` > 1 (the charts of one input on Dask workers), and for an input
        that reached a cap in a chunk (:meth:`_solve_chunk`), where the cap is then reported."""
        if trace is not None and self.platform is not None:
            raise ValueError("trace: only available with a loop formulation (paper, transversal, halves), "
                             "got the platform formulation")
        fallback = None
        if self.platform is not None:
            found = self._search_platform(values, progress)
            if isinstance(found, str):
                fallback = found
            else:
                report, poses = found
                # no refined searches: a platform root that finalize cannot prove goes to the loop equations
                solutions, refined, t_final = self._trust(values, report, self.strategy.tol, refine=False)
                fallback = disagreement(solutions, poses)
                if fallback is None:
                    return self._report(values, report, solutions, refined, t_final, None, None)
        report, limit, tol = self._search_loops(values, self.strategy.tol, progress, trace)
        interrupted = limit is not None and limit.interrupted
        solutions, refined, t_final = self._trust(values, report, tol, refine=not interrupted)
        return self._report(values, report, solutions, refined, t_final, fallback, limit)

    def _trust(self, values, report, tol, refine: bool):
        """(solutions, stats of refined searches, seconds): :func:`spherekin.trust.solutions.finalize` on the
        clusters of ``report``; with ``refine``, unresolved clusters are searched again, finer."""
        return self._trust_many([values], [report], tol, refine)[0]

    def _refiner(self, values, refined: list):
        """The ``refine`` callable of :func:`~spherekin.trust.solutions.finalize` at ``values``: a new search
        of a cluster's hull (which holds every root of its boxes) at a finer tol; its stats go to ``refined``."""
        s = self.strategy

        def again(lo, hi, t):
            finer = t * REFINE_FACTOR
            if finer < REFINE_MIN_TOL:
                return None
            box = {n: (float(a) - RANGE_TOL, float(b) + RANGE_TOL) for n, a, b in zip(self.names, lo, hi)}
            try:
                sub = self.loops.search(values, box, tol=finer, jobs=1, max_boxes=min(s.max_boxes, REFINE_MAX_BOXES))
            except SolverLimitError:
                return None
            refined.append(sub.stats)
            return sub.clusters, finer

        return again

    def _trust_many(self, values: list, reports: list, tols, refine) -> list:
        """(solutions, stats of refined searches, seconds) of every input: the trust layer over all the
        points of the chunk at once (:func:`spherekin.trust.solutions.finalize_many`, per tolerance).
        ``tols``: one tol for all or one per input; ``refine``: one flag for all or one per input
        (unresolved clusters searched again, finer). The seconds are each input's share of the chunk's."""
        tols = tols if isinstance(tols, list) else [tols] * len(values)
        refine = refine if isinstance(refine, list) else [refine] * len(values)
        refined: list[list[SolverStats]] = [[] for _ in values]
        solutions: list = [None] * len(values)
        t0 = time.perf_counter()
        groups: dict = {}
        for k, (tol, report) in enumerate(zip(tols, reports)):   # a covering run has a tolerance of its own
            groups.setdefault((tol, tuple(report.unknowns)), []).append(k)
        for (tol, unknowns), members in groups.items():
            found = finalize_many(self.mechanism, np.array([values[k] for k in members], dtype=float), unknowns,
                                  [reports[k].clusters for k in members], tol,
                                  refine=lambda i: self._refiner(values[members[i]], refined[members[i]])
                                  if refine[members[i]] else None)
            for k, sols in zip(members, found):
                solutions[k] = sols
        share = (time.perf_counter() - t0) / max(len(values), 1)
        return [(solutions[k], refined[k], share) for k in range(len(values))]

    def _report(self, values, report: SearchReport, solutions, refined, t_final, fallback,
                limit: SearchLimit | None) -> SolveReport:
        proven, exact = count_summary(solutions)
        system = Platform.name if report.settings.formulation == Platform.name else Loops.name
        settings = dataclasses.replace(report.settings, mechanism=self.mechanism.name,
                                       actuated=tuple(self.mechanism.actuated), inputs=tuple(float(v) for v in values),
                                       fallback=fallback, limit=limit, refined_searches=len(refined),
                                       system=system, declined=self.declined)
        if limit is not None:
            exact = False
        stats = report.stats
        for extra in refined:   # the refined searches' boxes count; their time is in time_finalize
            stats = stats + dataclasses.replace(extra, time_total=0.0, time_setup=0.0, time_restrict=0.0,
                                                time_prune=0.0, time_isolate=0.0)
        stats = dataclasses.replace(stats, time_finalize=t_final, time_total=report.stats.time_total + t_final)
        inputs = dict(zip(self.mechanism.actuated, (float(v) for v in values)))
        named = tuple(dataclasses.replace(s, unknowns=tuple(report.unknowns), actuated=inputs) for s in solutions)
        return SolveReport(report.unknowns, named, report.boxes, stats, settings, proven, exact,
                           mechanism=self.mechanism)

    # ------------------------------------------------------------------ many inputs

    def solve_many(self, inputs, *, progress: Callable[[int, int], None] | None = None,
                   chunk: int = DEFAULT_CHUNK) -> tuple[SolveReport, ...]:
        """One report per row of ``inputs`` (shape (K, number of actuated joints), radians), in order:
        for each row the report :meth:`solve` gives for it (``solve(x)`` is this on a chunk of one).

        The rows are solved ``chunk`` at a time, each chunk as one array program
        (:meth:`_solve_chunk`): the boxes of all its inputs in one box loop, with the input as a
        column, then the trust layer over all their points. Every row is checked before the first
        solve (one error naming the row); ``progress(done, total)`` is called after each chunk. An
        empty report's ``empty_reason`` is None here (it costs another solve: call
        :meth:`explain_empty` for the rows that need it).
        """
        rows = self._checked_rows("inputs", inputs)
        if isinstance(chunk, bool) or not isinstance(chunk, (int, np.integer)) or chunk < 1:
            raise ValueError(f"chunk: expected a positive number of inputs, got {chunk!r}")
        out: list[SolveReport] = []
        for first in range(0, len(rows), int(chunk)):
            part = rows[first:first + int(chunk)]
            values = [tuple(float(v) for v in row) for row in part]          # checked above
            if self.strategy.jobs == 1:
                out += self._solve_chunk(values, None)
            else:                               # jobs > 1: each input's charts on Dask workers
                out += [self._solve(v, None, None) for v in values]
            if progress is not None:
                progress(len(out), len(rows))
        return tuple(out)

    def _solve_chunk(self, values: list, progress) -> list[SolveReport]:
        """The reports of checked input rows ``values`` (K of them), as one array program per stage.

        1. platform system: the chart sets of every input stacked, one box loop over all their
           boxes (:func:`spherekin.search.boxloop.search_platform_many`), then the trust layer over
           all the points (:meth:`_trust_many`), each input's answer checked against its roots
           (:func:`disagreement`);
        2. the inputs the platform search does not answer (or every input, for the loop system):
           the loop equations of all of them in one box loop
           (:meth:`spherekin.systems.loops.CompiledLoops.search_many`), then the trust layer.

        An input that reaches a cap in a chunk is solved on its own (:meth:`_solve`), where the cap
        is handled and reported as for a single solve; so is every input after Ctrl-C in a chunk of
        one (its partial result is reported). ``progress(counts)``: the box loops' counters.
        """
        s = self.strategy
        out: list[SolveReport | None] = [None] * len(values)
        fallback: list[str | None] = [None] * len(values)
        todo = list(range(len(values))) if self.platform is None else []
        if self.platform is not None:
            t0 = time.perf_counter()
            charts = [self.platform.charts(v) for v in values]
            t_setup = (time.perf_counter() - t0) / len(values)
            try:
                found = search_platform_many(stack_chart_sets(charts), len(values), self.platform.pruner, s.tol,
                                             s.max_boxes, s.max_depth, progress)
            except SearchInterrupted:
                raise KeyboardInterrupt from None        # searches of milliseconds: nothing worth keeping
            pending = []
            for k, got in enumerate(self._platform_found_many(list(found), values, t_setup, charts[0].n_charts)):
                if got is None:
                    out[k] = self._solve(values[k], None, None)      # a cap: on its own, where it is reported
                elif isinstance(got, str):
                    fallback[k] = got
                    todo.append(k)
                else:
                    pending.append((k, got))
            trusted = self._trust_many([values[k] for k, _ in pending], [got[0] for _, got in pending],
                                       s.tol, refine=False)
            checks = disagreements([solutions for solutions, _, _ in trusted], [got[1] for _, got in pending])
            for (k, (report, poses)), (solutions, refined, t_final), check in zip(pending, trusted, checks):
                fallback[k] = check
                if fallback[k] is None:
                    out[k] = self._report(values[k], report, solutions, refined, t_final, None, None)
                else:
                    todo.append(k)
        if todo:
            todo.sort()
            searched = self._search_loops_many([values[k] for k in todo], progress)
            runs = [self._search_loops(values[k], s.tol, progress, None) if run is None else run
                    for k, run in zip(todo, searched)]            # None: a cap, handled as for one input
            trusted = self._trust_many([values[k] for k in todo], [r for r, _, _ in runs], [t for _, _, t in runs],
                                       refine=[limit is None or not limit.interrupted for _, limit, _ in runs])
            for k, (report, limit, _), (solutions, refined, t_final) in zip(todo, runs, trusted):
                out[k] = self._report(values[k], report, solutions, refined, t_final, fallback[k], limit)
        return out

    def _search_loops_many(self, values: list, progress) -> list:
        """(report, limit, tol) of the loop equations' search of each of ``values``, in one box loop;
        None where the input reached a cap (solved on its own then). Ctrl-C in a chunk of one hands
        over what was found (:meth:`_interrupted`); in a larger chunk it stops the chunk."""
        s = self.strategy
        try:
            found = self.loops.search_many(np.array(values), self.ranges, tol=s.tol, max_boxes=s.max_boxes,
                                           progress=progress)
        except SearchInterrupted as exc:
            if len(values) > 1:
                raise KeyboardInterrupt(*exc.args) from None
            return [self._interrupted(exc, s.tol)]
        return [None if report is None else (report, None, s.tol) for report in found]

    def _checked_rows(self, key: str, inputs) -> np.ndarray:
        """``inputs`` as an array (K, actuated joints), every row checked (one error naming the row)."""
        rows = np.asarray(inputs, dtype=float) if not isinstance(inputs, np.ndarray) else inputs
        if rows.ndim != 2 or rows.shape[1] != len(self.mechanism.actuated):
            raise ValueError(f"{key}: expected an array of shape (K, {len(self.mechanism.actuated)}) "
                             f"(one column per actuated joint: {', '.join(self.mechanism.actuated)}), "
                             f"got shape {rows.shape}")
        return self.mechanism.check_input_rows(rows, f"{key} row {{k}}")

    # ------------------------------------------------------------------ a path

    def track(self, path, *, start):
        """Follow one assembly mode along ``path`` (K inputs, shape (K, number of actuated joints),
        radians), every step proven: a :class:`~spherekin.trust.continuation.Track` with the pose at
        each row reached, and where it stopped: where the mode ends at a parallel singularity, or
        where a joint leaves its range. Any mechanism: on the platform's orientation
        (:mod:`spherekin.trust.continuation`) where it applies (three R-R-R legs with the base joints
        actuated: :func:`~spherekin.trust.continuation.not_tracked`), else on the loop equations
        (:mod:`spherekin.trust.loop_continuation`).

        ``start``: a :class:`~spherekin.results.Solution` of the solve at path[0] (e.g.
        ``report.solutions[4]``, the solution numbered 5 in printed tables, JSON and CSV), which
        must be certified; or an int K: ``report.solutions[K]`` (0-based, Python's indexing) of
        the full solve at path[0]; or, where the platform tracker applies, the platform
        rotation R (3x3) of an assembly at path[0].
        """
        from .trust.continuation import not_tracked, track
        from .trust.loop_continuation import track_loops

        rows = self._checked_rows("path", path)
        if not len(rows):
            raise ValueError("path: expected at least one row of inputs, got none")
        start = self._assembly_at(rows[0], start, "the first input of the path")
        if not_tracked(self.mechanism) is not None:
            return track_loops(self.mechanism, rows, start)
        return track(self.mechanism, rows, start)

    def free_box(self, home, *, start, inputs=None, **caps):
        """The largest box of inputs home +- r proven to hold the assembly ``start`` without a parallel
        singularity (:func:`spherekin.trust.free_box.free_box`; the inputs not in ``inputs`` fixed at
        home, None: all vary): a :class:`~spherekin.trust.free_box.FreeBox`. ``home``: one input per
        actuated joint (radians); ``start`` as :meth:`track`'s (a certified ``Solution`` at home, its
        index, or a platform rotation R); ``caps``: ``max_radius``, ``min_cell``, ``max_cells``."""
        from .trust.free_box import checked_home, free_box

        home = checked_home(self.mechanism, home)
        return free_box(self.mechanism, home, self._assembly_at(home, start, "home"), inputs, **caps)

    def _assembly_at(self, x0, start, where: str):
        """The assembly ``start`` names at the input x0 (``where`` says which, for messages): the
        platform rotation R where the platform tracker applies, else the passive angles by name
        (``start``: a certified Solution at x0, its index in the solve at x0, or a rotation R)."""
        from .results import Solution
        from .trust.continuation import not_tracked

        why = not_tracked(self.mechanism)          # None: the platform tracker follows it
        if isinstance(start, (int, np.integer)) and not isinstance(start, bool):
            report = self.solve(x0)
            n = len(report.solutions)
            if not 0 <= int(start) < n:
                raise ValueError(f"start: expected a solution index 0..{n - 1} of the solve at {where} "
                                 f"({n} solution(s)), got {int(start)}")
            start = report.solutions[int(start)]
        if isinstance(start, Solution):
            given = tuple(start.actuated.values())
            if given and np.abs(np.array(given, dtype=float) - x0).max() > RANGE_TOL:
                raise ValueError(f"start: expected a solution of the solve at {where} "
                                 f"{x0.tolist()}, got one at {list(given)}")
            if start.status != "certified" or (why is None and start.platform_rotation is None):
                raise ValueError(f"start: the solution at {where} is {start.status}, not certified; "
                                 "a track starts from a proven, isolated assembly")
            return start.passive_angles if why is not None else start.platform_rotation
        if why is not None:
            raise ValueError(f"start: a start rotation needs the platform tracker, which does not apply ({why}); "
                             f"start from a solution of the solve at {where} (--start-solution K; in Python "
                             "a Solution or its index)")
        from .mechanism.checks import check_rotation

        return check_rotation("start", start)

    # ------------------------------------------------------------------ stages

    @property
    def _loop_formulation(self) -> str:
        return self.loops.formulation

    def _search_platform(self, values, progress):
        """(report, poses of the roots in range) from the platform search, or why the loop equations
        must answer instead (a string)."""
        s = self.strategy
        t0 = time.perf_counter()
        charts = self.platform.charts(values)
        t_setup = time.perf_counter() - t0
        try:
            found = search_platform(charts, self.platform.pruner, s.tol, s.max_boxes, s.max_depth, progress)
        except SearchInterrupted:
            raise KeyboardInterrupt from None            # a search of milliseconds: nothing worth keeping
        except SolverLimitError as exc:
            return f"the platform search reached a cap ({exc})"
        return self._platform_found(found, values, t_setup, charts.n_charts)

    def _platform_found(self, found, values, t_setup: float, n_charts: int):
        """(report, poses of the roots in range) from what the platform search ``found`` at ``values``,
        or why the loop equations must answer instead (a string)."""
        return self._platform_found_many([found], [values], t_setup, n_charts)[0]

    def _platform_found_many(self, found: list, values: list, t_setup: float, n_charts: int) -> list:
        """:meth:`_platform_found` of every input of a chunk: the poses, joint readings and range tests
        of all their roots as array operations, then each input's report (None where ``found`` is)."""
        s = self.strategy
        owner = np.array([k for k, f in enumerate(found) if f is not None for _ in f.points], dtype=int)
        points = [p for f in found if f is not None for p in f.points]
        poses, readings, inside = np.empty((0, 3, 3)), np.empty((0, len(self.names))), np.empty(0, dtype=bool)
        if points:
            poses = self.platform.poses(np.array([c for c, _ in points]), np.array([x for _, x in points]))
            readings = self.platform.readings(np.array(values, dtype=float)[owner], poses)
            inside = np.ones(len(points), dtype=bool)
            for j, rng in enumerate(self.ranges.values()):
                inside &= in_range_many(readings[:, j], rng, s.tol + RANGE_TOL)
        settings = Settings(formulation="platform", pruner=s.pruner, lp_backend=s.lp_backend,
                            parameterization="quaternion", tol=s.tol, isolate=True, jobs=1, charts=n_charts)
        answered = np.array([f is not None and not f.unresolved for f in found], dtype=bool)
        kept = np.flatnonzero(first_of_duplicates(poses, owner, len(found)) & inside & answered[owner])
        clusters = clusters_in_range_many(readings[kept], readings[kept], owner[kept], len(found), self.ranges, s.tol)
        kept_of = np.split(kept, np.searchsorted(owner[kept], np.arange(1, len(found))))
        out: list = []
        for k, f in enumerate(found):
            if f is None:
                out.append(None)
            elif f.unresolved:
                out.append(f"the platform search left {f.unresolved} box(es) it could not isolate (a parallel "
                           "singularity or a double root nearby): solved with the loop equations")
            else:
                stats = dataclasses.replace(f.stats, time_setup=t_setup, time_total=f.stats.time_total + t_setup)
                out.append((SearchReport(self.names, tuple(clusters[k]), (), stats, settings), list(poses[kept_of[k]])))
        return out

    def _interrupted(self, exc: SearchInterrupted, tol: float) -> tuple:
        """(report, limit, tol) of a loop search stopped by Ctrl-C (or SIGTERM): what was accepted so far
        is finalized and reported, marked as interrupted (the count is then never exact), instead of
        being lost."""
        s = self.strategy
        settings = Settings(formulation=self._loop_formulation, pruner=s.pruner, lp_backend=s.lp_backend,
                            parameterization=s.parameterization, tol=tol, isolate=s.isolate, jobs=s.jobs, charts=0)
        return partial_report(exc, self.ranges, settings), SearchLimit(str(exc), tol, tol, interrupted=True), tol

    def _search_loops(self, values, tol, progress, trace):
        """(report, limit, tol): the loop equations' search; a capped one is re-run as a covering."""
        s = self.strategy

        def run(t):
            return self.loops.search(values, self.ranges, tol=t, jobs=s.jobs, max_boxes=s.max_boxes,
                                     progress=progress, trace=trace)

        try:
            return run(tol), None, tol
        except SearchInterrupted as exc:
            return self._interrupted(exc, tol)
        except SolverLimitError as exc:
            if s.on_cap == ON_CAP_RAISE:
                raise
            # A continuum of solutions (or a cap too small for this tol): cover the solution set with
            # boxes of CONTINUUM_TOL instead, and report what the cap stopped (the paper, Section 4: the
            # algorithm then returns a discretization of the solution set).
            covering = max(tol, CONTINUUM_TOL)
            limit = SearchLimit(str(exc), tol, covering)
            warnings.warn(CappedSearchWarning(
                f"the search at tol {tol:g} reached max_boxes={s.max_boxes} (a continuum of solutions, or a cap "
                f"too small for this tol): the solution set is covered at tol {covering:g} instead and the count "
                f"is not proven (report.settings.limit; on_cap='raise' to get the error)"), stacklevel=2)
            try:
                report = run(covering)
            except SolverLimitError as exc2:
                limit = dataclasses.replace(limit, covering_error=str(exc2))
                settings = Settings(formulation=self._loop_formulation, pruner=s.pruner, lp_backend=s.lp_backend,
                                    parameterization=s.parameterization, tol=covering, isolate=s.isolate,
                                    jobs=s.jobs, charts=0)
                report = partial_report(exc2, self.ranges, settings)
            return report, limit, covering


def first_of_duplicates(poses: np.ndarray, owner: np.ndarray, n_inputs: int, within: float = DUPLICATE_POSE) -> np.ndarray:
    """(N,) bool: which of the roots ``poses`` (N, 3, 3; ``owner`` (N,) the input of each, each
    input's roots in the order found) to keep: a root is dropped when a root kept before it, of the
    same input, is ``within`` it (largest entry; default DUPLICATE_POSE: the same root found on an
    overlapping chart). One pass per place in an input's list, each over every input of the chunk."""
    keep = np.zeros(len(poses), dtype=bool)
    if not len(poses):
        return keep
    flat, pos = pad_by_owner(np.asarray(poses).reshape(len(poses), 9), owner, n_inputs)   # NaN: no root
    near = np.abs(flat[:, :, None] - flat[:, None]).max(axis=3) <= within                  # (K, P, P)
    kept = np.zeros(flat.shape[:2], dtype=bool)
    for i in range(flat.shape[1]):
        kept[:, i] = ~np.isnan(flat[:, i, 0]) & ~np.any(near[:, i, :i] & kept[:, :i], axis=1)
    return kept[owner, pos]


def disagreement(solutions, poses) -> str | None:
    """Why the finalized ``solutions`` of a platform search are not its roots ``poses`` (None when
    they are): every entry proven, one entry per distinct root, each matching one (POSE_MATCH).

    The platform search proves where the roots are; the trust layer proves each assembly in the
    loop equations. The two must agree, or the input goes to the loop equations (in the manner of
    scipy's ``_check_result``: the fast path's answer is checked, not trusted).
    """
    return disagreements([solutions], [poses])[0]


def disagreements(solutions: list, poses: list) -> list[str | None]:
    """:func:`disagreement` of each input of a chunk (``solutions[k]``, ``poses[k]`` of input k), the
    pose comparisons of every input as array operations (pairs within an input, every input at once)."""
    out: list[str | None] = [None] * len(solutions)
    roots = [np.asarray(p, dtype=float).reshape(-1, 3, 3) for p in poses]
    owner = np.repeat(np.arange(len(roots)), [len(r) for r in roots])
    flat = np.concatenate(roots) if roots else np.empty((0, 3, 3))
    distinct = first_of_duplicates(flat, owner, len(roots), POSE_MATCH)
    n_distinct = np.bincount(owner[distinct], minlength=len(roots))
    got = [[s.platform_rotation for s in sols] for sols in solutions]
    g_owner = np.repeat(np.arange(len(got)), [len(g) for g in got])
    g_flat = np.array([np.full((3, 3), np.nan) if g is None else g for gs in got for g in gs]).reshape(-1, 9)
    padded, _ = pad_by_owner(g_flat, g_owner, len(got))                    # (K, G, 9); NaN: none
    d_flat = flat.reshape(-1, 9)[distinct]
    matched = np.any(np.all(np.abs(padded[owner[distinct]] - d_flat[:, None]) <= POSE_MATCH, axis=2), axis=1)
    unmatched = np.bincount(owner[distinct], weights=~matched, minlength=len(roots))
    for k, sols in enumerate(solutions):
        bad = [s.status for s in sols if not is_proven(s)]
        if bad:
            out[k] = f"the trust layer could not prove {len(bad)} root(s) of the platform search ({', '.join(bad)})"
        elif len(got[k]) != n_distinct[k] or unmatched[k]:
            out[k] = (f"the platform search found {n_distinct[k]} assemblies and the trust layer {len(got[k])} "
                      "different ones")
    return out


def compile(
    mechanism,
    *,
    formulation: str = DEFAULT_FORMULATION,
    pruner: str = DEFAULT_PRUNER,
    lp_backend: str | None = None,
    parameterization: str = DEFAULT_PARAMETERIZATION,
    tol: float = DEFAULT_TOL,
    isolate: bool = True,
    jobs: int = 1,
    max_boxes: int = DEFAULT_MAX_BOXES,
    max_depth: int | None = None,
    system: str = DEFAULT_SYSTEM,
    on_cap: str = ON_CAP_COVER,
) -> Problem:
    """Compile ``mechanism`` (a :class:`spherekin.mechanism.SphericalMechanism`, or the path of a
    mechanism file) for a strategy (the keywords of :func:`solve`, same defaults); every name and
    number is checked here, before any input is solved. Returns a :class:`Problem`."""
    mechanism = as_mechanism(mechanism)
    if not mechanism.passive:                  # a mechanism fact, before any system is asked (issue 42 item 12)
        raise ValueError(f"joints: every joint ({', '.join(mechanism.actuated)}) is actuated, so the direct "
                         "kinematics has no unknown to solve for; leave the joints the mechanism does not drive "
                         "passive (actuated = false), or evaluate every reading with forward()")
    if formulation not in formulation_choices():
        raise ValueError(f"formulation: expected one of {list(formulation_choices())}, got {formulation!r}")
    if system not in system_choices():
        raise ValueError(f"system: expected one of {list(system_choices())}, got {system!r}")
    if on_cap not in ON_CAP_CHOICES:
        raise ValueError(f"on_cap: expected one of {list(ON_CAP_CHOICES)}, got {on_cap!r}")
    check_strategy(LOOP_FORMULATION if formulation in ("auto", "platform") else formulation, pruner, lp_backend,
                   parameterization, tol, jobs)
    strategy = Strategy(formulation, pruner, lp_backend, parameterization, float(tol), bool(isolate), jobs,
                        max_boxes, max_depth, on_cap)
    chosen, declined = resolve_system(mechanism, strategy, system)
    resolved = formulation if formulation in FORMULATIONS else (
        LOOP_FORMULATION if chosen is Loops else chosen.name)
    strategy = dataclasses.replace(strategy, formulation=resolved)
    names = mechanism.loop_unknowns
    ranges = {n: mechanism.ranges[n] for n in names}
    platform = Platform.compile(mechanism, strategy) if chosen is Platform else None
    return Problem(mechanism, strategy, tuple(names), ranges, chosen.name, platform,
                   Loops.compile(mechanism, strategy), declined)


def resolve_system(mechanism, strategy: Strategy, system: str = DEFAULT_SYSTEM):
    """(the system class that solves ``mechanism`` with ``strategy``, the (name, reason) of the
    faster systems "auto" passed over). Formulation "platform" is the platform system, a loop
    formulation the loop system; "auto" with system "auto" is the first system that accepts
    (:func:`spherekin.systems.choose`). ValueError naming the keyword when the system asked for
    does not accept the mechanism or the strategy, or when the two keywords disagree."""
    formulation = strategy.formulation
    asked, key = system, f"system {system!r}"
    if formulation != AUTO:
        by_formulation = Platform.name if formulation == Platform.name else Loops.name
        if system not in (AUTO, by_formulation):
            raise ValueError(f"system: expected 'auto' or {by_formulation!r} with formulation {formulation!r}, "
                             f"got {system!r}")
        asked, key = by_formulation, f"formulation {formulation!r}"
    if asked == AUTO:
        return choose(mechanism, strategy)
    cls = SYSTEMS.lookup(asked)
    probe = dataclasses.replace(strategy, formulation=cls.name) if formulation == AUTO else strategy
    why = cls.accepts(mechanism, probe)
    if why is not None:
        raise ValueError(f"{key}: {why}; use 'auto' or a loop formulation")
    return cls, ()


def solve(
    mechanism,
    inputs,
    *,
    formulation: str = DEFAULT_FORMULATION,
    pruner: str = DEFAULT_PRUNER,
    lp_backend: str | None = None,
    parameterization: str = DEFAULT_PARAMETERIZATION,
    tol: float = DEFAULT_TOL,
    isolate: bool = True,
    jobs: int = 1,
    max_boxes: int = DEFAULT_MAX_BOXES,
    max_depth: int | None = None,
    progress: Callable[[dict], None] | None = None,
    trace: Callable[[dict], None] | None = None,
    system: str = DEFAULT_SYSTEM,
    on_cap: str = ON_CAP_COVER,
) -> SolveReport:
    """Direct kinematics: every assembly of ``mechanism`` at actuator ``inputs`` inside its joint ranges.

    ``mechanism``: a :class:`spherekin.mechanism.SphericalMechanism`, or the path (str or
    ``os.PathLike``) of a mechanism file (docs/mechanism-format.md); ``inputs``: one angle (radians)
    per actuated joint. Returns a :class:`SolveReport` whose solutions are polished, deduplicated
    and classified (:func:`spherekin.trust.solutions.finalize`): passive angles, platform rotation,
    residual, status and its evidence (``report.frame()``: a DataFrame of them; an empty report
    says why in ``report.empty_reason``). The strategy, by name:

    * ``system``: one of :func:`system_choices` ("auto": the first system of
      :data:`spherekin.systems.SYSTEMS` that accepts the mechanism and strategy: "platform" where it
      applies, else "loops"; ``report.settings`` says which solved it and why faster ones declined);
    * ``formulation``: one of :func:`formulation_choices` ("auto": the platform formulation where it
      applies, else "halves"; "platform" is the platform system, the others the loop system's);
    * ``pruner`` ("pp", "lp", "hybrid") and ``lp_backend`` (None: the pruner's default);
    * ``parameterization`` of the loop equations ("tan-half", "sin-cos");
    * ``tol``: the size (radians) of the boxes the search stops at; ``isolate``: Krawczyk isolation;
    * ``jobs``: worker processes over the charts of the loop equations;
    * caps ``max_boxes`` and ``max_depth`` (see :func:`spherekin.search.boxloop.solve_system`), and
      ``on_cap``, what a search that reaches ``max_boxes`` does (:data:`ON_CAP_CHOICES`): "cover" (the
      default) covers the solution set at :data:`CONTINUUM_TOL` instead (a continuum, or a cap too small
      for ``tol``), warns (:class:`CappedSearchWarning`) and reports it: the count is not proven,
      ``settings.tol`` is the covering's tolerance and ``settings.limit`` holds the one asked for;
      "raise" raises the search's :class:`~spherekin.search.boxloop.SolverLimitError` instead.

    The paper-faithful configuration is ``formulation="paper", pruner="lp", lp_backend="clarabel",
    isolate=False``. For many inputs, :func:`compile` once and call :meth:`Problem.solve_many`.
    ``progress`` is called with the search's counters; ``trace`` (loop formulations only) records
    every batch of boxes.
    """
    if trace is not None and formulation == "auto" and system in (AUTO, Loops.name):
        formulation = LOOP_FORMULATION                   # a trace records the boxes of the loop equations
    problem = compile(mechanism, formulation=formulation, pruner=pruner, lp_backend=lp_backend,
                      parameterization=parameterization, tol=tol, isolate=isolate, jobs=jobs, max_boxes=max_boxes,
                      max_depth=max_depth, system=system, on_cap=on_cap)
    return problem.solve(inputs, progress=progress, trace=trace)


def inverse_kinematics(mechanism, rotation, *, only_in_range: bool = False, **strategy) -> tuple:
    """Every input set (with every joint reading) that places the output link of ``mechanism`` at
    ``rotation`` (3x3): a tuple of :class:`~spherekin.mechanism.IKSolution`.

    Legs from the ground to the output (a 3-RRR, a five-bar written as legs or as a graph): the
    closed form of each leg (:meth:`~spherekin.mechanism.SphericalMechanism.inverse_kinematics`:
    Paden-Kahan, every working mode). Any other graph: the same loop machinery as the direct
    kinematics with the knowns swapped (:meth:`~spherekin.mechanism.SphericalMechanism.held_output`:
    the output held by a virtual actuated chain, the actuated joints unknown), solved with the
    joint ranges lifted and ``strategy`` (the keywords of :func:`compile`); each solution's
    ``status`` says what is proven of it, ``in_range`` whether every reading is in its range, and
    ``only_in_range`` drops the others. Angles in radians.
    """
    from .core.angles import in_range, into_range
    from .mechanism import IKSolution

    mech = as_mechanism(mechanism)
    if mech.legs:
        return mech.inverse_kinematics(rotation, only_in_range=only_in_range)
    held, inputs = mech.held_output(rotation)
    report = compile(held.without_ranges(), **strategy).solve(inputs)
    out = []
    for sol in report.solutions:
        readings = sol.joint_angles
        angles, ok = {}, True
        for j in mech.joints:
            r = readings[j.name]
            inside = in_range(r, j.range)
            ok = ok and inside
            angles[j.name] = into_range(r, j.range) if inside else r
        if only_in_range and not ok:
            continue
        out.append(IKSolution(joint_angles=angles, inputs=tuple(angles[n] for n in mech.actuated),
                              working_mode=(), in_range=ok, status=str(sol.status)))
    return tuple(out)


#: Default cell width (radians) of :func:`singular`: the issue's default; ~1e3 cells for a curve of length 10.
SINGULAR_TOL = 1e-2
#: Widest cell accepted (radians). Reason: the certificate of a cell is a Krawczyk test on the hull of the
#: cover's boxes over it (or a small box around Newton's root in it); measured on general_3rrr at beta3 = 0.5,
#: cells of 0.1 rad are proven for about two thirds of the cover; wider cells meet more branches and folds
#: of the curve per cell, where the slice has several roots or none, so they would mostly be ``unresolved``.
SINGULAR_MAX_TOL = 0.5
#: The finest boxes the cover searches (the smallest of REFINE_FRACTIONS and CUSP_REFINE_FRACTIONS times T,
#: T/32) must be at least this many times CELL_SLACK (:data:`spherekin.trust.singular.CELL_SLACK`, 1e-9 rad: the
#: allowance for the tan-half maps' rounding with which a box meets a cell); narrower, a box meets cells by its
#: slack alone and the refinement rounds cannot shrink the cover onto the curve. So T >= 4 x 1e-9 x 32 = 1.28e-7
#: rad (:func:`singular_min_tol`; a full turn is then 4.9e7 cells per axis, indices far inside int64).
SLACK_MARGIN = 4
#: Default box cap of the singular-set cover (boxes of the augmented system processed, all rounds). Reason:
#: general_3rrr over [-pi, pi]^2 with the traced cover processes ~1.5e6 boxes at T = 0.01 and ~3e6 at 1e-3
#: (measured; 5.7e6 at 0.01 before the tracing); the cap only stops a runaway (a continuum of singular configurations over
#: a 2-D region of the plane), whose unprocessed boxes are reported ``unresolved``.
SINGULAR_MAX_BOXES = 10_000_000
#: The cover accepts a box of the augmented system when every side is at most this fraction of the cell width
#: T (radians for the plane inputs, chart units for the orientation). Reason: a box then meets at most two
#: cells per axis, so the covered cells stay close to the curve (a box of side T meets up to 3).
COVER_FRACTION = 0.5
#: The cusp system's boxes are accepted below this fraction of T: small enough that a cluster of them is
#: one root whose hull Newton and the Krawczyk test handle (a cusp is a regular root of (F, D, C_r)).
CUSP_FRACTION = 0.25
#: The fixed vectors r of the tangency C_r = grad D . (adj(G) r) (:meth:`PlatformPlane.cusp_charts`): seeded, so that
#: the spurious factor l . r = 0 meets the curve only at isolated points; the second rules those points out.
#: Cusp candidates left without a proof are searched again at these fractions of T (as REFINE_FRACTIONS).
CUSP_REFINE_FRACTIONS = (0.03125,)
CUSP_VECTORS = ((0.5390, -0.7270, 0.4253), (-0.3120, 0.2240, 0.9233))

#: The pieces of the accepted boxes cut by the unresolved cells are searched again with boxes of these fractions
#: of T, one round each (the cells still unresolved after a round go to the next). Reason: a piece whose cell
#: the curve misses by less than a box width is not excluded by one pruning (the hull of a box's control
#: points overestimates by ~its width squared); measured on general_3rrr at T = 0.1 over [-0.5, 0.5]^2, one
#: round of T/8 cut the cells the reference curve misses from 15 to 6 (T/4: 14) and proved 4 more cells.
REFINE_FRACTIONS = (0.125, 0.03125)


def singular_min_tol() -> float:
    """The narrowest cell width T (radians) a singular set accepts: SLACK_MARGIN x CELL_SLACK over the finest
    fraction of T the cover searches (trust.singular is imported here, not at the module's top: 0.6 s)."""
    from .trust.singular import CELL_SLACK

    return SLACK_MARGIN * CELL_SLACK / min(REFINE_FRACTIONS + CUSP_REFINE_FRACTIONS)


def check_singular_tol(value, name: str = "tol") -> float:
    """The cell width T (radians) of a certified singular set, checked before any work: a number with
    :func:`singular_min_tol` <= T <= SINGULAR_MAX_TOL. ValueError naming ``name`` (the keyword or option as
    typed). The plane's coordinates are within a full turn of 0 (refused beyond, as every input is), where a
    cell of T >= singular_min_tol() is more than 1e5 float spacings wide: its edges are distinct floats."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or not 0 < value <= SINGULAR_MAX_TOL:
        raise ValueError(f"{name}: expected 0 < T <= {SINGULAR_MAX_TOL:g} (radians), got {value!r}")
    if value < singular_min_tol():
        raise ValueError(f"{name}: T = {value:g} rad is below {singular_min_tol():.3g}, the narrowest cell the cover "
                         "can resolve in float64 (its finest boxes, T/32, must stay wider than the 1e-9 rad allowance "
                         "for rounding with which a box meets a cell); locate a singular input more finely with "
                         "solve or the branch map")
    return float(value)


def _plane_axis(mech, key: str, spec) -> tuple:
    """(name, lo, hi) of a plane axis given as (name, lo, hi) (radians): ValueError naming ``key``."""
    try:
        name, lo, hi = spec
        lo, hi = float(lo), float(hi)
    except (TypeError, ValueError):
        raise ValueError(f"{key}: expected (name, lo, hi) with an actuated joint and radians, got {spec!r}") from None
    if name not in mech.actuated:
        raise ValueError(f"{key}: expected an actuated joint ({', '.join(mech.actuated)}), got {name!r}")
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
        raise ValueError(f"{key}: expected finite lo < hi (radians), got lo = {lo:.6g}, hi = {hi:.6g}")
    check_turn(f"{key} ({name}) lo", lo)       # what solve refuses as an input, a plane refuses too
    check_turn(f"{key} ({name}) hi", hi)
    if hi - lo > 2 * np.pi + 1e-12:
        raise ValueError(f"{key}: expected hi - lo <= 2 pi (one turn), got {hi - lo:.6g}")
    rng = mech.ranges[name]
    if rng is not None and not (in_range(lo, rng) and into_range(lo, rng) + (hi - lo) <= rng[1] + RANGE_TOL):
        raise ValueError(f"{key}: the window [{lo:.6g}, {hi:.6g}] of {name} leaves its joint range "
                         f"[{rng[0]:.6g}, {rng[1]:.6g}]; choose a window inside it (inputs outside the range are "
                         "never solved)")
    return (str(name), lo, hi)


@dataclass(frozen=True)
class _PlaneRun:
    """What one cover of a plane system hands to :func:`singular`: ``cells`` ((i, j) -> CellStatus), the
    cusp candidates (trust.singular.CuspStatus), and the work: boxes processed (``used``), box-loop seconds,
    boxes accepted and pending (pending > 0: the cap was reached), the boxes set aside in crowded cells
    (``crowded``, :data:`spherekin.trust.singular.CROWDED_CELL`), and the unresolved ``regions`` of the
    pending and crowded boxes (grid index ranges, :func:`spherekin.trust.singular.pending_regions`)."""

    cells: dict
    cusps: tuple
    used: int
    seconds: float
    accepted: int
    pending: int
    regions: tuple = ()
    crowded: int = 0
    cusps_searched: bool = True


def _plane_run(system, grid, tol: float, max_boxes: int, start, cusps, budget) -> _PlaneRun:
    """The certified cover of one plane system (:func:`singular`): the traced cover (a plane; a line: the
    plain cover) from the boxes ``start`` (None: every chart), the cusp search (``cusps``: "tangency", the
    cusp system of :meth:`PlatformPlane.cusp_charts`; "rank", the candidates of
    :func:`spherekin.trust.singular.rank_candidates`; None: none), the cells' certificates, the unresolved
    cells' pieces searched again (REFINE_FRACTIONS), the traced cells added. Once ``budget``
    (:class:`spherekin.budget.Budget`) names a reason to stop, every stage hands over what it has (boxes not
    processed: pending; cells not tested: unresolved) and the later stages are skipped (the cusps: not searched)."""
    from .search.boxloop import pruner_for, search_cover
    from .trust.singular import (SINGULAR, UNRESOLVED, CellStatus, cell_pieces, certify_cover, certify_cusps,
                                 pending_regions, rank_candidates, trace_cover)

    pruner = pruner_for(system.charts, DEFAULT_PRUNER, None)
    traced = None
    if hasattr(system, "trace") and len(system.plane_columns) == 2:
        # certified tracing (trust/singular.trace_cover): boxes whose branch is proven a graph stop early
        def search(width, cap, begin):
            return search_cover(system.charts, pruner, width, cap, start=start if begin is None else begin,
                                budget=budget)

        traced = trace_cover(system, search, grid, tol, COVER_FRACTION, max_boxes, budget)
        cover = traced.cover
    else:
        cover = search_cover(system.charts, pruner, COVER_FRACTION * tol, max_boxes, start=start, budget=budget)
    used, t_cover, accepted, pending = cover.boxes_processed, cover.seconds, len(cover.accepted[0]), cover.pending
    accepted += 0 if traced is None else traced.traced
    first = cover
    cells = {(c.i, c.j): c for c in certify_cover(system, cover, grid, budget)}
    # the cells left unresolved: the accepted boxes over them cut by the cell and searched again with smaller
    # boxes (pieces over a cell the curve misses are discarded, the hulls certified are tighter); the pending
    # boxes of every round are kept (their cells stay unresolved). ``final`` (the rank route only): the pieces
    # of every round over the cells it leaves (unit boxes), where the rank candidates are taken
    rank = cusps == "rank" and len(system.plane_columns) == 2
    final = []
    for fraction in REFINE_FRACTIONS:
        again = {k for k, c in cells.items() if c.status != SINGULAR}
        if not again or budget.exhausted():
            break
        if rank:
            final.append(cell_pieces(system, cover.accepted, grid, set(cells) - again))
        cover = search_cover(system.charts, pruner, fraction * tol, max(1, max_boxes - used),
                             start=cell_pieces(system, cover.accepted, grid, again), budget=budget)
        pending = tuple(np.concatenate([a, b]) for a, b in zip(pending, cover.pending))
        cover = dataclasses.replace(cover, pending=pending)
        used, t_cover, accepted = used + cover.boxes_processed, t_cover + cover.seconds, accepted + len(cover.accepted[0])
        for k in again:
            del cells[k]
        cells.update({(c.i, c.j): c for c in certify_cover(system, cover, grid, budget) if (c.i, c.j) in again})
    cands = ()
    searched = not budget.exhausted()
    if not searched:
        pass                            # stopped: the cusps are not searched (the list claims nothing)
    elif rank:
        # no tangency system on these variables: the untraced and pending boxes not proven cusp-free
        chart, alo, ahi = cover.accepted
        final.append((chart, system.unit(chart, alo), system.unit(chart, ahi)) if len(chart) else
                     (chart, alo, ahi))
        chart, ulo, uhi = (np.concatenate(parts) for parts in zip(*final))
        pchart, plo, phi = pending
        cands = rank_candidates(system, np.concatenate([chart, pchart]), np.concatenate([ulo, plo]),
                                np.concatenate([uhi, phi]), grid)
    elif cusps == "tangency" and len(system.plane_columns) == 2:
        # the cusp system (curve + tangency) searched again from the traced cover's accepted boxes (every
        # singular configuration of the plane lies in them, in the traced boxes, which hold no cusp
        # (trace_cover), or in the pending ones, whose cells stay unresolved). Not from the refined pieces
        # nor without the boxes proven cusp-free (faster): measured on general_3rrr at T = 1e-2, Newton then
        # missed the cusp near (1.5923, 0.1041) (proven from a neighbouring box's wider start)
        cusp_sets = system.cusp_charts(CUSP_VECTORS)
        chart = first.accepted[0]
        begin = (chart, system.unit(chart, first.accepted[1]), system.unit(chart, first.accepted[2]))
        found = search_cover(cusp_sets[0], pruner_for(cusp_sets[0], DEFAULT_PRUNER, None), CUSP_FRACTION * tol,
                             max(1, max_boxes - used), start=begin, budget=budget)
        used, t_cover = used + found.boxes_processed, t_cover + found.seconds
        cands = certify_cusps(system, cusp_sets, found)
        # candidates without a proof: their boxes searched again with smaller boxes (most hold no root and are
        # discarded; the hulls Newton and the Krawczyk test see get tighter)
        for fraction in CUSP_REFINE_FRACTIONS:
            open_ = [c for c in cands if c.status != "cusp"]
            chart, alo, ahi = found.accepted
            if not open_ or not len(chart) or len(found.pending[0]) or budget.exhausted():
                break                   # (a capped search keeps its pending candidates unresolved)
            cols = list(system.plane_columns)
            near = np.zeros(len(chart), dtype=bool)
            for c in open_:
                near |= ((alo[:, cols[0]] <= c.box_x[1]) & (ahi[:, cols[0]] >= c.box_x[0])
                         & (alo[:, cols[1]] <= c.box_y[1]) & (ahi[:, cols[1]] >= c.box_y[0]))
            begin = (chart[near], system.unit(chart[near], alo[near]), system.unit(chart[near], ahi[near]))
            found = search_cover(cusp_sets[0], pruner_for(cusp_sets[0], DEFAULT_PRUNER, None), fraction * tol,
                                 max(1, max_boxes - used), start=begin, budget=budget)
            used, t_cover = used + found.boxes_processed, t_cover + found.seconds
            cands = tuple(c for c in cands if c.status == "cusp") + certify_cusps(system, cusp_sets, found)
    if traced is not None:
        # the traced boxes' cells (in the cover whatever the searched boxes say), singular where proven
        for k in traced.met | traced.proven:
            if k in traced.proven or (k in cells and cells[k].status == SINGULAR):
                cells[k] = CellStatus(k[0], k[1], SINGULAR)
            elif k not in cells:
                cells[k] = CellStatus(k[0], k[1], UNRESOLVED)
    aside = traced.crowded if traced is not None else tuple(a[:0] for a in pending)     # crowded cells' boxes
    regions = pending_regions(system, grid, tuple(np.concatenate(ab) for ab in zip(pending, aside)))
    return _PlaneRun(cells, tuple(cands), used, t_cover, accepted, len(pending[0]), regions, len(aside[0]), searched)


#: A line's cover is held against proven counts (:func:`_line_cross_check`) at this many inputs of each free
#: interval (between two cells): its two ends, each moved inward by CROSS_CHECK_INSET of min(T, its length), and
#: the points between them evenly. Reason: a missed branch point changes the count between some two of them;
#: the ends are where a cell placed off the true point leaves it (issue 40: cells 0.02-0.07 off), and 3
#: solves per cell cost ~0.1 s on a six-bar.
CROSS_CHECK_POINTS = 3
#: ... inset of the ends: far enough from a cell that the solve there is not next to its fold (slow, flagged).
CROSS_CHECK_INSET = 0.25


def _free_intervals(boxes, lo: float, hi: float) -> list[tuple[float, float]]:
    """The parts of [lo, hi] outside every box's x-range (closed boxes, merged), in order."""
    out, at = [], lo
    for a, b in sorted((b.x[0], b.x[1]) for b in boxes):
        if a > at:
            out.append((at, a))
        at = max(at, b)
    if at < hi:
        out.append((at, hi))
    return out


def _line_cross_check(mech, ax, fixed, boxes, tol: float, on_platform: bool):
    """A line's cover held against proven counts (issue 40 item 3): solve at CROSS_CHECK_POINTS inputs of each
    free interval (:func:`_free_intervals`) and compare the exact counts within each interval; a
    :class:`spherekin.results.CrossCheck`. The counts are of the mechanism the cover describes: the platform
    system's cover ignores every joint range, so do its counts; the loop equations' cover applies the passive
    ranges, so a count could change where an assembly leaves its range (no singularity): skipped then."""
    from .results import CrossCheck

    ranged = [n for n in mech.passive if mech.joint(n).range is not None]
    if ranged and not on_platform:
        return CrossCheck(skipped=f"passive joint ranges ({', '.join(ranged)}): a count also changes where an "
                                  "assembly leaves its range")
    free = mech.without_ranges()
    rows, owner = [], []
    for k, (a, b) in enumerate(_free_intervals(boxes, ax[1], ax[2])):
        inset = CROSS_CHECK_INSET * min(tol, b - a)
        for u in np.linspace(a + inset, b - inset, CROSS_CHECK_POINTS):
            rows.append([u if n == ax[0] else fixed[n] for n in free.actuated])
            owner.append(k)
    if not rows:
        return CrossCheck()
    reports = compile(free).solve_many(np.array(rows))
    seen: dict = {}
    out = []
    for k, row, rep in zip(owner, rows, reports):
        if not rep.count_exact:
            continue
        x = row[free.actuated.index(ax[0])]
        if k in seen and seen[k][1] != rep.proven_count:
            out.append(((float(seen[k][0]), float(x), None, None), (seen[k][1], rep.proven_count)))
        seen[k] = (x, rep.proven_count)
    return CrossCheck(len(rows), sum(r.count_exact for r in reports), tuple(out))


def singular(mechanism, x, y=None, fixed: Mapping[str, float] | None = None, *, tol: float = SINGULAR_TOL,
             max_boxes: int = SINGULAR_MAX_BOXES, budget=None):
    """The parallel (Type-2) singular set of ``mechanism`` in a plane of inputs, certified (issue 31).

    ``x`` = (name, lo, hi), ``y`` = (name, lo, hi) or None (a line): actuated joints and ranges (radians,
    at most one turn); ``fixed``: every other actuated joint's reading (radians). ``tol``: the cells' width
    bound T (radians). Returns a :class:`spherekin.results.SingularSet`: the cells of a grid of width <= T
    that the cover of the augmented system meets, each ``singular`` (a singular configuration proven at an
    input of the cell) or ``unresolved``; the plane outside them is proven free of parallel singularities
    (:mod:`spherekin.trust.singular`). ``max_boxes`` caps the cover: when reached, ``complete`` is False and
    the unprocessed part of the plane is in ``unresolved`` regions (boxes wider than a cell, each a cusp
    candidate too: :func:`spherekin.trust.singular.pending_regions`). The system is chosen as a solve's: the
    platform system (three R-R-R legs; passive joint ranges not applied: the set may hold singular
    configurations with passive joints out of range) where it applies, else the loop equations (3 passive
    joints per loop: four-bars, five-bars, six-bars; passive ranges applied). A platform with stationary
    assemblies (orientations closing every input: the agile eye's four) is covered as two systems: the plane
    system without a box U about each, and U blown up (:mod:`spherekin.systems.blowup`), where the other
    assemblies' crossings with them become regular roots that the Krawczyk slices prove; the cusp
    candidates of both are then the boxes not proven cusp-free (no tangency system there).

    ``budget``: a :class:`spherekin.budget.Budget` (default: one with the machine's memory cap,
    :data:`spherekin.budget.MEMORY_FRACTION` of its memory). When it names a reason to stop (the memory cap, or
    a signal the command line turned into a stop), the run ends as at the box cap: ``complete`` False,
    ``stopped`` the reason, the unprocessed part unresolved regions, untested cells unresolved, cusps not searched.
    """
    from .budget import Budget
    from .systems.blowup import StationaryPlane, outside
    from .systems.singular import LoopPlane, PlatformPlane, SingularPlane
    from .results import Cusp, CuspSearch, SingularBox, SingularSet, SingularStats
    from .trust.singular import SINGULAR, Grid, merge_cusps, outside_regions, region_candidates

    mech = as_mechanism(mechanism)
    ax = _plane_axis(mech, "x", x)
    ay = None if y is None else _plane_axis(mech, "y", y)
    if ay is not None and ay[0] == ax[0]:
        raise ValueError(f"y: expected another actuated joint than x, got {ay[0]!r} twice")
    fixed = dict(fixed or {})
    for name, value in fixed.items():
        if name not in mech.actuated:
            raise ValueError(f"fixed: expected actuated joints ({', '.join(mech.actuated)}), got {name!r}")
        if name in (ax[0], None if ay is None else ay[0]):
            raise ValueError(f"fixed: {name} is an axis of the plane, it cannot also be fixed")
        if not np.isfinite(float(value)):
            raise ValueError(f"fixed: expected a finite reading (radians) for {name}, got {value!r}")
        check_turn(f"fixed ({name})", float(value))
        rng = mech.ranges[name]
        if rng is not None and not in_range(float(value), rng):
            raise ValueError(f"fixed ({name}): {float(value):.6g} is outside its joint range [{rng[0]:.6g}, {rng[1]:.6g}]")
    missing = [n for n in mech.actuated if n not in fixed and n not in (ax[0], None if ay is None else ay[0])]
    if missing:
        raise ValueError(f"fixed: expected a reading for every actuated joint off the plane, missing {', '.join(missing)}")
    tol = check_singular_tol(tol, "tol")
    if isinstance(max_boxes, bool) or not isinstance(max_boxes, (int, np.integer)) or max_boxes < 1:
        raise ValueError(f"max_boxes: expected a positive whole number, got {max_boxes!r}")
    budget = Budget() if budget is None else budget
    t0 = time.perf_counter()
    plane = SingularPlane(ax, ay, {k: float(v) for k, v in fixed.items()})
    on_platform = Platform.accepts(mech) is None
    system = PlatformPlane(mech, plane) if on_platform else LoopPlane(mech, plane)
    grid = Grid.over(plane.axes, tol)
    runs = []
    stationary = getattr(system, "stationary", ())
    if stationary:
        # the stationary assemblies' neighbourhoods blown up (systems/blowup.py): the plane system searches
        # the rest of the orientations, the blow-up patches the boxes U about them. Cusps by the rank test in
        # both: outside U the agile eye still has its self-motion inputs (beta = (+-pi/2, 0), (+-pi/2, pi) at
        # beta3 = 0.5: `solve` reports a continuum), around which the tangency system degenerates (measured,
        # whole plane at T = 0.1: 9,173 cusp boxes accepted, 72 candidates, none proven, ~300 s)
        runs.append(_plane_run(system, grid, tol, int(max_boxes), outside(system, stationary), "rank", budget))
        blown = StationaryPlane(mech, plane, stationary)
        runs.append(_plane_run(blown, grid, tol, max(1, int(max_boxes) - runs[0].used), None, "rank", budget))
    else:
        runs.append(_plane_run(system, grid, tol, int(max_boxes), None, "tangency" if on_platform else None,
                               budget))
    cells: dict = {}
    for run in runs:
        for k, c in run.cells.items():
            if k not in cells or c.status == SINGULAR:
                cells[k] = c
    used = sum(r.used for r in runs)
    t_cover = sum(r.seconds for r in runs)
    accepted = sum(r.accepted for r in runs)
    n_pending = sum(r.pending for r in runs)
    # the pending boxes' regions (a capped run): unresolved, and the cells inside them listed only when proven;
    # never searched for cusps, each is a cusp candidate too (not merged into a proven cusp it may meet)
    regions = sorted({g for r in runs for g in r.regions})
    cusps = tuple(Cusp(c.x, c.y, c.box_x, c.box_y, c.status)
                  for c in merge_cusps([c for r in runs for c in r.cusps]) + region_candidates(grid, regions)
                  ) if on_platform and ay is not None else ()
    listed = set(outside_regions(cells, regions)) | {k for k, c in cells.items() if c.status == SINGULAR}
    cells = [cells[k] for k in sorted(listed)]
    stopped = budget.reason or ("box cap" if n_pending else None)
    boxes = tuple(SingularBox(grid.edges(0, c.i), None if ay is None else grid.edges(1, c.j), c.status)
                  for c in cells)
    boxes += tuple(SingularBox((grid.edges(0, i0)[0], grid.edges(0, i1)[1]),
                               None if ay is None else (grid.edges(1, j0)[0], grid.edges(1, j1)[1]), "unresolved")
                   for i0, i1, j0, j1 in regions)
    check = None
    if ay is None and stopped is None:    # a line: the cover held against proven counts between its cells
        check = _line_cross_check(mech, ax, plane.fixed, boxes, tol, on_platform)
    complete = stopped is None and not (check and check.disagreements)
    t2 = time.perf_counter()
    # t_cover: the box loops; the rest: set-up, projection and certificates
    stats = SingularStats(used, accepted, n_pending, t_cover, t2 - t0 - t_cover, t2 - t0,
                          sum(r.crowded for r in runs))
    if ay is None:
        search = CuspSearch.NOT_APPLICABLE
    elif on_platform:
        search = CuspSearch.SEARCHED if all(r.cusps_searched for r in runs) else CuspSearch.NOT_SEARCHED
    else:
        search = CuspSearch.NONE_POSSIBLE if len(mech.link_graph.loops) == 1 else CuspSearch.NOT_SEARCHED
    return SingularSet(ax, ay, plane.fixed, float(tol), boxes, complete, stats,
                       Platform.name if on_platform else Loops.name, cusps, search, stopped=stopped,
                       cross_check=check)


#: Radii (radians of input) of the circles around a proven cusp tried by :func:`mode_change`, in order: small
#: enough that the circle meets only the cusp's two fold branches (general_3rrr's cusps are >= 0.1 apart
#: from other curves in the cases measured), large enough that the tracker's steps stay long.
MODE_RADII = (0.02, 0.05)
#: Points of the closed polygon on a circle (the tracker subdivides each side as it needs).
MODE_POINTS = 256
#: Start inputs tried on each circle: the solve at each; the track starts where the solve has the most
#: assemblies (the side of the cusp where three local assemblies exist, a wedge narrowing at the cusp).
MODE_STARTS = 48
#: A complete track's end pose is solution j of the start solve when their rotations agree to this (largest
#: entry): the tracker's poses are proven roots polished to ~1e-15; distinct certified solutions differ by
#: far more (disjoint proven boxes).
MODE_MATCH = 1e-9


def mode_change(mechanism, sset, *, radii=MODE_RADII, points: int = MODE_POINTS, starts: int = MODE_STARTS):
    """A proven assembly-mode change around a cusp of ``sset`` (a :class:`spherekin.results.SingularSet` of
    a plane of two inputs), issue 31 item 5: for each proven cusp (then each unresolved candidate) and
    each radius, the solve at ``starts`` inputs of the circle, the start where it has the most solutions,
    and every solution there tracked (:meth:`Problem.track`, every step proven) around the closed polygon
    of ``points`` sides; found when a complete track ends at another solution of the start solve. Returns
    a :class:`spherekin.results.ModeChange` (``found`` False with what was searched when none)."""
    from .results import ModeChange

    if sset.y is None:
        raise ValueError("mode_change: expected a plane of two inputs, got a line")
    problem = compile(mechanism)
    names = problem.mechanism.actuated
    ordered = sorted(sset.cusps, key=lambda c: c.status != "cusp")
    tried = 0
    for c in ordered:
        for rho in radii:
            tried += 1

            def rows(theta):
                r = np.empty((len(theta), len(names)))
                for j, n in enumerate(names):
                    r[:, j] = (c.x + rho * np.cos(theta) if n == sset.x[0] else
                               c.y + rho * np.sin(theta) if n == sset.y[0] else sset.fixed[n])
                return r

            angles = 2 * np.pi * np.arange(starts) / starts
            counts = [len(problem.solve(row).solutions) for row in rows(angles)]
            theta0 = angles[int(np.argmax(counts))]
            path = rows(theta0 + 2 * np.pi * np.arange(points + 1) / points)
            path[-1] = path[0]
            sols = problem.solve(path[0]).solutions
            for k, s in enumerate(sols):
                if s.platform_rotation is None:
                    break
                track = problem.track(path, start=k)
                if track.stop is not None:
                    continue
                end = track.poses[-1].platform_rotation
                gaps = [np.abs(end - o.platform_rotation).max() for o in sols]
                j = int(np.argmin(gaps))
                if j != k and gaps[j] <= MODE_MATCH:
                    return ModeChange(True, (c.x, c.y), float(rho), path, k + 1, j + 1, int(track.proven_steps),
                                      {"cusps": len(ordered), "radii": list(radii), "starts": starts},
                                      np.array(track.poses[0].platform_rotation), np.array(end), tuple(names))
    return ModeChange(False, None, None, None, None, None, 0,
                      {"cusps": len(ordered), "radii": list(radii), "starts": starts, "circles": tried})
