"""What the stages hand over: frozen dataclasses and enums (no behaviour beyond small derived views).

The box loop (:mod:`spherekin.search.boxloop`) hands over :class:`AcceptedBox` es merged into
:class:`Cluster` s, in a :class:`SearchReport`; the trust layer (:mod:`spherekin.trust.solutions`)
turns clusters into :class:`Solution` s with a :class:`Status`; the pipeline
(:mod:`spherekin.problem`) returns a :class:`SolveReport`. :class:`Settings` and
:class:`SearchLimit` say how the search ran, :class:`SolverStats` what it cost, :class:`EmptyReason`
why a solve found nothing. The views of them every reader shares live here too: the results table
(:func:`solution_columns`, a :class:`ResultsTable`: ``SolveReport.frame()`` and every batch table)
and the number format of printed tables (:func:`format_number`).
"""

from __future__ import annotations

import collections.abc
import math
from dataclasses import asdict, dataclass, field, fields
from enum import StrEnum
from typing import Mapping, Sequence

import numpy as np

from .core.orientation import (QUATERNION_COLUMNS, ROTATION_COLUMNS, check_euler_convention,
                               quaternions_from_rotations)
from .core.columns import table_columns

__all__ = ["Cusp", "ModeChange", "Status", "SolverStats", "AcceptedBox", "Cluster", "Solution", "SolutionArrays", "solution_arrays", "LazySolutions", "box_near", "is_proven", "SearchLimit", "SearchStrategy", "Settings",
           "SearchReport", "SolveReport", "EmptyReason", "EMPTY_OUTSIDE_RANGES", "EMPTY_INCONSISTENT",
           "EMPTY_OUTSIDE_WORKSPACE", "format_number", "QUATERNION_COLUMNS", "ROTATION_COLUMNS", "table_columns",
           "solution_table", "solution_columns", "ResultsTable", "TABLE_DTYPES", "SINGULAR_SCHEMA", "SOLVE_SCHEMA", "AssemblyTolerance", "ToleranceReport", "SingularBox",
           "SingularStats", "SingularSet", "CrossCheck"]


def format_number(value, spec: str = "+.6f") -> str:
    """``value`` formatted with ``spec`` (a format spec, e.g. "+11.6f"), a value that prints as zero
    printed as +0 (never "-0.000000" for -1e-17 or -0.0): the one number format of every printed table."""
    text = format(float(value), spec)
    return format(0.0, spec) if float(text) == 0.0 else text


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
    ``residual``: the largest entry of ``|F_n - I|`` over the loops; ``singularity``: the mechanism's
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
        return quaternions_from_rotations(self.platform_rotation)

    def euler(self, convention: str = "ZYX") -> np.ndarray | None:
        """The platform rotation as Euler angles (radians) in ``convention`` (upper case intrinsic,
        lower case extrinsic; see :mod:`spherekin.core.orientation`), or None without a rotation."""
        if self.platform_rotation is None:
            return None
        from scipy.spatial.transform import Rotation

        return Rotation.from_matrix(self.platform_rotation).as_euler(check_euler_convention(convention))

    def __repr__(self) -> str:
        angles = ", ".join(f"{n}={format_number(a)}" for n, a in self.passive_angles.items()) or \
            ", ".join(format_number(a) for a in self.angles)
        res = "" if self.residual is None else f", residual={self.residual:.1e}"
        return f"Solution({self.status}, {angles}{res}, {self.singularity or 'unclassified'})"


@dataclass(frozen=True, eq=False)
class SolutionArrays:
    """The columns of a report's entries that the results table reads (docs/results-format.md), one
    row per entry, in the entries' order: ``angles`` (R, M) radians in the order of the report's
    unknowns; ``status`` and ``singularity`` (R,) strings (objects; None where unclassified);
    ``residual`` (R,) (NaN where none); ``rotations`` (R, 3, 3) platform rotations (NaN where none).
    What :class:`LazySolutions` hands a table without building a :class:`Solution` per entry."""

    angles: np.ndarray
    status: np.ndarray
    singularity: np.ndarray
    residual: np.ndarray
    rotations: np.ndarray

    @classmethod
    def of(cls, solutions: Sequence[Solution], width: int) -> "SolutionArrays":
        """The columns of ``solutions`` (Solution objects with ``width`` angles each)."""
        nan_rot = np.full((3, 3), np.nan)
        return cls(np.array([np.asarray(s.angles, dtype=float) for s in solutions], dtype=float).reshape(-1, width),
                   _objects([str(s.status) for s in solutions]), _objects([s.singularity for s in solutions]),
                   np.array([np.nan if s.residual is None else float(s.residual) for s in solutions], dtype=float),
                   np.array([nan_rot if s.platform_rotation is None else np.asarray(s.platform_rotation, dtype=float)
                             for s in solutions], dtype=float).reshape(-1, 3, 3))

    def take(self, index) -> "SolutionArrays":
        """The rows ``index`` (a slice or an index array), in that order."""
        return SolutionArrays(self.angles[index], self.status[index], self.singularity[index], self.residual[index],
                              self.rotations[index])


