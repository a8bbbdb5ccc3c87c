"""The complete-count system: every assembly of a 3-RRR proven at once, without subdivision (issue 44).

Eq. (1) of each leg (:mod:`spherekin.systems.platform`) is a homogeneous quadric q^T M_i(d_i) q = 0
in the quaternion q of the platform displacement D, so the direct kinematics is the intersection of
three quadrics of P^3: at most 8 isolated points (Bezout; :mod:`spherekin.core.bezout` states the
refined theorem and proves the roots). At an input whose 8 complex roots are all proven (each by a
Krawczyk test in the complex, each proven real or not real, all proven distinct) the real ones are
every assembly, and the count is proven with no box search. Anything less (a root near another: a
fold; a continuum; a root whose joint reading is at a range end) passes the input on to the
platform search (the next system of the chain), which stays the reference and leads to the paper's
method.

**Candidates** (how the roots are found does not enter the proof). Leg i fixes its platform axis
p_i = D b_i on the circle e_i . p_i = c_i of the unit sphere (Eq. (1) with e, b, c at the input:
:func:`~spherekin.systems.platform.leg_terms`), a conic in t_i = tan(theta_i / 2):
p_i (1 + t^2) = (c e + s u) + 2 s v t + (c e - s u) t^2 (s = sqrt(1 - c^2), complex when |c| > 1;
u, v unit, normal to e and to each other). Legs 1 and 2 fix D when p_1 . p_2 = b_1 . b_2 (a rigid
pair), and leg 3's equation is e_3 . (alpha p_1 + beta p_2 + gamma p_1 x p_2) = c_3 with
b_3 = alpha b_1 + beta b_2 + gamma b_1 x b_2: two biquadratic equations in (t_1, t_2). Their
Sylvester matrix in t_2 (rows f, t_2 f, g, t_2 g on (1, t_2, t_2^2, t_2^3)) is a 4 x 4 matrix
S(t_1) = S_0 + t_1 S_1 + t_1^2 S_2, whose determinant is the classical polynomial of degree 8 in
t_1 (Gosselin, Sefrioui, Richard 1994); its companion linearization is one 8 x 8 eigenproblem per
input, batched (:func:`circle_candidates`); each eigenvector holds (1, t_2, t_2^2, t_2^3).

**The interval matrices.** M_i(d) = cos d Mc_i + sin d Ms_i + M0_i (:func:`leg_matrices`), with the
parts enclosing their exact values for the model's axes (interval arithmetic, once:
:func:`interval_leg_parts`), cos and sin enclosed by :func:`spherekin.core.intervals.cos_sin`,
and every entry widened by :data:`MODEL_TOLERANCE` so that the proof is about the mechanism as
described, not one rounding of it (the trust layer's angle tolerance, in the same spirit).

**Joint ranges.** A real root's passive readings are enclosed over its proven box
(:func:`~spherekin.systems.platform.passive_reading_enclosures`); a root is kept when every
reading is proven in its range, dropped when one is proven outside, and the input is passed on
when one is undecided. Departure from the trust layer's rule: that tests the polished float
angle; here the whole enclosure must decide (a root within ~1e-9 of a range end goes to the box
search, which reports it by the float rule).
"""

from __future__ import annotations

import functools
import math
import time

import numpy as np

from ..core import bezout
from ..core import intervals as iv
from ..core.angles import TWO_PI, into_range_many, span_in_range_many, span_outside_range_many
from ..core.orientation import quaternion_matrices
from ..core.rotations import cross
from ..mechanism.chains import axis_rotations
from .proven_roots import PROVEN_CHUNK, ChunkRoots
from ..results import LazySolutions, SearchReport, Settings, SolverStats
from .base import SYSTEMS, Compiled, Passed, Proven, System, own_variables_declined
from .platform import (QUADRATIC_TENSOR as _T, CHARTS, PlatformSystem, leg_terms, not_applicable, passive_names, passive_reading_enclosures,
                       passive_readings_many, platform_legs)

