"""Outward-rounded interval arithmetic on numpy float64 arrays, vectorized over any leading axes.

Representation: an *interval array* of element shape S is a float64 ndarray of shape (2, *S);
``x[0]`` holds the lower and ``x[1]`` the upper endpoints (lo <= hi). Operands broadcast like
numpy arrays of shape S (missing leading element axes are inserted after the endpoint axis).

Why it is rigorous: IEEE 754 binary64 +, - and * are correctly rounded; in the default mode
(round to nearest, gradual underflow) the computed v = fl(exact) satisfies
pred(v) <= exact <= succ(v), so moving each computed lower endpoint one ulp towards -inf and each
upper endpoint one ulp towards +inf (``np.nextafter``, exact) encloses the exact result. Every
operation below is one rounding followed by that widening (negation and min/max are exact), so
each result contains every value of the operation on points of the operand intervals. Overflow
gives infinite endpoints (still an enclosure); callers reject non-finite results.
:func:`rounding_environment_ok` checks the assumption (a library compiled with -ffast-math can
switch on flush-to-zero, which breaks it); callers must use a different method when it fails.

The only transcendental functions are cos and sin (:func:`cos_sin`, :func:`cos_sin_ball`): at
a float point a they come from :func:`spherekin.core.trig_enclosure.cos_sin_enclosure_many`
(double-double arithmetic with a proven error bound, outward-rounded; the fixed-point integer
routine beyond its range), the same floats for a point alone or in any array, then
over [a - r, a + r] from cos(a + d) = cos a cos d - sin a sin d,
sin(a + d) = sin a cos d + cos a sin d with cos d in [1 - r^2/2, 1] and |sin d| <= min(r, 1),
both true for every real d with |d| <= r, evaluated in this arithmetic.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .angles import wrap
from .trig_enclosure import cos_sin_enclosure, cos_sin_enclosure_many

__all__ = [
    "POINT_CACHE_SIZE",
    "SMALL_TABLE",
    "point",
    "from_bounds",
    "outward",
    "neg",
    "add",
    "sub",
    "mul",
    "scale",
    "isum",
    "sum_up",
    "matmul",
    "fmatmul",
    "magnitude",
    "point_cos_sin",
    "cos_sin_table",
    "cos_sin_ball",
    "cos_sin",
    "rounding_environment_ok",
    "add_unchecked",
    "sub_unchecked",
    "mul_unchecked",
    "scale_unchecked",
    "isum_unchecked",
    "cos_sin_table_unchecked",
    "ARC_PAD",
    "cross_float",
    "rotate_about",
    "arc",
]

#: Entries kept by the cache of :func:`point_cos_sin`. Reason: the constant angles of a
#: mechanism (joint offsets, known factor angles, ~a dozen per loop system) recur in every
#: certification of one solve and across radii; 2**14 entries (~2 MB) hold thousands of systems.
POINT_CACHE_SIZE = 1 << 14

#: Entries up to which :func:`cos_sin_table` takes the point enclosures one by one from the cache of
#: :func:`point_cos_sin` (the same floats as the array routine). Reason: one numpy call of
#: cos_sin_enclosure_many costs ~0.3 ms whatever its size, one uncached point ~16 us, a cached one
#: ~0.3 us (few-entry tables recur in tracking steps, with their constant angles).
SMALL_TABLE = 32

_INF = math.inf
_DIRECTIONS: dict[tuple, np.ndarray] = {}


def _directions(shape: tuple) -> np.ndarray:
    """An array of ``shape`` (2, ...) holding -inf in [0] and +inf in [1] (cached: numpy's
    nextafter is several times faster on equal shapes than with broadcasting)."""
    d = _DIRECTIONS.get(shape)
    if d is None:
        if len(_DIRECTIONS) > 256:
            _DIRECTIONS.clear()
        d = np.empty(shape)
        d[0], d[1] = -_INF, _INF
        d.flags.writeable = False
        _DIRECTIONS[shape] = d
    return d


def _as_interval(key: str, a) -> np.ndarray:
    arr = np.asarray(a, dtype=float)
    if arr.ndim == 0 or arr.shape[0] != 2:
        raise ValueError(f"{key}: expected an interval array of shape (2, ...) (lower, upper endpoints), got shape {arr.shape}")
    return arr


def _align(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Insert unit element axes after the endpoint axis so that a and b broadcast like their elements."""
    if a.shape == b.shape:
        return a, b
    if a.ndim < b.ndim:
        a = a.reshape((2,) + (1,) * (b.ndim - a.ndim) + a.shape[1:])
    elif b.ndim < a.ndim:
        b = b.reshape((2,) + (1,) * (a.ndim - b.ndim) + b.shape[1:])
    return a, b


