"""Rotations of serial chains of revolute joints through one point (spherical chains).

Rodrigues rotations, the product of exponentials of a chain, the columns of its Jacobian, and its
inverse kinematics by the Paden-Kahan subproblems (legs of 1, 2 or 3 joints). Angles in radians,
axes unit 3-vectors.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.rotations import cross

__all__ = ["IK_TOL", "axis_rotation", "axis_rotations", "angle_about", "least_aligned_basis", "perpendicular", "chain_rotation",
           "current_axes", "serial_ik", "sphere_point"]

#: Residual (max |entry| of the rotation mismatch) under which a leg's inverse kinematics is
#: accepted, and the negative slack allowed for the discriminant of the 3-joint subproblem.
#: Reason: for a reachable pose the residual is ~1e-15; legs of 1 or 2 joints can reach only a
#: lower-dimensional set of poses, and a pose built from the mechanism's own geometry lies on it to
#: rounding, while a pose off the set misses it by far more than 1e-9.
IK_TOL = 1e-9




def axis_rotation(axis, angle: float) -> np.ndarray:
    """Rot(a, angle): right-handed rotation about the unit vector a (Rodrigues), shape (3, 3).

    Rot(a, t) = I + sin t [a]x + (1 - cos t) [a]x^2.
    """
    a = np.asarray(axis, dtype=float)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * (k @ k)


def axis_rotations(axis, angles) -> np.ndarray:
    """Rot(a, t) for an array of angles t (radians, shape (...)): shape (..., 3, 3) (Rodrigues, batched)."""
    a = np.asarray(axis, dtype=float)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    t = np.asarray(angles, dtype=float)[..., None, None]
    return np.eye(3) + np.sin(t) * k + (1.0 - np.cos(t)) * (k @ k)


def angle_about(axis, x, y) -> float:
    """Signed angle (radians, in [-pi, pi]) about the unit vector ``axis`` from x to y.

    Both vectors are projected on the plane normal to ``axis`` first; the angle is
    atan2(axis . (x' x y'), x' . y'). It is 0 if a projection vanishes.
    """
    a = np.asarray(axis, dtype=float)
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    xp = x - a * (a @ x)
    yp = y - a * (a @ y)
    return math.atan2(float(a @ cross(xp, yp)), float(xp @ yp))


def least_aligned_basis(p) -> np.ndarray:
    """The basis vector e_x, e_y or e_z with the smallest |e . p| (the first one on ties)."""
    e = np.zeros(3)
    e[int(np.argmin(np.abs(np.asarray(p, dtype=float))))] = 1.0
    return e


def perpendicular(p: np.ndarray) -> np.ndarray:
    """A fixed unit vector normal to p: p x e / |.| for e = least_aligned_basis(p)."""
    n = cross(p, least_aligned_basis(p))
    return n / np.linalg.norm(n)


def chain_rotation(axes: np.ndarray, displacements) -> np.ndarray:
    """Product of exponentials Rot(a_1, d_1) ... Rot(a_k, d_k) (axes in the reference configuration)."""
    out = np.eye(3)
    for a, d in zip(axes, displacements):
        out = out @ axis_rotation(a, d)
    return out


def current_axes(axes: np.ndarray, displacements) -> np.ndarray:
    """Columns a_i(q) = Rot(a_1, d_1) ... Rot(a_{i-1}, d_{i-1}) a_i of a leg's Jacobian, shape (3, k)
    for displacements (k,); for displacements (..., k) (many configurations at once), (..., 3, k)."""
    axes = np.asarray(axes, dtype=float)
    d = np.asarray(displacements, dtype=float)
    rot = np.broadcast_to(np.eye(3), d.shape[:-1] + (3, 3))
    cols = []
    for i, a in enumerate(axes):
        cols.append(rot @ a)
        rot = rot @ axis_rotations(a, d[..., i])
    return np.stack(cols, axis=-1)


def serial_ik(axes: np.ndarray, target: np.ndarray) -> list[tuple[float, ...]]:
    """All displacements d with Rot(a_1, d_1) ... Rot(a_k, d_k) = target, for k = 1, 2, 3.

    Paden-Kahan subproblems: subproblem 1 (rotate x to y about one axis) for the last joint and for
    k <= 2; subproblem 2 (rotate p = a_3 to q = target a_3 about a_1 then a_2) for k = 3, whose
    intersection c = alpha a_1 + beta a_2 + gamma (a_1 x a_2) has gamma = +-sqrt(.) (two branches).
    Solutions whose residual exceeds IK_TOL are dropped (unreachable pose).
    """
    k = len(axes)
    if not 1 <= k <= 3:
        raise ValueError(f"axes: expected a chain of 1 to 3 joints, got {k}")

    def finish(prefix: list[float]) -> list[tuple[float, ...]]:
        rest = chain_rotation(axes[: len(prefix)], prefix).T @ target  # must be Rot(a_k, d_k)
        a = axes[-1]
        e = perpendicular(a)
        d = angle_about(a, e, rest @ e)
        sol = tuple(prefix) + (d,)
        if np.abs(chain_rotation(axes, sol) - target).max() > IK_TOL:
            return []
        return [sol]

    if k == 1:
        return finish([])
    if k == 2:
        a1, a2 = axes
        q = target @ a2
        if abs(a1 @ a2 - a1 @ q) > IK_TOL:
            return []
        return finish([angle_about(a1, a2, q)])
    a1, a2, p = axes
    q = target @ p
    c12 = float(a1 @ a2)
    den = c12 * c12 - 1.0
    alpha = (c12 * (a2 @ p) - a1 @ q) / den
    beta = (c12 * (a1 @ q) - a2 @ p) / den
    n12 = cross(a1, a2)
    g2 = (1.0 - alpha**2 - beta**2 - 2.0 * alpha * beta * c12) / (n12 @ n12)
    if g2 < -IK_TOL:
        return []
    gamma = math.sqrt(max(g2, 0.0))
    out = []
    for s in (1.0, -1.0):
        c = alpha * a1 + beta * a2 + s * gamma * n12
        d2 = angle_about(a2, p, c)
        d1 = angle_about(a1, c, q)
        out.extend(finish([d1, d2]))
    return out


def sphere_point(p, q, ang_p: float, ang_q: float, branch: float) -> np.ndarray | None:
    """The unit vector c with angle(c, p) = ang_p and angle(c, q) = ang_q (radians), on side
    ``branch`` (+1 or -1) of p x q; None when the two circles do not meet.

    c = a p + b q + g (p x q): the two angle conditions fix a and b (a 2 x 2 linear system in the
    Gram matrix of p, q), and |c| = 1 fixes g^2. p and q: non-parallel unit vectors.
    """
    p, q = np.asarray(p, dtype=float), np.asarray(q, dtype=float)
    cpq = float(p @ q)
    den = 1.0 - cpq * cpq
    a = (math.cos(ang_p) - cpq * math.cos(ang_q)) / den
    b = (math.cos(ang_q) - cpq * math.cos(ang_p)) / den
    n = cross(p, q)
    g2 = (1.0 - a * a - b * b - 2 * a * b * cpq) / float(n @ n)
    if g2 < 0:
        return None
    return a * p + b * q + branch * math.sqrt(g2) * n
