"""The array-module seam of issue 30 item 5 (spherekin.core.arrays) and the kernels that go through it.

Each kernel of a box-loop iteration (Bernstein restriction, the projected-polyhedron bounds, the
Krawczyk test's evaluations) runs on array_api_strict arrays, built from the same numpy data, on a
device that is not the CPU (``array_api_strict.Device("device1")``): numpy cannot read such arrays,
so a kernel that calls a numpy function on them raises, and an array a kernel creates on the default
device cannot be combined with them (the mistakes a CuPy or JAX port would meet). array_api_strict
computes with numpy underneath, so the results must be numpy's floats bit for bit. The numpy results
are checked against independent derivations in exact arithmetic (Fractions, math.comb, sympy): de
Casteljau restriction, the blossom, direct Bernstein sums, the exact derivative, the exact projection
of the control points' hull on the slab |w| <= tol; the outward-rounded results (the pruner's reduced
box, the derivative enclosures) computed under array_api_strict enclose the exact values.
"""

from fractions import Fraction
from math import comb

import array_api_strict as xps
import numpy as np
import pytest
import sympy

from spherekin.core import bernstein
from spherekin.core.arrays import namespace_of
from spherekin.search.isolation import _derivative, _derivative_bounds, _weights_at, evaluate_at, jacobian_at
from spherekin.search.pruners import ProjectedPolyhedron, excludes_zero, pp_intervals

#: A device numpy cannot read (array_api_strict raises on np.asarray of its arrays).
DEVICE = xps.Device("device1")
CPU = xps.Device("CPU_DEVICE")
#: Float kernels against exact arithmetic on O(1) dyadic data: a few roundings of O(1) numbers.
EXACT_AGREEMENT = 1e-13


def strict(a):
    """numpy data as an array_api_strict array on DEVICE."""
    return xps.asarray(np.asarray(a, dtype=np.float64), device=DEVICE)


def back(x):
    """An array_api_strict result (checked: a strict array, still on DEVICE) as numpy."""
    assert isinstance(x, type(xps.asarray(0.0))), f"expected an array_api_strict array, got {type(x)}"
    assert x.device == DEVICE
    return np.asarray(x.to_device(CPU))


def same_floats(strict_result, numpy_result):
    got, want = back(strict_result), np.asarray(numpy_result)
    assert got.dtype == want.dtype and got.shape == want.shape
    assert got.tobytes() == want.tobytes()          # bit for bit (signed zeros, nans included)


def dyadic(rng, shape, scale=32):
    """Random floats that are small multiples of 1/scale: exact in float64 and as Fractions."""
    return rng.integers(-2 * scale, 2 * scale + 1, size=shape) / scale


def boxes(rng, b, n):
    """(lo, hi) (B, n) dyadic sub-boxes of [0, 1]^n, among them the unit box and a point box."""
    ends = np.sort(rng.integers(0, 65, size=(b, n, 2)) / 64, axis=-1)
    lo, hi = ends[..., 0], ends[..., 1]
    lo[0], hi[0] = 0.0, 1.0
    hi[1] = lo[1]
    return lo, hi


# ------------------------------------------------------------------- exact references (independent)
def bernstein_value(c, u):
    """sum_I c_I prod_k C(m_k, i_k) u_k^i_k (1 - u_k)^(m_k - i_k) in Fractions; c an n-D float array."""
    u = [Fraction(x) for x in u]
    total = Fraction(0)
    for idx in np.ndindex(*c.shape):
        term = Fraction(c[idx])
        for k, i in enumerate(idx):
            m = c.shape[k] - 1
            term *= comb(m, i) * u[k] ** i * (1 - u[k]) ** (m - i)
        total += term
    return total


def bernstein_derivative(c, u, k):
    """d/du_k of the Bernstein sum of :func:`bernstein_value`, by the product rule, in Fractions."""
    u = [Fraction(x) for x in u]
    total = Fraction(0)
    for idx in np.ndindex(*c.shape):
        term = Fraction(c[idx])
        for j, i in enumerate(idx):
            m, t = c.shape[j] - 1, u[j]
            if j == k:
                term *= comb(m, i) * ((i * t ** (i - 1) * (1 - t) ** (m - i) if i else 0)
                                      - ((m - i) * t ** i * (1 - t) ** (m - i - 1) if m - i else 0))
            else:
                term *= comb(m, i) * t ** i * (1 - t) ** (m - i)
        total += term
    return total