# --------------------------------------------------------------------------------------------
# Construction
# --------------------------------------------------------------------------------------------

def point(x) -> np.ndarray:
    """The degenerate interval array [x, x] (exact) of a float array ``x``."""
    x = np.asarray(x, dtype=float)
    return np.stack((x, x))


def from_bounds(lo, hi) -> np.ndarray:
    """The interval array [lo, hi]; ValueError unless lo <= hi elementwise (NaN fails)."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    if lo.shape != hi.shape:
        raise ValueError(f"lo, hi: expected the same shape, got {lo.shape} and {hi.shape}")
    if not np.all(lo <= hi):
        raise ValueError("lo, hi: expected lo <= hi elementwise (and no NaN)")
    return np.stack((lo, hi))


def outward(v: np.ndarray) -> np.ndarray:
    """[pred(v[0]), succ(v[1])]: the enclosure of exact results whose rounded endpoints are ``v``."""
    return np.nextafter(v, _directions(v.shape))


# --------------------------------------------------------------------------------------------
# Arithmetic (each result encloses {x op y : x in a, y in b})
# --------------------------------------------------------------------------------------------

def neg(a) -> np.ndarray:
    """-a = [-hi, -lo] (exact)."""
    return _neg(_as_interval("a", a))


def add(a, b) -> np.ndarray:
    """a + b = [lo_a + lo_b, hi_a + hi_b], outward-rounded."""
    return add_unchecked(*_align(_as_interval("a", a), _as_interval("b", b)))


def sub(a, b) -> np.ndarray:
    """a - b = [lo_a - hi_b, hi_a - lo_b], outward-rounded."""
    return sub_unchecked(*_align(_as_interval("a", a), _as_interval("b", b)))


def mul(a, b) -> np.ndarray:
    """a * b = [min, max] of the four endpoint products, outward-rounded."""
    return mul_unchecked(*_align(_as_interval("a", a), _as_interval("b", b)))


def scale(c, a) -> np.ndarray:
    """c * a for a float array ``c`` (exact numbers, not rounded data): [min, max](c lo, c hi), outward."""
    c = np.asarray(c, dtype=float)
    a = _as_interval("a", a)
    if c.ndim > a.ndim - 1:
        a = a.reshape((2,) + (1,) * (c.ndim - a.ndim + 1) + a.shape[1:])
    return scale_unchecked(c, a)


def isum(a, axis: int = -1) -> np.ndarray:
    """Sum over element axis ``axis`` by pairwise outward-rounded additions (0 for an empty axis)."""
    a = _as_interval("a", a)
    if not -(a.ndim - 1) <= axis < a.ndim - 1:
        raise ValueError(f"axis: expected an element axis in [{-(a.ndim - 1)}, {a.ndim - 1}), got {axis}")
    return isum_unchecked(a, axis + 1 if axis >= 0 else a.ndim + axis)


def sum_up(x, axis: int = -1) -> np.ndarray:
    """An upper bound (float array) on the exact sum of the floats ``x`` over ``axis``.

    Pairwise additions, each rounded result moved one ulp towards +inf (0 for an empty axis).
    """
    x = np.asarray(x, dtype=float)
    if not -x.ndim <= axis < x.ndim:
        raise ValueError(f"axis: expected an axis in [{-x.ndim}, {x.ndim}), got {axis}")
    ax = axis % x.ndim
    head = (slice(None),) * ax
    n = x.shape[ax]
    if n == 0:
        return np.zeros(x.shape[:ax] + x.shape[ax + 1:])
    while n > 1:
        h = n // 2
        s = np.nextafter(x[head + (slice(0, h),)] + x[head + (slice(h, 2 * h),)], _INF)
        x = s if n % 2 == 0 else np.concatenate((s, x[head + (slice(2 * h, n),)]), axis=ax)
        n = x.shape[ax]
    return x[head + (0,)]


# Kernels: the same operations without argument checks, on float64 interval arrays whose shapes
# broadcast with the endpoint axis first (callers align them); public for the hot loops of
# spherekin.trust.transversal, which check their arguments once per call, not once per operation.

def _neg(a: np.ndarray) -> np.ndarray:
    return -a[::-1]


def add_unchecked(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """:func:`add` without argument checks."""
    return outward(a + b)


def sub_unchecked(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """:func:`sub` without argument checks."""
    return outward(a - b[::-1])


def mul_unchecked(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """:func:`mul` without argument checks."""
    a0, a1 = a[0], a[1]
    b0, b1 = b[0], b[1]
    p, q, r, s = a0 * b0, a0 * b1, a1 * b0, a1 * b1
    out = np.empty((2,) + p.shape)
    np.minimum(np.minimum(p, q), np.minimum(r, s), out=out[0])
    np.maximum(np.maximum(p, q, out=p), np.maximum(r, s, out=r), out=out[1])
    return np.nextafter(out, _directions(out.shape), out=out)


def scale_unchecked(c: np.ndarray, a: np.ndarray) -> np.ndarray:
    """:func:`scale` without argument checks."""
    p, q = c * a[0], c * a[1]
    out = np.empty((2,) + p.shape)
    np.minimum(p, q, out=out[0])
    np.maximum(p, q, out=out[1])
    return np.nextafter(out, _directions(out.shape), out=out)


def isum_unchecked(a: np.ndarray, ax: int) -> np.ndarray:
    """Sum over array axis ``ax`` (>= 1) of the interval array a."""
    head = (slice(None),) * ax
    n = a.shape[ax]
    if n == 0:
        return np.zeros(a.shape[:ax] + a.shape[ax + 1:])
    x = a
    while n > 1:
        h = n // 2
        s = outward(x[head + (slice(0, h),)] + x[head + (slice(h, 2 * h),)])
        x = s if n % 2 == 0 else np.concatenate((s, x[head + (slice(2 * h, n),)]), axis=ax)
        n = x.shape[ax]
    return x[head + (0,)]


def matmul(a, b) -> np.ndarray:
    """Interval matrix product: a (..., m, k) @ b (..., k, n), each entry an outward-rounded dot product."""
    a, b = _as_interval("a", a), _as_interval("b", b)
    if a.ndim < 3 or b.ndim < 3 or a.shape[-1] != b.shape[-2]:
        raise ValueError(f"a, b: expected interval matrices (2, ..., m, k) and (2, ..., k, n), got {a.shape} and {b.shape}")
    a, b = _align(a[..., :, :, None], b[..., None, :, :])
    return isum_unchecked(mul_unchecked(a, b), a.ndim - 2)


def fmatmul(c, a) -> np.ndarray:
    """Float matrix times interval matrix: c (..., m, k) @ a (..., k, n) (c exact numbers), outward-rounded."""
    c, a = np.asarray(c, dtype=float), _as_interval("a", a)
    if c.ndim < 2 or a.ndim < 3 or c.shape[-1] != a.shape[-2]:
        raise ValueError(f"c, a: expected a float matrix (..., m, k) and an interval matrix (2, ..., k, n), got {c.shape} and {a.shape}")
    p = scale(c[..., :, :, None], a[..., None, :, :])
    return isum_unchecked(p, p.ndim - 2)


def magnitude(a) -> np.ndarray:
    """max(|lo|, |hi|) = max |x| over x in a (exact)."""
    a = _as_interval("a", a)
    return np.maximum(np.abs(a[0]), np.abs(a[1]))


# --------------------------------------------------------------------------------------------
# cos and sin
# --------------------------------------------------------------------------------------------

@functools.lru_cache(maxsize=POINT_CACHE_SIZE)
def point_cos_sin(a: float) -> tuple[float, float, float, float]:
    """(cos_lo, cos_hi, sin_lo, sin_hi): floats enclosing cos(a) and sin(a) for a float ``a``.

    :func:`spherekin.core.trig_enclosure.cos_sin_enclosure` (normally the two floats adjacent to each
    exact value; the same floats as :func:`cos_sin_table` gives at radius 0), cached: a pure function of a.
    """
    return cos_sin_enclosure(a)


def cos_sin_table(center, radius) -> np.ndarray:
    """One interval array (2, 2, *shape) enclosing (cos, sin) over [center - radius, center + radius].

    Index [:, 0] is cos and [:, 1] sin; see :func:`cos_sin_ball` for the math.
    """
    center = np.asarray(center, dtype=float)
    radius = np.asarray(radius, dtype=float)
    if radius.shape != center.shape:
        radius = radius + np.zeros(center.shape)
    if not (np.isfinite(center).all() and np.isfinite(radius).all()):
        raise ValueError("center, radius: expected finite angles and radii (radians)")
    if not (radius >= 0).all():
        raise ValueError("radius: expected radii >= 0 (radians)")
    return cos_sin_table_unchecked(center, radius)


def cos_sin_table_unchecked(center: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """cos_sin_table without argument checks (center, radius: finite float arrays of one shape, radius >= 0)."""
    shape = center.shape
    # (2 endpoints, 2 functions (cos, sin), *shape): cos(a), sin(a) at the points
    if center.size <= SMALL_TABLE:      # the same floats entry by entry (cached), cheaper for few entries
        table = np.array([point_cos_sin(a) for a in center.ravel().tolist()], dtype=float).reshape((-1, 2, 2))
        point_cs = table.transpose(2, 1, 0).reshape((2, 2) + shape)
    else:
        point_cs = np.stack(cos_sin_enclosure_many(center)).reshape((2, 2) + shape)   # (c_lo, c_hi, s_lo, s_hi)
        point_cs = np.ascontiguousarray(point_cs.transpose((1, 0) + tuple(range(2, point_cs.ndim))))
    # cos d in [k, 1] with k = 1 - r^2/2 rounded down (exactly 1 when r = 0)
    half_r2 = np.nextafter(np.nextafter(radius * radius, _INF) * 0.5, _INF)
    k = np.maximum(np.nextafter(1.0 - half_r2, -_INF), -1.0)
    k[radius == 0] = 1.0
    if (k >= 0).all():
        # x [k, 1] for 0 <= k <= 1: [min(k lo, lo), max(k hi, hi)] (the bilinear extremes);
        # exact where k = 1 (r = 0), so no widening there
        main = k * point_cs
        np.minimum(main[0], point_cs[0], out=main[0])
        np.maximum(main[1], point_cs[1], out=main[1])
        np.nextafter(main, _directions(main.shape), out=main, where=k != 1.0)    # (cos a cos d, sin a cos d)
    else:
        cos_d = np.ones((2, 1) + shape)
        cos_d[0, 0] = k
        main = mul(point_cs, cos_d)
    # |sin a sin d| <= rho |sin a|max (for cos), |cos a sin d| <= rho |cos a|max (for sin); 0 when r = 0
    rho = np.minimum(radius, 1.0)
    spread = np.nextafter(rho * np.maximum(np.abs(point_cs[0]), np.abs(point_cs[1]))[::-1], _INF)
    spread[:, rho == 0] = 0.0
    out = np.empty_like(main)
    np.subtract(main[0], spread, out=out[0])
    np.add(main[1], spread, out=out[1])
    np.nextafter(out, _directions(out.shape), out=out, where=spread != 0)
    np.minimum(out, 1.0, out=out)
    np.maximum(out, -1.0, out=out)
    return out


def cos_sin_ball(center, radius) -> tuple[np.ndarray, np.ndarray]:
    """Interval arrays enclosing cos and sin over [center - radius, center + radius], elementwise.

    ``center``: finite floats; ``radius``: floats >= 0 broadcasting to center's shape. With
    a = center and |d| <= r = radius: cos(a + d) = cos a cos d - sin a sin d and
    sin(a + d) = sin a cos d + cos a sin d, where cos d in [1 - r^2/2, 1] and
    |sin d| <= rho = min(r, 1), so |x sin d| <= rho max|x| for x in an interval; results are
    intersected with [-1, 1]. cos a and sin a come from
    :func:`spherekin.core.trig_enclosure.cos_sin_enclosure_many` (the floats of :func:`point_cos_sin`).
    """
    table = cos_sin_table(center, radius)
    return table[:, 0], table[:, 1]


def cos_sin(a, center=None) -> tuple[np.ndarray, np.ndarray]:
    """Interval arrays enclosing cos and sin over the interval array ``a`` of angles (radians).

    ``center``: a float array inside ``a`` about which to expand (default: the midpoints); the
    radius is max(center - lo, hi - center), rounded up.
    """
    a = _as_interval("a", a)
    if not np.all(np.isfinite(a)) or not np.all(a[0] <= a[1]):
        raise ValueError("a: expected finite angles with lo <= hi")
    if center is None:
        center = np.clip(a[0] * 0.5 + a[1] * 0.5, a[0], a[1])
    else:
        center = np.broadcast_to(np.asarray(center, dtype=float), a.shape[1:])
        if not np.all((a[0] <= center) & (center <= a[1])):
            raise ValueError("center: expected points inside the intervals (lo <= center <= hi)")
    radius = np.maximum(np.nextafter(center - a[0], _INF), np.nextafter(a[1] - center, _INF))
    return cos_sin_ball(center, radius)


# --------------------------------------------------------------------------------------------
# Rotations and angles of interval vectors (the joint readings' enclosures)
# --------------------------------------------------------------------------------------------

#: Width (radians) added to each side of an enclosed angle (:func:`arc`): the arc's ends are atan2 of
#: outward-rounded corners, each rounded (~1e-16); 1e-12 covers that with room and is far below the
#: joint ranges' tolerance (RANGE_TOL, 1e-10), so an angle proven inside is inside.
ARC_PAD = 1e-12


def cross_float(a, v) -> np.ndarray:
    """a x v for a float vector a (3,) and interval vectors v (2, ..., 3), outward-rounded."""
    a = np.asarray(a, dtype=float)
    comps = [sub(scale(a[j], v[..., k]), scale(a[k], v[..., j])) for j, k in ((1, 2), (2, 0), (0, 1))]
    return np.stack(comps, axis=-1)


def rotate_about(axis, c, s, v) -> np.ndarray:
    """Rot(axis, theta) v (Rodrigues) for a float unit ``axis`` (3,), intervals c, s (2, N) of cos and
    sin theta and interval vectors v (2, N, 3)."""
    axis = np.asarray(axis, dtype=float)
    along = isum(scale(axis, v), -1)                                        # axis . v (2, N)
    one_minus = sub(point(np.ones(c.shape[1:])), c)
    out = add(mul(c[..., None], v), mul(s[..., None], cross_float(axis, v)))
    return add(out, scale(axis, mul(one_minus, along)[..., None]))


def arc(x, y) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) (N,) enclosing atan2(Y, X) over the boxes X x Y (intervals (2, N)), padded by
    :data:`ARC_PAD`; NaN where a box holds the origin (every angle). The extremes of the angle over a
    box that misses the origin are at its corners."""
    corners = np.arctan2(np.stack([y[0], y[0], y[1], y[1]]), np.stack([x[0], x[1], x[0], x[1]]))
    mid = np.arctan2(0.5 * (y[0] + y[1]), 0.5 * (x[0] + x[1]))
    off = wrap(corners - mid)                                               # each corner next to the middle
    lo, hi = mid + off.min(axis=0) - ARC_PAD, mid + off.max(axis=0) + ARC_PAD
    origin = (x[0] <= 0) & (x[1] >= 0) & (y[0] <= 0) & (y[1] >= 0)
    return np.where(origin, np.nan, lo), np.where(origin, np.nan, hi)


