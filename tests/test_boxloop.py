"""Tests for spherekin.search.boxloop against independent references.

* each solution's platform pose satisfies the 3-RRR leg constraints w_i(beta_i) . (R v_i^0) =
  cos(alpha2_i), computed here from the mechanism file with our own Rodrigues formula;
* round trip: random pose (scipy) -> inverse kinematics -> solve -> the pose is among the solutions;
* the paper's claim for the Gosselin platform: 8 solutions, 4 of them singular;
* every pruner and LP backend finds the same solutions.
"""

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from spherekin.mechanism import gosselin, load_mechanism
from spherekin.search.boxloop import (BoxLimitError, DepthLimitError, SolverLimitError, charts_for_range,
                                      clusters_in_range, clusters_in_range_many,
                                      solve_system)
from spherekin.problem import solve
from spherekin.results import AcceptedBox

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
INPUTS = (0.3, -0.2, 0.5)


def rodrigues(axis, angle):
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * kx + (1 - math.cos(angle)) * kx @ kx


def leg_residuals(path, inputs, rotation):
    """|w_i(beta_i) . (R v_i^0) - cos(alpha2_i)| for the three legs, straight from the TOML file."""
    data = tomllib.loads(Path(path).read_text())
    out = []
    for u, w0, v0, a2 in zip(data["base_axes"], data["elbow_axes_at_zero"], data["platform_axes"],
                             data["distal_link_angles"]):
        alpha2 = float(eval(a2, {"pi": math.pi})) if isinstance(a2, str) else float(a2)
        w = rodrigues(u, inputs[len(out)]) @ np.asarray(w0, float)
        out.append(abs(w @ (rotation @ np.asarray(v0, float)) - math.cos(alpha2)))
    return np.array(out)


@pytest.fixture(scope="module")
def gosselin_report():
    return solve(load_mechanism(EXAMPLES / "gosselin.toml"), INPUTS)


def test_gosselin_eight_solutions_four_singular(gosselin_report):
    sols = gosselin_report.solutions
    assert len(sols) == 8
    kinds = sorted(s.singularity for s in sols)
    assert kinds == ["regular"] * 4 + ["serial"] * 4
    assert sorted(s.status for s in sols) == ["certified"] * 4 + ["singular"] * 4
    for s in sols:
        assert s.residual < 1e-12                     # polished
        assert s.evidence["krawczyk_certified"]       # serial singularities are still isolated roots
        assert leg_residuals(EXAMPLES / "gosselin.toml", INPUTS, s.platform_rotation).max() < 1e-12
        np.testing.assert_allclose(s.platform_rotation @ s.platform_rotation.T, np.eye(3), atol=1e-12)
    poses = [s.platform_rotation for s in sols]
    assert min(np.abs(a - b).max() for i, a in enumerate(poses) for b in poses[i + 1:]) > 1e-3


def test_gosselin_solutions_include_angles_at_pi(gosselin_report):
    """The singular solutions have passive angles at exactly +-pi: found through the chart at pi."""
    at_pi = [a for s in gosselin_report.solutions for a in s.angles if abs(abs(a) - math.pi) < 1e-12]
    assert len(at_pi) >= 4


def test_regular_solutions_reproduce_inputs_by_inverse_kinematics(gosselin_report):
    mech = gosselin()
    for s in gosselin_report.solutions:
        if s.singularity != "regular":
            continue
        modes = mech.inverse_kinematics(s.platform_rotation)
        d = [np.abs(np.mod(np.array(m.inputs) - INPUTS + math.pi, 2 * math.pi) - math.pi).max() for m in modes]
        assert min(d) < 1e-12


@pytest.mark.parametrize("preset, seed", [("gosselin.toml", 1), ("general_3rrr.toml", 2)])
def test_round_trip_random_pose(preset, seed):
    mech = load_mechanism(EXAMPLES / preset)
    r0 = Rotation.random(random_state=seed).as_matrix()
    mode = mech.inverse_kinematics(r0)[0]
    rep = solve(mech, mode.inputs)
    assert min(np.abs(s.platform_rotation - r0).max() for s in rep.solutions) < 1e-10
    for s in rep.solutions:
        assert leg_residuals(EXAMPLES / preset, mode.inputs, s.platform_rotation).max() < 1e-12
    poses = [s.platform_rotation for s in rep.solutions]   # duplicates merged after polishing
    assert all(np.abs(a - b).max() > 1e-6 for i, a in enumerate(poses) for b in poses[i + 1:])


