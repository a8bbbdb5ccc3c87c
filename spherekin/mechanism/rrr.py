"""The 3-RRR spherical parallel manipulator, built from its geometry (the paper's Gosselin platform, Fig. 2).

Semantics (radians; every vector a unit vector through the common centre):

* ``base_axes`` u_i (base frame): the actuated joints. Actuation rotates the proximal link about
  u_i by the right-hand rule: w_i(beta_i) = Rot(u_i, beta_i) w_i^0.
* ``elbow_axes_at_zero`` w_i^0 (base frame): the elbow (intermediate) axis of leg i when
  beta_i = 0. The proximal link angle is alpha1_i = angle(u_i, w_i^0).
* ``platform_axes`` v_i^0 (platform frame). A pose is a rotation R mapping platform-frame vectors
  to the base frame, v_i = R v_i^0.
* ``distal_link_angles`` alpha2_i = angle(w_i, v_i).

Joint names (the inputs are beta1, beta2, beta3 in this order): leg i ("leg1".."leg3") has the
actuated joint ``beta{i}``, the elbow joint ``gamma{i}`` and the platform joint ``delta{i}``. The
passive joint readings are intrinsic (they do not depend on any reference configuration):

* gamma_i = signed angle about w_i (right-hand rule) from u_i to v_i (both projected on the plane
  normal to w_i): 0 when the leg is folded (v_i on u_i's side of the plane of the proximal link),
  +-pi when it is stretched;
* delta_i = signed angle about v_i from w_i to r_i = R r_i^0, where r_i^0 is the next platform
  axis v_{i+1}^0 (v_1^0 after v_3^0), or, if that axis is (nearly) parallel to v_i^0, the
  platform-frame basis vector least aligned with v_i^0.

Each reading grows by d when the joint turns the link after it (platform side) by d relative to the
link before it, so these are the readings of the general model (:mod:`.model`) whose
``reference_angle`` values are the intrinsic angles at an assembled reference configuration. That
configuration is found here: the pose R_ref = I if every leg can be assembled there, otherwise a
pose found by least squares (every leg needs angle(u_i, R v_i^0) within
[|alpha1_i - alpha2_i|, min(alpha1_i + alpha2_i, 2 pi - alpha1_i - alpha2_i)]).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np

from ..core.angles import check_geometry_angle, wrap
from ..core.rotations import cross
from .chains import angle_about, axis_rotation, least_aligned_basis
from .checks import check_range, given_unit_vector, normalized_floats, parse_angle, shown
from .model import PARALLEL_TOL, Joint, Leg, SphericalMechanism

__all__ = [
    "REFERENCE_MARGIN",
    "PLATFORM_DIRECTION_MIN_SINE",
    "THREE_RRR_KEYS",
    "ThreeRRRGeometry",
    "three_rrr",
    "rrr_joint_names",
    "elbow_angle",
    "platform_joint_angle",
    "find_reference_pose",
]

#: The reference configuration keeps each leg at least this far (radians) inside its assembly
#: band. Reason: at the band edges the leg is at a serial singularity (u, w, v coplanar) where the
#: reference readings are ill-conditioned; any interior configuration serves equally well.
REFERENCE_MARGIN = 1e-3

#: The next platform axis serves as the reference direction of delta_i only if the sine of its
#: angle to v_i^0 is at least this. Reason: delta_i is measured in the plane normal to v_i, and a
#: direction nearly parallel to v_i would make it ill-conditioned (error ~ 1e-16 / sine).
PLATFORM_DIRECTION_MIN_SINE = 1e-3

#: Keys of a 3-RRR description (Python keyword arguments and mechanism-file keys).
THREE_RRR_KEYS = ("base_axes", "elbow_axes_at_zero", "platform_axes", "distal_link_angles")


def rrr_joint_names() -> tuple[str, ...]:
    """The nine joint names of a 3-RRR, leg by leg: beta1, gamma1, delta1, beta2, ..."""
    return tuple(f"{p}{i}" for i in (1, 2, 3) for p in ("beta", "gamma", "delta"))


def _angle(a, b) -> float:
    """Unsigned angle between unit vectors (atan2 form, accurate near 0 and pi)."""
    return math.atan2(float(np.linalg.norm(cross(a, b))), float(np.dot(a, b)))


def elbow_angle(u, w, v) -> float:
    """gamma = signed angle about w from u to v (radians, in [-pi, pi])."""
    return angle_about(w, u, v)


def platform_joint_angle(w, v, r) -> float:
    """delta = signed angle about v from w to the platform reference direction r (radians)."""
    return angle_about(v, w, r)


@dataclass(frozen=True)
class ThreeRRRGeometry:
    """The description of a 3-RRR (see the module docstring); vectors as tuples, angles in radians."""

    base_axes: tuple
    elbow_axes_at_zero: tuple
    platform_axes: tuple
    distal_link_angles: tuple
    #: The description's vectors with their floats as given (issue 40): (base_axes,
    #: elbow_axes_at_zero, platform_axes) before normalization (None: the three lists above). The
    #: mechanism is their exact directions; the lists above round them to floats (~1e-16 off).
    given_axes: tuple | None = field(default=None, repr=False)
    #: The (joint name, offset) pairs of the nonzero ``joint_offsets`` (radians, as given), in
    #: :func:`rrr_joint_names` order: a joint reads its angle minus its offset.
    joint_offsets: tuple = ()

    def __post_init__(self):
        if self.given_axes is None:
            object.__setattr__(self, "given_axes", (tuple(self.base_axes), tuple(self.elbow_axes_at_zero),
                                                    tuple(self.platform_axes)))

    @property
    def proximal_link_angles(self) -> tuple[float, ...]:
        """alpha1_i = angle(u_i, w_i^0)."""
        return tuple(_angle(u, w) for u, w in zip(self.base_axes, self.elbow_axes_at_zero))

    def _next_axis_serves(self, i: int) -> bool:
        """Whether r_i^0 is the next platform axis (else a basis vector; the module docstring)."""
        v, nxt = self.platform_axes[i], self.platform_axes[(i + 1) % 3]
        return bool(np.linalg.norm(cross(v, nxt)) >= PLATFORM_DIRECTION_MIN_SINE)

    @property
    def platform_directions(self) -> tuple[tuple[float, ...], ...]:
        """r_i^0 (platform frame): the reference direction of delta_i (see the module docstring)."""
        return tuple(tuple(self.platform_axes[(i + 1) % 3]) if self._next_axis_serves(i)
                     else tuple(float(c) for c in least_aligned_basis(v)) for i, v in enumerate(self.platform_axes))

    @property
    def given_platform_directions(self) -> tuple[tuple[float, ...], ...]:
        """r_i^0 as :attr:`platform_directions` chooses it, with the next platform axis's floats as
        given (``given_axes``; a basis vector is exact): the direction the delta_i readings are
        measured to, for the proofs in extended precision."""
        given = self.given_axes[2]
        return tuple(tuple(given[(i + 1) % 3]) if self._next_axis_serves(i) else d
                     for i, d in enumerate(self.platform_directions))

    @property
    def offsets(self) -> dict[str, float]:
        """Joint name -> offset (radians) of every joint, 0.0 where none was given."""
        given = dict(self.joint_offsets)
        return {n: given.get(n, 0.0) for n in rrr_joint_names()}

    def assembly_bands(self) -> tuple[tuple[float, float], ...]:
        """Per leg, the interval of angle(u_i, v_i) for which the leg can be assembled."""
        return tuple(
            (abs(a1 - a2), min(a1 + a2, 2 * math.pi - a1 - a2))
            for a1, a2 in zip(self.proximal_link_angles, self.distal_link_angles)
        )


def _three_vectors(key: str, value) -> tuple:
    """The 3 vectors of ``key``, their floats as given (checked: unit within UNIT_TOL)."""
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, (Sequence, np.ndarray)):
        raise ValueError(f"{key}: expected a list of 3 unit vectors, got {shown(value)}")
    if len(value) != 3:
        raise ValueError(f"{key}: expected 3 unit vectors (one per leg), got {len(value)}")
    return tuple(given_unit_vector(f"{key}[{i}]", v) for i, v in enumerate(value))


def _three_angles(key: str, value) -> tuple:
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, (Sequence, np.ndarray)):
        raise ValueError(f"{key}: expected a list of 3 angles in radians, got {shown(value)}")
    if len(value) != 3:
        raise ValueError(f"{key}: expected 3 angles (one per leg), got {len(value)}")
    out = tuple(parse_angle(f"{key}[{i}]", a) for i, a in enumerate(value))
    for i, a in enumerate(out):
        if not 0.0 < a < math.pi:
            raise ValueError(f"{key}[{i}]: expected an angle strictly between 0 and pi, got {a!r}")
    return out


def _leg_angles(geom: ThreeRRRGeometry, rot: np.ndarray) -> np.ndarray:
    """angle(u_i, R v_i^0) for the three legs."""
    return np.array([_angle(u, rot @ np.array(v)) for u, v in zip(geom.base_axes, geom.platform_axes)])


def _cube_rotations() -> list[np.ndarray]:
    """The identity first, then the other 23 proper rotations of the cube (exact signed permutations)."""
    out = []
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            m = np.zeros((3, 3))
            for r, (c, s) in enumerate(zip(perm, signs)):
                m[r, c] = s
            if np.linalg.det(m) > 0:
                out.append(m)
    out.sort(key=lambda m: -np.trace(m))  # identity (trace 3) first
    return out


def _rotvec(rv: np.ndarray) -> np.ndarray:
    n = float(np.linalg.norm(rv))
    return np.eye(3) if n == 0.0 else axis_rotation(rv / n, n)


def find_reference_pose(geom: ThreeRRRGeometry) -> np.ndarray | None:
    """A pose R at which every leg of the 3-RRR can be assembled (REFERENCE_MARGIN inside its band).

    Deterministic: R = I if it works, else the first of the 24 cube rotations that works, else
    least squares on angle(u_i, R v_i^0) - (band centre) from each of them. None if all fail.
    """
    bands = np.array(geom.assembly_bands())
    lo, hi = bands[:, 0], bands[:, 1]
    margin = np.minimum(REFERENCE_MARGIN, (hi - lo) / 4)
    centre = 0.5 * (lo + hi)

    def feasible(rot):
        ang = _leg_angles(geom, rot)
        return bool(np.all(ang >= lo + margin) and np.all(ang <= hi - margin))

    starts = _cube_rotations()
    for rot in starts:
        if feasible(rot):
            return rot
    from scipy.optimize import least_squares  # rarely reached; scipy.optimize costs ~0.3 s to import

    for rot0 in starts:
        fit = least_squares(lambda rv: _leg_angles(geom, _rotvec(rv) @ rot0) - centre, np.zeros(3))
        rot = _rotvec(fit.x) @ rot0
        if feasible(rot):
            return rot
    return None


def _reference_beta(u, w0, v, alpha2) -> float:
    """The root nearest 0 of w(beta) . v = cos(alpha2), w(beta) = Rot(u, beta) w0 (a cos + b sin = e)."""
    u, w0, v = (np.asarray(x, dtype=float) for x in (u, w0, v))
    w_par = (u @ w0) * u
    a = float((w0 - w_par) @ v)
    b = float(cross(u, w0) @ v)
    e = math.cos(alpha2) - float(w_par @ v)
    rho = math.hypot(a, b)
    if rho < PARALLEL_TOL:  # v along u: every beta assembles (alpha1 = alpha2)
        return 0.0
    phi, dev = math.atan2(b, a), math.acos(max(-1.0, min(1.0, e / rho)))
    roots = [wrap(phi + s * dev) for s in (1.0, -1.0)]
    return min(roots, key=abs)  # the root nearest beta = 0 (the given w^0)


def _joint_table(key: str, table, what: str, check) -> dict:
    """A table joint name -> value of a 3-RRR (None: empty), each name known and each value checked
    by ``check(key.name, value)``; ValueError naming the first problem."""
    if table is None:
        return {}
    if not isinstance(table, Mapping):
        raise ValueError(f"{key}: expected a table joint name -> {what}, got {shown(table)}")
    names = rrr_joint_names()
    out = {}
    for n, v in table.items():
        if n not in names:
            raise ValueError(f"{key}: unknown joint {shown(n)}; valid names: {', '.join(names)}")
        out[n] = check(f"{key}.{n}", v)
    return out


def three_rrr(base_axes, elbow_axes_at_zero, platform_axes, distal_link_angles, joint_ranges=None, *,
              name: str = "3-RRR", reference_leg: str = "leg1", joint_offsets=None) -> SphericalMechanism:
    """A 3-RRR spherical parallel manipulator as a :class:`SphericalMechanism` (semantics in the module doc).

    ``joint_ranges``: optional mapping joint name (see :func:`rrr_joint_names`) -> (lo, hi) in
    radians; joints not listed are unlimited (the full circle). ``reference_leg``: the leg shared
    by the two loops ("leg1", "leg2" or "leg3"). ``joint_offsets``: optional mapping joint name ->
    radians moving the zero of that joint's reading: the joint then reads (geometric angle of the
    module doc) - offset, and its range and every reported angle are in that reading (e.g. an offset
    equal to a joint's angle at a home pose makes it read 0 there). Bad input raises ValueError
    naming the argument.
    """
    given = tuple(_three_vectors(key, value) for key, value in (
        ("base_axes", base_axes), ("elbow_axes_at_zero", elbow_axes_at_zero), ("platform_axes", platform_axes)))
    u, w0, v0 = (tuple(normalized_floats(v) for v in vectors) for vectors in given)
    alpha2 = _three_angles("distal_link_angles", distal_link_angles)
    for i in range(3):
        if np.linalg.norm(cross(u[i], w0[i])) < PARALLEL_TOL:
            raise ValueError(
                f"elbow_axes_at_zero[{i}]: inconsistent geometry: parallel to base_axes[{i}] "
                "(a proximal link angle of 0 or pi makes the two joints coaxial)"
            )
    ranges = _joint_table("joint_ranges", joint_ranges, "[lo, hi]", check_range)
    offsets = _joint_table("joint_offsets", joint_offsets, "angle",
                           lambda key, v: check_geometry_angle(key, parse_angle(key, v)))
    nonzero = tuple((n, offsets[n]) for n in rrr_joint_names() if offsets.get(n, 0.0) != 0.0)
    geom = ThreeRRRGeometry(u, w0, v0, alpha2, given_axes=given, joint_offsets=nonzero)
    rot = find_reference_pose(geom)
    if rot is None:
        bands = ", ".join(f"leg{i + 1}: [{lo:.4f}, {hi:.4f}]" for i, (lo, hi) in enumerate(geom.assembly_bands()))
        raise ValueError(
            "base_axes, elbow_axes_at_zero, platform_axes, distal_link_angles: inconsistent geometry: no platform "
            "pose assembles the three legs (leg i needs angle(u_i, R v_i^0) within its band, radians: "
            f"{bands}); check the distal link angles and the platform axes"
        )
    legs = []
    for i in range(3):
        ui, vi = np.array(u[i]), rot @ np.array(v0[i])
        beta = _reference_beta(ui, w0[i], vi, alpha2[i])
        wi = axis_rotation(ui, beta) @ np.array(w0[i])
        ri = rot @ np.array(geom.platform_directions[i])
        k = i + 1
        readings = (beta, elbow_angle(ui, wi, vi), platform_joint_angle(wi, vi, ri))
        legs.append(Leg(f"leg{k}", tuple(
            Joint(f"{j}{k}", axis, j == "beta", ranges.get(f"{j}{k}"), reading - offsets.get(f"{j}{k}", 0.0))
            for j, axis, reading in zip(("beta", "gamma", "delta"), (ui, wi, vi), readings))))
    return SphericalMechanism(
        legs=tuple(legs), name=name, reference_leg=reference_leg, platform_reference=rot,
        kind="3-RRR", geometry=geom,
    )
