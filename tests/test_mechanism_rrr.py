"""Tests for spherekin.mechanism.rrr: the 3-RRR semantics against closed-form leg geometry.

The independent model of a 3-RRR leg: w(beta) = Rot(u, beta) w^0 (scipy rotations), v = R v^0,
and the leg closes when w . v = cos(alpha2), i.e. a cos(beta) + b sin(beta) = e with
a = (w^0 - (u.w^0) u) . v, b = (u x w^0) . v, e = cos(alpha2) - (u.w^0)(u.v): at most two roots.
"""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from spherekin.mechanism import (
    ThreeRRRGeometry,
    find_reference_pose,
    general_3rrr,
    gosselin,
    rrr_joint_names,
    three_rrr,
)
from conftest import unit


def closed_form_betas(u, w0, v, alpha2):
    u, w0, v = map(np.asarray, (u, w0, v))
    a = (w0 - (u @ w0) * u) @ v
    b = np.cross(u, w0) @ v
    e = math.cos(alpha2) - (u @ w0) * (u @ v)
    rho = math.hypot(a, b)
    if abs(e) > rho:
        return []
    phi, dev = math.atan2(b, a), math.acos(e / rho)
    return sorted(math.remainder(phi + s * dev, 2 * math.pi) for s in (1, -1))


def signed_angle(axis, x, y):
    axis = np.asarray(axis)
    xp, yp = x - axis * (axis @ x), y - axis * (axis @ y)
    return math.atan2(axis @ np.cross(xp, yp), xp @ yp)


@pytest.mark.parametrize("make", [gosselin, general_3rrr])
def test_ik_matches_closed_form_leg_geometry(make):
    mech = make()
    g = mech.geometry
    rng = np.random.default_rng(1)
    for seed in range(6):
        pose = Rotation.from_rotvec(rng.normal(size=3) * 0.4).as_matrix() @ mech.platform_reference_matrix
        sols = mech.inverse_kinematics(pose)
        for i in range(3):
            v = pose @ np.array(g.platform_axes[i])
            expected = closed_form_betas(g.base_axes[i], g.elbow_axes_at_zero[i], v, g.distal_link_angles[i])
            got = sorted({round(s.joint_angles[f"beta{i + 1}"], 9) for s in sols})
            np.testing.assert_allclose(got, expected, atol=1e-9)
            for s in sols:
                beta = s.joint_angles[f"beta{i + 1}"]
                u = np.array(g.base_axes[i])
                w = Rotation.from_rotvec(beta * u).apply(g.elbow_axes_at_zero[i])  # right-hand rule
                assert w @ v == pytest.approx(math.cos(g.distal_link_angles[i]), abs=1e-12)
                # the model's elbow axis at this configuration is that w (leg Jacobian column 2)
                jl = mech.jacobians(s.joint_angles)["legs"][f"leg{i + 1}"]
                np.testing.assert_allclose(jl[:, 1], w, atol=1e-12)
                np.testing.assert_allclose(jl[:, 2], v, atol=1e-12)
                # intrinsic passive readings
                r = pose @ np.array(g.platform_directions[i])
                assert math.remainder(s.joint_angles[f"gamma{i + 1}"] - signed_angle(w, u, v), 2 * math.pi) \
                    == pytest.approx(0, abs=1e-12)
                assert math.remainder(s.joint_angles[f"delta{i + 1}"] - signed_angle(v, w, r), 2 * math.pi) \
                    == pytest.approx(0, abs=1e-12)


def test_actuation_turns_the_elbow_by_the_right_hand_rule():
    """Leg 1 of the Gosselin preset has u = x, w^0 = y: the right-hand rule gives w(beta) = (0, cos, sin)."""
    mech = gosselin()
    g = mech.geometry
    assert np.allclose(g.base_axes[0], [1, 0, 0]) and np.allclose(g.elbow_axes_at_zero[0], [0, 1, 0])
    betas = []
    for s in mech.inverse_kinematics(Rotation.from_rotvec([0.3, 0.2, -0.1]).as_matrix()):
        beta = s.joint_angles["beta1"]
        w = mech.jacobians(s.joint_angles)["legs"]["leg1"][:, 1]
        np.testing.assert_allclose(w, [0.0, math.cos(beta), math.sin(beta)], atol=1e-12)
        betas.append(beta)
    assert max(abs(math.sin(b)) for b in betas) > 0.1  # the sign of sin(beta) is actually tested


