"""Parameterizations: how an unknown joint angle becomes polynomial variables (Section 2.2 and Section 5).

A parameterization turns the closure loops of a mechanism (``build(chart_ranges) -> (loops,
unknowns)``, see :func:`spherekin.search.boxloop.solve_system`) into a :class:`ChartSet`: the unit boxes
the subdivision searches (one per chart), the Bernstein equation blocks on each of them, and the
maps between unit-box coordinates and joint angles. Chosen by name (:data:`PARAMETERIZATIONS`):

* ``tan-half`` -- the paper's substitution t = tan((theta - shift)/2) (Section 2.2): one variable
  per unknown angle, degree 2 in each, the denominators cleared by q_n = prod (1 + t_k^2). t is
  singular at theta = shift + pi, so a range wider than :data:`CHART_MAX_WIDTH` (a full circle in
  particular) is covered by several charts (:func:`charts_for_range`): 2^n charts for n unknowns
  with full ranges.
* ``sin-cos`` -- the paper's proposal of Section 5: x = sin(theta), y = cos(theta) with
  x^2 + y^2 = 1. Two variables (c, s) per unknown angle over the bounding box of its joint range's
  arc in [-1, 1]^2, one circle equation c^2 + s^2 - 1 = 0 per unknown, and closure entries that
  are multilinear (degree 1 in every variable), so their Bernstein control points are the values
  at the box corners: products of the factor matrices Rx(phi) Z evaluated at the corners. One chart
  covers any range, the full circle included; no singularity at pi.

Both give the same equations to the formulations (:mod:`spherekin.search.formulations`): the control
points of q F_n for each loop (q = q_n for tan-half, q = 1 for sin-cos).
"""

from __future__ import annotations

import itertools
import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar, Mapping, Sequence

import numpy as np

from ..core.angles import wrap
from ..closure import ClosureLoop, Term, Unknown, snapped_cos_sin, tan_half_angle
from .formulations import FORMULATIONS, ChartBilinear, EquationBlock, LoopPolynomials, formulate_polynomials
from .registry import Registry

__all__ = [
    "Parameterization",
    "LoopParameterization",
    "PARAMETERIZATIONS",
    "TanHalf",
    "SinCos",
    "CHART_MAX_WIDTH", "MAX_CHARTS",
    "ROUNDING_SAFETY",
    "ARC_BOX_MARGIN",
    "ChartSet",
    "charts_for_range",
    "arc_box",
    "make_charts",
    "stack_chart_sets",
    "tan_half_loop",
    "sin_cos_loop",
]

#: Joint ranges wider than this (radians) are split into equal tan-half charts of at most this
#: width: on a chart of width pi, |t| <= tan(pi/4) = 1, where the degree-2 Bernstein form is well
#: conditioned; a wider chart pushes |t| towards the singularity at theta = shift + pi.
CHART_MAX_WIDTH = math.pi
#: Most tan-half charts a problem may have (the product of every unknown's charts: 2^n for n
#: full-circle joints). Reason: each chart carries its own equation blocks and is searched from its
#: own root box, so charts cost memory and time before the first box is split; 2^12 holds every
#: mechanism of the examples and benchmarks (64 for a 3-RRR or a six-bar, 512 for nine unknowns)
#: with room to spare, while a 25-joint chain (2^25 charts) grew to 4.3 GB in 40 s with no output
#: (issue 42). Past it: one error before any work (ranges narrower than pi need one chart each, and
#: sin-cos has one chart in all).
MAX_CHARTS = 2 ** 12
#: Rounding errors of control points restricted from the unit box are at most about this many
#: machine epsilons of the equation's magnitude (``EquationBlock.scale``: the size of the terms
#: behind its control points, cos and sin of known angles counted as 1; products of ~2n factors in
#: [0, 1]); the test w = 0 accepts |w| up to it.
ROUNDING_SAFETY = 1e3
#: The sin-cos box of a limited joint range is the bounding box of its arc, widened by this (in
#: c, s units) so that a root at an end of the arc cannot be cut off by the rounding of cos and sin
#: (~1e-16); clipped to [-1, 1], which holds every point of the circle exactly.
ARC_BOX_MARGIN = 1e-12


