"""spherekin.trust.continuation: certified tracking, against the poses that generated the path, the
degree-8 eigenvalue reference (references/peers_closed_form.py) and scipy's rotations."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from references.peers_closed_form import direct_kinematics, geometry_of, leg_residuals
from tests.conftest import singular_beta1
from references.random_designs import random_3rrr
from spherekin import compile as compile_problem
from spherekin.core import intervals as iv
from spherekin.mechanism import five_bar
from spherekin.systems.platform import platform_legs
from spherekin.trust.continuation import LegEquations, cayley, track


def test_cayley_is_the_rotation_by_twice_atan_half_the_norm():
    rng = np.random.default_rng(1)
    for w in rng.normal(size=(20, 3)):
        n = np.linalg.norm(w)
        ref = Rotation.from_rotvec(2 * np.arctan(n / 2) * w / n).as_matrix()
        np.testing.assert_allclose(cayley(w), ref, atol=1e-14)


def test_leg_equations_are_eq_1_times_a_positive_factor_with_their_jacobian(mech):
    eqs = LegEquations(platform_legs(mech))
    ref = np.array(mech.platform_reference_matrix)
    rng = np.random.default_rng(2)
    geometry = geometry_of(mech)
    for _ in range(10):
        dc = Rotation.random(random_state=rng).as_matrix()
        w, beta = rng.normal(scale=0.3, size=3), rng.uniform(-3, 3, 3)
        h, jac = eqs.values(dc, w, beta)
        rot = dc @ cayley(w) @ ref
        # the independent leg constraints |w_i(beta_i) . (R v_i^0) - cos(alpha2_i)| of the reference
        np.testing.assert_allclose(np.abs(h) / (1 + w @ w / 4), leg_residuals(geometry, beta, rot), atol=1e-13)
        fd = np.array([(eqs.values(dc, w + 1e-6 * e, beta)[0] - eqs.values(dc, w - 1e-6 * e, beta)[0]) / 2e-6
                       for e in np.eye(3)]).T
        np.testing.assert_allclose(jac, fd, atol=1e-8)
        d = 1e-6
        rate = (eqs.values(dc, w, beta + d)[0] - eqs.values(dc, w, beta - d)[0]) / (2 * d)   # legs are independent
        r_box, _ = eqs.enclose(dc, iv.point(w), iv.point(beta), rate=True)
        assert np.all(r_box[0] - 1e-8 <= rate) and np.all(rate <= r_box[1] + 1e-8)


def test_interval_enclosures_hold_every_sampled_value(mech):
    eqs = LegEquations(platform_legs(mech))
    rng = np.random.default_rng(3)
    for _ in range(20):
        dc = Rotation.random(random_state=rng).as_matrix()
        c, r = rng.normal(scale=0.3, size=3), rng.uniform(0, 0.2, 3)
        b, rb = rng.uniform(-3, 3, 3), rng.uniform(0, 0.3, 3)
        h_box, j_box = eqs.enclose(dc, iv.from_bounds(c - r, c + r), iv.from_bounds(b - rb, b + rb))
        for _ in range(50):
            w = c + rng.uniform(-1, 1, 3) * r
            beta = b + rng.uniform(-1, 1, 3) * rb
            h, jac = eqs.values(dc, w, beta)
            assert np.all(h_box[0] <= h) and np.all(h <= h_box[1])
            assert np.all(j_box[0] <= jac) and np.all(jac <= j_box[1])


def ik_path(mech, rots, mode):
    """The inputs of working mode ``mode`` along the poses ``rots`` (None where a leg cannot reach)."""
    out = []
    for r in rots:
        sols = [s for s in mech.inverse_kinematics(r) if s.working_mode == mode]
        if not sols:
            return None
        out.append(sols[0].inputs)
    return np.array(out)


#: A pose curve generates a test path only when, at every row, every other assembly of the reference
#: is at least this far (largest entry) from the generating pose. Reason: near a parallel singularity
#: the straight input segments between rows (what is tracked) can pass on the other side of the
#: singularity than the smooth curve, and then legitimately continue to the other assembly mode.
SEPARATION = 0.05


@pytest.mark.parametrize("which", ["general_3rrr", "random"])
def test_tracked_poses_are_the_poses_that_generated_the_path(which, mech):
    if which == "random":
        rng = np.random.default_rng(7)
        m, _ = random_3rrr(rng)
    else:
        m, rng = mech, np.random.default_rng(8)
    geometry = geometry_of(m)
    for _ in range(100):                                         # a smooth pose curve every leg reaches
        axis0, axis1 = rng.normal(scale=0.5, size=3), rng.normal(scale=0.6, size=3)
        ts = np.linspace(0.0, 1.0, 120)
        rots = Rotation.from_rotvec(axis0 + np.outer(ts, axis1) + 0.1 * np.outer(np.sin(3 * ts), [1, -1, 0.5])).as_matrix()
        modes = m.inverse_kinematics(rots[0])
        path = ik_path(m, rots, modes[0].working_mode) if modes else None
        if path is None or np.abs(np.diff(path, axis=0)).max() > 0.3:
            continue
        gaps = [sorted(np.abs(r - rot).max() for r in direct_kinematics(geometry, x))[1:2] or [np.inf]
                for x, rot in zip(path, rots)]
        if min(g[0] for g in gaps) > SEPARATION:
            break
    else:
        pytest.fail("no pose curve away from parallel singularities found")
    tr = track(m, path, rots[0])
    assert tr.complete and len(tr.poses) == len(path)
    for p, r in zip(tr.poses, rots):
        np.testing.assert_allclose(p.platform_rotation, r, atol=1e-12)
    assert tr.proven_steps >= len(path) - 1


def test_a_path_into_a_parallel_singularity_stops_there_on_its_own_branch(mech):
    geometry = geometry_of(mech)
    # the reference has 6 assemblies at beta1 = -2.72 and 4 at -2.71 (beta2 = 0, beta3 = 0.5): two meet between
    assert len(direct_kinematics(geometry, (-2.72, 0.0, 0.5))) == 6
    assert len(direct_kinematics(geometry, (-2.71, 0.0, 0.5))) == 4
    x_star = singular_beta1(geometry, -2.72, -2.71, 6)
    path = np.column_stack([np.linspace(-3.0, -2.6, 17), np.zeros(17), np.full(17, 0.5)])
    stopped = 0
    for start in direct_kinematics(geometry, path[0]):
        tr = track(mech, path, start)
        previous = start
        for p in tr.poses:                      # every reported pose: a reference pose of the same branch
            ref = direct_kinematics(geometry, list(p.inputs.values()))
            dist = sorted(np.abs(r - p.platform_rotation).max() for r in ref)
            assert dist[0] < 1e-9
            nearest = min(ref, key=lambda r: np.abs(r - previous).max())
            np.testing.assert_allclose(p.platform_rotation, nearest, atol=1e-9)
            previous = p.platform_rotation
        if tr.stop is not None:
            stopped += 1
            assert abs(tr.stop.singular_inputs["beta1"] - x_star) < 1e-6
            assert abs(tr.stop.last_proven_inputs["beta1"] - x_star) < 1e-6
            assert tr.stop.last_proven_inputs["beta1"] <= x_star + 1e-9            # nothing proven beyond it
            assert all(p.inputs["beta1"] < x_star for p in tr.poses)
    assert stopped == 2                         # exactly the two modes that meet end there


def test_two_modes_1e_4_apart_without_a_singularity_do_not_swap(mech):
    geometry = geometry_of(mech)
    x_star = singular_beta1(geometry, -2.72, -2.71, 6)
    # go towards the singularity until the two modes that meet are ~1e-4 apart, then back
    for d in np.logspace(-6, -10, 41):
        poses = direct_kinematics(geometry, (x_star - d, 0.0, 0.5))
        gap = min(np.abs(a - b).max() for a, b in itertools.combinations(poses, 2))
        if gap < 1e-4:
            break
    assert 5e-5 < gap < 1e-4
    turn = x_star - d
    xs = np.concatenate([np.linspace(-2.8, turn, 12), np.linspace(turn, -2.8, 12)[1:]])
    path = np.column_stack([xs, np.zeros(len(xs)), np.full(len(xs), 0.5)])
    starts = direct_kinematics(geometry, path[0])
    for start in starts:
        tr = track(mech, path, start)
        assert tr.complete
        np.testing.assert_allclose(tr.poses[-1].platform_rotation, start, atol=1e-9)     # back where it started: no swap
        at_turn = tr.poses[11].platform_rotation
        assert min(np.abs(r - at_turn).max() for r in poses) < 1e-9


def test_start_errors_are_named(mech):
    path = np.array([[0.3, -0.2, 0.5], [0.31, -0.2, 0.5]])
    with pytest.raises(ValueError, match="does not close the legs"):
        track(mech, path, np.eye(3))
    problem = compile_problem(mech)
    with pytest.raises(ValueError, match="start: expected a solution index 0..7"):
        problem.track(path, start=8)
    with pytest.raises(ValueError, match="start: a start rotation needs the platform tracker"):
        compile_problem(five_bar()).track([[0.1, 0.2]], start=np.eye(3))
    with pytest.raises(ValueError, match="path: expected an array of shape"):
        problem.track([[0.1, 0.2]], start=0)
    tr = problem.track(path, start=3)
    report = problem.solve(path[0])
    np.testing.assert_allclose(tr.poses[0].platform_rotation, report.solutions[3].platform_rotation, atol=1e-13)


def _root_near(eqs, dc, beta):
    """The root of the leg equations at ``beta`` near w = 0, by plain Newton (30 steps)."""
    w = np.zeros(3)
    for _ in range(30):
        h, jac = eqs.values(dc, w, beta)
        w = w - np.linalg.solve(jac, h)
    return w


def test_krawczyk_step_refuses_a_box_that_misses_the_root_at_an_end_of_the_step(mech):
    from spherekin.trust.continuation import krawczyk_step

    eqs = LegEquations(platform_legs(mech))
    report = compile_problem(mech).solve([0.3, -0.2, 0.5])
    dc = report.solutions[0].platform_rotation @ np.array(mech.platform_reference_matrix).T
    b0, b1 = np.array([0.3, -0.2, 0.5]), np.array([0.32, -0.2, 0.5])
    w1 = _root_near(eqs, dc, b1)
    mid = _root_near(eqs, dc, 0.5 * (b0 + b1))
    r = 0.2 * np.abs(w1).max()                 # holds the middle root, not the roots at the ends (w = 0, w1)
    assert np.abs(w1 - mid).max() > r and np.abs(mid).max() > r
    assert krawczyk_step(eqs, dc, mid - r, mid + r, 0.5 * (b0 + b1), 0.5 * (b0 + b1))     # at the middle input: proven
    assert not krawczyk_step(eqs, dc, mid - r, mid + r, b0, b1)                          # over the step: it cannot be
    assert krawczyk_step(eqs, dc, w1 - r, w1 + r, b1, b1)                                # the same at the end input
    assert not krawczyk_step(eqs, dc, w1 - r, w1 + r, b0, b1)
    pad = 0.25 * np.abs(w1).max()
    assert krawczyk_step(eqs, dc, np.minimum(0, w1) - pad, np.maximum(0, w1) + pad, b0, b1)


def test_krawczyk_step_refuses_a_box_holding_two_modes(mech):
    from spherekin.trust.continuation import krawczyk_step

    geometry = geometry_of(mech)
    x_star = singular_beta1(geometry, -2.72, -2.71, 6)
    beta = np.array([x_star - 1e-6, 0.0, 0.5])
    poses = direct_kinematics(geometry, beta)
    a, b = min(itertools.combinations(poses, 2), key=lambda p: np.abs(p[0] - p[1]).max())
    eqs = LegEquations(platform_legs(mech))
    dc = a @ np.array(mech.platform_reference_matrix).T
    # b in the coordinates around a: w with D_c C(w) = b R_ref^T (Cayley: w = 2 vee(C - C^T) / (1 + tr C))
    c = dc.T @ (b @ np.array(mech.platform_reference_matrix).T)
    w_b = 2 * np.array([c[2, 1] - c[1, 2], c[0, 2] - c[2, 0], c[1, 0] - c[0, 1]]) / (1 + np.trace(c))
    np.testing.assert_allclose(cayley(w_b), c, atol=1e-12)
    for pad in (1e-6, 1e-5, 1e-4):
        lo, hi = np.minimum(0, w_b) - pad, np.maximum(0, w_b) + pad
        assert not krawczyk_step(eqs, dc, lo, hi, beta, beta)


def test_krawczyk_step_refuses_a_box_that_misses_the_root_in_one_coordinate(mech):
    from spherekin.trust.continuation import krawczyk_step

    eqs = LegEquations(platform_legs(mech))
    beta = np.array([0.3, -0.2, 0.5])
    report = compile_problem(mech).solve(beta)
    dc = report.solutions[0].platform_rotation @ np.array(mech.platform_reference_matrix).T
    r = 1e-4
    assert krawczyk_step(eqs, dc, np.full(3, -r), np.full(3, r), beta, beta)          # the root w = 0: proven
    for k in range(3):                           # shifted off the root along one axis only: refused
        shift = np.zeros(3)
        shift[k] = 3 * r
        assert not krawczyk_step(eqs, dc, shift - r, shift + r, beta, beta)


# ---------------------------------------------------------------- joint ranges, measure, names (issue 27)

#: gamma1's range of docs/mechanism-format.md's example, and a path (beta2 = 2.83, beta3 = -2.24)
#: along which the assembly with gamma1 = -2.64 at the first row turns gamma1 past -0.9 pi (near
#: beta1 = 0.2718, between rows 13 and 14).
GAMMA1_RANGE = (-0.9 * np.pi, 0.9 * np.pi)
RANGE_PATH = np.column_stack([np.linspace(0.07, 0.67, 41), np.full(41, 2.83), np.full(41, -2.24)])


def with_range(mech, name, rng):
    """``mech`` with joint ``name`` limited to ``rng`` (radians), as a [joint_ranges] entry does."""
    import dataclasses

    from spherekin.mechanism.model import Leg

    legs = tuple(Leg(leg.name, tuple(dataclasses.replace(j, range=rng) if j.name == name else j for j in leg.joints))
                 for leg in mech.legs)
    return dataclasses.replace(mech, legs=legs)


def _gamma1_by_ik(mech, pose, x):
    """gamma1 (radians, in [-pi, pi]) of the assembly at platform pose ``pose`` and inputs ``x``, by
    the mechanism's inverse kinematics (Paden-Kahan subproblems: no tracker, no passive readings)."""
    sols = [s for s in mech.inverse_kinematics(pose)
            if np.abs(np.angle(np.exp(1j * (np.array(s.inputs) - x)))).max() < 1e-8]
    assert len(sols) == 1
    return sols[0].joint_angles["gamma1"]


