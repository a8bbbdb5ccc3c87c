"""The Krawczyk operator, once, on enclosures the caller gives (Krawczyk 1969; Moore 1977; the
parametric form: Neumaier 1990, Thm 5.1.7).

For a box X of the unknowns, a point y of it, any matrix C (best: the inverse of a midpoint Jacobian),
an enclosure F(y) of the equations at y and J(X) of their Jacobian over X:

    K(X) = y - C F(y) + (I - C J(X)) (X - y)                                   (point form)
    K(X) = y - C F(y) - (C R) sigma + (I - C J(X)) (X - y)                     (parametric form)

where, with parameters p = p_c + sigma (sigma over a box), F(y) is taken at p_c and R encloses the
equations' derivative in p at y over the parameter box (mean-value form). Every root of F in X (for
every p of the box) lies in K(X); if K(X) lies in the interior of X, there is exactly one (for each p),
and every matrix of J(X) is regular. That is the test of box isolation (:mod:`spherekin.search.isolation`),
of point certification (:mod:`spherekin.trust.krawczyk`, :mod:`spherekin.trust.extended`), of the
trackers and free boxes (:mod:`spherekin.trust.continuation`), and of the singular cells and cusps.

Callers differ only in how they enclose F, J and R and in the number type, which is an argument:
``ar``, an arithmetic (see :class:`Arithmetic`). Two live here: :data:`INTERVALS`, outward-rounded
intervals of floats (:mod:`spherekin.core.intervals`: rigorous), and :data:`MIDRAD`, midpoints and
radii in plain floats (the search's isolation test: not rigorous, widened by a margin by its caller;
every root it isolates is certified later by the trust layer). The extended-precision test passes an
arithmetic of mpmath intervals (:mod:`spherekin.trust.extended`).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from . import intervals as iv

__all__ = ["Arithmetic", "Intervals", "MidRad", "INTERVALS", "MIDRAD", "krawczyk_operator"]


class Arithmetic(Protocol):
    """What :func:`krawczyk_operator` needs of a number type: vectors and matrices of enclosures (a batch of
    them: leading axes), and C a matrix of the caller's (numbers, or enclosures)."""

    def point(self, y): ...                    # y as an enclosure
    def add(self, a, b): ...
    def sub(self, a, b): ...
    def eye_minus(self, a): ...                # I - a (a: square matrices)
    def cmatvec(self, c, v): ...               # C v
    def cmatmat(self, c, a): ...               # C A
    def matvec(self, a, v): ...                # A v, both enclosures


def krawczyk_operator(ar: Arithmetic, y, f_y, c, j_x, dx, rate=None, sigma=None):
    """K(X) (module doc) in the arithmetic ``ar``: ``y`` the point (M,) (batches: leading axes), ``f_y``
    an enclosure of F(y), ``c`` the matrix C (M, M), ``j_x`` an enclosure of J over X (M, M), ``dx``
    an enclosure of X - y; with ``rate`` (an enclosure of dF/dp, (M, P)) and ``sigma`` (of the
    parameters' offsets from p_c, (P,)), the parametric form. Returns K(X) as an enclosure."""
    k = ar.sub(ar.point(y), ar.cmatvec(c, f_y))                           # y - C F(y)
    if rate is not None:
        k = ar.sub(k, ar.matvec(ar.cmatmat(c, rate), sigma))              # - (C R) sigma
    return ar.add(k, ar.matvec(ar.eye_minus(ar.cmatmat(c, j_x)), dx))     # + (I - C J(X)) (X - y)


class Intervals:
    """Outward-rounded float intervals stacked (2, ...) (:mod:`spherekin.core.intervals`); C floats."""

    def point(self, y):
        return iv.point(y)

    def add(self, a, b):
        return iv.add(a, b)

    def sub(self, a, b):
        return iv.sub(a, b)

    def eye_minus(self, a):
        m = a.shape[-1]
        return iv.sub(iv.point(np.broadcast_to(np.eye(m), a.shape[1:])), a)

    def cmatvec(self, c, v):
        return iv.fmatmul(c, v[..., None])[..., 0]

    def cmatmat(self, c, a):
        return iv.fmatmul(c, a)

    def matvec(self, a, v):
        return iv.matmul(a, v[..., None])[..., 0]


class MidRad:
    """Midpoint-radius pairs (mid, rad) of plain float arrays, no outward rounding (the search's
    isolation test: its caller adds a margin for the rounding, and the trust layer certifies every
    root it isolates); C floats."""

    def point(self, y):
        y = np.asarray(y, dtype=float)
        return y, np.zeros_like(y)

    def add(self, a, b):
        return a[0] + b[0], a[1] + b[1]

    def sub(self, a, b):
        return a[0] - b[0], a[1] + b[1]

    def eye_minus(self, a):
        return np.eye(a[0].shape[-1]) - a[0], a[1]

    def cmatvec(self, c, v):
        return (c @ v[0][..., None])[..., 0], (np.abs(c) @ v[1][..., None])[..., 0]

    def cmatmat(self, c, a):
        return c @ a[0], np.abs(c) @ a[1]

    def matvec(self, a, v):
        mid, rad = a
        return ((mid @ v[0][..., None])[..., 0],
                ((np.abs(mid) @ v[1][..., None]) + (rad @ (np.abs(v[0]) + v[1])[..., None]))[..., 0])


#: The two numpy arithmetics (stateless).
INTERVALS = Intervals()
MIDRAD = MidRad()
