"""What the stages hand over: frozen dataclasses and enums (no behaviour beyond small derived views).

The box loop (:mod:`spherekin.search.boxloop`) hands over :class:`AcceptedBox` es merged into
:class:`Cluster` s, in a :class:`SearchReport`; the trust layer (:mod:`spherekin.trust.solutions`)
turns clusters into :class:`Solution` s with a :class:`Status`; the pipeline
(:mod:`spherekin.problem`) returns a :class:`SolveReport`. :class:`Settings` and
:class:`SearchLimit` say how the search ran, :class:`SolverStats` what it cost.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields
from enum import StrEnum
from typing import Mapping

import numpy as np

__all__ = ["Status", "SolverStats", "AcceptedBox", "Cluster", "Solution", "box_near", "SearchLimit", "Settings",
           "SearchReport", "SolveReport"]


class Status(StrEnum):
    """What is proven about one entry of a solve (docs/results-format.md; :mod:`spherekin.trust.solutions`).

    A ``StrEnum``: each member equals its value ("certified", ...) and prints as it, in text and JSON.
    """

    CERTIFIED = "certified"
    SINGULAR = "singular"
    UNVERIFIED = "unverified"
    CLUSTER = "cluster"
    CONTINUUM = "continuum"


@dataclass(frozen=True)
class SolverStats:
    """Counters and timings of a solve (seconds).

    ``isolated``: boxes proven by the Krawczyk test to hold exactly one root of the square system
    (:mod:`spherekin.search.isolation`); ``spurious``: of those, the ones whose root is not a closure;
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
class Cluster:
    """Touching accepted boxes of the box loop: the candidate root(s) they enclose, not yet proven.

    ``angles`` (radians, one per unknown): the centre of the hull, wrapped to [-pi, pi);
    ``lo``/``hi``: the hull; ``n_boxes``: how many accepted boxes it merges; ``members``: their
    boxes (n_boxes, 2, M: lo then hi, unwrapped next to the hull), or None when only the hull is known.
    """

    angles: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    n_boxes: int
    members: np.ndarray | None = field(default=None, repr=False, compare=False)


@dataclass(frozen=True)
class Solution:
    """One entry of a solve: a solution, or a region or continuum of them, and what is proven of it.

    ``angles`` (radians, one per passive unknown) are polished (:mod:`spherekin.trust.solutions`);
    ``lo``/``hi``: the box the status speaks of (the certified box, or the cluster's hull) as the
    search stored it; ``box_lo``/``box_hi``: the same box moved by whole turns next to ``angles`` (the
    JSON's ``box_lo``/``box_hi``; :func:`box_near`);
    ``n_boxes``: accepted boxes of its cluster; ``platform_rotation``: R with v_i = R v_i^0;
    ``residual``: the largest entry of |F_n - I| over the loops; ``singularity``: the mechanism's
    classification ("regular", "serial", "parallel" or "serial+parallel"); ``status``: a
    :class:`Status`; ``evidence``: what backs it (docs/results-format.md).
    """

    angles: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    n_boxes: int
    platform_rotation: np.ndarray | None = None
    residual: float | None = None
    singularity: str | None = None
    status: Status = Status.UNVERIFIED
    evidence: dict = field(default_factory=dict)
    unknowns: tuple = field(default=(), compare=False)
    actuated: Mapping = field(default_factory=dict, compare=False)

    @property
    def box_lo(self) -> np.ndarray:
        """The lower corner of the box (radians) next to the angles, as ``box_lo`` of the JSON."""
        return box_near(self)[0]

    @property
    def box_hi(self) -> np.ndarray:
        """The upper corner of the box (radians) next to the angles, as ``box_hi`` of the JSON."""
        return box_near(self)[1]

    @property
    def passive_angles(self) -> dict[str, float]:
        """The passive angles by joint name (radians), as ``passive_angles`` of the JSON."""
        return {n: float(a) for n, a in zip(self.unknowns, self.angles)}

    @property
    def joint_angles(self) -> dict[str, float]:
        """Every joint angle by name (radians): the actuator inputs, then the passive angles (the JSON's
        ``joint_angles``)."""
        return {**{n: float(v) for n, v in self.actuated.items()}, **self.passive_angles}

    @property
    def quaternion(self) -> np.ndarray | None:
        """The platform rotation as a unit quaternion (w, x, y, z), w >= 0 (None without a rotation)."""
        if self.platform_rotation is None:
            return None
        from .core.orientation import quaternions_from_rotations

        return quaternions_from_rotations(self.platform_rotation)

    def euler(self, convention: str = "ZYX") -> np.ndarray | None:
        """The platform rotation as Euler angles (radians) in ``convention`` (upper case intrinsic,
        lower case extrinsic; see :mod:`spherekin.core.orientation`), or None without a rotation."""
        if self.platform_rotation is None:
            return None
        from scipy.spatial.transform import Rotation

        from .core.orientation import check_euler_convention

        return Rotation.from_matrix(self.platform_rotation).as_euler(check_euler_convention(convention))

    def __repr__(self) -> str:
        angles = ", ".join(f"{n}={a:+.6f}" for n, a in self.passive_angles.items()) or \
            ", ".join(f"{a:+.6f}" for a in self.angles)
        res = "" if self.residual is None else f", residual={self.residual:.1e}"
        return f"Solution({self.status}, {angles}{res}, {self.singularity or 'unclassified'})"