def _range_start(mech):
    geometry = geometry_of(mech)
    starts = [r for r in direct_kinematics(geometry, RANGE_PATH[0])
              if -2.7 < _gamma1_by_ik(mech, r, RANGE_PATH[0]) < -2.6]
    assert len(starts) == 1
    return starts[0]


def test_a_track_ends_where_a_passive_joint_leaves_its_range(mech):
    from spherekin.core.angles import RANGE_TOL

    ranged = with_range(mech, "gamma1", GAMMA1_RANGE)
    geometry = geometry_of(mech)
    tr = track(ranged, RANGE_PATH, _range_start(mech))
    st = tr.stop
    assert st is not None and st.kind == "range" and st.joint == "gamma1"
    assert st.between_rows == (13, 14) and st.joint_range == GAMMA1_RANGE
    assert [p.row for p in tr.poses] == list(range(14))            # nothing after the exit is reported
    for p in tr.poses:                                              # every reported pose inside, by IK
        x = np.array(list(p.inputs.values()))
        assert GAMMA1_RANGE[0] < _gamma1_by_ik(mech, p.platform_rotation, x) < GAMMA1_RANGE[1]
    # where gamma1 of this branch reaches -0.9 pi: bisection on beta1 with the degree-8 eigenvalue
    # reference (its pose nearest the tracked pose of row 13: the branch) and inverse kinematics
    near = tr.poses[13].platform_rotation
    lo, hi = RANGE_PATH[13, 0], RANGE_PATH[14, 0]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        x = np.array([mid, 2.83, -2.24])
        pose = min(direct_kinematics(geometry, x), key=lambda r: np.abs(r - near).max())
        if _gamma1_by_ik(mech, pose, x) >= GAMMA1_RANGE[0] - RANGE_TOL:   # the range's closed, widened end
            lo = mid
        else:
            hi = mid
    x_star = 0.5 * (lo + hi)
    assert abs(st.last_proven_inputs["beta1"] - x_star) < 1e-9
    assert abs(st.exit_inputs["beta1"] - x_star) < 1e-9
    assert 0 < st.exit_inputs["beta1"] - st.last_proven_inputs["beta1"] <= st.bracket + 1e-15
    assert st.bracket <= 1e-12
    assert abs(st.joint_angle - GAMMA1_RANGE[0]) <= RANGE_TOL + 1e-12
    assert st.fraction == pytest.approx((st.last_proven_inputs["beta1"] - RANGE_PATH[13, 0]) / 0.015, abs=1e-9)
    # the full solve agrees on both sides: the branch's pose is a solution 1e-6 before, not 1e-6 after
    problem = compile_problem(ranged)
    for d, found in ((-1e-6, True), (1e-6, False)):
        x = np.array([x_star + d, 2.83, -2.24])
        pose = min(direct_kinematics(geometry, x), key=lambda r: np.abs(r - near).max())
        hits = [s for s in problem.solve(x).solutions if np.abs(s.platform_rotation - pose).max() < 1e-8]
        assert bool(hits) is found
    # a start outside the ranges is refused, naming the joint
    free = track(mech, RANGE_PATH[:21], _range_start(mech))            # the same branch, gamma1 unlimited
    assert free.complete and free.poses[20].passive_angles["gamma1"] < GAMMA1_RANGE[0]      # outside the range
    with pytest.raises(ValueError, match=r"start: gamma1 = .* outside its joint range"):
        track(ranged, RANGE_PATH[20:], free.poses[20].platform_rotation)


