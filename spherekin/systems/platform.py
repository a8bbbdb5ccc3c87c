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

Eq. (1) is written once, here: :class:`LegConstants` holds its constants (e(d1) by Rodrigues, a3,
a2 . a3), which the compiled chart tensors (:meth:`PlatformSystem.from_mechanism`) and certified
tracking (:class:`spherekin.trust.continuation.LegEquations`) both read; :class:`Platform` is the
system of the registry (:mod:`spherekin.systems.base`): what it accepts and what it compiles.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.angles import wrap
from ..core.orientation import quaternion_matrix
from ..core.rotations import cross
from ..mechanism.chains import angle_about, axis_rotation, perpendicular
from ..search.parameterizations import ROUNDING_SAFETY, ChartSet, Parameterization
from ..search.pruners import make_pruner
from .base import SYSTEMS, Compiled, System

__all__ = ["CHARTS", "CHART_EXTENT", "ACCEPT_WIDTH", "PlatformLeg", "LegConstants", "leg_constants", "PlatformSystem",
           "platform_legs", "not_applicable", "quaternion_matrix", "form_matrix", "chart_control_points",
           "chart_quaternion", "chart_rotation", "passive_readings", "passive_readings_many", "passive_names",
           "Quaternion", "MAX_ASSEMBLIES", "Platform", "CompiledPlatform"]

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
    """Quaternions (B, 4) (not normalized) of unit-box points x (B, 3) of charts ``chart`` (B,)."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    chart = np.broadcast_to(np.asarray(chart, dtype=int), (len(x),))
    q = np.empty((len(x), 4))
    for b, (k, xb) in enumerate(zip(chart, x)):
        q[b] = np.insert(CHART_EXTENT * (2.0 * xb - 1.0), k, 1.0)
    return q


def chart_rotation(chart: int, x) -> np.ndarray:
    """The rotation (3, 3) at the unit-box point x (3,) of chart ``chart`` (for a mechanism: the
    platform displacement D, see :meth:`PlatformSystem.pose`)."""
    q = chart_quaternion(chart, x)[0]
    return quaternion_matrix(q) / float(q @ q)


class PlatformLeg:
    """One R-R-R leg as Eq. (1) sees it: joint names, reference axes (base frame) and readings."""

    __slots__ = ("names", "a1", "a2", "a3", "reference")

    names: tuple
    a1: np.ndarray
    a2: np.ndarray
    a3: np.ndarray
    reference: tuple

    def __init__(self, names, a1, a2, a3, reference):
        self.names = names
        self.a1 = a1
        self.a2 = a2
        self.a3 = a3
        self.reference = reference


def not_applicable(mechanism) -> str | None:
    """Why the platform formulation does not apply to ``mechanism`` (None when it does): its loops
    must close through one output link held by three R-R-R chains from the ground (its legs), each
    with the base joint actuated."""
    if not getattr(mechanism, "legs", None):
        return ("the platform formulation needs three legs from the ground to one output link, "
                "the mechanism has none (its loops do not close through one output link)")
    if len(mechanism.legs) != 3:
        return (f"the platform formulation needs 3 legs (3 equations in 3 unknowns), "
                f"got {len(mechanism.legs)}")
    for leg in mechanism.legs:
        kinds = [j.actuated for j in leg.joints]
        if kinds != [True, False, False]:
            pattern = "-".join("A" if a else "P" for a in kinds)
            return (f"the platform formulation needs R-R-R legs with the base joint actuated (A-P-P), "
                    f"leg {leg.name!r} is {pattern}")
    return None


def platform_legs(mechanism) -> tuple[PlatformLeg, ...]:
    """The legs of an eligible mechanism (:func:`not_applicable`), else ValueError naming why."""
    reason = not_applicable(mechanism)
    if reason is not None:
        raise ValueError(f"formulation 'platform': {reason}")
    return tuple(PlatformLeg(tuple(j.name for j in leg.joints), *(np.array(j.axis, dtype=float) for j in leg.joints),
                             tuple(j.reference_angle for j in leg.joints)) for leg in mechanism.legs)


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
    """The :class:`LegConstants` of ``legs`` (:class:`PlatformLeg`, from :func:`platform_legs`)."""
    c1 = np.array([float(leg.a1 @ leg.a2) for leg in legs])
    return LegConstants(ref=np.array([leg.reference[0] for leg in legs], dtype=float),
                        perp=np.array([leg.a2 - c * leg.a1 for leg, c in zip(legs, c1)]),
                        side=np.array([cross(leg.a1, leg.a2) for leg in legs]),
                        axial=np.array([c * leg.a1 for leg, c in zip(legs, c1)]),
                        b=np.array([leg.a3 for leg in legs]),
                        c=np.array([float(leg.a2 @ leg.a3) for leg in legs]))


def passive_readings(legs, inputs, rotation, platform_reference) -> dict[str, float]:
    """Passive joint readings (radians, wrapped to [-pi, pi)) of the assembly at platform pose R.

    The slow, readable reference of :func:`passive_readings_many` (which the solver uses).

    ``inputs``: the actuated readings, one per leg. R = D R_ref; per leg M = Rot(a1, -d1) D must be
    Rot(a2, d2) Rot(a3, d3): d2 turns a3 onto M a3 about a2, d3 = the angle of Rot(a2, -d2) M about a3.
    """
    d = np.asarray(rotation, dtype=float) @ np.asarray(platform_reference, dtype=float).T
    out = {}
    for leg, beta in zip(legs, inputs):
        m = axis_rotation(leg.a1, -(float(beta) - leg.reference[0])) @ d
        d2 = angle_about(leg.a2, leg.a3, m @ leg.a3)
        n = axis_rotation(leg.a2, -d2) @ m
        p = perpendicular(leg.a3)
        d3 = angle_about(leg.a3, p, n @ p)
        out[leg.names[1]] = wrap(leg.reference[1] + d2)
        out[leg.names[2]] = wrap(leg.reference[2] + d3)
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
    return tuple(n for leg in legs for n in leg.names[1:])


def passive_readings_many(legs, inputs, rotations, platform_reference) -> np.ndarray:
    """Passive joint readings (K, 2 x legs; radians, wrapped to [-pi, pi)) at K platform poses.

    The batch form of :func:`passive_readings` (its slow, readable reference), columns in the order
    of :func:`passive_names`. ``rotations`` (K, 3, 3); ``inputs``: the actuated readings, one per leg
    (shared by every pose), or one row of them per pose (K, legs).
    With M = Rot(a1, -d1) D: d2 = the angle about a2 from a3 to M a3; then Rot(a2, -d2) M p, for a
    fixed p normal to a3, written out by Rodrigues, gives d3 about a3.
    """
    d = np.asarray(rotations, dtype=float) @ np.asarray(platform_reference, dtype=float).T     # (K, 3, 3)
    inputs = np.asarray(inputs, dtype=float)
    cols = []
    for i, leg in enumerate(legs):
        if inputs.ndim == 1:
            m = axis_rotation(leg.a1, -(float(inputs[i]) - leg.reference[0])) @ d
        else:                                   # one input row per pose: Rot(a1, -d1) by Rodrigues, batched
            k1 = np.array([[0.0, -leg.a1[2], leg.a1[1]], [leg.a1[2], 0.0, -leg.a1[0]], [-leg.a1[1], leg.a1[0], 0.0]])
            t = -(inputs[:, i] - leg.reference[0])
            rot = np.eye(3) + np.sin(t)[:, None, None] * k1 + (1.0 - np.cos(t))[:, None, None] * (k1 @ k1)
            m = rot @ d
        ma3 = m @ leg.a3
        d2 = _angles_about(leg.a2, np.broadcast_to(leg.a3, ma3.shape), ma3)
        p = perpendicular(leg.a3)
        w = m @ p                                                 # M p, then Rot(a2, -d2) by Rodrigues
        a = leg.a2
        c, s = np.cos(d2)[:, None], -np.sin(d2)[:, None]
        a_cross_w = np.stack((a[1] * w[:, 2] - a[2] * w[:, 1], a[2] * w[:, 0] - a[0] * w[:, 2],
                              a[0] * w[:, 1] - a[1] * w[:, 0]), axis=1)
        n_p = w * c + a_cross_w * s + np.outer(w @ a, a) * (1.0 - c)
        d3 = _angles_about(leg.a3, np.broadcast_to(p, n_p.shape), n_p)
        cols += [wrap(leg.reference[1] + d2), wrap(leg.reference[2] + d3)]
    return np.stack(cols, axis=1).reshape(len(d), -1)


class PlatformSystem:
    """Eq. (1) of every leg compiled on the four charts: control points = cos d1 C_c + sin d1 C_s + C_0.

    ``parts`` (3 legs, 3 parts (c, s, 0), 4 charts, 3, 3, 3). Built by :meth:`from_mechanism`.
    """

    __slots__ = ("legs", "parts", "platform_reference", "constants")

    legs: tuple
    parts: np.ndarray
    platform_reference: np.ndarray
    constants: LegConstants

    def __init__(self, legs, parts, platform_reference, constants=None):
        self.legs = legs
        self.parts = parts
        self.platform_reference = platform_reference
        self.constants = leg_constants(legs) if constants is None else constants

    @classmethod
    def from_mechanism(cls, mechanism) -> "PlatformSystem":
        legs = platform_legs(mechanism)
        k = leg_constants(legs)
        # q^T M q of cos d1 perp + sin d1 side + axial against a3, less c: three parts linear in (cos d1, sin d1, 1)
        mats = [[form_matrix(k.perp[i], k.b[i], 0.0), form_matrix(k.side[i], k.b[i], 0.0),
                 form_matrix(k.axial[i], k.b[i], float(k.c[i]))] for i in range(len(legs))]
        return cls(legs, chart_control_points(np.array(mats)), np.array(mechanism.platform_reference_matrix), k)

    def control_points(self, inputs) -> np.ndarray:
        """Control points (4 charts, 3 legs, 3, 3, 3) of Eq. (1) at actuator ``inputs`` (radians, one per leg)."""
        d1 = np.asarray(inputs, dtype=float) - np.array([leg.reference[0] for leg in self.legs])
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
        names = tuple(leg.names[0] for leg in self.legs)
        variables = ("q_a", "q_b", "q_c")
        ones = np.full((CHARTS, 3), CHART_EXTENT)
        return ChartSet(Quaternion(), names, variables, [cps], [tols], [names], [tuple(range(len(self.legs)))],
                        -ones, ones, np.zeros((CHARTS, 3)), ACCEPT_WIDTH, [None], [True])

    def pose(self, chart: int, x) -> np.ndarray:
        """The platform pose R = D R_ref (3, 3) at the unit-box point x (3,) of chart ``chart``
        (the charts parameterize the displacement D)."""
        return chart_rotation(chart, x) @ self.platform_reference

    def residuals(self, inputs, rotation) -> np.ndarray:
        """Eq. (1) at a pose R (3, 3): e(d1) . (D a3) - a2 . a3 per leg (legs,; independent of the charts)."""
        d = np.asarray(rotation, dtype=float) @ self.platform_reference.T
        return self.constants.residual(d, np.asarray(inputs, dtype=float))


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


# ---------------------------------------------------------------------- the system of the registry

class CompiledPlatform(Compiled):
    """Eq. (1) compiled for one mechanism (:class:`PlatformSystem`) and its pruner, built once.

    ``names``: the passive joints the pipeline reports (the mechanism's ``loop_unknowns`` order);
    :meth:`readings` maps platform poses back to them.
    """

    def __init__(self, equations: PlatformSystem, pruner, names):
        self.equations = equations
        self.pruner = pruner
        self.names = tuple(names)
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

    def residuals(self, inputs, rotation) -> np.ndarray:
        return self.equations.residuals(inputs, rotation)

    def readings(self, inputs, poses) -> np.ndarray:
        """The passive joints' readings (K, len(names); radians, wrapped) at platform poses R (K, 3, 3)."""
        return passive_readings_many(self.legs, inputs, np.asarray(poses, dtype=float),
                                     self.platform_reference)[:, self.order]


@SYSTEMS.register
class Platform(System):
    """Eq. (1): 3 unknowns (the output link's orientation, 4 quaternion charts) for three R-R-R legs."""

    name = "platform"
    description = "three equations in the output link's orientation (three R-R-R legs, base joints actuated)"

    @classmethod
    def accepts(cls, mechanism, strategy=None) -> str | None:
        why = not_applicable(mechanism)
        if why is not None or strategy is None:
            return why
        if strategy.formulation not in ("auto", cls.name):
            return f"formulation {strategy.formulation!r} asked for (a loop formulation)"
        if strategy.formulation != cls.name and strategy.parameterization != "tan-half":
            return (f"parameterization {strategy.parameterization!r} asked for "
                    "(the platform formulation has its own variables)")
        if not strategy.isolate:
            return "isolate=False asked for (the platform formulation proves its roots by the Krawczyk test)"
        return None

    @classmethod
    def compile(cls, mechanism, strategy) -> CompiledPlatform:
        equations = PlatformSystem.from_mechanism(mechanism)
        pruner = make_pruner(strategy.pruner, [(len(equations.legs), 3, 3, 3)], strategy.lp_backend)
        return CompiledPlatform(equations, pruner, mechanism.loop_unknowns)