def _objects(values) -> np.ndarray:
    """``values`` as a 1-D object array (strings and None stay Python objects)."""
    out = np.empty(len(values), dtype=object)
    out[:] = values
    return out


def solution_arrays(solutions: Sequence[Solution], width: int) -> SolutionArrays:
    """The table columns of a report's entries: read from the arrays behind :class:`LazySolutions`
    (no Solution built), else from the Solution objects (``width``: angles per entry)."""
    if isinstance(solutions, LazySolutions) and solutions.arrays is not None:
        return solutions.arrays()
    return SolutionArrays.of(solutions, width)


class LazySolutions(collections.abc.Sequence):
    """The entries of one report, built only when read (issue 44: results for many inputs without an
    object per solution until someone asks for one): ``count`` entries, ``build()`` makes them all (a
    tuple of :class:`Solution`), called once, on the first access other than ``len``. Equal to a
    tuple of the same entries; pickled as that tuple. ``arrays()``, when given: their table columns
    (:class:`SolutionArrays`, the same entries in the same order) without building them."""

    def __init__(self, count: int, build, arrays=None):
        self._count = int(count)
        self._build = build
        self.arrays = arrays
        self._items: tuple | None = None

    def _all(self) -> tuple:
        if self._items is None:
            self._items = tuple(self._build())
            self._build = None
            if len(self._items) != self._count:
                raise RuntimeError(f"LazySolutions: built {len(self._items)} entries, expected {self._count}")
        return self._items

    def __len__(self) -> int:
        return self._count

    def __getitem__(self, index):
        return self._all()[index]

    def __iter__(self):
        return iter(self._all())

    def __eq__(self, other) -> bool:
        if isinstance(other, (tuple, list, LazySolutions)):
            return self._all() == tuple(other)
        return NotImplemented

    def __hash__(self):
        return hash(self._all())

    def __repr__(self) -> str:
        return repr(self._all())

    def __reduce__(self):
        return (tuple, (self._all(),))


def is_proven(sol: Solution) -> bool:
    """Whether an entry is a root proven by a certificate (it counts towards an exact count)."""
    return sol.status == Status.CERTIFIED or (sol.status == Status.SINGULAR and bool(sol.evidence.get("krawczyk_certified")))


def _in_order(readings: dict, mechanism) -> dict:
    """``readings`` (joint name -> radians) in the order the mechanism's file lists its joints
    (as given when the mechanism is not known)."""
    names = getattr(mechanism, "joint_names", ())
    return {**{n: readings[n] for n in names if n in readings}, **readings}


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

    def text(self) -> str:
        """What stopped the search, in a few words, with the tolerances: "interrupted (Ctrl-C)", or "the
        search at tol 1e-08 hit its cap; covered at tol 0.01 instead"."""
        if self.interrupted:
            return "interrupted (Ctrl-C)"
        covered = (f"covered at tol {self.covering_tol:g} instead" if self.covering_error is None
                   else f"the covering at tol {self.covering_tol:g} hit its cap too")
        return f"the search at tol {self.tol:g} hit its cap; {covered}"


@dataclass(frozen=True)
class SearchStrategy:
    """The strategy of a search, its names as resolved (radians for ``tol``): ``formulation``, ``pruner``,
    ``lp_backend`` (None: the pruner's default), ``parameterization``, ``tol``, ``isolate``, ``jobs``.
    The one place these fields are written: :class:`Settings` (how a solve ran) and
    :class:`spherekin.systems.Strategy` (how a problem is compiled) extend it."""

    formulation: str
    pruner: str
    lp_backend: str | None
    parameterization: str
    tol: float
    isolate: bool
    jobs: int


@dataclass(frozen=True)
class Settings(SearchStrategy):
    """How a search or solve ran: the :class:`SearchStrategy` as it ran, then

    the search's ``charts``. A solve adds ``mechanism``
    (its name), ``actuated`` and ``inputs`` (radians), and when they happened ``fallback`` (why
    the loop equations answered instead of the platform formulation), ``limit``
    (:class:`SearchLimit`) and ``refined_searches`` (clusters searched again at a finer tol). A
    solve also says which ``system`` of equations solved it (:data:`spherekin.systems.SYSTEMS`) and
    ``declined``: (system name, reason) of every faster system that did not accept the mechanism
    or the strategy (empty when the fastest solved it, or a system was asked for by name).
    """

    charts: int
    mechanism: str | None = None
    actuated: tuple = ()
    inputs: tuple = ()
    fallback: str | None = None
    limit: SearchLimit | None = None
    refined_searches: int = 0
    system: str | None = None
    declined: tuple = ()

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
        if self.system is None:
            del out["system"], out["declined"]
        else:
            out["declined"] = [{"system": name, "reason": reason} for name, reason in self.declined]
        return out

    def system_text(self, verbose: bool = False) -> str:
        """One line: which system solved it; with ``verbose``, why each faster one did not accept (those
        reasons speak of the systems' own terms, legs for the platform system: the default line keeps to
        the file's; they are always in the JSON's ``declined``)."""
        if self.system is None:
            return ""
        why = "; ".join(f"{name} did not accept it: {reason}" for name, reason in self.declined) if verbose else ""
        return f"solved by the {self.system} system" + (f" ({why})" if why else "")


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


