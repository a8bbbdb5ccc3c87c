"""Certification of solutions: a Krawczyk test in outward-rounded interval arithmetic.

The system certified is the *transversal* closure system in angle space: for every loop of a
:class:`~spherekin.mechanism.LoopSystem`, the entries (2,1), (3,1), (3,2) (1-based) of
F_n = prod_i Rx(phi_i) Z (Eq. 2), which vanish at closure (F = I + [w]x near I gives
(f21, f31, f32) = (w_z, -w_y, w_x): simple roots where the mechanism is regular). The unknowns are
the passive angles theta (radians), in ``LoopSystem.unknowns`` order; a factor angle is a known
number or phi = offset + sign * theta. These are the entries of the ``transversal`` formulation
(:data:`spherekin.formulations.TRANSVERSAL_ENTRIES`) without the tan-half-angle substitution and
without the factor q_n, so the Jacobian is taken directly with respect to the joint angles.

Krawczyk's test (Krawczyk 1969; Moore 1977; Rump 1983): for a box X, a point y in X, any real
matrix C and an enclosure J(X) of the Jacobian over X,

    K(X) = y - C F(y) + (I - C J(X)) (X - y).

Every zero of F in X lies in K(X); if K(X) lies in the interior of X (and C is nonsingular) then X
holds exactly one zero and J is nonsingular on X. All of K is evaluated in outward-rounded
interval arithmetic (the rounding of every +, *, sin and cos is enclosed), F(y) as an interval at
the point y. C = J(y)^-1 is an ordinary float inverse (any C is valid; a
good one makes K small).

Two implementations, with the same inputs and results:

* fast (:func:`krawczyk`, :func:`certify`, :func:`certify_many`, :func:`interval_transversal`,
  :func:`enclose_transversal`): interval arithmetic on float64 arrays, every operation rounded to
  nearest then widened one ulp outward (:mod:`spherekin.intervals`), vectorized over points,
  radii, loops and factors. A factor angle is phi = c + sign * theta, so
  cos phi = cos c cos theta - sign sin c sin theta and sin phi = sin c cos theta + sign cos c sin theta,
  with cos/sin of each constant c over c +- angle_tolerance and of each unknown over its box from
  :func:`spherekin.intervals.cos_sin_table` (:mod:`spherekin.trig_enclosure` at the float point, then a rigorous
  expansion). With P_i the product of the factors before factor i (P_0 = I), F = P_n by
  P_{i+1} = P_i Rx(phi_i) Z, and dF/dphi_i = [u_i]x F with u_i = P_i e1, because
  d/dphi Rx(phi) = [e1]x Rx(phi) and P [e1]x P^T = [P e1]x for a rotation P -- an identity of
  the exact matrices at every point of the box, so enclosures of u_i and F enclose the Jacobian.
  K uses (I - C J(X)) (X - y) in [-s, s], s = |I - C J(X)| rho with X - y in [-rho, rho] (a
  superset of the usual evaluation: both conclusions of the test stay valid). Outside the IEEE
  default floating-point environment (:func:`spherekin.intervals.rounding_environment_ok`) the
  fast functions use the reference.
* reference (:func:`krawczyk_reference`, :func:`certify_reference`,
  :func:`interval_transversal_reference`): mpmath's ``iv`` context for every operation (slow,
  obviously correct). F = P_n with prefix products as above and, since an unknown appears at most
  once per loop, dF/dtheta = sign * P_{i-1} (dRx(phi_i)/dphi Z) S_{i+1} with suffix products
  S_i = Rx(phi_i) Z S_{i+1}, using Rx(phi) Z = [[0,-1,0],[c,0,-s],[s,0,c]] and
  d/dphi (Rx(phi) Z) = [[0,0,0],[-s,0,-c],[c,0,-s]]; one routine does this in floats
  (:func:`transversal_equations`) and in intervals.

Departures from the paper: the paper does not certify its solutions (subdivision returns small
boxes, not proofs); this module is an addition. Known factor angles and term offsets are floats
rounded from the geometry; the test treats each as an interval of half-width
``angle_tolerance`` (default :data:`ANGLE_TOLERANCE`), so a certificate holds for every system
whose constant angles are that close to the floats -- including the snapped angles of the
Bernstein equations (:data:`spherekin.closure.KNOWN_ANGLE_SNAP`) and the exact angles (pi/2, pi,
...) that the floats round.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Mapping, Sequence

import numpy as np

from . import intervals as iv_ops
from .intervals import _add, _cos_sin_table, _isum, _mul, _scale, _sub
from .closure import KNOWN_ANGLE_SNAP, Term
from .formulations import TRANSVERSAL_ENTRIES
from .mechanism import LoopSystem

__all__ = [
    "ANGLE_TOLERANCE",
    "FINE_ANGLE_TOLERANCE",
    "CERTIFY_RADII",
    "MIDPOINT_RCOND_MIN",
    "OVERDETERMINED_BOUND",
    "BoxTests",
    "krawczyk_many",
    "KrawczykResult",
    "transversal_labels",
    "transversal_equations",
    "enclose_transversal",
    "interval_transversal",
    "interval_transversal_reference",
    "krawczyk",
    "krawczyk_reference",
    "certify",
    "certify_many",
    "certify_reference",
]

#: Half-width (radians) of the interval that stands for each constant angle (known factor angle,
#: term offset). Reason: the floats of a LoopSystem are rounded (np.pi, offsets from atan2 of
#: float axes: errors ~1e-16) and the Bernstein equations snap cos/sin within KNOWN_ANGLE_SNAP of 0,
#: i.e. move an angle by up to ~1e-14; twice the snap covers both, so the certificate is about the
#: mechanism, not about one rounding of it. It widens F(y) by ~n_factors * 2e-14, far below the
#: smallest radius tried.
ANGLE_TOLERANCE = 2.0 * KNOWN_ANGLE_SNAP

#: The tighter angle tolerance (radians) :mod:`spherekin.solutions` retries with when a test at
#: ANGLE_TOLERANCE fails next to a singularity. Reason: the width of F(y) (~n_factors * the angle
#: tolerance) divided by the smallest singular value of J bounds how small K(X) can be; for two
#: roots 1e-5 apart (sigma_min ~5e-6) 2e-14 makes K wider than any box that still contracts. The
#: constants of a LoopSystem are computed from the mechanism's floats in a few operations (a few
#: ulps of 2 pi, ~1e-15), so 4e-15 still covers every rounding of the mechanism; it no longer
#: covers the snapping of the Bernstein equations (the certificate is about the mechanism).
FINE_ANGLE_TOLERANCE = 4e-15

#: Box radii (radians) tried by :func:`certify`, smallest first. Reason: K's width is about
#: |C| (|F(y)| + rounding) + cond(J) * radius^2, so a small box suffices for a regular root polished
#: to ~1e-15 (1e-10 sits well above that accuracy and the ~1e-13 width of F(y)); larger radii
#: rescue points polished less accurately or Jacobians with |J^-1| up to ~1e5 (a root next to a
#: fold contracts only in a narrow window of radii, hence every decade), while 1e-6 stays
#: far below the distance between distinct solutions that the solver can separate (its default
#: tolerance is 1e-6).
CERTIFY_RADII = (1e-10, 1e-9, 1e-8, 1e-7, 1e-6)

#: The midpoint Jacobian is reported singular when sigma_min / sigma_max is below this. Reason:
#: entries of J are products of sines and cosines (|J_ij| <= 1), so then |C| >~ 1e12 and the width
#: of C F(y) alone (F(y) is at least ~1e-16 wide from rounding) exceeds the largest radius tried
#: (1e-6): the inclusion cannot succeed, and the singular Jacobian is the real reason.
MIDPOINT_RCOND_MIN = 1e-12

#: Over-determined systems: a certified square subsystem counts as a certificate of the whole system
#: only when the other equations stay within this bound over the certified box. Reason: on a box of
#: radius r their enclosure is ~|J| r wide (|J_ij| <= 1), so at a root and the radii tried (<= 1e-6)
#: it is ~1e-6 at most; a point where they are larger is not a root of the whole system to the
#: accuracy the radii can show (inconsistent redundant inputs leave residuals far above it).
OVERDETERMINED_BOUND = 1e-5


# --------------------------------------------------------------------------------------------
# Result
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class KrawczykResult:
    """Outcome of a Krawczyk test on the transversal system of a LoopSystem (radians throughout).

    * ``certified``: K(X) lies in the interior of X, so X holds exactly one solution;
    * ``reason``: why not (empty when certified);
    * ``names``, ``center`` (y), ``radius``: the unknowns and the box X = y +- radius;
    * ``box`` (X) and ``krawczyk_box`` (K(X), outward-rounded to floats; None when not computed):
      one (lo, hi) per unknown;
    * ``contraction``: max_k width(K_k) / width(X_k) (< 1 is necessary for success; nan when K was
      not computed);
    * ``no_solution``: K(X) and X are disjoint, which proves that X holds no solution;
    * ``residual``: an upper bound on max |F(y)| over the equations (for every system whose
      constant angles lie within the angle tolerance, so ~1e-13 at an exact root by default);
    * ``singular_values``: of the float Jacobian J(y), descending (its rank and conditioning);
    * ``n_equations``, ``n_unknowns``; ``radii_tried``: the radii tested, in order (by
      :func:`certify`; just ``(radius,)`` for a single test);
    * ``angle_tolerance``: the half-width of the interval each constant angle stood for;
    * over-determined systems (more equations than unknowns: redundant actuation):
      ``subsystem_rows``, the equations of the square subsystem tested (well-conditioned rows of
      J(y), see :func:`_subsystem_rows`), and ``other_bound``, a bound of |F| of the other
      equations over X. ``certified`` then means: X holds exactly one root of the subsystem (so at
      most one root of the whole system), and the other equations are within +-other_bound
      <= :data:`OVERDETERMINED_BOUND` on X. None and 0.0 for square systems.
    """

    certified: bool
    reason: str
    names: tuple
    center: tuple
    radius: float
    box: tuple
    krawczyk_box: tuple | None
    contraction: float
    no_solution: bool
    residual: float
    singular_values: tuple
    n_equations: int
    n_unknowns: int
    radii_tried: tuple
    subsystem_rows: tuple | None = None
    other_bound: float = 0.0
    angle_tolerance: float = ANGLE_TOLERANCE

    def summary(self) -> dict:
        """JSON-ready evidence: the verdict, radius, contraction, residual bound, singular values."""
        return {
            "certified": self.certified,
            "reason": self.reason,
            "radius": self.radius,
            "angle_tolerance": self.angle_tolerance,
            "contraction": None if math.isnan(self.contraction) else self.contraction,
            "no_solution": self.no_solution,
            "residual_bound": self.residual,
            "min_singular_value": self.singular_values[-1] if self.singular_values else None,
            "n_equations": self.n_equations,
            "n_unknowns": self.n_unknowns,
            "radii_tried": list(self.radii_tried),
            **({} if self.subsystem_rows is None else {
                "subsystem_rows": list(self.subsystem_rows), "other_equations_bound": self.other_bound}),
        }


# --------------------------------------------------------------------------------------------
# The transversal system: labels and float values
# --------------------------------------------------------------------------------------------

def transversal_labels(system: LoopSystem) -> tuple[str, ...]:
    """Names of the equations, in row order: "loop1:f21", "loop1:f31", "loop1:f32", "loop2:f21", ..."""
    _check_system(system)
    return tuple(f"loop{k + 1}:f{r + 1}{c + 1}" for k in range(len(system.loops)) for r, c in TRANSVERSAL_ENTRIES)


def transversal_equations(system: LoopSystem, theta) -> tuple[np.ndarray, np.ndarray]:
    """Float values F (E,) and Jacobian J (E, M) = dF/dtheta of the transversal system at ``theta``.

    ``theta``: passive angles (radians), a sequence in ``system.unknowns`` order or a mapping
    name -> angle. E = 3 * number of loops, M = number of unknowns. (The float twin of the
    reference evaluation.)
    """
    _check_system(system)
    y = _check_theta(system, theta)
    f, j = _evaluate(system, list(y), float, math.cos, math.sin)
    return np.array(f, dtype=float), np.array(j, dtype=float).reshape(len(f), len(y))


# --------------------------------------------------------------------------------------------
# Fast enclosures of F and J (vectorized interval arithmetic on float arrays)
# --------------------------------------------------------------------------------------------

#: (row, column) index arrays of the transversal entries of F_n.
_ENTRY_ROWS = np.array([r for r, _ in TRANSVERSAL_ENTRIES])
_ENTRY_COLS = np.array([c for _, c in TRANSVERSAL_ENTRIES])
#: For J = [u]x F: entry (r, c) is u[(r+1)%3] F[(r+2)%3, c] - u[(r+2)%3] F[(r+1)%3, c]; the
#: u indices and the (column, row) of F of the two products of every entry, interleaved.
_JAC_U = np.array([i for r, _ in TRANSVERSAL_ENTRIES for i in ((r + 1) % 3, (r + 2) % 3)])
_JAC_F_ROW = np.array([i for r, _ in TRANSVERSAL_ENTRIES for i in ((r + 2) % 3, (r + 1) % 3)])
_JAC_F_COL = np.array([c for _, c in TRANSVERSAL_ENTRIES for _ in range(2)])
#: Rows (0: cos, 1: sin) of the (cos, sin) table for (cos c, sin c, sin c, cos c), shaped to
#: index (4, n, 1, L) (see _enclose).
_QUAD_CONST = np.array([0, 1, 1, 0])[:, None, None, None]
#: Columns of P gathered by one prefix step (see _enclose): (P1, P2, P2, P1) times (c, s, c, -s).
_STEP_COLS = np.array([1, 2, 2, 1])


@dataclass(frozen=True)
class _Plan:
    """The factors of a LoopSystem as index arrays (L loops padded to n factors, M unknowns, T terms).

    * ``const`` (L, n): constant angle of each factor (a known angle, or a term's offset; 0 for
      padding); ``padding`` (L, n), or None without any;
    * ``theta_slot`` (n, 1, L): 1 + the index of the factor's unknown, or 0 for a known angle or
      padding (the dummy angle 0: cos = 1, sin = 0); ``theta_rows`` (4, n, 1, L): rows of
      (cos t, sign sin t, cos t, sign sin t) in the table (cos, sin, -sin) of _enclose;
      ``const_cols`` (n, 1, L): column of each constant among the constants;
    * per term (T rows): ``term_loop``, ``term_pos``, ``term_var`` (T, 1): its loop, position,
      unknown; ``term_rows`` (T, 3): its rows of J; ``jac_u``, ``jac_f_col``, ``jac_f_row``
      (T, 6): the gather indices of the products of J = sign [u]x F (see _enclose).
    """

    n_loops: int
    n_factors: int
    const: np.ndarray
    padding: np.ndarray | None
    theta_slot: np.ndarray
    theta_rows: np.ndarray
    const_cols: np.ndarray
    term_loop: np.ndarray
    term_pos: np.ndarray
    term_var: np.ndarray
    term_rows: np.ndarray
    jac_u: np.ndarray
    jac_f_col: np.ndarray
    jac_f_row: np.ndarray


def _plan(system: LoopSystem) -> _Plan:
    n_loops = len(system.loops)
    n = max((len(loop.factors) for loop in system.loops), default=0)
    const = np.zeros((n_loops, n))
    slot = np.zeros((n_loops, n), dtype=np.intp)
    padding = np.zeros((n_loops, n), dtype=bool)
    negative = np.zeros((n_loops, n), dtype=bool)
    terms = []
    for k, (loop, indices) in enumerate(zip(system.loops, system.loop_indices)):
        if len(set(indices)) != len(indices):
            raise ValueError(f"system: loop {k + 1} has an unknown more than once ({[system.names[g] for g in indices]}); "
                             "the transversal Jacobian assumes each appears at most once per loop")
        padding[k, len(loop.factors):] = True
        n_terms = 0
        for pos, fac in enumerate(loop.factors):
            if isinstance(fac, Term):
                g = indices[n_terms]                  # loop_indices follow the order of the loop's terms
                n_terms += 1
                const[k, pos] = fac.offset
                slot[k, pos] = g + 1
                negative[k, pos] = fac.sign == -1
                terms.append((k, pos, g, fac.sign == -1))
            else:
                const[k, pos] = float(fac)
    t = np.array(terms, dtype=np.intp).reshape(-1, 4)
    n_t = len(t)
    # sign -1: swap the two products of every entry, which negates it (u_a F_b - u_b F_a)
    swap = t[:, 3].astype(bool)
    jac_u, jac_f_row = np.tile(_JAC_U, (n_t, 1)), np.tile(_JAC_F_ROW, (n_t, 1))
    jac_u[swap] = _JAC_U.reshape(-1, 2)[:, ::-1].ravel()
    jac_f_row[swap] = _JAC_F_ROW.reshape(-1, 2)[:, ::-1].ravel()
    sin_row = 1 + negative.T[:, None, :]                                    # (n, 1, L): 1 sin, 2 -sin
    theta_rows = np.stack((np.zeros_like(sin_row), sin_row, np.zeros_like(sin_row), sin_row))
    return _Plan(n_loops=n_loops, n_factors=n, const=const, padding=padding if padding.any() else None,
                 theta_slot=slot.T[:, None, :].copy(), theta_rows=theta_rows,
                 const_cols=np.arange(n_loops * n).reshape(n_loops, n).T[:, None, :].copy(),
                 term_loop=t[:, :1], term_pos=t[:, 1:2], term_var=t[:, 2:3],
                 term_rows=3 * t[:, :1] + np.arange(3), jac_u=jac_u, jac_f_col=np.tile(_JAC_F_COL, (n_t, 1)),
                 jac_f_row=jac_f_row)


def _enclose(plan: _Plan, lo: np.ndarray, hi: np.ndarray, center: np.ndarray, tol: float,
             jacobian: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """Interval arrays F (2, B, E) and J (2, B, E, M) over B boxes [lo, hi] (B, M) of unknowns.

    ``center`` (B, M): a point of each box (the expansion point of cos/sin); every constant angle
    c stands for [c - tol, c + tol]. Every F(theta), dF/dtheta(theta) for theta in box b and
    constants in their intervals lies in F[:, b], J[:, b]. See the module docstring for the math.
    """
    b, m = center.shape
    n_loops, n = plan.n_loops, plan.n_factors
    n_th = 1 + b * m
    # (cos, sin) of the dummy angle 0, of the unknowns over their boxes (radius: the larger
    # distance from the centre, rounded up; 0 exactly for a point) and of the constants over
    # c +- tol, in one batch: (2, 2, 1 + B M + L n)
    radius = np.maximum(center - lo, hi - center)
    np.nextafter(radius, math.inf, out=radius, where=radius != 0)
    cs = _cos_sin_table(np.concatenate(((0.0,), center.ravel(), plan.const.ravel())),
                        np.concatenate(((0.0,), radius.ravel(), np.full(plan.const.size, tol))))
    # phi = c + sign t: cos phi = cos c cos t - sin c (sign sin t), sin phi = sin c cos t + cos c (sign sin t)
    table = np.empty((2, 3, n_th))                                                    # cos t, sin t, -sin t
    table[:, :2] = cs[:, :, :n_th]
    np.negative(cs[::-1, 1, :n_th], out=table[:, 2])
    theta_q = table[:, plan.theta_rows, plan.theta_slot + m * np.arange(b)[:, None] * (plan.theta_slot > 0)]
    const_q = cs[:, _QUAD_CONST, plan.const_cols + n_th]                              # (2, 4, n, 1, L)
    prods = _mul(const_q, theta_q)                                                    # (2, 4, n, B, L)
    cos_phi = _sub(prods[:, 0], prods[:, 1])[..., None]                               # (2, n, B, L, 1)
    sin_phi = _add(prods[:, 2], prods[:, 3])[..., None]
    # coefficients of the prefix steps, (2, n, 4, B, L, 3): (c, s, c, -s), repeated over the 3 rows
    coef = np.empty((2, n, 4, b, n_loops, 3))
    coef[:, :, 0] = coef[:, :, 2] = cos_phi
    coef[:, :, 1] = sin_phi
    np.negative(sin_phi[::-1], out=coef[:, :, 3])
    # prefix products P_i (product of the factors before factor i); pt[:, j, ..., :] is column j
    # of P_i. P_1 = Rx(phi_0) Z has columns (0, c, s), (-1, 0, 0), (0, -s, c) (exact copies);
    # P_{i+1} = P_i Rx(phi_i) Z has columns (c P1 + s P2, -P0, c P2 - s P1).
    # u[:, i] = P_i e1 (column 0 of P_i), the axis of the joint of factor i.
    u = np.zeros((2, n, b, n_loops, 3))
    u[:, 0, ..., 0] = 1.0
    pt = np.zeros((2, 3, b, n_loops, 3))
    pt[:, 0, ..., 1:] = coef[:, 0, :2, ..., 0].transpose(0, 2, 3, 1)
    pt[:, 2, ..., 1] = coef[:, 0, 3, ..., 0]
    pt[:, 2, ..., 2] = coef[:, 0, 0, ..., 0]
    pt[:, 1, ..., 0] = -1.0
    for i in range(1, n):
        u[:, i] = pt[:, 0]
        x = _mul(coef[:, i], pt[:, _STEP_COLS])                         # (2, 4, B, L, 3)
        new = np.empty_like(pt)
        new[:, 0::2] = _add(x[:, 0::2], x[:, 1::2])                     # c P1 + s P2, c P2 - s P1
        np.negative(pt[::-1, 0], out=new[:, 1])                         # -P0 (exact)
        if plan.padding is not None and plan.padding[:, i].any():
            new[..., plan.padding[:, i], :] = pt[..., plan.padding[:, i], :]
        pt = new
    f = pt[:, _ENTRY_COLS, :, :, _ENTRY_ROWS]                            # (3, 2, B, L): advanced axes first
    f = f.transpose(1, 2, 3, 0).reshape(2, b, 3 * n_loops)
    if not jacobian:
        return f, None
    # dF/dtheta at term t = sign * [u_t]x F: entry (r, c) = sign (u[r+1] F[r+2, c] - u[r+2] F[r+1, c])
    # (indices mod 3); the plan's gather indices put the two products in the order of the sign.
    jac = np.zeros((2, b, 3 * n_loops, m))
    if len(plan.term_loop):
        ut = u[:, plan.term_pos, :, plan.term_loop, plan.jac_u]                             # (T, 6, 2, B)
        ft = pt[:, plan.jac_f_col, :, plan.term_loop, plan.jac_f_row]                       # (T, 6, 2, B)
        p = _mul(ut.transpose(2, 0, 1, 3), ft.transpose(2, 0, 1, 3))                       # (2, T, 6, B)
        vals = _sub(p[:, :, 0::2], p[:, :, 1::2])                                           # (2, T, 3, B)
        jac[:, :, plan.term_rows, plan.term_var] = vals.transpose(0, 3, 1, 2)
    return f, jac


def enclose_transversal(system: LoopSystem, boxes, angle_tolerance: float = ANGLE_TOLERANCE,
                        jacobian: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """Outward-rounded enclosures of F and J over boxes, as float interval arrays (fast, batched).

    ``boxes``: shape (M, 2) or (B, M, 2), one (lo, hi) per unknown (radians, lo <= hi). Returns
    F of shape (2, E) or (2, B, E) and J of shape (2, E, M) or (2, B, E, M) (index 0: lower
    bounds, 1: upper bounds; J is None unless ``jacobian``). Every F(theta), dF/dtheta(theta) for
    theta in a box and constant angles within ``angle_tolerance`` of their floats lies in them.
    """
    _check_system(system)
    tol = _check_tolerance(angle_tolerance)
    m = len(system.unknowns)
    arr = np.asarray(boxes, dtype=float) if _is_numeric(boxes) else None
    if arr is None or arr.ndim not in (2, 3):
        raise ValueError(f"boxes: expected shape ({m}, 2) or (B, {m}, 2) of (lo, hi) angles in radians, got {boxes!r}")
    single = arr.ndim == 2
    arr = arr[None] if single else arr
    for k in range(arr.shape[0]):
        _check_box(system, arr[k], key="boxes" if single else f"boxes[{k}]")
    lo, hi = arr[..., 0], arr[..., 1]
    if not iv_ops.rounding_environment_ok():
        raise RuntimeError("the floating-point environment is not IEEE round-to-nearest with gradual underflow "
                           "(flush-to-zero?): fast enclosures would not be rigorous; use interval_transversal_reference")
    center = np.clip(lo * 0.5 + hi * 0.5, lo, hi)
    f, j = _enclose(_plan(system), lo, hi, center, tol, jacobian)
    if single:
        return f[:, 0], (j[:, 0] if j is not None else None)
    return f, j


def interval_transversal(system: LoopSystem, box, angle_tolerance: float = ANGLE_TOLERANCE,
                         jacobian: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """Outward-rounded enclosures of F (E,) and J (E, M) over a box of passive angles.

    ``box``: shape (M, 2), one (lo, hi) per unknown in ``system.unknowns`` order (radians; lo <= hi;
    lo == hi evaluates at a point). Every constant angle c is taken as [c - angle_tolerance,
    c + angle_tolerance]. Returns object arrays of ``mpmath.iv.mpf`` intervals (J is None unless
    ``jacobian``). Every value F(theta), dF/dtheta(theta) for theta in the box lies in them.
    Computed by the fast arithmetic (:func:`enclose_transversal`); the reference is
    :func:`interval_transversal_reference`.
    """
    _check_system(system)
    tol = _check_tolerance(angle_tolerance)
    lo, hi = _check_box(system, box)
    if not iv_ops.rounding_environment_ok():
        return interval_transversal_reference(system, box, angle_tolerance, jacobian)
    f, j = _enclose(_plan(system), lo[None], hi[None], np.clip(lo * 0.5 + hi * 0.5, lo, hi)[None], tol, jacobian)
    f_arr = _to_iv(f[:, 0])
    return f_arr, (_to_iv(j[:, 0]) if j is not None else None)


def _to_iv(a: np.ndarray) -> np.ndarray:
    """Object array of iv.mpf from a float interval array (2, ...) (exact: floats are 53-bit)."""
    from mpmath import iv   # the references only: mpmath's iv context costs ~20 ms to import
    out = np.empty(a.shape[1:], dtype=object)
    for idx in np.ndindex(out.shape):
        out[idx] = iv.mpf([float(a[(0,) + idx]), float(a[(1,) + idx])])
    return out


# --------------------------------------------------------------------------------------------
# Reference enclosures (mpmath iv, one scalar at a time)
# --------------------------------------------------------------------------------------------

def _times_factor(p, c, s):
    """P Rx(phi) Z for a 3x3 nested list P: columns (c P1 + s P2, -P0, c P2 - s P1)."""
    return [[c * row[1] + s * row[2], -row[0], c * row[2] - s * row[1]] for row in p]


def _factor_times(c, s, m):
    """Rx(phi) Z M for a 3x3 nested list M: rows (-M1, c M0 - s M2, s M0 + c M2)."""
    m0, m1, m2 = m
    return [[-v for v in m1],
            [c * a - s * b for a, b in zip(m0, m2)],
            [s * a + c * b for a, b in zip(m0, m2)]]


def _evaluate(system: LoopSystem, theta: Sequence, constant, cos, sin, jacobian: bool = True):
    """F (list of E values) and J (E x M nested list) of the transversal system.

    ``theta``: one value per unknown (float or interval); ``constant(a)`` turns a float constant
    angle into the arithmetic's number; ``cos``/``sin`` of that arithmetic. Implements Eq. (2),
    F_n = prod Rx(phi_i) Z, with the derivative rule of the module docstring (reference).
    """
    n_unk = len(system.unknowns)
    f_out, j_out = [], []
    for loop, indices in zip(system.loops, system.loop_indices):
        cs, var_at = [], {}   # (cos, sin) per factor; factor position -> (global unknown, sign)
        for pos, fac in enumerate(loop.factors):
            if isinstance(fac, Term):
                g = indices[len(var_at)]          # loop_indices follow the order of the loop's terms
                phi = constant(fac.offset) + (theta[g] if fac.sign == 1 else -theta[g])
                var_at[pos] = (g, fac.sign)
            else:
                phi = constant(fac)
            cs.append((cos(phi), sin(phi)))
        eye = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
        prefix = [eye]
        for c, s in cs:
            prefix.append(_times_factor(prefix[-1], c, s))
        f_out.extend(prefix[-1][r][col] for r, col in TRANSVERSAL_ENTRIES)
        if not jacobian:
            continue
        rows = [[0] * n_unk for _ in TRANSVERSAL_ENTRIES]
        suffix = eye
        for pos in range(len(cs) - 1, -1, -1):       # suffix = S_{pos+1} on entry
            c, s = cs[pos]
            if pos in var_at:
                g, sign = var_at[pos]
                left = prefix[pos]                    # P_{pos} = product of the factors before this one
                dcols = {}                            # D v for the needed columns v of the suffix
                for col in {col for _, col in TRANSVERSAL_ENTRIES}:
                    v0, v2 = suffix[0][col], suffix[2][col]
                    dcols[col] = (-s * v0 - c * v2, c * v0 - s * v2)
                for e, (r, col) in enumerate(TRANSVERSAL_ENTRIES):
                    d1, d2 = dcols[col]
                    val = left[r][1] * d1 + left[r][2] * d2
                    rows[e][g] = val if sign == 1 else -val
            suffix = _factor_times(c, s, suffix)
        j_out.extend(rows)
    return f_out, j_out


def interval_transversal_reference(system: LoopSystem, box, angle_tolerance: float = ANGLE_TOLERANCE,
                                   jacobian: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """:func:`interval_transversal` in mpmath's ``iv`` context (the slow, obviously correct reference)."""
    from mpmath import iv
    _check_system(system)
    tol = _check_tolerance(angle_tolerance)
    lo, hi = _check_box(system, box)
    xs = [iv.mpf([a, b]) for a, b in zip(lo, hi)]
    return _interval_eval(system, xs, tol, jacobian)


