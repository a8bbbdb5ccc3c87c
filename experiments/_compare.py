"""Mechanisms and ground-truth inputs shared by the comparison experiments (parameterizations,
lp_backends, scaling) and their tests.

Ground truth never comes from the solver: a configuration is built first (a platform pose, then
every joint reading by inverse kinematics or by spherical trigonometry), and its actuator readings
are the inputs. The configuration we started from must be among the solutions found.

* 3-DOF mechanisms (3-RRR, 4-leg variants): a random platform pose R (uniform on SO(3), or within
  a given angle of the reference pose for geometries with a limited workspace), every leg solved by
  the mechanism's inverse kinematics (Paden-Kahan), one working mode drawn at random.
* the four-bar and the five-bar (1 and 2 DOF, so a random pose is not reachable): random actuator
  readings; the platform joint C then lies at known spherical distances from two known axes (a
  circle-circle intersection on the sphere, two branches); the coupler pose R follows from the two
  platform axes, and inverse kinematics of R gives every joint reading.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from spherekin.core.angles import wrap
from spherekin.mechanism.chains import axis_rotation, serial_ik, sphere_point
from spherekin.mechanism.model import Joint, Leg, SphericalMechanism
from spherekin.mechanism.presets import five_bar, four_bar, general_3rrr, gosselin

#: Two angle vectors are the same solution when every angle agrees to this (radians, modulo 2 pi).
#: Solutions are polished to ~1e-15 by spherekin; the ground truth comes from closed forms
#: accurate to ~1e-15; 1e-7 is far above both and far below the spacing of distinct solutions.
MATCH_TOL = 1e-7
#: The closure check of a solution: every leg must give the same platform pose to this (max entry),
#: computed by plain Rodrigues products; polished solutions close to ~1e-15.
CLOSURE_TOL = 1e-9
#: General 3-RRR poses are drawn within this angle (radians) of the reference pose: its legs cannot
#: reach every orientation (link angles 50/75 deg), and poses near the reference are reachable.
GENERAL_POSE_ANGLE = 0.6
#: Draws of a pose before giving up on finding one every leg can reach.
MAX_DRAWS = 200


def random_rotation(rng: np.random.Generator, max_angle: float | None = None) -> np.ndarray:
    """A rotation uniform on SO(3) (unit quaternion from 4 normals), or a random axis and an angle
    uniform in [0, max_angle]."""
    if max_angle is None:
        q = rng.normal(size=4)
        w, x, y, z = q / np.linalg.norm(q)
        return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                         [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                         [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    axis = rng.normal(size=3)
    return axis_rotation(axis / np.linalg.norm(axis), rng.uniform(0.0, max_angle))


def _polar(polar_deg: float, azimuth_deg: float) -> np.ndarray:
    p, a = math.radians(polar_deg), math.radians(azimuth_deg)
    return np.array([math.sin(p) * math.cos(a), math.sin(p) * math.sin(a), math.cos(p)])


def _angle(a, b) -> float:
    return math.atan2(float(np.linalg.norm(np.cross(a, b))), float(np.dot(a, b)))


def _frame(p, q) -> np.ndarray:
    """Orthonormal frame (columns) built from two non-parallel unit vectors."""
    e1 = p / np.linalg.norm(p)
    e3 = np.cross(p, q)
    e3 /= np.linalg.norm(e3)
    return np.column_stack([e1, np.cross(e3, e1), e3])


# --------------------------------------------------------------------------------------------
# Mechanisms built with the general model (scaling experiment)
# --------------------------------------------------------------------------------------------

def _rrr_leg(k: int, u, v, proximal: float, distal: float, actuated=(True, False, False)) -> Leg:
    w = sphere_point(u, v, proximal, distal, 1.0)
    names = (f"beta{k}", f"gamma{k}", f"delta{k}")
    return Leg(f"leg{k}", tuple(Joint(n, a, act) for n, a, act in zip(names, (u, w, v), actuated)))


def four_rrr(actuated_legs: int = 4) -> SphericalMechanism:
    """A spherical platform on four RRR legs (link angles 50/75 deg, base axes at polar angle 110 deg and
    azimuths 0, 90, 180, 270 deg, platform axes at polar angle 60 deg, azimuths 45 + 90 k deg in the
    reference pose R = I). ``actuated_legs=4``: every base joint actuated (redundant actuation: 8
    passive unknowns, 9 scalar equations); ``3``: the fourth leg is fully passive (9 unknowns, 9
    equations, a square system)."""
    legs = []
    for k in range(4):
        act = (k < actuated_legs, False, False)
        legs.append(_rrr_leg(k + 1, _polar(110.0, 90.0 * k), _polar(60.0, 90.0 * k + 45.0),
                             math.radians(50.0), math.radians(75.0), act))
    kind = "redundantly actuated 4-RRR" if actuated_legs == 4 else "3-RRR + passive RRR leg"
    return SphericalMechanism(legs=tuple(legs), name=f"{kind} (50/75 deg)")


def three_rrr_rrrr() -> SphericalMechanism:
    """A 3-RRR whose third leg is an RRRR chain with its first two joints actuated (link angles
    40/45/60 deg): 4 inputs, 6 passive unknowns, 6 equations; the loop through the RRRR leg has
    one more factor pair. Axes as in :func:`four_rrr` (three legs at azimuths 0, 120, 240 deg)."""
    legs = [_rrr_leg(k + 1, _polar(110.0, 120.0 * k), _polar(60.0, 120.0 * k + 60.0),
                     math.radians(50.0), math.radians(75.0)) for k in range(2)]
    u, v = _polar(110.0, 240.0), _polar(60.0, 300.0)
    perp = v - (u @ v) * u          # towards v, normal to u: x1 is u turned 40 deg towards v
    x1 = math.cos(math.radians(40.0)) * u + math.sin(math.radians(40.0)) * perp / np.linalg.norm(perp)
    x2 = sphere_point(x1, v, math.radians(45.0), math.radians(60.0), 1.0)
    legs.append(Leg("leg3", (Joint("beta3", u, True), Joint("eps3", x1, True), Joint("gamma3", x2),
                             Joint("delta3", v))))
    return SphericalMechanism(legs=tuple(legs), name="3-RRR with an RRRR leg (2 actuated joints)")


# --------------------------------------------------------------------------------------------
# Ground-truth configurations
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Case:
    """Actuator inputs and one configuration (every joint reading, radians) that solves them."""

    inputs: tuple
    joints: dict

    def passive(self, names) -> np.ndarray:
        return np.array([self.joints[n] for n in names])


def _leg_pose(mech: SphericalMechanism, leg: Leg, readings) -> np.ndarray:
    out = np.eye(3)
    for j in leg.joints:
        out = out @ axis_rotation(np.array(j.axis), readings[j.name] - j.reference_angle)
    return out @ mech.platform_reference_matrix


def closure_error(mech: SphericalMechanism, readings) -> float:
    """Largest entry of the difference between the platform poses given by the legs: each leg's
    product of Rodrigues rotations about its reference axes (plain numpy, not the Eq. (2) loops)."""
    poses = [_leg_pose(mech, leg, readings) for leg in mech.legs]
    return max(float(np.abs(p - poses[0]).max()) for p in poses[1:])


def _ik_case(mech, rot, rng) -> Case | None:
    sols = mech.inverse_kinematics(rot)
    if not sols:
        return None
    s = sols[int(rng.integers(len(sols)))]
    return Case(tuple(s.inputs), dict(s.joint_angles))


def _rrrr_case(mech, rot, rng) -> Case | None:
    """IK of a pose for a mechanism whose leg3 has four joints: its first joint drawn at random, the
    other three by Paden-Kahan; the RRR legs by the model's inverse kinematics."""
    target = rot @ mech.platform_reference_matrix.T
    readings = {}
    for leg in mech.legs:
        axes = np.array([j.axis for j in leg.joints])
        if len(leg.joints) == 4:
            d1 = rng.uniform(-math.pi, math.pi)
            sols = serial_ik(axes[1:], axis_rotation(axes[0], d1).T @ target)
            disp = [(d1, *s) for s in sols]
        else:
            disp = serial_ik(axes, target)
        if not disp:
            return None
        d = disp[int(rng.integers(len(disp)))]
        readings.update({j.name: wrap(j.reference_angle + x) for j, x in zip(leg.joints, d)})
    return Case(tuple(readings[n] for n in mech.actuated), readings)


