"""The platform system: one equation per leg in the platform's orientation (an addition to the paper).

For a mechanism whose legs all end at one platform and are R-R-R chains with the base joint
actuated (the 3-RRR family: the Gosselin platform, general and random 3-RRR), the direct
kinematics has three unknowns, the platform orientation, instead of the six passive angles of the
loop equations (Eq. 2). Leg i with reference axes a1 (actuated, displacement d1 = beta - ref1), a2
(elbow) and a3 (platform joint) is assembled at the platform displacement D (R = D R_ref, the
product of exponentials of :meth:`SphericalMechanism.pose_from_passive`) iff

    e(d1) . (D a3) = a2 . a3,    e(d1) = Rot(a1, d1) a2                               (1)

(the elbow axis and the platform joint axis keep their angle). Conversely, when (1) holds, the
passive displacements are unique (a2 is not parallel to a3, which the model checks): d2 turns a3
onto Rot(a1, -d1) D a3 about a2, and d3 is what is left about a3 (:func:`passive_readings`). So
the poses that satisfy (1) for every leg are the assemblies, one for one.

With D = S(q) / |q|^2 for a quaternion q = (w, x, y, z) (S is quadratic in q), (1) becomes the
homogeneous quadratic form q^T M q = 0, M = T(e, a3) - (a2 . a3) I. Every orientation is q or -q
with some component of largest modulus; chart k fixes q_k = 1 and lets the three others range
over [-1, 1] (widened to CHART_EXTENT so that the charts overlap): four charts of 3 variables cover the rotation group (boundaries overlap; duplicates
are merged after polishing). On a chart, (1) is a polynomial of degree 2 in each variable; its
Bernstein control points are exact linear functions of M (:func:`chart_control_points`), and M is
linear in (cos d1, sin d1, 1) (Rodrigues): a new input costs three multiply-adds of compiled
tensors (:meth:`PlatformSystem.control_points`).

Measured against the paper's configuration: 4 charts x 3 variables instead of 64 charts x 6
variables (full ranges), see benchmarks/README.md. The loop formulations stay available and are
the fallback when the platform search cannot isolate every root (a parallel singularity: see
:func:`spherekin.problem.Problem.solve`).

Any one joint of a leg may be the actuated one (the elbow-actuated 3-RRR, a 3-RRR driven at the
platform joints): with the elbow's displacement d2 known, the base and platform axes keep the angle
across the elbow, a1 . (D a3) = a1 . Rot(a2, d2) a3; with the platform joint's d3 known, the base
and elbow axes keep theirs, a1 . (D Rot(a3, -d3) a2) = a1 . a2. Each is (1)'s form e . (D b) = c with
one of e, b, c linear in (cos d, sin d, 1) (:func:`leg_terms`), so the same compiled charts serve, and
the passive displacements are again unique (:func:`passive_readings`).

Eq. (1) is written once, here: :class:`LegConstants` holds its constants (e(d1) by Rodrigues, a3,
a2 . a3), which the compiled chart tensors (:meth:`PlatformSystem.from_mechanism`) and certified
tracking (:class:`spherekin.trust.continuation.LegEquations`) both read; :class:`Platform` is the
system of the registry (:mod:`spherekin.systems.base`): what it accepts and what it compiles.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np

from ..core import intervals as iv
from ..core.angles import RANGE_TOL, in_range_many, wrap
from ..core.groups import pad_by_owner
from ..results import SearchReport, Settings, is_proven
from ..search.boxloop import (SearchInterrupted, SolverLimitError, clusters_in_range_many, search_platform,
                              search_platform_many)
from ..core.orientation import quaternion_matrices, quaternion_matrix
from ..core.rotations import cross
from ..mechanism.chains import angle_about, axis_rotation, axis_rotations, perpendicular
from ..search.parameterizations import ROUNDING_SAFETY, ChartSet, Parameterization
from ..search.pruners import make_pruner
from ..search.parameterizations import stack_chart_sets
from .base import SYSTEMS, Compiled, Found, Passed, System, own_variables_declined

__all__ = ["QUADRATIC_TENSOR", "CHARTS", "CHART_EXTENT", "CHART_CORE", "CORE_ROUNDING", "ACCEPT_WIDTH", "PlatformLeg", "LegTerms", "leg_terms", "LegConstants", "leg_constants",
           "PlatformSystem", "leg_matrices",
           "platform_legs", "not_applicable", "quaternion_matrix", "form_matrix", "chart_control_points", "chart_rotations",
           "chart_quaternion", "chart_rotation", "passive_readings", "passive_readings_many", "passive_reading_enclosures", "passive_names",
           "Quaternion", "MAX_ASSEMBLIES", "Platform", "CompiledPlatform", "POSE_MATCH", "DUPLICATE_POSE",
           "first_of_duplicates", "disagreement", "disagreements"]

#: Number of quaternion charts (one per component fixed to 1).
CHARTS = 4
#: Most isolated assemblies (distinct platform rotations) such a mechanism has at one input. Reason:
#: each leg's equation (1) is a homogeneous quadratic form q^T M q = 0 and q, -q, any real multiple of
#: q are one rotation, so the assemblies are the real points where three quadrics of the projective
#: space P^3 meet: at most 2 * 2 * 2 = 8 isolated ones (Bezout's theorem).
MAX_ASSEMBLIES = 8
#: Each chart lets the three free components range over [-CHART_EXTENT, CHART_EXTENT], not [-1, 1].
#: Reason: a root with two components of equal largest modulus lies on the boundary of two
#: [-1, 1] charts, where no box can hold it in its interior, so the Krawczyk test could never
#: isolate it (measured: the agile eye's four serially singular assemblies, at every input, have
#: |q_i| = |q_j|). With overlapping charts it is interior to both; its duplicate is merged after
#: polishing.
CHART_EXTENT = 1.25
#: The core of chart k: where every free |u_j| <= CHART_CORE (its fixed component is the largest, up to
#: this factor); a chart searches its core only, and not the cores of the charts before it
#: (:meth:`Quaternion.contract`). Reason for 19/16: above 1 so that the cores overlap and a root whose
#: largest components tie (the agile eye's, at every input) is in the core of the first of them with
#: room to spare: a later chart drops a box around it once the box is within ~3/16 of the tie, which
#: is before it is isolated (measured on the Gosselin platform, 128 inputs: isolated roots 20 -> 8.5
#: an input, boxes 436 -> 397; 9/8 gave 9.3 and 417, 17/16 12.0 and 441); below CHART_EXTENT, so
#: that a root in a core is interior to its chart (the Krawczyk test needs that).
CHART_CORE = 1.1875
#: Relative margin of the core tests for the rounding of the chart map (a few ulps; far above them).
CORE_ROUNDING = 1e-12
#: Accept a chart box when each side is below tol times this. Reason: with q_k = 1 the unit
#: quaternion q/|q| moves by at most |du| (|q| >= 1) and the rotation angle by twice that, so sides
#: du <= tol / (2 sqrt 3) bound the rotation's change by tol. (Accepted boxes are not used as
#: solutions: they send the solve to a loop formulation, see the module doc.)
ACCEPT_WIDTH = 1.0 / (2.0 * math.sqrt(3.0))

# Bernstein coefficients (degree 2 on x in [0, 1]) of u^e, u = 2x - 1, for e = 0, 1, 2:
# 1 = (1, 1, 1); u = (-1, 0, 1); u^2 = (1, -1, 1) (u^2 at x = 1/2 is 0 = (1 + 2 b1 + 1) / 4).
_POWERS = np.array([[1.0, 1.0, 1.0], [-1.0, 0.0, 1.0], [1.0, -1.0, 1.0]])


def _quadratic_tensor() -> np.ndarray:
    """T (4, 4, 3, 3), symmetric in its first two axes, with S(q) = sum_ij q_i q_j T[i, j] (polarization)."""
    eye = np.eye(4)
    t = np.empty((4, 4, 3, 3))
    for i in range(4):
        for j in range(4):
            t[i, j] = (quaternion_matrix(eye[i] + eye[j]) - quaternion_matrix(eye[i]) - quaternion_matrix(eye[j])) / 2.0
            if i == j:
                t[i, j] = quaternion_matrix(eye[i])
    return t


_T = _quadratic_tensor()
#: T (4, 4, 3, 3): S(q) = sum_ij q_i q_j T[i, j] (exact entries: 0, +-1, +-2 halves of sums of them).
QUADRATIC_TENSOR = _T


def form_matrix(e, a, c: float) -> np.ndarray:
    """M (4, 4) symmetric with q^T M q = e . S(q) a - c |q|^2 (Eq. (1) of the module doc, homogenized)."""
    return np.einsum("ijmn,m,n->ij", _T, np.asarray(e, dtype=float), np.asarray(a, dtype=float)) - c * np.eye(4)


def _chart_basis() -> np.ndarray:
    """B (4 charts, 4, 4, 3, 3, 3): control points of q_i q_j on chart k (q_k = 1, the others
    CHART_EXTENT (2x - 1)); exact: CHART_EXTENT^e is a power of 5/4, representable in binary."""
    out = np.empty((CHARTS, 4, 4, 3, 3, 3))
    for k in range(CHARTS):
        others = [j for j in range(4) if j != k]
        for i in range(4):
            for j in range(4):
                exps = [0, 0, 0]
                for comp in (i, j):
                    if comp != k:
                        exps[others.index(comp)] += 1
                out[k, i, j] = np.einsum("a,b,c->abc", *(_POWERS[e] * CHART_EXTENT ** e for e in exps))
    return out


_BASIS = _chart_basis()


def chart_control_points(m) -> np.ndarray:
    """Bernstein control points (..., 4 charts, 3, 3, 3) of q^T M q on each chart's unit box.

    ``m``: (..., 4, 4). Exact (every basis coefficient is -1, 0 or 1): the only rounding is that of
    the sums.
    """
    return np.einsum("...ij,kijabc->...kabc", np.asarray(m, dtype=float), _BASIS)


def chart_quaternion(chart, x) -> np.ndarray:
    """Quaternions (B, 4) (not normalized) of unit-box points x (B, 3) of charts ``chart`` (B,):
    component ``chart`` is 1, the others CHART_EXTENT (2x - 1)."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    chart = np.broadcast_to(np.asarray(chart, dtype=int), (len(x),))
    u = CHART_EXTENT * (2.0 * x - 1.0)
    q = np.empty((len(x), 4))
    for k in range(CHARTS):                    # the four charts, each as one array operation
        rows = chart == k
        if rows.any():
            q[rows] = np.insert(u[rows], k, 1.0, axis=1)
    return q