@pytest.mark.slow
@pytest.mark.parametrize("preset", ["gosselin.toml", "general_3rrr.toml"])
def test_round_trip_sweep(preset):
    mech = load_mechanism(EXAMPLES / preset)
    misses = 0
    for seed in range(20):
        r0 = Rotation.random(random_state=100 + seed).as_matrix()
        for mode in mech.inverse_kinematics(r0)[:2]:
            rep = solve(mech, mode.inputs)
            misses += min(np.abs(s.platform_rotation - r0).max() for s in rep.solutions) >= 1e-10
    assert misses == 0


# ---------------------------------------------------------------- every pruner and backend

def _narrow(mech, centre, half, inputs=INPUTS):
    """A build function and ranges for a box of half-width ``half`` around passive angles ``centre``."""
    ranges = {n: (a - half, a + half) for n, a in centre.items()}

    def build(chart):
        system = mech.loop_system(inputs, chart)
        return system.loops, system.unknowns

    return build, ranges


#: A pose of the Gosselin platform chosen first; its inputs and passive angles come from inverse
#: kinematics (closed form), so the solver is checked against a root it did not compute.
REGULAR_POSE = Rotation.from_rotvec([0.3, -0.2, 0.25]).as_matrix()


@pytest.fixture(scope="module")
def regular_root():
    """(inputs, passive angles by name) of REGULAR_POSE, a regular assembly (checked)."""
    mech = gosselin()
    ik = mech.inverse_kinematics(REGULAR_POSE)[0]
    assert mech.singularity(ik.joint_angles).kind == "regular"
    names = mech.loop_unknowns
    return ik.inputs, {n: ik.joint_angles[n] for n in names}


@pytest.mark.parametrize("parameterization", ["tan-half", "sin-cos"])
@pytest.mark.parametrize("pruner, backend", [("pp", None), ("hybrid", None), ("lp", "highspy"), ("lp", "highs"),
                                             ("lp", "clarabel")])
class TestEveryPruner:
    def test_finds_the_solution(self, pruner, backend, parameterization, regular_root):
        inputs, root = regular_root
        build, ranges = _narrow(gosselin(), root, 0.15, inputs)
        rep = solve_system(build, ranges, pruner=pruner, lp_backend=backend, parameterization=parameterization,
                           formulation="halves")
        assert len(rep.clusters) == 1       # unpolished: the centre of a box of width <= tol (1e-6)
        np.testing.assert_allclose(rep.clusters[0].angles, list(root.values()), atol=2e-6)
        if pruner == "lp":
            assert rep.stats.lps_solved > 0

    def test_empty_when_no_solution_in_range(self, pruner, backend, parameterization, regular_root):
        inputs, root = regular_root
        away = {n: a + 0.5 for n, a in root.items()}
        build, ranges = _narrow(gosselin(), away, 0.1, inputs)
        rep = solve_system(build, ranges, pruner=pruner, lp_backend=backend, parameterization=parameterization)
        assert rep.clusters == ()


def _poses(report):
    return sorted((s.platform_rotation for s in report.solutions), key=lambda r: tuple(np.round(r.ravel(), 6)))


@pytest.mark.parametrize("parameterization", ["tan-half", "sin-cos"])
@pytest.mark.parametrize("formulation", ["transversal", "halves"])
def test_every_parameterization_and_formulation_finds_the_eight_solutions(parameterization, formulation):
    """8 distinct assemblies (the Bezout bound of a 3-RRR: none can be missing), each reached by the
    legs at INPUTS (leg residuals straight from the TOML file), and the regular ones reproduce INPUTS by
    inverse kinematics."""
    mech = gosselin()
    rep = solve(mech, INPUTS, parameterization=parameterization, formulation=formulation)
    assert sorted(s.status for s in rep.solutions) == ["certified"] * 4 + ["singular"] * 4
    poses = _poses(rep)
    assert min(np.abs(a - b).max() for i, a in enumerate(poses) for b in poses[i + 1:]) > 1e-3
    for s in rep.solutions:
        assert leg_residuals(EXAMPLES / "gosselin.toml", INPUTS, s.platform_rotation).max() < 1e-12
        if s.singularity == "regular":
            d = [np.abs(np.mod(np.array(m.inputs) - INPUTS + math.pi, 2 * math.pi) - math.pi).max()
                 for m in mech.inverse_kinematics(s.platform_rotation)]
            assert min(d) < 1e-12
    assert rep.settings.parameterization == parameterization
    assert rep.stats.charts == (64 if parameterization == "tan-half" else 1)


