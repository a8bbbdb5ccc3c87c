"""Rigorous enclosures of cos(a) and sin(a) at float points a: integer fixed point (A), double-double (B).

Every interval enclosure of cos and sin in :mod:`spherekin.core.intervals` starts from the values at a
float point; this module gives them: floats c_lo <= cos(a) <= c_hi and s_lo <= sin(a) <= s_hi,
normally the two floats adjacent to each exact value (the tightest float enclosure). Every error
below is counted, not estimated (A: Python's integers are exact; B: every rounding of binary64
is bounded); the default solve path needs no multiprecision library (importing mpmath cost
~15 ms per process). tests/test_trig_enclosure.py checks both against mpmath at 4000 bits.

A. The exact routine. Numbers are integers N standing for N 2^-W, W = :data:`WORK_BITS` + |e| for a = m 2^e
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
This is :func:`cos_sin_enclosure_exact` (~27 us a call): the slow reference, and the fallback of part B.

B. The vectorized enclosure :func:`cos_sin_enclosure_many` (numpy, ~0.6 us an entry on 10^4
entries, ~0.3 ms a call however small); :func:`cos_sin_enclosure` is it at one point (~16 us: the
same operations in the same order on Python floats, so the same floats, checked bit for bit in
the tests), so a point gets the same floats alone or in any array. Binary64, round to nearest, u = 2^-53; the standard model fl(x op y) = (x op y)(1 + d),
|d| <= u, holds for every product below (no operand comes near the subnormal range: |r| >= R_MIN)
and for every sum. TwoSum (Knuth, 6 operations) and Fast2Sum (Dekker, 3, when |x| >= |y|) give
s = fl(x + y) and the exact x + y - s; Dekker's TwoProduct (split by 2^27 + 1, no FMA) gives
p = fl(x y) and the exact x y - p. A double-double (h, l) stands for h + l with h = fl(h + l), so
|l| <= u |h| and |l| is at most half the gap between h and its neighbour on l's side.

B0. a = 0 gives (1, 1, 0, 0); 0 < |a| <= :data:`TINY_ANGLE` = 2^-26 gives cos a in [pred 1, 1]
   (1 - a^2/2 < cos a < 1, a^2/2 <= 2^-53 = 1 - pred 1) and sin a in [pred a, a] for a > 0
   (a - a^3/6 < sin a < a, a^3/6 < 2^-54 a <= the gap below a; subnormal a: the gap is 2^-1074),
   mirrored for a < 0.
B1. reduction, for |a| <= :data:`VECTOR_MAX_ANGLE` = 2^20: k = rint(fl(a 2/pi)), so
   |a 2/pi - k| <= 1/2 + 2^-31 and |r| <= pi/4 + 2^-31 < :data:`R_MAX` for r = a - k pi/2, and
   |k| < 2^20. pi/2 = P1 + ... + P5 + delta, Pj the j-th 33 bits of pi/2 (:data:`HALF_PI_PARTS`),
   0 <= delta <= :data:`HALF_PI_TAIL_BOUND` = 2^-163: every k Pj is exact (20 + 33 bits).
   r1 = fl(a - k P1) is exact: for k != 0, |a| >= 0.78, and a and k P1 are multiples of the ulp of a
   (>= 2^-53, and <= 2^-32, the last bit of P1, as |a| <= 2^20), as is r1, with |r1| <= 0.79 + 2^-12 < 1.
   (s2, e2) = TwoSum(r1, -k P2), (s3, e3) = TwoSum(s2, -k P3), t = fl(fl(fl(e2 + e3) - k P4) - k P5),
   (r_hi, r_lo) = TwoSum(s3, t): r_hi + r_lo = r - (t - exact t) - k delta, and recursive summation
   errs by at most gamma_3 (|e2| + |e3| + |k P4| + |k P5|) <= 2^-51 (...), so
   |r_hi + r_lo - r| <= e_r = 2^-51 (|e2| + |e3| + |k P4| + |k P5|) + |k| 2^-163 (evaluated in floats
   per entry; every bound evaluated in floats is a sum or product of nonnegative numbers with at
   most 40 roundings, multiplied by :data:`BOUND_SLACK` >= (1 - u)^-41 to stay an upper bound).
   Entries with |r_hi| outside [R_MIN, R_MAX (1 - 2^-40)] go to the fallback (none do in practice).
B2. double-double operations with their relative errors (inputs (xh, xl), (yh, yl) as above):
   product (DWTimesDW1): (ch, c1) = TwoProduct(xh, yh), c3 = fl(c1 + fl(fl(xh yl) + fl(xl yh))),
   Fast2Sum(ch, c3). With m = |xh yh|: the dropped xl yl <= u^2 m; the two products and their sum
   err by <= 4u^2 m + O(u^3) m; the last sum by <= u (|c1| + |c2|) <= 3u^2 m + O(u^3) m; and
   m <= |x y| / (1 - u)^2: relative error <= 8u^2 + O(u^3) <= 9u^2 (:data:`DD_MUL_ERROR_U2`).
   sum of a constant c and p with |p| <= 0.31 |c| (each Horner step below): (sh, sl) = Fast2Sum(ch, ph)
   (exact, as |ph| < |ch|),
   w = fl(sl + fl(cl + pl)), Fast2Sum(sh, w); error <= u (2 + u) u (|ch| + |ph|) + u^2 |sh|
   <= u^2 |c + p| ((2 + u) 1.31 / 0.69 + 1) / (1 - u) <= 5u^2 |c + p| (:data:`DD_ADD_ERROR_U2`).
B3. series at the double-double r^ = r_hi + r_lo: x^ = r^ r^ (B2 product); cos r^ = P(x),
   sin r^ = r^ Q(x), P = sum_{i<=N} (-1)^i x^i / (2i)!, Q = sum_{i<=N} (-1)^i x^i / (2i+1)!,
   N = :data:`SERIES_DEGREE` = 14 (the rests, alternating and decreasing for x < 1, are below
   x^(N+1)/(2N+2)! resp. /(2N+3)! < 2^-117). Horner: degrees >= M = :data:`DD_DEGREE` = 6 in plain
   double at x_hi (T^, within gamma_{2(N-M)+1}(u) 1.01 |c_M| + 1.1 u |c_M| of T(x): Higham's Horner
   bound with rounded coefficients, and x_hi within 1.01 u x of x, T' <= |c_(M+1)|), then degrees
   < M in double-double with coefficients (-1)^i/(i')! rounded to double-double (within u^2).
   Each step's sum satisfies |p| <= 0.31 |c| (x <= R_MAX^2 < 0.617, |c_(i+1)/c_i| <= 1/2, the
   inner value below |c_(i+1)| by alternation). Every double-double operation being a relative
   error <= 9u^2, the result is sum_i c_i x^i (1 + theta_i), |theta_i| <= gamma_(3M+1)(9u^2)
   (M products, M sums, the coefficient, and M powers of x^'s own error), so
   |P^ - cos r^| <= gamma_(3M+1)(9u^2) cosh R_MAX + (T^ error) R_MAX^(2M) + rest = :data:`COS_ERROR`
   (~2^-81.8) and |Q^ - sin r^ / r^| likewise with sinh R_MAX / R_MAX; with the product r^ Q^
   (9u^2) and |r^| <= |r_hi| (1 + u): |s^ - sin r^| <= :data:`SIN_RELATIVE_ERROR` |r_hi| (~2^-85.5).
   Both constants are computed at import in exact rational arithmetic and rounded up.
   cos and sin being 1-Lipschitz, the bounds E_cos = COS_ERROR + e_r and
   E_sin = SIN_RELATIVE_ERROR |r_hi| + e_r hold against cos r and sin r.
B4. quadrant as in step 4 (negation is exact; the error bound follows its value).
B5. outward rounding of a double-double (h, l) with error bound E <= |h| 2^-55 (:data:`GAP_FRACTION`;
   < half the gap on either side of h, as that gap >= 2^-54 |h| for normal h): the exact value v has
   v >= h + l - E > h - gap, so lo = h if l >= E (then v >= h), else pred h; symmetrically
   hi = h if l <= -E, else succ h; clamped to [-1, 1]. Both comparisons are exact. So the result is
   the two floats adjacent to v (one of them v itself if v is a float), one float wider on a
   side where v lies within E (< 2^-70 |v|) of a float. Entries with E > |h| 2^-55 (none in
   practice) go to the fallback, as do |a| > VECTOR_MAX_ANGLE (ValueError beyond MAX_ANGLE).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["WORK_BITS", "MAX_ANGLE", "HALF_PI_320", "FixedCosSin", "cos_sin_fixed", "cos_sin_enclosure_exact",
           "VECTOR_MAX_ANGLE", "HALF_PI_PARTS", "HALF_PI_TAIL_BOUND", "TINY_ANGLE", "R_MAX", "COS_ERROR",
           "SIN_RELATIVE_ERROR", "DoubleDoubleCosSin", "cos_sin_double_double", "cos_sin_enclosure_many",
           "cos_sin_enclosure", "series_error_bounds", "dd_coefficients", "DD_MUL_ERROR_U2", "DD_ADD_ERROR_U2"]

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


@dataclass(slots=True, eq=False)
class FixedCosSin:
    """cos a and sin a as integers in units of 2^-bits: |cos a - cos 2^-bits| <= error 2^-bits, the same for sin."""

    cos: int
    sin: int
    error: int
    bits: int


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


def cos_sin_enclosure_exact(a: float) -> tuple[float, float, float, float]:
    """(cos_lo, cos_hi, sin_lo, sin_hi): floats enclosing cos(a) and sin(a) for a float ``a`` (radians),
    by the fixed-point integer method (steps 1-5 above; ~27 us a call): the slow reference of
    :func:`cos_sin_enclosure_many` and its fallback outside its range.

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


