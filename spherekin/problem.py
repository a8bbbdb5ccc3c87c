"""The solve pipeline: a mechanism compiled once, then solved for one input or for many.

``problem = compile(mechanism, formulation=..., pruner=..., ...)`` does once what does not depend
on the actuator inputs: the strategy checks, the unknowns and their ranges, and the *chain* of
systems of equations (:func:`spherekin.systems.chain`): the system chosen from
:data:`spherekin.systems.SYSTEMS` (by name, or "auto": the first that accepts the mechanism and
strategy; ``settings.declined`` says why the faster ones did not), then every later system of the
registry that accepts it, each compiled once (its equations, charts and pruners). Then
``problem.solve(inputs)`` and ``problem.solve_many(rows)`` run, per input:

1. the systems of the chain in turn (:meth:`spherekin.systems.Compiled.search_many`): each searches
   the inputs still open as one array program and answers each with a ``Found`` (clusters in the
   passive joints), a ``Proven`` (solutions its own certificate proves, reported as they are: the
   complete count) or a ``Passed`` (why the next system must answer: ``settings.fallback``);
2. the trust layer (:func:`spherekin.trust.solutions.finalize_many`): polishing, certification,
   statuses and the count; the answering system may still pass an input on
   (:meth:`~spherekin.systems.Compiled.check`: the platform system checks the assemblies against its
   roots);
3. the report (:class:`spherekin.results.SolveReport`): ``settings.system`` is the system that answered.

``spherekin.solve(mechanism, inputs, ...)`` is ``compile(mechanism, ...).solve(inputs)``. This module
names no system: what each does is in its own file under :mod:`spherekin.systems`.
"""

from __future__ import annotations

import dataclasses
import os
import time
from dataclasses import dataclass
from typing import Callable, Mapping

import numpy as np

from .core.angles import RANGE_TOL, in_range, into_range
from .mechanism.io import load_mechanism
from .mechanism.model import SphericalMechanism
from .search.formulations import FORMULATIONS
from .systems import (AUTO, CONTINUUM_TOL, LOOP_FORMULATION, ON_CAP_CHOICES, ON_CAP_COVER, SEARCH_CHUNK, SYSTEMS,
                      CappedSearchWarning, Passed, Proven, Strategy, chain, choose, formulation_choices, system_choices, system_of_formulation)
from .results import (EmptyReason, SolveReport, SolverStats, EMPTY_INCONSISTENT, EMPTY_OUTSIDE_RANGES,
                      EMPTY_OUTSIDE_WORKSPACE)
from .trust.solutions import count_summary, finalize_many
from .trust.loop_tolerances import analyse_loops
from .trust.tolerances import analyse as analyse_tolerances, analyse_pose, not_analysed as tolerances_not_analysed
from .search.boxloop import (DEFAULT_MAX_BOXES, DEFAULT_PARAMETERIZATION, DEFAULT_PRUNER, DEFAULT_TOL, SolverLimitError,
                             check_strategy)

__all__ = ["DEFAULT_FORMULATION", "DEFAULT_SYSTEM", "LOOP_FORMULATION", "formulation_choices",
           "system_choices", "resolve_system", "CONTINUUM_TOL", "REFINE_FACTOR",
           "REFINE_MIN_TOL", "REFINE_MAX_BOXES", "REPR_NAME_CHARS", "Strategy", "Problem", "compile",
           "solve", "as_mechanism", "inverse_kinematics", "DEFAULT_CHUNK", "CappedSearchWarning",
           "ON_CAP_CHOICES"]

#: The default: the formulation of the first system that accepts the mechanism (the platform
#: formulation where it applies, else :data:`LOOP_FORMULATION`).
DEFAULT_FORMULATION = AUTO
#: The default: the first system of :data:`spherekin.systems.SYSTEMS` that accepts the mechanism.
DEFAULT_SYSTEM = AUTO


#: Longest mechanism name ``repr(problem)`` shows (longer ones are cut with "..."). Reason: keeps the
#: repr on one line of ~200 characters whatever the file calls its mechanism.
REPR_NAME_CHARS = 60


def _then(before: str | None, reason: str) -> str:
    """``settings.fallback`` after one more system passed an input on: every reason, in the chain's order."""
    return reason if before is None else f"{before}; then {reason}"


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


#: Inputs :meth:`Problem.solve_many` solves as one array program when asked for a box search: the
#: box systems' own chunk (:data:`spherekin.systems.base.SEARCH_CHUNK`, with its reason). By default
#: each problem uses its first system's (:attr:`Problem.chunk`: 1,024 for the complete counts).
DEFAULT_CHUNK = SEARCH_CHUNK
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


