"""General model of a spherical mechanism: joint axes -> loop equations (Eq. 1/2), IK, singularities.

A mechanism is a graph of links and revolute joints (:mod:`.graph`), written as such (the "graph"
file kind) or as a fixed base, a moving platform and l >= 2 legs, each a serial chain of revolute
joints listed from the base to the platform (the "general" and "3-RRR" kinds, front ends that build
the graph); every axis passes through the common centre O. What follows says "leg j" and "the
reference leg" for a loop's two chains: for a graph, read the loop's ``up`` and ``down`` chains from
its root link (:class:`~.graph.GraphLoop`).
The mechanism is described by every joint axis as a unit vector (base frame) in ONE assembled
reference configuration, which joints are actuated, each joint's range and its *reading* at the
reference configuration (``reference_angle``, default 0). A joint's reading (radians) is
``reference_angle + displacement``, where the displacement rotates the link after the joint
relative to the link before it about the joint's axis by the right-hand rule. Actuator inputs and
passive unknowns are readings; with the default reference_angle = 0 they are displacements from the
reference configuration.

Derivation (what :class:`SphericalMechanism` computes once, at construction):

* one independent loop per leg j other than the reference leg r: the closed chain that goes up
  leg j, across the platform, down leg r and across the base. Its spherical polygon (Section 2,
  Fig. 1) has the joint axes as vertices p_1..p_m (leg j base->platform, then leg r
  platform->base); side k joins p_k to p_{k+1} and is a link (a link twist of a leg, the platform
  side or the base side); its pole is n_k = p_k x p_{k+1} / |.|.
* the exterior angle at p_k is the signed angle about p_k (right-hand rule) from n_{k-1} to n_k,
  the convention under which Eq. (1), prod_k Rx(theta_k) Rz(alpha_k) = I, holds (checked against
  an independent polygon in tests/test_rotations.py). A joint's displacement turns the pole after
  it relative to the pole before it, so theta_k = offset_k + sign_k * reading_k, with sign +1 on
  leg j (traversed base->platform) and -1 on leg r (traversed platform->base); the offsets are the
  "joint-angle offsets" of the loop.
* the loop's closure equation in the normalized form of Eq. (2): when every side is pi/2 (the
  Gosselin platform) Eq. (1) is already Eq. (2), phi_k = theta_k (the paper's remark after
  Eq. (4); the "compact" form, n = m); otherwise the corrected rule of
  :func:`spherekin.core.rotations.normalize_polygon`, phi_{2k-1} = theta_k + pi, phi_{2k} = alpha_k + pi
  (the "doubled" form, n = 2m, equal to Eq. (1) up to conjugation by Rx(pi/2)).
* the same :class:`~spherekin.closure.Unknown` object stands for a passive joint in every loop
  where it appears (the reference leg's joints appear in all loops, each loop seeing them with
  its own offset, like Eq. (5) of the paper).

Departures from the paper: the paper writes the loops of one mechanism by hand; here they are
derived from the axes, for any number of legs and joints per leg and any link twists. A side of
twist 0 or pi (coaxial joints) is allowed on the base or the platform (e.g. coaxial actuators); its
pole is then any fixed perpendicular. Inside a leg, consecutive joints must not be coaxial.
"""

from __future__ import annotations

import collections.abc
import dataclasses
import itertools
import math
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Mapping, NamedTuple, Sequence

import numpy as np

from ..closure import ClosureLoop, Term, Unknown
from ..core.angles import MAX_INPUT_ANGLE, check_turn, in_range, in_range_many, into_range, wrap
from ..core.rotations import cross, normalize_polygon, normalized_closure
from .chains import axis_rotations, current_axes, perpendicular, serial_ik
from .checks import check_name, check_range, check_rotation, parse_angle, shown
from .graph import Joint, MechanismGraph, Step
from .tolerances import Tolerances

__all__ = [
    "PARALLEL_TOL",
    "RIGHT_ANGLE_TOL",
    "SINGULARITY_TOL",
    "FORMS",
    "HELD_JOINTS",
    "HELD_LINKS",
    "HELD_AXES",
    "Joint",
    "Leg",
    "LoopVertex",
    "FactorSpec",
    "LoopGeometry",
    "LoopSystem",
    "IKSolution",
    "ForwardResult",
    "SingularityReport",
    "SphericalMechanism",
]

#: |a x b| below this: the axes a, b are parallel (coaxial joints). Reason: with unit vectors
#: rounded to double precision, |a x b| of distinct axes is far above 1e-9 for any buildable design;
#: below it, the pole a x b / |a x b| would be dominated by rounding (error ~ 1e-16 / |a x b|).
PARALLEL_TOL = 1e-9

#: |alpha - pi/2| below this: the side is exactly pi/2 and the compact form of Eq. (2) applies.
#: Reason: atan2 of exact orthogonal unit vectors gives pi/2 to ~2e-16, so every right angle written
#: as such passes; the compact form replaces Rz(alpha) by Z, moving each of the loop's n factors by
#: |alpha - pi/2|, which must stay inside what the solver's equations and the certificates allow for
#: a constant's rounding: the certificates enclose each such Z as pi/2 +- (|alpha - pi/2| + their
#: angle tolerance) (:mod:`spherekin.trust.transversal`), and the Bernstein equations' rounding
#: tolerance (2.2e-13 M, :data:`spherekin.closure.KNOWN_ENTRY_FLOOR`) covers n * 1e-15 with room.
#: It was 1e-13 (a snap of up to 6e-13 per loop, not covered); next to a singularity the agile eye's
#: count changes with a twist 6e-17 off pi/2 (benchmarks/README.md, the edge campaign).
RIGHT_ANGLE_TOL = 1e-15

#: A configuration is singular when the smallest singular value of the relevant Jacobian is below
#: this (Jacobian columns are unit joint axes, so singular values are O(1) away from singularities
#: and behave like the sine of the distance to one). Reason: at a serial singularity the inverse
#: kinematics has a double root whose angles are only determined to ~sqrt(machine eps) = 1.5e-8,
#: so the computed singular value there is ~1e-8; 1e-7 leaves a margin.
SINGULARITY_TOL = 1e-7

#: Forms of the normalized loop equation (Eq. 2) that :meth:`SphericalMechanism.loop_system` builds.
FORMS = ("auto", "compact", "doubled")

#: Names of the virtual chain of :meth:`SphericalMechanism.held_output` (joints, then its two links).
HELD_JOINTS = ("held_1", "held_2", "held_3")
HELD_LINKS = ("held_link_1", "held_link_2")
#: Axes u, v of the virtual chain (u, v, u): perpendicular unit vectors in no special direction.
#: Reason: Rot(u, a) Rot(v, b) Rot(u, c) reaches every rotation when u is perpendicular to v, and
#: axes along no coordinate direction are unlikely to coincide with an axis of the mechanism, which
#: would make a side of a loop's polygon degenerate.
HELD_AXES = ((0.6, 0.64, 0.48), (0.8, -0.48, -0.36))

_TWO_PI = 2.0 * math.pi
_IDENTITY = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


