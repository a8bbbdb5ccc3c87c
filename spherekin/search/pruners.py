"""Pruners: from the control points of a box, a sub-box that contains every root in it (Section 4, step 2).

One small interface, chosen by name (:func:`make_pruner`): ``reduce(cps, tols)`` takes, for each
equation block, the control points restricted to B boxes with the BATCH AXIS LAST, shape
(E, d_1, ..., d_n, B) (the layout of :func:`spherekin.core.bernstein.restrict_batch_last`), and the
absolute tolerances of the test "w = 0", shape (E,) or per box (E, B); it returns ``(lo, hi)`` of
shape (B, n) in each box's own unit coordinates, with ``lo > hi`` in some coordinate marking a box
that holds no root.

* ``pp`` -- projected polyhedron: per equation and per variable k, the convex hull of the 2-D
  points (i_k / m_k, w_I) meets the band |w| <= tol on an interval of x_k; intersect over
  equations. No LP; vectorized over boxes. The box it returns contains the Eq. (12) box.
* ``lp`` -- the Eq. (12) linear programs: min and max of every x_k over the intersection of all
  equations' hulls with w = 0, solved by an LP backend (:mod:`spherekin.search.lp_backends`). Every answer
  is checked; on any doubt the bound stays at the box face, so a root is never lost.
* ``hybrid`` -- ``pp`` everywhere, ``lp`` where ``pp`` stalls on a small box (:class:`HybridPruner`).

``reduce`` may also receive ``widths`` (B,), each box's widest side in radians; only the hybrid
pruner uses it.

Departure from the paper: the plane w = 0 becomes the slab |w| <= tol, tol scaled to the
equation's control points on the whole unit box, because restricted control points carry rounding
errors of that absolute size; without it a tangential root (the scalar equation touches 0 from
below at every root) could be pruned away by rounding.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from math import prod
from typing import ClassVar, Sequence

import numpy as np

from ..core.arrays import namespace_of
from .lp_backends import backend_class, make_backend
from .registry import Registry

__all__ = ["Pruner", "PRUNERS", "make_pruner", "check_pruner", "ProjectedPolyhedron", "LinearProgramPruner",
           "HybridPruner", "pp_intervals", "excludes_zero"]

#: Every interval computed in floating point is widened by this much (unit coordinates of the
#: box): the crossing abscissae are rounded to ~1e-16 relative; 1e-12 keeps a wide safety margin
#: while still allowing twelve orders of magnitude of shrinking per step.
INTERVAL_MARGIN = 1e-12


def _hull_level_interval(s: Sequence[float], vals):
    """Interval of x where the lower hull of the points (s_i, vals_i) is <= 0.

    ``s`` (m+1,) increasing abscissae (Python floats: constants of the degree), ``vals`` (m+1, ...)
    ordinates (already shifted by the tolerance), the abscissa axis FIRST so that every step is an
    elementwise operation over whole arrays (numpy reductions over tiny trailing axes are an order of
    magnitude slower). Returns (lo, hi) of shape (...), lo = +inf when empty. The set is the convex
    hull of the admissible abscissae (vals <= 0) and of the crossings of level 0 by the segments
    joining an admissible and an excluded point; its left end is the first admissible abscissa or a
    crossing of a segment whose LEFT end is excluded, its right end symmetrically, so each segment
    i < j is computed once. Any array module (:func:`spherekin.core.arrays.namespace_of`).
    """
    xp = namespace_of(vals)
    ok = vals <= 0
    lo = xp.full_like(vals[0, ...], xp.inf)
    hi = xp.full_like(vals[0, ...], -xp.inf)
    for i in range(len(s) - 1, -1, -1):
        lo = xp.where(ok[i, ...], s[i], lo)
    for i in range(len(s)):
        hi = xp.where(ok[i, ...], s[i], hi)
    # numpy's floating-point error state (host-side, whatever the module): a segment whose ends are
    # both admissible or both excluded divides by zero or gives nan, and its crossing is never used
    with np.errstate(divide="ignore", invalid="ignore"):
        for i in range(len(s)):
            for j in range(i + 1, len(s)):
                x = s[i] + (s[j] - s[i]) * (vals[i, ...] / (vals[i, ...] - vals[j, ...]))
                lo = xp.where(ok[j, ...] & ~ok[i, ...], xp.minimum(lo, x), lo)
                hi = xp.where(ok[i, ...] & ~ok[j, ...], xp.maximum(hi, x), hi)
    return lo, hi


def _tolerances(xp, tol, ne: int, bsz: int):
    """The tolerances ``tol`` (E,) or (E, B) of E equations as an (E, B) array (a broadcast view)."""
    return xp.broadcast_to(xp.reshape(xp.asarray(tol, dtype=xp.float64), (ne, -1)), (ne, bsz))


def pp_intervals(cps, tol, var: int | None = None):
    """Projected-polyhedron intervals for each box, equation and variable.

    cps (E, d_1..d_n, B) (batch last), tol (E,) or (E, B). For every variable k with d_k > 1, the
    2-D points (i_k / m_k, w_I) are reduced to the lowest and highest w at each abscissa, whose
    hulls give the interval of x_k where |w| <= tol is reachable. Returns (variables, lo, hi) with
    lo, hi of shape (E, |variables|, B); lo > hi where the equation excludes the box. With ``var``
    given, returns (lo, hi) of shape (E, B) for that variable only. Any array module
    (:func:`spherekin.core.arrays.namespace_of`).
    """
    xp = namespace_of(cps, tol)
    ne, dims, bsz = cps.shape[0], cps.shape[1:-1], cps.shape[-1]
    variables = tuple(k for k, d in enumerate(dims) if d > 1)
    t = _tolerances(xp, tol, ne, bsz)
    if variables:
        vd = [dims[k] for k in variables]
        mins, maxs = {}, {}
        for j, d in enumerate(vd):                 # the lowest and highest w at each abscissa of x_k
            v = xp.reshape(cps, (ne, prod(vd[:j]), d, -1, bsz))
            mins[j] = xp.moveaxis(xp.min(v, axis=(1, 3)), 1, 0)
            maxs[j] = xp.moveaxis(xp.max(v, axis=(1, 3)), 1, 0)
        cols = {}                                  # variable position -> (lo, hi) (E, B)
        for d in sorted(set(vd)):
            group = [j for j, dj in enumerate(vd) if dj == d]
            low = xp.stack([mins[j] for j in group], axis=2) - t[None, :, None, :]     # (d, E, V_d, B)
            up = xp.stack([maxs[j] for j in group], axis=2) + t[None, :, None, :]
            s = np.linspace(0.0, 1.0, d).tolist()   # host constants: the abscissae i / m as numpy rounds them
            # the upper hull admits 0 where the lower hull of the mirrored points -up does
            lo1, hi1 = _hull_level_interval(s, low)                                    # (E, V_d, B)
            lo2, hi2 = _hull_level_interval(s, -up)
            glo, ghi = xp.maximum(lo1, lo2), xp.minimum(hi1, hi2)
            if len(group) == len(vd):              # one degree: every variable, in order
                lo, hi = glo, ghi
                break
            for q, j in enumerate(group):
                cols[j] = (glo[:, q, :], ghi[:, q, :])
        if cols:
            lo = xp.stack([cols[j][0] for j in range(len(vd))], axis=1)
            hi = xp.stack([cols[j][1] for j in range(len(vd))], axis=1)
    else:
        lo = hi = xp.expand_dims(t, axis=1)[:, :0, :]                                  # (E, 0, B)
    if var is None:
        return variables, lo, hi
    if var not in variables:
        raise ValueError(f"var: expected a variable of positive degree {variables}, got {var!r}")
    j = variables.index(var)
    return lo[:, j, :], hi[:, j, :]


def excludes_zero(cps: Sequence, tols: Sequence):
    """(B,) True where some equation's control points all lie beyond its slab |w| <= tol.

    ``cps``: per block, control points (E, d..., B) (batch last); ``tols``: (E,) or (E, B). By the
    convex hull property the equation then has no zero on the box (the range enclosure of a
    Bernstein polynomial is [min, max] of its control points). Any array module
    (:func:`spherekin.core.arrays.namespace_of`).
    """
    xp = namespace_of(*cps, *tols)
    bsz = cps[0].shape[-1]
    out = None
    for c, tol in zip(cps, tols):
        flat = xp.reshape(c, (c.shape[0], -1, bsz))
        t = _tolerances(xp, tol, c.shape[0], bsz)
        hit = xp.any((xp.min(flat, axis=1) > t) | (xp.max(flat, axis=1) < -t), axis=0)
        out = hit if out is None else out | hit
    return out


class Pruner(ABC):
    """A pruner: from a batch of boxes' control points, the sub-box of each that may hold a root.

    A new one subclasses this, sets ``name`` (and ``default_lp_backend`` when it solves Eq. (12)
    LPs, None otherwise), implements :meth:`reduce` and, when it needs more than a name to be
    built, :meth:`build`; it is registered with ``@PRUNERS.register``. ``lp_count`` and ``doubts``
    count the LPs solved and the LP answers that could not be certified.
    """

    name: ClassVar[str]
    #: The LP backend used when none is named; None: the pruner solves no LP.
    default_lp_backend: ClassVar[str | None] = None
    lp_count = 0
    doubts = 0

    @classmethod
    def check(cls, lp_backend: str | None) -> None:
        """ValueError when ``lp_backend`` does not fit this pruner; builds nothing. The backend's own
        name is checked first: a refused backend says why (its measurement) whatever the pruner."""
        if lp_backend is not None:
            backend_class(lp_backend)
        if cls.default_lp_backend is None and lp_backend is not None:
            raise ValueError(f"lp_backend: the {cls.name!r} pruner solves no LP; pass lp_backend=None or "
                             f"pruner='lp'")

    @classmethod
    def build(cls, shapes: Sequence[tuple[int, ...]], lp_backend: str | None) -> "Pruner":
        """The pruner for equation blocks of these coefficient shapes (E, d_1..d_n)."""
        cls.check(lp_backend)
        return cls()

    @abstractmethod
    def reduce(self, cps: Sequence[np.ndarray], tols: Sequence[np.ndarray], widths=None):
        """(lo, hi), each (B, n): the reduced boxes in the unit coordinates of the B boxes whose
        control points per block are ``cps`` (E, d_1..d_n, B), with the tolerances ``tols`` of each
        equation's test w = 0; lo > hi where a box holds no root. ``widths`` (B,): the boxes'
        metric widths (radians), for pruners that choose by size."""


#: The pruners, by name (:func:`make_pruner`).
PRUNERS = Registry("pruner")


@PRUNERS.register
class ProjectedPolyhedron(Pruner):
    """Projected-polyhedron pruning (Sherbrooke & Patrikalakis), vectorized over boxes."""

    name = "pp"

    def reduce(self, cps: Sequence[np.ndarray], tols: Sequence[np.ndarray], widths=None):
        # any array module (spherekin.core.arrays.namespace_of): each variable's bounds are a row
        # (B,), tightened by every equation that depends on it
        xp = namespace_of(*cps, *tols)
        bsz, n = cps[0].shape[-1], cps[0].ndim - 2
        first = xp.reshape(cps[0], (-1, bsz))[0, :]
        lo, hi = [xp.zeros_like(first)] * n, [xp.ones_like(first)] * n
        excluded = None
        for c, tol in zip(cps, tols):
            variables, l, h = pp_intervals(c, tol)
            if variables:
                lmax, hmin = xp.max(l, axis=0), xp.min(h, axis=0)                        # (V, B)
                for q, k in enumerate(variables):
                    lo[k] = xp.maximum(lo[k], lmax[q, :])
                    hi[k] = xp.minimum(hi[k], hmin[q, :])
            else:
                # an equation that depends on no variable has no projection to prune with: it
                # excludes the box when its (constant) value lies beyond the slab
                e = excludes_zero([c], [tol])
                excluded = e if excluded is None else excluded | e
        lo, hi = xp.stack(lo, axis=1), xp.stack(hi, axis=1)                              # (B, n)
        empty = xp.any(lo > hi, axis=1)
        if excluded is not None:
            empty = empty | excluded
        lo, hi = xp.maximum(lo - INTERVAL_MARGIN, 0.0), xp.minimum(hi + INTERVAL_MARGIN, 1.0)
        empty = empty[:, None]
        return xp.where(empty, 1.0, lo), xp.where(empty, 0.0, hi)


@PRUNERS.register
class LinearProgramPruner(Pruner):
    """The Eq. (12) LPs over the intersection of all equations' convex hulls, by a named backend."""

    name = "lp"
    default_lp_backend = "highs"

    def __init__(self, shapes: Sequence[tuple[int, ...]], backend: str):
        self.backend = make_backend(backend, shapes)
        self.lp_count = 0
        self.doubts = 0

    @classmethod
    def build(cls, shapes, lp_backend):
        cls.check(lp_backend)
        return cls(shapes, lp_backend or cls.default_lp_backend)

    def reduce(self, cps: Sequence[np.ndarray], tols: Sequence[np.ndarray], widths=None):
        bsz, n = cps[0].shape[-1], cps[0].ndim - 2
        lo, hi = np.zeros((bsz, n)), np.ones((bsz, n))
        for b in range(bsz):
            res = self.backend.box_bounds([c[..., b] for c in cps], [t if np.ndim(t) == 1 else t[:, b] for t in tols])
            self.lp_count += res.lp_count
            self.doubts += res.doubts
            if res.empty:
                lo[b], hi[b] = 1.0, 0.0
            else:
                lo[b] = np.maximum(res.lo - INTERVAL_MARGIN, 0.0)
                hi[b] = np.minimum(res.hi + INTERVAL_MARGIN, 1.0)
        return lo, hi


