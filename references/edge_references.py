"""Independent 50-digit references at the edges of spherical mechanisms (issue 26, item 2).

Everything here is computed from a mechanism's numbers as given (issue 40: what a proof is about):
its *joint axes* as given (``mech.legs[i].joints[j].given_axis``, ``.actuated``, ``.reference_angle``
and ``mech.platform_reference_matrix``), or for a kind "3-RRR" its description (base axes, elbow axes
at zero, platform axes as given, distal link angles, joint offsets: :func:`description_of`), or a
mechanism file read with tomllib (:func:`read_rrr_file`, :func:`read_graph_file`), converted exactly
to mpmath (``mpmath.mpf(float)`` is exact) and normalized there, at :data:`DIGITS` decimal digits
(:func:`precision`: another). spherekin's loop equations, its solver and its trust layer are never
called; the floats are the design, so a design that is a change-point mechanism on paper is, in
floats, within ~1e-16 of one, and the references say what that float design does. (Not its float
model: a 3-RRR's float joint axes are rotated and normalized in floats, another design ~1e-16 away,
whose folds lie up to ~4e-15 from the description's.)

Mechanisms of two legs (spherical four-bar and five-bar)
    The reference leg is (A*, B) with A actuated; the other leg is (D, C) (four-bar: D a passive
    base joint) or (E*, D, C) (five-bar: E actuated). At inputs theta, B(theta) = Rot(A, theta_A -
    ref_A) B0 and Q = D (four-bar) or Q = Rot(E, theta_E - ref_E) D0 (five-bar); the platform joint
    C lies at a = angle(B0, C0) from B and b = angle(D0, C0) from Q. With c = cos angle(B, Q), C =
    alpha B + beta Q + gamma (B x Q), and the Gram determinant of (B, Q, C),

        disc = 1 - c^2 - cos^2 a - cos^2 b + 2 c cos a cos b = (cos(a - b) - c) (c - cos(a + b)),

    decides the number of assemblies: 2 when disc > 0, 1 when disc = 0 (a double assembly), 0 when
    disc < 0 (:func:`two_leg_reference`). The branch inputs are where angle(B, Q) = |a - b| or
    min(a + b, 2 pi - a - b): c(theta_A) = P cos(phi) + S' sin(phi) + S is a sinusoid in
    phi = theta_A - ref_A, solved in closed form (:func:`two_leg_edges`). A *change point* is an
    extremum of c that touches one of the two values (a double root of disc); in floats it is within
    ~1e-16 of touching, so it is either two branch inputs ~1e-8 apart or no branch input at all,
    and the reference says which.

3-RRR
    The leg constraints w_i(beta_i) . (R' v_i) = w_i . v_i (the distal link angle), with the axes
    u_i, w_i, v_i of the reference configuration, w_i(beta_i) = Rot(u_i, beta_i - ref_i) w_i and R'
    the platform's displacement from the reference configuration (the reported pose is R' P, P the
    platform reference), as homogeneous quadrics in the quaternion of R'. The roots are found as in
    :mod:`references.reference_roots` (eigen-candidates of the degree-8 problem, complex Newton at
    50 digits, restarts until the 8 Bezout roots are distinct), but with the quadrics built at 50
    digits from the description's numbers as given (a 3-RRR of another kind: from its joint axes;
    reference_roots rebuilds them from the description lists normalized in floats, a design that
    differs in the last bit, enough to move a fold by ~1e-16), and with
    what it takes to separate the two roots of a pair 1e-16 from a fold (~1e-8 apart, where the
    eigen-candidates no longer do) or 1e-16 from the agile eye's singular lines (~1e-16 apart): the
    conjugate of each complex root, starts for a pair from the null direction of the Jacobian, and
    restarts with deflation (:func:`_rrr_roots`). A description (or file) is read with every vector
    the direction of its floats, w_i(beta_i) = Rot(u_i, beta_i + offset_i) w_i^0 and the pose R
    mapping v_i^0 to v_i (no platform reference). Undecided (``count`` None, with the reason): a
    degenerate design (no 8-dimensional null space: non-isolated roots), fewer than 8 distinct
    roots, two roots closer than :data:`DECIDE_SEPARATION`, or an odd number of real roots.
    :func:`rrr_singular_input` finds where the count changes along a segment to :data:`ROOT_ACCURACY`
    (references.reference_roots.singular_input bisects in floats, to ~1e-15).
"""

from __future__ import annotations

import contextlib
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import mpmath
import numpy as np

from references.peers_closed_form import candidate_points, leg_quadrics
from references.reference_roots import MAX_RESTARTS, leg_quadric_mp, quadric_system_mp, same_root
from spherekin.mechanism.chains import axis_rotation, sphere_point
from spherekin.mechanism.model import Joint, Leg, SphericalMechanism

__all__ = ["DIGITS", "CHANGE_TOL", "DECIDE_SEPARATION", "DISC_TOL", "ROOT_ACCURACY", "EdgeReference", "Edge",
           "four_bar", "five_bar", "two_leg_reference", "two_leg_edges", "two_leg_coincidences", "rrr_reference",
           "rrr_singular_input", "rrr_segment", "agile_eye_edge", "passive_angles", "inputs_at", "mp_axis", "precision",
           "file_angle", "RrrFile", "read_rrr_file", "description_of", "GraphFile", "read_graph_file", "watt_reference",
           "stephenson_reference", "graph_reference", "graph_folds", "SIX_BAR_TOL"]

#: Working precision (decimal digits).
DIGITS = 50
#: An extremum of cos angle(B, Q) within this of a branch value (1 - |x| in the normalized sinusoid)
#: is a change point (a double root of the discriminant) of the design: a design that is a change
#: point on paper misses it by ~1e-16 in floats; a generic design by far more than 1e-12.
CHANGE_TOL = mpmath.mpf("1e-12")
#: A 3-RRR reference is undecided when two of its 8 roots (real or complex, up to sign) are closer
#: than this: Newton's roots agree to ~1e-40, two roots of a pair 1e-16 from a fold are ~1e-8 apart,
#: and one at 1e-16 from a codimension-2 singular set of the agile eye ~1e-16 apart.
DECIDE_SEPARATION = mpmath.mpf("1e-22")
#: A two-leg reference is undecided when |disc| is below this (a double assembly to the working
#: precision; the smallest |disc| of the campaign, at the five-bar's coincidence 1e-16 from B = D,
#: is ~1e-33) or when 1 - cos^2 angle(B, Q) is (B and Q parallel: C on a circle).
DISC_TOL = mpmath.mpf("1e-45")
#: :func:`rrr_singular_input` locates x* to this (radians) and checks that the count changes across
#: it at this distance: far below the smallest distance approached (1e-16), while the merging pair
#: is still ~1e-10 apart, which the 50-digit Newton resolves (at ~1e-24 it sometimes does not).
ROOT_ACCURACY = mpmath.mpf("1e-20")
#: Newton steps per start: quadratic convergence from the eigen-candidates takes ~6; next to a fold
#: (candidates ~1e-8 off, a pair ~1e-8 apart) ~30 linear steps; a real start between a complex pair
#: never converges and is then handed to :func:`_pair_starts`.
NEWTON_STEPS = 80
#: Newton has converged when its step is below 10^-(DIGITS - 10), or below SMALL_STEP with the
#: residual below TINY_RESIDUAL: at a root whose Jacobian has a singular value ~1e-12 (the agile
#: eye next to its singular lines) the steps stall at ~1e-50 / 1e-12 while the residual is at
#: the working precision, the root then known to ~1e-35, far inside SAME_ROOT.
SMALL_STEP = mpmath.mpf("1e-25")
TINY_RESIDUAL = mpmath.mpf(10) ** (-(DIGITS - 3))


