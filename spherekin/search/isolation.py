"""Isolation of simple roots inside the box loop: a Krawczyk test and Newton's method in Bernstein form.

For a box X of the subdivision, the control points of every equation restricted to X are known
(batch axis last, see :func:`spherekin.core.bernstein.restrict_batch_last`). On the box's own unit
coordinates u in [0, 1]^N, for the *square system* F (N equations of simple roots: the transversal
entries of every loop, plus the circle equations of the sin-cos parameterization):

* F(y) at the centre y = (1/2, ..., 1/2) is a convex combination of control points (Bernstein
  basis at 1/2);
* an enclosure J(X) of the Jacobian over X: the derivative dF/du_k of a degree-m Bernstein
  polynomial has control points m (c_{i+1} - c_i) along axis k, and lies between their min and max;
* Krawczyk's operator (Krawczyk 1969; Moore 1977), with C = mid(J(X))^-1,

      K(X) = y - C F(y) + (I - C J(X)) (X - y),

  encloses every root of F in X. If K(X) lies in the interior of X, X holds exactly one root of F
  (and J is nonsingular on X); if K(X) and X are disjoint, X holds none; in every case the roots
  of F in X lie in K(X) n X, which contracts the box quadratically near a simple root.

Every root of the closure equations is a root of F (the transversal entries vanish at F_n = I),
so the contraction and the exclusion are safe for the solver. A box proven to hold one root of F
is *isolated*: the subdivision stops there and :func:`newton` converges to the root; the other
equations (Eq. 10, or the halves) then tell a closure from a spurious root of F (a rotation
diag(1, -1, -1), ...): a root is dropped as spurious only when :func:`spurious_proven` shows that
another equation has no zero on a box holding it (a float test at Newton's point is not enough:
next to a singularity the point errs by far more than the equations' rounding, issue 26).

Departure from the paper: the paper subdivides every box down to the tolerance; stopping at an
isolating box saves the tail of the subdivision (the paper's Section 5 asks for faster
convergence). Rounding: F and J are widened by the absolute tolerance of each equation (the same
rounding model as the pruners), and K by :data:`KRAWCZYK_MARGIN`; the rigorous certificate of each
final solution is :mod:`spherekin.trust.krawczyk`, in outward-rounded interval arithmetic.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..core import intervals
from ..core.arrays import namespace_of
from ..core.bernstein import restrict_batch_last
from ..core.krawczyk import MIDRAD, krawczyk_operator
from .pruners import excludes_zero

__all__ = ["full_rank_proven", "KRAWCZYK_MARGIN", "KRAWCZYK_RCOND", "NEWTON_MAX_STEPS", "NEWTON_STEP_TOL", "NEWTON_STALL_STEP", "SPURIOUS_FACTOR",
           "SPURIOUS_PROOF_RADIUS", "SquareSystem", "krawczyk_boxes", "krawczyk_parametric", "evaluate_at", "jacobian_at", "newton",
           "spurious_proven"]

#: K(X) is widened by this (unit coordinates of the box) before it is compared with X: its float
#: evaluation (a few dozen operations on O(1) numbers) errs by ~1e-15; the margin also keeps an
#: "isolated" verdict away from roots on the box faces.
KRAWCZYK_MARGIN = 1e-9
#: mid(J(X))^-1 is used only when the reciprocal condition number (1-norm) is above this; below it C
#: would amplify rounding beyond KRAWCZYK_MARGIN and the box is left to the pruners.
KRAWCZYK_RCOND = 1e-10
#: Newton steps at most from the centre of an isolating box (quadratic convergence from a box whose
#: Krawczyk image lies inside it needs ~6; the cap only stops a pathological case).
NEWTON_MAX_STEPS = 30
#: Newton stops when the step (unit coordinates of the box) is below this: ~ machine precision.
NEWTON_STEP_TOL = 4e-16
#: ... or when a step below this one is no smaller than the step before it: at the rounding floor of
#: the equations' evaluation the steps stop shrinking and alternate (measured on the Gosselin
#: platform: 2.7e-16 and 5.4e-16, above NEWTON_STEP_TOL, for 30 steps), and the point is then as
#: good as float64 makes it. Far above that floor (quadratic convergence shrinks a 1e-13 step to
#: ~1e-26) and far below any box the search isolates.
NEWTON_STALL_STEP = 1e-13
#: A root of the square system is a closure when every other equation vanishes there to within
#: this many times its rounding tolerance; at a spurious root the scalar equation is -2 q or -4 q,
#: some 1e12 tolerances away.
SPURIOUS_FACTOR = 1e4
#: Half-width (unit coordinates of the isolating box) of the small box around Newton's point on
#: which a suspected spurious root is proven spurious when the whole box is too wide for that:
#: Newton's point errs by ~1e-16 / sigma_min; a spurious root's other equations are ~1 away from 0,
#: so they exclude 0 on a box of this size while the Krawczyk test still proves the root inside.
SPURIOUS_PROOF_RADIUS = 1e-6


class SquareSystem:
    """Which equations of which blocks form the square system: ``rows[i] = (block, equation)``."""

    __slots__ = ("rows",)

    rows: tuple

    def __init__(self, rows):
        self.rows = rows

    @classmethod
    def from_blocks(cls, square: Sequence[Sequence[int]]) -> "SquareSystem":
        return cls(tuple((b, e) for b, eqs in enumerate(square) for e in eqs))

    def select(self, cps: Sequence[np.ndarray], tols: Sequence[np.ndarray]):
        """Per block, the (rows, control points (E', dims, B), tolerances (E', B)) of the square rows."""
        out = []
        for b, (c, t) in enumerate(zip(cps, tols)):
            eqs = [e for bb, e in self.rows if bb == b]
            if eqs:                 # blocks without square rows may be None (not evaluated)
                tb = np.broadcast_to(np.asarray(t, dtype=float).reshape(c.shape[0], -1), (c.shape[0], c.shape[-1]))
                out.append((eqs, c[eqs], tb[eqs]))
        return out


def _weights_at(m: int, u):
    """Bernstein basis b_{i,m}(u), shape (m+1, B) for u of shape (B,) (any array module)."""
    from math import comb

    xp = namespace_of(u)
    return xp.stack([comb(m, i) * u ** i * (1.0 - u) ** (m - i) for i in range(m + 1)])


def evaluate_at(c, u):
    """Values (E, B) of polynomials c (E, d_1..d_N, B) at points u (B, N) of their boxes (any array
    module: :func:`spherekin.core.arrays.namespace_of`)."""
    xp = namespace_of(c, u)
    ne, dims, bsz = c.shape[0], c.shape[1:-1], c.shape[-1]
    v = c
    for k in range(len(dims) - 1, -1, -1):
        d = v.shape[-2]
        if d > 1:
            w = _weights_at(d - 1, u[:, k])                              # (d, B)
            # sum_j v[..., j, b] w[j, b] as elementwise products in a fixed order (not einsum, whose
            # summation order depends on the array sizes): a box's value never depends on its batch
            out = v[..., 0, :] * w[0, :]
            for j in range(1, d):
                out += v[..., j, :] * w[j, :]
            v = out
        else:
            v = v[..., 0, :]
    return xp.reshape(v, (ne, bsz))


def _derivative(c, k: int):
    """Control points of dc/du_k (degree m - 1 along axis k), or None when c has degree 0 there."""
    d = c.shape[1 + k]
    if d == 1:
        return None
    xp = namespace_of(c)
    return (d - 1) * xp.diff(c, axis=1 + k)


def jacobian_at(c, u):
    """Jacobian (E, N, B) of polynomials c (E, d_1..d_N, B) at points u (B, N) (any array module)."""
    xp = namespace_of(c, u)
    ne, n, bsz = c.shape[0], c.ndim - 2, c.shape[-1]
    zero = None
    cols = []
    for k in range(n):
        dk = _derivative(c, k)
        if dk is not None:
            cols.append(evaluate_at(dk, u))
        else:
            zero = xp.zeros_like(xp.reshape(c, (ne, -1, bsz))[:, 0, :]) if zero is None else zero
            cols.append(zero)
    return xp.stack(cols, axis=1)


def _derivative_bounds(c, tol):
    """Enclosures (E, N, B) of dc/du_k over the box: min/max of the derivative control points,
    widened by the rounding tolerance (E, B) of a difference of two control points times the degree
    (any array module)."""
    xp = namespace_of(c, tol)
    ne, n, bsz = c.shape[0], c.ndim - 2, c.shape[-1]
    zero = None
    lo, hi = [], []
    for k in range(n):
        dk = _derivative(c, k)
        if dk is None:
            zero = xp.zeros_like(xp.reshape(c, (ne, -1, bsz))[:, 0, :]) if zero is None else zero
            lo.append(zero)
            hi.append(zero)
            continue
        flat = xp.reshape(dk, (ne, -1, bsz))
        widen = 2.0 * (c.shape[1 + k] - 1) * tol
        lo.append(xp.min(flat, axis=1) - widen)
        hi.append(xp.max(flat, axis=1) + widen)
    return xp.stack(lo, axis=1), xp.stack(hi, axis=1)


def _inverses(jmid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(ok (B,), C (B, N, N)): C = mid(J)^-1 of each box, ``ok`` where it exists and the reciprocal
    condition number 1 / (||mid(J)||_1 ||C||_1) is above KRAWCZYK_RCOND (C is garbage elsewhere).

    The 1-norm estimate costs the inverse the test needs anyway (an SVD gate cost 4x that: ~6% of a
    box loop); it is within a factor N of the 2-norm one. Each box's C is LAPACK's inverse of its
    own matrix, the same floats in any batch; a batch holding an exactly singular matrix (inv
    raises for the whole batch) is inverted box by box, with the same result for the others.
    """
    c = np.zeros_like(jmid)
    ok = np.all(np.isfinite(jmid), axis=(1, 2))
    with np.errstate(all="ignore"):
        try:
            c[ok] = np.linalg.inv(jmid[ok])
        except np.linalg.LinAlgError:
            for b in np.flatnonzero(ok):
                try:
                    c[b] = np.linalg.inv(jmid[b])
                except np.linalg.LinAlgError:
                    ok[b] = False
        norm_j = np.abs(jmid).sum(axis=1).max(axis=1)                  # max column sum: ||.||_1
        norm_c = np.abs(c).sum(axis=1).max(axis=1)
        ok &= np.isfinite(norm_c) & (norm_j * norm_c * KRAWCZYK_RCOND < 1.0)
    return ok, c


