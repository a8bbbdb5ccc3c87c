"""Tests for spherekin.mechanism.presets: the example files, the presets' geometry, and the paper's
Gosselin equations (Section 2.1, spherekin/paper_gosselin.py) against the loops derived from axes.

Finding recorded here (for the verification issue):

* Loop 1 as printed, Rx(pi + b1) Z Rx(th2^1) Z ... Rx(pi/2 - b2) Z, AGREES with the derived loop
  (legs 1-2) factor by factor, with th2^1 = gamma1 - pi, th3^1 = delta1 - pi,
  th4^1 = pi/2 - delta2, th5^1 = pi - gamma2 in the preset's conventions.
* Eq. (5) AGREES: the derived loop 2 (legs 3-2) sees delta2 with an offset larger by pi/2 and
  gamma2 with the same offset: th4^2 = th4^1 + pi/2, th5^2 = th5^1.
* The text's relations theta_1^2 = 3pi/2 + beta_3, theta_6^2 = pi - beta_2 AGREE with the
  derived loop 2, but the final printed loop 2 places Rx(pi - beta_2) first and Rx(3pi/2 + beta_3)
  last: the two known factors are exchanged. The printed loop 2 is not satisfied at the true
  configurations (it coincides with the correct one only when beta_2 + beta_3 = -pi/2 mod 2 pi),
  and no choice of th2^2, th3^2 satisfies it given the true th4^1, th5^1. Geometrically the
  printed order is impossible: the shared unknown th5 (elbow of leg 2) would be adjacent to leg 3's
  actuator.
"""

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from spherekin.closure import ClosureLoop, Term
from spherekin.mechanism import PRESETS, gosselin, load_mechanism, preset
from spherekin.paper_gosselin import paper_gosselin_loops
from spherekin.core.rotations import normalized_closure
from conftest import wrap

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"



def factor_value(f, values):
    """The angle of a loop factor given unknown values by name (radians)."""
    return f.offset + f.sign * values[f.unknown.name] if isinstance(f, Term) else f


def closure_error(loop, values):
    angles = [factor_value(f, values) for f in loop.factors]
    return np.abs(normalized_closure(angles) - np.eye(3)).max()


# --------------------------------------------------------------------------- examples and presets

@pytest.mark.parametrize("name", sorted(PRESETS))
def test_example_file_equals_preset(name):
    a, b = preset(name), load_mechanism(EXAMPLES / f"{name}.toml")
    assert (a.name, a.kind, a.reference_leg, a.actuated, a.passive) == (b.name, b.kind, b.reference_leg,
                                                                        b.actuated, b.passive)
    assert [leg.name for leg in a.legs] == [leg.name for leg in b.legs]
    for ja, jb in zip(a.joints, b.joints):
        np.testing.assert_allclose(ja.axis, jb.axis, atol=1e-12)
        assert ja.reference_angle == pytest.approx(jb.reference_angle, abs=1e-12)
        assert (ja.actuated, ja.range) == (jb.actuated, jb.range)
    np.testing.assert_allclose(a.platform_reference_matrix, b.platform_reference_matrix, atol=1e-12)


def test_every_example_loads():
    files = sorted(EXAMPLES.glob("*.toml"))
    assert {f.stem for f in files} >= set(PRESETS)
    for f in files:
        mech = load_mechanism(f)
        ref = {j.name: j.reference_angle for j in mech.joints}
        assert max(mech.forward(ref).loop_residuals) < 1e-12  # the reference configuration is assembled


def angle_deg(p, q):
    return math.degrees(math.atan2(np.linalg.norm(np.cross(p, q)), np.dot(p, q)))


def test_preset_geometries_and_mobility():
    dof = {"gosselin": 3, "general_3rrr": 3, "four_bar": 1, "five_bar": 2}
    for name, mech in ((n, preset(n)) for n in PRESETS):
        n_joints = len(mech.joints)
        assert len(mech.actuated) == dof[name] == n_joints - 3 * (len(mech.legs) - 1)  # Gruebler, spherical
    g = gosselin().geometry
    for i in range(3):
        for j in range(i + 1, 3):
            assert angle_deg(g.base_axes[i], g.base_axes[j]) == pytest.approx(90)
            assert angle_deg(g.platform_axes[i], g.platform_axes[j]) == pytest.approx(90)
    assert all(a == pytest.approx(math.pi / 2) for a in g.proximal_link_angles + g.distal_link_angles)
    four = preset("four_bar")
    ax = {j.name: np.array(j.axis) for j in four.joints}
    assert [round(angle_deg(ax[p], ax[q]), 9) for p, q in ("AD", "AB", "BC", "DC")] == [80, 30, 70, 60]
    five = preset("five_bar")
    ax = {j.name: np.array(j.axis) for j in five.joints}
    assert [round(angle_deg(ax[p], ax[q]), 9) for p, q in ("AE", "AB", "BC", "CD", "DE")] == [60, 45, 60, 60, 45]
    assert round(math.degrees(preset("general_3rrr").geometry.proximal_link_angles[0]), 9) == 50


# --------------------------------------------------------------------------- the paper's Gosselin loops

BETAS = (0.3, -0.7, 1.1)


def model_loops(betas):
    mech = gosselin()
    return mech.loop_system(betas, {n: (-3.0, 3.0) for n in mech.passive}).loops