# --------------------------------------------------------------------------------------------
# The vectorized enclosure (double-double arithmetic; derivation in the module docstring, part B)
# --------------------------------------------------------------------------------------------

#: Largest |a| of the vector path (radians; larger angles take the exact routine). Reason: it keeps
#: |k| <= 2^20 * 2/pi + 1 < 2^20 = :data:`K_BITS`, so k times a 33-bit part of pi/2 is exact.
VECTOR_MAX_ANGLE = 2.0 ** 20
#: Bits of |k| the Cody-Waite parts leave room for (53 - 33 bits of each part).
K_BITS = 20
#: Bits of each Cody-Waite part of pi/2 (53 - K_BITS).
PART_BITS = 53 - K_BITS
#: pi/2 = P1 + P2 + P3 + P4 + P5 + delta, each part the next PART_BITS bits of pi/2 (truncated from
#: HALF_PI_320, so 0 <= delta < 2^-164 + 2^-320 <= HALF_PI_TAIL_BOUND).
HALF_PI_PARTS = tuple(math.ldexp((HALF_PI_320 >> (321 - PART_BITS * (j + 1))) & ((1 << PART_BITS) - 1),
                                 -(PART_BITS * (j + 1) - 1)) for j in range(5))
#: Upper bound of the truncation delta = pi/2 - sum(HALF_PI_PARTS) >= 0 (checked with mpmath in the tests).
HALF_PI_TAIL_BOUND = 2.0 ** -163
#: |a| at or below which the closed forms of step B0 are used. Reason: a^2/2 <= 2^-53 (cos a in
#: [pred 1, 1]) and |a|^3/6 < half the gap below |a| (sin a strictly between pred a and a).
TINY_ANGLE = 2.0 ** -26
#: Bound of |r| on the vector path (radians). Reason: |r| <= pi/4 + 2^-31 < R_MAX (part B1); the run
#: time check |r_hi| <= R_MAX (1 - 2^-40) keeps |r_hi + r_lo| <= R_MAX for the constants of part B3.
R_MAX = 0.7854
#: Smallest |r| of the vector path. Reason: keeps every product of the series far above the
#: subnormal range (TwoProduct is exact there); no float of the range comes near it.
R_MIN = 2.0 ** -200
#: Degree from which the series are summed in plain double (then double-double below it). Reason:
#: the plain-double part then errs by < 2^-80 relative, far below the gap of the results.
DD_DEGREE = 6
#: Degree of the truncated series (in r^2). Reason: r^30/30! < 2^-117 for |r| <= R_MAX.
SERIES_DEGREE = 14
#: Relative error of one double-double product, in units of u^2 (u = 2^-53, the unit roundoff;
#: DWTimesDW1 with Dekker's TwoProduct; part B2).
DD_MUL_ERROR_U2 = 9
#: Relative error of the double-double sums of the Horner steps, in units of u^2 (part B2; needs
#: |p| <= 0.31 |c|).
DD_ADD_ERROR_U2 = 5
#: Factor making a float bound computed with m <= 40 roundings of nonnegative numbers an upper bound:
#: (1 - u)^-41 < 1 + 2^-46.
BOUND_SLACK = 1.0 + 2.0 ** -46
#: A result is rounded to floats only if its error bound E <= |h| 2^-55 (< half the gap of h);
#: otherwise the exact routine decides that entry.
GAP_FRACTION = 2.0 ** -55

