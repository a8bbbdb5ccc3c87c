"""Tests for spherekin.systems: the registry of equation systems, what each accepts, which one
"auto" chooses and how a solve reports it (Settings, JSON, the text of ``spherekin solve``)."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import spherekin
from spherekin.cli import main
from spherekin.mechanism import five_bar, four_bar, general_3rrr, gosselin, load_mechanism
from spherekin.problem import compile
from spherekin.results import Settings
from spherekin.systems import SYSTEMS, Strategy, System, choose, system_choices
from spherekin.systems.complete import Complete
from spherekin.systems.one_loop import OneLoop
from spherekin.systems.loops import Loops
from spherekin.systems.platform import Platform, PlatformSystem, leg_constants, platform_legs
from spherekin.trust.continuation import LegEquations
from tests.conftest import GOSSELIN_INPUTS

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def strategy(**kw) -> Strategy:
    base = dict(formulation="auto", pruner="pp", lp_backend=None, parameterization="tan-half", tol=1e-6,
                isolate=True, jobs=1, max_boxes=10_000, max_depth=None)
    return Strategy(**{**base, **kw})


def actuated_at(mech, *positions, name="elbow-actuated "):
    """``mech`` with each leg's joints at ``positions`` actuated instead of its first (1: a P-A-P 3-RRR)."""
    legs = tuple(dataclasses.replace(leg, joints=tuple(dataclasses.replace(j, actuated=(k in positions))
                                                       for k, j in enumerate(leg.joints))) for leg in mech.legs)
    return dataclasses.replace(mech, legs=legs, name=name + mech.name)


def elbow_actuated(mech):
    """``mech`` with each leg's second joint actuated instead of its first (a P-A-P 3-RRR)."""
    return actuated_at(mech, 1)


# ---------------------------------------------------------------- the registry

def test_the_registry_lists_the_systems_fastest_first():
    assert list(SYSTEMS) == ["complete", "complete-loop", "platform", "loops"]
    assert system_choices() == ("auto", "complete", "complete-loop", "platform", "loops")
    assert all(issubclass(cls, System) and cls.description and "\n" not in cls.description
               for cls in SYSTEMS.values())


def test_an_unknown_system_is_an_error_listing_the_valid_ones():
    with pytest.raises(ValueError, match=r"^system: expected one of \['complete', 'complete-loop', 'platform', 'loops'\], "
                                         r"got 'bogus'$"):
        SYSTEMS.lookup("bogus")
    with pytest.raises(ValueError, match=r"^system: expected one of \['auto', 'complete', 'complete-loop', 'platform', "
                                         r"'loops'\], got 'bogus'$"):
        compile(gosselin(), system="bogus")


def test_the_cli_rejects_an_unknown_system(capsys):
    assert main(["solve", str(EXAMPLES / "gosselin.toml"), "--inputs", "0.3,-0.2,0.5", "--system", "bogus"]) == 2
    assert "--system: expected one of auto, complete, complete-loop, platform, loops, got 'bogus'" in capsys.readouterr().err


# ---------------------------------------------------------------- accepts()

@pytest.mark.parametrize("make", [gosselin, general_3rrr])
def test_the_platform_system_accepts_a_3rrr_with_base_joints_actuated(make):
    assert Platform.accepts(make()) is None and Platform.accepts(make(), strategy()) is None


@pytest.mark.parametrize("make, words", [(four_bar, ["3 legs", "got 2"]), (five_bar, ["3 legs", "got 2"]),
                                         (lambda: actuated_at(general_3rrr(), 0, 1, name="redundant "),
                                          ["one joint actuated", "A-A-P"])])
def test_the_platform_system_says_why_it_does_not_accept(make, words):
    why = Platform.accepts(make())
    assert why is not None and all(w in why for w in words), why
    assert Loops.accepts(make()) is None and Loops.accepts(make(), strategy()) is None


@pytest.mark.parametrize("kw, words", [(dict(parameterization="sin-cos"), ["parameterization 'sin-cos'"]),
                                       (dict(isolate=False), ["isolate=False"]),
                                       (dict(formulation="paper"), ["formulation 'paper'"])])
def test_a_strategy_makes_the_platform_system_decline(kw, words):
    why = Platform.accepts(gosselin(), strategy(**kw))
    assert why is not None and all(w in why for w in words), why


def test_a_mechanism_without_legs_is_declined_with_that_reason():
    # a mechanism written as a graph that is not leg-shaped has no legs (an empty tuple)
    no_legs = type("NoLegs", (), {"legs": ()})()
    assert "has none" in Platform.accepts(no_legs)
    assert "has none" in Platform.accepts(type("Plain", (), {})())


def test_the_platform_formulation_asked_for_by_name_keeps_its_own_variables():
    # formulation "platform" (and system "platform") ignore the loop equations' parameterization, as before
    assert Platform.accepts(gosselin(), strategy(formulation="platform", parameterization="sin-cos")) is None
    assert compile(gosselin(), system="platform", parameterization="sin-cos").system == "platform"


# ---------------------------------------------------------------- auto

