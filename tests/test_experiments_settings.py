"""The experiments say what ran (issue 41 item 1): every solve pins its whole strategy, every row records
what ran (read back from the report) and a run that reached its cap is ``capped`` with no count.

The strategies asked for are checked against the paper's text, written here (the paper's algorithm is
Eq. (10) on the loop equations with the Eq. (12) LPs, Section 4; Section 5 changes only the
parameterization), not against the experiments' own constants."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import spherekin
from experiments import _common, _compare, convergence, lp_backends, parameterizations, reproduction, scaling
from spherekin.mechanism import gosselin

#: A box cap no search of these problems meets at its tol (they need hundreds of boxes or more).
TINY_CAP = 5
#: The keys a row must record of what ran.
RAN = ("system", "formulation", "parameterization", "pruner", "lp_backend", "tol")


def _no_count(row: dict) -> None:
    """A capped row: capped, the cap's message, and none of the numbers a count would be read from."""
    assert row["capped"] is True and row["error"]
    for key in ("boxes", "lps", "solutions", "n_solutions", "time", "median_boxes"):
        assert row.get(key) is None, key


# ------------------------------------------------------------------ the plumbing


def test_a_report_that_ran_another_strategy_is_refused(monkeypatch):
    """A library default that changed under an experiment (auto turning a loop solve into the platform
    system, issue 41) stops the experiment with the keys that differ, never a silent row."""
    real = spherekin.solve

    def drifted(mech, inputs, **kw):
        report = real(mech, inputs, **kw)
        return dataclasses.replace(report, settings=dataclasses.replace(report.settings, formulation="platform"))

    monkeypatch.setattr(spherekin, "solve", drifted)
    pinned = dataclasses.replace(scaling.LOOP_STRATEGY, tol=1e-3)
    with pytest.raises(RuntimeError, match="formulation 'halves' -> 'platform'"):
        _common.pinned_solve(_compare.MECHANISMS["four_bar"][0](), (0.4,), pinned)


def test_a_row_records_what_the_report_says_ran():
    got = _common.pinned_solve(gosselin(), reproduction.INPUTS, reproduction.CLAIMS)
    row = got.settings_row()
    st = got.report.settings
    assert row["ran"] == {k: getattr(st, k) for k in RAN} and row["capped"] is False
    assert row["ran"]["system"] == "loops" and row["ran"]["formulation"] == "halves"


def test_the_default_pipeline_row_records_what_the_library_chose():
    """On a 3-RRR "auto" is the complete count (quaternion charts): recorded as such, not as asked."""
    pinned = parameterizations.VARIANTS[parameterizations.DEFAULT_ROW]
    assert (pinned.system, pinned.formulation) == ("auto", "auto")
    row = _common.pinned_solve(gosselin(), reproduction.INPUTS, pinned).settings_row()
    assert row["ran"]["system"] == "complete" and row["ran"]["parameterization"] == "quaternion"


def test_a_strategy_with_lps_names_its_backend():
    with pytest.raises(ValueError, match="lp_backend"):
        _common.Pinned(system="loops", formulation="paper", parameterization="tan-half", pruner="lp",
                       lp_backend=None, tol=1e-2, isolate=False, max_boxes=10)


# ------------------------------------------------------------------ each experiment asks for what the paper says


def test_reproduction_asks_for_the_papers_algorithm():
    rows = {(c["problem"], c["name"]): c["pinned"] for c in reproduction.configurations(quick=False)}
    faithful = rows[("full", "paper-faithful (lp, clarabel)")]
    # Section 4: Eq. (10) on the loop equations, the Eq. (12) LPs, subdivision to tol (no isolation), t = tan/2
    assert (faithful.system, faithful.formulation, faithful.pruner, faithful.lp_backend, faithful.isolate,
            faithful.parameterization) == ("loops", "paper", "lp", "clarabel", False, "tan-half")
    assert rows[("full", reproduction.DEFAULT_ROW)].formulation == "auto"


def test_the_section_5_comparison_changes_only_the_parameterization():
    tan, sc = (dataclasses.asdict(parameterizations.VARIANTS[p]) for p in ("tan-half", "sin-cos"))
    assert {k for k in tan if tan[k] != sc[k]} == {"parameterization"}
    assert tan["system"] == "loops" and tan["formulation"] != "auto"      # the loop equations, not the platform


