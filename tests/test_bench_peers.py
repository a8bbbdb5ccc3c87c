"""The independent pieces of benchmarks/bench_peers.py, checked against closed forms (fast; phc parts skip without phc).

Poses come from the inverse kinematics (pose -> every joint reading -> inputs), so every check has
an exact answer: the quaternion quadrics and the sin/cos loop system vanish there, and the
degree-8 eigen solver must return the pose among its roots.
"""

import math

import numpy as np
import pytest

from references import peers_closed_form as pcf
from benchmarks import peers_phc as pphc
from spherekin.closure import ClosureLoop, Unknown
from spherekin.mechanism import axis_rotation, general_3rrr, gosselin, three_rrr

needs_phc = pytest.mark.skipif(not pphc.phc_available(), reason="phc (PHCpack) not installed")

#: Residual of an exact equation evaluated in floating point at an IK-generated pose.
EXACT_TOL = 1e-12


def _random_rotation(rng):
    q = rng.normal(size=4)
    return pcf.quaternion_rotation(q / np.linalg.norm(q))


def _random_mech(rng):
    while True:
        u, w0, v0 = ([v / np.linalg.norm(v) for v in rng.normal(size=(3, 3))] for _ in range(3))
        a2 = [float(np.arccos(np.clip(w @ v, -1, 1))) for w, v in zip(w0, v0)]
        if min(a2) < 0.3 or max(a2) > math.pi - 0.3:
            continue
        try:
            return three_rrr(u, w0, v0, a2)
        except ValueError:
            continue


def _cases():
    """(mechanism, pose, one IK solution) for the agile eye, the general preset and a random 3-RRR."""
    rng = np.random.default_rng(7)
    out = []
    for mech in (gosselin(), general_3rrr(), _random_mech(rng)):
        while True:
            rot = _random_rotation(rng)
            sols = mech.inverse_kinematics(rot)
            if sols:
                out.append((mech, rot, sols[int(rng.integers(len(sols)))]))
                break
    return out


CASES = _cases()
IDS = ["gosselin", "general_3rrr", "random"]


def test_quaternion_rotation_is_rodrigues():
    rng = np.random.default_rng(1)
    for _ in range(5):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        t = rng.uniform(-math.pi, math.pi)
        q = np.concatenate([[math.cos(t / 2)], math.sin(t / 2) * axis])
        assert np.allclose(pcf.quaternion_rotation(3.0 * q), axis_rotation(axis, t), atol=1e-14)
        assert np.allclose(pcf.quaternion_rotation(pcf.rotation_quaternion(axis_rotation(axis, t))),
                           axis_rotation(axis, t), atol=1e-14)


def test_leg_quadrics_expand_the_leg_constraint():
    """q^T A_i q = |q|^2 (w_i . R(q) v_i^0 - cos alpha2_i) for any q (not only unit ones)."""
    mech = general_3rrr()
    geom = pcf.geometry_of(mech)
    u, w0, v0, a2 = geom
    rng = np.random.default_rng(2)
    inputs = rng.uniform(-3, 3, size=3)
    quad = pcf.leg_quadrics(geom, inputs)
    for _ in range(5):
        q = rng.normal(size=4)
        rot = pcf.quaternion_rotation(q)
        for i in range(3):
            w = axis_rotation(u[i], inputs[i]) @ w0[i]
            assert q @ quad[i] @ q == pytest.approx((q @ q) * (w @ rot @ v0[i] - math.cos(a2[i])), abs=1e-12)


@pytest.mark.parametrize("mech, rot, ik", CASES, ids=IDS)
def test_quaternion_system_vanishes_at_ik_pose(mech, rot, ik):
    geom = pcf.geometry_of(mech)
    q = pcf.rotation_quaternion(rot)
    polys, names = pphc.quaternion_system(pcf.leg_quadrics(geom, ik.inputs))
    assert names == ["q0", "qx", "qy", "qz"] and len(polys) == 4
    for p in polys:
        assert abs(sum(c * np.prod(q ** np.array(e)) for e, c in p.items())) < EXACT_TOL
    assert pcf.leg_residuals(geom, ik.inputs, rot).max() < EXACT_TOL


@pytest.mark.parametrize("mech, rot, ik", CASES, ids=IDS)
def test_sincos_system_is_square_and_vanishes_at_ik_angles(mech, rot, ik):
    system = mech.loop_system(ik.inputs, {n: (-1.0, 1.0) for n in mech.passive})
    polys, names, exprs, cs = pphc.sincos_system(system.loops, system.names)
    assert len(exprs) == len(polys) == len(names) == 12   # 2 loops x 3 entries + 6 circles, 6 angles x (c, s)
    theta = [ik.joint_angles[n] for n in system.names]
    point = np.array([f(t) for t in theta for f in (math.cos, math.sin)])     # c1, s1, c2, s2, ...
    values = [sum(c * np.prod(point ** np.array(m)) for m, c in p.items()) for p in polys]
    assert max(abs(v) for v in values) < EXACT_TOL
    # the sympy expressions are the same polynomials as the dicts written for phc
    subs = {x: v for pair, (c, s) in zip(cs, point.reshape(-1, 2)) for x, v in zip(pair, (c, s))}
    for e, v in zip(exprs[:3], values[:3]):
        assert float(e.xreplace(subs)) == pytest.approx(v, abs=EXACT_TOL)
    # each loop entry is linear in (c_k, s_k) of each of its 4 unknowns
    assert all(max(sum(m) for m in p) <= 4 for p in polys[:6])
    assert pphc.loop_closes(system.loops, system.names, np.array(theta))
    assert np.allclose(mech.pose_from_passive(ik.inputs, dict(zip(system.names, theta))), rot, atol=1e-12)


