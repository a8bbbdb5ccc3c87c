"""The solve pipeline: a mechanism compiled once, then solved for one input or for many.

``problem = compile(mechanism, formulation=..., pruner=..., ...)`` does once what does not depend
on the actuator inputs: the strategy checks, the unknowns and their ranges, and, for the platform
formulation (:mod:`spherekin.search.platform_orientation`), Eq. (1)'s control-point tensors on the four
quaternion charts and the pruner (for the LP pruners, the compiled LP models); the loop equations'
pruner (and its LP model) is built at its first use, once per chart layout, and kept. Then
``problem.solve(inputs)`` and ``problem.solve_many(rows)`` run, per input:

1. the search (:mod:`spherekin.search.boxloop`): the box loop of Section 4 on the platform formulation,
   or on the loop equations (Eq. 2) in a parameterization and formulation of their own;
2. the trust layer (:func:`spherekin.trust.solutions.finalize`): polishing, certification, statuses and
   the count;
3. the report (:class:`spherekin.results.SolveReport`).

``spherekin.solve(mechanism, inputs, ...)`` is ``compile(mechanism, ...).solve(inputs)``.

Formulation ``"auto"`` (the default) is the platform formulation when it applies (legs R-R-R with
the base joint actuated, three of them; the tan-half parameterization asked for; isolation on) and
``"halves"`` otherwise. When the platform search cannot isolate every root (next to a parallel
singularity its Jacobian is singular; a cap), the input is solved again with the loop equations
(``settings.fallback`` says why): everything issue 13 built for the edge (cluster resolution,
refined searches, continua) works on those.
"""

from __future__ import annotations

import dataclasses
import os
import time
from dataclasses import dataclass
from typing import Callable, Mapping

import numpy as np

from .core.angles import RANGE_TOL
from .mechanism.io import load_mechanism
from .mechanism.model import SphericalMechanism
from .search.formulations import FORMULATIONS
from .search.platform_orientation import PlatformSystem, not_applicable, passive_names, passive_readings_many
from .search.pruners import make_pruner
from .results import (AcceptedBox, EmptyReason, SearchLimit, SearchReport, Settings, SolveReport, SolverStats,
                      EMPTY_INCONSISTENT, EMPTY_OUTSIDE_RANGES, EMPTY_OUTSIDE_WORKSPACE)
from .trust.solutions import count_summary, finalize, is_proven
from .search.boxloop import (DEFAULT_MAX_BOXES, DEFAULT_PARAMETERIZATION, DEFAULT_PRUNER, DEFAULT_TOL, SolverLimitError,
                     check_strategy, clusters_in_range, partial_report, search_platform, solve_system,
                     SearchInterrupted)

__all__ = ["DEFAULT_FORMULATION", "LOOP_FORMULATION", "PIPELINE_FORMULATIONS", "formulation_choices", "CONTINUUM_TOL", "REFINE_FACTOR",
           "REFINE_MIN_TOL", "REFINE_MAX_BOXES", "POSE_MATCH", "REPR_NAME_CHARS", "Strategy", "Problem", "compile",
           "solve", "disagreement", "as_mechanism"]

#: The default: the platform formulation where it applies, else :data:`LOOP_FORMULATION`.
DEFAULT_FORMULATION = "auto"
#: The loop formulation of "auto" and of the platform formulation's fallback (the fastest one that
#: finds every solution, benchmarks/README.md).
LOOP_FORMULATION = "halves"
#: The formulations a solve accepts beyond the registered loop formulations (FORMULATIONS).
PIPELINE_FORMULATIONS = ("auto", "platform")


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


@dataclass(frozen=True)
class Strategy:
    """How a problem is solved (see :func:`compile`); ``formulation`` is resolved ("auto" is gone)."""

    formulation: str
    pruner: str
    lp_backend: str | None
    parameterization: str
    tol: float
    isolate: bool
    jobs: int
    max_boxes: int
    max_depth: int | None


