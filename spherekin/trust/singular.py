"""Certified singular sets in a plane of inputs: the cover's projection onto cells and their statuses (issue 31).

The box loop's cover of the augmented system (:mod:`spherekin.systems.singular`,
:func:`spherekin.search.boxloop.search_cover`) holds every singular configuration whose inputs lie in
the plane: each accepted (or pending) box projects to a rectangle of the plane. The plane is cut into
a grid of cells no wider than T; a cell is in the cover when a rectangle meets it (closed, with
CELL_SLACK), so every point of the plane outside the covered cells is proven free of parallel
singularities (the charts cover every configuration; every discarded box was excluded by some
equation's Bernstein hull).

Each covered cell gets a status:

* ``singular``: the Krawczyk test proves a unique root of the square slice (the closure equations and
  D with one plane input held at a value inside the cell, the other free over the cell's range) in
  the hull of the cover's boxes of one chart that meet the slice: a singular configuration at an input
  of the cell (:meth:`spherekin.systems.singular.PlatformPlane.prove`). The slice holding x is tried
  first where the boxes spread more along x (the curve crosses x = const transversally), then y;
  Or, for a mechanism with stationary assemblies (orientations closing every input, e.g. the agile eye's
  four: :func:`spherekin.systems.singular.stationary_quaternions`, proven in rational arithmetic), where
  the Krawczyk test cannot apply: the interval enclosures of D at such an orientation q* have opposite
  signs at two sample points of the cell (:meth:`PlatformPlane.stationary_det`). D(q*, .) is continuous
  and (q*, p) closes at every input p, so D(q*, p) = 0 at some p of the segment between them, inside the
  (convex) cell: a singular configuration there. This is where the other assemblies cross q*
  (transversally: no fold, no Krawczyk proof, see :func:`stationary_sign_changes`);
* ``unresolved``: no such proof (cusps, crossings of two branches, a slice tangent to the curve, boxes
  never processed because the box cap was reached).

Cusps (:func:`certify_cusps`, issue 31 item 2): the cover of the cusp system (the curve system plus the
tangency C_r, :meth:`spherekin.systems.singular.PlatformPlane.cusp_charts`) is clustered per chart; each
Newton root proven unique by the Krawczyk test whose box also has adj(G) r enclosed away from 0 is a
``cusp``; clusters without such a proof are ``unresolved`` candidates. A cluster holding a proven root is
reported by it (its other boxes are not claimed root-free).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from ..closure import tan_half_unit
from ..core import bernstein
from ..systems.singular import PROOF_RADIUS, cusp_krawczyk, cusp_newton

__all__ = ["CELL_SLACK", "HULL_WIDEN", "Grid", "CellStatus", "cell_pieces", "certify_cover", "SINGULAR", "UNRESOLVED",
           "CUSP", "CuspStatus", "certify_cusps", "merge_cusps", "STATIONARY_SAMPLES", "stationary_sign_changes"]

SINGULAR = "singular"
UNRESOLVED = "unresolved"
#: A rectangle meets a cell when it comes within this (radians) of it: the chart maps (tan-half angle) round
#: by ~1e-16 rad, so adjacent charts may leave gaps of that size between their rectangles; far above it.
CELL_SLACK = 1e-9
#: The hull of a slice's boxes is widened by this fraction of its width on each side (unit coordinates)
#: before the Krawczyk test: the root must lie in the interior of the box tested, and the boxes' hull can
#: touch it at a face (accepted boxes are the pruner's tight reductions).
HULL_WIDEN = 0.1
#: Sample points per plane axis of a cell (its edges included) at which D at a stationary orientation is
#: enclosed (:func:`stationary_sign_changes`): 3 x 3 = the corners, the edges' midpoints and the centre, so
#: a curve through the cell that leaves its corners on one side (entering and leaving by one edge) is
#: still seen when it passes a midpoint. More points find more such cells, at 9 interval determinants each.
STATIONARY_SAMPLES = 3


@dataclass(frozen=True)
class Grid:
    """Cells of the plane: ``lo``, ``hi`` (2,) (radians; hi[1] = lo[1] for a line), ``n`` (2,) cells per
    axis (n[1] = 1 for a line); a cell is [lo + i w, lo + (i + 1) w] per axis, w = (hi - lo) / n <= T."""

    lo: tuple
    hi: tuple
    n: tuple

    @classmethod
    def over(cls, axes, tol: float) -> "Grid":
        """The grid over the plane's axes ((name, lo, hi), ...) with cells no wider than ``tol`` (radians)."""
        lo = tuple(float(a[1]) for a in axes)
        hi = tuple(float(a[2]) for a in axes)
        n = tuple(max(1, math.ceil((b - a) / tol - 1e-9)) for a, b in zip(lo, hi))
        return cls(lo, hi, n)

    def width(self, axis: int) -> float:
        return (self.hi[axis] - self.lo[axis]) / self.n[axis]

    def edges(self, axis: int, i: int) -> tuple[float, float]:
        """The cell range (radians) of index i on axis ``axis``."""
        w = self.width(axis)
        return self.lo[axis] + i * w, (self.hi[axis] if i == self.n[axis] - 1 else self.lo[axis] + (i + 1) * w)

    def span(self, axis: int, a, b) -> tuple[np.ndarray, np.ndarray]:
        """First and last cell indices (B,) on ``axis`` met by the ranges [a, b] (B,; radians), with CELL_SLACK."""
        w = self.width(axis)
        first = np.floor((np.asarray(a) - CELL_SLACK - self.lo[axis]) / w).astype(int)
        last = np.floor((np.asarray(b) + CELL_SLACK - self.lo[axis]) / w).astype(int)
        return np.clip(first, 0, self.n[axis] - 1), np.clip(last, 0, self.n[axis] - 1)