@PRUNERS.register
class HybridPruner(Pruner):
    """Projected polyhedron on every box; the Eq. (12) LPs only where it stalls on a small box.

    PP is cheap but projects each equation on one axis at a time, so near a nearly singular root
    (a mechanism close to a parallel singularity) it cannot cut across the thin valley where the
    equations almost vanish, and the box count explodes. The LP intersects all hulls in full
    dimension and cuts such valleys. A box goes to the LP when PP kept more than
    :data:`HYBRID_STALL_RATIO` of some side and the box is narrower than
    :data:`HYBRID_MAX_WIDTH` radians (on wide boxes the LP rarely pays for itself).
    """

    name = "hybrid"
    default_lp_backend = "highspy"

    def __init__(self, shapes, backend: str):
        self.pp = ProjectedPolyhedron()
        self.lp = LinearProgramPruner(shapes, backend)

    @classmethod
    def build(cls, shapes, lp_backend):
        cls.check(lp_backend)
        return cls(shapes, lp_backend or cls.default_lp_backend)

    @property
    def lp_count(self) -> int:
        return self.lp.lp_count

    @property
    def doubts(self) -> int:
        return self.lp.doubts

    def reduce(self, cps, tols, widths=None):
        lo, hi = self.pp.reduce(cps, tols)
        stalled = ~np.any(lo > hi, axis=1) & np.any(hi - lo > HYBRID_STALL_RATIO, axis=1)
        if widths is not None:
            stalled &= np.asarray(widths) < HYBRID_MAX_WIDTH
        if stalled.any():
            idx = np.flatnonzero(stalled)
            llo, lhi = self.lp.reduce([c[..., idx] for c in cps], [t if np.ndim(t) == 1 else t[:, idx] for t in tols])
            lo[idx], hi[idx] = np.maximum(lo[idx], llo), np.minimum(hi[idx], lhi)
        return lo, hi


#: The hybrid pruner calls the LP on boxes where PP kept more than this fraction of a side (the
#: solver would split them; same value as the solver's SPLIT_RATIO) ...
HYBRID_STALL_RATIO = 0.8
#: ... and whose widest side is below this (radians): measured on near-singular general 3-RRRs,
#: where PP alone needed over 500000 boxes and the valley around the roots is ~0.4 rad long.
HYBRID_MAX_WIDTH = 0.1

def make_pruner(name: str, shapes: Sequence[tuple[int, ...]], lp_backend: str | None = None) -> Pruner:
    """Pruner by name (one of PRUNERS); ``shapes`` are the equation blocks' coefficient shapes (E, d_1..d_n)."""
    return PRUNERS.lookup(name).build(shapes, lp_backend)


def check_pruner(name: str, lp_backend: str | None = None) -> None:
    """ValueError when the pruner or the LP backend named does not exist or do not fit together
    (:func:`make_pruner` would fail the same way); builds nothing (no LP model is compiled)."""
    PRUNERS.lookup(name).check(lp_backend)
