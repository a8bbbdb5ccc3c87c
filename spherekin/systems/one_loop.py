"""The complete count of a one-loop linkage with three passive joints: bound 2 (issue 44).

A mechanism of two legs from the ground to one output link (a spherical four-bar driven at one
joint, a five-bar at two) has one loop; written as its product of exponentials around the loop,
starting at its first passive joint p,

    Rot(a_p, x) K1 Rot(a_q, y) K2 Rot(a_r, z) K3 = I        (x, y, z: the passive displacements, signed)

with K1, K2, K3 products of the known (actuated) joints' rotations. Moving the knowns through:
Rot(a_p, x) Rot(b, y) Rot(c, z) = G with b = K1 a_q, c = K1 K2 a_r, G = (K1 K2 K3)^T: a spherical 3R
chain that must reach G. Applied to c and read along a_p (G c = K3^T a_r):

    A cos y + B sin y = C,   A = a_p . (c - (b . c) b),   B = a_p . (b x c),   C = a_p . G c - (b . c)(a_p . b)

In t = tan(y / 2) (homogeneous: the projective line) this is a quadratic form: at most 2 roots, or
every y (A = B = C = 0: a continuum). **The complete count**: with A, B, C enclosed in outward-rounded
interval arithmetic (every matrix of the model's axes, the inputs' cos and sin), D = A^2 + B^2 - C^2
> 0 proves two distinct real roots and D < 0 none (two complex ones): Bezout in P^1, so that is every
assembly; D's enclosure holding 0 (a branch or change point within its width, a continuum) passes
the input on to the loop equations. Each real y = atan2(B, A) +- acos(C / sqrt(A^2 + B^2)) is
enclosed, then x = the angle about a_p from Rot(b, y) c to G c and z = the angle about c from
G^T a_p to Rot(b, -y) a_p, unique where the arcs are proper (else the input is passed on); the joint
ranges are decided on those enclosures as in :mod:`spherekin.systems.complete`.
"""

from __future__ import annotations

import functools
import time

import numpy as np

from ..core import intervals as iv
from ..core.angles import TWO_PI, into_range_many, span_in_range_many, span_outside_range_many, wrap
from ..core.rotations import cross
from ..mechanism.chains import axis_rotations
from .proven_roots import PROVEN_CHUNK, ChunkRoots
from ..results import LazySolutions, SearchReport, Settings, SolverStats
from .base import SYSTEMS, Compiled, Passed, Proven, System, own_variables_declined

__all__ = ["FORMULATION", "BOUND", "LOOP_TOLERANCE", "not_one_loop", "LoopCycle", "CompiledOneLoop", "OneLoop"]

#: The formulation name that selects this system.
FORMULATION = "complete-loop"
#: Most isolated roots of A cos y + B sin y = C (a quadratic form on the projective line).
BOUND = 2
#: Half-width added to A, B and C (absolute). Reason: as the complete count's MODEL_TOLERANCE, the
#: proof covers the mechanism as described: axes within ~1e-15 of the file's move each of A, B, C (sums
#: of at most 3 products of unit vectors) by less than 1e-14; 1e-13 covers that with room.
LOOP_TOLERANCE = 1e-13


def not_one_loop(mechanism) -> str | None:
    """Why the one-loop count does not apply (None when it does): two legs from the ground to one
    output link with exactly three passive joints among them."""
    legs = getattr(mechanism, "legs", None) or ()
    if len(legs) != 2:
        return f"the one-loop count needs two legs from the ground to one output link, got {len(legs)}"
    passive = [j.name for leg in legs for j in leg.joints if not j.actuated]
    if len(passive) != 3:
        return f"the one-loop count needs 3 passive joints in its loop (one equation left), got {len(passive)}"
    return None