def _interval_eval(system: LoopSystem, xs: list, tol: float, jacobian: bool):
    from mpmath import iv
    spread = iv.mpf([-tol, tol])

    def constant(a: float):
        return iv.mpf(a) + spread if tol else iv.mpf(a)

    f, j = _evaluate(system, xs, constant, iv.cos, iv.sin, jacobian)
    f_arr = np.empty(len(f), dtype=object)
    f_arr[:] = [iv.mpf(v) for v in f]
    if not jacobian:
        return f_arr, None
    j_arr = np.empty((len(f), len(xs)), dtype=object)
    for e, row in enumerate(j):
        j_arr[e, :] = [iv.mpf(v) for v in row]   # structural zeros (int 0) become point intervals
    return f_arr, j_arr


# --------------------------------------------------------------------------------------------
# Krawczyk test (fast)
# --------------------------------------------------------------------------------------------

def krawczyk(system: LoopSystem, theta, radius: float, angle_tolerance: float = ANGLE_TOLERANCE) -> KrawczykResult:
    """Krawczyk test on X = theta +- radius (radians) for the transversal system of ``system``.

    K(X) = y - C F(y) + (I - C J(X)) (X - y), y = theta (the midpoint of X, up to the rounding of
    its float endpoints; any y in X is valid), C = J(y)^-1 (float), all in outward-rounded interval
    arithmetic; ``theta`` is a sequence in ``system.unknowns`` order or a mapping name -> angle.
    Certified iff K(X) lies in the interior of X: then X holds exactly one solution
    (Krawczyk/Moore). Not certified, with a reason, when the system is not square, the midpoint
    Jacobian is singular (sigma_min / sigma_max < MIDPOINT_RCOND_MIN) or K(X) is not inside X
    (then ``no_solution`` tells whether K(X) misses X, proving X holds no solution).
    Fast arithmetic; :func:`krawczyk_reference` is the mpmath reference.
    """
    _check_system(system)
    y = _check_theta(system, theta)
    r = _check_radius("radius", radius)
    tol = _check_tolerance(angle_tolerance)
    if not iv_ops.rounding_environment_ok():
        return krawczyk_reference(system, y, r, tol)
    (res,) = _krawczyk_batch(system, y[None], (r,), tol, first_success=False)
    return res[0]


