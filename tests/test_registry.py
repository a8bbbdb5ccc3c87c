"""One registry by name per strategy family: every check, error and CLI choice reads from it."""

from __future__ import annotations

import argparse

import numpy as np
import pytest

import spherekin
from spherekin.cli import build_parser
from spherekin.search.formulations import FORMULATIONS, Formulation, Halves
from spherekin.search.lp_backends import LP_BACKENDS, HighspyBackend, LPBackend
from spherekin.mechanism import gosselin
from spherekin.search.parameterizations import PARAMETERIZATIONS, LoopParameterization
from spherekin.problem import formulation_choices
from spherekin.search.pruners import PRUNERS, ProjectedPolyhedron, Pruner
from spherekin.search.registry import Registry

from conftest import GOSSELIN_INPUTS

FAMILIES = [(FORMULATIONS, Formulation, "formulation", ["paper", "transversal", "halves"]),
            (PARAMETERIZATIONS, LoopParameterization, "parameterization", ["tan-half", "sin-cos"]),
            (PRUNERS, Pruner, "pruner", ["pp", "lp", "hybrid"]),
            (LP_BACKENDS, LPBackend, "lp_backend", ["clarabel", "highs", "highspy"])]


@pytest.mark.parametrize("registry, base, family, names", FAMILIES)
def test_each_family_registers_its_strategies_as_subclasses_of_one_base(registry, base, family, names):
    assert list(registry) == names and registry.family == family
    assert all(issubclass(cls, base) and cls.name == name for name, cls in registry.items())


@pytest.mark.parametrize("keyword, family, names", [("formulation", "formulation", None),
                                                     ("parameterization", "parameterization", PARAMETERIZATIONS),
                                                     ("pruner", "pruner", PRUNERS),
                                                     ("lp_backend", "lp_backend", LP_BACKENDS)])
def test_an_unknown_name_is_one_error_listing_the_valid_ones(keyword, family, names):
    kwargs = {keyword: "nonesuch"}
    if keyword == "lp_backend":
        kwargs["pruner"] = "lp"
    with pytest.raises(ValueError) as err:
        spherekin.compile(gosselin(), **kwargs)
    text = str(err.value)
    assert text.startswith(f"{family}: expected one of") and "'nonesuch'" in text
    assert all(repr(n) in text for n in (names if names is not None else formulation_choices()))


def _choices(parser: argparse.ArgumentParser, command: str, option: str) -> list:
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices[command]
    return list(next(a for a in sub._actions if option in a.option_strings).choices)


def test_the_command_line_choices_are_the_registries():
    parser = build_parser()
    assert _choices(parser, "solve", "--parameterization") == list(PARAMETERIZATIONS)
    assert _choices(parser, "solve", "--pruner") == list(PRUNERS)
    assert _choices(parser, "solve", "--lp-backend") == list(LP_BACKENDS)
    assert _choices(parser, "solve", "--formulation") == ["auto", "complete", "complete-loop", "platform", *FORMULATIONS]


def test_a_registered_strategy_is_accepted_everywhere(registered, capsys):
    class CountingPP(ProjectedPolyhedron):
        name = "counting-pp"
        calls = 0

        def reduce(self, cps, tols, widths=None):
            type(self).calls += 1
            return super().reduce(cps, tols, widths)

    class HalvesAgain(Halves):
        name = "halves-again"

    registered(PRUNERS, CountingPP)
    registered(FORMULATIONS, HalvesAgain)
    report = spherekin.solve(gosselin(), GOSSELIN_INPUTS, pruner="counting-pp", formulation="halves-again")
    assert CountingPP.calls > 0 and report.settings.pruner == "counting-pp"
    assert report.settings.formulation == "halves-again" and report.proven_count == 8 and report.count_exact
    assert "counting-pp" in _choices(build_parser(), "solve", "--pruner")
    assert "halves-again" in formulation_choices()


def counting_pruner() -> type:
    """A new projected-polyhedron pruner class, "counting-builds", that counts its builds (``builds``)."""
    class CountingBuilds(ProjectedPolyhedron):
        name = "counting-builds"
        builds = 0

        @classmethod
        def build(cls, shapes, lp_backend):
            cls.builds += 1
            return super().build(shapes, lp_backend)

    return CountingBuilds


def test_compile_checks_names_without_building_and_builds_the_platform_pruner_once(registered):
    CountingBuilds = counting_pruner()
    registered(PRUNERS, CountingBuilds)
    spherekin.compile(gosselin(), pruner="counting-builds", formulation="halves")
    assert CountingBuilds.builds == 0          # a loop formulation: the checks build nothing
    problem = spherekin.compile(gosselin(), pruner="counting-builds")
    assert [c.system for c in problem.chain[:2]] == ["complete", "platform"] and CountingBuilds.builds == 1
    for _ in range(2):
        report = problem.solve(GOSSELIN_INPUTS)
        assert report.settings.fallback is None and report.proven_count == 8
    assert CountingBuilds.builds == 1          # the compiled problem's pruner serves every input


def test_a_compiled_loop_formulation_builds_its_pruner_and_lp_model_once_for_every_input(registered):
    """solve_many over the loop equations (halves): the pruner, and the LP backend's model inside a
    hybrid pruner, are built once per chart layout (the blocks' shapes do not depend on the inputs),
    not once per input; the reports are those of independent one-call solves."""
    CountingBuilds = counting_pruner()
    class CountingModels(HighspyBackend):
        name = "counting-models"
        models = 0

        def __init__(self, *args, **kwargs):
            type(self).models += 1
            super().__init__(*args, **kwargs)

    registered(PRUNERS, CountingBuilds)
    registered(LP_BACKENDS, CountingModels)
    rows = [GOSSELIN_INPUTS, (0.1, 0.4, -0.3), (-0.5, 0.2, 0.6)]
    problem = spherekin.compile(gosselin(), pruner="counting-builds", formulation="halves")
    reports = problem.solve_many(rows)
    assert CountingBuilds.builds == 1
    assert reports[0].proven_count == 8 and reports[0].count_exact
    for row, report in zip(rows, reports):
        alone = spherekin.solve(gosselin(), row, formulation="halves", pruner="counting-builds")
        assert [s.status for s in report.solutions] == [s.status for s in alone.solutions]
        assert all(np.allclose(a.angles, b.angles, atol=1e-12) for a, b in zip(report.solutions, alone.solutions))
    assert CountingBuilds.builds == 1 + len(rows)     # each one-call solve compiles its own
    hybrid = spherekin.compile(gosselin(), pruner="hybrid", lp_backend="counting-models", formulation="halves")
    assert CountingModels.models == 0                 # compile checks the names, builds no model
    hybrid.solve_many(rows[:2])
    assert CountingModels.models == 1


def test_the_registries_are_left_as_found_by_the_fixture():
    assert "counting-pp" not in PRUNERS and "halves-again" not in FORMULATIONS and "counting-builds" not in PRUNERS


def test_registry_refuses_a_class_without_a_name_or_a_name_taken():
    reg = Registry("thing")

    class A:
        name = "a"

    class Nameless:
        pass

    reg.register(A)
    with pytest.raises(ValueError, match="'a' is already registered"):
        reg.register(type("B", (), {"name": "a"}))
    with pytest.raises(ValueError, match="non-empty string attribute 'name'"):
        reg.register(Nameless)
    with pytest.raises(ValueError, match=r"thing: expected one of \['a'\], got 'b'"):
        reg.lookup("b")
    with pytest.raises(ValueError, match="thing: expected one of"):
        reg.lookup(["unhashable"])
    assert reg.unregister("a") is A and len(reg) == 0
