"""Certified tracking of one assembly on the loop equations, for any mechanism (an addition to the paper).

:mod:`spherekin.trust.continuation` tracks on the platform's orientation (three R-R-R legs); this
module tracks every other mechanism (four-bars, five-bars, six-bars, elbow-actuated 3-RRR ...) on
the closure equations themselves, with the same guarantees and the same result types
(:class:`~spherekin.trust.continuation.Track`, ``TrackedPose``, ``SingularStop``, ``RangeStop``).

The equations are the transversal system of :mod:`spherekin.trust.transversal` (entries (2,1),
(3,1), (3,2) of F_n = prod Rx(phi_i) Z, Eq. (2), per loop), built from ``mechanism.loop_geometry``
with the actuated joints as unknowns too: F(theta, x), theta the passive readings
(``mechanism.loop_unknowns``), x the inputs (``mechanism.actuated``), radians. Its enclosure
(:func:`spherekin.trust.transversal.enclose`) gives F and both Jacobian blocks J_p = dF/dtheta and
J_a = dF/dx over boxes of (theta, x), outward-rounded. Tracking needs a square system (3 equations
per loop, one unknown per passive joint: every mechanism whose mobility equals its actuated joints);
redundant actuation is refused.

A step from input x0 to x1 (x(sigma) = x1 + sigma delta, delta = x1 - x0, sigma in [-1, 0]): Newton
at x1 from the tangent predictor gives theta1; the box W = hull(theta0, theta1), widened by a margin
(MARGIN_RELATIVE), holds the proven root at x0 and the new one. With m the middle of W, X the
hull of the segment, Y a float inverse of (the middle of) J_p(m, X), the parametric Krawczyk operator

    K = m - Y F(m, x1) - (Y J_a(m, X) delta) sigma + (I - Y J_p(W, X)) (W - m)

encloses the Krawczyk operator of every input of the segment (F(m, x(sigma)) - F(m, x1) lies in
sigma J_a(m, X) delta by the mean-value theorem, one sigma for all rows, so Y keeps their
correlation); K inside the interior of W proves that every input of the step has exactly one root
in W and J_p is regular there: the root moves continuously from the proven one at x0 to the one at
x1, never to another assembly. A point test at x1 (radius POINT_RADIUS around theta1) then proves
the new root, which the next step's box holds: the chain of proofs is unbroken. (The transversal
entries also vanish where F_n is a half turn about a coordinate axis; a continuous path of roots
from a closure stays one, since those matrices are isolated from I, and every Newton root is
checked against the whole F_n.) Up to BATCH rows are predicted (Newton from row to row) and their
steps proven in one Krawczyk call; the segments whose step is not proven, or not proven inside the
ranges, are walked together (:func:`spherekin.trust.stepping.walk`, one Krawczyk call a round): failed steps are halved,
successful ones grow by STEP_GROWTH, and a walk's first step is the previous segment's last one (or
the whole segment); where a walk does not end at the predicted root (AGREE_TOL) the batch ends there. A step below MIN_STEP that cannot be proven ends the track at a
parallel singularity, located by bisection (Newton from the last proven pose converging with the
sign of det J_p kept: the branch exists) to LOCATE_TOL. The stepping loop is the platform
tracker's (:mod:`spherekin.trust.stepping`: MIN_STEP, FIRST_STEP, the step budget); these equations
are its :class:`_LoopStepper`. The constants POINT_RADIUS, LOCATE_TOL, MARGIN and Newton's are
the platform tracker's, for the reasons given there.

Joint ranges: every joint's angle over a proven step is enclosed directly (a passive joint by W, an
input by the hull of x0 and x1) and tested as a solve tests it (:func:`spherekin.core.angles.span_in_range_many`);
a step not proven inside is halved until it is, or until it ends with a joint outside: the track
then ends with a :class:`RangeStop`, the crossing located by bisection on that proven step to
LOCATE_TOL. Nothing beyond the last proven input is reported.

The poses' ``platform_rotation`` is ``mechanism.pose_from_passive`` (None for a mechanism without an
output link); the passive angles are the joint readings, wrapped to [-pi, pi) (into the joint's
range where it has one, as a solve reports them).
"""

from __future__ import annotations

import dataclasses
from typing import Mapping