_SPLIT = float((1 << 27) + 1)      # Dekker's splitter for binary64


def series_error_bounds() -> tuple[float, float]:
    """(COS_ERROR, SIN_RELATIVE_ERROR) of part B3 in exact rational arithmetic, rounded up: their
    derivation, run by the tests (the module keeps its result as literals, so that importing it
    imports no ``fractions``: the default solve's imports are kept to what it uses)."""
    from fractions import Fraction

    def _fraction_up(x: Fraction) -> float:            # the smallest float >= x (x > 0)
        f = float(x)
        return f if Fraction(f) >= x else math.nextafter(f, math.inf)

    _U = Fraction(1, 1 << 53)                          # the unit roundoff u
    DD_MUL_ERROR = DD_MUL_ERROR_U2 * _U * _U
    n, m = SERIES_DEGREE, DD_DEGREE
    r = Fraction(R_MAX)
    x = r * r
    fact = [Fraction(math.factorial(j)) for j in range(2 * n + 60)]
    cosh = sum(x ** i / fact[2 * i] for i in range(25)) + 2 * x ** 25 / fact[50]        # >= cosh R
    sinh_r = sum(x ** i / fact[2 * i + 1] for i in range(25)) + 2 * x ** 25 / fact[51]  # >= sinh R / R
    eps = DD_MUL_ERROR
    j = 3 * m + 1
    gamma = j * eps / (1 - j * eps)                                   # gamma_{3M+1}(9u^2)
    plain = 2 * (n - m) + 1                                           # roundings of the plain-double part
    gamma_plain = plain * _U / (1 - plain * _U)
    grow = Fraction(101, 100)                                         # sum_i>=M |c_i| x^(i-M) <= 1.01 |c_M|
    t_cos = (gamma_plain * grow + _U * Fraction(11, 10)) / fact[2 * m] * x ** m * (1 + gamma)
    t_sin = (gamma_plain * grow + _U * Fraction(11, 10)) / fact[2 * m + 1] * x ** m * (1 + gamma)
    cos_err = gamma * cosh + t_cos + x ** (n + 1) / fact[2 * n + 2]
    q_err = gamma * sinh_r + t_sin + x ** (n + 1) / fact[2 * n + 3]
    sin_rel = q_err + eps * (1 + q_err)
    return _fraction_up(cos_err), _fraction_up(sin_rel * (1 + _U) / (1 - _U))


