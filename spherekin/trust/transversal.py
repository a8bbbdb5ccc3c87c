"""The transversal closure system and its interval enclosures (the system that :mod:`spherekin.trust.krawczyk` certifies).

For every loop of a :class:`~spherekin.mechanism.LoopSystem`, the entries (2,1), (3,1), (3,2)
(1-based) of F_n = prod_i Rx(phi_i) Z (Eq. 2), which vanish at closure (F = I + [w]x near I gives
(f21, f31, f32) = (w_z, -w_y, w_x): simple roots where the mechanism is regular). The unknowns are
the passive angles theta (radians), in ``LoopSystem.unknowns`` order; a factor angle is a known
number or phi = offset + sign * theta. These are the entries of the ``transversal`` formulation
(:data:`spherekin.closure.TRANSVERSAL_ENTRIES`) without the tan-half-angle substitution and
without the factor q_n, so the Jacobian is taken directly with respect to the joint angles.

Values: :func:`transversal_equations` (floats). Enclosures of F and its Jacobian J over boxes, two
implementations with the same inputs and results:

* fast (:func:`enclose_transversal`, :func:`interval_transversal`, and :func:`enclose` on a
  :class:`TransversalPlan` for callers that evaluate one system many times): interval arithmetic
  on float64 arrays, every operation rounded to nearest then widened one ulp outward
  (:mod:`spherekin.core.intervals`), vectorized over boxes, loops and factors. A factor angle is
  phi = c + sign * theta, so cos phi = cos c cos theta - sign sin c sin theta and
  sin phi = sin c cos theta + sign cos c sin theta, with cos/sin of each constant c over
  c +- angle_tolerance and of each unknown over its box from :func:`spherekin.core.intervals.cos_sin_table`
  (:mod:`spherekin.core.trig_enclosure` at the float point, then a rigorous expansion). With P_i the
  product of the factors before factor i (P_0 = I), F = P_n by P_{i+1} = P_i Rx(phi_i) Z, and
  dF/dphi_i = [u_i]x F with u_i = P_i e1, because d/dphi Rx(phi) = [e1]x Rx(phi) and
  P [e1]x P^T = [P e1]x for a rotation P -- an identity of the exact matrices at every point of
  the box, so enclosures of u_i and F enclose the Jacobian.
* reference (:func:`interval_transversal_reference`, :func:`interval_eval`): mpmath's ``iv``
  context for every operation (slow, obviously correct). F = P_n with prefix products as above
  and, since an unknown appears at most once per loop, dF/dtheta = sign * P_{i-1} (dRx(phi_i)/dphi Z)
  S_{i+1} with suffix products S_i = Rx(phi_i) Z S_{i+1}, using Rx(phi) Z = [[0,-1,0],[c,0,-s],[s,0,c]]
  and d/dphi (Rx(phi) Z) = [[0,0,0],[-s,0,-c],[c,0,-s]], in intervals. The float values
  (:func:`transversal_equations`) are the transversal entries of
  :func:`spherekin.closure.closure_at`, the package's one float evaluation of F_n and dF_n/dtheta.

Known factor angles and term offsets are floats rounded from the geometry; the enclosures treat
each as an interval of half-width ``angle_tolerance`` (default :data:`ANGLE_TOLERANCE`), so they
hold for every system whose constant angles are that close to the floats -- including the snapped
angles of the Bernstein equations (:data:`spherekin.closure.KNOWN_ANGLE_SNAP`) and the exact
angles (pi/2, pi, ...) that the floats round.

The link twists are constants too. In the doubled form they are factor angles (above); in the
compact form (``LoopSystem.twists``) each Z of a loop is one of its sides, pi/2 only up to the
snapping d of :meth:`spherekin.mechanism.LoopGeometry.twist_slack` and the rounding of the
description (a distal link angle of float(pi/2) is pi/2 - 6e-17). Such a Z stands for
Z Rz(eps), ``|eps| <= d + tol``, and its effect is bounded rather than evaluated
(:func:`twist_widths`): with A_k = Rx(phi_k) Z orthogonal and ``||Rz(eps) - I||_2 <= |eps|``, the
product F' of n perturbed factors has ``||F' - F||_2 <= n (d + tol) = e``, and, since
dF/dphi_i = [u_i]x F with u_i = P_i e1 for any Z's, ``|J' - J| <= |u' - u| + ||F' - F|| <= 2 e`` per
entry; F and J of the loop are widened by e and 2 e. Next to a singularity this decides: on the
agile eye 1e-8 from its singular lines a pair of roots is real for exact right angles and complex
for float(pi/2), and only the widened enclosures refuse to prove either.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from ..core import intervals as iv_ops
from ..closure import KNOWN_ANGLE_SNAP, TRANSVERSAL_ENTRIES, ClosurePlan, Term, closure_at, closure_plan
from ..core.intervals import add_unchecked, cos_sin_table_unchecked, mul_unchecked, sub_unchecked
from ..mechanism import LoopSystem

__all__ = [
    "ANGLE_TOLERANCE",
    "TransversalPlan",
    "plan_of",
    "SystemStack",
    "stack_systems",
    "stack_inputs",
    "enclose",
    "transversal_labels",
    "transversal_equations",
    "enclose_transversal",
    "interval_transversal",
    "interval_transversal_reference",
    "interval_eval",
    "check_system",
    "check_theta",
    "check_angles",
    "check_tolerance",
    "check_box",
    "twist_widths",
]

#: Half-width (radians) of the interval that stands for each constant angle (known factor angle,
#: term offset). Reason: the floats of a LoopSystem are rounded (np.pi, offsets from atan2 of
#: float axes: errors ~1e-16) and the Bernstein equations snap cos/sin within KNOWN_ANGLE_SNAP of 0,
#: i.e. move an angle by up to ~1e-14; twice the snap covers both, so the certificate is about the
#: mechanism, not about one rounding of it. It widens F(y) by ~n_factors * 2e-14, far below the
#: smallest radius tried.
ANGLE_TOLERANCE = 2.0 * KNOWN_ANGLE_SNAP


# --------------------------------------------------------------------------------------------
# The transversal system: labels and float values
# --------------------------------------------------------------------------------------------

def transversal_labels(system: LoopSystem) -> tuple[str, ...]:
    """Names of the equations, in row order: "loop1:f21", "loop1:f31", "loop1:f32", "loop2:f21", ..."""
    check_system(system)
    return tuple(f"loop{k + 1}:f{r + 1}{c + 1}" for k in range(len(system.loops)) for r, c in TRANSVERSAL_ENTRIES)


def transversal_equations(system: LoopSystem, theta) -> tuple[np.ndarray, np.ndarray]:
    """Float values F (E,) and Jacobian J (E, M) = dF/dtheta of the transversal system at ``theta``.

    ``theta``: passive angles (radians), a sequence in ``system.unknowns`` order or a mapping
    name -> angle. E = 3 * number of loops, M = number of unknowns: the transversal entries of
    :func:`spherekin.closure.closure_at` (the interval reference below is an independent evaluation).
    """
    check_system(system)
    y = check_theta(system, theta)
    f, j = closure_at(system.loops, system.unknowns, y, jacobian=True, loop_indices=system.loop_indices)
    return f[:, _ENTRY_ROWS, _ENTRY_COLS].reshape(-1), j[:, _ENTRY_ROWS, _ENTRY_COLS, :].reshape(-1, len(y))


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


class TransversalPlan:
    """The factors of a LoopSystem as index arrays (L loops padded to n factors, M unknowns, T terms).

    * ``const`` (L, n): constant angle of each factor (a known angle, or a term's offset; 0 for
      padding); ``padding`` (L, n), or None without any;
    * ``theta_slot`` (n, 1, L): 1 + the index of the factor's unknown, or 0 for a known angle or
      padding (the dummy angle 0: cos = 1, sin = 0); ``theta_rows`` (4, n, 1, L): rows of
      (cos t, sign sin t, cos t, sign sin t) in the table (cos, sin, -sin) of _enclose;
      ``const_cols`` (n, 1, L): column of each constant among the constants;
    * per term (T rows): ``term_loop``, ``term_pos``, ``term_var`` (T, 1): its loop, position,
      unknown; ``term_rows`` (T, 3): its rows of J; ``jac_u``, ``jac_f_col``, ``jac_f_row``
      (T, 6): the gather indices of the products of J = sign [u]x F (see _enclose);
    * ``twist_count`` (L,): the number of Z's of each loop that stand for link twists (its factors
      in the compact form, 0 where they are exact), ``twist_slack`` (L,): their d (module docstring).
    """

    __slots__ = ("n_loops", "n_factors", "const", "padding", "theta_slot", "theta_rows", "const_cols",
                 "term_loop", "term_pos", "term_var", "term_rows", "jac_u", "jac_f_col", "jac_f_row",
                 "twist_count", "twist_slack")

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
    twist_count: np.ndarray
    twist_slack: np.ndarray

    def __init__(self, n_loops, n_factors, const, padding, theta_slot, theta_rows, const_cols,
                 term_loop, term_pos, term_var, term_rows, jac_u, jac_f_col, jac_f_row, twist_count, twist_slack):
        self.n_loops = n_loops
        self.n_factors = n_factors
        self.const = const
        self.padding = padding
        self.theta_slot = theta_slot
        self.theta_rows = theta_rows
        self.const_cols = const_cols
        self.term_loop = term_loop
        self.term_pos = term_pos
        self.term_var = term_var
        self.term_rows = term_rows
        self.jac_u = jac_u
        self.jac_f_col = jac_f_col
        self.jac_f_row = jac_f_row
        self.twist_count = twist_count
        self.twist_slack = twist_slack


def plan_of(system: LoopSystem) -> TransversalPlan:
    """The index arrays of ``system``'s factors that :func:`enclose` evaluates (built once per
    system; ValueError when an unknown appears twice in one loop)."""
    n_loops = len(system.loops)
    n = max((len(loop.factors) for loop in system.loops), default=0)
    const = closure_plan(system.loops, system.unknowns, system.loop_indices).offsets   # 0 for padding
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
                slot[k, pos] = g + 1
                negative[k, pos] = fac.sign == -1
                terms.append((k, pos, g, fac.sign == -1))
    t = np.array(terms, dtype=np.intp).reshape(-1, 4)
    n_t = len(t)
    # sign -1: swap the two products of every entry, which negates it (u_a F_b - u_b F_a)
    swap = t[:, 3].astype(bool)
    jac_u, jac_f_row = np.tile(_JAC_U, (n_t, 1)), np.tile(_JAC_F_ROW, (n_t, 1))
    jac_u[swap] = _JAC_U.reshape(-1, 2)[:, ::-1].ravel()
    jac_f_row[swap] = _JAC_F_ROW.reshape(-1, 2)[:, ::-1].ravel()
    twists = system.twists or (0.0,) * n_loops
    twist_count = np.array([0.0 if d is None else float(len(loop.factors)) for d, loop in zip(twists, system.loops)])
    twist_slack = np.array([0.0 if d is None else float(d) for d in twists])
    sin_row = 1 + negative.T[:, None, :]                                    # (n, 1, L): 1 sin, 2 -sin
    theta_rows = np.stack((np.zeros_like(sin_row), sin_row, np.zeros_like(sin_row), sin_row))
    return TransversalPlan(n_loops=n_loops, n_factors=n, const=const, padding=padding if padding.any() else None,
                 theta_slot=slot.T[:, None, :].copy(), theta_rows=theta_rows,
                 const_cols=np.arange(n_loops * n).reshape(n_loops, n).T[:, None, :].copy(),
                 term_loop=t[:, :1], term_pos=t[:, 1:2], term_var=t[:, 2:3],
                 term_rows=3 * t[:, :1] + np.arange(3), jac_u=jac_u, jac_f_col=np.tile(_JAC_F_COL, (n_t, 1)),
                 jac_f_row=jac_f_row, twist_count=twist_count, twist_slack=twist_slack)


def twist_widths(plan: TransversalPlan, tol: float) -> np.ndarray:
    """e_k >= n_k (d_k + tol) for each loop (L,), rounded up: how far the loop's transversal entries
    may move when each of its n_k twist Z's turns by up to d_k + tol (module docstring); 0 for a
    loop of exact Z's. Rounding: a sum and a product of floats (relative error <= 2 ulp), covered
    by the factor 1 + 1e-15 and one step up."""
    e = plan.twist_count * (plan.twist_slack + tol) * (1.0 + 1e-15)
    return np.where(e > 0, np.nextafter(e, math.inf), 0.0)




@dataclass(frozen=True, eq=False)
class SystemStack:
    """LoopSystems of one mechanism at K inputs, for tests of many points of many systems at once.

    ``systems`` (K, a sequence): the systems (same loops, unknowns and factors; their constant angles differ:
    the inputs are known angles); ``plan``: the :class:`TransversalPlan` of the first; ``closure``:
    its :class:`~spherekin.closure.ClosurePlan`; ``consts`` (K, L, n): every system's constant
    angles (radians), ``consts[k]`` being ``plan_of(systems[k]).const``.
    """

    systems: tuple
    plan: TransversalPlan
    closure: ClosurePlan
    consts: np.ndarray


def stack_systems(systems: Sequence[LoopSystem]) -> SystemStack:
    """The :class:`SystemStack` of ``systems`` (at least one); ValueError when two differ in more than their constants."""
    systems = tuple(systems)
    if not systems:
        raise ValueError("systems: expected at least one LoopSystem, got none")
    for s in systems:
        check_system(s)
    plans = [closure_plan(s.loops, s.unknowns, s.loop_indices) for s in systems]
    first = systems[0]
    for k, (s, p) in enumerate(zip(systems, plans)):
        if s.names != first.names or not plans[0].same_structure(p):
            raise ValueError(f"systems[{k}]: expected the loops of systems[0] with other constant angles "
                             f"(one mechanism at other inputs), got other unknowns or factors")
    return SystemStack(systems, plan_of(first), plans[0], np.stack([p.offsets for p in plans]))


class _SystemsAt(Sequence):
    """``mechanism.loop_system(inputs[k], passive_ranges)`` for k < K, each built when first asked for."""

    def __init__(self, mechanism, inputs, passive_ranges, first: LoopSystem):
        self._build = lambda k: mechanism.loop_system(tuple(float(v) for v in inputs[k]), passive_ranges)
        self._built = {0: first}
        self._n = len(inputs)

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, k):
        if isinstance(k, slice):
            return [self[i] for i in range(*k.indices(self._n))]
        k = range(self._n)[k]
        if k not in self._built:
            self._built[k] = self._build(k)
        return self._built[k]


def stack_inputs(mechanism, inputs, passive_ranges) -> SystemStack:
    """The :class:`SystemStack` of ``mechanism.loop_system(inputs[k], passive_ranges)`` for the K rows of
    ``inputs`` ((K, number of actuated joints), radians), without building K systems: the first is
    built, every system's constants come from ``mechanism.loop_constants`` (the rule loop_system
    reads its known angles from), and ``systems[k]`` is built when asked for."""
    inputs = np.asarray(inputs, dtype=float)
    if inputs.ndim != 2 or not len(inputs):
        raise ValueError(f"inputs: expected a (K, {len(mechanism.actuated)}) array with K >= 1, got shape {inputs.shape}")
    first = mechanism.loop_system(tuple(float(v) for v in inputs[0]), passive_ranges)
    plan = closure_plan(first.loops, first.unknowns, first.loop_indices)
    return SystemStack(_SystemsAt(mechanism, inputs, passive_ranges, first), plan_of(first), plan,
                       mechanism.loop_constants(inputs, first.form))


def enclose(plan: TransversalPlan, lo: np.ndarray, hi: np.ndarray, center: np.ndarray, tol: float,
             jacobian: bool = True, consts: np.ndarray | None = None,
             which: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """Interval arrays F (2, B, E) and J (2, B, E, M) over B boxes [lo, hi] (B, M) of unknowns.

    ``center`` (B, M): a point of each box (the expansion point of cos/sin); every constant angle
    c stands for [c - tol, c + tol]. Every F(theta), dF/dtheta(theta) for theta in box b and
    constants in their intervals lies in F[:, b], J[:, b]. See the module docstring for the math.
    Several systems of one structure (a :class:`SystemStack`): ``consts`` (K, L, n) their constant
    angles and ``which`` (B,) the system of each box (default: the plan's own constants for all).
    """
    b, m = center.shape
    n_loops, n = plan.n_loops, plan.n_factors
    n_th = 1 + b * m
    # (cos, sin) of the dummy angle 0, of the unknowns over their boxes (radius: the larger
    # distance from the centre, rounded up; 0 exactly for a point) and of the constants over
    # c +- tol, in one batch: (2, 2, 1 + B M + L n)
    radius = np.maximum(center - lo, hi - center)
    np.nextafter(radius, math.inf, out=radius, where=radius != 0)
    const = plan.const if consts is None else consts
    cs = cos_sin_table_unchecked(np.concatenate(((0.0,), center.ravel(), const.ravel())),
                        np.concatenate(((0.0,), radius.ravel(), np.full(const.size, tol))))
    # phi = c + sign t: cos phi = cos c cos t - sin c (sign sin t), sin phi = sin c cos t + cos c (sign sin t)
    table = np.empty((2, 3, n_th))                                                    # cos t, sin t, -sin t
    table[:, :2] = cs[:, :, :n_th]
    np.negative(cs[::-1, 1, :n_th], out=table[:, 2])
    theta_q = table[:, plan.theta_rows, plan.theta_slot + m * np.arange(b)[:, None] * (plan.theta_slot > 0)]
    cols = plan.const_cols if consts is None else plan.const_cols + plan.const.size * which[None, :, None]
    const_q = cs[:, _QUAD_CONST, cols + n_th]                                         # (2, 4, n, 1 or B, L)
    prods = mul_unchecked(const_q, theta_q)                                                    # (2, 4, n, B, L)
    cos_phi = sub_unchecked(prods[:, 0], prods[:, 1])[..., None]                               # (2, n, B, L, 1)
    sin_phi = add_unchecked(prods[:, 2], prods[:, 3])[..., None]
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
        x = mul_unchecked(coef[:, i], pt[:, _STEP_COLS])                         # (2, 4, B, L, 3)
        new = np.empty_like(pt)
        new[:, 0::2] = add_unchecked(x[:, 0::2], x[:, 1::2])                     # c P1 + s P2, c P2 - s P1
        np.negative(pt[::-1, 0], out=new[:, 1])                         # -P0 (exact)
        if plan.padding is not None and plan.padding[:, i].any():
            new[..., plan.padding[:, i], :] = pt[..., plan.padding[:, i], :]
        pt = new
    f = pt[:, _ENTRY_COLS, :, :, _ENTRY_ROWS]                            # (3, 2, B, L): advanced axes first
    f = f.transpose(1, 2, 3, 0).reshape(2, b, 3 * n_loops)
    e = twist_widths(plan, tol)                                          # (L,): the twist Z's, module docstring
    twisted = bool(e.any())
    if twisted:
        e_rows = np.repeat(e, 3)
        f = add_unchecked(f, np.stack((-e_rows, e_rows))[:, None, :])
    if not jacobian:
        return f, None
    # dF/dtheta at term t = sign * [u_t]x F: entry (r, c) = sign (u[r+1] F[r+2, c] - u[r+2] F[r+1, c])
    # (indices mod 3); the plan's gather indices put the two products in the order of the sign.
    jac = np.zeros((2, b, 3 * n_loops, m))
    if len(plan.term_loop):
        ut = u[:, plan.term_pos, :, plan.term_loop, plan.jac_u]                             # (T, 6, 2, B)
        ft = pt[:, plan.jac_f_col, :, plan.term_loop, plan.jac_f_row]                       # (T, 6, 2, B)
        p = mul_unchecked(ut.transpose(2, 0, 1, 3), ft.transpose(2, 0, 1, 3))                       # (2, T, 6, B)
        vals = sub_unchecked(p[:, :, 0::2], p[:, :, 1::2])                                           # (2, T, 3, B)
        if twisted:
            e_t = 2.0 * e[plan.term_loop[:, 0]]                                                 # (T,), exact doubling
            vals = add_unchecked(vals, np.stack((-e_t, e_t))[:, :, None, None])
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
    check_system(system)
    tol = check_tolerance(angle_tolerance)
    m = len(system.unknowns)
    arr = np.asarray(boxes, dtype=float) if _is_numeric(boxes) else None
    if arr is None or arr.ndim not in (2, 3):
        raise ValueError(f"boxes: expected shape ({m}, 2) or (B, {m}, 2) of (lo, hi) angles in radians, got {boxes!r}")
    single = arr.ndim == 2
    arr = arr[None] if single else arr
    for k in range(arr.shape[0]):
        check_box(system, arr[k], key="boxes" if single else f"boxes[{k}]")
    lo, hi = arr[..., 0], arr[..., 1]
    if not iv_ops.rounding_environment_ok():
        raise RuntimeError("the floating-point environment is not IEEE round-to-nearest with gradual underflow "
                           "(flush-to-zero?): fast enclosures would not be rigorous; use interval_transversal_reference")
    center = np.clip(lo * 0.5 + hi * 0.5, lo, hi)
    f, j = enclose(plan_of(system), lo, hi, center, tol, jacobian)
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
    check_system(system)
    tol = check_tolerance(angle_tolerance)
    lo, hi = check_box(system, box)
    if not iv_ops.rounding_environment_ok():
        return interval_transversal_reference(system, box, angle_tolerance, jacobian)
    f, j = enclose(plan_of(system), lo[None], hi[None], np.clip(lo * 0.5 + hi * 0.5, lo, hi)[None], tol, jacobian)
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
    check_system(system)
    tol = check_tolerance(angle_tolerance)
    lo, hi = check_box(system, box)
    xs = [iv.mpf([a, b]) for a, b in zip(lo, hi)]
    return interval_eval(system, xs, tol, jacobian)


def interval_eval(system: LoopSystem, xs: list, tol: float, jacobian: bool):
    """The reference enclosures (mpmath ``iv``) of F and, with ``jacobian``, J at the intervals
    ``xs`` (one ``iv.mpf`` per unknown), constants widened by ``tol``: object arrays (E,), (E, M)."""
    from mpmath import iv
    spread = iv.mpf([-tol, tol])

    def constant(a: float):
        return iv.mpf(a) + spread if tol else iv.mpf(a)

    f, j = _evaluate(system, xs, constant, iv.cos, iv.sin, jacobian)
    # the twist Z's of the compact form (module docstring): n_k (d_k + tol), in intervals
    twists = system.twists or (0.0,) * len(system.loops)
    widths = [iv.mpf(0) if d is None else iv.mpf(len(loop.factors)) * (iv.mpf(d) + iv.mpf(tol))
              for d, loop in zip(twists, system.loops)]
    spread_f = [iv.mpf([-w.b, w.b]) for w in widths for _ in TRANSVERSAL_ENTRIES]
    f_arr = np.empty(len(f), dtype=object)
    f_arr[:] = [iv.mpf(v) + sp for v, sp in zip(f, spread_f)]
    if not jacobian:
        return f_arr, None
    j_arr = np.empty((len(f), len(xs)), dtype=object)
    for e, row in enumerate(j):
        # structural zeros (int 0: the unknown is not in the loop) stay exact point intervals
        j_arr[e, :] = [iv.mpf(v) if isinstance(v, int) and v == 0 else iv.mpf(v) + 2 * spread_f[e] for v in row]
    return f_arr, j_arr


# --------------------------------------------------------------------------------------------
# Argument checks (shared with spherekin.trust.krawczyk)
# --------------------------------------------------------------------------------------------

def _is_numeric(value) -> bool:
    try:
        np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return False
    return True


def check_system(system) -> None:
    if not isinstance(system, LoopSystem):
        raise ValueError(f"system: expected a LoopSystem (mechanism.loop_system(...)), got {type(system).__name__}")


def check_theta(system: LoopSystem, theta, key: str = "theta") -> np.ndarray:
    """``theta`` (a sequence in ``system.unknowns`` order or a mapping name -> angle) as a float array."""
    return check_angles(system.names, theta, key)


def check_angles(names: tuple, theta, key: str = "theta") -> np.ndarray:
    """``theta`` (one angle per name, in order, or a mapping name -> angle) as a finite float array."""
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


def check_tolerance(value) -> float:
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"angle_tolerance: expected a non-negative angle (radians), got {value!r}")
    try:
        t = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"angle_tolerance: expected a non-negative angle (radians), got {value!r}") from None
    if not (math.isfinite(t) and 0.0 <= t < 1e-3):
        raise ValueError(f"angle_tolerance: expected a value in [0, 1e-3) radians, got {value!r}")
    return t


def check_box(system: LoopSystem, box, key: str = "box") -> tuple[np.ndarray, np.ndarray]:
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