__all__ = ["MODEL_TOLERANCE", "FORMULATION", "interval_leg_parts", "model_gap", "circle_candidates", "quaternions_of_rotations",
           "RealRoots", "CompiledComplete", "Complete"]

#: The formulation name that selects this system (``formulation="complete"``).
FORMULATION = "complete"
#: Half-width added to every entry of the matrices M_i of Eq. (1) (absolute). Reason: the proof must
#: hold for the mechanism as described, whose constants the model holds as floats (axes computed from
#: angles, cosines of link angles such as float(pi/2)): the trust layer lets every constant angle
#: move by its angle tolerance, 2e-14 rad. Moving the unit vectors e, b by 2e-14 and c by 4e-14
#: moves each entry of M = T(e, b) - c I (a sum of at most 6 products of unit-vector components
#: with coefficients at most 2) by less than 2.6e-13; 4e-13 covers that with room, and the width of
#: F(y) it makes (~1e-11) still lets a root with |J^-1| up to ~1e2 be proven at radius 1e-9.
MODEL_TOLERANCE = 4e-13


def interval_leg_parts(legs) -> np.ndarray:
    """Interval parts (2, L legs, 3 (c, s, 0), 4, 4) of M_i(d) = cos d Mc + sin d Ms + M0 enclosing
    the exact values for the model's float axes: :func:`~spherekin.systems.platform.leg_terms` and
    :func:`~spherekin.systems.platform.leg_matrices` evaluated in outward-rounded interval arithmetic
    (:mod:`spherekin.core.intervals`; the tensor T of S(q) is exact: entries 0, +-1, +-2)."""
    def dot(u, v):                              # (2, 1): a one-element interval
        return iv.isum(iv.mul(u, v), -1)[:, None]

    def crs(u, v):
        return np.concatenate([iv.sub(iv.mul(u[:, i:i + 1], v[:, j:j + 1]), iv.mul(u[:, j:j + 1], v[:, i:i + 1]))
                               for i, j in ((1, 2), (2, 0), (0, 1))], axis=-1)

    def rod(axis, v, sign=1.0):                 # Rot(axis, sign d) v as (cos, sin, 1) terms
        along = dot(axis, v)
        return [iv.sub(v, iv.mul(along, axis)), iv.scale(sign, crs(axis, v)), iv.mul(along, axis)]

    def form(e, a, c):                          # q^T M q = e . S(q) a - c |q|^2
        outer = iv.mul(e[:, :, None], a[:, None, :])                             # (2, 3, 3)
        t = iv.isum(iv.isum(iv.scale(_T, outer[:, None, None]), -1), -1)         # (2, 4, 4)
        return iv.sub(t, iv.scale(np.eye(4), c[:, :, None]))

    zero, nil = iv.point(np.zeros(3)), iv.point(np.zeros(1))
    out = np.empty((2, len(legs), 3, 4, 4))
    for li, leg in enumerate(legs):
        a1, a2, a3 = (iv.point(np.asarray(v, dtype=float)) for v in (leg.a1, leg.a2, leg.a3))
        if leg.actuated == 0:
            e, b, c = rod(a1, a2), [zero, zero, a3], [nil, nil, dot(a2, a3)]
        elif leg.actuated == 1:
            e, b, c = [zero, zero, a1], [zero, zero, a3], [dot(p, a1) for p in rod(a2, a3)]
        else:
            e, b, c = [zero, zero, a1], rod(a3, a2, -1.0), [nil, nil, dot(a1, a2)]
        parts = [iv.add(form(e[p], b[2], c[p]), form(e[2], b[p], nil)) for p in (0, 1)] + [form(e[2], b[2], c[2])]
        out[:, li] = np.stack(parts, axis=1)
    return out