#: The kinds of :class:`EmptyReason`: assemblies exist once the passive joints' ranges are lifted;
#: none exist (a redundantly actuated mechanism given inputs that do not fit together); none exist
#: (the inputs lie outside the workspace: the loops cannot be closed).
EMPTY_OUTSIDE_RANGES = "outside_ranges"
EMPTY_INCONSISTENT = "inconsistent_inputs"
EMPTY_OUTSIDE_WORKSPACE = "outside_workspace"


@dataclass(frozen=True)
class EmptyReason:
    """Why a solve found no assembly (:meth:`spherekin.problem.Problem.explain_empty`; the JSON's
    ``empty_reason``): ``kind`` (one of the EMPTY_* names), ``ranged_joints`` (the passive joints
    with a range), ``assemblies_without_ranges`` (entries of the solve with those ranges lifted:
    > 0 exactly for kind "outside_ranges")."""

    kind: str
    ranged_joints: tuple[str, ...] = ()
    assemblies_without_ranges: int = 0

    def text(self) -> str:
        """The sentence the CLI prints."""
        if self.kind == EMPTY_OUTSIDE_RANGES:
            n = self.assemblies_without_ranges
            return (f"no assembly inside the joint ranges; {n} assembl{'y' if n == 1 else 'ies'} exist with the "
                    f"passive joints unlimited (ranges set on {', '.join(self.ranged_joints)})")
        if self.kind == EMPTY_INCONSISTENT:
            return ("no assembly at all at these inputs: for a redundantly actuated mechanism, inputs that are not "
                    "consistent with one another")
        return "no assembly at all at these inputs: the loops cannot be closed (the inputs lie outside the workspace)"

    def as_dict(self) -> dict:
        return {"kind": self.kind, "ranged_joints": list(self.ranged_joints),
                "assemblies_without_ranges": self.assemblies_without_ranges, "note": self.text()}


@dataclass(frozen=True)
class AssemblyTolerance:
    """What the tolerances do to one assembly of the nominal input (:mod:`spherekin.trust.tolerances`;
    the JSON's ``tolerances.assemblies``, the same names). Radians.

    ``solution``: its number among the report's entries (from 1, as printed);
    ``worst_case_rotation_error``: a proven upper bound on the rotation angle between the nominal
    platform rotation and this assembly's, for every geometry and input within the tolerances (None:
    not proven, ``reason`` says why); ``worst_case_rotation_error_lower_bound``: the error of one
    geometry within the tolerances, solved (the linearized worst case: every axis tilted to its rim in
    the direction that moves the platform most), so the truth lies between the two;
    ``linear_worst_case``: the linearized maximum itself; ``enclosure_radius``: the radius (tan of
    half the rotation angle, per component) of the box proven to hold this assembly, and no other
    root, for every geometry within the tolerances; ``worst_case_geometry``: the geometry that reaches
    the lower bound (``axes``: joint name -> axis, base frame at the reference configuration;
    ``inputs``: actuated joint -> radians), to build and check; ``worst_case_joint_error`` (on the loop
    equations: any mechanism): passive joint -> a proven bound on how far its reading can be from the
    nominal one, and ``worst_case_joint_error_lower_bound`` the same for one geometry solved, per joint.
    """

    solution: int
    worst_case_rotation_error: float | None
    worst_case_rotation_error_lower_bound: float | None = None
    linear_worst_case: float | None = None
    enclosure_radius: tuple | None = None
    reason: str | None = None
    worst_case_geometry: Mapping | None = None
    worst_case_joint_error: Mapping | None = None
    worst_case_joint_error_lower_bound: Mapping | None = None

    @property
    def tightness(self) -> float | None:
        """Certified bound / searched lower bound (>= 1; None when either is missing or the lower is 0)."""
        up, lo = self.worst_case_rotation_error, self.worst_case_rotation_error_lower_bound
        return None if up is None or not lo else up / lo

    def as_dict(self) -> dict:
        return {"solution": self.solution, "worst_case_rotation_error": self.worst_case_rotation_error,
                "worst_case_rotation_error_lower_bound": self.worst_case_rotation_error_lower_bound,
                "linear_worst_case": self.linear_worst_case,
                "enclosure_radius": None if self.enclosure_radius is None else list(self.enclosure_radius),
                "tightness": self.tightness, "reason": self.reason, "worst_case_geometry": self.worst_case_geometry,
                "worst_case_joint_error": self.worst_case_joint_error,
                "worst_case_joint_error_lower_bound": self.worst_case_joint_error_lower_bound}