@pytest.mark.parametrize("name", ["four_bar", "gosselin"])
def test_every_recorded_row_ran_what_it_asked(name):
    """Section 5 rows on a small case: what each report says ran is what the row asked for (the default
    pipeline's choices aside), and tan-half and sin-cos find the same solutions."""
    mech = _compare.MECHANISMS[name][0]()
    case = _compare.random_cases(mech, np.random.default_rng(3), 1)[0]
    rows = {p: parameterizations.solve_case(mech, case, pinned, 1) for p, pinned in parameterizations.VARIANTS.items()}
    for p in ("tan-half", "sin-cos"):
        assert rows[p]["ran"] == rows[p]["asked"] and rows[p]["ran"]["parameterization"] == p
    assert _compare.same_set(rows["tan-half"]["solutions"], rows["sin-cos"]["solutions"])


# ------------------------------------------------------------------ a cap is recorded as capped, never as a count


def test_reproduction_records_a_capped_configuration():
    cfg = reproduction.config("paper + pp", "full", system="loops", formulation="paper", isolate=False, tol=1e-2,
                              max_boxes=TINY_CAP)
    _no_count(reproduction.run_config({"full": gosselin()}, reproduction.INPUTS, cfg, 1))


def test_convergence_records_a_capped_run_and_its_sweep_never_decreases():
    """A sweep's boxes grow as tol shrinks for one configuration; a capped entry has no count, and the
    sweep of that configuration stops there."""
    configs = tuple(c for c in convergence.CONFIGS if c[0] == "paper + pp")
    caps = {"pp": 12_000, "lp": 3_000}    # the 1e-2 .. 1e-4 runs fit, the paper's double roots at 1e-8 do not
    old = convergence.MAX_BOXES_QUICK
    try:
        convergence.MAX_BOXES_QUICK = caps
        data = convergence.experiment(quick=True, seed=0, roots=[2], configs=configs, tols=(1e-1, 1e-2, 1e-4, 1e-6, 1e-8),
                                      trace_tol={"paper": 1e-2, "transversal": 1e-2})
    finally:
        convergence.MAX_BOXES_QUICK = old
    sweep = data["sweep"]
    assert sweep[-1]["capped"] and all(not r["capped"] for r in sweep[:-1])     # the paper's double roots hit it
    assert [r["tol"] for r in sweep] == [1e-1, 1e-2, 1e-4, 1e-6, 1e-8][:len(sweep)]   # nothing after the cap
    _no_count(sweep[-1])
    counts = [r["boxes"] for r in sweep if not r["capped"]]
    assert len(counts) >= 2 and counts == sorted(counts)
    for r in sweep[:-1]:
        assert r["ran"]["tol"] == r["tol"] and r["ran"]["formulation"] == "paper"


def test_the_section_5_comparison_records_a_capped_run():
    mech = _compare.MECHANISMS["gosselin"][0]()
    case = _compare.random_cases(mech, np.random.default_rng(3), 1)[0]
    pinned = dataclasses.replace(parameterizations.VARIANTS["tan-half"], max_boxes=TINY_CAP)
    row = parameterizations.solve_case(mech, case, pinned, 1)
    _no_count(row)
    summary = parameterizations.summarize([dict(row, mechanism="gosselin", parameterization=p, same_solutions=None)
                                           for p in parameterizations.VARIANTS])
    assert all(s["inputs"] == 0 and s["capped"] == 1 and "median_boxes" not in s for s in summary)


def test_scaling_records_a_capped_run(monkeypatch):
    monkeypatch.setattr(scaling, "LOOP_STRATEGY", dataclasses.replace(scaling.LOOP_STRATEGY, max_boxes=TINY_CAP))
    data = scaling.run(quick=True, seed=1, mechanisms=["gosselin"], parameterizations=("tan-half",), repeats=1)
    (row,) = data["runs"]
    _no_count(row)


def test_lp_backends_records_a_capped_problem(monkeypatch):
    monkeypatch.setattr(lp_backends, "SEARCH", {**lp_backends.SEARCH, "max_boxes": 1})
    (prob,) = lp_backends.problems(quick=True)
    (row,) = lp_backends.measure("highspy", [prob], 0, 1)
    _no_count(row)
    lp_backends.compare([row], "highspy")          # nothing to compare, no error
    assert "same_counts" not in row


def test_timings_rest_on_at_least_three_runs():
    mech = _compare.MECHANISMS["four_bar"][0]()
    case = _compare.random_cases(mech, np.random.default_rng(2), 1)[0]
    got = scaling.solve_timed(mech, case.inputs, "tan-half", 1)
    assert len(got.times) >= 3 and math.isfinite(got.time)
    assert reproduction.REPEATS_SLOW >= 3 and reproduction.REPEATS_QUICK >= 3