def model_gap(mechanism) -> float:
    """For a 3-RRR written as its description (kind "3-RRR"): the largest |a2 . a3 - cos(alpha2)| over
    the legs, how far the model's distal link angles (its joint axes at the reference pose) are from
    the description's (cosines); 0 for a mechanism whose axes are given directly (they are its own)."""
    geometry = getattr(mechanism, "geometry", None)
    alpha2 = getattr(geometry, "distal_link_angles", None)
    if alpha2 is None:
        return 0.0
    return max(abs(float(np.dot(leg.joints[1].axis, leg.joints[2].axis)) - math.cos(a))
               for leg, a in zip(mechanism.legs, alpha2))


def _perpendiculars(v) -> np.ndarray:
    """Unit vectors (..., 3) normal to the unit vectors v (..., 3): v x (the basis vector least aligned)."""
    basis = np.eye(3)[np.argmin(np.abs(v), axis=-1)]
    n = cross(v, basis)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def quaternions_of_rotations(d) -> np.ndarray:
    """Quaternions q (..., 4) (complex, not normalized) of rotations D (..., 3, 3) (complex: points
    of the complexified group): the column of 4 q q^T (linear in D) with the largest diagonal entry."""
    d = np.asarray(d)
    d00, d01, d02 = d[..., 0, 0], d[..., 0, 1], d[..., 0, 2]
    d10, d11, d12 = d[..., 1, 0], d[..., 1, 1], d[..., 1, 2]
    d20, d21, d22 = d[..., 2, 0], d[..., 2, 1], d[..., 2, 2]
    k = np.stack([np.stack([1 + d00 + d11 + d22, d21 - d12, d02 - d20, d10 - d01], -1),
                  np.stack([d21 - d12, 1 + d00 - d11 - d22, d01 + d10, d02 + d20], -1),
                  np.stack([d02 - d20, d01 + d10, 1 - d00 + d11 - d22, d12 + d21], -1),
                  np.stack([d10 - d01, d02 + d20, d12 + d21, 1 - d00 - d11 + d22], -1)], -2)
    col = np.argmax(np.abs(np.diagonal(k, axis1=-2, axis2=-1)), axis=-1)
    return np.take_along_axis(k, col[..., None, None], axis=-1)[..., 0]


