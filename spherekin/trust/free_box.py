"""Singularity-free boxes of inputs around a home input, proven for one assembly (issue 31, item 4).

From a home input and the assembly the robot is in there (a start pose, a root of the closure at
home), :func:`free_box` returns the largest box of inputs home +- r (r the same for every free
input; the other inputs fixed at home) that it proves to hold that assembly without a parallel
singularity: for every input of the box the assembly has exactly one pose in a proven box of the
unknowns, the pose moves continuously with the input, and the Jacobian of the closure in the
unknowns is regular there (no two assemblies meet).

How a candidate box is proven (:func:`_cover`):

* The box is covered by cells (a grid of cells no wider than FIRST_CELL, each cell that fails halved
  along every free input, down to MIN_CELL). Each cell B is proven by the parametric Krawczyk test
  over boxes of inputs (:func:`spherekin.trust.continuation.krawczyk_input_boxes` on the platform's
  orientation, :meth:`spherekin.trust.loop_continuation.LoopEquations.krawczyk_input_boxes` on the
  loop equations of any mechanism), with the box W of unknowns centred on Newton's root at the
  cell's centre (continued from a neighbour's) and W_FACTOR times as wide as the roots' linear spread
  over the cell (plus W_EVEN times the largest spread). Proven: every input of B has exactly one
  root in W and J is regular on W x B.
* Cells are tied to the home assembly by a proven overlap: two cells sharing a face are the same
  branch when a point Krawczyk box P (radius POINT_RADIUS) around the root at the centre of their
  shared face lies inside both W's (with the trackers' margin MARGIN): each W holds exactly one root
  of that input, P holds one, so they are the same root, and over each cell the root in W is a
  continuous function of the input. The first cells are tied to the start pose the same way, at
  home. Breadth first from there; a cell that cannot be tied fails the box.

A box is free when every cell is proven and tied. The radius grows geometrically (GROWTH) from
FIRST_RADIUS until a box is not free (a cell below MIN_CELL fails: the box meets, or comes within
~a cell of, a singularity of the assembly; MAX_CELLS cells; or MAX_RADIUS), then the radius is bisected
BISECTIONS times between the last free and the first failed box. Every box returned is proven; the
next one out (by the bisection's last bracket) was not.

The charts: on the platform's orientation each cell's W is in Cayley coordinates about the pose at its
centre (:func:`spherekin.trust.continuation.cayley`), as each tracker step is about the step's start;
the overlap test reads the face's root in both charts in floats, with the tracker's margin MARGIN (ten
times POINT_RADIUS) for the rounding of that change of chart, as the tracker does from step to step.
Joint ranges are not constraints here (a pose with a passive joint out of its range is not a
singularity); the actuated joints' ranges are not clipped either.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from itertools import product
from typing import Mapping

import numpy as np

from ..core.angles import room_in_range
from ..systems.platform import platform_legs
from .continuation import (MARGIN, POINT_RADIUS, LegEquations, cayley, cayley_coordinates, krawczyk_input_boxes,
                           krawczyk_steps, not_tracked, predict_many)
from .loop_continuation import LoopEquations

__all__ = ["FIRST_RADIUS", "GROWTH", "BISECTIONS", "FACE_BISECTIONS", "SHAPES", "MAX_RADIUS", "FIRST_CELL", "MIN_CELL",
           "MAX_CELLS", "W_FACTOR", "W_EVEN", "START_TOL", "Face", "FreeBox", "checked_home", "free_box"]

#: The first radius tried (radians of every free input around home). Reason: small enough that a
#: home pose a few 0.01 rad from a singularity still gets a box from the bisection below it, large
#: enough that the geometric growth reaches 1 rad in ~7 boxes.
FIRST_RADIUS = 0.05
#: A free box's radius is multiplied by this until a box fails. Reason: 1.5 reaches the limit in a
#: few boxes and then leaves a bracket [r, 1.5 r] that BISECTIONS halvings narrow to 1 % of r.
GROWTH = 1.5
#: Halvings of the bracket [last free radius, first failed radius]. Reason: 6 narrow the 50 %
#: bracket of GROWTH to 0.8 % of r: the box returned is within 1 % of the largest free radius the
#: cells can prove (the cells' own resolution, MIN_CELL, limits it anyway).
BISECTIONS = 6
#: Largest radius (radians): home +- pi is a full turn of every free input, beyond which inputs repeat.
MAX_RADIUS = math.pi
#: Widest first cell (radians of input). Reason: the Krawczyk test over a cell passes when the roots'
#: spread over it is small against the distance to a singularity and their curvature; 0.1 rad passes
#: on general_3rrr away from its singular curves (a 1-rad box is ~400 first cells in a plane).
FIRST_CELL = 0.1
#: A cell this narrow (radians, every free input) that still cannot be proven fails the box. Reason:
#: next to a fold the provable cell shrinks like the distance to it, so the box stops ~a few MIN_CELL
#: from the singular set: 1e-3 rad is below any actuator's resolution that matters here and keeps the
#: number of halvings per failure at ~7 from FIRST_CELL.
MIN_CELL = 1e-3
#: Most cells of one candidate box (proven and failed, every halving counted). Reason: a box whose
#: edge runs within MIN_CELL of a singular curve needs ~edge / MIN_CELL cells along it; 20,000 keep one
#: box's proof under ~10 s on one core, a box needing more is reported as not proven ("cells").
MAX_CELLS = 20_000
#: The box W of unknowns of a cell is W_FACTOR times the linear spread of the roots over the cell,
#: |J^-1 J_input| (half-widths of the cell), on each side of the root at its centre. Reason: the
#: Krawczyk image is that spread plus terms quadratic in W, so W needs slack beyond it; 2 (as the
#: tracker's step box, the step's hull plus half of it on each side) passes cells on general_3rrr
#: where 1.3 fails twice as often.
W_FACTOR = 2.0
#: ... plus W_EVEN times the largest of those spreads on every side. Reason: where one unknown is
#: stationary over the cell (its spread ~0: the four-bar's coupler near A = 0.6) its side of W would
#: be thinner than the interval enclosure's overestimation, which follows the whole box: the tracker's
#: step box has the same floor (its margin is relative to the largest coordinate of the step).
W_EVEN = 0.5
#: Halvings of each face's bracket after the cube (shape "box"). Reason: 4 narrow a face's 50 % bracket
#: to 3 % of its extent at a third of BISECTIONS' cost (each is a whole box's proof); the cube's radius,
#: proven first to 1 %, is the floor of every face.
FACE_BISECTIONS = 4
#: The shapes of a free box: "cube", home +- r with one r for every free input; "box", that cube, then
#: its faces pushed out one at a time (each as far as it can be proven with the others held). Reason:
#: a singularity close on one side of home stops the cube; the box keeps the room on the other sides
#: (the designer's "how far can each actuator go").
SHAPES = ("box", "cube")
#: A start pose must close the equations at home to this (largest residual) before it is polished and proven.
START_TOL = 1e-6


@dataclass(frozen=True)
class Face:
    """One face of a free box: the side ("lo" or "hi") of the free input ``input``, its distance from
    home (``extent``, radians) and why it stops there (``limit``: as :class:`FreeBox`'s, plus "range":
    the input's joint range, "bounds": the bounds asked for; ``limit_at``: the failed cell's centre by input name, or None)."""

    input: str
    side: str
    extent: float
    limit: str
    limit_at: dict | None = None


@dataclass(frozen=True)
class FreeBox:
    """A box of inputs proven free of parallel singularities for one assembly (module doc).

    ``inputs``: the actuated joints' names; ``lo``, ``hi``: the box per input (radians; a fixed input
    has lo = hi = its home value); ``free``: the names of the inputs that vary; ``home`` (radians, per
    input); ``start``: the assembly's pose at home (the platform rotation R (3, 3) as nested tuples,
    or the passive angles by name); ``cells``: cells of the proof of the box returned; ``proven``: a box
    of positive radius was proven (False: not even FIRST_RADIUS / 2^BISECTIONS); ``radius``: the
    half-width of the largest cube proven (radians; the box's faces are at least that far from home
    unless a joint range is nearer); ``limit``: why the cube is not larger ("unproven": a cell of ``min_cell`` in the
    next box out could not be proven, near ``limit_at``: a singularity of the assembly within ~a cell
    of it, or, on the loop equations, enclosures too loose there; "link": a cell could not be tied to
    the home assembly; "cells": ``max_cells``; "radius": the largest radius asked for reached; "range":
    every face at its input's joint range; "bounds": every face at the ``bounds`` given);
    ``limit_at``: the inputs (by name) of the failed cell's centre, or None; ``faces``: each face of the
    box (:class:`Face`; shape "box": pushed out one at a time); ``shape``: "box" or "cube" (SHAPES);
    ``seconds``: the wall time.
    """

    inputs: tuple
    lo: tuple
    hi: tuple
    free: tuple
    home: tuple
    start: object = field(repr=False)
    cells: int
    proven: bool
    radius: float
    limit: str
    limit_at: dict | None
    faces: tuple = ()
    shape: str = "cube"
    seconds: float = field(repr=False, default=0.0)

    def as_dict(self) -> dict:
        """The JSON key ``"free_box"``: ``"x"``, ``"y"`` (the first two free inputs) and any further free
        input by name, each [lo, hi] (radians); ``"inputs"``: every input's [lo, hi]; ``"home"``,
        ``"radius"``, ``"cells"``, ``"proven"``, ``"limit"``, ``"limit_at"``, ``"shape"``, ``"faces"`` (per face:
        ``"input"``, ``"side"``, ``"extent"``, ``"limit"``, ``"limit_at"``), ``"start"`` (the assembly at
        home: the platform rotation R as rows, or the passive angles by name)."""
        box = {n: [float(a), float(b)] for n, a, b in zip(self.inputs, self.lo, self.hi)}
        out = {key: box[n] for key, n in zip(("x", "y"), self.free)}
        out.update({n: box[n] for n in self.free[2:]})
        out.update({"inputs": box, "home": [float(v) for v in self.home], "radius": self.radius,
                    "cells": self.cells, "proven": self.proven, "limit": self.limit,
                    "limit_at": None if self.limit_at is None else dict(self.limit_at), "shape": self.shape,
                    "faces": [{"input": f.input, "side": f.side, "extent": f.extent, "limit": f.limit,
                               "limit_at": None if f.limit_at is None else dict(f.limit_at)} for f in self.faces],
                    "start": ({n: float(v) for n, v in self.start.items()} if isinstance(self.start, Mapping)
                              else [[float(v) for v in row] for row in self.start])})
        return out


# ---------------------------------------------------------------- the two equation systems


class _Platform:
    """Cells on the platform's orientation: a state is a displacement D (3, 3); a cell's W is in
    Cayley coordinates about the pose at its centre (module doc)."""

    def __init__(self, mechanism, start):
        self.eqs = LegEquations(platform_legs(mechanism))
        self.ref = np.array(mechanism.platform_reference_matrix, dtype=float)
        self.start_rotation = np.asarray(start, dtype=float)

    def start_state(self, home):
        rot = self.start_rotation
        if rot.shape != (3, 3) or not np.all(np.isfinite(rot)):
            raise ValueError(f"start: expected a rotation matrix R (3, 3), got shape {rot.shape}")
        d = rot @ self.ref.T
        res = float(np.abs(self.eqs.residual(d, home)).max())
        if res > START_TOL:
            raise ValueError(f"start: the start pose does not close the legs at home {home.tolist()} (largest "
                             f"residual {res:.3g} > {START_TOL:g}); give the pose of an assembly at home")
        return d

    def continued(self, states, x0, x1):
        w, ok = predict_many(self.eqs, states, x0, x1)
        return states @ cayley(w), ok

    def chart(self, states, x_lo, x_hi):
        """(charts, w_lo, w_hi): the cells' W about their centre poses (W_FACTOR times the linear spread)."""
        x_c = 0.5 * (x_lo + x_hi)
        _, jac = self.eqs.values(states, np.zeros((len(states), 3)), x_c)
        rate = np.einsum("...ij,...ij->...i", self.eqs.elbow_rate(x_c) @ states, self.eqs.b)     # dh_i/dbeta_i
        spread = _spread(jac, rate[..., None] * np.eye(3), 0.5 * (x_hi - x_lo))
        return states, -spread, spread

    def prove(self, charts, w_lo, w_hi, x_lo, x_hi):
        return krawczyk_input_boxes(self.eqs, charts, w_lo, w_hi, x_lo, x_hi)[0]

    def point(self, states, x):
        pad = np.full((len(states), 3), POINT_RADIUS)
        return krawczyk_steps(self.eqs, states, -pad, pad, x, x)

    def coordinates(self, states, charts):
        return cayley_coordinates(np.swapaxes(charts, -1, -2) @ states)

    def pose(self, state):
        return tuple(tuple(map(float, row)) for row in state @ self.ref)


class _Loops:
    """Cells on the loop equations (any mechanism): a state is the passive angles theta (M,) and
    a cell's W a box of them."""

    def __init__(self, mechanism, start, home):
        self.mechanism = mechanism
        self.eqs = LoopEquations(mechanism, home)
        self.start_angles = start

    def start_state(self, home):
        names = self.eqs.passive
        if isinstance(self.start_angles, Mapping):
            missing = [n for n in names if n not in self.start_angles]
            if missing:
                raise ValueError(f"start: missing the angle(s) of {missing}; expected one per passive joint "
                                 f"{list(names)}")
            theta = np.array([float(self.start_angles[n]) for n in names])
        else:
            theta = np.asarray(self.start_angles, dtype=float).reshape(-1)
            if theta.shape != (len(names),):
                raise ValueError(f"start: expected {len(names)} passive angles {list(names)}, got shape {theta.shape}")
        res = self.eqs.closure(theta, home) if np.all(np.isfinite(theta)) else math.inf
        if not res <= START_TOL:
            raise ValueError(f"start: the start angles do not close the loops at home {home.tolist()} (largest "
                             f"entry of |F_n - I| {res:.3g} > {START_TOL:g}); give an assembly at home")
        return theta

    def continued(self, states, x0, x1):
        out = [self.eqs.predict(th, a, b) for th, a, b in zip(states, x0, x1)]
        ok = np.array([th is not None for th in out], dtype=bool)
        return np.array([states[i] if th is None else th for i, th in enumerate(out)]).reshape(states.shape), ok

    def chart(self, states, x_lo, x_hi):
        x_c = 0.5 * (x_lo + x_hi)
        jp, ja = zip(*[self.eqs.values(th, x)[1:] for th, x in zip(states, x_c)])
        spread = _spread(np.array(jp), np.array(ja), 0.5 * (x_hi - x_lo))
        return states, states - spread, states + spread

    def prove(self, charts, w_lo, w_hi, x_lo, x_hi):
        return self.eqs.krawczyk_input_boxes(w_lo, w_hi, x_lo, x_hi)

    def point(self, states, x):
        return self.eqs.krawczyk(states - POINT_RADIUS, states + POINT_RADIUS, x, x)

    def coordinates(self, states, charts):
        return states

    def pose(self, state):
        return dict(zip(self.eqs.passive, (float(v) for v in state)))


def _spread(jac, rate, half) -> np.ndarray:
    """W_FACTOR |J^-1 J_input| half + MARGIN (N, M): the half-widths of the cells' W (module doc), for
    Jacobians ``jac`` (N, M, M), ``rate`` (N, M, A) and cell half-widths ``half`` (N, A); inf where J is
    singular (the cell then fails)."""
    out = np.full(jac.shape[:2], np.inf)
    ok = np.isfinite(jac).all(axis=(1, 2)) & (np.abs(np.linalg.det(jac)) > 0)
    if ok.any():
        lin = np.linalg.solve(jac[ok], rate[ok])
        reach = np.einsum("nij,nj->ni", np.abs(lin), half[ok])
        out[ok] = W_FACTOR * reach + W_EVEN * reach.max(axis=1, keepdims=True) + MARGIN
    return out


# ---------------------------------------------------------------- one candidate box


@dataclass
class _Cells:
    """The cells of a candidate box (arrays over cells): inputs [lo, hi] (C, A), the state at the
    centre, the chart and W (lo, hi) of the unknowns."""

    lo: np.ndarray
    hi: np.ndarray
    states: np.ndarray
    charts: np.ndarray
    w_lo: np.ndarray
    w_hi: np.ndarray


def _edges(lo: float, h: float, hi: float) -> np.ndarray:
    """The first cells' edges along one input (radians): home ``h`` and its multiples of FIRST_CELL
    away, out to ``lo`` and ``hi``. Anchored at home, not at the box's ends, so that a box grown at one
    face has the same cells as before everywhere but next to that face: what was proven stays proven
    (and a failure of the grown box is where it grew)."""
    def out(room):
        n = math.ceil(room / FIRST_CELL - 1e-9) if room > 0 else 0
        steps = FIRST_CELL * np.arange(max(n, 1 if room > 0 else 0) + 1)
        steps[-1] = room
        return steps
    edges = np.concatenate([(h - out(h - lo))[::-1], (h + out(hi - h))[1:]])
    edges[0], edges[-1] = lo, hi                  # the box's own floats (h - (h - lo) may round off lo)
    return edges


def _cover(sys, home, start, free, lo, hi, min_cell: float, max_cells: int):
    """(free?, cells, why, where): whether the box [lo, hi] (A,) of inputs is proven free for the
    assembly of ``start`` at ``home`` (module doc); ``free``: indices of the inputs that vary;
    ``why``/``where``: the reason and the failed cell's centre when not."""
    edges = [_edges(lo[a], home[a], hi[a]) for a in free]
    n_axis = [len(e) - 1 for e in edges]
    grid = np.array(list(product(*[range(n) for n in n_axis])), dtype=int).reshape(-1, len(free))
    c_lo = np.tile(lo, (len(grid), 1))
    c_hi = np.tile(hi, (len(grid), 1))
    for k, a in enumerate(free):
        c_lo[:, a], c_hi[:, a] = edges[k][grid[:, k]], edges[k][grid[:, k] + 1]
    centres = 0.5 * (c_lo + c_hi)
    # Newton's roots at the cells' centres, layer by layer from the cell holding home (each from a
    # neighbour one step nearer home)
    h = np.array([min(int(np.searchsorted(e, home[a], side="right")) - 1, n - 1)
                  for e, a, n in zip(edges, free, n_axis)])
    order = np.abs(grid - h).sum(axis=1)
    flat = np.ravel_multi_index(grid.T, n_axis) if len(free) else np.zeros(1, dtype=int)
    where = np.empty(int(np.prod(n_axis)), dtype=int)
    where[flat] = np.arange(len(grid))
    # each cell's source: its own root where Newton found one, else its parent's source (a known root)
    states = np.empty((len(grid),) + start.shape)
    found = np.zeros(len(grid), dtype=bool)
    src, src_x = np.empty_like(states), np.empty_like(centres)
    first = np.flatnonzero(order == 0)
    src[first], src_x[first] = start, home
    for layer in range(int(order.max(initial=0)) + 1):
        idx = np.flatnonzero(order == layer)
        if layer:
            toward = grid[idx].copy()
            axis = np.argmax(toward != h, axis=1)                           # one step back toward home's cell
            rows = np.arange(len(idx))
            toward[rows, axis] -= np.sign(toward[rows, axis] - h[axis])
            parent = where[np.ravel_multi_index(toward.T, n_axis)]
            src[idx], src_x[idx] = src[parent], src_x[parent]
        states[idx], found[idx] = sys.continued(src[idx], src_x[idx], centres[idx])
        src[idx[found[idx]]], src_x[idx[found[idx]]] = states[idx[found[idx]]], centres[idx[found[idx]]]
    cells = []                                                             # proven _Cells batches
    todo = (c_lo, c_hi, states, found, src, src_x)
    total = len(c_lo)
    while len(todo[0]):
        t_lo, t_hi, t_states, t_found, t_src, t_src_x = todo
        ok = t_found.copy()
        charts, w_lo, w_hi = sys.chart(t_states[ok], t_lo[ok], t_hi[ok])
        if ok.any():
            ok[ok] = sys.prove(charts, w_lo, w_hi, t_lo[ok], t_hi[ok])
        keep = ok[t_found]
        cells.append(_Cells(t_lo[ok], t_hi[ok], t_states[ok], charts[keep], w_lo[keep], w_hi[keep]))
        bad = np.flatnonzero(~ok)
        if not len(bad):
            break
        width = (t_hi[bad][:, free] - t_lo[bad][:, free]).max(axis=1)
        small = width <= min_cell
        if small.any():
            k = bad[np.flatnonzero(small)[0]]
            return False, total, "unproven", 0.5 * (t_lo[k] + t_hi[k])
        total += len(bad) * 2 ** len(free)
        if total > max_cells:
            return False, total, "cells", 0.5 * (t_lo[bad[0]] + t_hi[bad[0]])
        # halve every failed cell along every free input; each half's root continued from the cell's source
        halves_lo, halves_hi = [], []
        for corner in product((0, 1), repeat=len(free)):
            n_lo, n_hi = t_lo[bad].copy(), t_hi[bad].copy()
            for k, a in enumerate(free):
                mid = 0.5 * (t_lo[bad, a] + t_hi[bad, a])
                if corner[k]:
                    n_lo[:, a] = mid
                else:
                    n_hi[:, a] = mid
            halves_lo.append(n_lo)
            halves_hi.append(n_hi)
        parents = np.tile(bad, 2 ** len(free))
        n_lo, n_hi = np.concatenate(halves_lo), np.concatenate(halves_hi)
        n_src, n_src_x = t_src[parents], t_src_x[parents]
        n_states, n_found = sys.continued(n_src, n_src_x, 0.5 * (n_lo + n_hi))
        n_src[n_found], n_src_x[n_found] = n_states[n_found], 0.5 * (n_lo + n_hi)[n_found]
        todo = (n_lo, n_hi, n_states, n_found, n_src, n_src_x)
    c = _Cells(*(np.concatenate([getattr(b, f) for b in cells]) for f in ("lo", "hi", "states", "charts", "w_lo",
                                                                          "w_hi")))
    tied = _tie(sys, c, home, start, free)
    if not tied.all():
        k = int(np.flatnonzero(~tied)[0])
        return False, len(c.lo), "link", 0.5 * (c.lo[k] + c.hi[k])
    return True, len(c.lo), None, None


def _inside(sys, states, c: _Cells, idx) -> np.ndarray:
    """Whether the point boxes (radius POINT_RADIUS, plus MARGIN for the change of chart) around
    ``states`` lie in the interior of the W of cells ``idx``."""
    w = sys.coordinates(states, c.charts[idx])
    pad = POINT_RADIUS + MARGIN
    with np.errstate(invalid="ignore"):
        return np.all(w - pad > c.w_lo[idx], axis=1) & np.all(w + pad < c.w_hi[idx], axis=1)


def _tie(sys, c: _Cells, home, start, free) -> np.ndarray:
    """Which cells are tied to the start pose's assembly (module doc): breadth first over cells sharing
    a face, from the cells holding home."""
    n = len(c.lo)
    tied = np.zeros(n, dtype=bool)
    holds = np.flatnonzero(np.all((c.lo <= home) & (home <= c.hi), axis=1))
    if len(holds) and bool(sys.point(start[None], home[None])[0]):
        tied[holds] = _inside(sys, np.broadcast_to(start, (len(holds),) + start.shape), c, holds)
    pairs = _neighbours(c, free)                                             # (P, 2) cells sharing a face
    if not len(pairs):
        return tied
    pairs = np.concatenate([pairs, pairs[:, ::-1]])
    tried = np.zeros(len(pairs), dtype=bool)
    while True:
        cand = np.flatnonzero(tied[pairs[:, 0]] & ~tied[pairs[:, 1]] & ~tried)
        if not len(cand):
            return tied
        tried[cand] = True
        p, q = pairs[cand, 0], pairs[cand, 1]
        face = 0.5 * (np.maximum(c.lo[p], c.lo[q]) + np.minimum(c.hi[p], c.hi[q]))    # the shared face's centre
        states, ok = sys.continued(c.states[p], 0.5 * (c.lo[p] + c.hi[p]), face)
        if ok.any():
            ok[ok] = sys.point(states[ok], face[ok])
        ok &= _inside(sys, states, c, p) & _inside(sys, states, c, q)
        tied[q[ok]] = True


def _neighbours(c: _Cells, free) -> np.ndarray:
    """Pairs (i, j) of cells whose faces overlap: hi_a(i) == lo_a(j) along one free input a (the cells'
    edges are the same floats, halvings of shared edges) and their other free intervals overlap."""
    out = []
    for a in free:
        others = [b for b in free if b != a]
        ends = {}
        for j, v in enumerate(c.lo[:, a]):
            ends.setdefault(float(v), []).append(j)
        for i, v in enumerate(c.hi[:, a]):
            js = ends.get(float(v))
            if not js:
                continue
            js = np.array(js)
            ov = np.ones(len(js), dtype=bool)
            for b in others:
                ov &= (np.maximum(c.lo[i, b], c.lo[js, b]) < np.minimum(c.hi[i, b], c.hi[js, b]))
            out.extend((i, int(j)) for j in js[ov])
    return np.array(out, dtype=int).reshape(-1, 2)


# ---------------------------------------------------------------- the growth


def checked_home(mechanism, home) -> np.ndarray:
    """``home`` as an array (A,) of one input per actuated joint (radians), checked as a solve checks
    inputs (finite, within a turn of 0, inside the joint ranges); else ValueError naming "home"."""
    names = tuple(mechanism.actuated)
    try:
        arr = np.asarray(home, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.shape != (len(names),):
        raise ValueError(f"home: expected {len(names)} inputs ({', '.join(names)}; radians), got {home!r}")
    return mechanism.check_input_rows(arr[None], "home")[0]


def free_box(mechanism, home, start, inputs=None, *, shape: str = "box", max_radius: float = MAX_RADIUS,
             min_cell: float = MIN_CELL, max_cells: int = MAX_CELLS, bounds=None) -> FreeBox:
    """The largest box of the inputs named in ``inputs`` (the others fixed at home; None: all) around
    ``home`` proven to hold the assembly of ``start`` without a parallel singularity (module doc).

    ``shape`` (SHAPES): "cube", home +- r with one r for every free input, r grown and bisected
    (BISECTIONS); "box" (default), that cube and then its faces pushed out: the free faces grow
    together until a box fails, the bracket is bisected (FACE_BISECTIONS), and the face nearest the
    failed cell is held there; the others go on, until every face is held (each face's reason in
    :attr:`FreeBox.faces`). Every face stays inside its input's joint range ("range") and within
    ``max_radius`` of home, and inside ``bounds`` (input name -> (lo, hi) radians, e.g. the plane a
    singular set was computed over: limit "bounds"; home must lie in them). Every box tried is proven
    whole, not the added slab alone.

    ``mechanism``: any; on the platform's orientation where the platform tracker applies
    (:func:`~spherekin.trust.continuation.not_tracked` is None: ``start`` is the platform rotation R
    (3, 3) of an assembly at home), else on the loop equations (``start``: the passive angles,
    name -> radians or a sequence in ``mechanism.loop_unknowns`` order). ``home``: one input per
    actuated joint (radians). ``max_radius``: the farthest a face goes (radians, at most MAX_RADIUS:
    "is home +- 0.2 free?"); ``min_cell``, ``max_cells``: the caps of the cells (MIN_CELL, MAX_CELLS).
    ValueError before any proof for a bad home, start, input name, shape or cap, or a start pose that
    is not a proven isolated root at home."""
    t0 = time.perf_counter()
    names = tuple(mechanism.actuated)
    home = checked_home(mechanism, home)
    if inputs is None:
        inputs = names
    if isinstance(inputs, str):
        inputs = (inputs,)
    unknown = [n for n in inputs if n not in names]
    if unknown or not inputs or len(set(inputs)) != len(tuple(inputs)):
        raise ValueError(f"inputs: expected distinct actuated joint names among {list(names)}, got {list(inputs)}")
    free = [names.index(n) for n in inputs]
    if shape not in SHAPES:
        raise ValueError(f"shape: expected one of {list(SHAPES)}, got {shape!r}")
    if not 0 < max_radius <= MAX_RADIUS:
        raise ValueError(f"max_radius: expected 0 < R <= {MAX_RADIUS:g} (radians), got {max_radius!r}")
    if not 0 < min_cell <= FIRST_CELL:
        raise ValueError(f"min_cell: expected 0 < W <= {FIRST_CELL:g} (radians), got {min_cell!r}")
    if int(max_cells) != max_cells or max_cells < 1:
        raise ValueError(f"max_cells: expected a positive integer, got {max_cells!r}")
    for name, (lo, hi) in (bounds or {}).items():
        if name not in names or not lo <= home[names.index(name)] <= hi:
            raise ValueError(f"bounds: expected (lo, hi) around home for actuated joints, got {name}: ({lo}, {hi})")
    sys = _Platform(mechanism, start) if not_tracked(mechanism) is None else _Loops(mechanism, start, home)
    state = sys.start_state(home)
    state, ok = sys.continued(state[None], home[None], home[None])
    if not ok[0] or not sys.point(state, home[None])[0]:
        raise ValueError("start: the start pose could not be proven an isolated assembly at home (it is at or next "
                         "to a parallel singularity)")
    state = state[0]
    # the room of each face (F, 2: lo side, hi side): the joint range, the bounds, then max_radius
    room = np.array([room_in_range(home[a], mechanism.joint(names[a]).range) for a in free], dtype=float)
    cap_limit = np.where(room < max_radius, "range", "radius").astype(object)
    for k, a in enumerate(free):
        if bounds is not None and names[a] in bounds:
            lo, hi = (float(v) for v in bounds[names[a]])
            within = np.array([home[a] - lo, hi - home[a]])
            tighter = within < np.minimum(room[k], max_radius)
            room[k] = np.where(tighter, within, room[k])
            cap_limit[k] = np.where(tighter, "bounds", cap_limit[k])
    cap = np.minimum(room, max_radius)

    def box(ext):
        lo, hi = home.copy(), home.copy()
        lo[free] -= ext[:, 0]
        hi[free] += ext[:, 1]
        return lo, hi

    def attempt(ext):
        return _cover(sys, home, state, free, *box(ext), min_cell, int(max_cells))

    def named(where):
        return None if where is None else dict(zip(names, map(float, where)))

    # the cube: one radius for every face (capped per face by its room)
    top = float(cap.max())
    good, good_cells = 0.0, 0
    r, bad, failure = min(FIRST_RADIUS, top), None, None
    while r > 0:
        ok, cells, why, where = attempt(np.minimum(r, cap))
        if not ok:
            bad, failure = r, (why, where)
            break
        good, good_cells = r, cells
        if r >= top:
            break
        r = min(top, r * GROWTH)
    if bad is not None:
        for _ in range(BISECTIONS):
            r = 0.5 * (good + bad)
            ok, cells, why, where = attempt(np.minimum(r, cap))
            if ok:
                good, good_cells = r, cells
            else:
                bad, failure = r, (why, where)
    if failure is None:
        capped_by = set(cap_limit.ravel()) - {"radius"}
        failure = (capped_by.pop() if len(capped_by) == 1 and (cap_limit != "radius").all() else "radius", None)
    ext = np.minimum(good, cap)
    # the faces: held where capped; the one nearest the cube's failure held at the cube
    held = {(k, s): (str(cap_limit[k, s]), None) for k in range(len(free)) for s in (0, 1) if ext[k, s] >= cap[k, s]}

    def nearest(failed_ext, where, open_faces):
        lo, hi = box(failed_ext)
        gap = [(where[free[k]] - lo[free[k]]) if s == 0 else (hi[free[k]] - where[free[k]]) for k, s in open_faces]
        return open_faces[int(np.argmin(gap))]

    open_faces = [(k, s) for k in range(len(free)) for s in (0, 1) if (k, s) not in held]
    if shape == "cube" or good == 0:
        for face in open_faces:
            held[face] = failure
        open_faces = []
    elif bad is not None:
        face = nearest(np.minimum(bad, cap), failure[1], open_faces)
        held[face] = failure
        open_faces.remove(face)
    while open_faces:
        rows, cols = np.array([k for k, _ in open_faces]), np.array([s for _, s in open_faces])

        def grown(t):
            out = ext.copy()
            out[rows, cols] = np.minimum(ext[rows, cols] * t, cap[rows, cols])
            return out

        lo_t, hi_t, last = 1.0, None, None
        t = GROWTH
        while True:
            ok, cells, why, where = attempt(grown(t))
            if not ok:
                hi_t, last = t, (why, where)
                break
            lo_t, good_cells = t, cells
            if np.all(grown(t)[rows, cols] >= cap[rows, cols]):
                break
            t *= GROWTH
        if hi_t is not None:
            for _ in range(FACE_BISECTIONS):
                t = 0.5 * (lo_t + hi_t)
                ok, cells, why, where = attempt(grown(t))
                if ok:
                    lo_t, good_cells = t, cells
                else:
                    hi_t, last = t, (why, where)
        ext = grown(lo_t)
        for face in list(open_faces):
            if ext[face] >= cap[face]:
                held[face] = (str(cap_limit[face]), None)
                open_faces.remove(face)
        if last is not None and open_faces:
            face = nearest(grown(hi_t), last[1], open_faces)
            held[face] = last
            open_faces.remove(face)
    lo, hi = box(ext)
    faces = tuple(Face(names[free[k]], ("lo", "hi")[s], float(ext[k, s]), held[(k, s)][0], named(held[(k, s)][1]))
                  for k in range(len(free)) for s in (0, 1))
    why, where = failure
    return FreeBox(names, tuple(map(float, lo)), tuple(map(float, hi)), tuple(inputs), tuple(map(float, home)),
                   sys.pose(state), good_cells, good > 0, float(good), why, named(where), faces, shape,
                   time.perf_counter() - t0)