# --------------------------------------------------------------------------------------------
# Data: joints, legs, loops, results
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Leg:
    """A serial chain of revolute joints from the base (first) to the platform (last)."""

    name: str
    joints: tuple

    def __post_init__(self):
        object.__setattr__(self, "name", check_name("name", self.name))
        if isinstance(self.joints, (str, bytes)) or not isinstance(self.joints, (Sequence, tuple)):
            raise ValueError(f"joints: expected a list of joints, got {self.joints!r}")
        joints = tuple(self.joints)
        if not joints:
            raise ValueError("joints: expected at least one joint, got none")
        for k, j in enumerate(joints):
            if not isinstance(j, Joint):
                raise ValueError(f"joints[{k}]: expected a Joint, got {j!r}")
        for k in range(len(joints) - 1):
            a, b = np.array(joints[k].axis), np.array(joints[k + 1].axis)
            if np.linalg.norm(cross(a, b)) < PARALLEL_TOL:
                raise ValueError(
                    f"joints[{k}], joints[{k + 1}] ({joints[k].name!r}, {joints[k + 1].name!r}): inconsistent "
                    "geometry: consecutive axes of a leg are parallel (link twist 0 or pi); two coaxial joints "
                    "in series act as one joint"
                )
        object.__setattr__(self, "joints", joints)

    @property
    def twists(self) -> tuple[float, ...]:
        """Link twist angles (radians, in (0, pi)) between consecutive joint axes of the leg."""
        return tuple(
            math.atan2(float(np.linalg.norm(cross(a.axis, b.axis))), float(np.dot(a.axis, b.axis)))
            for a, b in zip(self.joints, self.joints[1:])
        )


@dataclass(frozen=True)
class LoopVertex:
    """A vertex of a loop's spherical polygon: joint ``joint``, exterior angle theta = offset + sign * reading."""

    joint: str
    sign: int
    offset: float
    actuated: bool


class FactorSpec(NamedTuple):
    """One factor of Eq. (2) as the geometry gives it, before its unknown exists: phi = offset +
    sign * (reading of ``joint``), radians; a known angle ``offset`` when ``joint`` is None (sign 0).
    :meth:`SphericalMechanism.loop_system` turns it into a known angle or a
    :class:`spherekin.closure.Term` (offset, Unknown, sign) of the loop's unknowns."""

    offset: float
    joint: str | None
    sign: int


@dataclass(frozen=True)
class LoopGeometry:
    """The spherical polygon of one independent loop (Eq. 1): up the ``up`` chain, down the ``down`` one.

    ``up``/``down``: the loop's two chains from its root link (:class:`~.graph.Step` tuples, see
    :class:`~.graph.GraphLoop`); for a mechanism written as legs they are leg j and the reference
    leg, both from the base, and ``legs`` names them (up, down); for a graph, ``legs`` is
    ("loop closed by X", root link). ``vertices[k]`` is p_k (up's joints, then down's reversed);
    ``sides[k]`` is the side (link twist, radians in [0, pi]) from p_k to p_{k+1}, the last one
    being the root link's side back to p_1. ``right_angled`` is True when every side is pi/2
    (within RIGHT_ANGLE_TOL), so that Eq. (1) is already in the form of Eq. (2).
    """

    legs: tuple
    vertices: tuple
    sides: tuple
    right_angled: bool
    up: tuple = ()
    down: tuple = ()

    def compact(self, form: str = "auto") -> bool:
        """Whether ``form`` writes this loop in the compact form (every Z of Eq. 2 one of its sides)."""
        return form == "compact" or (form == "auto" and self.right_angled)

    def twist_slack(self, form: str = "auto") -> float | None:
        """How far (radians) the sides this loop's Z's stand for may be from pi/2 in ``form``: the
        largest ``|side - pi/2|`` (below RIGHT_ANGLE_TOL) in the compact form; None in the doubled form,
        whose Z's are exact rotations of the normal form (the sides are factor angles there)."""
        return float(np.max(np.abs(np.array(self.sides) - math.pi / 2))) if self.compact(form) else None

    def factor_specs(self, form: str = "auto") -> tuple[FactorSpec, ...]:
        """The factors of Eq. (2) as :class:`FactorSpec` (offset, joint name or None, sign): phi = offset + sign * reading.

        Compact form (all sides pi/2): phi_k = theta_k. Doubled form: the corrected rule of
        :func:`spherekin.core.rotations.normalize_polygon`, phi_{2k-1} = theta_k + pi, phi_{2k} = alpha_k + pi.
        """
        if form not in FORMS:
            raise ValueError(f"form: expected one of {FORMS}, got {form!r}")
        if form == "compact" and not self.right_angled:
            raise ValueError(
                "form: 'compact' needs every side of the loop to be pi/2, got sides "
                f"{[round(s, 6) for s in self.sides]}; use 'auto' or 'doubled'"
            )
        if self.compact(form):
            return tuple(FactorSpec(v.offset, v.joint, v.sign) for v in self.vertices)
        phis = normalize_polygon(np.array(self.sides), np.array([v.offset for v in self.vertices]))
        specs = []
        for k, v in enumerate(self.vertices):
            specs.append(FactorSpec(wrap(float(phis[2 * k])), v.joint, v.sign))
            specs.append(FactorSpec(float(phis[2 * k + 1]), None, 0))
        return tuple(specs)

    def factor_angles(self, readings: Mapping[str, float], form: str = "auto") -> np.ndarray:
        """The angles phi_1..phi_n of Eq. (2) at the given joint readings (radians), shape (n,)."""
        return np.array([f.offset + (f.sign * readings[f.joint] if f.joint is not None else 0.0)
                         for f in self.factor_specs(form)])


@dataclass(frozen=True)
class LoopSystem:
    """The closure equations of a mechanism at fixed actuator inputs (Eq. 2 for each loop).

    * ``loops``: the l - 1 independent loops as :class:`ClosureLoop` (normalized Eq. 2 form);
    * ``unknowns``: every passive joint that appears in a loop, in the mechanism's passive order;
      the same :class:`Unknown` object is used in every loop where that joint appears;
    * ``loop_indices[k]``: positions in ``unknowns`` of the unknowns of ``loops[k]``, in that
      loop's tensor-axis order (so ``x[..., loop_indices[k]]`` are the loop's coordinates);
    * ``shared``: names of the unknowns that appear in more than one loop;
    * ``inputs``/``input_names``: the actuator readings (radians) substituted as known angles;
    * ``loop_legs[k]``: (leg traversed up, reference leg traversed down) of loop k;
    * ``twists[k]``: what the Z's of loop k stand for: None when they are exact (the doubled form's
      normal-form rotations), else d >= 0: each Z is a link twist within d of pi/2 (the compact
      form: a side of the loop, snapped to pi/2; :meth:`LoopGeometry.twist_slack`). The
      certificates (:mod:`spherekin.trust.transversal`) enclose such a Z as a rotation by
      pi/2 +- (d + their angle tolerance), so that they hold for the mechanism as described and
      not only for its exact right angles. Empty (a system written by hand): every Z a twist, d = 0.
    """

    loops: tuple
    unknowns: tuple
    loop_indices: tuple
    shared: tuple
    inputs: tuple
    input_names: tuple
    loop_legs: tuple
    form: str
    twists: tuple = ()

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(u.name for u in self.unknowns)

    def unknown(self, name: str) -> Unknown:
        for u in self.unknowns:
            if u.name == name:
                return u
        raise ValueError(f"name: expected one of {self.names}, got {name!r}")

    def to_unit(self, passive_angles: Mapping[str, float]) -> np.ndarray:
        """Unit-box coordinates x (one per unknown, global order) of passive readings (radians)."""
        missing = [u.name for u in self.unknowns if u.name not in passive_angles]
        if missing:
            raise ValueError(f"passive_angles: missing {missing}")
        return np.array([float(u.to_unit(passive_angles[u.name])) for u in self.unknowns])

    def to_angles(self, x) -> dict[str, float]:
        """Passive readings (radians) at unit-box coordinates x, shape (n_unknowns,)."""
        x = np.asarray(x, dtype=float)
        if x.shape != (len(self.unknowns),):
            raise ValueError(f"x: expected shape ({len(self.unknowns)},), got {x.shape}")
        return {u.name: float(u.to_angle(xi)) for u, xi in zip(self.unknowns, x)}

    def residuals(self, x) -> np.ndarray:
        """||F_n - I|| (Frobenius) of each loop at unit-box points x, shape (..., n_unknowns) -> (..., n_loops)."""
        x = np.asarray(x, dtype=float)
        if x.ndim == 0 or x.shape[-1] != len(self.unknowns):
            raise ValueError(f"x: expected shape (..., {len(self.unknowns)}), got {x.shape}")
        out = [np.linalg.norm(loop.closure_matrix(x[..., list(idx)]) - np.eye(3), axis=(-2, -1))
               for loop, idx in zip(self.loops, self.loop_indices)]
        return np.stack(out, axis=-1)


