"""The comparison experiments (parameterizations, lp_backends, scaling) on tiny inputs, checked
against independent values: control-point counts from the degrees, closure by scipy rotation
products, the ground-truth configuration among the solutions, pi found exactly."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from experiments import _compare
from experiments import lp_backends as lpx
from experiments import parameterizations as par
from experiments import scaling

# fast: the whole file runs in a few seconds (not marked slow, so part of make test)

#: Solutions are polished to ~1e-15; the closure checked here with scipy must hold far below 1e-9.
CLOSURE = 1e-9


def _rodrigues_pose(mech, leg, readings):
    """Platform pose from a leg by scipy rotation-vector products (independent of spherekin's chains)."""
    out = np.eye(3)
    for j in leg.joints:
        out = out @ Rotation.from_rotvec(np.array(j.axis) * (readings[j.name] - j.reference_angle)).as_matrix()
    return out @ mech.platform_reference_matrix


def _closes(mech, readings) -> float:
    poses = [_rodrigues_pose(mech, leg, readings) for leg in mech.legs]
    return max(float(np.abs(p - poses[0]).max()) for p in poses[1:])


def _dist(a, b):
    d = np.asarray(a) - np.asarray(b)
    return float(np.abs((d + math.pi) % (2 * math.pi) - math.pi).max())


def _passive_per_loop(mech):
    """Unknown angles of each loop, counted from the loop's vertices (non-actuated joints)."""
    return [len({v.joint for v in g.vertices if not v.actuated}) for g in mech.loop_geometry]


@pytest.mark.parametrize("name", ["four_bar", "gosselin"])
def test_control_points_per_equation_from_degrees(name):
    mech = _compare.MECHANISMS[name][0]()
    inputs = [0.3] * len(mech.actuated)
    k = _passive_per_loop(mech)
    n = len(mech.passive)
    th = par.chart_summary(mech, inputs, "tan-half")
    # tan-half: degree 2 in each of the loop's k angles -> 3^k; full circles -> 2 charts per angle
    assert th["loop_control_points"] == sorted({3 ** kk for kk in k})
    assert th["charts"] == 2 ** n and th["variables"] == n
    # sin-cos: multilinear, degree 1 in c and in s of each angle -> (2 * 2)^k; circle c^2 + s^2 - 1: 3 * 3
    sc = par.chart_summary(mech, inputs, "sin-cos")
    assert sc["loop_control_points"] == sorted({4 ** kk for kk in k})
    assert sc["circle_control_points"] == [9]
    assert sc["charts"] == 1 and sc["variables"] == 2 * n


def test_parameterizations_agree_with_ground_truth_and_close():
    rng = np.random.default_rng(3)
    for name in ("four_bar", "gosselin"):
        rows = par.compare_mechanism(name, 1, 1, rng)
        mech = _compare.MECHANISMS[name][0]()
        assert {r["parameterization"] for r in rows} == {"tan-half", "sin-cos", par.DEFAULT_ROW}
        sets = {}
        for r in rows:
            inputs = dict(zip(mech.actuated, r["inputs"]))
            assert r["n_solutions"] >= 1
            for s in r["solutions"]:
                assert _closes(mech, {**inputs, **dict(zip(r["unknowns"], s))}) < CLOSURE
            sets[r["parameterization"]] = r["solutions"]
            assert r["truth_found"]
        # the two parameterizations: same solutions, checked here pairwise
        a, b = sets["tan-half"], sets["sin-cos"]
        assert len(a) == len(b)
        assert all(min(_dist(x, y) for y in b) < 1e-7 for x in a)


def test_four_bar_has_the_two_closed_form_assemblies():
    """Spherical four-bar at a crank angle: exactly two assemblies (the two circle intersections)."""
    mech = _compare.MECHANISMS["four_bar"][0]()
    rng = np.random.default_rng(5)
    case = _compare.random_cases(mech, rng, 1)[0]
    res = par.solve_case(mech, case, par.VARIANTS["tan-half"], 1)
    assert res["n_solutions"] == 2
    # the coupler joint C of each assembly: at the coupler twist from B and the rocker twist from D
    legs = {leg.name: leg for leg in mech.legs}
    twist_bc = math.acos(np.clip(np.dot(legs["crank"].joints[1].axis, legs["rocker"].joints[1].axis), -1, 1))
    twist_dc = legs["rocker"].twists[0]
    for s in res["solutions"]:
        readings = {**dict(zip(mech.actuated, case.inputs)), **dict(zip(res["unknowns"], s))}
        rot = _rodrigues_pose(mech, legs["crank"], readings) @ mech.platform_reference_matrix.T
        b, c = rot @ np.array(legs["crank"].joints[1].axis), rot @ np.array(legs["rocker"].joints[1].axis)
        d = np.array(legs["rocker"].joints[0].axis)
        assert math.acos(np.clip(b @ c, -1, 1)) == pytest.approx(twist_bc, abs=1e-9)
        assert math.acos(np.clip(d @ c, -1, 1)) == pytest.approx(twist_dc, abs=1e-9)
    assert res["truth_found"]


def test_passive_angle_exactly_pi_found_by_both():
    mech = _compare.MECHANISMS["gosselin"][0]()
    case = par.pi_case(mech, "leg2", ("delta2",), np.random.default_rng(0))
    assert case.joints["delta2"] == math.pi
    assert _closes(mech, case.joints) < CLOSURE
    for p in par.PARAMETERIZATIONS:
        res = par.solve_case(mech, case, par.VARIANTS[p], 1)
        k = res["unknowns"].index("delta2")
        hits = [s for s in res["solutions"] if _dist(s, case.passive(res["unknowns"])) < 1e-7]
        assert len(hits) == 1, p
        assert abs(abs(math.remainder(hits[0][k], 2 * math.pi)) - math.pi) < 1e-12


def test_lp_backends_same_boxes_and_truth():
    prob = dict(problem="gosselin small", mechanism="gosselin", formulation="halves", half_width=0.2)
    rows = lpx.measure("highspy", [prob], 0, 1) + lpx.measure("highs", [prob], 0, 1)
    lpx.compare(rows, "highspy")
    _, ranges, truth = lpx._system(prob, 0)
    n = len(ranges)
    for r in rows:
        assert r["truth_found"] and r["doubts"] == 0
        assert r["same_counts"] and r["max_solution_diff"] < 1e-7
        # at most 2n bound LPs per box (+ one Farkas re-solve each), at least one per box not empty at once
        assert 0 < r["lps"] <= 2 * (2 * n) * r["boxes"]


def test_lp_backends_measures_a_refused_backend_in_its_own_process():
    """The experiment reports osqp and scs although spherekin refuses them: each is registered only in
    its own fresh process (this one still refuses it); its per-LP bounds are certified and never
    tighter than HiGHS's certified bounds beyond HiGHS's own dual slack (both are lower bounds of
    the same LP optimum; measured: highspy's lies within 1e-7 of it). One process: ~3 s."""
    from spherekin.search.lp_backends import LP_BACKENDS, REJECTED_LP_BACKENDS

    prob = dict(problem="gosselin small", mechanism="gosselin", formulation="halves", half_width=0.2)
    (q,) = lpx._in_fresh_process(lpx.bound_quality, "osqp", [prob], 0, 2)
    assert "osqp" in REJECTED_LP_BACKENDS and "osqp" not in LP_BACKENDS
    assert q["backend"] == "osqp" and q["boxes"] == 2 and q["lps"] >= 4
    assert q["certified_share"] > 0 and q["loose_median"] > -1e-6


def test_scaling_structure_and_small_run():
    red = scaling.structure(_compare.four_rrr(4))
    assert (red["legs"], red["loops"], red["unknowns"], red["equations"], red["inputs"]) == (4, 3, 8, 9, 4)
    sq = scaling.structure(_compare.four_rrr(3))
    assert (sq["unknowns"], sq["equations"], sq["inputs"]) == (9, 9, 3)
    rrrr = scaling.structure(_compare.three_rrr_rrrr())
    assert (rrrr["unknowns"], rrrr["inputs"], rrrr["joints_per_leg"]) == (6, 4, "3/3/4")
    data = scaling.run(quick=True, seed=1, mechanisms=["five_bar", "3rrr_rrrr"], parameterizations=("tan-half",),
                       repeats=1)
    for r in data["runs"]:
        assert r["truth_found"] and r["max_closure_error"] < CLOSURE
    assert data["runs"][0]["charts"] == 2 ** 3 and data["runs"][1]["charts"] == 2 ** 6


def test_ground_truth_cases_close_and_rotations_are_rotations():
    rng = np.random.default_rng(7)
    for _ in range(5):
        r = _compare.random_rotation(rng)
        assert np.allclose(r @ r.T, np.eye(3), atol=1e-12) and np.linalg.det(r) == pytest.approx(1.0)
    for make, ang in list(_compare.MECHANISMS.values()) + [(_compare.three_rrr_rrrr, 0.6)]:
        mech = make()
        for case in _compare.random_cases(mech, rng, 2, ang):
            assert _closes(mech, case.joints) < CLOSURE
