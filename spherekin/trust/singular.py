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
* ``unresolved``: no such proof (cusps, crossings of two branches, a slice tangent to the curve, boxes
  never processed because the box cap was reached).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..closure import tan_half_unit

__all__ = ["CELL_SLACK", "HULL_WIDEN", "Grid", "CellStatus", "cell_pieces", "certify_cover", "SINGULAR", "UNRESOLVED"]

SINGULAR = "singular"
UNRESOLVED = "unresolved"
#: A rectangle meets a cell when it comes within this (radians) of it: the chart maps (tan-half angle) round
#: by ~1e-16 rad, so adjacent charts may leave gaps of that size between their rectangles; far above it.
CELL_SLACK = 1e-9
#: The hull of a slice's boxes is widened by this fraction of its width on each side (unit coordinates)
#: before the Krawczyk test: the root must lie in the interior of the box tested, and the boxes' hull can
#: touch it at a face (accepted boxes are the pruner's tight reductions).
HULL_WIDEN = 0.1


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
    out = [CellStatus(i, j, SINGULAR if (i, j) in proven else UNRESOLVED)
           for i, j in sorted(set(met) | pending_cells)]
    return tuple(out)


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
