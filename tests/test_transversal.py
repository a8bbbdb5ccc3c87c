"""Tests for spherekin.trust.transversal (the transversal closure system and its interval enclosures).

Every enclosure, fast and reference (``IMPLS``), must contain the exact values: F from
ClosureLoop-independent 40-digit mpmath products of the defining matrices, J from central finite
differences of them (tests/loop_system_cases.py); the fast batch form must agree with the
one-box form.
"""

from dataclasses import replace

import numpy as np
import pytest
from mpmath import mpf

from spherekin.mechanism import general_3rrr, gosselin
from spherekin.trust.transversal import (ANGLE_TOLERANCE, enclose_transversal, interval_transversal,
                                   interval_transversal_reference, transversal_equations)
from conftest import rot
from loop_system_cases import (FLOAT_REF_TOL, FD_STEP, FD_TOL, POINT_WIDTH, IMPLS, MECHS, system_at, theta_of, poses, reference_entries, mp_entries, mp_jacobian, contains)


@pytest.mark.parametrize("impl", sorted(IMPLS))
@pytest.mark.parametrize("name", sorted(MECHS))
def test_interval_f_and_j_enclose_float_values_in_a_box(name, impl):
    enclose = IMPLS[impl]["interval_transversal"]
    mech = MECHS[name]()
    rng = np.random.default_rng(5)
    sol = mech.inverse_kinematics(poses(name, 1, seed=21)[0])[1]
    system = system_at(mech, sol)
    # a box around a root and a box around an arbitrary point
    for centre, radius in ((theta_of(system, sol), 1e-2), (theta_of(system, sol) + rng.uniform(-0.5, 0.5, 6), 5e-2)):
        box = np.column_stack([centre - radius, centre + radius])
        f_box, j_box = enclose(system, box)
        for _ in range(20):
            p = rng.uniform(box[:, 0] + FD_STEP, box[:, 1] - FD_STEP)
            f_ref = reference_entries(system, p)
            assert all(contains(iv_, v, FLOAT_REF_TOL) for iv_, v in zip(f_box, f_ref))
            for k in range(len(p)):
                step = np.zeros(len(p))
                step[k] = FD_STEP
                fd = (reference_entries(system, p + step) - reference_entries(system, p - step)) / (2 * FD_STEP)
                assert all(contains(j_box[e, k], fd[e], FD_TOL) for e in range(len(fd))), (k, fd)
        # the float routine agrees with the references too
        f_float, j_float = transversal_equations(system, centre)
        np.testing.assert_allclose(f_float, reference_entries(system, centre), atol=FLOAT_REF_TOL)
        assert all(contains(j_box[e, k], j_float[e, k]) for e in range(6) for k in range(6))


@pytest.mark.parametrize("name", sorted(MECHS))
def test_fast_box_enclosures_contain_exact_values(name):
    """Exact (40-50 digit) F and J at points of a box lie in the fast enclosures over the box, no slack."""
    mech = MECHS[name]()
    rng = np.random.default_rng(15)
    sol = mech.inverse_kinematics(poses(name, 1, seed=22)[0])[3]
    system = system_at(mech, sol)
    centre, radius = theta_of(system, sol) + rng.uniform(-0.2, 0.2, 6), 1e-3
    box = np.column_stack([centre - radius, centre + radius])
    f_box, j_box = enclose_transversal(system, box)
    for p in [box[:, 0], box[:, 1], centre] + [rng.uniform(box[:, 0], box[:, 1]) for _ in range(4)]:
        for e, v in enumerate(mp_entries(system, p)):
            assert mpf(f_box[0, e]) <= v <= mpf(f_box[1, e])
        for e, row in enumerate(mp_jacobian(system, p)):
            for k, v in enumerate(row):
                assert mpf(j_box[0, e, k]) <= v <= mpf(j_box[1, e, k]), (e, k)


@pytest.mark.parametrize("impl", sorted(IMPLS))
@pytest.mark.parametrize("name", sorted(MECHS))
def test_point_enclosure_contains_40_digit_value(name, impl):
    """At a point (no angle tolerance) the interval is ulp-tight and contains the 40-digit value."""
    enclose = IMPLS[impl]["interval_transversal"]
    mech = MECHS[name]()
    rng = np.random.default_rng(8)
    sol = mech.inverse_kinematics(poses(name, 1, seed=31)[0])[6]
    system = system_at(mech, sol)
    for _ in range(5):
        theta = theta_of(system, sol) + rng.uniform(-0.3, 0.3, 6)
        f_pt, j_pt = enclose(system, np.column_stack([theta, theta]), angle_tolerance=0.0)
        exact = mp_entries(system, theta)
        for iv_, v in zip(f_pt, exact):
            assert contains(iv_, v)
            assert mpf(iv_.b) - mpf(iv_.a) < POINT_WIDTH[impl]
        for row_iv, row in zip(j_pt, mp_jacobian(system, theta)):
            assert all(contains(iv_, v) for iv_, v in zip(row_iv, row))


