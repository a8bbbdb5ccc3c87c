"""Closure equations of one spherical loop in Bernstein form (paper Sections 2.2 and 3).

A loop is the normalized closure equation (Eq. 2) F_n(Phi) = prod_{i=1..n} Rx(phi_i) Z = I in which
each factor angle phi_i is either a known number (actuator input, link twist) or
``offset + sign * theta`` for an unknown passive joint angle theta. Each unknown is parameterized by
t = tan((theta - shift) / 2) over its range, and t is mapped affinely to x in [0, 1]; the polynomials
below are tensor-product Bernstein polynomials in those x (see :mod:`spherekin.core.bernstein`), with
degree 2 in every unknown and one tensor axis per unknown, in order of first appearance in the loop.

Everything rests on the per-factor univariate polynomials (the "factor polynomials")

    q(t) = 1 + t^2,  c(t) = (1 + t^2) cos(phi),  s(t) = (1 + t^2) sin(phi)

(constants 1, cos phi, sin phi for a known factor: no tan(phi/2) is ever taken of a known angle,
so a known angle of exactly pi is harmless). Two independent routes build the loop polynomials:

* :func:`f11_f13_recursion` -- the paper's route: Prop. 2 / Cor. 1-2, generalized to known factors,
  arbitrary ranges and shifts (the paper's g1, g2, h1, h2 are q_{k-1} (x) (-c_k), q_{k-1} (x) s_k,
  s_k and -c_k, see the function's docstring);
* :func:`matrix_control_points` -- the product route: (1 + t^2) Rx(phi) Z is a degree-2 Bernstein
  matrix polynomial sum_k A_k b_k(x), so the control matrices of the whole product are the products
  of the factors' control matrices; this yields all nine entries at once.

:func:`scalar_control_points` assembles the scalar equation of Eq. (10),
f = f11bar + f22bar - 2 q_n, by either route.

Departure from the paper: the paper obtains f22bar from f11bar by the shift sigma,
c_I(f22bar) = c_{I^sigma}(f11bar) (Eq. 9/10), which presumes every factor is an unknown over the same
range. Here f22bar is f11bar *of the cyclically rotated factor list* (phi_n, phi_1, ..., phi_{n-1}),
followed by the same index shift (:func:`sigma_shift`); it reduces to the paper's formula in the
paper's setting and stays correct with known factors and per-variable ranges.

The low-level functions take factor polynomials as numpy arrays of any dtype; with ``dtype=object``
arrays of :class:`fractions.Fraction` they compute exactly (used by the tests against sympy).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence, Union

import numpy as np

from .core import bernstein
from .core.angles import wrap
from .core.rotations import normalized_closure

__all__ = [
    "KNOWN_ANGLE_SNAP",
    "KNOWN_ENTRY_FLOOR",
    "snapped_cos_sin",
    "tan_half_angle",
    "tan_half_unit",
    "Unknown",
    "Term",
    "FactorPolynomials",
    "known_factor",
    "variable_factor",
    "f11_f13_recursion",
    "matrix_control_points",
    "matrix_magnitude",
    "q_control_points",
    "sigma_shift",
    "scalar_control_points",
    "ClosureLoop",
    "ROUTES",
    "TRANSVERSAL_ENTRIES",
    "closure_at",
    "ClosurePlan",
    "closure_plan",
    "closure_many",
]

#: |cos| or |sin| of a known angle below this is taken as exactly 0 (and the other as +-1).
#: Reason: float multiples of pi/2 (np.pi, 3*np.pi/2, ...) have a cosine or sine of order 1e-16 * k
#: instead of 0; snapping keeps the structural zeros of the control points exact. The change to
#: the equations is below 1e-14, far below any tolerance a solver can use.
KNOWN_ANGLE_SNAP = 1e-14
#: In :func:`matrix_magnitude`, the cos and sin of a known angle count as at least this. Reason: an
#: error d in one of them (d <= KNOWN_ANGLE_SNAP) changes a control point by at most d times the
#: product of the other factors' magnitudes, i.e. by at most d / KNOWN_ENTRY_FLOOR times the control
#: point's magnitude M; over the ~8 known factors of a 3-RRR loop that is <= 8e-14 / 0.25 M = 3.2e-13 M
#: at the worst, and ~1e-15 M for the plain rounding of an angle (the snap moves only exact
#: multiples of pi/2, whose cos or sin is ~1e-16 k), so that the solver's rounding tolerance
#: (ROUNDING_SAFETY eps M = 2.2e-13 M) covers the known angles' errors as well as the products'
#: rounding. A floor of 1 would also do, at ~10x wider tolerances (slower final contraction).
KNOWN_ENTRY_FLOOR = 0.25

ROUTES = ("recursion", "product")
#: Entries (row, column) of F_n (or q_n F_n) that vanish at closure with a Jacobian of full rank on
#: so(3): the strictly lower triangle (F = I + [w]x gives (f21, f31, f32) = (w_z, -w_y, w_x)). The
#: transversal formulation's equations (:mod:`spherekin.search.formulations`) and their interval
#: enclosure (:mod:`spherekin.trust.transversal`) read them from here.
TRANSVERSAL_ENTRIES = ((1, 0), (2, 0), (2, 1))


# --------------------------------------------------------------------------------------------
# Unknowns and factor terms
# --------------------------------------------------------------------------------------------


def tan_half_angle(x, shift, t_lo, t_hi) -> np.ndarray:
    """theta = shift + 2 atan(t), t = t_lo + (t_hi - t_lo) x (Section 2.2): the angle (radians) at
    unit-box coordinate(s) x in [0, 1]; arrays that broadcast together.

    The one place of the tan-half unit-box -> angle map: :meth:`Unknown.to_angle` and the tan-half
    charts (:class:`spherekin.search.parameterizations.TanHalf`) both call it.
    """
    t = t_lo + (t_hi - t_lo) * np.asarray(x, dtype=float)
    return shift + 2.0 * np.arctan(t)


def tan_half_unit(theta, shift, t_lo, t_hi) -> np.ndarray:
    """The inverse of :func:`tan_half_angle`: unit-box coordinate(s) x of angle(s) theta (radians,
    taken modulo 2 pi into [shift - pi, shift + pi)); arrays that broadcast together."""
    rel = wrap(np.asarray(theta, dtype=float) - shift)                               # in [-pi, pi)
    return (np.tan(0.5 * rel) - t_lo) / (t_hi - t_lo)

def _finite_float(name: str, value) -> float:
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a finite real number, got {value!r}") from None
    if not math.isfinite(out):
        raise ValueError(f"{name}: expected a finite real number, got {value!r}")
    return out


def snapped_cos_sin(angle: float) -> tuple[float, float]:
    """cos and sin of a known angle, with values within KNOWN_ANGLE_SNAP of 0 made exact."""
    c, s = math.cos(angle), math.sin(angle)
    if abs(c) < KNOWN_ANGLE_SNAP:
        c, s = 0.0, math.copysign(1.0, s)
    elif abs(s) < KNOWN_ANGLE_SNAP:
        c, s = math.copysign(1.0, c), 0.0
    return c, s


class _AngleArithmetic:
    """``theta + a``, ``a - theta``, ``-theta`` build a :class:`Term` (an affine factor angle)."""

    __array_ufunc__ = None  # make numpy scalars defer to our reflected operators

    def _term(self) -> "Term":
        raise NotImplementedError

    def __add__(self, other):
        t = self._term()
        return Term(t.unknown, t.offset + _finite_float("offset", other), t.sign)

    __radd__ = __add__

    def __sub__(self, other):
        return self + (-_finite_float("offset", other))

    def __neg__(self):
        t = self._term()
        return Term(t.unknown, -t.offset, -t.sign)

    def __rsub__(self, other):
        return (-self) + other


@dataclass(frozen=True, eq=False)
class Unknown(_AngleArithmetic):
    """A passive joint angle theta (radians) with range [lo, hi], hi - lo < 2 pi.

    The variable of the polynomials is t = tan((theta - shift) / 2) on
    [t_lo, t_hi] = [tan((lo - shift)/2), tan((hi - shift)/2)], mapped affinely to x in [0, 1].
    ``shift=None`` picks 0 when lo > -pi and hi < pi (the paper's plain tangent-half-angle
    substitution) and the range midpoint otherwise: the shift suggested at the end of Section 2.2
    to avoid the singularity of tan(theta/2) at pi.

    Unknowns compare by identity: two loops share a variable by sharing the object.
    """

    name: str
    lo: float
    hi: float
    shift: float | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"name: expected a non-empty string, got {self.name!r}")
        lo = _finite_float(f"{self.name}.lo", self.lo)
        hi = _finite_float(f"{self.name}.hi", self.hi)
        if not lo < hi:
            raise ValueError(f"{self.name}: expected lo < hi, got lo={lo!r}, hi={hi!r}")
        if not hi - lo < 2 * math.pi:
            raise ValueError(
                f"{self.name}: expected a range narrower than 2*pi (tan(theta/2) is singular "
                f"somewhere on a full turn), got [{lo!r}, {hi!r}]"
            )
        if self.shift is None:
            shift = 0.0 if (lo > -math.pi and hi < math.pi) else 0.5 * (lo + hi)
        else:
            shift = _finite_float(f"{self.name}.shift", self.shift)
        if not (lo - shift > -math.pi and hi - shift < math.pi):
            raise ValueError(
                f"{self.name}: range [{lo!r}, {hi!r}] reaches the singularity of "
                f"tan((theta - shift)/2) at shift +- pi with shift={shift!r}; "
                "pass shift=None to choose one automatically"
            )
        object.__setattr__(self, "lo", lo)
        object.__setattr__(self, "hi", hi)
        object.__setattr__(self, "shift", shift)

    def _term(self) -> "Term":
        return Term(self)

    @property
    def t_range(self) -> tuple[float, float]:
        """(t_lo, t_hi): the range of t = tan((theta - shift)/2)."""
        return (math.tan(0.5 * (self.lo - self.shift)), math.tan(0.5 * (self.hi - self.shift)))

    def to_angle(self, x) -> np.ndarray:
        """theta (radians) at unit-box coordinate(s) x in [0, 1] (:func:`tan_half_angle`)."""
        return tan_half_angle(x, self.shift, *self.t_range)

    def to_unit(self, theta) -> np.ndarray:
        """Unit-box coordinate(s) x of angle(s) theta (radians, taken modulo 2 pi into the range;
        :func:`tan_half_unit`)."""
        return tan_half_unit(theta, self.shift, *self.t_range)

    def __repr__(self):
        return f"Unknown({self.name!r}, lo={self.lo!r}, hi={self.hi!r}, shift={self.shift!r})"


@dataclass(frozen=True)
class Term(_AngleArithmetic):
    """A factor angle phi = offset + sign * theta for an unknown theta (sign is +1 or -1)."""

    unknown: Unknown
    offset: float = 0.0
    sign: int = 1

    def __post_init__(self):
        if not isinstance(self.unknown, Unknown):
            raise ValueError(f"unknown: expected an Unknown, got {self.unknown!r}")
        object.__setattr__(self, "offset", _finite_float("offset", self.offset))
        if self.sign not in (1, -1):
            raise ValueError(f"sign: expected +1 or -1, got {self.sign!r}")

    def _term(self) -> "Term":
        return self

    def factor_polynomials(self) -> "FactorPolynomials":
        """Factor polynomials of this term over the unknown's range (see :func:`variable_factor`)."""
        cos_d, sin_d = snapped_cos_sin(self.offset + self.sign * self.unknown.shift)
        t_lo, t_hi = self.unknown.t_range
        return variable_factor(t_lo, t_hi, cos_d, sin_d, self.sign)


