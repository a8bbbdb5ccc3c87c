"""Certified tracking of one assembly mode along a path of actuator inputs (an addition to the paper).

The equations are those of the platform formulation (:mod:`spherekin.search.platform_orientation`,
Eq. (1) of each R-R-R leg): e_i(beta_i) . (D a3_i) = a2_i . a3_i, with D = R R_ref^T the platform's
displacement and e_i(beta) = Rot(a1_i, beta - beta_ref) a2_i the leg's elbow axis. Near the current
displacement D_c the unknown is a 3-vector w, D = D_c C(w), with the Cayley rotation
C(w) = (I - [w]/2)^-1 (I + [w]/2) (turn by 2 atan(|w|/2) about w). Multiplied by 1 + |w|^2/4 > 0
(which does not move the zeros) the leg equation is the quadratic

    h_i(w, beta) = (1 - |w|^2/4) (a.b) + w.(b x a) + (a.w)(w.b)/2 - c (1 + |w|^2/4),
    grad_w h_i   = -(a.b) w/2 + b x a + ((a.w) b + (b.w) a)/2 - c w/2,

with a = D_c^T e_i(beta), b = a3_i, c = a2_i . a3_i: polynomial in w and in (cos beta, sin beta),
so both are enclosed over boxes in interval arithmetic (:mod:`spherekin.core.intervals`, cos/sin of
an interval of beta included) without any Taylor remainder.

A step from input x0 to x1 (beta(s) = x0 + s (x1 - x0), s in [0, 1]): Newton at x1 from the
tangent predictor gives w1; the box W = hull(0, w1) widened by a margin holds the current root
(w = 0) and the new one. It is accepted when the Krawczyk operator over W, with beta ranging over
the whole hull of x0 and x1,

    K = m - Y h(m, B) + (I - Y J(W, B)) (W - m) lies in the interior of W,

which proves that for *every* input of the step the equations have exactly one root in W (and
that the Jacobian is regular there): the root moves continuously inside W from w = 0 to the root at
x1, so the new pose is the continuation of the old one, never another assembly mode. A point
Krawczyk test at x1 on a box of radius POINT_RADIUS around w1 then proves the new root to that
accuracy, the next step's box contains that one, and the chain of proofs is unbroken. A step that
cannot be proven is halved; the step grows again after successes.

Near a parallel singularity (a fold, where the assembly mode meets another and ends) the Jacobian
tends to a singular matrix and the provable steps shrink geometrically. When a step below
MIN_STEP (radians of input) cannot be proven, the tracker stops and reports where: the last proven
input, and the singular input located by bisection on the step (Newton from the last proven pose
converging to a root with the Jacobian's determinant of the same sign: the branch exists), to
LOCATE_TOL. Nothing beyond the last proven input is reported as a pose.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..core import intervals as iv
from ..search.platform_orientation import passive_names, passive_readings_many, platform_legs

__all__ = ["POINT_RADIUS", "MIN_STEP", "LOCATE_TOL", "MARGIN", "NEWTON_TOL", "MAX_STEPS", "TrackedPose",
           "SingularStop", "Track", "LegEquations", "cayley", "krawczyk_step", "track"]

#: Radius of the box around each accepted root that a point Krawczyk test proves (in w, ~radians).
#: Reason: Newton's roots are accurate to ~1e-15; 1e-10 leaves room for the rounding of the
#: change of coordinates D_c -> D_c C(w1) and is still far below any tolerance of a pose.
POINT_RADIUS = 1e-10
#: The step box W = hull(0, w1) is widened on each side by MARGIN_RELATIVE |w1| + MARGIN. Reason:
#: the box must hold the previous root's proven box (POINT_RADIUS) with room, and a Krawczyk
#: image needs some slack inside W; 10 POINT_RADIUS + 5% of the step does both.
MARGIN = 10 * POINT_RADIUS
MARGIN_RELATIVE = 0.05
#: A step (largest input change, radians) below this that still cannot be proven ends the track.
#: Reason: next to a fold the provable step shrinks like the distance d to it, while the two modes
#: that meet there are ~sqrt(d) apart; 1e-13 follows a mode to within ~1e-12 of its end (the modes
#: then ~1e-6 apart, the Jacobian's condition ~1e6, still well inside double precision), so two
#: modes that only come close (1e-4 apart: d ~ 1e-9) are followed through, never stopped at.
MIN_STEP = 1e-13
#: Width (radians of input) to which the bisection locates the singular input where a track stops.
LOCATE_TOL = 1e-12
#: Newton on h(w, beta) = 0: stop when the step is below this (|w| ~ radians) ...
NEWTON_TOL = 1e-15
#: ... or after this many iterations (quadratic convergence from the predictor needs ~4).
NEWTON_ITERATIONS = 12
#: Largest number of steps (proven or rejected) of one track. Reason: a smooth path of N inputs
#: needs a few steps per input; 200 per input plus 10,000 covers folds approached geometrically.
STEPS_PER_INPUT = 200
MAX_STEPS = 10_000
#: The first step of a segment tries the whole segment when its largest input change is below this
#: (radians), else this much; later steps grow by STEP_GROWTH after a success and halve after a failure.
FIRST_STEP = 0.1
STEP_GROWTH = 1.5


@dataclass(frozen=True)
class TrackedPose:
    """The tracked assembly at path row ``row``: ``inputs`` (radians), platform ``rotation`` R (3, 3),
    ``passive`` angles (radians, in ``Track.names`` order), ``residual`` (largest |Eq. (1)| over the
    legs), ``measure`` (:meth:`SphericalMechanism.parallel_measure`), ``steps``: proven steps from
    the previous row."""

    row: int
    inputs: tuple
    rotation: np.ndarray = field(repr=False)
    passive: np.ndarray = field(repr=False)
    residual: float
    measure: float
    steps: int


@dataclass(frozen=True)
class SingularStop:
    """Where a track ended before the end of the path: between rows ``row`` and ``row + 1``.

    ``fraction``: how far along that segment the last proven pose is (0..1); ``last_inputs``: its
    inputs; ``singular_inputs``: the singular input located by bisection (the branch exists up to
    it), with ``distance`` = largest |last_inputs - singular_inputs| (radians) and ``bracket`` the
    width of the final bisection interval; ``measure``: the parallel measure at the last proven pose.
    """

    row: int
    fraction: float
    last_inputs: tuple
    singular_inputs: tuple
    distance: float
    bracket: float
    measure: float
    reason: str


@dataclass(frozen=True)
class Track:
    """A tracked path: ``poses`` (one per path row reached, in order), ``stop`` (None when the whole
    path was tracked), ``names`` (the passive joints), ``steps`` proven and ``rejected`` steps."""

    names: tuple
    poses: tuple
    stop: SingularStop | None
    steps: int
    rejected: int

    @property
    def complete(self) -> bool:
        return self.stop is None


def cayley(w) -> np.ndarray:
    """C(w) (3, 3): the rotation by 2 atan(|w|/2) about w (module doc)."""
    w = np.asarray(w, dtype=float)
    n = float(w @ w)
    k = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    return np.eye(3) + (4.0 / (4.0 + n)) * (k + 0.5 * (k @ k))


class LegEquations:
    """h(w, beta) and its Jacobian for the three legs (module doc), in floats and in intervals."""

    def __init__(self, legs):
        self.legs = legs
        self.ref = np.array([leg.reference[0] for leg in legs])
        c1 = np.array([float(leg.a1 @ leg.a2) for leg in legs])
        self.perp = np.array([leg.a2 - c * leg.a1 for leg, c in zip(legs, c1)])     # (3 legs, 3)
        self.side = np.array([np.cross(leg.a1, leg.a2) for leg in legs])
        self.axial = np.array([c * leg.a1 for leg, c in zip(legs, c1)])
        self.b = np.array([leg.a3 for leg in legs])
        self.c = np.array([float(leg.a2 @ leg.a3) for leg in legs])

    # ---------------------------------------------------------------- floats

    def elbow(self, beta) -> np.ndarray:
        """e_i(beta_i) (3 legs, 3)."""
        d = np.asarray(beta, dtype=float) - self.ref
        return np.cos(d)[:, None] * self.perp + np.sin(d)[:, None] * self.side + self.axial

    def elbow_rate(self, beta) -> np.ndarray:
        """d e_i / d beta_i (3 legs, 3)."""
        d = np.asarray(beta, dtype=float) - self.ref
        return -np.sin(d)[:, None] * self.perp + np.cos(d)[:, None] * self.side

    def values(self, dc, w, beta) -> tuple[np.ndarray, np.ndarray]:
        """(h (3,), J = dh/dw (3, 3)) at w near the displacement ``dc`` and inputs ``beta``."""
        a = self.elbow(beta) @ dc                     # rows a_i = D_c^T e_i
        w = np.asarray(w, dtype=float)
        n = float(w @ w)
        ab = np.einsum("ij,ij->i", a, self.b)
        bxa = np.cross(self.b, a)
        aw, bw = a @ w, self.b @ w
        h = (1 - n / 4) * ab + bxa @ w + 0.5 * aw * bw - self.c * (1 + n / 4)
        jac = (-0.5 * ab[:, None] * w[None, :] + bxa + 0.5 * (aw[:, None] * self.b + bw[:, None] * a)
               - 0.5 * self.c[:, None] * w[None, :])
        return h, jac

    def residual(self, d, beta) -> np.ndarray:
        """Eq. (1) at the displacement D: e_i . (D a3_i) - c_i per leg."""
        return np.einsum("ij,ij->i", self.elbow(beta), (d @ self.b.T).T) - self.c

    # ---------------------------------------------------------------- intervals

    def enclose(self, dc, w_box, beta_box, rate: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Interval enclosures (2, 3) of h and (2, 3, 3) of J over the box ``w_box`` (2, 3) for every
        beta in ``beta_box`` (2, 3 legs), outward-rounded (module doc). With ``rate``: of dh_i/dbeta_i
        and its w-Jacobian instead (a replaced by D_c^T e_i'(beta), no constant term)."""
        cos_d, sin_d = iv.cos_sin(iv.sub(beta_box, iv.point(self.ref)))
        if rate:      # e' = -sin d perp + cos d side
            e = iv.add(iv.scale(-self.perp, sin_d[:, :, None]), iv.scale(self.side, cos_d[:, :, None]))
            c = np.zeros(3)
        else:         # e = cos d perp + sin d side + c1 a1
            e = iv.add(iv.add(iv.scale(self.perp, cos_d[:, :, None]), iv.scale(self.side, sin_d[:, :, None])),
                       iv.point(self.axial))                              # (2, 3 legs, 3)
            c = self.c
        a = iv.matmul(e, iv.point(dc))                                    # rows D_c^T e_i
        b = self.b
        ab = iv.isum(iv.scale(b, a), -1)                                  # (2, 3)
        bxa = _cross_float_interval(b, a)                                 # (2, 3, 3)
        w = w_box[:, None, :]                                             # (2, 1, 3)
        n = iv.isum(iv.mul(w, w), -1)                                     # (2, 1) |w|^2 (loose: a product, not a square)
        aw = iv.isum(iv.mul(a, w), -1)                                    # (2, 3)
        bw = iv.isum(iv.scale(b, w), -1)                                  # (2, 3)
        quarter = iv.scale(0.25, n)
        one_minus = iv.sub(iv.point(1.0), quarter)
        one_plus = iv.add(iv.point(1.0), quarter)
        h = iv.add(iv.add(iv.mul(one_minus, ab), iv.isum(iv.mul(bxa, w), -1)), iv.scale(0.5, iv.mul(aw, bw)))
        h = iv.sub(h, iv.scale(c, one_plus))
        jac = iv.add(iv.scale(-0.5, iv.mul(ab[:, :, None], w)), bxa)
        jac = iv.add(jac, iv.scale(0.5, iv.add(iv.scale(b, aw[:, :, None]), iv.mul(bw[:, :, None], a))))
        jac = iv.sub(jac, iv.scale(0.5 * c[:, None], iv.mul(iv.point(np.ones((3, 1))), w)))
        return h, jac