def circle_candidates(e, b, c) -> np.ndarray:
    """Candidate roots (K, 8, 4) complex (NaN: none) of Eq. (1) for K inputs: e, b (K, 3 legs, 3),
    c (K, 3) its terms at each input (e_i . D b_i = c_i). The Sylvester eigenproblem of the module
    doc; a candidate at infinity of the conics (1 + t^2 = 0) or of the pencil comes out NaN."""
    e, b, c = (np.asarray(x, dtype=float) for x in (e, b, c))
    kk = len(e)
    s = np.sqrt((1.0 - c[:, :2] ** 2).astype(complex))                       # (K, 2)
    conics = []
    for i in range(2):
        u = _perpendiculars(e[:, i])
        v = cross(e[:, i], u)
        ce, su = c[:, i, None] * e[:, i], s[:, i, None] * u
        conics.append(np.stack([ce + su, 2.0 * s[:, i, None] * v, ce - su], axis=1))   # (K, 3 powers, 3)
    x, y = conics
    b0, b1, b2 = b[:, 0], b[:, 1], b[:, 2]
    frame = np.stack([b0, b1, cross(b0, b1)], axis=-1)                        # columns b0, b1, b0 x b1
    with np.errstate(all="ignore"):
        abg = np.linalg.solve(frame, b2[..., None])[..., 0]                   # b2 in that frame
        o = np.array([1.0, 0.0, 1.0])                                          # 1 + t^2
        kappa = np.einsum("ki,ki->k", b0, b1)
        e2 = e[:, 2]
        f = np.einsum("kai,kbi->kab", x, y) - kappa[:, None, None] * np.outer(o, o)
        ex, ey = np.einsum("kai,ki->ka", x, e2), np.einsum("kbi,ki->kb", y, e2)
        ycross = np.stack([y[..., 1] * e2[:, None, 2] - y[..., 2] * e2[:, None, 1],
                           y[..., 2] * e2[:, None, 0] - y[..., 0] * e2[:, None, 2],
                           y[..., 0] * e2[:, None, 1] - y[..., 1] * e2[:, None, 0]], axis=-1)   # Y_b x e2
        g = (abg[:, 0, None, None] * ex[:, :, None] * o + abg[:, 1, None, None] * o[:, None] * ey[:, None, :]
             + abg[:, 2, None, None] * np.einsum("kai,kbi->kab", x, ycross) - c[:, 2, None, None] * np.outer(o, o))
        sylvester = np.zeros((kk, 3, 4, 4), dtype=complex)                     # [power of t1, row, column]
        sylvester[:, :, 0, :3], sylvester[:, :, 1, 1:] = f, f
        sylvester[:, :, 2, :3], sylvester[:, :, 3, 1:] = g, g
        ok = np.isfinite(sylvester).all(axis=(1, 2, 3)) & (np.abs(np.linalg.det(sylvester[:, 2])) > 0)
        lead = np.where(ok[:, None, None], sylvester[:, 2], np.eye(4))
        comp = np.zeros((kk, 8, 8), dtype=complex)
        comp[:, :4, 4:] = np.eye(4)
        comp[:, 4:, :4] = -np.linalg.solve(lead, sylvester[:, 0])
        comp[:, 4:, 4:] = -np.linalg.solve(lead, sylvester[:, 1])
        comp[~ok] = np.eye(8)
        # real pencils (every |c| <= 1: the usual case) by the real eigensolver, about twice as fast
        real = np.all(comp.imag == 0.0, axis=(1, 2))
        t1 = np.empty((kk, 8), dtype=complex)
        if real.any():
            t1[real] = np.linalg.eigvals(comp[real].real)
        if (~real).any():
            t1[~real] = np.linalg.eigvals(comp[~real])                          # (K, 8)
        t2 = _partners(f, g, t1)

        def on_conic(coef, t):
            return (coef[:, None, 0] + coef[:, None, 1] * t[..., None] + coef[:, None, 2] * t[..., None] ** 2) \
                / (1.0 + t[..., None] ** 2)

        p0, p1 = on_conic(x, t1), on_conic(y, t2)                             # (K, 8, 3)
        p01 = np.stack([p0[..., 1] * p1[..., 2] - p0[..., 2] * p1[..., 1], p0[..., 2] * p1[..., 0] - p0[..., 0] * p1[..., 2],
                        p0[..., 0] * p1[..., 1] - p0[..., 1] * p1[..., 0]], axis=-1)
        d = np.stack([p0, p1, p01], axis=-1) @ np.linalg.inv(frame)[:, None]  # D [b0 b1 b0xb1] = [p0 p1 p0xp1]
        q = quaternions_of_rotations(d)
    q[~ok] = np.nan
    return q


#: Two eigenvalues t_1 of the Sylvester pencil are taken for one double value (two roots with the same
#: platform axis p_1: the agile eye's assemblies come in such pairs) when closer than this (relative).
#: Reason: a double eigenvalue of a float eigenproblem splits by ~sqrt(eps) ~ 1e-8; distinct ones of
#: a generic input are ~1e-2 apart. A wrong call costs a candidate (the input falls back), not a count.
DOUBLE_EIGENVALUE = 1e-6


