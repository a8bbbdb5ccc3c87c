"""Tests for spherekin.mechanism.model: loops derived from axes, round trips, Jacobians, bad input.

Independent references used here:
* poses and rotations from scipy.spatial.transform.Rotation (not the model's Rodrigues helper);
* spherical four-bar configurations from spherical trigonometry (two circles on the sphere);
* Gosselin-Angeles Jacobians of the 3-RRR: A = [(w_i x v_i)^T], B = diag(det[u_i, w_i, v_i]);
* the product of exponentials of each leg (platform pose along each leg), which is not used to
  build the loop equations: a loop's Eq. (2) residual must equal the mismatch of two leg poses.
"""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from spherekin.core import bernstein
from spherekin.mechanism import (
    SINGULARITY_TOL,
    Joint,
    Leg,
    SphericalMechanism,
    four_bar,
    five_bar,
    general_3rrr,
    gosselin,
    three_rrr,
)
from spherekin.core.rotations import normalization_conjugator
from conftest import rot, unit


CLOSURE_TOL = 1e-12   # the bound for loop equations at IK solutions and for the recovered pose




def random_assembled_3rrr(seed):
    """A random 3-RRR that assembles at a known (R_true, beta_true); returns (mechanism, R_true)."""
    rng = np.random.default_rng(seed)
    r_true = Rotation.random(random_state=seed).as_matrix()
    u, w0, v0, a2 = [], [], [], []
    for _ in range(3):
        ui = unit(rng.normal(size=3))
        wi0 = unit(np.cross(ui, rng.normal(size=3)) + rng.uniform(-1.5, 1.5) * ui)  # alpha1 in ~(0.6, 2.5)
        beta = rng.uniform(-np.pi, np.pi)
        wi = rot(beta * ui) @ wi0
        # v at angle alpha2 from w, with the elbow angle gamma (from u to v about w) away from the
        # serial singularities gamma = 0, pi, so that the leg is well inside its workspace
        alpha2, gamma = rng.uniform(0.5, 2.6), rng.choice([-1, 1]) * rng.uniform(0.5, 2.6)
        e1 = unit(ui - (ui @ wi) * wi)
        vi = math.cos(alpha2) * wi + math.sin(alpha2) * (math.cos(gamma) * e1 + math.sin(gamma) * np.cross(wi, e1))
        u.append(ui), w0.append(wi0), v0.append(r_true.T @ vi), a2.append(alpha2)
    leg = f"leg{seed % 3 + 1}"
    return three_rrr(u, w0, v0, a2, name=f"random {seed}", reference_leg=leg), r_true


def ranges_around(mech, angles, half_width=1.0):
    return {n: (angles[n] - half_width, angles[n] + half_width) for n in mech.passive}


def check_round_trip(mech, pose, sol, form="auto"):
    """Loops built by the model vanish at the IK passive angles; the pose is recovered."""
    angles = dict(sol.joint_angles)
    system = mech.loop_system(sol.inputs, ranges_around(mech, angles), form=form)
    x = system.to_unit(angles)
    assert np.all((x > 0) & (x < 1))
    worst = 0.0
    for loop, idx in zip(system.loops, system.loop_indices):
        xl = np.array([u.to_unit(angles[u.name]) for u in loop.unknowns])
        np.testing.assert_array_equal(xl, x[list(idx)])
        f = loop.closure_matrix(xl)
        worst = max(worst, np.abs(f - np.eye(3)).max())
        # the scalar equation of Eq. (10) in Bernstein form vanishes there too (relative to its scale)
        c = loop.scalar_control_points()
        assert abs(bernstein.evaluate(c, xl)) < 1e-12 * np.abs(c).max()
    recovered = mech.pose_from_passive(sol.inputs, system.to_angles(x))
    return worst, np.abs(recovered - pose).max()


# --------------------------------------------------------------------------- round trips

def test_round_trip_agile_eye_many_poses():
    mech = gosselin()
    worst = (0.0, 0.0)
    for seed in range(50):
        pose = Rotation.random(random_state=1000 + seed).as_matrix()
        sols = mech.inverse_kinematics(pose)
        assert len(sols) == 8  # every pose is reachable by the pi/2 geometry, 2 branches per leg
        assert len({s.working_mode for s in sols}) == 8
        for sol in sols:
            res = check_round_trip(mech, pose, sol)
            worst = (max(worst[0], res[0]), max(worst[1], res[1]))
    assert worst[0] < CLOSURE_TOL and worst[1] < CLOSURE_TOL, worst


