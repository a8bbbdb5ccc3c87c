"""Certified singular sets in a plane of inputs: the cover's projection onto cells and their statuses (issue 31).

The box loop's cover of the augmented system (:mod:`spherekin.singularities.planes`,
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
  of the cell (:meth:`spherekin.singularities.planes.PlatformPlane.prove`). The slice holding x is tried
  first where the boxes spread more along x (the curve crosses x = const transversally), then y;
  Or, for a mechanism with stationary assemblies (orientations closing every input, e.g. the agile eye's
  four: :func:`spherekin.singularities.planes.stationary_quaternions`, proven in rational arithmetic), where
  the Krawczyk test cannot apply: the interval enclosures of D at such an orientation q* have opposite
  signs at two sample points of the cell (:meth:`PlatformPlane.stationary_det`). D(q*, .) is continuous
  and (q*, p) closes at every input p, so D(q*, p) = 0 at some p of the segment between them, inside the
  (convex) cell: a singular configuration there. This is where the other assemblies cross q*
  (transversally: no fold, no Krawczyk proof, see :func:`stationary_sign_changes`);
* ``unresolved``: no such proof (cusps, crossings of two branches, a slice tangent to the curve).

Boxes never processed because the box cap was reached (pending) are not cut into cells: a pending box can
span most of the plane (the whole plane at T = 1e-3 is ~4e7 cells, which took a capped run past its memory),
so its plane projection, snapped outward to the grid, is one unresolved *region* (:func:`pending_regions`),
and the cells inside a region are not listed unless proven singular (:func:`outside_regions`). So are the
boxes :func:`trace_cover` sets aside in *crowded* cells (CROWDED_CELL): above a continuum of singular
configurations over one input (a self-motion input) the cover would multiply without end.

A mechanism with stationary assemblies is covered twice (:func:`spherekin.singularities.singular`): the plane
system without the boxes U about them (:func:`spherekin.singularities.blowup.outside`) and the blow-up patches of
U (:class:`spherekin.singularities.blowup.StationaryPlane`), where the crossings are regular roots and the
Krawczyk slices above prove their cells; a cell is ``singular`` when either cover proves it. The patches have
no tangency system: their cusp candidates are the boxes :func:`rank_candidates` cannot prove cusp-free.

Cusps (:func:`certify_cusps`, issue 31 item 2): the cover of the cusp system (the curve system plus the
tangency C_r, :meth:`spherekin.singularities.planes.PlatformPlane.cusp_charts`) is clustered per chart; each
Newton root proven unique by the Krawczyk test whose box also has adj(G) r enclosed away from 0 is a
``cusp``; clusters without such a proof are ``unresolved`` candidates. A cluster holding a proven root is
reported by it (its other boxes are not claimed root-free).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ..closure import tan_half_unit
from ..core import bernstein
from .cell_width import CELL_SLACK
from .planes import PROOF_RADIUS, cusp_krawczyk, cusp_newton

__all__ = ["CELL_SLACK", "HULL_WIDEN", "Grid", "CellStatus", "cell_pieces", "certify_cover", "TracedCover",
           "trace_cover", "trace_levels", "SINGULAR", "UNRESOLVED", "CUSP", "CuspStatus", "certify_cusps",
           "merge_cusps", "rank_candidates", "STATIONARY_SAMPLES", "stationary_sign_changes"]

SINGULAR = "singular"
UNRESOLVED = "unresolved"
#: The hull of a slice's boxes is widened by this fraction of its width on each side (unit coordinates)
#: before the Krawczyk test: the root must lie in the interior of the box tested, and the boxes' hull can
#: touch it at a face (accepted boxes are the pruner's tight reductions).
HULL_WIDEN = 0.1
#: Slice tests per batch of ``system.prove`` in :func:`certify_cover`. Reason: each test builds its slice's
#: nets and their products (~10-50 kB); the agile eye's blow-up at T = 1e-3 sent all its cells' tests in one
#: batch and the process was killed by the kernel at 23.7 GB.
PROVE_BATCH = 8192
#: Sample points per plane axis of a cell (its edges included) at which D at a stationary orientation is
#: enclosed (:func:`stationary_sign_changes`): 3 x 3 = the corners, the edges' midpoints and the centre, so
#: a curve through the cell that leaves its corners on one side (entering and leaving by one edge) is
#: still seen when it passes a midpoint. More points find more such cells, at 9 interval determinants each.
STATIONARY_SAMPLES = 3


#: Most cells per axis of a :class:`Grid`: cell indices are computed as floor((x - lo) / w) in float64, exact as
#: integers up to 2^53; one bit of margin. (:func:`spherekin.singularities.cover.check_singular_tol` refuses far coarser
#: limits first: a full turn at its narrowest T is 4.9e7 cells.)
MAX_GRID_CELLS = 2.0 ** 52


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
        cells = [(b - a) / tol for a, b in zip(lo, hi)]
        if not all(math.isfinite(c) and 0 < c <= MAX_GRID_CELLS for c in cells):
            raise ValueError(f"tol: a grid of cells {tol!r} wide over {list(zip(lo, hi))} cannot be indexed in float64 "
                             f"(at most {MAX_GRID_CELLS:.3g} cells per axis)")
        n = tuple(max(1, math.ceil(c - 1e-9)) for c in cells)
        return cls(lo, hi, n)

    def width(self, axis: int) -> float:
        return (self.hi[axis] - self.lo[axis]) / self.n[axis]

    def edges(self, axis: int, i: int) -> tuple[float, float]:
        """The cell range (radians) of index i on axis ``axis``."""
        w = self.width(axis)
        return self.lo[axis] + i * w, (self.hi[axis] if i == self.n[axis] - 1 else self.lo[axis] + (i + 1) * w)

    def index(self, axis: int, x) -> np.ndarray:
        """The cell index (int array) on ``axis`` of x (radians; may lie outside the grid: indices < 0 or >= n).
        ValueError when an x is not finite (a box's bound NaN or infinite is a defect upstream, never guessed)."""
        x = np.asarray(x, dtype=float)
        if not np.all(np.isfinite(x)):
            raise ValueError(f"grid: a box bound is not finite ({x[~np.isfinite(x)][:3]}): no cell index")
        k = np.floor((x - self.lo[axis]) / self.width(axis))
        return np.clip(k, -1, self.n[axis]).astype(int)

    def span(self, axis: int, a, b) -> tuple[np.ndarray, np.ndarray]:
        """First and last cell indices (B,) on ``axis`` met by the ranges [a, b] (B,; radians), with CELL_SLACK."""
        first = self.index(axis, np.asarray(a) - CELL_SLACK)
        last = self.index(axis, np.asarray(b) + CELL_SLACK)
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


def certify_cover(system, cover, grid: Grid, budget=None) -> tuple[CellStatus, ...]:
    """The covered cells of ``grid`` and their statuses (module doc).

    ``system``: a compiled plane system (:class:`spherekin.singularities.planes.PlatformPlane` or ``LoopPlane``:
    ``charts``, ``plane_columns``, ``unit`` and ``prove``); ``cover``: its
    :class:`spherekin.search.boxloop.Cover`. The cells met by accepted boxes only: the pending boxes are
    the caller's unresolved regions (:func:`pending_regions`). Once ``budget`` (:class:`spherekin.budget.Budget`)
    names a reason to stop, no more cells are tested: they stay ``unresolved`` (no proof is claimed).
    """
    cols = list(system.plane_columns)
    n_plane = len(cols)
    chart, alo, ahi = cover.accepted
    met = _cells_met(grid, alo[:, cols], ahi[:, cols]) if len(chart) else {}
    ulo = system.unit(chart, alo) if len(chart) else alo
    uhi = system.unit(chart, ahi) if len(chart) else ahi
    proven = set()
    # attempts: (cell, chart, fixed axis, value, lo (N,), hi (N,)); two rounds (the preferred axis, then the other)
    for round_ in range(2 if n_plane == 2 else 1):
        if budget is not None and budget.exhausted():
            break
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
        cells, ch, fix, val, lo, hi = (np.array(v) for v in zip(*tries))
        ok = np.zeros(len(ch), dtype=bool)
        for s in range(0, len(ch), PROVE_BATCH):
            if budget is not None and budget.exhausted():
                break                                   # the rest untested: unresolved
            ok[s:s + PROVE_BATCH] = system.prove(ch[s:s + PROVE_BATCH], fix[s:s + PROVE_BATCH], val[s:s + PROVE_BATCH],
                                                 lo[s:s + PROVE_BATCH], hi[s:s + PROVE_BATCH])
        cells = [tuple(int(v) for v in c) for c in cells]
        proven |= {cells[k] for k in np.flatnonzero(ok)}
    if budget is None or not budget.exhausted():
        proven |= stationary_sign_changes(system, grid, sorted(set(met) - proven))
    out = [CellStatus(i, j, SINGULAR if (i, j) in proven else UNRESOLVED) for i, j in sorted(met)]
    return tuple(out)


def pending_regions(system, grid: Grid, pending) -> tuple:
    """The unresolved regions of the pending boxes ``pending`` = (chart (B,), unit lo, hi (B, N)) of
    ``system``'s charts: each box's plane projection snapped outward to the grid, as cell index ranges
    (i0, i1, j0, j1) (inclusive; j0 = j1 = 0 on a line), once each, sorted: at most one per pending box, so
    as many as the box cap allows (not merged: a hull merge over rectangles of very different sizes is
    quadratic in the k-d tree's pairs; measured, the agile eye capped at 3,000 boxes: 11 GB)."""
    chart, lo, hi = pending
    if not len(chart):
        return ()
    cols = list(system.plane_columns)
    rlo, rhi = system.charts.angle_box(chart, lo, hi)
    spans = [grid.span(a, rlo[:, cols[a]], rhi[:, cols[a]]) for a in range(len(cols))]
    zero = np.zeros(len(chart), dtype=int)
    i0, i1 = spans[0]
    j0, j1 = spans[1] if len(spans) > 1 else (zero, zero)
    return tuple(sorted({(int(a), int(b), int(c), int(d)) for a, b, c, d in zip(i0, i1, j0, j1)}))


def outside_regions(cells, regions) -> list:
    """The cells (an iterable of (i, j)) inside none of the index ranges ``regions`` ((i0, i1, j0, j1),
    :func:`pending_regions`), in their order. The cells sorted by row once; each region then tests only the
    cells of its rows (a slice found by bisection), so the cost is the cells the regions' rows hold, not the
    regions' rows (a stopped run at a small T: regions thousands of rows tall, millions of rows in all)."""
    cells = list(cells)
    if not cells or not regions:
        return cells
    ij = np.array(cells, dtype=np.int64).reshape(-1, 2)
    order = np.argsort(ij[:, 0], kind="stable")
    rows, cols = ij[order, 0], ij[order, 1]
    inside = np.zeros(len(ij), dtype=bool)
    for i0, i1, j0, j1 in regions:
        a, b = np.searchsorted(rows, i0, "left"), np.searchsorted(rows, i1, "right")
        if a < b:
            inside[a:b] |= (cols[a:b] >= j0) & (cols[a:b] <= j1)
    keep = np.ones(len(ij), dtype=bool)
    keep[order[inside]] = False
    return [c for c, k in zip(cells, keep) if k]


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
        for s in range(0, len(cells), PROVE_BATCH):          # bounded memory, as certify_cover's slices
            pts = points[s:s + PROVE_BATCH]
            det = system.stationary_det(q, pts.reshape(-1, n_plane)).reshape(2, len(pts), len(offsets))
            change = (det[0] > 0).any(axis=1) & (det[1] < 0).any(axis=1)
            out |= {cells[s + k] for k in np.flatnonzero(change)}
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
#: The multiples of that box tried in turn until the Krawczyk test proves the root. Reason: the box must be
#: wide enough that the coefficients' rounding (the nets' tolerances) does not swamp the contraction, and
#: narrow enough that the interval Jacobian is nearly a point and no second root is inside; where that
#: window lies depends on the chart's scale. Measured on general_3rrr at beta3 = 0.5: the cusp near
#: (-1.9253, 0.7221) is proven at 0.1-1 times on the square [-2.2, -1.7] x [0.5, 1.0], but over the whole
#: plane at T = 0.05 only at 3-100 times (its hull there is wider, its unit coordinates 12.6 times coarser).
PROOF_LADDER = (1.0, 10.0, 100.0, 0.1)


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


def _overlaps(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Component labels (B,) of the graph whose edges join boxes [lo, hi] (B, N) that meet (within
    CLUSTER_SLACK): candidate pairs from a k-d tree of the centres (max-norm distance at most the sum of the
    two largest half-widths), then the exact test."""
    n = len(lo)
    if n < 2:
        return np.zeros(n, dtype=int)
    centre, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    reach = 2.0 * float(half.max()) + CLUSTER_SLACK
    pairs = cKDTree(centre).query_pairs(reach, p=np.inf, output_type="ndarray")
    if len(pairs):
        a, b = pairs[:, 0], pairs[:, 1]
        meet = np.all((lo[a] <= hi[b] + CLUSTER_SLACK) & (hi[a] >= lo[b] - CLUSTER_SLACK), axis=1)
        a, b = a[meet], b[meet]
    else:
        a = b = np.zeros(0, dtype=int)
    graph = coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n))
    return connected_components(graph, directed=False)[1]


def _clusters(chart, lo, hi) -> list:
    """Indices of the boxes (chart (B,), unit lo, hi (B, N)) grouped into clusters per chart: boxes that
    meet are one cluster, and clusters whose hulls meet are merged until no two hulls meet (the hull is
    what Newton and the Krawczyk test see). k-d tree pairs, not all pairs: ~1e4 boxes in a second."""
    out = []
    for c in np.unique(chart):
        members = [[int(i)] for i in np.flatnonzero(chart == c)]
        glo, ghi = lo[chart == c], hi[chart == c]
        while True:
            labels = _overlaps(glo, ghi)
            count = int(labels.max()) + 1 if len(labels) else 0
            if count == len(members):
                break
            merged = [[] for _ in range(count)]
            for m, lab in zip(members, labels):
                merged[lab].extend(m)
            members = merged
            glo = np.array([lo[m].min(axis=0) for m in members])
            ghi = np.array([hi[m].max(axis=0) for m in members])
        out.extend(np.array(sorted(m)) for m in members)
    return out


def _excludes_zero(charts, block, chart, lo, hi) -> np.ndarray:
    """(B,) bool: some equation of ``block`` has a Bernstein hull (widened by its tolerance) excluding 0 on
    the boxes [lo, hi] (unit coordinates, (B, N)) of charts ``chart`` (B,): an enclosure of its values."""
    c = np.moveaxis(charts.coeffs[block][chart], 0, -1)                       # (E, d..., B)
    r = bernstein.restrict_batch_last(c, lo, hi, {})
    flat = r.reshape(r.shape[0], -1, r.shape[-1])
    tol = charts.tols[block][chart].T                                          # (E, B)
    return np.any((flat.min(axis=1) > tol) | (flat.max(axis=1) < -tol), axis=0)


def certify_cusps(system, cusp_charts, found, closes=None) -> tuple[CuspStatus, ...]:
    """The cusps of a plane system from the box loop's cover of its cusp system (:meth:`~spherekin.singularities.planes.PlatformPlane.cusp_charts`).

    ``closes``: None, or (charts, chart (B,), lo, hi (B, N)) -> (B,) bool, True where a root in the box is a
    closure of the mechanism (the loop equations' transversal entries also vanish at spurious half-turns:
    :meth:`spherekin.singularities.planes.LoopPlane.closes`); a proven root failing it stays ``unresolved``.
    ``system``: the :class:`spherekin.singularities.planes.PlatformPlane` (or a one-loop ``LoopPlane``); ``cusp_charts``: its
    :meth:`cusp_charts` for two vectors (r, r2); ``found``: the :class:`spherekin.search.boxloop.Cover` of
    the first (accepted: angle boxes; pending: unit boxes). Each cluster of accepted boxes on one chart is
    tested: Newton's root of the square system (F, D, C_r) in the cluster's hull, the Krawczyk test on a box
    PROOF_RADIUS times the hull around the root (or the multiples PROOF_LADDER of it). ``cusp`` when it
    proves a unique root in a box X AND the enclosure of adj(G(X)) r excludes the zero vector (then rank
    G = 2 at the root, adj(G) r = (l . r) k with l . r != 0, so C_r = 0 means grad D . k = 0: the curve's
    tangent projects to 0, a cusp). A proven root whose adjugate test fails is dropped when C_r2 excludes 0
    on X (no point of X satisfies the tangency for r2, so X holds no cusp: the spurious factor l . r = 0),
    else ``unresolved``; so are clusters without a proof and pending boxes."""
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
                for factor in PROOF_LADDER:
                    r = factor * PROOF_RADIUS * w
                    slo, shi = np.clip(root - r, 0, 1), np.clip(root + r, 0, 1)
                    ok, klo, khi = cusp_krawczyk(charts, cid, slo, shi)
                    if ok[0]:
                        break
                if not ok[0]:
                    unproven = True
                    continue
                box = (slo + klo * (shi - slo), slo + khi * (shi - slo))
                if not _excludes_zero(charts, ADJ_BLOCK, cid, *box)[0]:
                    if not _excludes_zero(charts2, 2, cid, *box)[0]:
                        out.append(_status(charts, cid, cols, root, box, UNRESOLVED))
                    continue                                 # the spurious factor l . r = 0: no cusp in the box
                if closes is not None and not closes(charts, cid, *box)[0]:
                    out.append(_status(charts, cid, cols, root, box, UNRESOLVED))
                    continue
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


def rank_candidates(system, chart, lo, hi, grid: Grid) -> tuple[CuspStatus, ...]:
    """Cusp candidates of a plane system without a tangency system (the blow-up patches,
    :class:`spherekin.singularities.blowup.StationaryPlane`): the boxes (chart (B,), unit lo, hi (B, N)) that
    ``system.cusp_free`` does not prove cusp-free, one ``unresolved`` candidate per cell of ``grid`` holding
    such a box's plane centre (at the cell's centre; its box: the hull of their plane projections). Every
    other box of the cover holds no cusp (traced boxes never do, :func:`trace_cover`)."""
    chart = np.asarray(chart, dtype=int)
    if not len(chart):
        return ()
    cols = list(system.plane_columns)
    open_ = ~system.cusp_free(chart, lo, hi)
    if not open_.any():
        return ()
    alo, ahi = system.charts.angle_box(chart[open_], lo[open_], hi[open_])
    mid = 0.5 * (alo[:, cols] + ahi[:, cols])
    cells: dict = {}
    for b in range(len(mid)):
        key = tuple(int(grid.span(a, mid[b, a], mid[b, a])[0]) for a in range(len(cols)))
        cells.setdefault(key, []).append(b)
    out = []
    for key, members in sorted(cells.items()):
        centre = [0.5 * sum(grid.edges(a, key[a])) for a in range(2)]
        out.append(CuspStatus(float(centre[0]), float(centre[1]),
                              (float(alo[members, cols[0]].min()), float(ahi[members, cols[0]].max())),
                              (float(alo[members, cols[1]].min()), float(ahi[members, cols[1]].max())), UNRESOLVED))
    return tuple(out)


def region_candidates(grid: Grid, regions) -> tuple[CuspStatus, ...]:
    """One ``unresolved`` cusp candidate per unresolved region ((i0, i1, j0, j1), :func:`pending_regions`) of
    a plane: the boxes left pending at the cap were never searched for cusps, so the list says where one
    may be (at the region's centre; its box: the region)."""
    out = []
    for i0, i1, j0, j1 in regions:
        bx, by = (grid.edges(0, i0)[0], grid.edges(0, i1)[1]), (grid.edges(1, j0)[0], grid.edges(1, j1)[1])
        out.append(CuspStatus(0.5 * (bx[0] + bx[1]), 0.5 * (by[0] + by[1]), bx, by, UNRESOLVED))
    return tuple(out)


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


# ---------------------------------------------------------------------------------------------- tracing
#: The traced cover's box widths (metric units, as :func:`spherekin.search.boxloop.search_cover`'s tol):
#: the search accepts boxes at TRACE_START, tries to trace each, and searches the others again at the width
#: divided by TRACE_STEP, down to the cell's own (COVER_FRACTION T). Reason: measured on general_3rrr at
#: beta3 = 0.5 over [-1, 0]^2, 3 % of the boxes of width 0.05, 30 % at 0.03 and 92 % at 0.0125 hold one branch
#: proven a graph over x or y (parametric Krawczyk), so the 5-D search stops there instead of going down to
#: T/2 everywhere (the test needs the Jacobian to vary little over the box); the boxes near
#: cusps, crossings and points where the branch turns go on down level by level.
TRACE_START = 0.05
TRACE_STEP = 4.0
#: The box a trace is tested on: the search's box widened along the non-parameter variables by this
#: fraction of max(its width there, its width along the parameter) on each side (unit coordinates, clipped
#: to the chart): the accepted boxes are the pruner's tight reductions, so the branch touches their faces,
#: and the Krawczyk test needs it inside (K in the interior of V).
TRACE_WIDEN = 0.25
#: ... plus this fraction of the box's width along the parameter (unit coordinates): room for the branch's
#: curvature off the tangent line; small, since the interval Jacobian (and the test's slack) grows with V.
TRACE_PAD = 0.05
#: Unit-coordinate pad of the boxes handed between the box loop (angle coordinates) and the trace tests
#: (unit coordinates): the round trip through tan-half maps errs by ~1e-16; far above it.
ROUNDTRIP_PAD = 1e-12
#: A piece of a traced box (its part over one cell along the parameter) whose cells are not all proven is
#: split into TRACE_SPLIT parts, at most TRACE_REFINE times: the parts' enclosures are tighter (fewer cells
#: met that the branch misses) and their end points prove more cells. Cheap (no search).
TRACE_SPLIT = 4
TRACE_REFINE = 2
#: A cell is proven from a piece's end points only when the end points are this far (radians) inside the
#: cell along the parameter and the enclosures clear the cell edges by it: the tan-half maps round by
#: ~1e-16 rad; far above it, far below any cell.
PROOF_SLACK = 1e-12
#: The end points of a piece are moved inward by this fraction of its width (a piece's ends are cell edges).
PROOF_NUDGE = 1e-4
#: Boxes per batch of trace tests (memory: ~8 kB of control points per box).
TRACE_BATCH = 4096
#: Pieces (a traced box's parts over one cell each along the parameter) tested in one group: each carries its
#: enclosure, end tests and cells (~1 kB with the Python lists), so a group stays ~0.1 GB however small T is.
PIECE_GROUP = 65536
#: A box is traced only when each of its pieces' enclosures meets at most this many cells. Reason: a piece is one
#: cell long along the parameter, so its enclosure's other side, over T, is the branch's slope plus the
#: enclosure's slack; at a small T a loose enclosure of a coarse level's box met ~10^4 cells per piece and the
#: cell lists ran the process out of memory (issue 40, T = 1e-6). Such a box is searched at the next level
#: (smaller boxes, tighter enclosures), or traced along the other input; at T >= 1e-3 no piece of general_3rrr's
#: whole plane met more than a handful (results unchanged, compared cell for cell at T = 0.05).
PIECE_CELLS = 64
#: A cell met by more untraced boxes of one level than this is crowded: those boxes are set aside (an
#: unresolved region, :func:`pending_regions`), not searched at the next, finer level. Reason: above a
#: continuum of singular configurations over one input (the agile eye's self-motion inputs, beta =
#: (+-pi/2, 0), (+-pi/2, +-pi) at beta3 = 0.5) the boxes multiply ~4x per level without end: measured
#: at T = 1e-3, the most crowded cell held 729, 2,693, 9,782 boxes at the levels 0.05, 0.0125, 0.003, and
#: the whole-plane cover ran past 10^7 boxes (12 GB); general_3rrr's most crowded cell at the same levels
#: (and 0.0008) held 29, 39, 61, 151 (cusps and crossings included). Never at the last level (the cell's
#: width): its boxes go to the certificates.
CROWDED_CELL = 1000


@dataclass(frozen=True)
class TracedCover:
    """What :func:`trace_cover` hands over. ``cover``: a :class:`spherekin.search.boxloop.Cover` of the
    boxes not traced (accepted at the cell's width: certified by :func:`certify_cover`) and every pending
    box of every level; ``met``: the cells (i, j) the traced boxes' pieces meet; ``proven``: those of them
    holding a proven singular point (a subset of ``met``); ``traced``: how many boxes were traced;
    ``boxes_processed``, ``seconds``: the searches' work; ``crowded``: the boxes set aside in crowded
    cells (chart (C,), unit lo, hi (C, N); :data:`CROWDED_CELL`), not searched further."""

    cover: object
    met: frozenset
    proven: frozenset
    traced: int
    boxes_processed: int
    seconds: float
    crowded: tuple = ()


def trace_levels(tol: float, cover_fraction: float) -> tuple:
    """The widths (metric units) of the traced cover's levels for cells of width ``tol``: TRACE_START
    divided by TRACE_STEP while above cover_fraction * tol, then cover_fraction * tol."""
    last = cover_fraction * tol
    out, w = [], TRACE_START
    while w > last * (1 + 1e-9):
        out.append(w)
        w /= TRACE_STEP
    return tuple(out) + (last,)


def trace_cover(system, search, grid: Grid, tol: float, cover_fraction: float, max_boxes: int,
                budget=None) -> TracedCover:
    """The cover of a plane system's singular curves with certified tracing (issue 31 benchmark).

    Level by level (:func:`trace_levels`), the box loop accepts boxes of the level's width (``search(width,
    max_boxes, start)``: :func:`spherekin.search.boxloop.search_cover` on the system's charts, returning
    its ``Cover``; passed in, the trust layer does not import the search). An accepted box is dropped when
    the parametric Krawczyk image of the box itself misses it (no singular configuration in it: K holds
    every root of the box; most accepted boxes are such near misses of the Bernstein hulls); the others are
    tested for a trace (:func:`_trace_boxes`): the plane input along which the box is longer (then the
    other) as a parameter p, the parametric Krawczyk test (:meth:`PlatformPlane.trace`) on the box V
    around Newton's tangent line (:func:`_trace_box`), then on each piece of the box's p-range cut at the
    grid's cell edges, on a narrow V' inside V (:func:`_test_pieces`). When they pass, for every p
    of the box one singular configuration lies in V, and it lies in the piece's K: the branch is a graph
    there, and the cells met by the pieces' enclosures cover every singular point of the box (the box is
    not searched further). Cells are proven from the pieces' end points: each point test encloses the
    other input y(p) at that p; by continuity of the graph, every y between the two ends' enclosures is
    reached at a p of the piece, so every cell meeting that gap (or holding an end's enclosure) holds a
    singular point. Boxes that fail go to the next level; at the cell's width they stay in the returned
    cover (the old certificate). No box is dropped: a pending box of any level stays pending, and a box of
    a level before the last in a crowded cell (:data:`CROWDED_CELL`) is set aside (``crowded``: the caller's
    unresolved regions).

    Also why the traced boxes hold no cusp: every J_V over the box is regular, so the branch's tangent
    has a nonzero component along p (J_V dv = -J_p dp, dp = 0 gives dv = 0): its projection to the
    plane is never 0. The cusp search may start from the untraced boxes only.

    Once ``budget`` (:class:`spherekin.budget.Budget`, also handed to ``search`` by the caller) names a reason to
    stop, the boxes of the level at hand that are not traced become pending (unresolved regions), not cells:
    a level's boxes may each span thousands of cells at a small T."""

    charts = system.charts
    n = len(charts.variables)
    met: set = set()
    proven: set = set()
    traced = used = 0
    seconds = 0.0
    pend = [np.zeros(0, dtype=int), np.zeros((0, n)), np.zeros((0, n))]
    crowd = [np.zeros(0, dtype=int), np.zeros((0, n)), np.zeros((0, n))]
    cols = list(system.plane_columns)
    start = None
    levels = trace_levels(tol, cover_fraction)
    rest = (np.zeros(0, dtype=int), np.zeros((0, n)), np.zeros((0, n)))
    for k, width in enumerate(levels):
        cover = search(width, max(1, int(max_boxes) - used), start)
        used += cover.boxes_processed
        seconds += cover.seconds
        pend = [np.concatenate([a, b]) for a, b in zip(pend, cover.pending)]
        chart, alo, ahi = cover.accepted
        if not len(chart):
            rest = cover.accepted
            break
        ulo = np.clip(system.unit(chart, alo) - ROUNDTRIP_PAD, 0.0, 1.0)
        uhi = np.clip(system.unit(chart, ahi) + ROUNDTRIP_PAD, 0.0, 1.0)
        ok = _trace_boxes(system, grid, chart, ulo, uhi, met, proven, budget)
        traced += int(ok.sum())
        if budget is not None and budget.exhausted():
            pend = [np.concatenate([a, b[~ok]]) for a, b in zip(pend, (chart, ulo, uhi))]
            rest = (chart[:0], alo[:0], ahi[:0])
            break
        if k == len(levels) - 1 or len(cover.pending[0]):
            rest = (chart[~ok], alo[~ok], ahi[~ok])      # the cell's width, or a capped search: the old path
            break
        aside = np.zeros(len(chart), dtype=bool)
        aside[~ok] = _in_crowded_cells(grid, alo[~ok][:, cols], ahi[~ok][:, cols])
        crowd = [np.concatenate([a, b[aside]]) for a, b in zip(crowd, (chart, ulo, uhi))]
        keep = ~ok & ~aside
        start = (chart[keep], ulo[keep], uhi[keep])
        if not len(start[0]):
            break
    rest_cover = dataclasses.replace(cover, accepted=rest, pending=tuple(pend), boxes_processed=used, seconds=seconds)
    return TracedCover(rest_cover, frozenset(met), frozenset(proven), traced, used, seconds, tuple(crowd))


def _in_crowded_cells(grid: Grid, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(B,) bool: the rectangles [lo, hi] (B, n_plane; radians) meeting a cell that more than CROWDED_CELL of
    them meet. First on a coarse grid of cells as wide as the widest rectangle: a cell of ``grid`` meets at
    most 2 coarse cells per axis, so when no coarse cell is met by more than CROWDED_CELL / 2^n_plane of them
    no cell is crowded, and the cells of ``grid`` (each rectangle meets ~(width / T)^n_plane of them: 22 s
    for a level of general_3rrr at T = 1e-3) are not counted at all."""
    out = np.zeros(len(lo), dtype=bool)
    if len(lo) <= CROWDED_CELL:
        return out
    n_plane = lo.shape[1]
    width = max(float(np.max(hi - lo)), *(grid.width(a) for a in range(n_plane)))     # > 0: a cell at least
    n = tuple(max(1, min(grid.n[a], math.ceil((grid.hi[a] - grid.lo[a]) / width))) if a < n_plane else 1
              for a in range(len(grid.n)))
    if any(n[a] < grid.n[a] for a in range(n_plane)):
        coarse = Grid(grid.lo, grid.hi, n)
        if max(len(m) for m in _cells_met(coarse, lo, hi).values()) <= CROWDED_CELL / 2 ** n_plane:
            return out
    for members in _cells_met(grid, lo, hi).values():
        if len(members) > CROWDED_CELL:
            out[members] = True
    return out


def _trace_boxes(system, grid: Grid, chart, ulo, uhi, met: set, proven: set, budget=None) -> np.ndarray:
    """Trace tests of boxes (chart (B,), unit lo, hi (B, N)): (B,) bool, True where traced; adds the
    traced boxes' cells to ``met`` and the cells proven to ``proven`` (:func:`trace_cover`). Batches left
    once ``budget`` names a reason to stop are not traced (False)."""

    def stop():
        return budget is not None and budget.exhausted()

    charts = system.charts
    cols = list(system.plane_columns)
    alo, ahi = charts.angle_box(chart, ulo, uhi)
    ext = ahi[:, cols] - alo[:, cols]
    pref = np.where(ext[:, 0] >= ext[:, 1], 0, 1)            # plane axis index of the parameter, first try
    traced = np.zeros(len(chart), dtype=bool)
    # boxes proven empty first: K of the box itself (either input the parameter) disjoint from it, so no
    # singular configuration in it (K holds every root of the box): dropped from the cover ("traced", no cell)
    for s in range(0, len(chart), TRACE_BATCH):
        if stop():
            return traced
        traced[s:s + TRACE_BATCH] = system.empty(chart[s:s + TRACE_BATCH], ulo[s:s + TRACE_BATCH], uhi[s:s + TRACE_BATCH])
    for round_ in range(2):
        axis_of = pref if round_ == 0 else 1 - pref
        for axis in (0, 1):
            idx = np.flatnonzero(~traced & (axis_of == axis))
            for s in range(0, len(idx), TRACE_BATCH):
                if stop():
                    return traced
                part = idx[s:s + TRACE_BATCH]
                traced[part] = _trace_axis(system, grid, axis, chart[part], ulo[part], uhi[part], met, proven, budget)
    return traced


def _trace_axis(system, grid: Grid, axis: int, chart, ulo, uhi, met: set, proven: set, budget=None) -> np.ndarray:
    """:func:`_trace_boxes` with plane axis ``axis`` (0: x, 1: y) as the parameter for every box.

    The box test (on V, :func:`_trace_box`) proves that for every p of the box one root lies in V; each
    piece is then tested on its own narrow V' (Newton's band over the piece, inside V): a root in V'
    is that unique root of V, so K(V') encloses every root of the box over the piece, tightly. The boxes
    whose box test passed go on in groups of at most PIECE_GROUP pieces (a box spans ~width / T cells along
    p: at a small T a batch of boxes has millions of pieces); groups left once ``budget`` names a reason to
    stop are not traced."""
    charts = system.charts
    p = list(system.plane_columns)[axis]
    vlo, vhi, line = _trace_box(system, p, chart, ulo, uhi)
    out = np.zeros(len(chart), dtype=bool)
    whole, _, _ = system.trace(chart, vlo, vhi, p)
    idx = np.flatnonzero(whole)
    if not len(idx):
        return out
    alo, ahi = charts.angle_box(chart[idx], vlo[idx], vhi[idx])
    first, last = grid.span(axis, alo[:, p], ahi[:, p])
    ends = np.cumsum(last - first + 1)                       # pieces of the boxes so far (at most: cells met)
    start = 0
    while start < len(idx):
        if budget is not None and budget.exhausted():
            break
        stop = max(start + 1, int(np.searchsorted(ends, (ends[start - 1] if start else 0) + PIECE_GROUP, "right")))
        group = idx[start:stop]
        out[group] = _trace_group(system, grid, axis, p, chart[group], vlo[group], vhi[group],
                                  tuple(v[group] for v in line), met, proven)
        start = stop
    return out


def _trace_group(system, grid: Grid, axis: int, p: int, chart, vlo, vhi, line, met: set, proven: set) -> np.ndarray:
    """The pieces of boxes whose box test passed (:func:`_trace_axis`): (B,) bool, True where every piece is
    proven (the box is traced); adds the cells to ``met`` and ``proven``."""
    charts = system.charts
    # the pieces: each box's range along p cut at the cell edges (fractions of the range; the ends 0 and 1
    # exact, each cut shared by the two pieces beside it: the pieces cover the range)
    owner, fa, fz = [], [], []
    for b in range(len(chart)):
        cuts = _cuts(grid, axis, charts, int(chart[b]), p, vlo[b, p], vhi[b, p])
        owner += [b] * (len(cuts) - 1)
        fa += cuts[:-1]
        fz += cuts[1:]
    owner, fa, fz = np.array(owner), np.array(fa), np.array(fz)
    ok, klo, khi, ends = _test_pieces(system, p, chart, vlo, vhi, line, owner, fa, fz)
    ok[ok] = _cells_in_pieces(system, grid, chart[owner[ok]], klo[ok], khi[ok]) <= PIECE_CELLS
    good = np.ones(len(chart), dtype=bool)
    good[owner[~ok]] = False                                 # a box is traced when every piece is proven
    keep = good[owner]
    owner, fa, fz, klo, khi = (v[keep] for v in (owner, fa, fz, klo, khi))
    ends = tuple(v[keep] for v in ends)
    for level in range(TRACE_REFINE + 1):
        cells = _piece_cells(system, grid, chart[owner], klo, khi)
        _prove_pieces(system, grid, axis, chart[owner], ends, proven)
        open_ = np.array([any(c not in proven for c in cs) for cs in cells], dtype=bool)
        for k in np.flatnonzero(~open_ if level < TRACE_REFINE else np.ones(len(cells), dtype=bool)):
            met.update(cells[k])
        if level == TRACE_REFINE or not open_.any():
            break
        # the open pieces split along p; a piece any part of which fails keeps its own cells
        o = np.flatnonzero(open_)
        frac = np.linspace(0.0, 1.0, TRACE_SPLIT + 1)
        cut = fa[o, None] + frac[None, :] * (fz[o] - fa[o])[:, None]
        cut[:, 0], cut[:, -1] = fa[o], fz[o]
        sown = np.repeat(owner[o], TRACE_SPLIT)
        sa, sz = cut[:, :-1].ravel(), cut[:, 1:].ravel()
        sub = _test_pieces(system, p, chart, vlo, vhi, line, sown, sa, sz)
        split_ok = sub[0].reshape(-1, TRACE_SPLIT).all(axis=1)
        for k in np.flatnonzero(~split_ok):
            met.update(cells[o[k]])
        g = np.repeat(split_ok, TRACE_SPLIT)
        owner, fa, fz = sown[g], sa[g], sz[g]
        klo, khi = sub[1][g], sub[2][g]
        ends = tuple(v[g] for v in sub[3])
        if not len(owner):
            break
    return good


def _test_pieces(system, p: int, chart, vlo, vhi, line, owner, fa, fz) -> tuple:
    """The trace test of pieces [fa, fz] (fractions of the range along p) of the traced boxes ``owner``
    (chart, [vlo, vhi] (B, N): boxes whose test on V passed; ``line``: their Newton points and slopes),
    each on its narrow V' inside V (:func:`_trace_axis`), else on V, with the point tests at the pieces'
    ends moved inward by PROOF_NUDGE (:func:`_prove_pieces`) on the same restriction. Returns (proven
    (P,), K lo, K hi (P, N), ends): ``ends`` = (proven (P,), K lo, K hi (P, N)) at either end."""
    w = vhi[owner, p] - vlo[owner, p]
    plo, phi = vlo[owner].copy(), vhi[owner].copy()
    plo[:, p] = vlo[owner, p] + fa * w
    phi[:, p] = np.where(fz == 1.0, vhi[owner, p], vlo[owner, p] + fz * w)
    c = chart[owner]
    ok_l, point, slope = line
    glo, ghi = _band(p, plo, phi, point[owner], slope[owner], ok_l[owner], vlo[owner], vhi[owner])
    nlo, nhi = np.maximum(glo, vlo[owner]), np.minimum(ghi, vhi[owner])
    out = _with_ends(system, p, c, nlo, nhi, np.arange(len(c)), np.zeros(len(c)), np.ones(len(c)))
    retry = np.flatnonzero(~out[0])                           # V' around the box's tangent line failed:
    if len(retry):                                            # V' around the piece's own (Newton)
        ok_n, point2, slope2 = system.predict(c[retry], glo[retry], ghi[retry], p)
        rlo, rhi = _band(p, plo[retry], phi[retry], point2, slope2, ok_n, glo[retry], ghi[retry])
        rlo, rhi = np.maximum(rlo, vlo[owner[retry]]), np.minimum(rhi, vhi[owner[retry]])
        sub = _with_ends(system, p, c[retry], rlo, rhi, np.arange(len(retry)), np.zeros(len(retry)),
                         np.ones(len(retry)))
        for a, b in zip(out, sub):
            a[retry] = b
    retry = np.flatnonzero(~out[0])
    if len(retry):                                            # on V itself
        sub = _with_ends(system, p, chart, vlo, vhi, owner[retry], fa[retry], fz[retry])
        for a, b in zip(out, sub):
            a[retry] = b
    return out[0], out[1], out[2], tuple(out[3:])


def _with_ends(system, p: int, chart, lo, hi, owner, fa, fz) -> list:
    """One restriction of the boxes (chart, [lo, hi]) for the tests of their pieces [fa, fz] along p and
    of the pieces' end points moved inward by PROOF_NUDGE: [proven, K lo, K hi] of the pieces, then of the
    first ends, then of the last ends (arrays, (P,) and (P, N))."""
    n = len(owner)
    ta, tb = fa + PROOF_NUDGE * (fz - fa), fz - PROOF_NUDGE * (fz - fa)
    ok, klo, khi = system.trace(chart, lo, hi, p, (np.concatenate([owner, owner, owner]),
                                                    np.concatenate([fa, ta, tb]), np.concatenate([fz, ta, tb])))
    return [v[k * n:(k + 1) * n] for k in range(3) for v in (ok, klo, khi)]


def _band(p: int, plo, phi, point, slope, ok, flo, fhi) -> tuple:
    """Boxes around the tangent lines v = point + slope (u_p - point_p) over [plo, phi] along p, widened
    by TRACE_WIDEN of max(their extent, the range along p) per variable and clipped to the chart; where
    ``ok`` is False, the fallback boxes [flo, fhi] with the range along p."""
    other = [k for k in range(plo.shape[1]) if k != p]
    a = (plo[:, p] - point[:, p])[:, None]
    z = (phi[:, p] - point[:, p])[:, None]
    blo = point[:, other] + np.minimum(slope[:, other] * a, slope[:, other] * z)
    bhi = point[:, other] + np.maximum(slope[:, other] * a, slope[:, other] * z)
    pad = TRACE_WIDEN * (bhi - blo) + TRACE_PAD * (phi[:, p] - plo[:, p])[:, None]
    lo, hi = plo.copy(), phi.copy()
    lo[:, other] = np.where(ok[:, None], np.clip(blo - pad, 0.0, 1.0), flo[:, other])
    hi[:, other] = np.where(ok[:, None], np.clip(bhi + pad, 0.0, 1.0), fhi[:, other])
    return lo, hi


def _trace_box(system, p: int, chart, ulo, uhi) -> tuple:
    """The boxes V of the trace tests (unit, (B, N)): the box's range along the parameter column ``p``; along
    the others the hull of the box and of the band around Newton's tangent line at the middle of the
    range (:meth:`PlatformPlane.predict`), widened by TRACE_WIDEN of max(band width, range along p): the
    branch crosses a search box from face to face (the loop splits boxes anywhere), while the test needs
    it inside V over the whole range. Boxes whose Newton fails keep their own V widened alike. Returns
    (lo, hi, (converged, point, slope))."""
    ok, point, slope = line = system.predict(chart, ulo, uhi, p)
    other = [k for k in range(ulo.shape[1]) if k != p]
    a = (ulo[:, p] - point[:, p])[:, None]
    z = (uhi[:, p] - point[:, p])[:, None]
    blo = np.where(ok[:, None], point[:, other] + np.minimum(slope[:, other] * a, slope[:, other] * z), ulo[:, other])
    bhi = np.where(ok[:, None], point[:, other] + np.maximum(slope[:, other] * a, slope[:, other] * z), uhi[:, other])
    blo, bhi = np.minimum(blo, ulo[:, other]), np.maximum(bhi, uhi[:, other])
    pad = TRACE_WIDEN * (bhi - blo) + TRACE_PAD * (uhi[:, p] - ulo[:, p])[:, None]
    vlo, vhi = ulo.copy(), uhi.copy()
    vlo[:, other] = np.clip(blo - pad, 0.0, 1.0)
    vhi[:, other] = np.clip(bhi + pad, 0.0, 1.0)
    return vlo, vhi, line


def _cuts(grid: Grid, axis: int, charts, c: int, col: int, u0: float, u1: float) -> list:
    """The fractions of [u0, u1] (unit coordinates of chart c, column ``col``) at the grid's cell edges
    along ``axis`` strictly inside it: [0, cuts..., 1]."""
    lo = np.array([[u0] * charts.map_lo.shape[1]])
    hi = np.array([[u1] * charts.map_lo.shape[1]])
    a0, a1 = charts.angle_box(np.array([c]), lo, hi)
    i0, i1 = grid.span(axis, float(a0[0, col]), float(a1[0, col]))
    edges = [grid.edges(axis, i)[0] for i in range(int(i0) + 1, int(i1) + 1)]
    if not edges:
        return [0.0, 1.0]
    u = tan_half_unit(np.array(edges), charts.shift[c, col], charts.map_lo[c, col], charts.map_hi[c, col])
    f = (np.asarray(u) - u0) / (u1 - u0)
    return [0.0] + [float(v) for v in f if 0.0 < v < 1.0] + [1.0]


def _cells_in_pieces(system, grid: Grid, chart, klo, khi) -> np.ndarray:
    """How many cells each piece's enclosure [klo, khi] (unit, (P, N)) meets, (P,) (no lists built)."""
    cols = list(system.plane_columns)
    alo, ahi = system.charts.angle_box(chart, klo, khi)
    s0 = grid.span(0, alo[:, cols[0]], ahi[:, cols[0]])
    s1 = grid.span(1, alo[:, cols[1]], ahi[:, cols[1]])
    return (s0[1] - s0[0] + 1) * (s1[1] - s1[0] + 1)


def _piece_cells(system, grid: Grid, chart, klo, khi) -> list:
    """The cells (i, j) met by each piece's enclosure [klo, khi] (unit, (P, N)): a list of lists."""
    cols = list(system.plane_columns)
    alo, ahi = system.charts.angle_box(chart, klo, khi)
    s0 = grid.span(0, alo[:, cols[0]], ahi[:, cols[0]])
    s1 = grid.span(1, alo[:, cols[1]], ahi[:, cols[1]])
    return [[(i, j) for i in range(s0[0][k], s0[1][k] + 1) for j in range(s1[0][k], s1[1][k] + 1)]
            for k in range(len(chart))]


def _prove_pieces(system, grid: Grid, axis: int, chart, ends, proven: set) -> None:
    """Cells proven by the pieces' end points (:func:`trace_cover`): ``ends`` = (proven, K lo, K hi) of the
    point tests at either end of each piece (charts ``chart`` (P,), :func:`_with_ends`); adds (i, j) to
    ``proven``."""
    charts = system.charts
    cols = list(system.plane_columns)
    p, q = cols[axis], cols[1 - axis]
    ok_a, la, ha, ok_b, lb, hb = ends
    alo, ahi = charts.angle_box(chart, la, ha)
    blo, bhi = charts.angle_box(chart, lb, hb)
    xa, ya0, ya1 = alo[:, p], alo[:, q], ahi[:, q]
    xb, yb0, yb1 = blo[:, p], blo[:, q], bhi[:, q]
    ok = ok_a & ok_b & np.isfinite(xa) & np.isfinite(xb)     # a failed test's enclosure is not read
    ia, ib = np.full(len(xa), -1), np.full(len(xb), -1)
    ia[ok], ib[ok] = grid.index(axis, xa[ok]), grid.index(axis, xb[ok])
    for k in np.flatnonzero(ok & (ia == ib) & (ia >= 0) & (ia < grid.n[axis])):
        e0, e1 = grid.edges(axis, int(ia[k]))
        if min(xa[k], xb[k]) - e0 < PROOF_SLACK or e1 - max(xa[k], xb[k]) < PROOF_SLACK:
            continue                                  # an end too close to the cell's edge along p
        j0, j1 = grid.span(1 - axis, min(ya0[k], yb0[k]), max(ya1[k], yb1[k]))
        g_lo = min(ya1[k], yb1[k]) + PROOF_SLACK          # the gap between the ends' enclosures: reached
        g_hi = max(ya0[k], yb0[k]) - PROOF_SLACK
        for j in range(int(j0), int(j1) + 1):
            f0, f1 = grid.edges(1 - axis, j)
            inside = any(f0 + PROOF_SLACK <= y0 and y1 <= f1 - PROOF_SLACK
                         for y0, y1 in ((ya0[k], ya1[k]), (yb0[k], yb1[k])))
            gap = g_lo <= g_hi and max(f0, g_lo) <= min(f1, g_hi)
            if inside or gap:
                proven.add((int(ia[k]), j) if axis == 0 else (j, int(ia[k])))