def _half_unit(b, n) -> tuple[np.ndarray, np.ndarray]:
    """X - y on the unit box around its centre, as (mid, rad) of shape (b, n): [-1/2, 1/2]."""
    return np.zeros((int(b), n)), np.full((int(b), n), 0.5)


def krawczyk_boxes(square: SquareSystem, cps: Sequence[np.ndarray], tols: Sequence[np.ndarray]):
    """The Krawczyk test on B boxes at once (see the module docstring).

    ``cps``/``tols``: every block's control points on the boxes (batch last) and tolerances.
    Returns (isolated (B,), lo (B, N), hi (B, N)): ``isolated[b]`` when K(X_b) lies in the interior
    of X_b (exactly one root of the square system in X_b); [lo, hi] = K(X_b) n X_b in the box's unit
    coordinates (lo > hi somewhere when they are disjoint: no root). Boxes whose mid(J(X)) is too
    ill-conditioned get the whole box back, not isolated.
    """
    parts = square.select(cps, tols)
    bsz, n = cps[0].shape[-1], cps[0].ndim - 2
    f = np.concatenate([evaluate_at(c, np.full((bsz, n), 0.5)) for _, c, _ in parts])       # (N, B)
    ftol = np.concatenate([t for _, _, t in parts])                                          # (N, B)
    jl, jh = zip(*(_derivative_bounds(c, t) for _, c, t in parts))
    jlo, jhi = np.concatenate(jl), np.concatenate(jh)                                        # (N, N, B)
    if f.shape[0] != n:
        raise ValueError(f"square: expected {n} equations (one per variable), got {f.shape[0]}")
    f, ftol = f.T, ftol.T                                                                    # (B, N)
    jmid = np.moveaxis(0.5 * (jlo + jhi), -1, 0)                                             # (B, N, N)
    jrad = np.moveaxis(0.5 * (jhi - jlo), -1, 0)
    lo, hi = np.zeros((bsz, n)), np.ones((bsz, n))
    isolated = np.zeros(bsz, dtype=bool)
    ok, c_all = _inverses(jmid)
    if not ok.any():
        return isolated, lo, hi
    # K on the unit box: y = its centre, X - y = [-1/2, 1/2] (midpoint-radius floats, widened by the margin)
    centre, radius = krawczyk_operator(MIDRAD, np.full((int(ok.sum()), n), 0.5), (f[ok], ftol[ok]), c_all[ok],
                              (jmid[ok], jrad[ok]), _half_unit(ok.sum(), n))
    klo, khi = centre - (radius + KRAWCZYK_MARGIN), centre + (radius + KRAWCZYK_MARGIN)
    isolated[ok] = np.all((klo > 0.0) & (khi < 1.0), axis=1)
    lo[ok] = np.maximum(klo, 0.0)
    hi[ok] = np.minimum(khi, 1.0)
    return isolated, lo, hi


