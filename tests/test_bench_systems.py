"""A smoke test of benchmarks/bench_systems.py: the script runs against the current API and its rows
agree with what is known of the mechanisms (not a timing test: no time is asserted)."""

from benchmarks.bench_systems import cases, elbow_actuated_3rrr, run


def test_bench_systems_runs_and_auto_chooses_the_fastest_that_accepts():
    rows = {(r["mechanism"], r["system"]): r for r in run(repeats=1, quick=True)}
    # a four-bar and a five-bar: the platform system declines (2 legs), the one-loop count solves, and the
    # loop system (its fallback) finds the same assemblies
    for mech in ("four-bar", "five-bar"):
        assert not rows[(mech, "platform")]["accepts"] and "got 2" in rows[(mech, "platform")]["reason"]
        one, loops = rows[(mech, "complete-loop")], rows[(mech, "loops")]
        assert one["chosen_by_auto"] and not loops["chosen_by_auto"] and one["proven"] == loops["proven"] >= 1
    # general_3rrr: all three accept, auto takes the complete count; all find the same proven assemblies
    first, fast, loops = (rows[("general_3rrr", name)] for name in ("complete", "platform", "loops"))
    assert first["chosen_by_auto"] and not fast["chosen_by_auto"] and not loops["chosen_by_auto"]
    assert first["proven"] == fast["proven"] == loops["proven"] == fast["solutions"] >= 1


def test_the_elbow_actuated_3rrr_actuates_the_elbows():
    mech = elbow_actuated_3rrr()
    assert [[j.actuated for j in leg.joints] for leg in mech.legs] == [[False, True, False]] * 3
    labels = [label for label, _, _ in cases(quick=True)]
    assert labels == ["four-bar", "five-bar", "general_3rrr"]
