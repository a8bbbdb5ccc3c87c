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

import itertools
import math
from dataclasses import dataclass, field
from fractions import Fraction
from types import SimpleNamespace

import numpy as np

from ..closure import tan_half_angle, tan_half_unit
from ..core import bernstein, intervals
from ..core.orientation import quaternions_from_rotations
from ..search.isolation import SquareSystem, krawczyk_boxes, newton
from ..search.parameterizations import CHART_MAX_WIDTH, ROUNDING_SAFETY, ChartSet, Parameterization
from .platform import CHART_EXTENT, CHARTS, Quaternion, chart_control_points, leg_matrices, platform_legs

__all__ = ["SingularPlane", "plane_charts", "PlaneParameterization", "PlatformPlane", "LoopPlane", "Q_VARIABLES",
           "SPURIOUS_BOUND", "CUSP_SQUARE",
           "cusp_newton", "cusp_krawczyk", "stationary_quaternions"]

#: Half-width (in unit coordinates of a slice's box) of the small box around Newton's root on which the
#: Krawczyk test is run again when it fails on the whole box: the interval Jacobian over a box of the
#: cover's size (~T) is often too loose for K(X) to fit in X, while on a box 1e-4 of it the Jacobian is
#: nearly a point and a regular root is proven. Any small value works (the root must be at least this far
#: inside the box, so the proven root is in the cell).
PROOF_RADIUS = 1e-4
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
    metric u = CHART_EXTENT (2x - 1)), then the plane inputs' tan-half variables (metric: the input,
    radians). ``angle_box`` gives (u..., beta_x, beta_y) bounds; :meth:`unit` inverts it. Its
    contraction is the quaternion charts' (:meth:`spherekin.systems.platform.Quaternion.contract`:
    a chart searches its core, not the cores of the charts before it), charts numbered plane-combination
    major with the quaternion chart last (chart % CHARTS)."""

    name = "plane"

    def __init__(self, n_q: int):
        self.n_q = n_q

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
        if np.abs(rot @ a3.T - target.T).max() > 1e-6:
            continue                                                  # no rotation fits this pattern
        q = quaternions_from_rotations(rot)
        q = np.round(q / np.abs(q).max() / STATIONARY_GRID) * STATIONARY_GRID
        qf = [Fraction(float(v)) for v in q]
        if all(sum(qf[a] * m[a][b] * qf[b] for a in range(4) for b in range(4)) == 0 for leg in exact for m in leg):
            if not any(np.array_equal(q, o) or np.array_equal(q, -o) for o in out):
                out.append(q)
    return tuple(out)


class PlatformPlane:
    """The platform system's singular set in a plane of inputs (module doc), compiled once.

    ``plane``: a :class:`SingularPlane` whose names are the legs' actuated joints; ``mats`` (3 legs, 3
    parts, 4, 4) (:func:`spherekin.systems.platform.leg_matrices`); ``refs`` (3,): the actuated joints'
    reference readings (d = beta - ref). ``charts``: the :class:`ChartSet` of the cover (variables q_a,
    q_b, q_c, t_x (, t_y)); blocks: the legs' equations (3) and D (1).
    """

    def __init__(self, mechanism, plane: SingularPlane):
        legs = platform_legs(mechanism)
        self.plane = plane
        self.mats = leg_matrices(legs)
        self.refs = np.array([leg.reference[leg.actuated] for leg in legs], dtype=float)
        names = [leg.names[leg.actuated] for leg in legs]
        self.axis_legs = tuple(names.index(a[0]) for a in plane.axes)
        self.fixed_values = {names.index(n): float(v) for n, v in plane.fixed.items()}
        self.plane_charts = [plane_charts(a[1], a[2]) for a in plane.axes]
        self.quad = chart_control_points(self.mats)             # (3 legs, 3 parts, 4 charts, 3, 3, 3)
        self.charts = self._cover_charts()
        self.plane_columns = tuple(3 + a for a in range(len(plane.axes)))
        self.stationary = stationary_quaternions(legs, self.mats)

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
        lin = _linear_basis(k)
        others = [j for j in range(4) if j != k]
        big = (batch,) + (3,) * n_plane

        def combine(parts, w):          # parts (3, *q dims), w (B, 3, *plane): sum_p w_p parts_p
            qd = parts.shape[1:]
            out = np.einsum("pq,bps->bqs", parts.reshape(3, -1), w.reshape(batch, 3, -1))
            return out.reshape((batch,) + qd + w.shape[2:])

        f, f_tol, entries, mags = [], [], [], []
        for i, w in enumerate(weights):
            qf = self.quad[i, :, k]                                                # (3 parts, 3, 3, 3)
            fi = combine(qf, w)
            fm = combine(np.abs(qf), np.abs(w))
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
        per_k = [self._blocks(k, weights) for k in range(CHARTS)]
        order = [(c, k) for c in range(len(combos)) for k in range(CHARTS)]   # chart = combo * CHARTS + k
        f = np.stack([per_k[k][0][c] for c, k in order])
        ft = np.stack([per_k[k][1][c] for c, k in order])
        d = np.stack([per_k[k][2][c] for c, k in order])
        dt = np.stack([per_k[k][3][c] for c, k in order])
        ext = np.full(3, CHART_EXTENT)
        map_lo = np.array([np.concatenate([-ext, [-t_half[a][c] for a in range(n_plane)]]) for c, _ in order])
        map_hi = np.array([np.concatenate([ext, [t_half[a][c] for a in range(n_plane)]]) for c, _ in order])
        shift = np.array([np.concatenate([np.zeros(3), [shifts[a][c] for a in range(n_plane)]]) for c, _ in order])
        names = tuple(a[0] for a in self.plane.axes)
        variables = Q_VARIABLES + tuple(f"t({n})" for n in names)
        legs = tuple(f"leg{i + 1}" for i in range(3))
        return ChartSet(PlaneParameterization(3), names, variables, [f, d], [ft, dt], [legs, ("det",)],
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
        for j in range(3):               # (adj G)_{j i} = (-1)^{i + j} minor(row i, column j)
            terms, tmag = [], []
            for i in range(3):
                if r[i] == 0.0:
                    continue
                rows = [a for a in range(3) if a != i]
                cols = [b for b in range(3) if b != j]
                sign = (-1.0) ** (i + j) * r[i]
                m1 = bernstein.multiply(entries[rows[0]][cols[0]], entries[rows[1]][cols[1]], nv)
                m2 = bernstein.multiply(entries[rows[0]][cols[1]], entries[rows[1]][cols[0]], nv)
                a1 = bernstein.multiply(mags[rows[0]][cols[0]], mags[rows[1]][cols[1]], nv)
                a2 = bernstein.multiply(mags[rows[0]][cols[1]], mags[rows[1]][cols[0]], nv)
                terms += [sign * m1, -sign * m2]
                tmag += [abs(r[i]) * a1, abs(r[i]) * a2]
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
        """The cusp systems on the cover's charts (a plane, not a line; design31.md section 3): for each
        r in ``rs`` ((3,) vectors), a :class:`ChartSet` over the cover's variables with blocks F (the legs'
        equations), D, C_r = grad_q D . (adj(G) r) (the curve's tangent projects to 0 in the plane: on the
        curve adj(G) = k l^T, so C_r = (l . r) (grad_q D . k)) and A = adj(G) r (3 rows, not pruned: the
        certificate's test that l . r != 0). Square system: (F, D, C_r) in (q_a, q_b, q_c, t_x, t_y)."""
        if len(self.plane_charts) != 2:
            raise ValueError("cusps: expected a plane of two inputs, got a line")
        cs = self.charts
        combos = list(itertools.product(*(range(len(p)) for p in self.plane_charts)))
        n_combo = len(combos)
        axes = [(self.axis_legs[a], cs.map_lo[::CHARTS, 3 + a], cs.map_hi[::CHARTS, 3 + a],
                 cs.shift[::CHARTS, 3 + a]) for a in range(2)]
        weights = [self._leg_weights(i, axes, {}, n_combo) for i in range(3)]
        per_k = [self._blocks(k, weights, rs)[4] for k in range(CHARTS)]
        order = [(c, k) for c in range(n_combo) for k in range(CHARTS)]
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
        for k, f_axis in {(int(c) % CHARTS, int(a)) for c, a in zip(chart, fix)}:
            rows = np.flatnonzero((chart % CHARTS == k) & (fix == f_axis))
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


def _add_elevated(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a + b for Bernstein tensors over the same variables (all axes), each raised to the larger degree per axis."""
    for k in range(a.ndim):
        if a.shape[k] < b.shape[k]:
            a = bernstein.elevate(a, k, b.shape[k] - a.shape[k])
        elif b.shape[k] < a.shape[k]:
            b = bernstein.elevate(b, k, a.shape[k] - b.shape[k])
    return a + b


class LoopPlane:
    """The loop equations' singular set in a plane of inputs: any mechanism with one loop (K_p 3 x 3).

    Unknowns: the passive joints and the plane's inputs, on the tan-half charts of the loop equations
    (:meth:`spherekin.mechanism.SphericalMechanism.loop_system` with ``free``: the plane inputs become unknowns);
    blocks: the closure equations of the formulation (pruned, no square system) and D = det K_p, whose columns
    are the passive joints' current axes (sign x R_link a, R_link the product of the rotations along the
    link's tree path; each rotation times 1 + t^2 is degree 2 in its t). D vanishes on the closure set exactly
    where the passive Jacobian loses rank (not the formulation's own degeneracies). The formulation is
    "transversal" (block 0: q f21, q f31, q f32 and Eq. (10)), whose square entries :meth:`prove` certifies.
    Passive joint ranges are constraints here (the mechanism's ranges).
    """

    def __init__(self, mechanism, plane: SingularPlane, formulation: str = "transversal"):
        from ..search.parameterizations import make_charts, stack_chart_sets

        m = mechanism
        if len(m.loop_geometry) != 1:
            raise ValueError(f"mechanism: singular sets on the loop equations need one loop (a 3 x 3 passive "
                             f"Jacobian), got {len(m.loop_geometry)}")
        self.mechanism = m
        self.plane = plane
        names = [a[0] for a in plane.axes]
        inputs = [plane.fixed.get(n, 0.0) for n in m.actuated]

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
        d, d_tol = self._determinant(closure)
        nb = len(closure.coeffs)
        self.charts = ChartSet(closure.parameterization, closure.unknowns, closure.variables,
                               list(closure.coeffs) + [d], list(closure.tols) + [d_tol],
                               list(closure.labels) + [("det K_p",)], [() for _ in range(nb + 1)],
                               closure.map_lo, closure.map_hi, closure.shift, closure.accept_width,
                               list(closure.bilinear or [None] * nb) + [None], list(closure.prune or [True] * nb) + [True])
        self.plane_columns = tuple(list(closure.variables).index(n) for n in names)

    def _determinant(self, charts: ChartSet):
        """D = det K_p (C, 1, *dims) on every chart, and its tolerance (C, 1): ROUNDING_SAFETY eps times the
        largest control point of the same products in absolute value (the terms behind each control point)."""
        m = self.mechanism
        variables = list(charts.variables)
        n = len(variables)
        terms = m.constraint_terms[0]
        passive_cols = {m.joint_names.index(p): p for p in m.passive}
        columns = [[t for t in terms if t[0] == col] for col in sorted(passive_cols, key=lambda c: m.passive.index(
            passive_cols[c]))]
        out, mags = [], []
        for c in range(charts.n_charts):
            dets = []
            for absolute in (False, True):
                cols = [self._column(col_terms, charts, c, variables, n, absolute) for col_terms in columns]
                det = None
                for perm in itertools.permutations(range(3)):
                    sign = 1.0 if absolute else float(np.linalg.det(np.eye(3)[list(perm)]))
                    term = bernstein.multiply(bernstein.multiply(cols[0][perm[0]], cols[1][perm[1]], n),
                                              cols[2][perm[2]], n)
                    det = sign * term if det is None else _add_elevated(det, sign * term)
                dets.append(det)
            out.append(dets[0])
            mags.append(float(np.abs(dets[1]).max()))
        d = np.stack(out)[:, None]
        tol = ROUNDING_SAFETY * np.finfo(float).eps * np.maximum(np.array(mags), np.abs(d).reshape(len(out), -1).max(
            axis=1))
        return d, tol[:, None]

    def _rotation(self, joint: str, sign: int, charts, c, variables, n, absolute) -> np.ndarray:
        """(1 + t^2) Rot(sign a, reading - ref) (3, 3, *sizes) of ``joint`` on chart c (a variable: degree 2 in
        its t), or Rot(...) itself (sizes 1) at the plane's fixed reading; in absolute value with ``absolute``."""
        j = self.mechanism.joint(joint)
        a = sign * np.asarray(j.axis, dtype=float)
        parts = np.stack([np.eye(3) - np.outer(a, a), _axis_cross(a), np.outer(a, a)])        # (cos, sin, 1)
        shape = [3, 3] + [1] * n
        if joint in variables:
            k = variables.index(joint)
            w = _weights(float(charts.shift[c, k]) - j.reference_angle, charts.map_lo[c, k], charts.map_hi[c, k])
            shape[2 + k] = 3
        else:
            d = self.plane.fixed[joint] - j.reference_angle
            w = np.array([[math.cos(d)], [math.sin(d)], [1.0]])
        if absolute:
            parts, w = np.abs(parts), np.abs(w)
        return np.einsum("pij,pk->ijk", parts, w).reshape(shape)

    def _column(self, col_terms, charts, c, variables, n, absolute) -> list[np.ndarray]:
        """The 3 entries (each a tensor over the n variables) of a passive joint's column of K_p on chart c."""
        m = self.mechanism
        total = None
        for _, sign, joint, link in col_terms:
            rot = np.eye(3).reshape([3, 3] + [1] * n)
            for st in m.link_paths[link]:
                r = self._rotation(st.joint, st.sign, charts, c, variables, n, absolute)
                rot = (rot[:, :, None] * r[None, :, :]).sum(axis=1)          # distinct variables: a tensor product
            axis = np.asarray(m.joint(joint).axis, dtype=float)
            vec = np.einsum("ij...,j->i...", np.abs(rot) if absolute else rot, np.abs(axis) if absolute else axis)
            vec = vec * (1.0 if absolute else sign)
            total = vec if total is None else np.stack([_add_elevated(total[i], vec[i]) for i in range(3)])
        return [total[i] for i in range(3)]

    def unit(self, chart, v) -> np.ndarray:
        """Unit coordinates (B, N) of angles v (B, N; radians) in charts ``chart`` (B,)."""
        cs = self.charts
        return tan_half_unit(np.asarray(v, dtype=float), cs.shift[chart], cs.map_lo[chart], cs.map_hi[chart])

    def prove(self, chart, fix, value, lo, hi) -> np.ndarray:
        """The Krawczyk test of the square slices (as :meth:`PlatformPlane.prove`, same arguments and
        result): the transversal closure entries q f21, q f31, q f32 and D, with plane axis ``fix[b]`` held at
        ``value[b]``, in the other variables on the box [lo[b], hi[b]] (unit coordinates of chart
        ``chart[b]``). The transversal entries also vanish at the three half-turns diag(+-1, +-1, +-1) != I
        (spurious closures), where Eq. (10)'s q (f11 + f22 - 2) is -2 q or -4 q (q >= 1): a proven root
        counts only where the Bernstein hull of Eq. (10) on the box stays above SPURIOUS_BOUND, so the root
        is a closure (F = I) and a singular configuration."""
        chart = np.asarray(chart, dtype=int)
        fix = np.asarray(fix, dtype=int)
        value = np.asarray(value, dtype=float)
        lo, hi = np.array(lo, dtype=float), np.array(hi, dtype=float)
        out = np.zeros(len(chart), dtype=bool)
        cs = self.charts
        for f_axis in np.unique(fix):
            rows = np.flatnonzero(fix == f_axis)
            c = chart[rows]
            blo, bhi = lo[rows], hi[rows]
            col = None if f_axis < 0 else self.plane_columns[f_axis]
            if col is not None:
                u = tan_half_unit(value[rows], cs.shift[c, col], cs.map_lo[c, col], cs.map_hi[c, col])
                blo[:, col] = bhi[:, col] = np.clip(u, 0.0, 1.0)
            blocks = [np.moveaxis(cs.coeffs[b][c], 0, -1) for b in (0, 1)]
            tols = [cs.tols[b][c].T for b in (0, 1)]

            def slices(boxes_lo, boxes_hi, which=slice(None)):
                cps = [bernstein.restrict_batch_last(bl[..., which], boxes_lo, boxes_hi, {}) for bl in blocks]
                if col is not None:             # the held axis (restricted to a point): dropped
                    cps = [np.take(cp, 0, axis=1 + col) for cp in cps]   # (E, d_1..d_N, B): variable k at axis 1 + k
                return cps

            cps = slices(blo, bhi)
            ok, _, _ = krawczyk_boxes(_LOOP_SLICE, cps, tols)
            ok &= cps[0][_SCALAR_ROW].reshape(-1, len(rows)).min(axis=0) > SPURIOUS_BOUND
            retry = np.flatnonzero(~ok)
            if len(retry):
                u, converged, _ = newton(_LOOP_SLICE, [cp[..., retry] for cp in cps], [t[:, retry] for t in tols])
                inner = converged & np.all((u > PROOF_RADIUS) & (u < 1.0 - PROOF_RADIUS), axis=1)
                retry, u = retry[inner], u[inner]
                if len(retry):
                    keep = [k for k in range(blo.shape[1]) if k != col]
                    rlo, rhi = blo[retry][:, keep], bhi[retry][:, keep]
                    w = rhi - rlo
                    slo, shi = blo[retry].copy(), bhi[retry].copy()
                    slo[:, keep], shi[:, keep] = rlo + (u - PROOF_RADIUS) * w, rlo + (u + PROOF_RADIUS) * w
                    small = slices(slo, shi, retry)
                    good, _, _ = krawczyk_boxes(_LOOP_SLICE, small, [t[:, retry] for t in tols])
                    good &= small[0][_SCALAR_ROW].reshape(-1, len(retry)).min(axis=0) > SPURIOUS_BOUND
                    ok[retry] = good
            out[rows] = ok
        return out


#: The loop slice's square system: the transversal entries q f21, q f31, q f32 (block 0) and D (block 1).
_LOOP_SLICE = SquareSystem(((0, 0), (0, 1), (0, 2), (1, 0)))
#: Row of Eq. (10), q (f11 + f22 - 2), in the transversal block.
_SCALAR_ROW = 3
#: A root of the transversal entries is a closure where Eq. (10) exceeds this on its box: at the spurious
#: half-turns it is -2 q or -4 q with q = prod (1 + t^2) >= 1, at a closure 0; -1 is halfway.
SPURIOUS_BOUND = -1.0
