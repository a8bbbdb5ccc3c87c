"""The certified singular set of a plane (or a line) of inputs: the cover, its cells and cusps (issue 31).

:func:`singular` checks the plane, chooses its augmented system through the systems' seam
(:func:`spherekin.singularities.planes.plane_system`: the first system of the registry that accepts
the mechanism and has a plane system), covers it with the box loop
(:func:`spherekin.search.boxloop.search_cover`, traced), certifies the cells and cusps
(:mod:`spherekin.singularities.cells`) and, on a line, holds the cover against the proven counts of
solves between its cells (:func:`_line_cross_check`). A mechanism with stationary assemblies is covered
as two systems (:mod:`spherekin.singularities.blowup`).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from ..budget import Budget
from ..core.angles import RANGE_TOL, check_turn, in_range, into_range
from ..problem import as_mechanism, compile
from ..results import CrossCheck, Cusp, CuspSearch, SingularBox, SingularSet, SingularStats
from ..search.boxloop import DEFAULT_PRUNER, pruner_for, search_cover
from .blowup import StationaryPlane, outside
from .cell_width import CUSP_REFINE_FRACTIONS, REFINE_FRACTIONS, SINGULAR_TOL, check_singular_tol
from .cells import SINGULAR, Grid, merge_cusps, outside_regions, region_candidates
from .planes import SingularPlane, plane_system

__all__ = ["SINGULAR_MAX_BOXES", "COVER_FRACTION", "CUSP_FRACTION",
           "CUSP_VECTORS", "CROSS_CHECK_POINTS", "CROSS_CHECK_INSET",
           "singular"]

#: The fixed vectors r of the tangency C_r = grad D . (adj(G) r) (:meth:`PlatformPlane.cusp_charts`): seeded, so that
#: the spurious factor l . r = 0 meets the curve only at isolated points; the second rules those points out.
CUSP_VECTORS = ((0.5390, -0.7270, 0.4253), (-0.3120, 0.2240, 0.9233))


#: Default box cap of the singular-set cover (boxes of the augmented system processed, all rounds). Reason:
#: general_3rrr over [-pi, pi]^2 with the traced cover processes ~1.5e6 boxes at T = 0.01 and ~3e6 at 1e-3
#: (measured; 5.7e6 at 0.01 before the tracing); the cap only stops a runaway (a continuum of singular configurations over
#: a 2-D region of the plane), whose unprocessed boxes are reported ``unresolved``.
SINGULAR_MAX_BOXES = 10_000_000
#: The cover accepts a box of the augmented system when every side is at most this fraction of the cell width
#: T (radians for the plane inputs, chart units for the orientation). Reason: a box then meets at most two
#: cells per axis, so the covered cells stay close to the curve (a box of side T meets up to 3).
COVER_FRACTION = 0.5
#: The cusp system's boxes are accepted below this fraction of T: small enough that a cluster of them is
#: one root whose hull Newton and the Krawczyk test handle (a cusp is a regular root of (F, D, C_r)).
CUSP_FRACTION = 0.25
def _plane_axis(mech, key: str, spec) -> tuple:
    """(name, lo, hi) of a plane axis given as (name, lo, hi) (radians): ValueError naming ``key``."""
    try:
        name, lo, hi = spec
        lo, hi = float(lo), float(hi)
    except (TypeError, ValueError):
        raise ValueError(f"{key}: expected (name, lo, hi) with an actuated joint and radians, got {spec!r}") from None
    if name not in mech.actuated:
        raise ValueError(f"{key}: expected an actuated joint ({', '.join(mech.actuated)}), got {name!r}")
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
        raise ValueError(f"{key}: expected finite lo < hi (radians), got lo = {lo:.6g}, hi = {hi:.6g}")
    check_turn(f"{key} ({name}) lo", lo)       # what solve refuses as an input, a plane refuses too
    check_turn(f"{key} ({name}) hi", hi)
    if hi - lo > 2 * np.pi + 1e-12:
        raise ValueError(f"{key}: expected hi - lo <= 2 pi (one turn), got {hi - lo:.6g}")
    rng = mech.ranges[name]
    if rng is not None and not (in_range(lo, rng) and into_range(lo, rng) + (hi - lo) <= rng[1] + RANGE_TOL):
        raise ValueError(f"{key}: the window [{lo:.6g}, {hi:.6g}] of {name} leaves its joint range "
                         f"[{rng[0]:.6g}, {rng[1]:.6g}]; choose a window inside it (inputs outside the range are "
                         "never solved)")
    return (str(name), lo, hi)


@dataclass(frozen=True)
class _PlaneRun:
    """What one cover of a plane system hands to :func:`singular`: ``cells`` ((i, j) -> CellStatus), the
    cusp candidates (singularities.cells.CuspStatus), and the work: boxes processed (``used``), box-loop seconds,
    boxes accepted and pending (pending > 0: the cap was reached), the boxes set aside in crowded cells
    (``crowded``, :data:`spherekin.singularities.cells.CROWDED_CELL`), and the unresolved ``regions`` of the
    pending and crowded boxes (grid index ranges, :func:`spherekin.singularities.cells.pending_regions`)."""

    cells: dict
    cusps: tuple
    used: int
    seconds: float
    accepted: int
    pending: int
    regions: tuple = ()
    crowded: int = 0
    cusps_searched: bool = True


def _plane_run(system, grid, tol: float, max_boxes: int, start, cusps, budget) -> _PlaneRun:
    """The certified cover of one plane system (:func:`singular`): the traced cover (a plane; a line: the
    plain cover) from the boxes ``start`` (None: every chart), the cusp search (``cusps``: "tangency", the
    cusp system of :meth:`PlatformPlane.cusp_charts`; "rank", the candidates of
    :func:`spherekin.singularities.cells.rank_candidates`; None: none), the cells' certificates, the unresolved
    cells' pieces searched again (REFINE_FRACTIONS), the traced cells added. Once ``budget``
    (:class:`spherekin.budget.Budget`) names a reason to stop, every stage hands over what it has (boxes not
    processed: pending; cells not tested: unresolved) and the later stages are skipped (the cusps: not searched)."""
    from .cells import (SINGULAR, UNRESOLVED, CellStatus, cell_pieces, certify_cover, certify_cusps,
                                 pending_regions, rank_candidates, trace_cover)

    pruner = pruner_for(system.charts, DEFAULT_PRUNER, None)
    traced = None
    if hasattr(system, "trace") and len(system.plane_columns) == 2:
        # certified tracing (singularities/cells.trace_cover): boxes whose branch is proven a graph stop early
        def search(width, cap, begin):
            return search_cover(system.charts, pruner, width, cap, start=start if begin is None else begin,
                                budget=budget)

        traced = trace_cover(system, search, grid, tol, COVER_FRACTION, max_boxes, budget)
        cover = traced.cover
    else:
        cover = search_cover(system.charts, pruner, COVER_FRACTION * tol, max_boxes, start=start, budget=budget)
    used, t_cover, accepted, pending = cover.boxes_processed, cover.seconds, len(cover.accepted[0]), cover.pending
    accepted += 0 if traced is None else traced.traced
    first = cover
    cells = {(c.i, c.j): c for c in certify_cover(system, cover, grid, budget)}
    # the cells left unresolved: the accepted boxes over them cut by the cell and searched again with smaller
    # boxes (pieces over a cell the curve misses are discarded, the hulls certified are tighter); the pending
    # boxes of every round are kept (their cells stay unresolved). ``final`` (the rank route only): the pieces
    # of every round over the cells it leaves (unit boxes), where the rank candidates are taken
    rank = cusps == "rank" and len(system.plane_columns) == 2
    final = []
    for fraction in REFINE_FRACTIONS:
        again = {k for k, c in cells.items() if c.status != SINGULAR}
        if not again or budget.exhausted():
            break
        if rank:
            final.append(cell_pieces(system, cover.accepted, grid, set(cells) - again))
        cover = search_cover(system.charts, pruner, fraction * tol, max(1, max_boxes - used),
                             start=cell_pieces(system, cover.accepted, grid, again), budget=budget)
        pending = tuple(np.concatenate([a, b]) for a, b in zip(pending, cover.pending))
        cover = dataclasses.replace(cover, pending=pending)
        used, t_cover, accepted = used + cover.boxes_processed, t_cover + cover.seconds, accepted + len(cover.accepted[0])
        for k in again:
            del cells[k]
        cells.update({(c.i, c.j): c for c in certify_cover(system, cover, grid, budget) if (c.i, c.j) in again})
    cands = ()
    searched = not budget.exhausted()
    if not searched:
        pass                            # stopped: the cusps are not searched (the list claims nothing)
    elif rank:
        # no tangency system on these variables: the untraced and pending boxes not proven cusp-free
        chart, alo, ahi = cover.accepted
        final.append((chart, system.unit(chart, alo), system.unit(chart, ahi)) if len(chart) else
                     (chart, alo, ahi))
        chart, ulo, uhi = (np.concatenate(parts) for parts in zip(*final))
        pchart, plo, phi = pending
        cands = rank_candidates(system, np.concatenate([chart, pchart]), np.concatenate([ulo, plo]),
                                np.concatenate([uhi, phi]), grid)
    elif cusps == "tangency" and len(system.plane_columns) == 2:
        # the cusp system (curve + tangency) searched again from the traced cover's accepted boxes (every
        # singular configuration of the plane lies in them, in the traced boxes, which hold no cusp
        # (trace_cover), or in the pending ones, whose cells stay unresolved). Not from the refined pieces
        # nor without the boxes proven cusp-free (faster): measured on general_3rrr at T = 1e-2, Newton then
        # missed the cusp near (1.5923, 0.1041) (proven from a neighbouring box's wider start)
        cusp_sets = system.cusp_charts(CUSP_VECTORS)
        chart = first.accepted[0]
        begin = (chart, system.unit(chart, first.accepted[1]), system.unit(chart, first.accepted[2]))
        found = search_cover(cusp_sets[0], pruner_for(cusp_sets[0], DEFAULT_PRUNER, None), CUSP_FRACTION * tol,
                             max(1, max_boxes - used), start=begin, budget=budget)
        used, t_cover = used + found.boxes_processed, t_cover + found.seconds
        cands = certify_cusps(system, cusp_sets, found)
        # candidates without a proof: their boxes searched again with smaller boxes (most hold no root and are
        # discarded; the hulls Newton and the Krawczyk test see get tighter)
        for fraction in CUSP_REFINE_FRACTIONS:
            open_ = [c for c in cands if c.status != "cusp"]
            chart, alo, ahi = found.accepted
            if not open_ or not len(chart) or len(found.pending[0]) or budget.exhausted():
                break                   # (a capped search keeps its pending candidates unresolved)
            cols = list(system.plane_columns)
            near = np.zeros(len(chart), dtype=bool)
            for c in open_:
                near |= ((alo[:, cols[0]] <= c.box_x[1]) & (ahi[:, cols[0]] >= c.box_x[0])
                         & (alo[:, cols[1]] <= c.box_y[1]) & (ahi[:, cols[1]] >= c.box_y[0]))
            begin = (chart[near], system.unit(chart[near], alo[near]), system.unit(chart[near], ahi[near]))
            found = search_cover(cusp_sets[0], pruner_for(cusp_sets[0], DEFAULT_PRUNER, None), fraction * tol,
                                 max(1, max_boxes - used), start=begin, budget=budget)
            used, t_cover = used + found.boxes_processed, t_cover + found.seconds
            cands = tuple(c for c in cands if c.status == "cusp") + certify_cusps(system, cusp_sets, found)
    if traced is not None:
        # the traced boxes' cells (in the cover whatever the searched boxes say), singular where proven
        for k in traced.met | traced.proven:
            if k in traced.proven or (k in cells and cells[k].status == SINGULAR):
                cells[k] = CellStatus(k[0], k[1], SINGULAR)
            elif k not in cells:
                cells[k] = CellStatus(k[0], k[1], UNRESOLVED)
    aside = traced.crowded if traced is not None else tuple(a[:0] for a in pending)     # crowded cells' boxes
    regions = pending_regions(system, grid, tuple(np.concatenate(ab) for ab in zip(pending, aside)))
    return _PlaneRun(cells, tuple(cands), used, t_cover, accepted, len(pending[0]), regions, len(aside[0]), searched)


#: A line's cover is held against proven counts (:func:`_line_cross_check`) at this many inputs of each free
#: interval (between two cells): its two ends, each moved inward by CROSS_CHECK_INSET of min(T, its length), and
#: the points between them evenly. Reason: a missed branch point changes the count between some two of them;
#: the ends are where a cell placed off the true point leaves it (issue 40: cells 0.02-0.07 off), and 3
#: solves per cell cost ~0.1 s on a six-bar.
CROSS_CHECK_POINTS = 3
#: ... inset of the ends: far enough from a cell that the solve there is not next to its fold (slow, flagged).
CROSS_CHECK_INSET = 0.25


def _free_intervals(boxes, lo: float, hi: float) -> list[tuple[float, float]]:
    """The parts of [lo, hi] outside every box's x-range (closed boxes, merged), in order."""
    out, at = [], lo
    for a, b in sorted((b.x[0], b.x[1]) for b in boxes):
        if a > at:
            out.append((at, a))
        at = max(at, b)
    if at < hi:
        out.append((at, hi))
    return out