import numpy as np

from ..closure import ClosureLoop, Term, Unknown, closure_at
from ..core import intervals as iv
from ..core.angles import in_range_many, into_range, span_in_range_many, wrap
from .continuation import (AGREE_TOL, BATCH, LOCATE_TOL, MARGIN, NEWTON_ITERATIONS, NEWTON_TOL, POINT_RADIUS, SIGMA,
                           RangeStop, SingularStop, Track, TrackedPose, parametric_krawczyk)
from .stepping import FIRST_STEP, MAX_STEPS, MIN_STEP, STEPS_PER_INPUT, Stop, walk
from .transversal import enclose, plan_of

__all__ = ["LoopEquations", "track_loops"]

#: Half-range (radians) of the tan-half-angle chart of the Unknowns built here. Reason: a
#: :class:`~spherekin.closure.Unknown` needs a range narrower than 2 pi, but only its name is used
#: (the enclosures and floats here work on the angles themselves, never on the chart).
CHART = 1.0
#: Largest entry of |F_n - I| at which Newton's root counts as converged (after a step below
#: NEWTON_TOL). Reason: the entries are O(1) products of sines and cosines, so 1e-13 is a few
#: hundred ulps of them: a closure to the precision of the floats.
NEWTON_RESIDUAL = 1e-13
#: The step box W = hull(theta0, theta1) is widened on each side by MARGIN_RELATIVE |theta1 - theta0| +
#: MARGIN (MARGIN: the platform tracker's, for the same reason). Reason: the enclosure of J_p over W
#: is a product of up to 2 x (joints of a loop) rotations in interval arithmetic, wider than the
#: platform's quadratic one, so K needs more room than the platform's 5%: on a 200-row crank turn of
#: the four-bar 30% tries 2.6x fewer steps than 5% (50% gains nothing more: the slope term grows with W).
MARGIN_RELATIVE = 0.3
#: Half-width (radians) of the interval each constant angle of the loops stands for in the step
#: proofs. Reason: 0, as the platform tracker proves its steps on the legs' floats: a track is about
#: the mechanism's floats, and any width here is divided by sigma_min of J_p next to a fold
#: (:data:`spherekin.trust.transversal.ANGLE_TOLERANCE`, 2e-14, stopped the proofs 7e-6 rad of input
#: before a four-bar's branch point, against 5e-9 with 0).
TRACK_ANGLE_TOLERANCE = 0.0
#: A proven step is followed by one STEP_GROWTH times longer (a rejected one by one half as long).
#: Reason: a step here costs ~100x the platform tracker's batched ones, and next to a fold, where the
#: provable step is a fixed fraction of the distance to it, the platform's 1.5 rejects every second
#: try: 1.2 tries 20% fewer steps to reach a four-bar's branch point (1.5: 1329, 1.2: ~1080) and a
#: few % fewer on regular paths.
STEP_GROWTH = 1.2


def _named(names, values) -> dict:
    """{name: float} of ``values`` in the order of ``names`` (radians)."""
    return {n: float(v) for n, v in zip(names, values)}


def _refusal(w_lo, w_hi, image: bool):
    """What a Krawczyk test of the boxes [w_lo, w_hi] answers without testing (None: test them): no box,
    or no IEEE default rounding (a refusal, never a wrong verdict: every box not proven, K the box)."""
    if len(w_lo) and iv.rounding_environment_ok():
        return None
    refused = np.zeros(len(w_lo), dtype=bool)
    return (refused, w_lo, w_hi) if image else refused