class LoopCycle:
    """The loop of a two-leg mechanism as one cycle of signed joints, from its first passive joint:
    ``items`` [(axis (3,), sign, name, reference, column or None)] with column the actuated joint's index
    (None: passive); ``p, q, r``: the passive joints' places in it (p = 0)."""

    def __init__(self, mechanism):
        left, right = mechanism.legs
        actuated = list(mechanism.actuated)
        seq = [(j, 1.0) for j in left.joints] + [(j, -1.0) for j in reversed(right.joints)]
        first = next(k for k, (j, _) in enumerate(seq) if not j.actuated)
        seq = seq[first:] + seq[:first]
        self.items = [(np.array(j.axis, dtype=float), s, j.name, float(j.reference_angle),
                       actuated.index(j.name) if j.actuated else None) for j, s in seq]
        self.p, self.q, self.r = (k for k, it in enumerate(self.items) if it[4] is None)

    def apply(self, vec, places, trig, inverse: bool, interval: bool):
        """Rot(E_i) ... applied to ``vec`` (3,) for the known joints at ``places`` (their product in cycle
        order, the innermost applied first; ``inverse``: the transpose); ``trig``: place -> (cos, sin) of
        its displacement at the input rows (:meth:`trig`). A float (N, 3) array or an interval one (2, N, 3)."""
        n = (next(iter(trig.values()))[0].shape[-1]) if trig else 0
        order = list(places) if inverse else list(reversed(places))
        v = np.broadcast_to(vec, (n, 3)).copy()
        v = iv.point(v) if interval else v
        for k in order:
            axis, sign, _, _, _ = self.items[k]
            turn = -sign if inverse else sign
            c, s = trig[k]
            if interval:
                v = iv.rotate_about(axis, c, iv.scale(turn, s), v)
            else:
                v = np.einsum("nij,nj->ni", _rotations_cs(axis, c, turn * s), v)
        return v

    def trig(self, rows, interval: bool) -> dict:
        """place -> (cos, sin) of each known joint's displacement (input - reference) at the rows (N,
        actuated): floats (N,) or intervals (2, N), each computed once."""
        out = {}
        for k, (_, _, _, ref, col) in enumerate(self.items):
            if col is None:
                continue
            if interval:
                out[k] = iv.cos_sin(iv.sub(iv.point(rows[:, col]), iv.point(np.full(len(rows), ref))))
            else:
                d = rows[:, col] - ref
                out[k] = (np.cos(d), np.sin(d))
        return out

    def terms(self, rows, interval: bool):
        """(a_p, b, c, G c, G^T a_p) at input rows: b = K1 a_q, c = K1 K2 a_r, G c = K3^T a_r,
        G^T a_p = K1 K2 K3 a_p (module doc)."""
        p, q, r = self.p, self.q, self.r
        known = [k for k in range(len(self.items)) if self.items[k][4] is not None]
        k1 = [k for k in known if p < k < q]
        k12 = [k for k in known if p < k < r]
        k3 = [k for k in known if k > r]
        a_p, a_q, a_r = self.items[p][0], self.items[q][0], self.items[r][0]
        trig = self.trig(rows, interval)
        return (a_p, self.apply(a_q, k1, trig, False, interval), self.apply(a_r, k12, trig, False, interval),
                self.apply(a_r, k3, trig, True, interval), self.apply(a_p, known, trig, False, interval))


def _abc_float(a_p, b, c, gc):
    bc = np.einsum("ni,ni->n", b, c)
    a = c @ a_p - bc * (b @ a_p)
    bb = cross(b, c) @ a_p
    cc = gc @ a_p - bc * (b @ a_p)
    return a, bb, cc


