"""Tests for spherekin.closure against independent derivations.

* numerics: Bernstein tensors evaluated at random points vs q(t) times the directly computed
  matrix product of Rx(phi) Z factors (numpy);
* exact: recursion route == product route == sympy's expansion of the symbolic matrix product, in
  rational arithmetic (Fractions / sympy Rationals), for n <= 5;
* the paper's printed control points of q, g1, g2, h1, h2 (Prop. 1, Cor. 2) as test data.
"""

import itertools
import math
from fractions import Fraction

import numpy as np
import pytest
import sympy as sp

from spherekin.core import bernstein
from spherekin import closure as C
from spherekin.paper_gosselin import paper_gosselin_loops

# Pythagorean (cos, sin) pairs: exact rational known angles.
PYTHAGOREAN = [(Fraction(3, 5), Fraction(4, 5)), (Fraction(-5, 13), Fraction(12, 13)),
               (Fraction(8, 17), Fraction(-15, 17)), (Fraction(0), Fraction(1)), (Fraction(-1), Fraction(0))]


# ---------------------------------------------------------------- independent sympy reference

def sym_factor(kind, x):
    """(q, c, s) of one factor as sympy expressions in x, derived from trig identities.

    kind = ("known", cos, sin) or ("var", t_lo, t_hi, cos_d, sin_d, sign): phi = d + sign * psi with
    tan(psi/2) = t = t_lo + (t_hi - t_lo) x; cos/sin of phi come from sympy's expand_trig and the
    half-angle substitution cos psi = (1-t^2)/(1+t^2), sin psi = 2t/(1+t^2).
    """
    if kind[0] == "known":
        return sp.Integer(1), sp.Rational(kind[1]), sp.Rational(kind[2])
    _, a, b, cd, sd, sign = kind
    d, psi = sp.symbols("d psi")
    t = sp.Rational(a) + (sp.Rational(b) - sp.Rational(a)) * x
    subs = {sp.cos(d): sp.Rational(cd), sp.sin(d): sp.Rational(sd),
            sp.cos(psi): (1 - t**2) / (1 + t**2), sp.sin(psi): 2 * t / (1 + t**2)}
    q = 1 + t**2
    cphi = sp.expand_trig(sp.cos(d + sign * psi)).subs(subs)
    sphi = sp.expand_trig(sp.sin(d + sign * psi)).subs(subs)
    return sp.expand(q), sp.cancel(q * cphi), sp.cancel(q * sphi)


