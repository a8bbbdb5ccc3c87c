"""The mechanism as built for any mechanism: tolerances on the loop equations (issue 45).

:mod:`spherekin.trust.tolerances` proves what tolerances do to a 3-RRR driven at its base (the
platform system); this module does it for every other mechanism, on its loop equations: each
independent loop closes when the product of the joint rotations up one chain equals the product down
the other (Eq. (1); :class:`~spherekin.mechanism.LoopGeometry`), three equations per loop, the passive
joints' readings the unknowns (as many as the equations: a mechanism that is not redundantly
actuated). Every joint axis lies in its cone (a tilt (s, t) in a disk, as in the platform case) and
every actuated input in its interval: the tolerance set T.

For a nominal assembly theta0: the loops' residual f = the skew part of U D^T (U, D the two chains'
products) and its Jacobian in the passive readings (column j: the current axis w_j of joint j, from
the chain's product before it, turned into [w_j]x U D^T or -U D^T [w_j]x) are second-order Taylor
forms over T (:mod:`spherekin.core.taylor`: cos and sin of readings that are themselves forms). With
G the nominal derivative of the readings in p, the parametric Krawczyk test of
:func:`spherekin.trust.tolerances.krawczyk_over` proves one assembly theta0 + G p + z(p), z in a box
Z, for every p in T. Then, per passive joint j, ``worst_case_joint_error[j]`` <= the exact reach of
row j of G over T + |Z_j|; with an output link, ``worst_case_rotation_error`` bounds the rotation
between the nominal output and the built one (the skew part of the output's rotation against its
nominal: a linear maximum over the sphere plus the rest, its arcsine); each beside a lower bound, the
linearized worst geometry solved by Newton's method. The count over the tolerances is decided for a
one-loop mechanism with three passive joints (the sign of A^2 + B^2 - C^2, :func:`_one_loop_count`),
not for several loops (null); :mod:`spherekin.trust.tolerances` decides it for the platform system.
"""

from __future__ import annotations

import math

import numpy as np

from ..core import intervals as iv
from ..core.taylor import TaylorForm, ToleranceSet, cos_sin, stack
from ..mechanism.chains import axis_rotations
from ..results import AssemblyTolerance, ToleranceReport
from .tolerances import (NEWTON_STEPS, ROUNDING, TILT_PAD, axis_basis, krawczyk_over, linear_worst_case, matmul_forms,
                         rim_of, row_reach, tilted_axis)

__all__ = ["LoopToleranceModel", "loops_not_analysed", "analyse_loops"]

#: The count over the tolerances on the loop equations: not decided (the module doc).
COUNT_UNDECIDED = ("the count over the tolerances is decided for 3-RRRs driven at their base (the platform "
                   "system) and for one-loop mechanisms; on the loop equations of several loops it is not")


def loops_not_analysed(mechanism) -> str | None:
    """Why the loop equations' tolerance analysis does not cover ``mechanism`` (None when it does)."""
    eqs = 3 * len(mechanism.loop_geometry)
    if eqs != len(mechanism.passive):
        return (f"the tolerance analysis on the loop equations needs as many equations ({eqs}: 3 per loop) as "
                f"passive joints ({len(mechanism.passive)}): a redundantly actuated mechanism is not covered")
    return None


def _skew(v: TaylorForm) -> TaylorForm:
    """[v]x (3, 3) of a vector form v (3,)."""
    zero = v[0].scale(0.0)
    return stack([stack([zero, -v[2], v[1]], 0), stack([v[2], zero, -v[0]], 0), stack([-v[1], v[0], zero], 0)], 0)


def _skew_part(m: TaylorForm) -> TaylorForm:
    """The vector (m21 - m12, m02 - m20, m10 - m01) / 2 of a matrix form (3, 3): 0 for a symmetric m,
    sin(angle) times the axis for a rotation."""
    return stack([(m[2, 1] - m[1, 2]).scale(0.5), (m[0, 2] - m[2, 0]).scale(0.5), (m[1, 0] - m[0, 1]).scale(0.5)], 0)