def _closure_map(mech, inputs, passive):
    """The loop closures, as rotation vectors of R_1^T R_j (legs 2 and 3 against leg 1), of the
    three legs' forward kinematics at the given joint angles (radians): 6 numbers, 0 when they close.
    Each leg: R = Rot(u_1, t_1 - t_1ref) Rot(u_2, ...) Rot(u_3, ...) (scipy's rotations)."""
    angles = {**inputs, **passive}
    rots = []
    for leg in mech.legs:
        r = Rotation.identity()
        for j in leg.joints:
            r = r * Rotation.from_rotvec((angles[j.name] - j.reference_angle) * np.asarray(j.axis))
        rots.append(r)
    return np.concatenate([(rots[0].inv() * r).as_rotvec() for r in rots[1:]])


@pytest.fixture(scope="module")
def fold_tracks(mech):
    """A track from every assembly at beta1 = -3 (beta2 = 0, beta3 = 0.5) to -2.6: two of them end
    at the parallel singularity near -2.7141."""
    path = np.column_stack([np.linspace(-3.0, -2.6, 17), np.zeros(17), np.full(17, 0.5)])
    return [track(mech, path, s) for s in direct_kinematics(geometry_of(mech), path[0])]


def test_the_parallel_measure_is_the_ratio_of_singular_values_of_the_closure_jacobian(mech, fold_tracks):
    ratios = []
    for tr in fold_tracks:
        for p in [*tr.poses[::4], tr.poses[-1]]:
            names = list(p.passive_angles)
            q = np.array(list(p.passive_angles.values()))
            assert np.abs(_closure_map(mech, p.inputs, p.passive_angles)).max() < 1e-9     # the pose closes
            h = 1e-6
            jac = np.array([(_closure_map(mech, p.inputs, dict(zip(names, q + h * e)))
                             - _closure_map(mech, p.inputs, dict(zip(names, q - h * e)))) / (2 * h)
                            for e in np.eye(len(q))]).T
            s = np.linalg.svd(jac, compute_uv=False)
            assert p.parallel_measure == pytest.approx(s[-1] / s[0], rel=1e-6, abs=1e-9)
            ratios.append(p.parallel_measure)
        if tr.stop is not None:                     # next to the fold: the measure tends to 0
            assert tr.stop.parallel_measure < 1e-3
    assert sum(tr.stop is not None for tr in fold_tracks) == 2
    assert max(ratios) > 0.1 and min(ratios) < 0.05


