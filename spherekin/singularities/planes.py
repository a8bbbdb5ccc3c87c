"""Parallel (Type-2) singular sets in a plane of actuator inputs: the augmented systems (issue 31).

A plane P = {x = beta_a in [xlo, xhi], y = beta_b in [ylo, yhi], the other inputs fixed} (y may be
absent: a line). The plane inputs become unknowns on tan-half charts, t = tan((beta - shift)/2), and
each equation that depends on beta is multiplied by 1 + t^2 (degree 2 in t, no new zeros):
cos d = (1 - t^2)/(1 + t^2), sin d = 2t/(1 + t^2) after the shift.

**Platform system** (3-RRR family, :mod:`spherekin.systems.platform`): unknowns (q_a, q_b, q_c) of the
quaternion chart k (q_k = 1) and the plane's t_x (, t_y). Equations, tensor degrees over (q_a, q_b,
q_c, t_x, t_y):

* F_i = (1 + t_i^2) q^T M_i(d_i) q for each leg (degree (2, 2, 2) in q, 2 in its own t);
* D = det G_k, G_k = [(M_i q)_j] (rows: legs, columns: j != k) (degree (3, 3, 3) in q, 2 in each t).

Why D is the Type-2 condition: grad_q (q^T M_i q) = 2 M_i q =: g_i, and by Euler g_i . q = 2 q^T M_i q
= 0 on the closure set, so the rows of the 3 x 4 matrix [g_i] are orthogonal to q. When it has rank 3
its 3 x 3 minors are proportional to the components of its kernel vector q; with q_k = 1 the minor
without column k is not 0. So, on the closure set, D = 0 iff rank [g_i] < 3 iff the leg constraints'
gradients in the platform orientation are dependent: a parallel singularity (the passive Jacobian
loses rank). Degree 3 in q, where the rotation-matrix form would give 6.

Everything is in Bernstein form on unit boxes (:class:`spherekin.search.parameterizations.ChartSet`),
so the box loop prunes it as it prunes the closure equations (:func:`spherekin.search.boxloop.search_cover`);
:meth:`PlatformPlane.prove` runs the Krawczyk test on the square slices the trust layer certifies.
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass, field
from fractions import Fraction
from types import SimpleNamespace

import numpy as np

from ..closure import tan_half_angle, tan_half_unit
from ..core import bernstein, intervals
from ..core.orientation import quaternions_from_rotations
from ..search.isolation import (SquareSystem, evaluate_at, full_rank_proven, jacobian_at, krawczyk_boxes,
                                krawczyk_parametric, newton)
from ..search.parameterizations import CHART_MAX_WIDTH, ROUNDING_SAFETY, ChartSet, Parameterization
from ..results import CuspSearch
from ..systems import SYSTEMS
from ..systems.platform import CHART_EXTENT, CHARTS, Quaternion, chart_control_points, leg_matrices, platform_legs

__all__ = ["SingularPlane", "plane_charts", "PlaneParameterization", "PlatformPlane", "LoopPlane", "Q_VARIABLES",
           "LoopColumn", "DetPlan", "det_plan", "MAX_LAPLACE_TERMS", "MAX_DET_COEFFS",
           "SPURIOUS_BOUND", "CUSP_SQUARE",
           "cusp_newton", "cusp_krawczyk", "stationary_quaternions", "PLANES", "plane_system"]

#: Half-width (in unit coordinates of a slice's box) of the small box around Newton's root on which the
#: Krawczyk test is run again when it fails on the whole box: the interval Jacobian over a box of the
#: cover's size (~T) is often too loose for K(X) to fit in X, while on a box 1e-4 of it the Jacobian is
#: nearly a point and a regular root is proven. Any small value works (the root must be at least this far
#: inside the box, so the proven root is in the cell).
PROOF_RADIUS = 1e-4
#: Newton steps of :meth:`PlatformPlane.predict` (a predictor from a box's centre; quadratic convergence from
#: a box of the cover's size) and the last step (unit coordinates of the box) below which it counts as converged.
PREDICT_STEPS = 6
PREDICT_CONVERGED = 1e-6
#: Pieces per batch of :meth:`PlatformPlane.trace` (memory: each piece copies its box's control points, ~8 kB,
#: several times over in the Krawczyk test: ~0.2 GB a batch).
PIECE_BATCH = 8192
#: Boxes per batch of :meth:`PlatformPlane.cusp_free` (memory: ~8 kB of control points per box).
CUSP_FREE_BATCH = 4096
#: The square slice: the three legs' equations (block 0) and D (block 1).
_SLICE = SquareSystem(((0, 0), (0, 1), (0, 2), (1, 0)))

#: The platform's orientation variables on a quaternion chart (the three free components).
Q_VARIABLES = ("q_a", "q_b", "q_c")


@dataclass(frozen=True)
class SingularPlane:
    """A plane (or line) of actuator inputs: ``x`` = (name, lo, hi) and ``y`` = (name, lo, hi) or None
    (radians, lo < hi, hi - lo <= 2 pi), ``fixed``: every other actuated joint's reading (name -> radians)."""

    x: tuple
    y: tuple | None
    fixed: dict = field(default_factory=dict)

    @property
    def axes(self) -> tuple:
        """The plane's inputs, x first: ((name, lo, hi), ...)."""
        return (self.x,) if self.y is None else (self.x, self.y)


def plane_charts(lo: float, hi: float) -> list[tuple[float, float]]:
    """Equal tan-half chart ranges (radians) covering [lo, hi], each no wider than CHART_MAX_WIDTH (|t| <= 1
    on a chart of width pi). Unlike :func:`spherekin.search.parameterizations.charts_for_range`, a full turn
    [lo, lo + 2 pi] keeps its own ends, so that the angles of the chart boxes lie in [lo, hi] unwrapped."""
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ValueError(f"range: expected finite lo < hi (radians), got {(lo, hi)!r}")
    pieces = max(1, math.ceil((hi - lo) / CHART_MAX_WIDTH - 1e-12))
    edges = np.linspace(lo, hi, pieces + 1)
    return [(float(a), float(b)) for a, b in zip(edges[:-1], edges[1:])]


class PlaneParameterization(Parameterization):
    """The variables of a plane system: ``n_q`` of the mechanism's own (quaternion chart components,
    metric u = CHART_EXTENT (2x - 1); or any affine metric), then the plane inputs' tan-half variables
    (metric: the input, radians). ``angle_box`` gives (u..., beta_x, beta_y) bounds; :meth:`unit` inverts
    it. With ``quaternion`` (the default) its contraction is the quaternion charts'
    (:meth:`spherekin.systems.platform.Quaternion.contract`: a chart searches its core, not the cores of
    the charts before it), charts numbered plane-combination major with the quaternion chart last
    (chart % CHARTS); without, none (the blow-up patches of :class:`StationaryPlane`)."""

    name = "plane"

    def __init__(self, n_q: int, quaternion: bool = True):
        self.n_q = n_q
        self.quaternion = quaternion

    def metric(self, charts, chart, x):
        x = np.asarray(x, dtype=float)
        lo, hi, shift = charts.map_lo[chart], charts.map_hi[chart], charts.shift[chart]
        q = self.n_q
        return np.concatenate([lo[:, :q] + (hi[:, :q] - lo[:, :q]) * x[:, :q],
                               tan_half_angle(x[:, q:], shift[:, q:], lo[:, q:], hi[:, q:])], axis=1)

    def unit(self, charts, chart, v):
        """Unit coordinates (B, N) of metric coordinates v (B, N) in charts ``chart`` (B,)."""
        v = np.asarray(v, dtype=float)
        lo, hi, shift = charts.map_lo[chart], charts.map_hi[chart], charts.shift[chart]
        q = self.n_q
        return np.concatenate([(v[:, :q] - lo[:, :q]) / (hi[:, :q] - lo[:, :q]),
                               tan_half_unit(v[:, q:], shift[:, q:], lo[:, q:], hi[:, q:])], axis=1)

    def contract(self, charts, chart, lo, hi, rlo, rhi):
        if not self.quaternion:
            return
        q = self.n_q
        view = SimpleNamespace(map_lo=charts.map_lo[:, :q], map_hi=charts.map_hi[:, :q])
        sub_lo, sub_hi = rlo[:, :q].copy(), rhi[:, :q].copy()
        Quaternion().contract(view, chart, lo[:, :q], hi[:, :q], sub_lo, sub_hi)
        drop = np.any(sub_lo > sub_hi, axis=1) & ~np.any(rlo[:, :q] > rhi[:, :q], axis=1)
        rlo[drop] = 1.0
        rhi[drop] = 0.0


def _weights(s0: float, t_lo, t_hi) -> np.ndarray:
    """Bernstein control points (..., 3 parts, 3) over x in [0, 1] of (1 + t^2) (cos d, sin d, 1) with
    d = s0 + 2 atan t, t = t_lo + (t_hi - t_lo) x (``t_lo``, ``t_hi``: (B,))."""
    a = np.asarray(t_lo, dtype=float)
    b = np.asarray(t_hi, dtype=float) - a
    zero, one = np.zeros_like(a), np.ones_like(a)
    p1 = np.stack([one, zero, zero], axis=-1)                    # power coefficients in x of 1, t, t^2
    pt = np.stack([a, b, zero], axis=-1)
    pt2 = np.stack([a * a, 2 * a * b, b * b], axis=-1)
    c, s = math.cos(s0), math.sin(s0)
    power = np.stack([c * (p1 - pt2) - s * 2 * pt, s * (p1 - pt2) + c * 2 * pt, p1 + pt2], axis=-2)
    return bernstein.from_power(power, nvars=1)


