"""The loop system's chart sets for many inputs as one array program, compiled once.

Why it works: an actuated joint's reading phi_a enters the closure equations (Eq. 2) only as the known
factor Rx(o + s phi_a) Z of each loop it lies in, whose entries are 1, cos(o + s phi_a) and
sin(o + s phi_a), linear combinations of (1, cos phi_a, sin phi_a); the control points of every
parameterization and formulation are multilinear in the factors' entries (products of factor
matrices, q_b (q_a P) - q_a (q_b S)^T, ...), so every per-chart array of a :class:`ChartSet` built
from the loops -- ``coeffs[b]`` and the bilinear halves ``bilinear[b].a``, ``.b`` -- is, exactly, a
multilinear function F(w) of the triples w_a = (1, cos phi_a, sin phi_a) of the actuated joints it
depends on (D, those of its block's loop): F(w) = sum_j w_j T_j over the 3^|D| products w_j.
The maps (``map_lo``, ``map_hi``, ``shift``), labels and layout depend on the ranges only.

Compiling (:class:`LoopCharts`, once per mechanism, strategy and ranges) builds the chart set directly
(:func:`spherekin.search.parameterizations.make_charts`) at the 3^A inputs of a tensor grid of nodes
(3 readings per actuated joint, :func:`interpolation_nodes`), finds which joints each array depends
on (its builds are bitwise equal along the axes of the others: each block is built from one loop
alone, by the same float operations whatever the other loops' inputs; and an array of a loop does
depend on each of its actuated joints, its corner control points being values of products of
invertible matrices, so the check that every block depends on exactly the actuated joints of one
loop, or none, is a guard against a build that breaks this), and extracts the tensors T_j by inverting the 3 x 3 node matrices V_a (rows (1, cos nu, sin
nu)) along the dependent axes. For K input rows the arrays are then one matrix product per array with
the (K, 3^|D|) weights, and the chart sets of the K inputs come out stacked input-major (chart c of
input k at index k C + c). Compiling then checks the reconstruction on RECON_CHECK_INPUTS seeded inputs
against the direct build (relative RECON_CHECK_RTOL, every array and map); when a parameterization or
formulation fails the check (an array not multilinear in the weights, a bilinear block whose halves
share an actuated joint, a layout that depends on the inputs) the whole chart set falls back to the
direct build per input, stacked (:func:`spherekin.search.parameterizations.stack_chart_sets`), and
``fallback`` says why. The direct path stays the slow, obviously correct reference.

Tolerances (this project never loses a root). Per block b, chart c and equation e (all bounds below
are per (c, e); a half's per (row, c)), with D the block's actuated joints, J = 3^|D|, eps the unit
roundoff's double (float eps):

* F: the exact arrays at the float inputs, as a multilinear function of the weights w (exact
  tensors T*_j); d_i: the direct build at node i, with its own bound |d_i - F(nu_i)| <= t_i (its
  ``tols``, ROUNDING_SAFETY eps scale_i); t = max_i t_i; Dmax = max_i max |d_i|.
* F^: the reconstruction, T = fl(P d) with P = fl(V^-1) along each axis of D (V_a: rows (1, cos nu,
  sin nu) of the float nodes); A = sum_j max |T_j| (>= |F^(w)| for |w| <= 1).
* F^ - F is multilinear, hence its own interpolant on the node grid:
  |F^(w) - F(w)| <= lambda(w) max_i |F^(nu~_i) - F(nu~_i)|, with the Lebesgue function
  lambda(w) = prod_{a in D} ||w_a V_a^-1||_1 <= prod (fl(||w_a P_a||_1) (1 + 8 eps) + 8 eps sum |P_a|)
  / (1 - rho_a) (rho_a: the defect ||V_a P_a - I||, computed exactly in fractions; the eps terms: the
  float evaluation); <= (5/3)^|D| for full-circle nodes.
* At a node: |F^(nu~_i) - F(nu~_i)| <= t + R + |D| TRIG_ERROR X, where R = (rho + (1 + sqrt 2)^|D|
  (3 |D| + 1) eps prod ||P_a||_inf) Dmax bounds the extraction's residual (its rounding, carried back
  through V, whose infinity norm is <= 1 + sqrt 2) and X = prod ||P_a||_1 (Dmax + t) >= sum_j |T*_j|
  bounds the effect of the float node weights (cos, sin off by <= TRIG_ERROR). For a bilinear block,
  R is also >= sum_t |coef_t| (R_a D_b + D_a R_b + R_a R_b + ASSEMBLY_ROUNDING eps D_a D_b) over its
  terms (the halves' rows' Dmax and R; the last term: exact vs float assembly of the node halves).
* At an input: the float weights w~ cost <= |D| TRIG_ERROR X, and evaluating sum_j w~_j T_j (the
  weights' products and the sum) rounds by <= gamma_{J + |D|} A per half, 2 (J + |D|) eps A for the
  two halves of a bilinear block.
* The box loop then restricts (and assembles) the reconstructed arrays, rounding by at most
  ROUNDING_SAFETY eps A (the direct build's budget, with A for the largest value the arrays take).

So each block's tolerance at input k is alpha + lambda(w~_k) beta, with

    alpha = (ROUNDING_SAFETY + 2 (J + |D|)) eps A + |D| TRIG_ERROR X,    beta = t + R + |D| TRIG_ERROR X,

every computed bound (and the tolerance itself, for its own products and sum) inflated by INFLATION. Measured: 1.7-3.7x the direct build's tolerances
(tests/test_loop_charts.py), never below what the reconstruction's rounding can do. A block that
depends on no actuated joint is the node build itself (its arrays and tolerances copied exactly).
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from ..search.formulations import ChartBilinear
from ..search.parameterizations import ROUNDING_SAFETY, ChartSet, make_charts, stack_chart_sets

__all__ = ["LoopCharts", "interpolation_nodes", "RECON_CHECK_INPUTS", "RECON_CHECK_RTOL", "TRIG_ERROR", "INFLATION", "ASSEMBLY_ROUNDING",
           "NODE_SPREAD", "MAX_NODE_LEBESGUE"]

#: Seeded inputs on which compiling compares the reconstruction with the direct build: a few catch
#: a non-multilinear array (any such array differs at almost every input), each costs one direct build.
RECON_CHECK_INPUTS = 3
#: Largest difference (relative to the array's largest |entry| over the block) the check accepts
#: between reconstructed and direct arrays: both are within ~1e-13 of the exact ones (their
#: tolerances); a non-multilinear array misses by far more (O(1)).
RECON_CHECK_RTOL = 1e-12
#: Bound on the error of a float cos or sin of a float (values in [-1, 1]): numpy's are within one
#: ulp (<= eps / 2 there); doubled.
TRIG_ERROR = float(np.finfo(float).eps)
#: Relative inflation of every computed bound: covers the rounding of computing the bounds themselves
#: (a few operations, ~1e-15) and the difference between the float node weights' inverse and the
#: exact nodes' (eps times ||P|| <= MAX_NODE_LEBESGUE: < 1e-12).
INFLATION = 1e-12
#: Rounding of the exact vs float assembly of a bilinear equation (<= 3 products and sums a term):
#: gamma_3 <= 3.01 eps, rounded up.
ASSEMBLY_ROUNDING = 4.0
#: The nodes of an unlimited actuated joint: three readings 2 pi / 3 apart (the best conditioned
#: choice: node matrix inverse of infinity norm 4/3, Lebesgue constant 5/3). A limited range gets
#: its midpoint and the midpoint +- NODE_SPREAD of its half-width (capped at 2 pi / 3), inside the range.
NODE_SPREAD = 0.9
#: Nodes whose Lebesgue function at the ends of the joint range, or whose inverse node matrix's 1- or
#: infinity norm, exceeds this are refused (the chart set falls back to the direct build): a narrow
#: actuated range makes the extraction ill-conditioned and the tolerances wide (a range of 0.1 rad
#: already gives ~1e3); INFLATION relies on the cap.
MAX_NODE_LEBESGUE = 1e3
_EPS = float(np.finfo(float).eps)
_V_NORM = 1.0 + math.sqrt(2.0)   # >= ||(1, cos, sin)||_1: the infinity norm of a node matrix


def interpolation_nodes(rng) -> tuple[float, float, float]:
    """The three readings (radians) at which an actuated joint of range ``rng`` ((lo, hi) or None) is built."""
    if rng is None:
        return (0.0, 2 * math.pi / 3, -2 * math.pi / 3)
    lo, hi = float(rng[0]), float(rng[1])
    mid, h = 0.5 * (lo + hi), min(2 * math.pi / 3, NODE_SPREAD * 0.5 * (hi - lo))
    return (mid, mid + h, mid - h)


def _node_matrix(nodes) -> np.ndarray:
    """V (3, 3): row i = (1, cos nu_i, sin nu_i) in float."""
    nu = np.asarray(nodes, dtype=float)
    return np.stack([np.ones(3), np.cos(nu), np.sin(nu)], axis=1)


def _inverse_defect(v: np.ndarray, p: np.ndarray) -> float:
    """max(||V P - I||_inf, ||V P - I||_1, ||P V - I||_inf, ||P V - I||_1), exactly (fractions of the floats).
    ``fractions`` is imported here, at a compile that needs it, not with the module: a default solve
    does not import it."""
    from fractions import Fraction

    vf = [[Fraction(float(x)) for x in row] for row in v]
    pf = [[Fraction(float(x)) for x in row] for row in p]
    out = 0.0
    for a, b in ((vf, pf), (pf, vf)):
        r = [[sum(a[i][k] * b[k][j] for k in range(3)) - (1 if i == j else 0) for j in range(3)] for i in range(3)]
        rows = max(sum(abs(x) for x in row) for row in r)
        cols = max(sum(abs(r[i][j]) for i in range(3)) for j in range(3))
        out = max(out, float(max(rows, cols)) * (1 + 4 * _EPS))
    return out


def _triples(rows: np.ndarray) -> np.ndarray:
    """(K, A, 3): (1, cos phi, sin phi) of every input reading (radians)."""
    return np.stack([np.ones_like(rows), np.cos(rows), np.sin(rows)], axis=-1)


def _weights(trip: np.ndarray, axes: tuple) -> np.ndarray:
    """(K, 3^|axes|): the products of the triples of the joints ``axes``, the first axis slowest."""
    w = np.ones((trip.shape[0], 1))
    for a in axes:
        w = (w[:, :, None] * trip[:, a, None, :]).reshape(trip.shape[0], -1)
    return w


class _Array:
    """One per-chart array reconstructed from its tensors: ``tensors`` (J, *shape) over the joints
    ``axes`` (J = 3^len(axes)); ``chart_axis``: the axis of ``shape`` that is the chart axis."""

    __slots__ = ("axes", "tensors", "shape", "chart_axis")

    def __init__(self, axes, tensors, shape, chart_axis):
        self.axes, self.tensors, self.shape, self.chart_axis = axes, tensors, shape, chart_axis

    def at(self, weights: dict) -> np.ndarray:
        """The array at K inputs, stacked input-major along its chart axis (computed once per call:
        ``weights`` also holds the arrays already made, by id)."""
        if id(self) in weights:
            return weights[id(self)]
        weights[id(self)] = out = self._at(weights)
        return out

    def _at(self, weights: dict) -> np.ndarray:
        w = weights[self.axes]
        k, c = w.shape[0], self.shape[self.chart_axis]
        # einsum, not a BLAS product: a (K, J) x (J, M) product with J <= 27 gains nothing from BLAS
        # and its threads cost ~100x on a busy machine (measured: 32 ms vs 0.4 ms at K = 256)
        # and the terms are summed one by one in a fixed order (not einsum, whose order depends on
        # the array sizes), so that an input's chart set has the same bits in any chunk
        if self.axes:
            tensors = self.tensors.reshape(self.tensors.shape[0], -1)
            flat = w[:, :1] * tensors[0]
            for j in range(1, tensors.shape[0]):
                flat += w[:, j:j + 1] * tensors[j]
        else:
            flat = np.broadcast_to(self.tensors.reshape(1, -1), (k, self.tensors[0].size))
        out = flat.reshape((k,) + self.shape)
        if self.chart_axis == 0:
            return np.ascontiguousarray(out).reshape((k * c,) + self.shape[1:])
        out = np.moveaxis(out, 0, -2)          # chart axis last: (..., K, C)
        return np.ascontiguousarray(out).reshape(self.shape[:-1] + (k * c,))


class _Block:
    """Block b: its arrays and its tolerance alpha + lambda_D(w) beta ((C, E) each; module docstring)."""

    __slots__ = ("axes", "coeffs", "a", "b", "alpha", "beta")

    def __init__(self, axes, coeffs, a, b, alpha, beta):
        self.axes, self.coeffs, self.a, self.b, self.alpha, self.beta = axes, coeffs, a, b, alpha, beta


class LoopCharts:
    """The chart sets of one loop system at any inputs over fixed ``ranges``, compiled once.

    ``build_at(inputs)`` is the direct build's loop builder at actuator ``inputs`` (radians, one per
    actuated joint); ``actuated_ranges``: each actuated joint's range (or None); ``ranges``: the
    unknowns' ranges (name -> (lo, hi) radians or None); ``parameterization``, ``formulation``:
    names. ``fallback`` is None, or why this chart set is built directly per input (module
    docstring). :meth:`charts` gives the stacked chart set of K input rows.
    """

    def __init__(self, build_at, actuated_ranges, ranges: Mapping, parameterization: str, formulation: str,
                 seed: int = 0, loop_joints=None):
        self.build_at = build_at
        #: per loop, the indices of the actuated joints in it (or None: not checked)
        self.loop_joints = None if loop_joints is None else {tuple(sorted(j)) for j in loop_joints}
        self.parameterization = parameterization
        self.formulation = formulation
        self.ranges = dict(ranges)
        self.n_inputs = len(actuated_ranges)
        self.nodes = [interpolation_nodes(r) for r in actuated_ranges]
        self.fallback: str | None = None
        self.template: ChartSet | None = None
        self.blocks: list[_Block] = []
        self._prepare(actuated_ranges, seed)

    # ------------------------------------------------------------------ direct path (the reference)

    def direct(self, row) -> ChartSet:
        """The chart set of one input row by the direct build (:func:`make_charts`)."""
        return make_charts(self.parameterization, self.build_at(tuple(float(x) for x in row)), self.ranges,
                           self.formulation)

    # ------------------------------------------------------------------ compile

    def _prepare(self, actuated_ranges, seed: int) -> None:
        n = self.n_inputs
        self._p, self._slack, self._rho, self._lam_abs = [], [], [], []
        for a, nodes in enumerate(self.nodes):
            v = _node_matrix(nodes)
            p = np.linalg.inv(v)
            rho = _inverse_defect(v, p)
            if rho >= 0.5:
                self.fallback = f"the interpolation nodes of actuated joint {a} are singular"
                return
            self._p.append(p)
            self._rho.append(rho)
            # lambda computed with P in float: ||w V^-1||_1 <= ||w P||_1 ||(V P)^-1||_1 <= ||w P||_1 / (1 - rho),
            # and the float evaluation of ||w P||_1 (per entry 3 products and 2 sums, then |.| and a sum
            # of 3) errs by <= gamma_5 sum_il |w_l P_li| + gamma_2 ||w P||_1 <= 8 eps (sum |P| + ||w P||_1)
            self._slack.append(1 / (1 - rho))
            self._lam_abs.append(8 * _EPS * float(np.abs(p).sum()))
        for a, rng in enumerate(actuated_ranges):
            if rng is not None:
                ends = np.array([[float(rng[0]), float(rng[1])]]).T
                lam = np.abs(_triples(ends)[:, 0, :] @ self._p[a]).sum(axis=1).max()
                lam = max(lam, np.abs(self._p[a]).sum(axis=0).max(), np.abs(self._p[a]).sum(axis=1).max())
                if lam > MAX_NODE_LEBESGUE:
                    self.fallback = (f"actuated joint {a}'s range is too narrow to interpolate in "
                                     f"(Lebesgue constant {lam:.3g} > {MAX_NODE_LEBESGUE:g})")
                    return
        grid = list(np.ndindex(*(3,) * n))
        sets = [self.direct([self.nodes[a][i[a]] for a in range(n)]) for i in grid]
        try:
            stack_chart_sets(sets)          # one layout at every node
        except ValueError as exc:
            self.fallback = f"the chart layout depends on the inputs ({exc})"
            return
        first = sets[0]
        for s in sets[1:]:
            if not all(np.array_equal(getattr(s, m), getattr(first, m)) for m in ("map_lo", "map_hi", "shift")):
                self.fallback = "the chart maps depend on the inputs"
                return
        self.template = first
        C = first.n_charts
        for b in range(len(first.coeffs)):
            coeffs = self._extract([s.coeffs[b] for s in sets], 0)
            bil = first.bilinear[b] if first.bilinear is not None else None
            a = bb = None
            axes = set(coeffs.axes)
            if bil is not None:
                a = self._extract([s.bilinear[b].a for s in sets], -1)
                bb = self._extract([s.bilinear[b].b for s in sets], -1)
                if set(a.axes) & set(bb.axes):
                    self.fallback = f"block {b}'s bilinear halves share an actuated joint (not multilinear)"
                    return
                axes |= set(a.axes) | set(bb.axes)
            axes = tuple(sorted(axes))
            if axes and self.loop_joints is not None and axes not in self.loop_joints:
                # each block comes from one loop, and depends on every actuated joint of it
                self.fallback = (f"block {b} depends on the actuated joints {axes}, not on those of one loop "
                                 f"{sorted(self.loop_joints)}")
                return
            tols = np.stack([s.tols[b] for s in sets])                      # (G, C, E)
            if not axes:   # the node build itself, tolerances included
                self.blocks.append(_Block((), coeffs, a, bb, first.tols[b], np.zeros_like(first.tols[b])))
                continue
            t = tols.max(axis=0)                                            # (C, E)
            big_a, dmax, res = (x.T for x in self._magnitudes(coeffs, [s.coeffs[b] for s in sets], 0))
            if bil is not None:
                aa, ad, ar = self._magnitudes(a, [s.bilinear[b].a for s in sets], -1)
                ba, bd, br = self._magnitudes(bb, [s.bilinear[b].b for s in sets], -1)
                bil_a, bil_r = np.zeros(big_a.shape), np.zeros(big_a.shape)
                for e, terms in enumerate(bil.sums):
                    for u, v, coef in terms:
                        bil_a[:, e] += abs(coef) * aa[u] * ba[v]
                        bil_r[:, e] += abs(coef) * (ar[u] * bd[v] + ad[u] * br[v] + ar[u] * br[v]
                                                    + ASSEMBLY_ROUNDING * _EPS * ad[u] * bd[v])
                big_a, res = np.maximum(big_a, bil_a), np.maximum(res, bil_r)
            d, j = len(axes), 3 ** len(axes)
            exact = math.prod(np.abs(self._p[x]).sum(axis=0).max() * self._slack[x] for x in axes) \
                * (dmax + t) * (1 + INFLATION)                              # >= sum_j |T_j exact|
            alpha = (ROUNDING_SAFETY * (1 + INFLATION) + 2 * (1 + INFLATION) * (j + d)) * _EPS * big_a \
                + d * TRIG_ERROR * exact
            beta = t + d * TRIG_ERROR * exact + res
            # every array of the block on the block's joints (an array constant along some of them
            # gets zero tensors there), so that one weight matrix serves the block
            coeffs = self._widen(coeffs, axes)
            if bil is not None:
                a, bb = self._shared(self._widen(a, axes)), self._shared(self._widen(bb, axes))
            self.blocks.append(_Block(axes, coeffs, a, bb, alpha, beta))
        assert all(blk.coeffs.shape[0] == C for blk in self.blocks)
        self._check(seed)

    def _shared(self, arr: _Array) -> _Array:
        """An earlier block's equal half (same joints, bitwise equal tensors) instead of ``arr``: the
        blocks of one loop share its halves (halves and transversal blocks), reconstructed once a call."""
        for blk in self.blocks:
            for other in (blk.a, blk.b):
                if (other is not None and other.axes == arr.axes and other.chart_axis == arr.chart_axis
                        and other.tensors.shape == arr.tensors.shape and np.array_equal(other.tensors, arr.tensors)):
                    return other
        return arr

    def _grid(self, arrays) -> np.ndarray:
        return np.stack(arrays).reshape((3,) * self.n_inputs + arrays[0].shape)

    def _extract(self, arrays, chart_axis: int) -> _Array:
        """The tensors of one array from its node builds (G = 3^A of them, grid order)."""
        g = self._grid(arrays)
        n = self.n_inputs
        axes = []
        for a in range(n):
            t = np.moveaxis(g, a, 0)
            if not (np.array_equal(t[0], t[1]) and np.array_equal(t[0], t[2])):
                axes.append(a)
        # independent axes: the (bitwise equal) node 0 slice
        idx = tuple(slice(None) if a in axes else 0 for a in range(n))
        g = g[idx]
        for pos, a in enumerate(axes):
            g = np.moveaxis(np.tensordot(self._p[a], g, axes=([1], [pos])), 0, pos)
        shape = arrays[0].shape
        tensors = np.ascontiguousarray(g.reshape((3 ** len(axes),) + shape))
        return _Array(tuple(axes), tensors, shape, chart_axis % len(shape))

    def _widen(self, arr: _Array, axes: tuple) -> np.ndarray:
        """``arr`` on the joints ``axes`` (a superset of its own): zero tensors where it is constant."""
        if arr.axes == axes:
            return arr
        full = np.zeros((3,) * len(axes) + arr.shape)
        idx = tuple(slice(None) if x in arr.axes else 0 for x in axes)
        full[idx] = arr.tensors.reshape((3,) * len(arr.axes) + arr.shape)
        return _Array(axes, full.reshape((3 ** len(axes),) + arr.shape), arr.shape, arr.chart_axis)

    def _magnitudes(self, arr: _Array, arrays, chart_axis: int):
        """(A, Dmax, R), each (rows, C) (rows: the equations of a dense block, the rows of a half):
        A = sum_j max |T_j| (the largest value the reconstruction takes at |w| <= 1), Dmax = the largest
        |value| at the nodes, R = the bound on |F^(nu~_i) - d_i| (the computed inverse's defect rho and
        the extraction's rounding, 3 |D| + 1 operations per entry, re-multiplied by the node matrices)."""
        def per_row(x, lead):          # max |.| over the control points: (lead..., rows, C)
            x = np.abs(np.moveaxis(x, lead + chart_axis if chart_axis >= 0 else chart_axis, lead + 1))
            return x.reshape(x.shape[:lead + 2] + (-1,)).max(axis=-1)

        big_a = per_row(arr.tensors, 1).sum(axis=0) * (1 + INFLATION)
        dmax = np.max([per_row(x, 0) for x in arrays], axis=0)
        d = len(arr.axes)
        rho = math.prod(1 + self._rho[x] for x in arr.axes) - 1
        pn = math.prod(np.abs(self._p[x]).sum(axis=1).max() for x in arr.axes)
        res = (rho + _V_NORM ** d * (3 * d + 1) * (1 + INFLATION) * _EPS * pn) * dmax
        return big_a, dmax, res

    def _check(self, seed: int) -> None:
        """Compare the reconstruction with the direct build on seeded inputs; on a miss, fall back."""
        rng = np.random.default_rng(seed)
        rows = np.array([[rng.uniform(lo, hi) for lo, hi in
                          ((min(nd), max(nd)) for nd in self.nodes)] for _ in range(RECON_CHECK_INPUTS)])
        got = self._reconstruct(rows)
        want = stack_chart_sets([self.direct(r) for r in rows])
        for b in range(len(want.coeffs)):
            pairs = [(got.coeffs[b], want.coeffs[b])]
            if want.bilinear is not None and want.bilinear[b] is not None:
                pairs += [(got.bilinear[b].a, want.bilinear[b].a), (got.bilinear[b].b, want.bilinear[b].b)]
            for x, y in pairs:
                scale = max(float(np.max(np.abs(y))), 1e-300)
                if x.shape != y.shape or float(np.max(np.abs(x - y))) > RECON_CHECK_RTOL * scale:
                    self.fallback = (f"block {b} ({want.labels[b][0]}...) is not multilinear in the actuated "
                                     "joints' (1, cos, sin): reconstruction misses the direct build")
                    return
            err = np.abs(got.coeffs[b] - want.coeffs[b]).reshape(got.tols[b].shape + (-1,)).max(axis=-1)
            if np.any(err > got.tols[b] + want.tols[b]):
                self.fallback = f"block {b}'s reconstruction differs from the direct build by more than both tolerances"
                return

    # ------------------------------------------------------------------ many inputs

    def _reconstruct(self, rows: np.ndarray, dense: bool = True) -> ChartSet:
        t = self.template
        k = rows.shape[0]
        trip = _triples(rows)
        weights, lams = {}, {}
        p = np.stack(self._p)                  # (A, 3, 3); the sum over i term by term (see _at)
        lam_a = trip[:, :, 0, None] * p[None, :, 0, :]
        for i in range(1, p.shape[1]):
            lam_a += trip[:, :, i, None] * p[None, :, i, :]
        lam_a = np.abs(lam_a).sum(axis=2)
        lam_a = (lam_a * (1 + 8 * _EPS) + np.array(self._lam_abs)) * np.array(self._slack)
        coeffs, tols, bilinear = [], [], []
        for blk in self.blocks:
            ax = blk.axes
            if ax not in weights:
                weights[ax] = _weights(trip, ax)
                lams[ax] = np.prod(lam_a[:, list(ax)], axis=1) if ax else np.ones(k)
            if dense or blk.a is None:
                coeffs.append(blk.coeffs.at(weights))
            else:       # a NaN placeholder of the right shape, no memory (see charts)
                shape = blk.coeffs.shape
                coeffs.append(np.broadcast_to(np.nan, (k * shape[0],) + shape[1:]))
            tol = (blk.alpha[None] + lams[ax][:, None, None] * blk.beta[None]) * (1 + INFLATION if ax else 1.0)
            tols.append(tol.reshape((-1,) + blk.alpha.shape[1:]))
        if t.bilinear is not None:
            for blk, f in zip(self.blocks, t.bilinear):
                bilinear.append(None if f is None else
                                ChartBilinear(f.a_vars, f.b_vars, blk.a.at(weights), blk.b.at(weights), f.sums, f.shape))
        tile = (k, 1)
        return ChartSet(t.parameterization, t.unknowns, t.variables, coeffs, tols, t.labels, t.square,
                        np.tile(t.map_lo, tile), np.tile(t.map_hi, tile), np.tile(t.shift, tile), t.accept_width,
                        bilinear if t.bilinear is not None else None, t.prune)

    def charts(self, rows, dense: bool = True) -> ChartSet:
        """The chart sets of the input rows (K, A; radians, checked by the caller) stacked input-major:
        chart c of row k at index k C + c of every per-chart array (C = charts per input).

        ``dense=False``: the dense ``coeffs`` of the blocks that have a bilinear form are read-only NaN
        placeholders of their shape (no memory), for an engine that restricts the halves, as the box
        loop does (on general_3rrr in the loop system they are ~90% of the 350 MB of K = 256 inputs);
        the direct fallback always gives them."""
        rows = np.asarray(rows, dtype=float)
        if self.fallback is not None:
            return stack_chart_sets([self.direct(r) for r in rows])
        return self._reconstruct(rows, dense)