def certify(system: LoopSystem, theta, radii: Sequence[float] = CERTIFY_RADII,
            angle_tolerance: float = ANGLE_TOLERANCE) -> KrawczykResult:
    """Krawczyk tests at increasing radii (default CERTIFY_RADII); the first success or the last failure.

    A non-square system or a singular midpoint Jacobian fails the same way at every radius, so it
    is reported after the first try. ``radii_tried`` of the result lists the radii tested (all
    radii are evaluated in one vectorized pass; the result is as if tried in order). Fast
    arithmetic; :func:`certify_reference` is the mpmath reference.
    """
    _check_system(system)
    y = _check_theta(system, theta)
    rs = _check_radii(radii)
    tol = _check_tolerance(angle_tolerance)
    return _certify_points(system, y[None], rs, tol)[0]


def certify_many(system: LoopSystem, thetas, radii: Sequence[float] = CERTIFY_RADII,
                 angle_tolerance: float = ANGLE_TOLERANCE) -> list[KrawczykResult]:
    """:func:`certify` for several candidate points of one LoopSystem, in one vectorized pass.

    ``thetas``: a sequence of points (each a sequence in ``system.unknowns`` order or a mapping
    name -> angle) or an array of shape (P, M). Returns one KrawczykResult per point, in order,
    each equal to ``certify(system, thetas[i], radii, angle_tolerance)``.
    """
    _check_system(system)
    if isinstance(thetas, (str, bytes, Mapping)) or not isinstance(thetas, (Sequence, np.ndarray)):
        raise ValueError(f"thetas: expected a sequence of points (one angle per unknown {system.names}), got {thetas!r}")
    ys = np.array([_check_theta(system, t, key=f"thetas[{i}]") for i, t in enumerate(thetas)], dtype=float)
    rs = _check_radii(radii)
    tol = _check_tolerance(angle_tolerance)
    if len(ys) == 0:
        return []
    return _certify_points(system, ys.reshape(len(ys), len(system.unknowns)), rs, tol)


