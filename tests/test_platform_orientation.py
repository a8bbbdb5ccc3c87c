"""Tests for spherekin.systems.platform (the platform formulation) and its solve path.

References: Rodrigues' formula for the quaternion rotation; sympy for the chart polynomials and
their Bernstein coefficients (exact rationals); the mechanism's own inverse kinematics (Paden-Kahan
subproblems, an independent route) for the passive readings; the 50-digit complex-Newton reference
of references/reference_roots.py for the solutions.
"""

import math
from pathlib import Path
from fractions import Fraction

import dataclasses

import numpy as np
import pytest
import sympy as sp

from references.reference_roots import reference_roots
from references.random_designs import random_3rrr, random_rotation
from spherekin.problem import compile, solve
from spherekin.mechanism import four_bar, general_3rrr, gosselin, load_mechanism
from spherekin.search.boxloop import search_platform
from spherekin.search.parameterizations import stack_chart_sets
from spherekin.systems.platform import (CHART_CORE, CHART_EXTENT, PlatformSystem, Quaternion, chart_control_points, chart_quaternion,
                                            chart_rotation, form_matrix, not_applicable, passive_names, passive_readings,
                                            passive_readings_many,
                                            quaternion_matrix)
from spherekin.trust.solutions import is_proven
from tests.conftest import rot, unit, wrap


def _random_unit(rng):
    return unit(rng.normal(size=3))


@pytest.mark.parametrize("seed", range(5))
def test_quaternion_matrix_is_the_rotation_by_twice_the_half_angle(seed):
    rng = np.random.default_rng(seed)
    axis, angle = _random_unit(rng), rng.uniform(-math.pi, math.pi)
    scale = rng.uniform(0.3, 3.0)                         # S(q) is homogeneous of degree 2
    q = scale * np.array([math.cos(angle / 2), *(math.sin(angle / 2) * axis)])
    np.testing.assert_allclose(quaternion_matrix(q) / (q @ q), rot(angle * axis), atol=1e-14)


@pytest.mark.parametrize("seed", range(5))
def test_form_matrix_is_the_homogenized_leg_equation(seed):
    rng = np.random.default_rng(seed)
    e, a, c = _random_unit(rng), _random_unit(rng), rng.uniform(-1, 1)
    m = form_matrix(e, a, c)
    np.testing.assert_allclose(m, m.T, atol=0)
    for _ in range(5):
        q = rng.normal(size=4)
        r = quaternion_matrix(q) / (q @ q)
        assert q @ m @ q == pytest.approx((q @ q) * (e @ r @ a - c), abs=1e-13)


def test_chart_control_points_are_the_exact_bernstein_coefficients():
    """Against sympy: q^T M q with q_k = 1 and q_j = E (2 x_j - 1), expanded in the tensor
    Bernstein basis of degree (2, 2, 2) by the textbook formula, for a rational M (all exact)."""
    rng = np.random.default_rng(7)
    ints = rng.integers(-9, 10, size=(4, 4))
    m = (ints + ints.T) / 8.0                               # exact in binary and in Fraction
    got = chart_control_points(m)
    x = sp.symbols("x0:3")
    ext = sp.Rational(Fraction(CHART_EXTENT))
    for k in range(4):
        free = iter(x)
        q = [sp.Integer(1) if j == k else ext * (2 * next(free) - 1) for j in range(4)]
        f = sp.expand(sum(sp.Rational(Fraction(float(m[i, j]))) * q[i] * q[j] for i in range(4) for j in range(4)))
        poly = sp.Poly(f, *x)
        for idx in np.ndindex(3, 3, 3):
            # b_I = sum_{J <= I} prod_v C(I_v, J_v) / C(2, J_v) a_J
            b = sum(poly.coeff_monomial(x[0] ** j0 * x[1] ** j1 * x[2] ** j2)
                    * math.prod(sp.binomial(i, j) / sp.binomial(2, j) for i, j in zip(idx, (j0, j1, j2)))
                    for j0 in range(idx[0] + 1) for j1 in range(idx[1] + 1) for j2 in range(idx[2] + 1))
            assert Fraction(float(got[k][idx])) == Fraction(int(sp.numer(b)), int(sp.denom(b))), (k, idx)


