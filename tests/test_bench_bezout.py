"""A smoke run of benchmarks/bench_bezout.py (no time is asserted): the three arithmetics of the complex
Krawczyk test (fast, intervals, FLINT's acb written root by root) prove the same roots of general_3rrr."""

import json

from benchmarks import bench_bezout


def test_the_three_arithmetics_prove_the_same_roots(tmp_path):
    out = tmp_path / "bezout.json"
    assert bench_bezout.main(["--inputs", "3", "--repeats", "1", "--out", str(out)]) == 0
    rows = {r["arithmetic"]: r for r in json.loads(out.read_text())["rows"]}
    assert set(rows) == {"fast", "intervals", "acb"}
    assert all(r["roots_proven"] == r["roots"] == 24 and r["differ_from_fast"] == 0 for r in rows.values())


def test_an_acb_test_fails_where_the_matrices_are_too_wide():
    import numpy as np
    import spherekin

    compiled = spherekin.compile("examples/general_3rrr.toml").compiled("complete")
    rows = np.array([[0.1, 0.2, 0.3]])
    m = compiled.matrices(rows)
    proof = spherekin.core.bezout.certify_roots(m, compiled.candidates(rows))
    q, chart = proof.roots[0, 0], proof.chart[0, 0]
    assert bench_bezout.acb_test(m[0, 0], m[1, 0], q, chart, 1e-9)
    assert not bench_bezout.acb_test(m[0, 0] - 1e-3, m[1, 0] + 1e-3, q, chart, 1e-9)
