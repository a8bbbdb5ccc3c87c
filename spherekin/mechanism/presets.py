"""Preset mechanisms (also shipped as ``examples/*.toml``; the tests check that both agree).

* :func:`gosselin` -- the paper's Gosselin platform (Section 2.1, Fig. 2): a 3-RRR whose link
  angles and base/platform axis angles are all pi/2 (the geometry of Gosselin's "agile eye").
* :func:`general_3rrr` -- a symmetric 3-RRR with link angles 50 and 75 degrees (non-pi/2).
* :func:`four_bar` -- a spherical four-bar linkage (one loop, 1 DOF).
* :func:`five_bar` -- a spherical five-bar linkage (one loop, 2 DOF).

Every joint is unlimited (the full circle); pass ranges through :func:`~.rrr.three_rrr` or a
mechanism file when needed.
"""

from __future__ import annotations

import math

import numpy as np

from .chains import axis_rotation, sphere_point
from .model import Joint, Leg, SphericalMechanism
from .rrr import three_rrr

__all__ = ["PRESETS", "gosselin", "general_3rrr", "four_bar", "five_bar", "preset"]


def gosselin() -> SphericalMechanism:
    """The paper's Gosselin platform (the agile eye geometry), with the paper's actuator conventions.

    Base axes u = (x, y, -z), elbow axes at zero w^0 = (y, -z, x) = (u_2, u_3, u_1), platform axes
    v^0 = (z, x, y) (platform frame), distal link angles pi/2. The reference configuration is
    beta = 0, R = I, where each leg's (u_i, w_i, v_i) is an orthonormal triad (the isotropic home
    pose of the agile eye). Loops use leg2 as reference leg, as in the paper (loop 1: legs 1-2,
    loop 2: legs 3-2). With these conventions the derived loops reproduce the actuator relations
    of Section 2.1 exactly: theta_1^1 = pi + beta_1, theta_6^1 = pi/2 - beta_2,
    theta_1^2 = 3 pi/2 + beta_3, theta_6^2 = pi - beta_2, and Eq. (5): theta_4^2 = theta_4^1 + pi/2,
    theta_5^2 = theta_5^1 (tests/test_mechanism_presets.py). u_3 = -z, not +z: the paper's
    relations need the base triad to be left-handed in the right-hand-rule convention of Eq. (1)
    (and the platform triad right-handed).
    """
    x, y, z = np.eye(3)
    return three_rrr(
        base_axes=[x, y, -z],
        elbow_axes_at_zero=[y, -z, x],
        platform_axes=[z, x, y],
        distal_link_angles=[math.pi / 2] * 3,
        name="Gosselin platform (agile eye)",
        reference_leg="leg2",
    )


def _polar(polar_deg: float, azimuth_deg: float) -> np.ndarray:
    p, a = math.radians(polar_deg), math.radians(azimuth_deg)
    return np.array([math.sin(p) * math.cos(a), math.sin(p) * math.sin(a), math.cos(p)])


def general_3rrr() -> SphericalMechanism:
    """A symmetric 3-RRR with proximal link angle 50 deg and distal link angle 75 deg.

    u_i: polar angle 110 deg (from +z), azimuth 120 (i - 1) deg; w_i^0: polar angle 60 deg, same
    azimuth (u_i turned 50 deg towards +z); v_i^0: polar angle 60 deg, azimuth 60 + 120 (i - 1) deg
    (platform frame). The legs do not close at beta = 0, R = I; the model's reference
    configuration is R = I with beta_i = 0.5447 rad (31.2 deg), found by
    :func:`~.rrr.find_reference_pose`.
    """
    az = [0.0, 120.0, 240.0]
    return three_rrr(
        base_axes=[_polar(110.0, a) for a in az],
        elbow_axes_at_zero=[_polar(60.0, a) for a in az],
        platform_axes=[_polar(60.0, a + 60.0) for a in az],
        distal_link_angles=[math.radians(75.0)] * 3,
        name="general 3-RRR (50/75 deg)",
    )


def four_bar() -> SphericalMechanism:
    """A spherical four-bar (crank-rocker): ground 80, crank 30, coupler 70, rocker 60 degrees.

    Joints: A (crank pivot, actuated) and D (rocker pivot) on the base, B (crank-coupler) and C
    (coupler-rocker). Legs: "crank" = (A, B) and "rocker" = (D, C); the platform is the coupler BC.
    Reference configuration: A = z, D in the xz-plane, B = Rot(A, 90 deg) of the point 30 deg from
    A towards D, C on the positive side of B x D.
    """
    a = np.array([0.0, 0.0, 1.0])
    d = _polar(80.0, 0.0)
    b = axis_rotation(a, math.pi / 2) @ _polar(30.0, 0.0)
    c = sphere_point(b, d, math.radians(70.0), math.radians(60.0), 1.0)
    return SphericalMechanism(
        legs=(Leg("crank", (Joint("A", a, actuated=True), Joint("B", b))),
              Leg("rocker", (Joint("D", d), Joint("C", c)))),
        name="spherical four-bar (80/30/70/60 deg)",
    )


def five_bar() -> SphericalMechanism:
    """A spherical five-bar: ground AE 60, AB 45, BC 60, CD 60, DE 45 degrees; A and E actuated.

    Legs: "left" = (A, B) and "right" = (E, D, C); the platform is the link BC. Reference
    configuration: A, E in the xz-plane at +-30 deg from z, B and D 45 deg from A and E towards +y,
    C on the side of D x B (near +z).
    """
    a, e = _polar(30.0, 180.0), _polar(30.0, 0.0)
    y = np.array([0.0, 1.0, 0.0])
    s45 = math.sin(math.radians(45.0))
    b = s45 * a + s45 * y
    d = s45 * e + s45 * y
    c = sphere_point(b, d, math.radians(60.0), math.radians(60.0), -1.0)
    return SphericalMechanism(
        legs=(Leg("left", (Joint("A", a, actuated=True), Joint("B", b))),
              Leg("right", (Joint("E", e, actuated=True), Joint("D", d), Joint("C", c)))),
        name="spherical five-bar (60/45/60/60/45 deg)",
    )


#: Preset name -> constructor (the examples/<name>.toml files hold the same mechanisms).
PRESETS = {"gosselin": gosselin, "general_3rrr": general_3rrr, "four_bar": four_bar, "five_bar": five_bar}


def preset(name: str) -> SphericalMechanism:
    """The preset called ``name`` (one of PRESETS)."""
    if name not in PRESETS:
        raise ValueError(f"name: expected one of {tuple(PRESETS)}, got {name!r}")
    return PRESETS[name]()