def casteljau_restrict_1d(points, a, b):
    """Control points of p on [a, b] by de Casteljau: keep [0, b], then its part from a / b on."""
    def split(cs, t):
        left, right, level = [cs[0]], [cs[-1]], list(cs)
        while len(level) > 1:
            level = [(1 - t) * p + t * q for p, q in zip(level, level[1:])]
            left.append(level[0])
            right.append(level[-1])
        return left, right[::-1]

    left = split(points, b)[0]
    return left if b == 0 else split(left, a / b)[1]


def casteljau_restrict(c, lo, hi):
    """An n-D float array of control points restricted to prod [lo_k, hi_k], exactly (object array)."""
    out = np.array([[Fraction(v)] for v in c.ravel()], dtype=object).reshape(c.shape)
    for k in range(c.ndim):
        moved = np.moveaxis(out, k, -1)
        res = np.empty_like(moved)
        for idx in np.ndindex(*moved.shape[:-1]):
            res[idx] = casteljau_restrict_1d(list(moved[idx]), Fraction(lo[k]), Fraction(hi[k]))
        out = np.moveaxis(res, -1, k)
    return out


def blossom(m, a, b):
    """R[k][j]: the z^j coefficient of ((1-a) + a z)^(m-k) ((1-b) + b z)^k, in Fractions."""
    def times(p, q):
        out = [Fraction(0)] * (len(p) + len(q) - 1)
        for i, x in enumerate(p):
            for j, y in enumerate(q):
                out[i + j] += x * y
        return out

    a, b = Fraction(a), Fraction(b)
    rows = []
    for k in range(m + 1):
        poly = [Fraction(1)]
        for _ in range(m - k):
            poly = times(poly, [1 - a, a])
        for _ in range(k):
            poly = times(poly, [1 - b, b])
        rows.append(poly)
    return rows


def hull_slab_interval(xs, ws, tol):
    """The exact projection on x of conv{(x_i, w_i)} n {|w| <= tol}: its vertices are the points in
    the slab and the crossings of the lines w = +-tol by segments between two points. None if empty."""
    cand = [x for x, w in zip(xs, ws) if -tol <= w <= tol]
    for p in range(len(xs)):
        for q in range(len(xs)):
            for level in (tol, -tol):
                if (ws[p] - level) * (ws[q] - level) < 0:
                    cand.append(xs[p] + (xs[q] - xs[p]) * (level - ws[p]) / (ws[q] - ws[p]))
    return (min(cand), max(cand)) if cand else None


def exact_pp(c, tol, k):
    """The exact projected-polyhedron interval of variable k for one equation c (n-D)."""
    m = c.shape[k] - 1
    xs, ws = [], []
    for idx in np.ndindex(*c.shape):
        xs.append(Fraction(idx[k], m))
        ws.append(Fraction(c[idx]))
    return hull_slab_interval(xs, ws, Fraction(tol))


# ------------------------------------------------------------------------------------ namespace_of
def test_namespace_of_numpy_strict_and_non_arrays():
    assert namespace_of(np.zeros(2), np.ones((2, 3))) is np
    assert namespace_of(strict([1.0]), strict([2.0])) is xps
    assert namespace_of(1.0, None, strict([1.0]), 2) is xps          # Python scalars and None skipped
    assert namespace_of(np.float64(1.0), np.zeros(1)) is np
    assert namespace_of(0.5, None) is np                               # no array: numpy


def test_namespace_of_refuses_two_modules():
    with pytest.raises(ValueError, match=r"^expected arrays of one array module, got numpy and array_api_strict$"):
        namespace_of(np.zeros(2), strict([1.0]))
    with pytest.raises(ValueError, match=r"^expected arrays of one array module, got array_api_strict and numpy$"):
        namespace_of(strict([1.0]), None, np.zeros(2))


def test_the_device_catches_numpy_only_calls():
    # what makes every test below fail when a kernel calls a numpy function or creates an array on
    # the default device: numpy cannot read DEVICE arrays, and strict refuses to mix devices
    a = strict([1.0, 2.0])
    with pytest.raises(RuntimeError, match="device"):
        np.stack([a, a])
    with pytest.raises(ValueError, match="different devices"):
        a + xps.zeros(2)

    def numpy_kernel(c):
        return np.diff(c)

    with pytest.raises(RuntimeError):
        numpy_kernel(a)


