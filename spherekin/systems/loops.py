"""The loop-equation system: the closure equations of every loop (Eq. 2) in the passive joints' angles.

It accepts every mechanism: its unknowns are the passive joints themselves (their readings are the
points the search finds), in a parameterization and formulation of the strategy's
(:mod:`spherekin.search.parameterizations`, :mod:`spherekin.search.formulations`). Compiling keeps
the mechanism's loop builder and a cache of pruners, one per chart layout, built at its first use
(for the LP pruners, the LP model is compiled once, not per input).
"""

from __future__ import annotations

import dataclasses
import time
import warnings
from typing import Callable

import numpy as np

from ..results import SearchLimit, Settings
from ..search.boxloop import SearchInterrupted, SolverLimitError, partial_report, solve_system, solve_system_many
from ..search.parameterizations import make_charts, stack_chart_sets
from ..search.formulations import FORMULATIONS
from ..search.parameterizations import ChartSet
from .base import (CONTINUUM_TOL, ON_CAP_RAISE, SYSTEMS, CappedSearchWarning, Compiled, Found, Strategy, System)
from .loop_charts import LoopCharts

__all__ = ["LOOP_FORMULATION", "COMPILED_MAX_BUILDS", "Loops", "CompiledLoops"]

#: The loop formulation of "auto" and of the platform system's fallback (the fastest one that
#: finds every solution, benchmarks/README.md).
LOOP_FORMULATION = "halves"


#: The loop charts are compiled (:mod:`.loop_charts`) when that takes at most this many direct
#: builds (3 per actuated joint, multiplied). Reason: a four- or five-bar's 3 or 9 builds (~0.1-0.2 s)
#: are paid back within a chunk of a few inputs and cost a one-off solve little; a 3-RRR's 27
#: builds of 6-unknown loops (~1-3 s) would be paid by every fallback of a small job.
COMPILED_MAX_BUILDS = 9


def _ranges_key(ranges) -> tuple:
    """A hashable form of joint ``ranges`` (name -> (lo, hi) radians, or None)."""
    return tuple((n, None if r is None else (float(r[0]), float(r[1]))) for n, r in dict(ranges).items())