def _abc_interval(a_p, b, c, gc):
    bc = iv.isum(iv.mul(b, c), -1)
    ap_b = iv.isum(iv.scale(a_p, b), -1)
    a = iv.sub(iv.isum(iv.scale(a_p, c), -1), iv.mul(bc, ap_b))
    bxc = np.stack([iv.sub(iv.mul(b[..., i], c[..., j]), iv.mul(b[..., j], c[..., i]))
                    for i, j in ((1, 2), (2, 0), (0, 1))], axis=-1)
    bb = iv.isum(iv.scale(a_p, bxc), -1)
    cc = iv.sub(iv.isum(iv.scale(a_p, gc), -1), iv.mul(bc, ap_b))
    widen = lambda x: iv.outward(np.stack([x[0] - LOOP_TOLERANCE, x[1] + LOOP_TOLERANCE]))   # noqa: E731
    return widen(a), widen(bb), widen(cc)


def _angle_about_rows(axis, x, y) -> np.ndarray:
    """Signed angles (N,) about the unit vectors ``axis`` (N, 3 or 3,) from x to y (N, 3)."""
    axis = np.broadcast_to(axis, x.shape)
    xp = x - np.einsum("ni,ni->n", x, axis)[:, None] * axis
    yp = y - np.einsum("ni,ni->n", y, axis)[:, None] * axis
    return np.arctan2(np.einsum("ni,ni->n", axis, cross(xp, yp)), np.einsum("ni,ni->n", xp, yp))


def _arc_about(axis, x, y):
    """(lo, hi) (N,): the angle about ``axis`` (float (3,) or intervals (2, N, 3)) from x to y (intervals
    (2, N, 3)): atan2(axis . (x x y), x . y - (axis . x)(axis . y)) over the boxes."""
    if np.ndim(axis) == 1:
        ax = iv.point(np.broadcast_to(axis, x.shape[1:]).copy())
    else:
        ax = axis
    xy = np.stack([iv.sub(iv.mul(x[..., i], y[..., j]), iv.mul(x[..., j], y[..., i]))
                   for i, j in ((1, 2), (2, 0), (0, 1))], axis=-1)
    sin_part = iv.isum(iv.mul(ax, xy), -1)
    cos_part = iv.sub(iv.isum(iv.mul(x, y), -1), iv.mul(iv.isum(iv.mul(ax, x), -1), iv.isum(iv.mul(ax, y), -1)))
    return iv.arc(cos_part, sin_part)


def _rotate_rows(axis, c, s, v):
    """Rot(axis, theta) v for interval axes (2, N, 3), cos/sin (2, N) and vectors (2, N, 3) (Rodrigues)."""
    along = iv.isum(iv.mul(axis, v), -1)
    axv = np.stack([iv.sub(iv.mul(axis[..., i], v[..., j]), iv.mul(axis[..., j], v[..., i]))
                    for i, j in ((1, 2), (2, 0), (0, 1))], axis=-1)
    out = iv.add(iv.mul(c[..., None], v), iv.mul(s[..., None], axv))
    one_minus = iv.sub(iv.point(np.ones(c.shape[1:])), c)
    return iv.add(out, iv.mul(axis, iv.mul(one_minus, along)[..., None]))