@dataclass(frozen=True)
class IKSolution:
    """One inverse-kinematics solution: every joint reading (radians) for the given pose.

    ``working_mode[i]`` is, for a leg of 3 joints, the sign of det[a_1, a_2, a_3] of its current
    axes (the branch of the leg's inverse kinematics; 0 at a serial singularity) and 0 for legs
    with another number of joints (one branch). ``in_range`` tells whether every reading lies in
    its joint's range. Readings are reduced modulo 2 pi into [lo, lo + 2 pi) for a limited joint
    and into [-pi, pi] otherwise. ``status``: None for the closed form of legs (exact); for a graph
    solved on its loop equations (:func:`spherekin.problem.inverse_kinematics`), the status of the
    direct-kinematics solution it is (docs/results-format.md).
    """

    joint_angles: Mapping
    inputs: tuple
    working_mode: tuple
    in_range: bool
    status: str | None = None

    def passive(self, names: Sequence[str]) -> dict[str, float]:
        return {n: self.joint_angles[n] for n in names}


@dataclass(frozen=True)
class ForwardResult:
    """Forward evaluation at given joint readings.

    ``pose``: the platform pose R (3x3) along the reference leg; ``leg_poses``: the pose along each
    leg (in leg order); ``loop_residuals``: ||F_n - I|| (Frobenius) of each loop's Eq. (2) product,
    0 exactly when the loop closes; ``loop_legs``: the (up, down) legs of each loop.
    """

    pose: np.ndarray
    leg_poses: tuple
    loop_residuals: tuple
    loop_legs: tuple


@dataclass(frozen=True)
class SingularityReport:
    """Singularity classification of a configuration (Jacobian criteria, tolerance ``tol``).

    * serial (inverse-kinematic) singularity: the actuators can move while the platform stays
      still -- a leg Jacobian [a_1 .. a_k] (current axes) loses rank with a null motion that moves
      an actuated joint; ``serial_margin`` is the smallest singular value over the legs with an
      actuator (``serial_legs`` names the singular ones);
    * parallel (direct-kinematic) singularity: the passive joints can move while the actuators are
      locked -- the Jacobian K_p of the loop constraints with respect to the passive joints loses
      column rank; ``parallel_margin`` is its smallest singular value. This is the Jacobian of the
      loop equations that a direct-kinematics solver faces.
    """

    serial: bool
    parallel: bool
    serial_margin: float
    parallel_margin: float
    serial_legs: tuple
    tol: float

    @property
    def kind(self) -> str:
        """"regular", "serial", "parallel" or "serial+parallel"."""
        if self.serial and self.parallel:
            return "serial+parallel"
        return "serial" if self.serial else ("parallel" if self.parallel else "regular")


# --------------------------------------------------------------------------------------------
# The mechanism
# --------------------------------------------------------------------------------------------

class LinkPaths(collections.abc.Mapping):
    """Link name -> its spanning tree's path from the ground (:class:`~.graph.Step` tuple,
    :meth:`MechanismGraph.path`), each computed when first asked for and kept. Lazy because the paths
    of all links together grow as the square of a long loop's length (a 16,000-joint loop: 128 million
    steps, issue 42 item 12), and a solve asks for a few (the output's, the loops' links). A plain
    class of a dict: it pickles, and mechanisms travel to Dask workers."""

    def __init__(self, graph: MechanismGraph):
        self.graph, self.cache = graph, {}

    def __getitem__(self, link: str) -> tuple:
        if link not in self.cache:
            if link not in self.graph.depth:
                raise KeyError(link)
            self.cache[link] = self.graph.path(link)
        return self.cache[link]

    def __iter__(self):
        return iter(self.graph.link_names)

    def __len__(self) -> int:
        return len(self.graph.link_names)