def sym_closure(kinds):
    """q_n * F_n as a sympy Matrix of polynomials, plus q_n and the variable symbols."""
    xs = []
    mat, qn = sp.eye(3), sp.Integer(1)
    zmat = sp.Matrix([[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    for k, kind in enumerate(kinds):
        x = sp.Symbol(f"x{k}")
        if kind[0] == "var":
            xs.append(x)
        q, c, s = sym_factor(kind, x)
        mat = mat * sp.Matrix([[q, 0, 0], [0, c, -s], [0, s, c]]) * zmat
        qn *= q
    return mat.applyfunc(sp.expand), sp.expand(qn), xs


def sym_bernstein(coeffs, xs):
    """sum_I c_I B_I(x) expanded, from the definition of the Bernstein basis."""
    total = sp.Integer(0)
    for idx in itertools.product(*(range(n) for n in np.shape(coeffs))):
        term = sp.Rational(coeffs[idx])
        for i, x in zip(idx, xs):
            term *= sp.binomial(2, i) * x**i * (1 - x) ** (2 - i)
        total += term
    return sp.expand(total)


def code_factor(kind):
    if kind[0] == "known":
        return C.known_factor(kind[1], kind[2])
    return C.variable_factor(*kind[1:])


def random_kinds(rng, n, n_var):
    where = set(rng.choice(n, size=n_var, replace=False).tolist())
    kinds = []
    for k in range(n):
        cd, sd = PYTHAGOREAN[rng.integers(len(PYTHAGOREAN))]
        if k in where:
            a = Fraction(int(rng.integers(-6, 4)), 4)
            b = a + Fraction(int(rng.integers(1, 8)), 4)
            kinds.append(("var", a, b, cd, sd, int(rng.choice([1, -1]))))
        else:
            kinds.append(("known", cd, sd))
    return kinds


# ---------------------------------------------------------------- the paper's printed data

UNIT = ("var", Fraction(0), Fraction(1), Fraction(1), Fraction(0), 1)


def test_prop1_and_cor2_constants_on_unit_ranges():
    f = C.variable_factor(Fraction(0), Fraction(1))
    assert list(f.q) == [1, 1, 2]                      # Prop. 1: q = b0 + b1 + 2 b2
    h1, h2 = f.s, -f.c
    assert list(h1) == [0, 1, 2]                       # c_1(h1) = 1, c_2(h1) = 2
    assert list(h2) == [-1, -1, 0]                     # c_0(h2) = c_1(h2) = -1
    g1, g2 = np.multiply.outer(f.q, h2), np.multiply.outer(f.q, h1)
    printed_g1 = {(0, 0): -1, (0, 1): -1, (1, 0): -1, (1, 1): -1, (2, 0): -2, (2, 1): -2}
    printed_g2 = {(0, 1): 1, (1, 1): 1, (0, 2): 2, (1, 2): 2, (2, 1): 2, (2, 2): 4}
    for idx in itertools.product(range(3), repeat=2):
        assert g1[idx] == printed_g1.get(idx, 0)
        assert g2[idx] == printed_g2.get(idx, 0)


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_prop1_q_is_two_to_chi(n):
    q = C.q_control_points([C.variable_factor(Fraction(0), Fraction(1))] * n)
    for idx in itertools.product(range(3), repeat=n):
        assert q[idx] == 2 ** sum(i == 2 for i in idx)


@pytest.mark.parametrize("n", [2, 3, 4, 5])
def test_paper_sigma_formula_in_paper_setting(n):
    """All factors unknown over [0, 1]: c_I(f22bar) = c_{I^sigma}(f11bar) as the paper states."""
    factors = [code_factor(UNIT)] * n
    f11, _ = C.f11_f13_recursion(factors)
    m = C.matrix_control_points(factors)
    assert np.array_equal(m[1, 1], C.sigma_shift(f11))


# ---------------------------------------------------------------- exact: both routes vs sympy

@pytest.mark.parametrize("n, n_var, seed", [(1, 1, 0), (2, 2, 1), (3, 2, 2), (3, 3, 3), (4, 2, 4), (4, 4, 5),
                                            (5, 3, 6), (6, 2, 7)])
def test_routes_agree_exactly(n, n_var, seed):
    kinds = random_kinds(np.random.default_rng(seed), n, n_var)
    factors = [code_factor(k) for k in kinds]
    m = C.matrix_control_points(factors)
    f11, f13 = C.f11_f13_recursion(factors)
    assert m.shape == (3, 3) + (3,) * n_var and m.dtype == object
    assert np.array_equal(f11, m[0, 0]) and np.array_equal(f13, m[0, 2])
    rec = C.scalar_control_points(factors, "recursion")
    prod = C.scalar_control_points(factors, "product")
    assert np.array_equal(rec, prod)


@pytest.mark.parametrize("n, n_var, seed", [(2, 2, 11), (3, 3, 12), (4, 3, 13), (4, 4, 14), (5, 5, 15)])
def test_control_points_equal_sympy_expansion(n, n_var, seed):
    kinds = random_kinds(np.random.default_rng(seed), n, n_var)
    mat, qn, xs = sym_closure(kinds)
    factors = [code_factor(k) for k in kinds]
    m = C.matrix_control_points(factors)
    entries = [(0, 0), (0, 2), (1, 1)] if n == 5 else list(itertools.product(range(3), repeat=2))
    for i, j in entries:
        assert sym_bernstein(m[i, j], xs) == mat[i, j], f"entry ({i},{j})"
    scalar = C.scalar_control_points(factors, "recursion")
    assert sym_bernstein(scalar, xs) == sp.expand(mat[0, 0] + mat[1, 1] - 2 * qn)


# ---------------------------------------------------------------- floats: vs direct numpy products

def random_loop(rng, n, n_var):
    where = set(rng.choice(n, size=n_var, replace=False).tolist())
    factors = []
    for k in range(n):
        if k in where:
            lo = rng.uniform(-6, 5)
            u = C.Unknown(f"u{k}", lo, lo + rng.uniform(0.1, 6.2))
            factors.append((u if rng.random() < 0.5 else -u) + rng.uniform(-4, 4) if rng.random() < 0.7 else u)
        else:
            factors.append(rng.choice([np.pi, -np.pi / 2, 0.0, rng.uniform(-4, 4)]))
    return C.ClosureLoop(factors)


@pytest.mark.parametrize("seed", range(8))
def test_control_points_match_numeric_matrix_product(seed):
    rng = np.random.default_rng(100 + seed)
    n = int(rng.integers(2, 9))
    loop = random_loop(rng, n, int(rng.integers(1, min(n, 5) + 1)))
    x = rng.uniform(0, 1, (50, len(loop.unknowns)))
    t_lo_hi = np.array([u.t_range for u in loop.unknowns])
    t = t_lo_hi[:, 0] + (t_lo_hi[:, 1] - t_lo_hi[:, 0]) * x
    qn = np.prod(1 + t**2, axis=-1)
    expected = qn[:, None, None] * loop.closure_matrix(x)
    got = np.moveaxis(bernstein.evaluate(loop.matrix_control_points(), x), -1, 0)
    scale = np.abs(expected).max(axis=(1, 2), keepdims=True)
    np.testing.assert_array_less(np.abs(got - expected) / scale, 1e-12)
    for route in C.ROUTES:
        f = bernstein.evaluate(loop.scalar_control_points(route), x)
        direct = qn * (np.trace(loop.closure_matrix(x), axis1=-2, axis2=-1) - loop.closure_matrix(x)[:, 2, 2] - 2)
        np.testing.assert_array_less(np.abs(f - direct) / scale[:, 0, 0], 1e-12)
        assert np.all(f <= 1e-12 * scale[:, 0, 0])  # Eq. (10) is <= 0 everywhere


def test_known_angle_pi_stays_exact():
    loop = C.ClosureLoop([np.pi, C.Unknown("a", -1, 1), 3 * np.pi / 2, -np.pi / 2])
    polys = loop.factor_polynomials()
    assert (float(polys[0].c), float(polys[0].s)) == (-1.0, 0.0)
    assert (float(polys[2].c), float(polys[2].s)) == (0.0, -1.0)
    assert (float(polys[3].c), float(polys[3].s)) == (0.0, -1.0)
    assert np.all(np.isfinite(loop.matrix_control_points()))


def test_unknown_range_through_pi_uses_midpoint_shift():
    u = C.Unknown("a", 2.5, 4.0)
    assert u.shift == pytest.approx(3.25)
    v = C.Unknown("b", -1.0, 2.0)
    assert v.shift == 0.0 and v.t_range == (math.tan(-0.5), math.tan(1.0))
    theta = np.linspace(2.5, 4.0, 7)
    np.testing.assert_allclose(u.to_angle(u.to_unit(theta)), theta, atol=1e-13)
    np.testing.assert_allclose(u.to_unit([2.5, 4.0]), [0.0, 1.0], atol=1e-13)


def test_tan_half_maps_are_inverse_and_are_what_unknowns_use():
    rng = np.random.default_rng(3)
    shift = np.array([0.0, math.pi, 3.25])
    t_lo, t_hi = np.tan(-0.5 * np.array([1.0, 1.5, 0.75])), np.tan(0.5 * np.array([1.2, 1.5, 0.75]))
    x = rng.uniform(0, 1, (50, 3))
    theta = C.tan_half_angle(x, shift, t_lo, t_hi)
    assert theta.shape == (50, 3)
    np.testing.assert_allclose(C.tan_half_unit(theta, shift, t_lo, t_hi), x, atol=1e-13)
    np.testing.assert_allclose(C.tan_half_unit(theta + 2 * math.pi, shift, t_lo, t_hi), x, atol=1e-12)
    u = C.Unknown("a", 2.5, 4.0)
    assert np.array_equal(u.to_angle(x[:, 2]), C.tan_half_angle(x[:, 2], u.shift, *u.t_range))
    assert np.array_equal(u.to_unit(theta[:, 2]), C.tan_half_unit(theta[:, 2], u.shift, *u.t_range))


def test_angle_arithmetic_builds_terms():
    u = C.Unknown("a", -1, 1)
    assert (u + 0.5) == C.Term(u, 0.5, 1)
    assert (np.float64(0.5) - u) == C.Term(u, 0.5, -1)
    assert -(u - 1.0) == C.Term(u, 1.0, -1)


# ---------------------------------------------------------------- the paper's Gosselin loops

def test_gosselin_loops_have_81_control_points_each():
    loops = paper_gosselin_loops(betas=(0.1, -0.2, 0.3))
    assert [len(lp.unknowns) for lp in loops] == [4, 4]
    sizes = [lp.scalar_control_points().size for lp in loops]
    assert sizes == [81, 81] and sum(sizes) == 162
    shared = set(loops[0].unknowns) & set(loops[1].unknowns)
    assert sorted(u.name for u in shared) == ["theta4_1", "theta5_1"]


def test_eq6_split_loop_equals_offset_loop():
    """Loop 2 written with the paper's Eq. (6) split equals it written with theta4^1 + pi/2."""
    split = paper_gosselin_loops(betas=(0.1, -0.2, 0.3), loop2_form="split")[1]
    offset = paper_gosselin_loops(betas=(0.1, -0.2, 0.3), loop2_form="offset")[1]
    assert split.n == 8 and offset.n == 6
    np.testing.assert_allclose(split.matrix_control_points(), offset.matrix_control_points(), atol=1e-12)


# ---------------------------------------------------------------- bad input

@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: C.Unknown("a", 1.0, 1.0), "lo < hi"),
        (lambda: C.Unknown("a", 0.0, np.nan), "a.hi"),
        (lambda: C.Unknown("a", -4.0, 2.3), "narrower than 2"),
        (lambda: C.Unknown("a", 0.0, 3.0, shift=-1.0), "singularity"),
        (lambda: C.Unknown("", 0.0, 1.0), "name"),
        (lambda: C.ClosureLoop([]), "factors"),
        (lambda: C.ClosureLoop([0.1, np.inf]), r"factors\[1\]"),
        (lambda: C.ClosureLoop(["x"]), r"factors\[0\]"),
        (lambda: C.Term(C.Unknown("a", 0, 1), sign=2), "sign"),
        (lambda: C.scalar_control_points([C.known_factor(1.0, 0.0)], "simplex"), "route"),
        (lambda: C.ClosureLoop([C.Unknown("a", 0, 1)]).closure_matrix([[0.5, 0.5]]), "x"),
    ],
)
def test_bad_input_names_the_problem(call, name):
    with pytest.raises(ValueError, match=name):
        call()


