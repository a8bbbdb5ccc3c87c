"""Systems of equations, each accepting some mechanisms (in the manner of cvxpy's reductions/solvers).

A :class:`System` says whether it accepts a mechanism (:meth:`System.accepts`: None, or the reason
it does not), compiles once per mechanism and strategy what does not depend on the actuator inputs
(:meth:`System.compile`: a :class:`Compiled` the pipeline searches), and maps the points it finds
back to joint readings (:meth:`Compiled.readings`). :data:`SYSTEMS` registers them in order of
preference (fastest first): "auto" is the first that accepts (:func:`choose`), and the
reasons of those before it are kept for the report (``Settings.declined``).

Nothing here imports the trust layer or the pipeline.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar

from ..search.registry import Registry

__all__ = ["AUTO", "ON_CAP_COVER", "ON_CAP_RAISE", "ON_CAP_CHOICES", "Strategy", "Compiled", "System", "SYSTEMS", "system_choices", "choose"]

#: The name that lets the registry choose: the first system (in order of preference) that accepts.
AUTO = "auto"

#: What a solve does when its search reaches ``max_boxes``: cover the solution set with coarser
#: boxes (``spherekin.problem.CONTINUUM_TOL``), say so (``settings.limit``, a warning, the count
#: not proven) and report the covering; or raise the search's ``SolverLimitError``.
ON_CAP_COVER = "cover"
ON_CAP_RAISE = "raise"
ON_CAP_CHOICES = (ON_CAP_COVER, ON_CAP_RAISE)


@dataclass(frozen=True)
class Strategy:
    """How a problem is solved (see :func:`spherekin.compile`); ``formulation`` is resolved by the
    pipeline ("platform" or a loop formulation; "auto" only while a system is being chosen)."""

    formulation: str
    pruner: str
    lp_backend: str | None
    parameterization: str
    tol: float
    isolate: bool
    jobs: int
    max_boxes: int
    max_depth: int | None
    on_cap: str = ON_CAP_COVER


class Compiled(ABC):
    """A system compiled for one mechanism and strategy. ``names``: the passive joints the pipeline
    reports, in the mechanism's ``loop_unknowns`` order."""

    names: tuple

    @abstractmethod
    def readings(self, inputs, points):
        """The readings (K, len(names); radians) of ``names`` at K points of this system's unknowns
        found at actuator ``inputs`` (radians, one per actuated joint)."""


class System(ABC):
    """One system of equations: ``name`` (registry key), ``description`` (one line), what it accepts
    and what it compiles."""

    name: ClassVar[str]
    description: ClassVar[str]

    @classmethod
    @abstractmethod
    def accepts(cls, mechanism, strategy: Strategy | None = None) -> str | None:
        """None when this system solves ``mechanism`` (with ``strategy``, when given: some strategies
        rule a system out), else the reason it does not (one line, for the report)."""

    @classmethod
    @abstractmethod
    def compile(cls, mechanism, strategy: Strategy) -> Compiled:
        """What this system needs for every input of ``mechanism``, built once (it accepts it)."""


#: The systems by name, in order of preference (fastest first; registered by their modules).
SYSTEMS = Registry("system")


def system_choices() -> tuple[str, ...]:
    """Every system a solve accepts by name: "auto" and the registered systems, in order of preference."""
    return (AUTO, *SYSTEMS)


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