def test_python_attribute_names_are_the_json_keys(mech, fold_tracks):
    import dataclasses

    tracks = list(fold_tracks)
    tracks.append(track(with_range(mech, "gamma1", GAMMA1_RANGE), RANGE_PATH, _range_start(mech)))
    kinds = set()
    for tr in tracks:
        data = tr.as_dict()
        assert data["schema"] == "spherekin.track/3"
        for obj, d in [(tr, data), (tr.poses[0], data["poses"][0]), *([(tr.stop, data["stop"])] if tr.stop else [])]:
            names = {f.name for f in dataclasses.fields(obj)}
            assert names <= set(d) and set(d) - names <= {"schema", "spherekin_version", "complete"}
            for n in names - {"poses", "stop"}:
                value = getattr(obj, n)
                expected = np.asarray(value).tolist() if isinstance(value, (np.ndarray, tuple)) else value
                assert d[n] == expected, n
        kinds.add(None if tr.stop is None else tr.stop.kind)
    assert kinds == {None, "singular", "range"}


def test_a_track_has_a_frame_and_a_short_repr(mech):
    path = np.column_stack([np.linspace(-3.0, -2.8, 1000), np.zeros(1000), np.full(1000, 0.5)])
    start = direct_kinematics(geometry_of(mech), path[0])[0]
    tr = track(mech, path, start)
    assert tr.complete and len(tr.poses) == 1000
    text = repr(tr)
    assert len(text) < 300 and "1000 of 1000 rows" in text and "row 999" in text
    frame = tr.frame()
    assert list(frame.columns) == ["row", "beta1", "beta2", "beta3", "gamma1", "delta1", "gamma2", "delta2", "gamma3",
                                   "delta3", "qw", "qx", "qy", "qz", *(f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)),
                                   "residual", "parallel_measure", "proven_steps"]
    assert len(frame) == 1000 and list(frame["row"]) == list(range(1000))
    np.testing.assert_array_equal(frame["parallel_measure"], [p.parallel_measure for p in tr.poses])
    np.testing.assert_array_equal(frame["beta1"], path[:, 0])
    k = 500
    np.testing.assert_allclose(frame.loc[k, ["r11", "r12", "r13", "r21", "r22", "r23", "r31", "r32", "r33"]].to_numpy(float),
                               tr.poses[k].platform_rotation.ravel(), atol=0)
    w, x, y, z = frame.loc[k, ["qw", "qx", "qy", "qz"]].to_numpy(float)
    np.testing.assert_allclose(Rotation.from_quat([x, y, z, w]).as_matrix(), tr.poses[k].platform_rotation, atol=1e-14)