def _cross_float_interval(b: np.ndarray, a: np.ndarray) -> np.ndarray:
    """b x a for float rows b (3, 3) and interval rows a (2, 3, 3), outward-rounded."""
    comps = []
    for i, j, k in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        comps.append(iv.sub(iv.scale(b[:, j], a[:, :, k]), iv.scale(b[:, k], a[:, :, j])))
    return np.stack(comps, axis=-1)


#: The inputs of a step are beta_mid + sigma delta, sigma in [-SIGMA, SIGMA]: 1 + 1e-12 so that
#: the float ends beta0, beta1 are inside whatever the rounding of beta_mid and delta (~1e-16).
SIGMA = 1.0 + 1e-12


def krawczyk_step(eqs: LegEquations, dc, w_lo, w_hi, beta0, beta1) -> bool:
    """Whether the Krawczyk operator maps the box [w_lo, w_hi] into its interior for every input on
    the segment from beta0 to beta1 (then each has exactly one root in the box; module doc).

    The segment is beta(sigma) = beta_mid + sigma delta; h(m, beta(sigma)) is enclosed in the
    mean-value form h(m, beta_mid) + (dh/dbeta (m, B) delta) sigma with one sigma shared by the
    three legs, so that Y h keeps the legs' correlation (a box of beta per leg would not: the roots
    over a box of inputs fill a parallelepiped far wider than the curve of the segment's roots).
    """
    m = 0.5 * (w_lo + w_hi)
    beta_mid = 0.5 * (beta0 + beta1)
    delta = 0.5 * (beta1 - beta0)
    _, j_mid = eqs.values(dc, m, beta_mid)
    try:
        y = np.linalg.inv(j_mid)
    except np.linalg.LinAlgError:
        return False
    if not np.all(np.isfinite(y)):
        return False
    spread = SIGMA * np.abs(delta)
    beta_box = iv.from_bounds(beta_mid - spread, beta_mid + spread)
    beta_box = iv.outward(beta_box)
    point_m = iv.point(m)
    h_m, _ = eqs.enclose(dc, point_m, iv.point(beta_mid))
    rate, _ = eqs.enclose(dc, point_m, beta_box, rate=True)              # dh_i/dbeta_i at m over the segment
    _, j_box = eqs.enclose(dc, iv.from_bounds(w_lo, w_hi), beta_box)
    y_h = iv.fmatmul(y, h_m[:, :, None])[:, :, 0]
    y_rate = iv.fmatmul(y, iv.scale(delta, rate)[:, :, None])[:, :, 0]   # Y dh/dsigma
    sigma = iv.from_bounds(np.array([-SIGMA]), np.array([SIGMA]))
    center = iv.sub(iv.sub(point_m, y_h), iv.mul(y_rate, sigma))
    slope = iv.sub(iv.point(np.eye(3)), iv.fmatmul(y, j_box))
    dev = iv.sub(iv.from_bounds(w_lo, w_hi), point_m)
    k = iv.add(center, iv.matmul(slope, dev[:, :, None])[:, :, 0])
    return bool(np.all(np.isfinite(k)) and np.all(k[0] > w_lo) and np.all(k[1] < w_hi))


