"""Tests of spherekin.core.bernstein against independent references (sympy, power-basis evaluation)."""

from __future__ import annotations

import itertools
import random
from fractions import Fraction

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings, strategies as st
from numpy.polynomial import polynomial as P

from spherekin.core import bernstein as bz

FAST = settings(max_examples=50, deadline=None)


# --------------------------------------------------------------------------- independent helpers
def rational_array(shape, rnd: random.Random) -> np.ndarray:
    vals = [Fraction(rnd.randint(-9, 9), rnd.randint(1, 9)) for _ in range(int(np.prod(shape)))]
    return np.array(vals, dtype=object).reshape(shape)


def sympy_bernstein(c: np.ndarray, xs) -> sp.Expr:
    """sum_I c_I prod_k C(m_k,i_k) x_k^i_k (1-x_k)^(m_k-i_k), written out independently."""
    degs = [k - 1 for k in c.shape]
    expr = sp.Integer(0)
    for idx in itertools.product(*(range(m + 1) for m in degs)):
        term = sp.Rational(c[idx])
        for x, m, i in zip(xs, degs, idx):
            term *= sp.binomial(m, i) * x**i * (1 - x) ** (m - i)
        expr += term
    return sp.expand(expr)


def sympy_power(a: np.ndarray, xs) -> sp.Expr:
    return sp.expand(sum(sp.Rational(a[idx]) * sp.prod([x**j for x, j in zip(xs, idx)])
                         for idx in np.ndindex(*a.shape)))