@dataclass(frozen=True)
class BoxTests:
    """Krawczyk tests of B general boxes X_b = [lo_b, hi_b] (radians) at points y_b in them.

    ``certified`` (B,): K(X_b) lies in the interior of X_b, so X_b holds exactly one solution (for
    an over-determined system, with the meaning of :class:`KrawczykResult`); ``no_solution`` (B,):
    K(X_b) misses X_b, so X_b holds none; ``krawczyk_lo``, ``krawczyk_hi`` (B, M): floats
    enclosing K(X_b) (nan where J(y_b) is singular or the system has fewer equations than
    unknowns: neither conclusion then).
    """

    certified: np.ndarray
    no_solution: np.ndarray
    krawczyk_lo: np.ndarray
    krawczyk_hi: np.ndarray


def krawczyk_many(system: LoopSystem, lo, hi, ys=None, angle_tolerance: float = ANGLE_TOLERANCE) -> BoxTests:
    """Krawczyk tests of B boxes [lo, hi] (B, M; radians, ``system.unknowns`` order) in one pass.

    ``ys`` (B, M): the point y of each test (default the box centres; it must lie in its box).
    Boxes may be thin or unequal (the Krawczyk operator is that of :func:`krawczyk`, with
    X - y enclosed by [-rho, rho], rho = max(hi - y, y - lo)). Fast arithmetic only: outside the
    IEEE default rounding environment every box is inconclusive (a refusal, never a wrong verdict).
    """
    _check_system(system)
    lo = np.asarray(lo, dtype=float)
    hi = np.asarray(hi, dtype=float)
    m = len(system.unknowns)
    if lo.ndim != 2 or lo.shape != hi.shape or lo.shape[1] != m or not np.all(np.isfinite(lo) & np.isfinite(hi)) \
            or np.any(lo > hi):
        raise ValueError(f"lo, hi: expected two (B, {m}) arrays of finite angles with lo <= hi, got shapes "
                         f"{lo.shape} and {hi.shape}")
    ys = 0.5 * (lo + hi) if ys is None else np.asarray(ys, dtype=float)
    if ys.shape != lo.shape or np.any((ys < lo) | (ys > hi)):
        raise ValueError(f"ys: expected a ({len(lo)}, {m}) array of points inside their boxes")
    tol = _check_tolerance(angle_tolerance)
    b = len(lo)
    nan = np.full((b, m), np.nan)
    if b == 0 or not iv_ops.rounding_environment_ok():
        return BoxTests(np.zeros(b, bool), np.zeros(b, bool), nan, nan.copy())
    core = _krawczyk_core(_plan(system), ys, lo[:, None], hi[:, None], tol)
    k_lo, k_hi = core["k_lo"][:, 0], core["k_hi"][:, 0]
    finite = np.all(np.isfinite(k_lo) & np.isfinite(k_hi), axis=1)
    inside = finite & np.all((k_lo > lo) & (k_hi < hi), axis=1) & (core["other"][:, 0] <= OVERDETERMINED_BOUND)
    disjoint = (finite & np.any((k_hi < lo) | (k_lo > hi), axis=1)) | core["excluded"][:, 0]
    return BoxTests(inside & ~disjoint, disjoint, k_lo, k_hi)


