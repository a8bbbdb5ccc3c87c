"""Systems of equations, each accepting some mechanisms (in the manner of cvxpy's reductions/solvers).

A :class:`System` says whether it accepts a mechanism (:meth:`System.accepts`: None, or the reason
it does not) and compiles once per mechanism and strategy what does not depend on the actuator
inputs (:meth:`System.compile`: a :class:`Compiled`). :data:`SYSTEMS` registers them in order of
preference (fastest first): "auto" is the first that accepts (:func:`choose`), and the reasons of
those before it are kept for the report (``Settings.declined``).

The seam the pipeline talks through (:mod:`spherekin.problem` names no system): a compiled problem
holds a *chain*, the accepting systems in registry order from the one chosen (:func:`chain`). Each
:class:`Compiled` searches a chunk of inputs (:meth:`Compiled.search_many`) or one input
(:meth:`Compiled.search_one`) and answers each with a :class:`Found` (clusters in the passive
joints, for the trust layer), a :class:`Proven` (solutions the system's own certificate proves:
no trust layer) or a :class:`Passed` (why the next system must answer); after the
trust layer, :meth:`Compiled.check` may still hand an input over (the platform system checks the
trust layer's assemblies against its roots). The last system of every chain answers every input.

Nothing here imports the trust layer or the pipeline.
"""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Callable, ClassVar, Sequence

from ..results import SearchLimit, SearchReport, SearchStrategy
from ..search.registry import Registry

__all__ = ["AUTO", "CONTINUUM_TOL", "CappedSearchWarning", "ON_CAP_COVER", "ON_CAP_RAISE", "ON_CAP_CHOICES", "SEARCH_CHUNK", "Strategy", "Found", "Proven", "Passed", "Compiled", "System",
           "SYSTEMS", "own_variables_declined", "system_choices", "formulation_choices", "system_of_formulation", "choose", "chain"]

#: The name that lets the registry choose: the first system (in order of preference) that accepts.
AUTO = "auto"

#: What a solve does when its search reaches ``max_boxes``: cover the solution set with coarser
#: boxes (:data:`CONTINUUM_TOL`), say so (``settings.limit``, a warning, the count
#: not proven) and report the covering; or raise the search's ``SolverLimitError``.
ON_CAP_COVER = "cover"
ON_CAP_RAISE = "raise"
ON_CAP_CHOICES = (ON_CAP_COVER, ON_CAP_RAISE)
#: Tolerance (radians) of the covering run when a solve hits a cap (a continuum of solutions): a
#: curve of length ~2 pi is covered by ~1e3 boxes of this size, well within the default cap, and
#: the boxes are fine enough to show its shape and estimate its dimension.
CONTINUUM_TOL = 1e-2


class CappedSearchWarning(UserWarning):
    """A solve's search reached ``max_boxes`` at the tolerance asked for and the solution set was covered
    at :data:`CONTINUUM_TOL` instead (``on_cap="cover"``): the count is not proven; the report's
    ``settings.tol`` is the covering's, ``settings.limit`` says what was asked and what stopped it."""


@dataclass(frozen=True)
class Strategy(SearchStrategy):
    """How a problem is solved (see :func:`spherekin.compile`): the :class:`~spherekin.results.SearchStrategy`
    and the caps. ``formulation`` is resolved by the pipeline ("platform" or a loop formulation; "auto" only
    while a system is being chosen)."""

    max_boxes: int
    max_depth: int | None
    on_cap: str = ON_CAP_COVER


@dataclass(frozen=True)
class Found:
    """A system's answer at one input, for the trust layer: ``report``, the search's clusters in the
    passive joints (the mechanism's ``loop_unknowns``); ``limit``, the cap or Ctrl-C that stopped the
    search (None: none; the count is then never exact); ``tol`` (radians), the tolerance of the
    clusters (a covering's, after a cap); ``refine``, whether the trust layer may search an
    unresolved cluster again, finer (:meth:`Compiled.search_box`); ``roots``, what
    :meth:`Compiled.check` compares the trust layer's solutions with (None: nothing)."""

    report: SearchReport
    limit: SearchLimit | None
    tol: float
    refine: bool
    roots: object = None