def krawczyk_parametric(square: SquareSystem, cps: Sequence[np.ndarray], tols: Sequence[np.ndarray], param: int):
    """The parametric Krawczyk test on B boxes: N - 1 equations in N variables, variable ``param`` a
    parameter p over the box's range, the others V (Neumaier 1990, Thm 5.1.7; the tracker's operator
    in :mod:`spherekin.trust.continuation`). In the box's unit coordinates, m = centre, C =
    mid(J_V(X))^-1:

        K = m_V - C F(m) - C J_p(X) (P - m_p) + (I - C J_V(X)) (V - m_V).

    If K lies in the interior of V, then for EVERY p in P the system has exactly one root in V (and
    lies in K): over P the solution set in the box is the graph of one continuous function p -> v(p)
    (every matrix of J_V(X) is regular). A box of width 0 along ``param`` is the point test.
    ``cps``/``tols`` as :func:`krawczyk_boxes`. Returns (proven (B,), lo (B, N - 1), hi (B, N - 1)):
    K n V in unit coordinates of the V columns (in order, ``param`` left out)."""
    parts = square.select(cps, tols)
    bsz, n = cps[0].shape[-1], cps[0].ndim - 2
    f = np.concatenate([evaluate_at(c, np.full((bsz, n), 0.5)) for _, c, _ in parts]).T     # (B, N - 1)
    ftol = np.concatenate([t for _, _, t in parts]).T
    jl, jh = zip(*(_derivative_bounds(c, t) for _, c, t in parts))
    jlo, jhi = np.moveaxis(np.concatenate(jl), -1, 0), np.moveaxis(np.concatenate(jh), -1, 0)  # (B, N - 1, N)
    if f.shape[1] != n - 1:
        raise ValueError(f"square: expected {n - 1} equations (one per variable but the parameter), got {f.shape[1]}")
    keep = [k for k in range(n) if k != param]
    jmid, jrad = 0.5 * (jlo + jhi), 0.5 * (jhi - jlo)
    lo, hi = np.zeros((bsz, n - 1)), np.ones((bsz, n - 1))
    proven = np.zeros(bsz, dtype=bool)
    ok, c_all = _inverses(jmid[:, :, keep])
    if not ok.any():
        return proven, lo, hi
    # the parametric form on the unit box: R = J_p(X), sigma = P - m_p = [-1/2, 1/2]
    b = int(ok.sum())
    centre, radius = krawczyk_operator(MIDRAD, np.full((b, n - 1), 0.5), (f[ok], ftol[ok]), c_all[ok],
                              (jmid[ok][:, :, keep], jrad[ok][:, :, keep]), _half_unit(b, n - 1),
                              rate=(jmid[ok][:, :, param:param + 1], jrad[ok][:, :, param:param + 1]),
                              sigma=_half_unit(b, 1))
    klo, khi = centre - (radius + KRAWCZYK_MARGIN), centre + (radius + KRAWCZYK_MARGIN)
    proven[ok] = np.all((klo > 0.0) & (khi < 1.0), axis=1)
    lo[ok] = np.maximum(klo, 0.0)
    hi[ok] = np.minimum(khi, 1.0)
    return proven, lo, hi