def _gamma_by_ik(mech, name, pose, x):
    """Joint ``name``'s angle at platform pose ``pose`` and inputs ``x``, by inverse kinematics."""
    sols = [s for s in mech.inverse_kinematics(pose)
            if np.abs(np.angle(np.exp(1j * (np.array(s.inputs) - x)))).max() < 1e-8]
    assert len(sols) == 1
    return sols[0].joint_angles[name]


def test_a_joint_that_leaves_its_range_and_comes_back_between_two_rows_ends_the_track(mech):
    from spherekin.core.angles import RANGE_TOL

    # beta1 from -0.1 to 0.06 (beta2 = -0.2, beta3 = 0.5): along one assembly gamma2 rises to a
    # maximum inside the segment and falls back; the reference (eigenvalues + inverse kinematics,
    # following the nearest pose) on a fine sampling of the segment
    geometry = geometry_of(mech)
    rows = np.array([[-0.1, -0.2, 0.5], [0.06, -0.2, 0.5]])
    xs = np.linspace(0.0, 1.0, 41)[:, None] * (rows[1] - rows[0]) + rows[0]
    for start in direct_kinematics(geometry, rows[0]):
        pose, curve = start, []
        for x in xs:
            pose = min(direct_kinematics(geometry, x), key=lambda r: np.abs(r - pose).max())
            curve.append((_gamma_by_ik(mech, "gamma2", pose, x), pose))
        g = np.array([c[0] for c in curve])
        if g.max() > max(g[0], g[-1]) + 5e-4 and 0 < g.argmax() < len(g) - 1:
            break
    else:
        pytest.fail("no assembly whose gamma2 has a maximum inside the segment")
    hi = 0.5 * (g.max() + max(g[0], g[-1]))               # both rows in range, the middle of the segment not
    ranged = with_range(mech, "gamma2", (-np.pi, hi))
    tr = track(ranged, rows, start)
    st = tr.stop
    assert st is not None and st.kind == "range" and st.joint == "gamma2" and st.between_rows == (0, 1)
    assert len(tr.poses) == 1
    # the reference's crossing of hi: bisection between the last sample below it and the first above
    k = int(np.argmax(g > hi))
    lo_x, hi_x, near = xs[k - 1, 0], xs[k, 0], curve[k - 1][1]
    for _ in range(60):
        mid = 0.5 * (lo_x + hi_x)
        x = np.array([mid, -0.2, 0.5])
        pose = min(direct_kinematics(geometry, x), key=lambda r: np.abs(r - near).max())
        if _gamma_by_ik(mech, "gamma2", pose, x) <= hi + RANGE_TOL:      # the range's closed, widened end
            lo_x = mid
        else:
            hi_x = mid
    assert abs(st.last_proven_inputs["beta1"] - lo_x) < 1e-9 and st.bracket <= 1e-12
    assert abs(st.joint_angle - hi) <= RANGE_TOL + 1e-12