@pytest.mark.parametrize("seed", range(30))
def test_round_trip_random_general_3rrr(seed):
    mech, r_true = random_assembled_3rrr(seed)
    rng = np.random.default_rng(50 + seed)
    tested = 0
    for _ in range(6):
        pose = rot(rng.normal(size=3) * 0.2) @ r_true
        for sol in mech.inverse_kinematics(pose):
            closure, pose_err = check_round_trip(mech, pose, sol)
            assert closure < CLOSURE_TOL and pose_err < CLOSURE_TOL, (closure, pose_err)
            tested += 1
    assert tested >= 8


def test_round_trip_doubled_form_and_conjugation():
    """The doubled form (n = 2m) closes at the same points; it is the compact form conjugated by Rx(pi/2)."""
    mech = gosselin()
    pose = Rotation.random(random_state=7).as_matrix()
    sol = mech.inverse_kinematics(pose)[3]
    for form in ("compact", "doubled"):
        closure, pose_err = check_round_trip(mech, pose, sol, form)
        assert closure < CLOSURE_TOL and pose_err < CLOSURE_TOL
    rng = np.random.default_rng(8)
    passive = {n: (-2.0, 2.5) for n in mech.passive}
    compact = mech.loop_system((0.3, -0.1, 0.7), passive, form="compact")
    doubled = mech.loop_system((0.3, -0.1, 0.7), passive, form="doubled")
    p = normalization_conjugator()
    for lc, ld in zip(compact.loops, doubled.loops):
        assert (lc.n, ld.n) == (6, 12) and lc.names == ld.names
        x = rng.uniform(0, 1, (20, len(lc.unknowns)))
        np.testing.assert_allclose(ld.closure_matrix(x), p @ lc.closure_matrix(x) @ p.T, atol=1e-13)


def four_bar_configuration(mech, crank, branch):
    """Geometric four-bar configuration at crank angle ``crank``: pose of the coupler (B, C).

    B = Rot(A, crank) B_ref; C is on the circle of radius angle(B, C) about B and of radius
    angle(D, C) about D (branch +-1 of the two intersections); the coupler pose maps the reference
    (B, C) frame to the new one.
    """
    a, b0, d, c0 = (np.array(mech.joint(n).axis) for n in "ABDC")
    b = rot(crank * a) @ b0
    ang = lambda p, q: math.atan2(np.linalg.norm(np.cross(p, q)), p @ q)  # noqa: E731
    rb, rd = ang(b0, c0), ang(d, c0)
    # c = x b + y d + z (b x d), with c.b = cos rb, c.d = cos rd, |c| = 1
    g = np.array([[1, b @ d], [b @ d, 1]])
    xy = np.linalg.solve(g, [math.cos(rb), math.cos(rd)])
    n = np.cross(b, d)
    z2 = (1 - xy @ g @ xy) / (n @ n)
    c = xy[0] * b + xy[1] * d + branch * math.sqrt(z2) * n
    frame = lambda p, q: np.column_stack([p, unit(np.cross(p, q)), np.cross(p, unit(np.cross(p, q)))])  # noqa
    return frame(b, c) @ frame(b0, c0).T


@pytest.mark.parametrize("crank", [0.3, 1.7, -2.4, 3.0])
def test_round_trip_four_bar_geometric(crank):
    mech = four_bar()
    for branch in (1, -1):
        pose = four_bar_configuration(mech, crank, branch)
        sols = mech.inverse_kinematics(pose)
        assert len(sols) == 1  # legs of 2 joints: one solution, and the pose must be on the curve
        assert math.remainder(sols[0].inputs[0] - crank, 2 * math.pi) == pytest.approx(0, abs=1e-12)
        closure, pose_err = check_round_trip(mech, pose, sols[0])
        assert closure < CLOSURE_TOL and pose_err < CLOSURE_TOL
    # a pose off the one-dimensional curve is not reachable
    assert mech.inverse_kinematics(rot([0.1, 0.2, 0.3]) @ pose) == ()