@dataclass(frozen=True)
class ToleranceReport:
    """The mechanism as built at one input (:mod:`spherekin.trust.tolerances`; the JSON's
    ``tolerances``, the same names): ``tolerances`` the tolerances analysed (``axes_deg``,
    ``inputs_deg``, ``joints``); ``count_constant_over_tolerances``: True only when proven (no assembly
    appears, vanishes or meets another for any geometry and input within them), False when a singular
    configuration is proven within them, None when undecided; ``count_reason`` says how, or why not;
    ``assemblies``: one :class:`AssemblyTolerance` per entry of the report, in its order;
    ``count_witnesses``: where the count is proven to change, the two geometries (``axes``, ``inputs``, as
    :attr:`AssemblyTolerance.worst_case_geometry`) whose proven counts differ, to build and check."""

    tolerances: Mapping
    count_constant_over_tolerances: bool | None
    count_reason: str
    assemblies: tuple = ()
    count_witnesses: tuple = ()

    @classmethod
    def uncovered(cls, tolerances: Mapping, why: str, entries: int) -> "ToleranceReport":
        """The report of a mechanism an analysis does not cover: ``why`` for the count and each of ``entries``."""
        return cls(tolerances, None, why, tuple(AssemblyTolerance(k, None, reason=why) for k in range(1, entries + 1)))

    @property
    def worst_case_rotation_error(self) -> float | None:
        """The largest proven bound over the assemblies (radians; None when one is not proven or there are none)."""
        values = [a.worst_case_rotation_error for a in self.assemblies]
        return None if not values or any(v is None for v in values) else max(values)

    def text(self) -> str:
        """The lines the CLI prints under the solutions' table."""
        t = self.tolerances
        joints = "".join(f", {n} {v:g} deg" for n, v in dict(t.get("joints", {})).items())
        head = f"under tolerances (axes {t['axes_deg']:g} deg{joints}, inputs {t['inputs_deg']:g} deg): "
        verdict = {True: "count constant (proven)", False: "count NOT constant (a singular configuration within "
                   "the tolerances is proven)", None: "count not proven constant"}[self.count_constant_over_tolerances]
        lines = [head + verdict + f": {self.count_reason}"]
        for a in self.assemblies:
            if a.worst_case_joint_error is not None:
                joints = ", ".join(f"{n} <= {v:.3e}" + ("" if a.worst_case_joint_error_lower_bound.get(n) is None else
                                                         f" (reached {a.worst_case_joint_error_lower_bound[n]:.3e})")
                                   for n, v in a.worst_case_joint_error.items())
                rot = ("" if a.worst_case_rotation_error is None else
                       f"; output rotation <= {a.worst_case_rotation_error:.3e}" +
                       ("" if a.worst_case_rotation_error_lower_bound is None else
                        f" (reached {a.worst_case_rotation_error_lower_bound:.3e})"))
                lines.append(f"  solution {a.solution}: worst-case joint error (rad) {joints}{rot}")
            elif a.worst_case_rotation_error is None:
                lines.append(f"  solution {a.solution}: worst-case rotation error not proven ({a.reason})")
            else:
                lines.append(f"  solution {a.solution}: worst-case rotation error <= {a.worst_case_rotation_error:.3e} rad "
                             f"({math.degrees(a.worst_case_rotation_error):.4f} deg; a geometry within the tolerances "
                             f"reaches {a.worst_case_rotation_error_lower_bound:.3e} rad)")
        return "\n".join(lines)

    def as_dict(self) -> dict:
        return {"tolerances": dict(self.tolerances), "count_constant_over_tolerances": self.count_constant_over_tolerances,
                "count_reason": self.count_reason, "worst_case_rotation_error": self.worst_case_rotation_error,
                "assemblies": [a.as_dict() for a in self.assemblies], "count_witnesses": list(self.count_witnesses)}


#: The pandas dtype of each kind of column of a results table (:class:`ResultsTable`): ``int64``
#: (``input``), ``float64`` (NaN: empty), ``Int64`` (``solution``: whole numbers, None empty) and
#: ``string`` (``status``, ``singularity``: None empty).
TABLE_DTYPES = ("int64", "float64", "Int64", "string")