def test_lower_triangle_also_vanishes_at_a_spurious_rotation():
    """Rx(theta) Z^4 = Rx(theta): its lower triangle vanishes at theta = pi (diag(1,-1,-1)), but it is no closure."""
    t = Unknown("t", -1.0, 1.0)
    loop = ClosureLoop([t, 0.0, 0.0, 0.0])
    polys, names, exprs, cs = pphc.sincos_system([loop], ["t"])
    c, s = cs[0]
    for theta in (0.0, math.pi):
        vals = {c: math.cos(theta), s: math.sin(theta)}
        assert all(abs(float(e.xreplace(vals))) < EXACT_TOL for e in exprs)
    assert pphc.loop_closes([loop], ["t"], np.array([0.0]))
    assert not pphc.loop_closes([loop], ["t"], np.array([math.pi]))


@pytest.mark.parametrize("mech, rot, ik", CASES, ids=IDS)
def test_degree8_solver_recovers_the_ik_pose(mech, rot, ik):
    geom = pcf.geometry_of(mech)
    roots, n_roots = pcf.solve_quadrics(pcf.leg_quadrics(geom, ik.inputs))
    assert n_roots == 8 and 1 <= len(roots) <= 8
    poses = [pcf.quaternion_rotation(q) for q in roots]
    assert min(np.abs(p - rot).max() for p in poses) < 1e-9
    for p in poses:
        assert pcf.leg_residuals(geom, ik.inputs, p).max() < 1e-12
        assert np.allclose(p @ p.T, np.eye(3), atol=1e-12) and np.linalg.det(p) == pytest.approx(1.0)


def test_gosselin_has_eight_real_poses():
    """The agile eye at the paper's inputs: 8 real assembly modes (4 of them serial-singular)."""
    poses = pcf.direct_kinematics(pcf.geometry_of(gosselin()), (0.3, -0.2, 0.5))
    assert len(poses) == 8


def test_phc_text_and_parser():
    text = pphc.system_to_phc([{(2, 0): 1.0, (0, 2): 1.0, (0, 0): -1.0}, {(1, 0): 1.0, (0, 1): -1.0}], ["x", "y"])
    assert text.splitlines()[0] == "2" and "*x^2" in text and text.count(";") == 2
    with pytest.raises(ValueError, match="imaginary unit"):
        pphc.system_to_phc([{(1,): 1.0}], ["i1"])
    canned = """THE SOLUTIONS :
2 2
===========================================================================
solution 1 :
t :  1.00000000000000E+00   0.00000000000000E+00
m : 1
the solution for t :
 x :  7.07106781186548E-01   2.94545607917864E-90
 y :  7.07106781186548E-01   0.00000000000000E+00
== err :  1.570E-16 = rco :  4.142E-01 = res :  2.220E-16 ==
solution 2 :
t :  1.00000000000000E+00   0.00000000000000E+00
m : 1
the solution for t :
 x : -7.07106781186548E-01   5.00000000000000E-01
 y : -7.07106781186548E-01   0.00000000000000E+00
== err :  1.570E-16 = rco :  4.142E-01 = res :  2.220E-16 = real regular ==
"""
    roots = pphc.parse_solutions(canned, ["x", "y"])
    assert len(roots) == 2 and roots[0].is_real() and not roots[1].is_real()
    assert roots[1].kind == "real regular" and roots[0].values[0].real == pytest.approx(2 ** -0.5)


@needs_phc
def test_phc_quaternion_system_finds_the_closed_form_poses():
    mech, rot, ik = CASES[1]
    geom = pcf.geometry_of(mech)
    polys, names = pphc.quaternion_system(pcf.leg_quadrics(geom, ik.inputs))
    run = pphc.run_phc(polys, names, timeout=60)
    assert len(run.roots) == 16 and run.paths == 16
    poses = [pcf.quaternion_rotation(r.values.real) for r in run.roots if r.is_real()]
    closed = pcf.direct_kinematics(geom, ik.inputs)
    assert len(poses) == 2 * len(closed)                          # q and -q
    for p in poses:
        assert min(np.abs(p - c).max() for c in closed) < 1e-9
    assert min(np.abs(p - rot).max() for p in poses) < 1e-9