def test_jobs_do_not_change_the_result():
    # the worker processes share out the charts of the loop equations (64 here)
    rep1 = solve(gosselin(), INPUTS, formulation="halves")
    rep2 = solve(gosselin(), INPUTS, formulation="halves", jobs=2)
    assert rep2.settings.jobs == 2 and rep2.stats.charts == 64
    assert [s.angles.tolist() for s in rep2.solutions] == [s.angles.tolist() for s in rep1.solutions]
    counts = ("boxes_processed", "discarded", "split", "reduced_again", "accepted", "isolated")
    assert [getattr(rep2.stats, c) for c in counts] == [getattr(rep1.stats, c) for c in counts]
    with pytest.raises(ValueError, match="jobs"):
        solve(gosselin(), INPUTS, jobs=0)


def test_trace_accounts_for_every_box(regular_root):
    from spherekin.search.boxloop import TRACE_OUTCOMES

    inputs, root = regular_root
    build, ranges = _narrow(gosselin(), root, 0.15, inputs)
    records = []
    rep = solve_system(build, ranges, trace=records.append)
    outcome = np.concatenate([r["outcome"] for r in records])
    assert len(outcome) == rep.stats.boxes_processed
    for k, name in enumerate(TRACE_OUTCOMES):
        assert np.sum(outcome == k) == getattr(rep.stats, name)
    for r in records:        # every reduction lies inside its box
        assert np.all(r["lo"] <= r["hi"])
        ok = r["outcome"] != 0
        assert np.all(r["reduced_lo"][ok] >= r["lo"][ok] - 1e-15) and np.all(r["reduced_hi"][ok] <= r["hi"][ok] + 1e-15)
    with pytest.raises(ValueError, match="trace"):
        solve_system(build, ranges, trace=records.append, jobs=2)


def test_isolation_saves_boxes_but_not_solutions():
    isolated = solve(gosselin(), INPUTS, formulation="halves")
    plain = solve(gosselin(), INPUTS, formulation="halves", isolate=False)
    for a, b in zip(_poses(plain), _poses(isolated)):
        np.testing.assert_allclose(a, b, atol=1e-12)
    assert isolated.stats.isolated >= 4 and plain.stats.isolated == 0
    assert plain.stats.boxes_processed > isolated.stats.boxes_processed


def _arc_box(lo, hi, samples=200_001):
    """Bounding box of the unit-circle arc [lo, hi] in (cos, sin), by dense sampling (to ~1e-10)."""
    t = np.linspace(lo, hi, samples)
    return np.cos(t).min(), np.cos(t).max(), np.sin(t).min(), np.sin(t).max()


def test_sin_cos_drops_solutions_outside_limited_ranges(regular_root):
    """The sin-cos box of an arc wider than pi is its bounding box in (c, s), which holds circle points
    beyond the arc. A range of width 4 rad for gamma1 is placed so that the root's gamma1 (from IK) is
    0.05 rad or more outside it yet inside that bounding box (by geometry): the box loop accepts boxes
    at the root (``boxes``: before the range filter) and the filter must drop them."""
    inputs, root = regular_root
    a = root["gamma1"]
    for delta in np.arange(0.05, 2.0, 0.05):          # range (a + delta, a + delta + 4): a is delta below it
        c_lo, c_hi, s_lo, s_hi = _arc_box(a + delta, a + delta + 4.0)
        if c_lo + 1e-3 < math.cos(a) < c_hi - 1e-3 and s_lo + 1e-3 < math.sin(a) < s_hi - 1e-3:
            break
    else:
        pytest.fail("no placement puts the root in the arc's bounding box")
    build, ranges = _narrow(gosselin(), root, 0.15, inputs)
    ranges["gamma1"] = (a + delta, a + delta + 4.0)
    rep = solve_system(build, ranges, parameterization="sin-cos", isolate=False)
    k = list(ranges).index("gamma1")
    near = [b for b in rep.boxes if abs(math.remainder(0.5 * (b.lo[k] + b.hi[k]) - a, 2 * math.pi)) < 1e-5]
    assert near                                        # the search reached the root outside the arc
    assert not any(abs(math.remainder(s.angles[k] - a, 2 * math.pi)) < 1e-3 for s in rep.clusters)
    for s in rep.clusters:
        assert math.remainder(s.angles[k] - (a + delta), 2 * math.pi) % (2 * math.pi) <= 4.0 + 1e-5


