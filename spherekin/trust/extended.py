"""Certification in extended precision: a Krawczyk test on closure equations written from the joint axes.

Why: :mod:`spherekin.trust.krawczyk` certifies in float64 interval arithmetic on the transversal
system of a LoopSystem, whose constant angles (offsets, twists, reference readings) are floats derived
from the axes and are therefore intervals of half-width >= 4e-15
(:data:`spherekin.trust.krawczyk.FINE_ANGLE_TOLERANCE`). Next to a branch or change point, two roots
delta apart have a Jacobian whose smallest singular value is ~delta, and the width of F(y) (~1e-14)
times |J^-1| exceeds every box that still contracts: for delta below ~1e-5 neither root can be
certified. Here every constant is exact and the arithmetic carries :data:`EXTENDED_DIGITS` digits,
so F(y) is ~1e-50 wide and the test is limited only by the float point y it is given.

The mechanism certified is the one its file's numbers give (issue 40: "the mechanism of the file, as
its floats give it"), every constant derived from them in extended precision; no float64
intermediate enters. Each actuator input is the exact value of its float (``mpf(float)`` is exact).

* kinds "graph" and "general": each joint axis is the direction of its vector as given
  (``Joint.given_axis``, normalized in interval arithmetic, so the exact unit vector lies in the
  enclosure; ``Joint.axis`` is that direction rounded to floats, the float model's), each reading
  offset (``Joint.reference_angle``) the exact value of its float;
* kind "3-RRR": the float model's joints are derived in floats (elbow axes rotated by a float
  reference input, normalized vectors, reference readings from atan2): ~1e-16 from the file's, a
  neighbouring mechanism whose folds lie up to ~4e-15 from the file's (general_3rrr.toml). The legs
  are written instead from the description's numbers (``ThreeRRRGeometry.given_axes``, the
  distal link angles' floats and the joint offsets, docs/mechanism-format.md), in interval
  arithmetic: u, w^0, v^0, r^0 the directions of the file's vectors, a2 the distal link angle,
  p = unit(u - (u.w^0) w^0), v_ref = cos a2 w^0 + sin a2 p, q = sin a2 w^0 - cos a2 p (w^0's
  direction normal to v_ref), q^0 = unit(r^0 - (r^0.v^0) v^0), and the leg's platform rotation at
  readings (beta, gamma, delta) is P = Rot(u, beta + o_beta) Rot(w^0, gamma + o_gamma)
  Rot(v_ref, delta + o_delta) T, T = [v_ref, q, v_ref x q] [v^0, q^0, v^0 x q^0]^T (o: the offsets,
  a reading being the angle minus its offset): at every geometric angle 0 the leg is folded
  (gamma = 0: v on u's side) with R r^0 along q (delta = 0), and each joint turns what follows it
  about its current axis, so P is the pose R of the description (v_i = R v_i^0 at the distal link
  angle from w_i = Rot(u_i, beta_i + o) w_i^0). The legs of the float model must agree with these
  to RECORD_MATCH_TOL (else ValueError: the proofs would be about other legs).

Nothing is read from the LoopSystem or the float model: the equations are written again from the
model's convention (:mod:`spherekin.mechanism.model`):

* a leg's joints are listed base -> platform; joint i turns by the displacement
  d_i = reading_i - reference_angle_i about its axis a_i in the reference configuration (right-hand
  rule), and the leg places the platform at D = Rot(a_1, d_1) ... Rot(a_k, d_k) (product of
  exponentials; Rodrigues' formula Rot(a, d) = cos d I + sin d [a]x + (1 - cos d) a a^T); the
  platform rotation along the leg is D R_ref (R_ref = ``platform_reference``, I by default);
* one loop per leg k other than the reference leg r; the loop closes iff both legs place the
  platform alike, D_r = D_k, i.e. M_k = D_r^T D_k = I (for a 3-RRR, M_k = P_r^T P_k with the legs'
  poses P above: the same condition). For a mechanism written as a graph the two "legs" of a loop
  are its two chains from its root link (``LoopGeometry.up``/``down``; a joint crossed from its
  second link to its first turns by -d), and the loop closes iff both turn the closing link alike:
  the same condition. (M_k = R_ref (R_r^T R_k) R_ref^T for the platform rotations R = D R_ref: the
  same condition, written so that the float R_ref, orthogonal only to rounding, does not enter;
  M_k = R_r^T R_k exactly when R_ref = I, as in every preset.)

The square system F: for every loop the entries (2,1), (3,1), (3,2) (1-based; :data:`LOOP_ENTRIES`)
of M_k, in the passive readings of ``mechanism.loop_unknowns`` order, the actuated readings fixed
at the inputs. Near M = I + [w]x they are (w_z, -w_y, w_x): simple roots where the mechanism is
regular. They also vanish where M_k is a half-turn about a coordinate axis (an orthogonal lower
triangular matrix is diagonal with entries +-1), so a certificate also requires every diagonal
entry of every M_k to be > 0 over the whole box: then M_k = I at the root, an assembly.

Jacobian: dD/dd_i = [w_i]x D with w_i = Rot(a_1, d_1) ... Rot(a_{i-1}, d_{i-1}) a_i (the current
axis; P [a]x P^T = [P a]x for a rotation P), so with u = D_r e_i, v = D_k e_j,
d(M_k)_ij / d(reading) = +w . (v x u) for a joint of leg k and -w . (v x u) for a joint of leg r
(identities of the exact matrices at every point, so enclosures of w, u, v enclose J over a box).

Krawczyk's test (as in :mod:`spherekin.trust.krawczyk`): for X = [lo, hi], y in X, a float matrix C
(the inverse of the float J(y)) and J(X) enclosing the Jacobian over X,
K(X) = y - C F(y) + (I - C J(X)) (X - y), every operation in interval arithmetic at EXTENDED_DIGITS
digits (EXTENDED_BITS bits): by default FLINT/Arb balls (python-flint's ``arb``, its working precision
set for the call and restored), or mpmath's ``iv`` intervals in a private context, the reference
(``arithmetic="mpmath"``, :data:`ARITHMETICS`). A ball holds every number of its interval, so the
two prove the same things; the balls come out slightly wider (a product of ranges that straddle 0)
and are computed several times faster (benchmarks/bench_extended.py measures both, same run). A
3-RRR's leg constants are written once in mpmath and read by either. Proven:

* K(X) in the interior of X and every diag(M_k) > 0 on X: X holds exactly one root of F, and it
  is an assembly of the mechanism given by its floats (``certified``);
* K(X) misses X, or an equation's enclosure over X excludes 0: X holds no root of F, hence no
  assembly (``no_solution``).

Departures from the float test: the equations are M_k = D_r^T D_k from the axes (not the Eq. (2)
products of a LoopSystem), the constants are exact (``angle_tolerance`` = 0: a certificate is about
the mechanism exactly as its file's floats give it, not about every rounding of it; a constant
derived from them, a cosine or a normalized axis, is an enclosure ~1e-50 wide of its exact value),
the diagonal check (the Eq. (2) products of the float test have no spurious half-turn roots to exclude), X - y is
evaluated as an interval per unknown (not enclosed by [-rho, rho]), and only square systems are
tested (redundant actuation is out of scope: "not certified: not square").
"""

