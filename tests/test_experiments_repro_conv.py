"""Tests of experiments/reproduction.py, experiments/convergence.py and paper_figures/exp_convergence.py.

The scripts' functions run on tiny inputs; their numbers are checked against independent values:
control point counts against (deg + 1)^n with the degree of the tan-half factors derived in sympy,
the order estimator against synthetic sequences of known order, every root against a plain numpy
closure (Rodrigues products of each leg, checked against a closed-form rotation), the measured
orders against the theory (simple roots: quadratic; the paper's double roots: at best linear).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import sympy as sp

from experiments import convergence, reproduction
from spherekin.mechanism import gosselin
from spherekin.problem import solve

INPUTS = reproduction.INPUTS


@pytest.fixture(scope="module")
def default_report():
    return solve(gosselin(), INPUTS)


# ------------------------------------------------------------------ control points

def test_tan_half_factor_degree_is_two():
    """The degree that (deg + 1)^n uses, derived in sympy: Rx(theta) Z (1 + t^2) is a polynomial of degree 2 in t."""
    t = sp.symbols("t")
    c, s = (1 - t**2) / (1 + t**2), 2 * t / (1 + t**2)
    rx = sp.Matrix([[1, 0, 0], [0, c, -s], [0, s, c]])
    z = sp.Matrix([[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    m = sp.simplify((rx * z) * (1 + t**2))
    assert max(sp.degree(sp.expand(e), t) for e in m) == reproduction.TAN_HALF_DEGREE


def test_control_point_counts_match_the_formula_and_the_paper():
    rows = reproduction.control_point_counts(INPUTS)
    assert {r["source"].split(" (")[0] for r in rows} >= {"paper's loops", "loops from the joint axes",
                                                            "solver's blocks"}
    for r in rows:
        assert r["unknowns"] == 4                         # Section 3: "each equation has four variables"
        assert r["counted"] == 3 ** 4 == r["expected"]    # (2 + 1)^4
        assert r["shape"] == "3x3x3x3"
    solver = [r for r in rows if r["source"].startswith("solver")]
    assert len(solver) == 2 and sum(r["counted"] for r in solver) == 162


# ------------------------------------------------------------------ numpy checks

def test_rodrigues_against_closed_form():
    a = 0.7
    rz = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    assert np.allclose(reproduction.rodrigues([0, 0, 1], a), rz, atol=1e-15)
    rx = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
    assert np.allclose(reproduction.rodrigues([1, 0, 0], a), rx, atol=1e-15)


def test_every_solution_closes_and_a_perturbed_one_does_not(default_report):
    mech = gosselin()
    assert len(default_report.solutions) == 8
    for s in default_report.solutions:
        passive = dict(zip(default_report.unknowns, map(float, s.angles)))
        chk = reproduction.independent_check(mech, INPUTS, passive, s.platform_rotation)
        assert chk["closure"] < reproduction.CLOSURE_TOL
        assert chk["rotation_error"] < reproduction.CLOSURE_TOL
        bad = dict(passive, gamma1=passive["gamma1"] + 0.01)
        assert reproduction.independent_check(mech, INPUTS, bad)["closure"] > 1e-3


def test_serial_singularity_test_counts_four(default_report):
    rows = reproduction.solution_rows(gosselin(), INPUTS, default_report)
    assert sum(r["serial_numpy"] for r in rows) == 4
    for r in rows:   # numpy's det test and spherekin's classification agree
        assert r["serial_numpy"] == (r["singularity"] == "serial")


def test_axis_angle_round_trip():
    rng = np.random.default_rng(1)
    for _ in range(5):
        ax = rng.normal(size=3)
        ax /= np.linalg.norm(ax)
        ang = rng.uniform(0.1, 3.0)
        deg, axis = reproduction.axis_angle(reproduction.rodrigues(ax, ang))
        assert deg == pytest.approx(math.degrees(ang), abs=1e-9)
        assert np.allclose(axis, ax, atol=1e-9)


def test_same_solutions():
    a = [[0.0, 1.0], [2.0, -3.0]]
    assert reproduction.same_solutions(a, [[2.0, -3.0 + 2 * math.pi], [1e-12, 1.0]])[0]
    assert not reproduction.same_solutions(a, [[2.0, -3.0], [1e-3, 1.0]])[0]
    assert not reproduction.same_solutions(a, a[:1])[0]


# ------------------------------------------------------------------ order estimation

def test_empirical_order_on_synthetic_sequences():
    w = [0.1]
    for _ in range(4):
        w.append(w[-1] ** 2)
    assert convergence.sequence_order(w) == pytest.approx(2.0, abs=1e-9)
    w = [0.1 * 0.5 ** k for k in range(20)]
    assert convergence.sequence_order(w) == pytest.approx(1.0, abs=1e-9)
    w = [0.01]
    for _ in range(4):
        w.append(3.0 * w[-1] ** 1.5)
    assert convergence.sequence_order(w) == pytest.approx(1.5, abs=1e-9)
    assert math.isnan(convergence.sequence_order([0.1]))


def test_asymptotic_steps_window():
    m = convergence.asymptotic_steps([1.0, 0.01, 1e-6, 1e-10], [0.5, 1e-4, 1e-12, 1e-13],
                                     max_width=0.05, min_width=1e-11)
    assert m.tolist() == [False, True, False, False]


# ------------------------------------------------------------------ the chains on a real (tiny) run

@pytest.fixture(scope="module")
def tiny_convergence():
    configs = tuple(c for c in convergence.CONFIGS if c[0] in ("paper + pp", "transversal + lp"))
    return convergence.experiment(quick=True, seed=0, roots=[2], configs=configs, tols=(1e-2, 1e-4),
                                  trace_tol={"paper": 1e-4, "transversal": 1e-10})


def test_orders_match_theory(tiny_convergence):
    by = {r["config"]: r for r in tiny_convergence["summary"]}
    trans, paper = by["transversal + lp"], by["paper + pp"]
    for r in (trans, paper):
        assert r["root_discarded"] == 0       # a box holding the root is never thrown away
        assert r["root_found"]
        assert r["final_width"] <= r["tol"]
    # simple roots with the Eq. (12) LPs: quadratic (p = 2; Sherbrooke & Patrikalakis)
    assert trans["near_steps"] >= 2 and trans["order"] > 1.6
    # the paper's double roots: a hull step never cuts a side around the root by more than half
    # (verification/REPORT.md, s4-quadratic-convergence), so w'/w >= 1/2 and the order is 1
    assert paper["near_steps"] >= 5 and paper["order"] < 1.2 and paper["min_ratio"] >= 0.5 - 1e-9


def test_chain_boxes_contain_the_root_and_shrink(tiny_convergence):
    for ch in tiny_convergence["chains"]:
        depths = [c["depth"] for c in ch["chain"]]
        assert depths == list(range(len(depths)))     # one box per level, from the initial box down
        for c in ch["chain"]:
            assert c["w_out"] <= c["w_in"] * (1 + 1e-9)
    sweep = {(r["config"], r["tol"]): r["boxes"] for r in tiny_convergence["sweep"]}
    assert sweep[("paper + pp", 1e-4)] > sweep[("paper + pp", 1e-2)] > 0
    assert ("transversal + lp", 1e-4) not in sweep     # --quick: LPs only at the loose tolerances


def test_local_problem_roots_close_in_numpy(tiny_convergence):
    mech = gosselin()
    for p in tiny_convergence["problems"]:
        assert reproduction.independent_check(mech, INPUTS, p["root"])["closure"] < reproduction.CLOSURE_TOL
        for name, (lo, hi) in p["ranges"].items():
            assert lo < p["root"][name] < hi


def test_figure_from_tiny_results(tiny_convergence, tmp_path):
    from paper_figures import exp_convergence

    data = json.loads(json.dumps(tiny_convergence, default=float))
    path = tmp_path / "convergence.json"
    path.write_text(json.dumps(data))
    pngs = exp_convergence.main(["--results", str(path), "--out-dir", str(tmp_path)])
    assert [p.suffix for p in pngs] == [".png", ".pdf"]
    assert pngs[0].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and pngs[0].stat().st_size > 10_000
