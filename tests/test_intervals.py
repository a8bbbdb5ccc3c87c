"""Tests for spherekin.core.intervals (outward-rounded interval arithmetic on float arrays).

Independent references:
* exact rational arithmetic (fractions.Fraction of the float endpoints): every exact result of an
  operation on points of the operand intervals (all endpoint combinations and random interior
  floats) must lie in the computed interval, and the interval may be only a few ulps wider than
  the exact hull;
* cos and sin: mpmath at 60 digits at sample points of the interval (not mpmath's interval code),
  and the point enclosures against mpmath's own iv.cos / iv.sin.
"""

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mpmath import iv, mp, mpf

from spherekin.core import intervals as I

#: The computed hull may exceed the exact hull by this many ulps per endpoint: one rounding to
#: nearest (<= 1/2 ulp) plus the one-ulp widening, for a single operation.
SINGLE_OP_ULPS = 2
#: Digits of the mpmath values used as the exact reference for cos and sin.
MP_DIGITS = 60
#: Random sample sizes (per test) of the exact-arithmetic checks.
SAMPLES = 200


def ulps_beyond(bound: float, exact: Fraction, side: str) -> int:
    """How many floats lie strictly between ``bound`` and the exact value on the outer side (0 if tight)."""
    n = 0
    x = bound
    if side == "lo":
        while Fraction(x) < exact and n < 100:
            x = math.nextafter(x, math.inf)
            if Fraction(x) <= exact:
                n += 1
    else:
        while Fraction(x) > exact and n < 100:
            x = math.nextafter(x, -math.inf)
            if Fraction(x) >= exact:
                n += 1
    return n


def encloses(lo: float, hi: float, exact: Fraction) -> bool:
    """lo <= exact <= hi with infinite bounds allowed (no NaN)."""
    if math.isnan(lo) or math.isnan(hi):
        return False
    ok_lo = lo == -math.inf or (lo != math.inf and Fraction(lo) <= exact)
    ok_hi = hi == math.inf or (hi != -math.inf and exact <= Fraction(hi))
    return ok_lo and ok_hi


