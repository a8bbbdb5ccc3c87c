"""Rigorous point enclosures of cos and sin (spherekin.core.trig_enclosure) against mpmath at 4000 bits."""

from __future__ import annotations

import math

import numpy as np
import pytest
from mpmath import mp, mpf

from spherekin.core.trig_enclosure import HALF_PI_320, MAX_ANGLE, cos_sin_enclosure, cos_sin_fixed


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


@pytest.mark.parametrize("a", angles())
def test_encloses_the_exact_values_with_adjacent_floats(a):
    c_lo, c_hi, s_lo, s_hi = cos_sin_enclosure(a)
    c, s = exact_cos_sin(a)
    with mp.workprec(4000):
        assert mpf(c_lo) <= c <= mpf(c_hi) and mpf(s_lo) <= s <= mpf(s_hi)
    # the exact values are 1e-19 or more (relative) from every float here: the tightest enclosure
    assert adjacent(c_lo, c_hi, c) and adjacent(s_lo, s_hi, s)


@pytest.mark.parametrize("a", [1e-300, 5e-324, -1e-320, 2.0 ** -160, 1e-60, -3e-100])
def test_tiny_angles_are_enclosed_within_two_ulps(a):
    """sin a = a - a^3/6 lies closer to the float a than the error bound: one float wider, still exact."""
    c_lo, c_hi, s_lo, s_hi = cos_sin_enclosure(a)
    c, s = exact_cos_sin(a)
    with mp.workprec(4000):
        assert mpf(c_lo) <= c <= mpf(c_hi) and mpf(s_lo) <= s <= mpf(s_hi)
    assert c_hi == 1.0 and c_lo >= math.nextafter(1.0, 0.0)
    assert s_lo <= a <= s_hi and s_hi - s_lo <= 2 * math.ulp(a)


def test_zero_and_the_range_of_the_results():
    assert cos_sin_enclosure(0.0) == (1.0, 1.0, 0.0, 0.0)
    assert cos_sin_enclosure(-0.0) == (1.0, 1.0, 0.0, 0.0)
    for a in angles():
        c_lo, c_hi, s_lo, s_hi = cos_sin_enclosure(a)
        assert -1.0 <= c_lo <= c_hi <= 1.0 and -1.0 <= s_lo <= s_hi <= 1.0


@pytest.mark.parametrize("bad, message", [(math.inf, "finite"), (math.nan, "finite"), (-math.inf, "finite"),
                                          (2.0 ** 65, "MAX_ANGLE|<="), (-1e300, "<=")])
def test_refuses_angles_it_cannot_enclose(bad, message):
    with pytest.raises(ValueError, match=message):
        cos_sin_enclosure(bad)


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