def _one_plus_t2(charts, c, v: int, n: int) -> np.ndarray:
    """(1 + t_v^2) (B, 1, .., 3, .., 1) in Bernstein form over the unit variable v of the charts ``c`` (index
    array (B,)) of ``charts``, t_v = lo + (hi - lo) x: (1 + lo^2) + 2 lo w x + w^2 x^2 (n variables)."""
    lo = np.asarray(charts.map_lo[c, v], dtype=float).reshape(-1)
    w = np.asarray(charts.map_hi[c, v], dtype=float).reshape(-1) - lo
    net = bernstein.from_power(np.stack([1.0 + lo * lo, 2.0 * lo * w, w * w], axis=-1), nvars=1)
    shape = [len(lo)] + [1] * n
    shape[1 + v] = 3
    return net.reshape(shape)


def _linear_basis(k: int) -> np.ndarray:
    """(4, 2, 2, 2): Bernstein control points (degree 1 per variable) of each quaternion component on
    chart k: q_k = 1, the others CHART_EXTENT (2x - 1) in their variable."""
    out = np.empty((4, 2, 2, 2))
    others = [j for j in range(4) if j != k]
    for comp in range(4):
        if comp == k:
            out[comp] = 1.0
        else:
            shape = [1, 1, 1]
            shape[others.index(comp)] = 2
            out[comp] = np.broadcast_to(np.array([-CHART_EXTENT, CHART_EXTENT]).reshape(shape), (2, 2, 2))
    return out


#: Candidate stationary quaternions (:func:`stationary_quaternions`), scaled so that their largest component is
#: 1, are rounded to multiples of this before the exact test: the rotation fitted by the SVD is exact only to
#: rounding (1e-16), while the exact test needs the exact point (for the agile eye (1, +-1, +-1, +-1)). A
#: candidate is only a guess: the test in rational arithmetic decides, so a stationary pose whose
#: quaternion is not on this grid is missed (no certificate), never claimed.
STATIONARY_GRID = 2.0 ** -20
#: A sign pattern's fitted rotation is a candidate when it maps every a3_i within this of s_i a1_i (unit
#: vectors). Reason: only a filter before the exact test, which decides: a pattern no rotation fits misses
#: by O(1) (unit vectors at wrong angles); a fitting one by the SVD's rounding, ~1e-15.
STATIONARY_FIT = 1e-6


def stationary_quaternions(legs, mats) -> tuple[np.ndarray, ...]:
    """The platform orientations at which every leg's equation holds whatever its input: quaternions (4,)
    (floats, largest component 1) with q^T M[i, part] q == 0 *exactly* (rational arithmetic on the float
    matrices ``mats`` (3 legs, 3 parts, 4, 4), :func:`spherekin.systems.platform.leg_matrices`) for every
    leg i and part (cos d, sin d, 1): then q^T M_i(d) q = 0 for every d, so q is a closure of the system
    at every input (a stationary assembly: each leg in a serial singularity, its input turning the elbow
    about the platform joint's axis). Candidates (base-actuated legs only; else none): for each sign
    pattern s in {+-1}^3 the rotation R fitted (SVD) to R a3_i = s_i a1_i (leg i's equation
    e(d) . (R a3) = c is independent of d iff R a3 is along a1), rounded (STATIONARY_GRID). The agile eye
    (examples/gosselin.toml) has four: (1, 1, 1, 1), (1, 1, -1, -1), (1, -1, 1, -1), (1, -1, -1, 1)."""
    if any(leg.actuated != 0 for leg in legs):
        return ()
    a1 = np.array([leg.a1 for leg in legs], dtype=float)
    a3 = np.array([leg.a3 for leg in legs], dtype=float)
    exact = [[[[Fraction(float(v)) for v in row] for row in mats[i, p]] for p in range(3)] for i in range(len(legs))]
    out = []
    for signs in itertools.product((1.0, -1.0), repeat=3):
        target = np.asarray(signs)[:, None] * a1
        u, _, vt = np.linalg.svd(target.T @ a3)                      # R = argmin sum |R a3_i - s_i a1_i|^2
        rot = u @ np.diag([1.0, 1.0, np.linalg.det(u @ vt)]) @ vt
        if np.abs(rot @ a3.T - target.T).max() > STATIONARY_FIT:
            continue                                                  # no rotation fits this pattern
        q = quaternions_from_rotations(rot)
        q = np.round(q / np.abs(q).max() / STATIONARY_GRID) * STATIONARY_GRID
        qf = [Fraction(float(v)) for v in q]
        if all(sum(qf[a] * m[a][b] * qf[b] for a in range(4) for b in range(4)) == 0 for leg in exact for m in leg):
            if not any(np.array_equal(q, o) or np.array_equal(q, -o) for o in out):
                out.append(q)
    return tuple(out)


@dataclass(frozen=True, eq=False)
class OrientationPatch:
    """A box of platform orientations a :class:`PlatformPlane` is written on, in three variables on the unit
    box (metric: ``lo`` + (``hi`` - ``lo``) x): ``quad`` (3 legs, 3 parts (cos d, sin d, 1), 3, 3, 3) the
    legs' closure forms in Bernstein form (q^T M q on a quaternion chart; (q^T M q) / rho on a blow-up patch,
    :func:`blowup_patches`) and ``quad_mag`` the nets of their terms' magnitudes (tolerances); ``lin`` (4,
    2, 2, 2) the quaternion's components (degree 1 per variable; q_k fixed, k the component not in
    ``others``); ``others``: the three columns j != k of D's minor [(M_i q)_j] (q_k != 0 on the patch)."""

    quad: np.ndarray
    quad_mag: np.ndarray
    lin: np.ndarray
    others: tuple
    lo: tuple
    hi: tuple