# ------------------------------------------------------------------------------ small mp helpers

_PRECISION = [DIGITS]


@contextlib.contextmanager
def precision(digits: int):
    """Every reference computed inside ``with precision(digits):`` works at ``digits`` decimal digits
    instead of DIGITS (the tolerances that follow the precision, Newton's and TINY_RESIDUAL's, with it;
    the fixed ones, DECIDE_SEPARATION, SMALL_STEP, ROOT_ACCURACY, stay)."""
    _PRECISION.append(int(digits))
    try:
        yield
    finally:
        _PRECISION.pop()


def _dps() -> int:
    return _PRECISION[-1]


def _tiny_residual():
    return mpmath.mpf(10) ** (-(_dps() - 3))


def mp_axis(v) -> list:
    """The direction of the float vector v in mpmath, normalized at DIGITS digits."""
    with mpmath.workdps(_dps()):
        x = [mpmath.mpf(float(t)) for t in v]
        n = mpmath.sqrt(sum(t * t for t in x))
        return [t / n for t in x]


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _rot(axis, angle, v):
    """Rot(axis, angle) v (Rodrigues; axis a unit mp vector)."""
    c, s = mpmath.cos(angle), mpmath.sin(angle)
    k = _cross(axis, v)
    d = _dot(axis, v)
    return [v[i] * c + k[i] * s + axis[i] * d * (1 - c) for i in range(3)]


def _angle(a, b):
    return mpmath.atan2(mpmath.sqrt(sum(t * t for t in _cross(a, b))), _dot(a, b))


def _frame(b, c):
    """The 3x3 mp matrix [b, c, b x c] (columns)."""
    n = _cross(b, c)
    return mpmath.matrix([[b[i], c[i], n[i]] for i in range(3)])


def _to_float(m) -> np.ndarray:
    return np.array([[float(m[i, j]) for j in range(m.cols)] for i in range(m.rows)])


def _mp(x):
    return x if isinstance(x, mpmath.mpf) else mpmath.mpf(float(x))


# ------------------------------------------------------------------------------ results

@dataclass(frozen=True)
class EdgeReference:
    """The reference at one input: ``count`` real assemblies (None: undecided, ``note`` says why),
    their platform ``rotations`` (float 3x3, from 50 digits; as spherekin's ``platform_rotation``),
    the same at 50 digits (``mp_rotations``), per assembly the current joint axes that fix it
    (``points``: joint name -> mp unit vector; two-leg mechanisms), the ``discriminant`` (two-leg:
    the Gram determinant; 3-RRR: None) and the smallest distance between two roots (3-RRR); six-bars:
    ``readings``, per assembly every joint's reading (name -> float, radians)."""

    count: int | None
    rotations: tuple = ()
    mp_rotations: tuple = field(default=(), repr=False)
    points: tuple = field(default=(), repr=False)
    discriminant: object = None
    min_separation: float | None = None
    note: str = ""
    readings: tuple = field(default=(), repr=False)


@dataclass(frozen=True)
class Edge:
    """An input where the number of assemblies changes or may change, to be approached.

    ``x_star``: the inputs at the edge (a tuple of mpf, 50 digits; inputs not moved are floats
    exactly); ``direction``: float vector along which to approach it (max norm 1); ``kind``:
    "branch" (a simple root of the discriminant: 2 <-> 0 assemblies), "change" (a double root: a
    change point, 2 on both sides in the paper design), "change-split" (a branch input within
    ~1e-6 of a change point: the float design's change point opened into a window), "coincident"
    (B = Q: a continuum of C in the paper design), "closest" (the inputs where the two assemblies
    come closest, for designs with no branch input), "singular" (3-RRR: the reference count changes
    there), "singular-line" (the agile eye's codimension-2 singular set)."""

    x_star: tuple
    direction: tuple
    kind: str
    note: str = ""


# ------------------------------------------------------------------------------ constructors

def _polar(polar_deg: float, azimuth_deg: float) -> np.ndarray:
    p, a = math.radians(polar_deg), math.radians(azimuth_deg)
    return np.array([math.sin(p) * math.cos(a), math.sin(p) * math.sin(a), math.cos(p)])


def four_bar(ground: float, crank: float, coupler: float, rocker: float, branch: float = 1.0,
             crank_azimuth: float = 90.0) -> SphericalMechanism:
    """A spherical four-bar with link angles in degrees, built as :func:`spherekin.mechanism.four_bar`.

    ground = angle(A, D), crank = angle(A, B), coupler = angle(B, C), rocker = angle(D, C). A = z
    (actuated), D in the xz-plane at ``ground`` from z, B = Rot(A, crank_azimuth) of the point at
    ``crank`` from A towards D, C on side ``branch`` of B x D. Legs "crank" = (A, B), "rocker" =
    (D, C); the coupler BC is the platform. With the defaults, ``four_bar(80, 30, 70, 60)`` is the
    preset. ValueError when the design cannot be assembled with the crank at ``crank_azimuth``.
    """
    a = np.array([0.0, 0.0, 1.0])
    d = _polar(ground, 0.0)
    b = axis_rotation(a, math.radians(crank_azimuth)) @ _polar(crank, 0.0)
    c = sphere_point(b, d, math.radians(coupler), math.radians(rocker), branch)
    if c is None:
        raise ValueError(f"four_bar({ground}, {crank}, {coupler}, {rocker}): cannot be assembled with the "
                         f"crank at azimuth {crank_azimuth} deg")
    return SphericalMechanism(
        legs=(Leg("crank", (Joint("A", a, actuated=True), Joint("B", b))),
              Leg("rocker", (Joint("D", d), Joint("C", c)))),
        name=f"spherical four-bar ({ground:g}/{crank:g}/{coupler:g}/{rocker:g} deg)",
    )


def five_bar(ground: float, left: float, coupler_left: float, coupler_right: float, right: float,
             branch: float = -1.0) -> SphericalMechanism:
    """A spherical five-bar with link angles in degrees, built as :func:`spherekin.mechanism.five_bar`.

    ground = angle(A, E), left = angle(A, B), coupler_left = angle(B, C), coupler_right =
    angle(C, D), right = angle(D, E). A, E in the xz-plane at -+ground/2 from z (A and E actuated),
    B and D at ``left`` and ``right`` from A and E towards +y, C on side ``branch`` of B x D. Legs
    "left" = (A, B), "right" = (E, D, C); the platform is the link BC.
    """
    a, e = _polar(ground / 2, 180.0), _polar(ground / 2, 0.0)
    y = np.array([0.0, 1.0, 0.0])
    b = math.cos(math.radians(left)) * a + math.sin(math.radians(left)) * y
    d = math.cos(math.radians(right)) * e + math.sin(math.radians(right)) * y
    c = sphere_point(b, d, math.radians(coupler_left), math.radians(coupler_right), branch)
    if c is None:
        raise ValueError(f"five_bar({ground}, {left}, {coupler_left}, {coupler_right}, {right}): cannot be "
                         "assembled at the reference inputs")
    return SphericalMechanism(
        legs=(Leg("left", (Joint("A", a, actuated=True), Joint("B", b))),
              Leg("right", (Joint("E", e, actuated=True), Joint("D", d), Joint("C", c)))),
        name=f"spherical five-bar ({ground:g}/{left:g}/{coupler_left:g}/{coupler_right:g}/{right:g} deg)",
    )


# ------------------------------------------------------------------------------ two-leg mechanisms

