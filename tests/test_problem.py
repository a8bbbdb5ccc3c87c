"""spherekin.problem: the chain of compiled systems a problem runs (issue 43: a system of the test's own,
registered first, answers what it accepts and passes the rest on, through solve, solve_many, batch, map,
track and the CLI), and what a solve does when its search reaches the box cap (issue 41 item 2: no silent
coarsening). The reference is geometric: the kite four-bar (ground = crank = 40 deg, coupler = rocker =
60 deg) at crank input -pi/2 folds so that B meets D and C is free on a 60-degree circle: a continuum,
which no box cap can resolve at any tolerance; a few degrees away it has two isolated assemblies."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from conftest import kite
from spherekin import compile, solve
from spherekin.problem import CONTINUUM_TOL, ON_CAP_CHOICES, CappedSearchWarning
from spherekin.search.boxloop import SolverLimitError

#: The tolerance asked for: far below the covering's, so the two can never be confused.
ASKED_TOL = 1e-6
#: A cap the continuum passes at ASKED_TOL but its covering at CONTINUUM_TOL does not (~1e3 boxes).
CAP = 5_000


FOLD = (-math.pi / 2,)


def test_a_capped_solve_says_so_where_a_caller_looks_first():
    """The count is not proven, a warning names both tolerances, ``settings.tol`` is the covering's
    (the tolerance that ran) and ``settings.limit.tol`` the one asked for; the count line says both."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        report = solve(kite(), FOLD, tol=ASKED_TOL, max_boxes=CAP)
    capped = [w for w in caught if issubclass(w.category, CappedSearchWarning)]
    assert len(capped) == 1
    assert f"tol {ASKED_TOL:g}" in str(capped[0].message) and f"tol {CONTINUUM_TOL:g}" in str(capped[0].message)
    assert not report.count_exact
    assert report.settings.tol == CONTINUUM_TOL
    assert report.settings.limit.tol == ASKED_TOL and report.settings.limit.covering_tol == CONTINUUM_TOL
    assert report.settings.limit.covering_error is None
    text = report.count_text()
    assert f"tol {ASKED_TOL:g}" in text and f"tol {CONTINUUM_TOL:g}" in text and "count not exact" in text
    assert report.as_dict()["settings"]["tol"] == CONTINUUM_TOL
    assert any(s.status == "continuum" for s in report.solutions)


def test_on_cap_raise_gives_the_search_error_and_no_report():
    with pytest.raises(SolverLimitError, match="max_boxes"):
        solve(kite(), FOLD, tol=ASKED_TOL, max_boxes=CAP, on_cap="raise")


def test_on_cap_raise_in_a_chunk_raises_too():
    """solve_many: the capped input of a chunk is solved on its own, where the cap is handled as for one."""
    problem = compile(kite(), tol=ASKED_TOL, max_boxes=CAP, on_cap="raise")
    with pytest.raises(SolverLimitError):
        problem.solve_many(np.array([[FOLD[0] + 0.3], [FOLD[0]]]))


def test_a_capped_input_of_a_chunk_is_reported_as_capped_and_its_neighbour_is_not():
    problem = compile(kite(), tol=ASKED_TOL, max_boxes=CAP)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CappedSearchWarning)
        away, fold = problem.solve_many(np.array([[FOLD[0] + 0.3], [FOLD[0]]]))
    assert away.settings.limit is None and away.settings.tol == ASKED_TOL
    assert away.count_exact and away.proven_count == 2      # two assemblies off the fold (the kite's geometry)
    assert fold.settings.limit is not None and fold.settings.tol == CONTINUUM_TOL and not fold.count_exact


def test_a_solve_within_its_cap_warns_nothing():
    with warnings.catch_warnings():
        warnings.simplefilter("error", CappedSearchWarning)
        report = solve(kite(), (FOLD[0] + 0.3,), tol=ASKED_TOL, max_boxes=CAP)
    assert report.settings.limit is None and report.settings.tol == ASKED_TOL


def test_an_unknown_on_cap_is_one_error_listing_the_choices():
    with pytest.raises(ValueError) as info:
        compile(kite(), on_cap="ignore")
    assert "on_cap" in str(info.value) and all(c in str(info.value) for c in ON_CAP_CHOICES)