def _partners(f, g, t1) -> np.ndarray:
    """t_2 (K, 8) for each eigenvalue t_1 (K, 8): of the two roots of f(t_1, .) = 0 (a quadratic in t_2,
    coefficients f (K, 3 powers of t_1, 3 powers of t_2)), the one where |g(t_1, .)| is smaller; for
    a double eigenvalue, the first root (in a fixed order) to its first copy and the second to the
    other (two roots sharing t_1 are the two roots of f there)."""
    powers = t1[..., None] ** np.arange(3)                                   # (K, 8, 3): 1, t1, t1^2
    fb = np.einsum("kna,kab->knb", powers, f)                                 # f = fb0 + fb1 t2 + fb2 t2^2
    gb = np.einsum("kna,kab->knb", powers, g)
    disc = np.sqrt(fb[..., 1] ** 2 - 4.0 * fb[..., 2] * fb[..., 0])
    big = -0.5 * (fb[..., 1] + np.where((np.conj(fb[..., 1]) * disc).real >= 0, disc, -disc))   # no cancellation
    roots = np.stack([big / fb[..., 2], fb[..., 0] / big], axis=-1)           # (K, 8, 2)
    swap = (roots[..., 0].real > roots[..., 1].real) | ((roots[..., 0].real == roots[..., 1].real)
                                                        & (roots[..., 0].imag > roots[..., 1].imag))
    roots = np.where(swap[..., None], roots[..., ::-1], roots)               # one order for both copies
    resid = np.abs(gb[..., 0, None] + gb[..., 1, None] * roots + gb[..., 2, None] * roots ** 2)
    resid = np.where(np.isfinite(resid), resid, np.inf)
    close = np.abs(t1[:, :, None] - t1[:, None, :]) <= DOUBLE_EIGENVALUE * (1.0 + np.abs(t1[:, :, None]))
    double = close.sum(axis=2) >= 2                                           # itself and another copy
    copy = np.tril(close, -1).sum(axis=2).clip(0, 1)                          # 0: first copy, 1: second
    pick = np.where(double, copy, np.argmin(resid, axis=-1))                  # a double value: one root each
    return np.take_along_axis(roots, pick[..., None], axis=-1)[..., 0]


class RealRoots:
    """The real roots of a chunk's complete inputs as arrays (one row per root: ``owner``, its input;
    ``slot``, its place among the 8), and what its reports read, computed for the whole chunk at once
    when first needed: the joint readings and their enclosures (:meth:`decide_ranges` needs them at
    once), the singularity classification, the poses and residuals, then each input's entries."""

    def __init__(self, compiled: "CompiledComplete", values, proof):
        self.compiled, self.values, self.proof = compiled, values, proof
        self.owner, self.slot = np.nonzero(proof.real & proof.complete[:, None])
        q = proof.roots[self.owner, self.slot].real                           # (R, 4), chart component 1
        self.displacements = quaternion_matrices(q) / (q * q).sum(axis=1)[:, None, None]
        self.keep = np.ones(len(self.owner), dtype=bool)

    @functools.cached_property
    def angles(self) -> np.ndarray:
        """(R, M): the passive readings of every root (radians, moved into their ranges)."""
        c = self.compiled
        at = self.values[self.owner]
        if not len(at):
            return np.zeros((0, len(c.names)))
        angles = c.readings(at, self.displacements @ c.equations.platform_reference)
        for j, name in enumerate(c.names):
            if c.ranges[name] is not None:
                angles[:, j] = into_range_many(angles[:, j], c.ranges[name])
        return angles

    @functools.cached_property
    def enclosures(self) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) (R, M): the passive readings enclosed over each root's proven box (radians), next
        to :attr:`angles` (whole turns); needed by :meth:`decide_ranges` and each entry's evidence,
        not by the results table."""
        c = self.compiled
        if not len(self.owner):
            empty = np.zeros((0, len(c.names)))
            return empty, empty
        lo, hi = c._enclosures(self.values[self.owner], self.proof.re_lo[self.owner, self.slot],
                               self.proof.re_hi[self.owner, self.slot])
        shift = TWO_PI * np.round((self.angles - 0.5 * (lo + hi)) / TWO_PI)
        return lo + shift, hi + shift

    def decide_ranges(self) -> np.ndarray:
        """Keep the roots whose every reading is proven in its range; (K,) how many of each input's
        are undecided (a reading whose enclosure straddles a range end: the input is passed on)."""
        c = self.compiled
        lo, hi = self.enclosures
        inside = np.ones(len(self.owner), dtype=bool)
        outside = np.zeros(len(self.owner), dtype=bool)
        for j, name in enumerate(c.names):
            rng = c.ranges[name]
            if rng is not None:
                inside &= span_in_range_many(lo[:, j], hi[:, j], rng)
                outside |= span_outside_range_many(lo[:, j], hi[:, j], rng)
        self.keep = inside
        return np.bincount(self.owner[~inside & ~outside], minlength=len(self.values))

    @functools.cached_property
    def table(self) -> ChunkRoots:
        """Every kept root, in the reports' order, classified and posed for the whole chunk at once."""
        c, proof = self.compiled, self.proof
        kept = np.flatnonzero(self.keep)
        angles = self.angles[kept]
        at = self.values[self.owner[kept]]
        poses = self.displacements[kept] @ c.equations.platform_reference

        def evidence(r: int) -> dict:
            k, m = int(self.owner[kept[r]]), int(self.slot[kept[r]])
            return {"bezout": {"bound": bezout.BEZOUT_BOUND, "roots_proven": int(proof.certified[k].sum()),
                               "real_roots": int(proof.real[k].sum()), "chart": int(proof.chart[k, m]),
                               "radius": float(proof.radius[k, m]), "model_tolerance": MODEL_TOLERANCE,
                               "quaternion_lo": proof.re_lo[k, m].tolist(), "quaternion_hi": proof.re_hi[k, m].tolist()}}

        return ChunkRoots(c.mechanism, c.names, self.values, self.owner[kept], angles,
                          lambda: tuple(x[kept] for x in self.enclosures), poses, c._closure(at, angles, poses), evidence)

    def solutions(self, k: int, count: int) -> LazySolutions:
        """Input k's ``count`` entries (:class:`~spherekin.results.LazySolutions` over :attr:`table`)."""
        return LazySolutions(count, lambda: self.table.entries(k), lambda: self.table.arrays(k))