class LoopToleranceModel:
    """A mechanism's loop equations as functions of its tolerance parameters: per joint (the file's
    order) the tilt (s, t) of its axis, then per actuated joint its input's error."""

    def __init__(self, mechanism, tolerances):
        self.mechanism = mechanism
        self.joints = list(mechanism.joints)
        self.index = {j.name: k for k, j in enumerate(self.joints)}
        self.passive = list(mechanism.passive)
        self.actuated = list(mechanism.actuated)
        self.tilt = np.array([math.tan(tolerances.axis_rad(j.name)) for j in self.joints]) * (1.0 + TILT_PAD)
        self.eps = tolerances.inputs_rad * (1.0 + TILT_PAD)
        self.axes = [np.asarray(j.axis, dtype=float) for j in self.joints]
        self.bases = [axis_basis(a) for a in self.axes]
        n = len(self.joints)
        blocks = [([2 * k, 2 * k + 1], float(self.tilt[k])) for k in range(n)]
        blocks += [([2 * n + i], float(self.eps)) for i in range(len(self.actuated))]
        self.blocks = blocks
        self.space = ToleranceSet(tuple(blocks), 2 * n + len(self.actuated))

    def radii(self):
        return self.blocks

    def axis_forms(self) -> list:
        return [tilted_axis(self.space, a, b, 2 * k, float(self.tilt[k]))
                for k, (a, b) in enumerate(zip(self.axes, self.bases))]

    def _rotation(self, axis: TaylorForm, angle: TaylorForm) -> TaylorForm:
        c, s = cos_sin(angle)
        eye = self.space.constant(np.eye(3))
        outer = axis[:, None] * axis[None, :]
        return eye * c + _skew(axis) * s + outer * (self.space.constant(1.0) - c)

    def system(self, axes, readings):
        """(f (3L,), J (3L, passive)) as forms at the readings ``readings`` (joint name -> form, radians)."""
        f_rows, j_rows = [], []
        for loop in self.mechanism.loop_geometry:
            chains = []
            for steps in (loop.up, loop.down):
                prod = self.space.constant(np.eye(3))
                current = {}
                for st in steps:
                    j = self.joints[self.index[st.joint]]
                    axis = axes[self.index[st.joint]]
                    current[st.joint] = (st.sign, matmul_forms(prod, axis[:, None])[:, 0])
                    angle = (readings[st.joint] - j.reference_angle).scale(float(st.sign))
                    prod = matmul_forms(prod, self._rotation(axis, angle))
                chains.append((prod, current))
            (up, up_axes), (down, down_axes) = chains
            m = matmul_forms(up, stack([stack([down[c, r] for c in range(3)], 0) for r in range(3)], 0))   # U D^T
            f_rows.append(_skew_part(m))
            cols = []
            for name in self.passive:
                if name in up_axes:
                    sign, w = up_axes[name]
                    cols.append(_skew_part(matmul_forms(_skew(w), m)).scale(float(sign)))
                elif name in down_axes:
                    sign, w = down_axes[name]
                    cols.append(_skew_part(matmul_forms(m, _skew(w))).scale(-float(sign)))
                else:
                    cols.append(self.space.constant(np.zeros(3)))
            j_rows.append(stack(cols, 1))
        f = stack([r[k] for r in f_rows for k in range(3)], 0)
        jac = stack([r[k] for r in j_rows for k in range(3)], 0)
        return f, jac

    def readings(self, values, theta0, g, z):
        """Every joint's reading as a form: passive ones theta0 + G p + z (z: bounds), actuated ones the
        input plus its parameter."""
        out = {}
        size, n = self.space.size, len(self.joints)
        for k, name in enumerate(self.passive):
            out[name] = TaylorForm(self.space, np.array(float(theta0[k])), np.asarray(g[k], dtype=float),
                                   np.zeros((size, size)), np.array(float(z[k])))
        for i, name in enumerate(self.actuated):
            out[name] = self.space.constant(float(values[i])) + self.space.symbol(2 * n + i)
        return out

    def point_axes(self, p) -> list:
        out = []
        for k, (a, (u1, u2)) in enumerate(zip(self.axes, self.bases)):
            w = a + p[2 * k] * u1 + p[2 * k + 1] * u2
            out.append(w / np.linalg.norm(w))
        return out

    def point_system(self, values, p, theta):
        """(f, J) in floats at the geometry p and passive readings theta (the same equations)."""
        axes = self.point_axes(p)
        read = dict(zip(self.passive, theta))
        n = len(self.joints)
        read.update({name: float(values[i]) + p[2 * n + i] for i, name in enumerate(self.actuated)})
        f_rows, j_rows = [], []
        for loop in self.mechanism.loop_geometry:
            chains = []
            for steps in (loop.up, loop.down):
                prod = np.eye(3)
                current = {}
                for st in steps:
                    j = self.joints[self.index[st.joint]]
                    axis = axes[self.index[st.joint]]
                    current[st.joint] = (st.sign, prod @ axis)
                    prod = prod @ axis_rotations(axis, st.sign * (read[st.joint] - j.reference_angle))
                chains.append((prod, current))
            (up, up_axes), (down, down_axes) = chains
            m = up @ down.T
            skew = lambda x: 0.5 * np.array([x[2, 1] - x[1, 2], x[0, 2] - x[2, 0], x[1, 0] - x[0, 1]])  # noqa: E731
            cross_m = lambda w: np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])  # noqa: E731
            f_rows.append(skew(m))
            cols = []
            for name in self.passive:
                if name in up_axes:
                    sign, w = up_axes[name]
                    cols.append(sign * skew(cross_m(w) @ m))
                elif name in down_axes:
                    sign, w = down_axes[name]
                    cols.append(-sign * skew(m @ cross_m(w)))
                else:
                    cols.append(np.zeros(3))
            j_rows.append(np.column_stack(cols))
        return np.concatenate(f_rows), np.vstack(j_rows)

    def newton(self, values, p, theta0, steps: int = NEWTON_STEPS):
        theta = np.array(theta0, dtype=float)
        for _ in range(steps):
            f, jac = self.point_system(values, p, theta)
            try:
                theta = theta - np.linalg.solve(jac, f)
            except np.linalg.LinAlgError:
                return None
        return theta if np.all(np.isfinite(theta)) else None

    def rim(self, direction) -> np.ndarray:
        """The geometry of T maximizing direction . p (:func:`spherekin.trust.tolerances.rim_of`)."""
        return rim_of(self.blocks, direction)


