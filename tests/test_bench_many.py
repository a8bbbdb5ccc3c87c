"""A smoke test of benchmarks/bench_many.py on three inputs: the script runs and its rows agree.

Not a timing test (no time is asserted): it checks that the benchmark still runs against the
current API and that its own consistency columns (poses equal to the baseline's, solution counts)
come out right on inputs whose assemblies are known from inverse kinematics.
"""

from benchmarks.bench_many import ik_inputs, run, run_lp
from spherekin.mechanism import general_3rrr


def test_bench_many_runs_and_every_method_finds_the_baselines_poses():
    mech = general_3rrr()
    rows = ik_inputs(mech, 3, seed=5)
    out = run(mech, rows, baseline_rows=3)
    assert [r["method"] for r in out] == ["loop of solve (halves)", "loop of solve (default)", "solve_many"]
    assert all(r["inputs"] == 3 and r["agree"] == 3 for r in out)
    assert len({r["solutions"] for r in out}) == 1 and out[0]["solutions"] >= 3     # each input assembles


def test_bench_many_lp_rows_run_and_agree():
    """The rows of the loop equations with LP models: the compiled problem finds what the loop of solve finds."""
    mech = general_3rrr()
    out = run_lp(mech, ik_inputs(mech, 1, seed=5))
    assert [r["inputs"] for r in out] == [1, 1] and out[1]["agree"] == 1
    assert out[0]["solutions"] == out[1]["solutions"] >= 1
