"""Rigorous point enclosures of cos and sin (spherekin.core.trig_enclosure) against mpmath at 4000 bits:
the exact integer routine (cos_sin_enclosure_exact), the vectorized double-double one
(cos_sin_enclosure_many) and the one-point cos_sin_enclosure (the vectorized one at one point)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from mpmath import mp, mpf

from spherekin.core.trig_enclosure import (COS_ERROR, HALF_PI_320, HALF_PI_PARTS, HALF_PI_TAIL_BOUND, MAX_ANGLE,
                                           SIN_RELATIVE_ERROR, VECTOR_MAX_ANGLE, cos_sin_double_double,
                                           cos_sin_enclosure, cos_sin_enclosure_exact, cos_sin_enclosure_many,
                                           cos_sin_fixed)

BOTH = pytest.mark.parametrize("enclose", [cos_sin_enclosure_exact, cos_sin_enclosure], ids=["exact", "vector"])


def exact_cos_sin(a: float):
    with mp.workprec(4000):
        return mp.cos(mpf(a)), mp.sin(mpf(a))


def adjacent(lo: float, hi: float, v) -> bool:
    """[lo, hi] is the tightest float enclosure of v: lo = the largest float <= v, hi = the smallest >= v."""
    with mp.workprec(4000):
        lo_ok = mpf(lo) == v or mpf(math.nextafter(lo, math.inf)) > v
        hi_ok = mpf(hi) == v or mpf(math.nextafter(hi, -math.inf)) < v
    return lo_ok and hi_ok


def angles() -> list[float]:
    rng = np.random.default_rng(41)
    out = list(rng.uniform(-20, 20, 300)) + list(rng.uniform(-1e18, 1e18, 40))
    out += [k * math.pi / 2 for k in range(-40, 41) if k]                        # next to multiples of pi/2
    out += [math.nextafter(k * math.pi / 2, math.inf) for k in range(1, 40)]
    out += [math.pi, -math.pi, 1.0, 1e6, 2.0 ** 60, MAX_ANGLE, -MAX_ANGLE, 355.0, 103993.0]
    out += [10.0 ** e for e in range(-20, 19)]
    return [float(a) for a in out]


def test_half_pi_constant_is_pi_over_two_rounded_down_at_320_bits():
    with mp.workprec(1000):
        scaled = mp.pi / 2 * mpf(2) ** 320
        assert mpf(HALF_PI_320) <= scaled < mpf(HALF_PI_320 + 1)


@BOTH
@pytest.mark.parametrize("a", angles())
def test_encloses_the_exact_values_with_adjacent_floats(a, enclose):
    c_lo, c_hi, s_lo, s_hi = enclose(a)
    c, s = exact_cos_sin(a)
    with mp.workprec(4000):
        assert mpf(c_lo) <= c <= mpf(c_hi) and mpf(s_lo) <= s <= mpf(s_hi)
    # the exact values are 1e-19 or more (relative) from every float here: the tightest enclosure
    assert adjacent(c_lo, c_hi, c) and adjacent(s_lo, s_hi, s)


@BOTH
@pytest.mark.parametrize("a", [1e-300, 5e-324, -1e-320, 2.0 ** -160, 1e-60, -3e-100, 2.0 ** -26, -1e-9])
def test_tiny_angles_are_enclosed_within_two_ulps(a, enclose):
    """sin a = a - a^3/6 lies closer to the float a than the error bound: one float wider, still exact."""
    c_lo, c_hi, s_lo, s_hi = enclose(a)
    c, s = exact_cos_sin(a)
    with mp.workprec(4000):
        assert mpf(c_lo) <= c <= mpf(c_hi) and mpf(s_lo) <= s <= mpf(s_hi)
    assert c_hi == 1.0 and c_lo >= math.nextafter(1.0, 0.0)
    assert s_lo <= a <= s_hi and s_hi - s_lo <= 2 * math.ulp(a)


@BOTH
def test_zero_and_the_range_of_the_results(enclose):
    assert enclose(0.0) == (1.0, 1.0, 0.0, 0.0)
    assert enclose(-0.0) == (1.0, 1.0, 0.0, 0.0)
    for a in angles():
        c_lo, c_hi, s_lo, s_hi = enclose(a)
        assert -1.0 <= c_lo <= c_hi <= 1.0 and -1.0 <= s_lo <= s_hi <= 1.0


@pytest.mark.parametrize("bad, message", [(math.inf, "finite"), (math.nan, "finite"), (-math.inf, "finite"),
                                          (2.0 ** 65, "MAX_ANGLE|<="), (-1e300, "<=")])
def test_refuses_angles_it_cannot_enclose(bad, message):
    for enclose in (cos_sin_enclosure_exact, cos_sin_enclosure, lambda a: cos_sin_enclosure_many(np.array([0.5, a]))):
        with pytest.raises(ValueError, match=message):
            enclose(bad)


@pytest.mark.parametrize("a", angles())
def test_the_counted_error_bounds_the_fixed_point_values(a):
    """|C - 2^W cos a| <= E and |S - 2^W sin a| <= E at the integer level, where the float rounding
    cannot hide a bound that is too small (large angles: the reduction error is most of E)."""
    if a == 0.0:
        return
    f = cos_sin_fixed(a)
    c, s = exact_cos_sin(a)
    with mp.workprec(4000):
        scale = mpf(2) ** f.bits
        assert abs(f.cos - c * scale) <= f.error and abs(f.sin - s * scale) <= f.error


# --------------------------------------------------------------------------------------------
# the vectorized double-double enclosure (module docstring, part B)
# --------------------------------------------------------------------------------------------

def vector_angles() -> np.ndarray:
    """Seeded floats over the vector path's range and its hard cases."""
    rng = np.random.default_rng(30)
    half_pi, quarter_pi = math.pi / 2, math.pi / 4
    ks = np.concatenate((np.arange(-60, 61), rng.integers(-600000, 600000, 40)))
    near = np.concatenate([np.nextafter(ks * m, d) for m in (half_pi, quarter_pi) for d in (-np.inf, np.inf)]
                          + [ks * half_pi, ks * quarter_pi])
    out = np.concatenate((
        rng.uniform(-VECTOR_MAX_ANGLE, VECTOR_MAX_ANGLE, 300), rng.uniform(-20.0, 20.0, 600),
        rng.uniform(-1.0, 1.0, 100) * 10.0 ** rng.uniform(-30, 0, 100),            # small and tiny
        near,
        [half_pi, -half_pi, math.nextafter(half_pi, 0.0), math.nextafter(half_pi, 4.0), math.pi, 0.0, -0.0,
         5e-324, -5e-324, 2.0 ** -1022, 1e-310, -3e-320, 2.0 ** -26, math.nextafter(2.0 ** -26, 1.0),
         VECTOR_MAX_ANGLE, -VECTOR_MAX_ANGLE, math.nextafter(VECTOR_MAX_ANGLE, math.inf), 3e6, -1e12, 2.0 ** 60],
    ))
    return out