def chart_rotations(chart, x) -> np.ndarray:
    """The rotations (B, 3, 3) at unit-box points x (B, 3) of charts ``chart`` (B,)."""
    q = chart_quaternion(chart, x)
    return quaternion_matrices(q) / (q * q).sum(axis=1)[:, None, None]


def chart_rotation(chart: int, x) -> np.ndarray:
    """The rotation (3, 3) at the unit-box point x (3,) of chart ``chart`` (for a mechanism: the
    platform displacement D, see :meth:`PlatformSystem.pose`)."""
    return chart_rotations([chart], np.asarray(x, dtype=float)[None])[0]


@dataclass(slots=True, eq=False)
class PlatformLeg:
    """One R-R-R leg as Eq. (1) sees it: joint names, reference axes (base frame), readings, and which
    joint (0 base, 1 elbow, 2 platform) is the actuated one."""

    names: tuple
    a1: np.ndarray
    a2: np.ndarray
    a3: np.ndarray
    reference: tuple
    actuated: int = 0

    @property
    def passive(self) -> tuple[str, str]:
        """The names of its two passive joints, base side first."""
        return tuple(n for k, n in enumerate(self.names) if k != self.actuated)


def not_applicable(mechanism) -> str | None:
    """Why the platform formulation does not apply to ``mechanism`` (None when it does): its loops
    must close through one output link held by three R-R-R chains from the ground (its legs), each
    with one joint actuated (any of the three)."""
    if not getattr(mechanism, "legs", None):
        return ("the platform formulation needs three legs from the ground to one output link, "
                "the mechanism has none (its loops do not close through one output link)")
    if len(mechanism.legs) != 3:
        return (f"the platform formulation needs 3 legs (3 equations in 3 unknowns), "
                f"got {len(mechanism.legs)}")
    for leg in mechanism.legs:
        kinds = [j.actuated for j in leg.joints]
        if len(kinds) != 3 or sum(kinds) != 1:
            pattern = "-".join("A" if a else "P" for a in kinds)
            return (f"the platform formulation needs R-R-R legs with one joint actuated (A-P-P, P-A-P or "
                    f"P-P-A), leg {leg.name!r} is {pattern}")
    return None


