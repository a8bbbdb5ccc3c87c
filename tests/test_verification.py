"""Tests for verification/: the quick subset of every check (so the proofs cannot rot), the exact
helpers against closed forms, the checks' ability to fail, spherekin.closure against the symbolic
results, and the report/CLI plumbing.
"""

import itertools
import math
from fractions import Fraction

import numpy as np
import pytest
import sympy as sp

import verification
from verification import bernstein_form, cli, convergence, gosselin_geometry, gosselin_solutions, symbolic
from verification.result import (ERRATUM, VERIFIED, VERIFIED_UNDER_CONDITIONS, CheckError, ClaimResult,
                                 VerificationRun)
from verification.spherical import exterior_angles, normalized_product, random_rotations, rx, rz, side_lengths

# The verdict of every claim, as established by the full run (verification/REPORT.md).
EXPECTED_VERDICTS = {
    "eq1": VERIFIED,
    "eq2-normalized": VERIFIED_UNDER_CONDITIONS,
    "eq2-index-rule": ERRATUM,
    "s21-normal-form": VERIFIED,
    "s21-actuators": VERIFIED_UNDER_CONDITIONS,
    "eq5": VERIFIED_UNDER_CONDITIONS,
    "eq6": VERIFIED,
    "s21-final-loop1": VERIFIED_UNDER_CONDITIONS,
    "s21-final-loop2": ERRATUM,
    "s21-eight-solutions": VERIFIED,
    "eq7": VERIFIED_UNDER_CONDITIONS,
    "eq8": VERIFIED_UNDER_CONDITIONS,
    "eq9-sigma": VERIFIED_UNDER_CONDITIONS,
    "s22-range-shift": VERIFIED,
    "prop1": VERIFIED,
    "prop2": VERIFIED_UNDER_CONDITIONS,
    "cor1": VERIFIED_UNDER_CONDITIONS,
    "cor2-constants": VERIFIED,
    "cor2-recursion": VERIFIED_UNDER_CONDITIONS,
    "eq10": VERIFIED,
    "s3-control-point-count": VERIFIED,
    "eq11": VERIFIED,
    "s4-quadratic-convergence": ERRATUM,
}
IMPL_CHECKS = {"impl:rotations", "impl:closure", "impl:paper-gosselin"}


@pytest.fixture(scope="module")
def quick_run() -> VerificationRun:
    return verification.run(quick=True)


# ---------------------------------------------------------------- the quick subset of every claim

def test_quick_run_has_no_errors_and_covers_every_claim(quick_run):
    assert quick_run.ok, [e.error for e in quick_run.errors]
    assert {r.claim_id for r in quick_run.claims} == set(EXPECTED_VERDICTS)
    assert {r.claim_id for r in quick_run.implementation_checks} == IMPL_CHECKS
    assert all(r.verdict == VERIFIED for r in quick_run.implementation_checks)


@pytest.mark.parametrize("claim_id, verdict", sorted(EXPECTED_VERDICTS.items()))
def test_verdict(quick_run, claim_id, verdict):
    result = quick_run.by_id(claim_id)
    assert result.verdict == verdict
    assert result.evidence and result.reference and result.statement
    if verdict == VERIFIED_UNDER_CONDITIONS:
        assert result.correction


def test_errata_show_printed_failing_and_corrected_holding(quick_run):
    rule = quick_run.by_id("eq2-index-rule").data
    assert rule["printed_min_residual"] > 1e-2 and rule["corrected_max_residual"] < 1e-12
    loop2 = quick_run.by_id("s21-final-loop2").data
    assert loop2["printed_min_residual"] > 1e-2 and loop2["corrected_max_residual"] < 1e-12
    assert loop2["grid_min_residual"] > 0.1            # no actuator-zero offsets rescue the printed form
    conv = quick_run.by_id("s4-quadratic-convergence").data
    assert conv["ratio_min"] == pytest.approx(0.5, abs=1e-6) and conv["ratio_max"] == pytest.approx(0.5, abs=1e-6)
    assert conv["hessian_ranks"] == [3, 3] and conv["transversal_steps"] <= 4


def test_section_2_1_conventions_are_unique(quick_run):
    data = quick_run.by_id("s21-actuators").data
    assert data["conventions_passing"] == 1
    assert data["same_handed_theta6_2_offset"] == pytest.approx(math.pi, abs=1e-9)
    assert quick_run.by_id("s21-eight-solutions").data["counts"] == [(8, 8, 4)] * 2


# ---------------------------------------------------------------- spherekin.closure vs the symbolic results