@dataclass(frozen=True)
class _TwoLeg:
    a_axis: list          # A (actuated, reference leg's base joint)
    a_ref: object         # A's reference angle (mpf)
    a_index: int          # A's position in mech.actuated
    b0: list              # B at the reference configuration
    b_name: str
    e_axis: list | None   # E (five-bar) or None (four-bar: Q = D fixed)
    e_ref: object
    e_index: int | None
    d0: list              # D at the reference configuration
    d_name: str
    c0: list              # C at the reference configuration
    c_name: str
    cos_a: object         # cos angle(B0, C0)
    cos_b: object         # cos angle(D0, C0)
    ang_a: object
    ang_b: object
    frame0_inv: object    # [B0, C0, B0 x C0]^-1
    platform: object      # the platform reference (mp matrix)


def _two_leg(mech: SphericalMechanism) -> _TwoLeg:
    legs = {leg.name: leg for leg in mech.legs}
    if len(legs) != 2:
        raise ValueError(f"mech: expected a spherical four-bar or five-bar (2 legs), got {len(legs)} legs")
    first = [leg for leg in mech.legs if len(leg.joints) == 2 and leg.joints[0].actuated and not leg.joints[1].actuated]
    if not first:
        raise ValueError("mech: no leg (A*, B) with A actuated")
    lb = first[0]
    lo = [leg for leg in mech.legs if leg is not lb][0]
    js = lo.joints
    if len(js) == 2 and not js[0].actuated and not js[1].actuated:
        e_joint, d_joint, c_joint = None, js[0], js[1]
    elif len(js) == 3 and js[0].actuated and not js[1].actuated and not js[2].actuated:
        e_joint, d_joint, c_joint = js
    else:
        raise ValueError(f"mech: leg {lo.name!r} is neither (D, C) nor (E*, D, C)")
    with mpmath.workdps(_dps()):
        b0, c0, d0 = mp_axis(lb.joints[1].given_axis), mp_axis(c_joint.given_axis), mp_axis(d_joint.given_axis)
        plat = mpmath.matrix([[mpmath.mpf(float(x)) for x in row] for row in mech.platform_reference_matrix])
        return _TwoLeg(
            a_axis=mp_axis(lb.joints[0].given_axis), a_ref=_mp(lb.joints[0].reference_angle),
            a_index=mech.actuated.index(lb.joints[0].name), b0=b0, b_name=lb.joints[1].name,
            e_axis=None if e_joint is None else mp_axis(e_joint.given_axis),
            e_ref=None if e_joint is None else _mp(e_joint.reference_angle),
            e_index=None if e_joint is None else mech.actuated.index(e_joint.name),
            d0=d0, d_name=d_joint.name, c0=c0, c_name=c_joint.name,
            cos_a=_dot(b0, c0), cos_b=_dot(d0, c0), ang_a=_angle(b0, c0), ang_b=_angle(d0, c0),
            frame0_inv=mpmath.inverse(_frame(b0, c0)), platform=plat)


def _q_point(g: _TwoLeg, inputs):
    if g.e_axis is None:
        return g.d0
    return _rot(g.e_axis, _mp(inputs[g.e_index]) - g.e_ref, g.d0)


def two_leg_reference(mech: SphericalMechanism, inputs) -> EdgeReference:
    """The reference of a spherical four-bar or five-bar at ``inputs`` (floats or mpf, radians, in
    the order of ``mech.actuated``): count 0, 1 or 2 from the sign of the Gram determinant of
    (B, Q, C), each assembly's platform rotation and its points B, D (current), C."""
    g = _two_leg(mech)
    with mpmath.workdps(_dps()):
        b = _rot(g.a_axis, _mp(inputs[g.a_index]) - g.a_ref, g.b0)
        q = _q_point(g, inputs)
        c = _dot(b, q)
        disc = 1 - c * c - g.cos_a ** 2 - g.cos_b ** 2 + 2 * c * g.cos_a * g.cos_b
        den = 1 - c * c
        if den < DISC_TOL:
            return EdgeReference(None, discriminant=disc, note=f"B and {g.d_name} (anti)parallel: C on a circle")
        if abs(disc) < DISC_TOL:
            return EdgeReference(None, discriminant=disc, note="discriminant 0 at 50 digits: a double assembly")
        if disc < 0:
            return EdgeReference(0, discriminant=disc)
        alpha = (g.cos_a - c * g.cos_b) / den
        beta = (g.cos_b - c * g.cos_a) / den
        n = _cross(b, q)
        gamma = mpmath.sqrt(disc) / den          # |n|^2 = den, gamma^2 |n|^2 = disc / den
        rots, mp_rots, points = [], [], []
        for sign in (1, -1):
            cc = [alpha * b[i] + beta * q[i] + sign * gamma * n[i] for i in range(3)]
            r = _frame(b, cc) * g.frame0_inv * g.platform
            mp_rots.append(r)
            rots.append(_to_float(r))
            points.append({g.b_name: b, g.d_name: q, g.c_name: cc})
        return EdgeReference(2, tuple(rots), tuple(mp_rots), tuple(points), disc)


def _sinusoid(g: _TwoLeg, inputs):
    """(P, S', S) with cos angle(B, Q) = P cos(phi) + S' sin(phi) + S, phi = theta_A - ref_A."""
    q = _q_point(g, inputs)
    ab, aq = _dot(g.a_axis, g.b0), _dot(g.a_axis, q)
    return _dot(q, g.b0) - ab * aq, _dot(q, _cross(g.a_axis, g.b0)), ab * aq


def two_leg_edges(mech: SphericalMechanism, inputs=None) -> list:
    """Every branch, change and coincidence input of A (the reference leg's actuator), the other
    inputs fixed at ``inputs`` (default: zeros), in closed form at 50 digits; "closest" edges (the
    two extrema of cos angle(B, Q)) when there is none. A list of :class:`Edge`."""
    g = _two_leg(mech)
    n_in = len(mech.actuated)
    inputs = [0.0] * n_in if inputs is None else list(inputs)
    direction = tuple(1.0 if i == g.a_index else 0.0 for i in range(n_in))
    out = []
    with mpmath.workdps(_dps()):
        p, s1, s0 = _sinusoid(g, inputs)
        rho = mpmath.sqrt(p * p + s1 * s1)
        phi0 = mpmath.atan2(s1, p)                       # cos angle(B, Q) is largest at phi0
        two_pi = 2 * mpmath.pi

        def at(phi, kind, note):
            theta = g.a_ref + phi
            theta = theta - two_pi * mpmath.nint(theta / two_pi)
            x = [_mp(v) for v in inputs]
            x[g.a_index] = theta
            out.append(Edge(tuple(x), direction, kind, note))

        targets = [(mpmath.cos(g.ang_a - g.ang_b), "inner", "angle(B, Q) = |a - b|"),
                   (mpmath.cos(g.ang_a + g.ang_b), "outer", "angle(B, Q) = min(a + b, 2 pi - a - b)")]
        for k, side, note in targets:
            x = (k - s0) / rho
            near = 1 - abs(x)
            change = abs(near) < CHANGE_TOL
            coincident = side == "inner" and abs(g.ang_a - g.ang_b) < CHANGE_TOL
            if change:
                kind = "coincident" if coincident else "change"
                at(phi0 if x > 0 else phi0 + mpmath.pi, kind, f"{note}: an extremum of cos angle(B, Q) "
                   f"touches it (1 - |x| = {mpmath.nstr(near, 3)})")
            if abs(x) <= 1:
                dev = mpmath.acos(x)
                for s in (1, -1):
                    at(phi0 + s * dev, "change-split" if change else "branch", note)
        if not out:
            at(phi0, "closest", "the two assemblies closest (no branch input): cos angle(B, Q) largest")
            at(phi0 + mpmath.pi, "closest", "the two assemblies closest (no branch input): cos angle(B, Q) smallest")
    return out