# --------------------------------------------------------------------------------------------
# Factor polynomials (pure functions, any dtype)
# --------------------------------------------------------------------------------------------

class FactorPolynomials:
    """q = (1+t^2), c = (1+t^2) cos phi, s = (1+t^2) sin phi of one factor of Eq. (2).

    For a variable factor each is a length-3 array of univariate Bernstein control points (degree 2
    in x on [0, 1]); for a known factor each is a 0-d array (the constants 1, cos phi, sin phi).
    """

    __slots__ = ("q", "c", "s")

    q: np.ndarray
    c: np.ndarray
    s: np.ndarray

    def __init__(self, q, c, s):
        self.q = q
        self.c = c
        self.s = s

    @property
    def is_variable(self) -> bool:
        return np.ndim(self.q) == 1


def known_factor(cos_phi, sin_phi) -> FactorPolynomials:
    """Factor polynomials of a known angle, given by its cosine and sine (exact types are kept)."""
    c = np.asarray(cos_phi)
    s = np.asarray(sin_phi)
    dtype = object if object in (c.dtype, s.dtype) else float
    one = np.array(1 if dtype is object else 1.0, dtype=dtype)
    return FactorPolynomials(one, np.asarray(cos_phi, dtype=dtype), np.asarray(sin_phi, dtype=dtype))