class PlatformPlane:
    """The platform system's singular set in a plane of inputs (module doc), compiled once.

    ``plane``: a :class:`SingularPlane` whose names are the legs' actuated joints; ``mats`` (3 legs, 3
    parts, 4, 4) (:func:`spherekin.systems.platform.leg_matrices`); ``refs`` (3,): the actuated joints'
    reference readings (d = beta - ref). ``charts``: the :class:`ChartSet` of the cover (variables q_a,
    q_b, q_c, t_x (, t_y)); blocks: the legs' equations (3) and D (1).
    """

    #: The system whose equations this plane system augments (:data:`spherekin.systems.SYSTEMS`).
    system = "platform"
    #: How its cusps are searched: the tangency system (:meth:`cusp_charts`).
    cusp_method = "tangency"
    #: Passive joint ranges are not applied: the set may hold singular configurations with a passive
    #: joint out of range (its counts too: :func:`spherekin.singularities.cover._line_cross_check`).
    applies_ranges = False
    #: The patches are the quaternion charts (their contraction applies).
    QUATERNION_CHARTS = True

    def __init__(self, mechanism, plane: SingularPlane):
        legs = platform_legs(mechanism)
        self.plane = plane
        self.mats = leg_matrices(legs)
        self.refs = np.array([leg.reference[leg.actuated] for leg in legs], dtype=float)
        names = [leg.names[leg.actuated] for leg in legs]
        self.axis_legs = tuple(names.index(a[0]) for a in plane.axes)
        self.fixed_values = {names.index(n): float(v) for n, v in plane.fixed.items()}
        self.plane_charts = [plane_charts(a[1], a[2]) for a in plane.axes]
        self.patches = self._patches()
        self.charts = self._cover_charts()
        self.plane_columns = tuple(3 + a for a in range(len(plane.axes)))
        self._batch_last = None
        self.stationary = stationary_quaternions(legs, self.mats)

    def _patches(self) -> tuple:
        """The orientation patches the system is written on: the four quaternion charts."""
        quad = chart_control_points(self.mats)                  # (3 legs, 3 parts, 4 charts, 3, 3, 3)
        ext = (-CHART_EXTENT,) * 3, (CHART_EXTENT,) * 3
        return tuple(OrientationPatch(quad[:, :, k], np.abs(quad[:, :, k]), _linear_basis(k),
                                      tuple(j for j in range(4) if j != k), *ext) for k in range(CHARTS))

    def unit(self, chart, v) -> np.ndarray:
        """Unit coordinates (B, N) of the cover's angle-box coordinates v (B, N) in charts ``chart`` (B,)."""
        return self.charts.parameterization.unit(self.charts, chart, v)

    # ---------------------------------------------------------------- tensors
    def _leg_weights(self, leg: int, axes: list, values: dict, batch: int) -> np.ndarray:
        """(B, 3 parts, *plane sizes) weights of leg ``leg``: ``axes[pos]`` = (leg, t_lo (B,), t_hi (B,),
        shift (B,)) for each plane variable of the system; a leg that is none of them reads its input
        from ``values[leg]`` (B,; radians) or the plane's fixed inputs."""
        shape = [batch, 3] + [1] * len(axes)
        for pos, (owner, t_lo, t_hi, shift) in enumerate(axes):
            if owner == leg:
                w = np.stack([_weights(float(s) - self.refs[leg], a, b) for a, b, s in zip(t_lo, t_hi, shift)])
                shape[2 + pos] = 3
                return w.reshape(shape)
        given = values.get(leg, self.fixed_values.get(leg))
        d = np.broadcast_to(np.asarray(given, dtype=float), (batch,)) - self.refs[leg]
        return np.stack([np.cos(d), np.sin(d), np.ones_like(d)], axis=1).reshape(shape)

    def _blocks(self, k: int, weights: list[np.ndarray], rs=None):
        """Control points and tolerances on quaternion chart k, batch first: legs' F (B, 3, 3, 3, 3,
        *3...) with tolerances (B, 3), D (B, 1, 4, 4, 4, *3...) with (B, 1); ``weights``: per leg (B, 3,
        *plane sizes) (:meth:`_leg_weights`). Size-1 plane axes (degree 0) are elevated to degree 2
        (a constant's control points are that constant: exact). With ``rs`` (a sequence of (3,) vectors),
        also, per r: the tangency C_r (B, 1, ...) with (B, 1) and adj(G) r (B, 3, ...) with (B, 3)
        (:meth:`_cusp_terms`)."""
        eps = np.finfo(float).eps
        n_plane = weights[0].ndim - 2
        batch = weights[0].shape[0]
        patch = self.patches[k]
        lin, others = patch.lin, patch.others
        big = (batch,) + (3,) * n_plane

        def combine(parts, w):          # parts (3, *q dims), w (B, 3, *plane): sum_p w_p parts_p
            qd = parts.shape[1:]
            out = np.einsum("pq,bps->bqs", parts.reshape(3, -1), w.reshape(batch, 3, -1))
            return out.reshape((batch,) + qd + w.shape[2:])

        f, f_tol, entries, mags = [], [], [], []
        for i, w in enumerate(weights):
            fi = combine(patch.quad[i], w)                                       # (3 parts, 3, 3, 3)
            fm = combine(patch.quad_mag[i], np.abs(w))
            f.append(np.broadcast_to(fi, fi.shape[:4] + big[1:]))
            f_tol.append(ROUNDING_SAFETY * eps * np.maximum(fm, np.abs(fi)).reshape(batch, -1).max(axis=1))
            row, mrow = [], []
            for j in others:
                parts = np.einsum("pl,labc->pabc", self.mats[i, :, j, :], lin)     # (3 parts, 2, 2, 2)
                row.append(combine(parts, w))
                mrow.append(combine(np.abs(parts), np.abs(w)))
            entries.append(row)
            mags.append(mrow)
        nv = 3 + n_plane
        det = mag = 0.0
        for perm in itertools.permutations(range(3)):
            sign = np.linalg.det(np.eye(3)[list(perm)])
            term = bernstein.multiply(bernstein.multiply(entries[0][perm[0]], entries[1][perm[1]], nv),
                                      entries[2][perm[2]], nv)
            tm = bernstein.multiply(bernstein.multiply(mags[0][perm[0]], mags[1][perm[1]], nv),
                                    mags[2][perm[2]], nv)
            det = det + sign * term
            mag = mag + tm
        d_tol = ROUNDING_SAFETY * eps * np.maximum(mag, np.abs(det)).reshape(batch, -1).max(axis=1)
        if rs is not None:
            extra = [self._cusp_terms(entries, mags, det, mag, np.asarray(r, dtype=float), big) for r in rs]
        det = np.broadcast_to(det, det.shape[:4] + big[1:])
        if rs is not None:
            return (np.ascontiguousarray(np.stack(f, axis=1)), np.stack(f_tol, axis=1),
                    np.ascontiguousarray(det[:, None]), d_tol[:, None], extra)
        return (np.ascontiguousarray(np.stack(f, axis=1)), np.stack(f_tol, axis=1),
                np.ascontiguousarray(det[:, None]), d_tol[:, None])

    def _cover_charts(self) -> ChartSet:
        combos = list(itertools.product(*(range(len(p)) for p in self.plane_charts)))
        n_plane = len(self.plane_charts)
        spans = [[self.plane_charts[a][c[a]] for c in combos] for a in range(n_plane)]
        t_half = [np.array([math.tan((hi - lo) / 4) for lo, hi in s]) for s in spans]
        shifts = [np.array([(lo + hi) / 2 for lo, hi in s]) for s in spans]
        axes = [(self.axis_legs[a], -t_half[a], t_half[a], shifts[a]) for a in range(n_plane)]
        weights = [self._leg_weights(i, axes, {}, len(combos)) for i in range(3)]
        n_patch = len(self.patches)
        per_k = [self._blocks(k, weights) for k in range(n_patch)]
        order = [(c, k) for c in range(len(combos)) for k in range(n_patch)]   # chart = combo * n_patch + k
        f = np.stack([per_k[k][0][c] for c, k in order])
        ft = np.stack([per_k[k][1][c] for c, k in order])
        d = np.stack([per_k[k][2][c] for c, k in order])
        dt = np.stack([per_k[k][3][c] for c, k in order])
        map_lo = np.array([np.concatenate([self.patches[k].lo, [-t_half[a][c] for a in range(n_plane)]])
                           for c, k in order])
        map_hi = np.array([np.concatenate([self.patches[k].hi, [t_half[a][c] for a in range(n_plane)]])
                           for c, k in order])
        shift = np.array([np.concatenate([np.zeros(3), [shifts[a][c] for a in range(n_plane)]]) for c, _ in order])
        names = tuple(a[0] for a in self.plane.axes)
        variables = Q_VARIABLES + tuple(f"t({n})" for n in names)
        legs = tuple(f"leg{i + 1}" for i in range(3))
        return ChartSet(PlaneParameterization(3, self.QUATERNION_CHARTS), names, variables, [f, d], [ft, dt], [legs, ("det",)],
                        [(), ()], map_lo, map_hi, shift, 1.0, [None, None], [True, True])

    @staticmethod
    def _cusp_terms(entries, mags, det, mag, r, big):
        """The tangency C_r = grad_q D . (adj(G) r) and A = adj(G) r of :meth:`cusp_charts`, batch first:
        (C (B, 1, 6, 6, 6, *5...), its tolerance (B, 1), A (B, 3, 3, 3, 3, *5...), its tolerances (B, 3)).
        ``entries``/``mags``: G's entries and their magnitudes' nets (rows: legs; columns: the chart's
        variables), ``det``/``mag``: D and its magnitudes' net. Every term is raised to the common degree
        (exact) before adding; tolerances: ROUNDING_SAFETY * eps * the nets of the magnitudes (as D's)."""
        eps = np.finfo(float).eps
        nv = det.ndim - 1

        def total(terms):
            shape = np.max([t.shape for t in terms], axis=0)
            out = 0.0
            for t in terms:
                for v in range(nv):
                    if t.shape[1 + v] < shape[1 + v]:
                        t = bernstein.elevate(t, v, int(shape[1 + v] - t.shape[1 + v]), nv)
                out = out + t
            return out

        def to_big(t):                  # plane axes of degree 0 raised to 2 (the shape of F's nets)
            for v in range(3, nv):
                if t.shape[1 + v] < big[v - 2]:
                    t = bernstein.elevate(t, v, big[v - 2] - t.shape[1 + v], nv)
            return t

        adj, adj_mag = [], []
        for terms, tmag in _adjugate_terms(lambda a, b: entries[a][b], lambda a, b: mags[a][b], r, nv):
            adj.append(to_big(total(terms)))
            adj_mag.append(to_big(total(tmag)))
        a_tol = [ROUNDING_SAFETY * eps * np.maximum(m, np.abs(a)).reshape(len(a), -1).max(axis=1)
                 for a, m in zip(adj, adj_mag)]
        c_terms, c_mag = [], []
        for j in range(3):               # d/dx_j of a Bernstein net of degree n: n (c_{i+1} - c_i)
            n = det.shape[1 + j] - 1
            dd = n * np.diff(det, axis=1 + j)
            dm = n * (np.take(mag, range(1, n + 1), axis=1 + j) + np.take(mag, range(n), axis=1 + j))
            c_terms.append(bernstein.multiply(dd, adj[j], nv))
            c_mag.append(bernstein.multiply(dm, adj_mag[j], nv))
        cr, cm = total(c_terms), total(c_mag)
        c_tol = ROUNDING_SAFETY * eps * np.maximum(cm, np.abs(cr)).reshape(len(cr), -1).max(axis=1)
        return cr[:, None], c_tol[:, None], np.stack(adj, axis=1), np.stack(a_tol, axis=1)

    def cusp_charts(self, rs) -> tuple:
        """The cusp systems on the cover's charts (a plane, not a line): for each
        r in ``rs`` ((3,) vectors), a :class:`ChartSet` over the cover's variables with blocks F (the legs'
        equations), D, C_r = grad_q D . (adj(G) r) (the curve's tangent projects to 0 in the plane: on the
        curve adj(G) = k l^T, so C_r = (l . r) (grad_q D . k)) and A = adj(G) r (3 rows, not pruned: the
        certificate's test that l . r != 0). Square system: (F, D, C_r) in (q_a, q_b, q_c, t_x, t_y)."""
        if len(self.plane_charts) != 2:
            raise ValueError("cusps: expected a plane of two inputs, got a line")
        cs = self.charts
        combos = list(itertools.product(*(range(len(p)) for p in self.plane_charts)))
        n_combo = len(combos)
        n_patch = len(self.patches)
        axes = [(self.axis_legs[a], cs.map_lo[::n_patch, 3 + a], cs.map_hi[::n_patch, 3 + a],
                 cs.shift[::n_patch, 3 + a]) for a in range(2)]
        weights = [self._leg_weights(i, axes, {}, n_combo) for i in range(3)]
        per_k = [self._blocks(k, weights, rs)[4] for k in range(n_patch)]
        order = [(c, k) for c in range(n_combo) for k in range(n_patch)]
        out = []
        for ri in range(len(rs)):
            blocks = [np.stack([per_k[k][ri][p][c] for c, k in order]) for p in range(4)]
            out.append(ChartSet(cs.parameterization, cs.unknowns, cs.variables,
                                [cs.coeffs[0], cs.coeffs[1], blocks[0], blocks[2]],
                                [cs.tols[0], cs.tols[1], blocks[1], blocks[3]],
                                [cs.labels[0], cs.labels[1], ("tangency",), ("adj_r1", "adj_r2", "adj_r3")],
                                [(), (), (), ()], cs.map_lo, cs.map_hi, cs.shift, 1.0,
                                [None] * 4, [True, True, True, False]))
        return tuple(out)

    # ---------------------------------------------------------------- certificates
    def trace(self, chart, lo, hi, param, pieces=None) -> tuple:
        """The parametric Krawczyk test of the curve system on boxes of the cover: on chart ``chart[b]``
        and the box [lo[b], hi[b]] (unit coordinates, (B, N)), the 4 equations (legs, D) in the 4
        variables other than the plane column ``param`` (3 = t_x, 4 = t_y), that plane input a
        parameter over the box's range (:func:`spherekin.search.isolation.krawczyk_parametric`).
        ``pieces`` = (owner (P,), a (P,), z (P,)): test instead the parts of the boxes ``owner`` whose
        range along ``param`` is [a, z] (fractions of the box's range; a = z: the point test at that
        input), each box restricted once and its pieces along ``param`` only. Returns (proven, K lo,
        K hi) ((B,) or (P,), and (., N)): where proven, for every input of the (piece's) range along
        ``param`` one singular configuration lies in the box, inside [K lo, K hi] (unit coordinates of
        the chart; the ``param`` column is the range itself)."""
        chart = np.asarray(chart, dtype=int)
        lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
        count = len(chart) if pieces is None else len(pieces[0])
        if count == 0 or len(chart) == 0:
            return np.zeros(0, dtype=bool), np.zeros((0, lo.shape[1])), np.zeros((0, lo.shape[1]))
        cs = self.charts
        if pieces is None:
            owner, a, z = np.arange(len(chart)), None, None
        else:
            owner, a, z = (np.asarray(v) for v in pieces)
            owner = owner.astype(int)
        at = -2 - (lo.shape[1] - 1 - param)                       # the param axis, counted from the batch axis
        out = []
        # in batches (of boxes, or of pieces with their boxes): a box over many cells along param has as many
        # pieces, each a copy of its control points (issue 40: 1.4e7 pieces at T = 1e-6 asked for 74 GB at once)
        for s in range(0, count, PIECE_BATCH):
            o = owner[s:s + PIECE_BATCH]
            boxes, inv = np.unique(o, return_inverse=True)
            cps = self._restricted(chart[boxes], lo[boxes], hi[boxes])
            tols = [cs.tols[b][chart[o]].T for b in (0, 1)]
            plo, phi = lo[o].copy(), hi[o].copy()
            if pieces is None:
                cps = [c[..., inv] for c in cps]
            else:
                pa, pz = a[s:s + PIECE_BATCH], z[s:s + PIECE_BATCH]
                cps = [np.moveaxis(bernstein.restrict_batch_last(np.moveaxis(c[..., inv], at, -2), pa[:, None],
                                                                 pz[:, None], {}), -2, at) for c in cps]
                w = phi[:, param] - plo[:, param]
                plo[:, param], phi[:, param] = plo[:, param] + pa * w, plo[:, param] + pz * w
            out.append(self._trace_test(cps, tols, plo, phi, param))
        return tuple(np.concatenate(parts) for parts in zip(*out))

    @staticmethod
    def _trace_test(cps, tols, lo, hi, param) -> tuple:
        """:meth:`trace` on restricted control points ``cps`` (batch last) of the boxes [lo, hi] (unit, (B, N))."""
        ok, klo, khi = krawczyk_parametric(_SLICE, cps, tols, int(param))
        keep = [k for k in range(lo.shape[1]) if k != param]
        out_lo, out_hi = lo.copy(), hi.copy()
        w = hi[:, keep] - lo[:, keep]
        out_lo[:, keep] = lo[:, keep] + klo * w
        out_hi[:, keep] = lo[:, keep] + khi * w
        return ok, out_lo, out_hi

    def _restricted(self, chart, lo, hi) -> list:
        """The legs' and D's control points (batch last) on the boxes [lo, hi] (unit, (B, N)) of charts
        ``chart`` (B,); the chart tensors are kept batch-last and contiguous (a gather, then the restriction:
        ~3x faster than restricting a strided view)."""
        if self._batch_last is None:
            self._batch_last = [np.ascontiguousarray(np.moveaxis(self.charts.coeffs[b], 0, -1)) for b in (0, 1)]
        return [bernstein.restrict_batch_last(np.take(c, chart, axis=-1), lo, hi, {}) for c in self._batch_last]

    def empty(self, chart, lo, hi) -> np.ndarray:
        """(B,) bool: the boxes [lo, hi] (unit, (B, N)) of charts ``chart`` proven to hold no point of the
        curve: for either plane input as the parameter, the parametric Krawczyk image of the box misses it
        (K holds every root of the box, :func:`spherekin.search.isolation.krawczyk_parametric`)."""
        chart = np.asarray(chart, dtype=int)
        out = np.zeros(len(chart), dtype=bool)
        if not len(chart):
            return out
        cps = self._restricted(chart, lo, hi)
        tols = [self.charts.tols[b][chart].T for b in (0, 1)]
        for p in self.plane_columns:
            _, klo, khi = krawczyk_parametric(_SLICE, cps, tols, p)
            out |= np.any(klo > khi, axis=1)
        return out

    def cusp_free(self, chart, lo, hi) -> np.ndarray:
        """(B,) bool: the boxes [lo, hi] (unit, (B, N)) of charts ``chart`` (B,) proven to hold no cusp: the
        interval Jacobian of (legs, D) in the three orientation variables has full column rank over the box
        (:func:`spherekin.search.isolation.full_rank_proven`), so at a point of the curve in the box its
        tangent has a nonzero plane component (J_v dv = 0 forces dv = 0). For the blow-up patches, whose
        variables are not the orientation's, the tangency system of :meth:`cusp_charts` does not apply; this
        test does (the blow-up maps (rho, a, b) to q smoothly and keeps the inputs)."""
        chart = np.asarray(chart, dtype=int)
        out = np.zeros(len(chart), dtype=bool)
        for s in range(0, len(chart), CUSP_FREE_BATCH):
            b = slice(s, s + CUSP_FREE_BATCH)
            cps = self._restricted(chart[b], np.asarray(lo)[b], np.asarray(hi)[b])
            tols = [self.charts.tols[k][chart[b]].T for k in (0, 1)]
            out[b] = full_rank_proven(_SLICE, cps, tols, (0, 1, 2))
        return out

    def predict(self, chart, lo, hi, param) -> tuple:
        """Newton's point of the curve at the middle of each box's range along the plane column ``param``
        and the branch's tangent there, a predictor for :meth:`trace` (a guess: the Krawczyk test
        decides). ``chart`` (B,), ``lo``, ``hi`` (B, N) unit coordinates. Returns (converged (B,), point
        (B, N), slope (B, N): d(unit coordinate)/d(unit coordinate of ``param``), 1 at ``param``)."""
        chart = np.asarray(chart, dtype=int)
        lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
        if len(chart) == 0:
            return np.zeros(0, dtype=bool), lo.copy(), np.zeros_like(lo)
        cps = self._restricted(chart, lo, hi)
        n = lo.shape[1]
        keep = [k for k in range(n) if k != param]
        u = np.full((len(chart), n), 0.5)
        step = np.zeros((len(chart), n - 1))
        with np.errstate(all="ignore"):
            for _ in range(PREDICT_STEPS):
                f = np.concatenate([evaluate_at(c, u) for c in cps]).T                       # (B, 4)
                jac = np.moveaxis(np.concatenate([jacobian_at(c, u) for c in cps]), -1, 0)    # (B, 4, N)
                try:
                    step = np.linalg.solve(jac[:, :, keep], f[..., None])[..., 0]
                except np.linalg.LinAlgError:
                    return np.zeros(len(chart), dtype=bool), lo, np.zeros_like(lo)
                u[:, keep] -= step
            # the slope from the last Jacobian (one step from the point: a predictor only)
            slope_v = -np.linalg.solve(jac[:, :, keep], jac[:, :, param:param + 1])[..., 0]
        w = hi - lo
        slope = np.ones_like(lo)
        with np.errstate(all="ignore"):
            slope[:, keep] = slope_v * w[:, keep] / np.where(w[:, param:param + 1] > 0, w[:, param:param + 1], 1.0)
        ok = (np.all(np.isfinite(u), axis=1) & np.all(np.isfinite(slope), axis=1)
              & (np.abs(step).max(axis=1) < PREDICT_CONVERGED))
        return ok, lo + u * w, slope
    def stationary_det(self, q, points) -> np.ndarray:
        """An enclosure (interval array (2, P)) of D at the stationary quaternion ``q`` (4,) (one of
        :attr:`stationary`) for plane inputs ``points`` (P, n_plane; radians, x first): det of the 3 x 3
        matrix [(M_i(d_i) q)_j] (rows: legs; columns j != k, k the component of q of largest size),
        outward-rounded interval arithmetic (:mod:`spherekin.core.intervals`: cos and sin of d_i = beta_i -
        ref_i enclosed). As :class:`PlatformPlane`'s D (the module doc): the rows are the closure's
        gradients in q, orthogonal to q (Euler), so with q_k != 0 this minor is 0 iff they are dependent.
        Since q closes every input, an interval excluding 0 proves the sign of D(q, p)."""
        q = np.asarray(q, dtype=float)
        points = np.atleast_2d(np.asarray(points, dtype=float))
        n = len(points)
        cols = [j for j in range(4) if j != int(np.argmax(np.abs(q)))]
        rows = []
        for i in range(3):
            beta = (points[:, self.axis_legs.index(i)] if i in self.axis_legs
                    else np.full(n, self.fixed_values[i]))
            d = intervals.sub(intervals.point(beta), intervals.point(np.full(n, self.refs[i])))
            cos, sin = intervals.cos_sin(d)
            parts = intervals.fmatmul(self.mats[i][:, cols, :], intervals.point(q[:, None]))[..., 0]   # (2, 3, 3)
            rows.append(intervals.add(intervals.add(intervals.mul(cos[:, :, None], parts[:, None, 0]),
                                                    intervals.mul(sin[:, :, None], parts[:, None, 1])),
                                      parts[:, None, 2]))                    # (2, P, 3)
        det = intervals.point(np.zeros(n))
        for perm in itertools.permutations(range(3)):
            sign = float(np.linalg.det(np.eye(3)[list(perm)]))
            term = intervals.mul(intervals.mul(rows[0][:, :, perm[0]], rows[1][:, :, perm[1]]), rows[2][:, :, perm[2]])
            det = intervals.add(det, intervals.scale(sign, term))
        return det

    def prove(self, chart, fix, value, lo, hi) -> np.ndarray:
        """The Krawczyk test (:func:`spherekin.search.isolation.krawczyk_boxes`) of the square slices:
        on cover chart ``chart[b]``, plane axis ``fix[b]`` (0 = x, 1 = y; -1: none, for a line)
        held at ``value[b]`` (radians), the 4 equations (legs, D) in the other 4 variables on the box
        [lo[b], hi[b]] (unit coordinates of the chart, (B, N) over all its variables; the fixed axis'
        column is ignored). True where it proves a unique root: a singular configuration at that
        input. Shapes: chart, fix, value (B,); returns (B,) bool."""
        chart = np.asarray(chart, dtype=int)
        fix = np.asarray(fix, dtype=int)
        value = np.asarray(value, dtype=float)
        lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
        out = np.zeros(len(chart), dtype=bool)
        n_plane = len(self.plane_charts)
        cs = self.charts
        n_patch = len(self.patches)
        for k, f_axis in {(int(c) % n_patch, int(a)) for c, a in zip(chart, fix)}:
            rows = np.flatnonzero((chart % n_patch == k) & (fix == f_axis))
            keep = [0, 1, 2] + [3 + a for a in range(n_plane) if a != f_axis]
            axes, values = [], {}
            c = chart[rows]
            for a in range(n_plane):
                if a == f_axis:
                    values[self.axis_legs[a]] = value[rows]
                else:
                    col = 3 + a
                    axes.append((self.axis_legs[a], cs.map_lo[c, col], cs.map_hi[c, col], cs.shift[c, col]))
            weights = [self._leg_weights(i, axes, values, len(rows)) for i in range(3)]
            f, ft, d, dt = self._blocks(k, weights)
            blo, bhi = lo[rows][:, keep], hi[rows][:, keep]
            blocks = (np.moveaxis(f, 0, -1), np.moveaxis(d, 0, -1))
            tols = [ft.T, dt.T]
            cps = [bernstein.restrict_batch_last(b, blo, bhi, {}) for b in blocks]
            ok, _, _ = krawczyk_boxes(_SLICE, cps, tols)
            # where the hull is too wide for the test: Newton's root in it, and the test on a small box there
            retry = np.flatnonzero(~ok)
            if len(retry):
                u, converged, _ = newton(_SLICE, [c[..., retry] for c in cps], [t[:, retry] for t in tols])
                inner = converged & np.all((u > PROOF_RADIUS) & (u < 1.0 - PROOF_RADIUS), axis=1)
                retry, u = retry[inner], u[inner]
                if len(retry):
                    w = bhi[retry] - blo[retry]
                    slo, shi = blo[retry] + (u - PROOF_RADIUS) * w, blo[retry] + (u + PROOF_RADIUS) * w
                    small = [bernstein.restrict_batch_last(b[..., retry], slo, shi, {}) for b in blocks]
                    ok[retry], _, _ = krawczyk_boxes(_SLICE, small, [t[:, retry] for t in tols])
            out[rows] = ok
        return out