def test_pose_convention_v_equals_R_v0():
    mech = general_3rrr()
    pose = Rotation.from_rotvec([0.2, -0.3, 0.1]).as_matrix()
    for s in mech.inverse_kinematics(pose):
        recovered = mech.pose_from_passive(s.inputs, s.passive(mech.passive))
        np.testing.assert_allclose(recovered, pose, atol=1e-12)
        for i in range(3):
            jl = mech.jacobians(s.joint_angles)["legs"][f"leg{i + 1}"]
            np.testing.assert_allclose(jl[:, 2], pose @ mech.geometry.platform_axes[i], atol=1e-12)


def test_reference_pose_search_when_identity_does_not_assemble():
    """Platform axes chosen so that R = I cannot assemble leg 1; a reference pose is found elsewhere."""
    x, y, z = np.eye(3)
    geom = dict(base_axes=[x, y, z], elbow_axes_at_zero=[y, z, x], platform_axes=[-x, -y, -z],
                distal_link_angles=[0.4, 0.4, 0.4])
    # proximal angle pi/2, distal 0.4: leg i needs angle(u_i, R v_i^0) in [pi/2 - 0.4, pi/2 + 0.4]; at R = I it is pi
    mech = three_rrr(**geom)
    r = mech.platform_reference_matrix
    assert not np.allclose(r, np.eye(3))
    for i, u in enumerate((x, y, z)):
        ang = math.acos(np.clip(u @ r @ geom["platform_axes"][i], -1, 1))
        assert math.pi / 2 - 0.4 < ang < math.pi / 2 + 0.4
    ref = {j.name: j.reference_angle for j in mech.joints}
    fr = mech.forward(ref)
    assert max(fr.loop_residuals) < 1e-12


def test_impossible_geometry_is_rejected():
    """Coaxial base axes, mutually orthogonal platform axes and short links cannot be assembled."""
    x, y, z = np.eye(3)
    with pytest.raises(ValueError, match="inconsistent geometry: no platform pose assembles"):
        three_rrr([z, z, z], [unit(z + 0.1 * x)] * 3, [x, y, z], [0.1, 0.1, 0.1])
    geom = ThreeRRRGeometry((tuple(z),) * 3, (tuple(unit(z + 0.1 * x)),) * 3, (tuple(x), tuple(y), tuple(z)),
                            (0.1, 0.1, 0.1))
    assert find_reference_pose(geom) is None



def test_joint_names_and_ranges():
    assert rrr_joint_names() == ("beta1", "gamma1", "delta1", "beta2", "gamma2", "delta2",
                                 "beta3", "gamma3", "delta3")
    x, y, z = np.eye(3)
    mech = three_rrr([x, y, -z], [y, -z, x], [z, x, y], ["pi/2"] * 3, {"gamma2": ["-pi", "pi/2"]})
    assert mech.ranges["gamma2"] == (-math.pi, math.pi / 2)
    assert mech.ranges["beta1"] is None
    assert mech.actuated == ("beta1", "beta2", "beta3")
    assert mech.kind == "3-RRR" and mech.reference_leg == "leg1"


X, Y, Z = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0])


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(base_axes=[X, Y]), r"base_axes: expected 3 unit vectors \(one per leg\), got 2"),
        (dict(base_axes=[X, Y, [0, 0, 0]]), r"base_axes\[2\]: expected a unit vector, got the zero vector"),
        (dict(elbow_axes_at_zero=[Y, Z, [1, 1, 0]]), r"elbow_axes_at_zero\[2\]: expected a unit vector \(norm 1"),
        (dict(platform_axes=[Z, X, [0, 1]]), r"platform_axes\[2\]: expected a unit vector of 3 components"),
        (dict(platform_axes="xyz"), r"platform_axes: expected a list of 3 unit vectors"),
        (dict(distal_link_angles=[1.0, 1.0]), r"distal_link_angles: expected 3 angles"),
        (dict(distal_link_angles=[1.0, 0.0, 1.0]), r"distal_link_angles\[1\]: expected an angle strictly between 0 and pi"),
        (dict(distal_link_angles=[1.0, "half"]), r"distal_link_angles: expected 3 angles"),
        (dict(distal_link_angles=[1.0, "half", 1.0]), r"distal_link_angles\[1\]: expected an angle in radians"),
        (dict(elbow_axes_at_zero=[X, Z, X]), r"elbow_axes_at_zero\[0\]: inconsistent geometry: parallel to base_axes\[0\]"),
        (dict(joint_ranges={"beta4": (0, 1)}), r"joint_ranges: unknown joint 'beta4'; valid names: beta1"),
        (dict(joint_ranges={"beta1": (1, 0)}), r"joint_ranges.beta1: expected lo < hi"),
        (dict(joint_ranges={"beta1": (0, 7)}), r"joint_ranges.beta1: expected a width hi - lo < 2\*pi"),
        (dict(joint_ranges=[("beta1", (0, 1))]), r"joint_ranges: expected a table"),
        (dict(reference_leg="leg4"), r"reference_leg: expected one of \['leg1', 'leg2', 'leg3'\]"),
    ],
)
def test_bad_input_names_the_argument(kwargs, match):
    args = dict(base_axes=[X, Y, [0.0, 0.0, -1.0]], elbow_axes_at_zero=[Y, [0.0, 0.0, -1.0], X],
                platform_axes=[Z, X, Y], distal_link_angles=[math.pi / 2] * 3)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        three_rrr(**args)