def variable_factor(t_lo, t_hi, cos_shift=1, sin_shift=0, sign=1) -> FactorPolynomials:
    """Factor polynomials of phi = delta + sign * 2 atan(t), t = t_lo + (t_hi - t_lo) x, x in [0, 1].

    With cos(delta), sin(delta) given as ``cos_shift``, ``sin_shift``:
        (1+t^2) cos phi = cos(delta) (1 - t^2) - sign sin(delta) 2t
        (1+t^2) sin phi = sin(delta) (1 - t^2) + sign cos(delta) 2t
    With delta = 0, sign = 1 and [t_lo, t_hi] = [0, 1] these are Prop. 1's q, and -h2, h1 of Cor. 1.
    Returns length-3 Bernstein arrays; exact if the inputs are Fractions.
    """
    a, w = t_lo, t_hi - t_lo
    if not _is_exact(t_lo, t_hi, cos_shift, sin_shift):
        return _variable_factor_float(float(a), float(w), float(cos_shift), float(sin_shift), sign)
    one_plus = np.array([1 + a * a, 2 * a * w, w * w], dtype=object)      # 1 + t^2 in powers of x
    one_minus = np.array([1 - a * a, -2 * a * w, -w * w], dtype=object)   # 1 - t^2
    two_t = np.array([2 * a, 2 * w, 0 * w], dtype=object)                 # 2 t
    c_pow = cos_shift * one_minus - sign * sin_shift * two_t
    s_pow = sin_shift * one_minus + sign * cos_shift * two_t
    dtype = object if _is_exact(t_lo, t_hi, cos_shift, sin_shift) else float
    return FactorPolynomials(*(bernstein.from_power(p.astype(dtype)) for p in (one_plus, c_pow, s_pow)))