def test_round_trip_five_bar_from_pose_of_the_platform():
    mech = five_bar()
    rng = np.random.default_rng(3)
    a, b0, e, d0, c0 = (np.array(mech.joint(n).axis) for n in "ABEDC")
    for _ in range(5):
        # pose of the platform BC: turn the left leg (A then B), the right leg follows
        t1, t2 = rng.uniform(-0.5, 0.5, 2)
        pose = rot(t1 * a) @ rot(t2 * b0)
        sols = mech.inverse_kinematics(pose)
        assert len(sols) >= 1
        for sol in sols:
            assert sol.joint_angles["A"] == pytest.approx(t1, abs=1e-12)
            assert sol.joint_angles["B"] == pytest.approx(t2, abs=1e-12)
            closure, pose_err = check_round_trip(mech, pose, sol)
            assert closure < CLOSURE_TOL and pose_err < CLOSURE_TOL


# --------------------------------------------------------------------------- derived geometry

def test_loop_residual_equals_leg_pose_mismatch():
    """Away from closure, ||F_n - I|| of a loop equals ||R_up - R_ref||_F of the two leg poses (PoE)."""
    rng = np.random.default_rng(11)
    for mech in (gosselin(), general_3rrr(), four_bar(), five_bar(), random_assembled_3rrr(4)[0]):
        for _ in range(5):
            angles = {n: rng.uniform(-4, 4) for n in mech.joint_names}
            for form in ("auto", "doubled"):
                fr = mech.forward(angles, form=form)
                names = [leg.name for leg in mech.legs]
                for res, (up, down) in zip(fr.loop_residuals, fr.loop_legs):
                    diff = fr.leg_poses[names.index(up)] - fr.leg_poses[names.index(down)]
                    assert res == pytest.approx(np.linalg.norm(diff), abs=1e-12)


def test_polygon_sides_are_link_twists_base_and_platform_angles():
    mech = general_3rrr()
    g = mech.geometry
    ang = lambda p, q: math.degrees(math.atan2(np.linalg.norm(np.cross(p, q)), np.dot(p, q)))  # noqa: E731
    for loop in mech.loop_geometry:
        up, down = (int(name[-1]) - 1 for name in loop.legs)
        v = [g.platform_axes[up], g.platform_axes[down]]
        expected = [50, 75, ang(*v), 75, 50, ang(g.base_axes[down], g.base_axes[up])]
        np.testing.assert_allclose(np.degrees(loop.sides), expected, atol=1e-12)
        assert [vx.sign for vx in loop.vertices] == [1, 1, 1, -1, -1, -1]
        assert not loop.right_angled
    assert mech.link_twists()["leg2"] == pytest.approx((math.radians(50), math.radians(75)), abs=1e-14)


def test_loop_system_twists_say_which_z_stands_for_a_side():
    """Compact loops carry how far their sides are from pi/2 (the certificates widen by it); the
    doubled form's Z's are exact (None); a side 1e-14 off pi/2 is no longer snapped to a right angle."""
    x, y, z = np.eye(3)
    eye = gosselin()
    ranges = {n: (-3.0, 3.0) for n in eye.passive}
    assert eye.loop_system((0.1, 0.2, 0.3), ranges).twists == (0.0, 0.0)
    assert eye.loop_system((0.1, 0.2, 0.3), ranges, form="doubled").twists == (None, None)
    assert general_3rrr().loop_system((0.5, 0.6, 0.4), ranges).twists == (None, None)
    off = three_rrr([x, y, -z], [y, -z, x], [z, x, y], [math.pi / 2 + 1e-14] * 3)
    assert max(abs(s - math.pi / 2) for g in off.loop_geometry for s in g.sides) > 5e-15
    assert not any(g.right_angled for g in off.loop_geometry)
    assert off.loop_system((0.1, 0.2, 0.3), ranges).twists == (None, None)
    # within rounding of a right angle: compact, d the side's distance from pi/2
    near = three_rrr([x, y, -z], [y, -z, x], [z, x, y], [math.pi / 2 + 2e-16] * 3)
    twists = near.loop_system((0.1, 0.2, 0.3), ranges).twists
    sides = [max(abs(s - math.pi / 2) for s in g.sides) for g in near.loop_geometry]
    assert all(g.right_angled for g in near.loop_geometry) and list(twists) == sides


