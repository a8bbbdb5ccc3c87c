"""Claims of Section 3 (and Eq. 11 of Section 4): Prop. 1, Prop. 2 with its base cases, Cor. 1,
Cor. 2 (every printed control point of g1, g2, h1, h2 and the recursion itself), Eq. (10) and the
linear precision behind Eq. (11); plus the cross-check of spherekin.closure against them.

Reference values are exact: sympy expansions of the matrix products (over QQ) converted to the
Bernstein basis in rational arithmetic (:mod:`verification.symbolic`). The paper's recursion is
re-implemented here from the printed constants, independently of spherekin.
"""

from __future__ import annotations

import itertools
from fractions import Fraction

import numpy as np
import sympy as sp

from .result import VERIFIED, VERIFIED_UNDER_CONDITIONS, ClaimResult, ImplementationMismatch
from .scalar_equation import affine_substitute
from .symbolic import (DEGREE, bernstein_coefficients, chain, chi, closure_polynomials, known_factor,
                       matmul, permute_indices, shifted_factor, sigma_index, unit_factor)

__all__ = [
    "PRINTED_G1", "PRINTED_G2", "PRINTED_H1", "PRINTED_H2",
    "paper_recursion", "symbolic_f11_f13",
    "check_prop1", "check_prop2", "check_cor1", "check_cor2_constants", "check_cor2_recursion",
    "check_eq10", "check_eq11", "check_impl_closure",
]

#: Control points of g1, g2, h1, h2 different from zero, as printed under Cor. 2.
PRINTED_G1 = {(0, 0): -1, (0, 1): -1, (1, 0): -1, (1, 1): -1, (2, 0): -2, (2, 1): -2}
PRINTED_G2 = {(0, 1): 1, (1, 1): 1, (0, 2): 2, (1, 2): 2, (2, 1): 2, (2, 2): 4}
PRINTED_H1 = {(1,): 1, (2,): 2}
PRINTED_H2 = {(0,): -1, (1,): -1}

#: Largest n of the Bernstein-coefficient checks (quick, full); the issue asks for n = 1..6.
MAX_N = (4, 6)
#: Largest n of the symbolic recursion checks of Prop. 2 / Cor. 1 (quick, full): cheap polynomials.
MAX_N_RECURSION = (6, 8)


def _max_n(quick: bool, table=MAX_N) -> int:
    return table[0 if quick else 1]


def _tensor(printed: dict, ndim: int) -> np.ndarray:
    out = np.full((DEGREE + 1,) * ndim, Fraction(0), dtype=object)
    for idx, v in printed.items():
        out[idx] = Fraction(v)
    return out


