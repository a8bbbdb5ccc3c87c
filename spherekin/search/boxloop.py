"""Subdivision-minimization (Section 4): all roots of the closure equations inside the joint ranges.

Implements the algorithm of Section 4 with Eq. (12) (or a cheaper pruner) at step 2:

1. map the joint ranges to the unit box of a parameterization (:mod:`spherekin.search.parameterizations`:
   the paper's tan-half-angle substitution, with charts, or the sin-cos form of Section 5) and
   compute the control points of every equation (:mod:`spherekin.search.formulations`);
2. reduce a box B to a sub-box B' that holds all its roots (:mod:`spherekin.search.pruners`), and, on
   small boxes, apply the Krawczyk test of :mod:`spherekin.search.isolation`, which contracts the box
   further and may prove that it holds exactly one root;
3. discard B' if empty, accept it when every side is below the tolerance (radians), set it aside
   when it is isolated (Newton then converges to its root), re-reduce it when the reduction shrank
   it well (every side ratio <= :data:`SPLIT_RATIO`), otherwise bisect its widest side.

Boxes are processed in batches (one numpy call restricts all control points to up to
:data:`BATCH` boxes, batch axis last). Tan-half joint ranges wider than pi, and full circles, are
covered by several charts, so a root at theta = pi is found as t = 0 of the chart centred at pi;
touching boxes, also across charts, are merged into one solution. With ``jobs > 1`` the charts are
spread over worker processes; every box is processed the same way whatever the batch it lands
in, so the solutions do not depend on ``jobs``.

Departures from the paper: the paper always splits B'; re-reducing a well-shrunk box (shrink
ratio <= SPLIT_RATIO) is the standard projected-polyhedron strategy. Near a simple root it
converges quadratically only with the Eq. (12) LPs on the transversal formulation (measured order
2.0; experiments/convergence.py); per-equation projected-polyhedron pruning converges linearly there
(order 1.0, each equation's zero set crosses the box), and on the paper's scalar equation every
pruner is linear (double roots). The fast tail of the default configuration comes from the
Krawczyk isolation and Newton, an addition to the paper (its Section 5 asks for faster convergence).
The pruners bound a box through the hull of its control points; before a box is accepted, its
equations are restricted to the reduced box once more and must still admit 0 (a hull can touch
w = 0 at one point where the equation does not vanish).
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Callable, Mapping, Sequence

import numpy as np

from ..core import bernstein
from ..core.groups import pad_by_owner
from ..core.angles import RANGE_TOL, in_range, in_range_many, near, near_groups, wrap
from ..closure import ClosureLoop, Unknown
from .formulations import FORMULATIONS, ChartBilinear
from .isolation import SquareSystem, krawczyk_boxes, newton, spurious_proven
from .parameterizations import (CHART_MAX_WIDTH, PARAMETERIZATIONS, ROUNDING_SAFETY, ChartSet, charts_for_range,
                                make_charts)
from .pruners import check_pruner, excludes_zero, make_pruner
from ..results import AcceptedBox, Cluster, SearchReport, Settings, SolverStats

__all__ = ["solve_system", "search_cover", "Cover", "solve_system_many", "search_platform_many", "CHUNK_BATCH", "pruner_for", "search_platform", "PlatformSearch", "check_strategy", "clusters_in_range", "clusters_in_range_many",
           "partial_report", "charts_for_range", "SolverLimitError", "SearchInterrupted", "DepthLimitError", "BoxLimitError",
           "DEFAULT_FORMULATION", "DEFAULT_PRUNER", "DEFAULT_PARAMETERIZATION", "DEFAULT_TOL", "MAX_TOL", "TRACE_OUTCOMES", "SPLIT_RATIO", "BATCH", "ISOLATION_MAX_WIDTH", "ROUNDING_SAFETY", "CHART_MAX_WIDTH"]

#: Default strategies: the fastest configuration that finds every solution (benchmarks/README.md).
DEFAULT_FORMULATION = "halves"
DEFAULT_PRUNER = "pp"
DEFAULT_PARAMETERIZATION = "tan-half"
#: Default tolerance (radians): a box is accepted when every joint angle is known to within it.
DEFAULT_TOL = 1e-6
#: Largest tolerance accepted (radians). Reason: a cluster of accepted boxes is polished from its
#: own boxes and accounted for by Krawczyk tests on them (:mod:`spherekin.trust.solutions`); boxes wider
#: than ~0.1 rad are wider than the distance between distinct assemblies of real mechanisms
#: (Gosselin: 0.3 rad) and than any box a Krawczyk test isolates (~0.3 rad), so a coarser tol could
#: only merge roots. The paper's coarsest run uses 1e-2.
MAX_TOL = 0.1
#: A reduced box whose sides all shrank to at most this fraction is reduced again instead of split
#: (Sherbrooke & Patrikalakis use 0.8: below it, another reduction pays more than a bisection).
SPLIT_RATIO = 0.8
#: A box is bisected at this fraction of its widest side, not at 1/2: symmetric mechanisms put
#: roots at the exact centre of a chart (theta = 0 or pi: the Gosselin platform's singular
#: solutions), where midpoint splits would keep them on box faces for ever, so that no box could
#: isolate them (the Krawczyk test needs the root inside) and each would be found as a cloud of
#: 2^k tolerance-sized boxes. Any value not near a simple fraction works.
SPLIT_POINT = 0.4917
#: Boxes restricted and pruned per numpy call; large enough to amortize Python overhead, small
#: enough that the breadth of the search stays near depth-first order in memory.
BATCH = 256
#: Cap on the subdivision depth (reductions + bisections of one box): bisecting a 2 pi range down
#: to 1e-12 takes ~43 steps per variable; 60 per variable leaves room for re-reductions.
DEPTH_PER_UNKNOWN = 60
#: Cap on the number of boxes processed in one solve: a finite set of roots at 1e-6 needs a few
#: thousand; far more means a continuum of solutions (or a formulation with singular roots).
DEFAULT_MAX_BOXES = 500_000
#: Accepted boxes closer than this many tolerances (Chebyshev gap, radians modulo 2 pi) form one
#: cluster. Small on purpose: a cluster is polished from its centre, so merging two roots would
#: lose one; the stray boxes that unpreconditioned pruning leaves near a root polish to the same
#: point and are merged after polishing (:mod:`spherekin.trust.solutions`).
MERGE_GAP_TOLS = 2.0
#: The Krawczyk test runs on boxes whose widest side (metric units: radians, or c/s) is below this.
#: On wider boxes the enclosure of the Jacobian is too loose for K(X) to fit inside X (measured on
#: the Gosselin platform: no box wider than ~0.3 rad was ever isolated), so the test would only cost.
ISOLATION_MAX_WIDTH = 0.5


class SolverLimitError(RuntimeError):
    """A cap of the box loop was reached; the roots found so far are in ``partial``, and ``stats``
    (a :class:`SolverStats`) counts the work done until then: boxes processed, discarded, split,
    LPs, charts and seconds, as a finished search reports them."""

    def __init__(self, message: str, partial: list[AcceptedBox], counts: dict | None = None,
                 times: tuple = (0.0, 0.0, 0.0)):
        super().__init__(message)
        self.partial = partial
        t_restrict, t_prune, t_isolate = times
        self.stats = SolverStats(**(counts or {}), time_restrict=t_restrict, time_prune=t_prune,
                                 time_isolate=t_isolate)

    def add_stats(self, **more) -> None:
        """Add counters and seconds known only to a caller (charts, LPs, set-up time) to ``stats``."""
        self.stats = dataclasses.replace(self.stats, **{k: getattr(self.stats, k) + v for k, v in more.items()})


class SearchInterrupted(SolverLimitError):
    """The search was interrupted (Ctrl-C, KeyboardInterrupt); the roots accepted so far are in
    ``partial``. Not a cap: the pipeline reports the partial result instead of searching again."""


class DepthLimitError(SolverLimitError):
    """A box was reduced or split more than the depth cap allows."""


class BoxLimitError(SolverLimitError):
    """More boxes were processed than the box cap allows."""


_COUNTERS = ("boxes_processed", "discarded", "split", "reduced_again", "accepted", "isolated", "max_depth")


class _Layout:
    """Chart-last copies of the dense blocks; the bilinear blocks (already chart-last) as they are."""

    def __init__(self, charts: ChartSet, dense: bool = False):
        self.blocks = []
        for b, c in enumerate(charts.coeffs):
            bil = None if dense or charts.bilinear is None else charts.bilinear[b]
            self.blocks.append(np.ascontiguousarray(np.moveaxis(c, 0, -1)) if bil is None else bil)


def _restrict(charts: ChartSet, layout: _Layout, chart, lo, hi, which=None, cache=None):
    """Control points of the blocks ``which`` (default all) on boxes [lo, hi] of charts ``chart``
    (batch last), and their tolerances; None for the blocks not asked for.

    Dense blocks are restricted as they are; a bilinear block restricts its two halves and
    assembles the products (:meth:`spherekin.search.formulations.ChartBilinear.assemble`), ~20x fewer
    operations. ``cache`` shares restriction matrices between calls on the same boxes.
    """
    cache = {} if cache is None else cache
    cps = []
    for b, block in enumerate(layout.blocks):
        if which is not None and b not in which:
            cps.append(None)
        elif isinstance(block, ChartBilinear):
            av, bv = list(block.a_vars), list(block.b_vars)
            ra = bernstein.restrict_batch_last(np.take(block.a, chart, axis=-1), lo[:, av], hi[:, av], cache, av)
            rb = bernstein.restrict_batch_last(np.take(block.b, chart, axis=-1), lo[:, bv], hi[:, bv], cache, bv)
            cps.append(block.assemble(ra, rb))
        else:
            cps.append(bernstein.restrict_batch_last(np.take(block, chart, axis=-1), lo, hi, cache))
    tols = [None if c is None else t[chart].T for c, t in zip(cps, charts.tols)]
    return cps, tols


#: Outcome codes of a processed box in a trace (see :func:`solve_system`).
TRACE_OUTCOMES = ("discarded", "accepted", "isolated", "reduced_again", "split")


def _box_loop(charts: ChartSet, pruner, tol, max_boxes, max_depth, start=None, isolate=True, progress=None,
              trace=None):
    """Section 4 steps 2-3 for one input. ``start`` = (chart, lo, hi) initial boxes (default:
    every chart's unit box). Reaching a cap raises (:class:`BoxLimitError`, :class:`DepthLimitError`).

    Returns (accepted [(chart, angle lo, angle hi)], isolated [(chart, x lo, x hi)], counts, timings).
    """
    loop = _loop(charts, pruner, tol, max_boxes, max_depth, start, isolate, progress, trace)
    return loop.accepted, loop.isolated, {k: int(v[0]) for k, v in loop.counts.items()}, loop.times


class _LoopResult:
    """What :func:`_loop` hands over: ``accepted`` [(chart, angle lo, angle hi)], ``isolated``
    [(chart, x lo, x hi)] (charts: indices into the chart set), ``counts`` (counter -> (K,) per
    input), ``times`` (restrict, prune, isolate seconds), ``capped`` (K,): inputs that reached a cap
    (their boxes are left out of the lists); ``pending`` [(chart, x lo, x hi)]: with ``keep_pending``,
    the boxes not processed when the one input's cap was reached (else empty)."""

    __slots__ = ("accepted", "isolated", "counts", "times", "capped", "pending")

    def __init__(self, accepted, isolated, counts, times, capped, pending=()):
        self.accepted = accepted
        self.isolated = isolated
        self.counts = counts
        self.times = times
        self.capped = capped
        self.pending = list(pending)


def _loop(charts: ChartSet, pruner, tol, max_boxes, max_depth, start=None, isolate=True, progress=None,
          trace=None, owner=None, n_inputs=1, batch=BATCH, keep_pending=False, budget=None) -> _LoopResult:
    """The box loop over the charts of one input (``owner`` None), or of a chunk of inputs.

    ``owner`` (C,) int: the input (0..n_inputs-1) each chart of ``charts`` belongs to (the chart sets
    of a chunk stacked along the chart axis: :func:`spherekin.search.parameterizations.stack_chart_sets`).
    The input of a box is then a column of the loop's arrays (``owner[chart]``): the counters are
    kept per input and the caps apply per input. Every box is processed the same way whatever the
    batch it lands in (restriction, pruning, the Krawczyk test and the split are functions of the
    box and its chart alone), so an input's boxes, and hence its roots, do not depend on the other
    inputs of the chunk nor on ``batch``. With one input a cap raises, with the boxes accepted so
    far; with an owner the input that reaches it is dropped from the loop (``capped``; its boxes
    are no longer processed) and the caller solves it again on its own, where the cap raises.
    ``keep_pending`` (one input only): reaching a cap stops the loop without raising and hands back
    the unprocessed boxes (the batch at hand and the stack) as ``pending``, none dropped (a cover:
    :func:`search_cover`); so does a ``budget`` (:class:`spherekin.budget.Budget`) that names a reason to stop.
    """
    n = len(charts.variables)
    layout = _Layout(charts)
    square = SquareSystem.from_blocks(charts.square)
    isolate = isolate and len(square.rows) == n
    pruned = [b for b, p in enumerate(charts.prune) if p]
    square_only = [b for b, rows in enumerate(charts.square) if rows and not charts.prune[b]]
    single = owner is None
    owner = np.zeros(charts.n_charts, dtype=int) if single else np.asarray(owner, dtype=int)
    counts = {k: np.zeros(n_inputs, dtype=int) for k in _COUNTERS}
    capped = np.zeros(n_inputs, dtype=bool)
    t_restrict = t_prune = t_isolate = 0.0
    accepted: list[tuple[int, np.ndarray, np.ndarray]] = []
    isolated: list[tuple[int, np.ndarray, np.ndarray]] = []
    limit = tol * charts.accept_width

    def add(name, own, mask=None):
        counts[name] += np.bincount(own if mask is None else own[mask], minlength=n_inputs)

    def stopped():
        # what a stopped loop hands over: the accepted boxes and the roots of the boxes isolated so far
        # (Newton, as a finished search does), the counters and the seconds spent so far
        points = _solve_isolated(charts, isolated)[0] if isolated else []
        return ([AcceptedBox(a, b, int(c)) for c, a, b in accepted]
                + [AcceptedBox(a, np.array(a, copy=True), int(c)) for c, a in points],
                {k: int(v[0]) for k, v in counts.items()}, (t_restrict, t_prune, t_isolate))

    if start is None:
        nc = charts.n_charts
        start = (np.arange(nc), np.zeros((nc, n)), np.ones((nc, n)))
    chart0, lo0, hi0 = start
    stack = [(lo0, hi0, np.zeros(len(lo0), dtype=int), np.asarray(chart0, dtype=int))]
    pending: list[tuple[int, np.ndarray, np.ndarray]] = []
    try:
        while stack:
            take, size = [], 0
            while stack and size < batch:            # fill one batch from the top of the stack
                take.append(stack.pop())
                size += len(take[-1][0])
            lo, hi, depth, chart = (np.concatenate(parts) for parts in zip(*take))
            if len(lo) > batch:
                stack.append((lo[batch:], hi[batch:], depth[batch:], chart[batch:]))
                lo, hi, depth, chart = lo[:batch], hi[:batch], depth[:batch], chart[:batch]
            own = owner[chart]
            if capped.any():                         # boxes of inputs dropped at a cap: not processed
                live = ~capped[own]
                lo, hi, depth, chart, own = lo[live], hi[live], depth[live], chart[live], own[live]
            if len(lo) == 0:
                continue
            add("boxes_processed", own)
            over = counts["boxes_processed"] > max_boxes
            deep = np.zeros(n_inputs, dtype=bool)
            deep[own[depth > max_depth]] = True
            if single and keep_pending and (over[0] or deep[0] or (budget is not None and budget.exhausted())):
                pending = [(c, a, b) for c, a, b in zip(chart, lo, hi)]
                pending += [(c, a, b) for s_lo, s_hi, _, s_chart in stack for c, a, b in zip(s_chart, s_lo, s_hi)]
                counts["boxes_processed"] -= np.bincount(own, minlength=n_inputs)    # this batch was not
                break                        # not ``capped``: the accepted boxes stay in the lists
            if single and over[0]:
                raise BoxLimitError(
                    f"more than max_boxes={max_boxes} boxes processed; the solution set may be a continuum, "
                    "or the tolerance too small for this formulation (the paper's scalar equation has double "
                    "roots: try formulation='transversal' or a larger tol)", *stopped())
            if single and deep[0]:
                raise DepthLimitError(
                    f"a box was subdivided more than max_depth={max_depth} times; the solution set may be a "
                    f"continuum, or the tolerance {tol} too small for this formulation", *stopped())
            if (over | deep).any():
                capped |= over | deep
                live = ~capped[own]
                lo, hi, depth, chart, own = lo[live], hi[live], depth[live], chart[live], own[live]
                if len(lo) == 0:
                    continue
            np.maximum.at(counts["max_depth"], own, depth)
            if progress is not None:
                progress({**{k: int(v.sum()) for k, v in counts.items()}, "max_depth": int(counts["max_depth"].max()),
                          "pending": sum(len(e[0]) for e in stack)})
            t1 = time.perf_counter()
            cache: dict = {}
            cps, tols = _restrict(charts, layout, chart, lo, hi, pruned, cache)
            t2 = time.perf_counter()
            mwidth = charts.metric(chart, hi) - charts.metric(chart, lo)
            widths = mwidth.max(axis=1)
            rlo, rhi = pruner.reduce([cps[b] for b in pruned], [tols[b] for b in pruned], widths=widths)
            charts.contract(chart, lo, hi, rlo, rhi)
            t3 = time.perf_counter()
            iso = np.zeros(len(lo), dtype=bool)
            if isolate:
                cand = np.flatnonzero(~np.any(rlo > rhi, axis=1) & (widths < ISOLATION_MAX_WIDTH))
                if len(cand):
                    extra, extra_t = _restrict(charts, layout, chart[cand], lo[cand], hi[cand], square_only)
                    k_iso, klo, khi = krawczyk_boxes(
                        square, [c[..., cand] if c is not None else e for c, e in zip(cps, extra)],
                        [t[:, cand] if t is not None else e for t, e in zip(tols, extra_t)])
                    iso[cand] = k_iso
                    rlo[cand] = np.maximum(rlo[cand], klo)
                    rhi[cand] = np.minimum(rhi[cand], khi)
            t_isolate += time.perf_counter() - t3
            t_prune += t3 - t2
            t_restrict += t2 - t1
            if iso.any():
                isolated += list(zip(chart[iso], lo[iso], hi[iso]))
                add("isolated", own, iso)
            keep = ~np.any(rlo > rhi, axis=1) & ~iso
            add("discarded", own, ~keep & ~iso)
            width = hi - lo
            if trace is not None:
                outcome = np.where(iso, 2, np.where(keep, 3, 0))   # refined below for kept boxes
                record = dict(chart=chart.copy(), depth=depth.copy(), lo=lo.copy(), hi=hi.copy(),
                              metric_width=mwidth.copy(), reduced_lo=lo + rlo * width, reduced_hi=lo + rhi * width)
            nlo, nhi = (lo + rlo * width)[keep], (lo + rhi * width)[keep]
            ratio, depth, chart, own = (rhi - rlo)[keep], depth[keep] + 1, chart[keep], own[keep]
            mw = charts.metric(chart, nhi) - charts.metric(chart, nlo)
            done = np.all(mw <= limit, axis=1)
            alive = np.ones(len(nlo), dtype=bool)
            if done.any():
                # Departure from the paper (Section 4, step 3 accepts a box once it is small): the
                # pruners bound the box through the hull of control points on the *unreduced* box, and
                # a hull can touch w = 0 at one abscissa where the equation does not vanish (a whole
                # chart can shrink to one such point). Restricted to the reduced box, the control
                # points must still admit 0, or the box holds no root.
                idx = np.flatnonzero(done)
                t4 = time.perf_counter()
                rc, rt = _restrict(charts, layout, chart[idx], nlo[idx], nhi[idx], pruned)
                empty = excludes_zero([rc[b] for b in pruned], [rt[b] for b in pruned])
                t_restrict += time.perf_counter() - t4
                alive[idx[empty]] = False
                done &= alive
                add("discarded", own[idx], empty)
            if trace is not None:
                kept = np.flatnonzero(keep)
                outcome[kept[done]] = 1
                outcome[kept[~done & alive & ~np.all(ratio <= SPLIT_RATIO, axis=1)]] = 4
                outcome[kept[~alive]] = 0
                record["outcome"] = outcome
                trace(record)
            if done.any():
                alo, ahi = charts.angle_box(chart[done], nlo[done], nhi[done])
                accepted += list(zip(chart[done], alo, ahi))
            add("accepted", own, done)
            again = ~done & alive & np.all(ratio <= SPLIT_RATIO, axis=1)
            add("reduced_again", own, again)
            if again.any():
                stack.append((nlo[again], nhi[again], depth[again], chart[again]))
            split = ~done & ~again & alive
            add("split", own, split)
            if split.any():
                slo, shi, sd, sc = nlo[split], nhi[split], depth[split], chart[split]
                axis = np.argmax(mw[split], axis=1)                     # widest side in metric units
                rows = np.arange(len(slo))
                mid = slo[rows, axis] + SPLIT_POINT * (shi[rows, axis] - slo[rows, axis])
                left_hi, right_lo = shi.copy(), slo.copy()
                left_hi[rows, axis] = mid
                right_lo[rows, axis] = mid
                stack.append((np.concatenate([right_lo, slo]), np.concatenate([shi, left_hi]),
                              np.concatenate([sd, sd]), np.concatenate([sc, sc])))
    except KeyboardInterrupt as exc:
        # Ctrl-C (or the command line's SIGTERM, whose text names it): stop now, hand over what was
        # accepted so far (the pipeline reports it, not exact)
        raise SearchInterrupted(f"interrupted ({str(exc) or 'Ctrl-C'}) after "
                                f"{int(counts['boxes_processed'].sum())} boxes", *stopped()) from None
    if capped.any():
        accepted = [a for a in accepted if not capped[owner[a[0]]]]
        isolated = [a for a in isolated if not capped[owner[a[0]]]]
    return _LoopResult(accepted, isolated, counts, (t_restrict, t_prune, t_isolate), capped, pending)


def _solve_isolated(charts: ChartSet, isolated):
    """Newton from every isolated box: (points [(chart, angles)], the charts (array) of the roots
    proven spurious, failed boxes)."""
    if not isolated:
        return [], np.zeros(0, dtype=int), []
    chart = np.array([c for c, _, _ in isolated])
    lo = np.array([a for _, a, _ in isolated])
    hi = np.array([b for _, _, b in isolated])
    cps, tols = _restrict(charts, _Layout(charts), chart, lo, hi)
    square = SquareSystem.from_blocks(charts.square)
    u, converged, closure = newton(square, cps, tols)
    suspect = np.flatnonzero(converged & ~closure)
    spurious = np.zeros(len(u), dtype=bool)
    if len(suspect):   # dropped only when proven (isolation.spurious_proven); else kept, for the trust layer
        spurious[suspect] = spurious_proven(square, [c[..., suspect] for c in cps],
                                            [np.asarray(t)[..., suspect] for t in tols], u[suspect])
    x = lo + u * (hi - lo)
    angles = charts.angles(chart, x)
    points = [(int(c), a) for c, a, ok, sp in zip(chart, angles, converged, spurious) if ok and not sp]
    failed = [(c, a, b) for c, a, b, ok in zip(chart, lo, hi, converged) if not ok]
    return points, chart[spurious], failed


def pruner_for(charts: ChartSet, pruner: str, lp_backend: str | None, built: dict | None = None):
    """The pruner ``pruner`` for the pruned blocks of ``charts`` (:func:`spherekin.search.pruners.make_pruner`).

    The blocks' coefficient shapes (E, d_1..d_n) depend on the formulation, parameterization and
    unknowns, not on the actuator inputs or the ranges: with ``built`` (a dict kept by the caller,
    keyed by pruner, backend and shapes) a pruner, and for the LP pruners its compiled LP model, is
    built once per chart layout and reused for every input.
    """
    shapes = tuple(tuple(c.shape[1:]) for c, p in zip(charts.coeffs, charts.prune) if p)
    if built is None:
        return make_pruner(pruner, shapes, lp_backend)
    key = (pruner, lp_backend, shapes)
    if key not in built:
        built[key] = make_pruner(pruner, shapes, lp_backend)
    return built[key]


def _run_group(charts, pruner, tol, max_boxes, max_depth, isolate, group, progress=None, trace=None):
    """The box loop on the charts of ``group`` (a worker's share), then Newton on its isolated boxes;
    ``pruner``: built (it may have been used before: its LP counters are read as differences)."""
    lp0, doubts0 = getattr(pruner, "lp_count", 0), getattr(pruner, "doubts", 0)
    n = len(charts.variables)
    group = np.asarray(group, dtype=int)
    start = (group, np.zeros((len(group), n)), np.ones((len(group), n)))
    try:
        accepted, isolated, counts, times = _box_loop(charts, pruner, tol, max_boxes, max_depth, start, isolate,
                                                      progress, trace)
    except SolverLimitError as exc:
        exc.add_stats(lps_solved=getattr(pruner, "lp_count", 0) - lp0, lp_doubts=getattr(pruner, "doubts", 0) - doubts0)
        raise
    points, spurious, failed = _solve_isolated(charts, isolated)
    if failed:  # Newton left an isolating box (not seen in practice): subdivide it the ordinary way
        c, a, b = (np.array(v) for v in zip(*failed))
        more, _, counts2, times2 = _box_loop(charts, pruner, tol, max_boxes, max_depth, (c, a, b), False)
        accepted += more
        counts = {k: (max(counts[k], counts2[k]) if k == "max_depth" else counts[k] + counts2[k]) for k in counts}
        times = tuple(x + y for x, y in zip(times, times2))
    counts.update(spurious=len(spurious), newton_failures=len(failed),
                  lps_solved=getattr(pruner, "lp_count", 0) - lp0, lp_doubts=getattr(pruner, "doubts", 0) - doubts0)
    return accepted, points, counts, times


class PlatformSearch:
    """What the box loop found on the quaternion charts of the platform formulation.

    ``points``: (chart, x) of every isolated root after Newton (x: the chart's unit coordinates,
    :func:`spherekin.systems.platform.chart_rotation`); ``unresolved``: boxes that reached the
    tolerance without being isolated, plus isolated boxes Newton did not converge in (then the
    points are not the whole answer); ``stats``: the search's counters and timings.
    """

    __slots__ = ("points", "unresolved", "stats")

    points: tuple
    unresolved: int
    stats: SolverStats

    def __init__(self, points, unresolved, stats):
        self.points = points
        self.unresolved = unresolved
        self.stats = stats


def search_platform(charts, pruner, tol: float, max_boxes: int = DEFAULT_MAX_BOXES, max_depth: int | None = None,
                    progress: Callable[[dict], None] | None = None) -> PlatformSearch:
    """Section 4's loop on the platform formulation's chart set
    (:meth:`spherekin.systems.platform.PlatformSystem.charts`), with Krawczyk isolation and
    Newton; ``pruner`` is built by the caller (once per compiled problem). Caps as in
    :func:`solve_system` (a :class:`SolverLimitError` when reached)."""
    t0 = time.perf_counter()
    lp0, doubts0 = getattr(pruner, "lp_count", 0), getattr(pruner, "doubts", 0)   # the pruner is reused
    if max_depth is None:
        max_depth = DEPTH_PER_UNKNOWN * len(charts.variables)
    accepted, isolated, counts, (t_r, t_p, t_i) = _box_loop(charts, pruner, tol, max_boxes, max_depth,
                                                            None, True, progress)
    points, spurious, failed = _solve_isolated(charts, isolated)
    counts.update(spurious=len(spurious), newton_failures=len(failed),
                  lps_solved=getattr(pruner, "lp_count", 0) - lp0, lp_doubts=getattr(pruner, "doubts", 0) - doubts0)
    stats = SolverStats(charts=charts.n_charts, **counts, time_restrict=t_r, time_prune=t_p, time_isolate=t_i,
                        time_total=time.perf_counter() - t0)
    return PlatformSearch(tuple(sorted(points, key=_chart_order)), len(accepted) + len(failed) + len(spurious), stats)


#: Boxes per numpy call in the box loop of a chunk of inputs, at most (:func:`search_platform_many`,
#: :func:`solve_system_many`: BATCH per input of the chunk, up to this). Reason: each batch costs a
#: fixed ~two dozen numpy calls whatever its size, so a chunk's boxes are taken many at a time (one
#: input's search rarely has more than a few hundred alive at once, so BATCH fits it, and a chunk
#: of one runs as a single solve always did: its progress lines and Ctrl-C come as often); at this
#: size the largest array of a batch (a block's control points, ~100 floats a box) stays within a
#: few MB.
CHUNK_BATCH = 4096


def _chunk_batch(n_inputs: int) -> int:
    """Boxes per batch of the box loop of ``n_inputs`` inputs (:data:`CHUNK_BATCH`)."""
    return min(CHUNK_BATCH, BATCH * n_inputs)


def _chart_order(item) -> tuple:
    """The order of found boxes and roots (chart, lo or point, ...) handed over: by chart, then
    coordinates, so that it does not depend on the order the box loop met them in."""
    return (int(item[0]), tuple(item[1]))


def _owner(charts: ChartSet, n_inputs: int) -> np.ndarray:
    """(C,) the input of each chart of a chunk's stacked chart sets (input-major, equal blocks)."""
    if isinstance(n_inputs, bool) or not isinstance(n_inputs, (int, np.integer)) or n_inputs < 1 \
            or charts.n_charts % n_inputs:
        raise ValueError(f"n_inputs: expected a positive divisor of the {charts.n_charts} stacked charts, "
                         f"got {n_inputs!r}")
    return np.repeat(np.arange(n_inputs), charts.n_charts // n_inputs)


def _by_input(items, owner, n_inputs, key=lambda item: item[0]) -> list[list]:
    """``items`` (each with a chart index at ``key``) split by the input of that chart, in order."""
    out: list[list] = [[] for _ in range(n_inputs)]
    for item in items:
        out[owner[key(item)]].append(item)
    return out


def _shares(loop: _LoopResult, n_inputs, pruner, lp0, doubts0, seconds) -> dict:
    """The chunk's LP counters and seconds, each input's share (in proportion to the boxes it
    processed): a chunk measures them once for all its inputs."""
    boxes = loop.counts["boxes_processed"].astype(float)
    weight = boxes / boxes.sum() if boxes.sum() else np.full(n_inputs, 1.0 / n_inputs)
    lps = getattr(pruner, "lp_count", 0) - lp0
    doubts = getattr(pruner, "doubts", 0) - doubts0
    return dict(lps=np.round(weight * lps).astype(int), doubts=np.round(weight * doubts).astype(int),
                times=[tuple(float(w * t) for t in loop.times) for w in weight], total=weight * seconds)


def search_platform_many(charts: ChartSet, n_inputs: int, pruner, tol: float, max_boxes: int = DEFAULT_MAX_BOXES,
                         max_depth: int | None = None, progress: Callable[[dict], None] | None = None,
                         batch: int | None = None) -> tuple:
    """:func:`search_platform` for each input of a chunk, as one box loop over all their boxes.

    ``charts``: the platform chart sets of the ``n_inputs`` inputs stacked input-major
    (:func:`spherekin.search.parameterizations.stack_chart_sets`); the points of each input's
    :class:`PlatformSearch` carry its own chart numbers (0..C-1). Each input's boxes and roots are
    those :func:`search_platform` finds for it alone (see :func:`_loop`); an input that reaches a
    cap gets None (:func:`search_platform` on its own raises the cap's error). The counters are
    each input's; LP counters and seconds are its share of the chunk's. ``progress(counts)``: as in
    :func:`solve_system`, with the chunk's counters summed.
    """
    t0 = time.perf_counter()
    owner = _owner(charts, n_inputs)
    per = charts.n_charts // n_inputs
    lp0, doubts0 = getattr(pruner, "lp_count", 0), getattr(pruner, "doubts", 0)
    if max_depth is None:
        max_depth = DEPTH_PER_UNKNOWN * len(charts.variables)
    batch = _chunk_batch(n_inputs) if batch is None else batch
    loop = _loop(charts, pruner, tol, max_boxes, max_depth, None, True, progress, None, owner, n_inputs, batch)
    points, spurious, failed = _solve_isolated(charts, loop.isolated)
    points_of = _by_input(points, owner, n_inputs)
    accepted_n = np.bincount(owner[[a[0] for a in loop.accepted]].astype(int), minlength=n_inputs) \
        if loop.accepted else np.zeros(n_inputs, dtype=int)
    failed_n = np.bincount(owner[[f[0] for f in failed]].astype(int), minlength=n_inputs) \
        if failed else np.zeros(n_inputs, dtype=int)
    spurious_n = np.bincount(owner[spurious], minlength=n_inputs)
    share = _shares(loop, n_inputs, pruner, lp0, doubts0, time.perf_counter() - t0)
    out = []
    for k in range(n_inputs):
        if loop.capped[k]:
            out.append(None)
            continue
        t_r, t_p, t_i = share["times"][k]
        stats = SolverStats(charts=per, **{name: int(v[k]) for name, v in loop.counts.items()},
                            spurious=int(spurious_n[k]), newton_failures=int(failed_n[k]),
                            lps_solved=int(share["lps"][k]), lp_doubts=int(share["doubts"][k]),
                            time_restrict=t_r, time_prune=t_p, time_isolate=t_i, time_total=float(share["total"][k]))
        mine = tuple(sorted(((c - k * per, x) for c, x in points_of[k]), key=_chart_order))
        out.append(PlatformSearch(mine, int(accepted_n[k] + failed_n[k] + spurious_n[k]), stats))
    return tuple(out)


def solve_system_many(charts: ChartSet, n_inputs: int, ranges: Mapping[str, tuple[float, float] | None], *,
                      formulation: str, pruner: str, lp_backend: str | None, parameterization: str, tol: float,
                      isolate: bool = True, max_boxes: int = DEFAULT_MAX_BOXES, max_depth: int | None = None,
                      pruners: dict | None = None, t_setup: float = 0.0,
                      progress: Callable[[dict], None] | None = None, batch: int | None = None) -> tuple:
    """:func:`solve_system` (``jobs=1``) for each input of a chunk, as one box loop over all their boxes.

    ``charts``: the loop equations' chart sets of the ``n_inputs`` inputs stacked input-major
    (:func:`spherekin.search.parameterizations.stack_chart_sets`), over the joint ``ranges`` shared
    by every input; ``t_setup``: the seconds it took to build them (each input gets its share).
    Returns one :class:`SearchReport` per input, the one :func:`solve_system` gives for it alone
    (see :func:`_loop`), or None where the input reached a cap (:func:`solve_system` on its own
    raises the cap's error, with what it found). Counters as in :func:`search_platform_many`.
    """
    check_strategy(formulation, pruner, lp_backend, parameterization, tol, 1)
    t0 = time.perf_counter()
    owner = _owner(charts, n_inputs)
    per = charts.n_charts // n_inputs
    if max_depth is None:
        max_depth = DEPTH_PER_UNKNOWN * len(charts.variables)
    built = pruner_for(charts, pruner, lp_backend, pruners)
    lp0, doubts0 = getattr(built, "lp_count", 0), getattr(built, "doubts", 0)
    batch = _chunk_batch(n_inputs) if batch is None else batch
    try:
        loop = _loop(charts, built, tol, max_boxes, max_depth, None, isolate, progress, None, owner, n_inputs, batch)
    except SolverLimitError as exc:          # Ctrl-C: the work done until then, as solve_system counts it
        exc.add_stats(charts=per, lps_solved=getattr(built, "lp_count", 0) - lp0,
                      lp_doubts=getattr(built, "doubts", 0) - doubts0, time_setup=t_setup,
                      time_total=time.perf_counter() - t0 + t_setup)
        raise
    points, spurious, failed = _solve_isolated(charts, loop.isolated)
    accepted = loop.accepted
    counts = {name: v.copy() for name, v in loop.counts.items()}
    capped = loop.capped.copy()
    if failed:  # Newton left an isolating box (not seen in practice): subdivide it the ordinary way
        c, a, b = (np.array(v) for v in zip(*failed))
        more = _loop(charts, built, tol, max_boxes, max_depth, (c, a, b), False, None, None, owner, n_inputs, batch)
        accepted = accepted + more.accepted
        counts = {name: (np.maximum(v, more.counts[name]) if name == "max_depth" else v + more.counts[name])
                  for name, v in counts.items()}
        capped |= more.capped
    share = _shares(loop, n_inputs, built, lp0, doubts0, time.perf_counter() - t0)
    spurious_n = np.bincount(owner[spurious], minlength=n_inputs)
    failed_n = np.bincount(owner[[f[0] for f in failed]].astype(int), minlength=n_inputs) \
        if failed else np.zeros(n_inputs, dtype=int)
    accepted_of = _by_input(accepted, owner, n_inputs)
    points_of = _by_input(points, owner, n_inputs)
    settings = Settings(formulation=formulation, pruner=pruner, lp_backend=lp_backend,
                        parameterization=parameterization, tol=tol, isolate=isolate, jobs=1, charts=per)
    boxes_of, found_of = [], []
    for k in range(n_inputs):
        mine = sorted(((c - k * per, lo, hi) for c, lo, hi in accepted_of[k]), key=_chart_order)
        roots = sorted(((c - k * per, x) for c, x in points_of[k]), key=_chart_order)
        boxes_of.append([AcceptedBox(lo, hi, int(c)) for c, lo, hi in mine])
        found_of.append([] if capped[k] else [(b.lo, b.hi) for b in boxes_of[-1]] + [(x, x) for _, x in roots])
    found = [box for f in found_of for box in f]
    clusters_of = clusters_in_range_many([a for a, _ in found], [b for _, b in found],
                                         np.repeat(np.arange(n_inputs), [len(f) for f in found_of]),
                                         n_inputs, ranges, tol)
    out = []
    for k in range(n_inputs):
        if capped[k]:
            out.append(None)
            continue
        t_r, t_p, t_i = share["times"][k]
        stats = SolverStats(charts=per, **{name: int(v[k]) for name, v in counts.items()},
                            spurious=int(spurious_n[k]), newton_failures=int(failed_n[k]),
                            lps_solved=int(share["lps"][k]), lp_doubts=int(share["doubts"][k]),
                            time_setup=t_setup / n_inputs, time_restrict=t_r, time_prune=t_p, time_isolate=t_i,
                            time_total=float(share["total"][k]) + t_setup / n_inputs)
        out.append(SearchReport(charts.unknowns, tuple(clusters_of[k]), tuple(boxes_of[k]), stats, settings))
    return tuple(out)


def _worker(args):
    charts, (pruner, lp_backend), *rest = args
    return _run_group(charts, pruner_for(charts, pruner, lp_backend), *rest)   # each worker builds its own


def check_strategy(formulation, pruner, lp_backend, parameterization, tol, jobs):
    """ValueError naming the first strategy name or number that is not valid (names: from the
    registries; ``formulation`` None: not a loop formulation, checked by the caller); builds nothing."""
    if formulation is not None:
        FORMULATIONS.lookup(formulation)
    check_pruner(pruner, lp_backend)
    PARAMETERIZATIONS.lookup(parameterization)
    if isinstance(tol, bool) or not (isinstance(tol, (int, float)) and math.isfinite(tol) and tol > 0):
        raise ValueError(f"tol: expected a positive number of radians, got {tol!r}")
    if tol > MAX_TOL:
        raise ValueError(f"tol: expected at most {MAX_TOL:g} rad, got {tol!r}: a coarser box could hold "
                         "several assemblies, which polishing would merge or move (the tolerance is the size of the "
                         "boxes the search stops at; the solutions are polished to ~1e-15 whatever it is)")
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise ValueError(f"jobs: expected a positive integer, got {jobs!r}")


def solve_system(
    build: Callable[[Mapping[str, tuple[float, float]]], tuple[Sequence[ClosureLoop], Sequence[Unknown]]],
    ranges: Mapping[str, tuple[float, float] | None],
    *,
    formulation: str = DEFAULT_FORMULATION,
    pruner: str = DEFAULT_PRUNER,
    lp_backend: str | None = None,
    parameterization: str = DEFAULT_PARAMETERIZATION,
    tol: float = DEFAULT_TOL,
    isolate: bool = True,
    jobs: int = 1,
    max_boxes: int = DEFAULT_MAX_BOXES,
    max_depth: int | None = None,
    progress: Callable[[dict], None] | None = None,
    trace: Callable[[dict], None] | None = None,
    pruners: dict | None = None,
    charts: ChartSet | None = None,
) -> SearchReport:
    """All roots of a system of closure loops inside the joint ranges (Section 4, Eq. 12).

    ``build(chart_ranges)`` returns (loops, unknowns) with every unknown's range set from
    ``chart_ranges`` (name -> (lo, hi) radians, width < 2 pi); ``ranges`` gives each unknown's
    joint range, or None for the full circle. ``tol`` is in radians. ``isolate``: stop subdividing
    a box once the Krawczyk test proves it holds one root (:mod:`spherekin.search.isolation`); only with
    a formulation that has a square system of simple roots. ``jobs``: Dask worker processes for
    the charts, on a local cluster started for the search (:mod:`spherekin.cluster`; ~2-3 s to
    start, worth it for searches of many seconds; the solutions do not depend on it; where starting
    one is not safe, e.g. an unguarded script, the charts run here and a warning says why). ``progress(counts)`` is called before each batch
    of boxes with the running counters (and "pending": boxes waiting; with ``jobs > 1`` once per
    finished worker). ``max_boxes`` (per worker) and ``max_depth`` (default DEPTH_PER_UNKNOWN per
    variable) cap the search; reaching a cap raises a :class:`SolverLimitError` subclass.
    Solutions whose angles lie outside ``ranges`` (the sin-cos boxes of limited ranges hold whole
    circles' worth of corners) are dropped.

    ``trace(record)``, for experiments (only with ``jobs=1``), is called once per batch of boxes
    with arrays over the batch: ``chart`` (B,), ``depth`` (B,), the box ``lo``, ``hi`` and its
    reduction ``reduced_lo``, ``reduced_hi`` (B, N) in the chart's unit coordinates, its sides in
    metric units ``metric_width`` (B, N; radians for tan-half) and ``outcome`` (B,): an index
    into :data:`TRACE_OUTCOMES`.

    ``pruners``: a dict the caller keeps across calls (a compiled :class:`spherekin.problem.Problem`
    keeps one for all its inputs), in which the pruner is built once per chart layout
    (:func:`pruner_for`) instead of once per call; with ``jobs > 1`` each worker builds its own.

    ``charts``: the chart set of ``build`` over ``ranges`` when the caller has it already (a
    compiled one: :meth:`spherekin.systems.loops.CompiledLoops.charts_many`); ``build`` is then not called.
    """
    check_strategy(formulation, pruner, lp_backend, parameterization, tol, jobs)
    if trace is not None and jobs != 1:
        raise ValueError(f"trace: only available with jobs=1, got jobs={jobs}")
    t0 = time.perf_counter()
    if charts is None:
        charts = make_charts(parameterization, build, ranges, formulation)
    t_setup = time.perf_counter() - t0
    if max_depth is None:
        max_depth = DEPTH_PER_UNKNOWN * len(charts.variables)
    groups = [list(range(i, charts.n_charts, jobs)) for i in range(min(jobs, charts.n_charts))]
    if len(groups) == 1:
        built = pruner_for(charts, pruner, lp_backend, pruners)
        try:
            results = [_run_group(charts, built, tol, max_boxes, max_depth, isolate, groups[0], progress, trace)]
        except SolverLimitError as exc:
            exc.add_stats(charts=charts.n_charts, time_setup=t_setup, time_total=time.perf_counter() - t0)
            raise
    else:
        from ..cluster import connect, map_in_order

        # the chart groups on a local Dask cluster of len(groups) worker processes (spherekin.cluster)
        args = [(charts, (pruner, lp_backend), tol, max_boxes, max_depth, isolate, g) for g in groups]
        results = []
        with connect(workers=len(groups)) as client:
            if client is None:      # no local cluster here (spherekin.cluster.local_cluster_unsafe): say so
                jobs = 1
            for res in map_in_order(client, _worker, args):
                results.append(res)
                if progress is not None:
                    progress({**res[2], "pending": 0})
    accepted = sorted((a for r in results for a in r[0]), key=_chart_order)
    points = sorted((p for r in results for p in r[1]), key=_chart_order)
    counts = {k: sum(r[2][k] for r in results) for k in results[0][2]}
    counts["max_depth"] = max(r[2]["max_depth"] for r in results)
    t_restrict, t_prune, t_isolate = (sum(r[3][i] for r in results) for i in range(3))
    boxes = [AcceptedBox(a, b, int(c)) for c, a, b in accepted]
    found = boxes + [AcceptedBox(a, a.copy(), c) for c, a in points]
    clusters = clusters_in_range(found, ranges, tol)
    stats = SolverStats(charts=charts.n_charts, **counts, time_setup=t_setup, time_restrict=t_restrict,
                        time_prune=t_prune, time_isolate=t_isolate, time_total=time.perf_counter() - t0)
    settings = Settings(formulation=formulation, pruner=pruner, lp_backend=lp_backend,
                        parameterization=parameterization, tol=tol, isolate=isolate, jobs=jobs, charts=charts.n_charts)  # jobs: those used
    return SearchReport(charts.unknowns, tuple(clusters), tuple(boxes), stats, settings)


def partial_report(exc: SolverLimitError, ranges, settings: Settings) -> SearchReport:
    """A report from the accepted boxes a capped or interrupted search had found (its clusters) and the
    statistics of the work it did; ``settings``: those of the stopped search (its chart count from ``exc``)."""
    found = list(exc.partial)
    clusters = clusters_in_range(found, ranges, settings.tol)
    settings = dataclasses.replace(settings, charts=exc.stats.charts)
    return SearchReport(tuple(ranges), tuple(clusters), tuple(found), exc.stats, settings)


def clusters_in_range(found: list[AcceptedBox], ranges, tol) -> list[Cluster]:
    """The clusters of the boxes found whose centres lie within the joint ranges (tol + RANGE_TOL)."""
    return [c for c in _merge(found, tol) if _within(c.angles, ranges, tol)]


#: :func:`clusters_in_range_many` compares the boxes of an input pairwise in one padded array (inputs
#: x P x P x unknowns) when it has at most this many: the common case (a few roots, each one box or
#: point); an input with more (a covering, a near-double root's stray boxes) is merged on its own.
PADDED_MAX_BOXES = 32


def clusters_in_range_many(lo, hi, owner, n_inputs: int, ranges, tol) -> list[list[Cluster]]:
    """:func:`clusters_in_range` of the boxes of each of ``n_inputs`` inputs at once: ``lo``, ``hi``
    (N, M; radians) the boxes, ``owner`` (N,) the input of each (each input's boxes in the order
    given); one list of clusters per input, the same clusters (same floats, same order) as
    clusters_in_range of that input's boxes.

    The common case runs as array operations over the chunk: an input whose boxes are pairwise far
    apart (no two near, :func:`spherekin.core.angles.near` with the gap of MERGE_GAP_TOLS * tol) has
    one cluster per box; its centre, range test and order are computed for all such boxes at once.
    Any other input (or one with more than PADDED_MAX_BOXES boxes) is merged on its own (_merge).
    """
    owner = np.asarray(owner, dtype=np.intp)
    if not len(owner):
        return [[] for _ in range(n_inputs)]
    lo = np.array(lo, dtype=float).reshape(len(owner), -1)
    hi = np.array(hi, dtype=float).reshape(len(owner), -1)
    m = lo.shape[1]
    counts = np.bincount(owner, minlength=n_inputs)
    small = counts <= PADDED_MAX_BOXES
    width = int(counts[small].max(initial=0))
    mid, _ = pad_by_owner(0.5 * (lo + hi), owner, n_inputs, width)               # NaN: no box
    half, _ = pad_by_owner(0.5 * (hi - lo), owner, n_inputs, width)
    close = near(mid[:, :, None], half[:, :, None], mid[:, None], half[:, None], MERGE_GAP_TOLS * tol)
    alone = small & ~np.any(np.triu(close, 1), axis=(1, 2))
    # one cluster per box of the inputs alone (_merge's floats for a group of one box)
    centre = wrap(0.5 * (lo + hi)).reshape(len(owner), m)
    keep = alone[owner]
    for j, rng in enumerate(ranges.values()):
        keep &= in_range_many(centre[:, j], rng, tol + RANGE_TOL)
    rounded = np.round(centre, 9)
    ranked = np.lexsort([*(rounded[:, j] for j in range(m - 1, -1, -1)), owner])   # by input, then angles
    ranked = ranked[keep[ranked]]
    members = np.stack((lo, hi), axis=1)[:, None]                                  # (N, 1, 2, M)
    out: list[list[Cluster]] = [[] for _ in range(n_inputs)]
    of = owner.tolist()
    for i in ranked.tolist():
        out[of[i]].append(Cluster(centre[i], lo[i], hi[i], 1, members=members[i]))
    for k in np.flatnonzero(~alone & (counts > 0)).tolist():
        out[k] = clusters_in_range([AcceptedBox(lo[i], hi[i], 0) for i in np.flatnonzero(owner == k)], ranges, tol)
    return out


def _within(angles, ranges, tol) -> bool:
    """Every angle within ``tol`` of its closed range (modulo 2 pi, :func:`spherekin.core.angles.in_range`)."""
    return all(in_range(a, rng, tol + RANGE_TOL) for a, rng in zip(angles, ranges.values()))


def _merge(boxes: list[AcceptedBox], tol: float) -> list[Cluster]:
    """Union of boxes closer than MERGE_GAP_TOLS * tol (angles modulo 2 pi) into clusters."""
    if not boxes:
        return []
    lo = np.array([b.lo for b in boxes])
    hi = np.array([b.hi for b in boxes])
    mid = 0.5 * (lo + hi)
    out = []
    for members in near_groups(lo, hi, MERGE_GAP_TOLS * tol):
        ref = mid[members[0]]
        # unwrap every member next to the first one, then take the hull
        shift = np.round((mid[members] - ref) / (2 * math.pi)) * 2 * math.pi
        glo, ghi = (lo[members] - shift).min(axis=0), (hi[members] - shift).max(axis=0)
        centre = wrap(0.5 * (glo + ghi))
        out.append(Cluster(centre, glo, ghi, len(members),
                           members=np.stack((lo[members] - shift, hi[members] - shift), axis=1)))
    out.sort(key=lambda s: tuple(np.round(s.angles, 9)))
    return out


@dataclasses.dataclass(frozen=True, eq=False)
class Cover:
    """What :func:`search_cover` hands over: a cover of the solution set of an under-determined system.

    ``accepted``: (chart (A,), lo (A, N), hi (A, N)): the accepted boxes, in the chart set's angle
    coordinates (:meth:`ChartSet.angle_box`); ``pending``: (chart (P,), lo (P, N), hi (P, N)): the
    boxes left unprocessed when ``max_boxes`` was reached, in unit-box coordinates (empty when the
    search finished). Every solution in the charts lies in an accepted or a pending box.
    ``boxes_processed``, ``seconds``: the work done.
    """

    accepted: tuple
    pending: tuple
    boxes_processed: int
    seconds: float

    @property
    def complete(self) -> bool:
        """True when no box was left unprocessed."""
        return len(self.pending[0]) == 0


def _box_arrays(boxes, n: int) -> tuple:
    """(chart (B,), lo (B, n), hi (B, n)) of a list of (chart, lo, hi)."""
    if not boxes:
        return np.zeros(0, dtype=int), np.zeros((0, n)), np.zeros((0, n))
    return (np.array([int(c) for c, _, _ in boxes]), np.array([a for _, a, _ in boxes], dtype=float),
            np.array([b for _, _, b in boxes], dtype=float))


def search_cover(charts: ChartSet, pruner, tol: float, max_boxes: int, start=None, budget=None) -> Cover:
    """A cover of the solutions of ``charts`` (any number of equations in N variables, no isolation):
    the box loop (:func:`_loop`) accepting boxes whose metric sides are all below ``tol *
    charts.accept_width``. ``pruner``: built for the pruned blocks (:func:`pruner_for`); ``start``:
    (chart, lo, hi) initial boxes (default: every chart's unit box). Reaching ``max_boxes`` (or the
    depth cap, DEPTH_PER_UNKNOWN per variable, or a ``budget`` that names a reason to stop:
    :class:`spherekin.budget.Budget`) stops the loop and the unprocessed boxes come back as
    ``pending``, never dropped: outside the accepted and pending boxes the charts hold no solution
    (every other box was discarded because some equation's Bernstein hull, widened by its
    tolerance, excludes 0)."""
    t0 = time.perf_counter()
    n = len(charts.variables)
    loop = _loop(charts, pruner, tol, max_boxes, DEPTH_PER_UNKNOWN * n, start, False, keep_pending=True,
                 budget=budget)
    return Cover(_box_arrays(loop.accepted, n), _box_arrays(loop.pending, n),
                 int(loop.counts["boxes_processed"][0]), time.perf_counter() - t0)