def charts_for_range(rng: tuple[float, float] | None) -> list[tuple[float, float]]:
    """Tan-half chart ranges (radians) covering a joint range; None means the full circle.

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


def arc_box(rng: tuple[float, float] | None) -> tuple[tuple[float, float], tuple[float, float]]:
    """((c_lo, c_hi), (s_lo, s_hi)): bounding box of {(cos t, sin t) : t in [lo, hi]}; None = circle.

    The extremes are at the ends of the arc and at the multiples of pi/2 inside it; the box is
    widened by ARC_BOX_MARGIN and clipped to [-1, 1].
    """
    if rng is None:
        return (-1.0, 1.0), (-1.0, 1.0)
    lo, hi = float(rng[0]), float(rng[1])
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ValueError(f"range: expected finite lo < hi (radians), got {rng!r}")
    if hi - lo >= 2 * math.pi:
        return (-1.0, 1.0), (-1.0, 1.0)
    cs = [math.cos(lo), math.cos(hi)]
    ss = [math.sin(lo), math.sin(hi)]
    k = math.ceil(lo / (math.pi / 2))
    while k * math.pi / 2 <= hi:
        cs.append(math.cos(k * math.pi / 2) if k % 2 == 0 else 0.0)
        ss.append(math.sin(k * math.pi / 2) if k % 2 else 0.0)
        k += 1

    def clip(v):
        return (max(-1.0, min(v) - ARC_BOX_MARGIN), min(1.0, max(v) + ARC_BOX_MARGIN))

    return clip(cs), clip(ss)


# --------------------------------------------------------------------------------------------
# Loop polynomials in each parameterization
# --------------------------------------------------------------------------------------------

def _split_point(loop: ClosureLoop) -> int | None:
    """Factor index s such that factors[:s] hold the first floor(k/2) of the loop's k unknowns."""
    var_idx = [i for i, f in enumerate(loop.factors) if isinstance(f, Term)]
    if len(var_idx) < 2:
        return None
    return var_idx[len(var_idx) // 2 - 1] + 1


def _half(matrix: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Rows 0..8 the entries of the (q-scaled) half product, row 9 its q: shape (10, *dims)."""
    return np.concatenate([matrix.reshape((9,) + q.shape), np.broadcast_to(q, q.shape)[None]])


def _half_magnitude(bound: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Per row of a half (:func:`_half`): the magnitude bound (10,) of its entries (``bound`` (3, 3),
    row-major) and of its q (the largest |control point|: q is a product without cancellation)."""
    return np.append(np.asarray(bound, dtype=float).reshape(9), float(np.max(np.abs(q))))


def tan_half_loop(index: int, loop: ClosureLoop, variables: Sequence[int], scalar: bool = True) -> LoopPolynomials:
    """q_n F_n of a loop in t = tan((theta - shift)/2) on each unknown's range (Sections 2.2, 3).

    ``variables``: the global variable index of each of the loop's unknowns (in loop order). The
    matrix comes from the product route, the scalar equation of Eq. (10) from the paper's
    recursion route (Cor. 2; skipped with ``scalar=False``, then read off the matrix when needed);
    both are exact reparameterizations of the same polynomials.
    """
    from ..closure import matrix_control_points, matrix_magnitude, q_control_points, scalar_control_points

    fps = loop.factor_polynomials()
    split = _split_point(loop)
    ha = hb = ha_mag = hb_mag = None
    if split is not None:
        qa, qb = q_control_points(fps[:split]), q_control_points(fps[split:])
        ha = _half(matrix_control_points(fps[:split]), qa)
        hb = _half(matrix_control_points(fps[split:]), qb)
        ha_mag = _half_magnitude(matrix_magnitude(fps[:split]), qa)
        hb_mag = _half_magnitude(matrix_magnitude(fps[split:]), qb)
    return LoopPolynomials(index, tuple(variables), matrix_control_points(fps), q_control_points(fps),
                           scalar_control_points(fps, "recursion") if scalar else None, ha, hb,
                           matrix_magnitude(fps), ha_mag, hb_mag)


def _sin_cos_factor(term: Term, cbox, sbox) -> np.ndarray:
    """Control matrices (2, 2, 3, 3) of Rx(phi) Z over (c, s) in cbox x sbox, phi = offset + sign theta.

    cos(phi) = cos(o) c - sign sin(o) s and sin(phi) = sin(o) c + sign cos(o) s are affine in
    (c, s), so Rx(phi) Z is multilinear and its degree-(1, 1) control points are its corner values.
    """
    co, so = snapped_cos_sin(term.offset)
    c = np.array(cbox, dtype=float)[:, None]
    s = np.array(sbox, dtype=float)[None, :]
    cp = co * c - term.sign * so * s
    sp = so * c + term.sign * co * s
    out = np.zeros((2, 2, 3, 3))
    out[..., 0, 1] = -1.0
    out[..., 1, 0] = cp
    out[..., 1, 2] = -sp
    out[..., 2, 0] = sp
    out[..., 2, 2] = cp
    return out


def _sin_cos_product(factors, names, boxes, magnitude: bool = False):
    """Control points (3, 3, *dims) of prod Rx(phi_i) Z over the (c, s) of its unknowns, and their variables.

    With ``magnitude``, the same product of the factors' matrices in absolute value with the cos and
    sin of every known angle or offset counted as 1 (cos phi = cos(o) c - sign sin(o) s as |c| + |s|):
    a bound on the terms behind each control point, which its rounding is relative to (as
    :func:`spherekin.closure.matrix_magnitude` for tan-half).
    """
    prod = np.eye(3)
    variables = []
    for f in factors:
        if isinstance(f, Term):
            k = list(names).index(f.unknown.name)
            variables += [2 * k, 2 * k + 1]
            if magnitude:
                cbox, sbox = boxes[f.unknown.name]
                m = np.abs(np.array(cbox, dtype=float))[:, None] + np.abs(np.array(sbox, dtype=float))[None, :]
                a = np.zeros((2, 2, 3, 3))
                a[..., 0, 1] = 1.0
                for i, j in ((1, 0), (1, 2), (2, 0), (2, 2)):
                    a[..., i, j] = m
            else:
                a = _sin_cos_factor(f, *boxes[f.unknown.name])
            prod = prod[..., None, None, :, :] @ a
        else:
            c, s = (1.0, 1.0) if magnitude else snapped_cos_sin(f)
            known = np.array([[0.0, -1.0, 0.0], [c, 0.0, -s], [s, 0.0, c]])
            prod = prod @ (np.abs(known) if magnitude else known)
    return np.moveaxis(np.moveaxis(prod, -1, 0), -1, 0), variables


def _largest(tensor: np.ndarray) -> np.ndarray:
    """(3, 3): the largest value of each entry of a (3, 3, *dims) tensor of control points."""
    return tensor.reshape(3, 3, -1).max(axis=2)


def sin_cos_loop(index: int, loop: ClosureLoop, names: Sequence[str],
                 boxes: Mapping[str, tuple]) -> LoopPolynomials:
    """F_n of a loop in the variables (c_k, s_k) = (cos theta_k, sin theta_k) (Section 5).

    ``names``: the unknowns' names (variable 2k is c_k, 2k+1 is s_k); ``boxes[name]``: its
    ((c_lo, c_hi), (s_lo, s_hi)). The control points of the product are the products of the
    factors' control matrices (tensor product over distinct variables), q = 1.
    """
    matrix, variables = _sin_cos_product(loop.factors, names, boxes)
    mag = _largest(_sin_cos_product(loop.factors, names, boxes, magnitude=True)[0])
    split = _split_point(loop)
    ha = hb = ha_mag = hb_mag = None
    if split is not None:
        halves = []
        for part in (loop.factors[:split], loop.factors[split:]):
            pm, _ = _sin_cos_product(part, names, boxes)
            pmag = _largest(_sin_cos_product(part, names, boxes, magnitude=True)[0])
            halves += [_half(pm, np.ones(pm.shape[2:])), _half_magnitude(pmag, np.ones(1))]
        ha, ha_mag, hb, hb_mag = halves
    return LoopPolynomials(index, tuple(variables), matrix, np.ones(matrix.shape[2:]), None, ha, hb,
                           mag, ha_mag, hb_mag)


def _circle_block(k: int, n_vars: int, cbox, sbox) -> EquationBlock:
    """c_k^2 + s_k^2 - 1 on the box: with c = a + (b - a) x, c^2 has control points (a^2, ab, b^2)."""
    (a, b), (p, q) = cbox, sbox
    cc = np.array([a * a, a * b, b * b])
    ss = np.array([p * p, p * q, q * q])
    tensor = cc[:, None] + ss[None, :] - 1.0
    shape = [1] * (n_vars + 1)
    shape[1 + 2 * k] = shape[2 + 2 * k] = 3
    coeffs = tensor.reshape(shape)
    magnitude = np.abs(cc)[:, None] + np.abs(ss)[None, :] + 1.0          # the terms behind each control point
    return EquationBlock(-1, (f"circle{k + 1}",), coeffs, np.array([magnitude.max()]), (0,))


# --------------------------------------------------------------------------------------------
# Chart sets
# --------------------------------------------------------------------------------------------

class Parameterization(ABC):
    """How unknown joint angles become the variables of the box loop, and back.

    It owns the maps between a chart's unit box and the angles: ``metric`` (a variable's metric
    coordinate: radians for tan-half, c or s for sin-cos), ``angles``, ``angle_box``, and the
    contraction of reduced boxes by constraints the equations do not carry (``contract``). The
    defaults are those of a metric that is the angle itself, affine in the unit coordinate.
    """

    name: ClassVar[str]

    def metric(self, charts: "ChartSet", chart: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Metric coordinates (B, N) of unit coordinates x (B, N) in charts ``chart`` (B,)."""
        lo, hi = charts.map_lo[chart], charts.map_hi[chart]
        return lo + (hi - lo) * x

    def angles(self, charts: "ChartSet", chart: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Unknown angles (B, n), radians, at unit coordinates x (B, N)."""
        return self.metric(charts, chart, x)

    def angle_box(self, charts: "ChartSet", chart: np.ndarray, lo: np.ndarray,
                  hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Angle bounds (B, n) of the boxes [lo, hi] (unit coordinates, B x N), radians."""
        return self.metric(charts, chart, lo), self.metric(charts, chart, hi)

    def contract(self, charts: "ChartSet", chart: np.ndarray, lo: np.ndarray, hi: np.ndarray, rlo: np.ndarray,
                 rhi: np.ndarray) -> None:
        """Shrink the reductions [rlo, rhi] (unit coordinates of the boxes [lo, hi], B x N, in place)
        by what the parameterization knows beyond the equations; nothing by default."""


class LoopParameterization(Parameterization):
    """A parameterization of the loop equations (Eq. 2), chosen by name (:data:`PARAMETERIZATIONS`).

    A new one subclasses this, sets ``name``, implements :meth:`charts` (and the maps it needs)
    and is registered with ``@PARAMETERIZATIONS.register``.
    """

    @abstractmethod
    def charts(self, build, ranges: Mapping[str, tuple[float, float] | None], formulation: str) -> "ChartSet":
        """The chart set of the loops of ``build`` over the joint ``ranges`` (see :func:`make_charts`)."""


@dataclass(frozen=True)
class ChartSet:
    """Everything the box loop needs, stacked along a leading chart axis (C charts).

    * ``parameterization``: the :class:`Parameterization` whose maps the methods below apply;
    * ``unknowns``: the unknown angles' names (n); ``variables``: the polynomial variables (N);
    * ``coeffs[b]`` (C, E_b, d_1..d_N) and ``tols[b]`` (C, E_b): equation block b on each chart's
      unit box and the absolute tolerance of its test w = 0; ``labels[b]``; ``square[b]``: the
      equations of block b that belong to the square system of simple roots (for the Krawczyk
      test), empty when the formulation has none;
    * ``map_lo``, ``map_hi`` (C, N): each variable's metric coordinate (radians for tan-half, c or s
      for sin-cos) is a monotone function of its unit coordinate x between these values;
    * ``accept_width``: a box is accepted when every metric side is below ``tol * accept_width``;
    * ``bilinear[b]``: None, or the :class:`spherekin.search.formulations.ChartBilinear` of block b when it
      is the bilinear form of a loop's halves on every chart: the box loop then restricts the
      halves and assembles them, not ``coeffs``;
    * ``prune[b]``: whether the pruners use block b (else only the Krawczyk test does).
    """

    parameterization: Parameterization
    unknowns: tuple
    variables: tuple
    coeffs: list
    tols: list
    labels: list
    square: list
    map_lo: np.ndarray
    map_hi: np.ndarray
    shift: np.ndarray
    accept_width: float
    bilinear: list = None
    prune: list = None

    @property
    def n_charts(self) -> int:
        return self.coeffs[0].shape[0]

    @property
    def square_size(self) -> int:
        return sum(len(s) for s in self.square)

    def metric(self, chart: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Metric coordinates (B, N) of unit coordinates x (B, N) in charts ``chart`` (B,)."""
        return self.parameterization.metric(self, chart, x)

    def angles(self, chart: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Unknown angles (B, n), radians, at unit coordinates x (B, N)."""
        return self.parameterization.angles(self, chart, x)

    def contract(self, chart: np.ndarray, lo: np.ndarray, hi: np.ndarray, rlo: np.ndarray, rhi: np.ndarray) -> None:
        """The parameterization's contraction of the reductions [rlo, rhi] (in place)."""
        self.parameterization.contract(self, chart, lo, hi, rlo, rhi)

    def angle_box(self, chart: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Angle bounds (B, n) of the boxes [lo, hi] (unit coordinates, B x N), radians."""
        return self.parameterization.angle_box(self, chart, lo, hi)


#: Slack (c, s units) of the circle bounds: a candidate point counts as inside a rectangle within
#: this distance of it, and the bounds are widened by it. The square roots and products behind a
#: bound err by a few 1e-16; 1e-12 is far above that and far below any tolerance of the solver.
CIRCLE_SLACK = 1e-12


def circle_bounds(c_lo, c_hi, s_lo, s_hi):
    """Bounding box of the unit circle inside the rectangles [c_lo, c_hi] x [s_lo, s_hi].

    Arrays of one shape; returns ((c_lo', s_lo'), (c_hi', s_hi')), with lo' > hi' where the circle
    misses the rectangle. The circle inside a rectangle is a union of arcs whose ends lie on the
    rectangle's edges; an arc reaches beyond its ends only at the axis points (+-1, 0), (0, +-1).
    So the bounding box is that of the edge crossings (c = c_lo: s = +-sqrt(1 - c_lo^2), ...) and
    of the axis points inside the rectangle. Widened by CIRCLE_SLACK.
    """
    m = CIRCLE_SLACK
    pts_c, pts_s = [], []

    def add(c, s):
        ok = (c >= c_lo - m) & (c <= c_hi + m) & (s >= s_lo - m) & (s <= s_hi + m)
        pts_c.append(np.where(ok, c, np.nan))
        pts_s.append(np.where(ok, s, np.nan))

    with np.errstate(invalid="ignore"):
        for edge in (c_lo, c_hi):
            root = np.sqrt(np.maximum(1.0 - edge * edge, 0.0))
            inside = np.abs(edge) <= 1.0 + m
            for sign in (1.0, -1.0):
                add(np.where(inside, edge, np.nan), sign * root)
        for edge in (s_lo, s_hi):
            root = np.sqrt(np.maximum(1.0 - edge * edge, 0.0))
            inside = np.abs(edge) <= 1.0 + m
            for sign in (1.0, -1.0):
                add(sign * root, np.where(inside, edge, np.nan))
        one, zero = np.ones_like(c_lo), np.zeros_like(c_lo)
        for c, s in ((one, zero), (-one, zero), (zero, one), (zero, -one)):
            add(c, s)
        pc, ps = np.stack(pts_c), np.stack(pts_s)
        found = ~np.all(np.isnan(pc), axis=0)
        lo_c = np.where(found, np.nanmin(np.where(np.isnan(pc), np.inf, pc), axis=0) - m, 1.0)
        hi_c = np.where(found, np.nanmax(np.where(np.isnan(pc), -np.inf, pc), axis=0) + m, 0.0)
        lo_s = np.where(found, np.nanmin(np.where(np.isnan(ps), np.inf, ps), axis=0) - m, 1.0)
        hi_s = np.where(found, np.nanmax(np.where(np.isnan(ps), -np.inf, ps), axis=0) + m, 0.0)
    return (lo_c, lo_s), (hi_c, hi_s)


def _stack_blocks(per_chart: list[list[EquationBlock]]):
    nb = len(per_chart[0])
    coeffs = [np.stack([bl[b].coeffs for bl in per_chart]) for b in range(nb)]
    eps = np.finfo(float).eps
    tols = [ROUNDING_SAFETY * eps * np.stack([bl[b].scale for bl in per_chart]) for b in range(nb)]
    labels = [bl.labels for bl in per_chart[0]]
    square = [bl.square for bl in per_chart[0]]
    n_vars = per_chart[0][0].coeffs.ndim - 1
    bilinear = []
    for b in range(nb):
        forms = [bl[b].bilinear for bl in per_chart]
        bilinear.append(None if any(f is None for f in forms) else ChartBilinear.stack(forms, n_vars))
    prune = [bl.prune for bl in per_chart[0]]
    return coeffs, tols, labels, square, bilinear, prune


def _rechart(loop: ClosureLoop, unknowns: Mapping[str, Unknown]) -> ClosureLoop:
    """The same loop with its unknowns replaced by ``unknowns[name]`` (another chart's ranges)."""
    return ClosureLoop([Term(unknowns[f.unknown.name], f.offset, f.sign) if isinstance(f, Term) else f
                        for f in loop.factors])


#: The parameterizations of the loop equations, by name (:func:`make_charts`).
PARAMETERIZATIONS = Registry("parameterization")


@PARAMETERIZATIONS.register
class TanHalf(LoopParameterization):
    """The paper's t = tan((theta - shift)/2) (Section 2.2): one variable per unknown, charts of
    width at most CHART_MAX_WIDTH; the metric of a variable is the angle itself."""

    name = "tan-half"

    def metric(self, charts, chart, x):
        return tan_half_angle(x, charts.shift[chart], charts.map_lo[chart], charts.map_hi[chart])

    def charts(self, build, ranges, formulation) -> ChartSet:
        """2^n-ish charts (:func:`charts_for_range` per unknown). ``build`` is called once: the loops'
        factors (known angles, offsets, signs) must not depend on the chart ranges, only the unknowns'
        ranges do; each loop's polynomials are computed once per combination of its own unknowns'
        charts (16 per Gosselin loop instead of 64) and shared by the charts that agree on them."""
        names = list(ranges)
        per_name = [charts_for_range(ranges[name]) for name in names]
        count = math.prod(len(p) for p in per_name)
        if count > MAX_CHARTS:
            wide = [name for name, p in zip(names, per_name) if len(p) > 1]
            raise ValueError(f"parameterization 'tan-half': {count:,} charts ({len(wide)} joints over more than "
                             f"{CHART_MAX_WIDTH:.4g} rad: {', '.join(wide[:6])}{', ...' if len(wide) > 6 else ''}), "
                             f"more than MAX_CHARTS = {MAX_CHARTS}: give those joints ranges narrower than pi, "
                             "or use parameterization 'sin-cos' (one chart)")
        combos = list(itertools.product(*(range(len(p)) for p in per_name)))
        loops, unknowns = build({name: per_name[k][0] for k, name in enumerate(names)})
        if tuple(u.name for u in unknowns) != tuple(names):
            raise ValueError(f"build: expected the unknowns {tuple(names)}, got {tuple(u.name for u in unknowns)}")
        chart_unknowns = [[Unknown(name, *rng) for rng in per_name[k]] for k, name in enumerate(names)]
        cache: dict = {}
        scalar = FORMULATIONS.lookup(formulation).uses_scalar   # the paper's recursion route where Eq. (10) is used
        per_chart, t_lo, t_hi, shift = [], [], [], []
        for combo in combos:
            blocks = []
            for j, lp in enumerate(loops):
                idx = tuple(names.index(n) for n in lp.names)
                key = (j, tuple(combo[i] for i in idx))
                if key not in cache:     # every formulation makes one block per loop, from that loop alone
                    local = {names[i]: chart_unknowns[i][combo[i]] for i in idx}
                    poly = tan_half_loop(j, _rechart(lp, local), idx, scalar=scalar)
                    cache[key] = formulate_polynomials(formulation, [poly], len(names))
                blocks += cache[key]
            per_chart.append(blocks)
            chosen = [chart_unknowns[i][c] for i, c in enumerate(combo)]
            t = np.array([u.t_range for u in chosen])
            t_lo.append(t[:, 0])
            t_hi.append(t[:, 1])
            shift.append([u.shift for u in chosen])
        coeffs, tols, labels, square, bilinear, prune = _stack_blocks(per_chart)
        return ChartSet(self, tuple(names), tuple(names), coeffs, tols, labels, square,
                        np.array(t_lo), np.array(t_hi), np.array(shift), 1.0, bilinear, prune)


#: sin-cos boxes are accepted when every c and s side is below tol times this: points of the unit
#: circle in a square of side w are at most 2 asin(w / sqrt 2) ~ 1.41 w apart in angle, so w <= tol / 2
#: bounds the angle uncertainty by ~0.71 tol < tol.
SIN_COS_ACCEPT = 0.5


@PARAMETERIZATIONS.register
class SinCos(LoopParameterization):
    """Section 5's x = sin(theta), y = cos(theta): two variables (c, s) per unknown on the bounding
    box of its range's arc, with the circle c^2 + s^2 = 1; one chart covers any range."""

    name = "sin-cos"

    def angles(self, charts, chart, x):
        v = self.metric(charts, chart, x)
        return np.arctan2(v[:, 1::2], v[:, 0::2])

    def contract(self, charts, chart, lo, hi, rlo, rhi):
        """Shrink the reductions [rlo, rhi] (in the unit coordinates of the boxes [lo, hi], all
        B x N, updated in place) to the bounding box of the unit circle inside each (c, s)
        rectangle (:func:`circle_bounds`); rlo > rhi where the circle misses one.

        Departure from the paper: the circle equation c^2 + s^2 = 1 is also a block that the
        pruners use, but its hull bounds are loose (the circle is curved); this exact bound is
        what the constraint allows, at the cost of a few square roots per box.
        """
        live = np.flatnonzero(~np.any(rlo > rhi, axis=1))
        if not len(live):
            return
        w = hi[live] - lo[live]
        mlo, mhi = charts.map_lo[chart[live]], charts.map_hi[chart[live]]
        span = (mhi - mlo) * w                                 # metric length of each box side
        base = mlo + (mhi - mlo) * lo[live]                    # metric coordinate of each box's lo
        clo, chi = base + span * rlo[live], base + span * rhi[live]
        blo, bhi = circle_bounds(clo[:, 0::2], chi[:, 0::2], clo[:, 1::2], chi[:, 1::2])
        new_lo, new_hi = np.empty_like(clo), np.empty_like(chi)
        new_lo[:, 0::2], new_lo[:, 1::2] = blo
        new_hi[:, 0::2], new_hi[:, 1::2] = bhi
        with np.errstate(divide="ignore", invalid="ignore"):
            rlo[live] = np.where(span > 0, np.maximum(rlo[live], (new_lo - base) / span), rlo[live])
            rhi[live] = np.where(span > 0, np.minimum(rhi[live], (new_hi - base) / span), rhi[live])

    def angle_box(self, charts, chart, lo, hi):
        """The angles of the four corners of each (c, s) rectangle, unwrapped next to the angle of
        its centre (the rectangles of accepted boxes are tiny and away from the origin)."""
        mlo, mhi = self.metric(charts, chart, lo), self.metric(charts, chart, hi)
        centre = np.arctan2(0.5 * (mlo[:, 1::2] + mhi[:, 1::2]), 0.5 * (mlo[:, 0::2] + mhi[:, 0::2]))
        corners = [np.arctan2(s[:, 1::2], c[:, 0::2]) for c in (mlo, mhi) for s in (mlo, mhi)]
        corners = [centre + wrap(a - centre) for a in corners]
        return np.minimum.reduce(corners), np.maximum.reduce(corners)

    def charts(self, build, ranges, formulation) -> ChartSet:
        names = list(ranges)
        loops, unknowns = build({name: (-1.0, 1.0) for name in names})
        if tuple(u.name for u in unknowns) != tuple(names):
            raise ValueError(f"build: expected the unknowns {tuple(names)}, got {tuple(u.name for u in unknowns)}")
        boxes = {name: arc_box(ranges[name]) for name in names}
        n_vars = 2 * len(names)
        polys = [sin_cos_loop(j, lp, names, boxes) for j, lp in enumerate(loops)]
        blocks = formulate_polynomials(formulation, polys, n_vars)
        blocks += [_circle_block(k, n_vars, *boxes[name]) for k, name in enumerate(names)]
        coeffs, tols, labels, square, bilinear, prune = _stack_blocks([blocks])
        lo = np.array([[v for name in names for v in (boxes[name][0][0], boxes[name][1][0])]])
        hi = np.array([[v for name in names for v in (boxes[name][0][1], boxes[name][1][1])]])
        variables = tuple(f"{v}({name})" for name in names for v in ("cos", "sin"))
        return ChartSet(self, tuple(names), variables, coeffs, tols, labels, square,
                        lo, hi, np.zeros_like(lo), SIN_COS_ACCEPT, bilinear, prune)




def make_charts(name: str, build, ranges: Mapping[str, tuple[float, float] | None], formulation: str) -> ChartSet:
    """The :class:`ChartSet` of parameterization ``name`` (one of PARAMETERIZATIONS).

    ``build(chart_ranges)`` returns (loops, unknowns) with each unknown's range set from
    ``chart_ranges`` (name -> (lo, hi), width < 2 pi); ``ranges`` gives each unknown's joint range
    (radians) or None for the full circle.
    """
    parameterization = PARAMETERIZATIONS.lookup(name)()
    if not ranges:
        raise ValueError("ranges: expected at least one unknown, got none")
    return parameterization.charts(build, dict(ranges), formulation)


def stack_chart_sets(sets: Sequence[ChartSet]) -> ChartSet:
    """One :class:`ChartSet` holding the charts of ``sets`` in order (chart c of ``sets[k]`` at index
    k C_0 + ... + c: input-major when each set is one input's).

    Every per-chart array is concatenated along its chart axis: ``coeffs[b]``, ``tols[b]``,
    ``map_lo``, ``map_hi``, ``shift`` (axis 0) and each bilinear block's ``a``, ``b`` (last axis).
    The sets must share one layout: the same parameterization, unknowns, variables, accept width,
    block labels, square systems, prune flags, coefficient shapes, and bilinear forms (variables,
    sums, shapes); else a ValueError naming what differs.
    """
    sets = list(sets)
    if not sets:
        raise ValueError("sets: expected at least one chart set, got none")
    first = sets[0]
    nb = len(first.coeffs)

    def same(k: int, what: str, a, b) -> None:
        if a != b:
            raise ValueError(f"sets[{k}]: expected the layout of sets[0], but its {what} differs ({b!r} vs {a!r})")

    def bil_key(f):
        return None if f is None else (f.a_vars, f.b_vars, f.sums, f.shape, f.a.shape[:-1], f.b.shape[:-1])

    def layout(s: ChartSet):
        return {
            "parameterization": type(s.parameterization).__name__,
            "unknowns": s.unknowns,
            "variables": s.variables,
            "accept_width": s.accept_width,
            "number of blocks": len(s.coeffs),
            "labels": [tuple(x) for x in s.labels],
            "square": [tuple(x) for x in s.square],
            "prune": list(s.prune) if s.prune is not None else None,
            "coefficient shapes": [c.shape[1:] for c in s.coeffs],
            "tolerance shapes": [t.shape[1:] for t in s.tols],
            "map shapes": (s.map_lo.shape[1:], s.map_hi.shape[1:], s.shift.shape[1:]),
            "bilinear forms": None if s.bilinear is None else [bil_key(f) for f in s.bilinear],
        }

    ref = layout(first)
    for k, s in enumerate(sets[1:], 1):
        for what, value in layout(s).items():
            same(k, what, ref[what], value)
    if len(sets) == 1:
        return first
    coeffs = [np.concatenate([s.coeffs[b] for s in sets]) for b in range(nb)]
    tols = [np.concatenate([s.tols[b] for s in sets]) for b in range(nb)]
    bilinear = first.bilinear
    if bilinear is not None:
        bilinear = [None if f is None else ChartBilinear(
            f.a_vars, f.b_vars, np.concatenate([s.bilinear[b].a for s in sets], axis=-1),
            np.concatenate([s.bilinear[b].b for s in sets], axis=-1), f.sums, f.shape)
            for b, f in enumerate(bilinear)]
    return ChartSet(first.parameterization, first.unknowns, first.variables, coeffs, tols, first.labels,
                    first.square, np.concatenate([s.map_lo for s in sets]), np.concatenate([s.map_hi for s in sets]),
                    np.concatenate([s.shift for s in sets]), first.accept_width, bilinear, first.prune)
