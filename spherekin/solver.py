"""Subdivision-minimization (Section 4): all roots of the closure equations inside the joint ranges.

Implements the algorithm of Section 4 with Eq. (12) (or a cheaper pruner) at step 2:

1. map the joint ranges to the unit box and compute the control points of every equation;
2. reduce a box B to a sub-box B' that holds all its roots (:mod:`spherekin.pruners`);
3. discard B' if empty, accept it when every side is below the tolerance (radians), re-reduce it
   when the reduction shrank it well (every side ratio <= :data:`SPLIT_RATIO`), otherwise bisect
   its widest side.

Boxes are processed in batches (one numpy call restricts all control points to up to
:data:`BATCH` boxes). Joint ranges wider than pi, and full circles, are covered by several charts
(tan((theta - shift)/2) stays within [-1, 1] on each), so a root at theta = pi is found as t = 0
of the chart centred at pi; touching boxes, also across charts, are merged into one solution.
Departure from the paper: the paper always splits B'; re-reducing a well-shrunk box is the
standard projected-polyhedron strategy and is what makes simple roots converge quadratically.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
from typing import Callable, Mapping, Sequence

import numpy as np

from . import bernstein
from .closure import ClosureLoop, Unknown
from .formulations import FORMULATIONS, formulate
from .pruners import PRUNERS, make_pruner
from .results import AcceptedBox, Solution, SolveReport, SolverStats
from .solutions import finalize

__all__ = ["solve", "solve_system", "charts_for_range", "SolverLimitError", "DepthLimitError", "BoxLimitError",
           "DEFAULT_TOL", "SPLIT_RATIO", "BATCH"]

#: Default tolerance (radians): a box is accepted when every joint angle is known to within it.
DEFAULT_TOL = 1e-6
#: A reduced box whose sides all shrank to at most this fraction is reduced again instead of split
#: (Sherbrooke & Patrikalakis use 0.8: below it, another reduction pays more than a bisection).
SPLIT_RATIO = 0.8
#: Boxes restricted and pruned per numpy call; large enough to amortize Python overhead, small
#: enough that the breadth of the search stays near depth-first order in memory.
BATCH = 256
#: Cap on the subdivision depth (reductions + bisections of one box): bisecting a 2 pi range down
#: to 1e-12 takes ~43 steps per unknown; 60 per unknown leaves room for re-reductions.
DEPTH_PER_UNKNOWN = 60
#: Cap on the number of boxes processed in one solve: a finite set of roots at 1e-6 needs a few
#: thousand; far more means a continuum of solutions (or a formulation with singular roots).
DEFAULT_MAX_BOXES = 500_000
#: Rounding errors of control points restricted from the unit box are at most about this many
#: machine epsilons of the equation's largest control point (products of ~2n factors in [0, 1]);
#: the test w = 0 accepts |w| up to it.
ROUNDING_SAFETY = 1e3
#: Accepted boxes closer than this many tolerances (Chebyshev gap, radians modulo 2 pi) form one
#: cluster. Small on purpose: a cluster is polished from its centre, so merging two roots would
#: lose one; the stray boxes that unpreconditioned pruning leaves near a root polish to the same
#: point and are merged after polishing (:mod:`spherekin.solutions`).
MERGE_GAP_TOLS = 2.0
#: Joint ranges wider than this (radians) are split into equal charts of at most this width.
CHART_MAX_WIDTH = math.pi


class SolverLimitError(RuntimeError):
    """A cap of the box loop was reached; the roots found so far are in ``partial``."""

    def __init__(self, message: str, partial: list[AcceptedBox]):
        super().__init__(message)
        self.partial = partial


class DepthLimitError(SolverLimitError):
    """A box was reduced or split more than the depth cap allows."""


class BoxLimitError(SolverLimitError):
    """More boxes were processed than the box cap allows."""


def charts_for_range(rng: tuple[float, float] | None) -> list[tuple[float, float]]:
    """Chart ranges (radians) covering a joint range; None means the full circle.

    The full circle gets the two charts [-pi/2, pi/2] and [pi/2, 3 pi/2] (centres 0 and pi); a range
    wider than CHART_MAX_WIDTH is cut into equal pieces no wider than it.
    """
    full = [(-math.pi / 2, math.pi / 2), (math.pi / 2, 3 * math.pi / 2)]
    if rng is None:
        return full
    lo, hi = float(rng[0]), float(rng[1])
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ValueError(f"range: expected finite lo < hi (radians), got {rng!r}")
    if hi - lo >= 2 * math.pi:  # a multi-turn range: every angle modulo 2 pi is reachable
        return full
    pieces = max(1, math.ceil((hi - lo) / CHART_MAX_WIDTH - 1e-12))
    edges = np.linspace(lo, hi, pieces + 1)
    return [(float(a), float(b)) for a, b in zip(edges[:-1], edges[1:])]


class _Charts:
    """Per-chart data of the box loop, stacked along a leading chart axis.

    ``coeffs[b]`` (C, E, d_1..d_n) and ``tols[b]`` (C, E) per equation block; ``t_lo``, ``t_hi``,
    ``shift`` (C, n) map unit coordinates to angles, theta = shift + 2 atan(t_lo + (t_hi - t_lo) x).
    """

    def __init__(self, systems, formulation):
        self.names = tuple(u.name for u in systems[0][1])
        blocks = []
        for loops, unknowns in systems:
            if tuple(u.name for u in unknowns) != self.names:
                raise ValueError(f"build: expected the unknowns {self.names} in every chart, "
                                 f"got {tuple(u.name for u in unknowns)}")
            blocks.append(formulate(formulation, loops, unknowns))
        self.coeffs = [np.stack([bl[b].coeffs for bl in blocks]) for b in range(len(blocks[0]))]
        eps = np.finfo(float).eps
        self.tols = [ROUNDING_SAFETY * eps * np.stack([bl[b].scale for bl in blocks]) for b in range(len(blocks[0]))]
        t = np.array([[u.t_range for u in unknowns] for _, unknowns in systems])      # (C, n, 2)
        self.t_lo, self.t_hi = t[..., 0], t[..., 1]
        self.shift = np.array([[u.shift for u in unknowns] for _, unknowns in systems])

    def angles(self, chart: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Angles (radians) of unit coordinates x (B, n) in charts ``chart`` (B,); increasing in x."""
        lo, hi = self.t_lo[chart], self.t_hi[chart]
        return self.shift[chart] + 2.0 * np.arctan(lo + (hi - lo) * x)


