"""Results of a solve: frozen dataclasses only (no behaviour beyond small derived views)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

__all__ = ["SolverStats", "AcceptedBox", "Solution", "SolveReport"]


@dataclass(frozen=True)
class SolverStats:
    """Counters and timings of a solve (seconds).

    ``isolated``: boxes proven by the Krawczyk test to hold exactly one root of the square system
    (:mod:`spherekin.isolation`); ``spurious``: of those, the ones whose root is not a closure;
    ``newton_failures``: isolated boxes Newton did not converge in (then subdivided as usual).
    ``time_finalize``: polishing, certification and classification of the solutions.
    """

    charts: int = 0
    boxes_processed: int = 0
    discarded: int = 0
    split: int = 0
    reduced_again: int = 0
    accepted: int = 0
    isolated: int = 0
    spurious: int = 0
    newton_failures: int = 0
    lps_solved: int = 0
    lp_doubts: int = 0
    max_depth: int = 0
    time_setup: float = 0.0
    time_restrict: float = 0.0
    time_prune: float = 0.0
    time_isolate: float = 0.0
    time_finalize: float = 0.0
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
    hull, ``n_boxes`` how many accepted boxes it merges, ``members`` their boxes (n_boxes, 2, M:
    lo then hi, unwrapped next to the hull; None once finalized). When solved from a mechanism the angles
    are polished (:mod:`spherekin.solutions`): ``platform_rotation`` is R with v_i = R v_i^0,
    ``residual`` the largest entry of |F_n - I| over the loops, ``singularity`` the mechanism's
    classification ("regular", "serial", "parallel" or "serial+parallel"), ``status`` one of
    "certified", "singular", "unverified", and ``evidence`` what backs the status.
    """

    angles: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    n_boxes: int
    platform_rotation: np.ndarray | None = None
    residual: float | None = None
    singularity: str | None = None
    status: str | None = None
    evidence: dict = field(default_factory=dict)
    members: np.ndarray | None = field(default=None, repr=False, compare=False)


@dataclass(frozen=True)
class SolveReport:
    """Everything a solve returns: the unknowns' names, the solutions, the raw boxes, statistics.

    ``proven_count``: the number of solutions proven by a certificate (status ``certified``, or
    ``singular`` with ``krawczyk_certified`` in its evidence); ``count_exact``: True when that is
    every entry, so the count is exact; False when it is a lower bound ("at least"). Both None
    for the raw clusters of :func:`spherekin.solver.solve_system`.
    """

    unknowns: tuple[str, ...]
    solutions: tuple[Solution, ...]
    boxes: tuple[AcceptedBox, ...]
    stats: SolverStats
    settings: dict = field(default_factory=dict)
    proven_count: int | None = None
    count_exact: bool | None = None

    def count_text(self) -> str:
        """"8 solutions (count proven)", "at least 6 solutions (2 entries unresolved)", or for an
        unfinalized report (:func:`spherekin.solver.solve_system`) "N cluster(s) of boxes"."""
        if self.count_exact is None:
            return f"{len(self.solutions)} cluster(s) of boxes (not polished nor certified)"
        n = self.proven_count
        word = "solution" if n == 1 else "solutions"
        if self.count_exact:
            return f"{n} {word} (count proven: each one has a Krawczyk certificate)"
        others: dict[str, int] = {}
        for s in self.solutions:
            if s.status != "certified" and not (s.status == "singular" and s.evidence.get("krawczyk_certified")):
                key = "singular without certificate" if s.status == "singular" else s.status
                others[key] = others.get(key, 0) + 1
        listed = ", ".join(f"{v} {k}" for k, v in others.items())
        capped = "; the search hit a cap" if "limit" in self.settings else ""
        return f"at least {n} {word} proven (count not exact: {listed or 'none listed'}{capped}; see the status column)"

    def table(self, degrees: bool = False) -> str:
        """A readable table of the solutions (angles in radians, or degrees)."""
        scale = 180.0 / np.pi if degrees else 1.0
        extra = any(s.residual is not None for s in self.solutions)
        head = "  #  " + " ".join(f"{name:>11s}" for name in self.unknowns) + "  boxes"
        head += "   residual  status      singularity" if extra else ""
        rows = [head]
        for i, s in enumerate(self.solutions, start=1):
            row = f"{i:3d}  " + " ".join(f"{a * scale:+11.6f}" for a in s.angles) + f"  {s.n_boxes:5d}"
            if extra:
                res = "-" if s.residual is None else f"{s.residual:9.1e}"
                row += f"  {res:>9s}  {s.status or '-':10s}  {s.singularity or '-'}"
            rows.append(row)
        return "\n".join(rows)

    def as_dict(self) -> dict:
        """JSON-ready dict: per solution the passive angles (radians), the platform rotation
        (3x3, v_i = R v_i^0), residual, singularity and box; the statistics and settings."""
        from . import __version__

        def arr(a):
            return None if a is None else np.asarray(a, dtype=float).tolist()

        actuated = dict(zip(self.settings.get("actuated", ()), self.settings.get("inputs", ())))
        return {
            "schema": "spherekin.solve/2",
            "spherekin_version": __version__,
            "settings": self.settings,
            "unknowns": list(self.unknowns),
            "count": {"proven": self.proven_count, "exact": self.count_exact, "entries": len(self.solutions)},
            "solutions": [
                {"passive_angles": dict(zip(self.unknowns, arr(s.angles))),
                 "joint_angles": {**actuated, **dict(zip(self.unknowns, arr(s.angles)))},
                 "platform_rotation": arr(s.platform_rotation), "residual": s.residual,
                 "singularity": s.singularity, "status": s.status, "evidence": s.evidence,
                 "box_lo": arr(s.lo), "box_hi": arr(s.hi), "n_boxes": s.n_boxes}
                for s in self.solutions],
            "statistics": self.stats.as_dict(),
        }