def test_loop_system_structure_and_shared_unknowns():
    mech = general_3rrr()
    system = mech.loop_system((0.5, 0.6, 0.4), {n: (-3.0, 3.0) for n in mech.passive})
    assert system.names == mech.passive == ("gamma1", "delta1", "gamma2", "delta2", "gamma3", "delta3")
    assert [lp.n for lp in system.loops] == [12, 12]  # doubled form: 2 factors per vertex, 6 vertices
    assert system.loop_legs == (("leg2", "leg1"), ("leg3", "leg1"))
    assert system.shared == ("gamma1", "delta1")
    l1, l2 = system.loops
    assert set(map(id, l1.unknowns)) & set(map(id, l2.unknowns)) == {id(system.unknown("gamma1")),
                                                                      id(system.unknown("delta1"))}
    assert [system.names[i] for i in system.loop_indices[1]] == list(l2.names)
    assert [lp.scalar_control_points().size for lp in system.loops] == [81, 81]
    four = four_bar().loop_system((0.2,), {n: (-1.0, 1.0) for n in "BCD"})
    assert len(four.loops) == 1 and four.names == ("B", "D", "C") and four.shared == ()
    five = five_bar()
    assert five.actuated == ("A", "E") and len(five.loop_system((0.1, 0.2), {n: (-1, 1) for n in "BCD"}).unknowns) == 3


def test_reference_angles_make_readings_not_displacements():
    """A mechanism with reference readings equals the one with zero readings, shifted."""
    base = four_bar()
    shift = {"A": 0.4, "B": -1.1, "C": 2.0, "D": 0.3}
    legs = tuple(Leg(leg.name, tuple(Joint(j.name, j.axis, j.actuated, None, shift[j.name]) for j in leg.joints))
                 for leg in base.legs)
    shifted = SphericalMechanism(legs, name="shifted")
    pose = four_bar_configuration(base, 1.0, 1)
    (s0,), (s1,) = base.inverse_kinematics(pose), shifted.inverse_kinematics(pose)
    for n in "ABCD":
        assert math.remainder(s1.joint_angles[n] - s0.joint_angles[n] - shift[n], 2 * math.pi) == pytest.approx(0, abs=1e-12)


def test_ik_respects_ranges():
    mech = three_rrr(*_gosselin_args(), joint_ranges={"beta1": (-0.5, 2.0), "gamma2": (0.0, 3.0)})
    pose = Rotation.random(random_state=5).as_matrix()
    sols = mech.inverse_kinematics(pose)
    kept = mech.inverse_kinematics(pose, only_in_range=True)
    assert 0 < len(kept) < len(sols) and all(s.in_range for s in kept)
    for s in sols:
        b1 = s.joint_angles["beta1"]
        assert -0.5 <= b1 < -0.5 + 2 * math.pi
        assert s.in_range == (b1 <= 2.0 and s.joint_angles["gamma2"] <= 3.0)


def _gosselin_args():
    x, y, z = np.eye(3)
    return [x, y, -z], [y, -z, x], [z, x, y], [math.pi / 2] * 3


# --------------------------------------------------------------------------- singularities

def gosselin_angeles(mech, angles):
    """Independent 3-RRR Jacobians: A = [(w_i x v_i)^T], B = diag(det[u_i, w_i, v_i])."""
    g = mech.geometry
    pose = mech.forward(angles).pose
    a, bdiag = [], []
    for i in range(3):
        u = np.array(g.base_axes[i])
        w = Rotation.from_rotvec(angles[f"beta{i + 1}"] * u).apply(g.elbow_axes_at_zero[i])
        v = pose @ g.platform_axes[i]
        a.append(np.cross(w, v))
        bdiag.append(np.linalg.det(np.array([u, w, v])))
    return np.array(a), np.array(bdiag)


def test_regular_configurations_agree_with_gosselin_angeles():
    mech = general_3rrr()
    for seed in range(5):
        pose = rot(np.random.default_rng(seed).normal(size=3) * 0.2)
        for sol in mech.inverse_kinematics(pose):
            rep = mech.singularity(sol.joint_angles)
            a, b = gosselin_angeles(mech, sol.joint_angles)
            assert rep.kind == "regular"
            assert rep.parallel_margin > 1e-3 and abs(np.linalg.det(a)) > 1e-4
            # the leg Jacobian [u, w, v] has det B_ii; the working mode is its sign
            assert sol.working_mode == tuple(int(np.sign(bi)) for bi in b)