@dataclass(frozen=True)
class SphericalMechanism:
    """A spherical mechanism: a graph of links and revolute joints (see module doc and :mod:`.graph`).

    Two ways to write one, one model:

    * ``graph``: a :class:`~.graph.MechanismGraph` (links named by the joints, a ground, an optional
      output link; the file kind "graph"); ``legs`` is then derived: the graph's chains from the
      ground to the output when it is legs (:meth:`~.graph.MechanismGraph.chains`), else ().
    * ``legs``: a base, a platform and l >= 2 legs, each base -> platform (the kinds "general" and
      "3-RRR"), a front end that builds the graph (ground "base", output "platform", the links of
      leg L named "L/1", "L/2", ...) with the spanning tree of the paper's Eq. (5): the
      ``reference_leg`` (default: the first) whole and every other leg without its last joint.

    ``platform_reference``: the output link's pose R at the reference configuration (default I:
    its frame coincides with the base frame there). The pose at other configurations is R = D R_ref
    with D the output link's rotation relative to its reference position (the product of
    exponentials along the tree, see :meth:`pose_from_passive`). ``kind`` and ``geometry`` record how
    it was built ("graph", "general", "3-RRR").

    Public derived data: ``actuated`` and ``passive`` (joint names, in the order written), ``ranges``,
    ``link_graph`` (the :class:`~.graph.MechanismGraph`, also for legs), ``loop_geometry`` (one
    :class:`LoopGeometry` per independent loop), ``output`` (the output link, or None).
    """

    legs: tuple = ()
    name: str = "mechanism"
    reference_leg: str | None = None
    platform_reference: tuple = _IDENTITY
    kind: str = "general"
    geometry: object = None
    graph: MechanismGraph | None = None
    #: How far the as-built mechanism may be from this one (:class:`~.tolerances.Tolerances`; None:
    #: the nominal mechanism only). Read by :mod:`spherekin.trust.tolerances`.
    tolerances: Tolerances | None = None
    link_graph: MechanismGraph | None = field(init=False, repr=False, compare=False, default=None)
    loop_geometry: tuple = field(init=False, repr=False, compare=False, default=())
    #: Derived once for the Jacobians and poses (hot in the trust layer): joint name -> Joint; link ->
    #: its tree path as Steps; per loop, (column, sign, joint, first link) of each term of its velocity
    #: constraint (:meth:`_constraints`).
    joint_map: Mapping = field(init=False, repr=False, compare=False, default=None)
    link_paths: Mapping = field(init=False, repr=False, compare=False, default=None)
    constraint_terms: tuple = field(init=False, repr=False, compare=False, default=())

    # ---------------------------------------------------------------- construction

    def __post_init__(self):
        object.__setattr__(self, "name", check_name("name", self.name))
        if self.graph is not None:
            self._from_graph()
        else:
            self._from_legs()
        if self.tolerances is not None:
            if not isinstance(self.tolerances, Tolerances):
                raise ValueError(f"tolerances: expected a spherekin.mechanism.Tolerances or None, got "
                                 f"{type(self.tolerances).__name__}")
            self.tolerances.check_joints(self.joint_names)
        platform = check_rotation("platform_reference", self.platform_reference)
        object.__setattr__(self, "platform_reference", tuple(tuple(float(v) for v in row) for row in platform))
        graph = self.link_graph
        if not self.actuated:
            raise ValueError(f"{'joints' if self.graph is not None else 'legs'}: expected at least one actuated "
                             "joint, got none")
        n_loops = len(graph.loops)
        if self.graph is not None:
            if n_loops == 0:
                raise ValueError("joints: the links form no closed loop (an open chain): its direct kinematics is "
                                 "the chain's product of rotations, nothing to solve; a mechanism needs a loop")
            mob = graph.mobility
            if len(self.actuated) < mob:
                raise ValueError(
                    f"joints: under-actuated: the mobility is M = 3 (links - 1) - 2 joints = 3 x {len(graph.link_names) - 1}"
                    f" - 2 x {len(graph.joints)} = {mob}, but {len(self.actuated)} joint(s) are actuated "
                    f"({', '.join(self.actuated)}); mark {mob - len(self.actuated)} more as actuated (more than M "
                    "is redundant actuation, allowed)")
            self._check_binary_links()
        elif len(self.passive) > 3 * n_loops:
            raise ValueError(
                f"legs: the {n_loops} loop(s) give {3 * n_loops} scalar equations, which fix at most that many "
                f"passive joints, but {len(self.passive)} joints are passive ({', '.join(self.passive)}); the "
                "direct kinematics would have a continuum of solutions: mark more joints as actuated"
            )
        joints = {j.name: j for j in graph.joints}
        loops = tuple(self._polygon(self._loop_labels(lp), lp.up, lp.down, joints) for lp in graph.loops)
        object.__setattr__(self, "loop_geometry", loops)
        # plain dicts (a mappingproxy cannot be pickled, and mechanisms travel to Dask workers)
        object.__setattr__(self, "joint_map", dict(joints))
        object.__setattr__(self, "link_paths", LinkPaths(graph))
        first_link = {j.name: pair[0] for j, pair in zip(graph.joints, graph.links)}
        column = {j.name: k for k, j in enumerate(graph.joints)}
        object.__setattr__(self, "constraint_terms", tuple(
            tuple((column[st.joint], sgn * st.sign, st.joint, first_link[st.joint])
                  for steps, sgn in ((g.up, 1.0), (g.down, -1.0)) for st in steps)
            for g in loops))

    def _from_legs(self) -> None:
        if isinstance(self.legs, (str, bytes)) or not isinstance(self.legs, (Sequence, tuple)):
            raise ValueError(f"legs: expected a list of legs, got {self.legs!r}")
        legs = tuple(self.legs)
        for i, leg in enumerate(legs):
            if not isinstance(leg, Leg):
                raise ValueError(f"legs[{i}]: expected a Leg, got {leg!r}")
        if len(legs) < 2:
            raise ValueError(f"legs: expected at least 2 legs (a parallel mechanism has a closed loop), got {len(legs)}")
        leg_names = [leg.name for leg in legs]
        for i, n in enumerate(leg_names):
            if n in leg_names[:i]:
                raise ValueError(f"legs[{i}].name: leg name {n!r} is used twice")
        seen = {}
        for i, leg in enumerate(legs):
            for k, j in enumerate(leg.joints):
                if j.name in seen:
                    raise ValueError(f"legs[{i}].joints[{k}].name: joint name {j.name!r} is used twice "
                                     f"(also {seen[j.name]})")
                seen[j.name] = f"legs[{i}].joints[{k}]"
        ref = leg_names[0] if self.reference_leg is None else self.reference_leg
        if ref not in leg_names:
            raise ValueError(f"reference_leg: expected one of {leg_names}, got {shown(ref)}")
        object.__setattr__(self, "legs", legs)
        object.__setattr__(self, "reference_leg", ref)
        # the front end: links "base", "platform" and "L/k"; the tree of Eq. (5) (reference leg whole)
        joints, links, tree = [], [], []
        for leg in legs:
            chain = ["base", *[f"{leg.name}/{k}" for k in range(1, len(leg.joints))], "platform"]
            for k, j in enumerate(leg.joints):
                joints.append(j)
                links.append((chain[k], chain[k + 1]))
                if leg.name == ref or k < len(leg.joints) - 1:
                    tree.append(j.name)
        object.__setattr__(self, "link_graph", MechanismGraph(tuple(joints), tuple(links), "base", "platform",
                                                              tuple(tree)))

    def _from_graph(self) -> None:
        graph = self.graph
        if not isinstance(graph, MechanismGraph):
            raise ValueError(f"graph: expected a MechanismGraph, got {type(graph).__name__}")
        object.__setattr__(self, "link_graph", graph)     # legs given with a graph are its own, derived again
        chains = graph.chains()
        legs, ref = (), None
        if chains is not None and len(chains) >= 2:
            try:
                legs = tuple(Leg(f"leg{i + 1}", tuple(graph.joints[k] for k in chain))
                             for i, chain in enumerate(chains))
            except ValueError:
                legs = ()                              # parallel axes in series: reported by _check_binary_links
            last = graph.parent[graph.output][0]
            ref = next((f"leg{i + 1}" for i, chain in enumerate(chains) if last in chain), None)
        object.__setattr__(self, "legs", legs)
        object.__setattr__(self, "reference_leg", ref if legs else None)

    def _check_binary_links(self) -> None:
        """A moving link with exactly two joints whose axes are parallel turns about one axis: the two
        joints act as one and the loops through it have a continuum of solutions."""
        graph = self.link_graph
        for link in graph.link_names:
            on = graph.joints_of(link)
            if link == graph.ground or len(on) != 2:
                continue
            a, b = (np.array(graph.joints[k].axis) for k in on)
            if np.linalg.norm(cross(a, b)) < PARALLEL_TOL:
                names = [graph.joints[k].name for k in on]
                raise ValueError(
                    f"joints: inconsistent geometry: link {link!r} has only the joints {names[0]!r} and {names[1]!r}, "
                    "and their axes are parallel (link twist 0 or pi): two coaxial joints in series act as one "
                    "joint (the loops through them have a continuum of solutions)")

    def _loop_labels(self, loop) -> tuple[str, str]:
        """(up, down) leg names of a loop of legs; ("loop closed by X", root link) of a graph's."""
        if self.graph is None:
            joints_leg = {j.name: leg.name for leg in self.legs for j in leg.joints}
            return joints_leg[loop.up[-1].joint], self.reference_leg
        return f"loop closed by {loop.closing}", loop.root

    @staticmethod
    def _polygon(labels, up, down, joints) -> LoopGeometry:
        """Spherical polygon of the loop up ``up`` and down ``down`` (chains of :class:`~.graph.Step`
        from the loop's root link) at the reference configuration."""
        verts = [(joints[s.joint], s.sign) for s in up] + [(joints[s.joint], -s.sign) for s in reversed(down)]
        p = np.array([j.axis for j, _ in verts])
        nxt = np.roll(p, -1, axis=0)
        normals = cross(p, nxt)
        sines = np.linalg.norm(normals, axis=1)
        sides = np.arctan2(sines, np.sum(p * nxt, axis=1))
        poles = np.empty_like(p)
        names = [j.name for j, _ in verts]
        for k in range(len(verts)):
            if sines[k] >= PARALLEL_TOL:
                poles[k] = normals[k] / sines[k]
            elif np.array_equal(p[k], nxt[k]) or np.array_equal(p[k], -nxt[k]):
                poles[k] = perpendicular(p[k])  # coaxial joints on one link: any fixed normal
            else:
                raise ValueError(
                    f"legs: inconsistent geometry: the axes of joints {names[k]!r} and "
                    f"{names[(k + 1) % len(names)]!r} are parallel within {PARALLEL_TOL:g} but not equal; "
                    "write them identical (coaxial joints) or separate them"
                )
        prev = np.roll(poles, 1, axis=0)
        exterior = np.arctan2(np.sum(p * cross(prev, poles), axis=1), np.sum(prev * poles, axis=1))
        vertices = tuple(
            LoopVertex(j.name, s, wrap(float(th) - s * j.reference_angle), j.actuated)
            for (j, s), th in zip(verts, exterior)
        )
        right = bool(np.all(np.abs(sides - math.pi / 2) < RIGHT_ANGLE_TOL))
        return LoopGeometry(tuple(labels), vertices, tuple(float(s) for s in sides), right, tuple(up), tuple(down))

    # ---------------------------------------------------------------- names and ranges

    @property
    def joints(self) -> tuple[Joint, ...]:
        """Every joint, in the order written (leg by leg, base to platform, for legs)."""
        return self.link_graph.joints

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    @property
    def actuated(self) -> tuple[str, ...]:
        """Names of the actuated joints: the inputs, in order (the order written)."""
        return tuple(j.name for j in self.joints if j.actuated)

    @property
    def passive(self) -> tuple[str, ...]:
        """Names of the passive joints, in the same order."""
        return tuple(j.name for j in self.joints if not j.actuated)

    @property
    def output(self) -> str | None:
        """The output link (whose rotation is the pose), or None."""
        return self.link_graph.output

    @property
    def ranges(self) -> Mapping[str, tuple[float, float] | None]:
        """Joint name -> (lo, hi) in radians, or None for an unlimited joint (the full circle)."""
        return MappingProxyType({j.name: j.range for j in self.joints})

    @property
    def loop_unknowns(self) -> tuple[str, ...]:
        """The passive joints that appear in the loop equations (the unknowns of the direct
        kinematics, in the order of ``passive``)."""
        in_loops = {v.joint for g in self.loop_geometry for v in g.vertices if not v.actuated}
        return tuple(n for n in self.passive if n in in_loops)

    @property
    def platform_reference_matrix(self) -> np.ndarray:
        return np.array(self.platform_reference)

    def joint(self, name: str) -> Joint:
        try:
            return self.joint_map[name]
        except (KeyError, TypeError):
            raise ValueError(f"name: expected one of {self.joint_names}, got {name!r}") from None

    def leg(self, name: str) -> Leg:
        for leg in self.legs:
            if leg.name == name:
                return leg
        raise ValueError(f"name: expected one of {[leg.name for leg in self.legs]}, got {name!r}")

    def held_output(self, R) -> tuple["SphericalMechanism", tuple[float, float, float]]:
        """The inverse kinematics of any mechanism as a direct kinematics (the knowns swapped): this
        mechanism with its output link held at the pose ``R`` (3x3), and the inputs that hold it.

        A virtual chain of three actuated joints (names in :data:`HELD_JOINTS`, axes u, v, u with
        u, v of :data:`HELD_AXES`, u perpendicular to v, so that Rot(u, a) Rot(v, b) Rot(u, c) reaches
        every rotation: Davenport angles) joins the ground to the output link; its readings are the
        Paden-Kahan solution of Rot(u, a) Rot(v, b) Rot(u, c) = R R_ref^T. The original actuated joints
        become passive unknowns with their ranges (use :meth:`without_ranges` first to find every
        solution). Every solution of the held mechanism's direct kinematics is an input set (with the
        passive readings) of this one placing the output at R, and conversely. The held mechanism's
        mobility is this one's; its three actuated joints over-actuate a mechanism of M < 3 (the pose
        then exists only where the output can reach it: redundant actuation)."""
        rot = check_rotation("R", R)
        if self.output is None:
            raise ValueError("output: this mechanism names no output link, so a pose fixes nothing; name one "
                             "(output = \"link\" in the file)")
        graph = self.link_graph
        taken = set(self.joint_names) | set(graph.link_names)
        clash = [n for n in (*HELD_JOINTS, *HELD_LINKS) if n in taken]
        if clash:
            raise ValueError(f"R: the names {clash} of the virtual chain are taken by this mechanism; rename them")
        u, v = (np.array(a) for a in HELD_AXES)
        axes = np.array([u, v, u])
        found = serial_ik(axes, rot @ self.platform_reference_matrix.T)
        if not found:
            raise ValueError("R: no Davenport angles found for the pose (not a rotation?)")
        virtual = tuple(Joint(n, tuple(a), actuated=True) for n, a in zip(HELD_JOINTS, axes))
        swapped = tuple(dataclasses.replace(j, actuated=False) for j in graph.joints)
        chain = (graph.ground, *HELD_LINKS, graph.output)
        links = graph.links + tuple((chain[k], chain[k + 1]) for k in range(3))
        held = MechanismGraph(swapped + virtual, links, graph.ground, graph.output)
        mech = dataclasses.replace(self, legs=(), graph=held, kind="graph", name=f"{self.name} (output held)")
        return mech, tuple(float(d) for d in found[0])

    def _not_legs(self) -> str:
        """Why a graph has no legs (for messages)."""
        graph = self.link_graph
        if graph.output is None:
            return "no output link is named"
        other = [n for n in graph.link_names if n not in (graph.ground, graph.output) and len(graph.joints_of(n)) != 2]
        if other:
            return f"link {other[0]!r} has {len(graph.joints_of(other[0]))} joints"
        return "a chain from the ground does not end at the output, or a joint is written output side first"

    def link_twists(self) -> dict[str, tuple[float, ...]]:
        """Leg name -> link twist angles (radians) between its consecutive joints (legs only)."""
        return {leg.name: leg.twists for leg in self.legs}

    # ---------------------------------------------------------------- input checks

    def check_inputs(self, inputs) -> tuple[float, ...]:
        """The actuator ``inputs`` (one angle in radians per actuated joint, in the order of
        ``actuated``) as floats, each within a full turn of 0 (:data:`~spherekin.core.angles.MAX_INPUT_ANGLE`:
        17 is refused, being 17 degrees far more often than 17 rad) and inside its closed joint range;
        else one ValueError naming it."""
        names = self.actuated
        if isinstance(inputs, (str, bytes, Mapping)) or not isinstance(inputs, (Sequence, np.ndarray)):
            raise ValueError(f"inputs: expected {len(names)} actuator angles in radians {names}, got {inputs!r}")
        if len(inputs) != len(names):
            raise ValueError(f"inputs: expected {len(names)} actuator angles {names}, got {len(inputs)}")
        out = []
        for name, value in zip(names, inputs):
            v = check_turn(f"inputs ({name})", parse_angle(f"inputs ({name})", value))
            rng = self.joint(name).range
            if not in_range(v, rng):
                raise ValueError(f"inputs ({name}): {v!r} is outside the joint range [{rng[0]!r}, {rng[1]!r}]")
            out.append(v)
        return tuple(out)

    def check_input_rows(self, rows, row_label: str = "row {k}") -> np.ndarray:
        """K rows of actuator inputs (K, len(actuated); radians) checked as :meth:`check_inputs`
        checks one, as one array operation (a chunk or a path of thousands of rows); returns them as
        a float array. The first row refused gets :meth:`check_inputs`'s message, prefixed with
        ``row_label`` formatted with its index k."""
        arr = np.asarray(rows, dtype=float)
        with np.errstate(invalid="ignore"):
            ok = np.isfinite(arr) & (np.abs(arr) <= MAX_INPUT_ANGLE)
            ok &= np.stack([in_range_many(arr[:, a], self.joint(n).range) for a, n in enumerate(self.actuated)],
                           axis=1)
        for k in np.flatnonzero(~ok.all(axis=1))[:1]:
            try:
                self.check_inputs(arr[k])
            except ValueError as exc:
                raise ValueError(f"{row_label.format(k=k)}: {exc}") from None
            raise ValueError(f"{row_label.format(k=k)}: expected finite angles (radians) within a turn of 0 and "
                             f"inside the joint ranges, got {tuple(arr[k])}")
        return arr

    def _check_angles(self, key: str, angles, required: Sequence[str]) -> dict[str, float]:
        if not isinstance(angles, Mapping):
            raise ValueError(f"{key}: expected a mapping joint name -> angle (radians), got {type(angles).__name__}")
        valid = set(self.joint_names)
        unknown = [n for n in angles if n not in valid]
        if unknown:
            raise ValueError(f"{key}: unknown joint name(s) {unknown}; valid names: {self.joint_names}")
        missing = [n for n in required if n not in angles]
        if missing:
            raise ValueError(f"{key}: missing angle(s) for {missing}")
        return {n: check_turn(f"{key}[{n!r}]", parse_angle(f"{key}[{n!r}]", v)) for n, v in angles.items()}

    # ---------------------------------------------------------------- loop equations

    def loop_system(self, inputs, passive_ranges: Mapping | None = None, form: str = "auto",
                    free: Mapping | None = None) -> LoopSystem:
        """The l - 1 closure equations (Eq. 2) with the actuator readings ``inputs`` substituted.

        ``inputs``: one angle (radians) per actuated joint, in the order of ``actuated``.
        ``passive_ranges``: optional name -> (lo, hi) (width < 2 pi) overriding passive joint
        ranges, e.g. to cover a full-circle joint by charts. A passive joint with an unlimited
        range and no override is a ValueError (tan(theta/2) cannot cover the full circle).
        ``form``: "auto" (compact when every side of a loop is pi/2, else doubled), "compact" or
        "doubled" (see :meth:`LoopGeometry.factor_specs`). ``free``: actuated joint name -> (lo, hi)
        (width < 2 pi): those joints become unknowns over that range too (after the passive ones; their
        entries of ``inputs`` are not used), e.g. for the singular set in a plane of inputs.
        """
        values = self.check_inputs(inputs)
        free = dict(free or {})
        for n in free:
            if n not in self.actuated:
                raise ValueError(f"free: {n!r} is not an actuated joint; valid names: {self.actuated}")
        if form not in FORMS:
            raise ValueError(f"form: expected one of {FORMS}, got {form!r}")
        overrides = {}
        if passive_ranges is not None:
            if not isinstance(passive_ranges, Mapping):
                raise ValueError(f"passive_ranges: expected a mapping name -> (lo, hi), got {passive_ranges!r}")
            for n, r in passive_ranges.items():
                if n not in self.passive:
                    raise ValueError(f"passive_ranges: {n!r} is not a passive joint; valid names: {self.passive}")
                if r is None:
                    raise ValueError(f"passive_ranges[{n!r}]: expected (lo, hi) with hi - lo < 2*pi, got None")
                overrides[n] = check_range(f"passive_ranges[{n!r}]", r)
        consts = self.loop_constants([values], form)[0]
        unknowns = {}
        for name in self.loop_unknowns:
            rng = overrides.get(name, self.joint(name).range)
            if rng is None:
                raise ValueError(
                    f"passive_ranges: passive joint {name!r} has an unlimited range (the full circle), which one "
                    f"unknown t = tan((theta - shift)/2) cannot cover; pass passive_ranges={{{name!r}: (lo, hi)}} "
                    "with hi - lo < 2*pi (e.g. two charts)"
                )
            unknowns[name] = Unknown(name, rng[0], rng[1])
        for name, rng in free.items():
            rng = check_range(f"free[{name!r}]", rng)
            unknowns[name] = Unknown(name, rng[0], rng[1])
        loops, indices = [], []
        order = list(unknowns)
        for li, g in enumerate(self.loop_geometry):
            factors = []
            for i, spec in enumerate(g.factor_specs(form)):
                if spec.joint is None or (spec.joint in self.actuated and spec.joint not in free):
                    factors.append(float(consts[li, i]))
                else:
                    factors.append(Term(unknowns[spec.joint], spec.offset, spec.sign))
            loop = ClosureLoop(factors)
            loops.append(loop)
            indices.append(tuple(order.index(u.name) for u in loop.unknowns))
        in_loops = [set(lp.names) for lp in loops]          # (a loop's names are computed on each access)
        counts = {n: sum(n in names for names in in_loops) for n in order}
        return LoopSystem(
            loops=tuple(loops),
            unknowns=tuple(unknowns.values()),
            loop_indices=tuple(indices),
            shared=tuple(n for n in order if counts[n] > 1),
            inputs=values,
            input_names=self.actuated,
            loop_legs=tuple(g.legs for g in self.loop_geometry),
            form=form,
            twists=tuple(g.twist_slack(form) for g in self.loop_geometry),
        )

    def loop_constants(self, inputs, form: str = "auto") -> np.ndarray:
        """The constant angle (radians) of every factor of :meth:`loop_system` at K actuator inputs at
        once: ``inputs`` (K, number of actuated joints), radians, unchecked (the solver's own); shape
        (K, L, n), L loops padded with 0 to n factors. A factor of a fixed angle is its offset, of an
        actuated joint wrap(offset + sign * input), of a passive joint its term's offset. The one rule
        of the known angles: :meth:`loop_system` reads its own from here."""
        values = np.asarray(inputs, dtype=float).reshape(-1, len(self.actuated))
        specs = [g.factor_specs(form) for g in self.loop_geometry]
        out = np.zeros((len(values), len(specs), max((len(f) for f in specs), default=0)))
        for li, loop in enumerate(specs):
            for i, spec in enumerate(loop):
                if spec.joint in self.actuated:
                    phis = spec.offset + spec.sign * values[:, self.actuated.index(spec.joint)]
                    out[:, li, i] = wrap(np.asarray(phis, dtype=float))    # exact
                else:
                    out[:, li, i] = spec.offset
        return out

    # ---------------------------------------------------------------- poses and forward evaluation

    def _steps_rotation(self, steps, readings: Mapping[str, np.ndarray]) -> np.ndarray:
        """Product of Rot(a_k, s_k (reading_k - reference_k)) along ``steps`` (:class:`~.graph.Step`),
        at N configurations (readings: name -> (N,) radians): shape (N, 3, 3)."""
        n = len(next(iter(readings.values()))) if readings else 1
        out = np.broadcast_to(np.eye(3), (n, 3, 3))
        for st in steps:
            j = self.joint_map[st.joint]
            out = out @ axis_rotations(j.axis, st.sign * (np.asarray(readings[st.joint], dtype=float) - j.reference_angle))
        return out

    def link_rotations(self, joint_angles: Mapping[str, float]) -> dict[str, np.ndarray]:
        """Link name -> its rotation D (3x3) relative to the reference assembly at the joint readings
        (radians) of the spanning tree's joints (product of exponentials from the ground: R_b =
        R_a Rot(axis, reading - reference) for a joint [a, b]); the ground's is I."""
        readings = {n: np.array([float(v)]) for n, v in joint_angles.items()}
        graph = self.link_graph
        need = {graph.joints[k].name for k, _, _ in graph.parent.values()}      # the tree's joints
        missing = [n for n in self.joint_names if n in need and n not in readings]
        if missing:
            raise ValueError(f"joint_angles: missing angle(s) for {missing}")
        return {link: self._steps_rotation(self.link_paths[link], readings)[0] for link in graph.link_names}

    def pose_from_passive(self, inputs, passive_angles: Mapping[str, float]) -> np.ndarray | None:
        """The output link's pose R (3x3) from actuator inputs and solved passive readings (radians),
        or None for a mechanism without an output link.

        R = Rot(a_1, d_1) ... Rot(a_k, d_k) R_ref along the spanning tree's path from the ground to
        the output (product of exponentials, axes a_i in the reference configuration, d_i = +-(reading_i
        - reference_angle_i)); for legs, the reference leg (a 3-RRR: the R with v_i = R v_i^0). Only
        that path's passive joints are needed. :meth:`poses_from_passive` at one configuration.
        """
        values = dict(zip(self.actuated, self.check_inputs(inputs)))
        if self.output is None:
            return None
        need = [st.joint for st in self.link_paths[self.output] if st.joint not in values]
        angles = self._check_angles("passive_angles", passive_angles, need)
        bad = [n for n in angles if n in values]
        if bad:
            raise ValueError(f"passive_angles: {bad} are actuated joints; give them in inputs")
        return self.poses_from_passive(np.array([list(values.values())], dtype=float).reshape(1, -1),
                                       {n: [v] for n, v in angles.items()})[0]

    def poses_from_passive(self, inputs, passive_angles: Mapping[str, Sequence[float]]) -> np.ndarray | None:
        """:meth:`pose_from_passive` at N configurations at once: ``inputs`` (N, number of actuated
        joints) and ``passive_angles`` name -> N readings (radians; the output path's passive joints
        at least); shape (N, 3, 3), or None for a mechanism without an output link. Unchecked
        beyond shapes: the readings are the solver's own."""
        if self.output is None:
            return None
        inputs = np.asarray(inputs, dtype=float)
        readings = {n: np.asarray(v, dtype=float).reshape(-1) for n, v in passive_angles.items()}
        readings.update({n: inputs[:, i] for i, n in enumerate(self.actuated)})
        return self._steps_rotation(self.link_paths[self.output], readings) @ self.platform_reference_matrix

    def forward(self, joint_angles: Mapping[str, float], form: str = "auto") -> ForwardResult:
        """Forward evaluation: every joint reading (radians) -> pose (None without an output link), the
        pose along each leg (legs only) and per-loop closure residuals."""
        readings = self._check_angles("joint_angles", joint_angles, self.joint_names)
        arrays = {n: np.array([v]) for n, v in readings.items()}
        ref = self.platform_reference_matrix
        leg_poses = tuple(self._steps_rotation([Step(j.name, 1) for j in leg.joints], arrays)[0] @ ref
                          for leg in self.legs)
        residuals = tuple(
            float(np.linalg.norm(normalized_closure(g.factor_angles(readings, form)) - np.eye(3)))
            for g in self.loop_geometry
        )
        pose = None
        if self.output is not None:
            pose = self._steps_rotation(self.link_paths[self.output], arrays)[0] @ ref
        return ForwardResult(
            pose=pose,
            leg_poses=leg_poses,
            loop_residuals=residuals,
            loop_legs=tuple(g.legs for g in self.loop_geometry),
        )

    # ---------------------------------------------------------------- inverse kinematics

    def inverse_kinematics(self, R, only_in_range: bool = False) -> tuple[IKSolution, ...]:
        """Every joint solution (all working modes) for the platform pose R (3x3 rotation).

        Each leg is solved as a serial chain for the platform displacement D = R R_ref^T
        (Paden-Kahan subproblems; legs of 1, 2 or 3 joints; up to 2 branches per 3-joint leg) and
        the branches of the legs are combined, e.g. 2^3 = 8 working modes for a 3-RRR. A pose a leg
        cannot reach gives no solution. With ``only_in_range`` the solutions whose readings leave a
        joint range are dropped.
        """
        rot = check_rotation("R", R)
        if not self.legs:
            raise ValueError(
                f"R: this mechanism is not legs from the ground to an output link ({self._not_legs()}); its inverse "
                "kinematics is solved on the loop equations: spherekin.inverse_kinematics(mechanism, R)")
        target = rot @ self.platform_reference_matrix.T
        per_leg = []
        for leg in self.legs:
            axes = np.array([j.axis for j in leg.joints])
            if len(leg.joints) > 3:
                raise ValueError(
                    f"R: inverse kinematics needs legs of at most 3 joints; leg {leg.name!r} has "
                    f"{len(leg.joints)} (its inverse kinematics has a continuum of solutions)"
                )
            sols = []
            for disp in serial_ik(axes, target):
                readings = [wrap(j.reference_angle + d) for j, d in zip(leg.joints, disp)]
                mode = 0
                if len(leg.joints) == 3:
                    cur = current_axes(axes, disp)
                    det = float(np.linalg.det(cur))
                    mode = 0 if abs(det) < SINGULARITY_TOL else int(math.copysign(1, det))
                sols.append((readings, mode))
            per_leg.append(sols)
        out = []
        for combo in itertools.product(*per_leg):
            angles, ok = {}, True
            for leg, (readings, _) in zip(self.legs, combo):
                for j, r in zip(leg.joints, readings):
                    if j.range is not None:
                        ok = ok and in_range(r, j.range)
                        r = into_range(r, j.range) if ok else j.range[0] + (r - j.range[0]) % _TWO_PI
                    angles[j.name] = r
            if only_in_range and not ok:
                continue
            out.append(IKSolution(
                joint_angles=MappingProxyType(angles),
                inputs=tuple(angles[n] for n in self.actuated),
                working_mode=tuple(mode for _, mode in combo),
                in_range=ok,
            ))
        return tuple(out)

    # ---------------------------------------------------------------- singularities

    def jacobians(self, joint_angles: Mapping[str, float]) -> dict[str, np.ndarray]:
        """Velocity Jacobians at given readings (radians).

        ``legs``: per leg, J_i = [a_1 .. a_k] (current axes, base frame; omega = J_i qdot_i; legs
        only); ``constraints``: K (3 loops x n_joints, columns in ``joint_names`` order), each
        loop's velocity constraint: the angular velocity of its closing link along ``up`` minus that
        along ``down`` (sum of sign x current axis x rate), 0 (for legs: J_j qdot_j - J_r qdot_r);
        ``K_a``, ``K_p``: its actuated and passive columns (K_a qdot_a + K_p qdot_p = 0).
        """
        readings = self._check_angles("joint_angles", joint_angles, self.joint_names)
        leg_j, k_mat = self._constraints({n: np.array([v]) for n, v in readings.items()})
        names = self.joint_names
        act = [names.index(n) for n in self.actuated]
        pas = [names.index(n) for n in self.passive]
        k_mat = k_mat[0]
        return {"legs": {n: j[0] for n, j in leg_j.items()}, "constraints": k_mat, "K_a": k_mat[:, act],
                "K_p": k_mat[:, pas]}

    def _constraints(self, readings: Mapping[str, np.ndarray]) -> tuple[dict, np.ndarray]:
        """(leg name -> current axes (N, 3, k), K (N, 3 loops, n_joints)) at N configurations: every
        joint's readings (N,), radians (see :meth:`jacobians`). A joint [a, b]'s current axis is
        R_a a_0 (the link it turns relative to does not move it)."""
        names = self.joint_names
        n = len(next(iter(readings.values())))
        leg_j = {}
        for leg in self.legs:
            axes = np.array([j.axis for j in leg.joints])
            disp = np.stack([np.asarray(readings[j.name], dtype=float) - j.reference_angle for j in leg.joints], axis=-1)
            leg_j[leg.name] = current_axes(axes, disp)
        rotations: dict[str, np.ndarray] = {}
        rows = []
        for terms in self.constraint_terms:
            block = np.zeros((n, 3, len(names)))
            for col, sign, joint, link in terms:
                if link not in rotations:
                    rotations[link] = self._steps_rotation(self.link_paths[link], readings)
                block[:, :, col] += sign * (rotations[link] @ np.asarray(self.joint_map[joint].axis))
            rows.append(block)
        return leg_j, np.concatenate(rows, axis=1)

    def without_ranges(self, names: Sequence[str] | None = None) -> "SphericalMechanism":
        """The same mechanism with the joints ``names`` (default: every joint) unlimited."""
        def free(j):
            return dataclasses.replace(j, range=None) if names is None or j.name in names else j

        if self.graph is not None:
            return dataclasses.replace(self, graph=dataclasses.replace(
                self.graph, joints=tuple(free(j) for j in self.graph.joints)))
        legs = tuple(Leg(leg.name, tuple(free(j) for j in leg.joints)) for leg in self.legs)
        return dataclasses.replace(self, legs=legs)

    def parallel_measure(self, joint_angles: Mapping[str, float]) -> float:
        """The normalized distance to a parallel singularity at ``joint_angles`` (name -> radians):
        sigma_min / sigma_max of K_p (:meth:`jacobians`), 1 for an isotropic configuration, 0 at a
        parallel singularity (where assembly modes meet). K_p's columns are the passive joints'
        current axes (unit vectors) combined loop by loop, so the ratio is dimensionless and does not
        depend on the number of loops. NaN without passive joints; 0 with more of them than rows."""
        readings = self._check_angles("joint_angles", joint_angles, self.joint_names)
        return float(self.parallel_measures({n: [v] for n, v in readings.items()})[0])

    def parallel_measures(self, joint_angles: Mapping[str, Sequence[float]]) -> np.ndarray:
        """:meth:`parallel_measure` at N configurations at once: ``joint_angles`` every joint's name
        -> N readings (radians); shape (N,). (A tracked path of 1,000 poses: one call, not 1,000.)"""
        missing = [n for n in self.joint_names if n not in joint_angles]
        if missing:
            raise ValueError(f"joint_angles: missing angle(s) for {missing}")
        _, k_mat = self._constraints({n: np.asarray(joint_angles[n], dtype=float).reshape(-1) for n in self.joint_names})
        pas = [self.joint_names.index(n) for n in self.passive]
        kp = k_mat[:, :, pas]
        if kp.shape[2] == 0:
            return np.full(len(kp), np.nan)
        if kp.shape[2] > kp.shape[1]:
            return np.zeros(len(kp))
        s = np.linalg.svd(kp, compute_uv=False)
        return np.where(s[:, 0] == 0.0, 0.0, s[:, -1] / np.where(s[:, 0] == 0.0, 1.0, s[:, 0]))

    def singularity(self, joint_angles: Mapping[str, float], tol: float = SINGULARITY_TOL) -> SingularityReport:
        """Classify a configuration as regular, serial-, parallel- or doubly singular (see
        :class:`SingularityReport`; tolerance SINGULARITY_TOL by default): :meth:`singularities` at one
        configuration."""
        readings = self._check_angles("joint_angles", joint_angles, self.joint_names)
        return self.singularities({n: [v] for n, v in readings.items()}, tol)[0]

    def singularities(self, joint_angles: Mapping[str, Sequence[float]],
                      tol: float = SINGULARITY_TOL) -> list[SingularityReport]:
        """:meth:`singularity` at N configurations at once: ``joint_angles`` every joint's name -> N
        readings (radians); one :class:`SingularityReport` per configuration, in order (the leg and
        loop Jacobians of all N in one stack of SVDs)."""
        if isinstance(tol, (bool, np.bool_)) or not isinstance(tol, (int, float, np.integer, np.floating)) \
                or not math.isfinite(tol) or not tol > 0:
            raise ValueError(f"tol: expected a positive tolerance, got {tol!r}")
        tol = float(tol)
        missing = [n for n in self.joint_names if n not in joint_angles]
        if missing:
            raise ValueError(f"joint_angles: missing angle(s) for {missing}")
        readings = {n: np.asarray(joint_angles[n], dtype=float).reshape(-1) for n in self.joint_names}
        leg_j, k_mat = self._constraints(readings)
        n = k_mat.shape[0]
        serial_margin = np.full(n, math.inf)
        serial_legs = [[] for _ in range(n)]
        for leg in self.legs:
            act = np.array([j.actuated for j in leg.joints])
            if not act.any():
                continue
            jl = leg_j[leg.name]                                              # (N, 3, k)
            _, s, vt = np.linalg.svd(jl)                                      # full: vt is (N, k, k)
            s_full = np.concatenate([s, np.zeros((n, len(leg.joints) - s.shape[1]))], axis=1)
            serial_margin = np.minimum(serial_margin, s_full.min(axis=1))
            # a null motion of the leg (platform still) that moves an actuated joint
            null = s_full < tol                                              # (N, k): rows of vt
            moved = np.sqrt(np.einsum("nr,nra->n", null.astype(float), vt[:, :, act] ** 2))
            for i in np.flatnonzero(null.any(axis=1) & (moved > math.sqrt(tol))):
                serial_legs[i].append(leg.name)
        pas = [self.joint_names.index(name) for name in self.passive]
        kp = k_mat[:, :, pas]
        if kp.shape[2] == 0:
            parallel_margin = np.full(n, math.inf)
        elif kp.shape[2] > kp.shape[1]:
            parallel_margin = np.zeros(n)
        else:
            parallel_margin = np.linalg.svd(kp, compute_uv=False).min(axis=1)
        return [SingularityReport(serial=bool(legs), parallel=bool(pm < tol), serial_margin=float(sm),
                                  parallel_margin=float(pm), serial_legs=tuple(legs), tol=tol)
                for legs, sm, pm in zip(serial_legs, serial_margin, parallel_margin)]