def paper_recursion(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Control points of fbar11^n, fbar13^n by Cor. 2 with the printed g1, g2, h1, h2 (exact).

    Base cases (not printed in the paper; they follow from F_0 = I and F_1 = Rx(phi_1) Z, whose first
    row is (0, -1, 0)): fbar11^0 = 1, fbar13^0 = 0, fbar11^1 = fbar13^1 = 0 (as degree-2 polynomials).
    Shapes (3,) * n.
    """
    if not isinstance(n, int) or n < 1:
        raise ValueError(f"n: expected an integer >= 1, got {n!r}")
    g1, g2 = _tensor(PRINTED_G1, 2), _tensor(PRINTED_G2, 2)
    h1, h2 = _tensor(PRINTED_H1, 1), _tensor(PRINTED_H2, 1)
    f11 = [np.array(Fraction(1), dtype=object), np.full(3, Fraction(0), dtype=object)]
    f13 = [np.array(Fraction(0), dtype=object), np.full(3, Fraction(0), dtype=object)]
    for k in range(2, n + 1):
        f11.append(np.multiply.outer(f11[k - 2], g1) + np.multiply.outer(f13[k - 1], h1))
        f13.append(np.multiply.outer(f11[k - 2], g2) - np.multiply.outer(f13[k - 1], h2))
    return f11[n], f13[n]


def symbolic_f11_f13(n: int) -> dict[str, np.ndarray]:
    """Exact Bernstein control points (t in [0,1], degree 2 per variable) of fbar11, fbar13, fbar22,
    q_n and f = fbar11 + fbar22 - 2 q_n, from the sympy expansion of prod (1+t_k^2) Rx(phi_k) Z."""
    fbar, qn, _ = closure_polynomials(n)
    return {
        "f11": bernstein_coefficients(fbar[0][0]),
        "f13": bernstein_coefficients(fbar[0][2]),
        "f22": bernstein_coefficients(fbar[1][1]),
        "q": bernstein_coefficients(qn),
        "f": bernstein_coefficients(fbar[0][0] + fbar[1][1] - 2 * qn),
        "matrix": np.array([[bernstein_coefficients(fbar[i][j]) for j in range(3)] for i in range(3)]),
    }


def check_prop1(quick: bool) -> ClaimResult:
    """Prop. 1: c_I(q_n) = 2^chi(I)."""
    t = sp.Symbol("t")
    uni = bernstein_coefficients(sp.Poly(1 + t**2, t))
    mismatches, sizes = [], []
    for n in range(1, _max_n(quick) + 1):
        _, qn, _ = closure_polynomials(n)
        c = bernstein_coefficients(qn)
        sizes.append(c.size)
        mismatches.append(sum(c[idx] != 2 ** chi(idx) for idx in itertools.product(range(3), repeat=n)))
    if list(uni) != [1, 1, 2] or any(mismatches):
        raise AssertionError(f"Prop. 1: q = {list(uni)}, mismatches {mismatches}")
    return ClaimResult(
        "prop1", "Prop. 1, Section 3", VERIFIED,
        evidence=(f"exact Bernstein coefficients of q_n = prod (1 + t_i^2) (t in [0,1], degree 2 per variable): "
                  f"univariate (1, 1, 2), i.e. q = b0 + b1 + 2 b2 as in the proof; c_I(q_n) = 2^chi(I) at all "
                  f"{sum(sizes)} control points for n = 1..{_max_n(quick)} (mismatches {mismatches})."),
        statement="c_I(q_n) = 2^chi(I), chi(I) = number of entries of I equal to 2",
        data={"mismatches": mismatches},
    )


def _trig_chain(n: int):
    cs = sp.symbols(f"c1:{n + 1}"), sp.symbols(f"s1:{n + 1}")
    mats = [[[0, -1, 0], [c, 0, -s], [s, 0, c]] for c, s in zip(*cs)]
    partial = [[[1, 0, 0], [0, 1, 0], [0, 0, 1]]]
    for m in mats:
        partial.append(matmul(partial[-1], m))
    return partial, cs


def check_prop2(quick: bool) -> ClaimResult:
    """Prop. 2: f11^n = -f11^(n-2) cos(phi_n) + f13^(n-1) sin(phi_n), f13^n = f11^(n-2) sin + f13^(n-1) cos."""
    max_n = _max_n(quick, MAX_N_RECURSION)
    partial, (c, s) = _trig_chain(max_n)           # partial[k] = F_k (F_0 = I)
    ok11, ok13 = [], []
    for n in range(2, max_n + 1):
        f11 = -partial[n - 2][0][0] * c[n - 1] + partial[n - 1][0][2] * s[n - 1]
        f13 = partial[n - 2][0][0] * s[n - 1] + partial[n - 1][0][2] * c[n - 1]
        ok11.append(sp.expand(partial[n][0][0] - f11) == 0)
        ok13.append(sp.expand(partial[n][0][2] - f13) == 0)
    base = (partial[0][0][0], partial[0][0][2], partial[1][0][0], partial[1][0][2])
    if not (all(ok11) and all(ok13) and base == (1, 0, 0, 0)):
        raise AssertionError(f"Prop. 2: f11 {ok11}, f13 {ok13}, base {base}")
    return ClaimResult(
        "prop2", "Prop. 2, Section 3", VERIFIED_UNDER_CONDITIONS,
        evidence=(f"sympy, exact: with c_k = cos(phi_k), s_k = sin(phi_k) as free symbols (the identity does not "
                  f"even need c^2 + s^2 = 1), both recursions equal the entries (1,1) and (1,3) of the expanded "
                  f"product F_n for n = 2..{max_n}; the base values are f11^0 = 1, f13^0 = 0 (F_0 = I) and "
                  f"f11^1 = f13^1 = 0 (first row of Rx(phi_1) Z is (0, -1, 0))."),
        correction=("Valid for n >= 2 with the base cases f11^0 = 1, f13^0 = 0, f11^1 = 0, f13^1 = 0, which the "
                    "paper does not state; the left-hand sides should read f11^n, f13^n."),
        statement="f11^n = -f11^(n-2) cos(phi_n) + f13^(n-1) sin(phi_n); "
                  "f13^n = f11^(n-2) sin(phi_n) + f13^(n-1) cos(phi_n)",
        data={"max_n": max_n, "base": base},
    )


def _printed_polys(t_prev, t_n, gens):
    h1 = sp.Poly(2 * t_n, *gens, domain="QQ")
    h2 = sp.Poly(t_n**2 - 1, *gens, domain="QQ")
    g1 = sp.Poly((t_prev**2 + 1) * (t_n**2 - 1), *gens, domain="QQ")
    g2 = sp.Poly((t_prev**2 + 1) * 2 * t_n, *gens, domain="QQ")
    return g1, g2, h1, h2


def check_cor1(quick: bool) -> ClaimResult:
    """Cor. 1: fbar11^n = fbar11^(n-2) g1 + fbar13^(n-1) h1, fbar13^n = fbar11^(n-2) g2 - fbar13^(n-1) h2."""
    max_n = _max_n(quick, MAX_N_RECURSION)
    ts = sp.symbols(f"t1:{max_n + 1}")
    one, zero = sp.Poly(1, *ts, domain="QQ"), sp.Poly(0, *ts, domain="QQ")
    partial = [[[one if i == j else zero for j in range(3)] for i in range(3)]]
    for t in ts:
        q, c, s = unit_factor(t, ts)
        partial.append(matmul(partial[-1], [[zero, -q, zero], [c, zero, -s], [s, zero, c]]))
    results = []
    for n in range(2, max_n + 1):
        g1, g2, h1, h2 = _printed_polys(ts[n - 2], ts[n - 1], ts)
        f11 = partial[n - 2][0][0] * g1 + partial[n - 1][0][2] * h1
        f13 = partial[n - 2][0][0] * g2 - partial[n - 1][0][2] * h2
        results.append((f11 - partial[n][0][0]).is_zero and (f13 - partial[n][0][2]).is_zero)
    if not all(results):
        raise AssertionError(f"Cor. 1 fails for n in {[n for n, r in zip(range(2, max_n + 1), results) if not r]}")
    return ClaimResult(
        "cor1", "Cor. 1, Section 3", VERIFIED_UNDER_CONDITIONS,
        evidence=(f"sympy, exact over QQ: with h1 = 2t_n, h2 = t_n^2 - 1, g1 = (t_(n-1)^2 + 1) h2, "
                  f"g2 = (t_(n-1)^2 + 1) h1 as printed, both recursions reproduce the expanded fbar11^n, fbar13^n "
                  f"of prod (1+t_k^2) Rx(phi_k) Z for n = 2..{max_n}."),
        correction="Valid for n >= 2 with fbar11^0 = 1, fbar13^0 = 0, fbar11^1 = fbar13^1 = 0 (not stated).",
        statement="fbar11^n = fbar11^(n-2) g1 + fbar13^(n-1) h1; fbar13^n = fbar11^(n-2) g2 - fbar13^(n-1) h2, "
                  "h1 = 2t_n, h2 = t_n^2 - 1, g1 = (t_(n-1)^2+1) h2, g2 = (t_(n-1)^2+1) h1",
        data={"max_n": max_n},
    )


def check_cor2_constants(quick: bool) -> ClaimResult:
    """Cor. 2: every printed control point of g1, g2, h1, h2 (and that all others are zero)."""
    a, b = sp.symbols("a b")
    g1, g2, h1, h2 = _printed_polys(a, b, (a, b))
    exact = {
        "g1": (bernstein_coefficients(g1), _tensor(PRINTED_G1, 2)),
        "g2": (bernstein_coefficients(g2), _tensor(PRINTED_G2, 2)),
        "h1": (bernstein_coefficients(sp.Poly(2 * b, b)), _tensor(PRINTED_H1, 1)),
        "h2": (bernstein_coefficients(sp.Poly(b**2 - 1, b)), _tensor(PRINTED_H2, 1)),
    }
    bad = {k: int(np.sum(c != p)) for k, (c, p) in exact.items()}
    listed = len(PRINTED_G1) + len(PRINTED_G2) + len(PRINTED_H1) + len(PRINTED_H2)
    if any(bad.values()):
        raise AssertionError(f"Cor. 2 constants: mismatches {bad}")
    return ClaimResult(
        "cor2-constants", "Cor. 2, Section 3 (control points of g1, g2, h1, h2)", VERIFIED,
        evidence=(f"exact Bernstein coefficients (degree 2 per variable, t in [0,1]) of the printed g1, g2, h1, h2: "
                  f"all {listed} listed nonzero values are right and the other "
                  f"{9 + 9 + 3 + 3 - listed} coefficients are 0 (mismatches {bad})."),
        statement="c_(0,0)(g1) = c_(0,1)(g1) = c_(1,0)(g1) = c_(1,1)(g1) = -1, c_(2,0)(g1) = c_(2,1)(g1) = -2, "
                  "c_(0,1)(g2) = c_(1,1)(g2) = 1, c_(0,2)(g2) = c_(1,2)(g2) = c_(2,1)(g2) = 2, c_(2,2)(g2) = 4, "
                  "c_1(h1) = 1, c_2(h1) = 2, c_0(h2) = c_1(h2) = -1, all others 0",
        data={"mismatches": bad},
    )


def check_cor2_recursion(quick: bool) -> ClaimResult:
    """Cor. 2: the control-point recursion, against exact expansions for n = 1..6."""
    max_n = _max_n(quick)
    mism, sizes = [], []
    for n in range(1, max_n + 1):
        ref = symbolic_f11_f13(n)
        c11, c13 = paper_recursion(n)
        sizes.append(c11.size)
        mism.append(int(np.sum(c11 != ref["f11"]) + np.sum(c13 != ref["f13"])))
    if any(mism):
        raise AssertionError(f"Cor. 2 recursion mismatches {mism}")
    return ClaimResult(
        "cor2-recursion", "Cor. 2, Section 3 (recursion)", VERIFIED_UNDER_CONDITIONS,
        evidence=(f"the recursion with the printed g1, g2, h1, h2, in Fractions, against the exact Bernstein "
                  f"coefficients of the expanded fbar11^n and fbar13^n (sympy over QQ) for n = 1..{max_n}: "
                  f"{2 * sum(sizes)} control points, mismatches {mism}."),
        correction=("Base cases c(fbar11^0) = 1, c(fbar13^0) = 0, c(fbar11^1) = c(fbar13^1) = (0, 0, 0) (not "
                    "stated). The control points are those of the basis b_(i,2)(t_k) with t_k in [0,1] "
                    "(phi_k in [0, pi/2]); other ranges need the reparameterization of Section 4 (or factor "
                    "polynomials built for the range)."),
        statement="c_I(fbar11^n) = c(fbar11^(n-2)) c(g1) + c(fbar13^(n-1)) c(h1); "
                  "c_I(fbar13^n) = c(fbar11^(n-2)) c(g2) - c(fbar13^(n-1)) c(h2)",
        data={"max_n": max_n, "mismatches": mism, "control_points": 2 * sum(sizes)},
    )


def check_eq10(quick: bool) -> ClaimResult:
    """Eq. (10): c_I(f) = c_I(fbar11) + c_(I^sigma)(fbar11) - 2^(chi(I)+1), 3^n control points."""
    max_n = _max_n(quick)
    mism, sizes = [], []
    for n in range(1, max_n + 1):
        ref = symbolic_f11_f13(n)
        c11 = paper_recursion(n)[0]
        shifted = permute_indices(c11, sigma_index)
        twos = np.empty_like(c11)
        for idx in itertools.product(range(3), repeat=n):
            twos[idx] = Fraction(2 ** (chi(idx) + 1))
        printed = c11 + shifted - twos
        sizes.append(printed.size)
        mism.append(int(np.sum(printed != ref["f"])))
    if any(mism) or sizes != [3 ** n for n in range(1, max_n + 1)]:
        raise AssertionError(f"Eq. (10): mismatches {mism}, sizes {sizes}")
    return ClaimResult(
        "eq10", "Eq. (10), Section 3", VERIFIED,
        evidence=(f"c_I(fbar11) from Cor. 2 (printed constants), shifted by I^sigma, minus 2^(chi(I)+1), against "
                  f"the exact Bernstein coefficients of fbar11 + fbar22 - 2 q_n for n = 1..{max_n}: control-point "
                  f"counts {sizes} (= 3^n), mismatches {mism}. Setting of the paper: every phi_i unknown, "
                  f"t in [0,1]."),
        statement="sum_I [c_I(fbar11) + c_(I^sigma)(fbar11) - 2^(chi(I)+1)] B_I(t) = 0, with 3^n control points",
        data={"max_n": max_n, "mismatches": mism, "sizes": sizes},
    )


def check_eq11(quick: bool) -> ClaimResult:
    """Eq. (11): F(x) = (x, f(x)) = sum_I v_I B_I(x) with v_I = (i_1/m_1, ..., w_I) (linear precision)."""
    x = sp.Symbol("x")
    ok = []
    max_m = 6
    for m in range(1, max_m + 1):
        b = [sp.binomial(m, i) * x**i * (1 - x) ** (m - i) for i in range(m + 1)]
        ok.append(sp.expand(sum(sp.Rational(i, m) * bi for i, bi in enumerate(b)) - x) == 0
                  and sp.expand(sum(b) - 1) == 0)
    if not all(ok):
        raise AssertionError(f"Eq. (11): linear precision fails for m in {ok}")
    return ClaimResult(
        "eq11", "Eq. (11), Section 4", VERIFIED,
        evidence=(f"sympy: sum_i (i/m) b_(i,m)(x) = x and sum_i b_(i,m)(x) = 1 for m = 1..{max_m}; with tensor "
                  f"products this gives x_k = sum_I (i_k/m_k) B_I(x), so the graph (x, f(x)) has control points "
                  f"v_I = (I/M, w_I) as printed."),
        statement="F(x) = (x, f(x)) = sum_I v_I B_I(x), v_I = (i_1/m_1, ..., i_n/m_n, w_I)",
        data={"max_m": max_m},
    )


#: Ranged/shifted factors of the generalized cross-check: (kind, args) with exact numbers.
MIXED_CHAIN = (
    ("var", Fraction(-1, 2), Fraction(3, 4), Fraction(3, 5), Fraction(4, 5), 1),
    ("known", Fraction(-5, 13), Fraction(12, 13)),
    ("var", Fraction(1, 3), Fraction(2), Fraction(0), Fraction(1), -1),
    ("known", Fraction(-1), Fraction(0)),
    ("var", Fraction(-2), Fraction(-1, 4), Fraction(8, 17), Fraction(-15, 17), 1),
)


def _mixed_reference():
    """Exact matrix control points of MIXED_CHAIN: factors built from trig identities, then the affine
    range map t = a + (b - a) x applied to the expanded product."""
    ts, xs = sp.symbols("t1:4"), sp.symbols("x1:4")
    factors, ranges, k = [], [], 0
    for kind in MIXED_CHAIN:
        if kind[0] == "var":
            _, a, b, cd, sd, sign = kind
            factors.append(shifted_factor(ts[k], sp.Rational(cd.numerator, cd.denominator),
                                          sp.Rational(sd.numerator, sd.denominator), sign, ts))
            ranges.append((a, b))
            k += 1
        else:
            factors.append(known_factor(sp.Rational(kind[1].numerator, kind[1].denominator),
                                        sp.Rational(kind[2].numerator, kind[2].denominator), ts))
    mat, qn = chain(factors)
    conv = [[bernstein_coefficients(affine_substitute(mat[i][j], ranges, xs)) for j in range(3)] for i in range(3)]
    return np.array(conv), bernstein_coefficients(affine_substitute(qn, ranges, xs))


def check_impl_closure(quick: bool) -> ClaimResult:
    """spherekin.closure against the exact expansions (Prop. 1, Cor. 2, Eq. 9/10, the matrix route)."""
    from spherekin import closure as C

    max_n = _max_n(quick)
    unit = C.variable_factor(Fraction(0), Fraction(1))
    problems = []
    for n in range(1, max_n + 1):
        ref = symbolic_f11_f13(n)
        factors = [unit] * n
        f11, f13 = C.f11_f13_recursion(factors)
        checks = {
            "f11_f13_recursion": np.array_equal(f11, ref["f11"]) and np.array_equal(f13, ref["f13"]),
            "matrix_control_points": np.array_equal(C.matrix_control_points(factors), ref["matrix"]),
            "q_control_points": np.array_equal(C.q_control_points(factors), ref["q"]),
            "sigma_shift": np.array_equal(C.sigma_shift(f11), ref["f22"]),
            "scalar_control_points(recursion)": np.array_equal(C.scalar_control_points(factors, "recursion"), ref["f"]),
            "scalar_control_points(product)": np.array_equal(C.scalar_control_points(factors, "product"), ref["f"]),
        }
        problems += [f"{name} (n = {n})" for name, good in checks.items() if not good]
    mixed = [C.known_factor(k[1], k[2]) if k[0] == "known" else C.variable_factor(*k[1:]) for k in MIXED_CHAIN]
    ref_mat, ref_q = _mixed_reference()
    mat = C.matrix_control_points(mixed)
    scalar = C.scalar_control_points(mixed, "recursion")
    if not np.array_equal(mat, ref_mat):
        problems.append("matrix_control_points (known factors, ranges, shifts)")
    if not np.array_equal(scalar, ref_mat[0, 0] + ref_mat[1, 1] - 2 * ref_q):
        problems.append("scalar_control_points (known factors, ranges, shifts)")
    if problems:
        raise ImplementationMismatch("spherekin.closure disagrees with the exact expansion: " + ", ".join(problems))
    return ClaimResult(
        "impl:closure", "spherekin.closure (Prop. 1, Cor. 2, Eq. 9-10, product route)", VERIFIED,
        evidence=(f"exact equality (Fractions) with the sympy expansions for n = 1..{max_n} unknowns on [0,1]: "
                  f"f11_f13_recursion, matrix_control_points (all 9 entries), q_control_points, sigma_shift, "
                  f"scalar_control_points by both routes; and for a 5-factor chain with 2 known factors, 3 "
                  f"unknowns with shifts, signs and distinct ranges (all 9 entries and Eq. 10)."),
        data={"max_n": max_n},
    )