#: The cusp system's square rows: the legs' equations (block 0), D (block 1) and the tangency C_r (block 2)
#: (:meth:`PlatformPlane.cusp_charts`).
CUSP_SQUARE = SquareSystem(((0, 0), (0, 1), (0, 2), (1, 0), (2, 0)))


def _cusp_square(charts, chart, lo, hi):
    """The square blocks (F, D, C_r) of a cusp ChartSet restricted to the boxes [lo, hi] (unit, (B, N)) of
    charts ``chart`` (B,), batch last, and their tolerances."""
    cps = [bernstein.restrict_batch_last(np.moveaxis(charts.coeffs[b][chart], 0, -1), lo, hi, {}) for b in range(3)]
    return cps, [charts.tols[b][chart].T for b in range(3)]


def cusp_newton(charts, chart, lo, hi):
    """Newton's method on the cusp system (F, D, C_r) from the centre of each box: (u (B, N) in each box's
    unit coordinates, converged (B,))."""
    u, converged, _ = newton(CUSP_SQUARE, *_cusp_square(charts, chart, lo, hi))
    return u, converged


def cusp_krawczyk(charts, chart, lo, hi):
    """The Krawczyk test of the cusp system on the boxes: (isolated (B,), K lo, K hi (B, N) in each box's
    unit coordinates), as :func:`spherekin.search.isolation.krawczyk_boxes`."""
    return krawczyk_boxes(CUSP_SQUARE, *_cusp_square(charts, chart, lo, hi))