@dataclass(frozen=True)
class Proven:
    """A system's answer at one input whose solutions its own certificate already proves (the
    complete count, :mod:`spherekin.systems.complete`): the pipeline reports them as they are, with
    no trust layer and no :meth:`Compiled.check`. ``report``: the search report (names, stats,
    settings); ``solutions``: the :class:`~spherekin.results.Solution` entries, in the joint ranges,
    each certified or singular with its evidence; ``limit``: None (a proof has no cap)."""

    report: SearchReport
    solutions: Sequence
    proven: int
    exact: bool
    limit: SearchLimit | None = None


@dataclass(frozen=True)
class Passed:
    """A system hands an input to the next one in the chain: ``reason`` (one line, for the report's
    ``settings.fallback``)."""

    reason: str


#: Inputs a box search takes as one array program by default (:attr:`Compiled.chunk`). Reason:
#: measured (benchmarks/bench_engine.py) its throughput per input levels off past ~100 inputs a chunk
#: (the fixed cost of each box-loop iteration is then spread thin), and a chunk of 256 holds at most
#: a few MB of boxes.
SEARCH_CHUNK = 256


class Compiled(ABC):
    """A system compiled for one mechanism and strategy: what the pipeline asks of it.

    ``system``: the registry name of its system; ``names``: the passive joints the pipeline reports,
    in the mechanism's ``loop_unknowns`` order; ``ranges``: their joint ranges (name -> (lo, hi)
    radians, or None: the full circle).
    """

    system: ClassVar[str]
    #: Inputs its :meth:`search_many` takes as one array program when the caller does not say
    #: (:meth:`spherekin.problem.Problem.solve_many`'s ``chunk``).
    chunk: ClassVar[int] = SEARCH_CHUNK
    names: tuple
    ranges: dict

    @abstractmethod
    def readings(self, inputs, points):
        """The readings (K, len(names); radians) of ``names`` at K points of this system's unknowns
        found at actuator ``inputs`` (radians, one per actuated joint)."""

    @abstractmethod
    def search_many(self, rows: list, progress: Callable[[dict], None] | None) -> list:
        """One answer per checked input row of ``rows`` (tuples of radians, one per actuated joint),
        the chunk searched as one array program: a :class:`Found`, a :class:`Proven`, a
        :class:`Passed`, or None where
        the row reached a cap in the chunk (the pipeline then calls :meth:`search_one` for it).
        Ctrl-C (:class:`~spherekin.search.boxloop.SearchInterrupted`) in a chunk of more than one
        row raises KeyboardInterrupt."""

    @abstractmethod
    def search_one(self, values, progress: Callable[[dict], None] | None,
                   trace: Callable[[dict], None] | None) -> Found | Passed:
        """The answer at one checked input ``values``, searched on its own (a cap handled here: a
        covering or a :class:`Passed`; ``jobs`` > 1 and ``trace`` where the system supports them)."""

    def check(self, solutions: list, found: list) -> list:
        """Why the trust layer's ``solutions[k]`` (of :class:`Found` ``found[k]``) are not this system's
        answer at input k (the input then goes to the next system), or None; default: None for all."""
        return [None] * len(solutions)

    def search_box(self, values, box, tol: float, max_boxes: int) -> SearchReport:
        """A search at ``values`` over ``box`` (name -> (lo, hi) radians) at ``tol``: for the trust
        layer's refined searches, asked only of a :class:`Found` with ``refine`` set."""
        raise NotImplementedError(f"the {self.system} system does not search sub-boxes")

    @abstractmethod
    def describe(self) -> str:
        """A few words for ``repr(problem)``: the system's formulation (and parameterization)."""