def _variable_factor_float(a: float, w: float, cd: float, sd: float, sign: int) -> FactorPolynomials:
    """Float fast path of :func:`variable_factor` (the solver builds thousands of factors).

    For p(x) = p0 + p1 x + p2 x^2 the degree-2 Bernstein coefficients are (p0, p0 + p1/2,
    p0 + p1 + p2); with t = a + w x: 1 + t^2 -> (1 + a^2, 2aw, w^2), 1 - t^2 -> (1 - a^2, -2aw, -w^2),
    2t -> (2a, 2w, 0). Same formulas as the exact path, evaluated in floats.
    """
    pw = np.array([[1 + a * a, 2 * a * w, w * w], [1 - a * a, -2 * a * w, -w * w], [2 * a, 2 * w, 0.0]])
    one_plus, one_minus, two_t = pw
    c_pow = cd * one_minus - sign * sd * two_t
    s_pow = sd * one_minus + sign * cd * two_t
    p = np.stack([one_plus, c_pow, s_pow])
    b = np.stack([p[:, 0], p[:, 0] + 0.5 * p[:, 1], p[:, 0] + p[:, 1] + p[:, 2]], axis=1)
    return FactorPolynomials(b[0], b[1], b[2])


def _is_exact(*values) -> bool:
    """True if any value is an exact number (Fraction, sympy Rational), not an int or float."""
    return any(not isinstance(v, (int, float, np.integer, np.floating)) for v in values)