class CompiledComplete(Compiled):
    """Eq. (1) compiled for the complete count: the float leg terms (the candidates), the interval
    parts of M (the proof), and the readings of :class:`~spherekin.systems.platform.PlatformSystem`."""

    system = "complete"
    chunk = PROVEN_CHUNK

    def __init__(self, mechanism, strategy):
        self.mechanism = mechanism
        self.strategy = strategy
        self.equations = PlatformSystem.from_mechanism(mechanism)
        self.legs = self.equations.legs
        self.terms = [leg_terms(leg) for leg in self.legs]
        self.parts = interval_leg_parts(self.legs)                                 # (2, 3, 3, 4, 4)
        self.reference = np.array([leg.reference[leg.actuated] for leg in self.legs], dtype=float)
        self.names = tuple(mechanism.loop_unknowns)
        self.ranges = {n: mechanism.ranges[n] for n in self.names}
        self.order = [passive_names(self.legs).index(n) for n in self.names]
        self.limited = any(r is not None for r in self.ranges.values())

    def describe(self) -> str:
        return "complete (Bezout count of Eq. (1))"

    def readings(self, inputs, poses) -> np.ndarray:
        return passive_readings_many(self.legs, inputs, np.asarray(poses, dtype=float),
                                     self.equations.platform_reference)[:, self.order]

    def matrices(self, rows) -> np.ndarray:
        """Interval matrices (2, K, 3, 4, 4) of Eq. (1) at K input rows (radians), every entry widened
        by :data:`MODEL_TOLERANCE`."""
        d = iv.sub(iv.point(np.asarray(rows, dtype=float)), iv.point(self.reference))     # (2, K, 3)
        cos, sin = iv.cos_sin(d)
        p = self.parts[:, None]                                                # (2, 1, 3, 3, 4, 4)
        m = iv.add(iv.add(iv.mul(cos[..., None, None], p[:, :, :, 0]), iv.mul(sin[..., None, None], p[:, :, :, 1])),
                   p[:, :, :, 2])
        return iv.outward(np.stack([m[0] - MODEL_TOLERANCE, m[1] + MODEL_TOLERANCE]))

    def candidates(self, rows) -> np.ndarray:
        """:func:`circle_candidates` at K input rows (radians): (K, 8, 4) complex."""
        d = np.asarray(rows, dtype=float) - self.reference
        w = np.stack([np.cos(d), np.sin(d), np.ones_like(d)], axis=-1)         # (K, 3 legs, 3)
        e = np.stack([w[:, i] @ t.e for i, t in enumerate(self.terms)], axis=1)
        b = np.stack([w[:, i] @ t.b for i, t in enumerate(self.terms)], axis=1)
        c = np.stack([w[:, i] @ t.c for i, t in enumerate(self.terms)], axis=1)
        return circle_candidates(e, b, c)

    def search_one(self, values, progress, trace):
        if trace is not None:
            raise ValueError("trace: only available with a loop formulation (paper, transversal, halves), "
                             "got the complete formulation")
        return self.search_many([values], progress)[0]

    def search_many(self, rows: list, progress) -> list:
        """Every input's roots proven at once (:func:`spherekin.core.bezout.certify_roots`): a
        :class:`~.base.Proven` where the count is complete and every reading decided against its
        range, else a :class:`~.base.Passed` saying what was missing. The entries of a chunk are
        arrays (:class:`RealRoots`); each report's :class:`~spherekin.results.Solution` objects are
        built when first read (:class:`~spherekin.results.LazySolutions`), for the whole chunk at once."""
        t0 = time.perf_counter()
        values = np.asarray(rows, dtype=float).reshape(len(rows), len(self.legs))
        proof = bezout.certify_roots(self.matrices(values), self.candidates(values))
        roots = RealRoots(self, values, proof)
        undecided = np.zeros(len(values), dtype=int)
        if self.limited:                         # the ranges decide which roots are kept, now
            undecided = roots.decide_ranges()
        counts = np.bincount(roots.owner[roots.keep], minlength=len(values))
        s = self.strategy
        settings = Settings(formulation=FORMULATION, pruner=s.pruner, lp_backend=s.lp_backend,
                            parameterization="quaternion", tol=s.tol, isolate=True, jobs=1, charts=CHARTS)
        stats = SolverStats(charts=CHARTS, isolated=bezout.BEZOUT_BOUND,             # roots proven
                            time_total=(time.perf_counter() - t0) / max(len(values), 1))
        report = SearchReport(self.names, (), (), stats, settings)
        out: list = []
        for k in range(len(values)):
            if not proof.complete[k]:
                out.append(Passed(self._why(proof, k)))
            elif undecided[k]:
                out.append(Passed(f"the complete count proved all {bezout.BEZOUT_BOUND} roots, but {undecided[k]} "
                                  "real one(s) could not be proven inside or outside the joint ranges (a reading "
                                  "next to a range end): searched with the platform equations"))
            else:
                out.append(Proven(report, roots.solutions(k, int(counts[k])), int(counts[k]), True))
        return out

    def _enclosures(self, at, q_lo, q_hi):
        """(lo, hi) (R, M): the passive readings (``names`` order) over the real quaternion boxes
        [q_lo, q_hi] (R, 4; chart component exact) at inputs ``at`` (R, legs)."""
        if not len(at):
            return np.zeros((0, len(self.names))), np.zeros((0, len(self.names)))
        q = iv.from_bounds(q_lo, q_hi)                                          # (2, R, 4)
        w, x, y, z = (q[..., i] for i in range(4))
        sq = lambda a: iv.mul(a, a)                                             # noqa: E731
        tw = lambda a, b: iv.scale(2.0, iv.mul(a, b))                           # noqa: E731
        ww, xx, yy, zz = sq(w), sq(x), sq(y), sq(z)
        rows = [[iv.sub(iv.add(ww, xx), iv.add(yy, zz)), iv.sub(tw(x, y), tw(w, z)), iv.add(tw(x, z), tw(w, y))],
                [iv.add(tw(x, y), tw(w, z)), iv.sub(iv.add(ww, yy), iv.add(xx, zz)), iv.sub(tw(y, z), tw(w, x))],
                [iv.sub(tw(x, z), tw(w, y)), iv.add(tw(y, z), tw(w, x)), iv.sub(iv.add(ww, zz), iv.add(xx, yy))]]
        s_q = np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)           # S(q) (2, R, 3, 3)
        norm = iv.add(iv.add(ww, xx), iv.add(yy, zz))                           # |q|^2 >= 1 (chart component 1)
        inv = iv.from_bounds(np.nextafter(1.0 / norm[1], -np.inf), np.nextafter(1.0 / norm[0], np.inf))
        d = iv.mul(s_q, inv[..., None, None])
        lo, hi = passive_reading_enclosures(self.legs, iv.point(at), d)
        return lo[:, self.order], hi[:, self.order]

    def _closure(self, at, angles, poses) -> np.ndarray:
        """The largest entry of |R_i - R| over the legs i (R, ): the platform rotation each leg's chain
        reaches at the readings, against the pose (the closure of the loops through the legs)."""
        if not len(at):
            return np.zeros(0)
        names = passive_names(self.legs)
        readings = np.empty((len(at), len(names)))
        readings[:, self.order] = angles
        col = {nm: j for j, nm in enumerate(names)}
        worst = np.zeros(len(at))
        for i, leg in enumerate(self.legs):
            chain = np.broadcast_to(np.eye(3), (len(at), 3, 3))
            for k, axis in enumerate((leg.a1, leg.a2, leg.a3)):
                value = at[:, i] if k == leg.actuated else readings[:, col[leg.names[k]]]
                chain = chain @ axis_rotations(axis, value - leg.reference[k])
            reached = chain @ self.equations.platform_reference
            worst = np.maximum(worst, np.abs(reached - poses).max(axis=(1, 2)))
        return worst

    @staticmethod
    def _why(proof, k) -> str:
        """Why input k's count is not complete (for ``settings.fallback``)."""
        proven = int(proof.certified[k].sum())
        if proven < bezout.BEZOUT_BOUND:
            return (f"the complete count proved {proven} of the {bezout.BEZOUT_BOUND} complex roots (two roots close "
                    "together: a fold or a double root nearby, or a degenerate input): searched with the platform "
                    "equations")
        if not proof.distinct[k]:
            return "the complete count could not prove its roots distinct: searched with the platform equations"
        return ("the complete count could not prove every root real or not real (a complex pair next to the real "
                "space): searched with the platform equations")