def _certify_points(system: LoopSystem, ys: np.ndarray, rs: list[float], tol: float) -> list[KrawczykResult]:
    if not iv_ops.rounding_environment_ok():
        return [certify_reference(system, y, rs, tol) for y in ys]
    return _krawczyk_batch(system, ys, rs, tol, first_success=True)


def _subsystem_rows(j_mid: np.ndarray) -> np.ndarray:
    """Rows (P, M) of a well-conditioned square subsystem of J(y) (P, E, M), E >= M, in ascending order.

    Greedy pivoted Gram-Schmidt on the rows (QR with column pivoting of J^T): at each step the row
    with the largest component orthogonal to the rows already taken. For E == M, all rows.
    """
    n_pts, n_eq, m = j_mid.shape
    if n_eq == m:
        return np.broadcast_to(np.arange(m), (n_pts, m)).copy()
    out = np.empty((n_pts, m), dtype=np.intp)
    for p in range(n_pts):
        rows = j_mid[p].copy()
        taken = []
        for k in range(m):
            norms = np.einsum("ij,ij->i", rows, rows)
            norms[taken] = -1.0
            i = int(np.argmax(norms))
            taken.append(i)
            q = rows[i] / math.sqrt(norms[i]) if norms[i] > 0 else rows[i]
            rows -= np.outer(rows @ q, q)
        out[p] = np.sort(taken)
    return out