from __future__ import annotations

import contextlib
import functools
import math
from dataclasses import replace
from typing import Mapping, Sequence

import numpy as np

from ..core.krawczyk import krawczyk_operator

from ..mechanism import SphericalMechanism
from ..mechanism.chains import axis_rotation
from ..mechanism.rrr import ThreeRRRGeometry, rrr_joint_names
from .krawczyk import BoxTests, KrawczykResult, check_radii
from .transversal import check_angles

__all__ = [
    "EXTENDED_DIGITS",
    "EXTENDED_BITS",
    "ARITHMETICS",
    "EXTENDED_RADII",
    "EXTENDED_RCOND_MIN",
    "LOOP_ENTRIES",
    "RECORD_MATCH_TOL",
    "RRR_CONSTANTS_CACHE",
    "EXTENDED_NEWTON_STEPS",
    "EXTENDED_NEWTON_TOL",
    "EXTENDED_NEWTON_STALL",
    "certify_extended",
    "krawczyk_boxes_extended",
    "polish_extended",
    "leg_rotations_extended",
]

#: Decimal digits of the interval arithmetic (mpmath ``iv`` context, ~169 bits). Reason: with exact
#: constants, F(y) is then ~1e-50 wide, so C F(y) stays far below any box radius above 1e-30 even
#: for |J^-1| ~ 1e15 (roots ~1e-15 apart); the float point y (ulp ~4e-16 for angles ~ 2 pi) limits
#: the test long before the arithmetic does, and 50 digits keep every call within milliseconds.
EXTENDED_DIGITS = 50
#: The same precision in bits (FLINT/Arb works in bits): 50 digits need 167; 169 is mpmath's choice.
EXTENDED_BITS = 169

#: Box radii (radians) tried by :func:`certify_extended`, smallest first. Reason: the smallest
#: exceeds the distance from a polished float point to its root (a few ulps of the angle times
#: |J^-1|, ~1e-15 for a regular root) with margin; a root delta from another contracts only for
#: radii between that distance and ~0.4 delta, hence every decade; the largest, 1e-6, is the float
#: test's largest (:data:`spherekin.trust.krawczyk.CERTIFY_RADII`) and the solver's tolerance.
EXTENDED_RADII = (1e-13, 1e-12, 1e-11, 1e-10, 1e-9, 1e-8, 1e-7, 1e-6)

#: The midpoint Jacobian is reported singular when sigma_min / sigma_max of the float J(y) is below
#: this. Reason: C is the float inverse of the float J(y) (entries rounded to ~1e-16), so
#: |I - C J(y)| ~ 1e-16 / rcond: at 1e-14 it is ~1e-2, beyond which C no longer makes K small; and
#: roots that close (~1e-14 rad) cannot be told apart by boxes around float points (ulp ~4e-16).
EXTENDED_RCOND_MIN = 1e-14

#: A kind "3-RRR" mechanism's legs must agree with the legs written from its description to this
#: (max |entry| of each joint's axis and each leg's platform rotation at the reference readings, in
#: floats). Reason: both are the same legs computed two ways in floats (~1e-15 apart, a little more
#: where a reference reading is ill-conditioned); legs that are not the description's (another
#: mechanism given the same ``geometry``) are off by far more, and the proofs would not be about them.
RECORD_MATCH_TOL = 1e-9

#: The entries (row, column), 0-based, of M_k = D_r^T D_k that form the equations of each loop:
#: (2,1), (3,1), (3,2) 1-based, i.e. (w_z, -w_y, w_x) of M = I + [w]x (the float test's choice,
#: :data:`spherekin.closure.TRANSVERSAL_ENTRIES`).
LOOP_ENTRIES = ((1, 0), (2, 0), (2, 1))


# --------------------------------------------------------------------------------------------
# Public API
# --------------------------------------------------------------------------------------------

def certify_extended(mechanism, inputs, theta, radii: Sequence[float] = EXTENDED_RADII, *,
                     arithmetic: str = "arb") -> KrawczykResult:
    """Krawczyk tests of X = theta +- r (radians) for r in ``radii``, ascending: the first success or the last failure.

    ``mechanism``: a :class:`~spherekin.mechanism.SphericalMechanism`; ``inputs``: one reading per
    actuated joint (``mechanism.actuated`` order); ``theta``: the passive readings y (a sequence in
    ``mechanism.loop_unknowns`` order or a mapping name -> angle). y = theta exactly (floats),
    X = [y - r, y + r] (endpoints in extended precision, rounded outward), C the float inverse of
    the float J(y). Certified iff K(X) lies in the interior of X and every diagonal entry of every
    loop's M_k is > 0 over X: then X holds exactly one assembly of the mechanism given by its floats
    (module docstring). ``no_solution``: K(X) misses X or an equation's enclosure over X excludes 0.
    A singular midpoint Jacobian (rcond < :data:`EXTENDED_RCOND_MIN`) or a non-square system fails
    at once ("not certified: not square" for redundant actuation). The result is a
    :class:`~spherekin.trust.krawczyk.KrawczykResult`: ``box``/``krawczyk_box`` as float (lo, hi)
    rounded outward from the extended values, ``residual`` a bound on max |F(y)|,
    ``singular_values`` of the float J(y), ``angle_tolerance`` 0.0 (exact constants). ``arithmetic``:
    a name of :data:`ARITHMETICS` (the numbers the test is computed in; the verdicts agree).
    """
    arith = _arithmetic(arithmetic)
    with arith.precision():
        return _certify(_Plan(mechanism, inputs, arith=arith), theta, radii)