def full_rank_proven(square: SquareSystem, cps: Sequence[np.ndarray], tols: Sequence[np.ndarray], columns) -> np.ndarray:
    """(B,) bool: True where every matrix of the square system's interval Jacobian over the box, restricted to
    the variables ``columns`` (E equations x m columns, m <= E), has full column rank m. The enclosure J of
    the Jacobian is the derivative control points' hull (as the Krawczyk tests'); with C (m x E) the
    pseudo-inverse of mid(J), C J is enclosed in outward-rounded interval arithmetic and ||I - C J||_inf < 1
    proves every C A (A in J) regular, so every A has rank m. Used for: no cusp of a plane curve in the box
    (the curve's tangent cannot project to 0 in the plane when the Jacobian in the non-plane variables has
    full column rank). ``cps``/``tols`` as :func:`krawczyk_boxes`."""
    parts = square.select(cps, tols)
    bsz = cps[0].shape[-1]
    if bsz == 0:
        return np.zeros(0, dtype=bool)
    jl, jh = zip(*(_derivative_bounds(c, t) for _, c, t in parts))
    cols = list(columns)
    jlo = np.moveaxis(np.concatenate(jl), -1, 0)[:, :, cols]                  # (B, E, m)
    jhi = np.moveaxis(np.concatenate(jh), -1, 0)[:, :, cols]
    with np.errstate(all="ignore"):
        finite = np.all(np.isfinite(jlo) & np.isfinite(jhi), axis=(1, 2))
        mid = np.where(finite[:, None, None], 0.5 * (jlo + jhi), 0.0)
        c_mat = np.linalg.pinv(mid)                                           # (B, m, E)
        jac = intervals.from_bounds(np.where(finite[:, None, None], jlo, 0.0), np.where(finite[:, None, None], jhi, 0.0))
        gap = intervals.sub(intervals.point(np.eye(len(cols))), intervals.fmatmul(c_mat, jac))
        norm = intervals.magnitude(gap).sum(axis=-1).max(axis=-1)
    return finite & np.all(np.isfinite(c_mat), axis=(1, 2)) & (norm < 1.0)