# ------------------------------------------------------------------------------------------ bernstein
@pytest.mark.parametrize("m", [0, 1, 2, 3, 4])
def test_restriction_matrices_same_floats_and_the_exact_blossom(m):
    rng = np.random.default_rng(m)
    lo, hi = boxes(rng, 9, 1)
    a, b = lo[:, 0], hi[:, 0]
    got = bernstein.restriction_matrices(m, a, b)
    same_floats(bernstein.restriction_matrices(m, strict(a), strict(b)), got)
    for r in range(len(a)):
        exact = blossom(m, a[r], b[r])
        for k in range(m + 1):
            for j in range(m + 1):
                assert abs(got[r, k, j] - exact[k][j]) <= EXACT_AGREEMENT


@pytest.mark.parametrize("shape", [(2, 3, 3, 7), (3, 2, 1, 4, 7), (1, 5, 7), (2, 2, 3, 2, 2, 7)])
def test_restrict_batch_last_same_floats_and_exact_de_casteljau(shape):
    rng = np.random.default_rng(len(shape) * 10 + shape[-2])
    n = len(shape) - 2
    c = dyadic(rng, shape)
    lo, hi = boxes(rng, shape[-1], n)
    got = bernstein.restrict_batch_last(c, lo, hi)
    same_floats(bernstein.restrict_batch_last(strict(c), strict(lo), strict(hi)), got)
    cache = {}                                           # shared entries: the same floats again
    bernstein.restrict_batch_last(strict(c), strict(lo), strict(hi), cache, list(range(10, 10 + n)))
    same_floats(bernstein.restrict_batch_last(strict(c), strict(lo), strict(hi), cache, list(range(10, 10 + n))), got)
    for e in range(shape[0]):
        for b in range(shape[-1]):
            exact = casteljau_restrict(c[e, ..., b], lo[b], hi[b])
            np.testing.assert_allclose(got[e, ..., b], exact.astype(float), rtol=0, atol=EXACT_AGREEMENT)


# ------------------------------------------------------------------------------------------ isolation
def test_weights_and_evaluate_at_same_floats_and_the_exact_bernstein_sum():
    rng = np.random.default_rng(5)
    c = dyadic(rng, (2, 3, 1, 4, 6))
    u = rng.integers(0, 17, size=(6, 3)) / 16
    got = evaluate_at(c, u)
    same_floats(evaluate_at(strict(c), strict(u)), got)
    for m in (1, 2, 3):
        same_floats(_weights_at(m, strict(u[:, 0])), _weights_at(m, u[:, 0]))
    for e in range(2):
        for b in range(6):
            assert abs(got[e, b] - bernstein_value(c[e, ..., b], u[b])) <= EXACT_AGREEMENT


def test_derivative_and_jacobian_same_floats_and_the_exact_derivative():
    rng = np.random.default_rng(6)
    c = dyadic(rng, (2, 3, 1, 4, 5))
    u = rng.integers(0, 9, size=(5, 3)) / 8
    got = jacobian_at(c, u)
    same_floats(jacobian_at(strict(c), strict(u)), got)
    for k in (0, 2):
        same_floats(_derivative(strict(c), k), _derivative(c, k))
    assert _derivative(strict(c), 1) is None
    x = sympy.symbols("x0:3")
    for e in range(2):
        for b in range(5):
            p = sum(sympy.Rational(Fraction(c[(e, *idx, b)])) * sympy.prod(
                sympy.binomial(c.shape[1 + k] - 1, i) * x[k] ** i * (1 - x[k]) ** (c.shape[1 + k] - 1 - i)
                for k, i in enumerate(idx)) for idx in np.ndindex(*c.shape[1:-1]))
            at = {x[k]: sympy.Rational(Fraction(u[b, k])) for k in range(3)}
            for k in range(3):
                assert abs(got[e, k, b] - float(sympy.diff(p, x[k]).subs(at))) <= EXACT_AGREEMENT


def test_derivative_bounds_same_floats_and_they_enclose_the_exact_derivative():
    rng = np.random.default_rng(7)
    c = dyadic(rng, (2, 3, 4, 6)) + rng.normal(size=(2, 3, 4, 6)) * 1e-3     # not all dyadic: roundings
    tol = np.full((2, 6), 1e-15)
    lo, hi = _derivative_bounds(c, tol)
    slo, shi = _derivative_bounds(strict(c), strict(tol))
    same_floats(slo, lo)
    same_floats(shi, hi)
    slo, shi = back(slo), back(shi)
    for e in range(2):
        for b in range(6):
            for k in range(2):
                cs = np.moveaxis(c[e, ..., b], k, 0)
                m = cs.shape[0] - 1
                # the exact derivative's control points m (c_{i+1} - c_i), and its values at grid points
                exact = [m * (Fraction(cs[i + 1][j]) - Fraction(cs[i][j])) for i in range(m) for j in range(cs.shape[1])]
                for t in (Fraction(0), Fraction(1, 3), Fraction(7, 8)):
                    for s in (Fraction(0), Fraction(1, 2), Fraction(1)):
                        exact.append(bernstein_derivative(c[e, ..., b], [t, s], k))
                assert slo[e, k, b] <= min(exact) and max(exact) <= shi[e, k, b]