def test_coaxial_platform_joints_use_the_fallback_direction():
    """v_1^0 = v_2^0: delta_1 is measured to the basis vector least aligned with v_1^0 (here x)."""
    x, y, z = np.eye(3)
    mech = three_rrr([x, y, -z], [y, -z, x], [z, z, y], [math.pi / 2] * 3, reference_leg="leg3")
    g = mech.geometry
    assert g.platform_directions[0] == (1.0, 0.0, 0.0) and g.platform_directions[1] == (0.0, 1.0, 0.0)
    for seed in range(3):
        pose = Rotation.random(random_state=seed).as_matrix()
        sols = mech.inverse_kinematics(pose)
        assert len(sols) == 8
        for s in sols:
            fr = mech.forward(s.joint_angles)
            assert max(fr.loop_residuals) < 1e-12
            np.testing.assert_allclose(mech.pose_from_passive(s.inputs, s.passive(mech.passive)), pose, atol=1e-12)
            w = Rotation.from_rotvec(s.joint_angles["beta1"] * x).apply(y)
            expected = signed_angle(pose @ z, w, pose @ x)
            assert math.remainder(s.joint_angles["delta1"] - expected, 2 * math.pi) == pytest.approx(0, abs=1e-12)


def test_joint_offsets_move_the_zero_of_the_readings_and_nothing_else():
    import tomllib

    from spherekin import solve
    from spherekin.mechanism import general_3rrr, mechanism_from_dict
    from spherekin.mechanism.io import dumps_mechanism

    g = general_3rrr().geometry
    plain = three_rrr(g.base_axes, g.elbow_axes_at_zero, g.platform_axes, g.distal_link_angles)
    offsets = {"gamma1": 1.0, "delta2": "-pi/2", "beta3": 0.25}
    moved = three_rrr(g.base_axes, g.elbow_axes_at_zero, g.platform_axes, g.distal_link_angles, joint_offsets=offsets)
    shift = {"gamma1": 1.0, "delta2": -np.pi / 2, "beta3": 0.25}
    # the same physical configuration reads (geometric angle) - offset
    for p, m in zip(plain.joints, moved.joints):
        assert m.reference_angle == pytest.approx(p.reference_angle - shift.get(p.name, 0.0), abs=1e-15)
    inputs = (0.3, -0.2, 0.5)
    a = solve(plain, inputs)
    b = solve(moved, (0.3, -0.2, 0.5 - 0.25))          # beta3's reading moved by its offset: the same actuators
    assert len(a.solutions) == len(b.solutions) == 8
    for sa in a.solutions:
        sb = min(b.solutions, key=lambda s: np.abs(s.platform_rotation - sa.platform_rotation).max())
        np.testing.assert_allclose(sb.platform_rotation, sa.platform_rotation, atol=1e-12)
        for n in a.unknowns:
            diff = sa.passive_angles[n] - sb.passive_angles[n] - shift.get(n, 0.0)
            assert abs(np.mod(diff + np.pi, 2 * np.pi) - np.pi) < 1e-10, n
    again = mechanism_from_dict(tomllib.loads(dumps_mechanism(moved)))
    assert [j.reference_angle for j in again.joints] == pytest.approx([j.reference_angle for j in moved.joints], abs=1e-15)
    assert "[joint_offsets]" not in dumps_mechanism(plain)
    with pytest.raises(ValueError, match="joint_offsets: unknown joint 'gamma4'"):
        three_rrr(g.base_axes, g.elbow_axes_at_zero, g.platform_axes, g.distal_link_angles, joint_offsets={"gamma4": 1})