@dataclass(frozen=True, eq=False)
class ResultsTable:
    """The results table (docs/results-format.md) as columns, built without pandas: what a batch
    hands from a solve to its output (importing pandas costs a process ~0.3 s; a CSV output is
    written from these columns, :mod:`spherekin.batch.sinks`). ``columns``: the names; ``data``: one
    array per column, all of one length (rows): int64, float64 (NaN: empty) or object (Python ints
    or strs; None: empty); ``dtypes``: each column's kind (:data:`TABLE_DTYPES`, the dtype of its
    column in :meth:`frame`)."""

    columns: tuple[str, ...]
    data: tuple[np.ndarray, ...]
    dtypes: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.data[0]) if self.data else 0

    def __getitem__(self, name: str) -> np.ndarray:
        """The column ``name`` (an array of the table's length)."""
        return self.data[self.columns.index(name)]

    def with_columns(self, columns, data, dtypes) -> "ResultsTable":
        """This table with more columns (names, arrays of its length, kinds of :data:`TABLE_DTYPES`) last."""
        return ResultsTable(self.columns + tuple(columns), self.data + tuple(data), self.dtypes + tuple(dtypes))

    def frame(self):
        """The table as a pandas DataFrame (the dtypes of ``dtypes``)."""
        import pandas as pd

        def column(values, dtype):
            return pd.array(values.tolist(), dtype=dtype) if dtype in ("Int64", "string") else values

        return pd.DataFrame({n: column(v, d) for n, v, d in zip(self.columns, self.data, self.dtypes)},
                            columns=list(self.columns))

    @staticmethod
    def concat(tables: "Sequence[ResultsTable]") -> "ResultsTable":
        """The rows of ``tables`` (at least one, all with the same columns), in their order."""
        first = tables[0]
        return ResultsTable(first.columns, tuple(np.concatenate([t.data[k] for t in tables])
                                                 for k in range(len(first.columns))), first.dtypes)


def solution_columns(actuated, unknowns, items, measures=None) -> ResultsTable:
    """The results table (:class:`ResultsTable`; docs/results-format.md) of ``items``: (input index,
    its inputs (radians, one per name of ``actuated``), the names of its solutions' angles, its
    solutions) each; one row per solution, passive angles in the order of ``unknowns``; an input
    without solutions gets one row with empty solution columns. ``measures(joint_angles)``: the
    ``parallel_measure`` of every solution at once (name -> array of radians; returns an array; NaN
    without it or where it raises ValueError). Built here once for :meth:`SolveReport.frame` and every batch table
    (:mod:`spherekin.batch.rows`), so the columns cannot drift apart."""
    names, actuated = list(unknowns), list(actuated)
    idx, sol, has, inp, blocks = [], [], [], [], []
    for index, row, their_names, solutions in items:
        row = np.asarray(row, dtype=float)
        arr = solution_arrays(solutions or (), len(their_names))
        if tuple(their_names) != tuple(names):
            arr = SolutionArrays(arr.angles[:, [list(their_names).index(n) for n in names]], arr.status,
                                 arr.singularity, arr.residual, arr.rotations)
        r = len(arr.residual)
        rows = max(r, 1)                       # an input without solution keeps one row, its solution columns empty
        if rows > r:
            arr = SolutionArrays(np.full((1, len(names)), np.nan), _objects([None]), _objects([None]),
                                 np.full(1, np.nan), np.full((1, 3, 3), np.nan))
        idx.append(np.full(rows, index, dtype=np.int64))
        sol += list(range(1, r + 1)) + [None] * (rows - r)     # numbered from 1, as printed tables and the JSON
        has.append(np.arange(rows) < r)
        inp.append(np.broadcast_to(row, (rows, len(actuated))))
        blocks.append(arr)
    has = np.concatenate(has) if has else np.zeros(0, dtype=bool)
    idx = np.concatenate(idx) if idx else np.zeros(0, dtype=np.int64)
    sol = _objects(sol)
    inp = np.concatenate(inp).astype(float) if inp else np.zeros((0, len(actuated)))
    angles = np.concatenate([b.angles for b in blocks]) if blocks else np.zeros((0, len(names)))
    status = np.concatenate([b.status for b in blocks]) if blocks else _objects([])
    sing = np.concatenate([b.singularity for b in blocks]) if blocks else _objects([])
    resid = np.concatenate([b.residual for b in blocks]) if blocks else np.zeros(0)
    rots = np.concatenate([b.rotations for b in blocks]) if blocks else np.zeros((0, 3, 3))
    meas = np.full(len(has), np.nan)
    if measures is not None and has.any():
        joints = {**{n: inp[has, j] for j, n in enumerate(actuated)}, **{n: angles[has, j] for j, n in enumerate(names)}}
        try:
            meas[has] = measures(joints)
        except ValueError:                 # a joint the loop equations do not carry: no Jacobian
            pass
    quats = np.full((len(rots), 4), np.nan)
    known = np.isfinite(rots).all(axis=(1, 2))
    if known.any():
        quats[known] = quaternions_from_rotations(rots[known])

    flat = rots.reshape(-1, 9)
    data = {"input": (idx, "int64")}
    data.update({n: (inp[:, j].copy(), "float64") for j, n in enumerate(actuated)})
    data["solution"] = (sol, "Int64")
    data["status"] = (status, "string")
    data.update({n: (angles[:, j], "float64") for j, n in enumerate(names)})
    data.update({c: (quats[:, j], "float64") for j, c in enumerate(QUATERNION_COLUMNS)})
    data.update({c: (flat[:, j], "float64") for j, c in enumerate(ROTATION_COLUMNS)})
    data["residual"] = (resid, "float64")
    data["singularity"] = (sing, "string")
    data["parallel_measure"] = (np.array(meas, dtype=float), "float64")
    cols = table_columns(actuated, names)
    return ResultsTable(tuple(cols), tuple(data[c][0] for c in cols), tuple(data[c][1] for c in cols))