class CompiledOneLoop(Compiled):
    """A one-loop mechanism compiled for its complete count: the cycle and the ranges."""

    system = "complete-loop"
    chunk = PROVEN_CHUNK

    def __init__(self, mechanism, strategy):
        self.mechanism, self.strategy = mechanism, strategy
        self.cycle = LoopCycle(mechanism)
        self.names = tuple(mechanism.loop_unknowns)
        self.ranges = {n: mechanism.ranges[n] for n in self.names}
        self.limited = any(r is not None for r in self.ranges.values())
        items = self.cycle.items
        self.passive = tuple((items[k][2], items[k][1], items[k][3]) for k in (self.cycle.p, self.cycle.q, self.cycle.r))
        self.column = [self.names.index(name) for name, _, _ in self.passive]

    def describe(self) -> str:
        return "complete-loop (A cos y + B sin y = C, bound 2)"

    def readings(self, inputs, points):
        raise NotImplementedError("the one-loop count reports its readings itself")

    def search_one(self, values, progress, trace):
        if trace is not None:
            raise ValueError("trace: only available with a loop formulation (paper, transversal, halves), "
                             "got the complete-loop formulation")
        return self.search_many([values], progress)[0]

    def search_many(self, rows: list, progress) -> list:
        t0 = time.perf_counter()
        values = np.asarray(rows, dtype=float).reshape(len(rows), len(self.mechanism.actuated))
        n = len(values)
        a_p, b, c, gc, gta = self.cycle.terms(values, interval=True)
        a_iv, b_iv, c_iv = _abc_interval(a_p, b, c, gc)
        disc = iv.sub(iv.add(iv.mul(a_iv, a_iv), iv.mul(b_iv, b_iv)), iv.mul(c_iv, c_iv))
        two, none = disc[0] > 0.0, disc[1] < 0.0
        roots = LoopRoots(self, values, np.flatnonzero(two), (a_iv, b_iv, c_iv), (a_p, b, c, gc, gta))
        undecided = roots.decide()
        counts = np.bincount(roots.owner[roots.keep], minlength=n)
        s = self.strategy
        settings = Settings(formulation=FORMULATION, pruner=s.pruner, lp_backend=s.lp_backend,
                            parameterization="tan-half", tol=s.tol, isolate=True, jobs=1, charts=0)
        stats = SolverStats(isolated=BOUND, time_total=(time.perf_counter() - t0) / max(n, 1))
        report = SearchReport(self.names, (), (), stats, settings)
        out: list = []
        for k in range(n):
            if not (two[k] or none[k]):
                out.append(Passed(f"the one-loop count could not decide the sign of A^2 + B^2 - C^2 (enclosure "
                                  f"[{disc[0][k]:.1e}, {disc[1][k]:.1e}]: a branch or change point within it, or a "
                                  "continuum): searched with the loop equations"))
            elif undecided[k]:
                out.append(Passed(f"the one-loop count proved its {BOUND} roots, but {undecided[k]} real one(s) could "
                                  "not be proven inside or outside the joint ranges, or their readings not enclosed: "
                                  "searched with the loop equations"))
            else:
                out.append(Proven(report, roots.solutions(k, int(counts[k])),
                                  int(counts[k]), True))
        return out


