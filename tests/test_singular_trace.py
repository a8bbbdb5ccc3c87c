"""Certified tracing of general_3rrr's singular curves (spherekin.singularities.cells.trace_cover, issue 31's benchmark).

Checked against the independent references of tests/singular_refs.py (the degree-8 oracle's real-root count
along segments, bisected where it changes): the traced cells and the rest of the cover hold every reference
singular input of seeded segments across a square of the plane beta3 = 0.5, and every cell the traces prove
``singular`` is crossed by the reference curve (a singular input on the cell's own boundary). The control
flow that keeps proofs honest (a box is traced only when every piece passed its Krawczyk test; a cell is
proven only from end points whose point tests passed; the pieces cover the box's range exactly, one cell
each) is checked by failing the tests on purpose and by the pieces' cut points against the tan-half map
computed here.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import spherekin
from spherekin.problem import as_mechanism
from spherekin.singularities.cover import COVER_FRACTION
from spherekin.search.boxloop import pruner_for
from spherekin.singularities.planes import PlatformPlane, SingularPlane
from spherekin.singularities import cells as ts
from singular_refs import EXAMPLES, lines_across, singular_points_on_line

RRR = EXAMPLES / "general_3rrr.toml"
#: A square the curves cross several times (the one of tests/test_singular.py's quarter set).
SQUARE = ((0.9, 1.4), (1.1, 1.6))
#: Cells of 0.02: the levels 0.05, 0.0125 and 0.01 (tracing starts to succeed at 0.0125).
T = 0.02
#: Closed cells: a reference point (bisected to 1e-10) on a cell edge counts as inside within this.
EDGE = 1e-9


@pytest.fixture(scope="module")
def plane_system():
    (x0, x1), (y0, y1) = SQUARE
    plane = SingularPlane(("beta1", x0, x1), ("beta2", y0, y1), {"beta3": 0.5})
    system = PlatformPlane(as_mechanism(RRR), plane)
    return system, ts.Grid.over(plane.axes, T)


@pytest.fixture(scope="module")
def traced(plane_system):
    system, grid = plane_system
    from spherekin.search.boxloop import search_cover

    pruner = pruner_for(system.charts, "pp", None)
    return ts.trace_cover(system, lambda w, cap, start: search_cover(system.charts, pruner, w, cap, start=start),
                          grid, T, COVER_FRACTION, 10**6)


@pytest.fixture(scope="module")
def reference_points():
    pts = [s.inputs[:2] for p0, p1 in lines_across(SQUARE, 4, 7)
           for s in singular_points_on_line(p0, p1, n_samples=50)]
    assert len(pts) >= 8
    return np.array(pts)


def _cell_of(grid, point) -> list:
    """The closed cells (i, j) holding a point (two or four on an edge or a corner)."""
    out = []
    for i in range(grid.n[0]):
        e0, e1 = grid.edges(0, i)
        if e0 - EDGE <= point[0] <= e1 + EDGE:
            for j in range(grid.n[1]):
                f0, f1 = grid.edges(1, j)
                if f0 - EDGE <= point[1] <= f1 + EDGE:
                    out.append((i, j))
    return out


def test_traced_cover_holds_every_reference_point(plane_system, traced, reference_points):
    """Every reference singular input lies in a traced cell or in a rectangle of the rest of the cover; the
    traces carry most of them (the path is exercised), and the whole API result covers them too."""
    system, grid = plane_system
    assert traced.traced > 0 and traced.cover.complete
    chart, alo, ahi = traced.cover.accepted
    cols = list(system.plane_columns)
    in_traced = 0
    for p in reference_points:
        cells = _cell_of(grid, p)
        assert cells
        if any(c in traced.met for c in cells):
            in_traced += 1
            continue
        rest = np.all((alo[:, cols] - EDGE <= p) & (p <= ahi[:, cols] + EDGE), axis=1)
        assert rest.any(), f"reference singular input {p} outside the cover"
    assert in_traced >= 0.7 * len(reference_points)
    (x0, x1), (y0, y1) = SQUARE
    sset = spherekin.singular(RRR, x=("beta1", x0, x1), y=("beta2", y0, y1), fixed={"beta3": 0.5}, tol=T)
    lo = np.array([[b.x[0], b.y[0]] for b in sset.boxes])
    hi = np.array([[b.x[1], b.y[1]] for b in sset.boxes])
    for p in reference_points:
        assert np.any(np.all((lo - EDGE <= p) & (p <= hi + EDGE), axis=1)), p
    singular = {(round((b.x[0] - x0) / grid.width(0)), round((b.y[0] - y0) / grid.width(1)))
                for b in sset.boxes if b.status == "singular"}
    assert traced.proven <= singular


def test_traced_singular_cells_are_crossed_by_the_reference_curve(plane_system, traced):
    """Each cell the traces prove ``singular`` (a seeded sample of them): the reference finds a singular input
    on the cell's own boundary (the curve through the cell leaves it; the cells are far smaller than the
    curve's loops), so a proof put in a neighbouring cell fails here."""
    system, grid = plane_system
    assert len(traced.proven) >= 20
    assert traced.proven <= traced.met
    cells = sorted(traced.proven)
    rng = np.random.default_rng(3)
    for k in rng.choice(len(cells), size=8, replace=False):
        i, j = cells[k]
        x0, x1 = grid.edges(0, i)
        y0, y1 = grid.edges(1, j)
        edges = [((x0, y0), (x1, y0)), ((x1, y0), (x1, y1)), ((x1, y1), (x0, y1)), ((x0, y1), (x0, y0))]
        found = [s for p0, p1 in edges for s in singular_points_on_line(p0, p1, n_samples=10, seed=1)]
        assert found, f"no reference singular input on the boundary of the proven cell {(i, j)}"