def _excludes_zero(f_all, j_all, ys, x_lo, x_hi, j_mid) -> np.ndarray:
    """(P, R) bool: 0 is not in F(X), shown for some row of F(X) or of U^T F(X) (centred form).

    ``f_all``, ``j_all``: the enclosures of _krawczyk_core (P points then P * R boxes). F(X) is
    the natural enclosure; U^T F(X) is enclosed by U^T F(y) + |U^T J(X)| [-rho, rho] (mean value
    theorem; rho as in :func:`_krawczyk_operator`), with U from the SVD of the float J(y): any
    matrix gives a valid test, an orthogonal one rotates F so that the rows along the regular
    directions of J are not swamped by a nearly singular one (a Krawczyk preconditioner J(y)^-1
    amplifies the variation of J over X by 1 / sigma_min in every row). No root in X when either
    excludes 0.
    """
    n_pts, m = ys.shape
    n_rad = x_lo.shape[1]
    f_y = f_all[:, :n_pts]
    f_x = f_all[:, n_pts:].reshape(2, n_pts, n_rad, -1)
    natural = np.any((f_x[0] > 0) | (f_x[1] < 0), axis=-1)
    if m == 0:
        return natural
    j_x = j_all[:, n_pts:].reshape(2, n_pts, n_rad, f_y.shape[-1], m)
    ut = np.swapaxes(np.linalg.svd(j_mid)[0], -1, -2)                                 # (P, E, E)
    cf = iv_ops.fmatmul(ut, f_y[..., None])[..., 0]                                   # (2, P, E)
    cj = iv_ops.fmatmul(ut[:, None], j_x)                                             # (2, P, R, E, M)
    rho = np.maximum(np.nextafter(x_hi - ys[:, None], math.inf), np.nextafter(ys[:, None] - x_lo, math.inf))
    spread = iv_ops.sum_up(np.nextafter(iv_ops.magnitude(cj) * rho[:, :, None, :], math.inf), axis=-1)
    g = iv_ops.add(cf[:, :, None, :], np.stack((-spread, spread)))                   # (2, P, R, E)
    return natural | np.any((g[0] > 0) | (g[1] < 0), axis=-1)


def _krawczyk_core(plan: _Plan, ys: np.ndarray, x_lo: np.ndarray, x_hi: np.ndarray, tol: float) -> dict:
    """Krawczyk operators of the boxes X = [x_lo, x_hi] (P, R, M) around the points ys (P, M).

    Returns arrays: ``residual`` (P,) bounds max |F(y)|; ``sv`` (P, min(E, M)) singular values of
    the float J(y); ``regular`` (P,); ``rows`` (P, M) the equations of the square (sub)system (all
    of them when E == M; see :func:`_subsystem_rows` when E > M; None when E < M); ``k_lo``,
    ``k_hi`` (P, R, M) enclose K(X) of that subsystem (nan where not computed); ``other`` (P, R)
    bounds |F| of the equations left out of the subsystem over X (0 when square).
    """
    n_pts, m = ys.shape
    n_rad = x_lo.shape[1]
    n_eq = 3 * plan.n_loops
    # one evaluation: the P points (F(y), J(y)) then the P * R boxes (F(X), J(X))
    lo = np.concatenate((ys, x_lo.reshape(-1, m)))
    hi = np.concatenate((ys, x_hi.reshape(-1, m)))
    center = np.concatenate((ys, np.repeat(ys, n_rad, axis=0)))
    f_all, j_all = _enclose(plan, lo, hi, center, tol, jacobian=True)
    f_y = f_all[:, :n_pts]                                           # (2, P, E)
    residual = iv_ops.magnitude(f_y).max(axis=-1, initial=0.0)
    j_mid = 0.5 * (j_all[0, :n_pts] + j_all[1, :n_pts])              # a float J(y) (any C is valid)
    out = dict(residual=residual, rows=None, k_lo=np.full((n_pts, n_rad, m), np.nan),
               k_hi=np.full((n_pts, n_rad, m), np.nan), other=np.zeros((n_pts, n_rad)),
               excluded=_excludes_zero(f_all, j_all, ys, x_lo, x_hi, j_mid))
    if n_eq < m or m == 0:
        out["sv"] = np.linalg.svd(j_mid, compute_uv=False) if j_mid.size else np.zeros((n_pts, 0))
        out["regular"] = np.zeros(n_pts, bool)
        return out
    rows = _subsystem_rows(j_mid)
    out["rows"] = rows
    pick = np.arange(n_pts)[:, None]
    j_sq = j_mid[pick, rows]                                         # (P, M, M)
    svd_u, sv, svd_vt = np.linalg.svd(j_sq)
    regular = sv[:, -1] > MIDPOINT_RCOND_MIN * sv[:, 0]
    out.update(sv=sv, regular=regular)
    if n_eq > m:
        left = np.ones((n_pts, n_eq), bool)
        left[pick, rows] = False
        f_x = iv_ops.magnitude(f_all[:, n_pts:]).reshape(n_pts, n_rad, n_eq)
        out["other"] = np.where(left[:, None, :], f_x, 0.0).max(axis=-1)
    if regular.any():
        ok = np.flatnonzero(regular)
        j_x = j_all[:, n_pts:].reshape(2, n_pts, n_rad, n_eq, m)[:, ok]             # (2, P', R, E, M)
        sel = rows[ok][None, :, None, :, None]
        j_x = np.take_along_axis(j_x, np.broadcast_to(sel, j_x.shape[:3] + (m, m)), axis=3)
        f_sq = np.take_along_axis(f_y[:, ok], np.broadcast_to(rows[ok][None], (2, len(ok), m)), axis=2)
        # C = J(y)^-1 = V S^-1 U^T (floats; any C is valid, a good one makes K small)
        c = np.matmul(np.swapaxes(svd_vt[ok], -1, -2) / sv[ok, None, :], np.swapaxes(svd_u[ok], -1, -2))
        out["k_lo"][ok], out["k_hi"][ok] = _krawczyk_operator(ys[ok], x_lo[ok], x_hi[ok], f_sq, j_x, c)
    return out