def test_charts_cover_every_rotation_with_room_to_spare():
    rng = np.random.default_rng(3)
    for _ in range(200):
        r = random_rotation(rng)
        hits = 0
        for k in range(4):
            # the quaternion of r with q_k = 1, if |q_k| is large enough for this chart
            from references.peers_closed_form import rotation_quaternion

            q = rotation_quaternion(r)
            if abs(q[k]) < 1e-9:
                continue
            u = np.delete(q / q[k], k)
            if np.all(np.abs(u) <= CHART_EXTENT):
                x = (u / CHART_EXTENT + 1) / 2
                np.testing.assert_allclose(chart_rotation(k, x), r, atol=1e-13)
                np.testing.assert_allclose(chart_quaternion(k, x)[0], q / q[k], atol=1e-15)
                hits += 1
                # the chart that holds the largest component holds r strictly inside
                if k == int(np.argmax(np.abs(q))):
                    assert np.all(np.abs(u) <= 1.0 + 1e-15) and CHART_EXTENT > 1.0
        assert hits >= 1


def driven_at(position):
    """general_3rrr with each leg's joint at ``position`` (1 elbow, 2 platform joint) actuated instead."""
    def make():
        mech = general_3rrr()
        legs = tuple(dataclasses.replace(leg, joints=tuple(dataclasses.replace(j, actuated=(k == position))
                                                           for k, j in enumerate(leg.joints))) for leg in mech.legs)
        return dataclasses.replace(mech, legs=legs)
    return make


@pytest.mark.parametrize("preset", [gosselin, general_3rrr, driven_at(1), driven_at(2)])
def test_passive_readings_match_inverse_kinematics(preset):
    """For random poses, every inverse-kinematics working mode gives inputs and passive angles; the
    passive readings recovered from (inputs, pose) must be that working mode's, and Eq. (1) holds."""
    mech = preset()
    system = PlatformSystem.from_mechanism(mech)
    rng = np.random.default_rng(11)
    checked = 0
    for _ in range(20):
        r = random_rotation(rng)
        for mode in mech.inverse_kinematics(r):
            readings = passive_readings(system.legs, mode.inputs, r, system.platform_reference)
            batch = passive_readings_many(system.legs, mode.inputs, r[None], system.platform_reference)[0]
            for name, value in readings.items():
                assert abs(wrap(value - mode.joint_angles[name])) < 1e-9, name
            for name, value in zip(passive_names(system.legs), batch):
                assert abs(wrap(value - mode.joint_angles[name])) < 1e-9, name
            assert np.abs(system.residuals(mode.inputs, r)).max() < 1e-12
            checked += 1
    assert checked > 20


@pytest.mark.parametrize("preset", [gosselin, general_3rrr, driven_at(1), driven_at(2)])
def test_batch_passive_readings_equal_the_reference_at_any_pose(preset):
    """The batch readings equal the one-pose reference column for column at random poses and inputs
    (poses that are no assembly of those inputs too: the formulas must agree everywhere)."""
    mech = preset()
    system = PlatformSystem.from_mechanism(mech)
    rng = np.random.default_rng(23)
    poses = np.array([random_rotation(rng) for _ in range(40)])
    inputs = rng.uniform(-np.pi, np.pi, 3)
    batch = passive_readings_many(system.legs, inputs, poses, system.platform_reference)
    assert batch.shape == (40, 6)
    for r, row in zip(poses, batch):
        ref = passive_readings(system.legs, inputs, r, system.platform_reference)
        assert list(ref) == list(passive_names(system.legs))
        assert max(abs(wrap(a - b)) for a, b in zip(row, ref.values())) < 1e-12
    # one input row per pose (a tracked path): the same as the reference pose by pose
    rows = rng.uniform(-np.pi, np.pi, (40, 3))
    batch = passive_readings_many(system.legs, rows, poses, system.platform_reference)
    for r, x, row in zip(poses, rows, batch):
        ref = passive_readings(system.legs, x, r, system.platform_reference)
        assert max(abs(wrap(a - b)) for a, b in zip(row, ref.values())) < 1e-12