def test_paper_formulation_finds_the_solution_at_coarse_tolerance(regular_root):
    inputs, root = regular_root
    build, ranges = _narrow(gosselin(), root, 0.15, inputs)
    rep = solve_system(build, ranges, formulation="paper", tol=1e-3)
    assert len(rep.clusters) >= 1      # unpolished clusters: solve() polishes and merges them
    for sol in rep.clusters:  # a double root: boxes survive ~sqrt(hull slack) away, beyond tol
        np.testing.assert_allclose(sol.angles, list(root.values()), atol=2e-2)
    assert sum(s.n_boxes for s in rep.clusters) > 10  # the double root leaves a cloud of boxes


# ---------------------------------------------------------------- charts, caps, bad input

def test_charts_cover_ranges():
    full = charts_for_range(None)
    assert full == [(-math.pi / 2, math.pi / 2), (math.pi / 2, 3 * math.pi / 2)]
    assert charts_for_range((-3.0, 3.5)) == full  # wider than 2 pi: every angle is reachable
    parts = charts_for_range((-3.0, 3.0))
    assert parts[0][0] == -3.0 and parts[-1][1] == 3.0
    assert all(b - a <= math.pi + 1e-12 for a, b in parts)
    assert all(parts[i][1] == parts[i + 1][0] for i in range(len(parts) - 1))
    assert charts_for_range((0.0, 1.0)) == [(0.0, 1.0)]
    with pytest.raises(ValueError, match="range"):
        charts_for_range((1.0, 1.0))


def test_caps_raise_distinct_errors(regular_root):
    inputs, root = regular_root
    build, ranges = _narrow(gosselin(), root, 0.15, inputs)
    with pytest.raises(BoxLimitError, match="max_boxes") as err:
        solve_system(build, ranges, max_boxes=5)
    assert isinstance(err.value, SolverLimitError)
    with pytest.raises(DepthLimitError, match="max_depth") as err:
        solve_system(build, ranges, tol=1e-12, max_depth=3, isolate=False)
    assert isinstance(err.value, SolverLimitError) and not isinstance(err.value, BoxLimitError)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(inputs=(0.1, 0.2)), "inputs"),
        (dict(inputs=(0.1, float("nan"), 0.2)), "inputs"),
        (dict(formulation="newton"), "formulation.*paper.*transversal"),
        (dict(pruner="simplex"), "pruner"),
        (dict(pruner="pp", lp_backend="highs"), "lp_backend"),
        (dict(pruner="lp", lp_backend="cplex"), "lp_backend"),
        (dict(tol=0.0), "tol"),
        (dict(parameterization="quaternion"), "parameterization: expected one of .*tan-half.*sin-cos"),
    ],
)
def test_bad_input_is_a_clear_error(kwargs, match):
    inputs = kwargs.pop("inputs", INPUTS)
    with pytest.raises(ValueError, match=match):
        solve(gosselin(), inputs, **kwargs)


def test_package_level_entry_points():
    import spherekin

    rep = spherekin.solve(spherekin.load_mechanism(EXAMPLES / "four_bar.toml"), (0.4,))
    assert rep.solutions and all(s.residual < 1e-12 for s in rep.solutions)
    with pytest.raises(AttributeError, match="nothing"):
        spherekin.nothing  # noqa: B018


def test_a_capped_search_hands_over_the_roots_it_had_isolated():
    """partial (of a cap, or of Ctrl-C) holds the roots already isolated, not only the accepted boxes:
    each closes every loop (the mechanism's forward kinematics, not the solver, says so)."""
    from spherekin.mechanism import gosselin
    from spherekin.search.boxloop import SolverLimitError

    mech, x = gosselin(), (0.3, -0.2, 0.5)

    def build(chart):
        system = mech.loop_system(x, chart)
        return system.loops, system.unknowns

    ranges = {n: mech.ranges[n] for n in mech.loop_unknowns}
    with pytest.raises(SolverLimitError) as info:
        solve_system(build, ranges, formulation="halves", max_boxes=2000)   # the full search takes ~2,700
    points = [b for b in info.value.partial if np.array_equal(b.lo, b.hi)]
    assert len(points) >= 2
    for p in points:
        joints = {**dict(zip(mech.actuated, x)), **dict(zip(mech.loop_unknowns, p.lo.tolist()))}
        assert max(mech.forward(joints).loop_residuals) < 1e-9


