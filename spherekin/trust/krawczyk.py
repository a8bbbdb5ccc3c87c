"""Certification of solutions: a Krawczyk test in outward-rounded interval arithmetic.

The system certified is the transversal closure system of :mod:`spherekin.trust.transversal` (three
entries of F_n per loop, in the passive angles; simple roots where the mechanism is regular).
Krawczyk's test (Krawczyk 1969; Moore 1977; Rump 1983): for a box X, a point y in X, any real
matrix C and an enclosure J(X) of the Jacobian over X,

    K(X) = y - C F(y) + (I - C J(X)) (X - y).

Every zero of F in X lies in K(X); if K(X) lies in the interior of X (and C is nonsingular) then X
holds exactly one zero and J is nonsingular on X. All of K is evaluated in outward-rounded
interval arithmetic (the rounding of every +, *, sin and cos is enclosed), F(y) as an interval at
the point y. C = J(y)^-1 is an ordinary float inverse (any C is valid; a good one makes K small).

Two implementations, with the same inputs and results:

* fast (:func:`krawczyk`, :func:`certify`, :func:`certify_many`, :func:`krawczyk_many`): the
  enclosures of :func:`spherekin.trust.transversal.enclose`, vectorized over points, radii and boxes;
  :func:`certify_stacked` and :func:`krawczyk_stacked` do the same for the points and boxes of several
  systems of one mechanism at once (a :class:`~spherekin.trust.transversal.SystemStack`: one
  mechanism at the inputs of a chunk), each tested in its own system only.
  K uses (I - C J(X)) (X - y) in [-s, s], s = |I - C J(X)| rho with X - y in [-rho, rho] (a
  superset of the usual evaluation: both conclusions of the test stay valid). Outside the IEEE
  default floating-point environment (:func:`spherekin.core.intervals.rounding_environment_ok`) the
  fast functions use the reference.
* reference (:func:`krawczyk_reference`, :func:`certify_reference`): mpmath's ``iv`` context for
  every operation (slow, obviously correct).

Departures from the paper: the paper does not certify its solutions (subdivision returns small
boxes, not proofs); this module is an addition. Constant angles are intervals of half-width
``angle_tolerance`` (:data:`spherekin.trust.transversal.ANGLE_TOLERANCE`): a certificate is about the
mechanism, not one rounding of it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Mapping, Sequence

import numpy as np

from ..core import intervals as iv_ops
from ..core.krawczyk import INTERVALS, krawczyk_operator
from ..mechanism import LoopSystem
from .transversal import (ANGLE_TOLERANCE, SystemStack, TransversalPlan, check_system, check_theta, check_tolerance,
                          enclose, interval_eval, plan_of, transversal_equations)

__all__ = [
    "FINE_ANGLE_TOLERANCE",
    "CERTIFY_RADII",
    "MIDPOINT_RCOND_MIN",
    "OVERDETERMINED_BOUND",
    "KrawczykResult",
    "BoxTests",
    "krawczyk",
    "krawczyk_many",
    "krawczyk_stacked",
    "krawczyk_reference",
    "certify",
    "certify_many",
    "certify_stacked",
    "certify_reference",
    "check_radii",
]

#: The tighter angle tolerance (radians) :mod:`spherekin.trust.solutions` retries with when a test at
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
    check_system(system)
    y = check_theta(system, theta)
    r = _check_radius("radius", radius)
    tol = check_tolerance(angle_tolerance)
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
    check_system(system)
    y = check_theta(system, theta)
    rs = check_radii(radii)
    tol = check_tolerance(angle_tolerance)
    return _certify_points(system, y[None], rs, tol)[0]


def certify_many(system: LoopSystem, thetas, radii: Sequence[float] = CERTIFY_RADII,
                 angle_tolerance: float = ANGLE_TOLERANCE) -> list[KrawczykResult]:
    """:func:`certify` for several candidate points of one LoopSystem, in one vectorized pass.

    ``thetas``: a sequence of points (each a sequence in ``system.unknowns`` order or a mapping
    name -> angle) or an array of shape (P, M). Returns one KrawczykResult per point, in order,
    each equal to ``certify(system, thetas[i], radii, angle_tolerance)``.
    """
    check_system(system)
    if isinstance(thetas, (str, bytes, Mapping)) or not isinstance(thetas, (Sequence, np.ndarray)):
        raise ValueError(f"thetas: expected a sequence of points (one angle per unknown {system.names}), got {thetas!r}")
    ys = np.array([check_theta(system, t, key=f"thetas[{i}]") for i, t in enumerate(thetas)], dtype=float)
    rs = check_radii(radii)
    tol = check_tolerance(angle_tolerance)
    if len(ys) == 0:
        return []
    return _certify_points(system, ys.reshape(len(ys), len(system.unknowns)), rs, tol)


def certify_stacked(stack: SystemStack, which, thetas, radii: Sequence[float] = CERTIFY_RADII,
                    angle_tolerance: float = ANGLE_TOLERANCE) -> list[KrawczykResult]:
    """:func:`certify_many` for points of several systems of one mechanism (a
    :class:`~spherekin.trust.transversal.SystemStack`, e.g. one mechanism at the K inputs of a chunk),
    in one vectorized pass: point i (``thetas`` (P, M), radians) is tested in
    ``stack.systems[which[i]]`` only, and its result equals ``certify_many(stack.systems[which[i]],
    [thetas[i]], radii, angle_tolerance)[0]``.
    """
    ys = np.asarray(thetas, dtype=float)
    m = len(stack.systems[0].unknowns)
    if ys.ndim != 2 or ys.shape[1] != m or not np.all(np.isfinite(ys)):
        raise ValueError(f"thetas: expected a (P, {m}) array of finite angles (radians), got shape {ys.shape}")
    w = _check_which(stack, which, len(ys))
    rs = check_radii(radii)
    tol = check_tolerance(angle_tolerance)
    if not len(ys):
        return []
    return _certify_points(stack.systems[0], ys, rs, tol, stack, w)


class BoxTests:
    """Krawczyk tests of B general boxes X_b = [lo_b, hi_b] (radians) at points y_b in them.

    ``certified`` (B,): K(X_b) lies in the interior of X_b, so X_b holds exactly one solution (for
    an over-determined system, with the meaning of :class:`KrawczykResult`); ``no_solution`` (B,):
    K(X_b) misses X_b, so X_b holds none; ``krawczyk_lo``, ``krawczyk_hi`` (B, M): floats
    enclosing K(X_b) (nan where J(y_b) is singular or the system has fewer equations than
    unknowns: neither conclusion then).
    """

    __slots__ = ("certified", "no_solution", "krawczyk_lo", "krawczyk_hi")

    certified: np.ndarray
    no_solution: np.ndarray
    krawczyk_lo: np.ndarray
    krawczyk_hi: np.ndarray

    def __init__(self, certified, no_solution, krawczyk_lo, krawczyk_hi):
        self.certified = certified
        self.no_solution = no_solution
        self.krawczyk_lo = krawczyk_lo
        self.krawczyk_hi = krawczyk_hi


def krawczyk_many(system: LoopSystem, lo, hi, ys=None, angle_tolerance: float = ANGLE_TOLERANCE) -> BoxTests:
    """Krawczyk tests of B boxes [lo, hi] (B, M; radians, ``system.unknowns`` order) in one pass.

    ``ys`` (B, M): the point y of each test (default the box centres; it must lie in its box).
    Boxes may be thin or unequal (the Krawczyk operator is that of :func:`krawczyk`, with
    X - y enclosed by [-rho, rho], rho = max(hi - y, y - lo)). Fast arithmetic only: outside the
    IEEE default rounding environment every box is inconclusive (a refusal, never a wrong verdict).
    """
    check_system(system)
    return _box_tests(system, None, None, lo, hi, ys, angle_tolerance)


def krawczyk_stacked(stack: SystemStack, which, lo, hi, ys=None, angle_tolerance: float = ANGLE_TOLERANCE) -> BoxTests:
    """:func:`krawczyk_many` for boxes of several systems of one mechanism (a
    :class:`~spherekin.trust.transversal.SystemStack`): box b is tested in ``stack.systems[which[b]]``
    (``which`` (B,) ints); each verdict is the one krawczyk_many gives for that box in its own system."""
    return _box_tests(stack.systems[0], stack, _check_which(stack, which, len(lo)), lo, hi, ys, angle_tolerance)


def _check_which(stack: SystemStack, which, n: int) -> np.ndarray:
    """``which`` as an int array (n,) of indices into ``stack.systems``; ValueError naming it otherwise."""
    w = np.asarray(which)
    if w.shape != (n,) or (n and (w.dtype.kind not in "iu" or w.min() < 0 or w.max() >= len(stack.systems))):
        raise ValueError(f"which: expected {n} indices of systems in [0, {len(stack.systems)}), got {which!r}")
    return w.astype(np.intp)


def _box_tests(system: LoopSystem, stack: SystemStack | None, which, lo, hi, ys, angle_tolerance) -> BoxTests:
    """:func:`krawczyk_many` (``stack`` None) or :func:`krawczyk_stacked`: one implementation."""
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
    tol = check_tolerance(angle_tolerance)
    b = len(lo)
    nan = np.full((b, m), np.nan)
    if b == 0 or not iv_ops.rounding_environment_ok():
        return BoxTests(np.zeros(b, bool), np.zeros(b, bool), nan, nan.copy())
    plan = plan_of(system) if stack is None else stack.plan
    core = _krawczyk_core(plan, ys, lo[:, None], hi[:, None], tol, None if stack is None else stack.consts, which)
    k_lo, k_hi = core["k_lo"][:, 0], core["k_hi"][:, 0]
    _, inside, disjoint, _ = _verdicts(k_lo, k_hi, lo, hi)
    inside &= core["other"][:, 0] <= OVERDETERMINED_BOUND
    disjoint |= core["excluded"][:, 0]
    return BoxTests(inside & ~disjoint, disjoint, k_lo, k_hi)


def _certify_points(system: LoopSystem, ys: np.ndarray, rs: list[float], tol: float,
                    stack: SystemStack | None = None, which: np.ndarray | None = None) -> list[KrawczykResult]:
    if not iv_ops.rounding_environment_ok():
        return [certify_reference(system if stack is None else stack.systems[w], y, rs, tol)
                for y, w in zip(ys, np.zeros(len(ys), int) if which is None else which)]
    return _krawczyk_batch(system, ys, rs, tol, first_success=True, stack=stack, which=which)


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


def _krawczyk_core(plan: TransversalPlan, ys: np.ndarray, x_lo: np.ndarray, x_hi: np.ndarray, tol: float,
                   consts: np.ndarray | None = None, which: np.ndarray | None = None) -> dict:
    """Krawczyk operators of the boxes X = [x_lo, x_hi] (P, R, M) around the points ys (P, M).

    ``consts`` (K, L, n), ``which`` (P,): point p is of the system with constants consts[which[p]]
    (a :class:`~spherekin.trust.transversal.SystemStack`; default: the plan's own system for all).

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
    of_box = None if which is None else np.concatenate((which, np.repeat(which, n_rad)))
    f_all, j_all = enclose(plan, lo, hi, center, tol, jacobian=True, consts=consts, which=of_box)
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
                    first_success: bool, stack: SystemStack | None = None, which: np.ndarray | None = None) -> list:
    """Krawczyk tests of every point ys[p] (P, M) at every radius rs[k] in one vectorized pass.

    ``first_success``: return, per point, the result of certify (first success, or the first
    non-square/singular failure, or the last failure; radii_tried set); else a list of results per
    radius per point. With ``first_success``, every point is tested at the first radius, and only
    the points that fail there (with K(X) computed) at the others: a test's verdict depends on its
    point and radius alone, so the results are those of the one pass over every radius, and a
    regular root (certified at the first radius) costs one box instead of len(rs).
    """
    if first_success and len(rs) > 1:
        out = [res for (res,) in _krawczyk_batch(system, ys, rs[:1], tol, False, stack, which)]   # radii_tried (rs[0],)
        again = [p for p, res in enumerate(out) if not (res.certified or res.krawczyk_box is None)]
        if again:
            rest = _krawczyk_batch(system, ys[again], rs[1:], tol, True, stack, None if which is None else which[again])
            for p, res in zip(again, rest):
                out[p] = replace(res, radii_tried=(rs[0], *res.radii_tried))
        return out
    tplan = plan_of(system) if stack is None else stack.plan
    n_pts, m = ys.shape
    n_eq = 3 * len(system.loops)
    radii = np.asarray(rs, dtype=float)
    x_lo = ys[:, None, :] - radii[None, :, None]                     # (P, R, M), the floats of X
    x_hi = ys[:, None, :] + radii[None, :, None]
    core = _krawczyk_core(tplan, ys, x_lo, x_hi, tol, None if stack is None else stack.consts, which)
    square, regular = core["rows"] is not None, core["regular"]
    verdicts = _verdicts(core["k_lo"], core["k_hi"], x_lo, x_hi)      # (P, R) each, all points at once
    # Python floats and tuples for the results, converted once for the whole batch
    boxes, k_lo, k_hi = np.stack((x_lo, x_hi), axis=-1).tolist(), core["k_lo"].tolist(), core["k_hi"].tolist()
    verdicts = [v.tolist() for v in verdicts]
    centers, residuals, svs = ys.tolist(), core["residual"].tolist(), core["sv"].tolist()
    others = core["other"].tolist()
    rows = None if core["rows"] is None or n_eq == m else core["rows"].tolist()
    out = []
    for p in range(n_pts):
        base = dict(names=system.names, center=tuple(centers[p]), residual=residuals[p],
                    singular_values=tuple(svs[p]), n_equations=n_eq, n_unknowns=m,
                    subsystem_rows=None if rows is None else tuple(rows[p]), angle_tolerance=tol)
        results = []
        for ri, r in enumerate(rs):
            k = (k_lo[p][ri], k_hi[p][ri]) if regular[p] else None
            verdict = tuple(v[p][ri] for v in verdicts) if regular[p] else None
            results.append(_outcome(base, r, tuple(map(tuple, boxes[p][ri])), square, bool(regular[p]), k,
                                    others[p][ri], verdict))
            if first_success and (results[-1].certified or results[-1].krawczyk_box is None):
                break
        if not first_success:
            out.append(results)
        else:
            out.append(results[-1] if len(results) == 1 else replace(results[-1], radii_tried=tuple(rs[:len(results)])))
    return out


