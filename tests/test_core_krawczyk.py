"""spherekin.core.krawczyk: the one Krawczyk operator, against the formula in exact rational arithmetic.

K(X) = y - C F(y) - (C R) sigma + (I - C J(X)) (X - y) on small systems whose enclosures are exact
(rational data, point or interval), so that the operator's interval result must contain the exact
interval image computed with Fractions (endpoints: the extremes of each product), and the
midpoint-radius form must equal its formula to rounding."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from spherekin.core import intervals as iv
from spherekin.core.krawczyk import INTERVALS, MIDRAD, krawczyk_operator

small = st.integers(-8, 8).map(lambda k: k / 4)          # exact in binary floating point


def exact_image(y, f, c, j, dx, rate=None, sigma=None):
    """The interval K by the formula with Fractions: intervals as (lo, hi) pairs of Fractions."""
    def mul(a, b):
        prods = [a[0] * b[0], a[0] * b[1], a[1] * b[0], a[1] * b[1]]
        return min(prods), max(prods)

    def add(a, b):
        return a[0] + b[0], a[1] + b[1]

    m = len(y)
    out = []
    for i in range(m):
        acc = (Fraction(y[i]), Fraction(y[i]))
        for p in range(m):                                   # - C F(y)
            t = mul((Fraction(c[i][p]),) * 2, f[p])
            acc = add(acc, (-t[1], -t[0]))
        if rate is not None:                                 # - (C R) sigma
            for q in range(len(sigma)):
                cr = (Fraction(0), Fraction(0))
                for p in range(m):
                    cr = add(cr, mul((Fraction(c[i][p]),) * 2, rate[p][q]))
                t = mul(cr, sigma[q])
                acc = add(acc, (-t[1], -t[0]))
        for k in range(m):                                   # + (I - C J) (X - y)
            cj = (Fraction(0), Fraction(0))
            for p in range(m):
                cj = add(cj, mul((Fraction(c[i][p]),) * 2, j[p][k]))
            slope = ((1 if i == k else 0) - cj[1], (1 if i == k else 0) - cj[0])
            acc = add(acc, mul(slope, dx[k]))
        out.append(acc)
    return out


def stacked(pairs):
    """(2, ...) float intervals of nested lists of (lo, hi) Fractions (exact in binary)."""
    a = np.array(pairs, dtype=object)
    return np.stack([a[..., 0].astype(float), a[..., 1].astype(float)])


@settings(max_examples=60, deadline=None)
@given(st.data())
def test_the_interval_form_contains_the_exact_image_point_and_parametric(data):
    m = data.draw(st.integers(1, 3))
    n_par = data.draw(st.integers(0, 2))
    interval = st.tuples(small, small).map(lambda t: (Fraction(min(t)), Fraction(max(t))))
    y = [data.draw(small) for _ in range(m)]
    f = [data.draw(interval) for _ in range(m)]
    c = [[data.draw(small) for _ in range(m)] for _ in range(m)]
    j = [[data.draw(interval) for _ in range(m)] for _ in range(m)]
    dx = [data.draw(interval) for _ in range(m)]
    rate = [[data.draw(interval) for _ in range(n_par)] for _ in range(m)] if n_par else None
    sigma = [data.draw(interval) for _ in range(n_par)] if n_par else None
    want = exact_image(y, f, c, j, dx, rate, sigma)
    got = krawczyk_operator(INTERVALS, np.array(y, dtype=float), stacked(f), np.array(c, dtype=float), stacked(j),
                            stacked(dx), None if rate is None else stacked(rate),
                            None if sigma is None else stacked(sigma))
    for i, (lo, hi) in enumerate(want):
        assert Fraction(float(got[0][i])) <= lo and hi <= Fraction(float(got[1][i]))


def test_a_linear_system_is_proven_and_its_root_lies_in_the_image():
    """F(x) = A x - b with C = A^-1: K(X) = x* exactly (up to rounding), inside X; a box beside the root
    gives an image disjoint from it (no root there)."""
    a = np.array([[2.0, 1.0], [0.5, 3.0]])
    root = np.array([0.25, -0.5])
    b = a @ root
    c = np.linalg.inv(a)
    for y, r, inside in ((root + 0.01, 0.1, True), (root + 1.0, 0.1, False)):
        f_y = iv.point(a @ y - b)
        j = iv.point(np.broadcast_to(a, (2, 2)))
        k = krawczyk_operator(INTERVALS, y, f_y, c, j, iv.from_bounds(-np.full(2, r), np.full(2, r)))
        assert np.all(k[0] <= root + 1e-12) and np.all(root - 1e-12 <= k[1])
        in_x = np.all(k[0] > y - r) and np.all(k[1] < y + r)
        assert in_x == inside


@pytest.mark.parametrize("seed", range(5))
def test_the_midpoint_radius_form_is_its_formula(seed):
    """The search's isolation form on the unit box (y = 1/2, X - y = [-1/2, 1/2]): centre 1/2 - C f, radius
    |C| ftol + 1/2 sum_k (|I - C Jmid| + |C| Jrad)_ik (and the parameter column's 1/2 (|C Jp| + |C| Jp_rad))."""
    rng = np.random.default_rng(seed)
    b, n = 4, 3
    f, ftol = rng.normal(size=(b, n)), rng.uniform(0, 1e-3, (b, n))
    c = rng.normal(size=(b, n, n))
    jmid, jrad = rng.normal(size=(b, n, n)), rng.uniform(0, 0.1, (b, n, n))
    pmid, prad = rng.normal(size=(b, n, 1)), rng.uniform(0, 0.1, (b, n, 1))
    half = (np.zeros((b, n)), np.full((b, n), 0.5))
    centre, radius = krawczyk_operator(MIDRAD, np.full((b, n), 0.5), (f, ftol), c, (jmid, jrad), half,
                                       rate=(pmid, prad), sigma=(np.zeros((b, 1)), np.full((b, 1), 0.5)))
    ac = np.abs(c)
    want_c = 0.5 - np.einsum("bij,bj->bi", c, f)
    m_mid = np.eye(n) - c @ jmid
    want_r = (np.einsum("bij,bj->bi", ac, ftol) + 0.5 * (np.abs(m_mid) + ac @ jrad).sum(axis=2)
              + 0.5 * (np.abs(c @ pmid) + ac @ prad)[..., 0])
    np.testing.assert_allclose(centre, want_c, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(radius, want_r, rtol=1e-12, atol=1e-13)


def test_the_interval_and_midpoint_radius_forms_agree_on_point_data():
    """Both number types evaluate one operator: on point data (no radius) their images agree to rounding."""
    rng = np.random.default_rng(3)
    y, f, c, j = rng.normal(size=3), rng.normal(size=3), rng.normal(size=(3, 3)), rng.normal(size=(3, 3))
    dx_r = rng.uniform(0.1, 1.0, 3)
    k = krawczyk_operator(INTERVALS, y, iv.point(f), c, iv.point(j), iv.from_bounds(-dx_r, dx_r))
    mid, rad = krawczyk_operator(MIDRAD, y, (f, np.zeros(3)), c, (j, np.zeros((3, 3))), (np.zeros(3), dx_r))
    np.testing.assert_allclose(0.5 * (k[0] + k[1]), mid, atol=1e-12)
    np.testing.assert_allclose(0.5 * (k[1] - k[0]), rad, atol=1e-12)
    assert np.all(k[0] <= mid - rad + 1e-12) and np.all(k[1] >= mid + rad - 1e-12)
