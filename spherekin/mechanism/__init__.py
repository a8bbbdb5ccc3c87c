"""Mechanism model: spherical parallel mechanisms from joint axes to loop equations (paper Section 2).

* :mod:`.model` -- the general model :class:`SphericalMechanism` (legs of revolute joints given by
  their axes in one assembled reference configuration): spherical polygons, link twists, joint
  offsets and the l - 1 closure equations in the normalized form of Eq. (2)
  (:meth:`~SphericalMechanism.loop_system` -> :class:`LoopSystem` of
  :class:`~spherekin.closure.ClosureLoop`), pose recovery, forward evaluation, inverse kinematics
  (all working modes) and singularity classification;
* :mod:`.chains` -- rotations and inverse kinematics of serial spherical chains (Paden-Kahan);
* :mod:`.checks` -- validation of angles, unit vectors, ranges and rotations (messages name the key);
* :mod:`.rrr` -- the 3-RRR constructor :func:`three_rrr` (base axes, elbow axes at zero, platform
  axes, distal link angles);
* :mod:`.presets` -- :func:`gosselin` (the paper's example), :func:`general_3rrr`,
  :func:`four_bar`, :func:`five_bar`;
* :mod:`.tolerances` -- the mechanism as built: :class:`Tolerances` (joint axis cones, input
  intervals) read from a file's ``[tolerances]`` table;
* :mod:`.io` -- mechanism files in TOML (:func:`load_mechanism`, :func:`dumps_mechanism`); format in
  docs/mechanism-format.md.

Typical use by a direct-kinematics solver::

    mech = load_mechanism("examples/gosselin.toml")
    system = mech.loop_system(inputs=(0.1, -0.2, 0.3),
                              passive_ranges={n: (-3.0, 3.0) for n in mech.passive})
    system.loops, system.unknowns        # ClosureLoop objects sharing Unknown objects
    R = mech.pose_from_passive((0.1, -0.2, 0.3), system.to_angles(x))   # x: a solution box point
"""

from .io import KINDS, MechanismFileError, dumps_mechanism, load_mechanism, mechanism_from_dict
from .chains import IK_TOL, angle_about, axis_rotation
from .checks import ROTATION_TOL, UNIT_TOL, parse_angle
from .model import (
    FORMS,
    PARALLEL_TOL,
    RIGHT_ANGLE_TOL,
    SINGULARITY_TOL,
    ForwardResult,
    IKSolution,
    Joint,
    Leg,
    LoopGeometry,
    LoopSystem,
    LoopVertex,
    FactorSpec,
    SingularityReport,
    SphericalMechanism,
)
from .tolerances import MAX_TOLERANCE_DEG, Tolerances, parse_tolerances_option
from .presets import PRESETS, five_bar, four_bar, general_3rrr, gosselin, preset
from .rrr import (
    PLATFORM_DIRECTION_MIN_SINE,
    REFERENCE_MARGIN,
    THREE_RRR_KEYS,
    ThreeRRRGeometry,
    elbow_angle,
    find_reference_pose,
    platform_joint_angle,
    rrr_joint_names,
    three_rrr,
)

__all__ = [
    "FORMS", "IK_TOL", "PARALLEL_TOL", "RIGHT_ANGLE_TOL", "ROTATION_TOL", "SINGULARITY_TOL", "UNIT_TOL",
    "ForwardResult", "IKSolution", "Joint", "Leg", "FactorSpec", "LoopGeometry", "LoopSystem", "LoopVertex",
    "SingularityReport", "SphericalMechanism", "angle_about", "axis_rotation", "parse_angle",
    "PLATFORM_DIRECTION_MIN_SINE", "REFERENCE_MARGIN", "THREE_RRR_KEYS", "ThreeRRRGeometry", "elbow_angle",
    "find_reference_pose", "platform_joint_angle", "rrr_joint_names", "three_rrr",
    "PRESETS", "five_bar", "four_bar", "general_3rrr", "gosselin", "preset",
    "MAX_TOLERANCE_DEG", "Tolerances", "parse_tolerances_option",
    "KINDS", "MechanismFileError", "dumps_mechanism", "load_mechanism", "mechanism_from_dict",
]