def _verdicts(k_lo, k_hi, x_lo, x_hi) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(finite, inside, disjoint, contraction) of K(X) = [k_lo, k_hi] against X = [x_lo, x_hi], any
    leading shape (the last axis the unknowns): K(X) finite; in the interior of X; missing X;
    max_k width(K_k) / width(X_k) (nan where K(X) is not)."""
    finite = np.all(np.isfinite(k_lo) & np.isfinite(k_hi), axis=-1)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        inside = finite & np.all((k_lo > x_lo) & (k_hi < x_hi), axis=-1)
        disjoint = finite & np.any((k_hi < x_lo) | (k_lo > x_hi), axis=-1)
        ratio = np.max((k_hi - k_lo) / (x_hi - x_lo), axis=-1, initial=-math.inf)   # -inf: no unknown
    return finite, inside, disjoint, ratio


def _krawczyk_operator(y, x_lo, x_hi, f_y, j_x, c) -> tuple[np.ndarray, np.ndarray]:
    """Floats (lo, hi), each (P, R, M), enclosing K(X) = y - C F(y) + (I - C J(X)) (X - y)
    (:func:`spherekin.core.krawczyk.krawczyk_operator` in outward-rounded intervals).

    ``y`` (P, M); X = [x_lo, x_hi] (P, R, M); ``f_y`` (2, P, M) encloses F(y); ``j_x``
    (2, P, R, M, M) encloses J over X; ``c`` (P, M, M): any float matrices. X - y is enclosed by
    [-rho, rho] (rho = max(x_hi - y, y - x_lo) rounded up).
    """
    rho = np.maximum(np.nextafter(x_hi - y[:, None], math.inf), np.nextafter(y[:, None] - x_lo, math.inf))
    n_rad = x_lo.shape[1]
    k = krawczyk_operator(INTERVALS, np.repeat(y[:, None], n_rad, axis=1), np.repeat(f_y[:, :, None], n_rad, axis=2),
                 np.repeat(c[:, None], n_rad, axis=1), j_x, iv_ops.from_bounds(-rho, rho))
    return k[0], k[1]


def _outcome(base: dict, r: float, box: tuple, square: bool, regular: bool, k, other: float = 0.0,
             verdict: tuple | None = None) -> KrawczykResult:
    """The KrawczykResult of one box X (``box``: one (lo, hi) pair of floats per unknown) from
    K(X) = (k_lo, k_hi) (sequences of floats enclosing it; None when not computed).

    ``square``: a square (sub)system could be formed (False when there are fewer equations than
    unknowns); ``other``: bound of the equations left out of the subsystem over X; ``verdict``:
    :func:`_verdicts` of K(X) and X when the caller computed them for many boxes at once.
    """
    names = base["names"]
    sv = base["singular_values"]
    common = dict(base, radius=r, box=box, krawczyk_box=None, contraction=math.nan, no_solution=False,
                  radii_tried=(r,), other_bound=float(other))
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
    if verdict is None:
        verdict = tuple(v.item() for v in _verdicts(np.asarray(k[0], dtype=float), np.asarray(k[1], dtype=float),
                                                    *(np.asarray(b, dtype=float) for b in zip(*box))))
    finite, inside, disjoint, ratio = verdict
    common.update(krawczyk_box=tuple(zip(map(float, k[0]), map(float, k[1]))), contraction=float(ratio),
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
        (x_lo, x_hi), (k_lo, k_hi) = (np.asarray(v, dtype=float) for v in zip(*box)), np.asarray(k, dtype=float)
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
    check_system(system)
    y = check_theta(system, theta)
    r = _check_radius("radius", radius)
    tol = check_tolerance(angle_tolerance)
    n_unk, n_eq = len(y), 3 * len(system.loops)
    lo, hi = y - r, y + r
    f_y, _ = interval_eval(system, [iv.mpf(v) for v in y], tol, jacobian=False)
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
        return _outcome(base, r, tuple(zip(map(float, lo), map(float, hi))), square, regular, None)
    c_float = np.linalg.inv(j_sq)
    xs = [iv.mpf([a, b]) for a, b in zip(lo, hi)]
    f_box, j_box = interval_eval(system, xs, tol, jacobian=True)
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
    return _outcome(base, r, tuple(zip(map(float, lo), map(float, hi))), True, True,
                    ([a for a, _ in k_float], [b for _, b in k_float]), other)


def certify_reference(system: LoopSystem, theta, radii: Sequence[float] = CERTIFY_RADII,
                      angle_tolerance: float = ANGLE_TOLERANCE) -> KrawczykResult:
    """:func:`certify` with :func:`krawczyk_reference`: radii tried one by one, in order."""
    rs = check_radii(radii)
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


def check_radii(radii) -> list[float]:
    """``radii`` (radians) as a list of floats in (0, pi), strictly increasing; ValueError naming the first bad one."""
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