@dataclass(frozen=True, eq=False)
class Problem:
    """A mechanism compiled for one strategy: call :meth:`solve` or :meth:`solve_many`.

    ``names``: the passive unknowns (order of every solution's angles); ``ranges``: their joint
    ranges (None: the full circle); ``system``: the name of the system that solves it (in
    :data:`spherekin.systems.SYSTEMS`); ``chain``: the compiled systems that answer an input in
    turn, the chosen one first, then every later system of the registry that accepts the
    mechanism (:func:`spherekin.systems.chain`; each answers what the one before it passed on);
    ``declined``: (name, reason) of every system before ``system`` in the registry's order that
    "auto" passed over (empty when a system or formulation was asked for by name).
    """

    mechanism: object
    strategy: Strategy
    names: tuple
    ranges: Mapping
    system: str
    chain: tuple
    declined: tuple = ()

    @property
    def chunk(self) -> int:
        """Inputs :meth:`solve_many` solves as one array program by default: its first system's
        (:attr:`spherekin.systems.base.Compiled.chunk`); what a later system is passed it searches in
        chunks of its own."""
        return int(self.chain[0].chunk)

    def compiled(self, system: str):
        """The compiled system named ``system`` in this problem's chain; ValueError naming the chain otherwise."""
        for c in self.chain:
            if c.system == system:
                return c
        raise ValueError(f"system: expected one of {[c.system for c in self.chain]} (this problem's chain), "
                         f"got {system!r}")

    def __repr__(self) -> str:
        """One line: the mechanism's name and size and the strategy (not the whole mechanism)."""
        st = self.strategy
        name = self.mechanism.name or "unnamed mechanism"
        if len(name) > REPR_NAME_CHARS:
            name = name[:REPR_NAME_CHARS - 3] + "..."
        backend = f" ({st.lp_backend})" if st.lp_backend else ""
        return (f"Problem({name!r}, {len(self.mechanism.joints)} joints, {len(self.names)} unknowns; "
                f"{self.chain[0].describe()}, pruner {st.pruner}{backend}, tol {st.tol:g})")

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
        return self._with_tolerances(self._explained(report, values), values)

    def _with_tolerances(self, report: SolveReport, values) -> SolveReport:
        """``report`` with ``tolerances`` set (:func:`spherekin.trust.tolerances.analyse`: each assembly
        under the mechanism's tolerances, and whether the count stays) when the mechanism has them."""
        tolerances = self.mechanism.tolerances
        if tolerances is None:
            return report
        analysis = analyse_tolerances if tolerances_not_analysed(self.mechanism) is None else analyse_loops
        return dataclasses.replace(report, tolerances=analysis(self.mechanism, tolerances, values, report))

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
        that reached a cap in a chunk (:meth:`_solve_chunk`), where the cap is then reported. The
        systems of the chain answer in turn (:meth:`spherekin.systems.Compiled.search_one`)."""
        fallback = None
        for system in self.chain:
            found = system.search_one(values, progress, trace)
            if isinstance(found, Passed):
                fallback = _then(fallback, found.reason)
                continue
            if isinstance(found, Proven):            # its own certificate: no trust layer, no check
                return self._proven_report(system, values, found, fallback)
            solutions, refined, t_final = self._trust_many(system, [values], [found])[0]
            why = system.check([solutions], [found])[0]
            if why is None or system is self.chain[-1]:
                return self._report(system, values, found, solutions, refined, t_final, fallback)
            fallback = _then(fallback, why)
        raise RuntimeError(f"the last system of the chain ({self.chain[-1].system}) passed an input on")

    def _refiner(self, system, values, refined: list):
        """The ``refine`` callable of :func:`~spherekin.trust.solutions.finalize` at ``values``: a new search
        of a cluster's hull (which holds every root of its boxes) by ``system`` at a finer tol
        (:meth:`~spherekin.systems.Compiled.search_box`); its stats go to ``refined``."""
        s = self.strategy

        def again(lo, hi, t):
            finer = t * REFINE_FACTOR
            if finer < REFINE_MIN_TOL:
                return None
            box = {n: (float(a) - RANGE_TOL, float(b) + RANGE_TOL) for n, a, b in zip(self.names, lo, hi)}
            try:
                sub = system.search_box(values, box, finer, min(s.max_boxes, REFINE_MAX_BOXES))
            except SolverLimitError:
                return None
            refined.append(sub.stats)
            return sub.clusters, finer

        return again

    def _trust_many(self, system, values: list, found: list) -> list:
        """(solutions, stats of refined searches, seconds) of every input: the trust layer over all the
        points of the chunk at once (:func:`spherekin.trust.solutions.finalize_many`, per tolerance),
        ``found[k]`` (a :class:`~spherekin.systems.Found` of ``system``) the search at ``values[k]``;
        where ``found[k].refine``, unresolved clusters are searched again, finer. The seconds are
        each input's share of the chunk's."""
        refined: list[list[SolverStats]] = [[] for _ in values]
        solutions: list = [None] * len(values)
        t0 = time.perf_counter()
        groups: dict = {}
        for k, f in enumerate(found):          # a covering run has a tolerance of its own
            groups.setdefault((f.tol, tuple(f.report.unknowns)), []).append(k)
        for (tol, unknowns), members in groups.items():
            got = finalize_many(self.mechanism, np.array([values[k] for k in members], dtype=float), unknowns,
                                [found[k].report.clusters for k in members], tol,
                                refine=lambda i: self._refiner(system, values[members[i]], refined[members[i]])
                                if found[members[i]].refine else None)
            for k, sols in zip(members, got):
                solutions[k] = sols
        share = (time.perf_counter() - t0) / max(len(values), 1)
        return [(solutions[k], refined[k], share) for k in range(len(values))]

    def _report(self, system, values, found, solutions, refined, t_final, fallback) -> SolveReport:
        """The :class:`SolveReport` of ``values`` answered by ``system`` (its :class:`~spherekin.systems.Found`
        ``found``, the trust layer's ``solutions``), ``fallback``: why the systems before it passed."""
        report, limit = found.report, found.limit
        proven, exact = count_summary(solutions)
        settings = dataclasses.replace(report.settings, mechanism=self.mechanism.name,
                                       actuated=tuple(self.mechanism.actuated), inputs=tuple(float(v) for v in values),
                                       fallback=fallback, limit=limit, refined_searches=len(refined),
                                       system=system.system, declined=self.declined)
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

    def _proven_report(self, system, values, proven, fallback, common: dict | None = None) -> SolveReport:
        """The :class:`SolveReport` of ``values`` answered by ``system`` with a
        :class:`~spherekin.systems.Proven` (its solutions as they are, perhaps not built yet). ``common``:
        a cache, for a chunk, of the settings' fields its answers share (one ``Settings`` built per input
        from it, not copied field by field: a chunk of thousands of proven inputs spent a third of its
        time in ``dataclasses.replace``)."""
        report = proven.report
        common = {} if common is None else common
        key = id(report.settings)
        if key not in common:
            base = {f.name: getattr(report.settings, f.name) for f in dataclasses.fields(report.settings)}
            base.update(mechanism=self.mechanism.name, actuated=tuple(self.mechanism.actuated), limit=None,
                        refined_searches=0, system=system.system, declined=self.declined)
            common[key] = (report.settings, base)          # the settings object kept: its id stays its own
        settings = type(report.settings)(**{**common[key][1], "inputs": tuple(float(v) for v in values),
                                            "fallback": fallback})
        return SolveReport(report.unknowns, proven.solutions, report.boxes, report.stats, settings, proven.proven,
                           proven.exact, mechanism=self.mechanism)

    # ------------------------------------------------------------------ many inputs

    def solve_many(self, inputs, *, progress: Callable[[int, int], None] | None = None,
                   chunk: int | None = None) -> tuple[SolveReport, ...]:
        """One report per row of ``inputs`` (shape (K, number of actuated joints), radians), in order:
        for each row the report :meth:`solve` gives for it (``solve(x)`` is this on a chunk of one).

        The rows are solved ``chunk`` at a time (None: :attr:`chunk`, the first system's), each chunk
        as one array program
        (:meth:`_solve_chunk`): the boxes of all its inputs in one box loop, with the input as a
        column, then the trust layer over all their points. Every row is checked before the first
        solve (one error naming the row); ``progress(done, total)`` is called after each chunk. An
        empty report's ``empty_reason`` is None here (it costs another solve: call
        :meth:`explain_empty` for the rows that need it).
        """
        rows = self._checked_rows("inputs", inputs)
        chunk = self.chunk if chunk is None else chunk
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
        if self.mechanism.tolerances is not None:
            out = [self._with_tolerances(r, tuple(float(v) for v in row)) for r, row in zip(out, rows)]
        return tuple(out)

    def _solve_chunk(self, values: list, progress) -> list[SolveReport]:
        """The reports of checked input rows ``values`` (K of them), as one array program per stage.

        The systems of the chain answer in turn: each searches the inputs still open as one chunk
        (:meth:`spherekin.systems.Compiled.search_many`: for the platform system the chart sets of
        every input stacked in one box loop; for the loop system the loop equations of all of them),
        then the trust layer runs over all the points it found (:meth:`_trust_many`) and the system
        checks the answers (:meth:`spherekin.systems.Compiled.check`); what a system passes on or
        fails its check goes to the next one, with the reason (``settings.fallback``).

        An input that reaches a cap in a chunk is searched on its own
        (:meth:`~spherekin.systems.Compiled.search_one`), where the cap is handled and reported as for
        a single solve; so is Ctrl-C in a chunk of one (its partial result is reported).
        ``progress(counts)``: the box loops' counters.
        """
        out: list[SolveReport | None] = [None] * len(values)
        fallback: list[str | None] = [None] * len(values)
        todo = list(range(len(values)))
        for system in self.chain:
            if not todo:
                break
            answers = [a for first in range(0, len(todo), system.chunk)
                       for a in system.search_many([values[k] for k in todo[first:first + system.chunk]], progress)]
            answers = [system.search_one(values[k], progress, None) if a is None else a
                       for k, a in zip(todo, answers)]                # None: a cap, searched on its own
            passed, common = [], {}
            for k, a in zip(todo, answers):
                if isinstance(a, Passed):
                    fallback[k] = _then(fallback[k], a.reason)
                    passed.append(k)
                elif isinstance(a, Proven):          # its own certificate: no trust layer, no check
                    out[k] = self._proven_report(system, values[k], a, fallback[k], common)
            found = [(k, a) for k, a in zip(todo, answers) if not isinstance(a, (Passed, Proven))]
            trusted = self._trust_many(system, [values[k] for k, _ in found], [a for _, a in found])
            checks = system.check([sols for sols, _, _ in trusted], [a for _, a in found])
            last = system is self.chain[-1]
            for (k, a), (solutions, refined, t_final), why in zip(found, trusted, checks):
                if why is None or last:
                    out[k] = self._report(system, values[k], a, solutions, refined, t_final, fallback[k])
                else:
                    fallback[k] = _then(fallback[k], why)
                    passed.append(k)
            todo = sorted(passed)
        if todo:
            raise RuntimeError(f"the last system of the chain ({self.chain[-1].system}) passed an input on")
        return out

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
        # (with tolerances, each pose reached is also analysed under them: TrackedPose.tolerances)
        start = self._assembly_at(rows[0], start, "the first input of the path")
        if not_tracked(self.mechanism) is not None:
            found = track_loops(self.mechanism, rows, start)
        else:
            found = track(self.mechanism, rows, start)
        tolerances = self.mechanism.tolerances
        if tolerances is None:
            return found
        poses = tuple(dataclasses.replace(p, tolerances=analyse_pose(self.mechanism, tolerances, rows[p.row],
                                                                     p.platform_rotation)) for p in found.poses)
        return dataclasses.replace(found, poses=poses)

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
    check_strategy(formulation if formulation in FORMULATIONS else None, pruner, lp_backend, parameterization, tol, jobs)
    strategy = Strategy(formulation, pruner, lp_backend, parameterization, float(tol), bool(isolate), jobs,
                        max_boxes, max_depth, on_cap)
    chosen, declined = resolve_system(mechanism, strategy, system)
    strategy = dataclasses.replace(strategy, formulation=chosen.default_formulation if formulation == AUTO else formulation)
    names = tuple(mechanism.loop_unknowns)
    return Problem(mechanism, strategy, names, {n: mechanism.ranges[n] for n in names}, chosen.name,
                   chain(mechanism, strategy, chosen), declined)


def resolve_system(mechanism, strategy: Strategy, system: str = DEFAULT_SYSTEM):
    """(the system class that solves ``mechanism`` with ``strategy``, the (name, reason) of the
    faster systems "auto" passed over). A formulation by name selects its system
    (:func:`spherekin.systems.system_of_formulation`: "platform" the platform system, a loop
    formulation the loop system); "auto" with system "auto" is the first system that accepts
    (:func:`spherekin.systems.choose`). ValueError naming the keyword when the system asked for
    does not accept the mechanism or the strategy, or when the two keywords disagree."""
    formulation = strategy.formulation
    asked, key = system, f"system {system!r}"
    if formulation != AUTO:
        by_formulation = system_of_formulation(formulation).name
        if system not in (AUTO, by_formulation):
            raise ValueError(f"system: expected 'auto' or {by_formulation!r} with formulation {formulation!r}, "
                             f"got {system!r}")
        asked, key = by_formulation, f"formulation {formulation!r}"
    if asked == AUTO:
        return choose(mechanism, strategy)
    cls = SYSTEMS.lookup(asked)
    probe = dataclasses.replace(strategy, formulation=cls.default_formulation) if formulation == AUTO else strategy
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
    if trace is not None and formulation == AUTO and (system == AUTO or system in SYSTEMS and SYSTEMS[system].traces):
        formulation = next(c for c in SYSTEMS.values() if c.traces).default_formulation   # the system that records boxes
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
