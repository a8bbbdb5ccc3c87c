"""Branches and circuits of a one-degree-of-freedom linkage: every assembly over its one input.

A mechanism with one actuated joint (a spherical four-bar, a Watt six-bar, ...) has, at each input
u, a finite set of assemblies (the passive joint readings q). As u moves, each assembly moves
continuously, until it meets another one at a *branch point*: a parallel singularity (det K_p = 0,
K_p the passive Jacobian of the loop equations, :meth:`~spherekin.mechanism.SphericalMechanism.jacobians`)
where two assemblies meet and vanish, the input turning back there. A *branch* is an assembly
followed over an input interval without meeting one; a *circuit* is a maximal set of branches joined
at branch points (and, for a full-turn input, across the wrap from +pi to -pi): the solutions the
linkage can reach from one another without disassembly. A circuit that covers the whole input
circle without a branch point is a *crank* circuit.

Method (:func:`branch_map`):

1. solve (``spherekin.compile(mech).solve_many``) over a grid of inputs: the input joint's range, or
   a full turn (the grid wraps around: its last interval ends at its first input plus 2 pi);
2. connect the solutions of consecutive inputs (a :data:`Connector`; the default,
   :class:`NearestConnector`, continues each solution to the nearest one of the next input after a
   first-order prediction along the curve, when that is unambiguous); an interval where the match is
   ambiguous, or where the count changes, is halved (one solve at its midpoint) until it is not,
   or, for a count change (by 2 k: k pairs of assemblies meet), until it is :data:`BISECT_TOL` wide
   (bisection on the input); an ambiguous interval that narrow is matched to the nearest when it lies
   next to a count change (the two assemblies meeting at that branch point are too close there for a
   clear match, and end in one circuit either way), else reported unresolved (branches crossing);
3. locate each branch point: from the bisected bracket, Newton (Gauss-Newton, least squares) on the
   augmented system (the loop equations, F_n - I = 0 of every loop, and det K_p = 0) in the passive
   readings and the input, to :data:`NEWTON_STEP_TOL`;
4. hold the located branch points against the certified singular cover of the input's line
   (:func:`spherekin.singular` at :data:`COVER_TOL`, step 0 below): a branch point of a one-input
   linkage is a parallel-singular input, and outside the cover's cells the count is proven constant
   (:func:`cross_check`). A located branch point outside every cell is a *disagreement* (reported,
   never dropped: one of the two is wrong); a part of the cover no located branch point accounts for
   (:data:`COVER_EXPLAINS` cells around each) is turned *unresolved*: a pair of branch points closer
   than the sampling may lie there, so the branches are cut there and no circuit is joined across it.
   The resolution left: branch points within :data:`COVER_EXPLAINS` T of a located one are taken
   for it (as two closer than :data:`BISECT_TOL` are by the bisection);
5. join branches into circuits (union-find over branch points and the wrap).

Step 0, before the first solve: the cover, and the edges of its runs of adjacent cells added to the
grid (up to :data:`COVER_SAMPLES`), so that a count change the grid steps over is seen at a run's
edges and bisected (a pair of branch points a grid step apart is then located, not only flagged);
only a pair inside one run of cells stays unresolved. The step is skipped with ``cover_tol=None``
(then nothing says the sampling lost no pair).

The connect step is a function of two consecutive samples only (:data:`Connector`), so a certified
continuation on the loop equations (:mod:`spherekin.trust.loop_continuation`) can take the place of
the nearest-neighbour rule: measured on examples/stephenson_six_bar.toml it gave the same circuits
at twice the time (its steps next to a fold are short), so it is not the default.

JSON: :meth:`BranchMap.as_dict` (schema :data:`BRANCHES_SCHEMA`, docs/results-format.md).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Callable, Sequence

import numpy as np

from ..core.groups import connected_groups

from ..core.angles import TWO_PI, wrap
from ..results import solution_arrays
from .inputs import GridAxis, grid_inputs

__all__ = ["BRANCHES_SCHEMA", "COVER_TOL", "DEFAULT_SAMPLES", "Branch", "BranchPoint", "Circuit", "BranchMap",
           "Connector", "CoverCheck", "NearestConnector", "branch_map", "check_one_input", "cross_check",
           "locate_branch_point"]

#: Inputs solved between two calls of a branch map's progress callback. Reason: one solve of a
#: six-bar takes ~0.1 s, so a line every ~1 s; fewer inputs per call would cost solve_many's batching.
PROGRESS_CHUNK = 8

#: The JSON schema name of :meth:`BranchMap.as_dict`.
BRANCHES_SCHEMA = "spherekin.branches/1"
#: Grid points of a full turn (or of the input joint's range) when no grid is given. Reason: 4 deg
#: steps keep every solution of a four-bar within a clear nearest match of the next one; the local
#: refinement adds points only where a match is ambiguous or the count changes.
DEFAULT_SAMPLES = 90
#: A grid whose hi - lo is 2 pi within this (radians) is a full turn: its last point is its first.
#: Reason: lo and hi written as text ("-pi", "pi") or in degrees differ from 2 pi by rounding only.
FULL_TURN_TOL = 1e-9
#: A solution continues to the nearest predicted candidate only when the next nearest is at least
#: this many times farther away. Reason: a factor 2 leaves room for the prediction's second-order
#: error while still telling apart two assemblies that pass close by each other.
MATCH_RATIO = 2.0
#: The largest move (radians, any passive joint, after the prediction) accepted as one continuation
#: between two samples; farther, the interval is halved. Reason: with the first-order prediction a
#: move this large means the grid is far coarser than the curve's curvature.
MAX_JUMP = 0.5
#: Bisection on the input around a count change stops at a bracket this wide (radians); Newton
#: polishes from there. Reason: next to a branch point the two merging assemblies are
#: ~sqrt(distance) apart, so 1e-6 leaves them ~1e-3 apart: well inside Newton's basin, and still
#: two roots the solver (tolerance 1e-6) separates (closer, its solves slow down and its counts
#: become unreliable: measured on a Stephenson six-bar, seconds per solve below 1e-8). It also
#: bounds the halving of an ambiguous interval: one still ambiguous this narrow is reported
#: unresolved (a crossing of two branches, or two branch points closer than this).
BISECT_TOL = 1e-6
#: Newton on the augmented system stops when its step (radians, every coordinate) is below this.
#: Reason: at a regular root of the augmented system (a simple branch point) the step is the error
#: before it, squared after it: 1e-12 means the point is known to ~1e-15 or better.
NEWTON_STEP_TOL = 1e-12
#: The smallest tolerance a polished branch point's input is given (radians). Reason: Newton's last
#: step can be far below what float64 resolves there: det K_p and the residuals are evaluated to
#: ~1e-16, and the branch points of the tests agree with the closed form to ~1e-15.
LOCATE_FLOOR = 1e-14
#: Newton steps at most (quadratic convergence needs ~5 from a bisected bracket).
NEWTON_MAX_ITER = 30
#: Central finite-difference step (radians) of the derivatives Newton takes numerically (the loop
#: residual in the input, det K_p in every coordinate). Reason: the error is O(h^2) ~ 1e-12 of
#: O(1) derivatives, far below what the quadratic convergence needs.
FD_STEP = 1e-6
#: Half width (radians) of the chart of :meth:`loop_system` around a point Newton evaluates. Reason:
#: the residual is evaluated in angles; the chart only has to hold the point (width < 2 pi).
CHART_HALF_WIDTH = 1.0
#: A polished branch point is accepted when its closure residual (largest |F_n - I| entry) is below
#: this. Reason: the same bound polishing accepts a root with (trust/polish.py CONVERGED_TOL).
BRANCH_RESIDUAL_TOL = 1e-12

#: Cell width T (radians of input) of the certified singular cover the branch points are held against
#: (step 4 of the module doc). Reason: the same resolution as :data:`BISECT_TOL`: a branch point the
#: map misses next to one it locates lies within :data:`COVER_EXPLAINS` T of it, the "closer than
#: 1e-6" the map already leaves unresolved; and a line's cover costs about the same at any T from 1e-2
#: to 1e-6 (measured, medians of 3 at T = 1e-2 / 1e-3 / 1e-6: the boxes of the passive unknowns
#: dominate; examples/four_bar.toml 0.13 / 0.13 / 0.18 s, examples/watt_six_bar.toml 2.0 / 2.3 / 2.7 s,
#: examples/stephenson_six_bar.toml 17 / 20 / 14 s), more below (a near-tangency's run of unresolved
#: cells grows as 1/T: the issue-40 change-point four-bar 0.9 s at 1e-6, 12 s at 1e-8, one run).
COVER_TOL = 1e-6
#: A located branch point accounts for the cover's cells within this many cell widths T of it (its
#: interval +- its tolerance, widened by this times T). Reason: the cover accepts boxes of sides at most
#: T/2 (problem.COVER_FRACTION), so a box around a branch point meets its own cell and at most the
#: next one on either side: measured, the examples' folds within T/2 of a cell's edge give a second,
#: adjacent cell (examples/watt_six_bar.toml at T = 1e-5, examples/stephenson_six_bar.toml at 1e-2
#: and 1e-3).
COVER_EXPLAINS = 2.0
#: Box cap of the branch map's cover (boxes of the augmented system processed). Reason: about 7 times
#: what the examples' Stephenson six-bar needs at T = 1e-6 (2.7e5 boxes, ~15 s); a cover that reaches it (a
#: continuum of singular assemblies over an interval of inputs) returns the unprocessed part as
#: unresolved regions, which the cross-check turns unresolved like any cell it cannot account for.
COVER_MAX_BOXES = 2_000_000
#: The edges of the cover's runs of adjacent cells solved as extra samples at most (more: none; the
#: runs are then judged on the grid's samples alone). Reason: a solve takes ~10 ms (four-bar) to ~0.1 s
#: (six-bar), ~0.5 s within 1e-5 of a near-tangency, so ~20-100 s more at most; a generic linkage's
#: cover has one run per branch point, many only over a continuum of singular assemblies. Only a run's
#: two edges: inside a run of unresolved cells the solver slows down without bound (the change-point
#: four-bar: 0.4-0.7 s per solve at its run's cell edges, 42 s at its discriminant's minimum).
COVER_SAMPLES = 200

#: The connect step: ``connect(u0, Q0, u1, Q1)`` with the solutions at inputs u0 < u1 (arrays
#: (n0, P) and (n1, P) of passive readings, radians) -> for each row of Q0 the row of Q1 it continues
#: to (-1: it ends in the interval, at a branch point), or None when that is not clear (the interval
#: is then halved). Rows of Q1 no row of Q0 reaches start in the interval.
Connector = Callable[[float, np.ndarray, float, np.ndarray], "np.ndarray | None"]


@dataclass(frozen=True, eq=False)
class Branch:
    """One assembly followed without a branch point: ``inputs`` (m,) increasing (radians; on a
    full-turn grid up to the first input + 2 pi), ``angles`` (m, P) the passive readings at each
    (radians, in [-pi, pi), columns :attr:`BranchMap.joints`). ``start``/``end``: the index of the
    branch point it starts or ends at (its first or last sample is that point), or None (the
    grid's end, or the wrap of a full turn)."""

    inputs: np.ndarray = field(repr=False)
    angles: np.ndarray = field(repr=False)
    start: int | None = None
    end: int | None = None


@dataclass(frozen=True)
class BranchPoint:
    """Where two assemblies meet (det K_p = 0): ``input`` (radians), ``angles`` (P,) passive
    readings (radians, columns :attr:`BranchMap.joints`), ``tolerance``: how well the input is
    known (radians: Newton's last step, at least :data:`LOCATE_FLOOR`, when ``polished``, else the
    bisected bracket's width);
    ``residual``: the largest |F_n - I| entry there; ``branches``: the two branches it joins. At an
    input where several pairs of assemblies meet at once (a Stephenson six-bar whose four-bar loop
    turns back), each pair has its own point."""

    input: float
    angles: tuple[float, ...]
    tolerance: float
    residual: float
    polished: bool
    branches: tuple[int, int]


@dataclass(frozen=True)
class Circuit:
    """Branches joined at branch points (and across the wrap of a full turn): ``branches`` and
    ``branch_points`` (indices), ``intervals``: the input intervals (lo, hi) it spans (radians),
    ``crank``: whether it covers the full input turn (a full-turn grid, no branch point)."""

    branches: tuple[int, ...]
    branch_points: tuple[int, ...]
    intervals: tuple[tuple[float, float], ...]
    crank: bool


@dataclass(frozen=True)
class CoverCheck:
    """What the cross-check against the certified singular cover did (:func:`cross_check`).

    ``tol``: the cover's cell width T (radians); ``complete``: whether the cover finished within its
    box cap (when not, its unprocessed part is among ``cells`` as unresolved regions, wider than T);
    ``cells``: the cover's cells (lo, hi, status "singular" or "unresolved"), radians; outside them no
    branch point (the count is proven constant); ``unresolved``: the input intervals (lo, hi) turned
    unresolved in the map: where the cover holds cells no located branch point accounts for (each
    widened to the solved inputs the branches end at); ``disagreements``: the indices of the located
    branch points outside every cell (one of the two results is wrong there); ``samples``: the cells'
    edges added to the grid; ``seconds``: the cover's time; ``error``: why the cover could not be
    computed (one line; then nothing was checked and the other fields are empty)."""

    tol: float
    complete: bool
    cells: tuple[tuple[float, float, str], ...] = ()
    unresolved: tuple[tuple[float, float], ...] = ()
    disagreements: tuple[int, ...] = ()
    samples: int = 0
    seconds: float = 0.0
    error: str | None = None

    def summary(self, input_name: str, scale: float = 1.0, unit: str = " rad") -> str:
        """One line: the cover, and what it found against the map (``scale``, ``unit``: the angles')."""
        if self.error is not None:
            return f"cross-check: not done (the certified singular cover failed: {self.error})"
        head = (f"cross-check: certified singular cover of {input_name} at T = {self.tol * scale:.1e}{unit}, "
                f"{'complete' if self.complete else 'capped'}, {len(self.cells)} cell(s), {self.seconds:.1f} s")
        if not self.cells:
            parts = ["no branch point over the input's range (proven)"]
        elif self.unresolved:
            parts = [f"{len(self.unresolved)} interval(s) no branch point accounts for, turned unresolved"]
        else:
            parts = ["every cell next to a located branch point"]
        if self.disagreements:
            parts.append(f"DISAGREES: {len(self.disagreements)} located branch point(s) outside the cover "
                         f"(branch point(s) {', '.join(str(k + 1) for k in self.disagreements)})")
        elif self.cells:
            parts.append("every located branch point inside it")
        return head + ": " + "; ".join(parts)

    def as_dict(self) -> dict:
        """The ``cover`` object of the branch map's JSON (docs/results-format.md)."""
        return {"tol": float(self.tol), "complete": bool(self.complete),
                "cells": [{"x": [float(lo), float(hi)], "status": st} for lo, hi, st in self.cells],
                "unresolved": [[float(lo), float(hi)] for lo, hi in self.unresolved],
                "disagreements": [int(k) for k in self.disagreements], "samples": int(self.samples),
                "seconds": float(self.seconds), "error": self.error}


@dataclass(frozen=True, eq=False)
class BranchMap:
    """The branches and circuits of a one-input mechanism (module doc). ``input``: the actuated
    joint; ``joints``: the passive joints (columns of every angle array); ``output``: the joint
    drawn and reported; ``grid``: the inputs first solved (radians); ``full_turn``: whether the grid
    wraps; ``counts``: solutions at each grid input; ``samples``: inputs solved in all;
    ``unresolved``: input intervals (lo, hi) whose solutions could not be connected (the branches end
    there and the circuits are not joined across them): :data:`BISECT_TOL` wide where two branches
    cross, and the cells of the singular cover no located branch point accounts for (``cover``);
    ``cover``: the cross-check against the certified singular cover (:class:`CoverCheck`, None when
    skipped)."""

    mechanism: str
    input: str
    joints: tuple[str, ...]
    output: str
    grid: np.ndarray = field(repr=False)
    full_turn: bool
    counts: tuple[int, ...]
    samples: int
    branches: tuple[Branch, ...]
    branch_points: tuple[BranchPoint, ...]
    circuits: tuple[Circuit, ...]
    unresolved: tuple[tuple[float, float], ...] = ()
    cover: CoverCheck | None = None

    @property
    def output_column(self) -> int:
        """The column of :attr:`output` in every angle array."""
        return self.joints.index(self.output)

    def report(self, degrees: bool = False) -> str:
        """One line per circuit: the input interval(s) it spans, its branch points, whether it is a crank."""
        scale, unit = (180.0 / math.pi, " deg") if degrees else (1.0, " rad")
        k = self.output_column
        span = "full turn" if self.full_turn else f"[{self.grid[0] * scale:.6g}, {self.grid[-1] * scale:.6g}]{unit}"
        rows = [f"{len(self.circuits)} circuit(s), {len(self.branches)} branch(es), {len(self.branch_points)} branch "
                f"point(s) of {self.input} over {span} ({len(self.grid)} grid inputs, {self.samples} solved); "
                f"output: {self.output}"]
        for c, circ in enumerate(self.circuits, start=1):
            spans = ", ".join(f"[{lo * scale:.6g}, {hi * scale:.6g}]" for lo, hi in circ.intervals)
            points = "; ".join(
                f"{self.input} = {self.branch_points[b].input * scale:.10g}, {self.output} = "
                f"{self.branch_points[b].angles[k] * scale:.10g} (+-{self.branch_points[b].tolerance * scale:.1e})"
                for b in circ.branch_points) or "none"
            kind = "crank: covers the full input turn" if circ.crank else "not a full turn"
            rows.append(f"  circuit {c}: {self.input} in {spans}{unit}; branch points: {points}; {kind}")
        flagged = set(self.cover.unresolved) if self.cover is not None else set()
        for lo, hi in self.unresolved:
            why = ("the certified cover holds a singular input there that no located branch point accounts for: "
                   "branch points closer than the sampling may lie there" if (lo, hi) in flagged
                   else "branches crossing, or branch points closer than that")
            rows.append(f"  unresolved: the solutions at {self.input} = {lo * scale:.10g} and {hi * scale:.10g}{unit} "
                        f"could not be connected ({why})")
        rows.append("  " + (self.cover.summary(self.input, scale, unit) if self.cover is not None
                            else "cross-check: skipped (no certified singular cover: a pair of branch points closer "
                                 "than the sampling would go unseen)"))
        return "\n".join(rows)

    def as_dict(self) -> dict:
        """The JSON (schema :data:`BRANCHES_SCHEMA`, docs/results-format.md); angles in radians."""
        return {
            "schema": BRANCHES_SCHEMA, "mechanism": self.mechanism, "input": self.input, "joints": list(self.joints),
            "output": self.output, "full_turn": bool(self.full_turn),
            "inputs": [float(u) for u in self.grid], "counts": [int(n) for n in self.counts],
            "samples": int(self.samples),
            "branches": [{"inputs": b.inputs.tolist(), "angles": b.angles.tolist(), "start": _int(b.start),
                          "end": _int(b.end)} for b in self.branches],
            "branch_points": [{"input": float(p.input), "angles": {n: float(a) for n, a in zip(self.joints, p.angles)},
                               "tolerance": float(p.tolerance), "residual": float(p.residual),
                               "polished": bool(p.polished), "branches": [int(b) for b in p.branches]}
                              for p in self.branch_points],
            "circuits": [{"branches": [int(b) for b in c.branches], "branch_points": [int(b) for b in c.branch_points],
                          "intervals": [[float(lo), float(hi)] for lo, hi in c.intervals], "crank": bool(c.crank)}
                         for c in self.circuits],
            "unresolved": [[float(lo), float(hi)] for lo, hi in self.unresolved],
            "cover": None if self.cover is None else self.cover.as_dict(),
        }


def _int(value):
    """An index for the JSON: int, or None (a branch that starts or ends at no branch point)."""
    return None if value is None else int(value)


# ---------------------------------------------------------------------------------------------- checks


def check_one_input(mechanism, key: str = "mechanism") -> str:
    """The actuated joint of a one-input mechanism whose passive Jacobian is square (one degree of
    freedom); ValueError naming ``key`` otherwise."""
    actuated = tuple(mechanism.actuated)
    if len(actuated) != 1:
        raise ValueError(f"{key}: branches and circuits are drawn for a mechanism with one actuated joint (one "
                         f"degree of freedom), got {len(actuated)} ({', '.join(actuated)})")
    rows, cols = 3 * len(mechanism.loop_geometry), len(mechanism.loop_unknowns)
    if rows != cols:
        raise ValueError(f"{key}: branches need as many loop equations as passive unknowns (one degree of freedom), "
                         f"got {rows} equations for {cols} unknowns")
    return actuated[0]


def _grid_of(mechanism, name: str, grid, samples: int) -> tuple[np.ndarray, bool]:
    """(grid inputs (N,), full turn) from ``grid`` (None: the joint's range or a full turn of
    ``samples`` points; a GridAxis or "name=lo:hi:n")."""
    if grid is None:
        rng = mechanism.ranges[name]
        if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 3:
            raise ValueError(f"samples: expected a whole number >= 3, got {samples!r}")
        lo, hi = (-math.pi, math.pi) if rng is None else rng
        axis = GridAxis(name, np.linspace(lo, hi, int(samples)))
    else:
        axis = grid
    axis = grid_inputs(mechanism, [axis]).axes[0]     # the joint's name and every value's range checked
    values = np.asarray(axis.values, dtype=float)
    full = bool(mechanism.ranges[name] is None and abs(values[-1] - values[0] - TWO_PI) <= FULL_TURN_TOL)
    return values, full


# ---------------------------------------------------------------------------------------------- connect


def _gaps(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Largest wrapped difference (radians) between every row of a (n, P) and of b (m, P): (n, m)."""
    if len(a) == 0 or len(b) == 0:
        return np.zeros((len(a), len(b)))
    return np.abs(wrap(a[:, None, :] - b[None, :, :])).max(axis=-1)


class NearestConnector:
    """The default connect step (:data:`Connector`): each solution at u0 is moved to u1 along its
    tangent (dq/du = -K_p^-1 K_a, :meth:`~spherekin.mechanism.SphericalMechanism.jacobians`) and
    continues to the nearest solution at u1, when that one is :data:`MATCH_RATIO` times nearer than
    any other, within :data:`MAX_JUMP`, and no two reach the same one. With counts n0 != n1 only
    min(n0, n1) continue and the others (two, at one branch point) end or start in the interval."""

    def __init__(self, mechanism, input_name: str, joints: Sequence[str]):
        self.mechanism, self.input, self.joints = mechanism, input_name, tuple(joints)

    def tangent(self, u: float, q: np.ndarray) -> np.ndarray:
        """dq/du (P,) at input u and readings q (zeros where K_p is singular)."""
        jac = self.mechanism.jacobians({**dict(zip(self.joints, map(float, q))), self.input: float(u)})
        kp, ka = jac["K_p"], jac["K_a"][:, 0]
        order = [self.mechanism.passive.index(n) for n in self.joints]
        try:
            dq = -np.linalg.solve(kp[:, order], ka)
        except np.linalg.LinAlgError:
            return np.zeros(len(self.joints))
        return dq if np.all(np.isfinite(dq)) else np.zeros(len(self.joints))

    @staticmethod
    def _move(du: float, dq: np.ndarray) -> np.ndarray:
        """The predicted move du * dq, or none where it exceeds :data:`MAX_JUMP` (next to a branch
        point the tangent grows without bound and the first-order prediction means nothing)."""
        move = du * dq
        return move if np.max(np.abs(move)) <= MAX_JUMP else np.zeros_like(move)

    def __call__(self, u0, q0, u1, q1):
        n0, n1 = len(q0), len(q1)
        if n0 == 0 or n1 == 0:
            return np.full(n0, -1, dtype=int)
        du = u1 - u0
        ahead = np.array([q + self._move(du, self.tangent(u0, q)) for q in q0])
        behind = np.array([q - self._move(du, self.tangent(u1, q)) for q in q1])
        gap = np.minimum(_gaps(ahead, q1), _gaps(q0, behind))      # each pair judged by its better prediction
        small, large = (gap, 0) if n0 <= n1 else (gap.T, 1)       # match the rows of the smaller side
        pick = np.argmin(small, axis=1)
        best = small[np.arange(len(small)), pick]
        if np.any(best > MAX_JUMP) or len(set(pick.tolist())) != len(pick):
            return None
        others = small.copy()
        others[np.arange(len(small)), pick] = np.inf
        if small.shape[1] > 1 and np.any(MATCH_RATIO * best >= others.min(axis=1)):
            return None
        if n0 <= n1:
            return pick.astype(int)
        out = np.full(n0, -1, dtype=int)
        out[pick] = np.arange(n1)
        return out


# ---------------------------------------------------------------------------------------------- locate


def _augmented(mechanism, input_name: str, joints: tuple, z: np.ndarray) -> tuple[np.ndarray, float]:
    """(the stacked F_n - I of every loop (9 L,), det K_p) at z = (passive readings (P,), input)."""
    from ..trust.polish import closure_residual

    q, u = z[:-1], float(z[-1])
    system = mechanism.loop_system([u], {n: (float(a) - CHART_HALF_WIDTH, float(a) + CHART_HALF_WIDTH)
                                        for n, a in zip(joints, q)})
    theta = np.array([q[joints.index(n)] for n in system.names])
    res = closure_residual(system.loops, system.unknowns, theta)
    jac = mechanism.jacobians({**dict(zip(joints, map(float, q))), input_name: u})["K_p"]
    order = [mechanism.passive.index(n) for n in joints]
    return res, float(np.linalg.det(jac[:, order]))


def locate_branch_point(mechanism, input_name: str, joints: Sequence[str], u0: float, q0,
                        bracket: tuple[float, float]) -> tuple[float, np.ndarray, float, float, bool]:
    """A branch point near input ``u0`` and passive readings ``q0`` (P,), by Newton on the augmented
    system (loop equations and det K_p = 0) in (readings, input): (input, readings (P,), tolerance,
    residual, polished). ``bracket`` (lo, hi): the bisected input interval holding it; when Newton
    does not converge inside it (to :data:`BRANCH_RESIDUAL_TOL`), the bracket's midpoint and width
    are returned unpolished."""
    joints = tuple(joints)
    lo, hi = bracket
    z = np.append(np.asarray(q0, dtype=float), float(u0))
    step = np.inf
    try:
        for _ in range(NEWTON_MAX_ITER):
            res, det = _augmented(mechanism, input_name, joints, z)
            if np.max(np.abs(step)) < NEWTON_STEP_TOL:
                break
            jac = np.empty((len(res) + 1, len(z)))
            for k in range(len(z)):
                dz = np.zeros(len(z))
                dz[k] = FD_STEP
                r_plus, d_plus = _augmented(mechanism, input_name, joints, z + dz)
                r_minus, d_minus = _augmented(mechanism, input_name, joints, z - dz)
                jac[:-1, k] = (r_plus - r_minus) / (2 * FD_STEP)
                jac[-1, k] = (d_plus - d_minus) / (2 * FD_STEP)
            step = np.linalg.lstsq(jac, -np.append(res, det), rcond=None)[0]
            z = z + step
        residual = float(np.max(np.abs(res)))
        inside = lo - (hi - lo) <= z[-1] <= hi + (hi - lo)
        if np.max(np.abs(step)) < NEWTON_STEP_TOL and residual < BRANCH_RESIDUAL_TOL and inside:
            return float(z[-1]), wrap(z[:-1]), max(float(abs(step[-1])), LOCATE_FLOOR), residual, True
    except (ValueError, np.linalg.LinAlgError):       # an input Newton took out of the joint's range
        pass
    res, _ = _augmented(mechanism, input_name, joints, np.append(np.asarray(q0, dtype=float), float(u0)))
    return 0.5 * (lo + hi), np.asarray(q0, dtype=float), float(hi - lo), float(np.max(np.abs(res))), False


# ---------------------------------------------------------------------------------------------- the map


class _Samples:
    """Solved inputs: u -> passive readings (n, P) (columns ``joints``, radians in [-pi, pi)),
    solved in batches (``Problem.solve_many``); with ``wraps`` (a full turn) an input is solved as
    its value in [-pi, pi) (the grid runs up to its first input + 2 pi)."""

    def __init__(self, problem, joints, wraps: bool, progress=None, planned: int = 0):
        self.problem, self.joints, self.wraps = problem, tuple(joints), wraps
        self.at: dict[float, np.ndarray] = {}
        self.progress, self.planned = progress, planned

    def solve(self, us: Sequence[float]) -> None:
        todo = [u for u in us if u not in self.at]
        self.planned = max(self.planned, len(self.at) + len(todo))
        for start in range(0, len(todo), PROGRESS_CHUNK):
            part = todo[start:start + PROGRESS_CHUNK]
            rows = np.array([[wrap(u) if self.wraps else u] for u in part])
            for u, rep in zip(part, self.problem.solve_many(rows)):
                cols = [rep.unknowns.index(n) for n in self.joints]
                self.at[u] = wrap(solution_arrays(rep.solutions, len(rep.unknowns)).angles[:, cols])
            if self.progress is not None:     # refinements add inputs: the total grows with them
                self.progress(len(self.at), self.planned)


def branch_map(mechanism, grid: GridAxis | str | None = None, *, joint: str | None = None,
               samples: int = DEFAULT_SAMPLES, connect: Connector | None = None,
               progress: Callable[[int, int], None] | None = None, cover_tol: float | None = COVER_TOL,
               **strategy) -> BranchMap:
    """The branches, branch points and circuits of a one-input mechanism (module doc).

    ``mechanism``: a SphericalMechanism or a mechanism file's path, one actuated joint; ``grid``:
    that joint's inputs ("name=lo:hi:n" or a GridAxis; default: its range, or a full turn, of
    ``samples`` points; a grid spanning 2 pi of an unlimited joint wraps); ``joint``: the passive
    joint reported and drawn (default: the first passive joint); ``connect``: the connect step
    (default :class:`NearestConnector`); ``progress``: called with (inputs solved, inputs planned so
    far) as solving goes (refinements add inputs); ``cover_tol``: the cell width T (radians) of the
    certified singular cover the map is held against (:class:`CoverCheck`; None: no cross-check);
    ``strategy``: the keywords of :func:`spherekin.compile`.
    The passive joints' ranges are lifted: a circuit is a property of the linkage, which a range
    cuts short but never joins to another (an assembly leaving a range meets no other there).
    Islands of assemblies narrower than a grid step between two inputs of the same count are not seen
    by the sampling; the cover's cells show where they may be (step 4 of the module doc).
    """
    from ..problem import as_mechanism, compile as compile_problem
    from ..singularities import check_singular_tol

    mech = as_mechanism(mechanism)
    name = check_one_input(mech)
    joints = tuple(mech.loop_unknowns)
    if joint is None:
        joint = joints[0]
    if joint not in joints:
        raise ValueError(f"joint: {joint!r} is not a passive joint of this mechanism; expected one of "
                         f"{', '.join(joints)}")
    values, full = _grid_of(mech, name, grid, samples)
    if cover_tol is not None:                       # as singular() checks it, on the grid's range: before any work
        cover_tol = check_singular_tol(cover_tol, "cover_tol")
    mech = mech.without_ranges(mech.passive)        # circuits are the linkage's: a passive range cuts them, joins none
    problem = compile_problem(mech, **strategy)
    connect = connect or NearestConnector(mech, name, joints)
    base = list(values[:-1]) if full else list(values)
    ends = base + ([base[0] + TWO_PI] if full else [])
    check = None if cover_tol is None else _cover(mech, name, ends[0], ends[-1], float(cover_tol))
    if check is not None and check.error is None:   # the cells' edges: a count change inside the grid's steps
        extra = _edge_samples(check.cells, ends[0], ends[-1])
        check = replace(check, samples=len(set(extra) - set(ends)))
        ends = sorted(set(ends) | set(extra))
    store = _Samples(problem, joints, full, progress, len(ends) - (1 if full else 0))
    store.solve(ends[:-1] if full else ends)
    if full:
        store.at[ends[-1]] = store.at[ends[0]]
    # ----- resolve every interval: a matching, or a bisected count change
    pending = list(zip(ends, ends[1:]))
    done: dict[float, tuple[float, np.ndarray, bool]] = {}      # a -> (b, match, count change)
    unresolved = []
    while pending:
        halve = []
        for a, b in pending:
            qa, qb = store.at[a], store.at[b]
            match = connect(a, qa, b, qb)
            change = len(qa) - len(qb)
            narrow = b - a <= BISECT_TOL
            if match is None and narrow and change == 0 and _next_to_a_count_change(store, a, b):
                match = _nearest(qa, qb)                   # next to a fold: the pair that meets is one circuit
            if match is not None and (change == 0 or (narrow and change % 2 == 0)):
                done[a] = (b, match, change != 0)
            elif narrow:                                   # nothing continues across it
                done[a] = (b, np.full(len(qa), -1, dtype=int), False)
                unresolved.append((a, b))
            else:
                halve.append((a, b))
        mids = [0.5 * (a + b) for a, b in halve]
        store.solve(mids)
        pending = [part for (a, b), m in zip(halve, mids) for part in ((a, m), (m, b))]
    located = _locate_all(mech, name, joints, store, done)
    if check is not None and check.error is None:
        points = [(r[0], r[2]) for a in sorted(located) for _, _, r in located[a]]    # the branch points' order
        left, outside = cross_check([(lo, hi) for lo, hi, _ in check.cells], points, check.tol,
                                    TWO_PI if full else None)
        flagged = _cut(store, done, left)
        check = replace(check, unresolved=flagged, disagreements=outside)
        unresolved = [iv for iv in unresolved if not any(lo <= iv[0] and iv[1] <= hi for lo, hi in flagged)]
        unresolved = sorted(unresolved + list(flagged))
    return _assemble(mech, name, joints, joint, values, full, store, ends, done, located, tuple(unresolved), check)


def _cover(mech, name: str, lo: float, hi: float, tol: float) -> CoverCheck:
    """The certified singular cover of the input ``name`` over [lo, hi] (radians) at cell width ``tol``
    (:func:`spherekin.singular`), as a :class:`CoverCheck` not yet judged (``error``: its one-line
    refusal, e.g. a mechanism whose det K_p it cannot expand)."""
    from ..singularities import singular

    t0 = time.perf_counter()
    try:
        sset = singular(mech, x=(name, lo, hi), tol=tol, max_boxes=COVER_MAX_BOXES)
    except ValueError as exc:
        return CoverCheck(tol, False, error=str(exc).splitlines()[0] if str(exc) else type(exc).__name__)
    cells = tuple(sorted((float(b.x[0]), float(b.x[1]), str(b.status)) for b in sset.boxes))
    return CoverCheck(tol, bool(sset.complete), cells, seconds=time.perf_counter() - t0)


def _runs(intervals) -> list[tuple[float, float]]:
    """Intervals (lo, hi) merged where they meet or touch, sorted."""
    out: list[list[float]] = []
    for lo, hi in sorted(intervals):
        if out and lo <= out[-1][1]:
            out[-1][1] = max(out[-1][1], hi)
        else:
            out.append([lo, hi])
    return [(lo, hi) for lo, hi in out]


def _edge_samples(cells, lo: float, hi: float) -> list[float]:
    """The inputs to add to the grid for the cover's ``cells`` (lo, hi, status): the two edges of each
    run of adjacent cells within [lo, hi], none when more than :data:`COVER_SAMPLES`."""
    edges = sorted({e for run in _runs(c[:2] for c in cells) for e in run if lo <= e <= hi})
    return edges if len(edges) <= COVER_SAMPLES else []


def cross_check(cells, points, tol: float, period: float | None = None):
    """Located branch points against a certified singular cover of their input's line.

    ``cells``: the cover's cells (lo, hi) (radians): outside them no branch point; ``points``: the
    located branch points (input, tolerance) (radians); ``tol``: the cover's cell width T; ``period``:
    2 pi for a full turn (a point is then also compared at +- one period). Returns (``left``: the parts
    of the cover no point accounts for, merged intervals (lo, hi), sorted; a point accounts for the
    cover within its tolerance plus :data:`COVER_EXPLAINS` T of it; ``outside``: the indices of the
    points that meet no cell, which account for nothing)."""
    runs = _runs(cells)
    shifts = (0.0,) if period is None else (-period, 0.0, period)
    outside, windows = [], []
    for k, (u, t) in enumerate(points):
        if not any(lo <= u + s + t and u + s - t <= hi for lo, hi in runs for s in shifts):
            outside.append(k)
            continue
        reach = t + COVER_EXPLAINS * tol
        windows += [(u + s - reach, u + s + reach) for s in shifts]
    left = []
    for lo, hi in runs:
        pieces = [(lo, hi)]
        for w_lo, w_hi in _runs(windows):
            pieces = [part for a, b in pieces for part in ((a, min(b, w_lo)), (max(a, w_hi), b)) if part[1] > part[0]]
        left += pieces
    return tuple(left), tuple(outside)


def _cut(store, done: dict, left) -> tuple[tuple[float, float], ...]:
    """Cut the map's connections across the intervals ``left`` (lo, hi) (radians): each run of
    consecutive connected intervals meeting one becomes one interval connecting nothing (``done``
    updated in place; a count change keeps its branch point). Returns the intervals flagged
    unresolved: each of ``left`` widened to the solved inputs its cut ends at, merged."""
    flagged = []
    for lo, hi in left:
        keys = [a for a in sorted(done) if a < hi and done[a][0] > lo]
        f_lo, f_hi = lo, hi
        run: list[float] = []
        for a in keys + [None]:
            if a is not None and not done[a][2]:
                run.append(a)
                continue
            if run:
                end = done[run[-1]][0]
                done[run[0]] = (end, np.full(len(store.at[run[0]]), -1, dtype=int), False)
                for inner in run[1:]:
                    del done[inner]
                f_lo, f_hi = min(f_lo, run[0]), max(f_hi, end)
            run = []
        flagged.append((f_lo, f_hi))
    return tuple(_runs(flagged))


def _next_to_a_count_change(store, a: float, b: float) -> bool:
    """Whether the solved input next to the narrow interval [a, b] on either side (within its width)
    has another count: the interval lies at a branch point, whose two meeting assemblies are too
    close there for a clear match (and end in one circuit whichever way they are matched)."""
    n, width = len(store.at[a]), b - a
    near = [u for u in store.at if u != a and u != b and (a - width <= u < a or b < u <= b + width)]
    return any(len(store.at[u]) != n for u in near)


def _nearest(qa: np.ndarray, qb: np.ndarray) -> np.ndarray | None:
    """Each row of qa to its nearest row of qb (equal counts), when no two pick the same; else None."""
    if len(qa) != len(qb) or not len(qa):
        return None
    pick = np.argmin(_gaps(qa, qb), axis=1)
    return pick.astype(int) if len(set(pick.tolist())) == len(pick) else None


def _pairs(q: np.ndarray) -> list[tuple[int, int]]:
    """The rows of q (2 k, P) in pairs, nearest first: the pairs of assemblies that meet at one input."""
    gap = _gaps(q, q)
    np.fill_diagonal(gap, np.inf)
    left, pairs = set(range(len(q))), []
    for flat in np.argsort(gap, axis=None):
        i, j = divmod(int(flat), len(q))
        if i in left and j in left:
            pairs.append((i, j))
            left -= {i, j}
    return pairs


def _meeting_rows(store, done: dict, a: float) -> tuple[float, list[int], bool]:
    """The count change over ``done[a]``: (the input of its larger side, the rows there no solution
    of the other side continues to or from, whether that side is ``a``)."""
    b, match, _ = done[a]
    na, nb = len(store.at[a]), len(store.at[b])
    if na > nb:
        return a, [r for r in range(na) if match[r] < 0], True
    return b, sorted(set(range(nb)) - set(int(m) for m in match if m >= 0)), False


def _locate_all(mech, name, joints, store, done: dict) -> dict:
    """Every count change of ``done`` -> [(i, j, located)]: the rows of :func:`_meeting_rows` met in
    pairs (:func:`_pairs`) and each pair's branch point (:func:`locate_branch_point`'s tuple)."""
    out = {}
    for a in sorted(done):
        b, _, transition = done[a]
        if not transition:
            continue
        at, rows, _ = _meeting_rows(store, done, a)
        q = store.at[at][rows]
        out[a] = [(i, j, locate_branch_point(mech, name, joints, at, q[i] + 0.5 * wrap(q[j] - q[i]), (a, b)))
                  for i, j in _pairs(q)]
    return out


def _assemble(mech, name, joints, joint, values, full, store, ends, done, located, unresolved, check) -> BranchMap:
    """Chains of matched samples -> branches; count changes -> the located branch points; circuits."""
    us = sorted(done) + [ends[-1]]
    # chains: (sample input, row) sequences; a row at u continues to match[row] at the next input
    chains: list[list[tuple[float, int]]] = []
    head: dict[tuple[float, int], int] = {}                     # (u, row) -> chain it is the last of
    for u in us:
        for row in range(len(store.at[u])):
            if (u, row) not in head:                            # nothing reached it: a new chain
                chains.append([(u, row)])
                head[(u, row)] = len(chains) - 1
        if u not in done:
            continue
        b, match, _ = done[u]
        for row, nxt in enumerate(match):
            if nxt >= 0:
                c = head.pop((u, row))
                chains[c].append((b, int(nxt)))
                head[(b, int(nxt))] = c
    first = {(c[0]): k for k, c in enumerate(chains)}
    last = {(c[-1]): k for k, c in enumerate(chains)}
    # branch points: the unmatched rows of each count change's larger side, in pairs
    points, joins = [], []
    starts: dict[int, int] = {}
    stops: dict[int, int] = {}
    for a in sorted(located):
        at, rows, ending = _meeting_rows(store, done, a)
        chain_of = [(last if ending else first)[(at, r)] for r in rows]
        for i, j, (u_bp, q_bp, tol, residual, polished) in located[a]:
            k = len(points)
            pair = (chain_of[i], chain_of[j])
            points.append(BranchPoint(float(u_bp), tuple(float(x) for x in q_bp), float(tol), float(residual), bool(polished),
                                      pair))
            for c in pair:
                (stops if ending else starts)[c] = k
            joins.append(pair)
    # the wrap of a full turn: a chain ending at the last input continues as the one at the first
    if full:
        for row in range(len(store.at[ends[-1]])):
            if (ends[-1], row) in last and (ends[0], row) in first:
                joins.append((last[(ends[-1], row)], first[(ends[0], row)]))
    branches = []
    for k, chain in enumerate(chains):
        inputs = [u for u, _ in chain]
        angles = [store.at[u][r] for u, r in chain]
        if k in starts:
            p = points[starts[k]]
            inputs, angles = [p.input] + inputs, [np.array(p.angles)] + angles
        if k in stops:
            p = points[stops[k]]
            inputs, angles = inputs + [p.input], angles + [np.array(p.angles)]
        branches.append(Branch(np.array(inputs), np.array(angles).reshape(len(inputs), len(joints)),
                               starts.get(k), stops.get(k)))
    circuits = _circuits(branches, points, joins, full, ends)
    return BranchMap(mech.name, name, joints, joint, values, full, tuple(len(store.at[u]) for u in values),
                     len(store.at) - (1 if full else 0), tuple(branches), tuple(points), circuits, unresolved, check)


def _circuits(branches, points, joins, full, ends) -> tuple[Circuit, ...]:
    """The branches joined over ``joins`` (pairs of branch indices): the circuits."""
    out = []
    for members in sorted(connected_groups(len(branches), joins)):
        bps = tuple(sorted({k for k, p in enumerate(points) if p.branches[0] in members}))
        spans = sorted((float(branches[k].inputs[0]), float(branches[k].inputs[-1])) for k in members)
        merged: list[list[float]] = []
        for lo, hi in spans:
            if merged and lo <= merged[-1][1]:
                merged[-1][1] = max(merged[-1][1], hi)
            else:
                merged.append([lo, hi])
        crank = bool(full) and not bps and bool(merged) and merged[0][0] <= ends[0] and merged[-1][1] >= ends[-1] \
            and len(merged) == 1
        out.append(Circuit(tuple(members), bps, tuple((lo, hi) for lo, hi in merged), crank))
    return tuple(out)