def _line_cross_check(mech, ax, fixed, boxes, tol: float, applies_ranges: bool):
    """A line's cover held against proven counts (issue 40 item 3): solve at CROSS_CHECK_POINTS inputs of each
    free interval (:func:`_free_intervals`) and compare the exact counts within each interval; a
    :class:`spherekin.results.CrossCheck`. The counts are of the mechanism the cover describes: the platform
    system's cover ignores every joint range, so do its counts; the loop equations' cover applies the passive
    ranges, so a count could change where an assembly leaves its range (no singularity): skipped then."""
    ranged = [n for n in mech.passive if mech.joint(n).range is not None]
    if ranged and applies_ranges:
        return CrossCheck(skipped=f"passive joint ranges ({', '.join(ranged)}): a count also changes where an "
                                  "assembly leaves its range")
    free = mech.without_ranges()
    rows, owner = [], []
    for k, (a, b) in enumerate(_free_intervals(boxes, ax[1], ax[2])):
        inset = CROSS_CHECK_INSET * min(tol, b - a)
        for u in np.linspace(a + inset, b - inset, CROSS_CHECK_POINTS):
            rows.append([u if n == ax[0] else fixed[n] for n in free.actuated])
            owner.append(k)
    if not rows:
        return CrossCheck()
    reports = compile(free).solve_many(np.array(rows))
    seen: dict = {}
    out = []
    for k, row, rep in zip(owner, rows, reports):
        if not rep.count_exact:
            continue
        x = row[free.actuated.index(ax[0])]
        if k in seen and seen[k][1] != rep.proven_count:
            out.append(((float(seen[k][0]), float(x), None, None), (seen[k][1], rep.proven_count)))
        seen[k] = (x, rep.proven_count)
    return CrossCheck(len(rows), sum(r.count_exact for r in reports), tuple(out))