def box_near(sol: Solution) -> tuple[np.ndarray, np.ndarray]:
    """The box (lo, hi) of ``sol`` moved by whole turns, per angle, next to the solution's angle (a
    box found on a chart centred at pi may be stored around 3.44 for an angle reported as -2.84:
    the same set of orientations, shown where the reader looks for it)."""
    lo, hi = np.asarray(sol.lo, dtype=float), np.asarray(sol.hi, dtype=float)
    turns = np.round((0.5 * (lo + hi) - np.asarray(sol.angles, dtype=float)) / (2 * np.pi))
    return lo - 2 * np.pi * turns, hi - 2 * np.pi * turns


@dataclass(frozen=True)
class SearchLimit:
    """A search stopped by a cap (a continuum of solutions, or a cap too small for ``tol``), and
    the covering search run instead at ``covering_tol`` (``covering_error``: it was capped too);
    or, with ``interrupted``, stopped by Ctrl-C (no covering search: what was found is reported)."""

    error: str
    tol: float
    covering_tol: float
    covering_error: str | None = None
    interrupted: bool = False

    def as_dict(self) -> dict:
        return {k: v for k, v in asdict(self).items() if v is not None and v is not False}


@dataclass(frozen=True)
class Settings:
    """How a search or solve ran (the strategy names as resolved, radians for ``tol``).

    The search's: ``formulation``, ``pruner``, ``lp_backend`` (None: the pruner's default),
    ``parameterization``, ``tol``, ``isolate``, ``jobs``, ``charts``. A solve adds ``mechanism``
    (its name), ``actuated`` and ``inputs`` (radians), and when they happened ``fallback`` (why
    the loop equations answered instead of the platform formulation), ``limit``
    (:class:`SearchLimit`) and ``refined_searches`` (clusters searched again at a finer tol).
    """

    formulation: str
    pruner: str
    lp_backend: str | None
    parameterization: str
    tol: float
    isolate: bool
    jobs: int
    charts: int
    mechanism: str | None = None
    actuated: tuple = ()
    inputs: tuple = ()
    fallback: str | None = None
    limit: SearchLimit | None = None
    refined_searches: int = 0

    def as_dict(self) -> dict:
        """JSON-ready: the search's keys always, the others when set (the JSON schema of docs/results-format.md)."""
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        for key in ("mechanism", "fallback", "limit"):
            if out[key] is None:
                del out[key]
        if not out["refined_searches"]:
            del out["refined_searches"]
        if self.mechanism is None and not self.actuated:
            del out["actuated"], out["inputs"]
        else:
            out["actuated"], out["inputs"] = list(self.actuated), [float(v) for v in self.inputs]
        if self.limit is not None:
            out["limit"] = self.limit.as_dict()
        return out


@dataclass(frozen=True)
class SearchReport:
    """What a search of the loop equations (:func:`spherekin.search.boxloop.solve_system`) or of the
    platform formulation finds: the unknowns' names, the clusters inside the ranges, the raw
    accepted boxes, statistics and settings. Nothing in it is polished or proven yet."""

    unknowns: tuple[str, ...]
    clusters: tuple[Cluster, ...]
    boxes: tuple[AcceptedBox, ...]
    stats: SolverStats
    settings: Settings

    def count_text(self) -> str:
        return f"{len(self.clusters)} cluster(s) of boxes (not polished nor certified)"