def test_residuals_do_not_vanish_off_the_assembly():
    mech = general_3rrr()
    system = PlatformSystem.from_mechanism(mech)
    rng = np.random.default_rng(5)
    r = random_rotation(rng)
    mode = mech.inverse_kinematics(r)[0]
    other = np.array(mode.inputs) + np.array([0.3, 0.0, 0.0])
    res = system.residuals(other, r)
    assert abs(res[0]) > 1e-3 and np.abs(res[1:]).max() < 1e-12


def test_control_points_evaluate_to_the_leg_equations():
    """The Bernstein form at a chart point equals |q|^2 times Eq. (1) evaluated from the rotation."""
    from spherekin.search.isolation import evaluate_at

    mech = general_3rrr()
    system = PlatformSystem.from_mechanism(mech)
    rng = np.random.default_rng(2)
    inputs = rng.uniform(-math.pi, math.pi, 3)
    cps = system.control_points(inputs)
    for k in range(4):
        x = rng.uniform(0, 1, 3)
        q = chart_quaternion(k, x)[0]
        vals = evaluate_at(cps[k][..., None], x[None])[:, 0]
        np.testing.assert_allclose(vals, (q @ q) * system.residuals(inputs, chart_rotation(k, x)), atol=1e-13)


def _same_poses(report, reference):
    got = [s.platform_rotation for s in report.solutions]
    assert len(got) == reference.count
    for q in reference.rotations:
        assert min(np.abs(g - q).max() for g in got) < 1e-9


@pytest.mark.parametrize("system", ["complete", "platform"])
@pytest.mark.parametrize("seed", range(6))
def test_platform_solve_equals_the_50_digit_reference_on_random_geometries(seed, system):
    rng = np.random.default_rng(100 + seed)
    mech, data = random_3rrr(rng)
    geometry = tuple(np.array(v, dtype=float) for v in data)
    inputs = rng.uniform(-math.pi, math.pi, 3)
    rep = solve(mech, tuple(inputs), system=system)
    ref = reference_roots(geometry, inputs)
    assert rep.count_exact and rep.proven_count == ref.count
    _same_poses(rep, ref)
    if rep.settings.formulation in ("platform", "complete"):
        assert rep.settings.parameterization == "quaternion" and rep.stats.charts == 4
    else:   # the loop equations answered: the report says why
        assert "platform search" in rep.settings.fallback


def test_gosselin_by_the_platform_formulation():
    from tests.conftest import GOSSELIN_INPUTS

    rep = solve(gosselin(), GOSSELIN_INPUTS, system="platform")
    assert rep.settings.formulation == "platform" and rep.settings.fallback is None
    assert sorted(s.status for s in rep.solutions) == ["certified"] * 4 + ["singular"] * 4
    assert rep.stats.isolated >= 8 and rep.stats.accepted == 0
    assert all(is_proven(s) for s in rep.solutions) and rep.count_exact
    halves = solve(gosselin(), GOSSELIN_INPUTS, formulation="halves")
    for a, b in zip(rep.solutions, halves.solutions):
        np.testing.assert_allclose(a.angles, b.angles, atol=1e-12)


def test_platform_roots_outside_passive_ranges_are_dropped():
    mech = general_3rrr()
    rng = np.random.default_rng(4)
    modes = ()
    while not modes:                          # a pose the mechanism reaches
        r = random_rotation(rng)
        modes = mech.inverse_kinematics(r)
    mode = modes[0]
    full = solve(mech, mode.inputs, system="platform")
    assert full.settings.formulation == "platform"
    target = next(s for s in full.solutions if np.abs(s.platform_rotation - r).max() < 1e-9)
    # limit gamma1 to a range of 0.02 rad around this solution's gamma1: only the solutions with
    # gamma1 inside it remain (counted independently from the full solve's angles)
    g = full.unknowns.index("gamma1")
    centre = float(target.angles[g])
    from spherekin.mechanism import SphericalMechanism, Leg, Joint

    legs = []
    for leg in mech.legs:
        joints = [Joint(j.name, j.axis, j.actuated, (centre - 0.01, centre + 0.01) if j.name == "gamma1" else j.range,
                        j.reference_angle) for j in leg.joints]
        legs.append(Leg(leg.name, joints))
    narrow = SphericalMechanism(legs, mech.name, mech.reference_leg, mech.platform_reference, mech.kind,
                                mech.geometry)
    expected = [s for s in full.solutions if abs(wrap(s.angles[g] - centre)) <= 0.01]
    for system in ("platform", "complete"):
        rep = solve(narrow, mode.inputs, system=system)
        assert rep.settings.formulation == system
        assert len(rep.solutions) == len(expected) >= 1