@dataclass(frozen=True, eq=False)
class Problem:
    """A mechanism compiled for one strategy: call :meth:`solve` or :meth:`solve_many`.

    ``names``: the passive unknowns (order of every solution's angles); ``ranges``: their joint
    ranges (None: the full circle); ``platform``: the compiled platform formulation, or None;
    ``not_platform``: why "auto" chose the loop equations (None when it did not).
    """

    mechanism: object
    strategy: Strategy
    names: tuple
    ranges: Mapping
    platform: PlatformSystem | None
    platform_pruner: object
    not_platform: str | None
    #: The loop equations' pruners, built on first use once per chart layout and kept for every
    #: input (:func:`spherekin.search.boxloop.pruner_for`): for the LP pruners, the LP model is
    #: compiled once, not per input.
    loop_pruners: dict = dataclasses.field(default_factory=dict)

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
        return dict(formulation=st.formulation if self.not_platform is None else DEFAULT_FORMULATION,
                    pruner=st.pruner, lp_backend=st.lp_backend, parameterization=st.parameterization, tol=st.tol,
                    isolate=st.isolate, jobs=st.jobs, max_boxes=st.max_boxes, max_depth=st.max_depth)

    # ------------------------------------------------------------------ one input

    def solve(self, inputs, *, progress: Callable[[dict], None] | None = None,
              trace: Callable[[dict], None] | None = None) -> SolveReport:
        """Every assembly at actuator ``inputs`` (radians, one per actuated joint) inside the joint
        ranges: polished, certified and classified (see :func:`spherekin.solve`). ``trace`` (loop
        formulations only, ``jobs=1``) records every batch of boxes for experiments. A report
        without solutions (and no cap or Ctrl-C) says why in ``empty_reason`` (:meth:`explain_empty`)."""
        values = self.mechanism.check_inputs(inputs)
        report = self._solve(values, progress, trace)
        if not report.solutions and report.settings.limit is None:
            report = dataclasses.replace(report, empty_reason=self.explain_empty(values))
        return report

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
        """The report of checked ``values`` (without :meth:`explain_empty`)."""
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
        s = self.strategy
        refined: list[SolverStats] = []

        def again(lo, hi, t):
            # a new search of a cluster's hull (which holds every root of its boxes) at a finer tol
            finer = t * REFINE_FACTOR
            if finer < REFINE_MIN_TOL:
                return None
            box = {n: (float(a) - RANGE_TOL, float(b) + RANGE_TOL) for n, a, b in zip(self.names, lo, hi)}
            try:
                sub = solve_system(self._builder(values), box, formulation=self._loop_formulation,
                                   pruner=s.pruner, lp_backend=s.lp_backend, parameterization=s.parameterization,
                                   tol=finer, isolate=s.isolate, jobs=1,
                                   max_boxes=min(s.max_boxes, REFINE_MAX_BOXES), max_depth=s.max_depth,
                                   pruners=self.loop_pruners)
            except SolverLimitError:
                return None
            refined.append(sub.stats)
            return sub.clusters, finer

        t0 = time.perf_counter()
        solutions = finalize(self.mechanism, values, report.unknowns, report.clusters, tol,
                             refine=again if refine else None)
        return solutions, refined, time.perf_counter() - t0

    def _report(self, values, report: SearchReport, solutions, refined, t_final, fallback,
                limit: SearchLimit | None) -> SolveReport:
        proven, exact = count_summary(solutions)
        settings = dataclasses.replace(report.settings, mechanism=self.mechanism.name,
                                       actuated=tuple(self.mechanism.actuated), inputs=tuple(float(v) for v in values),
                                       fallback=fallback, limit=limit, refined_searches=len(refined))
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

    def solve_many(self, inputs, *, progress: Callable[[int, int], None] | None = None) -> tuple[SolveReport, ...]:
        """One report per row of ``inputs`` (shape (K, number of actuated joints), radians), in order.

        Every row is checked before the first solve (one error naming the row); ``progress(done,
        total)`` is called after each row. An empty report's ``empty_reason`` is None here (it costs
        another solve: call :meth:`explain_empty` for the rows that need it).
        """
        rows = self._checked_rows("inputs", inputs)
        out = []
        for k, row in enumerate(rows):
            out.append(self._solve(self.mechanism.check_inputs(row), None, None))
            if progress is not None:
                progress(k + 1, len(rows))
        return tuple(out)

    def _checked_rows(self, key: str, inputs) -> np.ndarray:
        """``inputs`` as an array (K, actuated joints), every row checked (one error naming the row)."""
        rows = np.asarray(inputs, dtype=float) if not isinstance(inputs, np.ndarray) else inputs
        if rows.ndim != 2 or rows.shape[1] != len(self.mechanism.actuated):
            raise ValueError(f"{key}: expected an array of shape (K, {len(self.mechanism.actuated)}) "
                             f"(one column per actuated joint: {', '.join(self.mechanism.actuated)}), "
                             f"got shape {rows.shape}")
        for k, row in enumerate(rows):
            try:
                self.mechanism.check_inputs(row)
            except ValueError as exc:
                raise ValueError(f"{key} row {k}: {exc}") from None
        return rows

    # ------------------------------------------------------------------ a path

    def track(self, path, *, start):
        """Follow one assembly mode along ``path`` (K inputs, shape (K, number of actuated joints),
        radians), every step proven: a :class:`~spherekin.trust.continuation.Track` with the pose at
        each row reached, and where it stopped: where the mode ends at a parallel singularity, or
        where a joint leaves its range. Any mechanism: on the platform's orientation
        (:mod:`spherekin.trust.continuation`) where the platform formulation applies (three R-R-R
        legs with the base joints actuated), else on the loop equations
        (:mod:`spherekin.trust.loop_continuation`).

        ``start``: a :class:`~spherekin.results.Solution` of the solve at path[0] (e.g.
        ``report.solutions[4]``, the solution numbered 5 in printed tables, JSON and CSV), which
        must be certified; or an int K: ``report.solutions[K]`` (0-based, Python's indexing) of
        the full solve at path[0]; or, where the platform formulation applies, the platform
        rotation R (3x3) of an assembly at path[0].
        """
        from .results import Solution
        from .trust.continuation import track
        from .trust.loop_continuation import track_loops

        rows = self._checked_rows("path", path)
        if not len(rows):
            raise ValueError("path: expected at least one row of inputs, got none")
        why = not_applicable(self.mechanism)
        if isinstance(start, (int, np.integer)) and not isinstance(start, bool):
            report = self.solve(rows[0])
            n = len(report.solutions)
            if not 0 <= int(start) < n:
                raise ValueError(f"start: expected a solution index 0..{n - 1} of the solve at the first input "
                                 f"({n} solution(s)), got {int(start)}")
            start = report.solutions[int(start)]
        if isinstance(start, Solution):
            given = tuple(start.actuated.values())
            if given and np.abs(np.array(given, dtype=float) - rows[0]).max() > RANGE_TOL:
                raise ValueError(f"start: expected a solution of the solve at the first input of the path "
                                 f"{rows[0].tolist()}, got one at {list(given)}")
            if start.status != "certified" or (why is None and start.platform_rotation is None):
                raise ValueError(f"start: the solution at the first input is {start.status}, not certified; "
                                 "a track starts from a proven, isolated assembly")
            if why is not None:
                return track_loops(self.mechanism, rows, start.passive_angles)
            start = start.platform_rotation
        elif why is not None:
            raise ValueError(f"start: a start rotation needs the platform formulation, which does not apply ({why}); "
                             "start from a solution of the solve at the first input (--start-solution K; in Python "
                             "a Solution or its index)")
        else:
            from .mechanism.checks import check_rotation

            start = check_rotation("start", start)
        return track(self.mechanism, rows, start)

    # ------------------------------------------------------------------ stages

    @property
    def _loop_formulation(self) -> str:
        return LOOP_FORMULATION if self.strategy.formulation == "platform" else self.strategy.formulation

    def _builder(self, values):
        def build(chart):
            system = self.mechanism.loop_system(values, chart)
            return system.loops, system.unknowns
        return build

    def _search_platform(self, values, progress):
        """(report, poses of the roots in range) from the platform search, or why the loop equations
        must answer instead (a string)."""
        s = self.strategy
        t0 = time.perf_counter()
        charts = self.platform.charts(values)
        t_setup = time.perf_counter() - t0
        try:
            found = search_platform(charts, self.platform_pruner, s.tol, s.max_boxes, s.max_depth, progress)
        except SearchInterrupted:
            raise KeyboardInterrupt from None            # a search of milliseconds: nothing worth keeping
        except SolverLimitError as exc:
            return f"the platform search reached a cap ({exc})"
        if found.unresolved:
            return (f"the platform search left {found.unresolved} box(es) it could not isolate (a parallel "
                          "singularity or a double root nearby): solved with the loop equations")
        distinct, charts_of = [], []
        for chart, x in found.points:
            pose = self.platform.pose(chart, x)
            if any(np.abs(pose - p).max() <= DUPLICATE_POSE for p in distinct):
                continue                                  # the same root from an overlapping chart
            distinct.append(pose)
            charts_of.append(int(chart))
        boxes, poses = [], []
        if distinct:
            legs = self.platform.legs
            order = [passive_names(legs).index(n) for n in self.names]
            readings = passive_readings_many(legs, values, np.array(distinct), self.platform.platform_reference)
            for pose, chart, angles in zip(distinct, charts_of, readings[:, order]):
                box = AcceptedBox(angles, angles.copy(), chart)
                if clusters_in_range([box], self.ranges, s.tol):
                    boxes.append(box)
                    poses.append(pose)
        clusters = clusters_in_range(boxes, self.ranges, s.tol)
        stats = dataclasses.replace(found.stats, time_setup=t_setup,
                                    time_total=found.stats.time_total + time.perf_counter() - t0
                                    - found.stats.time_total)
        settings = Settings(formulation="platform", pruner=s.pruner, lp_backend=s.lp_backend,
                            parameterization="quaternion", tol=s.tol, isolate=True, jobs=1, charts=charts.n_charts)
        return SearchReport(self.names, tuple(clusters), (), stats, settings), poses

    def _search_loops(self, values, tol, progress, trace):
        """(report, limit, tol): the loop equations' search; a capped one is re-run as a covering."""
        s = self.strategy

        def run(t):
            return solve_system(self._builder(values), self.ranges, formulation=self._loop_formulation,
                                pruner=s.pruner, lp_backend=s.lp_backend, parameterization=s.parameterization,
                                tol=t, isolate=s.isolate, jobs=s.jobs, max_boxes=s.max_boxes,
                                max_depth=s.max_depth, progress=progress, trace=trace, pruners=self.loop_pruners)

        try:
            return run(tol), None, tol
        except SearchInterrupted as exc:
            # Ctrl-C: what was accepted so far is finalized and reported, marked as interrupted (the
            # count is then never exact), instead of being lost
            settings = Settings(formulation=self._loop_formulation, pruner=s.pruner, lp_backend=s.lp_backend,
                                parameterization=s.parameterization, tol=tol, isolate=s.isolate, jobs=s.jobs,
                                charts=0)
            return partial_report(exc, self.ranges, settings), SearchLimit(str(exc), tol, tol, interrupted=True), tol
        except SolverLimitError as exc:
            # A continuum of solutions (or a cap too small for this tol): cover the solution set with
            # boxes of CONTINUUM_TOL instead, and report what the cap stopped (the paper, Section 4: the
            # algorithm then returns a discretization of the solution set).
            covering = max(tol, CONTINUUM_TOL)
            limit = SearchLimit(str(exc), tol, covering)
            try:
                report = run(covering)
            except SolverLimitError as exc2:
                limit = dataclasses.replace(limit, covering_error=str(exc2))
                settings = Settings(formulation=self._loop_formulation, pruner=s.pruner, lp_backend=s.lp_backend,
                                    parameterization=s.parameterization, tol=covering, isolate=s.isolate,
                                    jobs=s.jobs, charts=0)
                report = partial_report(exc2, self.ranges, settings)
            return report, limit, covering