@pytest.mark.parametrize("make", [gosselin, general_3rrr])
def test_auto_chooses_the_complete_count_for_a_base_actuated_3rrr(make):
    cls, declined = choose(make(), strategy())
    assert cls is Complete and declined == ()
    problem = compile(make())
    assert (problem.system, problem.declined, problem.strategy.formulation) == ("complete", (), "complete")
    assert [c.system for c in problem.chain] == ["complete", "platform", "loops"]


@pytest.mark.parametrize("make", [lambda: elbow_actuated(general_3rrr()),
                                  lambda: actuated_at(gosselin(), 2, name="platform-joint-actuated ")])
def test_auto_chooses_the_platform_system_for_a_3rrr_driven_elsewhere(make):
    cls, declined = choose(make(), strategy())
    assert cls is Platform and [name for name, _ in declined] == ["complete", "complete-loop"]
    assert "base-actuated" in declined[0][1]
    problem = compile(make())
    assert (problem.system, problem.strategy.formulation) == ("platform", "platform")


@pytest.mark.parametrize("make", [four_bar, five_bar])
def test_auto_chooses_the_one_loop_count_for_a_linkage_of_two_legs(make):
    cls, declined = choose(make(), strategy())
    assert cls is OneLoop and declined == (("complete", Complete.accepts(make())),)
    problem = compile(make())
    assert (problem.system, problem.strategy.formulation) == ("complete-loop", "complete-loop")
    assert [c.system for c in problem.chain] == ["complete-loop", "loops"]


@pytest.mark.parametrize("make", [lambda: actuated_at(general_3rrr(), 0, 1, name="redundant "),
                                  lambda: load_mechanism(EXAMPLES / "four_bar_graph.toml")])
def test_auto_chooses_the_loops_system_with_the_faster_ones_reasons(make):
    cls, declined = choose(make(), strategy())
    assert cls is Loops and declined == (("complete", Complete.accepts(make())), ("complete-loop", OneLoop.accepts(make())),
                                         ("platform", Platform.accepts(make())))
    problem = compile(make())
    assert (problem.system, problem.strategy.formulation) == ("loops", "halves")
    assert problem.declined == declined


def test_auto_passes_over_the_platform_for_the_strategy_and_says_why():
    problem = compile(gosselin(), isolate=False)
    assert problem.system == "loops" and "isolate=False" in dict(problem.declined)["platform"]


def test_a_system_asked_for_by_name_is_used_or_refused_with_the_reason():
    assert compile(gosselin(), system="loops").system == "loops"
    assert compile(gosselin(), system="loops").declined == ()            # asked for: nothing passed over
    with pytest.raises(ValueError, match=r"^system 'platform': the platform formulation needs 3 legs"):
        compile(four_bar(), system="platform")
    with pytest.raises(ValueError, match=r"^system: expected 'auto' or 'loops' with formulation 'paper', got 'platform'"):
        compile(gosselin(), system="platform", formulation="paper")
    with pytest.raises(ValueError, match=r"^system: expected 'auto' or 'platform' with formulation 'platform'"):
        compile(gosselin(), system="loops", formulation="platform")


def test_both_systems_find_the_same_eight_assemblies_of_the_agile_eye():
    # the Gosselin platform at these inputs has 8 real assemblies (tests/test_platform_orientation.py
    # checks them against the degree-8 reference); each system alone must find all of them
    fast = spherekin.solve(gosselin(), GOSSELIN_INPUTS, system="platform")
    loops = spherekin.solve(gosselin(), GOSSELIN_INPUTS, system="loops")
    assert (fast.settings.system, loops.settings.system) == ("platform", "loops")
    assert fast.proven_count == loops.proven_count == 8
    assert fast.unknowns == loops.unknowns == gosselin().loop_unknowns
    for s in fast.solutions:
        match = min(loops.solutions, key=lambda t: np.abs(s.platform_rotation - t.platform_rotation).max())
        assert np.abs(s.platform_rotation - match.platform_rotation).max() < 1e-9
        # the platform system's readings (mapped back from the pose) are the loop system's unknowns
        turns = (np.asarray(s.angles) - np.asarray(match.angles)) / (2 * math.pi)
        np.testing.assert_allclose(turns, np.round(turns), atol=1e-9)


# ---------------------------------------------------------------- Eq. (1) once

def test_the_leg_constants_give_eq_1_as_written_independently():
    """e(d1) . (D a3) - a2 . a3 with e(d1) = Rot(a1, d1) a2 computed by scipy, against the constants
    that the platform system's tensors and the tracker both read."""
    mech = general_3rrr()
    legs = platform_legs(mech)
    k = leg_constants(legs)
    rng = np.random.default_rng(3)
    ref = np.array(mech.platform_reference_matrix)
    system = PlatformSystem.from_mechanism(mech)
    eqs = LegEquations(legs)
    for _ in range(5):
        beta = rng.uniform(-math.pi, math.pi, 3)
        rotation = Rotation.random(random_state=rng).as_matrix()
        d = rotation @ ref.T
        want = [Rotation.from_rotvec((b - leg.reference[0]) * leg.a1).apply(leg.a2) @ (d @ leg.a3) - leg.a2 @ leg.a3
                for leg, b in zip(legs, beta)]
        np.testing.assert_allclose(k.residual(d, beta), want, atol=1e-14)
        np.testing.assert_allclose(system.residuals(beta, rotation), want, atol=1e-14)
        np.testing.assert_allclose(eqs.residual(d, beta), want, atol=1e-14)