def test_not_applicable_and_strategy_errors():
    assert not_applicable(gosselin()) is None
    why = not_applicable(four_bar())
    assert why is not None and "3 legs" in why or "R-R-R" in why
    with pytest.raises(ValueError, match="formulation 'platform'"):
        compile(four_bar(), formulation="platform")
    with pytest.raises(ValueError, match="isolate"):
        compile(gosselin(), formulation="platform", isolate=False)
    with pytest.raises(ValueError, match="expected one of .*'auto', 'complete', 'complete-loop', 'platform'"):
        compile(gosselin(), formulation="quaternion")
    # auto: the loop equations where the platform formulation does not apply, and why (a four-bar written
    # as a graph: as legs, the one-loop count takes it first)
    graph = load_mechanism(Path(__file__).resolve().parent.parent / "examples" / "four_bar_graph.toml")
    assert compile(graph).strategy.formulation == "halves"
    assert "the platform formulation needs three legs" in dict(compile(graph).declined)["platform"]
    assert compile(four_bar(), system="loops").strategy.formulation == "halves"
    p = compile(gosselin(), parameterization="sin-cos")
    assert p.strategy.formulation == "halves" and "sin-cos" in dict(p.declined)["platform"]
    assert "sin-cos" in dict(p.declined)["complete"]
    assert compile(gosselin(), isolate=False).strategy.formulation == "halves"


def test_solve_many_equals_one_solve_per_row_and_checks_rows_first():
    mech = general_3rrr()
    rng = np.random.default_rng(9)
    rows = rng.uniform(-math.pi, math.pi, (4, 3))
    problem = compile(mech, system="platform")
    seen = []
    many = problem.solve_many(rows, progress=lambda done, total: seen.append((done, total)), chunk=3)
    assert seen == [(3, 4), (4, 4)]                   # after each chunk
    for row, rep in zip(rows, many):
        one = solve(mech, tuple(row), system="platform")
        assert list(rep.settings.inputs) == list(row)
        assert [s.angles.tolist() for s in rep.solutions] == [s.angles.tolist() for s in one.solutions]
    with pytest.raises(ValueError, match=r"shape \(K, 3\)"):
        problem.solve_many(rows[:, :2])
    bad = rows.copy()
    bad[2, 1] = np.nan
    with pytest.raises(ValueError, match="inputs row 2"):
        problem.solve_many(bad)
    with pytest.raises(ValueError, match="chunk: expected a positive number of inputs, got 0"):
        problem.solve_many(rows, chunk=0)


def test_disagreement_between_platform_roots_and_finalized_solutions():
    from spherekin.systems.platform import disagreement
    from spherekin.results import Solution

    r1, r2 = rot([0.1, 0.2, 0.3]), rot([-0.4, 0.0, 0.9])

    def entry(r, status="certified"):
        z = np.zeros(6)
        return Solution(z, z, z, 1, platform_rotation=r, status=status, evidence={"krawczyk_certified": True})

    assert disagreement([entry(r1), entry(r2)], [r1, r2, r2 + 1e-12]) is None      # a duplicate root
    assert "could not prove" in disagreement([entry(r1), entry(r2, "unverified")], [r1, r2])
    assert "found 2 assemblies and the trust layer 1" in disagreement([entry(r1)], [r1, r2])
    assert "found 1 assemblies and the trust layer 2" in disagreement([entry(r1), entry(r2)], [r1])
    assert disagreement([entry(r1)], [r2]) is not None                               # moved by polishing
    assert "found 1 assemblies and the trust layer 1" in disagreement([entry(None)], [r1])   # no pose