def _axis_cross(a) -> np.ndarray:
    """[a]x (3, 3): the cross-product matrix of a."""
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def _adjugate_terms(entry, magnitude, r, nvars: int) -> list[tuple[list, list]]:
    """The terms of adj(M) r in Bernstein form, per component j (3): (signed products, their magnitudes'
    products times |r_i|), summed by the caller. (adj M)_{j i} = (-1)^{i + j} minor(row i, column j);
    ``entry(a, b)`` / ``magnitude(a, b)``: the net of M[a][b] and of its magnitudes (Bernstein tensors
    over ``nvars`` variables); ``r`` (3,) floats (components 0 skipped). Used by the cusps' tangency of
    both systems (the platform's G_k, the loops' K~)."""
    out = []
    for j in range(3):
        terms, mags = [], []
        for i in range(3):
            if r[i] == 0.0:
                continue
            rows = [a for a in range(3) if a != i]
            cols = [b for b in range(3) if b != j]
            sign = (-1.0) ** (i + j) * r[i]
            terms += [sign * bernstein.multiply(entry(rows[0], cols[0]), entry(rows[1], cols[1]), nvars),
                      -sign * bernstein.multiply(entry(rows[0], cols[1]), entry(rows[1], cols[0]), nvars)]
            mags += [abs(r[i]) * bernstein.multiply(magnitude(rows[0], cols[0]), magnitude(rows[1], cols[1]), nvars),
                     abs(r[i]) * bernstein.multiply(magnitude(rows[0], cols[1]), magnitude(rows[1], cols[0]), nvars)]
        out.append((terms, mags))
    return out


def _add_elevated(a: np.ndarray, b: np.ndarray, nvars: int | None = None) -> np.ndarray:
    """a + b for Bernstein tensors over the same variables (the last ``nvars`` axes, default all; leading batch
    axes broadcast), each raised to the larger degree per variable."""
    n = a.ndim if nvars is None else nvars
    for v in range(n):
        k = a.ndim - n + v
        kb = b.ndim - n + v
        if a.shape[k] < b.shape[kb]:
            a = bernstein.elevate(a, v, b.shape[kb] - a.shape[k], n)
        elif b.shape[kb] < a.shape[k]:
            b = bernstein.elevate(b, v, a.shape[k] - b.shape[kb], n)
    return a + b


#: Caps on det K_p of a mechanism with several loops (:class:`LoopPlane`), checked before anything is built:
#: the number of terms of its Laplace expansion over the loops' row blocks (six-bars: 1 or 2; each term is l
#: 3 x 3 minors multiplied, so thousands would take minutes per chart) ...
MAX_LAPLACE_TERMS = 200
#: ... and the Bernstein coefficients of D on one chart (the product of (degree + 1) over the variables):
#: the box loop restricts D on every box (a 5-loop mechanism written from the ground frame could reach 3^30);
#: 2e5 coefficients, 1.6 MB per chart, keep a search of ~1e4 boxes within seconds to a minute (six-bars: <= 27).
MAX_DET_COEFFS = 200_000


@dataclass(frozen=True)
class LoopColumn:
    """A passive joint's column of one loop's block of K_p, in that loop's frame link: ``column`` (index in
    ``SphericalMechanism.loop_unknowns``), ``sign`` (+-1: the joint's sign in the loop's velocity constraint,
    ``SphericalMechanism.constraint_terms``), ``path``: ((joint, sign), ...) the rotations from the frame link
    to a link carrying the joint (its current axis in the frame is Rot(s_1 a_1, th_1) ... Rot(s_k a_k, th_k) a,
    angles reading - reference)."""

    column: int
    sign: float
    joint: str
    path: tuple