def platform_legs(mechanism) -> tuple[PlatformLeg, ...]:
    """The legs of an eligible mechanism (:func:`not_applicable`), else ValueError naming why."""
    reason = not_applicable(mechanism)
    if reason is not None:
        raise ValueError(f"formulation 'platform': {reason}")
    return tuple(PlatformLeg(tuple(j.name for j in leg.joints), *(np.array(j.axis, dtype=float) for j in leg.joints),
                             tuple(j.reference_angle for j in leg.joints),
                             [j.actuated for j in leg.joints].index(True)) for leg in mechanism.legs)


@dataclass(frozen=True, eq=False)
class LegTerms:
    """Eq. (1) of one leg, e(d) . (D b(d)) = c(d), each side linear in w = (cos d, sin d, 1) with d the
    actuated joint's displacement: ``e`` (3 terms, 3), ``b`` (3, 3), ``c`` (3,): e(d) = w @ e, ... Only
    one of e, b, c depends on d (:func:`leg_terms`)."""

    e: np.ndarray
    b: np.ndarray
    c: np.ndarray


def leg_terms(leg: PlatformLeg) -> LegTerms:
    """The one place Eq. (1) is written, for the actuated joint at any position of the leg:

    * base (d = d1): e = Rot(a1, d1) a2 = cos d1 (a2 - (a1.a2) a1) + sin d1 a1 x a2 + (a1.a2) a1, b = a3,
      c = a2 . a3 (the elbow and platform axes keep their angle);
    * elbow (d = d2): e = a1, b = a3, c = a1 . Rot(a2, d2) a3 (the base and platform axes keep the angle
      across the elbow);
    * platform joint (d = d3): e = a1, b = Rot(a3, -d3) a2, c = a1 . a2 (the base and elbow axes keep theirs).
    """
    def rod(axis, v, sign=1.0):             # Rot(axis, sign d) v as (cos, sin, 1) terms (Rodrigues)
        along = float(axis @ v)
        return np.array([v - along * axis, sign * cross(axis, v), along * axis])

    zero, a1, a2, a3 = np.zeros(3), leg.a1, leg.a2, leg.a3
    if leg.actuated == 0:
        return LegTerms(rod(a1, a2), np.array([zero, zero, a3]), np.array([0.0, 0.0, float(a2 @ a3)]))
    if leg.actuated == 1:
        return LegTerms(np.array([zero, zero, a1]), np.array([zero, zero, a3]), rod(a2, a3) @ a1)
    return LegTerms(np.array([zero, zero, a1]), rod(a3, a2, -1.0), np.array([0.0, 0.0, float(a1 @ a2)]))


@dataclass(frozen=True, eq=False)
class LegConstants:
    """The constants of Eq. (1) for L legs, the one place it is written:

        e_i(d1) . (D a3_i) = c_i,   e_i(d1) = cos d1 perp_i + sin d1 side_i + axial_i   (Rodrigues about a1_i)

    ``ref`` (L,): the actuated joints' reference readings (d1 = beta - ref); ``perp``, ``side``,
    ``axial`` (L, 3): a2 - (a1 . a2) a1, a1 x a2, (a1 . a2) a1; ``b`` (L, 3): a3; ``c`` (L,): a2 . a3
    (the twist the elbow and platform axes keep). Built by :func:`leg_constants`.
    """

    ref: np.ndarray
    perp: np.ndarray
    side: np.ndarray
    axial: np.ndarray
    b: np.ndarray
    c: np.ndarray

    def elbow(self, beta) -> np.ndarray:
        """e_i(beta_i) (..., L legs, 3) for inputs beta (..., L; radians)."""
        d = np.asarray(beta, dtype=float) - self.ref
        return np.cos(d)[..., None] * self.perp + np.sin(d)[..., None] * self.side + self.axial

    def elbow_rate(self, beta) -> np.ndarray:
        """d e_i / d beta_i (..., L legs, 3)."""
        d = np.asarray(beta, dtype=float) - self.ref
        return -np.sin(d)[..., None] * self.perp + np.cos(d)[..., None] * self.side

    def residual(self, d, beta) -> np.ndarray:
        """Eq. (1) at platform displacements D (..., 3, 3): e_i . (D a3_i) - c_i per leg (..., L)."""
        return np.einsum("...ij,...ij->...i", self.elbow(beta), np.swapaxes(d @ self.b.T, -1, -2)) - self.c


