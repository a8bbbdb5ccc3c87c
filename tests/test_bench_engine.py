"""The floor of benchmarks/bench_engine.py (the degree-8 eigen solve vectorized over inputs) against
independent references, and smoke runs of bench_engine / bench_crossover (no time is asserted).

References: the per-input eigen solver of references/peers_closed_form.py (one input at a time),
exact real-root counts by sympy (a lex Groebner basis of the three quadrics in the chart q0 = 1,
then Sturm counting of its univariate polynomial, in exact rationals), and poses from the inverse
kinematics (every pose the IK places must be a root of the floor's quadrics).
"""

import json
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from benchmarks import bench_crossover, bench_engine
from references.peers_closed_form import (geometry_of, leg_quadrics, quaternion_rotation, real_roots_many,
                                          rotation_quaternion, solve_quadrics)
from spherekin.mechanism import general_3rrr, load_mechanism

#: A pose placed by the inverse kinematics is a root of the quadrics up to rounding of ~1e-15
#: per term (entries of A and q are O(1)).
ROOT_TOL = 1e-12
#: Polished floor roots and the per-input solver's roots agree to Newton's accuracy on a
#: well-separated root (the two differ only in lstsq vs pinv and the order of operations).
SAME_POSE = 1e-8


def _inputs(n, seed):
    return np.random.default_rng(seed).uniform(-np.pi, np.pi, (n, 3))


def _sympy_real_count(quadrics) -> int:
    """Real roots of the three quadrics q^T A q = 0 in the chart q0 = 1, exactly: the lex Groebner
    basis of a generic system is {x - p(z), y - r(z), u(z)} (shape lemma, checked), so the real
    points are the real roots of u, counted by Sturm sequences."""
    x, y, z = sp.symbols("x y z")
    q = sp.Matrix([1, x, y, z])
    polys = [sp.expand((q.T * sp.Matrix(4, 4, [sp.Rational(float(v)) for v in a.ravel()]) * q)[0])
             for a in quadrics]
    basis = sp.groebner(polys, x, y, z, order="lex").exprs
    assert len(basis) == 3 and sp.Poly(basis[-1], x, y, z).degree(z) == 8     # shape position, Bezout 8
    assert all(sp.Poly(b, x, y).total_degree() == 1 for b in basis[:2])
    return sp.Poly(basis[-1], z).count_roots()


def test_vectorized_floor_counts_equal_the_per_input_solver_and_its_roots():
    mech = general_3rrr()
    rows = _inputs(40, seed=11)
    quats, real, ok = real_roots_many(bench_engine.floor_quadrics(mech, rows))
    assert ok.all()
    counts = real.sum(axis=1)
    geometry = geometry_of(mech)
    for k, x in enumerate(rows):
        ref, _ = solve_quadrics(leg_quadrics(geometry, x))
        assert counts[k] == len(ref)
        got = quats[k][real[k]]
        for r in ref:                                   # each reference root among the floor's, up to sign
            assert min(np.abs(g - s * r).max() for g in got for s in (1, -1)) < SAME_POSE
    assert len(set(counts)) >= 3                        # the inputs cover several counts (0..8)
    assert (bench_engine.floor_counts(mech, rows) == counts).all()


def test_vectorized_floor_counts_equal_exact_sympy_counts():
    mech = general_3rrr()
    rows = _inputs(3, seed=3)
    quadrics = bench_engine.floor_quadrics(mech, rows)
    counts = bench_engine.floor_counts(mech, rows)
    assert [_sympy_real_count(a) for a in quadrics] == list(counts)
    assert 0 in counts and counts.max() > 0                  # an input without assembly, one with


def test_floor_quadrics_vanish_at_the_poses_of_the_inverse_kinematics():
    """Both layouts: the inputs that IK gives for a pose make that pose's quaternion a root."""
    rng = np.random.default_rng(5)
    for mech in (general_3rrr(), _elbow_from_file()):
        found = 0
        while found < 3:
            q = rng.normal(size=4)
            rot = quaternion_rotation(q / np.linalg.norm(q))
            for sol in mech.inverse_kinematics(rot):
                a = bench_engine.floor_quadrics(mech, np.array([sol.inputs]))[0]
                p = rotation_quaternion(rot)
                assert np.abs(np.einsum("i,aij,j->a", p, a, p)).max() < ROOT_TOL
                assert bench_engine.floor_counts(mech, np.array([sol.inputs]))[0] >= 1
                found += 1