@dataclass(frozen=True)
class DetPlan:
    """How :class:`LoopPlane` builds D = det K_p: ``loops``: per loop its :class:`LoopColumn` s; ``terms``:
    the Laplace expansion over the loops' row blocks, (sign, (S_1, ..., S_l)) with S_i the sorted columns
    (indices into ``loops[i]``) of loop i's 3 x 3 minor; ``degrees``: D's degree per variable (the chart's
    ``variables`` order; the largest over the terms); ``lifts``: per term, per variable, the factors
    (1 + t_v^2) it is multiplied by so that every term carries the same factor prod_v (1 + t_v^2)^(degree_v / 2).

    Why the lifts: a rotation by a variable joint is built as (1 + t^2) Rot, so a term whose columns' paths
    cross variable v k times carries (1 + t_v^2)^k. Terms whose paths differ (a Stephenson six-bar driven on its
    three-link chain: one term crosses J1 and J2, the other neither) carry different factors, and their plain sum
    is not a positive multiple of det K_p: its zeros are not the singular set (issue 40)."""

    loops: tuple
    terms: tuple
    degrees: tuple
    lifts: tuple

    @property
    def coefficients(self) -> int:
        """D's Bernstein coefficients on one chart."""
        return int(np.prod([d + 1 for d in self.degrees]))


def _parity(order) -> float:
    """+1 or -1: the sign of the permutation ``order`` of 0 .. n - 1."""
    order, sign = list(order), 1.0
    for i in range(len(order)):
        while order[i] != i:
            j = order[i]
            order[i], order[j] = order[j], order[i]
            sign = -sign
    return sign


def det_plan(mechanism, variables) -> DetPlan:
    """The plan of D = det K_p for ``mechanism`` whose joints ``variables`` (names) are unknowns (the others:
    actuated joints at fixed readings, constant rotations). ValueError (one line) when the mechanism has not
    3 passive joints per loop, or D exceeds MAX_LAPLACE_TERMS / MAX_DET_COEFFS.

    Frames: multiplying loop i's three rows of K_p by R_F^T (F any link of the loop) leaves every 3 x 3 minor
    of the block, hence det K_p, unchanged; in F's frame a joint's current axis is the product of the rotations
    of the joints between F and the joint going either way round the loop (equal on the closure set, which is
    solved with D). Each column takes the way with fewer variable joints, each loop the frame link giving the
    fewest coefficients. A rotation times 1 + t^2 is degree 2 in its t, so D's degree in t_v is 2 x the number of
    the chosen minors' columns whose path crosses v (the largest over the Laplace terms): four-bar and five-bar
    (passive B, C, D; frame the link carrying C and D): det[Rot(C) a_B, a_C, a_D], degree 2 in C only (singular
    where the axes B, C, D are coplanar); Watt six-bar: 2 in each of B, C, E (one term: the two loops' minors);
    Stephenson six-bar: 2 in each of C, E, G (two terms); general_3rrr as a graph: 2 in each delta_i (two terms)."""
    m = mechanism
    cols = list(m.loop_unknowns)
    n_loops = len(m.loop_geometry)
    if len(cols) != 3 * n_loops:
        raise ValueError(f"mechanism: singular sets need 3 passive joints per loop (a square passive Jacobian, "
                         f"3 x {n_loops} = {3 * n_loops}), got {len(cols)} ({', '.join(cols)})")
    variables = list(variables)
    loops = []
    for g, terms in zip(m.loop_geometry, m.constraint_terms):
        cycle = [(st.joint, st.sign) for st in g.up] + [(st.joint, -st.sign) for st in reversed(g.down)]
        n = len(cycle)
        signs = {joint: sgn for _, sgn, joint, _ in terms}
        best = None
        for f in range(n):               # frame: the link between cycle[f - 1] and cycle[f]
            loop = []
            for k, (joint, _) in enumerate(cycle):
                if joint not in cols:
                    continue
                fwd = tuple(cycle[p % n] for p in range(f, f + (k - f) % n))
                bwd = tuple((cycle[p % n][0], -cycle[p % n][1]) for p in range(f - 1, f - 1 - (f - k - 1) % n, -1))
                path = min(fwd, bwd, key=lambda p: (sum(j in variables for j, _ in p), len(p)))
                loop.append(LoopColumn(cols.index(joint), float(signs[joint]), joint, path))
            count = [2 * sum(any(j == v for j, _ in c.path) for c in loop) for v in variables]
            cost = (float(np.prod([d + 1 for d in count])), sum(len(c.path) for c in loop))
            if best is None or cost < best[0]:
                best = (cost, tuple(loop))
        loops.append(best[1])
    terms = []

    def expand(i, used, chosen):
        if len(terms) > MAX_LAPLACE_TERMS:
            return
        if i == n_loops:
            order = [loops[k][c].column for k, s in enumerate(chosen) for c in s]
            terms.append((_parity(order), tuple(chosen)))
            return
        free = [c for c, lc in enumerate(loops[i]) if lc.column not in used]
        for s in itertools.combinations(free, 3):
            taken = used | {loops[i][c].column for c in s}
            later = {lc.column for k in range(i + 1, n_loops) for lc in loops[k]}
            if all(c in taken or c in later for c in range(len(cols))):
                expand(i + 1, taken, chosen + [s])

    expand(0, frozenset(), [])
    if len(terms) > MAX_LAPLACE_TERMS:
        raise ValueError(f"mechanism: det K_p of its {n_loops} loops has more than {MAX_LAPLACE_TERMS} Laplace terms "
                         "(MAX_LAPLACE_TERMS): too large to build; singular sets are computed for up to a few loops")
    if not terms:
        raise ValueError("mechanism: its passive Jacobian is singular everywhere (no choice of 3 passive joints per "
                         "loop covers every passive joint): no isolated singular set")
    # the factors (1 + t_v^2) each term carries: one per chosen column whose path crosses v
    carried = [tuple(sum(any(j == name for j, _ in loops[k][c].path) for k, s in enumerate(chosen) for c in s)
                     for name in variables) for _, chosen in terms]
    top = [max(col) for col in zip(*carried)]
    lifts = tuple(tuple(t - e for t, e in zip(top, own)) for own in carried)
    plan = DetPlan(tuple(loops), tuple(terms), tuple(2 * t for t in top), lifts)
    if plan.coefficients > MAX_DET_COEFFS:
        raise ValueError(f"mechanism: det K_p of its {n_loops} loops would have {plan.coefficients} Bernstein "
                         f"coefficients per chart (degrees {dict(zip(variables, plan.degrees))}), more than MAX_DET_COEFFS "
                         f"= {MAX_DET_COEFFS}: too large to search")
    return plan