class LoopEquations:
    """The transversal closure system F(theta, x) of ``mechanism`` with its inputs as unknowns.

    ``passive`` (M names: ``mechanism.loop_unknowns``) then ``actuated`` (A names) are the columns;
    F has E = 3 loops rows. ``system`` is a :class:`~spherekin.mechanism.LoopSystem` over all M + A
    (for :func:`~spherekin.trust.transversal.plan_of`); ValueError unless E == M (module doc).
    """

    def __init__(self, mechanism, inputs):
        self.passive = tuple(mechanism.loop_unknowns)
        self.actuated = tuple(mechanism.actuated)
        names = self.passive + self.actuated
        chart = {n: Unknown(n, -CHART, CHART) for n in names}
        loops, indices = [], []
        for g in mechanism.loop_geometry:
            loop = ClosureLoop([spec.offset if spec.joint is None else Term(chart[spec.joint], spec.offset, spec.sign)
                                for spec in g.factor_specs()])
            loops.append(loop)
            indices.append(tuple(names.index(u.name) for u in loop.unknowns))
        self.n_eq, self.m, self.a = 3 * len(loops), len(self.passive), len(self.actuated)
        if self.n_eq != self.m:
            raise ValueError(f"track: the loop equations of {mechanism.name or 'the mechanism'} have {self.n_eq} "
                             f"equations ({len(loops)} loop(s)) in {self.m} passive joint(s): redundant actuation is "
                             "not tracked (expected as many equations as passive joints)")
        counts = {n: sum(n in lp.names for lp in loops) for n in names}
        base = mechanism.loop_system(inputs, passive_ranges={n: (-CHART, CHART) for n in self.passive})
        self.loops, self.unknowns, self.indices = tuple(loops), tuple(chart.values()), tuple(indices)
        self.system = dataclasses.replace(base, loops=self.loops, unknowns=self.unknowns, loop_indices=self.indices,
                                          shared=tuple(n for n in names if counts[n] > 1))
        self.plan = plan_of(self.system)
        self.last_closure = float("nan")         # max |F_n - I| at the last :meth:`values` (see :meth:`closure`)
        self._cached = None                      # (point, values, closure) of the last :meth:`values`

    # ---------------------------------------------------------------- floats

    def values(self, theta, x) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(F (E,), J_p (E, M), J_a (E, A)) at passive angles ``theta`` (M,) and inputs ``x`` (A,)."""
        point = np.concatenate((theta, x))
        if self._cached is not None and np.array_equal(point, self._cached[0]):
            self.last_closure = self._cached[2]   # (Newton's last point is the next step's tangent point)
            return self._cached[1]
        f, j = closure_at(self.loops, self.unknowns, point, jacobian=True, loop_indices=self.indices)
        self.last_closure = float(np.abs(f - np.eye(3)).max(initial=0.0))
        # the transversal entries (2,1), (3,1), (3,2) of each F_n, in the order of the enclosure's rows
        # (search.formulations.TRANSVERSAL_ENTRIES; not imported: trust/ stops importing search/)
        f = np.stack((f[:, 1, 0], f[:, 2, 0], f[:, 2, 1]), axis=1).reshape(-1)
        j = np.stack((j[:, 1, 0], j[:, 2, 0], j[:, 2, 1]), axis=1).reshape(self.n_eq, -1)
        out = (f, j[:, :self.m], j[:, self.m:])
        self._cached = (point, out, self.last_closure)
        return out

    def closure(self, theta, x) -> float:
        """The largest entry of |F_n - I| over the loops (radians-scale; 0 at a closure). The
        transversal entries also vanish where F_n is a half turn about a coordinate axis, which this
        tells apart."""
        self.values(theta, x)
        return self.last_closure

    def newton(self, theta, x):
        """(theta, converged): Newton on F(., x) = 0 from ``theta``; converged once a step was below
        NEWTON_TOL and the loops close to NEWTON_RESIDUAL after it (:meth:`closure`: a root of the
        transversal entries alone may be a half turn, not a closure; past a fold, where no closure
        is left, Newton finds such roots)."""
        theta = np.array(theta, dtype=float)
        small = False
        for i in range(NEWTON_ITERATIONS + 1):
            f, jp, _ = self.values(theta, x)
            if small and self.last_closure <= NEWTON_RESIDUAL:
                return theta, True
            if i == NEWTON_ITERATIONS:
                break
            try:
                d = np.linalg.solve(jp, f)
            except np.linalg.LinAlgError:
                return theta, False
            theta = theta - d
            if not np.all(np.isfinite(theta)):
                return theta, False
            small = np.abs(d).max(initial=0.0) <= NEWTON_TOL
        return theta, False

    def predict(self, theta0, x0, x1):
        """Newton's root at x1 from the tangent predictor at (theta0, x0), or None."""
        _, jp, ja = self.values(theta0, x0)
        try:
            guess = theta0 - np.linalg.solve(jp, ja @ (np.asarray(x1) - x0))
        except np.linalg.LinAlgError:
            return None
        theta1, ok = self.newton(guess, x1)
        return theta1 if ok else None

    def det_sign(self, theta, x) -> float:
        return float(np.sign(np.linalg.det(self.values(theta, x)[1])))

    # ---------------------------------------------------------------- proofs

    def krawczyk(self, w_lo, w_hi, x0, x1, image: bool = False):
        """Whether the parametric Krawczyk operator (module doc) maps each box [w_lo, w_hi] (N, M)
        into its interior for every input of the segment x0 -> x1 (N, A each): a boolean per box; with
        ``image``, also the operator's image K (lo, hi; (N, M) each), which holds every root in the
        box of every input of the segment (the Krawczyk theorem), far tighter than the box."""
        w_lo, w_hi = np.asarray(w_lo, dtype=float), np.asarray(w_hi, dtype=float)
        x0, x1 = np.asarray(x0, dtype=float), np.asarray(x1, dtype=float)
        refused = _refusal(w_lo, w_hi, image)
        if refused is not None:
            return refused
        delta = x1 - x0
        sigma = iv.from_bounds(np.array([-SIGMA]), np.array([SIGMA - 1.0])).reshape(2, 1, 1)
        xs = iv.add(iv.point(x1), iv.mul(iv.point(delta), sigma))               # holds x1 + sigma delta
        f_m, ja, jp, jp_mid = self._enclosures(w_lo, w_hi, x1, xs, np.clip(0.5 * (xs[0] + xs[1]), xs[0], xs[1]))
        rate = iv.isum(iv.scale(delta[:, None, :], ja), -1)                   # J_a(m, X) delta (2, N, E)
        ok, k = parametric_krawczyk(w_lo, w_hi, jp_mid, f_m, rate, jp, sigma)
        return (ok, k[0], k[1]) if image else ok

    def _enclosures(self, w_lo, w_hi, x_p, xs, x_mid):
        """(F(m, x_p) (2, N, E), J_a(m, X) (2, N, E, A), J_p(W, X) (2, N, E, M), J_p's middle at m
        (N, E, M)) for the boxes W = [w_lo, w_hi] (N, M), m their centres, the inputs X = ``xs``
        (intervals (2, N, A)) with the expansion point ``x_p`` (N, A) and the centre ``x_mid``."""
        n = len(w_lo)
        mid = 0.5 * (w_lo + w_hi)
        lo = np.concatenate((np.concatenate((mid, x_p), 1), np.concatenate((mid, xs[0]), 1),
                             np.concatenate((w_lo, xs[0]), 1)))
        hi = np.concatenate((np.concatenate((mid, x_p), 1), np.concatenate((mid, xs[1]), 1),
                             np.concatenate((w_hi, xs[1]), 1)))
        center = np.concatenate((np.concatenate((mid, x_p), 1), np.concatenate((mid, x_mid), 1),
                                 np.concatenate((mid, x_mid), 1)))
        f, j = enclose(self.plan, lo, hi, center, TRACK_ANGLE_TOLERANCE)
        jp_mid = 0.5 * (j[0, n:2 * n, :, :self.m] + j[1, n:2 * n, :, :self.m])     # J_p at m, mid-box
        return f[:, :n], j[:, n:2 * n, :, self.m:], j[:, 2 * n:, :, :self.m], jp_mid

    def krawczyk_input_boxes(self, w_lo, w_hi, x_lo, x_hi, image: bool = False):
        """The box sibling of :meth:`krawczyk` (:func:`~spherekin.trust.continuation.krawczyk_input_boxes`
        on the loop equations): whether the parametric Krawczyk operator

            K = m - Y F(m, x_c) - (Y J_a(m, X)) (X - x_c) + (I - Y J_p(W, X)) (W - m)

        maps each box W = [w_lo, w_hi] (N, M passive angles, radians) into its interior for every
        input of the box X = [x_lo, x_hi] (N, A each; a fixed input: lo = hi), x_c its centre: then
        every input of X has exactly one root in W and J_p is regular on W x X (no parallel
        singularity of that assembly over X). A boolean per box; with ``image``, also K (lo, hi)."""
        w_lo, w_hi = np.asarray(w_lo, dtype=float), np.asarray(w_hi, dtype=float)
        x_lo, x_hi = np.asarray(x_lo, dtype=float), np.asarray(x_hi, dtype=float)
        refused = _refusal(w_lo, w_hi, image)
        if refused is not None:
            return refused
        xs = iv.from_bounds(x_lo, x_hi)
        x_c = np.clip(0.5 * (x_lo + x_hi), x_lo, x_hi)
        f_m, ja, jp, jp_mid = self._enclosures(w_lo, w_hi, x_c, xs, x_c)
        ok, k = parametric_krawczyk(w_lo, w_hi, jp_mid, f_m, ja, jp, iv.sub(xs, iv.point(x_c)))
        return (ok, k[0], k[1]) if image else ok

    def certify_step(self, theta0, theta1, x0, x1) -> tuple[np.ndarray, np.ndarray] | None:
        """The step box (:func:`step_box`) over the segment x0 -> x1, and the point box of radius
        POINT_RADIUS around theta1 at x1, both proven (module doc): then the Krawczyk image of the step
        box (lo, hi; (M,) each), which holds the root of every input of the step (what the joint ranges
        are tested on: the box's margins would keep a joint from being proven inside its range closer
        than them to its end); else None."""
        w_lo, w_hi = step_box(theta0, theta1)
        lo = np.stack((w_lo, theta1 - POINT_RADIUS))
        hi = np.stack((w_hi, theta1 + POINT_RADIUS))
        ok, k_lo, k_hi = self.krawczyk(lo, hi, np.stack((x0, x1)), np.stack((x1, x1)), image=True)
        return (k_lo[0], k_hi[0]) if ok.all() else None


    def certify_steps(self, theta0, theta1, x0, x1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`certify_step` of N steps at once, in one Krawczyk call: roots ``theta0`` ->
        ``theta1`` (N, M each) over the segments x0 -> x1 (N, A each); (proven (N,), lo, hi (N, M):
        the Krawczyk images of the step boxes, meaningful where proven)."""
        n = len(theta0)
        w_lo, w_hi = step_box(theta0, theta1)
        ok, k_lo, k_hi = self.krawczyk(np.concatenate((w_lo, theta1 - POINT_RADIUS)),
                                       np.concatenate((w_hi, theta1 + POINT_RADIUS)),
                                       np.concatenate((x0, x1)), np.concatenate((x1, x1)), image=True)
        return ok[:n] & ok[n:], k_lo[:n], k_hi[:n]


def step_box(theta0, theta1) -> tuple[np.ndarray, np.ndarray]:
    """W = hull(theta0, theta1) widened by the margins (MARGIN_RELATIVE, MARGIN; radians, (M,) each,
    or (N, M) for N steps)."""
    pad = MARGIN_RELATIVE * np.abs(theta1 - theta0).max(axis=-1, keepdims=True, initial=0.0) + MARGIN
    return np.minimum(theta0, theta1) - pad, np.maximum(theta0, theta1) + pad


class _Ranges:
    """Every joint's range (the inputs then the passive joints) and the tests of a solve."""

    def __init__(self, mechanism, eqs: LoopEquations):
        self.names = eqs.actuated + eqs.passive
        self.ranges = [mechanism.ranges[n] for n in self.names]
        self.limited = any(r is not None for r in self.ranges)
        self.a = eqs.a

    def outside(self, x, theta) -> str | None:
        """The first joint outside its range at inputs ``x`` and passive angles ``theta``, or None."""
        for name, rng, v in zip(self.names, self.ranges, np.concatenate((x, theta))):
            if not in_range_many(v, rng):
                return name
        return None

    def steps_inside(self, w_lo, w_hi, x0, x1) -> np.ndarray:
        """:meth:`step_inside` of N proven steps (boxes (N, M), inputs (N, A) each): a boolean per step."""
        lo = np.concatenate((np.minimum(x0, x1), w_lo), axis=1)
        hi = np.concatenate((np.maximum(x0, x1), w_hi), axis=1)
        ok = np.ones(len(lo), dtype=bool)
        for j, rng in enumerate(self.ranges):
            ok &= span_in_range_many(lo[:, j], hi[:, j], rng)
        return ok

    def step_inside(self, w_lo, w_hi, x0, x1) -> bool:
        """Whether every joint is proven inside its range over a proven step (its box W, inputs x0 -> x1)."""
        lo = np.concatenate((np.minimum(x0, x1), w_lo))
        hi = np.concatenate((np.maximum(x0, x1), w_hi))
        return all(bool(span_in_range_many(a, b, rng)) for a, b, rng in zip(lo, hi, self.ranges))


class _LoopStepper:
    """The loop equations as a :class:`~spherekin.trust.stepping.Stepper`: the state and a proposal
    the passive angles theta (M,); a proven step is tested against the joint ranges at once
    (:meth:`check`)."""

    growth = STEP_GROWTH

    def __init__(self, eqs: LoopEquations, ranges: "_Ranges"):
        self.eqs, self.ranges = eqs, ranges

    def predict(self, thetas, b0, b1):
        new = [self.eqs.predict(th, x0, x1) for th, x0, x1 in zip(thetas, b0, b1)]
        found = np.array([th is not None for th in new], dtype=bool)
        out = np.full((len(new), self.eqs.m), np.nan)
        if found.any():
            out[found] = np.array([th for th in new if th is not None]).reshape(-1, self.eqs.m)
        return out, found

    def certify(self, thetas, new, b0, b1):
        return self.eqs.certify_steps(thetas, new, b0, b1)

    def advance(self, theta, new):
        return new

    def locate(self, theta, b0, direction, t_max: float):
        return _locate_singular(self.eqs, theta, b0, direction, t_max)

    def check(self, theta, new, x0, direction, s: float, t: float, b0, b1, w_lo, w_hi):
        """None (the step stands), a range :class:`~spherekin.trust.stepping.Stop` where a joint leaves
        its range at the step's end, or "finer" when the step is proven but not proven inside the
        ranges (walked again in halves)."""
        ranges = self.ranges
        if not ranges.limited:
            return None
        if ranges.outside(b1, new) is not None:
            lo, hi, theta_in, joint = _locate_exit(self.eqs, ranges, theta, new, x0, direction, s, t, w_lo, w_hi)
            return Stop("range", lo, theta_in, lo, hi, joint)
        span = float(np.abs(direction).max(initial=0.0))
        if (t - s) * span > LOCATE_TOL and not ranges.step_inside(w_lo, w_hi, b0, b1):
            return "finer"
        return None


def _locate_exit(eqs, ranges, theta, theta1, x0, direction, s0, s1, w_lo, w_hi):
    """Bisection on the proven step from s0 (pose ``theta``, in range) to s1 (pose ``theta1``,
    outside) for where a joint leaves its range, to LOCATE_TOL in input: (s_in, s_out, theta at
    s_in, the joint outside at s_out). A Newton root counts only inside the step's box W (the step
    is proven: the root there is the tracked one)."""
    b0 = x0 + s0 * direction
    scale = float(np.abs(direction).max(initial=0.0))
    lo, hi, theta_lo, theta_hi = s0, s1, theta, theta1
    while (hi - lo) * scale > LOCATE_TOL:
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        x = x0 + mid * direction
        th = eqs.predict(theta, b0, x)
        inside_w = th is not None and bool(np.all(th >= w_lo) and np.all(th <= w_hi))
        if inside_w and ranges.outside(x, th) is None:
            lo, theta_lo = mid, th
        else:
            hi = mid
            theta_hi = th if inside_w else theta_hi
    joint = ranges.outside(x0 + hi * direction, theta_hi) or ranges.outside(x0 + s1 * direction, theta1)
    return lo, hi, theta_lo, joint


def _locate_singular(eqs: LoopEquations, theta, b0, direction, t_max: float) -> tuple[float, float]:
    """Bisection on t in [0, t_max] (inputs b0 + t direction) for the end of the branch from the
    proven root ``theta`` at b0: the largest t where Newton from it converges with the sign of
    det J_p kept, to LOCATE_TOL in input units."""
    sign = eqs.det_sign(theta, b0)
    scale = float(np.abs(direction).max(initial=0.0))
    lo, hi = 0.0, t_max
    while (hi - lo) * scale > LOCATE_TOL:
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        x = b0 + mid * direction
        th = eqs.predict(theta, b0, x)
        if th is not None and eqs.det_sign(th, x) == sign:
            lo = mid
        else:
            hi = mid
    return lo, hi


def _readings(mechanism, names, theta) -> np.ndarray:
    """The passive readings as a solve reports them: wrapped to [-pi, pi), into the joint's range if any."""
    return np.array([into_range(wrap(float(v)), mechanism.ranges[n]) for n, v in zip(names, theta)])


def track_loops(mechanism, path, start_angles, *, start_tol: float = 1e-6) -> Track:
    """Follow the assembly at the passive angles ``start_angles`` along ``path`` (K, A inputs,
    radians), every step proven on the loop equations (module doc).

    ``start_angles``: name -> reading (radians) of every passive joint of the loops
    (``mechanism.loop_unknowns``), or a sequence in that order; it must close the loops at path[0]
    to ``start_tol`` (largest entry of |F_n - I|) with every joint in its range, and is polished by
    Newton and proven (a point Krawczyk test) first. Returns a
    :class:`~spherekin.trust.continuation.Track`: the pose at every row reached, and the stop (a
    parallel singularity, or a joint leaving its range) if the path was not completed.
    """
    path = np.asarray(path, dtype=float)
    a = len(mechanism.actuated)
    if path.ndim != 2 or path.shape[1] != a or not len(path):
        raise ValueError(f"path: expected an array of shape (K, {a}), got shape {path.shape}")
    if not np.all(np.isfinite(path)):
        raise ValueError("path: expected finite inputs (radians)")
    eqs = LoopEquations(mechanism, path[0])
    ranges = _Ranges(mechanism, eqs)
    names = eqs.passive
    if isinstance(start_angles, Mapping):
        missing = [nm for nm in names if nm not in start_angles]
        if missing:
            raise ValueError(f"start: missing the angle(s) of {missing}; expected one per passive joint {list(names)}")
        theta = np.array([float(start_angles[nm]) for nm in names])
    else:
        theta = np.asarray(start_angles, dtype=float).reshape(-1)
        if theta.shape != (len(names),):
            raise ValueError(f"start: expected {len(names)} passive angles {list(names)}, got shape {theta.shape}")
    if not np.all(np.isfinite(theta)):
        raise ValueError("start: expected finite passive angles (radians)")
    res0 = eqs.closure(theta, path[0])
    if res0 > start_tol:
        raise ValueError(f"start: the start angles do not close the loops at the first input of the path (largest "
                         f"entry of |F_n - I| {res0:.3g} > {start_tol:g}); give an assembly at {path[0].tolist()}")
    theta, ok = eqs.newton(theta, path[0])
    if not ok or not eqs.krawczyk((theta - POINT_RADIUS)[None], (theta + POINT_RADIUS)[None], path[:1], path[:1])[0]:
        raise ValueError("start: the start pose could not be proven an isolated assembly at the first input "
                         "(it is at or next to a parallel singularity)")
    out0 = ranges.outside(path[0], theta)
    if out0 is not None:
        value = dict(zip(ranges.names, np.concatenate((path[0], theta))))[out0]
        raise ValueError(f"start: {out0} = {value:.6g} rad at the start pose is outside its joint range "
                         f"{list(mechanism.ranges[out0])}; give an assembly inside the ranges")
    n = len(path)
    thetas, steps_of = [theta], [0]
    n_steps = rejected = 0
    budget = MAX_STEPS + STEPS_PER_INPUT * n
    seg = None
    last = FIRST_STEP                             # the input change of the last proven step (radians)
    k = 0
    while k < n - 1 and (seg is None or seg.end is not None):
        # predict up to BATCH rows (Newton, in floats), prove every step in one Krawczyk call, walk
        # the segments whose step is not proven (or not proven inside the ranges) together
        end = min(n - 1, k + BATCH)
        pred = [thetas[-1]]
        for j in range(k, end):
            th = eqs.predict(pred[-1], path[j], path[j + 1])
            if th is None:
                break
            pred.append(th)
        m = len(pred) - 1
        pred = np.array(pred)
        good = np.zeros(m, dtype=bool)
        if m:
            good, k_lo, k_hi = eqs.certify_steps(pred[:m], pred[1:], path[k:k + m], path[k + 1:k + m + 1])
            if ranges.limited and good.any():
                good[good] = ranges.steps_inside(k_lo[good], k_hi[good], path[k:k + m][good],
                                                 path[k + 1:k + m + 1][good])
        rejected += int((~good).sum())
        # the segments to walk (and the one Newton failed on), together; each walk's first step the
        # previous segment's proven one where that was proven in the batch, else the last known
        walked = [j for j in range(m) if not good[j]] + ([m] if m < end - k else [])
        spans = np.abs(np.diff(path[k:k + m + 2], axis=0)).max(axis=1, initial=0.0)
        firsts = [spans[j - 1] if j and good[j - 1] and spans[j - 1] else last for j in walked]
        idx = k + np.array(walked, dtype=int)
        walks = dict(zip(walked, walk(_LoopStepper(eqs, ranges), pred[walked], path[idx], path[idx + 1],
                                      budget - n_steps - rejected, firsts))) if walked else {}
        for j in range(m + (m < end - k)):        # the batch's segments in order (and the one Newton failed on)
            r = k + j
            if j not in walks:
                n_steps += 1
                last = float(spans[j]) or last
                thetas.append(pred[j + 1])
                steps_of.append(1)
                continue
            seg = walks[j]
            n_steps += seg.steps
            rejected += seg.rejected
            if seg.end is None:
                k = r
                break
            last = seg.last_step
            thetas.append(seg.end)
            steps_of.append(seg.steps)
            if j + 1 < len(pred) and np.abs(seg.end - pred[j + 1]).max() > AGREE_TOL:
                k = r + 1                          # not the predicted root: the later steps start elsewhere
                break
            thetas[-1] = pred[j + 1] if j + 1 < len(pred) else seg.end
        else:
            k = k + j + 1
    reached = len(thetas)
    all_names = [j.name for j in mechanism.joints]
    act = eqs.actuated

    def pose_data(xs, ths):
        """(readings (K, M), rotations, residuals, measures) at inputs xs (K, A) and roots ths (K, M)."""
        readings = np.array([_readings(mechanism, names, th) for th in ths]).reshape(len(ths), len(names))
        rotations = [mechanism.pose_from_passive(tuple(x), _named(names, r)) for x, r in zip(xs, readings)]
        residuals = [eqs.closure(th, x) for x, th in zip(xs, ths)]
        cols = {**{nm: xs[:, j] for j, nm in enumerate(act)}, **{nm: readings[:, j] for j, nm in enumerate(names)}}
        measures = mechanism.parallel_measures({nm: cols.get(nm, np.zeros(len(xs))) for nm in all_names})
        return readings, rotations, residuals, measures

    readings, rotations, residuals, measures = pose_data(path[:reached], np.array(thetas))
    poses = tuple(TrackedPose(r, _named(act, path[r]), None if rotations[r] is None else np.asarray(rotations[r]),
                              _named(names, readings[r]), residuals[r], float(measures[r]), int(steps_of[r]))
                  for r in range(reached))
    stop = None
    if seg is not None and seg.end is None:
        seg = seg.stop
        x0, direction = path[k], path[k + 1] - path[k]
        here = x0 + seg.s * direction
        (reading,), _, _, (measure,) = pose_data(here[None], seg.state[None])
        if seg.kind == "range":
            there = x0 + seg.hi * direction
            rng = tuple(float(v) for v in mechanism.ranges[seg.joint])
            angle = dict(zip(ranges.names, np.concatenate((here, reading))))[seg.joint]
            stop = RangeStop((k, k + 1), float(seg.s), seg.joint, rng, float(angle), _named(act, here),
                             _named(act, there), float(np.abs(there - here).max(initial=0.0)), float(measure),
                             f"{seg.joint} leaves its joint range {list(rng)} (radians): no pose beyond is reported")
        else:
            singular = x0 + 0.5 * (seg.lo + seg.hi) * direction
            stop = SingularStop((k, k + 1), float(seg.s), _named(act, here), _named(act, singular),
                                float(np.abs(singular - here).max(initial=0.0)),
                                float((seg.hi - seg.lo) * np.abs(direction).max(initial=0.0)), float(measure),
                                f"no step longer than {MIN_STEP:g} rad of input could be proven: the assembly "
                                "meets another (a parallel singularity) and ends")
    return Track(mechanism.name, act, names, n, poses, stop, n_steps, rejected)