# --------------------------------------------------------------------------------------------
# Floating-point environment
# --------------------------------------------------------------------------------------------

def _bits_to_floats(bits) -> np.ndarray:
    """float64 values with the given IEEE bit patterns (no arithmetic, so no rounding or flushing)."""
    return np.array(bits, dtype=np.uint64).view(np.float64)


# Probes of rounding_environment_ok, tiled to 16 entries so numpy uses its vector loops:
# 1 + 1.5u -> 1 + 2u (rounds up), -1 - 1.5u -> -1 - 2u (rounds down), 1 + u -> 1 (tie to even),
# with u = 2^-53; 2^-1022 * 0.5 -> 2^-1023 (no flush to zero), 2^-1023 * 2 -> 2^-1022 (a
# subnormal input is not read as zero).
_ONE, _MINUS_ONE, _ONE_PLUS_ULP, _MINUS_ONE_MINUS_ULP = 0x3FF0000000000000, 0xBFF0000000000000, 0x3FF0000000000001, 0xBFF0000000000001
_THREE_HALF_U, _MINUS_THREE_HALF_U, _U = 0x3CA8000000000000, 0xBCA8000000000000, 0x3CA0000000000000
_TINY, _SUBNORMAL, _HALF, _TWO = 0x0010000000000000, 0x0008000000000000, 0x3FE0000000000000, 0x4000000000000000
_PROBE_REPEAT = 4
_ADD_X = _bits_to_floats([_ONE, _MINUS_ONE, _ONE, _ONE] * _PROBE_REPEAT)
_ADD_Y = _bits_to_floats([_THREE_HALF_U, _MINUS_THREE_HALF_U, _U, 0] * _PROBE_REPEAT)
_ADD_EXPECTED = np.array([_ONE_PLUS_ULP, _MINUS_ONE_MINUS_ULP, _ONE, _ONE] * _PROBE_REPEAT, dtype=np.uint64)
_MUL_X = _bits_to_floats([_TINY, _SUBNORMAL] * 2 * _PROBE_REPEAT)
_MUL_Y = _bits_to_floats([_HALF, _TWO] * 2 * _PROBE_REPEAT)
_MUL_EXPECTED = np.array([_SUBNORMAL, _TINY] * 2 * _PROBE_REPEAT, dtype=np.uint64)


def rounding_environment_ok() -> bool:
    """True when numpy float64 arithmetic rounds to nearest (ties to even) with gradual underflow.

    Compares bit patterns of probe results: 1 + 1.5u rounds up and -1 - 1.5u rounds down (no
    directed rounding), 1 + u ties to 1 (not upward), 2^-1022 / 2 stays subnormal (no flush to
    zero) and 2^-1023 * 2 = 2^-1022 (subnormal inputs are not read as zero); u = 2^-53.
    """
    return ((_ADD_X + _ADD_Y).tobytes() == _ADD_EXPECTED.tobytes()
            and (_MUL_X * _MUL_Y).tobytes() == _MUL_EXPECTED.tobytes())