@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_spherekin_closure_equals_symbolic_expansion(n):
    from spherekin import closure as C

    ref = bernstein_form.symbolic_f11_f13(n)
    factors = [C.variable_factor(Fraction(0), Fraction(1))] * n
    f11, f13 = C.f11_f13_recursion(factors)
    assert np.array_equal(f11, ref["f11"]) and np.array_equal(f13, ref["f13"])
    assert np.array_equal(C.q_control_points(factors), ref["q"])
    for route in C.ROUTES:
        assert np.array_equal(C.scalar_control_points(factors, route), ref["f"])
    # and the paper's recursion with its printed constants gives the same tensors
    c11, c13 = bernstein_form.paper_recursion(n)
    assert np.array_equal(c11, ref["f11"]) and np.array_equal(c13, ref["f13"])


# ---------------------------------------------------------------- exact helpers vs closed forms

def test_bernstein_coefficients_closed_forms():
    t = sp.Symbol("t")
    assert list(symbolic.bernstein_coefficients(sp.Poly(1 + t**2, t))) == [1, 1, 2]     # Prop. 1's proof
    assert list(symbolic.bernstein_coefficients(sp.Poly(t, t))) == [0, Fraction(1, 2), 1]
    assert list(symbolic.bernstein_coefficients(sp.Poly(2 * t, t))) == [0, 1, 2]          # h1
    with pytest.raises(ValueError, match="degree <= 2"):
        symbolic.bernstein_coefficients(sp.Poly(t**3, t))


def test_bernstein_coefficients_round_trip():
    rng = np.random.default_rng(0)
    gens = a, b, c = sp.symbols("a b c")
    for _ in range(5):
        expr = sum(int(rng.integers(-5, 6)) * sp.Rational(1, int(rng.integers(1, 4))) * a**i * b**j * c**k
                   for i, j, k in itertools.product(range(3), repeat=3) if rng.random() < 0.5)
        poly = sp.Poly(expr, *gens, domain="QQ")
        assert symbolic.bernstein_polynomial(symbolic.bernstein_coefficients(poly), gens) == poly


def test_octant_triangle_closed_form():
    """The octant triangle e1, e2, e3: sides and exterior angles pi/2, and (Rx(pi/2) Rz(pi/2))^3 = I."""
    p = np.eye(3)
    np.testing.assert_allclose(side_lengths(p), [math.pi / 2] * 3, atol=1e-15)
    np.testing.assert_allclose(exterior_angles(p), [math.pi / 2] * 3, atol=1e-15)
    prod = np.linalg.matrix_power(rx(math.pi / 2) @ rz(math.pi / 2), 3)
    np.testing.assert_allclose(prod, np.eye(3), atol=1e-15)
    np.testing.assert_allclose(normalized_product([math.pi / 2] * 3), np.eye(3), atol=1e-15)


def test_geometric_model_inverse_kinematics():
    model = gosselin_geometry.PAPER_CONVENTION
    np.testing.assert_allclose(model.elbows([0.0, 0.0, 0.0]), model.base[:, [1, 2, 0]], atol=1e-15)
    for rot in random_rotations(np.random.default_rng(1), 10):
        betas, w = model.inverse_kinematics(rot, (1, -1, 1))
        v = rot @ model.platform
        np.testing.assert_allclose(np.sum(w * model.base, axis=0), 0, atol=1e-12)   # link u-w is pi/2
        np.testing.assert_allclose(np.sum(w * v, axis=0), 0, atol=1e-12)            # link w-v is pi/2
        np.testing.assert_allclose(model.elbows(betas), w, atol=1e-12)              # Rodrigues agrees


def test_geometric_model_rejects_bad_input():
    with pytest.raises(ValueError, match="base"):
        gosselin_geometry.GosselinGeometry(np.ones((3, 3)), np.eye(3), np.eye(3))
    with pytest.raises(ValueError, match="zeros"):
        gosselin_geometry.GosselinGeometry(np.eye(3), np.eye(3), np.eye(3))
    with pytest.raises(ValueError, match="singular"):
        gosselin_geometry.PAPER_CONVENTION.inverse_kinematics(np.eye(3), (1, 1, 1))


def test_hull_interval_and_double_root_contraction():
    assert convergence.hull_interval([-1, 1, -1]) == (0.25, 0.75)
    assert convergence.hull_interval([1, 2, 1]) is None
    assert convergence.hull_interval([-1, 0, 1]) == (0.5, 0.5)
    # -(t - r)^2 on [r - d0, r + d1] keeps exactly [r - d0/2, r + d1/2]
    r, d0, d1 = 0.3, 0.1, 0.25
    widths = convergence.contract([-r * r, 2 * r, -1.0], r - d0, r + d1, 5)
    np.testing.assert_allclose(np.array(widths[1:]) / np.array(widths[:-1]), 0.5, rtol=1e-9)
    # a simple root converges quadratically
    simple = convergence.contract([-0.3, 1.0, 0.5], 0.0, 0.5, 6)
    assert simple[-1] < 1e-12 and len(simple) <= 6


