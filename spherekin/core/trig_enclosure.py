"""Rigorous enclosures of cos(a) and sin(a) at a float point a, in fixed-point integer arithmetic.

Every interval enclosure of cos and sin in :mod:`spherekin.core.intervals` starts from the values at a
float point; this module gives them: floats c_lo <= cos(a) <= c_hi and s_lo <= sin(a) <= s_hi,
normally the two floats adjacent to each exact value (the tightest float enclosure). Python's
integers are exact, so every error below is counted, not estimated; the default solve path
needs no multiprecision library (importing mpmath cost ~15 ms per process).
tests/test_trig_enclosure.py checks the results against mpmath at 4000 bits.

Method. Numbers are integers N standing for N 2^-W, W = :data:`WORK_BITS` + |e| for a = m 2^e
(frexp), so that a (exact: its 53-bit mantissa shifted), its reduced argument and the results keep
at least WORK_BITS bits below their leading bit, for tiny and large angles alike.

1. reduction: k = the integer nearest a / (pi/2) and r = a - k pi/2, with pi/2 from
   :data:`HALF_PI_320` (pi/2 rounded down at 320 bits, below 2^-320 off) cut to W bits (floor,
   less than 2 units below 2^W pi/2): |error of r| < 2 |k| units of 2^-W; r = a exactly when k = 0;
2. Taylor series of cos r and sin r at the computed r, each term the previous times -r^2 / (n (n+1)),
   products and quotients floored: each term is within 4 units of its exact value (the floors and
   the error of r^2 add at most 2 units per step, and the factor r^2 / (n (n+1)) <= 1/2 halves the
   error carried from the previous term); the series stops when both terms vanish, and the exact
   rest is then below 2 units (alternating, decreasing terms for |r| < 1);
3. E = 6 (terms + 1) + 1 + 2 |k| units bounds |computed - exact| of both values (6 per term
   covers each term's 4 and the rest; cos and sin are 1-Lipschitz, which carries the reduction
   error over);
4. quadrant: (cos a, sin a) = (cos r, sin r), (-sin r, cos r), (-cos r, -sin r), (sin r, -cos r)
   for k = 0, 1, 2, 3 (mod 4);
5. outward: c_lo = the largest float <= (C - E) 2^-W, c_hi = the smallest float >= (C + E) 2^-W
   (exact integer comparisons), clamped to [-1, 1].

Angles beyond :data:`MAX_ANGLE` are refused (no joint angle is one; pi/2 would need more bits).
"""

from __future__ import annotations

import math

__all__ = ["WORK_BITS", "MAX_ANGLE", "HALF_PI_320", "FixedCosSin", "cos_sin_fixed", "cos_sin_enclosure"]

#: pi/2 rounded down to a multiple of 2^-320 (an integer in units of 2^-320), i.e.
#: HALF_PI_320 <= 2^320 pi/2 < HALF_PI_320 + 1; checked against mpmath in the tests.
HALF_PI_320 = int("1921fb54442d18469898cc51701b839a252049c1114cf98e804177d4c76273644a29410f31c6809bb", 16)
#: Fraction bits of the computation beyond the angle's binary exponent. Reason: the error bound is
#: a few hundred units of 2^-W, so 160 bits leave ~150 bits of margin below the 53 bits of the
#: results; no float a lies closer than ~2^-62 to a nonzero multiple of pi/2 (Kahan and
#: McDonald), so r keeps ~90 correct bits even there.
WORK_BITS = 160
#: Largest |a| accepted (radians). Reason: W = WORK_BITS + 65 <= 320 bits of pi/2 for |a| <= 2^64;
#: joint angles are a few turns at most.
MAX_ANGLE = 2.0 ** 64


def _series(r: int, w: int) -> tuple[int, int, int]:
    """(cos r, sin r, terms) in units of 2^-w by their Taylor series, for |r| < 2^w."""
    r2 = (r * r) >> w
    c_term, c_sum = 1 << w, 1 << w
    s_term, s_sum = r, r
    n, terms = 0, 1
    while c_term or s_term:
        n += 2
        c_term = -((c_term * r2) >> w) // ((n - 1) * n)
        s_term = -((s_term * r2) >> w) // (n * (n + 1))
        c_sum += c_term
        s_sum += s_term
        terms += 1
    return c_sum, s_sum, terms


def _float_below(n: int, w: int) -> float:
    """The largest float <= n 2^-w."""
    f = n / (1 << w)                             # int / int is correctly rounded (subnormals included)
    p, q = f.as_integer_ratio()                  # f = p / q exactly, q a power of 2
    if p << w > n * q:
        f = math.nextafter(f, -math.inf)
    return f


def _float_above(n: int, w: int) -> float:
    """The smallest float >= n 2^-w."""
    f = n / (1 << w)
    p, q = f.as_integer_ratio()
    if p << w < n * q:
        f = math.nextafter(f, math.inf)
    return f


class FixedCosSin:
    """cos a and sin a as integers in units of 2^-bits: |cos a - cos 2^-bits| <= error 2^-bits, the same for sin."""

    __slots__ = ("cos", "sin", "error", "bits")

    cos: int
    sin: int
    error: int
    bits: int

    def __init__(self, cos, sin, error, bits):
        self.cos = cos
        self.sin = sin
        self.error = error
        self.bits = bits


def cos_sin_fixed(a: float) -> FixedCosSin:
    """Steps 1-4 of the module docstring for a finite nonzero float ``a``, |a| <= MAX_ANGLE (unchecked)."""
    mant, exp = math.frexp(a)
    w = WORK_BITS + abs(exp)
    x = int(mant * (1 << 53)) << (exp - 53 + w)  # exact: exp - 53 + w >= 0 for every exp
    half_pi = HALF_PI_320 >> (320 - w) if w <= 320 else HALF_PI_320 << (w - 320)   # w > 320: |a| < 2^-160, k = 0
    k = (2 * x + half_pi) // (2 * half_pi)       # nearest integer to x / (pi/2) (up to ties)
    r = x - k * half_pi
    c_r, s_r, terms = _series(r, w)
    err = 6 * (terms + 1) + 1 + 2 * abs(k)
    quadrant = k % 4
    if quadrant == 0:
        c, s = c_r, s_r
    elif quadrant == 1:
        c, s = -s_r, c_r
    elif quadrant == 2:
        c, s = -c_r, -s_r
    else:
        c, s = s_r, -c_r
    return FixedCosSin(c, s, err, w)


def cos_sin_enclosure(a: float) -> tuple[float, float, float, float]:
    """(cos_lo, cos_hi, sin_lo, sin_hi): floats enclosing cos(a) and sin(a) for a float ``a`` (radians).

    Rigorous (see the module docstring) and normally the two floats adjacent to each exact value;
    exact at a = 0. ValueError for a non-finite ``a`` or |a| > MAX_ANGLE.
    """
    a = float(a)
    if not math.isfinite(a):
        raise ValueError(f"a: expected a finite angle (radians), got {a!r}")
    if abs(a) > MAX_ANGLE:
        raise ValueError(f"a: expected |a| <= {MAX_ANGLE:g} (radians), got {a!r}")
    if a == 0.0:
        return 1.0, 1.0, 0.0, 0.0
    f = cos_sin_fixed(a)
    c, s, err, w = f.cos, f.sin, f.error, f.bits
    return (max(_float_below(c - err, w), -1.0), min(_float_above(c + err, w), 1.0),
            max(_float_below(s - err, w), -1.0), min(_float_above(s + err, w), 1.0))