@(lambda cls: SYSTEMS.register(cls, first=True))      # before the platform system it imports
class Complete(System):
    """All 8 complex roots of Eq. (1) proven at once (Bezout's bound reached): three R-R-R legs, base joints actuated."""

    name = "complete"
    default_formulation = FORMULATION
    description = ("every root of the three leg quadrics proven at once, the count complete by Bezout's bound "
                   "(three R-R-R legs, base joints actuated)")

    @classmethod
    def formulations(cls) -> tuple[str, ...]:
        return (FORMULATION,)

    @classmethod
    def accepts(cls, mechanism, strategy=None) -> str | None:
        why = not_applicable(mechanism)
        if why is not None:
            return why
        driven = [leg.names[leg.actuated] for leg in platform_legs(mechanism) if leg.actuated != 0]
        if driven:
            return (f"the complete count reads the passive joints by interval formulas written for base-actuated "
                    f"legs, got {', '.join(driven)} actuated")
        gap = model_gap(mechanism)
        if gap > MODEL_TOLERANCE / 16:
            return (f"the model's distal link angles are {gap:.1e} from the description's (cosines), beyond what the "
                    f"complete count's model tolerance ({MODEL_TOLERANCE:g}) covers with room")
        if strategy is None:
            return None
        return own_variables_declined(strategy, FORMULATION, "the complete count")

    @classmethod
    def compile(cls, mechanism, strategy) -> CompiledComplete:
        return CompiledComplete(mechanism, strategy)