def solution_table(actuated, unknowns, items, measures=None):
    """The results table of :func:`solution_columns` as a pandas DataFrame."""
    return solution_columns(actuated, unknowns, items, measures).frame()


@dataclass(frozen=True)
class SolveReport:
    """Everything a solve returns: the unknowns' names, the solutions, the raw boxes, statistics.

    ``proven_count``: the number of solutions proven by a certificate (status ``certified``, or
    ``singular`` with ``krawczyk_certified`` in its evidence); ``count_exact``: True when that is
    every entry, so the count is exact; False when it is a lower bound ("at least").
    ``mechanism``: the mechanism solved (None when not known); ``empty_reason``: why there is no
    solution (:class:`EmptyReason`; None when there are solutions, or when not asked for).

    :meth:`frame` is a DataFrame of the solutions, :meth:`as_dict` the JSON. To draw them:
    ``spherekin.plot.plot_report(report, path=None)`` returns the matplotlib Figure (plotting is
    an interface, a layer above this hand-over type, so the report has no ``plot`` method).
    """

    unknowns: tuple[str, ...]
    solutions: Sequence[Solution]          # a tuple, or LazySolutions (built when read)
    boxes: tuple[AcceptedBox, ...]
    stats: SolverStats
    settings: Settings
    proven_count: int
    count_exact: bool
    mechanism: object = field(default=None, repr=False, compare=False)
    empty_reason: EmptyReason | None = None
    tolerances: ToleranceReport | None = None

    def frame(self):
        """The solutions as a pandas DataFrame, one row per solution, in the columns of a batch's
        results table (docs/results-format.md; :func:`solution_table`): ``input`` (0), the actuated
        joints and ``solution`` (index among the entries), ``status``, the passive angles, ``qw ...
        qz``, ``r11 ... r33``, ``residual``, ``singularity``, ``parallel_measure`` (NaN when the
        report does not hold its mechanism). Angles in radians. A report without solutions gives one
        row with empty solution columns, as a batch does."""
        mech = self.mechanism
        names = self.unknowns if mech is None else mech.loop_unknowns
        measures = None if mech is None else mech.parallel_measures
        return solution_table(self.settings.actuated, names,
                              [(0, self.settings.inputs, self.unknowns, self.solutions)], measures)

    def __repr__(self) -> str:
        return (f"SolveReport({self.count_text()}; {len(self.solutions)} entries over {', '.join(self.unknowns)}; "
                f"{self.settings.formulation}, {self.stats.time_total:.3f} s)")

    def _repr_html_(self) -> str:
        """A notebook's view: the count and one table row per solution."""
        from html import escape

        head = "".join(f"<th>{escape(n)}</th>" for n in ("#", *self.unknowns, "status", "residual", "singularity"))
        rows = []
        for i, s in enumerate(self.solutions, start=1):
            cells = [str(i), *(format_number(a) for a in s.angles), str(s.status),
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
        capped = "" if limit is None else f"; {limit.text()}"
        if not self.solutions and limit is not None:
            stopped = limit.text()
            return f"no solution found before the search stopped ({stopped}): the count is not known"
        return f"at least {n} {word} proven (count not exact: {listed or 'none listed'}{capped}; see the status column)"

    def table(self, degrees: bool = False) -> str:
        """A readable table of the solutions (angles in radians, or degrees)."""
        scale = 180.0 / np.pi if degrees else 1.0
        head = "  #  " + " ".join(f"{name:>11s}" for name in self.unknowns) + "  boxes"
        head += "   residual  status      singularity"
        rows = [head]
        for i, s in enumerate(self.solutions, start=1):
            row = f"{i:3d}  " + " ".join(format_number(a * scale, "+11.6f") for a in s.angles) + f"  {s.n_boxes:5d}"
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
            "schema": SOLVE_SCHEMA,
            "spherekin_version": __version__,
            "settings": self.settings.as_dict(),
            "unknowns": list(self.unknowns),
            "count": {"proven": self.proven_count, "exact": self.count_exact, "entries": len(self.solutions)},
            "solutions": [
                {"number": number, "passive_angles": dict(zip(self.unknowns, arr(s.angles))),
                 "joint_angles": _in_order({**actuated, **dict(zip(self.unknowns, arr(s.angles)))}, self.mechanism),
                 "platform_rotation": arr(s.platform_rotation), "residual": s.residual,
                 "singularity": s.singularity, "status": str(s.status), "evidence": s.evidence,
                 "box_lo": arr(s.box_lo), "box_hi": arr(s.box_hi), "n_boxes": s.n_boxes}
                for number, s in enumerate(self.solutions, start=1)],     # numbered as printed, from 1
            "statistics": self.stats.as_dict(),
            **({} if self.empty_reason is None else {"empty_reason": self.empty_reason.as_dict()}),
            **({} if self.tolerances is None else {"tolerances": self.tolerances.as_dict()}),
        }


