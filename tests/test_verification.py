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
from verification.result import (ERRATUM, VERDICTS, VERIFIED, VERIFIED_UNDER_CONDITIONS, CheckError, ClaimResult,
                                 VerificationRun)
from verification.spherical import exterior_angles, normalized_product, random_rotations, rx, rz, side_lengths

#: Numbers at or below this count as zero (double-precision residuals of O(1) quantities).
ZERO = 1e-12
#: Numbers above this count as a clear failure (a printed form missing by far more than rounding).
CLEAR = 1e-2


def _zero(*values) -> bool:
    return all(abs(float(v)) <= ZERO for v in values)


def _all_zero(counts) -> bool:
    return all(int(c) == 0 for c in counts)


def _positive_for_real_arguments(text: str) -> bool:
    """Is -p > 0 for every real argument, p given as a sympy string? True when -p has only
    positive coefficients and even exponents (a positive constant plus even powers): no real root."""
    poly = sp.Poly(-sp.sympify(text))
    terms = poly.terms()
    return (all(c > 0 for _, c in terms) and all(e % 2 == 0 for m, _ in terms for e in m)
            and any(not any(m) for m, _ in terms))


# What each claim's own numbers (ClaimResult.data) show, read independently of the check's verdict:
# ("erratum", ok) -- the printed form fails clearly and the corrected form holds (ok: both shown);
# ("holds", ok, outside) -- the printed form holds (ok), and ``outside`` says whether the data also
# records a case outside the stated conditions where it fails (True: the claim needs its conditions;
# False: the claim is unconditional, nothing can fail; None: the conditions, e.g. unstated base
# cases or axis conventions, leave no number in the data, so either verdict of a holding claim fits).
EVIDENCE = {
    "eq1": lambda d: ("holds", _zero(d["residual"], d["residual_frame_walk"], d["residual_negated_angles"]), False),
    "eq2-normalized": lambda d: ("holds", _zero(d["residual"]), d["max_product_difference_open_chains"] > CLEAR),
    "eq2-index-rule": lambda d: ("erratum", d["printed_min_residual"] > CLEAR and _zero(d["corrected_max_residual"])),
    "s21-normal-form": lambda d: ("holds", _zero(d["side_deviation"], d["residual"]), False),
    "s21-actuators": lambda d: ("holds", d["conventions_passing"] >= 1 and _zero(*d["max_residuals"].values()),
                                abs(d["same_handed_theta6_2_offset"]) > CLEAR),
    "eq5": lambda d: ("holds", _zero(d["theta4_residual"], d["theta5_residual"]), d["mirrored_theta4_offset"] > CLEAR),
    "eq6": lambda d: ("holds", d["identity"] is True and d["section_2_1_use"] is True, False),
    "s21-final-loop1": lambda d: ("holds", _zero(d["residual"]), None),
    "s21-final-loop2": lambda d: ("erratum", d["printed_min_residual"] > CLEAR and _zero(d["corrected_max_residual"])
                                  and d["grid_min_residual"] > CLEAR),
    "s21-eight-solutions": lambda d: ("holds", d["inputs"] >= 1 and all(c[0] == c[1] == 8 for c in d["counts"]), False),
    # an orthogonal F with det -1 satisfies f11 + f22 - 2 = 0 (value 0) without being I
    "eq7": lambda d: ("holds", d["identity"] is True and d["max_value"] <= ZERO, _zero(d["reflection_value"])),
    # for n = 2 the only closure phi = (pi, pi) is out of reach of t = tan(phi/2): the equation has no real root
    "eq8": lambda d: ("holds", _zero(d["max_relative_deviation"]), _positive_for_real_arguments(d["n2_polynomial"])),
    "eq9-sigma": lambda d: ("holds", _all_zero(d["paper_direction_mismatches"]) and d["rotated_chain_mismatches"] == 0,
                            any(d["opposite_direction_mismatches"]) or d["unequal_ranges_mismatches"] > 0
                            or d["known_factor_mismatches"] > 0),
    # ranges narrower than 2 pi: |t| stays finite after the shift
    "s22-range-shift": lambda d: ("holds", all(w < 2 * math.pi and math.isfinite(t) for w, t in d["max_abs_t"].items()),
                                  False),
    "prop1": lambda d: ("holds", _all_zero(d["mismatches"]), False),
    "prop2": lambda d: ("holds", d["max_n"] >= 2 and tuple(d["base"]) == (1, 0, 0, 0), None),
    "cor1": lambda d: ("holds", d["max_n"] >= 2, None),
    "cor2-constants": lambda d: ("holds", _all_zero(d["mismatches"].values()), False),
    "cor2-recursion": lambda d: ("holds", _all_zero(d["mismatches"]) and d["control_points"] > 0, None),
    "eq10": lambda d: ("holds", _all_zero(d["mismatches"]) and d["sizes"] == [3 ** n for n in range(1, d["max_n"] + 1)],
                       False),
    "s3-control-point-count": lambda d: ("holds", d["per_loop"] == d["spherekin_sizes"] == [81, 81], False),
    "eq11": lambda d: ("holds", d["max_m"] >= 1, False),
    # a ratio e_(k+1)/e_k -> 1/2 is linear convergence (double roots), not quadratic; the transversal
    # equations (the correction) converge in a few steps
    "s4-quadratic-convergence": lambda d: ("erratum", abs(d["ratio_min"] - 0.5) < 1e-3 and abs(d["ratio_max"] - 0.5) < 1e-3
                                           and d["transversal_steps"] <= 6),
}