def two_leg_coincidences(mech: SphericalMechanism) -> list:
    """Five-bar: the float inputs of E (the other leg's actuator) at which D(theta_E) lies on the
    circle that B describes about A (angle(A, D) = angle(A, B0)), so that moving A brings B onto D:
    with angle(B0, C0) = angle(D0, C0) there, C then turns on a circle (a continuum) in the paper
    design. Closed form at 50 digits, rounded to floats; [] for a four-bar."""
    g = _two_leg(mech)
    if g.e_axis is None:
        return []
    out = []
    with mpmath.workdps(_dps()):
        # cos angle(A, D(phi)) = P cos(phi) + S' sin(phi) + S, phi = theta_E - ref_E
        ed, ea = _dot(g.e_axis, g.d0), _dot(g.e_axis, g.a_axis)
        p = _dot(g.a_axis, g.d0) - ed * ea
        s1 = _dot(g.a_axis, _cross(g.e_axis, g.d0))
        x = (_dot(g.a_axis, g.b0) - ed * ea) / mpmath.sqrt(p * p + s1 * s1)
        if abs(x) <= 1:
            phi0, dev = mpmath.atan2(s1, p), mpmath.acos(x)
            for sg in (1, -1):
                theta = g.e_ref + phi0 + sg * dev
                theta = theta - 2 * mpmath.pi * mpmath.nint(theta / (2 * mpmath.pi))
                out.append(float(theta))
    return out


# ------------------------------------------------------------------------------ mechanism files (issue 40)

_FILE_ANGLE = re.compile(r"^\s*(?P<sign>[+-])?\s*(?P<num>\d+(?:\.\d*)?(?:[eE][+-]?\d+)?|\.\d+)?\s*(?P<star>\*)?\s*"
                         r"(?P<pi>pi)?\s*(?:/\s*(?P<den>\d+(?:\.\d*)?|\.\d+))?\s*$")


def file_angle(value) -> float:
    """An angle of a mechanism file (docs/mechanism-format.md), as the float it stands for: a number, or
    a text [sign][number][*]pi[/denominator] evaluated left to right in double precision (the number
    times pi, then divided), the sign last. The file's floats are these numbers."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return float(value)
    m = _FILE_ANGLE.match(value) if isinstance(value, str) else None
    if m is None or not (m["num"] or m["pi"]):
        raise ValueError(f"angle: expected a number or a pi expression, got {value!r}")
    out = float(m["num"]) if m["num"] else 1.0
    if m["pi"]:
        out *= math.pi
    if m["den"]:
        out /= float(m["den"])
    return -out if m["sign"] == "-" else out


@dataclass(frozen=True)
class RrrFile:
    """A kind "3-RRR" mechanism file read with tomllib (not with spherekin): its numbers as written.
    ``u``, ``w0``, ``v0``: the base axes, elbow axes at zero and platform axes (3 float triples each,
    not normalized); ``alpha2``: the distal link angles (:func:`file_angle`); ``offsets``: the
    ``[joint_offsets]`` table as (joint name, float) pairs (a joint reads its angle minus its offset)."""

    path: str
    u: tuple
    w0: tuple
    v0: tuple
    alpha2: tuple
    offsets: tuple = ()

    def offset(self, name: str) -> float:
        return dict(self.offsets).get(name, 0.0)


def read_rrr_file(path) -> RrrFile:
    """The :class:`RrrFile` of a kind "3-RRR" mechanism file."""
    data = tomllib.loads(Path(path).read_text())
    if data.get("kind") != "3-RRR":
        raise ValueError(f"{path}: expected a kind \"3-RRR\" file")

    def triples(key):
        return tuple(tuple(float(t) for t in v) for v in data[key])

    return RrrFile(str(path), triples("base_axes"), triples("elbow_axes_at_zero"), triples("platform_axes"),
                   tuple(file_angle(a) for a in data["distal_link_angles"]),
                   tuple((n, file_angle(v)) for n, v in data.get("joint_offsets", {}).items()))


def _rrr_of_file(f: RrrFile) -> "_Rrr":
    """The 3-RRR of a file at the working precision: u_i, w_i^0, v_i^0 the directions of the file's
    vectors (normalized in mpmath), cos alpha2_i of the file's float; input beta_i (a reading) turns the
    elbow to Rot(u_i, beta_i + offset_i) w_i^0 (refs = -offsets); the platform frame is the file's (R
    maps v_i^0 to v_i: no platform reference)."""
    with mpmath.workdps(_dps()):
        u, w, v = ([mp_axis(x) for x in vs] for vs in (f.u, f.w0, f.v0))
        refs = [-_mp(f.offset(f"beta{i + 1}")) for i in range(3)]
        cos_a2 = [mpmath.cos(_mp(a)) for a in f.alpha2]
        fgeo = tuple(np.array([[float(t) for t in x] for x in vs]) for vs in (u, w, v)) + (np.array(f.alpha2, float),)
        return _Rrr(u, w, v, refs, cos_a2, mpmath.eye(3), fgeo)


# ------------------------------------------------------------------------------ 3-RRR

@dataclass(frozen=True)
class _Rrr:
    u: list
    w: list
    v: list
    refs: list
    cos_a2: list
    platform: object
    float_geometry: tuple


def description_of(mech: SphericalMechanism) -> RrrFile:
    """The numbers of a kind "3-RRR" mechanism's description as given (``geometry.given_axes``, the
    distal link angles' floats, the joint offsets): what its file holds (tests/test_mechanism_io.py checks
    that they are the file's), as an :class:`RrrFile`."""
    g = mech.geometry
    return RrrFile(f"<{mech.name}>", *g.given_axes, tuple(g.distal_link_angles), tuple(g.joint_offsets))


def _rrr(mech) -> _Rrr:
    if isinstance(mech, RrrFile):
        return _rrr_of_file(mech)
    if getattr(mech, "kind", None) == "3-RRR" and getattr(mech.geometry, "given_axes", None) is not None:
        return _rrr_of_file(description_of(mech))        # its description's numbers, not its float joint axes
    if len(mech.legs) != 3 or any(len(leg.joints) != 3 or not leg.joints[0].actuated
                                  or leg.joints[1].actuated or leg.joints[2].actuated for leg in mech.legs):
        raise ValueError("mech: expected a 3-RRR (three legs of 3 joints, the base joint actuated)")
    order = [mech.actuated.index(leg.joints[0].name) for leg in mech.legs]
    legs = [mech.legs[order.index(i)] for i in range(3)]      # leg of input i
    with mpmath.workdps(_dps()):
        u = [mp_axis(leg.joints[0].axis) for leg in legs]
        w = [mp_axis(leg.joints[1].axis) for leg in legs]
        v = [mp_axis(leg.joints[2].axis) for leg in legs]
        refs = [_mp(leg.joints[0].reference_angle) for leg in legs]
        cos_a2 = [_dot(w[i], v[i]) for i in range(3)]
        plat = mpmath.matrix([[mpmath.mpf(float(x)) for x in row] for row in mech.platform_reference_matrix])
        fgeo = (np.array([[float(t) for t in x] for x in u]), np.array([[float(t) for t in x] for x in w]),
                np.array([[float(t) for t in x] for x in v]), np.array([float(mpmath.acos(c)) for c in cos_a2]))
    return _Rrr(u, w, v, refs, cos_a2, plat, fgeo)


def _rrr_quadrics(g: _Rrr, inputs) -> list:
    """q^T A_i q = |q|^2 (w_i(beta_i) . R'(q) v_i - cos alpha2_i), at DIGITS digits."""
    out = []
    with mpmath.workdps(_dps()):
        for i in range(3):
            w = _rot(g.u[i], _mp(inputs[i]) - g.refs[i], g.w[i])
            out.append(leg_quadric_mp(w, g.v[i], g.cos_a2[i]))
    return out