def gap(x: float, direction: float) -> float:
    return abs(math.nextafter(x, direction) - x)


def test_half_pi_parts_are_33_bit_and_sum_to_pi_over_two_within_the_tail_bound():
    for part in HALF_PI_PARTS:
        mantissa, _ = math.frexp(part)
        assert (mantissa * 2 ** 33).is_integer()                   # k * part exact for |k| < 2^20
    with mp.workprec(1000):
        delta = mp.pi / 2 - sum(mpf(p) for p in HALF_PI_PARTS)
        assert 0 <= delta <= mpf(HALF_PI_TAIL_BOUND)


def test_series_error_constants_are_far_below_an_ulp():
    """The proven bounds (part B3) leave the results at the adjacent floats but for rare ties."""
    assert 0 < COS_ERROR < 2.0 ** -80 and 0 < SIN_RELATIVE_ERROR < 2.0 ** -84


def test_vector_enclosure_contains_the_exact_values_and_is_at_most_two_gaps_wide():
    a = vector_angles()
    c_lo, c_hi, s_lo, s_hi = cos_sin_enclosure_many(a)
    not_adjacent = 0
    for n, x in enumerate(a.tolist()):
        c, s = exact_cos_sin(x)
        with mp.workprec(4000):
            assert mpf(c_lo[n]) <= c <= mpf(c_hi[n]) and mpf(s_lo[n]) <= s <= mpf(s_hi[n]), x
        for lo, hi in ((c_lo[n], c_hi[n]), (s_lo[n], s_hi[n])):
            assert -1.0 <= lo <= hi <= 1.0
            # at most one float strictly inside: [pred h, succ h] for the double-double's float h
            assert math.nextafter(math.nextafter(lo, math.inf), math.inf) >= hi, x
        for lo, hi, v in ((c_lo[n], c_hi[n], c), (s_lo[n], s_hi[n], s)):
            # the bound is < 2^-70 relative: one float wider than adjacent only where the exact value
            # lies that close to a float (here: cos a = 1 - a^2/2 next to pred 1 for a = succ 2^-26)
            if not adjacent(lo, hi, v):
                not_adjacent += 1
                with mp.workprec(4000):
                    assert abs(v - mpf(float(v))) <= abs(v) * mpf(2) ** -70, x
    assert not_adjacent <= 2