def random_intervals(rng, shape, scale=1.0, include_special=True):
    """An interval array (2, *shape) of floats of mixed signs and magnitudes, with zeros and point intervals."""
    a = rng.normal(size=shape) * scale * 10.0 ** rng.integers(-3, 4, size=shape)
    w = np.abs(rng.normal(size=shape)) * scale * 10.0 ** rng.integers(-12, 1, size=shape)
    lo, hi = a - w, a + w
    if include_special:
        flat_lo, flat_hi = lo.reshape(-1), hi.reshape(-1)
        n = flat_lo.size
        flat_lo[: n // 8] = flat_hi[: n // 8]                 # point intervals
        flat_lo[n // 8: n // 4] = 0.0                          # touching zero
        flat_hi[n // 4: 3 * n // 8] = 0.0
        flat_lo[3 * n // 8: n // 2] = np.minimum(flat_lo[3 * n // 8: n // 2], 0.0)   # straddling zero
    lo, hi = np.minimum(lo, hi), np.maximum(lo, hi)
    return np.stack((lo, hi))


def points_of(a, rng, k=3):
    """Endpoints and k random interior floats of every element of the interval array a: list of arrays."""
    pts = [a[0], a[1]]
    for _ in range(k):
        t = rng.uniform(size=a.shape[1:])
        pts.append(np.clip(a[0] + t * (a[1] - a[0]), a[0], a[1]))
    return pts


def check_binary(op, exact_op, a, b, rng, tight=True):
    out = op(a, b)
    assert out.shape == (2,) + np.broadcast_shapes(a.shape[1:], b.shape[1:])
    for x in points_of(a, rng):
        for y in points_of(b, rng):
            xb, yb = np.broadcast_arrays(x, y)
            for idx in np.ndindex(xb.shape):
                exact = exact_op(Fraction(xb[idx]), Fraction(yb[idx]))
                assert encloses(out[(0,) + idx], out[(1,) + idx], exact), (idx, xb[idx], yb[idx])
    if tight:   # the hull of the exact endpoint combinations is reached within a few ulps (same shapes)
        for idx in np.ndindex(out.shape[1:]):
            ai, bi = (a[(0,) + idx], a[(1,) + idx]), (b[(0,) + idx], b[(1,) + idx])
            corners = [exact_op(Fraction(p), Fraction(q)) for p in ai for q in bi]
            assert ulps_beyond(out[(0,) + idx], min(corners), "lo") <= SINGLE_OP_ULPS
            assert ulps_beyond(out[(1,) + idx], max(corners), "hi") <= SINGLE_OP_ULPS
    return out


# ----------------------------------------------------------------------------- exact checks

def test_add_sub_mul_enclose_exact_rational_results():
    rng = np.random.default_rng(1)
    a, b = random_intervals(rng, (40,)), random_intervals(rng, (40,))
    check_binary(I.add, lambda x, y: x + y, a, b, rng)
    check_binary(I.sub, lambda x, y: x - y, a, b, rng)
    check_binary(I.mul, lambda x, y: x * y, a, b, rng)


def test_broadcasting_follows_the_element_shapes():
    rng = np.random.default_rng(2)
    a, b = random_intervals(rng, (3, 1)), random_intervals(rng, (4,))
    out = check_binary(I.mul, lambda x, y: x * y, a, b, rng, tight=False)
    assert out.shape == (2, 3, 4)
    assert I.add(a, random_intervals(rng, ())).shape == (2, 3, 1)


def test_neg_scale_and_magnitude_are_exact_or_enclosing():
    rng = np.random.default_rng(3)
    a = random_intervals(rng, (50,))
    n = I.neg(a)
    np.testing.assert_array_equal(n[0], -a[1])
    np.testing.assert_array_equal(n[1], -a[0])
    c = rng.normal(size=50) * 10.0 ** rng.integers(-5, 5, size=50)
    c[:5] = 0.0
    out = I.scale(c, a)
    for k in range(50):
        for x in (a[0, k], a[1, k], 0.5 * (a[0, k] + a[1, k])):
            if a[0, k] <= x <= a[1, k]:
                assert encloses(out[0, k], out[1, k], Fraction(c[k]) * Fraction(x))
    mag = I.magnitude(a)
    np.testing.assert_array_equal(mag, np.maximum(np.abs(a[0]), np.abs(a[1])))


def test_isum_matmul_fmatmul_sum_up_enclose_exact_results():
    rng = np.random.default_rng(4)
    a, b = random_intervals(rng, (5, 3, 4)), random_intervals(rng, (5, 4, 2))
    c = rng.normal(size=(3, 4))
    prod, fprod = I.matmul(a, b), I.fmatmul(c, b)
    sums = I.isum(a, axis=-1)
    assert prod.shape == (2, 5, 3, 2) and fprod.shape == (2, 5, 3, 2) and sums.shape == (2, 5, 3)
    for x in points_of(a, rng, k=2):
        for y in points_of(b, rng, k=2):
            for bt in range(5):
                for i in range(3):
                    s = sum(Fraction(v) for v in x[bt, i])
                    assert encloses(sums[0, bt, i], sums[1, bt, i], s)
                    for j in range(2):
                        exact = sum(Fraction(x[bt, i, k]) * Fraction(y[bt, k, j]) for k in range(4))
                        assert encloses(prod[0, bt, i, j], prod[1, bt, i, j], exact)
                        fexact = sum(Fraction(c[i, k]) * Fraction(y[bt, k, j]) for k in range(4))
                        assert encloses(fprod[0, bt, i, j], fprod[1, bt, i, j], fexact)
    v = np.abs(rng.normal(size=(6, 7))) * 10.0 ** rng.integers(-300, 300, size=(6, 7))
    up = I.sum_up(v, axis=1)
    for i in range(6):
        assert Fraction(up[i]) >= sum(Fraction(x) for x in v[i])
    assert I.isum(np.zeros((2, 3, 0)), axis=-1).shape == (2, 3)


@pytest.mark.filterwarnings("ignore:overflow encountered")
def test_subnormal_and_huge_values_stay_enclosed():
    tiny = 5e-324
    cases = [
        (np.array([[tiny], [tiny]]), np.array([[0.5], [0.5]])),        # result below the smallest subnormal
        (np.array([[2.0 ** -1070], [2.0 ** -1060]]), np.array([[1e-10], [3e-10]])),
        (np.array([[-1e300], [1e300]]), np.array([[1e10], [1e10]])),   # overflow: infinite bounds
        (np.array([[-0.0], [0.0]]), np.array([[-3.0], [2.0]])),
        (np.array([[1e308], [1.7e308]]), np.array([[1e308], [1e308]])),
    ]
    rng = np.random.default_rng(5)
    for a, b in cases:
        check_binary(I.mul, lambda x, y: x * y, a, b, rng, tight=False)
        check_binary(I.add, lambda x, y: x + y, a, b, rng, tight=False)
        check_binary(I.sub, lambda x, y: x - y, a, b, rng, tight=False)
    out = I.mul(np.array([[1e300], [1e300]]), np.array([[1e10], [1e10]]))
    assert out[1, 0] == math.inf and out[0, 0] == np.finfo(float).max


finite = st.floats(allow_nan=False, allow_infinity=False, min_value=-1e200, max_value=1e200)
any_finite = st.floats(allow_nan=False, allow_infinity=False)


@st.composite
def interval(draw, elements=finite):
    x, y = draw(elements), draw(elements)
    return (min(x, y), max(x, y))


@pytest.mark.filterwarnings("ignore:overflow encountered")
@settings(max_examples=300, deadline=None)
@given(interval(any_finite), interval(any_finite), st.floats(0, 1), st.floats(0, 1))
def test_hypothesis_binary_ops_enclose_exact_results(a, b, s, t):
    """For any finite float intervals and any points in them, the exact result is enclosed."""
    ai, bi = np.array([[a[0]], [a[1]]]), np.array([[b[0]], [b[1]]])
    x = min(max(a[0] + s * (a[1] - a[0]), a[0]), a[1]) if math.isfinite(a[1] - a[0]) else a[0]
    y = min(max(b[0] + t * (b[1] - b[0]), b[0]), b[1]) if math.isfinite(b[1] - b[0]) else b[1]
    for op, exact in ((I.add, lambda p, q: p + q), (I.sub, lambda p, q: p - q), (I.mul, lambda p, q: p * q)):
        out = op(ai, bi)
        assert out[0, 0] <= out[1, 0]
        for p in (a[0], a[1], x):
            for q in (b[0], b[1], y):
                assert encloses(out[0, 0], out[1, 0], exact(Fraction(p), Fraction(q))), (op.__name__, p, q)


@pytest.mark.filterwarnings("ignore:overflow encountered")
@settings(max_examples=200, deadline=None)
@given(st.lists(interval(), min_size=1, max_size=9), st.lists(finite, min_size=9, max_size=9))
def test_hypothesis_sums_and_float_products_enclose_exact_results(items, coefs):
    a = np.array(items, dtype=float).T                     # (2, n)
    n = a.shape[1]
    s = I.isum(a, axis=0)
    assert encloses(s[0], s[1], sum(Fraction(v) for v in a[0]))
    assert encloses(s[0], s[1], sum(Fraction(v) for v in a[1]))
    c = np.array(coefs[:n])
    out = I.fmatmul(c[None, :], a[:, :, None])             # (2, 1, 1)
    for pts in (a[0], a[1]):
        exact = sum(Fraction(ci) * Fraction(v) for ci, v in zip(c, pts))
        assert encloses(out[0, 0, 0], out[1, 0, 0], exact)


# ----------------------------------------------------------------------------- cos and sin

def mp_cos_sin(x: float):
    with mp.workdps(MP_DIGITS):
        return mp.cos(mpf(x)), mp.sin(mpf(x))


def contains_mp(lo: float, hi: float, v) -> bool:
    return mpf(lo) <= v <= mpf(hi)


def test_point_cos_sin_is_at_least_as_tight_as_mpmath_interval_functions():
    """The point enclosures contain the 60-digit values and lie inside mpmath's own interval
    cos/sin at that point (an independent rigorous routine: never wider than it)."""
    rng = np.random.default_rng(6)
    values = list(rng.uniform(-20, 20, 40)) + [0.0, -0.0, math.pi, math.pi / 2, -math.pi / 2, 1e-300, 5e-324,
                                               -1e-320, 1e6, 2.0 ** 60, 1.0]
    for a in values:
        c_lo, c_hi, s_lo, s_hi = I.point_cos_sin(float(a))
        c_iv, s_iv = iv.cos(iv.mpf([a, a])), iv.sin(iv.mpf([a, a]))
        if all(v == 0 or abs(mpf(v)) >= mpf(2) ** -1022 for v in (c_iv.a, c_iv.b, s_iv.a, s_iv.b)):
            # (mpmath's endpoints below the normal range are not floats: no float enclosure is inside them)
            assert mpf(c_iv.a) <= mpf(c_lo) and mpf(c_hi) <= mpf(c_iv.b), a
            assert mpf(s_iv.a) <= mpf(s_lo) and mpf(s_hi) <= mpf(s_iv.b), a
        c, s = mp_cos_sin(a)
        assert contains_mp(c_lo, c_hi, c) and contains_mp(s_lo, s_hi, s)
        assert c_hi - c_lo <= 4e-16 and s_hi - s_lo <= 4e-16 * max(1.0, abs(s_hi)) + 1e-320


@pytest.mark.parametrize("radius", [0.0, 1e-14, 1e-10, 1e-6, 1e-2, 0.5, 1.5, 3.0, 10.0])
def test_cos_sin_ball_encloses_60_digit_values(radius):
    rng = np.random.default_rng(int(radius * 1e6) % 1000 + 7)
    centers = np.concatenate((rng.uniform(-10, 10, 20), [0.0, math.pi / 2, math.pi, -math.pi / 2]))
    cos, sin = I.cos_sin_ball(centers, radius)
    assert cos.shape == sin.shape == (2, len(centers))
    assert np.all(cos >= -1) and np.all(cos <= 1) and np.all(sin >= -1) and np.all(sin <= 1)
    for k, a in enumerate(centers):
        for d in np.concatenate(([-radius, radius, 0.0], rng.uniform(-radius, radius, 5))):
            with mp.workdps(MP_DIGITS):
                x = mpf(float(a)) + mpf(float(d))
                c, s = mp.cos(x), mp.sin(x)
            assert contains_mp(cos[0, k], cos[1, k], c), (a, d)
            assert contains_mp(sin[0, k], sin[1, k], s), (a, d)
        # width: about 2 r |derivative| + r^2 + ulps (tight enough to be useful)
        assert cos[1, k] - cos[0, k] <= 2 * radius + radius ** 2 + 1e-15
        assert sin[1, k] - sin[0, k] <= 2 * radius + radius ** 2 + 1e-15
    if radius == 0.0:   # point enclosures are a few ulps wide
        assert np.all(cos[1] - cos[0] <= 1e-15) and np.all(sin[1] - sin[0] <= 1e-15)


def test_cos_sin_table_contains_the_exact_value_of_its_formula():
    """From the same point enclosures, cos d in [k, 1] and |sin d| <= rho evaluated exactly (Fractions)
    lie inside the float result: every rounding of the formula is outward."""
    rng = np.random.default_rng(12)
    centers = rng.uniform(-4, 4, 60)
    radii = np.concatenate((np.zeros(5), 10.0 ** rng.uniform(-15, 0.3, 55)))
    table = I.cos_sin_table(centers, radii)
    for n, (a, r) in enumerate(zip(centers, radii)):
        c_lo, c_hi, s_lo, s_hi = (Fraction(v) for v in I.point_cos_sin(float(a)))
        rf = Fraction(float(r))
        k = max(1 - rf * rf / 2, Fraction(-1))
        rho = min(rf, Fraction(1))
        cos_cd = [v * w for v in (c_lo, c_hi) for w in (k, Fraction(1))]
        sin_cd = [v * w for v in (s_lo, s_hi) for w in (k, Fraction(1))]
        spread_cos, spread_sin = rho * max(abs(s_lo), abs(s_hi)), rho * max(abs(c_lo), abs(c_hi))
        exact = [(min(cos_cd) - spread_cos, max(cos_cd) + spread_cos), (min(sin_cd) - spread_sin, max(sin_cd) + spread_sin)]
        for f, (lo, hi) in enumerate(exact):
            lo, hi = max(lo, Fraction(-1)), min(hi, Fraction(1))
            assert Fraction(table[0, f, n]) <= lo and hi <= Fraction(table[1, f, n]), (a, r, f)


def test_cos_sin_of_intervals_and_center_choice():
    rng = np.random.default_rng(8)
    lo = rng.uniform(-5, 5, 30)
    hi = lo + np.abs(rng.normal(size=30)) * 10.0 ** rng.integers(-12, 0, size=30)
    a = I.from_bounds(lo, hi)
    for center in (None, lo, hi):
        cos, sin = I.cos_sin(a, center=center)
        for k in range(30):
            for x in (lo[k], hi[k], 0.5 * (lo[k] + hi[k])):
                c, s = mp_cos_sin(x)
                assert contains_mp(cos[0, k], cos[1, k], c) and contains_mp(sin[0, k], sin[1, k], s)


#: u = 2^-53, half an ulp of 1.0.
U = Fraction(1, 2**53)
#: Operations whose exact results (Fractions) are not floats: a correctly outward-rounded
#: result must enclose them with both endpoints strictly apart from them.
INEXACT_CASES = [
    ("add", 0.1, 0.2), ("add", 1.0, float(U)), ("add", 1.0, float(3 * U / 2)), ("add", -1.0, -float(3 * U / 2)),
    ("add", 1e16, 1.0), ("sub", 1.0, 1e-20), ("sub", 1.0, 0.1), ("sub", -1e-300, 1.0),
    ("mul", 0.1, 3.0), ("mul", 1 / 3, 1 / 3), ("mul", -0.1, 0.7), ("mul", 2.0**-1022, 0.75 + float(U)),
]
EXACT_OPS = {"add": lambda x, y: x + y, "sub": lambda x, y: x - y, "mul": lambda x, y: x * y}


def representable(v: Fraction) -> bool:
    return Fraction(float(v)) == v


@pytest.mark.parametrize("op, x, y", INEXACT_CASES)
def test_outward_rounding_strictly_encloses_inexact_results(op, x, y):
    exact = EXACT_OPS[op](Fraction(x), Fraction(y))
    assert not representable(exact)
    lo, hi = getattr(I, op)(I.point([x]), I.point([y]))[:, 0]
    assert Fraction(lo) < exact < Fraction(hi)
    assert ulps_beyond(lo, exact, "lo") <= SINGLE_OP_ULPS and ulps_beyond(hi, exact, "hi") <= SINGLE_OP_ULPS


def test_rounding_environment_matches_exact_round_to_nearest():
    """The arithmetic here rounds to nearest, ties to even, with gradual underflow (checked against
    exact Fractions, independently of the probes), and rounding_environment_ok() says so."""
    for x, y, nearest in [(1.0, 3 * U / 2, 1 + 2 * U), (-1.0, -3 * U / 2, -1 - 2 * U), (1.0, U, Fraction(1)),
                          (1.0, 3 * U, 1 + 4 * U)]:
        total = Fraction(x) + y
        assert not representable(total)
        got = np.full(16, x) + np.full(16, float(y))           # numpy's vector loop, as the probes
        assert all(Fraction(v) == nearest for v in got.tolist())
    tiny = 2.0**-1022
    assert Fraction((np.full(16, tiny) * 0.5)[0]) == Fraction(tiny) / 2   # no flush to zero
    assert Fraction((np.full(16, tiny / 2) * 2.0)[0]) == Fraction(tiny)   # subnormal inputs read as such
    assert I.rounding_environment_ok()


@pytest.mark.parametrize("probe", ["_ADD_EXPECTED", "_MUL_EXPECTED"])
def test_rounding_environment_check_fails_when_a_probe_disagrees(monkeypatch, probe):
    """The check compares the probe results: expecting the bits of another environment (one bit
    flipped: rounding up or flushing to zero) makes it False."""
    wrong = getattr(I, probe).copy()
    wrong[0] ^= np.uint64(1)
    monkeypatch.setattr(I, probe, wrong)
    assert not I.rounding_environment_ok()


# ----------------------------------------------------------------------------- bad input

@pytest.mark.parametrize("call, message", [
    (lambda: I.from_bounds([1.0], [0.0]), r"lo, hi: expected lo <= hi"),
    (lambda: I.from_bounds([0.0, 1.0], [1.0]), r"lo, hi: expected the same shape"),
    (lambda: I.add(np.zeros((3, 2)), np.zeros((2, 2))), r"a: expected an interval array of shape \(2, \.\.\.\)"),
    (lambda: I.mul(np.zeros((2, 2)), np.zeros(3)), r"b: expected an interval array"),
    (lambda: I.isum(np.zeros((2, 3)), axis=1), r"axis: expected an element axis"),
    (lambda: I.matmul(np.zeros((2, 2, 3)), np.zeros((2, 2, 3))), r"a, b: expected interval matrices"),
    (lambda: I.fmatmul(np.zeros(3), np.zeros((2, 3, 1))), r"c, a: expected a float matrix"),
    (lambda: I.cos_sin_ball([0.0], [-1.0]), r"radius: expected radii >= 0"),
    (lambda: I.cos_sin_ball([math.nan], [0.0]), r"center, radius: expected finite"),
    (lambda: I.cos_sin(I.from_bounds([0.0], [1.0]), center=[2.0]), r"center: expected points inside"),
    (lambda: I.point_cos_sin(math.inf), r"a: expected a finite angle"),
    (lambda: I.sum_up(np.zeros(3), axis=2), r"axis: expected an axis"),
])
def test_bad_input_raises_value_error(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_cos_sin_table_at_radius_zero_is_the_vector_point_enclosure_alone_or_in_a_chunk():
    """One definition of the point enclosure: the table's radius-0 entries are cos_sin_enclosure_many's
    floats, equal to point_cos_sin's for each point alone, and contain the 60-digit values."""
    from spherekin.core.trig_enclosure import cos_sin_enclosure_many
    rng = np.random.default_rng(30)
    centers = np.concatenate((rng.uniform(-8, 8, 50), [0.0, math.pi / 2, 1e-9, 3e6]))
    table = I.cos_sin_table(centers, np.zeros_like(centers))
    c_lo, c_hi, s_lo, s_hi = cos_sin_enclosure_many(centers)
    assert np.array_equal(table[:, 0], np.stack((c_lo, c_hi))) and np.array_equal(table[:, 1], np.stack((s_lo, s_hi)))
    assert centers.size > I.SMALL_TABLE                 # the array path; a few entries take the cached points
    small = I.cos_sin_table(centers[:I.SMALL_TABLE], np.zeros(I.SMALL_TABLE))
    assert np.array_equal(small, table[..., :I.SMALL_TABLE])
    for n, a in enumerate(centers.tolist()):
        assert I.point_cos_sin(a) == (c_lo[n], c_hi[n], s_lo[n], s_hi[n])
        c, s = mp_cos_sin(a)
        assert contains_mp(c_lo[n], c_hi[n], c) and contains_mp(s_lo[n], s_hi[n], s)