def _box_loop(charts: _Charts, pruner, tol, max_boxes, max_depth, progress=None):
    """Section 4 steps 2-3 on every chart at once. Returns (accepted [(chart, lo, hi)], counts, timings)."""
    n = len(charts.names)
    n_charts = charts.coeffs[0].shape[0]
    counts = dict(boxes_processed=0, discarded=0, split=0, reduced_again=0, accepted=0, max_depth=0)
    t_restrict = t_prune = 0.0
    accepted: list[tuple[int, np.ndarray, np.ndarray]] = []

    def partial():
        return [AcceptedBox(a, b, int(c)) for c, a, b in accepted]

    stack = [(np.zeros((n_charts, n)), np.ones((n_charts, n)), np.zeros(n_charts, dtype=int),
              np.arange(n_charts))]
    while stack:
        take, size = [], 0
        while stack and size < BATCH:            # fill one batch from the top of the stack
            take.append(stack.pop())
            size += len(take[-1][0])
        lo, hi, depth, chart = (np.concatenate(parts) for parts in zip(*take))
        if len(lo) > BATCH:
            stack.append((lo[BATCH:], hi[BATCH:], depth[BATCH:], chart[BATCH:]))
            lo, hi, depth, chart = lo[:BATCH], hi[:BATCH], depth[:BATCH], chart[:BATCH]
        counts["boxes_processed"] += len(lo)
        if counts["boxes_processed"] > max_boxes:
            raise BoxLimitError(
                f"more than max_boxes={max_boxes} boxes processed; the solution set may be a continuum, "
                "or the tolerance too small for this formulation (the paper's scalar equation has double "
                "roots: try formulation='transversal' or a larger tol)", partial())
        if depth.max() > max_depth:
            raise DepthLimitError(
                f"a box was subdivided more than max_depth={max_depth} times; the solution set may be a "
                f"continuum, or the tolerance {tol} too small for this formulation", partial())
        counts["max_depth"] = max(counts["max_depth"], int(depth.max()))
        if progress is not None:
            progress({**counts, "pending": sum(len(e[0]) for e in stack)})
        t1 = time.perf_counter()
        boxes = np.stack([lo, hi], axis=-1)[:, None]            # (B, 1, n, 2)
        cps = [bernstein.restrict(c[chart], boxes, nvars=n) for c in charts.coeffs]
        tols = [t[chart] for t in charts.tols]
        t2 = time.perf_counter()
        widths = np.max(charts.angles(chart, hi) - charts.angles(chart, lo), axis=1)
        rlo, rhi = pruner.reduce(cps, tols, widths=widths)
        t_prune += time.perf_counter() - t2
        t_restrict += t2 - t1
        keep = ~np.any(rlo > rhi, axis=1)
        counts["discarded"] += int(np.sum(~keep))
        width = hi - lo
        nlo, nhi = (lo + rlo * width)[keep], (lo + rhi * width)[keep]
        ratio, depth, chart = (rhi - rlo)[keep], depth[keep] + 1, chart[keep]
        alo, ahi = charts.angles(chart, nlo), charts.angles(chart, nhi)
        awidth = ahi - alo
        done = np.all(awidth <= tol, axis=1)
        accepted += list(zip(chart[done], alo[done], ahi[done]))
        counts["accepted"] += int(done.sum())
        again = ~done & np.all(ratio <= SPLIT_RATIO, axis=1)
        counts["reduced_again"] += int(again.sum())
        if again.any():
            stack.append((nlo[again], nhi[again], depth[again], chart[again]))
        split = ~done & ~again
        counts["split"] += int(split.sum())
        if split.any():
            slo, shi, sd, sc = nlo[split], nhi[split], depth[split], chart[split]
            axis = np.argmax(awidth[split], axis=1)                 # widest side in radians
            rows = np.arange(len(slo))
            mid = 0.5 * (slo[rows, axis] + shi[rows, axis])
            left_hi, right_lo = shi.copy(), slo.copy()
            left_hi[rows, axis] = mid
            right_lo[rows, axis] = mid
            stack.append((np.concatenate([right_lo, slo]), np.concatenate([shi, left_hi]),
                          np.concatenate([sd, sd]), np.concatenate([sc, sc])))
    return accepted, counts, (t_restrict, t_prune)