def verdicts_from_evidence(result: ClaimResult) -> set[str]:
    """The verdicts that the claim's own data permits (empty: the data contradicts every verdict)."""
    reading = EVIDENCE[result.claim_id](result.data)
    if reading[0] == "erratum":
        return {ERRATUM} if reading[1] else set()
    _, holds, outside = reading
    if not holds:
        return set()
    return {None: {VERIFIED, VERIFIED_UNDER_CONDITIONS}, True: {VERIFIED_UNDER_CONDITIONS}, False: {VERIFIED}}[outside]


IMPL_CHECKS = {"impl:rotations", "impl:closure", "impl:paper-gosselin"}


@pytest.fixture(scope="module")
def quick_run() -> VerificationRun:
    return verification.run(quick=True)


# ---------------------------------------------------------------- the quick subset of every claim

def test_quick_run_has_no_errors_and_covers_every_claim(quick_run):
    assert quick_run.ok, [e.error for e in quick_run.errors]
    assert {r.claim_id for r in quick_run.claims} == set(EVIDENCE)
    assert {r.claim_id for r in quick_run.implementation_checks} == IMPL_CHECKS
    assert all(r.verdict == VERIFIED for r in quick_run.implementation_checks)


@pytest.mark.parametrize("claim_id", sorted(EVIDENCE))
def test_verdict_follows_from_the_claims_own_evidence(quick_run, claim_id):
    result = quick_run.by_id(claim_id)
    assert result.verdict in verdicts_from_evidence(result), (result.verdict, dict(result.data))
    assert result.evidence and result.reference and result.statement
    if result.verdict in (VERIFIED_UNDER_CONDITIONS, ERRATUM):
        assert result.correction


def test_evidence_reading_rejects_wrong_verdicts(quick_run):
    """The reading is not vacuous: swapping the verdicts of a holding claim and an erratum (what a
    wrong verdict in a check would do) is caught for every claim whose data decides its verdict."""
    for result in quick_run.claims:
        allowed = verdicts_from_evidence(result)
        assert allowed and allowed != set(VERDICTS)
        if result.verdict == ERRATUM:
            assert VERIFIED not in allowed and VERIFIED_UNDER_CONDITIONS not in allowed
        else:
            assert ERRATUM not in allowed
    # a holding claim whose data records a counterexample outside its conditions cannot be VERIFIED
    assert verdicts_from_evidence(quick_run.by_id("eq9-sigma")) == {VERIFIED_UNDER_CONDITIONS}
    assert verdicts_from_evidence(quick_run.by_id("eq1")) == {VERIFIED}


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
    for result in quick_run.claims:
        assert f"**{result.claim_id}**" in text
        if result.verdict == ERRATUM:
            assert f"### {result.claim_id} -- " in text
    errata = text.split("## Errata")[1].split("## Conditions")[0]
    assert errata.count("- **Printed:**") == errata.count("- **Corrected:**") == errata.count(
        "- **Numeric demonstration:**") == sum(r.verdict == ERRATUM for r in quick_run.claims) == 3
    table = [line for line in text.split("## Claims")[1].split("## Errata")[0].splitlines() if line.startswith("| **")]
    assert len(table) == len(quick_run.claims) and all(line.count(" | ") == 4 for line in table)
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


# ---------------------------------------------------------------- a report that does not change run to run

def test_rounded_bounds_rounding_noise_and_keeps_real_deviations():
    from verification.result import ROUNDOFF, rounded
    assert ROUNDOFF == 1e-12
    assert rounded(6.6e-16) == rounded(-7.4e-16) == rounded(0.0) == "< 1e-12"
    assert rounded(3.14159e-5) == "= 3.1e-05"
    assert rounded(1e-12) == "= 1.0e-12"          # the bound itself is not noise


def test_report_is_the_same_on_another_blas_kernel(quick_run, tmp_path):
    """A second run in a fresh interpreter whose BLAS uses another kernel (OPENBLAS_CORETYPE=Prescott:
    SSE3 instead of AVX2, as on an older machine) writes the same report, byte for byte: the residual
    digits that differ between kernels (6.6e-16 here, 7.4e-16 there) are printed as a bound."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(verification.__file__).resolve().parent.parent
    env = dict(os.environ, OPENBLAS_CORETYPE="Prescott", PYTHONPATH=str(root))
    out = tmp_path / "REPORT.md"
    done = subprocess.run([sys.executable, "-m", "verification", "--quick", "--report", str(out)], cwd=root,
                          env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert out.read_text(encoding="utf-8") == verification.render_report(quick_run)
