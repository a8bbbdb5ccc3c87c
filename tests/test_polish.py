"""Tests for spherekin.trust.polish: analytic Jacobian vs finite differences, convergence to IK roots."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from spherekin.closure import ClosureLoop, Unknown
from spherekin.mechanism import general_3rrr, gosselin
from spherekin.trust.polish import CONVERGED_TOL, closure_residual, polish


def random_system(rng):
    a, b, c = (Unknown(n, -1.0, 1.0) for n in "abc")
    loops = [ClosureLoop([0.3, a, -b + 0.5, 1.2, c, np.pi]), ClosureLoop([b, 2.0, a + 1.0, -0.7])]
    return loops, [a, b, c]


def test_jacobian_matches_central_differences():
    rng = np.random.default_rng(0)
    loops, unknowns = random_system(rng)
    for theta in rng.uniform(-3, 3, (5, 3)):
        r, jac = closure_residual(loops, unknowns, theta, jacobian=True)
        h = 1e-6
        fd = np.column_stack([(closure_residual(loops, unknowns, theta + h * e)
                               - closure_residual(loops, unknowns, theta - h * e)) / (2 * h) for e in np.eye(3)])
        np.testing.assert_allclose(jac, fd, atol=1e-8)
        assert r.shape == (18,) and jac.shape == (18, 3)


@pytest.mark.parametrize("factory, seed", [(gosselin, 3), (general_3rrr, 4)])
def test_polish_converges_to_the_inverse_kinematics_root(factory, seed):
    mech = factory()
    r0 = Rotation.random(random_state=seed).as_matrix()
    for mode in mech.inverse_kinematics(r0):
        exact = {n: mode.joint_angles[n] for n in mech.passive}
        system = mech.loop_system(mode.inputs, {n: (a - 1.0, a + 1.0) for n, a in exact.items()})
        truth = np.array([exact[u.name] for u in system.unknowns])
        assert np.abs(closure_residual(system.loops, system.unknowns, truth)).max() < 1e-13
        start = truth + np.random.default_rng(seed).uniform(-1e-4, 1e-4, truth.shape)
        res = polish(system.loops, system.unknowns, start)
        assert res.converged and res.residual <= CONVERGED_TOL
        assert res.iterations <= 6  # quadratic convergence at a regular root
        np.testing.assert_allclose(res.theta, truth, atol=1e-11)


def test_polish_rejects_bad_start():
    loops, unknowns = random_system(np.random.default_rng(1))
    with pytest.raises(ValueError, match="theta0"):
        polish(loops, unknowns, [0.1, np.nan, 0.2])
    with pytest.raises(ValueError, match="theta0"):
        polish(loops, unknowns, [0.1, 0.2])


def test_polish_many_polishes_each_point_in_its_own_system_as_polish_does_alone():
    """polish_many over the roots of several inputs at once (each row with its own constants):
    every row is polish of that input's system alone, bit for bit, and converges to the inverse
    kinematics root of its own input (not another's)."""
    from spherekin.closure import closure_plan
    from spherekin.trust.polish import polish_many

    mech = general_3rrr()
    rng = np.random.default_rng(7)
    starts, truths, systems = [], [], []
    seed = 10
    while len(systems) < 4:
        modes = mech.inverse_kinematics(Rotation.random(random_state=seed).as_matrix())
        seed += 1
        if not modes:
            continue
        exact = {n: modes[0].joint_angles[n] for n in mech.passive}
        system = mech.loop_system(modes[0].inputs, {n: (a - 1.0, a + 1.0) for n, a in exact.items()})
        truth = np.array([exact[u.name] for u in system.unknowns])
        systems.append(system)
        truths.append(truth)
        starts.append(truth + rng.uniform(-1e-4, 1e-4, truth.shape))
    plans = [closure_plan(s.loops, s.unknowns, s.loop_indices) for s in systems]
    offsets = np.stack([p.offsets for p in plans])
    batch = polish_many(plans[0], np.array(starts), offsets)
    for k, system in enumerate(systems):
        alone = polish(system.loops, system.unknowns, starts[k])
        assert np.array_equal(batch.theta[k], alone.theta) and batch.iterations[k] == alone.iterations
        assert batch.converged[k]
        np.testing.assert_allclose(batch.theta[k], truths[k], atol=1e-11)
    # the same starts with the constants of the next input: another system, other roots
    other = polish_many(plans[0], np.array(starts), np.roll(offsets, 1, axis=0))
    assert all(np.abs(other.theta[k] - truths[k]).max() > 1e-8 for k in range(4))