def _accepted_boxes(system, width):
    """The cover's accepted boxes at one level (unit coordinates of their charts)."""
    from spherekin.search.boxloop import search_cover

    cov = search_cover(system.charts, pruner_for(system.charts, "pp", None), width, 10**6)
    chart, alo, ahi = cov.accepted
    return chart, system.unit(chart, alo), system.unit(chart, ahi)


class _Failing:
    """The plane system with its trace tests failed on purpose where ``fail(pieces)`` says so."""

    def __init__(self, system, fail):
        self._system, self._fail = system, fail
        self.charts, self.plane_columns = system.charts, system.plane_columns
        self.calls = []

    def predict(self, *args):
        return self._system.predict(*args)

    def empty(self, *args):
        return self._system.empty(*args)

    def trace(self, chart, lo, hi, param, pieces=None):
        ok, klo, khi = self._system.trace(chart, lo, hi, param, pieces)
        self.calls.append((np.asarray(chart), np.asarray(lo), np.asarray(hi), param, pieces))
        return ok & ~self._fail(np.asarray(lo), np.asarray(hi), param, pieces, len(ok)), klo, khi


def _empty(system, chart, lo, hi) -> np.ndarray:
    """Boxes whose parametric Krawczyk image (either input the parameter) misses the box: no root."""
    out = np.zeros(len(chart), dtype=bool)
    for p in system.plane_columns:
        _, klo, khi = system.trace(chart, lo, hi, p)
        out |= np.any(klo > khi, axis=1)
    return out


@pytest.fixture(scope="module")
def small_boxes(plane_system):
    """Accepted boxes of the level 0.0125 (unit coordinates) not proven empty and traced by the real tests."""
    system, grid = plane_system
    chart, lo, hi = _accepted_boxes(system, 0.0125)
    keep = ~_empty(system, chart, lo, hi)
    chart, lo, hi = chart[keep], lo[keep], hi[keep]
    ok = ts._trace_boxes(system, grid, chart, lo, hi, set(), set())
    assert ok.sum() >= 10
    return chart[ok], lo[ok], hi[ok]


def test_a_box_is_traced_only_when_every_piece_is_proven(plane_system, small_boxes, monkeypatch):
    system, grid = plane_system
    real = ts._test_pieces

    def failing(*args):                            # every piece's test failed
        ok, *rest = real(*args)
        return (np.zeros_like(ok), *rest)

    monkeypatch.setattr(ts, "_test_pieces", failing)
    met, proven = set(), set()
    assert not ts._trace_boxes(system, grid, *small_boxes, met, proven).any()
    assert not met and not proven
    monkeypatch.undo()
    # the test of the whole box (on V, no pieces: the uniqueness over the range) failed: nothing traced
    _, blo, bhi = small_boxes

    def whole(lo, hi, p, pieces, n):                # a call on whole boxes: their full range along p
        if pieces is not None:
            return np.zeros(n, dtype=bool)
        return np.array([np.any((blo[:, p] == a) & (bhi[:, p] == b)) for a, b in zip(lo[:, p], hi[:, p])])

    met = set()
    assert not ts._trace_boxes(_Failing(system, whole), grid, *small_boxes, met, set()).any()
    assert not met


def test_a_cell_is_proven_only_by_passed_point_tests(plane_system, small_boxes):
    """The end points' tests failed on purpose: the boxes are still traced (their cells in the cover) but
    no cell is proven."""
    system, grid = plane_system
    fake = _Failing(system, lambda lo, hi, p, pieces, n: (np.zeros(n, dtype=bool) if pieces is None
                                                         else np.asarray(pieces[1]) == np.asarray(pieces[2])))
    met, proven = set(), set()
    assert ts._trace_boxes(fake, grid, *small_boxes, met, proven).all()
    assert met and not proven