def leg_constants(legs) -> LegConstants:
    """The :class:`LegConstants` of ``legs`` (:class:`PlatformLeg`, from :func:`platform_legs`), each
    with its base joint actuated (the form tracking uses: :func:`leg_terms` with only e varying)."""
    driven = [leg.names[leg.actuated] for leg in legs if leg.actuated != 0]
    if driven:
        raise ValueError(f"legs: the leg constants of Eq. (1) with e varying need the base joints actuated, "
                         f"got {driven} actuated")
    terms = [leg_terms(leg) for leg in legs]
    return LegConstants(ref=np.array([leg.reference[0] for leg in legs], dtype=float),
                        perp=np.array([t.e[0] for t in terms]), side=np.array([t.e[1] for t in terms]),
                        axial=np.array([t.e[2] for t in terms]), b=np.array([t.b[2] for t in terms]),
                        c=np.array([t.c[2] for t in terms]))


def passive_readings(legs, inputs, rotation, platform_reference) -> dict[str, float]:
    """Passive joint readings (radians, wrapped to [-pi, pi)) of the assembly at platform pose R.

    The slow, readable reference of :func:`passive_readings_many` (which the solver uses).

    ``inputs``: the actuated readings, one per leg. R = D R_ref and D = Rot(a1, d1) Rot(a2, d2) Rot(a3, d3):
    base actuated: M = Rot(a1, -d1) D, d2 turns a3 onto M a3 about a2, d3 = the angle of Rot(a2, -d2) M
    about a3; elbow actuated: d1 turns Rot(a2, d2) a3 onto D a3 about a1, d3 what is left about a3;
    platform joint actuated: with D' = D Rot(a3, -d3), d1 turns a2 onto D' a2 about a1, d2 what is left
    about a2.
    """
    d = np.asarray(rotation, dtype=float) @ np.asarray(platform_reference, dtype=float).T
    out = {}
    for leg, value in zip(legs, inputs):
        known = float(value) - leg.reference[leg.actuated]
        if leg.actuated == 0:
            m = axis_rotation(leg.a1, -known) @ d
            d2 = angle_about(leg.a2, leg.a3, m @ leg.a3)
            p = perpendicular(leg.a3)
            disp = (known, d2, angle_about(leg.a3, p, axis_rotation(leg.a2, -d2) @ m @ p))
        elif leg.actuated == 1:
            d1 = angle_about(leg.a1, axis_rotation(leg.a2, known) @ leg.a3, d @ leg.a3)
            n = axis_rotation(leg.a2, -known) @ axis_rotation(leg.a1, -d1) @ d
            p = perpendicular(leg.a3)
            disp = (d1, known, angle_about(leg.a3, p, n @ p))
        else:
            dp = d @ axis_rotation(leg.a3, -known)
            d1 = angle_about(leg.a1, leg.a2, dp @ leg.a2)
            p = perpendicular(leg.a2)
            disp = (d1, angle_about(leg.a2, p, axis_rotation(leg.a1, -d1) @ dp @ p), known)
        for k in range(3):
            if k != leg.actuated:
                out[leg.names[k]] = wrap(leg.reference[k] + disp[k])
    return out