def _merge(boxes: list[AcceptedBox], tol: float) -> list[Solution]:
    """Union of boxes closer than MERGE_GAP_TOLS * tol (angles modulo 2 pi) into solutions."""
    if not boxes:
        return []
    lo = np.array([b.lo for b in boxes])
    hi = np.array([b.hi for b in boxes])
    mid = 0.5 * (lo + hi)
    half = 0.5 * (hi - lo)
    parent = list(range(len(boxes)))

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i in range(len(boxes)):
        d = np.abs(np.mod(mid[i + 1:] - mid[i] + math.pi, 2 * math.pi) - math.pi)
        close = np.all(d <= half[i + 1:] + half[i] + MERGE_GAP_TOLS * tol, axis=1)
        for j in np.flatnonzero(close) + i + 1:
            parent[find(j)] = find(i)
    groups: dict[int, list[int]] = {}
    for i in range(len(boxes)):
        groups.setdefault(find(i), []).append(i)
    out = []
    for members in groups.values():
        ref = mid[members[0]]
        # unwrap every member next to the first one, then take the hull
        shift = np.round((mid[members] - ref) / (2 * math.pi)) * 2 * math.pi
        glo, ghi = (lo[members] - shift).min(axis=0), (hi[members] - shift).max(axis=0)
        centre = np.mod(0.5 * (glo + ghi) + math.pi, 2 * math.pi) - math.pi
        out.append(Solution(centre, glo, ghi, len(members)))
    out.sort(key=lambda s: tuple(np.round(s.angles, 9)))
    return out