def _certify(plan: "_Plan", theta, radii) -> KrawczykResult:
    y = check_angles(plan.names, theta)
    rs = check_radii(radii)
    ctx = plan.ctx
    y_iv = [ctx.mpf(v) for v in y]                 # exact
    f_y, sv, c = _at_point(plan, y_iv, y)
    base = dict(names=plan.names, center=tuple(float(v) for v in y), residual=_magnitude_up(f_y),
                singular_values=sv, n_equations=plan.n_eq, n_unknowns=plan.m, subsystem_rows=None,
                other_bound=0.0, angle_tolerance=0.0)
    tried, res = [], None
    for r in rs:
        tried.append(r)
        x = [ctx.make_mpf((_raw(yv - r)[0], _raw(yv + r)[1])) for yv in y_iv]   # [y - r, y + r] outward
        res = _test_box(plan, base, r, x, y_iv, f_y, c)
        if res.certified or res.krawczyk_box is None:
            break
    return replace(res, radii_tried=tuple(tried))


#: Newton steps at most in :func:`polish_extended`. Reason: from a float point next to a near-double
#: root (off by up to ~sqrt(1e-16) = 1e-8 of a pair ~1e-8 apart) Newton first halves its distance
#: per step (a double root's linear phase) and then doubles its digits: ~30 steps reach 1e-30.
EXTENDED_NEWTON_STEPS = 60
#: :func:`polish_extended` stops when a step is below this (radians): far below the smallest radius
#: the test uses (1e-13) and far above the working precision (1e-50).
EXTENDED_NEWTON_TOL = 1e-30
#: :func:`polish_extended` gives up when its smallest step so far has not shrunk by half within this
#: many steps. Reason: converging, Newton at least halves its step every step (a double root's linear
#: phase, then quadratic); next to a complex pair, where the mechanism has no assembly (an input past
#: a fold), its steps bounce at about the pair's imaginary part (~3e-8 at 1e-15 from a fold) for all
#: EXTENDED_NEWTON_STEPS steps (~0.5 s each time at a 3-RRR); 8 leaves room for a start that wanders
#: a few steps before the halving sets in. Giving up proves nothing: the point stays unproven.
EXTENDED_NEWTON_STALL = 8


def polish_extended(mechanism, inputs, theta, steps: int = EXTENDED_NEWTON_STEPS, *,
                    arithmetic: str = "arb") -> np.ndarray | None:
    """Newton's method on this module's equations F in extended precision from ``theta`` (passive
    readings, ``mechanism.loop_unknowns`` order): the root it converges to, rounded to floats, or
    None (no convergence within ``steps``, a smallest step not halved within EXTENDED_NEWTON_STALL
    steps, a singular Jacobian, or a system that is not square).

    Why: next to a branch or change point the float polish (:mod:`spherekin.trust.polish`) stops
    ~1e-16 / sigma_min away from a root (a valley of near-solutions ~1e-7 long where two roots are
    ~5e-8 apart); the Krawczyk test at radii below their separation needs a point ~1e-16 from the
    root. Nothing is proven here: the point is only a candidate for :func:`certify_extended`.
    """
    arith = _arithmetic(arithmetic)
    with arith.precision():
        return _polish(_Plan(mechanism, inputs, arith=arith), theta, steps)


def _polish(plan: "_Plan", theta, steps: int) -> np.ndarray | None:
    import mpmath

    y0 = check_angles(plan.names, theta)
    if not plan.square or plan.m == 0:
        return None
    ctx = plan.ctx
    with mpmath.workdps(EXTENDED_DIGITS):
        y = [mpmath.mpf(float(v)) for v in y0]
        smallest, since = math.inf, 0
        for _ in range(steps):
            f, _, jac = plan.evaluate([ctx.mpf(v) for v in y], jacobian=True)
            step = ctx.newton_step(jac, f)
            if step is None:
                return None
            y = [a - b for a, b in zip(y, step)]
            if not all(mpmath.isfinite(v) for v in y):
                return None
            size = max(abs(v) for v in step)
            if size < EXTENDED_NEWTON_TOL:
                return np.array([float(v) for v in y])
            if size <= smallest / 2:
                smallest, since = size, 0
            else:
                since += 1
                if since >= EXTENDED_NEWTON_STALL:
                    return None
    return None


def krawczyk_boxes_extended(mechanism, inputs, lo, hi, *, arithmetic: str = "arb") -> BoxTests:
    """Krawczyk tests of B boxes [lo, hi] (arrays (B, M), radians, ``mechanism.loop_unknowns`` order).

    The meaning of :func:`spherekin.trust.krawczyk.krawczyk_many`, in extended precision on the
    equations of this module: y_b is the exact midpoint of box b (computed in extended precision),
    ``certified`` (B,): K(X_b) in the interior of X_b and every diag(M_k) > 0 on X_b (exactly one
    assembly in X_b); ``no_solution`` (B,): K(X_b) misses X_b or an equation's enclosure over X_b
    excludes 0 (no assembly in X_b); ``krawczyk_lo``/``krawczyk_hi`` (B, M): floats enclosing K(X_b),
    rounded outward (nan where the system is not square or J(y_b) is singular: then no_solution
    may still hold from the enclosures of F). ``arithmetic``: a name of :data:`ARITHMETICS`.
    """
    arith = _arithmetic(arithmetic)
    with arith.precision():
        return _boxes(_Plan(mechanism, inputs, arith=arith), lo, hi)


def _boxes(plan: "_Plan", lo, hi) -> BoxTests:
    m = plan.m
    lo = np.asarray(lo, dtype=float)
    hi = np.asarray(hi, dtype=float)
    if lo.ndim != 2 or lo.shape != hi.shape or lo.shape[1] != m or not np.all(np.isfinite(lo) & np.isfinite(hi)) \
            or np.any(lo > hi):
        raise ValueError(f"lo, hi: expected two (B, {m}) arrays of finite angles with lo <= hi, got shapes "
                         f"{lo.shape} and {hi.shape}")
    b = len(lo)
    certified, no_solution = np.zeros(b, bool), np.zeros(b, bool)
    k_lo, k_hi = np.full((b, m), np.nan), np.full((b, m), np.nan)
    ctx = plan.ctx
    for i in range(b):
        x = [ctx.mpf([float(a), float(c)]) for a, c in zip(lo[i], hi[i])]
        y_iv = [(ctx.mpf(float(a)) + ctx.mpf(float(c))) / 2 for a, c in zip(lo[i], hi[i])]   # the midpoint, enclosed
        f_y, _, c = _at_point(plan, y_iv, 0.5 * (lo[i] + hi[i]))
        out = _box_core(plan, x, y_iv, f_y, c, bounds=(lo[i], hi[i]))
        no_solution[i] = out["disjoint"] or out["excluded"]
        if out["k"] is not None:
            k_lo[i], k_hi[i] = zip(*(_outward(v) for v in out["k"]))
            certified[i] = out["inside"] and out["diagonal_ok"] and not out["disjoint"]
    return BoxTests(certified, no_solution, k_lo, k_hi)