#: |computed cos r - cos r| for the computed double-double r (part B3; absolute, cos r >= 0.7):
#: :func:`series_error_bounds`, kept as a literal (tests/test_trig_enclosure.py recomputes it).
COS_ERROR = float.fromhex('0x1.20ce8916ae618p-82')
#: |computed sin r - sin r| / |r_hi| (part B3): :func:`series_error_bounds`, as COS_ERROR.
SIN_RELATIVE_ERROR = float.fromhex('0x1.637fa543bb2cap-86')


def dd_coefficients(odd: bool) -> tuple[tuple[float, float], ...]:
    """(hi, lo) of (-1)^i / (2i + odd)! for i < DD_DEGREE: hi + lo within u^2 |c| of the exact value
    (the derivation of the literals _COS_DD, _SIN_DD, recomputed by the tests)."""
    from fractions import Fraction

    out = []
    for i in range(DD_DEGREE):
        c = Fraction((-1) ** i, math.factorial(2 * i + odd))
        hi = float(c)
        out.append((hi, float(c - Fraction(hi))))
    return tuple(out)


_COS_DD = ((float.fromhex('0x1.0000000000000p+0'), float.fromhex('0x0.0p+0')), (float.fromhex('-0x1.0000000000000p-1'), float.fromhex('0x0.0p+0')), (float.fromhex('0x1.5555555555555p-5'), float.fromhex('0x1.5555555555555p-59')), (float.fromhex('-0x1.6c16c16c16c17p-10'), float.fromhex('0x1.f49f49f49f49fp-65')), (float.fromhex('0x1.a01a01a01a01ap-16'), float.fromhex('0x1.a01a01a01a01ap-76')), (float.fromhex('-0x1.27e4fb7789f5cp-22'), float.fromhex('-0x1.cbbc05b4fa99ap-76')))
_SIN_DD = ((float.fromhex('0x1.0000000000000p+0'), float.fromhex('0x0.0p+0')), (float.fromhex('-0x1.5555555555555p-3'), float.fromhex('-0x1.5555555555555p-57')), (float.fromhex('0x1.1111111111111p-7'), float.fromhex('0x1.1111111111111p-63')), (float.fromhex('-0x1.a01a01a01a01ap-13'), float.fromhex('-0x1.a01a01a01a01ap-73')), (float.fromhex('0x1.71de3a556c734p-19'), float.fromhex('-0x1.c154f8ddc6c00p-73')), (float.fromhex('-0x1.ae64567f544e4p-26'), float.fromhex('0x1.c062e06d1f209p-80')))
_COS_PLAIN = tuple((-1) ** i / math.factorial(2 * i) for i in range(DD_DEGREE, SERIES_DEGREE + 1))
_SIN_PLAIN = tuple((-1) ** i / math.factorial(2 * i + 1) for i in range(DD_DEGREE, SERIES_DEGREE + 1))


