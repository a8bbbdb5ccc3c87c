"""First-order affine forms over a set of small parameters: x(p) = c + L p + r, |r| <= rad, for every p.

(Real or complex: c and L may be complex, r is then a complex number of modulus <= rad.)

Interval arithmetic forgets that two quantities depend on the same parameters: x - x over an interval
is twice its width, not 0. An affine form keeps the dependence to first order: each quantity is its
value at p = 0, its gradient in the parameters, and a bound on everything else (second order and
rounding). The parameters lie in a *tolerance set*: a product of disks (two parameters, a tilt
(s, t) with s^2 + t^2 <= r^2) and intervals (one parameter, |p| <= r), so that the reach of a linear
term over the set is exact: max |L p| = sum over the blocks of r_j |L_j|_2 (:meth:`ToleranceSet.reach`).
Products bound the product of the linear parts by the product of their reaches (second order).

Why our own: the affine-arithmetic packages on PyPI (affapy) work on one scalar at a time and on
boxes; this needs numpy arrays of forms (vectors, matrices) and the disks' exact reach.

Rounding: every operation adds :data:`ROUND` times the magnitude of its result (centre, reach of the
gradient and bound) to the bound: far above the rounding of the few dozen float operations behind
each entry (Higham's gamma_n, n <= 40: ~1e-14 relative).

Shapes: a form of shape S has ``c`` (S), ``lin`` (S + (P,)) and ``rad`` (S) (P parameters).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["ROUND", "ToleranceSet", "Affine", "stack", "cos_sin_shift"]

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
        sq = np.asarray(lin)
        sq = (sq.real ** 2 + sq.imag ** 2) if np.iscomplexobj(sq) else sq * sq
        return (np.sqrt(sq @ self._member) @ self._radii) * (1.0 + ROUND)

    def symbol(self, column: int) -> "Affine":
        """The parameter ``column`` itself."""
        lin = np.zeros(self.size)
        lin[column] = 1.0
        return Affine(self, np.array(0.0), lin, np.array(0.0))

    def constant(self, value) -> "Affine":
        """A float (or complex) array of exact numbers as forms."""
        value = _numbers(value)
        return Affine(self, value, np.zeros(value.shape + (self.size,)), np.zeros(value.shape))


@dataclass(frozen=True, eq=False)
class Affine:
    """x(p) = c + lin . p + r with |r| <= rad, for every p in ``space`` (elementwise over arrays)."""

    space: ToleranceSet
    c: np.ndarray
    lin: np.ndarray
    rad: np.ndarray

    def _rounded(self, c, lin, rad) -> "Affine":
        c, lin, rad = _numbers(c), _numbers(lin), np.asarray(rad, dtype=float)
        rad = rad + ROUND * (np.abs(c) + self.space.reach(lin) + rad)
        return Affine(self.space, c, lin, rad)

    @property
    def shape(self) -> tuple:
        return self.c.shape

    def __getitem__(self, index) -> "Affine":
        index = index if isinstance(index, tuple) else (index,)
        return Affine(self.space, self.c[index], self.lin[index + (slice(None),)], self.rad[index])

    def reach(self) -> np.ndarray:
        """max |x(p) - c| over the set (>= |lin . p| + rad)."""
        return self.space.reach(self.lin) + self.rad

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi): x(p) within them for every p of the set."""
        r = self.reach() * (1.0 + ROUND)
        return self.c - r, self.c + r

    def __add__(self, other) -> "Affine":
        o = _as_form(self.space, other)
        return self._rounded(self.c + o.c, self.lin + o.lin, self.rad + o.rad)

    def __sub__(self, other) -> "Affine":
        o = _as_form(self.space, other)
        return self._rounded(self.c - o.c, self.lin - o.lin, self.rad + o.rad)

    def __neg__(self) -> "Affine":
        return Affine(self.space, -self.c, -self.lin, self.rad)

    def __mul__(self, other) -> "Affine":
        """Elementwise product (numpy broadcasting of the shapes)."""
        o = _as_form(self.space, other)
        c = self.c * o.c
        lin = self.c[..., None] * o.lin + o.c[..., None] * self.lin
        rad = (np.abs(self.c) * o.rad + np.abs(o.c) * self.rad
               + (self.space.reach(self.lin) + self.rad) * (self.space.reach(o.lin) + o.rad))
        return self._rounded(c, lin, rad)

    def scale(self, k) -> "Affine":
        """Times the float (or complex) array ``k`` (exact numbers; broadcasting)."""
        k = _numbers(k)
        return self._rounded(k * self.c, k[..., None] * self.lin, np.abs(k) * self.rad)

    def sum(self, axis: int = -1) -> "Affine":
        """The sum over an axis of the shape."""
        axis = axis % len(self.shape)
        return self._rounded(self.c.sum(axis=axis), self.lin.sum(axis=axis), self.rad.sum(axis=axis))

    def dot(self, other) -> "Affine":
        """Sum over the last axis of the elementwise product (vectors (..., n))."""
        return (self * other).sum(-1)

    def cross(self, other) -> "Affine":
        """Cross products of vectors (..., 3)."""
        o = _as_form(self.space, other)
        parts = [self[..., j] * o[..., k] - self[..., k] * o[..., j] for j, k in ((1, 2), (2, 0), (0, 1))]
        return stack(parts, -1)

    def contract(self, t) -> "Affine":
        """The linear map of the float array ``t`` (out shape + this form's shape) applied to the form:
        sum over this form's axes of t * x (np.tensordot)."""
        t = _numbers(t)
        nd = self.c.ndim
        c = np.tensordot(t, self.c, axes=nd)
        lin = np.tensordot(t, self.lin, axes=(list(range(t.ndim - nd, t.ndim)), list(range(nd))))
        rad = np.tensordot(np.abs(t), self.rad, axes=nd)
        return self._rounded(c, lin, rad)

    def disk(self) -> tuple[np.ndarray, np.ndarray]:
        """(centre, radius): x(p) within radius of the centre (real or complex) for every p of the set."""
        return self.c, self.reach() * (1.0 + ROUND)

    def bmatvec(self, m) -> "Affine":
        """Matrices ``m`` (..., n, k) (floats or complex, one per form of the leading shape) times the
        vectors (..., k)."""
        m = np.asarray(m)
        c = np.einsum("...nk,...k->...n", m, self.c)
        lin = np.einsum("...nk,...kp->...np", m, self.lin)
        rad = np.einsum("...nk,...k->...n", np.abs(m), self.rad)
        return self._rounded(c, lin, rad)

    def matvec(self, m) -> "Affine":
        """The float matrix ``m`` (n, k) times the vectors (..., k)."""
        m = np.asarray(m)
        c = self.c @ m.T
        lin = np.einsum("nk,...kp->...np", m, self.lin)
        rad = self.rad @ np.abs(m).T
        return self._rounded(c, lin, rad)