def solve_system(
    build: Callable[[Mapping[str, tuple[float, float]]], tuple[Sequence[ClosureLoop], Sequence[Unknown]]],
    ranges: Mapping[str, tuple[float, float] | None],
    *,
    formulation: str = "transversal",
    pruner: str = "hybrid",
    lp_backend: str | None = None,
    tol: float = DEFAULT_TOL,
    max_boxes: int = DEFAULT_MAX_BOXES,
    max_depth: int | None = None,
    progress: Callable[[dict], None] | None = None,
) -> SolveReport:
    """All roots of a system of closure loops inside the joint ranges (Section 4, Eq. 12).

    ``build(chart_ranges)`` returns (loops, unknowns) with every unknown's range set from
    ``chart_ranges`` (name -> (lo, hi) radians, width < 2 pi); ``ranges`` gives each unknown's
    joint range, or None for the full circle. ``tol`` is in radians. ``progress(counts)`` is called
    before each batch of boxes with the running counters (and "pending": boxes waiting).
    ``max_boxes`` and ``max_depth`` (default DEPTH_PER_UNKNOWN per unknown) cap the search; reaching
    a cap raises a :class:`SolverLimitError` subclass.
    """
    if formulation not in FORMULATIONS:
        raise ValueError(f"formulation: expected one of {sorted(FORMULATIONS)}, got {formulation!r}")
    if pruner not in PRUNERS:
        raise ValueError(f"pruner: expected one of {PRUNERS}, got {pruner!r}")
    if not (isinstance(tol, (int, float)) and math.isfinite(tol) and tol > 0):
        raise ValueError(f"tol: expected a positive number of radians, got {tol!r}")
    t0 = time.perf_counter()
    names = list(ranges)
    combos = list(itertools.product(*(charts_for_range(ranges[name]) for name in names)))
    systems = []
    for combo in combos:
        systems.append(build(dict(zip(names, combo))))
    charts = _Charts(systems, formulation)
    pr = make_pruner(pruner, [c.shape[1:] for c in charts.coeffs], lp_backend)
    t_setup = time.perf_counter() - t0
    if max_depth is None:
        max_depth = DEPTH_PER_UNKNOWN * len(charts.names)
    found, counts, (t_restrict, t_prune) = _box_loop(charts, pr, tol, max_boxes, max_depth, progress)
    boxes = [AcceptedBox(a, b, int(c)) for c, a, b in found]
    stats = SolverStats(charts=len(combos), **counts, lps_solved=getattr(pr, "lp_count", 0),
                        lp_doubts=getattr(pr, "doubts", 0), time_setup=t_setup, time_restrict=t_restrict,
                        time_prune=t_prune)
    order = charts.names
    solutions = _merge(boxes, tol)
    stats = SolverStats(**{**stats.as_dict(), "time_total": time.perf_counter() - t0})
    settings = dict(formulation=formulation, pruner=pruner, lp_backend=lp_backend, tol=tol, charts=len(combos))
    return SolveReport(order, tuple(solutions), tuple(boxes), stats, settings)


def solve(
    mechanism,
    inputs,
    *,
    formulation: str = "transversal",
    pruner: str = "hybrid",
    lp_backend: str | None = None,
    tol: float = DEFAULT_TOL,
    max_boxes: int = DEFAULT_MAX_BOXES,
    max_depth: int | None = None,
    progress: Callable[[dict], None] | None = None,
) -> SolveReport:
    """Direct kinematics: every assembly of ``mechanism`` at actuator ``inputs`` inside its joint ranges.

    ``mechanism`` is a :class:`spherekin.mechanism.SphericalMechanism`; ``inputs`` one angle
    (radians) per actuated joint. Passive joints with unlimited or wide ranges are searched by
    charts (see :func:`charts_for_range`). Returns a :class:`SolveReport` whose solutions are
    polished, deduplicated and classified (:func:`spherekin.solutions.finalize`): passive angles,
    platform rotation, residual, status and its evidence. Defaults: the fastest
    configuration that finds every solution (transversal equations, hybrid pruner); the
    paper-faithful one is
    ``formulation="paper", pruner="lp", lp_backend="clarabel"``.
    """
    names = mechanism.loop_system(inputs, {n: (-1.0, 1.0) for n in mechanism.passive}).names
    ranges = {n: mechanism.ranges[n] for n in names}

    def build(chart):
        system = mechanism.loop_system(inputs, chart)
        return system.loops, system.unknowns

    report = solve_system(build, ranges, formulation=formulation, pruner=pruner, lp_backend=lp_backend,
                          tol=tol, max_boxes=max_boxes, max_depth=max_depth, progress=progress)
    solutions = finalize(mechanism, inputs, report.unknowns, report.solutions, tol)
    settings = {**report.settings, "mechanism": mechanism.name, "actuated": list(mechanism.actuated),
                "inputs": [float(v) for v in mechanism._check_inputs(inputs)]}
    return dataclasses.replace(report, solutions=tuple(solutions), settings=settings)