def _angles_about(axis: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Signed angles (K,) about the unit vector ``axis`` (3,) from x to y (K, 3 each): the batch form
    of :func:`spherekin.mechanism.chains.angle_about` (cross product written out, no np.cross)."""
    xp = x - np.outer(x @ axis, axis)
    yp = y - np.outer(y @ axis, axis)
    cross_axis = (axis[0] * (xp[:, 1] * yp[:, 2] - xp[:, 2] * yp[:, 1])
                  + axis[1] * (xp[:, 2] * yp[:, 0] - xp[:, 0] * yp[:, 2])
                  + axis[2] * (xp[:, 0] * yp[:, 1] - xp[:, 1] * yp[:, 0]))
    return np.arctan2(cross_axis, np.einsum("ki,ki->k", xp, yp))


def passive_names(legs) -> tuple[str, ...]:
    """The passive joints of the legs, in the column order of :func:`passive_readings_many`."""
    return tuple(n for leg in legs for n in leg.passive)


def passive_readings_many(legs, inputs, rotations, platform_reference) -> np.ndarray:
    """Passive joint readings (K, 2 x legs; radians, wrapped to [-pi, pi)) at K platform poses.

    The batch form of :func:`passive_readings` (its slow, readable reference; same steps), columns in
    the order of :func:`passive_names`. ``rotations`` (K, 3, 3); ``inputs``: the actuated readings,
    one per leg (shared by every pose), or one row of them per pose (K, legs).
    """
    d = np.asarray(rotations, dtype=float) @ np.asarray(platform_reference, dtype=float).T     # (K, 3, 3)
    inputs = np.asarray(inputs, dtype=float)
    n = len(d)
    cols = []
    for i, leg in enumerate(legs):
        value = inputs[i] if inputs.ndim == 1 else inputs[:, i]
        known = np.broadcast_to(np.asarray(value, dtype=float) - leg.reference[leg.actuated], (n,))
        if leg.actuated == 0:
            m = axis_rotations(leg.a1, -known) @ d
            d2 = _angles_about(leg.a2, np.broadcast_to(leg.a3, (n, 3)), m @ leg.a3)
            p = perpendicular(leg.a3)
            disp = (d2, _angles_about(leg.a3, np.broadcast_to(p, (n, 3)), axis_rotations(leg.a2, -d2) @ m @ p))
        elif leg.actuated == 1:
            d1 = _angles_about(leg.a1, axis_rotations(leg.a2, known) @ leg.a3, d @ leg.a3)
            rest = axis_rotations(leg.a2, -known) @ axis_rotations(leg.a1, -d1) @ d
            p = perpendicular(leg.a3)
            disp = (d1, _angles_about(leg.a3, np.broadcast_to(p, (n, 3)), rest @ p))
        else:
            dp = d @ axis_rotations(leg.a3, -known)
            d1 = _angles_about(leg.a1, np.broadcast_to(leg.a2, (n, 3)), dp @ leg.a2)
            p = perpendicular(leg.a2)
            disp = (d1, _angles_about(leg.a2, np.broadcast_to(p, (n, 3)), axis_rotations(leg.a1, -d1) @ dp @ p))
        refs = [leg.reference[k] for k in range(3) if k != leg.actuated]
        cols += [wrap(refs[0] + disp[0]), wrap(refs[1] + disp[1])]
    return np.stack(cols, axis=1).reshape(n, -1)


def passive_reading_enclosures(legs, beta, d, platform_joints=None) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) (N, 2 x legs; radians, the columns of :func:`passive_names`): arcs enclosing each
    passive joint's reading over every displacement D in the intervals ``d`` (2, N, 3, 3) and every
    input in ``beta`` (2, N, legs) (radians), by the formulas of :func:`passive_readings_many` in
    outward-rounded interval arithmetic (the cos and sin of an interval angle from
    :func:`spherekin.core.intervals.cos_sin`); NaN where an arc is unknown (its atan2 box holds the
    origin). Legs with the base joint actuated only (ValueError otherwise); ``platform_joints``
    (one bool per leg, default all): whether to enclose the leg's platform joint too (NaN if not)."""
    driven = [leg.names[leg.actuated] for leg in legs if leg.actuated != 0]
    if driven:
        raise ValueError(f"legs: the reading enclosures are written for base-actuated legs, got {driven} actuated")
    n = d.shape[1]
    lo, hi = np.full((n, 2 * len(legs)), np.nan), np.full((n, 2 * len(legs)), np.nan)
    for i, leg in enumerate(legs):
        c1, s1 = iv.cos_sin(iv.sub(beta[..., i], iv.point(leg.reference[0])))
        m3 = iv.rotate_about(leg.a1, c1, iv.neg(s1), iv.isum(iv.scale(leg.a3, d), -1))          # Rot(a1, -d1) D a3
        xp = leg.a3 - (leg.a3 @ leg.a2) * leg.a2
        d2_lo, d2_hi = iv.arc(iv.isum(iv.scale(xp, m3), -1), iv.isum(iv.scale(np.cross(leg.a2, xp), m3), -1))
        lo[:, 2 * i], hi[:, 2 * i] = leg.reference[1] + d2_lo, leg.reference[1] + d2_hi
        if platform_joints is not None and not platform_joints[i]:
            continue
        known = np.isfinite(d2_lo)
        if not known.any():
            continue
        p = perpendicular(leg.a3)
        mp = iv.rotate_about(leg.a1, c1, iv.neg(s1), iv.isum(iv.scale(p, d), -1))              # Rot(a1, -d1) D p
        c2, s2 = iv.cos_sin(iv.from_bounds(np.where(known, d2_lo, 0.0), np.where(known, d2_hi, 0.0)))
        n_p = iv.rotate_about(leg.a2, c2, iv.neg(s2), mp)                                     # Rot(a2, -d2) M p
        d3_lo, d3_hi = iv.arc(iv.isum(iv.scale(p, n_p), -1), iv.isum(iv.scale(np.cross(leg.a3, p), n_p), -1))
        lo[:, 2 * i + 1] = np.where(known, leg.reference[2] + d3_lo, np.nan)
        hi[:, 2 * i + 1] = np.where(known, leg.reference[2] + d3_hi, np.nan)
    return lo, hi


def leg_matrices(legs) -> np.ndarray:
    """M (L legs, 3 parts, 4, 4): leg i's Eq. (1) is q^T M(d) q = 0 with M(d) = cos d M[i, 0] + sin d M[i, 1]
    + M[i, 2] (d: its actuated joint's displacement, radians)."""
    mats = []
    for leg in legs:
        # q^T M q of e(d) against b(d), less c(d): one of them varies, so M is linear in (cos d, sin d, 1)
        t = leg_terms(leg)
        mats.append([form_matrix(t.e[p], t.b[2], t.c[p]) + form_matrix(t.e[2], t.b[p], 0.0) for p in (0, 1)]
                    + [form_matrix(t.e[2], t.b[2], t.c[2])])
    return np.array(mats)


@dataclass(slots=True, eq=False)
class PlatformSystem:
    """Eq. (1) of every leg compiled on the four charts: control points = cos d1 C_c + sin d1 C_s + C_0.

    ``parts`` (3 legs, 3 parts (c, s, 0), 4 charts, 3, 3, 3). Built by :meth:`from_mechanism`.
    """

    legs: tuple
    parts: np.ndarray
    platform_reference: np.ndarray
    constants: LegConstants | None = None     # the tracker's form (base joints actuated), else None

    @classmethod
    def from_mechanism(cls, mechanism) -> "PlatformSystem":
        legs = platform_legs(mechanism)
        constants = leg_constants(legs) if all(leg.actuated == 0 for leg in legs) else None
        return cls(legs, chart_control_points(leg_matrices(legs)), np.array(mechanism.platform_reference_matrix),
                   constants)

    def control_points(self, inputs) -> np.ndarray:
        """Control points (4 charts, 3 legs, 3, 3, 3) of Eq. (1) at actuator ``inputs`` (radians, one per leg)."""
        d1 = np.asarray(inputs, dtype=float) - np.array([leg.reference[leg.actuated] for leg in self.legs])
        w = np.stack([np.cos(d1), np.sin(d1), np.ones_like(d1)], axis=1)            # (legs, 3)
        return np.moveaxis(np.einsum("lp,lpkabc->lkabc", w, self.parts), 1, 0)

    def charts(self, inputs) -> ChartSet:
        """The chart set of the box loop at actuator ``inputs``: one block of 3 equations (one per leg)
        on 4 charts, each equation's tolerance ROUNDING_SAFETY eps times its magnitude: the largest
        control point of |C_c| + |C_s| + |C_0|, the terms behind cos d1 C_c + sin d1 C_s + C_0 (not of
        the sum itself, which can be small on a whole chart while its rounding is not)."""
        cps = self.control_points(inputs)
        magnitude = np.abs(self.parts).sum(axis=1)                                   # (legs, 4 charts, 3, 3, 3)
        magnitude = np.moveaxis(magnitude.reshape(len(self.legs), CHARTS, -1).max(axis=2), 1, 0)
        tols = ROUNDING_SAFETY * np.finfo(float).eps * np.maximum(
            magnitude, np.abs(cps).reshape(CHARTS, len(self.legs), -1).max(axis=2))
        names = tuple(leg.names[leg.actuated] for leg in self.legs)
        variables = ("q_a", "q_b", "q_c")
        ones = np.full((CHARTS, 3), CHART_EXTENT)
        return ChartSet(Quaternion(), names, variables, [cps], [tols], [names], [tuple(range(len(self.legs)))],
                        -ones, ones, np.zeros((CHARTS, 3)), ACCEPT_WIDTH, [None], [True])

    def pose(self, chart: int, x) -> np.ndarray:
        """The platform pose R = D R_ref (3, 3) at the unit-box point x (3,) of chart ``chart``
        (the charts parameterize the displacement D)."""
        return self.poses([chart], np.asarray(x, dtype=float)[None])[0]

    def poses(self, chart, x) -> np.ndarray:
        """The platform poses (B, 3, 3) at unit-box points x (B, 3) of charts ``chart`` (B,)."""
        return chart_rotations(chart, x) @ self.platform_reference

    def residuals(self, inputs, rotation) -> np.ndarray:
        """Eq. (1) at a pose R (3, 3): e(d) . (D b(d)) - c(d) per leg (legs,; independent of the charts)."""
        d = np.asarray(rotation, dtype=float) @ self.platform_reference.T
        out = []
        for leg, value in zip(self.legs, np.asarray(inputs, dtype=float)):
            t = leg_terms(leg)
            disp = float(value) - leg.reference[leg.actuated]
            w = np.array([math.cos(disp), math.sin(disp), 1.0])
            out.append(float((w @ t.e) @ d @ (w @ t.b) - w @ t.c))
        return np.array(out)


class Quaternion(Parameterization):
    """The platform formulation's variables: a chart's three free quaternion components.

    Chart coordinates u = CHART_EXTENT (2x - 1) are the metric; a chart point's "angles" are its unit
    coordinates x (the rotation is :func:`chart_rotation`; the joint readings :func:`passive_readings_many`).
    Not among the loop equations' parameterizations (:data:`spherekin.search.parameterizations.PARAMETERIZATIONS`):
    it belongs to the platform formulation, which is chosen as a formulation.
    """

    name = "quaternion"

    def angles(self, charts, chart, x):
        return np.asarray(x, dtype=float)

    def contract(self, charts, chart, lo, hi, rlo, rhi):
        """Discard (rlo > rhi) the boxes whose roots another chart surely finds: the reduction
        [rlo, rhi] (unit coordinates of the boxes [lo, hi], B x N, updated in place) of a box of
        chart k is dropped when, on the whole reduced box, (a) some free |u_j| > CHART_CORE, or
        (b) the box lies in the core of a chart i < k: |u_i| >= 1 / CHART_CORE and every other
        free |u_l| <= CHART_CORE |u_i| (with the rounding margin CORE_ROUNDING).

        Why no root is lost: the core of chart j is where every free |u| <= CHART_CORE (q_j is
        the largest component, up to the factor CHART_CORE); every root lies in the core of its
        largest component's chart. Let j be the first chart (lowest index) whose core holds the
        root: on chart j no box holding it is dropped by (a) (it is in the core) nor by (b) (no
        earlier core holds it), and it is interior to chart j (CHART_CORE < CHART_EXTENT), so the
        Krawczyk test can isolate it there. What is dropped is the search of the same root again on
        other charts: measured on the Gosselin platform, its four serially singular assemblies
        have |q_0| = |q_1| = |q_2| = |q_3| at every input and were isolated on all four charts
        (20 roots an input for 8 assemblies).
        """
        width = hi - lo
        mlo, mhi = charts.map_lo[chart], charts.map_hi[chart]
        ulo = mlo + (mhi - mlo) * (lo + rlo * width)
        uhi = mlo + (mhi - mlo) * (lo + rhi * width)
        big = np.maximum(np.abs(ulo), np.abs(uhi))                                   # max |u| on the box
        small = np.where((ulo > 0.0) | (uhi < 0.0), np.minimum(np.abs(ulo), np.abs(uhi)), 0.0)   # min |u|
        drop = np.any(small > CHART_CORE * (1.0 + CORE_ROUNDING), axis=1)                        # (a)
        fixed = chart % CHARTS                  # the chart's fixed component (a chunk stacks 4 per input)
        for i in range(CHARTS - 1):             # (b): the core of chart i, as seen from charts k > i
            later = fixed > i                   # on chart k > i, component i is free variable i
            floor = small[:, i] * CHART_CORE * (1.0 - CORE_ROUNDING)
            others = np.delete(big, i, axis=1)
            drop |= later & (floor >= 1.0) & np.all(others <= floor[:, None], axis=1)
        rlo[drop] = 1.0
        rhi[drop] = 0.0


# ---------------------------------------------------------------------- the system of the registry

#: A root of the platform search and a finalized solution are the same assembly when their poses
#: agree to this (largest entry). Reason: both are Newton/Gauss-Newton limits accurate to ~1e-14 away
#: from parallel singularities (near one, the platform search does not isolate the roots and this
#: check is not reached), and distinct assemblies closer than 1e-8 occur only next to one.
POSE_MATCH = 1e-8
#: Two roots of the platform search are one (found from two overlapping charts, or on the face of
#: two boxes) when their poses agree to this. Reason: Newton limits of one root agree to ~1e-15;
#: two distinct roots this close could not be told apart by any float64 test downstream either.
DUPLICATE_POSE = 1e-12


class CompiledPlatform(Compiled):
    """Eq. (1) compiled for one mechanism (:class:`PlatformSystem`) and its pruner, built once.

    ``names``: the passive joints the pipeline reports (the mechanism's ``loop_unknowns`` order);
    :meth:`readings` maps platform poses back to them. In the chain (:mod:`.base`), an input whose
    roots this search cannot all isolate, or whose trust-layer answer disagrees with its roots
    (:meth:`check`), goes to the next system (the loop equations).
    """

    system = "platform"

    def __init__(self, equations: PlatformSystem, pruner, names, ranges, strategy):
        self.equations = equations
        self.pruner = pruner
        self.names = tuple(names)
        self.ranges = dict(ranges)
        self.strategy = strategy
        self.order = [passive_names(equations.legs).index(n) for n in self.names]

    @property
    def legs(self):
        return self.equations.legs

    @property
    def platform_reference(self) -> np.ndarray:
        return self.equations.platform_reference

    def charts(self, inputs) -> ChartSet:
        """The box loop's chart set at actuator ``inputs`` (:meth:`PlatformSystem.charts`)."""
        return self.equations.charts(inputs)

    def pose(self, chart: int, x) -> np.ndarray:
        """The platform pose R (3, 3) at the unit-box point x (3,) of chart ``chart``."""
        return self.equations.pose(chart, x)

    def poses(self, chart, x) -> np.ndarray:
        """The platform poses (B, 3, 3) at unit-box points x (B, 3) of charts ``chart`` (B,)."""
        return self.equations.poses(chart, x)

    def residuals(self, inputs, rotation) -> np.ndarray:
        return self.equations.residuals(inputs, rotation)

    def readings(self, inputs, poses) -> np.ndarray:
        """The passive joints' readings (K, len(names); radians, wrapped) at platform poses R (K, 3, 3);
        ``inputs``: the actuator readings of every pose, or one row per pose (K, legs)."""
        return passive_readings_many(self.legs, inputs, np.asarray(poses, dtype=float),
                                     self.platform_reference)[:, self.order]

    # ------------------------------------------------------------------ the pipeline's seam

    def describe(self) -> str:
        return "platform"

    def search_one(self, values, progress, trace):
        """The platform search at one input: a :class:`~.base.Found` (its roots' poses kept for
        :meth:`check`), or why the loop equations must answer instead (a :class:`~.base.Passed`)."""
        if trace is not None:
            raise ValueError("trace: only available with a loop formulation (paper, transversal, halves), "
                             "got the platform formulation")
        s = self.strategy
        t0 = time.perf_counter()
        charts = self.charts(values)
        t_setup = time.perf_counter() - t0
        try:
            found = search_platform(charts, self.pruner, s.tol, s.max_boxes, s.max_depth, progress)
        except SearchInterrupted:
            raise KeyboardInterrupt from None            # a search of milliseconds: nothing worth keeping
        except SolverLimitError as exc:
            return Passed(f"the platform search reached a cap ({exc})")
        return self._answers([found], [values], t_setup, charts.n_charts)[0]

    def search_many(self, rows: list, progress) -> list:
        """The chart sets of every row stacked, one box loop over all their boxes
        (:func:`spherekin.search.boxloop.search_platform_many`); None where a row reached a cap."""
        s = self.strategy
        t0 = time.perf_counter()
        charts = [self.charts(v) for v in rows]
        t_setup = (time.perf_counter() - t0) / len(rows)
        try:
            found = search_platform_many(stack_chart_sets(charts), len(rows), self.pruner, s.tol, s.max_boxes,
                                         s.max_depth, progress)
        except SearchInterrupted:
            raise KeyboardInterrupt from None        # searches of milliseconds: nothing worth keeping
        return self._answers(list(found), rows, t_setup, charts[0].n_charts)

    def _answers(self, found: list, values: list, t_setup: float, n_charts: int) -> list:
        """The answer of each input of a chunk from what the platform search ``found`` there: the poses,
        joint readings and range tests of all their roots as array operations, then each input's
        :class:`~.base.Found` (None where ``found`` is: a cap), or a :class:`~.base.Passed` where
        the search left boxes it could not isolate."""
        s = self.strategy
        owner = np.array([k for k, f in enumerate(found) if f is not None for _ in f.points], dtype=int)
        points = [p for f in found if f is not None for p in f.points]
        poses, readings, inside = np.empty((0, 3, 3)), np.empty((0, len(self.names))), np.empty(0, dtype=bool)
        if points:
            poses = self.poses(np.array([c for c, _ in points]), np.array([x for _, x in points]))
            readings = self.readings(np.array(values, dtype=float)[owner], poses)
            inside = np.ones(len(points), dtype=bool)
            for j, rng in enumerate(self.ranges.values()):
                inside &= in_range_many(readings[:, j], rng, s.tol + RANGE_TOL)
        settings = Settings(formulation="platform", pruner=s.pruner, lp_backend=s.lp_backend,
                            parameterization="quaternion", tol=s.tol, isolate=True, jobs=1, charts=n_charts)
        answered = np.array([f is not None and not f.unresolved for f in found], dtype=bool)
        kept = np.flatnonzero(first_of_duplicates(poses, owner, len(found)) & inside & answered[owner])
        clusters = clusters_in_range_many(readings[kept], readings[kept], owner[kept], len(found), self.ranges, s.tol)
        kept_of = np.split(kept, np.searchsorted(owner[kept], np.arange(1, len(found))))
        out: list = []
        for k, f in enumerate(found):
            if f is None:
                out.append(None)
            elif f.unresolved:
                out.append(Passed(f"the platform search left {f.unresolved} box(es) it could not isolate (a parallel "
                                  "singularity or a double root nearby): solved with the loop equations"))
            else:
                stats = dataclasses.replace(f.stats, time_setup=t_setup, time_total=f.stats.time_total + t_setup)
                report = SearchReport(self.names, tuple(clusters[k]), (), stats, settings)
                # no refined searches: a root the trust layer cannot prove goes to the loop equations
                out.append(Found(report, None, s.tol, False, list(poses[kept_of[k]])))
        return out

    def check(self, solutions: list, found: list) -> list:
        """:func:`disagreements` of the trust layer's solutions with the roots of each input's search."""
        return disagreements(solutions, [f.roots for f in found])


def first_of_duplicates(poses: np.ndarray, owner: np.ndarray, n_inputs: int, within: float = DUPLICATE_POSE) -> np.ndarray:
    """(N,) bool: which of the roots ``poses`` (N, 3, 3; ``owner`` (N,) the input of each, each
    input's roots in the order found) to keep: a root is dropped when a root kept before it, of the
    same input, is ``within`` it (largest entry; default DUPLICATE_POSE: the same root found on an
    overlapping chart). One pass per place in an input's list, each over every input of the chunk."""
    keep = np.zeros(len(poses), dtype=bool)
    if not len(poses):
        return keep
    flat, pos = pad_by_owner(np.asarray(poses).reshape(len(poses), 9), owner, n_inputs)   # NaN: no root
    near = np.abs(flat[:, :, None] - flat[:, None]).max(axis=3) <= within                  # (K, P, P)
    kept = np.zeros(flat.shape[:2], dtype=bool)
    for i in range(flat.shape[1]):
        kept[:, i] = ~np.isnan(flat[:, i, 0]) & ~np.any(near[:, i, :i] & kept[:, :i], axis=1)
    return kept[owner, pos]


def disagreement(solutions, poses) -> str | None:
    """Why the finalized ``solutions`` of a platform search are not its roots ``poses`` (None when
    they are): every entry proven, one entry per distinct root, each matching one (POSE_MATCH).

    The platform search proves where the roots are; the trust layer proves each assembly in the
    loop equations. The two must agree, or the input goes to the loop equations (in the manner of
    scipy's ``_check_result``: the fast path's answer is checked, not trusted).
    """
    return disagreements([solutions], [poses])[0]


def disagreements(solutions: list, poses: list) -> list[str | None]:
    """:func:`disagreement` of each input of a chunk (``solutions[k]``, ``poses[k]`` of input k), the
    pose comparisons of every input as array operations (pairs within an input, every input at once)."""
    out: list[str | None] = [None] * len(solutions)
    roots = [np.asarray(p, dtype=float).reshape(-1, 3, 3) for p in poses]
    owner = np.repeat(np.arange(len(roots)), [len(r) for r in roots])
    flat = np.concatenate(roots) if roots else np.empty((0, 3, 3))
    distinct = first_of_duplicates(flat, owner, len(roots), POSE_MATCH)
    n_distinct = np.bincount(owner[distinct], minlength=len(roots))
    got = [[s.platform_rotation for s in sols] for sols in solutions]
    g_owner = np.repeat(np.arange(len(got)), [len(g) for g in got])
    g_flat = np.array([np.full((3, 3), np.nan) if g is None else g for gs in got for g in gs]).reshape(-1, 9)
    padded, _ = pad_by_owner(g_flat, g_owner, len(got))                    # (K, G, 9); NaN: none
    d_flat = flat.reshape(-1, 9)[distinct]
    matched = np.any(np.all(np.abs(padded[owner[distinct]] - d_flat[:, None]) <= POSE_MATCH, axis=2), axis=1)
    unmatched = np.bincount(owner[distinct], weights=~matched, minlength=len(roots))
    for k, sols in enumerate(solutions):
        bad = [s.status for s in sols if not is_proven(s)]
        if bad:
            out[k] = f"the trust layer could not prove {len(bad)} root(s) of the platform search ({', '.join(bad)})"
        elif len(got[k]) != n_distinct[k] or unmatched[k]:
            out[k] = (f"the platform search found {n_distinct[k]} assemblies and the trust layer {len(got[k])} "
                      "different ones")
    return out


@SYSTEMS.register
class Platform(System):
    """Eq. (1): 3 unknowns (the output link's orientation, 4 quaternion charts) for three R-R-R legs."""

    name = "platform"
    default_formulation = "platform"
    description = "three equations in the output link's orientation (three R-R-R legs, one joint of each actuated)"

    @classmethod
    def formulations(cls) -> tuple[str, ...]:
        return (cls.name,)

    @classmethod
    def accepts(cls, mechanism, strategy=None) -> str | None:
        why = not_applicable(mechanism)
        if why is not None or strategy is None:
            return why
        return own_variables_declined(strategy, cls.name, "the platform formulation", " by the Krawczyk test")

    @classmethod
    def compile(cls, mechanism, strategy) -> CompiledPlatform:
        equations = PlatformSystem.from_mechanism(mechanism)
        pruner = make_pruner(strategy.pruner, [(len(equations.legs), 3, 3, 3)], strategy.lp_backend)
        names = tuple(mechanism.loop_unknowns)
        return CompiledPlatform(equations, pruner, names, {n: mechanism.ranges[n] for n in names}, strategy)