def test_unknown_twice_in_a_loop_is_rejected():
    u = C.Unknown("a", 0, 1)
    with pytest.raises(ValueError, match="appears twice"):
        C.ClosureLoop([u, 0.3, u + 1.0])


@pytest.mark.parametrize("seed", range(4))
def test_closure_at_is_the_product_of_rotations_and_its_derivative(seed):
    """closure_at: F_n against the product of Rx(phi_i) Z built here with sympy-free numpy (one
    rotation at a time), and dF/dtheta against central differences of that product."""
    rng = np.random.default_rng(seed)
    a, b, c = (C.Unknown(n, -3.0, 3.0) for n in "abc")
    loops = [C.ClosureLoop([0.4, a, np.pi / 2 - b, 1.1, c + 0.3]), C.ClosureLoop([b, -0.7, c, a + np.pi])]
    theta = rng.uniform(-3.0, 3.0, 3)

    def product(th):
        out = []
        for phis in ([0.4, th[0], np.pi / 2 - th[1], 1.1, th[2] + 0.3], [th[1], -0.7, th[2], th[0] + np.pi]):
            m = np.eye(3)
            for phi in phis:
                rx = np.array([[1, 0, 0], [0, math.cos(phi), -math.sin(phi)], [0, math.sin(phi), math.cos(phi)]])
                m = m @ rx @ np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])
            out.append(m)
        return np.array(out)

    f, j = C.closure_at(loops, [a, b, c], theta, jacobian=True)
    assert f.shape == (2, 3, 3) and j.shape == (2, 3, 3, 3)
    np.testing.assert_allclose(f, product(theta), atol=1e-14)
    np.testing.assert_array_equal(C.closure_at(loops, [a, b, c], theta), f)
    h = 1e-6
    fd = np.stack([(product(theta + h * e) - product(theta - h * e)) / (2 * h) for e in np.eye(3)], axis=-1)
    np.testing.assert_allclose(j, fd, atol=1e-8)