@dataclass(frozen=True)
class CellStatus:
    """One covered cell: indices ``i``, ``j`` (j = 0 on a line) and its ``status``."""

    i: int
    j: int
    status: str


def _cells_met(grid: Grid, lo: np.ndarray, hi: np.ndarray) -> dict:
    """cell (i, j) -> indices of the rectangles [lo, hi] (B, n_plane; radians) that meet it."""
    out: dict = {}
    spans = [grid.span(a, lo[:, a], hi[:, a]) for a in range(lo.shape[1])]
    for b in range(len(lo)):
        i0, i1 = spans[0][0][b], spans[0][1][b]
        j0, j1 = (spans[1][0][b], spans[1][1][b]) if len(spans) > 1 else (0, 0)
        for i in range(i0, i1 + 1):
            for j in range(j0, j1 + 1):
                out.setdefault((i, j), []).append(b)
    return out


def cell_pieces(system, accepted, grid: Grid, cells=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each accepted box (chart (A,), angle lo, hi (A, N), :class:`spherekin.search.boxloop.Cover`) cut by
    the cells it meets: (chart (P,), lo (P, N), hi (P, N)) in unit coordinates, one piece per (box, cell),
    the plane columns clipped to the cell (only the cells in ``cells``, a set of (i, j), when given).
    Searched again with smaller boxes, the pieces a cell holds no singular point of are discarded: the
    cover then meets fewer cells that the curve misses, and the hulls the certificates test are tighter."""
    chart, alo, ahi = accepted
    if not len(chart):
        return chart, alo, ahi
    cols = list(system.plane_columns)
    out_c, out_lo, out_hi = [], [], []
    for (i, j), members in _cells_met(grid, alo[:, cols], ahi[:, cols]).items():
        if cells is not None and (i, j) not in cells:
            continue
        members = np.array(members)
        lo, hi = alo[members].copy(), ahi[members].copy()
        for a, k in enumerate((i, j)[:len(cols)]):
            e0, e1 = grid.edges(a, k)
            lo[:, cols[a]] = np.maximum(lo[:, cols[a]], e0)
            hi[:, cols[a]] = np.minimum(hi[:, cols[a]], e1)
        ok = np.all(lo <= hi, axis=1)
        out_c.append(chart[members][ok])
        out_lo.append(lo[ok])
        out_hi.append(hi[ok])
    if not out_c:
        return chart[:0], alo[:0], ahi[:0]
    c = np.concatenate(out_c)
    lo, hi = system.unit(c, np.concatenate(out_lo)), system.unit(c, np.concatenate(out_hi))
    return c, np.clip(lo, 0.0, 1.0), np.clip(hi, 0.0, 1.0)


def certify_cover(system, cover, grid: Grid) -> tuple[CellStatus, ...]:
    """The covered cells of ``grid`` and their statuses (module doc).

    ``system``: a compiled plane system (:class:`spherekin.systems.singular.PlatformPlane` or ``LoopPlane``:
    ``charts``, ``plane_columns``, ``unit`` and ``prove``); ``cover``: its
    :class:`spherekin.search.boxloop.Cover`. Cells met only by pending boxes are ``unresolved``.
    """
    charts = system.charts
    cols = list(system.plane_columns)
    n_plane = len(cols)
    chart, alo, ahi = cover.accepted
    met = _cells_met(grid, alo[:, cols], ahi[:, cols]) if len(chart) else {}
    pchart, plo, phi = cover.pending
    pending_cells = set()
    if len(pchart):
        rlo, rhi = charts.angle_box(pchart, plo, phi)
        pending_cells = set(_cells_met(grid, rlo[:, cols], rhi[:, cols]))
    ulo = system.unit(chart, alo) if len(chart) else alo
    uhi = system.unit(chart, ahi) if len(chart) else ahi
    proven = set()
    # attempts: (cell, chart, fixed axis, value, lo (N,), hi (N,)); two rounds (the preferred axis, then the other)
    for round_ in range(2 if n_plane == 2 else 1):
        tries = []
        for cell, members in met.items():
            if cell in proven:
                continue
            members = np.array(members)
            for c in np.unique(chart[members]):
                mine = members[chart[members] == c]
                tries.extend(_attempt(system, grid, cell, int(c), mine, alo, ahi, ulo, uhi, cols, round_))
        if not tries:
            break
        cells, ch, fix, val, lo, hi = zip(*tries)
        ok = system.prove(np.array(ch), np.array(fix), np.array(val), np.array(lo), np.array(hi))
        proven |= {cells[k] for k in np.flatnonzero(ok)}
    proven |= stationary_sign_changes(system, grid, sorted((set(met) | pending_cells) - proven))
    out = [CellStatus(i, j, SINGULAR if (i, j) in proven else UNRESOLVED)
           for i, j in sorted(set(met) | pending_cells)]
    return tuple(out)


def stationary_sign_changes(system, grid: Grid, cells) -> set:
    """The cells (of ``cells``, (i, j) pairs) holding a proven singular configuration at a stationary
    orientation q* of ``system`` (its ``stationary``: none for the loop system or a mechanism without them):
    the enclosures of D(q*, p) (``system.stationary_det``) at two of the cell's STATIONARY_SAMPLES^2 sample
    points p (a line: STATIONARY_SAMPLES) exclude 0 with opposite signs (module doc). Why this and not the
    Krawczyk test there: on the stationary sheet the closure does not depend on the inputs (dF/dt = 0) and
    its Jacobian in q has rank 2 where D = 0, so the square slice's Jacobian is singular at every such point
    (the other assemblies cross q* there transversally; an O(eps) change of the mechanism could turn the
    crossing into two folds or into none, so no test on the floating-point curve system can prove it)."""
    stationary = getattr(system, "stationary", ())
    if not stationary or not len(cells):
        return set()
    n_plane = len(system.plane_columns)
    frac = np.linspace(0.0, 1.0, STATIONARY_SAMPLES)
    offsets = np.array(list(itertools.product(frac, repeat=n_plane)))             # (S, n_plane)
    cells = list(cells)
    lo = np.array([[grid.edges(a, c[a])[0] for a in range(n_plane)] for c in cells])
    hi = np.array([[grid.edges(a, c[a])[1] for a in range(n_plane)] for c in cells])
    points = np.clip(lo[:, None] + offsets[None] * (hi - lo)[:, None], lo[:, None], hi[:, None])   # (C, S, n_plane)
    out = set()
    for q in stationary:
        det = system.stationary_det(q, points.reshape(-1, n_plane)).reshape(2, len(cells), len(offsets))
        change = (det[0] > 0).any(axis=1) & (det[1] < 0).any(axis=1)
        out |= {cells[k] for k in np.flatnonzero(change)}
    return out


def _attempt(system, grid, cell, c, mine, alo, ahi, ulo, uhi, cols, round_):
    """The slice test of one cell on chart c (its boxes ``mine``), holding the preferred plane axis
    (round 0) or the other (round 1): [] when the boxes do not reach the held value."""
    charts = system.charts
    n_plane = len(cols)
    cell_rng = [grid.edges(a, cell[a]) for a in range(n_plane)]
    if n_plane == 1:
        fix = -1
        use = mine
    else:
        extent = [ahi[mine, cols[a]].max() - alo[mine, cols[a]].min() for a in range(2)]
        fix = (0 if extent[0] >= extent[1] else 1) if round_ == 0 else (1 if extent[0] >= extent[1] else 0)
        a_lo = max(cell_rng[fix][0], alo[mine, cols[fix]].min())
        a_hi = min(cell_rng[fix][1], ahi[mine, cols[fix]].max())
        if a_lo > a_hi:
            return []
        value = 0.5 * (a_lo + a_hi)
        use = mine[(alo[mine, cols[fix]] <= value) & (ahi[mine, cols[fix]] >= value)]
        if not len(use):
            return []
    lo, hi = ulo[use].min(axis=0), uhi[use].max(axis=0)
    pad = HULL_WIDEN * (hi - lo)
    lo, hi = np.clip(lo - pad, 0.0, 1.0), np.clip(hi + pad, 0.0, 1.0)
    for a in range(n_plane):                   # the free plane axis: within the cell
        if a == fix:
            continue
        col = cols[a]
        e = tan_half_unit(np.array(cell_rng[a]), charts.shift[c, col], charts.map_lo[c, col], charts.map_hi[c, col])
        lo[col], hi[col] = max(lo[col], e[0]), min(hi[col], e[1])
    if np.any(lo >= hi):
        return []
    return [(cell, c, fix, 0.0 if fix < 0 else value, lo, hi)]


CUSP = "cusp"
#: The block of the cusp charts holding adj(G) r (three rows; :meth:`PlatformPlane.cusp_charts`).
ADJ_BLOCK = 3
#: Accepted boxes of the cusp system within this (unit coordinates) of each other on one chart are one
#: cluster (one root, tested once): adjacent boxes of the box loop share faces exactly, far above rounding.
CLUSTER_SLACK = 1e-9
#: Newton starts from each accepted box of the cusp system on that box widened this many times about its
#: centre (unit coordinates, clipped to the chart): the boxes are small (CUSP_FRACTION T) and a cusp's
#: neighbours need not hold it; Newton is only a guess, the Krawczyk test decides.
NEWTON_WIDEN = 4.0
#: Boxes per batch of Newton's method on the cusp system (:func:`_newton_roots`): each box holds its restricted
#: nets (~6,500 coefficients, the tangency's 5,400) and Newton's derivative nets, ~0.3 MB per box; 2,000 boxes
#: keep a batch near 0.6 GB. Reason: the agile eye's crossings leave ~1e5 candidate boxes over the whole plane,
#: which in one batch took the process past 23 GB (killed by the kernel).
NEWTON_CHUNK = 2_000
#: Newton roots of one cluster closer than this (unit coordinates, largest component) are one root.
ROOT_SEPARATION = 1e-7
#: The Krawczyk box about a Newton root is PROOF_RADIUS times the cluster's hull, whose sides are at least
#: this (unit coordinates): a hull flat along a variable would give a box too thin to contain the root.
PROOF_MIN_WIDTH = 1e-3


@dataclass(frozen=True)
class CuspStatus:
    """One cusp candidate: ``x``, ``y`` (radians; Newton's root, or the cluster's centre when unresolved),
    ``box_x``, ``box_y`` ((lo, hi), radians: the plane projection of the box whose unique root was proven,
    or of the cluster), ``status``: ``cusp`` or ``unresolved``."""

    x: float
    y: float
    box_x: tuple
    box_y: tuple
    status: str


def _clusters(chart, lo, hi) -> list:
    """Indices of the boxes (chart (B,), unit lo, hi (B, N)) grouped into connected clusters per chart."""
    out = []
    for c in np.unique(chart):
        idx = list(np.flatnonzero(chart == c))
        while idx:
            group, grow = [idx.pop(0)], True
            while grow:
                grow = False
                glo, ghi = lo[group].min(axis=0), hi[group].max(axis=0)
                near = [b for b in idx if np.all(lo[b] <= ghi + CLUSTER_SLACK) and np.all(hi[b] >= glo - CLUSTER_SLACK)]
                if near:
                    group += near
                    idx = [b for b in idx if b not in near]
                    grow = True
            out.append(np.array(group))
    return out


def _excludes_zero(charts, block, chart, lo, hi) -> np.ndarray:
    """(B,) bool: some equation of ``block`` has a Bernstein hull (widened by its tolerance) excluding 0 on
    the boxes [lo, hi] (unit coordinates, (B, N)) of charts ``chart`` (B,): an enclosure of its values."""
    c = np.moveaxis(charts.coeffs[block][chart], 0, -1)                       # (E, d..., B)
    r = bernstein.restrict_batch_last(c, lo, hi, {})
    flat = r.reshape(r.shape[0], -1, r.shape[-1])
    tol = charts.tols[block][chart].T                                          # (E, B)
    return np.any((flat.min(axis=1) > tol) | (flat.max(axis=1) < -tol), axis=0)


def certify_cusps(system, cusp_charts, found) -> tuple[CuspStatus, ...]:
    """The cusps of a plane system from the box loop's cover of its cusp system (design31.md section 3).

    ``system``: the :class:`spherekin.systems.singular.PlatformPlane`; ``cusp_charts``: its
    :meth:`cusp_charts` for two vectors (r, r2); ``found``: the :class:`spherekin.search.boxloop.Cover` of
    the first (accepted: angle boxes; pending: unit boxes). Each cluster of accepted boxes on one chart is
    tested: Newton's root of the square system (F, D, C_r) in the cluster's hull, the Krawczyk test on the
    hull or on a box PROOF_RADIUS around the root. ``cusp`` when it proves a unique root in a box X AND the
    enclosure of adj(G(X)) r excludes the zero vector (then rank G = 2 at the root, adj(G) r = (l . r) k with
    l . r != 0, so C_r = 0 means grad D . k = 0: the curve's tangent projects to 0, a cusp). A proven root
    whose adjugate test fails is dropped when C_r2 excludes 0 on X (no point of X satisfies the tangency for
    r2, so X holds no cusp: the spurious factor l . r = 0), else ``unresolved``; so are clusters without a
    proof and pending boxes."""
    charts, charts2 = cusp_charts
    cols = list(system.plane_columns)
    chart, alo, ahi = found.accepted
    out = []
    if len(chart):
        ulo, uhi = system.unit(chart, alo), system.unit(chart, ahi)
        # Newton from every accepted box (on the box widened NEWTON_WIDEN times about its centre): the roots
        roots, owners = _newton_roots(charts, chart, ulo, uhi)
        for group in _clusters(chart, ulo, uhi):
            c = int(chart[group[0]])
            cid = np.array([c])
            lo, hi = ulo[group].min(axis=0)[None], uhi[group].max(axis=0)[None]
            mine = [k for k in range(len(roots)) if owners[k] == c
                    and np.all(roots[k] >= lo[0] - CLUSTER_SLACK) and np.all(roots[k] <= hi[0] + CLUSTER_SLACK)]
            unproven = not mine
            kept = []
            for k in mine:                                  # distinct roots of the cluster
                if any(np.max(np.abs(roots[k] - roots[m])) < ROOT_SEPARATION for m in kept):
                    continue
                kept.append(k)
                root = roots[k][None]
                w = np.maximum(hi - lo, PROOF_MIN_WIDTH)
                slo, shi = np.clip(root - PROOF_RADIUS * w, 0, 1), np.clip(root + PROOF_RADIUS * w, 0, 1)
                ok, klo, khi = cusp_krawczyk(charts, cid, slo, shi)
                if not ok[0]:
                    unproven = True
                    continue
                box = (slo + klo * (shi - slo), slo + khi * (shi - slo))
                if not _excludes_zero(charts, ADJ_BLOCK, cid, *box)[0]:
                    if not _excludes_zero(charts2, 2, cid, *box)[0]:
                        out.append(_status(charts, cid, cols, root, box, UNRESOLVED))
                    continue                                 # the spurious factor l . r = 0: no cusp in the box
                out.append(_status(charts, cid, cols, root, box, CUSP))
            if unproven:
                out.append(_status(charts, cid, cols, None, (lo, hi), UNRESOLVED))
    pchart, plo, phi = found.pending
    if len(pchart):
        rlo, rhi = charts.angle_box(pchart, plo, phi)
        for b in range(len(pchart)):
            out.append(CuspStatus(float(0.5 * (rlo[b, cols[0]] + rhi[b, cols[0]])), float(0.5 * (rlo[b, cols[1]] + rhi[b, cols[1]])),
                                  (float(rlo[b, cols[0]]), float(rhi[b, cols[0]])), (float(rlo[b, cols[1]]), float(rhi[b, cols[1]])),
                                  UNRESOLVED))
    return merge_cusps(out)


def _status(charts, cid, cols, root, box, status) -> CuspStatus:
    """The plane reading of a candidate: the root's inputs (or the box's centre) and the box's projection."""
    blo, bhi = charts.angle_box(cid, *box)
    pt = 0.5 * (blo[0] + bhi[0]) if root is None else charts.angle_box(cid, root, root)[0][0]
    return CuspStatus(float(pt[cols[0]]), float(pt[cols[1]]), (float(blo[0, cols[0]]), float(bhi[0, cols[0]])),
                      (float(blo[0, cols[1]]), float(bhi[0, cols[1]])), status)


def _newton_roots(charts, chart, lo, hi):
    """Newton's roots of the square cusp system from the centre of each box [lo, hi] (unit, (B, N)) widened
    NEWTON_WIDEN times about its centre: (roots (R, N) in the chart's unit coordinates, their charts (R,))."""
    mid, half = 0.5 * (lo + hi), 0.5 * NEWTON_WIDEN * (hi - lo)
    wlo, whi = np.clip(mid - half, 0.0, 1.0), np.clip(mid + half, 0.0, 1.0)
    roots, owners = [], []
    for a in range(0, len(chart), NEWTON_CHUNK):          # bounded memory: see NEWTON_CHUNK
        b = slice(a, a + NEWTON_CHUNK)
        u, converged = cusp_newton(charts, chart[b], wlo[b], whi[b])
        roots.append((wlo[b] + u * (whi[b] - wlo[b]))[converged])
        owners.append(chart[b][converged])
    if not roots:
        return wlo[:0], chart[:0]
    return np.concatenate(roots), np.concatenate(owners)


def merge_cusps(found) -> tuple[CuspStatus, ...]:
    """One entry per cusp: a cusp proven on several quaternion charts (they overlap) is listed once (the
    first proof kept; its other proofs' boxes meet its box); unresolved candidates meeting a proven
    cusp's box are that cusp. Sorted by (x, y)."""
    proven, rest = [], []
    for f in found:
        meets = [p for p in proven if f.box_x[0] <= p.box_x[1] and p.box_x[0] <= f.box_x[1]
                 and f.box_y[0] <= p.box_y[1] and p.box_y[0] <= f.box_y[1]]
        if f.status == CUSP:
            if not meets:
                proven.append(f)
        else:
            rest.append(f)
    rest = [f for f in rest if not any(f.box_x[0] <= p.box_x[1] and p.box_x[0] <= f.box_x[1]
                                       and f.box_y[0] <= p.box_y[1] and p.box_y[0] <= f.box_y[1] for p in proven)]
    return tuple(sorted(proven + rest, key=lambda f: (f.x, f.y)))