# ------------------------------------------------------------------------------------------- pruners
def _mixed_equations(rng, b):
    """Equations with roots in the unit box: dyadic control points around 0, mixed degrees."""
    return dyadic(rng, (3, 3, 4, b), scale=8) * 0.5


def test_pp_intervals_same_floats_and_the_exact_hull_projection():
    rng = np.random.default_rng(8)
    c = _mixed_equations(rng, 12)
    tol = np.array([0.0, 1 / 16, 1 / 4])
    variables, lo, hi = pp_intervals(c, tol)
    svars, slo, shi = pp_intervals(strict(c), strict(tol))
    assert svars == variables == (0, 1)
    same_floats(slo, lo)
    same_floats(shi, hi)
    tol_b = np.tile(tol[:, None], (1, 12)) * (1 + np.arange(12)) / 8
    same_floats(pp_intervals(strict(c), strict(tol_b), var=1)[0], pp_intervals(c, tol_b, var=1)[0])
    seen = 0
    for e in range(3):
        for b in range(12):
            for q, k in enumerate(variables):
                exact = exact_pp(c[e, ..., b], tol[e], k)
                if exact is None:
                    assert lo[e, q, b] > hi[e, q, b]
                else:
                    seen += 1
                    assert abs(lo[e, q, b] - exact[0]) <= EXACT_AGREEMENT and abs(hi[e, q, b] - exact[1]) <= EXACT_AGREEMENT
    assert seen > 20


def test_pp_reduce_same_floats_and_its_box_encloses_the_exact_one():
    rng = np.random.default_rng(9)
    b = 40
    c = _mixed_equations(rng, b) + rng.normal(size=(3, 3, 4, b)) * 1e-9    # crossings that round
    const = dyadic(rng, (2, 1, 1, b), scale=4) * 0.25                        # no variable: excludes_zero
    tols = [np.full(3, 1 / 4), np.full(2, 1 / 4)]
    lo, hi = ProjectedPolyhedron().reduce([c, const], tols)
    slo, shi = ProjectedPolyhedron().reduce([strict(c), strict(const)], [strict(t) for t in tols])
    same_floats(slo, lo)
    same_floats(shi, hi)
    slo, shi = back(slo), back(shi)
    nonempty = 0
    for box in range(b):
        ends = [[exact_pp(c[e, ..., box], tols[0][e], k) for e in range(3)] for k in range(2)]
        const_ok = all(abs(Fraction(const[e, 0, 0, box])) <= Fraction(tols[1][e]) for e in range(2))
        if not const_ok or any(x is None for per in ends for x in per):
            continue
        elo = [max(x[0] for x in per) for per in ends]
        ehi = [min(x[1] for x in per) for per in ends]
        if any(a > z for a, z in zip(elo, ehi)):
            continue
        nonempty += 1
        for k in range(2):       # outward: the float box holds the exact one
            assert slo[box, k] <= elo[k] and ehi[k] <= shi[box, k]
    assert nonempty >= 5 and (slo > shi).any(axis=1).sum() >= 5


def test_excludes_zero_same_answer_and_the_exact_control_point_test():
    rng = np.random.default_rng(10)
    blocks = [dyadic(rng, (2, 3, 3, 20), scale=4) + 1.0, dyadic(rng, (1, 2, 20), scale=4) - 1.0]
    tols = [np.array([0.25, 0.5]), np.full((1, 20), 0.25)]
    got = excludes_zero(blocks, tols)
    same_floats(excludes_zero([strict(c) for c in blocks], [strict(t) for t in tols]), got)
    for b in range(20):
        exact = False
        for c, t in zip(blocks, tols):
            t = np.broadcast_to(t.reshape(c.shape[0], -1), (c.shape[0], 20))
            for e in range(c.shape[0]):
                vals = [Fraction(v) for v in c[e, ..., b].ravel()]
                exact |= min(vals) > Fraction(t[e, b]) or max(vals) < -Fraction(t[e, b])
        assert got[b] == exact
    assert 0 < got.sum() < 20