# ---------------------------------------------------------------- magnitudes (issue 26)

def _random_factors(rng, n_var: int, n_known: int, tiny: bool):
    """Float factors in random order: variable ones on random t-ranges (|t| <= 1) with random shifts,
    known ones with random angles; with ``tiny`` every known angle is pi/2 + a few 1e-16 (cos ~1e-16)."""
    kinds = rng.permutation([True] * n_var + [False] * n_known)
    out = []
    for variable in kinds:
        if variable:
            a = float(rng.uniform(-1.0, 0.5))
            d = float(rng.uniform(-math.pi, math.pi))
            out.append(C.variable_factor(a, a + float(rng.uniform(0.01, 0.5)), math.cos(d), math.sin(d),
                                         int(rng.choice([-1, 1]))))
        else:
            phi = math.pi / 2 + float(rng.integers(-3, 4)) * 2.2e-16 if tiny else float(rng.uniform(-4.0, 4.0))
            out.append(C.known_factor(math.cos(phi), math.sin(phi)))
    return out


def _exact(f: C.FactorPolynomials) -> C.FactorPolynomials:
    as_fraction = np.vectorize(lambda v: Fraction(float(v)), otypes=[object])
    return C.FactorPolynomials(*(as_fraction(np.asarray(a, dtype=float)) for a in (f.q, f.c, f.s)))