def test_the_range_enclosure_of_a_step_never_proves_inside_an_angle_sampled_outside(mech):
    from spherekin.trust.continuation import JointRanges, _certify_steps, _predict

    rng = np.random.default_rng(11)
    problem = compile_problem(mech)
    checked = 0
    for _ in range(6):
        x0 = rng.uniform(-np.pi, np.pi, 3)
        report = problem.solve(x0)
        for sol in report.solutions[:3]:
            x1 = x0 + rng.uniform(-0.005, 0.005, 3)           # a step the Krawczyk test proves
            dc = sol.platform_rotation @ np.array(mech.platform_reference_matrix).T
            eqs = LegEquations(platform_legs(mech))
            w1 = _predict(eqs, dc, x0, x1)
            if w1 is None:
                continue
            proven, lo, hi = _certify_steps(eqs, dc[None], w1[None], x0[None], x1[None])
            if not proven[0]:                      # lo, hi: the boxes the tracker tests the ranges on
                continue
            free = JointRanges(mech, platform_legs(mech))
            samples = np.array([free.angles(x0 + t * (x1 - x0), dc @ cayley(_predict(eqs, dc, x0, x0 + t * (x1 - x0))))[0]
                                for t in np.linspace(0, 1, 41)])
            for j, name in enumerate(free.names):
                a, b = samples[:, j].min(), samples[:, j].max()
                for rng_j, inside in (((a - 0.3, b + 0.3), True), ((a + 0.3 * (b - a), b + 1.0), False),
                                      ((a - 1.0, b - 0.3 * (b - a)), False)):
                    joints = JointRanges(with_range(mech, name, rng_j), platform_legs(mech))
                    got = bool(joints.steps_inside(dc[None], lo, hi, x0[None], x1[None])[0])
                    if not inside:                 # a sampled angle is outside: never proven inside
                        assert got is False, (name, rng_j)
                    else:                          # 0.3 rad of room: the enclosure of a 0.005 step is not that loose
                        assert got is True, (name, rng_j)
                    checked += 1
    assert checked > 100