class LoopRoots:
    """The real roots (two per input with D > 0) of a chunk as arrays: their angles, enclosures and ranges."""

    def __init__(self, compiled: CompiledOneLoop, values, inputs, abc_iv, terms_iv):
        self.compiled, self.values = compiled, values
        self.owner = np.repeat(inputs, 2)
        self.branch = np.tile([1.0, -1.0], len(inputs))
        m = len(self.owner)
        at = values[self.owner]
        # floats: y = phi +- delta, then x and z (module doc)
        a_p, b, c, gc, gta = compiled.cycle.terms(at, interval=False)
        fa, fb, fc = _abc_float(a_p, b, c, gc)
        rho = np.hypot(fa, fb)
        with np.errstate(invalid="ignore", divide="ignore"):
            y = np.arctan2(fb, fa) + self.branch * np.arccos(np.clip(fc / rho, -1.0, 1.0))
        v = np.einsum("nij,nj->ni", _rotations_rows(b, y), c)
        x = _angle_about_rows(a_p, v, gc)
        u1 = np.einsum("nij,nj->ni", _rotations_rows(b, -y), np.broadcast_to(a_p, (m, 3)))
        z = _angle_about_rows(c, gta, u1)
        self.angles = np.empty((m, len(compiled.names)))
        disp = (x, y, z)
        for k, (name, sign, ref) in enumerate(compiled.passive):
            self.angles[:, compiled.column[k]] = wrap(ref + sign * disp[k])
        # intervals: y, x, z over everything the proof covers
        self.lo, self.hi = self._enclosures(inputs, abc_iv, terms_iv)
        self.keep = np.ones(m, dtype=bool)

    def _enclosures(self, inputs, abc_iv, terms_iv):
        c = self.compiled
        m = len(self.owner)
        lo, hi = np.full((m, len(c.names)), np.nan), np.full((m, len(c.names)), np.nan)
        if not m:
            return lo, hi
        pick = lambda arr: np.repeat(arr[:, inputs], 2, axis=1)                # noqa: E731
        a_iv, b_iv, c_iv = (pick(x) for x in abc_iv)
        a_p, b, cv, gc, gta = terms_iv
        b, cv, gc, gta = (pick(x) for x in (b, cv, gc, gta))
        phi_lo, phi_hi = iv.arc(a_iv, b_iv)
        rho2 = iv.add(iv.mul(a_iv, a_iv), iv.mul(b_iv, b_iv))
        with np.errstate(invalid="ignore", divide="ignore"):
            rho = iv.outward(np.sqrt(np.maximum(rho2, 0.0)))
            ratio = np.stack([np.minimum(c_iv[0] / rho[1], c_iv[0] / rho[0]), np.maximum(c_iv[1] / rho[1], c_iv[1] / rho[0])])
            ratio = iv.outward(ratio)
            ok = np.isfinite(ratio).all(axis=0) & (ratio[0] > -1.0) & (ratio[1] < 1.0) & (rho[0] > 0)
            d_lo = np.arccos(np.clip(ratio[1], -1.0, 1.0)) - iv.ARC_PAD      # arccos decreases
            d_hi = np.arccos(np.clip(ratio[0], -1.0, 1.0)) + iv.ARC_PAD
        branch = self.branch
        y_lo = np.where(branch > 0, phi_lo + d_lo, phi_lo - d_hi)
        y_hi = np.where(branch > 0, phi_hi + d_hi, phi_hi - d_lo)
        ok &= np.isfinite(y_lo) & np.isfinite(y_hi)
        y_lo, y_hi = np.where(ok, y_lo, 0.0), np.where(ok, y_hi, 0.0)
        cy, sy = iv.cos_sin(iv.from_bounds(y_lo, y_hi))
        v = _rotate_rows(b, cy, sy, cv)
        x_lo, x_hi = _arc_about_axis(a_p, v, gc)
        ap = iv.point(np.broadcast_to(a_p, (m, 3)).copy())
        u1 = _rotate_rows(b, cy, iv.neg(sy), ap)
        z_lo, z_hi = _arc_about(cv, gta, u1)
        disp = ((x_lo, x_hi), (y_lo, y_hi), (z_lo, z_hi))
        for k, (name, sign, ref) in enumerate(c.passive):
            d_lo_k, d_hi_k = disp[k]
            if sign < 0:
                d_lo_k, d_hi_k = -d_hi_k, -d_lo_k
            j = c.column[k]
            lo[:, j] = np.where(ok, ref + d_lo_k, np.nan)
            hi[:, j] = np.where(ok, ref + d_hi_k, np.nan)
        # each enclosure next to its float reading (whole turns)
        shift = TWO_PI * np.round((self.angles - 0.5 * (lo + hi)) / TWO_PI)
        return lo + shift, hi + shift

    def decide(self) -> np.ndarray:
        """Keep the roots proven inside every range; (K,) how many of each input's are undecided (an
        enclosure straddling a range end, or unknown)."""
        c = self.compiled
        known = np.all(np.isfinite(self.lo) & np.isfinite(self.hi), axis=1)
        inside = known.copy()
        outside = np.zeros(len(self.owner), dtype=bool)
        for j, name in enumerate(c.names):
            rng = c.ranges[name]
            if rng is not None:
                inside &= span_in_range_many(self.lo[:, j], self.hi[:, j], rng)
                outside |= span_outside_range_many(self.lo[:, j], self.hi[:, j], rng)
                self.angles[:, j] = into_range_many(self.angles[:, j], rng)
        self.keep = inside
        return np.bincount(self.owner[~inside & ~outside], minlength=len(self.values))

    @functools.cached_property
    def table(self) -> ChunkRoots:
        """Every kept root, in the reports' order, classified and posed for the whole chunk at once."""
        c = self.compiled
        mech = c.mechanism
        kept = np.flatnonzero(self.keep)
        at = self.values[self.owner[kept]]
        angles = self.angles[kept]
        poses = mech.poses_from_passive(at, {nm: angles[:, j] for j, nm in enumerate(c.names)}) if len(kept) else None
        closure = _closure(mech, at, angles, c.names) if len(kept) else np.zeros(0)
        evidence = {"bezout": {"bound": BOUND, "roots_proven": BOUND, "real_roots": BOUND,
                               "discriminant_positive": True, "model_tolerance": LOOP_TOLERANCE}}
        return ChunkRoots(mech, c.names, self.values, self.owner[kept], angles,
                          lambda: (self.lo[kept], self.hi[kept]), poses,
                          closure, lambda r: {"bezout": dict(evidence["bezout"])})

    def solutions(self, k: int, count: int) -> LazySolutions:
        """Input k's ``count`` entries (:class:`~spherekin.results.LazySolutions` over :attr:`table`)."""
        return LazySolutions(count, lambda: self.table.entries(k), lambda: self.table.arrays(k))