def _krawczyk_batch(system: LoopSystem, ys: np.ndarray, rs: Sequence[float], tol: float,
                    first_success: bool) -> list:
    """Krawczyk tests of every point ys[p] (P, M) at every radius rs[k] in one vectorized pass.

    ``first_success``: return, per point, the result of certify (first success, or the first
    non-square/singular failure, or the last failure; radii_tried set); else a list of results per
    radius per point.
    """
    plan = _plan(system)
    n_pts, m = ys.shape
    n_eq = 3 * len(system.loops)
    radii = np.asarray(rs, dtype=float)
    x_lo = ys[:, None, :] - radii[None, :, None]                     # (P, R, M), the floats of X
    x_hi = ys[:, None, :] + radii[None, :, None]
    core = _krawczyk_core(plan, ys, x_lo, x_hi, tol)
    out = []
    for p in range(n_pts):
        base = dict(names=system.names, center=tuple(float(v) for v in ys[p]), residual=float(core["residual"][p]),
                    singular_values=tuple(float(v) for v in core["sv"][p]), n_equations=n_eq, n_unknowns=m,
                    subsystem_rows=None if core["rows"] is None or n_eq == m else tuple(int(i) for i in core["rows"][p]),
                    angle_tolerance=tol)
        results = []
        for ri, r in enumerate(rs):
            k = None if not core["regular"][p] else (core["k_lo"][p, ri], core["k_hi"][p, ri])
            results.append(_outcome(base, r, x_lo[p, ri], x_hi[p, ri], core["rows"] is not None,
                                    bool(core["regular"][p]), k, float(core["other"][p, ri])))
            if first_success and (results[-1].certified or results[-1].krawczyk_box is None):
                break
        out.append(replace(results[-1], radii_tried=tuple(rs[:len(results)])) if first_success else results)
    return out


def _krawczyk_operator(y, x_lo, x_hi, f_y, j_x, c) -> tuple[np.ndarray, np.ndarray]:
    """Floats (lo, hi), each (P, R, M), enclosing K(X) = y - C F(y) + (I - C J(X)) (X - y).

    ``y`` (P, M); X = [x_lo, x_hi] (P, R, M); ``f_y`` (2, P, M) encloses F(y); ``j_x``
    (2, P, R, M, M) encloses J over X; ``c`` (P, M, M): any float matrices. X - y is enclosed by
    [-rho, rho] (rho = max(x_hi - y, y - x_lo) rounded up), so the last term lies in [-s, s] with
    s = |I - C J(X)| rho (magnitudes, summed rounding up): the result contains the exact interval
    evaluation of the expression, which keeps both conclusions of the test valid.
    """
    cf = iv_ops.fmatmul(c, f_y[..., None])[..., 0]                                 # C F(y)
    base = iv_ops.sub(iv_ops.point(y), cf)                                         # y - C F(y)
    cj = iv_ops.fmatmul(c[:, None], j_x)                                           # C J(X)
    a = iv_ops.sub(iv_ops.point(np.eye(y.shape[-1])), cj)                          # I - C J(X)
    rho = np.maximum(np.nextafter(x_hi - y[:, None], math.inf), np.nextafter(y[:, None] - x_lo, math.inf))
    spread = iv_ops.sum_up(np.nextafter(iv_ops.magnitude(a) * rho[:, :, None, :], math.inf), axis=-1)
    k = iv_ops.add(base[:, :, None], np.stack((-spread, spread)))                  # (2, P, R, M)
    return k[0], k[1]


def _outcome(base: dict, r: float, x_lo, x_hi, square: bool, regular: bool, k, other: float = 0.0) -> KrawczykResult:
    """The KrawczykResult of one box X = [x_lo, x_hi] from K(X) = (k_lo, k_hi) (floats enclosing it).

    ``square``: a square (sub)system could be formed (False when there are fewer equations than
    unknowns); ``other``: bound of the equations left out of the subsystem over X.
    """
    names = base["names"]
    sv = base["singular_values"]
    common = dict(base, radius=r, box=tuple((float(a), float(b)) for a, b in zip(x_lo, x_hi)),
                  krawczyk_box=None, contraction=math.nan, no_solution=False, radii_tried=(r,),
                  other_bound=float(other))
    if not square:
        return KrawczykResult(certified=False, reason=f"not certified: {base['n_equations']} equations, "
                                                      f"{base['n_unknowns']} unknowns (not isolated roots)", **common)
    if not regular:
        smin = sv[-1] if sv else 0.0
        return KrawczykResult(
            certified=False,
            reason=(f"not certified: singular midpoint Jacobian (smallest singular value {smin:.3g}, "
                    f"{smin / sv[0] if sv and sv[0] else 0.0:.3g} of the largest, below {MIDPOINT_RCOND_MIN:g})"),
            **common)
    k_lo, k_hi = np.asarray(k[0], dtype=float), np.asarray(k[1], dtype=float)
    x_lo, x_hi = np.asarray(x_lo, dtype=float), np.asarray(x_hi, dtype=float)
    finite = bool(np.all(np.isfinite(k_lo)) and np.all(np.isfinite(k_hi)))
    inside = finite and bool(np.all((k_lo > x_lo) & (k_hi < x_hi)))
    disjoint = finite and bool(np.any((k_hi < x_lo) | (k_lo > x_hi)))
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        ratio = float(np.max((k_hi - k_lo) / (x_hi - x_lo)))
    common.update(krawczyk_box=tuple((float(a), float(b)) for a, b in zip(k_lo, k_hi)), contraction=ratio,
                  no_solution=disjoint)
    if inside and other > OVERDETERMINED_BOUND and not disjoint:
        return KrawczykResult(certified=False, reason=(
            f"not certified at radius {r:g}: the square subsystem has one root in X but the other "
            f"equations reach {other:.3g} there (above {OVERDETERMINED_BOUND:g})"), **common)
    if inside:
        return KrawczykResult(certified=True, reason="", **common)
    if not finite:
        why = "K(X) is not finite"
    elif disjoint:
        why = "K(X) does not meet X, so X holds no solution"
    else:
        excess = np.maximum(x_lo - k_lo, k_hi - x_hi)
        worst = int(np.argmax(excess))
        why = (f"K(X) is not inside X (contraction {ratio:.3g}; {names[worst]!r} leaves X by "
               f"{float(excess[worst]):.3g} rad)")
    return KrawczykResult(certified=False, reason=f"not certified at radius {r:g}: {why}", **common)


# --------------------------------------------------------------------------------------------
# Krawczyk test (reference, mpmath iv)
# --------------------------------------------------------------------------------------------