def test_gosselin_loops_have_the_papers_structure():
    l1, l2 = model_loops(BETAS)
    p1, p2 = paper_gosselin_loops(BETAS, loop2_form="offset")
    assert l1.n == p1.n == 6 and l2.n == p2.n == 6  # compact form: already normalized (Section 2.1)
    assert l1.names == ("gamma1", "delta1", "delta2", "gamma2")
    assert l2.names == ("gamma3", "delta3", "delta2", "gamma2")
    assert [lp.scalar_control_points().size for lp in (l1, l2)] == [81, 81]  # 162, as in the paper
    b1, b2, b3 = BETAS
    # loop 1: theta_1^1 = pi + beta_1, theta_6^1 = pi/2 - beta_2, as printed
    assert wrap(l1.factors[0] - (math.pi + b1)) == pytest.approx(0, abs=1e-14)
    assert wrap(l1.factors[5] - (math.pi / 2 - b2)) == pytest.approx(0, abs=1e-14)
    assert wrap(l1.factors[0] - p1.factors[0]) == pytest.approx(0, abs=1e-14)
    assert wrap(l1.factors[5] - p1.factors[5]) == pytest.approx(0, abs=1e-14)
    # loop 2: theta_1^2 = 3pi/2 + beta_3 and theta_6^2 = pi - beta_2 as in the text; the printed
    # equation has these two factors exchanged
    assert wrap(l2.factors[0] - (3 * math.pi / 2 + b3)) == pytest.approx(0, abs=1e-14)
    assert wrap(l2.factors[5] - (math.pi - b2)) == pytest.approx(0, abs=1e-14)
    assert wrap(l2.factors[0] - p2.factors[5]) == pytest.approx(0, abs=1e-14)
    assert wrap(l2.factors[5] - p2.factors[0]) == pytest.approx(0, abs=1e-14)
    assert abs(wrap(l2.factors[0] - p2.factors[0])) > 0.1
    # Eq. (5): th4^2 = th4^1 + pi/2 (delta2), th5^2 = th5^1 (gamma2)
    t41, t42, t51, t52 = l1.factors[3], l2.factors[3], l1.factors[4], l2.factors[4]
    assert t41.unknown is t42.unknown and t41.sign == t42.sign
    assert wrap(t42.offset - t41.offset - math.pi / 2) == pytest.approx(0, abs=1e-14)
    assert t51 == t52
    # passive unknowns: the paper's theta's are the model's readings shifted (signs: legs 1, 3 up, leg 2 down)
    expected = [(1, math.pi), (1, math.pi), (-1, math.pi / 2), (-1, math.pi)]  # (sign, offset mod 2 pi)
    for f, (sign, offset) in zip(l1.factors[1:5], expected):
        assert f.sign == sign and wrap(f.offset - offset) == pytest.approx(0, abs=1e-14)


def paper_values(l1, l2, angles):
    """The paper's six unknowns at the model's readings, through the model's factor terms."""
    keys1 = ("theta2_1", "theta3_1", "theta4_1", "theta5_1")
    out = {k: factor_value(f, angles) for k, f in zip(keys1, l1.factors[1:5])}
    out.update({k: factor_value(f, angles) for k, f in zip(("theta2_2", "theta3_2"), l2.factors[1:3])})
    return out


def test_paper_equations_at_true_configurations():
    """Random pose -> IK (all 8 working modes) -> the paper's loops evaluated at the true angles."""
    mech = gosselin()
    checked_printed = 0
    for seed in range(5):
        pose = Rotation.random(random_state=200 + seed).as_matrix()
        for sol in mech.inverse_kinematics(pose):
            l1, l2 = model_loops(sol.inputs)
            pv = paper_values(l1, l2, sol.joint_angles)
            for form in ("split", "offset"):
                p1, p2 = paper_gosselin_loops(sol.inputs, loop2_form=form)
                corrected = ClosureLoop([p2.factors[-1], *p2.factors[1:-1], p2.factors[0]])
                assert closure_error(p1, pv) < 1e-12          # loop 1 as printed holds
                assert closure_error(corrected, pv) < 1e-12   # loop 2 with theta_1^2, theta_6^2 as in the text
            b2, b3 = sol.inputs[1:]
            if abs(wrap(b2 + b3 + math.pi / 2)) < 0.3:
                continue  # near beta_2 + beta_3 = -pi/2 the exchanged factors coincide
            assert closure_error(p2, pv) > 1e-2                # loop 2 as printed fails
            checked_printed += 1
    assert checked_printed >= 24


def test_printed_loop2_cannot_close_with_any_free_unknowns():
    """With the true beta's and th4^1, th5^1, no (th2^2, th3^2) closes the printed loop 2."""
    mech = gosselin()
    for seed in (0, 2, 3):
        pose = Rotation.random(random_state=200 + seed).as_matrix()
        sol = mech.inverse_kinematics(pose)[0]
        l1, l2 = model_loops(sol.inputs)
        pv = paper_values(l1, l2, sol.joint_angles)
        p2 = paper_gosselin_loops(sol.inputs, loop2_form="offset")[1]
        corrected = ClosureLoop([p2.factors[-1], *p2.factors[1:-1], p2.factors[0]])

        def residual(t, loop):
            angles = [factor_value(f, {**pv, "theta2_2": t[0], "theta3_2": t[1]}) for f in loop.factors]
            return (normalized_closure(angles) - np.eye(3)).ravel()

        starts = np.random.default_rng(seed).uniform(-3, 3, (8, 2))
        best_printed = min(np.linalg.norm(least_squares(residual, s, args=(p2,)).fun) for s in starts)
        best_corrected = min(np.linalg.norm(least_squares(residual, s, args=(corrected,)).fun) for s in starts)
        assert best_printed > 1e-2 and best_corrected < 1e-10