def _quat_rotation_mp(q):
    q0, x, y, z = q
    n = q0 * q0 + x * x + y * y + z * z
    return mpmath.matrix([
        [q0 * q0 + x * x - y * y - z * z, 2 * (x * y - z * q0), 2 * (x * z + y * q0)],
        [2 * (x * y + z * q0), q0 * q0 - x * x + y * y - z * z, 2 * (y * z - x * q0)],
        [2 * (x * z - y * q0), 2 * (y * z + x * q0), q0 * q0 - x * x - y * y + z * z]]) / n


def _newton(quadrics, q0, max_steps: int = NEWTON_STEPS, deflate=()):
    """Complex Newton from q0 on F = (q^T A_i q, q . q - 1), as references.reference_roots._newton
    but with fewer steps; (q, converged: see SMALL_STEP).

    ``deflate``: roots already found (and their negatives, the same pose): Newton then runs on
    G = F / prod_k ((q - r_k) . (q - r_k))^(1/2) (analytic; its Jacobian is (J - F m^T) / prod with
    m = sum_k (q - r_k) / ((q - r_k) . (q - r_k))), which no longer has the r_k as roots, so a start
    next to a found root is driven to a missing one; the result is then polished without deflation."""
    q = mpmath.matrix([mpmath.mpc(x) for x in q0])
    q = q / mpmath.sqrt(sum(x * x for x in q))
    tol = mpmath.mpf(10) ** (-(_dps() - 10))
    known = [r for r0 in deflate for r in (r0, -r0)]
    for k in range(max_steps):
        f, jac = quadric_system_mp(quadrics, q)
        if known:
            m = mpmath.matrix(4, 1)
            for r in known:
                d = q - r
                dd = sum(x * x for x in d)
                if dd == 0:
                    return q, False
                m += d / dd
            jac = jac - f * m.T
        try:
            step = mpmath.lu_solve(jac, f)
        except ZeroDivisionError:
            return q, False
        q = q - step
        size = mpmath.norm(step, mpmath.inf)
        if known:
            if size < mpmath.mpf(10) ** -20:
                return _newton(quadrics, q, max_steps - k)
        elif size < tol or (size < SMALL_STEP and mpmath.norm(f, mpmath.inf) < _tiny_residual()):
            return q, True
    return q, False


def _pair_starts(quadrics, r) -> list:
    """Starts for the two roots of a pair next to a fold, from a real point r near them (a root, or
    where Newton stalled between a complex pair): along the right singular vector v of smallest
    singular value of the Jacobian J(r), with u the left one, F(r + h v) = F(r) + h J v + h^2 F2(v)
    exactly (every equation is a quadratic form); its component along u is a quadratic in h whose
    two roots, real or complex, give the starts r + h v."""
    r = mpmath.matrix([mpmath.re(x) for x in r])
    jac = mpmath.matrix(4, 4)
    f = []
    for i, a in enumerate(quadrics):
        aq = a * r
        f.append(sum(r[j] * aq[j] for j in range(4)))
        for j in range(4):
            jac[i, j] = 2 * aq[j]
    f.append(sum(x * x for x in r) - 1)
    for j in range(4):
        jac[3, j] = 2 * r[j]
    u_mat, sv, vt = mpmath.svd_r(jac)
    k = min(range(4), key=lambda i: sv[i])
    v = mpmath.matrix([vt[k, j] for j in range(4)])
    u = [u_mat[i, k] for i in range(4)]
    jv = jac * v
    f2 = [sum(v[a] * sum(quad[a, b] * v[b] for b in range(4)) for a in range(4)) for quad in quadrics]
    f2.append(sum(x * x for x in v))
    qa = sum(u[i] * f2[i] for i in range(4))
    qb = sum(u[i] * jv[i] for i in range(4))
    qc = sum(u[i] * f[i] for i in range(4))
    if qa == 0:
        return []
    disc = mpmath.sqrt(mpmath.mpc(qb * qb - 4 * qa * qc))
    return [r + ((-qb + sg * disc) / (2 * qa)) * v for sg in (1, -1)]


def _rrr_roots(g: _Rrr, inputs, seed: int = 0):
    """The 8 roots (mp complex quaternions), or (the roots found, the reason).

    As references.reference_roots.reference_roots (its restarts here with deflation of the roots
    found, :func:`_newton`), plus two searches for the partner of a root next
    to a fold, where the eigen-candidates (~sqrt of the distance to the fold) no longer separate
    the pair: the conjugate of every complex root (a root: the quadrics are real), and for every
    real root or point where Newton stalled, the pair's two starts of :func:`_pair_starts`."""
    quadrics = _rrr_quadrics(g, inputs)
    float_inputs = [float(_mp(inputs[i]) - g.refs[i]) for i in range(3)]
    try:
        starts = list(candidate_points(leg_quadrics(g.float_geometry, float_inputs)))
    except ValueError as exc:
        return [], f"degenerate: {exc}"
    roots: list = []
    rng = np.random.default_rng(seed)

    stalled = []

    def add(start):
        q, ok = _newton(quadrics, start)
        if ok and not any(same_root(q, r) for r in roots):
            roots.append(q)
        elif not ok:
            stalled.append(q)

    for start in starts:
        add(start)
    if len(roots) < 8:
        for r in list(roots) + stalled:
            if max(abs(mpmath.im(x)) for x in r) > mpmath.mpf("1e-30"):
                add(mpmath.matrix([mpmath.conj(x) for x in r]))
            else:
                for start in _pair_starts(quadrics, r):
                    add(start)
    restarts = 0
    while len(roots) < 8 and restarts < MAX_RESTARTS:
        restarts += 1
        base = roots[restarts % len(roots)] if roots else np.ones(4)
        scale = 10.0 ** rng.uniform(-8, -2)
        start = np.array([complex(base[j]) for j in range(4)]) + scale * (rng.normal(size=4) + 1j * rng.normal(size=4))
        q, ok = _newton(quadrics, start, deflate=roots)
        if ok and not any(same_root(q, r) for r in roots):
            roots.append(q)
    if len(roots) != 8:
        return roots, f"found {len(roots)} distinct roots of the quaternion quadrics, not 8"
    return roots, ""


def _pair_distance(a, b):
    return min(max(abs(a[j] - s * b[j]) for j in range(4)) for s in (1, -1))


def rrr_reference(mech, inputs, seed: int = 0) -> EdgeReference:
    """The reference of a 3-RRR at ``inputs`` (floats or mpf, radians, order of ``mech.actuated``),
    from its joint axes (``mech`` a SphericalMechanism) or from its file's numbers (``mech`` an
    :class:`RrrFile`); ``count`` None when undecided (module docstring)."""
    g = _rrr(mech)
    with mpmath.workdps(_dps()):
        roots, why = _rrr_roots(g, inputs, seed)
        if why:
            return EdgeReference(None, note=why)
        sep = min(_pair_distance(a, b) for i, a in enumerate(roots) for b in roots[i + 1:])
        if sep < DECIDE_SEPARATION:
            return EdgeReference(None, min_separation=float(sep),
                                 note=f"two roots {mpmath.nstr(sep, 3)} apart: not resolved at {_dps()} digits")
        real = [r for r in roots if max(abs(mpmath.im(x)) for x in r) < mpmath.mpf("1e-30")]
        if len(real) % 2:
            return EdgeReference(None, min_separation=float(sep), note=f"{len(real)} real roots (odd)")
        mp_rots = [_quat_rotation_mp([mpmath.re(x) for x in r]) * g.platform for r in real]
        return EdgeReference(len(real), tuple(_to_float(r) for r in mp_rots), tuple(mp_rots),
                             min_separation=float(sep))


