"""systems/one_loop.py: the complete count of a one-loop linkage (bound 2), against independent references.

The reference is references/edge_references.two_leg_reference: the four-bar's and five-bar's assemblies at
50 digits from the sign of a Gram determinant and the points B, D, C (not the loop's A cos y + B sin y = C);
its branch and change inputs (two_leg_edges) give inputs 1e-2 .. 1e-16 from where the count changes.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import spherekin
from references import edge_references as er
from spherekin.core.angles import RANGE_TOL
from spherekin.mechanism import Joint, Leg, SphericalMechanism, five_bar, four_bar, general_3rrr, load_mechanism
from spherekin.systems import Passed, Proven
from spherekin.systems.one_loop import OneLoop, not_one_loop

from conftest import with_range
from test_trust_many import rocker_driven_four_bar


def _rows(mech, n, seed):
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(*(mech.ranges.get(a) or (-math.pi, math.pi)), n) for a in mech.actuated])


@pytest.mark.parametrize("make", [four_bar, five_bar, rocker_driven_four_bar])
def test_the_count_and_poses_are_the_50_digit_references(make):
    mech = make()
    rows = _rows(mech, 60, 3)
    problem = spherekin.compile(mech)
    assert problem.system == "complete-loop"
    for row, rep in zip(rows, problem.solve_many(rows)):
        ref = er.two_leg_reference(mech, row)
        if ref.count is None:
            continue
        assert rep.count_exact and rep.proven_count == ref.count, (row, rep.proven_count, ref.count)
        if rep.settings.system != "complete-loop":
            continue
        for r in ref.rotations:
            assert min(np.abs(s.platform_rotation - r).max() for s in rep.solutions) < 1e-9
        for s in rep.solutions:
            enc = s.evidence["root_enclosure"]
            assert np.all(np.array(enc["lo"]) <= s.angles) and np.all(s.angles <= np.array(enc["hi"]))
            assert s.residual < 1e-12 and s.evidence["bezout"]["bound"] == 2


def test_the_same_assemblies_as_the_loop_equations():
    for mech in (four_bar(), five_bar()):
        rows = _rows(mech, 40, 4)
        fast = spherekin.compile(mech).solve_many(rows)
        boxes = spherekin.compile(mech, system="loops").solve_many(rows)
        for a, b in zip(fast, boxes):
            assert a.count_exact and b.count_exact and a.proven_count == b.proven_count
            for s in a.solutions:
                t = min(b.solutions, key=lambda t: np.abs(t.platform_rotation - s.platform_rotation).max())
                assert np.abs(t.platform_rotation - s.platform_rotation).max() < 1e-9
                assert (s.status, s.singularity) == (t.status, t.singularity)


def test_next_to_branch_and_change_points_it_is_right_or_passes():
    """Every edge of the preset five-bar and the rocker-driven four-bar (limit inputs, where the two
    assemblies meet), 1e-2 .. 1e-16 away on both sides: what the one-loop count proves is the 50-digit count
    (the discriminant grows linearly from an edge: proven down to ~1e-12); at 1e-16 it passes the input on
    (the discriminant's enclosure holds 0)."""
    proven = passed = 0
    for mech in (rocker_driven_four_bar(), five_bar()):
        compiled = spherekin.compile(mech).compiled("complete-loop")
        for edge in er.two_leg_edges(mech)[:2]:
            pairs = [(d, er.inputs_at(edge, d)[0]) for d in (1e-2, -1e-2, 1e-6, -1e-6, 1e-12, -1e-12, 1e-16, -1e-16)]
            for (dist, x), answer in zip(pairs, compiled.search_many([tuple(x) for _, x in pairs], None)):
                ref = er.two_leg_reference(mech, x)
                if isinstance(answer, Proven):
                    proven += 1
                    assert ref.count is not None and answer.proven == ref.count, (dist, answer.proven, ref.count)
                else:
                    passed += 1
                    assert isinstance(answer, Passed) and "A^2 + B^2 - C^2" in answer.reason
                if abs(dist) <= 1e-16 and edge.kind in ("branch", "change"):
                    assert isinstance(answer, Passed), dist
                if abs(dist) >= 1e-2:
                    assert isinstance(answer, Proven), dist
    assert proven and passed


def test_a_reading_at_a_range_end_is_passed_on_and_ends_a_hair_away_are_decided():
    mech, x = four_bar(), (0.7,)
    full = spherekin.solve(mech, x)
    assert full.settings.system == "complete-loop" and full.proven_count == 2
    c = full.solutions[0].passive_angles["C"]
    other = full.solutions[1].passive_angles["C"]
    assert abs(math.remainder(other - c, 2 * math.pi)) > 0.1
    at_end = with_range(mech, "C", (c - 0.05, c - RANGE_TOL))
    rep = spherekin.solve(at_end, x)
    assert rep.settings.system != "complete-loop" and "joint ranges" in rep.settings.fallback
    for end, kept in ((c + 1e-6, 1), (c - 1e-6, 0)):
        ranged = with_range(mech, "C", (c - 0.05, end))
        rep, boxes = spherekin.solve(ranged, x), spherekin.solve(ranged, x, system="loops")
        assert rep.settings.system == "complete-loop" and rep.proven_count == boxes.proven_count == kept


def test_what_it_accepts():
    assert OneLoop.accepts(four_bar()) is None and OneLoop.accepts(five_bar()) is None
    assert "two legs" in not_one_loop(general_3rrr())
    graph = load_mechanism("examples/four_bar_graph.toml")           # a graph, not written as legs
    assert "two legs" in OneLoop.accepts(graph)
    assert spherekin.compile(graph).system == "loops"
    with pytest.raises(ValueError, match="formulation 'complete-loop'"):
        spherekin.compile(general_3rrr(), formulation="complete-loop")


def test_the_equation_is_enclosed_for_every_mechanism_within_the_tolerance_of_the_model():
    """A, B, C of axes each turned by ~3e-15 (a description the model rounds) lie in the intervals computed
    from the model's axes: the proof is about the mechanism as described, not one rounding of it."""
    from spherekin.systems import one_loop

    mech = four_bar()
    rng = np.random.default_rng(5)
    legs = []
    for leg in mech.legs:
        joints = []
        for j in leg.joints:
            axis = np.array(j.axis) + 3e-15 * rng.normal(size=3)
            joints.append(Joint(j.name, tuple(axis / np.linalg.norm(axis)), j.actuated, j.range, j.reference_angle))
        legs.append(Leg(leg.name, tuple(joints)))
    turned = SphericalMechanism(tuple(legs), name="turned", reference_leg=mech.reference_leg)
    rows = _rows(mech, 200, 6)
    got = one_loop._abc_interval(*one_loop.LoopCycle(mech).terms(rows, interval=True)[:4])
    want = one_loop._abc_float(*one_loop.LoopCycle(turned).terms(rows, interval=False)[:4])
    moved = max(np.abs(w - one_loop._abc_float(*one_loop.LoopCycle(mech).terms(rows, interval=False)[:4])[k]).max()
                for k, w in enumerate(want))
    assert moved > 1e-16                                   # the turn does move the equation
    for (lo, hi), w in zip(got, want):
        assert np.all((lo <= w) & (w <= hi))