def _numbers(x) -> np.ndarray:
    """``x`` as a float array, or a complex one when it is complex."""
    x = np.asarray(x)
    return x if np.iscomplexobj(x) else x.astype(float, copy=False)


def _as_form(space: ToleranceSet, x) -> Affine:
    return x if isinstance(x, Affine) else space.constant(x)


def stack(forms, axis: int = 0) -> Affine:
    """Forms of one shape stacked along a new axis of the shape."""
    space = forms[0].space
    nd = len(forms[0].shape) + 1
    axis = axis % nd
    return Affine(space, np.stack([f.c for f in forms], axis=axis), np.stack([f.lin for f in forms], axis=axis),
                  np.stack([f.rad for f in forms], axis=axis))


def cos_sin_shift(space: ToleranceSet, angle: float, column: int, radius: float) -> tuple[Affine, Affine]:
    """cos and sin of angle + p (p the parameter ``column``, |p| <= radius): cos a - sin a p and
    sin a + cos a p, each within radius^2 / 2 (Taylor; |cos''|, |sin''| <= 1). ``angle`` is a float;
    its cos and sin are floats within an ulp (added to the bound)."""
    ca, sa = math.cos(angle), math.sin(angle)
    lin_c, lin_s = np.zeros(space.size), np.zeros(space.size)
    lin_c[column], lin_s[column] = -sa, ca
    rest = 0.5 * radius * radius + 4.0 * np.finfo(float).eps * (1.0 + radius)
    return (Affine(space, np.array(ca), lin_c, np.array(rest)), Affine(space, np.array(sa), lin_s, np.array(rest)))