def test_vector_and_exact_routines_both_contain_the_truth_and_mostly_agree():
    a = vector_angles()
    vec = np.stack(cos_sin_enclosure_many(a), axis=1)
    exact = np.array([cos_sin_enclosure_exact(float(x)) for x in a])
    for n, x in enumerate(a.tolist()):
        c, s = exact_cos_sin(x)
        with mp.workprec(4000):
            for row in (vec[n], exact[n]):
                assert mpf(row[0]) <= c <= mpf(row[1]) and mpf(row[2]) <= s <= mpf(row[3]), x
    # both are normally the adjacent floats; they differ only where one is a float wider: tiny
    # angles (closed forms), or an exact value within 2^-70 (relative) of a float
    for n in np.flatnonzero(~np.all(vec == exact, axis=1)).tolist():
        if abs(a[n]) > 2.0 ** -26:
            c, s = exact_cos_sin(float(a[n]))
            with mp.workprec(4000):
                assert min(abs(v - mpf(float(v))) / abs(v) for v in (c, s)) <= mpf(2) ** -70, a[n]


def test_a_point_gets_the_same_floats_alone_or_in_any_array():
    a = vector_angles()
    together = np.stack(cos_sin_enclosure_many(a))
    rng = np.random.default_rng(3)
    perm = rng.permutation(a.size)
    shuffled = np.stack(cos_sin_enclosure_many(a[perm].reshape(-1, 1)))[:, :, 0]
    assert np.array_equal(shuffled, together[:, perm])
    for n in rng.choice(a.size, 40, replace=False).tolist():
        assert np.array_equal(np.stack(cos_sin_enclosure_many(a[n:n + 3]))[:, 0], together[:, n])
    # the one-point routine (Python floats, the same operations) gives the same floats, bit for bit
    more = np.concatenate((a, rng.uniform(-50, 50, 3000), rng.uniform(-VECTOR_MAX_ANGLE, VECTOR_MAX_ANGLE, 1000)))
    many = np.stack(cos_sin_enclosure_many(more), axis=1)
    one = np.array([cos_sin_enclosure(x) for x in more.tolist()])
    assert np.array_equal(one, many) and np.array_equal(np.signbit(one), np.signbit(many))


def test_the_double_double_error_bound_holds_and_is_needed():
    """At the double-double level (where float rounding cannot hide a bound that is too small):
    |exact - (hi + lo)| <= error for every valid entry; and the exact value is never the
    double-double value itself, so dropping the bound (error 0) would claim a false enclosure."""
    a = vector_angles()
    a = a[np.abs(a) > 2.0 ** -26]
    dd = cos_sin_double_double(a)
    assert dd.valid[np.abs(a) <= VECTOR_MAX_ANGLE].all()
    worst = 0.0
    with mp.workprec(4000):
        for n in np.flatnonzero(dd.valid).tolist():
            c, s = exact_cos_sin(float(a[n]))
            for v, hi, lo, err in ((c, dd.cos_hi[n], dd.cos_lo[n], dd.cos_error[n]),
                                   (s, dd.sin_hi[n], dd.sin_lo[n], dd.sin_error[n])):
                miss = abs(v - (mpf(hi) + mpf(lo)))
                assert 0 < miss <= mpf(err), float(a[n])
                assert mpf(err) <= abs(v) * mpf(2) ** -70          # tight: far below the gap of the floats
                worst = max(worst, float(miss / mpf(err)))
    assert worst > 2.0 ** -40                                       # the bound is not vacuous either



def test_the_kept_error_constants_and_coefficients_are_their_exact_derivations():
    """The module keeps COS_ERROR, SIN_RELATIVE_ERROR and the double-double series coefficients as
    literals (no ``fractions`` import on the solve path); they must be what the exact derivations
    give, and the coefficients within u^2 of 1/(2i)! and 1/(2i+1)! (checked in fractions here)."""
    from fractions import Fraction
    import math

    from spherekin.core import trig_enclosure as te

    assert (te.COS_ERROR, te.SIN_RELATIVE_ERROR) == te.series_error_bounds()
    assert te._COS_DD == te.dd_coefficients(False) and te._SIN_DD == te.dd_coefficients(True)
    u2 = Fraction(1, 1 << 106)
    for odd, table in ((0, te._COS_DD), (1, te._SIN_DD)):
        for i, (hi, lo) in enumerate(table):
            exact = Fraction((-1) ** i, math.factorial(2 * i + odd))
            assert abs(Fraction(hi) + Fraction(lo) - exact) <= u2 * abs(exact)