def disagreement(solutions, poses) -> str | None:
    """Why the finalized ``solutions`` of a platform search are not its roots ``poses`` (None when
    they are): every entry proven, one entry per distinct root, each matching one (POSE_MATCH).

    The platform search proves where the roots are; the trust layer proves each assembly in the
    loop equations. The two must agree, or the input goes to the loop equations (in the manner of
    scipy's ``_check_result``: the fast path's answer is checked, not trusted).
    """
    bad = [s.status for s in solutions if not is_proven(s)]
    if bad:
        return f"the trust layer could not prove {len(bad)} root(s) of the platform search ({', '.join(bad)})"
    distinct: list = []
    for r in poses:
        if not any(np.abs(r - d).max() <= POSE_MATCH for d in distinct):
            distinct.append(r)
    got = [s.platform_rotation for s in solutions]
    if len(got) != len(distinct) or any(
            not any(g is not None and np.abs(g - r).max() <= POSE_MATCH for g in got) for r in distinct):
        return (f"the platform search found {len(distinct)} assemblies and the trust layer {len(got)} "
                "different ones")
    return None


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
) -> Problem:
    """Compile ``mechanism`` (a :class:`spherekin.mechanism.SphericalMechanism`, or the path of a
    mechanism file) for a strategy (the keywords of :func:`solve`, same defaults); every name and
    number is checked here, before any input is solved. Returns a :class:`Problem`."""
    mechanism = as_mechanism(mechanism)
    if formulation not in formulation_choices():
        raise ValueError(f"formulation: expected one of {list(formulation_choices())}, got {formulation!r}")
    check_strategy(LOOP_FORMULATION if formulation in ("auto", "platform") else formulation, pruner, lp_backend,
                   parameterization, tol, jobs)
    why = not_applicable(mechanism)
    if formulation == "platform":
        if why is not None:
            raise ValueError(f"formulation 'platform': {why}; use 'auto' or a loop formulation")
        if not isolate:
            raise ValueError("formulation 'platform': needs isolate=True (its roots are proven by the Krawczyk test)")
    not_platform = None
    if formulation == "auto":
        if why is None and parameterization != "tan-half":
            why = f"parameterization {parameterization!r} asked for (the platform formulation has its own variables)"
        if why is None and not isolate:
            why = "isolate=False asked for (the platform formulation proves its roots by the Krawczyk test)"
        formulation, not_platform = ("platform", None) if why is None else (LOOP_FORMULATION, why)
    names = mechanism.loop_unknowns
    ranges = {n: mechanism.ranges[n] for n in names}
    platform = pruner_obj = None
    if formulation == "platform":
        platform = PlatformSystem.from_mechanism(mechanism)
        pruner_obj = make_pruner(pruner, [(len(platform.legs), 3, 3, 3)], lp_backend)
    strategy = Strategy(formulation, pruner, lp_backend, parameterization, float(tol), bool(isolate), jobs,
                        max_boxes, max_depth)
    return Problem(mechanism, strategy, tuple(names), ranges, platform, pruner_obj, not_platform)


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
) -> SolveReport:
    """Direct kinematics: every assembly of ``mechanism`` at actuator ``inputs`` inside its joint ranges.

    ``mechanism``: a :class:`spherekin.mechanism.SphericalMechanism`, or the path (str or
    ``os.PathLike``) of a mechanism file (docs/mechanism-format.md); ``inputs``: one angle (radians)
    per actuated joint. Returns a :class:`SolveReport` whose solutions are polished, deduplicated
    and classified (:func:`spherekin.trust.solutions.finalize`): passive angles, platform rotation,
    residual, status and its evidence (``report.frame()``: a DataFrame of them; an empty report
    says why in ``report.empty_reason``). The strategy, by name:

    * ``formulation``: one of :func:`formulation_choices` ("auto": the platform formulation where it
      applies, else "halves");
    * ``pruner`` ("pp", "lp", "hybrid") and ``lp_backend`` (None: the pruner's default);
    * ``parameterization`` of the loop equations ("tan-half", "sin-cos");
    * ``tol``: the size (radians) of the boxes the search stops at; ``isolate``: Krawczyk isolation;
    * ``jobs``: worker processes over the charts of the loop equations;
    * caps ``max_boxes`` and ``max_depth`` (see :func:`spherekin.search.boxloop.solve_system`).

    The paper-faithful configuration is ``formulation="paper", pruner="lp", lp_backend="clarabel",
    isolate=False``. For many inputs, :func:`compile` once and call :meth:`Problem.solve_many`.
    ``progress`` is called with the search's counters; ``trace`` (loop formulations only) records
    every batch of boxes.
    """
    if trace is not None and formulation == "auto":
        formulation = LOOP_FORMULATION                   # a trace records the boxes of the loop equations
    problem = compile(mechanism, formulation=formulation, pruner=pruner, lp_backend=lp_backend,
                      parameterization=parameterization, tol=tol, isolate=isolate, jobs=jobs, max_boxes=max_boxes,
                      max_depth=max_depth)
    return problem.solve(inputs, progress=progress, trace=trace)