def _outer(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Tensor product of polynomials in disjoint variables (0-d arrays act as scalars)."""
    return np.multiply.outer(a, b)


def f11_f13_recursion(factors: Sequence[FactorPolynomials]) -> tuple[np.ndarray, np.ndarray]:
    """Control points of f11bar and f13bar of F_n (Cor. 2, generalized).

    Implements Prop. 2 / Cor. 1-2: with F_k = prod_{i<=k} Rx(phi_i) Z and fbar = q_k f,
        f11bar_k = f11bar_{k-2} (x) q_{k-1} (x) (-c_k) + f13bar_{k-1} (x) s_k
        f13bar_k = f11bar_{k-2} (x) q_{k-1} (x) s_k    - f13bar_{k-1} (x) (-c_k)
    ((x) = tensor product; the paper's g1 = q_{k-1} (x) h2, g2 = q_{k-1} (x) h1, h1 = s_k, h2 = -c_k).
    Base cases (found by expanding F_0 = I and F_1 = Rx(phi_1) Z, whose first row is (0, -1, 0)):
        f11bar_0 = 1, f13bar_0 = 0, f11bar_1 = 0 * q_1, f13bar_1 = 0 * q_1.
    Returns tensors with one axis of length 3 per variable factor, in factor order.
    """
    if len(factors) == 0:
        raise ValueError("factors: expected at least one factor, got none")
    dtype = _common_dtype(factors)
    zero = np.array(0 if dtype is object else 0.0, dtype=dtype)
    one = np.array(1 if dtype is object else 1.0, dtype=dtype)
    f11_prev = one                                    # k = 0 (f13bar_0 = 0 is never read)
    f11_cur, f13_cur = zero * factors[0].q, zero * factors[0].q  # k = 1
    for k in range(1, len(factors)):
        g_base = _outer(f11_prev, factors[k - 1].q)
        fk = factors[k]
        f11_next = _outer(g_base, -fk.c) + _outer(f13_cur, fk.s)
        f13_next = _outer(g_base, fk.s) + _outer(f13_cur, fk.c)
        f11_prev, (f11_cur, f13_cur) = f11_cur, (f11_next, f13_next)
    return f11_cur, f13_cur


def _control_matrices(f: FactorPolynomials) -> np.ndarray:
    """Control matrices of (1+t^2) Rx(phi) Z = [[0,-q,0],[c,0,-s],[s,0,c]]: shape (*q.shape, 3, 3)."""
    out = np.zeros(np.shape(f.q) + (3, 3), dtype=np.result_type(f.q, f.c, f.s))
    out[..., 0, 1] = -f.q
    out[..., 1, 0] = f.c
    out[..., 1, 2] = -f.s
    out[..., 2, 0] = f.s
    out[..., 2, 2] = f.c
    return out


def matrix_control_points(factors: Sequence[FactorPolynomials]) -> np.ndarray:
    """Control points of all nine entries of q_n F_n (product route), shape (3, 3, 3, ..., 3).

    Each factor (1+t^2) Rx(phi) Z = sum_k A_k b_{k,2}(x); a product of polynomials in distinct
    variables has as control points the products of the factors' control points, so the control
    matrix at multi-index (k_1..k_v) is the ordered product of the chosen A's. Entry [i, j] of the
    result is the Bernstein tensor of q_n f_ij (one axis per variable factor, in factor order).
    """
    if len(factors) == 0:
        raise ValueError("factors: expected at least one factor, got none")
    dtype = _common_dtype(factors)
    prod = np.eye(3, dtype=dtype) if dtype is not object else np.eye(3, dtype=int).astype(object)
    for f in factors:
        a = _control_matrices(f)
        prod = prod[..., None, :, :] @ a if f.is_variable else prod @ a
    return np.moveaxis(np.moveaxis(prod, -1, 0), -1, 0)


def _magnitude_matrix(f: FactorPolynomials) -> np.ndarray:
    """The largest |control matrix| (3, 3) of one factor over its control points, with each entry
    bounded in a way that does not shrink with cos phi or sin phi: max(|q|, |c|, |s|) over the
    control points for every entry of a variable factor; max(|cos phi|, KNOWN_ENTRY_FLOOR) and
    max(|sin phi|, KNOWN_ENTRY_FLOOR) for a known factor."""
    if f.is_variable:
        m = max(float(np.max(np.abs(np.asarray(a, dtype=float)))) for a in (f.q, f.c, f.s))
        c = s = q = m
    else:
        q = 1.0
        c, s = (max(abs(float(v)), KNOWN_ENTRY_FLOOR) for v in (f.c, f.s))
    return np.array([[0.0, q, 0.0], [c, 0.0, s], [s, 0.0, c]])


def matrix_magnitude(factors: Sequence[FactorPolynomials]) -> np.ndarray:
    """A bound M (3, 3) on the size of the terms behind every control point of entry (i, j) of
    :func:`matrix_control_points`: the ordered product of each factor's largest |control matrix|
    (:func:`_magnitude_matrix`; nonnegative matrices, so the product bounds every product of
    control matrices in absolute value), with the cos and sin of every angle counted as at least
    KNOWN_ENTRY_FLOOR.

    Why: a control point is a sum of products of the factors' entries, and its computed value errs
    by at most ~(number of factors) * eps times the sum of those products' absolute values (the
    standard running error bound), not times the control point itself; the cos and sin of a known
    angle (an input plus an offset, rounded once in float) err by ~1e-16 absolutely, however small
    they are, and :data:`KNOWN_ANGLE_SNAP` moves them by up to 1e-14. Near an input where an entry of
    the loop is small on a whole chart (the cos of an input near pi/2), the entry's own control
    points are far smaller than their rounding: a tolerance taken from them let the pruners discard
    boxes that hold roots, and the box loop call roots spurious (issue 26).
    """
    if len(factors) == 0:
        raise ValueError("factors: expected at least one factor, got none")
    prod = np.eye(3)
    for f in factors:
        prod = prod @ _magnitude_matrix(f)
    return prod


def q_control_points(factors: Sequence[FactorPolynomials]) -> np.ndarray:
    """Control points of q_n = prod (1 + t_i^2) over the variable factors (Prop. 1, generalized).

    On the paper's unit ranges this is 2^chi(I), chi(I) = number of indices equal to 2.
    """
    out = np.array(1, dtype=_common_dtype(factors))
    for f in factors:
        out = _outer(out, f.q)
    return out


def sigma_shift(c: np.ndarray) -> np.ndarray:
    """The index shift of Section 3: out[I] = c[I^sigma], I^sigma = (i_n, i_1, ..., i_{n-1}).

    Gives the control points of g(t^sigma) = g(t_n, t_1, ..., t_{n-1}) from those of g when all
    variables share one range (Eq. 9/10).
    """
    return np.moveaxis(c, 0, -1) if np.ndim(c) else c


def scalar_control_points(factors: Sequence[FactorPolynomials], route: str = "recursion") -> np.ndarray:
    """Control points of f = f11bar + f22bar - 2 q_n, the scalar closure equation (Eq. 8-10).

    ``route="recursion"`` follows the paper (Cor. 2 for f11bar, the sigma shift for f22bar, Prop. 1
    for q_n; see the module docstring for the generalized shift); ``route="product"`` reads f11bar
    and f22bar off :func:`matrix_control_points`. f <= 0 on the whole box, with equality exactly
    at closure (f11 + f22 = 2 forces f11 = f22 = 1, hence F = I for a rotation).
    """
    if route not in ROUTES:
        raise ValueError(f"route: expected one of {ROUTES}, got {route!r}")
    q = q_control_points(factors)
    if route == "product":
        m = matrix_control_points(factors)
        return m[0, 0] + m[1, 1] - 2 * q
    f11, _ = f11_f13_recursion(factors)
    rotated = [factors[-1], *factors[:-1]]
    f22_rot, _ = f11_f13_recursion(rotated)
    f22 = sigma_shift(f22_rot) if factors[-1].is_variable else f22_rot
    return f11 + f22 - 2 * q


def _common_dtype(factors: Sequence[FactorPolynomials]):
    dtypes = {np.asarray(a).dtype for f in factors for a in (f.q, f.c, f.s)}
    return object if np.dtype(object) in dtypes else float


# --------------------------------------------------------------------------------------------
# A loop of a mechanism
# --------------------------------------------------------------------------------------------

Factor = Union[float, Unknown, Term]


@dataclass(frozen=True)
class ClosureLoop:
    """One closure equation prod_i Rx(phi_i) Z = I (Eq. 2) with known and unknown factor angles.

    ``factors`` is a sequence whose items are a real number (a known angle, radians), an
    :class:`Unknown` theta (phi = theta) or a :class:`Term` such as ``theta + pi/2`` or
    ``pi/2 - theta``. Each unknown may appear at most once in a loop (so every polynomial has
    degree 2 in it); the same Unknown object in several loops is a shared variable.
    """

    factors: tuple

    def __post_init__(self):
        items = tuple(self.factors) if not isinstance(self.factors, (str, bytes)) else None
        if not items:
            raise ValueError(f"factors: expected a non-empty sequence of angles and unknowns, got {self.factors!r}")
        norm, seen = [], set()
        for i, f in enumerate(items):
            if isinstance(f, Unknown):
                f = Term(f)
            if isinstance(f, Term):
                if id(f.unknown) in seen:
                    raise ValueError(
                        f"factors[{i}]: unknown {f.unknown.name!r} appears twice in one loop; "
                        "each unknown may appear at most once per loop"
                    )
                seen.add(id(f.unknown))
            else:
                f = _finite_float(f"factors[{i}]", f)
            norm.append(f)
        names = [t.unknown.name for t in norm if isinstance(t, Term)]
        if len(set(names)) != len(names):
            raise ValueError(f"factors: distinct unknowns share a name in {names}")
        object.__setattr__(self, "factors", tuple(norm))

    @property
    def n(self) -> int:
        """Number of factors of Eq. (2)."""
        return len(self.factors)

    @property
    def unknowns(self) -> tuple[Unknown, ...]:
        """The loop's unknowns, in tensor-axis order (order of appearance)."""
        return tuple(f.unknown for f in self.factors if isinstance(f, Term))

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(u.name for u in self.unknowns)

    def factor_polynomials(self) -> list[FactorPolynomials]:
        return [f.factor_polynomials() if isinstance(f, Term) else known_factor(*snapped_cos_sin(f))
                for f in self.factors]

    def matrix_control_points(self) -> np.ndarray:
        """Control points of q_n F_n, shape (3, 3) + (3,) * len(unknowns)."""
        return matrix_control_points(self.factor_polynomials())

    def scalar_control_points(self, route: str = "recursion") -> np.ndarray:
        """Control points of the scalar equation of Eq. (10), shape (3,) * len(unknowns)."""
        return scalar_control_points(self.factor_polynomials(), route)

    def q_control_points(self) -> np.ndarray:
        return q_control_points(self.factor_polynomials())

    def angles(self, x) -> np.ndarray:
        """Factor angles phi_1..phi_n (radians) at unit-box point(s) x, shape (..., k) -> (..., n)."""
        x = self._check_points(x)
        cols = []
        for f in self.factors:
            if isinstance(f, Term):
                theta = f.unknown.to_angle(x[..., self.unknowns.index(f.unknown)])
                cols.append(f.offset + f.sign * theta)
            else:
                cols.append(np.full(x.shape[:-1], f))
        return np.stack(cols, axis=-1)

    def closure_matrix(self, x) -> np.ndarray:
        """F_n at unit-box point(s) x by direct matrix multiplication, shape (..., 3, 3)."""
        return normalized_closure(self.angles(x))

    def _check_points(self, x) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        k = len(self.unknowns)
        if x.ndim == 0 or x.shape[-1] != k:
            raise ValueError(f"x: expected shape (..., {k}) (one coordinate per unknown), got {x.shape}")
        if not np.all(np.isfinite(x)):
            raise ValueError("x: expected finite coordinates")
        return x

    def summary(self) -> dict:
        """Unknowns, number of control points and the control-point enclosure of Eq. (10)."""
        c = self.scalar_control_points()
        lo, hi = bernstein.bounds(c) if c.ndim else (float(c), float(c))
        return {
            "n_factors": self.n,
            "unknowns": self.names,
            "n_control_points": int(np.size(c)),
            "enclosure": (float(lo), float(hi)),
        }


# --------------------------------------------------------------------------------------------
# F_n and dF_n/dtheta at angles (floats)
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class ClosurePlan:
    """The factors of loops (Eq. 2) as arrays, for :func:`closure_many` (L loops padded to n factors).

    ``offsets`` (L, n): the constant part of each factor angle (radians: a known angle, or a term's
    offset; 0 for padding); ``slots`` (L, n): the position of the factor's unknown among the
    unknowns, -1 for a known angle, -2 for padding (a factor I); ``signs`` (L, n): +-1 for a term,
    0 otherwise; ``n_unknowns``: M. Systems of one mechanism at different inputs have the same
    slots and signs and differ only in their offsets (the inputs are known angles).
    """

    offsets: np.ndarray
    slots: np.ndarray
    signs: np.ndarray
    n_unknowns: int

    def same_structure(self, other: "ClosurePlan") -> bool:
        """Whether ``other`` has the same factors up to the constants (offsets may differ)."""
        return (self.n_unknowns == other.n_unknowns and self.slots.shape == other.slots.shape
                and bool(np.array_equal(self.slots, other.slots)) and bool(np.array_equal(self.signs, other.signs)))


def closure_plan(loops: Sequence["ClosureLoop"], unknowns: Sequence[Unknown],
                 loop_indices: Sequence[Sequence[int]] | None = None) -> ClosurePlan:
    """The :class:`ClosurePlan` of ``loops``: a term's unknown is found among ``unknowns`` by identity,
    or, given ``loop_indices`` (as :attr:`spherekin.mechanism.LoopSystem.loop_indices`), it is
    ``unknowns[loop_indices[l][j]]`` for the j-th term of loop l."""
    n = max((len(loop.factors) for loop in loops), default=0)
    offsets = np.zeros((len(loops), n))
    slots = np.full((len(loops), n), -2, dtype=np.intp)
    signs = np.zeros((len(loops), n))
    for li, loop in enumerate(loops):
        j = 0
        for i, f in enumerate(loop.factors):
            if isinstance(f, Term):
                slots[li, i] = (loop_indices[li][j] if loop_indices is not None
                                else next(k for k, u in enumerate(unknowns) if u is f.unknown))
                offsets[li, i], signs[li, i] = f.offset, f.sign
                j += 1
            else:
                offsets[li, i], slots[li, i] = float(f), -1
    return ClosurePlan(offsets, slots, signs, len(unknowns))


def closure_many(plan: ClosurePlan, theta, offsets=None, jacobian: bool = False):
    """F_n = prod_i Rx(phi_i) Z of Eq. (2) for every loop at P points: ``theta`` (P, M) passive
    angles (radians); ``offsets`` (P, L, n): each point's constant angles (default ``plan.offsets``
    for every point: one system). Shape (P, L, 3, 3); with ``jacobian``, also dF_n/dtheta, shape
    (P, L, 3, 3, M), as ``(F, J)``.

    phi_i = offset_i + sign_i theta_k(i); with M_i = Rx(phi_i) Z, the derivative is the sum over
    the factors of unknown k of sign_i M_1 ... M_{i-1} (dRx/dphi)(phi_i) Z M_{i+1} ... M_n (prefix
    and suffix products), evaluated for every point and loop at once, one factor at a time.
    """
    theta = np.asarray(theta, dtype=float)
    n_pts = len(theta)
    n_loops, n = plan.slots.shape
    offs = np.broadcast_to(plan.offsets, (n_pts, n_loops, n)) if offsets is None else offsets
    terms = plan.slots >= 0
    phis = offs + np.where(terms, plan.signs * theta[:, np.where(terms, plan.slots, 0)], 0.0)
    c, s = np.cos(phis), np.sin(phis)
    # Rx(phi) Z = [[0, -1, 0], [c, 0, -s], [s, 0, c]]; padding: I
    mats = np.zeros((n_pts, n_loops, n, 3, 3))
    mats[..., 0, 1] = -1.0
    mats[..., 1, 0], mats[..., 1, 2] = c, -s
    mats[..., 2, 0], mats[..., 2, 2] = s, c
    pad = plan.slots == -2
    if pad.any():
        mats[:, pad] = np.eye(3)
    prefix = [np.broadcast_to(np.eye(3), (n_pts, n_loops, 3, 3))]
    for i in range(n):
        prefix.append(prefix[-1] @ mats[:, :, i])
    f = np.array(prefix[-1])
    if not jacobian:
        return f
    # (d/dphi Rx(phi)) Z = [[0, 0, 0], [-s, 0, -c], [c, 0, -s]]
    jac_t = np.zeros((n_loops, plan.n_unknowns, n_pts, 3, 3))                # (L, M, P, 3, 3)
    suffix = np.broadcast_to(np.eye(3), (n_pts, n_loops, 3, 3))
    for i in range(n - 1, -1, -1):
        ls = np.flatnonzero(terms[:, i])
        if len(ls):
            d = np.zeros((n_pts, len(ls), 3, 3))
            d[..., 1, 0], d[..., 1, 2] = -s[:, ls, i], -c[:, ls, i]
            d[..., 2, 0], d[..., 2, 2] = c[:, ls, i], -s[:, ls, i]
            t = prefix[i][:, ls] @ d @ suffix[:, ls]
            jac_t[ls, plan.slots[ls, i]] += (plan.signs[ls, i][:, None, None, None] * t.transpose(1, 0, 2, 3))
        suffix = mats[:, :, i] @ suffix
    return f, jac_t.transpose(2, 0, 3, 4, 1)


def closure_at(loops: Sequence["ClosureLoop"], unknowns: Sequence[Unknown], theta, jacobian: bool = False,
               loop_indices: Sequence[Sequence[int]] | None = None):
    """F_n = prod_i Rx(phi_i) Z of Eq. (2) for every loop at the passive angles ``theta`` (radians,
    one per entry of ``unknowns``), shape (L, 3, 3); with ``jacobian``, also dF_n/dtheta, shape
    (L, 3, 3, M), as ``(F, J)``.

    A factor is a known angle or a :class:`Term` offset + sign * theta_k: k is the position of the
    term's unknown among ``unknowns`` (by identity), or, given ``loop_indices`` (as
    :attr:`spherekin.mechanism.LoopSystem.loop_indices`), ``loop_indices[l][j]`` for the j-th term
    of loop l. With M_i = Rx(phi_i) Z, the derivative is the sum over the factors of
    unknown k of sign_i M_1 ... M_{i-1} (dRx/dphi)(phi_i) Z M_{i+1} ... M_n (prefix and suffix
    products). :func:`closure_many` at one point, the one float evaluation of the closure equations
    at angles: polishing (:mod:`spherekin.trust.polish`) and the transversal system
    (:mod:`spherekin.trust.transversal`) call it.
    """
    theta = np.asarray(theta, dtype=float)
    out = closure_many(closure_plan(loops, unknowns, loop_indices), theta[None], jacobian=jacobian)
    return (out[0][0], out[1][0]) if jacobian else out[0]