def test_the_tracker_reads_the_platform_systems_constants():
    legs = platform_legs(gosselin())
    eqs = LegEquations(legs)
    k = leg_constants(legs)
    for name in ("ref", "perp", "side", "axial", "b", "c"):
        np.testing.assert_array_equal(getattr(eqs, name), getattr(k, name))


# ---------------------------------------------------------------- Settings, JSON, text

def test_settings_json_has_the_system_and_the_declined_ones():
    report = spherekin.solve(four_bar(), [0.3], system="loops")
    assert report.settings.as_dict()["declined"] == []          # asked for by name: nothing passed over
    report = spherekin.solve(load_mechanism(EXAMPLES / "four_bar_graph.toml"), [0.3])
    out = report.settings.as_dict()
    assert out["system"] == "loops"
    graph = load_mechanism(EXAMPLES / "four_bar_graph.toml")
    assert out["declined"] == [{"system": "complete", "reason": Complete.accepts(graph)},
                               {"system": "complete-loop", "reason": OneLoop.accepts(graph)},
                               {"system": "platform", "reason": Platform.accepts(graph)}]
    fast = spherekin.solve(gosselin(), GOSSELIN_INPUTS).settings.as_dict()
    assert (fast["system"], fast["declined"]) == ("complete", [])
    # a search's settings (no solve, no system) have neither key
    search = Settings("halves", "pp", None, "tan-half", 1e-6, True, 1, 1).as_dict()
    assert "system" not in search and "declined" not in search


def test_solve_json_and_text_say_which_system_solved_and_why_not_the_fastest(tmp_path, capsys):
    out = tmp_path / "fb.json"
    graph = str(EXAMPLES / "four_bar_graph.toml")
    assert main(["solve", graph, "--inputs", "0.3", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    settings = json.loads(out.read_text())["settings"]
    assert settings["system"] == "loops"
    assert [d["system"] for d in settings["declined"]] == ["complete", "complete-loop", "platform"]
    lines = [line for line in text.splitlines() if line.startswith("solved by")]
    assert lines == ["solved by the loops system"]          # a graph has no legs: no platform talk by default
    assert "leg" not in text
    assert main(["solve", graph, "--inputs", "0.3", "-v"]) == 0
    lines = [line for line in capsys.readouterr().out.splitlines() if line.startswith("solved by")]
    assert lines == ["solved by the loops system (" + "; ".join(f"{d['system']} did not accept it: {d['reason']}"
                                                               for d in settings["declined"]) + ")"]
    assert main(["solve", str(EXAMPLES / "gosselin.toml"), "--inputs", "0.3,-0.2,0.5"]) == 0
    assert "\nsolved by the complete system\n" in capsys.readouterr().out
    assert main(["solve", str(EXAMPLES / "gosselin.toml"), "--inputs", "0.3,-0.2,0.5", "--no-isolate", "-v"]) == 0
    assert "platform did not accept it: --no-isolate asked for" in capsys.readouterr().out


@pytest.mark.parametrize("position", [1, 2])
def test_a_3rrr_driven_at_its_elbows_or_platform_joints_is_solved_by_the_platform_system(position):
    """The platform system with the actuated joint in the middle or at the platform (Eq. (1) as a1 . (D a3) =
    a1 . Rot(a2, d2) a3, or a1 . (D Rot(a3, -d3) a2) = a1 . a2): every assembly the loop equations find,
    each joint reading alike, and the assembly the inputs were read from (a solve of the base-actuated
    mechanism, whose platform pose the solve must give back)."""
    base = general_3rrr()
    driven = actuated_at(base, position)
    assert Platform.accepts(driven) is None
    fast, loops = compile(driven), compile(driven, system="loops")
    assert fast.system == "platform"
    for beta in [(0.3, -0.2, 0.4), (1.0, 0.1, -0.7)]:
        for made in compile(base).solve(beta).solutions:
            inputs = [made.joint_angles[n] for n in driven.actuated]
            a, b = fast.solve(inputs), loops.solve(inputs)
            assert a.settings.system == "platform" and a.settings.fallback is None
            assert a.count_exact and b.count_exact and a.proven_count == b.proven_count >= 1
            assert min(np.abs(s.platform_rotation - made.platform_rotation).max() for s in a.solutions) < 1e-9
            for s in a.solutions:
                twin = min(b.solutions, key=lambda t: np.abs(t.platform_rotation - s.platform_rotation).max())
                assert np.abs(twin.platform_rotation - s.platform_rotation).max() < 1e-9
                assert max(abs(math.remainder(s.joint_angles[n] - twin.joint_angles[n], 2 * math.pi))
                           for n in base.joint_names) < 1e-9