def test_the_disagreements_of_a_chunk_are_each_inputs_own():
    """disagreements over a chunk of inputs against the rule written out for each input alone (every
    entry proven; the distinct roots, greedily within POSE_MATCH, as many as the entries, each
    matched by one), on random cases: duplicates, a root moved, entries missing or extra, unproven
    ones, inputs without roots or entries; roots of one input never match entries of another."""
    from spherekin.systems.platform import POSE_MATCH, disagreements
    from spherekin.results import Solution

    rng = np.random.default_rng(35)

    def entry(r, status):
        z = np.zeros(6)
        return Solution(z, z, z, 1, platform_rotation=r, status=status, evidence={"krawczyk_certified": True})

    def by_hand(sols, roots):
        if any(s.status not in ("certified", "singular") for s in sols):
            return "could not prove"
        distinct = []
        for r in roots:
            if all(np.abs(r - d).max() > POSE_MATCH for d in distinct):
                distinct.append(r)
        got = [s.platform_rotation for s in sols]
        ok = len(got) == len(distinct) and all(any(np.abs(g - r).max() <= POSE_MATCH for g in got) for r in distinct)
        return None if ok else f"found {len(distinct)} assemblies and the trust layer {len(got)}"

    cases = []
    shared = rot(rng.normal(size=3))
    for k in range(40):
        roots = [rot(rng.normal(size=3)) for _ in range(k % 5)] + ([shared] if k % 7 == 0 else [])
        sols = [entry(r, "certified") for r in roots]
        roots = roots + [r + 0.5 * POSE_MATCH for r in roots[:k % 3]]           # found twice
        kind = k % 6
        if kind == 1 and sols:
            sols[0] = entry(sols[0].platform_rotation + 3 * POSE_MATCH, "certified")  # moved
        elif kind == 2 and sols:
            sols.pop()                                                         # one missing
        elif kind == 3:
            sols.append(entry(shared, "singular"))                             # one extra (another input's root)
        elif kind == 4 and sols:
            sols[-1] = entry(sols[-1].platform_rotation, "unverified")
        cases.append((sols, roots))
    got = disagreements([c[0] for c in cases], [c[1] for c in cases])
    kinds = set()
    for (sols, roots), g in zip(cases, got):
        want = by_hand(sols, roots)
        assert (g is None) == (want is None) and (want is None or want in g), (want, g)
        kinds.add(want.split(" ")[0] if want else None)
    assert kinds == {None, "could", "found"}


def test_a_platform_answer_the_trust_layer_disagrees_with_goes_to_the_loop_equations(monkeypatch):
    """The wiring of the check: the first trust layer (platform roots) loses one entry, as a broken
    passive-angle map or polish would; the input must be solved again with the loop equations."""
    import spherekin.problem as pipeline
    from tests.conftest import GOSSELIN_INPUTS

    real = pipeline.finalize_many
    calls = []

    def lossy(*args, **kwargs):
        out = real(*args, **kwargs)            # one list of entries per input of the chunk (one here)
        calls.append(len(out[0]))
        return [out[0][1:]] if len(calls) == 1 else out

    monkeypatch.setattr(pipeline, "finalize_many", lossy)
    rep = pipeline.solve(gosselin(), GOSSELIN_INPUTS, system="platform")
    assert calls == [8, 8]
    assert "found 8 assemblies and the trust layer 7" in rep.settings.fallback
    assert rep.settings.formulation == "halves" and len(rep.solutions) == 8 and rep.count_exact