#: Schema tag of the singular-set JSON (docs/results-format.md).
SINGULAR_SCHEMA = "spherekin.singular/1"
#: The schema of a solve's JSON (docs/results-format.md). /3: the optional ``tolerances`` key (issue 45).
SOLVE_SCHEMA = "spherekin.solve/3"


class CuspSearch(StrEnum):
    """What the cusp list of a :class:`SingularSet` covers (JSON ``cusp_search``).

    * ``searched``: the platform system in a plane of two inputs: every cusp of the plane is in the list,
      proven (``cusp``) or as an ``unresolved`` candidate;
    * ``none_possible``: one loop in a plane of two inputs: no cusp exists (its 3 passive joints close a
      spherical 3R chain, at most 2 assemblies or a continuum, so three never meet), the list is empty;
    * ``not_searched``: the loop equations of several loops in a plane: cusps may exist and are not searched
      (the list is empty, which proves nothing);
    * ``not_applicable``: a line of one input (its singular set is points; cusps are points of a curve).
    """

    SEARCHED = "searched"
    NONE_POSSIBLE = "none_possible"
    NOT_SEARCHED = "not_searched"
    NOT_APPLICABLE = "not_applicable"


@dataclass(frozen=True)
class CrossCheck:
    """A singular set held against proven counts (issue 40 item 3): outside its cells the count cannot change,
    so two inputs between the same two cells (a *free interval* of a line, or two neighbours of a map's grid)
    with different proven counts prove the cover wrong. ``samples``: inputs solved (or grid points read);
    ``proven``: of them with an exact count; ``disagreements``: ((x lo, x hi, y lo, y hi), (count, count)) per
    pair of inputs (radians; y None on a line) whose proven counts differ with no cell between them: the cover
    is then not complete. ``skipped``: why no check ran (None when it ran)."""

    samples: int = 0
    proven: int = 0
    disagreements: tuple = ()
    skipped: str | None = None

    def text(self) -> str:
        """One line for the command line's report."""
        if self.skipped:
            return f"cross-check: not run ({self.skipped})"
        if not self.disagreements:
            return f"cross-check: the proven counts at {self.proven} of {self.samples} inputs agree with the cells"
        (x0, x1, y0, y1), (a, b) = self.disagreements[0]
        at = f"x in [{x0:.6g}, {x1:.6g}]" + ("" if y0 is None else f", y in [{y0:.6g}, {y1:.6g}]")
        return (f"cross-check: DISAGREES: proven counts {a} and {b} at {at} with no cell between them "
                f"({len(self.disagreements)} such pair(s)): a singular input was missed, the set is not complete")

    def as_dict(self) -> dict:
        return {"samples": self.samples, "proven": self.proven, "skipped": self.skipped,
                "disagreements": [{"between": [float(v) if v is not None else None for v in box],
                                   "counts": [int(k) for k in counts]} for box, counts in self.disagreements]}


@dataclass(frozen=True)
class SingularBox:
    """A cell of the plane in the cover of the singular set: ``x``, ``y`` = (lo, hi) radians (``y`` None
    on a line); ``status``: "singular" (a singular configuration is proven at an input of the cell) or
    "unresolved" (no proof either way)."""

    x: tuple
    y: tuple | None
    status: str


@dataclass(frozen=True)
class Cusp:
    """A cusp of the singular curve in the plane (three assemblies meet): ``x``, ``y`` its inputs (radians;
    Newton's root of the cusp system), ``box_x``, ``box_y`` = (lo, hi) radians: the plane projection of
    the box in which the certificate proved a unique root; ``status``: "cusp" (a unique root of the curve
    system plus its tangency condition, with the spurious factor excluded) or "unresolved"."""

    x: float
    y: float
    box_x: tuple
    box_y: tuple
    status: str

    def as_dict(self) -> dict:
        return {"x": float(self.x), "y": float(self.y),
                "box": {"x": [float(self.box_x[0]), float(self.box_x[1])],
                        "y": [float(self.box_y[0]), float(self.box_y[1])]}, "status": self.status}