class CompiledLoops(Compiled):
    """The loop equations of one mechanism in one formulation, with their pruners (kept per chart layout)."""

    system = "loops"

    def __init__(self, mechanism, strategy: Strategy, formulation: str):
        self.mechanism = mechanism
        self.strategy = strategy
        self.formulation = formulation
        self.names = tuple(mechanism.loop_unknowns)
        self.ranges = {n: mechanism.ranges[n] for n in self.names}
        #: chart layout -> pruner (:func:`spherekin.search.boxloop.pruner_for`), filled at first use
        self.pruners: dict = {}
        #: ranges -> :class:`spherekin.systems.loop_charts.LoopCharts`, compiled at the first charts_many over them
        self.loop_charts: dict = {}
        #: the joint ranges of the unknowns (every solve's; :meth:`uses_compiled`), hashable
        self.home = _ranges_key({n: mechanism.ranges[n] for n in self.names})

    def builder(self, inputs) -> Callable:
        """chart -> (loops, unknowns) of the loop equations at actuator ``inputs`` (radians)."""
        def build(chart):
            system = self.mechanism.loop_system(inputs, chart)
            return system.loops, system.unknowns
        return build

    def compiled_charts(self, ranges) -> LoopCharts:
        """The :class:`~spherekin.systems.loop_charts.LoopCharts` of these equations over ``ranges``
        (name -> (lo, hi) radians, or None), compiled at its first use and kept."""
        key = _ranges_key(ranges)
        if key not in self.loop_charts:
            m = self.mechanism
            loop_joints = [{m.actuated.index(v.joint) for v in g.vertices if v.actuated} for g in m.loop_geometry]
            self.loop_charts[key] = LoopCharts(self.builder, [m.joint(n).range for n in m.actuated], dict(ranges),
                                               self.strategy.parameterization, self.formulation,
                                               loop_joints=loop_joints)
        return self.loop_charts[key]

    def uses_compiled(self, ranges) -> bool:
        """Whether the searches over ``ranges`` build their charts with :meth:`charts_many` (compiled
        once) rather than directly per input: over the joint ranges of the mechanism (every solve's),
        when compiling takes at most COMPILED_MAX_BUILDS direct builds. Decided by the mechanism,
        never by the chunk or by what was solved before, so that an input gets the same charts alone
        (:meth:`search`) or in a chunk (:meth:`search_many`). Both builds are rigorous."""
        return 3 ** len(self.mechanism.actuated) <= COMPILED_MAX_BUILDS and _ranges_key(ranges) == self.home

    def charts_many(self, rows, ranges, dense: bool = True) -> ChartSet:
        """The chart sets (:func:`spherekin.search.parameterizations.make_charts`) of the K input rows
        ``rows`` (K, actuated; radians) over ``ranges`` (name -> (lo, hi) radians, or None), stacked
        along the chart axis input-major: chart c of row k at index k C + c of every per-chart array
        (C charts per input; the bilinear halves' chart axis is their last). One array program
        compiled once per ranges (:mod:`spherekin.systems.loop_charts`: the arrays are multilinear in
        the actuated joints' (1, cos, sin), tolerances included), or the direct build per input where
        a parameterization or formulation is not (``compiled_charts(ranges).fallback`` says why).
        Each row is checked as :meth:`spherekin.mechanism.SphericalMechanism.check_inputs` does.
        ``dense=False``: the dense coefficients of blocks with a bilinear form are NaN placeholders
        (:meth:`~spherekin.systems.loop_charts.LoopCharts.charts`), for an engine that restricts the halves."""
        m = self.mechanism
        arr = np.asarray(rows, dtype=float) if not isinstance(rows, (str, bytes)) else None
        if arr is None or arr.ndim != 2 or arr.shape[1] != len(m.actuated) or arr.shape[0] == 0:
            raise ValueError(f"rows: expected a (K, {len(m.actuated)}) array of actuator angles in radians "
                             f"{m.actuated}, got {np.shape(rows) if arr is not None else rows!r}")
        arr = m.check_input_rows(arr, "rows[{k}]")
        return self.compiled_charts(ranges).charts(arr, dense)

    def search(self, inputs, ranges, *, tol: float, jobs: int, max_boxes: int, progress=None, trace=None):
        """:func:`spherekin.search.boxloop.solve_system` on these equations at ``inputs`` over ``ranges``
        (name -> (lo, hi) radians, or None), with the strategy's names and the kept pruners."""
        s = self.strategy
        charts = self.charts_many(np.asarray(inputs, dtype=float)[None], ranges, dense=False) \
            if self.uses_compiled(ranges) else None
        return solve_system(self.builder(inputs), ranges, formulation=self.formulation, pruner=s.pruner,
                            lp_backend=s.lp_backend, parameterization=s.parameterization, tol=tol, isolate=s.isolate,
                            jobs=jobs, max_boxes=max_boxes, max_depth=s.max_depth, progress=progress, trace=trace,
                            pruners=self.pruners, charts=charts)

    def search_many_over(self, rows, ranges, *, tol: float, max_boxes: int, progress=None) -> tuple:
        """:func:`spherekin.search.boxloop.solve_system_many` at every row of ``rows`` (K, actuated;
        radians) over ``ranges``: one report per row, None where the row reached a cap."""
        s = self.strategy
        t0 = time.perf_counter()
        rows = np.asarray(rows, dtype=float)
        if self.uses_compiled(ranges):
            charts = self.charts_many(rows, ranges, dense=False)
        else:
            charts = stack_chart_sets([make_charts(s.parameterization, self.builder(row), ranges, self.formulation)
                                       for row in rows])
        return solve_system_many(charts, len(rows), ranges, formulation=self.formulation, pruner=s.pruner,
                                 lp_backend=s.lp_backend, parameterization=s.parameterization, tol=tol,
                                 isolate=s.isolate, max_boxes=max_boxes, max_depth=s.max_depth, pruners=self.pruners,
                                 t_setup=time.perf_counter() - t0, progress=progress)

    def readings(self, inputs, points) -> np.ndarray:
        """The points themselves: the unknowns are the passive joints' readings."""
        return np.asarray(points, dtype=float)

    # ------------------------------------------------------------------ the pipeline's seam

    def describe(self) -> str:
        return f"{self.formulation}, {self.strategy.parameterization}"

    def search_many(self, rows: list, progress) -> list:
        """The chunk's rows in one box loop over the joint ranges: a :class:`~.base.Found` per row,
        None where a row reached a cap. Ctrl-C in a chunk of one hands over what was found
        (:meth:`_interrupted`); in a larger chunk it stops the chunk."""
        s = self.strategy
        try:
            found = self.search_many_over(np.array(rows), self.ranges, tol=s.tol, max_boxes=s.max_boxes,
                                          progress=progress)
        except SearchInterrupted as exc:
            if len(rows) > 1:
                raise KeyboardInterrupt(*exc.args) from None
            return [self._interrupted(exc, s.tol)]
        return [None if report is None else Found(report, None, s.tol, True) for report in found]

    def search_one(self, values, progress, trace) -> Found:
        """One input over the joint ranges (``jobs`` Dask workers over its charts, ``trace``); a capped
        search is re-run as a covering (``on_cap="cover"``) or raises (``"raise"``)."""
        s = self.strategy
        tol = s.tol

        def run(t):
            return self.search(values, self.ranges, tol=t, jobs=s.jobs, max_boxes=s.max_boxes, progress=progress,
                               trace=trace)

        try:
            return Found(run(tol), None, tol, True)
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
                report = partial_report(exc2, self.ranges, self._settings(covering))
            return Found(report, limit, covering, True)

    def search_box(self, values, box, tol: float, max_boxes: int):
        """A search of ``box`` (a cluster's hull) at ``values``, one process (the trust layer's refined search)."""
        return self.search(values, box, tol=tol, jobs=1, max_boxes=max_boxes)

    def _settings(self, tol: float) -> Settings:
        s = self.strategy
        return Settings(formulation=self.formulation, pruner=s.pruner, lp_backend=s.lp_backend,
                        parameterization=s.parameterization, tol=tol, isolate=s.isolate, jobs=s.jobs, charts=0)

    def _interrupted(self, exc: SearchInterrupted, tol: float) -> Found:
        """A loop search stopped by Ctrl-C (or SIGTERM): what was accepted so far is finalized and
        reported, marked as interrupted (the count is then never exact, nothing refined), not lost."""
        return Found(partial_report(exc, self.ranges, self._settings(tol)),
                     SearchLimit(str(exc), tol, tol, interrupted=True), tol, False)


@SYSTEMS.register
class Loops(System):
    """The closure equations of every loop (Eq. 2): any mechanism."""

    name = "loops"
    default_formulation = LOOP_FORMULATION
    traces = True
    description = "the closure equations of every loop in the passive joints' angles (any mechanism)"

    @classmethod
    def formulations(cls) -> tuple[str, ...]:
        return tuple(FORMULATIONS)

    @classmethod
    def accepts(cls, mechanism, strategy=None) -> str | None:
        return None

    @classmethod
    def compile(cls, mechanism, strategy) -> CompiledLoops:
        formulation = strategy.formulation if strategy.formulation in FORMULATIONS else LOOP_FORMULATION
        return CompiledLoops(mechanism, strategy, formulation)