def test_serial_singularity_leg_stretched():
    """Pose with v_1 at angle alpha1 + alpha2 from u_1 (leg 1 stretched): det[u1, w1, v1] = 0."""
    mech = general_3rrr()
    g = mech.geometry
    u1, v01 = np.array(g.base_axes[0]), np.array(g.platform_axes[0])
    target_angle = g.proximal_link_angles[0] + g.distal_link_angles[0]
    # rotate v_1^0 in the plane of (u1, v1^0) until its angle to u1 is alpha1 + alpha2
    axis = unit(np.cross(u1, v01))
    now = math.atan2(np.linalg.norm(np.cross(u1, v01)), u1 @ v01)
    pose = rot((target_angle - now) * axis)
    sols = mech.inverse_kinematics(pose)
    assert sols, "the stretched leg must still be reachable (double root)"
    for sol in sols:
        rep = mech.singularity(sol.joint_angles)
        _, b = gosselin_angeles(mech, sol.joint_angles)
        assert abs(b[0]) < 1e-7 and rep.serial and "leg1" in rep.serial_legs
        assert sol.working_mode[0] == 0


def test_agile_eye_actuator_free_when_v_equals_u():
    """v_1 = u_1: the actuator beta1 turns freely without moving the platform (serial singularity)."""
    mech = gosselin()
    pose = rot([0.0, math.pi / 2, 0.0])  # Ry(pi/2) maps v_1^0 = z to x = u_1
    np.testing.assert_allclose(pose @ [0, 0, 1], [1, 0, 0], atol=1e-15)
    sols = mech.inverse_kinematics(pose)
    assert sols
    assert all(mech.singularity(s.joint_angles).serial for s in sols)


def test_parallel_singularity_found_by_bisection_on_det_a():
    """Bisect det A (Gosselin-Angeles) along a path of poses, then classify the singular configuration."""
    mech = general_3rrr()
    mode = (1, 1, 1)

    def at(s):
        pose = rot([s, 0.0, 0.0])
        (sol,) = [q for q in mech.inverse_kinematics(pose) if q.working_mode == mode]
        return sol, np.linalg.det(gosselin_angeles(mech, sol.joint_angles)[0])

    grid = np.linspace(0.0, 2.0, 21)  # det A changes sign near s = 1.4 for this working mode
    dets = []
    for s in grid:
        try:
            dets.append(at(s)[1])
        except ValueError:
            dets.append(np.nan)
    k = next(i for i in range(20) if np.isfinite(dets[i]) and np.isfinite(dets[i + 1]) and dets[i] * dets[i + 1] < 0)
    lo, hi = grid[k], grid[k + 1]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if at(mid)[1] * dets[k] > 0:
            lo = mid
        else:
            hi = mid
    sol, det = at(lo)
    rep = mech.singularity(sol.joint_angles)
    assert abs(det) < 1e-12
    assert rep.parallel and not rep.serial and rep.parallel_margin < SINGULARITY_TOL
    near = mech.singularity(at(grid[k])[0].joint_angles)
    assert near.kind == "regular"


def test_four_bar_parallel_singularity_when_coupler_and_rocker_align():
    """Ground 60, crank 40, coupler 50, rocker 50 deg: at crank angle pi (B opposite D) B, C, D are coplanar."""
    a = np.array([0.0, 0.0, 1.0])
    polar = lambda p, az: np.array([math.sin(math.radians(p)) * math.cos(math.radians(az)),  # noqa: E731
                                    math.sin(math.radians(p)) * math.sin(math.radians(az)), math.cos(math.radians(p))])
    d, b = polar(60, 0), polar(40, 90)
    probe = SphericalMechanism((Leg("crank", (Joint("A", a, True), Joint("B", b))),
                                Leg("rocker", (Joint("D", d), Joint("C", [1.0, 0.0, 0.0])))), name="probe")
    # reference C from the geometric construction (angle(B, C) = angle(D, C) = 50 deg)
    g = np.array([[1, b @ d], [b @ d, 1]])
    xy = np.linalg.solve(g, [math.cos(math.radians(50))] * 2)
    n = np.cross(b, d)
    c = xy[0] * b + xy[1] * d + math.sqrt((1 - xy @ g @ xy) / (n @ n)) * n
    mech = SphericalMechanism((probe.legs[0], Leg("rocker", (Joint("D", d), Joint("C", c)))), name="4R")
    crank = math.pi / 2  # B_ref at azimuth 90 deg; +90 deg more puts B at azimuth 180, opposite D
    b_s = rot(crank * a) @ b
    assert math.degrees(math.acos(b_s @ d)) == pytest.approx(100.0)  # = coupler + rocker: stretched
    c_s = unit(b_s + d)  # C halfway on the arc from B to D (50 deg from each)
    frame = lambda p, q: np.column_stack([p, unit(np.cross(p, q)), np.cross(p, unit(np.cross(p, q)))])  # noqa
    pose = frame(b_s, c_s) @ frame(b, c).T
    (sol,) = mech.inverse_kinematics(pose)
    assert sol.inputs[0] == pytest.approx(crank, abs=1e-12)
    rep = mech.singularity(sol.joint_angles)
    assert rep.kind == "parallel" and rep.parallel_margin < 1e-12
    (near,) = mech.inverse_kinematics(four_bar_configuration(mech, crank - 0.3, 1))
    assert mech.singularity(near.joint_angles).kind == "regular"


