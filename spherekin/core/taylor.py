"""Second-order Taylor forms over a set of small parameters: x(p) = c + L p + p^T Q p + r, |r| <= rad.

(Real or complex: c, L and Q may be complex; r is then a complex number of modulus <= rad.)

Interval arithmetic forgets that two quantities depend on the same parameters: x - x over an interval
is twice its width, not 0. A Taylor form keeps the dependence to second order: each quantity is its
value at p = 0, its gradient and its quadratic part in the parameters, and a bound on everything
else (third order and rounding). The parameters lie in a *tolerance set*: a product of disks (two
parameters, a tilt (s, t) with s^2 + t^2 <= r^2) and intervals (one parameter, |p| <= r), so that
the reach of a linear term over the set is exact, max |L p| = sum over the blocks of r_j |L_j|_2,
and that of a quadratic term is bounded block by block, |p^T Q p| <= sum_jk r_j r_k |Q_jk|_F
(:meth:`ToleranceSet.reach`, :meth:`ToleranceSet.reach_quadratic`). A product keeps the product of
the linear parts as a quadratic term and bounds the rest (third and fourth order) by reaches.

Why the second order: the certified bounds of :mod:`spherekin.trust.tolerances` are a linear maximum
plus what the forms leave in their bounds; with first-order forms that rest is second order but
compounds a reach product at every multiplication (a factor ~4 over the truth on sensitive
assemblies); with the quadratic part carried exactly it is bounded once, at the end.

Why our own: the affine-arithmetic packages on PyPI (affapy) work on one scalar at a time, to first
order and on boxes; this needs numpy arrays of forms (vectors, matrices) and the disks' exact reach.

Rounding: every operation adds :data:`ROUND` times the magnitude of its result (centre, reaches,
bound) to the bound: far above the rounding of the few dozen float operations behind each entry
(Higham's gamma_n, n <= 40: ~1e-14 relative).

Shapes: a form of shape S has ``c`` (S), ``lin`` (S + (P,)), ``quad`` (S + (P, P)) and ``rad`` (S)
(P parameters).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["ROUND", "ToleranceSet", "TaylorForm", "stack", "cos_sin_shift", "cos_sin", "inverse_norm"]

#: Relative allowance for rounding added to each result's bound (see the module doc).
ROUND = 1e-14


@dataclass(frozen=True, eq=False)
class ToleranceSet:
    """The parameters' set: ``blocks`` ((columns, radius) pairs: two columns a disk, one an interval)
    over ``size`` parameters, every parameter in exactly one block."""

    blocks: tuple
    size: int

    def __post_init__(self):
        member = np.zeros((self.size, len(self.blocks)))
        for j, (cols, _) in enumerate(self.blocks):
            member[list(cols), j] = 1.0
        if not np.array_equal(member.sum(axis=1), np.ones(self.size)):
            raise ValueError("blocks: expected every parameter in exactly one block")
        object.__setattr__(self, "_member", member)
        object.__setattr__(self, "_radii", np.array([float(rad) for _, rad in self.blocks]))

    def reach(self, lin) -> np.ndarray:
        """max over the set of |lin . p| for each row of ``lin`` (..., P) (floats, rounded up):
        sum over the blocks of radius_j |lin_j|_2."""
        sq = _squares(lin)
        return (np.sqrt(sq @ self._member) @ self._radii) * (1.0 + ROUND)

    def reach_quadratic(self, quad) -> np.ndarray:
        """An upper bound over the set of |p^T quad p| for each matrix of ``quad`` (..., P, P):
        sum over block pairs of r_j r_k |quad_jk|_F (the Frobenius norm bounds the spectral one)."""
        per_pair = np.sqrt(self._member.T @ _squares(quad) @ self._member)          # (..., blocks, blocks)
        return ((per_pair @ self._radii) @ self._radii) * (1.0 + ROUND)

    def magnitude_bound(self, lin, quad) -> np.ndarray:
        """A cheap upper bound of |lin . p| + |p^T quad p| over the set (rmax |lin|_1 + rmax^2 |quad|_1):
        for the rounding allowance, not for the forms' reach."""
        r = float(self._radii.max(initial=0.0))
        return r * np.abs(lin).sum(axis=-1) + r * r * np.abs(quad).sum(axis=(-2, -1))

    def symbol(self, column: int) -> "TaylorForm":
        """The parameter ``column`` itself."""
        lin = np.zeros(self.size)
        lin[column] = 1.0
        return TaylorForm(self, np.array(0.0), lin, np.zeros((self.size, self.size)), np.array(0.0))

    def constant(self, value) -> "TaylorForm":
        """A float (or complex) array of exact numbers as forms."""
        value = _numbers(value)
        return TaylorForm(self, value, np.zeros(value.shape + (self.size,)),
                          np.zeros(value.shape + (self.size, self.size)), np.zeros(value.shape))


def _squares(x) -> np.ndarray:
    x = np.asarray(x)
    return (x.real ** 2 + x.imag ** 2) if np.iscomplexobj(x) else x * x