def leg_rotations_extended(mechanism, joint_angles: Mapping[str, float]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The platform rotation along each leg, D_leg R_ref, enclosed in extended precision, as float bounds.

    ``joint_angles``: every joint's reading (name -> radians). Returns leg name -> (lo, hi), two
    (3, 3) float arrays rounded outward from the extended enclosure (what
    ``mechanism.forward(joint_angles).leg_poses`` computes in floats; the tests compare the two).
    R_ref enters as its floats; the certified equations do not use it (module docstring).
    """
    readings = _check_readings(mechanism, joint_angles)
    arith = _arithmetic("arb")
    with arith.precision():
        return _leg_rotations(mechanism, readings, arith)


def _leg_rotations(mechanism, readings: dict, arith) -> dict:
    plan = _Plan(mechanism, [readings[n] for n in mechanism.actuated], check_ranges=False, arith=arith)
    ctx = plan.ctx
    x = [ctx.mpf(readings[n]) for n in plan.names]
    ref = [[ctx.mpf(float(v)) for v in row] for row in mechanism.platform_reference]
    if plan.tails[0][0] is not None:
        # a 3-RRR's legs give the pose P(x) of its description: D = P(x) P(x_ref)^T, x_ref the
        # joints' reference readings (both P exact rotations, enclosed)
        at_ref = _Plan(mechanism, [j.reference_angle for j in mechanism.joints if j.actuated], check_ranges=False,
                       arith=arith)
        x_ref = [at_ref.ctx.mpf(float(mechanism.joint(n).reference_angle)) for n in at_ref.names]
    out = {}
    for k, name in enumerate(plan.chain_names[:plan.n_legs]):
        d, _ = plan.leg_rotation(k, x, jacobian=False)
        if plan.tails[0][k] is not None:
            p_ref, _ = at_ref.leg_rotation(k, x_ref, jacobian=False)
            d = _matmul(d, [[p_ref[j][i] for j in range(3)] for i in range(3)])     # P(x_ref)^T
        bounds = [[_outward(v) for v in row] for row in _matmul(d, ref)]
        out[name] = (np.array([[b[0] for b in row] for row in bounds]),
                     np.array([[b[1] for b in row] for row in bounds]))
    return out


# --------------------------------------------------------------------------------------------
# The equations in extended interval arithmetic
# --------------------------------------------------------------------------------------------

class _Numbers:
    """One number system for the equations: (cos, sin), 0 and 1 of the private ``iv`` context
    (enclosures) or of floats (the float J(y) that gives C and the singular values)."""

    __slots__ = ("cos_sin", "zero", "one")

    def __init__(self, cos_sin, zero, one):
        self.cos_sin = cos_sin
        self.zero = zero
        self.one = one


class _JointPlan:
    """One joint on one chain in one number system: its unit axis a (enclosed, for intervals), a a^T,
    its reference angle, the sign it turns with along the chain (+1, or -1 when the chain crosses it
    from its second link to its first), and either the index of its unknown or its rotation
    Rot(a, sign (input - reference))."""

    __slots__ = ("axis", "outer", "reference", "sign", "unknown", "rotation")

    def __init__(self, axis, outer, reference, sign, unknown, rotation):
        self.axis = axis
        self.outer = outer
        self.reference = reference
        self.sign = sign
        self.unknown = unknown
        self.rotation = rotation


class _Plan:
    """Everything one call needs, built per call: the equations in interval arithmetic at
    EXTENDED_BITS (``exact``; ``ctx`` one of :data:`ARITHMETICS`) and in floats (``approx``, for C
    and the singular values only).

    ``names``: the unknowns (``mechanism.loop_unknowns``); ``chain_names``: a label per chain (the
    legs first, for legs, then each loop's chains from its root link: ``mechanism.loop_geometry``'s
    ``up`` and ``down``); ``loops``: (index of the up chain k, index of the down chain r) per loop;
    ``n_eq`` = 3 * loops, ``m`` = unknowns, ``square``.
    """

    def __init__(self, mechanism, inputs, check_ranges: bool = True, arith=None):
        if not isinstance(mechanism, SphericalMechanism):
            raise ValueError(f"mechanism: expected a SphericalMechanism, got {type(mechanism).__name__}")
        values = mechanism.check_inputs(inputs) if check_ranges else tuple(float(v) for v in inputs)
        ctx = _arithmetic("arb") if arith is None else arith      # its numbers; built inside its precision()
        self.ctx = ctx
        self.exact_numbers = _Numbers(ctx.cos_sin, ctx.mpf(0), ctx.mpf(1))
        self.float_numbers = _Numbers(lambda d: (math.cos(d), math.sin(d)), 0.0, 1.0)
        self.names = tuple(mechanism.loop_unknowns)
        known = dict(zip(mechanism.actuated, values))
        index = {n: i for i, n in enumerate(self.names)}
        for j in mechanism.joints:
            if j.name not in known and j.name not in index:
                raise ValueError(f"mechanism: passive joint {j.name!r} appears in no loop")
        # every chain once: the legs (leg_rotations_extended), then the loops' chains
        chains: dict[tuple, int] = {}
        labels = []
        for leg in mechanism.legs:
            chains.setdefault(tuple((j.name, 1) for j in leg.joints), len(chains))
            labels.append(leg.name)
        self.n_legs = len(mechanism.legs)
        loops = []
        for g in mechanism.loop_geometry:
            ends = []
            for side, label in ((g.up, g.legs[0]), (g.down, g.legs[1])):
                key = tuple((st.joint, st.sign) for st in side)
                if key not in chains:
                    chains[key] = len(chains)
                    labels.append(label)
                ends.append(chains[key])
            loops.append(tuple(ends))
        joints = {j.name: j for j in mechanism.joints}
        record = _three_rrr_record(mechanism)
        legs = None if record is None else _rrr_leg_constants(record, mechanism.legs)
        exact, approx, tails_exact, tails_approx = [], [], [], []
        for key in chains:
            if legs is None:
                # the direction of the joint's floats as given (its axis: that direction rounded)
                consts = [(_unit_exact(ctx, joints[n].given_axis), ctx.mpf(float(joints[n].reference_angle)))
                          for n, _ in key]
                floats = [(list(joints[n].axis), float(joints[n].reference_angle)) for n, _ in key]
                tail = tail_float = None
            elif key in legs:
                raw_consts, raw_tail, floats, tail_float = legs[key]
                consts = [([ctx.make_mpf(v) for v in axis], ctx.make_mpf(ref)) for axis, ref in raw_consts]
                tail = [[ctx.make_mpf(v) for v in row] for row in raw_tail]
            else:
                raise ValueError(f"mechanism: the chain {[n for n, _ in key]} of a kind \"3-RRR\" mechanism is "
                                 "not a leg")
            exact.append(tuple(self._joint(joints[n], sign, known, index, a, r, True)
                               for (n, sign), (a, r) in zip(key, consts)))
            approx.append(tuple(self._joint(joints[n], sign, known, index, list(a), r, False)
                                for (n, sign), (a, r) in zip(key, floats)))
            tails_exact.append(tail)
            tails_approx.append(tail_float)
        self.exact = tuple(exact)
        self.approx = tuple(approx)
        self.tails = (tuple(tails_exact), tuple(tails_approx))
        self.chain_names = tuple(labels)
        self.loops = tuple(loops)
        self.n_eq = 3 * len(self.loops)
        self.m = len(self.names)
        self.square = self.n_eq == self.m

    def _joint(self, joint, sign: int, known: dict, index: dict, axis, ref, exact: bool) -> _JointPlan:
        """The joint's plan from its constants (``axis``: the unit vector at the reference configuration,
        ``ref``: its reading there; enclosures of the exact ones when ``exact``, else floats next to them)."""
        if exact:
            num = self.exact_numbers
            fixed = self.ctx.mpf(known[joint.name]) if joint.name in known else None    # exact
        else:
            num = self.float_numbers
            fixed = known.get(joint.name)
        outer = [[axis[p] * axis[q] for q in range(3)] for p in range(3)]
        if fixed is None:
            return _JointPlan(axis, outer, ref, sign, index[joint.name], None)
        return _JointPlan(axis, outer, ref, sign, None, _rodrigues(num, axis, outer, sign * (fixed - ref)))

    def leg_rotation(self, leg: int, x, jacobian: bool, exact: bool = True):
        """D = Rot(a_1, s_1 d_1) ... Rot(a_k, s_k d_k) of chain number ``leg`` at the unknowns x
        (intervals, or floats when not ``exact``), and the rates of its passive joints' rotations,
        s_i w_i with w_i = Rot(a_1, s_1 d_1) ... Rot(a_{i-1}, s_{i-1} d_{i-1}) a_i, as (unknown
        index, s_i w_i) pairs (empty unless ``jacobian``)."""
        num = self.exact_numbers if exact else self.float_numbers
        p = None
        currents = []
        for jp in (self.exact if exact else self.approx)[leg]:
            if jp.unknown is None:
                rot = jp.rotation
            else:
                if jacobian:
                    w = jp.axis if p is None else _matvec(p, jp.axis)
                    currents.append((jp.unknown, w if jp.sign > 0 else [-w[0], -w[1], -w[2]]))
                rot = _rodrigues(num, jp.axis, jp.outer, jp.sign * (x[jp.unknown] - jp.reference))
            p = rot if p is None else _matmul(p, rot)
        tail = self.tails[0 if exact else 1][leg]
        return (p if tail is None else _matmul(p, tail)), currents

    def evaluate(self, x, jacobian: bool, exact: bool = True):
        """At the unknowns x (intervals, or floats when not ``exact``): F (n_eq values, LOOP_ENTRIES
        of each M_k), the diagonal entries of each M_k (3 per loop), and J (n_eq rows of m values;
        None unless ``jacobian``)."""
        zero = (self.exact_numbers if exact else self.float_numbers).zero
        legs = [self.leg_rotation(k, x, jacobian, exact) for k in range(len(self.chain_names))]
        f, diag, jac = [], [], []
        for k, r in self.loops:
            dk, wk = legs[k]
            dr, wr = legs[r]
            col_k = [[dk[p][j] for p in range(3)] for j in range(3)]      # D_k e_j
            col_r = [[dr[p][i] for p in range(3)] for i in range(3)]      # D_r e_i
            for i in range(3):
                diag.append(_dot(col_r[i], col_k[i]))
            for i, j in LOOP_ENTRIES:
                u, v = col_r[i], col_k[j]
                f.append(_dot(u, v))                                       # (M_k)_ij = u . v
                if jacobian:
                    row = [zero] * self.m
                    vxu = _cross(v, u)
                    for idx, w in wk:
                        row[idx] = row[idx] + _dot(w, vxu)                 # d/d reading, leg k
                    for idx, w in wr:
                        row[idx] = row[idx] - _dot(w, vxu)                 # d/d reading, leg r
                    jac.append(row)
        return f, diag, (jac if jacobian else None)


def _three_rrr_record(mechanism):
    """The :class:`~spherekin.mechanism.rrr.ThreeRRRGeometry` of a kind "3-RRR" mechanism (its
    description's floats as given), or None for the other kinds (their joints' ``given_axis`` and
    ``reference_angle`` are the file's numbers)."""
    g = mechanism.geometry
    if mechanism.kind != "3-RRR" or not isinstance(g, ThreeRRRGeometry):
        return None
    if tuple(j.name for j in mechanism.joints) != rrr_joint_names() or len(mechanism.legs) != 3 \
            or any(len(leg.joints) != 3 for leg in mechanism.legs):
        raise ValueError("mechanism: a kind \"3-RRR\" mechanism whose legs are not beta_i, gamma_i, delta_i")
    return g


#: How many 3-RRR descriptions keep their legs' constants (:func:`_rrr_leg_constants`) between calls.
#: Reason: they depend on the description alone, cost ~8 ms to compute at EXTENDED_DIGITS (square
#: roots, a cosine and a sine, 3 x 3 products per leg: more than a Krawczyk test), and one solve calls
#: this module up to 1,000 times on one mechanism; a batch or a campaign works on a few at a time.
RRR_CONSTANTS_CACHE = 16


@functools.lru_cache(maxsize=RRR_CONSTANTS_CACHE)
def _rrr_leg_constants(g, legs) -> dict:
    """Chain key -> (per joint (axis, reference reading), tail T) of each leg of a 3-RRR, written in
    extended precision from its description's floats as given (``g``: its
    :class:`~spherekin.mechanism.rrr.ThreeRRRGeometry`; ``legs``: its legs; module docstring,
    "3-RRR"), as raw interval endpoints (mpmath's, EXTENDED_DIGITS; every arithmetic of
    :data:`ARITHMETICS` reads them with ``make_mpf``), then the same as floats next to them. ValueError unless the legs
    are those the description gives: at the joints' reference readings, each joint's current axis
    within RECORD_MATCH_TOL of its float axis (the platform reference, which only names the pose,
    does not enter the equations)."""
    ctx = _MpmathIntervals()
    offsets = g.offsets
    u_all, w_all, v_all = g.given_axes
    out = {}
    for i, leg in enumerate(legs):
        u, w0, v0 = (_unit_exact(ctx, vs[i]) for vs in (u_all, w_all, v_all))
        r0 = _unit_exact(ctx, g.given_platform_directions[i])
        ca, sa = ctx.cos_sin(ctx.mpf(float(g.distal_link_angles[i])))
        p = _unit_of(ctx, [a - _dot(u, w0) * b for a, b in zip(u, w0)])      # u's direction normal to w0
        v_ref = [ca * a + sa * b for a, b in zip(w0, p)]                       # gamma = 0: v on u's side
        q = [sa * a - ca * b for a, b in zip(w0, p)]                           # w0's direction normal to v_ref
        q0 = _unit_of(ctx, [a - _dot(r0, v0) * b for a, b in zip(r0, v0)])    # r0's direction normal to v0
        frame, frame0 = (_columns(a, b, _cross(a, b)) for a, b in ((v_ref, q), (v0, q0)))
        tail = _matmul(frame, [list(col) for col in zip(*frame0)])             # T v0 = v_ref, T q0 = q
        axes = (u, w0, v_ref)
        refs = [-ctx.mpf(float(offsets[j.name])) for j in leg.joints]
        # the legs of the float model are these: each current axis at the joints' reference readings
        rot = np.eye(3)
        for axis, ref, j in zip(axes, refs, leg.joints):
            a = np.array([_mid(v) for v in axis])
            if not np.abs(rot @ a - np.array(j.axis)).max() <= RECORD_MATCH_TOL:
                raise ValueError(f"mechanism: joint {j.name!r} of a kind \"3-RRR\" mechanism is not the one its "
                                 "description (geometry) gives")
            rot = rot @ axis_rotation(a, float(j.reference_angle) - _mid(ref))
        out[tuple((j.name, 1) for j in leg.joints)] = (
            tuple((tuple(_raw(v) for v in axis), _raw(ref)) for axis, ref in zip(axes, refs)),
            tuple(tuple(_raw(v) for v in row) for row in tail),
            tuple((tuple(_mid(v) for v in axis), _mid(ref)) for axis, ref in zip(axes, refs)),
            tuple(tuple(_mid(v) for v in row) for row in tail))
    return out


def _unit_exact(ctx, vec):
    """The unit vector along the float vector ``vec``, enclosed (mpf(float) is exact)."""
    return _unit_of(ctx, [ctx.mpf(float(v)) for v in vec])


def _unit_of(ctx, vec):
    """vec / |vec| for an interval vector (encloses the exact unit vector of every vector in vec)."""
    norm = ctx.sqrt(vec[0] * vec[0] + vec[1] * vec[1] + vec[2] * vec[2])
    return [v / norm for v in vec]


def _columns(a, b, c):
    """The 3x3 matrix with columns a, b, c."""
    return [[a[i], b[i], c[i]] for i in range(3)]


def _mid(v) -> float:
    """A float next to the midpoint of an interval (a float is returned as is)."""
    if isinstance(v, float):
        return v
    m = v.mid
    return float(m() if callable(m) else m)


def _rodrigues(num: _Numbers, a, outer, d):
    """Rot(a, d) = cos d I + sin d [a]x + (1 - cos d) a a^T (a: the unit axis, enclosed for intervals)."""
    c, s = num.cos_sin(d)
    v = num.one - c
    sa = [s * a[0], s * a[1], s * a[2]]
    return [[c + v * outer[0][0], v * outer[0][1] - sa[2], v * outer[0][2] + sa[1]],
            [v * outer[1][0] + sa[2], c + v * outer[1][1], v * outer[1][2] - sa[0]],
            [v * outer[2][0] - sa[1], v * outer[2][1] + sa[0], c + v * outer[2][2]]]


class _MpmathIntervals:
    """mpmath's ``iv`` intervals at EXTENDED_DIGITS, in a private context (the shared ``mpmath.iv``
    keeps its precision): the reference arithmetic, slow and obviously correct. ``mpf`` makes an
    interval of a float, an mpmath number or a pair [lo, hi] (exact), ``make_mpf`` of raw endpoints."""

    name = "mpmath"

    def __init__(self):
        from mpmath.ctx_iv import MPIntervalContext

        self.ctx = MPIntervalContext()
        self.ctx.dps = EXTENDED_DIGITS
        self.mpf, self.make_mpf, self.sqrt = self.ctx.mpf, self.ctx.make_mpf, self.ctx.sqrt

    def newton_step(self, jac, f):
        """The solution (mpmath numbers) of mid(J) s = mid(F), by mpmath's LU; None when singular."""
        import mpmath

        def mid(v):
            return mpmath.mp.make_mpf(_mid_raw(v))

        try:
            step = mpmath.lu_solve(mpmath.matrix([[mid(v) for v in row] for row in jac]),
                                   mpmath.matrix([mid(v) for v in f]))
        except ZeroDivisionError:
            return None
        return [step[i] for i in range(len(f))]

    def cos_sin(self, d):
        """Enclosures of (cos d, sin d) for an interval d, in one range reduction (mpmath's mpi_cos_sin)."""
        from mpmath.libmp.libmpi import mpi_cos_sin
        c, s = mpi_cos_sin(d._mpi_, self.ctx.prec)
        return self.ctx.make_mpf(c), self.ctx.make_mpf(s)

    def precision(self):
        return contextlib.nullcontext()


class _ArbIntervals:
    """FLINT/Arb balls (python-flint's ``arb``) at EXTENDED_BITS: the default arithmetic, enclosures
    as rigorous as mpmath's intervals and several times faster (benchmarks/bench_extended.py). A pair
    [lo, hi] becomes the ball union of its ends (its radius rounded up: a little wider, never less).
    Its numbers are made and combined inside :meth:`precision` (python-flint's working precision is
    process-wide: it is set for the call and restored after)."""

    name = "arb"

    def __init__(self):
        import flint

        self._arb = flint.arb
        self._flint = flint

    def mpf(self, x):
        if isinstance(x, (list, tuple)):
            return self._arb(x[0]).union(self._arb(x[1]))
        return self._arb(x)                      # a float, an int or an mpmath number (its _mpf_): exact

    def make_mpf(self, raw):
        import mpmath

        lo, hi = raw
        a = self._arb(mpmath.mp.make_mpf(lo))
        return a if lo == hi else a.union(self._arb(mpmath.mp.make_mpf(hi)))

    def sqrt(self, v):
        return v.sqrt()

    def cos_sin(self, d):
        s, c = d.sin_cos()
        return c, s

    def newton_step(self, jac, f):
        """The solution (mpmath numbers, the balls' midpoints) of mid(J) s = mid(F), by FLINT's
        ``arb_mat.solve`` at the working precision; None when it finds mid(J) singular."""
        import mpmath

        mat = self._flint.arb_mat([[v.mid() for v in row] for row in jac])
        rhs = self._flint.arb_mat([[v.mid()] for v in f])
        try:
            sol = mat.solve(rhs)
        except (ZeroDivisionError, ValueError):
            return None
        return [mpmath.mp.make_mpf(sol[i, 0].mid()._mpf_) for i in range(len(f))]

    def precision(self):
        return self._flint.ctx.workprec(EXTENDED_BITS)


#: The interval arithmetics of the extended-precision test, by name (``arithmetic=`` of the public
#: functions): "arb" (python-flint, the default) and "mpmath" (the reference).
ARITHMETICS = {"arb": _ArbIntervals, "mpmath": _MpmathIntervals}


def _arithmetic(name: str):
    if name not in ARITHMETICS:
        raise ValueError(f"arithmetic: expected one of {', '.join(ARITHMETICS)}, got {name!r}")
    return ARITHMETICS[name]()


def _matmul(p, q):
    return [[p[i][0] * q[0][j] + p[i][1] * q[1][j] + p[i][2] * q[2][j] for j in range(3)] for i in range(3)]


def _matvec(p, a):
    return [p[i][0] * a[0] + p[i][1] * a[1] + p[i][2] * a[2] for i in range(3)]


def _dot(u, v):
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


def _cross(u, v):
    return [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]


# --------------------------------------------------------------------------------------------
# The Krawczyk test
# --------------------------------------------------------------------------------------------

def _at_point(plan: _Plan, y_iv, y_float):
    """At the point y: F(y) enclosed (y_iv: exact intervals), the singular values of the float J at
    y_float (a float next to y; descending), and C (:func:`_preconditioner`)."""
    f_y, _, _ = plan.evaluate(y_iv, jacobian=False)
    _, _, j_y = plan.evaluate([float(v) for v in y_float], jacobian=True, exact=False)
    j_float = np.array(j_y, dtype=float).reshape(plan.n_eq, plan.m)
    sv = tuple(float(v) for v in np.linalg.svd(j_float, compute_uv=False)) if j_float.size else ()
    return f_y, sv, _preconditioner(plan, j_float, sv)


def _preconditioner(plan: _Plan, j_float: np.ndarray, sv: tuple):
    """C = the float inverse of the float J(y), as exact intervals; None when the system is not
    square or J(y) is singular (rcond below EXTENDED_RCOND_MIN). Any C is valid; a good one makes K small."""
    if not plan.square or plan.m == 0 or not sv or not np.all(np.isfinite(j_float)) \
            or not sv[-1] > EXTENDED_RCOND_MIN * sv[0]:
        return None
    c = np.linalg.inv(j_float)
    if not np.all(np.isfinite(c)):
        return None
    return [[plan.ctx.mpf(float(v)) for v in row] for row in c]


class _ListIntervals:
    """The arithmetic of :func:`spherekin.core.krawczyk.krawczyk_operator` on mpmath intervals: vectors
    are lists of intervals, matrices lists of rows; C is a matrix of exact intervals (floats)."""

    __slots__ = ("zero", "one")

    def __init__(self, num: _Numbers):
        self.zero, self.one = num.zero, num.one

    def point(self, y):
        return list(y)

    def add(self, a, b):
        return [u + v for u, v in zip(a, b)]

    def sub(self, a, b):
        return [u - v for u, v in zip(a, b)]

    def eye_minus(self, a):
        return [[(self.one - v) if i == j else -v for j, v in enumerate(row)] for i, row in enumerate(a)]

    def cmatvec(self, c, v):
        return [_sum([ci[p] * v[p] for p in range(len(v))], self.zero) for ci in c]

    def cmatmat(self, c, a):
        return [[_sum([ci[p] * a[p][j] for p in range(len(a))], self.zero) for j in range(len(a[0]))] for ci in c]

    matvec = cmatvec


def _krawczyk_operator(num: _Numbers, y, f_y, c, j_x, x):
    """K(X) = y - C F(y) + (I - C J(X)) (X - y) in mpmath intervals (lists; c, j_x: m x m):
    :func:`spherekin.core.krawczyk.krawczyk_operator` with :class:`_ListIntervals`. Every root of F in
    X lies in K(X) (Krawczyk; Moore)."""
    return krawczyk_operator(_ListIntervals(num), y, f_y, c, j_x, [xv - yv for xv, yv in zip(x, y)])


def _sum(values, zero):
    acc = zero
    for v in values:
        acc = acc + v
    return acc


def _box_core(plan: _Plan, x, y, f_y, c, bounds=None) -> dict:
    """One box X (intervals) around y: F, diag(M), J over X, K(X) (None when c is None), and the verdicts.

    ``bounds``: the floats (lo, hi) X was made from, when X may be wider (a ball around them): K(X) is
    then held against them, so that the verdicts are about the box the caller gave (the roots of F in
    that box lie in X, hence in K(X))."""
    f_x, diag_x, j_x = plan.evaluate(x, jacobian=c is not None)
    excluded = any(_lo(v) > 0 or _hi(v) < 0 for v in f_x)
    bad_diag = [(i, v) for i, v in enumerate(diag_x) if not _lo(v) > 0]
    out = dict(f_x=f_x, excluded=excluded, diagonal_ok=not bad_diag, bad_diag=bad_diag, k=None,
               inside=False, disjoint=False)
    if c is None:
        return out
    k = _krawczyk_operator(plan.exact_numbers, y, f_y, c, j_x, x)
    out["k"] = k
    ends = [(_lo(xv), _hi(xv)) for xv in x] if bounds is None else list(zip(*bounds))
    out["inside"] = all(_lo(kv) > a and _hi(kv) < b for kv, (a, b) in zip(k, ends))
    out["disjoint"] = any(_hi(kv) < a or _lo(kv) > b for kv, (a, b) in zip(k, ends))
    return out


def _test_box(plan: _Plan, base: dict, r: float, x, y, f_y, c) -> KrawczykResult:
    """The KrawczykResult of the box X (intervals) of radius r around y."""
    common = dict(base, radius=r, box=tuple(_outward(v) for v in x), krawczyk_box=None, contraction=math.nan,
                  no_solution=False, radii_tried=(r,))
    out = _box_core(plan, x, y, f_y, c)
    common["no_solution"] = bool(out["excluded"])
    if not plan.square:
        return KrawczykResult(certified=False, reason=(
            f"not certified: not square ({plan.n_eq} equations, {plan.m} unknowns; redundant actuation is "
            "out of scope of the extended-precision test)"
            + ("; F excludes 0 over X, so X holds no solution" if out["excluded"] else "")), **common)
    if out["k"] is None:
        sv = base["singular_values"]
        smin = sv[-1] if sv else 0.0
        return KrawczykResult(certified=False, reason=(
            f"not certified: singular midpoint Jacobian (smallest singular value {smin:.3g}, "
            f"{smin / sv[0] if sv and sv[0] else 0.0:.3g} of the largest, below {EXTENDED_RCOND_MIN:g})"
            + ("; F excludes 0 over X, so X holds no solution" if out["excluded"] else "")), **common)
    k = out["k"]
    k_box = tuple(_outward(v) for v in k)
    ratio = max(_width_ratio(kv, xv) for kv, xv in zip(k, x)) if k else math.nan
    disjoint = out["disjoint"] or out["excluded"]
    common.update(krawczyk_box=k_box, contraction=ratio, no_solution=bool(disjoint))
    if out["inside"] and out["diagonal_ok"] and not disjoint:
        return KrawczykResult(certified=True, reason="", **common)
    names = base["names"]
    if out["disjoint"]:
        why = "K(X) does not meet X, so X holds no solution"
    elif out["excluded"]:
        why = "an equation's enclosure over X excludes 0, so X holds no solution"
    elif out["inside"]:
        i, v = out["bad_diag"][0]
        loop, entry = divmod(i, 3)
        k_leg, r_leg = plan.loops[loop]
        why = (f"K(X) lies inside X (one root of the loop entries) but the diagonal entry ({entry + 1},{entry + 1}) "
               f"of M = D_r^T D_k for the legs ({plan.chain_names[k_leg]!r}, {plan.chain_names[r_leg]!r}) is not > 0 "
               f"over X "
               f"(down to {_outward(v)[0]:.3g}): the root may be a half-turn M != I, not an assembly")
    else:
        x_box = common["box"]
        excess = [max(xb[0] - kb[0], kb[1] - xb[1]) for xb, kb in zip(x_box, k_box)]
        worst = int(np.argmax(excess))
        why = (f"K(X) is not inside X (contraction {ratio:.3g}; {names[worst]!r} leaves X by "
               f"{excess[worst]:.3g} rad)")
    return KrawczykResult(certified=False, reason=f"not certified at radius {r:g}: {why}", **common)


# --------------------------------------------------------------------------------------------
# Helpers: interval endpoints, outward rounding, checks
# --------------------------------------------------------------------------------------------

def _raw(v):
    """The endpoints (lo, hi) of an interval (mpmath's) or a ball (arb's: rounded outward at the
    working precision), as raw mpmath numbers (libmp tuples)."""
    mpi = getattr(v, "_mpi_", None)
    return mpi if mpi is not None else (v.lower()._mpf_, v.upper()._mpf_)


def _mid_raw(v):
    """The midpoint of an interval or a ball, as a raw mpmath number (for Newton's floats-free steps)."""
    mpi = getattr(v, "_mpi_", None)
    return v.mid._mpi_[0] if mpi is not None else v.mid()._mpf_


def _lo(v):
    """The lower endpoint of an interval, exactly (a :class:`_Raw`, comparable with floats and other endpoints)."""
    return _Raw(_raw(v)[0])


def _hi(v):
    """The upper endpoint of an interval, exactly."""
    return _Raw(_raw(v)[1])


class _Raw:
    """A raw mpmath number (libmp tuple) with exact comparisons."""

    __slots__ = ("value",)

    def __init__(self, value):
        self.value = value

    def _cmp(self, other) -> int:
        from mpmath.libmp import from_float, mpf_cmp
        o = other.value if isinstance(other, _Raw) else from_float(float(other))
        return mpf_cmp(self.value, o)

    def __lt__(self, other):
        return self._cmp(other) < 0

    def __gt__(self, other):
        return self._cmp(other) > 0


def _round(raw, up: bool) -> float:
    """The float next to the raw mpf ``raw`` on the side ``up`` (so it bounds raw from that side)."""
    from mpmath.libmp import finf, fninf, from_float, mpf_cmp, to_float
    if raw == finf or raw == fninf:
        return math.inf if raw == finf else -math.inf
    f = to_float(raw, rnd="c" if up else "f")
    c = mpf_cmp(from_float(f), raw)
    if up and c < 0:
        f = math.nextafter(f, math.inf)
    elif not up and c > 0:
        f = math.nextafter(f, -math.inf)
    return f


def _outward(v) -> tuple[float, float]:
    """Floats (lo, hi) enclosing the interval v."""
    a, b = _raw(v)
    return _round(a, up=False), _round(b, up=True)


def _magnitude_up(values) -> float:
    """An upper bound (float) on max |v| over the intervals ``values``."""
    out = 0.0
    for v in values:
        lo, hi = _outward(v)
        out = max(out, -lo, hi)
    return out


def _width_ratio(k, x) -> float:
    """width(k) / width(x) for intervals, to float (computed in extended precision: the widths
    can be far below the float spacing of the angles)."""
    from mpmath.libmp import mpf_div, mpf_sub, round_ceiling, round_floor, to_float
    (k_lo, k_hi), (x_lo, x_hi) = _raw(k), _raw(x)
    kw = mpf_sub(k_hi, k_lo, 64, round_ceiling)
    xw = mpf_sub(x_hi, x_lo, 64, round_floor)
    if not to_float(xw) > 0:
        return math.inf
    return to_float(mpf_div(kw, xw, 64, round_ceiling))


def _check_readings(mechanism, joint_angles) -> dict[str, float]:
    if not isinstance(joint_angles, Mapping):
        raise ValueError(f"joint_angles: expected a mapping joint name -> angle (radians), got {joint_angles!r}")
    missing = [n for n in mechanism.joint_names if n not in joint_angles]
    if missing:
        raise ValueError(f"joint_angles: missing angle(s) for {missing}")
    out = {}
    for n in mechanism.joint_names:
        v = float(joint_angles[n])
        if not math.isfinite(v):
            raise ValueError(f"joint_angles[{n!r}]: expected a finite angle (radians), got {joint_angles[n]!r}")
        out[n] = v
    return out