class LoopPlane:
    """The loop equations' singular set in a plane of inputs: any mechanism the loop system accepts whose
    passive joints are 3 per loop (l loops, K_p 3 l x 3 l): four-bars, five-bars, six-bars, ...

    Unknowns: the passive joints and the plane's inputs, on the tan-half charts of the loop equations
    (:meth:`spherekin.mechanism.SphericalMechanism.loop_system` with ``free``: the plane inputs become unknowns);
    blocks: the closure equations of the formulation, one block per loop (pruned, no square system), and
    D = det K_p (:func:`det_plan`: a Laplace expansion over the loops' row blocks of 3 x 3 minors whose columns
    are the passive joints' current axes in a frame link of the loop; K_p's column of joint j in loop i is
    s_ij omega_j, as :meth:`~spherekin.mechanism.SphericalMechanism.jacobians`). D vanishes on the closure set
    exactly where the passive Jacobian loses rank (not the formulation's own degeneracies). One plane input
    (a 1-DOF mechanism: the four-bar, six-bars) gives isolated singular inputs on the line; two, curves. The
    formulation is "transversal" (per loop: q f21, q f31, q f32 and Eq. (10)), whose square entries
    :meth:`prove` certifies. Passive joint ranges are constraints here (the mechanism's ranges).
    """

    #: The system whose equations this plane system augments (:data:`spherekin.systems.SYSTEMS`).
    system = "loops"
    #: Cusps are not searched on the loop equations (:meth:`cusps_without_search` says what that means).
    cusp_method = None
    #: Passive joint ranges are constraints of the cover.
    applies_ranges = True

    def __init__(self, mechanism, plane: SingularPlane, formulation: str = "transversal"):
        from ..search.parameterizations import make_charts, stack_chart_sets

        m = mechanism
        self.mechanism = m
        self.plane = plane
        names = [a[0] for a in plane.axes]
        lows = {a[0]: a[1] for a in plane.axes}       # a plane joint's entry is not used: any value in its range
        inputs = [plane.fixed[n] if n in plane.fixed else lows[n] for n in m.actuated]
        self.plan = det_plan(m, list(m.loop_unknowns) + names)   # before any chart is built: refusals first

        def build(chart_ranges):
            system = m.loop_system(inputs, {n: chart_ranges[n] for n in m.loop_unknowns}, free={
                n: chart_ranges[n] for n in names})
            return system.loops, system.unknowns

        # one chart set per combination of the plane's pieces (plane_charts: width <= pi, ends kept), so that
        # each plane variable has one chart per piece with its centre as shift (an Unknown strictly inside
        # (-pi, pi) takes shift 0, which a piece ending at pi would make ill-conditioned)
        passive = {n: m.joint(n).range for n in m.loop_unknowns}
        pieces = [plane_charts(a[1], a[2]) for a in plane.axes]
        closure = stack_chart_sets([make_charts("tan-half", build, {**passive, **dict(zip(names, combo))}, formulation)
                                    for combo in itertools.product(*pieces)])
        if tuple(closure.variables) != tuple(m.loop_unknowns) + tuple(names):
            raise AssertionError(f"LoopPlane: chart variables {closure.variables} are not the plan's")
        d, d_tol = self._determinant(closure)
        nb = len(closure.coeffs)
        self.charts = ChartSet(closure.parameterization, closure.unknowns, closure.variables,
                               list(closure.coeffs) + [d], list(closure.tols) + [d_tol],
                               list(closure.labels) + [("det K_p",)], [() for _ in range(nb + 1)],
                               closure.map_lo, closure.map_hi, closure.shift, closure.accept_width,
                               list(closure.bilinear or [None] * nb) + [None], list(closure.prune or [True] * nb) + [True])
        self.plane_columns = tuple(list(closure.variables).index(n) for n in names)
        # the square slice: each loop's transversal entries q f21, q f31, q f32 (block b, rows 0-2) and D
        self.slice = SquareSystem(tuple((b, r) for b in range(nb) for r in range(3)) + ((nb, 0),))

    def cusps_without_search(self) -> CuspSearch:
        """What the set says of its cusps, none searched: none possible on a one-loop mechanism (a 1-DOF
        loop has isolated singular inputs on a line and no fold curves to meet), else not searched."""
        return CuspSearch.NONE_POSSIBLE if len(self.mechanism.link_graph.loops) == 1 else CuspSearch.NOT_SEARCHED

    def _determinant(self, charts: ChartSet):
        """D = det K_p (C, 1, *dims) on every chart (:func:`det_plan`), and its tolerance (C, 1):
        ROUNDING_SAFETY eps times the largest control point of the same products in absolute value (the terms
        behind each control point)."""
        count = charts.n_charts
        det, mag = self._det_nets(charts, np.arange(count))
        d = np.ascontiguousarray(np.broadcast_to(det, (count,) + det.shape[1:]))[:, None]
        mags = np.broadcast_to(mag.reshape(mag.shape[0], -1).max(axis=1), (count,))
        tol = ROUNDING_SAFETY * np.finfo(float).eps * np.maximum(mags, np.abs(d).reshape(count, -1).max(axis=1))
        return d, tol[:, None]

    def _det_nets(self, charts: ChartSet, c) -> tuple[np.ndarray, np.ndarray]:
        """(D, the net of its terms' magnitudes) on the charts ``c`` (index array (B,)): tensors (B or 1, *dims)
        over the chart's variables, batch first (:func:`det_plan`)."""
        plan = self.plan
        variables = list(charts.variables)
        n = len(variables)
        dets = []
        for absolute in (False, True):
            cols = [[self._column(lc, charts, c, variables, n, absolute) for lc in loop] for loop in plan.loops]
            minors: dict = {}
            det = None
            for (sign, chosen), lift in zip(plan.terms, plan.lifts):
                term = None
                for i, s in enumerate(chosen):
                    if (i, s) not in minors:
                        minors[i, s] = self._minor([cols[i][k] for k in s], n, absolute)
                    term = minors[i, s] if term is None else bernstein.multiply(term, minors[i, s], n)
                for v, power in enumerate(lift):          # the factors (1 + t_v^2) the other terms carry
                    for _ in range(power):
                        factor = _one_plus_t2(charts, c, v, n)
                        term = bernstein.multiply(term, np.abs(factor) if absolute else factor, n)
                term = term if absolute else sign * term
                det = term if det is None else _add_elevated(det, term, n)
            dets.append(det)
        return dets[0], dets[1]

    @staticmethod
    def _minor(cols, n, absolute) -> np.ndarray:
        """det[c_1, c_2, c_3] of three columns (each 3 tensors over the n variables, batch first), by its 6
        permutations (all with sign +1 and entries' magnitudes with ``absolute``)."""
        det = None
        for perm in itertools.permutations(range(3)):
            sign = 1.0 if absolute else _parity(perm)
            term = bernstein.multiply(bernstein.multiply(cols[0][perm[0]], cols[1][perm[1]], n), cols[2][perm[2]], n)
            det = sign * term if det is None else _add_elevated(det, sign * term, n)
        return det

    def _rotation(self, joint: str, sign: int, charts, c, variables, n, absolute) -> np.ndarray:
        """(1 + t^2) Rot(sign a, reading - ref) (B, 3, 3, *sizes) of ``joint`` on the charts ``c`` (index array
        (B,); a variable: degree 2 in its t), or Rot(...) itself (1, 3, 3, sizes 1) at the plane's fixed reading;
        in absolute value with ``absolute``."""
        j = self.mechanism.joint(joint)
        a = sign * np.asarray(j.axis, dtype=float)
        parts = np.stack([np.eye(3) - np.outer(a, a), _axis_cross(a), np.outer(a, a)])        # (cos, sin, 1)
        shape = [-1, 3, 3] + [1] * n
        if joint in variables:
            k = variables.index(joint)
            w = np.stack([_weights(float(charts.shift[ci, k]) - j.reference_angle, charts.map_lo[ci, k],
                                   charts.map_hi[ci, k]) for ci in c])                    # (B, 3 parts, 3)
            shape[3 + k] = 3
        else:
            d = self.plane.fixed[joint] - j.reference_angle
            w = np.array([[[math.cos(d)], [math.sin(d)], [1.0]]])                         # (1, 3 parts, 1)
        if absolute:
            parts, w = np.abs(parts), np.abs(w)
        return np.einsum("pij,bpk->bijk", parts, w).reshape(shape)

    def _column(self, lc: LoopColumn, charts, c, variables, n, absolute) -> list[np.ndarray]:
        """The 3 entries (each a tensor (B or 1, *sizes) over the n variables) of a passive joint's column
        (:class:`LoopColumn`) of its loop's block of K_p in the loop's frame, on the charts ``c`` (index array
        (B,)); entries' magnitudes with ``absolute``."""
        rot = np.eye(3).reshape([1, 3, 3] + [1] * n)
        for joint, sign in lc.path:
            r = self._rotation(joint, sign, charts, c, variables, n, absolute)
            rot = (rot[:, :, :, None] * r[:, None, :, :]).sum(axis=2)          # distinct variables: a tensor product
        axis = np.asarray(self.mechanism.joint(lc.joint).axis, dtype=float)
        vec = np.einsum("bij...,j->bi...", np.abs(rot) if absolute else rot, np.abs(axis) if absolute else axis)
        return [vec[:, i] if absolute else lc.sign * vec[:, i] for i in range(3)]

    def cusp_charts(self, rs) -> tuple:
        """The cusp systems of a one-loop mechanism in a plane of two inputs (as
        :meth:`PlatformPlane.cusp_charts`, same block layout, so :func:`spherekin.singularities.cells.certify_cusps`
        certifies them): per r in ``rs`` ((3,) vectors) a :class:`ChartSet` over the cover's variables with blocks
        the closure (transversal), D, the tangency C_r and A = adj(K~) r (3 rows, not pruned).

        K~ is the loop-frame K_p whose column j carries the factor Q_j = prod (1 + t_k^2) over the joints of its
        path, so adj(K~) = diag(prod_i Q_i / Q_j) adj(K) (K the rotations' matrix) and k = adj(K) r has
        k_j proportional to Q_j (adj(K~) r)_j. On the closure set D = P det K (P > 0, a product of 1 + t^2) and
        dtheta_j / dt_j = 2 / (1 + t_j^2), so the derivative of det K along the kernel, sum_j d det K / dtheta_j
        k_j, is a positive multiple of C_r = sum_j dD/dt_j (1 + t_j^2) Q_j (adj(K~) r)_j (passive joints j).
        On the curve adj(K) = k l^T: C_r = 0 iff (l . r) (grad det K . k) = 0, the tangent projecting to 0 in
        the plane (three assemblies meet), or the spurious l . r = 0 that the certificate rules out with A."""
        if len(self.plane_columns) != 2:
            raise ValueError("cusps: expected a plane of two inputs, got a line")
        if len(self.plan.loops) != 1:
            raise ValueError(f"cusps: searched on the loop equations of one-loop mechanisms, got {len(self.plan.loops)} "
                             "loops")
        eps = np.finfo(float).eps
        cs = self.charts
        variables = list(cs.variables)
        n = len(variables)
        loop = self.plan.loops[0]
        per_r = [([], [], [], []) for _ in rs]
        for c in range(cs.n_charts):
            d, dmag = (x[0] for x in self._det_nets(cs, np.array([c])))
            width = cs.map_hi[c] - cs.map_lo[c]

            def one_plus_t2(v):          # (1 + t_v^2) in the chart's unit variable
                return _one_plus_t2(cs, np.array([c]), v, n)[0]

            weights = []                 # per column j: dD/dt_j (1 + t_j^2) Q_j and its magnitudes' net (None: D free of t_j)
            for lc in loop:
                v = lc.column
                deg = d.shape[v] - 1
                if deg == 0:
                    weights.append(None)
                    continue
                dd = deg * np.diff(d, axis=v) / width[v]
                dm = deg * (np.take(dmag, range(1, deg + 1), axis=v) + np.take(dmag, range(deg), axis=v)) / width[v]
                factor = one_plus_t2(v)
                for joint, _ in lc.path:
                    if joint in variables:
                        factor = bernstein.multiply(factor, one_plus_t2(variables.index(joint)), n)
                weights.append((bernstein.multiply(dd, factor, n), bernstein.multiply(dm, factor, n)))
            cols = [[e[0] for e in self._column(lc, cs, np.array([c]), variables, n, False)] for lc in loop]
            mcols = [[e[0] for e in self._column(lc, cs, np.array([c]), variables, n, True)] for lc in loop]
            for ri, r in enumerate(rs):
                r = np.asarray(r, dtype=float)
                adj, adj_mag = [], []
                # M[i][j] = cols[j][i]: the columns are the passive joints' axes
                for terms, tmag in _adjugate_terms(lambda a, b: cols[b][a], lambda a, b: mcols[b][a], r, n):
                    adj.append(functools.reduce(_add_elevated, terms))
                    adj_mag.append(functools.reduce(_add_elevated, tmag))
                cr = cm = None
                for j, w in enumerate(weights):
                    if w is None:
                        continue
                    t, tm = bernstein.multiply(w[0], adj[j], n), bernstein.multiply(w[1], adj_mag[j], n)
                    cr = t if cr is None else _add_elevated(cr, t)
                    cm = tm if cm is None else _add_elevated(cm, tm)
                if cr is None:           # D constant on the chart: no tangency to search (C_r = 0 would keep all)
                    raise ValueError("cusps: the determinant does not depend on any passive joint")
                big = adj[0]
                for a in adj[1:]:
                    big = _add_elevated(big, 0.0 * a)
                adj = [_add_elevated(a, 0.0 * big) for a in adj]
                adj_mag = [_add_elevated(a, 0.0 * big) for a in adj_mag]
                per_r[ri][0].append(cr)
                per_r[ri][1].append(ROUNDING_SAFETY * eps * max(float(cm.max()), float(np.abs(cr).max())))
                per_r[ri][2].append(np.stack(adj))
                per_r[ri][3].append([ROUNDING_SAFETY * eps * max(float(m.max()), float(np.abs(a).max()))
                                     for a, m in zip(adj, adj_mag)])
        out = []
        bil = list(cs.bilinear or [None, None])
        for cr, ct, ad, at in per_r:
            out.append(ChartSet(cs.parameterization, cs.unknowns, cs.variables,
                                [cs.coeffs[0], cs.coeffs[1], np.stack(cr)[:, None], np.stack(ad)],
                                [cs.tols[0], cs.tols[1], np.array(ct)[:, None], np.array(at)],
                                [cs.labels[0], cs.labels[1], ("tangency",), ("adj_r1", "adj_r2", "adj_r3")],
                                [(), (), (), ()], cs.map_lo, cs.map_hi, cs.shift, cs.accept_width,
                                bil[:2] + [None, None], [True, True, True, False]))
        return tuple(out)

    def closes(self, charts, chart, lo, hi) -> np.ndarray:
        """(B,) bool: every loop's Eq. (10) (row _SCALAR_ROW of its transversal block) has a Bernstein hull above
        SPURIOUS_BOUND on the boxes [lo, hi] (unit, (B, N)) of charts ``chart`` (B,) of ``charts`` (the cover's or
        a cusp ChartSet): a root of the transversal entries there closes the loops (not a spurious half-turn)."""
        chart = np.asarray(chart, dtype=int)
        out = np.ones(len(chart), dtype=bool)
        for b in range(len(self.plan.loops)):
            c = np.moveaxis(charts.coeffs[b][chart][:, _SCALAR_ROW:_SCALAR_ROW + 1], 0, -1)
            r = bernstein.restrict_batch_last(c, np.asarray(lo, dtype=float), np.asarray(hi, dtype=float), {})
            out &= r.reshape(-1, len(chart)).min(axis=0) > SPURIOUS_BOUND
        return out

    def unit(self, chart, v) -> np.ndarray:
        """Unit coordinates (B, N) of angles v (B, N; radians) in charts ``chart`` (B,)."""
        cs = self.charts
        return tan_half_unit(np.asarray(v, dtype=float), cs.shift[chart], cs.map_lo[chart], cs.map_hi[chart])

    def prove(self, chart, fix, value, lo, hi) -> np.ndarray:
        """The Krawczyk test of the square slices (as :meth:`PlatformPlane.prove`, same arguments and
        result): each loop's transversal closure entries q f21, q f31, q f32 and D, with plane axis ``fix[b]``
        held at ``value[b]``, in the other variables on the box [lo[b], hi[b]] (unit coordinates of chart
        ``chart[b]``). The transversal entries also vanish at the three half-turns diag(+-1, +-1, +-1) != I
        (spurious closures), where Eq. (10)'s q (f11 + f22 - 2) is -2 q or -4 q (q >= 1): a proven root
        counts only where the Bernstein hull of every loop's Eq. (10) on the box stays above SPURIOUS_BOUND,
        so the root closes every loop (F = I) and is a singular configuration."""
        chart = np.asarray(chart, dtype=int)
        fix = np.asarray(fix, dtype=int)
        value = np.asarray(value, dtype=float)
        lo, hi = np.array(lo, dtype=float), np.array(hi, dtype=float)
        out = np.zeros(len(chart), dtype=bool)
        cs = self.charts
        nb = len(cs.coeffs) - 1                 # the loops' blocks; D last

        def closes(cps, count):                 # every loop's Eq. (10) above SPURIOUS_BOUND on the box
            return np.all([cps[b][_SCALAR_ROW].reshape(-1, count).min(axis=0) > SPURIOUS_BOUND for b in range(nb)],
                          axis=0)

        for f_axis in np.unique(fix):
            rows = np.flatnonzero(fix == f_axis)
            c = chart[rows]
            blo, bhi = lo[rows], hi[rows]
            col = None if f_axis < 0 else self.plane_columns[f_axis]
            # a joint's side the pruner shrank to (nearly) a point -- D linear in one joint pins it -- is widened
            # to SLICE_MIN_WIDTH about its centre: the root must be interior to the box tested (plane axes kept)
            mid = 0.5 * (blo + bhi)
            thin = (bhi - blo < SLICE_MIN_WIDTH) & ~np.isin(np.arange(blo.shape[1]), self.plane_columns)
            blo = np.where(thin, np.clip(mid - SLICE_MIN_WIDTH / 2, 0.0, 1.0), blo)
            bhi = np.where(thin, np.clip(mid + SLICE_MIN_WIDTH / 2, 0.0, 1.0), bhi)
            if col is not None:
                u = tan_half_unit(value[rows], cs.shift[c, col], cs.map_lo[c, col], cs.map_hi[c, col])
                blo[:, col] = bhi[:, col] = np.clip(u, 0.0, 1.0)
            blocks = [np.moveaxis(cs.coeffs[b][c], 0, -1) for b in range(nb + 1)]
            tols = [cs.tols[b][c].T for b in range(nb + 1)]

            def slices(boxes_lo, boxes_hi, which=slice(None)):
                cps = [bernstein.restrict_batch_last(bl[..., which], boxes_lo, boxes_hi, {}) for bl in blocks]
                if col is not None:             # the held axis (restricted to a point): dropped
                    cps = [np.take(cp, 0, axis=1 + col) for cp in cps]   # (E, d_1..d_N, B): variable k at axis 1 + k
                return cps

            cps = slices(blo, bhi)
            ok, _, _ = krawczyk_boxes(self.slice, cps, tols)
            ok &= closes(cps, len(rows))
            retry = np.flatnonzero(~ok)
            if len(retry):
                u, converged, _ = newton(self.slice, [cp[..., retry] for cp in cps], [t[:, retry] for t in tols])
                inner = converged & np.all((u > PROOF_RADIUS) & (u < 1.0 - PROOF_RADIUS), axis=1)
                retry, u = retry[inner], u[inner]
                if len(retry):
                    keep = [k for k in range(blo.shape[1]) if k != col]
                    rlo, rhi = blo[retry][:, keep], bhi[retry][:, keep]
                    w = rhi - rlo
                    slo, shi = blo[retry].copy(), bhi[retry].copy()
                    slo[:, keep], shi[:, keep] = rlo + (u - PROOF_RADIUS) * w, rlo + (u + PROOF_RADIUS) * w
                    small = slices(slo, shi, retry)
                    good, _, _ = krawczyk_boxes(self.slice, small, [t[:, retry] for t in tols])
                    ok[retry] = good & closes(small, len(retry))
            out[rows] = ok
        return out