def singular(mechanism, x, y=None, fixed: Mapping[str, float] | None = None, *, tol: float = SINGULAR_TOL,
             max_boxes: int = SINGULAR_MAX_BOXES, budget=None):
    """The parallel (Type-2) singular set of ``mechanism`` in a plane of inputs, certified (issue 31).

    ``x`` = (name, lo, hi), ``y`` = (name, lo, hi) or None (a line): actuated joints and ranges (radians,
    at most one turn); ``fixed``: every other actuated joint's reading (radians). ``tol``: the cells' width
    bound T (radians). Returns a :class:`spherekin.results.SingularSet`: the cells of a grid of width <= T
    that the cover of the augmented system meets, each ``singular`` (a singular configuration proven at an
    input of the cell) or ``unresolved``; the plane outside them is proven free of parallel singularities
    (:mod:`spherekin.singularities.cells`). ``max_boxes`` caps the cover: when reached, ``complete`` is False and
    the unprocessed part of the plane is in ``unresolved`` regions (boxes wider than a cell, each a cusp
    candidate too: :func:`spherekin.singularities.cells.pending_regions`). The system is chosen as a solve's: the
    platform system (three R-R-R legs; passive joint ranges not applied: the set may hold singular
    configurations with passive joints out of range) where it applies, else the loop equations (3 passive
    joints per loop: four-bars, five-bars, six-bars; passive ranges applied). A platform with stationary
    assemblies (orientations closing every input: the agile eye's four) is covered as two systems: the plane
    system without a box U about each, and U blown up (:mod:`spherekin.singularities.blowup`), where the other
    assemblies' crossings with them become regular roots that the Krawczyk slices prove; the cusp
    candidates of both are then the boxes not proven cusp-free (no tangency system there).

    ``budget``: a :class:`spherekin.budget.Budget` (default: one with the machine's memory cap,
    :data:`spherekin.budget.MEMORY_FRACTION` of its memory). When it names a reason to stop (the memory cap, or
    a signal the command line turned into a stop), the run ends as at the box cap: ``complete`` False,
    ``stopped`` the reason, the unprocessed part unresolved regions, untested cells unresolved, cusps not searched.
    """
    mech = as_mechanism(mechanism)
    ax = _plane_axis(mech, "x", x)
    ay = None if y is None else _plane_axis(mech, "y", y)
    if ay is not None and ay[0] == ax[0]:
        raise ValueError(f"y: expected another actuated joint than x, got {ay[0]!r} twice")
    fixed = dict(fixed or {})
    for name, value in fixed.items():
        if name not in mech.actuated:
            raise ValueError(f"fixed: expected actuated joints ({', '.join(mech.actuated)}), got {name!r}")
        if name in (ax[0], None if ay is None else ay[0]):
            raise ValueError(f"fixed: {name} is an axis of the plane, it cannot also be fixed")
        if not np.isfinite(float(value)):
            raise ValueError(f"fixed: expected a finite reading (radians) for {name}, got {value!r}")
        check_turn(f"fixed ({name})", float(value))
        rng = mech.ranges[name]
        if rng is not None and not in_range(float(value), rng):
            raise ValueError(f"fixed ({name}): {float(value):.6g} is outside its joint range [{rng[0]:.6g}, {rng[1]:.6g}]")
    missing = [n for n in mech.actuated if n not in fixed and n not in (ax[0], None if ay is None else ay[0])]
    if missing:
        raise ValueError(f"fixed: expected a reading for every actuated joint off the plane, missing {', '.join(missing)}")
    tol = check_singular_tol(tol, "tol")
    if isinstance(max_boxes, bool) or not isinstance(max_boxes, (int, np.integer)) or max_boxes < 1:
        raise ValueError(f"max_boxes: expected a positive whole number, got {max_boxes!r}")
    budget = Budget() if budget is None else budget
    t0 = time.perf_counter()
    plane = SingularPlane(ax, ay, {k: float(v) for k, v in fixed.items()})
    system = plane_system(mech, plane)
    grid = Grid.over(plane.axes, tol)
    runs = []
    stationary = getattr(system, "stationary", ())
    if stationary:
        # the stationary assemblies' neighbourhoods blown up (singularities/blowup.py): the plane system searches
        # the rest of the orientations, the blow-up patches the boxes U about them. Cusps by the rank test in
        # both: outside U the agile eye still has its self-motion inputs (beta = (+-pi/2, 0), (+-pi/2, pi) at
        # beta3 = 0.5: `solve` reports a continuum), around which the tangency system degenerates (measured,
        # whole plane at T = 0.1: 9,173 cusp boxes accepted, 72 candidates, none proven, ~300 s)
        runs.append(_plane_run(system, grid, tol, int(max_boxes), outside(system, stationary), "rank", budget))
        blown = StationaryPlane(mech, plane, stationary)
        runs.append(_plane_run(blown, grid, tol, max(1, int(max_boxes) - runs[0].used), None, "rank", budget))
    else:
        runs.append(_plane_run(system, grid, tol, int(max_boxes), None, system.cusp_method,
                               budget))
    cells: dict = {}
    for run in runs:
        for k, c in run.cells.items():
            if k not in cells or c.status == SINGULAR:
                cells[k] = c
    used = sum(r.used for r in runs)
    t_cover = sum(r.seconds for r in runs)
    accepted = sum(r.accepted for r in runs)
    n_pending = sum(r.pending for r in runs)
    # the pending boxes' regions (a capped run): unresolved, and the cells inside them listed only when proven;
    # never searched for cusps, each is a cusp candidate too (not merged into a proven cusp it may meet)
    regions = sorted({g for r in runs for g in r.regions})
    cusps = tuple(Cusp(c.x, c.y, c.box_x, c.box_y, c.status)
                  for c in merge_cusps([c for r in runs for c in r.cusps]) + region_candidates(grid, regions)
                  ) if system.cusp_method is not None and ay is not None else ()
    listed = set(outside_regions(cells, regions)) | {k for k, c in cells.items() if c.status == SINGULAR}
    cells = [cells[k] for k in sorted(listed)]
    stopped = budget.reason or ("box cap" if n_pending else None)
    boxes = tuple(SingularBox(grid.edges(0, c.i), None if ay is None else grid.edges(1, c.j), c.status)
                  for c in cells)
    boxes += tuple(SingularBox((grid.edges(0, i0)[0], grid.edges(0, i1)[1]),
                               None if ay is None else (grid.edges(1, j0)[0], grid.edges(1, j1)[1]), "unresolved")
                   for i0, i1, j0, j1 in regions)
    check = None
    if ay is None and stopped is None:    # a line: the cover held against proven counts between its cells
        check = _line_cross_check(mech, ax, plane.fixed, boxes, tol, system.applies_ranges)
    complete = stopped is None and not (check and check.disagreements)
    t2 = time.perf_counter()
    # t_cover: the box loops; the rest: set-up, projection and certificates
    stats = SingularStats(used, accepted, n_pending, t_cover, t2 - t0 - t_cover, t2 - t0,
                          sum(r.crowded for r in runs))
    if ay is None:
        search = CuspSearch.NOT_APPLICABLE
    elif system.cusp_method is not None:
        search = CuspSearch.SEARCHED if all(r.cusps_searched for r in runs) else CuspSearch.NOT_SEARCHED
    else:
        search = system.cusps_without_search()
    return SingularSet(ax, ay, plane.fixed, float(tol), boxes, complete, stats,
                       system.system, cusps, search, stopped=stopped,
                       cross_check=check)