def power_eval(a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Power-basis value sum_J a_J x^J at points x (..., n), straight from the monomials."""
    out = np.zeros(x.shape[:-1])
    for idx in np.ndindex(*a.shape):
        out += a[idx] * np.prod([x[..., k] ** j for k, j in enumerate(idx)], axis=0)
    return out


SYMS = sp.symbols("x0:3")
EXACT_DEGREES = [(2,), (3, 1), (2, 2, 1)]


# --------------------------------------------------------------------------- exact (sympy) checks
@pytest.mark.parametrize("degs", EXACT_DEGREES)
def test_from_power_matches_sympy_expansion(degs):
    rnd = random.Random(hash(degs) % 1000)
    a = rational_array(tuple(m + 1 for m in degs), rnd)
    c = bz.from_power(a)
    assert c.dtype == object and all(isinstance(v, Fraction) for v in c.ravel())
    xs = SYMS[:len(degs)]
    assert sp.expand(sympy_bernstein(c, xs) - sympy_power(a, xs)) == 0
    assert np.array_equal(bz.to_power(c), a)


def test_sympy_rational_entries_stay_exact():
    a = np.array([sp.Rational(1, 3), sp.Rational(-2, 7), sp.Rational(5, 2)], dtype=object)
    c = bz.from_power(a)
    x = sp.Symbol("x")
    assert sp.expand(sympy_bernstein(c, [x]) - sympy_power(a, [x])) == 0
    assert bz.evaluate(c, [Fraction(1, 3)])[()] == a[0] + a[1] / 3 + a[2] / 9


@pytest.mark.parametrize("s", [Fraction(1, 2), Fraction(1, 4)])
@pytest.mark.parametrize("var", [0, 1])
def test_subdivide_exact_against_sympy(s, var):
    rnd = random.Random(7)
    c = rational_array((4, 3), rnd)
    xs = sp.symbols("u0:2")
    p = sympy_bernstein(c, xs)
    left, right = bz.subdivide(c, var, s)
    s_ = sp.Rational(s)
    p_left = sp.expand(p.subs(xs[var], s_ * xs[var]))
    p_right = sp.expand(p.subs(xs[var], s_ + (1 - s_) * xs[var]))
    assert sp.expand(sympy_bernstein(left, xs) - p_left) == 0
    assert sp.expand(sympy_bernstein(right, xs) - p_right) == 0
    assert left.dtype == object and all(isinstance(v, Fraction) for v in left.ravel())


def test_restrict_exact_against_sympy_and_reference():
    rnd = random.Random(11)
    c = rational_array((3, 2, 4), rnd)
    xs = sp.symbols("u0:3")
    box = np.array([[Fraction(1, 3), Fraction(5, 7)], [0, 1], [Fraction(1, 8), Fraction(1, 2)]],
                   dtype=object)
    q = bz.restrict(c, box)
    assert np.array_equal(q, bz.restrict_reference(c, box))
    p = sympy_bernstein(c, xs)
    mapped = {x: sp.Rational(a) + x * (sp.Rational(b) - sp.Rational(a)) for x, (a, b) in zip(xs, box)}
    assert sp.expand(sympy_bernstein(q, xs) - sp.expand(p.subs(mapped, simultaneous=True))) == 0


def test_restrict_matches_reference_on_random_rational_boxes():
    rnd = random.Random(3)
    c = rational_array((4, 3), rnd)
    for _ in range(5):
        box = []
        for _ in range(2):
            a, b = sorted(rnd.sample(range(0, 17), 2))
            box.append([Fraction(a, 16), Fraction(b, 16)])
        assert np.array_equal(bz.restrict(c, box), bz.restrict_reference(c, box))


def test_exact_evaluate_and_degenerate_box():
    rnd = random.Random(5)
    c = rational_array((3, 4), rnd)
    x = np.array([[Fraction(1, 3), Fraction(2, 5)], [0, 1]], dtype=object)
    val = bz.evaluate(c, x)
    assert np.array_equal(val, bz.evaluate_de_casteljau(c, x))
    u0, u1 = sp.symbols("u0:2")
    expr = sympy_bernstein(c, [u0, u1])
    assert val[0] == expr.subs({u0: sp.Rational(1, 3), u1: sp.Rational(2, 5)})
    q = bz.restrict(c, [[Fraction(1, 3), Fraction(1, 3)], [0, 1]])   # constant along axis 0
    assert all(np.array_equal(q[i], q[0]) for i in range(3))
    assert sp.expand(sympy_bernstein(q[0], [u1]) - expr.subs(u0, sp.Rational(1, 3))) == 0


# --------------------------------------------------------------------------- float checks
@pytest.mark.parametrize("degs", [(4,), (2, 3), (3, 1, 2)])
def test_evaluate_against_power_basis(degs):
    rng = np.random.default_rng(sum(degs))
    a = rng.uniform(-1, 1, size=tuple(m + 1 for m in degs))
    c = bz.from_power(a)
    x = rng.random((7, 5, len(degs)))
    np.testing.assert_allclose(bz.evaluate(c, x), power_eval(a, x), rtol=0, atol=1e-12)
    np.testing.assert_allclose(bz.evaluate_de_casteljau(c, x), power_eval(a, x), rtol=0, atol=1e-12)
    if len(degs) == 2:
        np.testing.assert_allclose(bz.evaluate(c, x), P.polyval2d(x[..., 0], x[..., 1], a),
                                   rtol=0, atol=1e-12)
    assert bz.evaluate(c, x[0, 0]).shape == ()


def test_integer_input_promoted_to_float():
    c = bz.from_power(np.array([1, 2, 3]))
    assert c.dtype == np.float64
    assert bz.degrees(np.zeros((2, 3, 4)), nvars=2) == (2, 3)


def test_restriction_matrix_batched_and_shapes():
    a, b = np.array([0.0, 0.25, 0.5]), np.array([1.0, 0.75, 0.5])
    R = bz.restriction_matrix(3, a, b)
    assert R.shape == (3, 4, 4)
    np.testing.assert_allclose(R[0], np.eye(4), atol=1e-15)       # [0, 1] is the identity
    np.testing.assert_allclose(R.sum(-1), 1.0, atol=1e-15)          # rows are convex weights
    for k in range(3):
        np.testing.assert_array_equal(R[k], bz.restriction_matrix(3, a[k], b[k]))


# --------------------------------------------------------------------------- hypothesis properties
@st.composite
def poly(draw, max_vars=3, max_deg=4):
    degs = draw(st.lists(st.integers(0, max_deg), min_size=1, max_size=max_vars))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    return rng.uniform(-10, 10, size=tuple(m + 1 for m in degs)), rng


@FAST
@given(poly(), st.data())
def test_restrict_then_evaluate(cr, data):
    c, rng = cr
    n = c.ndim
    ends = np.sort(np.array(data.draw(st.lists(
        st.tuples(st.floats(0, 1), st.floats(0, 1)), min_size=n, max_size=n))), axis=1)
    u = rng.random((6, n))
    mapped = ends[:, 0] + u * (ends[:, 1] - ends[:, 0])
    np.testing.assert_allclose(bz.evaluate(bz.restrict(c, ends), u), bz.evaluate(c, mapped),
                               rtol=0, atol=1e-9)


@FAST
@given(poly())
def test_bounds_enclose_samples(cr):
    c, rng = cr
    vals = bz.evaluate(c, rng.random((50, c.ndim)))
    lo, hi = bz.bounds(c)
    assert lo.shape == hi.shape == ()
    assert np.all(lo - 1e-12 <= vals) and np.all(vals <= hi + 1e-12)


@FAST
@given(poly(), st.integers(0, 2**32 - 1))
def test_multiply_is_product_of_values(cr, seed):
    c1, rng = cr
    c2 = np.random.default_rng(seed).uniform(-10, 10, size=tuple(rng.integers(1, 4, size=c1.ndim)))
    prod = bz.multiply(c1, c2)
    assert bz.degrees(prod) == tuple(m + p for m, p in zip(bz.degrees(c1), bz.degrees(c2)))
    x = rng.random((8, c1.ndim))
    np.testing.assert_allclose(bz.evaluate(prod, x), bz.evaluate(c1, x) * bz.evaluate(c2, x),
                               rtol=1e-12, atol=1e-9)


@FAST
@given(poly(), st.integers(0, 3), st.integers(0, 2))
def test_elevate_preserves_values(cr, r, var_seed):
    c, rng = cr
    var = var_seed % c.ndim
    e = bz.elevate(c, var, r)
    assert e.shape[var] == c.shape[var] + r
    x = rng.random((8, c.ndim))
    np.testing.assert_allclose(bz.evaluate(e, x), bz.evaluate(c, x), rtol=0, atol=1e-10)


@FAST
@given(poly())
def test_power_round_trip(cr):
    a, _ = cr
    np.testing.assert_allclose(bz.to_power(bz.from_power(a)), a, rtol=0, atol=1e-9)
    np.testing.assert_allclose(bz.from_power(bz.to_power(a)), a, rtol=0, atol=1e-9)


# --------------------------------------------------------------------------- batches
def test_batched_calls_equal_loops():
    rng = np.random.default_rng(1)
    c = rng.normal(size=(5, 3, 2, 4))                  # 5 polynomials in 3 variables
    lo = rng.random((5, 3)) * 0.5
    boxes = np.stack([lo, lo + rng.random((5, 3)) * 0.5], axis=-1)   # (5, 3, 2)
    x = rng.random((4, 3))
    q = bz.restrict(c, boxes)
    left, right = bz.subdivide(c, 1, 0.3, nvars=3)
    lo_b, hi_b = bz.bounds(c, nvars=3)
    prod = bz.multiply(c, c[0], nvars=3)
    for k in range(5):
        np.testing.assert_allclose(q[k], bz.restrict(c[k], boxes[k]), atol=1e-14)
        np.testing.assert_allclose(bz.restrict(c, boxes[0])[k], bz.restrict(c[k], boxes[0]), atol=1e-14)
        np.testing.assert_allclose(bz.evaluate(c, x)[k], bz.evaluate(c[k], x), atol=1e-14)
        np.testing.assert_allclose(left[k], bz.subdivide(c[k], 1, 0.3)[0], atol=1e-14)
        np.testing.assert_allclose(right[k], bz.subdivide(c[k], 1, 0.3)[1], atol=1e-14)
        assert lo_b[k] == bz.bounds(c[k])[0] and hi_b[k] == bz.bounds(c[k])[1]
        np.testing.assert_allclose(prod[k], bz.multiply(c[k], c[0]), atol=1e-12)
        np.testing.assert_allclose(bz.elevate(c, 2, 2, nvars=3)[k], bz.elevate(c[k], 2, 2), atol=1e-14)
        np.testing.assert_allclose(bz.to_power(c, nvars=3)[k], bz.to_power(c[k]), atol=1e-12)
    # one polynomial, many boxes: the box batch broadcasts against an empty c batch
    many = bz.restrict(c[0], boxes)
    assert many.shape == (5, 3, 2, 4)
    np.testing.assert_allclose(many[2], bz.restrict(c[0], boxes[2]), atol=1e-14)


# --------------------------------------------------------------------------- bad input
C3 = np.zeros((3, 2, 4))


@pytest.mark.parametrize("call, name", [
    (lambda: bz.restrict(C3, np.zeros((2, 2)), nvars=3), "box"),
    (lambda: bz.restrict(C3, np.zeros((3, 3))), "box"),
    (lambda: bz.restrict(C3, np.zeros((4, 2))), "box"),
    (lambda: bz.restrict(C3, [[0, 1], [0.7, 0.2], [0, 1]]), "box"),
    (lambda: bz.restrict(C3, [[-0.1, 1], [0, 1], [0, 1]]), "box"),
    (lambda: bz.restrict(C3, [[0, 1.5], [0, 1], [0, 1]]), "box"),
    (lambda: bz.restrict(C3, [[0, np.nan], [0, 1], [0, 1]]), "box"),
    (lambda: bz.restrict(C3[None].repeat(4, 0), np.tile([[0, 1.0]], (3, 3, 1))), "box"),
    (lambda: bz.restrict_reference(C3, [[0, 1], [0.5, 0.5], [0, 1]]), "box"),
    (lambda: bz.restrict_reference(C3, np.tile([[0, 1.0]], (2, 3, 1))), "box"),
    (lambda: bz.evaluate(C3, np.zeros(2), nvars=3), "x"),
    (lambda: bz.evaluate(C3, np.zeros(4)), "x"),
    (lambda: bz.evaluate(C3, [0.1, np.inf, 0.2]), "x"),
    (lambda: bz.evaluate(C3, 0.5), "x"),
    (lambda: bz.evaluate_de_casteljau(C3, [[0.1, 0.2]], nvars=3), "x"),
    (lambda: bz.subdivide(C3, 5), "var"),
    (lambda: bz.subdivide(C3, 0, 1.5), "s"),
    (lambda: bz.subdivide(C3, 0, float("nan")), "s"),
    (lambda: bz.subdivide(C3, 0, [0.1, 0.2]), "s"),
    (lambda: bz.elevate(C3, -1), "var"),
    (lambda: bz.elevate(C3, 0, r=-2), "r"),
    (lambda: bz.bounds(C3, nvars=4), "nvars"),
    (lambda: bz.bounds(np.zeros((3, 0))), "c"),
    (lambda: bz.degrees(np.float64(1.0)), "c"),
    (lambda: bz.multiply(C3, np.zeros((2, 2))), "c2"),
    (lambda: bz.multiply(np.zeros((4, 3)), np.zeros((5, 3)), nvars=1), "c2"),
    (lambda: bz.restriction_matrix(-1, 0, 1), "m"),
    (lambda: bz.restriction_matrix(2, [0, 0.5], [1, 1, 1]), "b"),
    (lambda: bz.from_power(np.array(["a", "b"])), "a"),
])
def test_bad_input_raises_value_error_naming_argument(call, name):
    with pytest.raises(ValueError, match=rf"^{name}: expected"):
        call()


# ---------------------------------------------------------------- the solver's batch-last kernels

def test_restriction_matrices_equal_the_blossom():
    rng = np.random.default_rng(12)
    a, b = rng.uniform(0, 1, 7), rng.uniform(0, 1, 7)
    for m in (0, 1, 2, 3):
        np.testing.assert_allclose(bz.restriction_matrices(m, a, b), bz.restriction_matrix(m, a, b),
                                   atol=1e-15)


def test_restrict_batch_last_exact_on_dyadic_data():
    """Dyadic control points and box ends keep every product and sum exact in binary floating
    point, so the fast kernel must reproduce the exact (Fraction) reference bit for bit."""
    rnd = random.Random(13)
    dims, nb = (3, 1, 2, 3), 6
    c = np.array([[rnd.randint(-64, 64) / 8 for _ in range(nb)] for _ in range(2 * int(np.prod(dims)))])
    c = c.reshape((2,) + dims + (nb,))
    lo = np.array([[rnd.randint(0, 8) / 16 for _ in dims] for _ in range(nb)])
    hi = lo + np.array([[rnd.randint(0, 8) / 16 for _ in dims] for _ in range(nb)])
    got = bz.restrict_batch_last(c, lo, hi)
    for b in range(nb):
        exact = np.vectorize(Fraction, otypes=[object])(c[..., b])
        box = np.array([[Fraction(x), Fraction(y)] for x, y in zip(lo[b], hi[b])], dtype=object)
        ref = bz.restrict(exact, box, nvars=len(dims))
        assert np.array_equal(got[..., b], ref.astype(float)), b


def test_restrict_batch_last_rejects_mismatched_shapes():
    with pytest.raises(ValueError, match="lo, hi"):
        bz.restrict_batch_last(np.zeros((2, 3, 3, 4)), np.zeros((5, 2)), np.ones((5, 2)))