def _step(jac: np.ndarray, f: np.ndarray) -> np.ndarray:
    """One box's Newton step: jac^-1 f, or the least-squares step where jac (N, N) is singular."""
    try:
        return np.linalg.solve(jac, f)
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(jac, f, rcond=None)[0]


def newton(square: SquareSystem, cps: Sequence[np.ndarray], tols: Sequence[np.ndarray]):
    """Newton's method on the square system from the centre of each box (batch last).

    Returns (u (B, N), converged (B,), closure (B,)): the root in each box's unit coordinates,
    whether Newton converged inside the box, and whether every non-square equation vanishes there
    (within SPURIOUS_FACTOR tolerances). ``closure`` False is only a suspicion: u errs from the
    root by up to the rounding over the smallest singular value of the square Jacobian (1e-10 and
    more next to a singularity), so the other equations need not vanish at u even at a closure;
    :func:`spurious_proven` decides.
    """
    parts = square.select(cps, tols)
    bsz, n = cps[0].shape[-1], cps[0].ndim - 2
    u = np.full((bsz, n), 0.5)
    active = np.ones(bsz, dtype=bool)
    converged = np.zeros(bsz, dtype=bool)
    last = np.full(bsz, np.inf)                    # each box's previous step (largest entry)
    for _ in range(NEWTON_MAX_STEPS):
        if not active.any():
            break
        idx = np.flatnonzero(active)
        sub = [c[..., idx] for _, c, _ in parts]
        f = np.concatenate([evaluate_at(c, u[idx]) for c in sub]).T                    # (b, N)
        jac = np.moveaxis(np.concatenate([jacobian_at(c, u[idx]) for c in sub]), -1, 0)  # (b, N, N)
        try:
            step = np.linalg.solve(jac, f[..., None])[..., 0]
        except np.linalg.LinAlgError:
            # a singular Jacobian in the batch: least squares for that box only, so that a box's
            # step never depends on the other boxes of its batch (a chunk of inputs shares batches)
            step = np.stack([_step(j, r) for j, r in zip(jac, f)])
        u[idx] -= step
        size = np.abs(step).max(axis=1)
        done = (size <= NEWTON_STEP_TOL) | ((size <= NEWTON_STALL_STEP) & (size >= last[idx]))
        last[idx] = size
        left = np.any((u[idx] < -KRAWCZYK_MARGIN) | (u[idx] > 1.0 + KRAWCZYK_MARGIN), axis=1) | \
            ~np.all(np.isfinite(u[idx]), axis=1)
        converged[idx[done & ~left]] = True
        active[idx[done | left]] = False
    u = np.clip(u, 0.0, 1.0)
    closure = np.ones(bsz, dtype=bool)
    rows = set(square.rows)
    for b, (c, t) in enumerate(zip(cps, tols)):
        others = [e for e in range(c.shape[0]) if (b, e) not in rows]
        if not others:
            continue
        tb = np.broadcast_to(np.asarray(t, dtype=float).reshape(c.shape[0], -1), (c.shape[0], bsz))[others]
        vals = evaluate_at(c[others], u)
        closure &= np.all(np.abs(vals) <= SPURIOUS_FACTOR * tb, axis=0)
    return u, converged, closure