@pytest.mark.parametrize("impl", sorted(IMPLS))
def test_angle_tolerance_encloses_perturbed_constants(impl):
    """With the default tolerance, F(y) encloses F of the system whose constant angles moved by < tol."""
    enclose = IMPLS[impl]["interval_transversal"]
    mech = general_3rrr()
    sol = mech.inverse_kinematics(rot([0.2, 0.1, 0.0]))[4]
    system = system_at(mech, sol)
    theta = theta_of(system, sol)
    n_const = sum(loop.n for loop in system.loops)
    point = np.column_stack([theta, theta])
    wide, _ = enclose(system, point, jacobian=False)
    tight, _ = enclose(system, point, angle_tolerance=0.0, jacobian=False)
    rng = np.random.default_rng(9)
    for shift in (np.full(n_const, 0.9 * ANGLE_TOLERANCE), rng.uniform(-0.9, 0.9, n_const) * ANGLE_TOLERANCE):
        moved = mp_entries(system, theta, shifts=iter(shift))
        assert all(contains(iv_, v) for iv_, v in zip(wide, moved))
    moved = mp_entries(system, theta, shifts=iter(np.full(n_const, 0.9 * ANGLE_TOLERANCE)))
    assert not all(contains(iv_, v) for iv_, v in zip(tight, moved))  # the tolerance is what covers them


@pytest.mark.parametrize("impl", sorted(IMPLS))
def test_compact_form_twists_are_enclosed_off_the_right_angle(impl):
    """The compact form's Z's are link twists (LoopSystem.twists): F and J enclose the system whose
    every Z turns by pi/2 + eps, |eps| <= d + tol, and without the widening they do not."""
    enclose = IMPLS[impl]["interval_transversal"]
    mech = gosselin()
    sol = mech.inverse_kinematics(rot([0.3, -0.2, 0.5]))[1]
    system = system_at(mech, sol)
    assert system.twists == (0.0, 0.0)                       # the agile eye's right angles, compact form
    theta = theta_of(system, sol)
    n_z = sum(len(loop.factors) for loop in system.loops)
    rng = np.random.default_rng(12)
    point = np.column_stack([theta, theta])
    wide, _ = enclose(system, point, jacobian=False)
    for eps in (np.full(n_z, 0.9 * ANGLE_TOLERANCE), -np.full(n_z, 0.9 * ANGLE_TOLERANCE),
                rng.choice([-0.9, 0.9], n_z) * ANGLE_TOLERANCE):
        moved = mp_entries(system, theta, twist_shifts=iter(eps))
        assert all(contains(iv_, v) for iv_, v in zip(wide, moved))
    # a snapped side d off pi/2 (no angle tolerance): covered by d alone; exact Z's (None) cover nothing
    eps = rng.choice([-0.9, 0.9], n_z) * 1e-14
    moved = mp_entries(system, theta, twist_shifts=iter(eps))
    snapped, _ = enclose(replace(system, twists=(1e-14, 1e-14)), point, angle_tolerance=0.0, jacobian=False)
    assert all(contains(iv_, v) for iv_, v in zip(snapped, moved))
    exact, _ = enclose(replace(system, twists=(None, None)), point, angle_tolerance=0.0, jacobian=False)
    assert not all(contains(iv_, v) for iv_, v in zip(exact, moved))
    # J at the point, the Z's turned: inside with the widening, not without
    j_turned = mp_jacobian(system, theta, twist_shifts=list(eps))
    _, j_snapped = enclose(replace(system, twists=(1e-14, 1e-14)), point, angle_tolerance=0.0)
    assert all(contains(j_snapped[e, k], v) for e, row in enumerate(j_turned) for k, v in enumerate(row))
    _, j_exact = enclose(replace(system, twists=(None, None)), point, angle_tolerance=0.0)
    assert not all(contains(j_exact[e, k], v) for e, row in enumerate(j_turned) for k, v in enumerate(row))


def test_enclose_transversal_batches_boxes_like_interval_transversal():
    mech = gosselin()
    sol = mech.inverse_kinematics(rot([0.1, 0.4, -0.3]))[2]
    system = system_at(mech, sol)
    theta = theta_of(system, sol)
    boxes = np.stack([np.column_stack([theta - r, theta + r]) for r in (0.0, 1e-8, 1e-3, 0.3)])
    f_all, j_all = enclose_transversal(system, boxes)
    assert f_all.shape == (2, 4, 6) and j_all.shape == (2, 4, 6, 6)
    assert np.all(f_all[0] <= f_all[1]) and np.all(j_all[0] <= j_all[1])
    for k, box in enumerate(boxes):
        f_iv, j_iv = interval_transversal(system, box)
        f_one, j_one = enclose_transversal(system, box)
        np.testing.assert_array_equal(f_one, f_all[:, k])
        np.testing.assert_array_equal(j_one, j_all[:, k])
        assert all(float(mpf(v.a)) == f_one[0, e] and float(mpf(v.b)) == f_one[1, e] for e, v in enumerate(f_iv))
        assert all(float(mpf(j_iv[e, c].a)) == j_one[0, e, c] for e in range(6) for c in range(6))
    f_only, j_none = enclose_transversal(system, boxes[1], jacobian=False)
    assert j_none is None and f_only.shape == (2, 6)
    widths = f_all[1] - f_all[0]
    assert np.all(np.diff(widths.max(axis=-1)) > 0)  # larger boxes, wider enclosures