@dataclass(frozen=True, eq=False)
class TaylorForm:
    """x(p) = c + lin . p + p^T quad p + r with |r| <= rad, for every p in ``space`` (elementwise over arrays)."""

    space: ToleranceSet
    c: np.ndarray
    lin: np.ndarray
    quad: np.ndarray
    rad: np.ndarray

    def _rounded(self, c, lin, quad, rad) -> "TaylorForm":
        c, lin, quad, rad = _numbers(c), _numbers(lin), _numbers(quad), np.asarray(rad, dtype=float)
        sp = self.space
        rad = rad + ROUND * (np.abs(c) + sp.magnitude_bound(lin, quad) + rad)
        return TaylorForm(sp, c, lin, quad, rad)

    @property
    def shape(self) -> tuple:
        return self.c.shape

    def __getitem__(self, index) -> "TaylorForm":
        index = index if isinstance(index, tuple) else (index,)
        return TaylorForm(self.space, self.c[index], self.lin[index + (slice(None),)],
                          self.quad[index + (slice(None), slice(None))], self.rad[index])

    def _reaches(self) -> tuple[np.ndarray, np.ndarray]:
        """(reach of the linear part, bound of the quadratic part), computed once per form."""
        got = self.__dict__.get("_memo")
        if got is None:
            got = (self.space.reach(self.lin), self.space.reach_quadratic(self.quad))
            object.__setattr__(self, "_memo", got)
        return got

    def reach(self) -> np.ndarray:
        """max |x(p) - c| over the set (>= |lin . p| + |p^T quad p| + rad)."""
        rl, rq = self._reaches()
        return rl + rq + self.rad

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi): x(p) within them for every p of the set (real forms)."""
        r = self.reach() * (1.0 + ROUND)
        return self.c - r, self.c + r

    def disk(self) -> tuple[np.ndarray, np.ndarray]:
        """(centre, radius): x(p) within radius of the centre (real or complex) for every p of the set."""
        return self.c, self.reach() * (1.0 + ROUND)

    def __add__(self, other) -> "TaylorForm":
        o = _as_form(self.space, other)
        return self._rounded(self.c + o.c, self.lin + o.lin, self.quad + o.quad, self.rad + o.rad)

    def __sub__(self, other) -> "TaylorForm":
        o = _as_form(self.space, other)
        return self._rounded(self.c - o.c, self.lin - o.lin, self.quad - o.quad, self.rad + o.rad)

    def __neg__(self) -> "TaylorForm":
        return TaylorForm(self.space, -self.c, -self.lin, -self.quad, self.rad)

    def __mul__(self, other) -> "TaylorForm":
        """Elementwise product (numpy broadcasting of the shapes)."""
        o = _as_form(self.space, other)
        c = self.c * o.c
        lin = self.c[..., None] * o.lin + o.c[..., None] * self.lin
        quad = (self.c[..., None, None] * o.quad + o.c[..., None, None] * self.quad
                + self.lin[..., :, None] * o.lin[..., None, :])
        rla, rqa = self._reaches()
        rlb, rqb = o._reaches()
        rad = (np.abs(self.c) * o.rad + np.abs(o.c) * self.rad + rla * rqb + rqa * rlb + rqa * rqb
               + (rla + rqa + self.rad) * o.rad + self.rad * (rlb + rqb))
        return self._rounded(c, lin, quad, rad)

    def scale(self, k) -> "TaylorForm":
        """Times the float (or complex) array ``k`` (exact numbers; broadcasting)."""
        k = _numbers(k)
        return self._rounded(k * self.c, k[..., None] * self.lin, k[..., None, None] * self.quad, np.abs(k) * self.rad)

    def sum(self, axis: int = -1) -> "TaylorForm":
        """The sum over an axis of the shape."""
        axis = axis % len(self.shape)
        return self._rounded(self.c.sum(axis=axis), self.lin.sum(axis=axis), self.quad.sum(axis=axis),
                             self.rad.sum(axis=axis))

    def dot(self, other) -> "TaylorForm":
        """Sum over the last axis of the elementwise product (vectors (..., n))."""
        return (self * other).sum(-1)

    def cross(self, other) -> "TaylorForm":
        """Cross products of vectors (..., 3)."""
        o = _as_form(self.space, other)
        parts = [self[..., j] * o[..., k] - self[..., k] * o[..., j] for j, k in ((1, 2), (2, 0), (0, 1))]
        return stack(parts, -1)

    def contract(self, t) -> "TaylorForm":
        """The linear map of the float array ``t`` (out shape + this form's shape) applied to the form:
        sum over this form's axes of t * x (np.tensordot)."""
        t = _numbers(t)
        nd = self.c.ndim
        axes_t = list(range(t.ndim - nd, t.ndim))
        c = np.tensordot(t, self.c, axes=nd)
        lin = np.tensordot(t, self.lin, axes=(axes_t, list(range(nd))))
        quad = np.tensordot(t, self.quad, axes=(axes_t, list(range(nd))))
        rad = np.tensordot(np.abs(t), self.rad, axes=nd)
        return self._rounded(c, lin, quad, rad)

    def bmatvec(self, m) -> "TaylorForm":
        """Matrices ``m`` (..., n, k) (floats or complex, one per form of the leading shape) times the
        vectors (..., k)."""
        m = np.asarray(m)
        c = np.einsum("...nk,...k->...n", m, self.c)
        lin = np.einsum("...nk,...kp->...np", m, self.lin)
        quad = np.einsum("...nk,...kpq->...npq", m, self.quad)
        rad = np.einsum("...nk,...k->...n", np.abs(m), self.rad)
        return self._rounded(c, lin, quad, rad)

    def matvec(self, m) -> "TaylorForm":
        """The float matrix ``m`` (n, k) times the vectors (..., k)."""
        m = np.asarray(m)
        c = self.c @ m.T
        lin = np.einsum("nk,...kp->...np", m, self.lin)
        quad = np.einsum("nk,...kpq->...npq", m, self.quad)
        rad = self.rad @ np.abs(m).T
        return self._rounded(c, lin, quad, rad)


def _numbers(x) -> np.ndarray:
    """``x`` as a float array, or a complex one when it is complex."""
    x = np.asarray(x)
    return x if np.iscomplexobj(x) else x.astype(float, copy=False)


def _as_form(space: ToleranceSet, x) -> TaylorForm:
    return x if isinstance(x, TaylorForm) else space.constant(x)


def stack(forms, axis: int = 0) -> TaylorForm:
    """Forms of one shape stacked along a new axis of the shape."""
    space = forms[0].space
    nd = len(forms[0].shape) + 1
    axis = axis % nd
    return TaylorForm(space, np.stack([f.c for f in forms], axis=axis), np.stack([f.lin for f in forms], axis=axis),
                      np.stack([f.quad for f in forms], axis=axis), np.stack([f.rad for f in forms], axis=axis))


def cos_sin_shift(space: ToleranceSet, angle: float, column: int, radius: float) -> tuple[TaylorForm, TaylorForm]:
    """cos and sin of angle + p (p the parameter ``column``, |p| <= radius): cos a - sin a p - cos a p^2/2
    and sin a + cos a p - sin a p^2/2, each within radius^3 / 6 (Taylor; the third derivatives are
    bounded by 1). ``angle`` is a float; its cos and sin are floats within an ulp (added to the bound)."""
    ca, sa = math.cos(angle), math.sin(angle)
    lin_c, lin_s = np.zeros(space.size), np.zeros(space.size)
    quad_c, quad_s = np.zeros((space.size, space.size)), np.zeros((space.size, space.size))
    lin_c[column], lin_s[column] = -sa, ca
    quad_c[column, column], quad_s[column, column] = -0.5 * ca, -0.5 * sa
    rest = radius ** 3 / 6.0 + 4.0 * np.finfo(float).eps * (1.0 + radius)
    return (TaylorForm(space, np.array(ca), lin_c, quad_c, np.array(rest)),
            TaylorForm(space, np.array(sa), lin_s, quad_s, np.array(rest)))


def inverse_norm(space: ToleranceSet, columns, radius: float, slack: float) -> TaylorForm:
    """1 / sqrt(1 + s^2 + t^2) over the disk of the parameters ``columns`` = (s, t) of radius
    ``radius``: 1 - (s^2 + t^2) / 2 within 3/8 radius^4 (the series of (1 + u)^-1/2 alternates with
    decreasing terms for 0 <= u <= 1), plus ``slack`` (for a norm that is 1 + s^2 + t^2 only to rounding)."""
    quad = np.zeros((space.size, space.size))
    for k in columns:
        quad[k, k] = -0.5
    return TaylorForm(space, np.array(1.0), np.zeros(space.size), quad, np.array(0.375 * radius ** 4 + slack))


def cos_sin(u: TaylorForm) -> tuple[TaylorForm, TaylorForm]:
    """cos u and sin u of a real form u = u0 + v (u0 its centre): with w = 1 - v^2 / 2,
    cos u = cos u0 w - sin u0 v and sin u = sin u0 w + cos u0 v, within |cos u0| |v|^4 / 24 +
    |sin u0| |v|^3 / 6 (and the same with cos and sin exchanged), |v| bounded by its reach (Taylor's
    remainders of cos v and sin v)."""
    space = u.space
    u0 = u.c
    v = u - u0
    r = v.reach() * (1.0 + ROUND)
    w = space.constant(np.ones(np.shape(u0))) - (v * v).scale(0.5)
    c0, s0 = np.cos(u0), np.sin(u0)
    eps = 4.0 * np.finfo(float).eps * (1.0 + r)
    rest_c = np.abs(c0) * r ** 4 / 24.0 + np.abs(s0) * r ** 3 / 6.0 + eps
    rest_s = np.abs(s0) * r ** 4 / 24.0 + np.abs(c0) * r ** 3 / 6.0 + eps
    cos_u = w.scale(c0) - v.scale(s0)
    sin_u = w.scale(s0) + v.scale(c0)
    return (TaylorForm(space, cos_u.c, cos_u.lin, cos_u.quad, cos_u.rad + rest_c),
            TaylorForm(space, sin_u.c, sin_u.lin, sin_u.quad, sin_u.rad + rest_s))