def _two_sum(a, b):
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


def _fast_two_sum(a, b):
    s = a + b
    return s, b - (s - a)


def _split(a):
    t = _SPLIT * a
    hi = t - (t - a)
    return hi, a - hi


def _two_product(a, b, a_split=None):
    p = a * b
    ah, al = _split(a) if a_split is None else a_split
    bh, bl = _split(b)
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


def _dd_mul(xh, xl, yh, yl, x_split=None):
    """DWTimesDW1 (part B2): relative error <= DD_MUL_ERROR for normalized inputs."""
    ch, c1 = _two_product(xh, yh, x_split)
    c3 = c1 + (xh * yl + xl * yh)
    return _fast_two_sum(ch, c3)


def _dd_add(ch, cl, ph, pl):
    """Sum of a double-double constant c and p with |p| <= 0.31 |c| (part B2): error <= DD_ADD_ERROR |c + p|."""
    sh, sl = _fast_two_sum(ch, ph)                # exact: |ph| <= 0.31 |c| (1 + u) < |ch|
    return _fast_two_sum(sh, sl + (cl + pl))


def _reduced_cos_sin(rh, rl, r_err):
    """cos r = P(x) and sin r = r Q(x), x = r^2, of the reduced argument r = rh + rl (double-double; floats or
    arrays alike) and their error bounds (r_err: the reduction's): (ch, cl, sh, sl, cos_err, sin_err)."""
    r_split = _split(rh)
    xh, xl = _dd_mul(rh, rl, rh, rl, r_split)
    x_split = _split(xh)
    ch, cl = _horner(xh, xl, x_split, _COS_DD, _COS_PLAIN)
    qh, ql = _horner(xh, xl, x_split, _SIN_DD, _SIN_PLAIN)
    sh, sl = _dd_mul(rh, rl, qh, ql, r_split)
    cos_err = (COS_ERROR + r_err) * BOUND_SLACK
    sin_err = (abs(rh) * SIN_RELATIVE_ERROR + r_err) * BOUND_SLACK
    return ch, cl, sh, sl, cos_err, sin_err


def _horner(xh, xl, x_split, dd_coefs, plain_coefs):
    """Part B3: sum_i c_i x^i for the double-double x (plain double from DD_DEGREE up)."""
    t = plain_coefs[-1] + 0.0 * xh                                # (an array for an array xh)
    for c in plain_coefs[-2::-1]:
        t = t * xh + c
    yh, yl = t, 0.0 * t
    for ch, cl in dd_coefs[::-1]:
        ph, pl = _dd_mul(xh, xl, yh, yl, x_split)
        yh, yl = _dd_add(ch, cl, ph, pl)
    return yh, yl


def _round_out(h, l, err):
    """Part B5: floats lo <= v <= hi for every v with |v - (h + l)| <= err, where h = RN(h + l)
    and err <= |h| GAP_FRACTION (entries where that fails are marked in the returned mask)."""
    ok = err <= np.abs(h) * GAP_FRACTION
    lo = np.where(l >= err, h, np.nextafter(h, -math.inf))
    hi = np.where(-l >= err, h, np.nextafter(h, math.inf))
    return np.maximum(lo, -1.0), np.minimum(hi, 1.0), ok


