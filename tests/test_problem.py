"""spherekin.problem: what a solve does when its search reaches the box cap (issue 41 item 2: no silent
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