def _assembly(model, values, theta0, number: int, rotation) -> AssemblyTolerance:
    axes = model.axis_forms()
    zero = np.zeros((len(model.passive), model.space.size))
    f0, j0 = model.system(axes, model.readings(values, theta0, zero, np.zeros(len(model.passive))))
    try:
        c = np.linalg.inv(j0.c)
        g = -c @ f0.lin
    except np.linalg.LinAlgError:
        return AssemblyTolerance(number, None, reason="the nominal assembly is singular (the loop Jacobian)")

    def chart(z):
        return model.system(axes, model.readings(values, theta0, g, z))

    box = krawczyk_over(chart, c)
    if box is None:
        return AssemblyTolerance(number, None, reason="the assembly was not proven to persist over the tolerances (the "
                                                      "Krawczyk test did not contract: a singular configuration may lie "
                                                      "within them)")
    z, k = box
    per_joint = (row_reach(g, model.radii()) + iv.magnitude(k)) * (1.0 + ROUNDING)
    joint_bound = {name: float(np.nextafter(v, math.inf)) for name, v in zip(model.passive, per_joint)}
    joint_low = {}
    for j, name in enumerate(model.passive):
        best = None
        for sign in (1.0, -1.0):
            theta = model.newton(values, model.rim(sign * g[j]), theta0)
            if theta is not None and np.all(np.abs(theta - theta0 - g @ model.rim(sign * g[j])) <= z[1]):
                err = abs(float(theta[j] - theta0[j]))
                best = err if best is None else max(best, err)
        joint_low[name] = best
    rot_bound = rot_low = None
    mech = model.mechanism
    if mech.output is not None and rotation is not None:
        rot_bound, rot_low = _output_rotation(model, values, theta0, g, z, axes, np.asarray(rotation, dtype=float))
    return AssemblyTolerance(number, rot_bound, rot_low, enclosure_radius=tuple(float(v) for v in per_joint),
                             worst_case_joint_error=joint_bound, worst_case_joint_error_lower_bound=joint_low)