def test_solve_poses_rejects_bad_input():
    with pytest.raises(ValueError, match="ts"):
        gosselin_solutions.solve_poses(["x", 1, 2])
    with pytest.raises(ValueError, match="ts"):
        gosselin_solutions.solve_poses([1, 2])


# ---------------------------------------------------------------- the checks can fail

def test_cor2_constants_check_detects_a_wrong_constant(monkeypatch):
    wrong = dict(bernstein_form.PRINTED_G2)
    wrong[(2, 2)] = 2
    monkeypatch.setattr(bernstein_form, "PRINTED_G2", wrong)
    with pytest.raises(AssertionError, match="g2"):
        bernstein_form.check_cor2_constants(quick=True)
    with pytest.raises(AssertionError, match="recursion"):
        bernstein_form.check_cor2_recursion(quick=True)


def test_final_loop2_check_detects_a_correct_printed_form(monkeypatch):
    monkeypatch.setattr(gosselin_geometry, "printed_loop2", gosselin_geometry.corrected_loop2)
    with pytest.raises(AssertionError, match="final loop 2"):
        gosselin_geometry.check_final_loop2(quick=True)


# ---------------------------------------------------------------- results, report, command line

def test_claim_result_validation():
    with pytest.raises(ValueError, match="verdict"):
        ClaimResult("x", "ref", "TRUE", "evidence")
    with pytest.raises(ValueError, match="ERRATUM needs"):
        ClaimResult("x", "ref", ERRATUM, "evidence", correction="fixed")
    with pytest.raises(ValueError, match="conditions"):
        ClaimResult("x", "ref", VERIFIED_UNDER_CONDITIONS, "evidence")
    with pytest.raises(ValueError, match="claim_id"):
        ClaimResult("", "ref", VERIFIED, "evidence")
    r = ClaimResult("x", "ref", VERIFIED, "evidence", data={"a": 1})
    with pytest.raises(TypeError):
        r.data["a"] = 2                                  # read-only


def test_run_records_failing_checks_and_bad_arguments():
    def broken(quick):
        raise RuntimeError("boom")

    def wrong_type(quick):
        return 42

    result = verification.run(quick=True, checks=[broken, wrong_type, bernstein_form.check_eq11])
    assert not result.ok and [e.check.split(".")[-1] for e in result.errors] == ["broken", "wrong_type"]
    assert "RuntimeError: boom" in result.errors[0].error
    assert [r.claim_id for r in result.results] == ["eq11"]
    with pytest.raises(ValueError, match="quick"):
        verification.run(quick="yes")
    with pytest.raises(ValueError, match="checks"):
        verification.run(quick=True, checks=[1])


def test_report_lists_every_claim_and_erratum(quick_run, tmp_path):
    text = verification.render_report(quick_run)
    assert text.startswith("# Verification of the paper's claims")
    assert "| Claim | Reference | Verdict | Evidence | Corrected form / conditions |" in text
    for claim_id, verdict in EXPECTED_VERDICTS.items():
        assert f"**{claim_id}**" in text
        if verdict == ERRATUM:
            assert f"### {claim_id} -- " in text
    errata = text.split("## Errata")[1].split("## Conditions")[0]
    assert errata.count("- **Printed:**") == errata.count("- **Corrected:**") == errata.count(
        "- **Numeric demonstration:**") == 3
    table = [line for line in text.split("## Claims")[1].split("## Errata")[0].splitlines() if line.startswith("| **")]
    assert len(table) == len(EXPECTED_VERDICTS) and all(line.count(" | ") == 4 for line in table)
    path = verification.write_report(quick_run, tmp_path / "REPORT.md")
    assert path.read_text(encoding="utf-8") == text
    with pytest.raises(ValueError, match="path"):
        verification.write_report(quick_run, tmp_path / "missing" / "REPORT.md")


def test_main_exit_status(quick_run, tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(cli, "run", lambda quick, progress=None: quick_run)
    assert cli.main(["--quick", "--report", str(tmp_path / "ok.md")]) == 0
    assert "23 claims" in capsys.readouterr().out and (tmp_path / "ok.md").exists()
    failed = VerificationRun(True, quick_run.results, (CheckError("check_x", "RuntimeError: boom"),))
    monkeypatch.setattr(cli, "run", lambda quick, progress=None: failed)
    assert cli.main(["--report", str(tmp_path / "bad.md")]) == 1
    assert "## Errors" in (tmp_path / "bad.md").read_text(encoding="utf-8")
    assert cli.main(["--report", str(tmp_path / "missing" / "r.md")]) == 2
    with pytest.raises(SystemExit) as exc:
        cli.main(["--fast"])
    assert exc.value.code == 2