def test_the_parametric_krawczyk_operator_on_a_linear_family_with_known_roots():
    """parametric_krawczyk on F(w, x) = A w - x (M = 2; roots w(x) = A^-1 x, x on the segment
    x1 + sigma delta, sigma in [-1, 0]): a box holding every root of the segment with room to spare
    is proven and its image holds them; a box missing the roots of one end is not; a singular A is
    not proven."""
    from spherekin.core import intervals as iv
    from spherekin.trust.continuation import SIGMA, parametric_krawczyk

    a = np.array([[2.0, 0.5], [-0.3, 1.5]])
    x0, x1 = np.array([0.1, -0.2]), np.array([0.14, -0.17])
    roots = np.linalg.solve(a, np.stack([x0, x1, 0.5 * (x0 + x1)]).T).T      # (3, 2)
    lo_r, hi_r = roots.min(axis=0), roots.max(axis=0)
    boxes_lo = np.stack([lo_r - 0.01, lo_r - 0.01, lo_r + 0.3 * (hi_r - lo_r)])
    boxes_hi = np.stack([hi_r + 0.01, hi_r + 0.01, hi_r + 0.01])
    mats = np.stack([a, np.array([[1.0, 2.0], [0.5, 1.0]]), a])             # the second singular
    mid = 0.5 * (boxes_lo + boxes_hi)
    f_m = iv.point(np.einsum("nij,nj->ni", mats, mid) - x1)                 # F(m, x1)
    rate = iv.point(np.broadcast_to(-(x1 - x0), (3, 2)))                    # dF/dsigma = -delta
    j_box = iv.point(mats)
    sigma = iv.from_bounds(np.array([-SIGMA]), np.array([SIGMA - 1.0])).reshape(2, 1, 1)
    ok, k = parametric_krawczyk(boxes_lo, boxes_hi, mats, f_m, rate, j_box, sigma)
    assert ok.tolist() == [True, False, False]
    assert np.all(k[0, 0] <= lo_r) and np.all(hi_r <= k[1, 0])