@dataclass(frozen=True)
class SolveReport:
    """Everything a solve returns: the unknowns' names, the solutions, the raw boxes, statistics.

    ``proven_count``: the number of solutions proven by a certificate (status ``certified``, or
    ``singular`` with ``krawczyk_certified`` in its evidence); ``count_exact``: True when that is
    every entry, so the count is exact; False when it is a lower bound ("at least").
    """

    unknowns: tuple[str, ...]
    solutions: tuple[Solution, ...]
    boxes: tuple[AcceptedBox, ...]
    stats: SolverStats
    settings: Settings
    proven_count: int
    count_exact: bool

    def __repr__(self) -> str:
        return (f"SolveReport({self.count_text()}; {len(self.solutions)} entries over {', '.join(self.unknowns)}; "
                f"{self.settings.formulation}, {self.stats.time_total:.3f} s)")

    def _repr_html_(self) -> str:
        """A notebook's view: the count and one table row per solution."""
        from html import escape

        head = "".join(f"<th>{escape(n)}</th>" for n in ("#", *self.unknowns, "status", "residual", "singularity"))
        rows = []
        for i, s in enumerate(self.solutions, start=1):
            cells = [str(i), *(f"{a:+.6f}" for a in s.angles), str(s.status),
                     "-" if s.residual is None else f"{s.residual:.1e}", s.singularity or "-"]
            rows.append("<tr>" + "".join(f"<td>{escape(c)}</td>" for c in cells) + "</tr>")
        return (f"<p><b>{escape(self.count_text())}</b> (radians)</p><table><thead><tr>{head}</tr></thead>"
                f"<tbody>{''.join(rows)}</tbody></table>")

    def count_text(self) -> str:
        """"8 solutions (count proven)" or "at least 6 solutions (2 entries unresolved)"."""
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
        limit = self.settings.limit
        capped = "" if limit is None else ("; interrupted (Ctrl-C)" if limit.interrupted else "; the search hit a cap")
        return f"at least {n} {word} proven (count not exact: {listed or 'none listed'}{capped}; see the status column)"

    def table(self, degrees: bool = False) -> str:
        """A readable table of the solutions (angles in radians, or degrees)."""
        scale = 180.0 / np.pi if degrees else 1.0
        head = "  #  " + " ".join(f"{name:>11s}" for name in self.unknowns) + "  boxes"
        head += "   residual  status      singularity"
        rows = [head]
        for i, s in enumerate(self.solutions, start=1):
            row = f"{i:3d}  " + " ".join(f"{a * scale:+11.6f}" for a in s.angles) + f"  {s.n_boxes:5d}"
            res = "-" if s.residual is None else f"{s.residual:9.1e}"
            row += f"  {res:>9s}  {s.status:10s}  {s.singularity or '-'}"
            rows.append(row)
        return "\n".join(rows)

    def as_dict(self) -> dict:
        """JSON-ready dict: per solution the passive angles (radians), the platform rotation
        (3x3, v_i = R v_i^0), residual, singularity and box; the statistics and settings."""
        from . import __version__

        def arr(a):
            return None if a is None else np.asarray(a, dtype=float).tolist()

        actuated = dict(zip(self.settings.actuated, (float(v) for v in self.settings.inputs)))
        return {
            "schema": "spherekin.solve/2",
            "spherekin_version": __version__,
            "settings": self.settings.as_dict(),
            "unknowns": list(self.unknowns),
            "count": {"proven": self.proven_count, "exact": self.count_exact, "entries": len(self.solutions)},
            "solutions": [
                {"number": number, "passive_angles": dict(zip(self.unknowns, arr(s.angles))),
                 "joint_angles": {**actuated, **dict(zip(self.unknowns, arr(s.angles)))},
                 "platform_rotation": arr(s.platform_rotation), "residual": s.residual,
                 "singularity": s.singularity, "status": str(s.status), "evidence": s.evidence,
                 "box_lo": arr(s.box_lo), "box_hi": arr(s.box_hi), "n_boxes": s.n_boxes}
                for number, s in enumerate(self.solutions, start=1)],     # numbered as printed, from 1
            "statistics": self.stats.as_dict(),
        }