def _closest_pair_g(g: _Rrr, x):
    """g = sum (q1 - s q2)_j^2 of the closest pair of roots at inputs x (mp): > 0 for a real pair,
    < 0 for a complex-conjugate pair; analytic, and linear through 0 at a fold."""
    roots, why = _rrr_roots(g, x)
    if why:
        raise ValueError(why)
    best = None
    for i, a in enumerate(roots):
        for b in roots[i + 1:]:
            for s in (1, -1):
                d = [a[j] - s * b[j] for j in range(4)]
                m = max(abs(t) for t in d)
                if best is None or m < best[0]:
                    best = (m, d)
    return mpmath.re(sum(t * t for t in best[1]))


def rrr_singular_input(mech, x_a, x_b, width: float = 1e-9, accuracy=ROOT_ACCURACY):
    """(x*, direction): the input on the segment x_a -> x_b where the reference count changes, to
    ~``accuracy`` (radians; mpf tuple), and x_b - x_a scaled to max norm 1 (``mech``: as
    :func:`rrr_reference`). Bisection on the count (ends with
    different counts required) to a bracket of ``width`` (radians), then regula falsi (Illinois) on
    the signed squared distance of the merging pair of roots, which is linear through the fold.
    ValueError when the counts at the ends are equal or a count is undecided."""
    g = _rrr(mech)
    with mpmath.workdps(_dps()):
        xa = [_mp(v) for v in x_a]
        xb = [_mp(v) for v in x_b]
        span = max(abs(xb[i] - xa[i]) for i in range(3))
        direction = tuple(float((xb[i] - xa[i]) / span) for i in range(3))

        def point(s):
            return [xa[i] + s * (xb[i] - xa[i]) for i in range(3)]

        def count(s):
            c = rrr_reference(mech, point(s)).count
            if c is None:
                raise ValueError(f"undecided reference at s = {mpmath.nstr(s, 17)}")
            return c

        lo, hi = mpmath.mpf(0), mpmath.mpf(1)
        c_lo = count(lo)
        if count(hi) == c_lo:
            raise ValueError("rrr_singular_input: the reference counts at the two ends are equal")

        def bisect(lo, hi, stop, undecided_ends=False):
            """The bracket [lo, hi] halved on the count until it is narrower than stop (radians); with
            ``undecided_ends``, a count the reference cannot decide ends it with the bracket so far."""
            while (hi - lo) * span > stop:
                mid = (lo + hi) / 2
                try:
                    below = count(mid) == c_lo
                except ValueError:
                    if undecided_ends:
                        break
                    raise
                lo, hi = (mid, hi) if below else (lo, mid)
            return lo, hi

        lo, hi = bisect(lo, hi, width)
        best = (lo + hi) / 2
        try:
            g_lo, g_hi = _closest_pair_g(g, point(lo)), _closest_pair_g(g, point(hi))
        except ValueError:
            g_lo = g_hi = mpmath.mpf(1)
        best_g, side = None, 0
        for _ in range(60):
            if g_lo * g_hi > 0 or (hi - lo) * span < accuracy:
                break               # done, or not a simple fold: keep the bracket
            s = (lo * g_hi - hi * g_lo) / (g_hi - g_lo)
            try:
                gs = _closest_pair_g(g, point(s))
            except ValueError:
                break               # the pair too close to resolve
            if best_g is None or abs(gs) < best_g:
                best, best_g = s, abs(gs)
            if gs == 0 or abs(gs) < mpmath.mpf(10) ** (-(_dps() - 5)):
                break
            if gs * g_lo > 0:
                lo, g_lo = s, gs
                if side == -1:
                    g_hi /= 2
                side = -1
            else:
                hi, g_hi = s, gs
                if side == 1:
                    g_lo /= 2
                side = 1
        # check: the count changes across best (accuracy on either side); else bisect on
        eps = mpmath.mpf(accuracy) / span
        try:
            ok = count(best - eps) == c_lo and count(best + eps) != c_lo
        except ValueError:
            ok = False
        if not ok:
            lo, hi = bisect(lo, hi, accuracy, undecided_ends=True)
            best = (lo + hi) / 2
        return tuple(point(best)), direction


def rrr_segment(mech, rng, max_tries: int = 200):
    """A random segment of inputs (uniform in [-pi, pi]^3) along which the reference count changes:
    (x*, direction) by :func:`rrr_singular_input`. RuntimeError after ``max_tries`` segments."""
    for _ in range(max_tries):
        x_a, x_b = rng.uniform(-np.pi, np.pi, 3), rng.uniform(-np.pi, np.pi, 3)
        ca, cb = rrr_reference(mech, x_a).count, rrr_reference(mech, x_b).count
        if ca is None or cb is None or ca == cb:
            continue
        try:
            return rrr_singular_input(mech, x_a, x_b)
        except ValueError:
            continue
    raise RuntimeError(f"no segment with a change of count in {max_tries} tries")


def agile_eye_edge(beta3: float = 0.3, direction=(0.6, 0.8, 0.3), sign: int = 1) -> Edge:
    """An input on the agile eye's (spherekin.mechanism.gosselin) codimension-2 singular set
    beta1 = 0, beta2 = sign pi/2 (any beta3; pairs of assembly modes merge there), at 50 digits."""
    with mpmath.workdps(_dps()):
        x = (mpmath.mpf(0), sign * mpmath.pi / 2, mpmath.mpf(float(beta3)))
    d = np.asarray(direction, float)
    return Edge(x, tuple(d / np.abs(d).max()), "singular-line", "beta1 = 0, beta2 = +-pi/2")


# ------------------------------------------------------------------------------ six-bars (graph files, issue 40)

#: A six-bar reference is undecided when a discriminant (Watt: the Gram determinant of a circle
#: intersection; Stephenson: the imaginary part of a root of the eliminant, relative to 1 + |t|) is
#: below this: at 1e-16 from a fold a pair is ~1e-8 apart (discriminant ~1e-16, imaginary part
#: ~1e-8); at the working precision (50-60 digits) rounding is below 1e-45.
SIX_BAR_TOL = mpmath.mpf("1e-40")
#: mpmath.polyroots' iterations and extra precision (bits) for the Stephenson eliminant (degree 8): two
#: roots 1e-8 apart converge only linearly at first; 400 steps and 120 extra bits leave its error
#: estimate below 1e-40 at 1e-16 from a fold (checked: the error is part of the decision).
POLYROOTS_STEPS = 400
POLYROOTS_EXTRAPREC = 120


@dataclass(frozen=True)
class GraphFile:
    """A kind "graph" mechanism file read with tomllib: ``joints`` maps a name to (links (a, b), the
    axis floats as written, actuated, reference_angle float); ``ground``, ``output``. Joint [a, b]
    turns link b relative to link a: R_b = R_a Rot(axis, reading - reference_angle), every link's frame
    the ground's in the reference assembly."""

    path: str
    joints: tuple
    ground: str
    output: str | None

    def joint(self, name: str):
        return dict((n, rest) for n, *rest in self.joints)[name]


def read_graph_file(path) -> GraphFile:
    data = tomllib.loads(Path(path).read_text())
    if data.get("kind") != "graph":
        raise ValueError(f"{path}: expected a kind \"graph\" file")
    joints = tuple((j["name"], tuple(j["links"]), tuple(float(t) for t in j["axis"]), bool(j.get("actuated", False)),
                    file_angle(j.get("reference_angle", 0.0))) for j in data["joints"])
    return GraphFile(str(path), joints, data["ground"], data.get("output"))


