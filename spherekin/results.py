"""Results of a solve: frozen dataclasses only (no behaviour beyond small derived views)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

__all__ = ["SolverStats", "AcceptedBox", "Solution", "SolveReport"]


@dataclass(frozen=True)
class SolverStats:
    """Counters and timings of the box loop (seconds)."""

    charts: int = 0
    boxes_processed: int = 0
    discarded: int = 0
    split: int = 0
    reduced_again: int = 0
    accepted: int = 0
    lps_solved: int = 0
    lp_doubts: int = 0
    max_depth: int = 0
    time_setup: float = 0.0
    time_restrict: float = 0.0
    time_prune: float = 0.0
    time_total: float = 0.0

    def __add__(self, other: "SolverStats") -> "SolverStats":
        vals = {k: getattr(self, k) + getattr(other, k) for k in self.__dataclass_fields__ if k != "max_depth"}
        vals["max_depth"] = max(self.max_depth, other.max_depth)
        return SolverStats(**vals)

    def as_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class AcceptedBox:
    """A box smaller than the tolerance that may hold a root: angle bounds (radians) per unknown."""

    lo: np.ndarray
    hi: np.ndarray
    chart: int


@dataclass(frozen=True)
class Solution:
    """One cluster of touching accepted boxes: the candidate solution it encloses.

    ``angles`` (radians, one per unknown) is the centre of the cluster's hull, ``lo``/``hi`` the
    hull, ``n_boxes`` how many accepted boxes it merges. When solved from a mechanism,
    ``platform_rotation`` is R with v_i = R v_i^0 and ``residual`` the largest loop closure
    residual ||F_n - I|| (Frobenius) at ``angles``.
    """

    angles: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    n_boxes: int
    platform_rotation: np.ndarray | None = None
    residual: float | None = None


@dataclass(frozen=True)
class SolveReport:
    """Everything a solve returns: the unknowns' names, the solutions, the raw boxes, statistics."""

    unknowns: tuple[str, ...]
    solutions: tuple[Solution, ...]
    boxes: tuple[AcceptedBox, ...]
    stats: SolverStats
    settings: dict = field(default_factory=dict)

    def table(self) -> str:
        """A readable table of the solutions (angles in radians)."""
        head = "  #  " + " ".join(f"{name:>11s}" for name in self.unknowns) + "  boxes"
        rows = [head]
        for i, s in enumerate(self.solutions, start=1):
            rows.append(f"{i:3d}  " + " ".join(f"{a:+11.6f}" for a in s.angles) + f"  {s.n_boxes:5d}")
        return "\n".join(rows)