@dataclass(frozen=True)
class DoubleDoubleCosSin:
    """Part B1-B4 for a 1-D float array of n angles (radians): cos a within ``cos_error`` of
    cos_hi + cos_lo and sin a within ``sin_error`` of sin_hi + sin_lo, each hi = fl(hi + lo) (all
    float arrays (n,)), where ``valid`` (bool (n,)) holds; elsewhere (|a| beyond VECTOR_MAX_ANGLE, r
    outside [R_MIN, R_MAX]) the values are meaningless."""

    cos_hi: np.ndarray
    cos_lo: np.ndarray
    cos_error: np.ndarray
    sin_hi: np.ndarray
    sin_lo: np.ndarray
    sin_error: np.ndarray
    valid: np.ndarray


def cos_sin_double_double(a: np.ndarray) -> DoubleDoubleCosSin:
    """Parts B1-B4 of the module docstring for a 1-D array of finite floats ``a`` (radians)."""
    valid = np.abs(a) <= VECTOR_MAX_ANGLE
    # B1: Cody-Waite reduction r = a - k pi/2, |k| < 2^K_BITS
    x = np.where(valid, a, 0.0)
    k = np.rint(x * (2.0 / math.pi))
    p1, p2, p3, p4, p5 = (k * part for part in HALF_PI_PARTS)     # exact (33-bit parts, |k| < 2^20)
    r1 = x - p1                                                   # exact (part B1)
    s2, e2 = _two_sum(r1, -p2)
    s3, e3 = _two_sum(s2, -p3)
    rh, rl = _two_sum(s3, ((e2 + e3) - p4) - p5)
    r_err = ((np.abs(e2) + np.abs(e3)) + (np.abs(p4) + np.abs(p5))) * 2.0 ** -51 + np.abs(k) * HALF_PI_TAIL_BOUND
    r_abs = np.abs(rh)
    valid &= (r_abs <= R_MAX * (1.0 - 2.0 ** -40)) & (r_abs >= R_MIN)
    rh = np.where(valid, rh, 0.5)                                 # harmless values off the vector path
    rl = np.where(valid, rl, 0.0)
    # B2-B3: x = r^2, cos r = P(x), sin r = r Q(x)
    ch, cl, sh, sl, cos_err, sin_err = _reduced_cos_sin(rh, rl, r_err)
    # B4: quadrant (negation exact; the error bound follows its value)
    quadrant = np.mod(k, 4.0)
    swap = (quadrant == 1.0) | (quadrant == 3.0)
    c_h, c_l, c_e = np.where(swap, sh, ch), np.where(swap, sl, cl), np.where(swap, sin_err, cos_err)
    s_h, s_l, s_e = np.where(swap, ch, sh), np.where(swap, cl, sl), np.where(swap, cos_err, sin_err)
    c_neg = (quadrant == 1.0) | (quadrant == 2.0)
    s_neg = (quadrant == 2.0) | (quadrant == 3.0)
    c_h, c_l = np.where(c_neg, -c_h, c_h), np.where(c_neg, -c_l, c_l)
    s_h, s_l = np.where(s_neg, -s_h, s_h), np.where(s_neg, -s_l, s_l)
    return DoubleDoubleCosSin(c_h, c_l, c_e, s_h, s_l, s_e, valid)