def test_the_strategy_keywords_carry_on_cap():
    """A problem compiled again from its strategy (explain_empty, batch workers) keeps on_cap."""
    problem = compile(kite(), on_cap="raise")
    assert problem.strategy_keywords()["on_cap"] == "raise"
    assert compile(kite(), **problem.strategy_keywords()).strategy.on_cap == "raise"


def test_the_command_line_says_both_tolerances_or_stops_with_one_line(tmp_path, capsys):
    from spherekin.cli import main
    from spherekin.mechanism.io import dumps_mechanism

    path = tmp_path / "kite.toml"
    path.write_text(dumps_mechanism(kite()))
    common = ["solve", str(path), "--inputs", repr(FOLD[0]), "--tol", repr(ASKED_TOL), "--max-boxes", str(CAP)]
    assert main(common) == 0
    out = capsys.readouterr()
    assert f"tol {ASKED_TOL:g}" in out.out and f"tol {CONTINUUM_TOL:g} instead" in out.out
    assert f"tol {CONTINUUM_TOL:g} rad:" in out.out           # the statistics line: the tolerance that ran
    assert "CappedSearchWarning" not in out.err                  # the count line says it, no Python warning
    assert main([*common, "--on-cap", "raise"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    err = [line for line in err if "boxes" not in line or "max_boxes" in line]   # progress lines aside
    assert len(err) == 1 and "max_boxes" in err[0]


def test_a_mechanism_with_every_joint_actuated_is_one_error_in_its_own_words(tmp_path):
    """Issue 42 item 12: a file whose every joint is actuated got the search's internal "ranges:
    expected at least one unknown, got none"; it has nothing to solve for, and the error says so."""
    from spherekin.mechanism import mechanism_from_dict

    joints = [{"name": n, "links": list(pair), "axis": list(axis), "actuated": True} for n, pair, axis in (
        ("A", ("ground", "crank"), (0.0, 0.0, 1.0)), ("B", ("crank", "coupler"), (0.0, 0.6, 0.8)),
        ("C", ("coupler", "rocker"), (0.6, 0.8, 0.0)), ("D", ("ground", "rocker"), (1.0, 0.0, 0.0)))]
    mech = mechanism_from_dict({"kind": "graph", "name": "all driven", "ground": "ground", "joints": joints})
    with pytest.raises(ValueError, match=r"^joints: every joint \(A, B, C, D\) is actuated, so the direct "
                                         "kinematics has no unknown"):
        compile(mech)
    with pytest.raises(ValueError, match="every joint"):
        solve(mech, [0.1, 0.2, 0.3, 0.4])


# ---------------------------------------------------------------- one seam (issue 43 item 1)

import dataclasses  # noqa: E402

from spherekin import batch  # noqa: E402
from spherekin.cli import build_parser  # noqa: E402
from spherekin.mechanism import five_bar  # noqa: E402
from spherekin.systems import SYSTEMS, Compiled, Passed, System  # noqa: E402
from spherekin.systems.loops import Loops  # noqa: E402

#: Why the test's system passes an input on (the report's ``settings.fallback``).
NEGATIVE = "the half-plane system answers A >= 0 only"


class CompiledHalfPlane(Compiled):
    """The test's own compiled system: the loop equations in the transversal formulation (not the loop
    system's default) for the inputs with A >= 0; every other input is passed to the next system.
    ``CALLS`` counts the inputs it was asked, over every instance (batch compiles its own)."""

    system = "half-plane"
    CALLS: list = []

    def __init__(self, mechanism, strategy):
        self.inner = Loops.compile(mechanism, dataclasses.replace(strategy, formulation="transversal"))
        self.names, self.ranges = self.inner.names, self.inner.ranges

    def readings(self, inputs, points):
        return self.inner.readings(inputs, points)

    def describe(self) -> str:
        return "half-plane (transversal)"

    def search_many(self, rows, progress):
        CompiledHalfPlane.CALLS.extend(rows)
        mine = [k for k, row in enumerate(rows) if row[0] >= 0]
        found = self.inner.search_many([rows[k] for k in mine], progress) if mine else []
        out = [Passed(NEGATIVE)] * len(rows)
        for k, f in zip(mine, found):
            out[k] = f
        return out

    def search_one(self, values, progress, trace):
        CompiledHalfPlane.CALLS.append(tuple(values))
        return self.inner.search_one(values, progress, trace) if values[0] >= 0 else Passed(NEGATIVE)

    def search_box(self, values, box, tol, max_boxes):
        return self.inner.search_box(values, box, tol, max_boxes)


class HalfPlane(System):
    """A system registered by this test module only: it accepts the five-bar (two actuated joints)."""

    name = "half-plane"
    default_formulation = "transversal"
    description = "the test's system: the five-bar's loop equations for A >= 0"

    @classmethod
    def formulations(cls):
        return ()

    @classmethod
    def accepts(cls, mechanism, strategy=None):
        return None if mechanism.actuated == ("A", "E") else "not the five-bar"

    @classmethod
    def compile(cls, mechanism, strategy):
        return CompiledHalfPlane(mechanism, strategy)


@pytest.fixture
def half_plane(registered):
    """HalfPlane registered first (the registry's order is the chain's), unregistered after the test."""
    registered(SYSTEMS, HalfPlane, first=True)
    CompiledHalfPlane.CALLS.clear()
    return HalfPlane


ROWS = np.array([[0.4, -0.3], [-0.5, 0.2], [1.1, 0.6], [-1.2, -0.7]])


def test_a_system_of_ones_own_is_one_file_and_the_pipeline_runs_through_it(half_plane):
    """Registered first, it answers the inputs it accepts and passes the others down the chain to the
    loop system (with its reason), for solve, solve_many, batch, map and track alike; the answers are
    those of the loop system alone (the same equations, another formulation), the CLI lists it."""
    mech = five_bar()
    problem = compile(mech)
    assert [c.system for c in problem.chain] == ["half-plane", "loops"]     # the platform does not accept it
    assert problem.system == "half-plane" and problem.strategy.formulation == "transversal"
    assert dict(problem.declined) == {}
    alone = compile(mech, system="loops").solve_many(ROWS)
    many = problem.solve_many(ROWS)
    for row, got, ref in zip(ROWS, many, alone):
        assert got.settings.system == ("half-plane" if row[0] >= 0 else "loops")
        assert got.settings.fallback == (None if row[0] >= 0 else NEGATIVE)
        assert (got.proven_count, got.count_exact) == (ref.proven_count, ref.count_exact) and got.proven_count
        np.testing.assert_allclose(np.sort([s.angles for s in got.solutions], axis=0),
                                   np.sort([s.angles for s in ref.solutions], axis=0), atol=1e-9)
    one = problem.solve(ROWS[1])
    assert (one.settings.system, one.settings.fallback) == ("loops", NEGATIVE)
    assert len(CompiledHalfPlane.CALLS) == len(ROWS) + 1

    CompiledHalfPlane.CALLS.clear()
    table = batch.solve_many(mech, ROWS, workers=0)
    assert len(CompiledHalfPlane.CALLS) == len(ROWS)
    assert len(table) == sum(r.proven_count for r in alone)

    CompiledHalfPlane.CALLS.clear()
    amap = batch.assembly_map(mech, "A=-0.5:0.5:3", "E=-0.2:0.2:2", workers=0)
    assert len(CompiledHalfPlane.CALLS) == 6
    ref = compile(mech, system="loops").solve_many([[a, e] for a in (-0.5, 0.0, 0.5) for e in (-0.2, 0.2)])
    assert amap.solutions.ravel().tolist() == [len(r.solutions) for r in ref]

    CompiledHalfPlane.CALLS.clear()
    track = problem.track([[0.4, -0.3], [0.42, -0.3], [0.44, -0.3]], start=0)
    assert CompiledHalfPlane.CALLS == [(0.4, -0.3)] and track.proven_steps >= 2

    choices = next(a for a in build_parser()._subparsers._group_actions[0].choices["solve"]._actions
                   if a.dest == "system").choices
    assert list(choices) == ["auto", "half-plane", "complete", "complete-loop", "platform", "loops"]