def _others(square: SquareSystem, cps: Sequence[np.ndarray], tols: Sequence[np.ndarray]):
    """The equations outside the square system: (control points per block, tolerances (E', B) per block)."""
    rows = set(square.rows)
    cs, ts = [], []
    for b, (c, t) in enumerate(zip(cps, tols)):
        others = [e for e in range(c.shape[0]) if (b, e) not in rows]
        if others:
            tb = np.broadcast_to(np.asarray(t, dtype=float).reshape(c.shape[0], -1), (c.shape[0], c.shape[-1]))
            cs.append(c[others])
            ts.append(tb[others])
    return cs, ts


def spurious_proven(square: SquareSystem, cps: Sequence[np.ndarray], tols: Sequence[np.ndarray], u: np.ndarray,
                    radius: float = SPURIOUS_PROOF_RADIUS) -> np.ndarray:
    """(B,) True where the one root of the square system in an isolating box is proven not to be a
    closure: some other equation has no zero on a box that holds that root.

    ``cps``/``tols``: every block on the isolating boxes (batch last), ``u`` (B, N) Newton's point in
    each. The box is the isolating box itself, else the box u +- ``radius`` (unit coordinates), once
    a Krawczyk test proves it holds a root of the square system (the only one of the isolating box).
    False means not proven: the caller keeps the root (the trust layer then proves or flags it).
    """
    others = _others(square, cps, tols)
    bsz = cps[0].shape[-1]
    if not others[0]:
        return np.zeros(bsz, dtype=bool)
    proven = excludes_zero(*others)
    rest = np.flatnonzero(~proven)
    if len(rest):
        ylo = np.clip(u[rest] - radius, 0.0, 1.0)
        yhi = np.clip(u[rest] + radius, 0.0, 1.0)
        sub = [restrict_batch_last(c[..., rest], ylo, yhi) for c in cps]
        sub_tols = [np.broadcast_to(np.asarray(t, dtype=float).reshape(c.shape[0], -1),
                                    (c.shape[0], bsz))[:, rest] for c, t in zip(cps, tols)]
        holds, _, _ = krawczyk_boxes(square, sub, sub_tols)
        proven[rest] = holds & excludes_zero(*_others(square, sub, sub_tols))
    return proven