def _rotations_cs(axis, c, s) -> np.ndarray:
    """Rot(axis, theta) (N, 3, 3) for a unit axis (3,) from cos and sin theta (N,) (Rodrigues)."""
    a = np.asarray(axis, dtype=float)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + s[:, None, None] * k + (1.0 - c)[:, None, None] * (k @ k)


def _rotations_rows(axes, angles) -> np.ndarray:
    """Rot(axes[n], angles[n]) (N, 3, 3) for unit axes (N, 3) (Rodrigues)."""
    k = np.zeros(axes.shape[:1] + (3, 3))
    k[:, 0, 1], k[:, 0, 2], k[:, 1, 2] = -axes[:, 2], axes[:, 1], -axes[:, 0]
    k[:, 1, 0], k[:, 2, 0], k[:, 2, 1] = axes[:, 2], -axes[:, 1], axes[:, 0]
    s, c = np.sin(angles)[:, None, None], np.cos(angles)[:, None, None]
    return np.eye(3) + s * k + (1.0 - c) * (k @ k)


def _arc_about_axis(axis, x, y):
    """:func:`_arc_about` for a float axis (3,)."""
    return _arc_about(axis, x, y)


def _closure(mech, at, angles, names) -> np.ndarray:
    """The largest entry of |R_left - R_right| (N,): the output link's rotation through each leg."""
    readings = {**{nm: at[:, i] for i, nm in enumerate(mech.actuated)}, **{nm: angles[:, j] for j, nm in enumerate(names)}}
    chains = []
    for leg in mech.legs:
        r = np.broadcast_to(np.eye(3), (len(at), 3, 3))
        for j in leg.joints:
            r = r @ axis_rotations(np.array(j.axis, dtype=float), readings[j.name] - j.reference_angle)
        chains.append(r)
    return np.abs(chains[0] - chains[1]).max(axis=(1, 2))


@(lambda cls: SYSTEMS.register(cls, first=True))
class OneLoop(System):
    """Every assembly of a one-loop linkage with three passive joints proven at once (bound 2)."""

    name = "complete-loop"
    default_formulation = FORMULATION
    description = ("the one loop's equation A cos y + B sin y = C, both roots proven at once, the count complete "
                   "(two legs to one output link, three passive joints)")

    @classmethod
    def formulations(cls) -> tuple[str, ...]:
        return (FORMULATION,)

    @classmethod
    def accepts(cls, mechanism, strategy=None) -> str | None:
        why = not_one_loop(mechanism)
        if why is not None or strategy is None:
            return why
        return own_variables_declined(strategy, FORMULATION, "the one-loop count")

    @classmethod
    def compile(cls, mechanism, strategy) -> CompiledOneLoop:
        return CompiledOneLoop(mechanism, strategy)