def _clusters_by_hand(lo, hi, ranges, tol):
    """Clusters of boxes that are pairwise far apart, written out: one per box, its centre wrapped to
    [-pi, pi), kept when every centre is within tol + 1e-10 of its range (mod 2 pi), sorted by the
    centres rounded to 1e-9."""
    out = []
    for a, b in zip(lo, hi):
        c = [math.remainder(0.5 * (x + y), 2 * math.pi) for x, y in zip(a, b)]
        ok = all(rng is None or (x - (rng[0] - tol - 1e-10)) % (2 * math.pi) <= rng[1] - rng[0] + 2 * (tol + 1e-10)
                 for x, rng in zip(c, ranges.values()))
        if ok:
            out.append((c, list(a), list(b)))
    return sorted(out, key=lambda t: tuple(round(v, 9) for v in t[0]))


def test_clusters_of_many_inputs_are_those_of_each_input_alone():
    """clusters_in_range_many over a chunk against clusters_in_range input by input (the reference
    merge) and, for inputs of far-apart boxes, against the clusters written out by hand: near pairs,
    boxes across +-pi, points (lo == hi), boxes out of range, an input with more than the padded
    array's boxes, inputs with none."""
    rng = np.random.default_rng(31)
    tol = 1e-6
    ranges = {"a": (-2.0, 2.5), "b": None, "c": (0.5, 6.0)}
    lo, hi, owner = [], [], []
    n_inputs = 40
    for k in range(n_inputs):
        n = [0, 3, 8, 40][k % 4]
        c = rng.uniform(-math.pi, math.pi, (n, 3))
        if k % 5 == 1 and n > 1:
            c[1] = c[0] + rng.uniform(-1, 1, 3) * tol            # a near pair: merged
        if k % 7 == 2 and n > 2:
            c[2, 0] = math.pi - 1e-7                              # across +-pi from c[0]'s copy
            c[0, :] = c[2, :]
            c[0, 0] = -math.pi + 1e-7
        w = rng.uniform(0, tol, (n, 3)) * (rng.random((n, 1)) < 0.5)     # half of them points
        lo += list(c - w)
        hi += list(c + w)
        owner += [k] * n
    lo, hi, owner = np.array(lo), np.array(hi), np.array(owner)
    perm = rng.permutation(len(owner))                            # the chunk in any order of inputs
    many = clusters_in_range_many(lo[perm], hi[perm], owner[perm], n_inputs, ranges, tol)
    merged = 0
    for k in range(n_inputs):
        mine = [i for i in perm if owner[i] == k]
        alone = clusters_in_range([AcceptedBox(lo[i], hi[i], 0) for i in mine], ranges, tol)
        assert len(many[k]) == len(alone)
        for a, b in zip(many[k], alone):
            assert np.array_equal(a.angles, b.angles) and np.array_equal(a.lo, b.lo) and np.array_equal(a.hi, b.hi)
            assert a.n_boxes == b.n_boxes and np.array_equal(a.members, b.members)
        merged += sum(c.n_boxes > 1 for c in alone)
        far = all(np.abs(np.remainder(lo[i] - lo[j] + math.pi, 2 * math.pi) - math.pi).max() > 3 * tol
                  for i in mine for j in mine if i < j)
        if far:
            hand = _clusters_by_hand(lo[mine], hi[mine], ranges, tol)
            assert len(hand) == len(many[k])
            for (c, a, b), got in zip(hand, many[k]):
                assert np.allclose(got.angles, c, atol=1e-15) and np.array_equal(got.lo, a)
    assert merged >= 3                                            # the near pairs were merged


def test_a_ctrl_c_during_a_search_says_ctrl_c_and_what_it_had_done():
    """A plain KeyboardInterrupt (no text) reads "interrupted (Ctrl-C) after N boxes", not "interrupted ()"
    (issue 42 item 17), and the solve reports what was accepted as interrupted."""
    calls = []

    def progress(counts):
        calls.append(counts)
        if len(calls) == 3:
            raise KeyboardInterrupt

    report = solve(gosselin(), (0.3, -0.2, 0.5), system="loops", formulation="halves", jobs=1, progress=progress,
                   trace=lambda record: None)
    limit = report.settings.limit
    assert limit.interrupted and limit.error.startswith("interrupted (Ctrl-C) after ") and "boxes" in limit.error
    assert not report.count_exact