def _newton(eqs: LegEquations, dc, w, beta):
    """(w, converged): Newton on h(., beta) = 0 from w."""
    w = np.array(w, dtype=float)
    for _ in range(NEWTON_ITERATIONS):
        h, jac = eqs.values(dc, w, beta)
        try:
            dw = np.linalg.solve(jac, h)
        except np.linalg.LinAlgError:
            return w, False
        w = w - dw
        if not np.all(np.isfinite(w)):
            return w, False
        if np.abs(dw).max() <= NEWTON_TOL * max(1.0, np.abs(w).max()):
            return w, True
    h, _ = eqs.values(dc, w, beta)
    return w, bool(np.abs(h).max() < 1e-13)


def _tangent(eqs: LegEquations, dc, beta, dbeta) -> np.ndarray | None:
    """dw for an input change dbeta at w = 0 (first order): -J^-1 (dh/dbeta) dbeta."""
    _, jac = eqs.values(dc, np.zeros(3), beta)
    rate = np.einsum("ij,ij->i", eqs.elbow_rate(beta) @ dc, eqs.b) * np.asarray(dbeta)
    try:
        return -np.linalg.solve(jac, rate)
    except np.linalg.LinAlgError:
        return None


def _prove_step(eqs: LegEquations, dc, beta0, beta1):
    """The root w1 at beta1 continuing w = 0 at beta0, proven (module doc), or None."""
    guess = _tangent(eqs, dc, beta0, beta1 - beta0)
    if guess is None:
        return None
    w1, ok = _newton(eqs, dc, guess, beta1)
    if not ok:
        return None
    pad = MARGIN_RELATIVE * float(np.abs(w1).max()) + MARGIN
    lo, hi = np.minimum(0.0, w1) - pad, np.maximum(0.0, w1) + pad
    if not krawczyk_step(eqs, dc, lo, hi, beta0, beta1):
        return None
    if not krawczyk_step(eqs, dc, w1 - POINT_RADIUS, w1 + POINT_RADIUS, beta1, beta1):
        return None
    return w1