@dataclass(frozen=True)
class ModeChange:
    """A proven assembly-mode change around a cusp (issue 31 item 5), or the record of a search that found none.

    ``found``; ``cusp`` (x, y) radians (None if not found); ``radius`` of the circle of inputs around it;
    ``path`` (K, number of actuated joints) radians, closed (last row = first); ``start_solution`` and
    ``end_solution``: the solutions (numbered from 1) of the solve at path[0] where the track starts and
    where it comes back (different); ``proven_steps``; ``searched``: what was tried (cusps, radii, starts);
    ``start_pose``, ``end_pose``: the platform rotations (3, 3) at path[0] where the track starts and ends;
    ``columns``: the path's columns (the actuated joints' names)."""

    found: bool
    cusp: tuple | None
    radius: float | None
    path: np.ndarray | None = field(repr=False)
    start_solution: int | None
    end_solution: int | None
    proven_steps: int
    searched: dict
    start_pose: np.ndarray | None = field(default=None, repr=False)
    end_pose: np.ndarray | None = field(default=None, repr=False)
    columns: tuple = ()

    def as_dict(self) -> dict:
        return {"found": self.found,
                "start_pose": None if self.start_pose is None else np.asarray(self.start_pose).tolist(),
                "end_pose": None if self.end_pose is None else np.asarray(self.end_pose).tolist(), "cusp": None if self.cusp is None else [float(v) for v in self.cusp],
                "radius": self.radius, "path": None if self.path is None else np.asarray(self.path).tolist(),
                "start_solution": self.start_solution, "end_solution": self.end_solution,
                "proven_steps": self.proven_steps, "searched": dict(self.searched), "columns": list(self.columns)}


@dataclass(frozen=True)
class SingularStats:
    """What a singular-set search cost: boxes processed by the box loop, accepted and pending boxes (in
    the augmented system's variables), seconds: ``seconds_cover`` in the box loops, ``seconds_certify``
    the rest (compiling the system, projecting, the certificates), ``seconds`` the total; ``crowded``: boxes
    set aside in crowded cells (unresolved regions; :data:`spherekin.singularities.cells.CROWDED_CELL`)."""

    boxes_processed: int
    accepted: int
    pending: int
    seconds_cover: float
    seconds_certify: float
    seconds: float
    crowded: int = 0


@dataclass(frozen=True)
class SingularSet:
    """The parallel (Type-2) singular set of a mechanism in a plane of inputs (issue 31).

    ``x``, ``y``: (name, lo, hi) of the plane's inputs (radians; ``y`` None for a line); ``fixed``: the
    other actuated joints' readings; ``tol``: the cells' width bound (radians); ``boxes``: the covered
    cells (:class:`SingularBox`); everything in the plane outside them is proven free of parallel
    singularities when ``complete``, and also when not (then the unprocessed part is in ``unresolved``
    regions: boxes wider than a cell, the plane projections of the boxes left pending at the cap). ``cusps``: the curve's cusps (:class:`Cusp`; platform systems in a plane, else empty), and
    ``cusp_search`` what that list covers (:class:`CuspSearch`). ``system``: the equations used ("platform"
    or "loops"). ``stopped``: why the run ended before its work was done ("box cap", "memory cap", "SIGINT",
    "SIGTERM"), None when it finished; ``complete`` is False then. ``cross_check``: the set held against proven
    counts (:class:`CrossCheck`; a line's free intervals, by :func:`spherekin.singular`; a map's grid, by the
    map); a disagreement makes ``complete`` False.
    """

    x: tuple
    y: tuple | None
    fixed: Mapping
    tol: float
    boxes: tuple
    complete: bool
    stats: SingularStats
    system: str
    cusps: tuple = ()
    cusp_search: CuspSearch = CuspSearch.NOT_SEARCHED
    free_box: object = None
    mode_change: object = None
    stopped: str | None = None
    cross_check: CrossCheck | None = None

    def counts(self) -> dict:
        """Boxes by status: {"singular": n, "unresolved": m}."""
        out = {"singular": 0, "unresolved": 0}
        for b in self.boxes:
            out[b.status] = out.get(b.status, 0) + 1
        return out

    def as_dict(self) -> dict:
        """The JSON document (schema SINGULAR_SCHEMA, docs/results-format.md): plain floats, radians."""
        return {"schema": SINGULAR_SCHEMA, "x": self.x[0], "y": None if self.y is None else self.y[0],
                "x_range": [float(self.x[1]), float(self.x[2])],
                "y_range": None if self.y is None else [float(self.y[1]), float(self.y[2])],
                "fixed": {k: float(v) for k, v in self.fixed.items()}, "tol": float(self.tol),
                "system": self.system, "complete": bool(self.complete), "stopped": self.stopped,
                "boxes": [{"x": [float(b.x[0]), float(b.x[1])],
                           "y": None if b.y is None else [float(b.y[0]), float(b.y[1])], "status": b.status}
                          for b in self.boxes],
                "cusps": [c.as_dict() for c in self.cusps], "cusp_search": str(self.cusp_search),
                "free_box": self.free_box,
                "mode_change": None if self.mode_change is None else self.mode_change.as_dict(),
                "cross_check": None if self.cross_check is None else self.cross_check.as_dict(),
                "stats": asdict(self.stats)}