def _output_rotation(model, values, theta0, g, z, axes, rotation):
    """(bound, lower bound) of the rotation between the nominal output and the built one (radians)."""
    mech = model.mechanism
    readings = model.readings(values, theta0, g, z[1])
    prod = model.space.constant(np.eye(3))
    for st in mech.link_paths[mech.output]:
        j = model.joints[model.index[st.joint]]
        angle = (readings[st.joint] - j.reference_angle).scale(float(st.sign))
        prod = matmul_forms(prod, model._rotation(axes[model.index[st.joint]], angle))
    ref = np.asarray(mech.platform_reference_matrix, dtype=float)
    nominal_d = rotation @ ref.T                                          # D0 = R0 R_ref^T
    e = prod.matvec(nominal_d)                                            # D D0^T (matvec applies m^T on the right)
    vec = _skew_part(e)                                                   # sin(angle) axis
    trace = e[0, 0] + e[1, 1] + e[2, 2]
    if not trace.bounds()[0] > 1.0:                                       # cos(angle) > 0: angle < pi / 2
        return None, None
    upper, _, n = linear_worst_case(vec.lin, model.radii())
    rest = float(np.linalg.norm(model.space.reach_quadratic(vec.quad) + vec.rad))
    sine = (upper + rest) * (1.0 + ROUNDING)
    bound = float(np.nextafter(math.asin(min(1.0, sine)) * (1.0 + ROUNDING), math.inf)) if sine < 1.0 else None
    low = None
    for sign in (1.0, -1.0):
        p = model.rim(sign * (n @ vec.lin))
        theta = model.newton(values, p, theta0)
        if theta is None:
            continue
        axes_p = model.point_axes(p)
        read = dict(zip(model.passive, theta))
        read.update({name: float(values[i]) + p[2 * len(model.joints) + i] for i, name in enumerate(model.actuated)})
        d = np.eye(3)
        for st in mech.link_paths[mech.output]:
            j = model.joints[model.index[st.joint]]
            d = d @ axis_rotations(axes_p[model.index[st.joint]], st.sign * (read[st.joint] - j.reference_angle))
        err = math.acos(max(-1.0, min(1.0, (np.trace(d @ nominal_d.T) - 1.0) / 2.0)))
        low = err if low is None else max(low, err)
    return bound, low