def _branch_exists(eqs: LegEquations, dc, beta0, beta, sign: float) -> bool:
    """Newton from the last proven pose converges at ``beta`` to a root where det J keeps its sign."""
    guess = _tangent(eqs, dc, beta0, beta - beta0)
    if guess is None:
        return False
    w, ok = _newton(eqs, dc, guess, beta)
    if not ok:
        return False
    _, jac = eqs.values(dc, w, beta)
    return bool(np.sign(np.linalg.det(jac)) == sign)


def _locate(eqs: LegEquations, dc, beta0, direction, lo: float, hi: float) -> tuple[float, float]:
    """Bisection on t in [lo, hi] (inputs beta0 + t direction) for the end of the branch: the
    largest t where it exists (see :func:`_branch_exists`), to LOCATE_TOL in input units."""
    _, jac = eqs.values(dc, np.zeros(3), beta0)
    sign = float(np.sign(np.linalg.det(jac)))
    scale = float(np.abs(direction).max())
    while (hi - lo) * scale > LOCATE_TOL:
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        if _branch_exists(eqs, dc, beta0, beta0 + mid * direction, sign):
            lo = mid
        else:
            hi = mid
    return lo, hi


def track(mechanism, path, start_rotation, *, start_tol: float = 1e-6) -> Track:
    """Follow the assembly at pose ``start_rotation`` (R, 3x3) along ``path`` (K, 3 inputs, radians).

    ``mechanism``: one the platform formulation applies to (three R-R-R legs, base joints
    actuated; ValueError otherwise). The start pose must close the legs at path[0] to ``start_tol``
    (largest |Eq. (1)|); it is polished by Newton and proven (a point Krawczyk test) first.
    """
    legs = platform_legs(mechanism)
    eqs = LegEquations(legs)
    path = np.asarray(path, dtype=float)
    if path.ndim != 2 or path.shape[1] != len(legs) or not len(path):
        raise ValueError(f"path: expected an array of shape (K, {len(legs)}), got shape {path.shape}")
    if not np.all(np.isfinite(path)):
        raise ValueError("path: expected finite inputs (radians)")
    ref = np.array(mechanism.platform_reference_matrix, dtype=float)
    dc = np.asarray(start_rotation, dtype=float) @ ref.T
    res0 = float(np.abs(eqs.residual(dc, path[0])).max())
    if res0 > start_tol:
        raise ValueError(f"start: the start pose does not close the legs at the first input of the path "
                         f"(largest residual {res0:.3g} > {start_tol:g}); give the pose of an assembly at "
                         f"{path[0].tolist()}")
    w0, ok = _newton(eqs, dc, np.zeros(3), path[0])
    if not ok or not krawczyk_step(eqs, dc, w0 - POINT_RADIUS, w0 + POINT_RADIUS, path[0], path[0]):
        raise ValueError("start: the start pose could not be proven an isolated assembly at the first input "
                         "(it is at or next to a parallel singularity)")
    dc = dc @ cayley(w0)
    names = tuple(mechanism.loop_unknowns)
    order = [passive_names(legs).index(n) for n in names]
    actuated = tuple(mechanism.actuated)

    def pose(row: int, d: np.ndarray, steps: int) -> TrackedPose:
        rot = d @ ref
        x = path[row]
        passive = passive_readings_many(legs, x, rot[None], ref)[0, order]
        joints = {**dict(zip(actuated, x.tolist())), **dict(zip(names, passive.tolist()))}
        return TrackedPose(row, tuple(float(v) for v in x), rot, passive, float(np.abs(eqs.residual(d, x)).max()),
                           mechanism.parallel_measure(joints), steps)

    poses = [pose(0, dc, 0)]
    n_steps = rejected = 0
    budget = MAX_STEPS + STEPS_PER_INPUT * len(path)
    for row in range(len(path) - 1):
        x0, x1 = path[row], path[row + 1]
        direction = x1 - x0
        span = float(np.abs(direction).max())
        s, h = 0.0, 1.0 if span <= FIRST_STEP else FIRST_STEP / span
        steps_here = 0
        while s < 1.0:
            if n_steps + rejected > budget:
                raise RuntimeError(f"track: more than {budget} steps (MAX_STEPS) on a path of {len(path)} inputs")
            t = min(1.0, s + h)
            b0, b1 = x0 + s * direction, (x1 if t == 1.0 else x0 + t * direction)
            w1 = _prove_step(eqs, dc, b0, b1)
            if w1 is not None:
                dc = dc @ cayley(w1)
                s, h = t, h * STEP_GROWTH
                n_steps += 1
                steps_here += 1
                continue
            rejected += 1
            h *= 0.5
            if h * span < MIN_STEP:
                lo, hi = _locate(eqs, dc, b0, direction, 0.0, 1.0 - s)
                last = poses[-1]
                here = x0 + s * direction
                rot = dc @ ref
                passive = passive_readings_many(legs, here, rot[None], ref)[0, order]
                joints = {**dict(zip(actuated, here.tolist())), **dict(zip(names, passive.tolist()))}
                singular = b0 + 0.5 * (lo + hi) * direction
                stop = SingularStop(row, float(s), tuple(float(v) for v in here), tuple(float(v) for v in singular),
                                    float(np.abs(singular - here).max()), float((hi - lo) * span),
                                    mechanism.parallel_measure(joints),
                                    "no step longer than MIN_STEP could be proven: the assembly mode meets another "
                                    "(a parallel singularity) and ends")
                del last
                return Track(names, tuple(poses), stop, n_steps, rejected)
        poses.append(pose(row + 1, dc, steps_here))
    return Track(names, tuple(poses), None, n_steps, rejected)