def _elbow_from_file():
    """The elbow-actuated 3-RRR as the benchmark reads it: from the legs file it writes."""
    with tempfile.TemporaryDirectory() as tmp:
        case = next(c for c in bench_engine.cases(Path(tmp)) if c.label == "elbow-actuated 3-RRR")
        mech = load_mechanism(case.file)
    assert bench_engine.floor_layout(mech) == "elbow"
    return mech


def _has_baseline() -> bool:
    return subprocess.run(["git", "-C", str(bench_engine.ROOT), "cat-file", "-e", f"{bench_engine.BASELINE}^{{commit}}"],
                          capture_output=True).returncode == 0


def test_bench_engine_help(capsys):
    with pytest.raises(SystemExit) as exc:
        bench_engine.main(["--help"])
    assert exc.value.code == 0 and "--chunk" in capsys.readouterr().out


def test_bench_engine_refuses_a_bad_size(capsys):
    with pytest.raises(SystemExit) as exc:
        bench_engine.main(["--inputs", "0"])
    assert exc.value.code == 2 and "--inputs: expected a whole number >= 1, got 0" in capsys.readouterr().err


@pytest.mark.skipif(not _has_baseline(), reason=f"{bench_engine.BASELINE} not in this clone's history")
def test_bench_engine_tiny_run(tmp_path):
    out = tmp_path / "engine.json"
    assert bench_engine.main(["--inputs", "2", "--repeats", "1", "--only", "four-bar", "general_3rrr",
                              "--out", str(out)]) == 0
    rows = {r["mechanism"]: r for r in json.loads(out.read_text())["rows"]}
    assert set(rows) == {"four-bar", "general_3rrr"}
    assert rows["general_3rrr"]["count_mismatches"] == 0 and rows["general_3rrr"]["floor_mismatches"] == 0
    assert rows["general_3rrr"]["system"] == "complete" and rows["general_3rrr"]["boxes_mismatches"] == 0
    assert rows["general_3rrr"]["answered_by"] == {"complete": 2} and rows["general_3rrr"]["eigvals_per_s"] > 0
    assert rows["general_3rrr"]["strategy"]["formulation"] == "complete"
    assert rows["four-bar"]["floor_per_s"] is None and rows["four-bar"]["system"] == "complete-loop"
    assert rows["four-bar"]["boxes_per_s"] > 0 and rows["four-bar"]["boxes_mismatches"] == 0


def test_bench_crossover_help_and_line_crossing(capsys):
    with pytest.raises(SystemExit) as exc:
        bench_crossover.main(["--help"])
    assert exc.value.code == 0 and "--sizes" in capsys.readouterr().out
    sizes = [10, 30, 100, 300, 1000]
    here = [0.03 * n for n in sizes]                    # 30 ms a solve, no start-up
    cluster = [3.0 + 0.015 * n for n in sizes]          # 3 s to start, then two workers
    cross = bench_crossover.crossover(sizes, here, cluster)
    assert cross["first_size_where_cluster_wins"] == 300
    assert cross["fit"]["crossover_n"] == pytest.approx(3.0 / 0.015)


def test_bench_engine_without_baseline_and_with_an_agreement_run(tmp_path):
    out = tmp_path / "engine.json"
    assert bench_engine.main(["--inputs", "2", "--repeats", "1", "--baseline", "none", "--agree", "3", "--only",
                              "gosselin", "four-bar", "--out", str(out)]) == 0
    data = json.loads(out.read_text())
    rows = {r["mechanism"]: r for r in data["rows"]}
    assert rows["gosselin"]["baseline_per_s"] is None and rows["gosselin"]["ratio"] is None
    assert rows["four-bar"]["verdict"] in ("PASS", "FAIL")          # the one-loop count's goal is a rate
    agreed = {a["mechanism"]: a for a in data["agreement"]}         # the complete counts' mechanisms
    assert set(agreed) == {"gosselin", "four-bar"}
    assert all(a["inputs"] == 3 and a["count_mismatches"] == 0 for a in agreed.values())