def test_a_chart_drops_exactly_the_boxes_another_chart_surely_searches():
    """Quaternion.contract against its rule evaluated on the points of each reduced box: on chart k
    (q_k = 1, the other components u = CHART_EXTENT (2x - 1)), a box is dropped iff some free |u_j|
    exceeds CHART_CORE on the whole box, or the whole box lies in the core of a chart i < k
    (max_l |q_l| <= CHART_CORE |q_i|). The extremes of every |u_l| on a box are at its ends or at
    0, so the box's points are checked on that grid; every other box keeps its reduction. Also:
    the charts are taken modulo 4 (a chunk stacks the 4 charts of each input)."""
    rng = np.random.default_rng(34)
    n = 1500
    centre = rng.choice([-1.0, 1.0], (n, 3)) * rng.uniform(0.7, 1.3, (n, 3)) * (rng.random((n, 3)) < 0.8)
    half = rng.uniform(0.005, 0.3, (n, 3))
    lo = np.clip((centre - half) / (2 * CHART_EXTENT) + 0.5, 0, 1)
    hi = np.clip((centre + half) / (2 * CHART_EXTENT) + 0.5, 0, 1)
    rlo, rhi = rng.uniform(0, 0.2, (n, 3)), rng.uniform(0.8, 1.0, (n, 3))
    charts = stack_chart_sets([PlatformSystem.from_mechanism(gosselin()).charts(v) for v in ((0.1, 0.2, 0.3), (0, 0, 1))])
    chart = rng.integers(0, 8, n)
    got_lo, got_hi = rlo.copy(), rhi.copy()
    Quaternion().contract(charts, chart, lo, hi, got_lo, got_hi)
    dropped = 0
    for b in range(n):
        k = chart[b] % 4
        ends = [CHART_EXTENT * (2 * (lo[b] + r * (hi[b] - lo[b])) - 1) for r in (rlo[b], rhi[b])]
        grid = [sorted({ends[0][j], ends[1][j]} | ({0.0} if ends[0][j] < 0 < ends[1][j] else set())) for j in range(3)]
        points = np.array([np.insert([a, c, d], k, 1.0) for a in grid[0] for c in grid[1] for d in grid[2]])
        free = [l for l in range(4) if l != k]
        beyond = any(np.all(np.abs(points[:, l]) > CHART_CORE) for l in free)
        earlier = any(np.all(np.abs(points).max(axis=1) <= CHART_CORE * np.abs(points[:, i])) for i in range(k))
        if beyond or earlier:
            assert np.any(got_lo[b] > got_hi[b]), (b, k, grid)
            dropped += 1
        else:
            assert np.array_equal(got_lo[b], rlo[b]) and np.array_equal(got_hi[b], rhi[b]), (b, k, grid)
    assert 100 < dropped < n - 100


def test_no_root_is_lost_to_the_chart_cores_not_even_tied_ones():
    """Every root of the 50-digit reference (random 3-RRRs) or of the loop equations (the agile eye,
    whose serially singular assemblies have two largest components of equal modulus, |u_j| = 1 on
    two charts) is among the platform search's roots."""
    from tests.conftest import GOSSELIN_INPUTS

    rng = np.random.default_rng(33)
    cases = [(gosselin(), GOSSELIN_INPUTS, None)]
    while len(cases) < 5:                              # random 3-RRRs at inputs with two roots or more
        mech, data = random_3rrr(rng)
        inputs, geometry = tuple(rng.uniform(-math.pi, math.pi, 3)), tuple(np.array(v, dtype=float) for v in data)
        if reference_roots(geometry, inputs).count >= 2:
            cases.append((mech, inputs, geometry))
    ties = 0
    for mech, inputs, geometry in cases:
        problem = compile(mech)
        found = search_platform(problem.compiled("platform").charts(inputs), problem.compiled("platform").pruner, 1e-6)
        rots = [problem.compiled("platform").pose(c, x) for c, x in found.points]
        if geometry:
            expect = reference_roots(geometry, inputs).rotations
        else:                                          # the loop equations: another formulation
            expect = [s.platform_rotation for s in solve(mech, inputs, formulation="halves").solutions]
            q = np.array([chart_quaternion(c, x)[0] for c, x in found.points])
            q = np.sort(np.abs(q) / np.abs(q).max(axis=1, keepdims=True), axis=1)
            ties += int(np.sum(q[:, -2] > 1 - 1e-9))
        assert len(expect) >= 2
        for q in expect:
            assert min(np.abs(r - q).max() for r in rots) < 1e-9
    assert ties >= 4                                   # the agile eye's tied assemblies