def _one_loop_case(mech, rng) -> Case | None:
    """Four-bar / five-bar: the legs' second-to-last axes from the inputs (and the base axis of a
    passive base joint), the platform joint C by a circle-circle intersection, R from (B, C)."""
    legs = mech.legs
    left, right = legs[0], legs[1]
    inputs = {n: rng.uniform(-math.pi, math.pi) for n in mech.actuated}
    b0 = np.array(left.joints[-1].axis)
    c0 = np.array(right.joints[-1].axis)
    # B: carried by the left leg's actuated joints (all joints of the left leg but the last are actuated)
    rot_l = np.eye(3)
    for j in left.joints[:-1]:
        rot_l = rot_l @ axis_rotation(np.array(j.axis), inputs[j.name] - j.reference_angle)
    b = rot_l @ b0
    # the right leg's joint before C: moved by the actuated joints before it; C is at its link twist from it
    rot_r = np.eye(3)
    for j in right.joints[:-2]:
        rot_r = rot_r @ axis_rotation(np.array(j.axis), inputs[j.name] - j.reference_angle)
    d = rot_r @ np.array(right.joints[-2].axis)
    twist_bc, twist_dc = _angle(b0, c0), right.twists[-1]
    c = sphere_point(b, d, twist_bc, twist_dc, 1.0 if rng.random() < 0.5 else -1.0)
    if c is None:
        return None
    rot = _frame(b, c) @ _frame(b0, c0).T @ mech.platform_reference_matrix
    want = np.array([inputs[n] for n in mech.actuated])
    for s in mech.inverse_kinematics(rot):
        if np.abs(np.array([wrap(x) for x in np.array(s.inputs) - want])).max() < MATCH_TOL:
            return Case(tuple(s.inputs), dict(s.joint_angles))
    return None