def cos_sin_enclosure_many(a) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(cos_lo, cos_hi, sin_lo, sin_hi): float arrays of a's shape enclosing cos and sin of each entry
    of the float array ``a`` (radians), elementwise.

    Rigorous (module docstring, part B) and, like :func:`cos_sin_enclosure_exact`, normally the two
    floats adjacent to each exact value: on the vector path never more than 2 gaps wide (lo >= pred h,
    hi <= succ h for the double-double value's float h), one float wider than adjacent on a side only where the
    exact value lies within the error bound (< 2^-70 relative) of a float. Every entry's result
    depends on that entry alone (the same floats alone or in any array). Entries with
    |a| > VECTOR_MAX_ANGLE (or failing a checked range) take the exact routine; a = 0 gives
    (1, 1, 0, 0). ValueError for a non-finite entry or |a| > MAX_ANGLE.
    """
    a = np.asarray(a, dtype=float)
    shape = a.shape
    a = a.ravel()
    finite = np.isfinite(a)
    if not finite.all():
        cos_sin_enclosure_exact(float(a[~finite][0]))            # raises the ValueError
    dd = cos_sin_double_double(a)
    # B5: outward rounding
    c_lo, c_hi, c_ok = _round_out(dd.cos_hi, dd.cos_lo, dd.cos_error)
    s_lo, s_hi, s_ok = _round_out(dd.sin_hi, dd.sin_lo, dd.sin_error)
    fast = dd.valid & c_ok & s_ok
    # B0: zero and tiny angles
    tiny = np.abs(a) <= TINY_ANGLE
    c_lo[tiny], c_hi[tiny] = np.nextafter(1.0, 0.0), 1.0
    s_lo[tiny] = np.where(a[tiny] > 0, np.nextafter(a[tiny], -math.inf), a[tiny])
    s_hi[tiny] = np.where(a[tiny] > 0, a[tiny], np.nextafter(a[tiny], math.inf))
    zero = a == 0.0
    c_lo[zero], c_hi[zero], s_lo[zero], s_hi[zero] = 1.0, 1.0, 0.0, 0.0
    # the rest: the exact routine, entry by entry
    for n in np.flatnonzero(~(fast | tiny)).tolist():
        c_lo[n], c_hi[n], s_lo[n], s_hi[n] = cos_sin_enclosure_exact(float(a[n]))
    return c_lo.reshape(shape), c_hi.reshape(shape), s_lo.reshape(shape), s_hi.reshape(shape)


def _cos_sin_one(a: float) -> tuple[float, float, float, float]:
    """cos_sin_enclosure_many at one finite float ``a``: the same operations in the same order on
    Python floats (binary64, round to nearest, like numpy's; round() and np.rint both round half to
    even), so the same floats (tests/test_trig_enclosure.py checks this bit for bit), ~20x faster
    than a numpy call on one entry."""
    mag = abs(a)
    if a == 0.0:
        return 1.0, 1.0, 0.0, 0.0
    if mag <= TINY_ANGLE:
        s_lo, s_hi = (math.nextafter(a, -math.inf), a) if a > 0 else (a, math.nextafter(a, math.inf))
        return math.nextafter(1.0, 0.0), 1.0, s_lo, s_hi
    if mag > VECTOR_MAX_ANGLE:
        return cos_sin_enclosure_exact(a)
    k = float(round(a * (2.0 / math.pi)))
    p1, p2, p3, p4, p5 = (k * part for part in HALF_PI_PARTS)
    r1 = a - p1
    s2, e2 = _two_sum(r1, -p2)
    s3, e3 = _two_sum(s2, -p3)
    rh, rl = _two_sum(s3, ((e2 + e3) - p4) - p5)
    r_err = ((abs(e2) + abs(e3)) + (abs(p4) + abs(p5))) * 2.0 ** -51 + abs(k) * HALF_PI_TAIL_BOUND
    if not (R_MIN <= abs(rh) <= R_MAX * (1.0 - 2.0 ** -40)):
        return cos_sin_enclosure_exact(a)
    ch, cl, sh, sl, cos_err, sin_err = _reduced_cos_sin(rh, rl, r_err)
    quadrant = k % 4.0
    if quadrant == 1.0 or quadrant == 3.0:
        (c_h, c_l, c_e), (s_h, s_l, s_e) = (sh, sl, sin_err), (ch, cl, cos_err)
    else:
        (c_h, c_l, c_e), (s_h, s_l, s_e) = (ch, cl, cos_err), (sh, sl, sin_err)
    if quadrant == 1.0 or quadrant == 2.0:
        c_h, c_l = -c_h, -c_l
    if quadrant == 2.0 or quadrant == 3.0:
        s_h, s_l = -s_h, -s_l
    out = []
    for h, l, err in ((c_h, c_l, c_e), (s_h, s_l, s_e)):
        if not err <= abs(h) * GAP_FRACTION:
            return cos_sin_enclosure_exact(a)
        lo = h if l >= err else math.nextafter(h, -math.inf)
        hi = h if -l >= err else math.nextafter(h, math.inf)
        out += [max(lo, -1.0), min(hi, 1.0)]
    return out[0], out[1], out[2], out[3]


def cos_sin_enclosure(a: float) -> tuple[float, float, float, float]:
    """(cos_lo, cos_hi, sin_lo, sin_hi) of one float ``a`` (radians): the floats of
    :func:`cos_sin_enclosure_many` at ``a`` (the same alone or in any array). ValueError as there."""
    a = float(a)
    if not math.isfinite(a):
        cos_sin_enclosure_exact(a)                                # raises the ValueError
    return _cos_sin_one(a)