def krawczyk_reference(system: LoopSystem, theta, radius: float,
                       angle_tolerance: float = ANGLE_TOLERANCE) -> KrawczykResult:
    """:func:`krawczyk` in mpmath's ``iv`` context, one scalar at a time (the slow, obviously correct reference)."""
    from mpmath import iv
    _check_system(system)
    y = _check_theta(system, theta)
    r = _check_radius("radius", radius)
    tol = _check_tolerance(angle_tolerance)
    n_unk, n_eq = len(y), 3 * len(system.loops)
    lo, hi = y - r, y + r
    f_y, _ = _interval_eval(system, [iv.mpf(v) for v in y], tol, jacobian=False)
    residual = max((_magnitude(v) for v in f_y), default=0.0)
    _, j_float = transversal_equations(system, y)
    square = n_eq >= n_unk > 0
    rows = _subsystem_rows(j_float[None])[0] if square else np.arange(0)
    j_sq = j_float[rows] if square else j_float
    sv = tuple(float(v) for v in np.linalg.svd(j_sq, compute_uv=False)) if j_sq.size else ()
    base = dict(names=system.names, center=tuple(float(v) for v in y), residual=residual, singular_values=sv,
                n_equations=n_eq, n_unknowns=n_unk,
                subsystem_rows=tuple(int(i) for i in rows) if square and n_eq > n_unk else None, angle_tolerance=tol)
    regular = bool(sv) and sv[-1] > MIDPOINT_RCOND_MIN * sv[0]
    if not (square and regular):
        return _outcome(base, r, lo, hi, square, regular, None)
    c_float = np.linalg.inv(j_sq)
    xs = [iv.mpf([a, b]) for a, b in zip(lo, hi)]
    f_box, j_box = _interval_eval(system, xs, tol, jacobian=True)
    other = max((_magnitude(f_box[i]) for i in range(n_eq) if i not in set(rows.tolist())), default=0.0)
    f_y = [f_y[i] for i in rows]
    j_box = j_box[rows]
    c_iv = [[iv.mpf(float(v)) for v in row] for row in c_float]
    y_iv = [iv.mpf(v) for v in y]
    dx = [x - yv for x, yv in zip(xs, y_iv)]
    k_box = []
    for i in range(n_unk):
        acc = y_iv[i] - _dot(c_iv[i], f_y)
        for j in range(n_unk):
            cj = _dot(c_iv[i], j_box[:, j])
            a_ij = (1 - cj) if i == j else -cj       # (I - C J(X))_ij
            acc = acc + a_ij * dx[j]
        k_box.append(acc)
    k_float = [_outward(k) for k in k_box]           # floats enclosing K(X) (exact at iv's 53 bits)
    return _outcome(base, r, lo, hi, True, True, ([a for a, _ in k_float], [b for _, b in k_float]), other)


def certify_reference(system: LoopSystem, theta, radii: Sequence[float] = CERTIFY_RADII,
                      angle_tolerance: float = ANGLE_TOLERANCE) -> KrawczykResult:
    """:func:`certify` with :func:`krawczyk_reference`: radii tried one by one, in order."""
    rs = _check_radii(radii)
    tried = []
    for r in rs:
        res = krawczyk_reference(system, theta, r, angle_tolerance)
        tried.append(r)
        if res.certified or res.krawczyk_box is None:
            break
    return replace(res, radii_tried=tuple(tried))


# --------------------------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------------------------

def _dot(row, col):
    from mpmath import iv
    acc = iv.mpf(0)
    for a, b in zip(row, col):
        acc = acc + a * b
    return acc


def _magnitude(v) -> float:
    """An upper bound (float) on |v| for an interval v."""
    from mpmath import mpf
    m = max(abs(mpf(v.a)), abs(mpf(v.b)))
    out = float(m)
    return out if mpf(out) >= m else math.nextafter(out, math.inf)


def _outward(v) -> tuple[float, float]:
    """Float (lo, hi) enclosing the interval v (exact at iv's default 53-bit precision)."""
    from mpmath import mpf
    a, b = mpf(v.a), mpf(v.b)
    lo, hi = float(a), float(b)
    if mpf(lo) > a:
        lo = math.nextafter(lo, -math.inf)
    if mpf(hi) < b:
        hi = math.nextafter(hi, math.inf)
    return lo, hi


def _is_numeric(value) -> bool:
    try:
        np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return False
    return True


def _check_system(system) -> None:
    if not isinstance(system, LoopSystem):
        raise ValueError(f"system: expected a LoopSystem (mechanism.loop_system(...)), got {type(system).__name__}")


def _check_theta(system: LoopSystem, theta, key: str = "theta") -> np.ndarray:
    names = system.names
    if isinstance(theta, Mapping):
        missing = [n for n in names if n not in theta]
        if missing:
            raise ValueError(f"{key}: missing angle(s) for {missing}; expected one per unknown {names}")
        values = [theta[n] for n in names]
    elif isinstance(theta, (str, bytes)):
        raise ValueError(f"{key}: expected {len(names)} passive angles (radians) {names}, got {theta!r}")
    else:
        values = theta
    try:
        y = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{key}: expected {len(names)} real angles (radians) {names}, got {theta!r}") from None
    if y.shape != (len(names),):
        raise ValueError(f"{key}: expected shape ({len(names)},) (one angle per unknown {names}), got {y.shape}")
    if not np.all(np.isfinite(y)):
        raise ValueError(f"{key}: expected finite angles (radians), got {theta!r}")
    return y


def _check_radii(radii) -> list[float]:
    if isinstance(radii, (str, bytes)) or not isinstance(radii, (Sequence, np.ndarray)) or len(radii) == 0:
        raise ValueError(f"radii: expected a non-empty sequence of positive radii (radians), got {radii!r}")
    rs = [_check_radius(f"radii[{i}]", v) for i, v in enumerate(radii)]
    if any(b <= a for a, b in zip(rs, rs[1:])):
        raise ValueError(f"radii: expected strictly increasing radii, got {list(radii)!r}")
    return rs


def _check_radius(key: str, value) -> float:
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{key}: expected a positive radius (radians), got {value!r}")
    try:
        r = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{key}: expected a positive radius (radians), got {value!r}") from None
    if not (math.isfinite(r) and 0.0 < r < math.pi):
        raise ValueError(f"{key}: expected a radius in (0, pi) radians, got {value!r}")
    return r


def _check_tolerance(value) -> float:
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"angle_tolerance: expected a non-negative angle (radians), got {value!r}")
    try:
        t = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"angle_tolerance: expected a non-negative angle (radians), got {value!r}") from None
    if not (math.isfinite(t) and 0.0 <= t < 1e-3):
        raise ValueError(f"angle_tolerance: expected a value in [0, 1e-3) radians, got {value!r}")
    return t


def _check_box(system: LoopSystem, box, key: str = "box") -> tuple[np.ndarray, np.ndarray]:
    m = len(system.unknowns)
    try:
        arr = np.asarray(box, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{key}: expected shape ({m}, 2) of (lo, hi) angles in radians, got {box!r}") from None
    if arr.shape != (m, 2):
        raise ValueError(f"{key}: expected shape ({m}, 2) (one (lo, hi) per unknown {system.names}), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{key}: expected finite bounds (radians)")
    if np.any(arr[:, 0] > arr[:, 1]):
        bad = [system.names[k] for k in np.flatnonzero(arr[:, 0] > arr[:, 1])]
        raise ValueError(f"{key}: expected lo <= hi, got lo > hi for {bad}")
    return arr[:, 0], arr[:, 1]