def _check_topology(g: GraphFile, links: dict, actuated: tuple) -> None:
    got = {n: tuple(lk) for n, lk, *_ in g.joints}
    if got != links or tuple(n for n, _, _, act, _ in g.joints if act) != actuated:
        raise ValueError(f"{g.path}: not the six-bar this reference is written for (joints {got})")


def _unit_mp(v):
    n = mpmath.sqrt(_dot(v, v))
    return [t / n for t in v]


def _frame_onb(p, q):
    """The rotation matrix with columns (p, n, p x n), n = unit(p x q): F(R p, R q) = R F(p, q)."""
    n = _unit_mp(_cross(p, q))
    m = _cross(p, n)
    return mpmath.matrix([[p[i], n[i], m[i]] for i in range(3)])


def _carry(p0, q0, p, q):
    """The rotation taking p0 to p and q0 to q (angle(p0, q0) = angle(p, q))."""
    return _frame_onb(p, q) * _frame_onb(p0, q0).T


def _rot_mat(axis, angle):
    k = mpmath.matrix([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return mpmath.eye(3) + mpmath.sin(angle) * k + (1 - mpmath.cos(angle)) * k * k


def _apply(m, v):
    return [sum(m[i, j] * v[j] for j in range(3)) for i in range(3)]


def _circles(p, cp, q, cq):
    """The unit vectors x with x . p = cp and x . q = cq (p, q unit, not parallel): (the two, the Gram
    discriminant g2 |p x q|^2 = 1 - |alpha p + beta q|^2; the two are real when it is > 0)."""
    pq = _dot(p, q)
    den = 1 - pq * pq
    alpha, beta = (cp - pq * cq) / den, (cq - pq * cp) / den
    n = _cross(p, q)
    base = [alpha * p[i] + beta * q[i] for i in range(3)]
    disc = 1 - _dot(base, base)
    if disc <= 0:
        return [], disc
    gamma = mpmath.sqrt(disc / den)
    return [[base[i] + s * gamma * n[i] for i in range(3)] for s in (1, -1)], disc


def _readings(g: GraphFile, axes: dict, rots: dict) -> dict:
    """Every joint's reading (float, wrapped to [-pi, pi]) from the links' rotations: joint [a, b] with
    axis X0 reads reference + the angle of R_a^T R_b about X0."""
    out = {}
    for name, (a, b), _, _, ref in g.joints:
        x0 = axes[name]
        p = _unit_mp(_cross(x0, [1, 0, 0] if abs(x0[0]) < 0.9 else [0, 1, 0]))
        qp = _apply(rots[a].T * rots[b], p)
        phi = mpmath.atan2(_dot(x0, _cross(p, qp)), _dot(p, qp))
        out[name] = float(mpmath.atan2(mpmath.sin(ref + phi), mpmath.cos(ref + phi)))
    return out


def _graph_result(g: GraphFile, axes, assemblies, undecided: str = "") -> EdgeReference:
    if undecided:
        return EdgeReference(None, note=undecided)
    rots = tuple(_to_float(r[g.output]) for r in assemblies)
    return EdgeReference(len(assemblies), rots, tuple(r[g.output] for r in assemblies),
                         readings=tuple(_readings(g, axes, r) for r in assemblies))


WATT_LINKS = {"A": ("ground", "crank"), "B": ("crank", "coupler"), "C": ("coupler", "rocker"),
              "D": ("ground", "rocker"), "E": ("crank", "link5"), "F": ("link5", "link6"), "G": ("link6", "coupler")}
STEPHENSON_LINKS = {"A": ("ground", "ternary1"), "B": ("ternary1", "link1"), "C": ("link1", "ternary2"),
                    "D": ("ternary1", "link2"), "E": ("link2", "ternary2"), "F": ("ground", "link4"),
                    "G": ("link4", "ternary2")}


def watt_reference(g: GraphFile, inputs) -> EdgeReference:
    """The Watt I six-bar of examples/watt_six_bar.toml (joint names and links as there) at input A =
    inputs[0], from the file's numbers: the crank turns by A; C lies at its arcs from B (crank) and D
    (ground): 0 or 2 points, each placing the coupler (B, C, G); F lies at its arcs from E (crank) and G
    (coupler): 0 or 2 for each. Count and every assembly's link rotations and readings."""
    _check_topology(g, WATT_LINKS, ("A",))
    with mpmath.workdps(_dps()):
        ax = {n: _unit_mp([_mp(t) for t in v]) for n, _, v, _, _ in g.joints}
        r_crank = _rot_mat(ax["A"], _mp(inputs[0]) - _mp(g.joint("A")[3]))
        b, e = _apply(r_crank, ax["B"]), _apply(r_crank, ax["E"])
        cs, disc1 = _circles(b, _dot(ax["B"], ax["C"]), ax["D"], _dot(ax["D"], ax["C"]))
        if abs(disc1) < SIX_BAR_TOL:
            return _graph_result(g, ax, [], f"circle discriminant of C {mpmath.nstr(disc1, 3)}: a double assembly")
        out = []
        for c in cs:
            r_coupler = _carry(ax["B"], ax["C"], b, c)
            r_rocker = _carry(ax["D"], ax["C"], ax["D"], c)
            gg = _apply(r_coupler, ax["G"])
            fs, disc2 = _circles(e, _dot(ax["E"], ax["F"]), gg, _dot(ax["G"], ax["F"]))
            if abs(disc2) < SIX_BAR_TOL:
                return _graph_result(g, ax, [], f"circle discriminant of F {mpmath.nstr(disc2, 3)}: a double assembly")
            for f in fs:
                out.append({"ground": mpmath.eye(3), "crank": r_crank, "coupler": r_coupler, "rocker": r_rocker,
                            "link5": _carry(ax["E"], ax["F"], e, f), "link6": _carry(ax["F"], ax["G"], f, gg)})
        return _graph_result(g, ax, out)


#: Stephenson eliminant: phi = PHI0 + 2 atan t (PHI0 puts t = infinity, phi = PHI0 + pi, away from the
#: roots of examples/stephenson_six_bar.toml; as tests/test_singular_loops.py::stephenson_count).
STEPHENSON_PHI0 = 0.3


def stephenson_reference(g: GraphFile, inputs) -> EdgeReference:
    """The Stephenson six-bar of examples/stephenson_six_bar.toml at input A = inputs[0], from the file's
    numbers: ternary2 = Rot(F, phi) Rot(G, psi) (the chain ground - link4 - ternary2), and the links B-C,
    D-E keep their arcs: a_i + b_i cos psi + c_i sin psi = 0 (i = 1, 2), each of a, b, c times (1 + t^2)
    of degree 2 in t = tan((phi - STEPHENSON_PHI0) / 2); eliminating psi (Cramer, cos^2 + sin^2 = 1)
    leaves h(t) = (a2 c1 - a1 c2)^2 + (a1 b2 - a2 b1)^2 - (b1 c2 - b2 c1)^2 of degree 8, whose real roots
    are the assemblies (tests/test_singular_loops.py::stephenson_h, here at the working precision)."""
    _check_topology(g, STEPHENSON_LINKS, ("A",))
    with mpmath.workdps(_dps()):
        ax = {n: _unit_mp([_mp(t) for t in v]) for n, _, v, _, _ in g.joints}
        r1 = _rot_mat(ax["A"], _mp(inputs[0]) - _mp(g.joint("A")[3]))
        f, gax = ax["F"], ax["G"]
        c0, s0 = mpmath.cos(STEPHENSON_PHI0), mpmath.sin(STEPHENSON_PHI0)
        coefs = []
        for near, far in (("B", "C"), ("D", "E")):
            u, v, k = _apply(r1, ax[near]), ax[far], _dot(ax[near], ax[far])
            v0 = [_dot(gax, v) * t for t in gax]
            parts = (v0, [v[i] - v0[i] for i in range(3)], _cross(gax, v))      # Rot(G, psi) v
            w0 = [_dot(f, u) * t for t in f]
            w1, w2 = [u[i] - w0[i] for i in range(3)], [-t for t in _cross(f, u)]   # Rot(F, -phi) u
            row = []
            for j, pj in enumerate(parts):
                al, be, ga = _dot(w0, pj), _dot(w1, pj), _dot(w2, pj)    # al + be cos phi + ga sin phi
                if j == 0:
                    al -= k
                # (1 + t^2)(al + be cos phi + ga sin phi), phi = PHI0 + u, cos u = (1 - t^2)/(1 + t^2), ...
                p1, p2 = c0 * be + s0 * ga, -s0 * be + c0 * ga
                row.append([al + p1, 2 * p2, al - p1])                      # coefficients of 1, t, t^2
            coefs.append(row)

        def mul(p, q):
            out = [mpmath.mpf(0)] * (len(p) + len(q) - 1)
            for i, a in enumerate(p):
                for j, b in enumerate(q):
                    out[i + j] += a * b
            return out

        def sub(p, q):
            return [a - b for a, b in zip(p, q)]

        (a1, b1, c1), (a2, b2, c2) = coefs
        x_num, y_num, det = sub(mul(a2, c1), mul(a1, c2)), sub(mul(a1, b2), mul(a2, b1)), sub(mul(b1, c2), mul(b2, c1))
        h = sub([p + q for p, q in zip(mul(x_num, x_num), mul(y_num, y_num))], mul(det, det))
        roots, err = mpmath.polyroots(h[::-1], maxsteps=POLYROOTS_STEPS, extraprec=POLYROOTS_EXTRAPREC, error=True)
        if err > SIX_BAR_TOL:
            return _graph_result(g, ax, [], f"eliminant roots not converged (error {mpmath.nstr(err, 3)})")
        out = []
        for t in roots:
            im = abs(mpmath.im(t)) / (1 + abs(t))
            if SIX_BAR_TOL <= im < mpmath.mpf("1e-25"):
                return _graph_result(g, ax, [], f"a root of the eliminant with imaginary part {mpmath.nstr(im, 3)}")
            if im >= SIX_BAR_TOL:
                continue
            t = mpmath.re(t)

            def ev(p):
                return sum(cf * t ** i for i, cf in enumerate(p))

            d = ev(det)
            cos_psi, sin_psi = ev(x_num) / d, ev(y_num) / d
            phi = STEPHENSON_PHI0 + 2 * mpmath.atan(t)
            psi = mpmath.atan2(sin_psi, cos_psi)
            r4 = _rot_mat(f, phi)
            r2 = r4 * _rot_mat(gax, psi)
            b, d_, c, e = _apply(r1, ax["B"]), _apply(r1, ax["D"]), _apply(r2, ax["C"]), _apply(r2, ax["E"])
            out.append({"ground": mpmath.eye(3), "ternary1": r1, "link4": r4, "ternary2": r2,
                        "link1": _carry(ax["B"], ax["C"], b, c), "link2": _carry(ax["D"], ax["E"], d_, e)})
        return _graph_result(g, ax, out)


def graph_reference(g: GraphFile, inputs) -> EdgeReference:
    """The reference of a six-bar file: :func:`watt_reference` or :func:`stephenson_reference` by its links."""
    links = {n: tuple(lk) for n, lk, *_ in g.joints}
    return (watt_reference if links == WATT_LINKS else stephenson_reference)(g, inputs)


def graph_folds(g: GraphFile, lo: float = -math.pi, hi: float = math.pi, samples: int = 400,
                accuracy=mpmath.mpf("1e-30"), limit: int | None = None) -> list:
    """The inputs A in [lo, hi] where the reference count changes (the six-bar's folds), as :class:`Edge`
    (direction +1), each bisected on the count at the working precision to ``accuracy`` (radians; an
    undecided count ends the bisection there); ``limit``: the first ones only (samples taken in order
    until then)."""
    xs = np.linspace(lo, hi, samples)
    out = []
    with mpmath.workdps(_dps()):
        k0 = graph_reference(g, (xs[0],)).count
        for x0, x1 in zip(xs[:-1], xs[1:]):
            if limit is not None and len(out) >= limit:
                break
            k1 = graph_reference(g, (x1,)).count
            if k0 is None or k1 is None or k0 == k1:
                k0 = k1
                continue
            a, b = mpmath.mpf(float(x0)), mpmath.mpf(float(x1))
            while b - a > accuracy:
                m = (a + b) / 2
                k = graph_reference(g, (m,)).count
                if k is None:
                    break
                a, b = (m, b) if k == k0 else (a, m)
            out.append(Edge(((a + b) / 2,), (1.0,), "fold", f"{k0} -> {k1} assemblies"))
            k0 = k1
    return out


# ------------------------------------------------------------------------------ shared helpers

def inputs_at(edge: Edge, distance: float) -> tuple:
    """The float inputs nearest x* + distance * direction (each entry rounded once from 50 digits),
    and the actual signed distance (float) along the direction's largest entry."""
    with mpmath.workdps(_dps()):
        d = mpmath.mpf(float(distance))
        x = tuple(float(edge.x_star[i] + d * mpmath.mpf(edge.direction[i])) for i in range(len(edge.x_star)))
        k = int(np.argmax(np.abs(edge.direction)))
        actual = float((mpmath.mpf(x[k]) - edge.x_star[k]) / mpmath.mpf(edge.direction[k]))
    return x, actual


def passive_angles(mech: SphericalMechanism, rotation, inputs) -> list:
    """The passive joint readings (dicts name -> radians, in [-pi, pi]) of the pose ``rotation`` with
    the actuators at ``inputs``: every combination of the legs' solutions. Each leg's chain
    Rot(a_1, d_1) ... Rot(a_k, d_k) = R P^T (axes at the reference configuration, d = reading -
    reference angle, P the platform reference) is solved for its passive joints with its actuated
    joints (a prefix of the leg) fixed, by the Paden-Kahan subproblems
    (:func:`spherekin.mechanism.chains.serial_ik`). Unlike ``mech.inverse_kinematics``, this stays
    right where a leg is at a serial singularity (the agile eye's axis u_i = v_i, where the actuator
    turns freely and inverse kinematics returns an arbitrary actuator reading)."""
    from spherekin.core.angles import wrap
    from spherekin.mechanism.chains import serial_ik

    target = np.asarray(rotation, float) @ mech.platform_reference_matrix.T
    values = dict(zip(mech.actuated, (float(v) for v in inputs)))
    per_leg = []
    for leg in mech.legs:
        k = 0
        rest = target
        while k < len(leg.joints) and leg.joints[k].actuated:
            j = leg.joints[k]
            rest = axis_rotation(j.axis, values[j.name] - j.reference_angle).T @ rest
            k += 1
        joints = leg.joints[k:]
        if any(j.actuated for j in joints):
            raise ValueError(f"leg {leg.name!r}: actuated joints must come first")
        if not joints:
            per_leg.append([{}])
            continue
        sols = serial_ik(np.array([j.axis for j in joints]), rest)
        per_leg.append([{j.name: wrap(j.reference_angle + d) for j, d in zip(joints, sol)} for sol in sols])
    out = [{}]
    for options in per_leg:
        out = [{**a, **b} for a in out for b in options]
    return out