# --------------------------------------------------------------------------- bad input

def _mech():
    return gosselin()


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: _mech().loop_system((0.1, 0.2)), r"inputs: expected 3 actuator angles"),
        (lambda: _mech().loop_system((0.1, 0.2, "x")), r"inputs \(beta3\)"),
        (lambda: _mech().loop_system((0.1, 0.2, 0.3)), r"'gamma1' has an unlimited range \(the full circle\)"),
        (lambda: _mech().loop_system((0, 0, 0), {"beta1": (0, 1)}), r"'beta1' is not a passive joint"),
        (lambda: _mech().loop_system((0, 0, 0), {"gamma1": (-4, 3)}), r"passive_ranges\['gamma1'\]: expected a width"),
        (lambda: _mech().loop_system((0, 0, 0), {"gamma1": (1, 1)}), r"lo < hi"),
        (lambda: _mech().loop_system((0, 0, 0), {n: (-1, 1) for n in _mech().passive}, form="tight"), r"form: expected one of"),
        (lambda: general_3rrr().loop_system((0, 0, 0), {n: (-1, 1) for n in _mech().passive}, form="compact"),
         r"'compact' needs every side"),
        (lambda: _mech().inverse_kinematics(np.eye(3) * 2), r"R: expected a rotation matrix"),
        (lambda: _mech().inverse_kinematics(np.eye(2)), r"R: expected a finite 3x3"),
        (lambda: _mech().forward({"beta1": 0.0}), r"joint_angles: missing angle"),
        (lambda: _mech().forward({"nope": 0.0}), r"joint_angles: unknown joint name"),
        (lambda: _mech().pose_from_passive((0, 0, 0), {"gamma2": 0.0}), r"passive_angles: missing angle\(s\) for \['delta2'\]"),
        (lambda: _mech().singularity({n: 0.0 for n in _mech().joint_names}, tol=-1), r"tol: expected a positive"),
        (lambda: Joint("a", [0, 0, 0]), r"axis: expected a unit vector, got the zero vector"),
        (lambda: Joint("a", [0, 0, 2]), r"axis: expected a unit vector \(norm 1"),
        (lambda: Joint("a", [0, 1]), r"axis: expected a unit vector of 3 components"),
        (lambda: Joint("a", [0, 0, 1], actuated="yes"), r"actuated: expected true or false"),
        (lambda: Joint("a", [0, 0, 1], range=(2, 1)), r"range: expected lo < hi"),
        (lambda: Joint("", [0, 0, 1]), r"name: expected a non-empty name"),
        (lambda: Leg("l", (Joint("a", [0, 0, 1]), Joint("b", [0, 0, -1]))), r"consecutive axes of a leg are parallel"),
        (lambda: SphericalMechanism((Leg("l", (Joint("a", [0, 0, 1], True),)),)), r"at least 2 legs"),
        (lambda: SphericalMechanism((Leg("l", (Joint("a", [0, 0, 1], True),)), Leg("l", (Joint("b", [1, 0, 0]),)))),
         r"legs\[1\].name: leg name 'l' is used twice"),
        (lambda: SphericalMechanism((Leg("l", (Joint("a", [0, 0, 1], True),)), Leg("m", (Joint("a", [1, 0, 0]),)))),
         r"joint name 'a' is used twice"),
        (lambda: SphericalMechanism((Leg("l", (Joint("a", [0, 0, 1]), Joint("b", [1, 0, 0]))),
                                     Leg("m", (Joint("c", [0, 1, 0]), Joint("d", [1, 0, 0]))))),
         r"at least one actuated joint"),
        (lambda: SphericalMechanism((Leg("l", (Joint("a", [0, 0, 1], True), Joint("b", [1, 0, 0]), Joint("e", [0, 1, 0]))),
                                     Leg("m", (Joint("c", [0, 1, 0]), Joint("d", [1, 0, 0]))))),
         r"which fix at most that many passive joints, but 4 joints are passive"),
        (lambda: SphericalMechanism(four_bar().legs, reference_leg="coupler"), r"reference_leg: expected one of"),
        (lambda: SphericalMechanism(four_bar().legs, platform_reference=np.ones((3, 3))), r"platform_reference"),
        (lambda: SphericalMechanism((Leg("l", (Joint("a", [0, 0, 1], True), Joint("b", [1, 0, 0]))),
                                     Leg("m", (Joint("c", [0, 1e-12, 1]), Joint("d", [0, 1, 0]))))),
         r"parallel within 1e-09 but not equal"),
    ],
)
def test_bad_input_names_the_problem(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_coaxial_base_joints_are_allowed():
    """A side of twist 0 on the base (coaxial actuators): the loop still closes at IK solutions."""
    z = [0.0, 0.0, 1.0]
    w0 = [[1.0, 0.0, 0.0], [-0.5, math.sqrt(3) / 2, 0.0], [-0.5, -math.sqrt(3) / 2, 0.0]]
    v0 = [unit([math.cos(t), math.sin(t), 0.6]) for t in (0.3, 2.4, 4.5)]
    mech = three_rrr([z, z, z], w0, v0, [1.2, 1.2, 1.2], name="coaxial")
    assert mech.loop_geometry[0].sides[-1] == 0.0
    pose = rot([0.05, -0.1, 0.4]) @ mech.platform_reference_matrix
    sols = mech.inverse_kinematics(pose)
    assert sols
    for sol in sols:
        closure, pose_err = check_round_trip(mech, pose, sol)
        assert closure < CLOSURE_TOL and pose_err < CLOSURE_TOL


def test_sphere_point_meets_both_angles_on_the_asked_side():
    """chains.sphere_point against its definition: unit length, the two angles, the side of p x q;
    None when the circles miss (checked by arccos of dot products, not by the formula)."""
    from spherekin.mechanism.chains import sphere_point

    rng = np.random.default_rng(11)
    hits = 0
    for _ in range(200):
        p, q = (v / np.linalg.norm(v) for v in rng.normal(size=(2, 3)))
        ang_p, ang_q = rng.uniform(0.05, math.pi - 0.05, 2)
        branch = rng.choice([-1.0, 1.0])
        c = sphere_point(p, q, ang_p, ang_q, branch)
        gap = math.acos(np.clip(p @ q, -1, 1))
        meet = abs(ang_p - ang_q) <= gap <= min(ang_p + ang_q, 2 * math.pi - ang_p - ang_q)
        if c is None:
            assert not meet
            continue
        hits += 1
        assert abs(np.linalg.norm(c) - 1) < 1e-9
        assert abs(math.acos(np.clip(c @ p, -1, 1)) - ang_p) < 1e-6
        assert abs(math.acos(np.clip(c @ q, -1, 1)) - ang_q) < 1e-6
        assert branch * (c @ np.cross(p, q)) >= -1e-12
    assert hits > 50


def _leg_pose_jacobian_kp(mech, joints, h=1e-6):
    """K_p by central differences of the leg poses (mechanism.forward), independent of mechanism.jacobians:
    column j = vee(d(R_up R_down^T)/d theta_j) per loop."""
    def loop_products(angles):
        res = mech.forward(angles)
        poses = dict(zip([leg.name for leg in mech.legs], res.leg_poses))
        return [poses[up] @ poses[down].T for up, down in res.loop_legs]

    base = loop_products(joints)
    cols = []
    for name in mech.passive:
        plus, minus = dict(joints), dict(joints)
        plus[name] += h
        minus[name] -= h
        col = []
        for p, m, b in zip(loop_products(plus), loop_products(minus), base):
            w = (p - m) / (2 * h) @ b.T
            col += [w[2, 1], w[0, 2], w[1, 0]]
        cols.append(col)
    return np.array(cols).T


def test_parallel_measure_is_the_condition_of_an_independent_jacobian():
    from spherekin import compile as compile_problem
    from spherekin.mechanism import general_3rrr

    mech = general_3rrr()
    rows = np.array([[0.3, -0.2, 0.5]])
    reports = compile_problem(mech).solve_many(rows)
    for sol in reports[0].solutions[:4]:
        joints = {**dict(zip(mech.actuated, rows[0])), **dict(zip(reports[0].unknowns, sol.angles))}
        s = np.linalg.svd(_leg_pose_jacobian_kp(mech, joints), compute_uv=False)
        assert mech.parallel_measure(joints) == pytest.approx(s[-1] / s[0], rel=1e-6)


def test_factor_specs_are_the_terms_of_the_loop_system():
    """Each factor of Eq. (2) is one FactorSpec (offset, joint or None, sign) at the geometry level;
    the loop system turns the passive ones into Terms with the same offset, sign and joint, and
    the actuated ones into known angles offset + sign * input."""
    from spherekin.closure import Term
    from spherekin.mechanism import FactorSpec

    for mech in (gosselin(), general_3rrr()):
        inputs = (0.3, -0.2, 0.5)
        system = mech.loop_system(inputs, {n: (-3.0, 3.0) for n in mech.passive})
        known = dict(zip(mech.actuated, inputs))
        for g, loop in zip(mech.loop_geometry, system.loops):
            specs = g.factor_specs()
            assert all(isinstance(s, FactorSpec) for s in specs) and len(specs) == len(loop.factors)
            for spec, factor in zip(specs, loop.factors):
                if spec.joint is None or spec.joint in known:
                    want = spec.offset + (spec.sign * known[spec.joint] if spec.joint else 0.0)
                    assert not isinstance(factor, Term)
                    assert math.remainder(float(factor) - want, 2 * math.pi) == pytest.approx(0.0, abs=1e-12)
                else:
                    assert (factor.unknown.name, factor.offset, factor.sign) == (spec.joint, spec.offset, spec.sign)


def test_check_input_rows_refuses_exactly_the_rows_check_inputs_refuses():
    """The array check of many rows against check_inputs row by row: range ends (widened by
    RANGE_TOL), just beyond them, a full turn, NaN, infinity; the first bad row is named."""
    import dataclasses
    import math

    from spherekin.core.angles import MAX_INPUT_ANGLE, RANGE_TOL
    from spherekin.mechanism import four_bar

    mech = four_bar()
    mech = dataclasses.replace(mech, legs=(dataclasses.replace(mech.legs[0], joints=(
        dataclasses.replace(mech.legs[0].joints[0], range=(-0.5, 1.0)),) + mech.legs[0].joints[1:]),)
        + mech.legs[1:])
    values = [-0.5, 1.0, -0.5 - 0.5 * RANGE_TOL, 1.0 + 0.5 * RANGE_TOL, -0.5 - 2 * RANGE_TOL, 1.0 + 2 * RANGE_TOL,
              0.3, math.nan, math.inf, MAX_INPUT_ANGLE + 1.0]
    for v in values:
        try:
            mech.check_inputs([v])
            alone = True
        except ValueError:
            alone = False
        if alone:
            assert mech.check_input_rows([[0.3], [v]]).tolist() == [[0.3], [v]]
        else:
            with pytest.raises(ValueError, match=r"^row 1: inputs \(A\)"):
                mech.check_input_rows([[0.3], [v], [math.nan]])


def test_loop_system_free_inputs_become_unknowns():
    """loop_system(free={name: (lo, hi)}): the actuated joint is an unknown after the passive ones, and the
    loop's closure matrix at its reading equals the closure with that reading substituted (matrix products of
    both, at the same passive readings); a passive or unknown name is refused."""
    from spherekin.mechanism import load_mechanism

    mech = load_mechanism(__file__.rsplit("/tests/", 1)[0] + "/examples/five_bar.toml")
    ranges = {n: (-1.5, 1.5) for n in mech.loop_unknowns}
    free = mech.loop_system([0.0, 0.0], ranges, free={"A": (-1.0, 1.0)})
    assert free.names == (*mech.loop_unknowns, "A")
    passive = {"B": 0.4, "D": -0.3, "C": 1.1}
    fixed = mech.loop_system([0.3, 0.2], ranges)
    x_fixed = fixed.to_unit(passive)
    x_free = free.to_unit({**passive, "A": 0.3})
    with_e = mech.loop_system([0.0, 0.2], ranges, free={"A": (-1.0, 1.0)})
    for lf, lx, idf, idx in zip(with_e.loops, fixed.loops, with_e.loop_indices, fixed.loop_indices):
        np.testing.assert_allclose(lf.closure_matrix(x_free[list(idf)]), lx.closure_matrix(x_fixed[list(idx)]),
                                   atol=1e-12)
    with pytest.raises(ValueError, match="free: 'B' is not an actuated joint"):
        mech.loop_system([0.0, 0.0], ranges, free={"B": (-1.0, 1.0)})