class System(ABC):
    """One system of equations: ``name`` (registry key), ``description`` (one line), what it accepts
    and what it compiles."""

    name: ClassVar[str]
    description: ClassVar[str]

    #: The formulation a problem resolves "auto" to when this system is chosen.
    default_formulation: ClassVar[str]
    #: Whether its search records a ``trace`` of every batch of boxes (for experiments).
    traces: ClassVar[bool] = False

    @classmethod
    @abstractmethod
    def formulations(cls) -> tuple[str, ...]:
        """The formulation names that select this system (``formulation=`` of :func:`spherekin.compile`)."""

    @classmethod
    @abstractmethod
    def accepts(cls, mechanism, strategy: Strategy | None = None) -> str | None:
        """None when this system solves ``mechanism`` (with ``strategy``, when given: some strategies
        rule a system out), else the reason it does not (one line, for the report)."""

    @classmethod
    @abstractmethod
    def compile(cls, mechanism, strategy: Strategy) -> Compiled:
        """What this system needs for every input of ``mechanism``, built once (it accepts it)."""


def own_variables_declined(strategy: Strategy, formulation: str, what: str, proof: str = "") -> str | None:
    """Why a system with variables of its own (the formulation named ``formulation``; ``what``: how its
    reasons name it) declines ``strategy``: another formulation asked for; a loop parameterization asked
    for while the formulation is "auto"; isolate=False (it proves its roots; ``proof``: by what). None
    when it accepts it. The check the platform system and the complete counts share."""
    if strategy.formulation not in (AUTO, formulation):
        return f"formulation {strategy.formulation!r} asked for"
    if strategy.formulation != formulation and strategy.parameterization != "tan-half":
        return f"parameterization {strategy.parameterization!r} asked for ({what} has its own variables)"
    if not strategy.isolate:
        return f"isolate=False asked for ({what} proves its roots{proof})"
    return None


#: The systems by name, in order of preference (fastest first; registered by their modules).
SYSTEMS = Registry("system")


def system_choices() -> tuple[str, ...]:
    """Every system a solve accepts by name: "auto" and the registered systems, in order of preference."""
    return (AUTO, *SYSTEMS)


def formulation_choices() -> tuple[str, ...]:
    """Every formulation a solve accepts by name: "auto" and each system's, in order of preference."""
    return (AUTO, *(f for cls in SYSTEMS.values() for f in cls.formulations()))


def system_of_formulation(formulation: str) -> type[System]:
    """The system a formulation name selects (one of :func:`formulation_choices` other than "auto")."""
    for cls in SYSTEMS.values():
        if formulation in cls.formulations():
            return cls
    raise ValueError(f"formulation: expected one of {list(formulation_choices())}, got {formulation!r}")


def chain(mechanism, strategy: Strategy, first: type[System]) -> tuple[Compiled, ...]:
    """The compiled chain of a problem: ``first`` (the system chosen), then every system registered
    after it that accepts ``mechanism`` with ``strategy``, each compiled, in registry order. Each
    answers the inputs the one before it passed on; the last must answer every input."""
    names = list(SYSTEMS)
    later = [SYSTEMS[n] for n in names[names.index(first.name) + 1:]]
    # a formulation that names the first system selects it, not its fallbacks: they are asked as "auto"
    rest = dataclasses.replace(strategy, formulation=AUTO) if strategy.formulation in first.formulations() else strategy
    return (first.compile(mechanism, strategy),
            *(cls.compile(mechanism, rest) for cls in later if cls.accepts(mechanism, rest) is None))


def choose(mechanism, strategy: Strategy) -> tuple[type[System], tuple[tuple[str, str], ...]]:
    """(the first system of :data:`SYSTEMS` that accepts ``mechanism`` with ``strategy``, the
    (name, reason) of every system before it, which did not); ValueError when none accepts."""
    declined = []
    for name, cls in SYSTEMS.items():
        why = cls.accepts(mechanism, strategy)
        if why is None:
            return cls, tuple(declined)
        declined.append((name, why))
    raise ValueError("system: no registered system accepts this mechanism ("
                     + "; ".join(f"{n}: {r}" for n, r in declined) + ")")