#: Smallest side (unit coordinates of a chart) of a passive joint in a box :meth:`LoopPlane.prove` tests: where D
#: depends on one joint alone (the four-bar's det[a_B, a_C, Rot(C) a_D]) the pruner narrows that joint to its
#: root's value (to ~1e-13) and the hull of the cover's boxes has width ~0 there, on which no Krawczyk test can
#: succeed; 1e-6 is far above that rounding and far below the cells' width.
SLICE_MIN_WIDTH = 1e-6
#: Row of Eq. (10), q (f11 + f22 - 2), in each loop's transversal block.
_SCALAR_ROW = 3
#: A root of the transversal entries is a closure where Eq. (10) exceeds this on its box: at the spurious
#: half-turns it is -2 q or -4 q with q = prod (1 + t^2) >= 1, at a closure 0; -1 is halfway.
SPURIOUS_BOUND = -1.0


#: The plane systems by the name of the system whose equations they augment (the systems' seam for
#: singular sets: a system without an entry has no singular-set cover).
PLANES = {cls.system: cls for cls in (PlatformPlane, LoopPlane)}


def plane_system(mechanism, plane: SingularPlane):
    """The plane system of ``mechanism`` over ``plane``: that of the first system of
    :data:`spherekin.systems.SYSTEMS` (in order of preference) that accepts the mechanism and has
    one in :data:`PLANES`, as a solve chooses its system."""
    for name, cls in SYSTEMS.items():
        if name in PLANES and cls.accepts(mechanism) is None:
            return PLANES[name](mechanism, plane)
    raise ValueError(f"singular: no system with a singular-set cover accepts this mechanism ({', '.join(PLANES)})")
