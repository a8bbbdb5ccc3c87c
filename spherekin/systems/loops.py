"""The loop-equation system: the closure equations of every loop (Eq. 2) in the passive joints' angles.

It accepts every mechanism: its unknowns are the passive joints themselves (their readings are the
points the search finds), in a parameterization and formulation of the strategy's
(:mod:`spherekin.search.parameterizations`, :mod:`spherekin.search.formulations`). Compiling keeps
the mechanism's loop builder and a cache of pruners, one per chart layout, built at its first use
(for the LP pruners, the LP model is compiled once, not per input).
"""

from __future__ import annotations

import time
from typing import Callable

import numpy as np

from ..search.boxloop import solve_system, solve_system_many
from ..search.parameterizations import make_charts, stack_chart_sets
from ..search.formulations import FORMULATIONS
from .base import SYSTEMS, Compiled, Strategy, System

__all__ = ["LOOP_FORMULATION", "Loops", "CompiledLoops"]

#: The loop formulation of "auto" and of the platform system's fallback (the fastest one that
#: finds every solution, benchmarks/README.md).
LOOP_FORMULATION = "halves"


class CompiledLoops(Compiled):
    """The loop equations of one mechanism in one formulation, with their pruners (kept per chart layout)."""

    def __init__(self, mechanism, strategy: Strategy, formulation: str):
        self.mechanism = mechanism
        self.strategy = strategy
        self.formulation = formulation
        self.names = tuple(mechanism.loop_unknowns)
        #: chart layout -> pruner (:func:`spherekin.search.boxloop.pruner_for`), filled at first use
        self.pruners: dict = {}

    def builder(self, inputs) -> Callable:
        """chart -> (loops, unknowns) of the loop equations at actuator ``inputs`` (radians)."""
        def build(chart):
            system = self.mechanism.loop_system(inputs, chart)
            return system.loops, system.unknowns
        return build

    def search(self, inputs, ranges, *, tol: float, jobs: int, max_boxes: int, progress=None, trace=None):
        """:func:`spherekin.search.boxloop.solve_system` on these equations at ``inputs`` over ``ranges``
        (name -> (lo, hi) radians, or None), with the strategy's names and the kept pruners."""
        s = self.strategy
        return solve_system(self.builder(inputs), ranges, formulation=self.formulation, pruner=s.pruner,
                            lp_backend=s.lp_backend, parameterization=s.parameterization, tol=tol, isolate=s.isolate,
                            jobs=jobs, max_boxes=max_boxes, max_depth=s.max_depth, progress=progress, trace=trace,
                            pruners=self.pruners)

    def search_many(self, rows, ranges, *, tol: float, max_boxes: int, progress=None) -> tuple:
        """:func:`spherekin.search.boxloop.solve_system_many` at every row of ``rows`` (K, actuated;
        radians) over ``ranges``: one report per row, None where the row reached a cap."""
        s = self.strategy
        t0 = time.perf_counter()
        charts = stack_chart_sets([make_charts(s.parameterization, self.builder(row), ranges, self.formulation)
                                   for row in rows])
        return solve_system_many(charts, len(rows), ranges, formulation=self.formulation, pruner=s.pruner,
                                 lp_backend=s.lp_backend, parameterization=s.parameterization, tol=tol,
                                 isolate=s.isolate, max_boxes=max_boxes, max_depth=s.max_depth, pruners=self.pruners,
                                 t_setup=time.perf_counter() - t0, progress=progress)

    def readings(self, inputs, points) -> np.ndarray:
        """The points themselves: the unknowns are the passive joints' readings."""
        return np.asarray(points, dtype=float)


@SYSTEMS.register
class Loops(System):
    """The closure equations of every loop (Eq. 2): any mechanism."""

    name = "loops"
    description = "the closure equations of every loop in the passive joints' angles (any mechanism)"

    @classmethod
    def accepts(cls, mechanism, strategy=None) -> str | None:
        return None

    @classmethod
    def compile(cls, mechanism, strategy) -> CompiledLoops:
        formulation = strategy.formulation if strategy.formulation in FORMULATIONS else LOOP_FORMULATION
        return CompiledLoops(mechanism, strategy, formulation)
