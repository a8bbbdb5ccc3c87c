"""The mechanism as built: how far each joint axis and each actuated input may be from the file's.

A mechanism file may carry a ``[tolerances]`` table (docs/mechanism-format.md)::

    [tolerances]
    axes_deg = 0.1      # each joint axis within this angle of its nominal direction (a cone)
    inputs_deg = 0.01   # each actuated input within +- this of the value given

    [tolerances.joints] # per joint (names as the file's joints): that joint's axis cone, degrees
    beta1 = 0.05

Every joint axis the model has (for kind "3-RRR": the base, elbow and platform axes; the distal link
angles stay as given) lies anywhere in its cone, independently of the others; every actuated input
anywhere in its interval. :class:`Tolerances` holds them (degrees, as written); the analysis that
proves what they do to an assembly is :mod:`spherekin.trust.tolerances`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

from .checks import shown

__all__ = ["Tolerances", "MAX_TOLERANCE_DEG", "TOLERANCE_KEYS", "tolerances_from_table", "parse_tolerances_option"]

#: The largest tolerance accepted (degrees, an axis cone or an input interval). Reason: a machined
#: joint is off by tenths of a degree; 10 degrees is another mechanism (its assemblies are no longer
#: near the nominal ones, and the certified bounds, built on the nominal assembly, would not be of use).
MAX_TOLERANCE_DEG = 10.0
#: The keys of a ``[tolerances]`` table.
TOLERANCE_KEYS = ("axes_deg", "inputs_deg", "joints")


def _degrees(key: str, value) -> float:
    """``value`` as a tolerance in degrees: a number in [0, MAX_TOLERANCE_DEG], else ValueError naming ``key``."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{key}: expected a number of degrees in [0, {MAX_TOLERANCE_DEG:g}], got {shown(value)}")
    value = float(value)
    if not math.isfinite(value) or value < 0.0:
        raise ValueError(f"{key}: expected a number of degrees in [0, {MAX_TOLERANCE_DEG:g}], got {shown(value)}")
    if value > MAX_TOLERANCE_DEG:
        raise ValueError(f"{key}: {value:g} degrees is over the {MAX_TOLERANCE_DEG:g} accepted (a tolerance, not "
                         "another mechanism)")
    return value


@dataclass(frozen=True)
class Tolerances:
    """Geometric and encoder tolerances (degrees): ``axes_deg`` the half-angle of every joint axis's
    cone, ``joints`` (name, degrees) pairs overriding it per joint, ``inputs_deg`` the half-width of
    every actuated input's interval. Checked on construction (each in [0, MAX_TOLERANCE_DEG]); the
    joint names are checked against a mechanism by :meth:`check_joints`."""

    axes_deg: float = 0.0
    inputs_deg: float = 0.0
    joints: tuple = ()

    def __post_init__(self):
        object.__setattr__(self, "axes_deg", _degrees("axes_deg", self.axes_deg))
        object.__setattr__(self, "inputs_deg", _degrees("inputs_deg", self.inputs_deg))
        pairs = self.joints.items() if isinstance(self.joints, Mapping) else self.joints
        checked = []
        for pair in pairs:
            if not isinstance(pair, (tuple, list)) or len(pair) != 2 or not isinstance(pair[0], str):
                raise ValueError(f"joints: expected joint name -> degrees, got {shown(pair)}")
            checked.append((pair[0], _degrees(f"joints.{pair[0]}", pair[1])))
        object.__setattr__(self, "joints", tuple(checked))

    def axis_deg(self, joint: str) -> float:
        """The half-angle (degrees) of ``joint``'s axis cone."""
        return dict(self.joints).get(joint, self.axes_deg)

    def axis_rad(self, joint: str) -> float:
        """The half-angle (radians) of ``joint``'s axis cone."""
        return math.radians(self.axis_deg(joint))

    @property
    def inputs_rad(self) -> float:
        """The half-width (radians) of every actuated input's interval."""
        return math.radians(self.inputs_deg)

    @property
    def zero(self) -> bool:
        """No tolerance at all: the nominal mechanism."""
        return self.axes_deg == 0.0 and self.inputs_deg == 0.0 and all(v == 0.0 for _, v in self.joints)

    def check_joints(self, joint_names) -> None:
        """ValueError naming the first joint of ``joints`` that is not among ``joint_names``."""
        for name, _ in self.joints:
            if name not in joint_names:
                raise ValueError(f"tolerances.joints.{name}: no joint of that name; the joints are "
                                 f"{', '.join(joint_names)}")

    def replaced(self, **changes) -> "Tolerances":
        """These tolerances with ``changes``: ``axes_deg``, ``inputs_deg``, or a joint's name (its cone)."""
        axes = changes.pop("axes_deg", self.axes_deg)
        inputs = changes.pop("inputs_deg", self.inputs_deg)
        return Tolerances(axes, inputs, {**dict(self.joints), **changes})

    def as_dict(self) -> dict:
        """JSON-ready: ``axes_deg``, ``inputs_deg``, ``joints`` (name -> degrees)."""
        return {"axes_deg": self.axes_deg, "inputs_deg": self.inputs_deg, "joints": dict(self.joints)}


def tolerances_from_table(table) -> Tolerances:
    """The :class:`Tolerances` of a parsed ``[tolerances]`` table; ValueError naming the key otherwise."""
    if not isinstance(table, Mapping):
        raise ValueError(f"tolerances: expected a table (axes_deg, inputs_deg, [tolerances.joints]), got {shown(table)}")
    for key in table:
        if key not in TOLERANCE_KEYS:
            raise ValueError(f"tolerances.{key}: unknown key; valid keys here: {', '.join(TOLERANCE_KEYS)}")
    joints = table.get("joints", {})
    if not isinstance(joints, Mapping):
        raise ValueError(f"tolerances.joints: expected a table of joint name = degrees, got {shown(joints)}")
    try:
        return Tolerances(table.get("axes_deg", 0.0), table.get("inputs_deg", 0.0), dict(joints))
    except ValueError as exc:
        raise ValueError(f"tolerances.{exc}") from None


def parse_tolerances_option(text: str, base: Tolerances | None = None) -> Tolerances:
    """The tolerances of a command-line value ``axes_deg=0.1,inputs_deg=0.01,beta1=0.05`` (a joint's
    name sets its cone), over ``base`` (the file's, or none); ValueError naming the part otherwise."""
    changes: dict = {}
    for part in (p.strip() for p in str(text).split(",")):
        if not part:
            continue
        key, sep, value = part.partition("=")
        key = key.strip()
        if not sep or not key:
            raise ValueError(f"--tolerances: expected key=degrees pairs separated by commas (axes_deg=0.1,"
                             f"inputs_deg=0.01,<joint>=0.05), got {part!r}")
        try:
            changes[key] = float(value)
        except ValueError:
            raise ValueError(f"--tolerances: {key}: expected a number of degrees, got {value.strip()!r}") from None
    if not changes:
        raise ValueError(f"--tolerances: expected key=degrees pairs (axes_deg=0.1,inputs_deg=0.01), got {text!r}")
    try:
        return (base or Tolerances()).replaced(**changes)
    except ValueError as exc:
        raise ValueError(f"--tolerances: {exc}") from None