@pytest.mark.parametrize("tiny", [False, True])
def test_matrix_magnitude_bounds_the_rounding(tiny):
    """The float control points of a product differ from the exact product of the same float factors
    (Fractions) by at most 64 eps times matrix_magnitude (per entry), also where cancellation or a
    cos of ~1e-16 makes the control points far smaller than their rounding (the case that lost roots
    when tolerances were taken from the control points themselves)."""
    rng = np.random.default_rng(26)
    eps = np.finfo(float).eps
    worst_own = 0.0
    for _ in range(20):
        factors = _random_factors(rng, 3, 4, tiny)
        got = C.matrix_control_points(factors)
        exact = C.matrix_control_points([_exact(f) for f in factors])
        err = np.vectorize(lambda e, g: abs(float(e - Fraction(float(g)))))(exact, got)
        mag = C.matrix_magnitude(factors).reshape((3, 3) + (1,) * (got.ndim - 2))
        assert np.all(err <= 64 * eps * mag)
        with np.errstate(divide="ignore", invalid="ignore"):
            worst_own = max(worst_own, float(np.nanmax(np.where(err > 0, err / (eps * np.abs(got)), 0.0))))
    if tiny:
        assert worst_own > 1e3        # the control points' own size would not have bounded it


def test_matrix_magnitude_covers_the_known_angles_tolerance():
    """Moving the cos and sin of every known angle by up to KNOWN_ANGLE_SNAP (the snap of the Bernstein
    equations; the rounding of an input plus an offset is far less) changes each control point by at
    most ROUNDING_SAFETY eps times its magnitude: the solver's tolerance covers it, even where the cos
    of a known angle is ~1e-16 (an input next to pi/2)."""
    from spherekin.search.parameterizations import ROUNDING_SAFETY

    rng = np.random.default_rng(261)
    bound = ROUNDING_SAFETY * np.finfo(float).eps
    for tiny in (False, True):
        for _ in range(20):
            factors = _random_factors(rng, 3, 4, tiny)
            moved = [f if f.is_variable else C.known_factor(float(f.c) + rng.uniform(-1, 1) * C.KNOWN_ANGLE_SNAP,
                                                            float(f.s) + rng.uniform(-1, 1) * C.KNOWN_ANGLE_SNAP)
                     for f in factors]
            change = np.abs(C.matrix_control_points(moved) - C.matrix_control_points(factors))
            mag = C.matrix_magnitude(factors).reshape((3, 3) + (1,) * (change.ndim - 2))
            assert np.all(change <= bound * mag)