def random_cases(mech: SphericalMechanism, rng: np.random.Generator, n: int,
                 max_angle: float | None = None) -> list[Case]:
    """``n`` ground-truth configurations of ``mech`` (see the module doc)."""
    out = []
    for _ in range(n * MAX_DRAWS):
        if len(out) == n:
            break
        if len(mech.actuated) < 3:
            case = _one_loop_case(mech, rng)
        elif any(len(leg.joints) > 3 for leg in mech.legs):
            case = _rrrr_case(mech, random_rotation(rng, max_angle), rng)
        else:
            case = _ik_case(mech, random_rotation(rng, max_angle), rng)
        if case is not None:
            out.append(case)
    if len(out) < n:
        raise RuntimeError(f"{mech.name}: found only {len(out)} reachable configurations in {n * MAX_DRAWS} draws")
    return out


#: The comparison mechanisms: name -> (constructor, max pose angle for the random poses or None).
MECHANISMS = {
    "four_bar": (four_bar, None),
    "five_bar": (five_bar, None),
    "gosselin": (gosselin, None),
    "general_3rrr": (general_3rrr, GENERAL_POSE_ANGLE),
}


def angle_distance(a, b) -> float:
    """Largest |a_i - b_i| modulo 2 pi (radians)."""
    d = np.asarray(a, float) - np.asarray(b, float)
    return float(np.abs(np.remainder(d + math.pi, 2 * math.pi) - math.pi).max()) if d.size else 0.0


def contains(solutions, point, tol: float = MATCH_TOL) -> bool:
    """Whether one of the angle vectors ``solutions`` equals ``point`` within tol (modulo 2 pi)."""
    return any(angle_distance(s, point) <= tol for s in solutions)


def same_set(a, b, tol: float = MATCH_TOL) -> bool:
    """Whether two lists of angle vectors hold the same points (modulo 2 pi, within tol)."""
    return len(a) == len(b) and all(contains(b, x, tol) for x in a) and all(contains(a, y, tol) for y in b)