def test_pieces_cover_each_box_range_one_cell_each(plane_system, small_boxes, monkeypatch):
    """The pieces of the traced boxes (the first call of the piece tests): fractions from 0 to 1, each cut
    shared by two neighbours, each inner cut at a cell edge (the tan-half map computed here), each piece
    inside one cell."""
    system, grid = plane_system
    calls = []
    real = ts._test_pieces

    def spy(*args):
        calls.append(args)
        return real(*args)

    monkeypatch.setattr(ts, "_test_pieces", spy)
    ts._trace_boxes(system, grid, *small_boxes, set(), set())
    _, p, chart, lo, hi, _, owner, a, z = calls[0]
    axis = list(system.plane_columns).index(p)
    cs = system.charts
    w = grid.width(axis)
    checked = 0
    for b in np.unique(owner):
        mine = np.flatnonzero(owner == b)
        fa, fz = a[mine], z[mine]
        assert fa[0] == 0.0 and fz[-1] == 1.0 and np.array_equal(fa[1:], fz[:-1])
        c = int(chart[b])
        u = lo[b, p] + np.concatenate([fa, [1.0]]) * (hi[b, p] - lo[b, p])
        t = cs.map_lo[c, p] + u * (cs.map_hi[c, p] - cs.map_lo[c, p])           # the tan-half variable
        beta = cs.shift[c, p] + 2.0 * np.arctan(t)
        for x in beta[1:-1]:                                                     # inner cuts: cell edges
            k = (x - grid.lo[axis]) / w
            assert abs(k - round(k)) < 1e-9
        for x0, x1 in zip(beta[:-1], beta[1:]):                                  # one cell per piece
            assert math.floor((x0 - grid.lo[axis]) / w + 1e-9) == math.floor((x1 - grid.lo[axis]) / w - 1e-9)
        checked += len(fa) > 1
    assert checked >= 3                                                          # boxes cut at cell edges


def test_trace_levels():
    assert ts.trace_levels(0.1, 0.5) == (0.05,)
    levels = ts.trace_levels(1e-3, 0.5)
    assert levels[0] == ts.TRACE_START and levels[-1] == 5e-4
    assert all(a > b for a, b in zip(levels, levels[1:]))


@pytest.mark.parametrize("seed", range(6))
def test_crowded_cells_are_those_a_count_over_every_cell_finds(seed, monkeypatch):
    """singularities.cells._in_crowded_cells (a coarse grid first, to skip counting the fine cells when no cell can
    be crowded) against counting every cell of the grid: the same rectangles flagged, for clusters of
    rectangles dense enough or not, wide or narrow beside the cells (the threshold made 12 for the test)."""
    import spherekin.singularities.cells as ts

    monkeypatch.setattr(ts, "CROWDED_CELL", 12)
    rng = np.random.default_rng(seed)
    grid = ts.Grid.over([("x", -1.0, 1.0), ("y", -1.0, 1.0)], 0.05)
    width = (0.02, 0.1, 0.3)[seed % 3]
    lo = np.concatenate([rng.uniform(-1, 1 - width, (20, 2)),
                         rng.uniform(0.2, 0.2 + 0.1 * seed, (rng.integers(5, 30), 2))])
    hi = lo + width
    counts = {}
    for b in range(len(lo)):
        for i in range(int(grid.span(0, lo[b, 0], hi[b, 0])[0]), int(grid.span(0, lo[b, 0], hi[b, 0])[1]) + 1):
            for j in range(int(grid.span(1, lo[b, 1], hi[b, 1])[0]), int(grid.span(1, lo[b, 1], hi[b, 1])[1]) + 1):
                counts.setdefault((i, j), []).append(b)
    want = np.zeros(len(lo), dtype=bool)
    for members in counts.values():
        if len(members) > 12:
            want[members] = True
    assert np.array_equal(ts._in_crowded_cells(grid, lo, hi), want)


def test_a_crowd_split_over_four_coarse_cells_is_still_found(monkeypatch):
    """16 small rectangles around a corner of the coarse grid, 4 in each coarse cell, all in one cell of the
    grid (its edges are not the coarse grid's): that cell is crowded (threshold 12) though no coarse cell is
    met by more than 4 (plus one wide rectangle far away, which sets the coarse width)."""
    import spherekin.singularities.cells as ts

    monkeypatch.setattr(ts, "CROWDED_CELL", 12)
    grid = ts.Grid.over([("x", -1.0, 1.03), ("y", -1.0, 1.03)], 0.05)
    coarse_w = (1.03 + 1.0) / math.ceil((1.03 + 1.0) / 0.4)
    p = np.array([-1.0 + 2 * coarse_w, -1.0 + 3 * coarse_w])          # a corner of the coarse cells
    offsets = [(sx * d, sy * d) for sx in (-1, 1) for sy in (-1, 1) for d in (1e-3, 2e-3, 3e-3, 4e-3)]
    lo = np.array([p + o for o in offsets] + [[0.55, -0.95]])
    hi = lo + np.array([[1e-4, 1e-4]] * 16 + [[0.4, 0.4]])
    got = ts._in_crowded_cells(grid, lo, hi)
    assert got[:16].all() and not got[16]