def _one_loop_count(model, values) -> tuple[bool | None, str]:
    """The count over the tolerances of a one-loop mechanism with three passive joints (module doc of
    :mod:`spherekin.systems.one_loop`): around the loop from its first passive joint p,
    Rot(a_p, x) K1 Rot(a_q, y) K2 Rot(a_r, z) K3 = I and A cos y + B sin y = C with b = K1 a_q,
    c = K1 K2 a_r, G c = K3^T a_r: A = a_p . (c - (b . c) b), B = a_p . (b x c), C = a_p . G c -
    (b . c)(a_p . b). D = A^2 + B^2 - C^2 as a Taylor form over T: D > 0 everywhere proves 2 assemblies
    for every geometry, D < 0 none (Bezout on the projective line); else (None, why)."""
    mech = model.mechanism
    if len(mech.loop_geometry) != 1 or len(model.passive) != 3:
        return None, COUNT_UNDECIDED
    loop = mech.loop_geometry[0]
    cycle = [(st.joint, st.sign) for st in loop.up] + [(st.joint, -st.sign) for st in reversed(loop.down)]
    first = next(k for k, (name, _) in enumerate(cycle) if name in model.passive)
    cycle = cycle[first:] + cycle[:first]
    places = [k for k, (name, _) in enumerate(cycle) if name in model.passive]
    axes = model.axis_forms()
    zero = np.zeros((len(model.passive), model.space.size))
    readings = model.readings(values, np.zeros(len(model.passive)), zero, np.zeros(len(model.passive)))

    def product(part):
        out = model.space.constant(np.eye(3))
        for name, sign in part:
            j = model.joints[model.index[name]]
            angle = (readings[name] - j.reference_angle).scale(float(sign))
            out = matmul_forms(out, model._rotation(axes[model.index[name]], angle))
        return out

    p, q, r = places
    k1, k2, k3 = product(cycle[p + 1:q]), product(cycle[q + 1:r]), product(cycle[r + 1:])
    a_p, a_q, a_r = (axes[model.index[cycle[k][0]]] for k in (p, q, r))
    b = matmul_forms(k1, a_q[:, None])[:, 0]
    c = matmul_forms(matmul_forms(k1, k2), a_r[:, None])[:, 0]
    k3t = stack([stack([k3[col, row] for col in range(3)], 0) for row in range(3)], 0)
    gc = matmul_forms(k3t, a_r[:, None])[:, 0]
    bc = b.dot(c)
    a = a_p.dot(c - b * bc)
    bb = a_p.dot(b.cross(c))
    cc = a_p.dot(gc) - bc * a_p.dot(b)
    d = a * a + bb * bb - cc * cc
    lo, hi = d.bounds()
    if lo > 0.0:
        return True, ("the loop's A^2 + B^2 - C^2 is positive for every geometry and input within the tolerances "
                      "(a Taylor form over them): 2 assemblies, always")
    if hi < 0.0:
        return True, ("the loop's A^2 + B^2 - C^2 is negative for every geometry and input within the tolerances: "
                      "no assembly, always")
    # D's value at two geometries of T, each proven by the form (value within rad + its rounding): opposite
    # signs prove a branch point (two assemblies meeting) between them, inside T (convex)
    signs = set()
    for sign in (1.0, -1.0):
        pt = model.rim(sign * d.lin)
        value = float(d.c + d.lin @ pt + pt @ d.quad @ pt)
        if abs(value) > float(d.rad) * (1.0 + ROUNDING) + 1e-12 * (1.0 + abs(float(d.c))):
            signs.add(value > 0.0)
    if len(signs) == 2:
        return False, ("the loop's A^2 + B^2 - C^2 is proven positive at one geometry within the tolerances and "
                       "negative at another: a branch point (two assemblies meeting) lies between them")
    return None, (f"the loop's A^2 + B^2 - C^2 may change sign within the tolerances (its enclosure [{lo:.2e}, "
                  f"{hi:.2e}]): a branch point may lie within them")


def analyse_loops(mechanism, tolerances, values, report) -> ToleranceReport:
    """The :class:`~spherekin.results.ToleranceReport` of ``report`` (the nominal solve at ``values``) on
    the loop equations: per assembly ``worst_case_joint_error`` (and, with an output link,
    ``worst_case_rotation_error``); the count undecided."""
    info = tolerances.as_dict()
    entries = list(report.solutions)
    why = loops_not_analysed(mechanism)
    if why is not None:
        return ToleranceReport.uncovered(info, why, len(entries))
    model = LoopToleranceModel(mechanism, tolerances)
    out = []
    for k, sol in enumerate(entries, start=1):
        if str(sol.status) != "certified":
            out.append(AssemblyTolerance(k, None, reason=f"status {sol.status}: only certified regular assemblies are "
                                                         "analysed on the loop equations"))
            continue
        angles = dict(zip(report.unknowns, np.asarray(sol.angles, dtype=float)))
        theta0 = np.array([angles[name] for name in model.passive])
        out.append(_assembly(model, np.asarray(values, dtype=float), theta0, k, sol.platform_rotation))
    constant, why = (None, "the nominal count is not proven") if not report.count_exact else \
        _one_loop_count(model, np.asarray(values, dtype=float))
    if constant and any(mechanism.ranges.get(n) is not None for n in mechanism.passive):
        constant, why = None, "passive joint ranges are not decided under tolerances; " + why
    return ToleranceReport(info, constant, why, tuple(out))
