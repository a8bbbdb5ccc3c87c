"""Certified tracking of one assembly mode along a path of actuator inputs (an addition to the paper).

The equations are those of the platform system (:mod:`spherekin.systems.platform`, Eq. (1) of each
R-R-R leg, its constants :class:`~spherekin.systems.platform.LegConstants` read from there): e_i(beta_i) . (D a3_i) = a2_i . a3_i, with D = R R_ref^T the platform's
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
accuracy, the next step's box contains that one, and the chain of proofs is unbroken.

In arrays: up to BATCH rows are predicted at once (:func:`_predict_rows`: Newton on every row within
PREDICT_REACH of a block's first pose in one call), and every step between consecutive rows is proven
in one call (:func:`_certify_steps`); the margin of W (MARGIN_RELATIVE) lets 0.01-rad rows pass as
they are. The segments whose step is not proven are walked together (:func:`spherekin.trust.stepping.walk`): each
round proves the next step of every walk in one call, a failed step halved, a proven one followed by
one STEP_GROWTH times longer; a walk's end must agree with its row's predicted pose (AGREE_TOL) for
the batch's later steps, proven from that pose, to follow on, else the batch ends at that row.

Near a parallel singularity (a fold, where the assembly mode meets another and ends) the Jacobian
tends to a singular matrix and the provable steps shrink geometrically. When a step below
MIN_STEP (radians of input) cannot be proven, the tracker stops and reports where: the last proven
input, and the singular input located by bisection on the step (Newton from the last proven pose
converging to a root with the Jacobian's determinant of the same sign: the branch exists), to
LOCATE_TOL. Nothing beyond the last proven input is reported as a pose.

Joint ranges: the test a solve uses (:func:`spherekin.core.angles.in_range`, closed ranges read
modulo 2 pi with RANGE_TOL) holds on every joint, actuated and passive, over every proven step, not
only at its ends: each joint's angle is enclosed over the step (its input segment and its box W) in
interval arithmetic (:meth:`JointRanges.steps_inside`), and a step not proven inside is walked again
in halves, each proven, until every part is proven inside or one ends outside. The track ends at the
first pose outside (a :class:`RangeStop`): the crossing is located by bisection on the proven part,
to LOCATE_TOL in input, and no row beyond it is reported.

The parallel measure of each pose is the mechanism's (:meth:`spherekin.mechanism.SphericalMechanism.parallel_measure`:
sigma_min / sigma_max of the passive-joint Jacobian K_p), the one batch and map report.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core import intervals as iv
from ..core.krawczyk import INTERVALS, krawczyk_operator
from ..core.angles import in_range_many, span_in_range_many
from ..core.orientation import QUATERNION_COLUMNS, ROTATION_COLUMNS, quaternions_from_rotations
from ..systems.platform import (leg_constants, passive_reading_enclosures, not_applicable, passive_names, passive_readings_many,
                                platform_legs)
from .stepping import MAX_STEPS, MIN_STEP, STEPS_PER_INPUT, walk

__all__ = ["POINT_RADIUS", "LOCATE_TOL", "MARGIN", "NEWTON_TOL", "TrackedPose",
           "SingularStop", "RangeStop", "Track", "JointRanges", "LegEquations", "cayley", "cayley_coordinates",
           "krawczyk_step", "krawczyk_steps", "krawczyk_input_boxes", "predict_many", "parametric_krawczyk", "track",
           "not_tracked"]

#: Radius of the box around each accepted root that a point Krawczyk test proves (in w, ~radians).
#: Reason: Newton's roots are accurate to ~1e-15; 1e-10 leaves room for the rounding of the
#: change of coordinates D_c -> D_c C(w1) and is still far below any tolerance of a pose.
POINT_RADIUS = 1e-10
#: The step box W = hull(0, w1) is widened on each side by MARGIN_RELATIVE |w1| + MARGIN. Reason:
#: the box must hold the previous root's proven box (POINT_RADIUS) with room (10 POINT_RADIUS), and
#: the Krawczyk image needs slack inside W: it is hull(0, w1) (the segment's roots) plus terms
#: ~ c |W|^2, so with |W| = (1 + 2 r) |w1| a margin r |w1| passes while |w1| < r / (c (1 + 2 r)^2),
#: largest at r = 1/2 (4x the steps that 5% passes: 0.01-rad rows of general_3rrr pass first time,
#: none did at 5%). The joint ranges are tested on the Krawczyk image, not on W (_certify_steps).
MARGIN = 10 * POINT_RADIUS
MARGIN_RELATIVE = 0.5
#: Width (radians of input) to which the bisection locates the singular input where a track stops.
LOCATE_TOL = 1e-12
#: Newton on h(w, beta) = 0: stop after a step below this (|w| ~ radians). Reason: convergence is
#: quadratic, so after a step of 1e-9 the error is ~1e-18 (times a constant of order 1-10 away from
#: a singularity): far below POINT_RADIUS, which the point Krawczyk test then proves anyway ...
NEWTON_TOL = 1e-9
#: ... or after this many iterations (quadratic convergence from the predictor needs ~4).
NEWTON_ITERATIONS = 12
#: A proven step is followed by one this many times longer (a rejected one by one half as long):
#: the batched steps here are cheap, so the walk reaches long steps fast.
STEP_GROWTH = 1.5


def _named(names, values) -> dict:
    """{name: float} of ``values`` in the order of ``names`` (radians)."""
    return {n: float(v) for n, v in zip(names, values)}


@dataclass(frozen=True)
class TrackedPose:
    """The tracked assembly at path row ``row`` (0-based, the row of the path's CSV or array).

    ``inputs``: the actuated joints' angles by name (radians); ``platform_rotation``: R (3, 3),
    v_i = R v_i^0 (None for a mechanism without an output link); ``passive_angles``: by name (radians, in ``Track.passive_joints`` order);
    ``residual``: the largest |Eq. (1)| over the legs (on the loop equations,
    :mod:`spherekin.trust.loop_continuation`: the largest entry of |F_n - I|); ``parallel_measure``: sigma_min / sigma_max
    of the passive-joint Jacobian (:meth:`spherekin.mechanism.SphericalMechanism.parallel_measure`,
    0 at a parallel singularity); ``proven_steps``: proven steps from the previous row. The
    attribute names are the keys of :meth:`as_dict` (the JSON of ``spherekin track``).
    """

    row: int
    inputs: dict
    platform_rotation: np.ndarray | None = field(repr=False)
    passive_angles: dict = field(repr=False)
    residual: float
    parallel_measure: float
    proven_steps: int
    #: Under the mechanism's tolerances (issue 45), what they do to this pose
    #: (:func:`spherekin.trust.tolerances.analyse_pose`); None without tolerances.
    tolerances: object = field(default=None, repr=False)

    def as_dict(self) -> dict:
        return {"row": self.row, "inputs": dict(self.inputs),
                "platform_rotation": (None if self.platform_rotation is None
                                      else np.asarray(self.platform_rotation, dtype=float).tolist()),
                "passive_angles": dict(self.passive_angles), "residual": self.residual,
                "parallel_measure": self.parallel_measure, "proven_steps": self.proven_steps,
                "tolerances": None if self.tolerances is None else self.tolerances.as_dict()}


@dataclass(frozen=True)
class SingularStop:
    """Where a track ended at a parallel singularity: between rows ``between_rows`` = (r, r + 1).

    ``fraction``: how far along that segment the last proven pose is (0..1); ``last_proven_inputs``:
    its inputs by name (radians); ``singular_inputs``: the singular input located by bisection (the
    branch exists up to it), with ``distance`` = largest |last_proven_inputs - singular_inputs|
    (radians) and ``bracket`` the width of the final bisection interval (radians);
    ``parallel_measure``: at the last proven pose. Names = the keys of :meth:`as_dict`.
    """

    between_rows: tuple
    fraction: float
    last_proven_inputs: dict
    singular_inputs: dict
    distance: float
    bracket: float
    parallel_measure: float
    reason: str
    kind: str = "singular"

    def as_dict(self) -> dict:
        return {"kind": self.kind, "between_rows": list(self.between_rows), "fraction": self.fraction,
                "last_proven_inputs": dict(self.last_proven_inputs), "singular_inputs": dict(self.singular_inputs),
                "distance": self.distance, "bracket": self.bracket, "parallel_measure": self.parallel_measure,
                "reason": self.reason}


@dataclass(frozen=True)
class RangeStop:
    """Where a track ended because joint ``joint`` left its range ``joint_range`` (lo, hi; radians,
    closed, read modulo 2 pi as a solve reads it): between rows ``between_rows`` = (r, r + 1).

    ``last_proven_inputs``: the last input (by name, radians) of the proven track where every joint
    is in its range, ``fraction`` of the way along the segment; ``exit_inputs``: the first input
    found with ``joint`` outside, ``bracket`` (radians of input, at most LOCATE_TOL) further;
    ``joint_angle``: the joint's angle at the last proven input (radians, next to a range end);
    ``parallel_measure``: there. Names = the keys of :meth:`as_dict`.
    """

    between_rows: tuple
    fraction: float
    joint: str
    joint_range: tuple
    joint_angle: float
    last_proven_inputs: dict
    exit_inputs: dict
    bracket: float
    parallel_measure: float
    reason: str
    kind: str = "range"

    def as_dict(self) -> dict:
        return {"kind": self.kind, "between_rows": list(self.between_rows), "fraction": self.fraction,
                "joint": self.joint, "joint_range": [float(v) for v in self.joint_range],
                "joint_angle": self.joint_angle, "last_proven_inputs": dict(self.last_proven_inputs),
                "exit_inputs": dict(self.exit_inputs), "bracket": self.bracket,
                "parallel_measure": self.parallel_measure, "reason": self.reason}


#: The version of :meth:`Track.as_dict` (the JSON of ``spherekin track``; docs/results-format.md).
#: 2: Python's attribute names everywhere ("poses", "proven_steps", "rejected_steps", "parallel_measure"),
#: the stop's "kind" and the range stop. 3: each pose's "tolerances" (issue 45; null without them).
TRACK_SCHEMA = "spherekin.track/3"


@dataclass(frozen=True)
class Track:
    """A tracked path: ``poses`` (one :class:`TrackedPose` per path row reached, in order), ``stop``
    (None when the whole path was tracked, else a :class:`SingularStop` or :class:`RangeStop`),
    ``mechanism`` (its name), ``actuated`` and ``passive_joints`` (names), ``path_rows`` (rows of
    the path given), ``proven_steps`` and ``rejected_steps`` (every step tried: those of the
    segment where the track stopped included). Names = the keys of :meth:`as_dict`."""

    mechanism: str | None
    actuated: tuple
    passive_joints: tuple
    path_rows: int
    poses: tuple = field(repr=False)
    stop: SingularStop | RangeStop | None
    proven_steps: int
    rejected_steps: int

    @property
    def complete(self) -> bool:
        return self.stop is None

    @property
    def rotations(self) -> np.ndarray:
        """Every pose's platform rotation, shape (K, 3, 3); NaN where a pose has none (no output link)."""
        return np.array([np.full((3, 3), np.nan) if p.platform_rotation is None else p.platform_rotation
                         for p in self.poses], dtype=float).reshape(-1, 3, 3)

    def as_dict(self) -> dict:
        """JSON-ready (schema TRACK_SCHEMA): the attributes above, each pose and the stop by their ``as_dict``."""
        from .. import __version__

        return {"schema": TRACK_SCHEMA, "spherekin_version": __version__, "mechanism": self.mechanism,
                "actuated": list(self.actuated), "passive_joints": list(self.passive_joints),
                "path_rows": self.path_rows, "complete": self.complete, "proven_steps": self.proven_steps,
                "rejected_steps": self.rejected_steps, "poses": [p.as_dict() for p in self.poses],
                "stop": None if self.stop is None else self.stop.as_dict()}

    def frame(self):
        """A pandas DataFrame, one row per pose: ``row``, the inputs and passive angles by joint name
        (radians), the platform rotation as ``qw qx qy qz`` and ``r11 ... r33`` (the columns of
        batch's table; NaN without an output link), ``residual``, ``parallel_measure``, ``proven_steps``."""
        import pandas as pd

        names = [*self.actuated, *self.passive_joints]
        rots = self.rotations
        quats = quaternions_from_rotations(rots) if len(rots) else np.empty((0, 4))
        data = {"row": np.array([p.row for p in self.poses], dtype=np.int64)}
        data.update({n: np.array([{**p.inputs, **p.passive_angles}[n] for p in self.poses], dtype=float)
                     for n in names})
        data.update({c: quats[:, j] for j, c in enumerate(QUATERNION_COLUMNS)})
        data.update({c: rots.reshape(-1, 9)[:, j] for j, c in enumerate(ROTATION_COLUMNS)})
        for key in ("residual", "parallel_measure"):
            data[key] = np.array([getattr(p, key) for p in self.poses], dtype=float)
        data["proven_steps"] = np.array([p.proven_steps for p in self.poses], dtype=np.int64)
        return pd.DataFrame(data)

    def __repr__(self) -> str:
        def at(p):
            return f"row {p.row} ({', '.join(f'{v:.4g}' for v in p.inputs.values())})"

        head = (f"Track({self.mechanism or 'mechanism'}: {len(self.poses)} of {self.path_rows} rows, "
                f"{self.proven_steps} proven steps ({self.rejected_steps} rejected)")
        if self.poses:
            head += f"; {at(self.poses[0])}" + (f" to {at(self.poses[-1])}" if len(self.poses) > 1 else "")
        if self.stop is None:
            return head + "; complete)"
        what = "a parallel singularity" if self.stop.kind == "singular" else f"{self.stop.joint} leaves its range"
        return head + f"; stopped between rows {self.stop.between_rows[0]} and {self.stop.between_rows[1]}: {what})"


def cayley(w) -> np.ndarray:
    """C(w) (..., 3, 3): the rotation by 2 atan(|w|/2) about w (module doc), for w (..., 3)."""
    w = np.asarray(w, dtype=float)
    n = (w * w).sum(axis=-1)[..., None, None]
    zero = np.zeros(w.shape[:-1])
    k = np.stack([np.stack([zero, -w[..., 2], w[..., 1]], -1), np.stack([w[..., 2], zero, -w[..., 0]], -1),
                  np.stack([-w[..., 1], w[..., 0], zero], -1)], -2)
    return np.eye(3) + (4.0 / (4.0 + n)) * (k + 0.5 * (k @ k))


class LegEquations:
    """h(w, beta) and its Jacobian for the three legs (module doc), in floats and in intervals."""

    def __init__(self, legs):
        self.legs = legs
        self.constants = k = leg_constants(legs)            # Eq. (1)'s constants, from the platform system
        self.ref, self.perp, self.side, self.axial, self.b, self.c = k.ref, k.perp, k.side, k.axial, k.b, k.c
        # [b_i]x: b_i x v = b_cross[i] @ v
        self.b_cross = np.array([[[0.0, -b[2], b[1]], [b[2], 0.0, -b[0]], [-b[1], b[0], 0.0]] for b in self.b])

    # ---------------------------------------------------------------- floats

    def elbow(self, beta) -> np.ndarray:
        """e_i(beta_i) (..., 3 legs, 3) for inputs beta (..., 3)."""
        return self.constants.elbow(beta)

    def elbow_rate(self, beta) -> np.ndarray:
        """d e_i / d beta_i (..., 3 legs, 3)."""
        return self.constants.elbow_rate(beta)

    def values(self, dc, w, beta) -> tuple[np.ndarray, np.ndarray]:
        """(h (..., 3), J = dh/dw (..., 3, 3)) at w (..., 3) near the displacements ``dc`` (..., 3, 3)
        and inputs ``beta`` (..., 3); leading axes broadcast (one step, or many at once)."""
        a = self.elbow(beta) @ dc                     # rows a_i = D_c^T e_i
        w = np.asarray(w, dtype=float)
        wc = w[..., None]
        n = (w * w).sum(axis=-1)[..., None]
        ab = (a * self.b).sum(axis=-1)
        bxa = np.einsum("ijk,...ik->...ij", self.b_cross, a)           # rows b_i x a_i
        aw = (a @ wc)[..., 0]
        bw = w @ self.b.T
        h = (1 - n / 4) * ab + (bxa @ wc)[..., 0] + 0.5 * aw * bw - self.c * (1 + n / 4)
        wi = w[..., None, :]
        jac = (-0.5 * ab[..., None] * wi + bxa + 0.5 * (aw[..., None] * self.b + bw[..., None] * a)
               - 0.5 * self.c[:, None] * wi)
        return h, jac

    def residual(self, d, beta) -> np.ndarray:
        """Eq. (1) at the displacements D (..., 3, 3): e_i . (D a3_i) - c_i per leg (..., 3)."""
        return self.constants.residual(d, beta)

    # ---------------------------------------------------------------- intervals

    def enclose(self, dc, w_box, beta_box, rate: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Interval enclosures (2, ..., 3) of h and (2, ..., 3, 3) of J over the boxes ``w_box``
        (2, ..., 3) for every beta in ``beta_box`` (2, ..., 3 legs), with displacements ``dc``
        (..., 3, 3); outward-rounded (module doc). With ``rate``: of dh_i/dbeta_i and its w-Jacobian
        instead (a replaced by D_c^T e_i'(beta), no constant term)."""
        cos_d, sin_d = iv.cos_sin(iv.sub(beta_box, iv.point(self.ref)))
        if rate:      # e' = -sin d perp + cos d side
            e = iv.add(iv.scale(-self.perp, sin_d[..., None]), iv.scale(self.side, cos_d[..., None]))
            c = np.zeros(3)
        else:         # e = cos d perp + sin d side + c1 a1
            e = iv.add(iv.add(iv.scale(self.perp, cos_d[..., None]), iv.scale(self.side, sin_d[..., None])),
                       iv.point(self.axial))                              # (2, ..., 3 legs, 3)
            c = self.c
        a = iv.matmul(e, iv.point(np.broadcast_to(dc, e.shape[1:])))     # rows D_c^T e_i
        b = self.b
        ab = iv.isum(iv.scale(b, a), -1)                                  # (2, ..., 3)
        bxa = _cross_float_interval(b, a)                                 # (2, ..., 3, 3)
        w = w_box[..., None, :]                                           # (2, ..., 1, 3)
        n = iv.isum(iv.mul(w, w), -1)                                     # (2, ..., 1) |w|^2 (loose: a product)
        aw = iv.isum(iv.mul(a, w), -1)                                    # (2, ..., 3)
        bw = iv.isum(iv.scale(b, w), -1)                                  # (2, ..., 3)
        quarter = iv.scale(0.25, n)
        one_minus = iv.sub(iv.point(np.ones(n.shape[1:])), quarter)
        one_plus = iv.add(iv.point(np.ones(n.shape[1:])), quarter)
        h = iv.add(iv.add(iv.mul(one_minus, ab), iv.isum(iv.mul(bxa, w), -1)), iv.scale(0.5, iv.mul(aw, bw)))
        h = iv.sub(h, iv.scale(c, one_plus))
        jac = iv.add(iv.scale(-0.5, iv.mul(ab[..., None], w)), bxa)
        jac = iv.add(jac, iv.scale(0.5, iv.add(iv.scale(b, aw[..., None]), iv.mul(bw[..., None], a))))
        jac = iv.sub(jac, iv.scale(0.5 * c[:, None], iv.mul(iv.point(np.ones(w.shape[1:-2] + (3, 1))), w)))
        return h, jac


def _cross_float_interval(b: np.ndarray, a: np.ndarray) -> np.ndarray:
    """b x a for float rows b (3, 3) and interval rows a (2, ..., 3, 3), outward-rounded."""
    comps = []
    for i, j, k in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        comps.append(iv.sub(iv.scale(b[:, j], a[..., k]), iv.scale(b[:, k], a[..., j])))
    return np.stack(comps, axis=-1)


#: The inputs of a step are beta1 + sigma delta, sigma in [-SIGMA, SIGMA - 1]: 1 + 1e-12 so that
#: beta0 is inside whatever the rounding of delta = beta1 - beta0 (~1e-16 relative).
SIGMA = 1.0 + 1e-12


def krawczyk_step(eqs: LegEquations, dc, w_lo, w_hi, beta0, beta1) -> bool:
    """Whether the Krawczyk operator maps the box [w_lo, w_hi] into its interior for every input on
    the segment from beta0 to beta1 (then each has exactly one root in the box; module doc). The
    one-step form of :func:`krawczyk_steps`."""
    return bool(krawczyk_steps(eqs, np.asarray(dc)[None], np.asarray(w_lo)[None], np.asarray(w_hi)[None],
                               np.asarray(beta0)[None], np.asarray(beta1)[None])[0])


def krawczyk_steps(eqs: LegEquations, dc, w_lo, w_hi, beta0, beta1) -> np.ndarray:
    """:func:`krawczyk_step` of N steps at once: displacements ``dc`` (N, 3, 3), boxes [w_lo, w_hi]
    (N, 3 each), segments beta0 -> beta1 (N, 3 each); a boolean per step (:func:`_krawczyk_images`)."""
    return _krawczyk_images(eqs, dc, w_lo, w_hi, beta0, beta1)[0]


def _krawczyk_images(eqs: LegEquations, dc, w_lo, w_hi, beta0, beta1) -> tuple[np.ndarray, np.ndarray]:
    """(proven (N,), K (2, N, 3)): :func:`krawczyk_steps` and the Krawczyk images K of the boxes.
    Where a step is proven, K lies inside [w_lo, w_hi] and holds the root of every input of the step
    (each root w* in the box is w* - Y h(w*, beta), which the mean-value form below encloses in K):
    a tighter enclosure of the roots than the box itself, the one the joint ranges are tested on.

    Each segment is beta(sigma) = beta1 + sigma delta, delta = beta1 - beta0, sigma in [-1, 0]
    (widened by SIGMA - 1 at both ends); h(m, beta(sigma)) is enclosed in the mean-value form
    h(m, beta1) + (dh/dbeta (m, B) delta) sigma with one sigma shared by the three legs, so that Y h
    keeps the legs' correlation (a box of beta per leg would not: the roots over a box of inputs fill
    a parallelepiped far wider than the curve of the segment's roots). Expanding about the end
    beta1 rather than the middle gives an enclosure of the same width and lets the point test at
    beta1, and the next step's, reuse the cos/sin enclosures of beta1 (cached).
    """
    w_lo, w_hi = np.asarray(w_lo, dtype=float), np.asarray(w_hi, dtype=float)
    beta0, beta1 = np.asarray(beta0, dtype=float), np.asarray(beta1, dtype=float)
    m = 0.5 * (w_lo + w_hi)
    delta = beta1 - beta0
    _, j_mid = eqs.values(dc, m, 0.5 * (beta0 + beta1))
    sigma = iv.from_bounds(np.array([-SIGMA]), np.array([SIGMA - 1.0]))
    spread = iv.scale(np.abs(delta), sigma.reshape(2, 1, 1))                 # |delta| [-SIGMA, SIGMA - 1]
    lo_b = np.minimum(iv.add(iv.point(beta1), spread)[0], iv.sub(iv.point(beta1), spread)[0])
    hi_b = np.maximum(iv.add(iv.point(beta1), spread)[1], iv.sub(iv.point(beta1), spread)[1])
    beta_box = iv.from_bounds(lo_b, hi_b)                                   # holds beta1 + sigma delta
    point_m = iv.point(m)
    h_m, _ = eqs.enclose(dc, point_m, iv.point(beta1))
    rate, _ = eqs.enclose(dc, point_m, beta_box, rate=True)              # dh_i/dbeta_i at m over the segment
    _, j_box = eqs.enclose(dc, iv.from_bounds(w_lo, w_hi), beta_box)
    return parametric_krawczyk(w_lo, w_hi, j_mid, h_m, iv.scale(delta, rate), j_box, sigma.reshape(2, 1, 1))


def krawczyk_input_boxes(eqs: LegEquations, dc, w_lo, w_hi, beta_lo, beta_hi) -> tuple[np.ndarray, np.ndarray]:
    """(proven (N,), K (2, N, 3)): the parametric Krawczyk operator over N *boxes* of inputs
    B = [beta_lo, beta_hi] (N, 3 each, radians; a fixed input: lo = hi), the boxes W = [w_lo, w_hi]
    (N, 3) of Cayley coordinates near the displacements ``dc`` (N, 3, 3):

        K = m - Y h(m, b_c) - (Y dh/dbeta(m, B)) (B - b_c) + (I - Y J(W, B)) (W - m),

    b_c the boxes' centres (:func:`parametric_krawczyk` with P = 3 parameters; dh/dbeta is diagonal,
    each leg driven by its own input). Proven: every input of B has exactly one root in W (inside K)
    and every Jacobian of J(W, B) is regular, so that assembly meets no parallel singularity over B
    (the free boxes of :mod:`spherekin.trust.free_box`)."""
    w_lo, w_hi = np.asarray(w_lo, dtype=float), np.asarray(w_hi, dtype=float)
    beta_lo, beta_hi = np.asarray(beta_lo, dtype=float), np.asarray(beta_hi, dtype=float)
    dc = np.asarray(dc, dtype=float)
    n = len(w_lo)
    if n == 0 or not iv.rounding_environment_ok():
        return np.zeros(n, dtype=bool), iv.from_bounds(w_lo, w_hi)       # a refusal, never a wrong verdict
    m = 0.5 * (w_lo + w_hi)
    b_c = np.clip(0.5 * (beta_lo + beta_hi), beta_lo, beta_hi)
    beta_box = iv.from_bounds(beta_lo, beta_hi)
    _, j_mid = eqs.values(dc, m, b_c)
    point_m = iv.point(m)
    h_m, _ = eqs.enclose(dc, point_m, iv.point(b_c))
    rate, _ = eqs.enclose(dc, point_m, beta_box, rate=True)                # dh_i/dbeta_i at m over B (2, N, 3)
    _, j_box = eqs.enclose(dc, iv.from_bounds(w_lo, w_hi), beta_box)
    diag = rate[..., :, None] * np.eye(3)                                   # dh/dbeta (2, N, 3, 3): exact zeros off it
    return parametric_krawczyk(w_lo, w_hi, j_mid, h_m, diag, j_box, iv.sub(beta_box, iv.point(b_c)))


def parametric_krawczyk(w_lo, w_hi, j_mid, f_m, rate, j_box, sigma) -> tuple[np.ndarray, np.ndarray]:
    """(proven (N,), K (2, N, M)): the parametric Krawczyk operator of both trackers (module doc) and
    of the free boxes (:func:`krawczyk_input_boxes`) on N boxes W = [w_lo, w_hi] (N, M) of the
    unknowns over boxes of P parameters p = p_c + sigma, sigma in ``sigma`` (intervals (2, N, P), or
    broadcasting to it):

        K = m - Y F(m, p_c) - (Y (dF/dp)(m, P)) sigma + (I - Y J(W, P)) (W - m),

    m the boxes' centres, Y = j_mid^-1 (floats: any Y is valid, a good one makes K small; none where
    j_mid (N, M, M) is singular or not finite: not proven). ``f_m`` (2, N, M) encloses F(m, p_c),
    ``rate`` (2, N, M, P) dF/dp at m over the parameter box (mean-value form), ``j_box``
    (2, N, M, M) the unknowns' Jacobian over W and the parameter box. A tracker's segment of inputs
    x(sigma) = x1 + sigma delta, sigma in [-1, 0], is one parameter (P = 1: ``rate`` (2, N, M) =
    J_x delta, one sigma for every row, so that Y keeps their correlation); a box of inputs B is
    P = the inputs, p_c its centre, sigma = B - p_c. Proven where K lies in the interior of W: each
    parameter of the box has exactly one root in W, it lies in K, and every J in J(W, P) is regular
    (Krawczyk/Moore)."""
    if rate.ndim == 3:                                                        # one parameter (a segment)
        rate = rate[..., None]
    mid = 0.5 * (w_lo + w_hi)
    ok = np.isfinite(j_mid).all(axis=(1, 2)) & (np.abs(np.linalg.det(j_mid)) > 0)
    y = np.zeros_like(j_mid)
    if ok.any():
        y[ok] = np.linalg.inv(j_mid[ok])
    ok &= np.isfinite(y).all(axis=(1, 2))
    dev = iv.sub(iv.from_bounds(w_lo, w_hi), iv.point(mid))
    k = krawczyk_operator(INTERVALS, mid, f_m, y, j_box, dev, rate=rate, sigma=sigma)
    inside = np.isfinite(k).all(axis=(0, 2)) & np.all(k[0] > w_lo, axis=1) & np.all(k[1] < w_hi, axis=1)
    return ok & inside, k


def _solve_many(jac, rhs) -> tuple[np.ndarray, np.ndarray]:
    """(x (N, 3), solved (N,)): J x = rhs for N systems J (N, 3, 3), rhs (N, 3); not solved (x = 0)
    where J is singular or anything is not finite."""
    det = np.linalg.det(jac)
    solved = np.isfinite(det) & (det != 0) & np.isfinite(rhs).all(axis=-1)
    x = np.zeros(rhs.shape)
    if solved.any():
        try:
            x[solved] = np.linalg.solve(jac[solved], rhs[solved][..., None])[..., 0]
        except np.linalg.LinAlgError:          # an exactly singular pivot det did not see: one at a time
            for i in np.flatnonzero(solved):
                try:
                    x[i] = np.linalg.solve(jac[i], rhs[i])
                except np.linalg.LinAlgError:
                    solved[i] = False
    return x, solved


def _newton_many(eqs: LegEquations, dc, w, beta) -> tuple[np.ndarray, np.ndarray]:
    """(w (N, 3), converged (N,)): Newton on h(., beta) = 0 from w for N systems at once
    (displacements ``dc`` (N, 3, 3), inputs ``beta`` (N, 3)); each stops after a step below
    NEWTON_TOL, or after NEWTON_ITERATIONS with |h| < 1e-13."""
    w = np.array(w, dtype=float)
    active = np.ones(len(w), dtype=bool)
    converged = np.zeros(len(w), dtype=bool)
    for _ in range(NEWTON_ITERATIONS):
        idx = np.flatnonzero(active)
        if not len(idx):
            return w, converged
        h, jac = eqs.values(dc[idx], w[idx], beta[idx])
        dw, solved = _solve_many(jac, h)
        new = w[idx] - dw
        finite = solved & np.isfinite(new).all(axis=-1)
        w[idx[finite]] = new[finite]
        done = finite & (np.abs(dw).max(axis=-1) <= NEWTON_TOL)
        converged[idx[done]] = True
        active[idx[~finite | done]] = False
    idx = np.flatnonzero(active)
    if len(idx):
        h, _ = eqs.values(dc[idx], w[idx], beta[idx])
        converged[idx] = np.abs(h).max(axis=-1) < 1e-13
    return w, converged


def _newton(eqs: LegEquations, dc, w, beta):
    """(w, converged): :func:`_newton_many` of one system."""
    w, ok = _newton_many(eqs, np.asarray(dc, dtype=float)[None], np.asarray(w, dtype=float)[None],
                         np.asarray(beta, dtype=float)[None])
    return w[0], bool(ok[0])


def _tangents(eqs: LegEquations, dc, beta, dbeta) -> tuple[np.ndarray, np.ndarray]:
    """(dw (N, 3), found (N,)): for input changes dbeta (N, 3) at w = 0 (first order, inputs beta
    (N, 3), displacements ``dc`` (N, 3, 3)): -J^-1 (dh/dbeta) dbeta."""
    _, jac = eqs.values(dc, np.zeros(np.shape(beta)), beta)
    rate = np.einsum("...ij,...ij->...i", eqs.elbow_rate(beta) @ dc, eqs.b) * np.asarray(dbeta)
    dw, found = _solve_many(jac, rate)
    return -dw, found


def _branch_exists(eqs: LegEquations, dc, beta0, beta, sign: float) -> bool:
    """Newton from the last proven pose converges at ``beta`` to a root where det J keeps its sign."""
    w = _predict(eqs, dc, beta0, beta)
    if w is None:
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


def predict_many(eqs: LegEquations, dc, beta0, beta1) -> tuple[np.ndarray, np.ndarray]:
    """(w (N, 3), found (N,)): Newton's roots at beta1 (N, 3) from the tangent predictor at w = 0
    (inputs beta0 (N, 3), displacements ``dc`` (N, 3, 3)); not found: no proof of anything."""
    beta0, beta1 = np.asarray(beta0, dtype=float), np.asarray(beta1, dtype=float)
    guess, found = _tangents(eqs, dc, beta0, beta1 - beta0)
    w, converged = _newton_many(eqs, dc, guess, beta1)
    return w, found & converged


def _predict(eqs: LegEquations, dc, beta0, beta1):
    """:func:`predict_many` of one step: w (3,), or None."""
    w, ok = predict_many(eqs, np.asarray(dc, dtype=float)[None], np.asarray(beta0, dtype=float)[None],
                          np.asarray(beta1, dtype=float)[None])
    return w[0] if ok[0] else None


def cayley_coordinates(q) -> np.ndarray:
    """w (..., 3) with C(w) = Q for rotations Q (..., 3, 3) (not a half turn): the inverse of
    :func:`cayley`, w = 2 vee(Q - Q^T) / (1 + trace Q)."""
    q = np.asarray(q, dtype=float)
    vee = np.stack([q[..., 2, 1] - q[..., 1, 2], q[..., 0, 2] - q[..., 2, 0], q[..., 1, 0] - q[..., 0, 1]], -1)
    return 2.0 * vee / (1.0 + np.trace(q, axis1=-2, axis2=-1))[..., None]


#: The rows predicted together from one pose (:func:`_predict_rows`) lie within this (largest input
#: change, radians) of its row. Reason: Newton from the tangent predictor converges to the same root
#: when the predictor's error (~ |input change|^2) is well inside the root's basin; 0.1 rad (FIRST_STEP,
#: the walk's first step) keeps that error ~0.01 for general_3rrr, and a wrong prediction costs time only
#: (its step is not proven and is walked; the poses agree or the prediction restarts there).
PREDICT_REACH = 0.1


def _predict_rows(eqs: LegEquations, d0, rows) -> tuple[np.ndarray, np.ndarray]:
    """(poses (m + 1, 3, 3), w (m, 3)): the displacements predicted at rows[0 .. m] (inputs
    (K, 3), radians) from ``d0`` at rows[0], and each step's Cayley coordinates (poses[j] C(w[j]) =
    poses[j + 1]); m < K - 1 where Newton fails first. In blocks: every row within PREDICT_REACH of a
    block's first row is predicted at once (:func:`predict_many` from that row's pose), the block's
    last pose starts the next block."""
    poses, steps = [np.asarray(d0, dtype=float)], []
    k = 0
    while k < len(rows) - 1:
        reach = np.abs(rows[k + 1:] - rows[k]).max(axis=1)
        end = k + 1 + max(1, int(np.argmax(reach > PREDICT_REACH)) if (reach > PREDICT_REACH).any() else len(reach))
        block = rows[k + 1:end]
        w, found = predict_many(eqs, np.broadcast_to(poses[-1], (len(block), 3, 3)),
                                 np.broadcast_to(rows[k], block.shape), block)
        good = len(block) if found.all() else int(np.argmin(found))
        if not good:
            break
        new = poses[-1] @ cayley(w[:good])
        before = np.concatenate([poses[-1][None], new[:-1]])
        steps.append(cayley_coordinates(np.swapaxes(before, -1, -2) @ new))
        poses.extend(new)
        if good < len(block):
            break
        k = end - 1
    return np.array(poses), (np.concatenate(steps) if steps else np.empty((0, 3)))


def _boxes(w1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The step boxes hull(0, w1) widened by the margin (module doc), for rows of w1 (N, 3)."""
    pad = MARGIN_RELATIVE * np.abs(w1).max(axis=-1, keepdims=True) + MARGIN
    return np.minimum(0.0, w1) - pad, np.maximum(0.0, w1) + pad


def _certify_steps(eqs: LegEquations, dcs, w1, beta0, beta1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(proven (N,), lo, hi (N, 3)): which of N predicted steps are proven (the step box over the
    segment, then the point box of radius POINT_RADIUS around the new root at beta1; module doc),
    and boxes holding the root of every input of each step: the Krawczyk image of the step box
    where proven (:func:`_krawczyk_images`), else the step box."""
    lo, hi = _boxes(w1)
    ok, k = _krawczyk_images(eqs, dcs, lo, hi, beta0, beta1)
    if ok.any():
        ok[ok] = krawczyk_steps(eqs, dcs[ok], w1[ok] - POINT_RADIUS, w1[ok] + POINT_RADIUS, beta1[ok], beta1[ok])
    return ok, np.where(ok[:, None], k[0], lo), np.where(ok[:, None], k[1], hi)


#: Segments predicted (Newton, in floats) and then certified together, at most. Reason: one batch of
#: interval arithmetic over many steps costs little more than over one (numpy's per-call overhead
#: dominates a 3 x 3 system); a prediction that goes wrong wastes at most this many steps' work.
BATCH = 256
#: A walked segment (its step not proven at once, :func:`spherekin.trust.stepping.walk`) ends at a displacement
#: that must agree with the one predicted for its row to this (largest entry) for the batch's later
#: steps, proven from the predicted one, to follow on. Reason: both are Newton's roots (~1e-15 apart
#: when they are the same root); the walk's last step proves the mode's root within POINT_RADIUS of
#: its end, so within ~2 POINT_RADIUS of the predicted one, inside the next step's box (its margin
#: is MARGIN = 10 POINT_RADIUS), which holds one root: the next step continues the mode. Else the
#: batch ends at that row and the prediction restarts from the walk's end.
AGREE_TOL = POINT_RADIUS


class JointRanges:
    """Every joint's angle at tracked poses and the range test of a solve (module doc): the actuated
    joints (the inputs) then the passive ones, names in ``names``."""

    def __init__(self, mechanism, legs):
        self.mechanism = mechanism
        self.legs = legs
        self.ref = np.array(mechanism.platform_reference_matrix, dtype=float)
        self.actuated = tuple(mechanism.actuated)
        self.passive = tuple(mechanism.loop_unknowns)
        self.names = (*self.actuated, *self.passive)
        self.order = [passive_names(legs).index(nm) for nm in self.passive]
        self.ranges = [mechanism.ranges[nm] for nm in self.names]
        self.limited = any(r is not None for r in self.ranges)

    def angles(self, inputs, dcs) -> np.ndarray:
        """Every joint's angle (K, joints; radians) at inputs (K, 3) and displacements D (K, 3, 3)."""
        inputs = np.asarray(inputs, dtype=float).reshape(-1, len(self.actuated))
        rotations = np.asarray(dcs, dtype=float).reshape(-1, 3, 3) @ self.ref
        passive = passive_readings_many(self.legs, inputs, rotations, self.ref)[:, self.order]
        return np.concatenate([inputs, passive], axis=1)

    def first_outside(self, inputs, dcs) -> tuple[int, str] | None:
        """(first pose, first joint) with a joint outside its range (:func:`in_range_many`), or None."""
        angles = self.angles(inputs, dcs)
        inside = np.ones(angles.shape, dtype=bool)
        for j, rng in enumerate(self.ranges):
            inside[:, j] = in_range_many(angles[:, j], rng)
        bad = np.flatnonzero(~inside.all(axis=1))
        if not len(bad):
            return None
        return int(bad[0]), self.names[int(np.argmin(inside[bad[0]]))]

    def steps_inside(self, dcs, w_lo, w_hi, beta0, beta1) -> np.ndarray:
        """Whether every joint is proven inside its range over each of N proven steps: displacements
        D_c (N, 3, 3) at the steps' starts, boxes [w_lo, w_hi] (N, 3) holding the root of every
        input of the step (D = D_c C(w)), inputs from beta0 to beta1 (N, 3). Interval enclosures of
        each joint's angle over the box and the segment (the readings' formulas of
        :func:`~spherekin.systems.platform.passive_readings_many`, the cos and sin of an
        angle by outward-rounded interval arithmetic); False where one is not proven inside (a joint
        may leave its range, or the enclosure is too wide to tell)."""
        dcs = np.asarray(dcs, dtype=float)
        n = len(dcs)
        ok = np.ones(n, dtype=bool)
        lo_b, hi_b = np.minimum(beta0, beta1), np.maximum(beta0, beta1)
        for j, rng in enumerate(self.ranges[:len(self.actuated)]):
            ok &= span_in_range_many(lo_b[:, j], hi_b[:, j], rng)
        if not ok.any() or all(r is None for r in self.ranges[len(self.actuated):]):
            return ok
        w = iv.from_bounds(w_lo, w_hi)                                          # (2, N, 3)
        zero = np.zeros((2, n))
        kx = np.stack([np.stack([zero, iv.neg(w[..., 2]), w[..., 1]], -1),
                       np.stack([w[..., 2], zero, iv.neg(w[..., 0])], -1),
                       np.stack([iv.neg(w[..., 1]), w[..., 0], zero], -1)], -2)   # [w]x (2, N, 3, 3)
        sq = iv.isum(iv.mul(w, w), -1)
        f = iv.from_bounds(np.nextafter(4.0 / (4.0 + sq[1]), -np.inf),
                           np.nextafter(4.0 / (4.0 + np.maximum(sq[0], 0.0)), np.inf))   # 4 / (4 + |w|^2)
        cay = iv.add(iv.point(np.broadcast_to(np.eye(3), (n, 3, 3))),
                     iv.mul(f[..., None, None], iv.add(kx, iv.scale(0.5, iv.matmul(kx, kx)))))
        d = iv.fmatmul(dcs, cay)                                                 # D = D_c C(w) (2, N, 3, 3)
        pas = {nm: r for nm, r in zip(self.passive, self.ranges[len(self.actuated):])}
        names = passive_names(self.legs)
        lo, hi = passive_reading_enclosures(self.legs, iv.from_bounds(lo_b, hi_b), d,
                                            [pas.get(leg.names[2]) is not None for leg in self.legs])
        for j, nm in enumerate(names):
            if pas.get(nm) is not None:
                ok &= span_in_range_many(lo[:, j], hi[:, j], pas[nm])
        return ok

    def measures(self, angles) -> np.ndarray:
        """The parallel measure (:meth:`~spherekin.mechanism.SphericalMechanism.parallel_measures`) at
        each row of :meth:`angles` (K, joints): shape (K,)."""
        angles = np.asarray(angles, dtype=float).reshape(-1, len(self.names))
        return self.mechanism.parallel_measures({n: angles[:, j] for j, n in enumerate(self.names)})


#: Largest number of parts one proven step is cut into while testing the joint ranges over it
#: (:func:`_ranges_walk`). Reason: a step is halved only around the point where a joint reaches a
#: range end, ~40 halvings from a step of 1 rad to LOCATE_TOL (two parts each), so ~100 parts suffice; the
#: cap turns a part that can never be decided into an error instead of an endless walk.
MAX_RANGE_PARTS = 1_000


def _ranges_walk(eqs: LegEquations, joints: "JointRanges", x0, x1, s_a: float, d_a, s_b: float, record: list,
                 parts: list | None = None):
    """Re-walk the proven step from s_a (displacement ``d_a``) to s_b of the segment x0 -> x1 in
    halves until every part is proven inside the ranges (:meth:`JointRanges.steps_inside`) or a part
    ends outside them. Appends (s, D, w, lo, hi) at the end of each part to ``record``; returns D at s_b, or
    None when the last part appended ends outside (the exit lies in it: :func:`_locate_exit`).
    Each part's joint angles are enclosed over its Krawczyk image (:func:`_certify_steps`).
    ``parts`` counts the parts walked (RuntimeError beyond MAX_RANGE_PARTS)."""
    parts = [] if parts is None else parts
    parts.append(s_a)
    if len(parts) > MAX_RANGE_PARTS:
        raise RuntimeError(f"track: testing the joint ranges over one proven step took more than "
                           f"{MAX_RANGE_PARTS:,} parts without deciding where a joint leaves its range")
    direction = x1 - x0
    span = float(np.abs(direction).max())
    b_a, b_b = x0 + s_a * direction, (x1 if s_b == 1.0 else x0 + s_b * direction)
    w = _predict(eqs, d_a, b_a, b_b)
    proven, lo, hi = ((np.zeros(1, dtype=bool), None, None) if w is None
                      else _certify_steps(eqs, d_a[None], w[None], b_a[None], b_b[None]))
    if proven[0]:
        d_b = d_a @ cayley(w)
        if joints.first_outside(b_b, d_b) is not None:
            record.append((s_b, d_b, w, lo[0], hi[0]))
            return None
        if (s_b - s_a) * span <= LOCATE_TOL or joints.steps_inside(d_a[None], lo, hi, b_a[None], b_b[None])[0]:
            record.append((s_b, d_b, w, lo[0], hi[0]))
            return d_b
    elif (s_b - s_a) * span <= MIN_STEP:
        raise RuntimeError("track: a part of a proven step could not be proven again while testing the joint "
                           "ranges")
    s_m = 0.5 * (s_a + s_b)
    d_m = _ranges_walk(eqs, joints, x0, x1, s_a, d_a, s_m, record, parts)
    return None if d_m is None else _ranges_walk(eqs, joints, x0, x1, s_m, d_m, s_b, record, parts)


def _segment_exit(eqs: LegEquations, joints: "JointRanges", x0, x1, d0, steps):
    """Where a joint leaves its range on the proven ``steps`` of the segment x0 -> x1 from the
    in-range displacement ``d0`` at x0: ``steps`` = (s, D, w, lo, hi) at the end of each, in order
    (lo, hi: a box holding the root of every input of the step, relative to its start). None when
    every step is proven inside the ranges; else (s_a, D_a, record): the last pose proven in range
    and the proven parts after it, the last one ending outside (for :func:`_locate_exit`)."""
    if not joints.limited or not steps:
        return None
    direction = x1 - x0
    s_prev = np.array([0.0] + [st[0] for st in steps[:-1]])
    d_prev = np.array([d0] + [st[1] for st in steps[:-1]])
    s_end = np.array([st[0] for st in steps])
    lo, hi = np.array([st[3] for st in steps]), np.array([st[4] for st in steps])
    ends = x0 + s_end[:, None] * direction
    inside = joints.steps_inside(d_prev, lo, hi, x0 + s_prev[:, None] * direction, ends)
    for j in np.flatnonzero(~inside):
        record: list = []
        if _ranges_walk(eqs, joints, x0, x1, float(s_prev[j]), d_prev[j], float(s_end[j]), record) is None:
            s_a, d_a = (float(s_prev[j]), d_prev[j]) if len(record) == 1 else record[-2][:2]
            return s_a, d_a, record[-1:]
    return None


def _locate_exit(eqs: LegEquations, joints: JointRanges, x0, x1, s0: float, d0, step):
    """Where a joint leaves its range on the proven ``step`` = (s1, D, w, lo, hi) of the segment x0 -> x1,
    from the pose D = ``d0`` at s0, in range, to s1, outside: bisection on it (Newton from the step's
    start: the step is proven, so every input of it has exactly one root in its box, which the root
    found must lie in) to LOCATE_TOL in input. Returns (s_in, s_out, D at s_in): the last input found
    in range and the first outside."""
    direction = x1 - x0
    s1, w1 = step[0], step[2]
    box_lo, box_hi = _boxes(np.asarray(w1)[None])
    b0 = x0 + s0 * direction
    lo, hi, d_lo = s0, s1, d0
    scale = float(np.abs(direction).max())
    while (hi - lo) * scale > LOCATE_TOL:
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        x = x0 + mid * direction
        w = _predict(eqs, d0, b0, x)
        if (w is not None and np.all(w >= box_lo[0]) and np.all(w <= box_hi[0])
                and joints.first_outside(x, d0 @ cayley(w)) is None):
            lo, d_lo = mid, d0 @ cayley(w)
        else:
            hi = mid
    return lo, hi, d_lo


def not_tracked(mechanism) -> str | None:
    """Why this tracker (the platform's orientation, Eq. (1) with the base joints actuated) does not
    follow ``mechanism`` (None when it does)."""
    why = not_applicable(mechanism)
    if why is not None:
        return why
    driven = [leg.names[leg.actuated] for leg in platform_legs(mechanism) if leg.actuated != 0]
    if driven:
        return (f"the platform tracker follows R-R-R legs with the base joint actuated; {', '.join(driven)} "
                "are not base joints")
    return None


def track(mechanism, path, start_rotation, *, start_tol: float = 1e-6) -> Track:
    """Follow the assembly at pose ``start_rotation`` (R, 3x3) along ``path`` (K, 3 inputs, radians).

    ``mechanism``: one the platform formulation applies to (three R-R-R legs, base joints
    actuated; ValueError otherwise). The start pose must close the legs at path[0] to ``start_tol``
    (largest |Eq. (1)|) with every joint in its range; it is polished by Newton and proven (a point
    Krawczyk test) first.

    How (module doc): rows are predicted in floats up to BATCH at a time, then every step between
    them is proven in one batch of interval arithmetic; the segments whose step is not proven are
    walked together in adaptive proven steps (halved on failure, grown after success), each round
    one array call. Every accepted step has its own proof; none depends on the prediction being right. Every row reached, and the end of every
    adaptive step, is tested against the joint ranges (module doc); the track ends at the first
    pose outside (a :class:`RangeStop`) or at a parallel singularity (a :class:`SingularStop`).
    """
    why = not_tracked(mechanism)
    if why is not None:
        raise ValueError(f"mechanism: {why}")
    legs = platform_legs(mechanism)
    eqs = LegEquations(legs)
    path = np.asarray(path, dtype=float)
    if path.ndim != 2 or path.shape[1] != len(legs) or not len(path):
        raise ValueError(f"path: expected an array of shape (K, {len(legs)}), got shape {path.shape}")
    if not np.all(np.isfinite(path)):
        raise ValueError("path: expected finite inputs (radians)")
    joints = JointRanges(mechanism, legs)
    ref = joints.ref
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
    n = len(path)
    dcs = np.empty((n, 3, 3))
    dcs[0] = dc @ cayley(w0)
    out0 = joints.first_outside(path[0], dcs[0])
    if out0 is not None:
        name = out0[1]
        angle = joints.angles(path[0], dcs[0])[0, joints.names.index(name)]
        raise ValueError(f"start: {name} = {angle:.6g} rad at the start pose is outside its joint range "
                         f"{list(mechanism.ranges[name])}; give an assembly inside the ranges")
    steps_of = np.zeros(n, dtype=int)
    n_steps = rejected = 0
    budget = MAX_STEPS + STEPS_PER_INPUT * n
    stop = None
    leaves = None            # (segment k, _segment_exit's answer) where a joint leaves its range
    k = 0
    while k < n - 1 and stop is None and leaves is None:
        last = min(n - 1, k + BATCH)                 # predict segments k .. last - 1 (fewer if Newton fails)
        pose, w_m = _predict_rows(eqs, dcs[k], path[k:last + 1])   # pose[j]: the displacement at row k + j
        m = len(w_m)
        proven = np.zeros(m, dtype=bool)
        if m:
            proven, lo_m, hi_m = _certify_steps(eqs, pose[:m], w_m, path[k:k + m], path[k + 1:k + m + 1])
            inside = np.ones(m, dtype=bool)
            if joints.limited and proven.any():      # each step proven inside the ranges, else walked finer
                inside[proven] = joints.steps_inside(pose[:m][proven], lo_m[proven], hi_m[proven],
                                                     path[k:k + m][proven], path[k + 1:k + m + 1][proven])
        # every segment whose step is not proven (and the one Newton failed on) walked together
        walked = [j for j in range(m) if not proven[j]] + ([m] if m < last - k else [])
        walks = dict(zip(walked, walk(_LegStepper(eqs), pose[walked], path[k + np.array(walked, dtype=int)],
                                      path[k + 1 + np.array(walked, dtype=int)],
                                      budget - n_steps - rejected))) if walked else {}
        rejected += sum(1 for j in walked if j < m)   # the batch's first proof of each failed
        for j in range(m + (m < last - k)):          # the batch's segments in order, up to an end
            r = k + j
            if j in walks:
                walked_j = walks[j]
                n_steps += walked_j.steps
                rejected += walked_j.rejected
                found = _segment_exit(eqs, joints, path[r], path[r + 1], pose[j], walked_j.record)
                if found is not None:                # before the singularity, if any: the range ends the track
                    leaves = (r, found)
                    break
                if walked_j.stop is not None:
                    stop = (r, walked_j.stop)
                    break
                steps_of[r + 1] = walked_j.steps
                if j + 1 < len(pose) and np.abs(walked_j.end - pose[j + 1]).max() > AGREE_TOL:
                    dcs[r + 1] = walked_j.end            # not the predicted pose: the later steps start elsewhere
                    break
                dcs[r + 1] = pose[j + 1] if j + 1 < len(pose) else walked_j.end
            else:
                if not inside[j]:
                    found = _segment_exit(eqs, joints, path[r], path[r + 1], pose[j],
                                          [(1.0, pose[j + 1], w_m[j], lo_m[j], hi_m[j])])
                    if found is not None:
                        n_steps += 1
                        leaves = (r, found)
                        break
                n_steps += 1
                steps_of[r + 1] = 1
                dcs[r + 1] = pose[j + 1]
        else:
            k = k + j + 1
            continue
        k = r if (stop is not None or leaves is not None) else r + 1
    reached = k + 1
    rotations = dcs[:reached] @ ref
    angles = joints.angles(path[:reached], dcs[:reached])
    residuals = np.abs(eqs.residual(dcs[:reached], path[:reached])).max(axis=1)
    act, pas = joints.actuated, joints.passive
    na = len(act)
    measures = joints.measures(angles)
    poses = tuple(TrackedPose(r, _named(act, angles[r, :na]), rotations[r], _named(pas, angles[r, na:]),
                              float(residuals[r]), float(measures[r]), int(steps_of[r])) for r in range(reached))
    if leaves is not None:
        row, (s_a, d_a, parts) = leaves
        x0, x1 = path[row], path[row + 1]
        s_in, s_out, d_in = _locate_exit(eqs, joints, x0, x1, s_a, d_a, parts[-1])
        direction = x1 - x0
        here, there = x0 + s_in * direction, x0 + s_out * direction
        outside = (joints.first_outside(there, _exit_pose(eqs, d_in, here, there))
                   or joints.first_outside(x0 + parts[-1][0] * direction, parts[-1][1]))   # else the part's end
        name = outside[1]
        at = joints.angles(here, d_in)[0]
        stop = RangeStop((row, row + 1), float(s_in), name, tuple(float(v) for v in mechanism.ranges[name]),
                         float(at[joints.names.index(name)]), _named(act, here), _named(act, there),
                         float(np.abs(there - here).max()), float(joints.measures(at)[0]),
                         f"{name} leaves its joint range {[float(v) for v in mechanism.ranges[name]]} (radians): "
                         "no pose beyond is reported")
    elif stop is not None:
        row, at = stop
        x0, direction = path[row], path[row + 1] - path[row]
        here = x0 + at.s * direction
        singular = x0 + 0.5 * (at.lo + at.hi) * direction
        stop = SingularStop((row, row + 1), float(at.s), _named(act, here), _named(act, singular),
                            float(np.abs(singular - here).max()),
                            float((at.hi - at.lo) * np.abs(direction).max()),
                            float(joints.measures(joints.angles(here, at.state))[0]),
                            f"no step longer than {MIN_STEP:g} rad of input could be proven: the assembly mode "
                            "meets another (a parallel singularity) and ends")
    return Track(mechanism.name, act, pas, n, poses, stop, n_steps, rejected)


def _exit_pose(eqs: LegEquations, d_in, here, there):
    """The pose at ``there`` (within LOCATE_TOL of ``here``) continued from D = ``d_in`` at ``here``."""
    w = _predict(eqs, d_in, here, there)
    return d_in if w is None else d_in @ cayley(w)


class _LegStepper:
    """The platform's leg equations as a :class:`~spherekin.trust.stepping.Stepper`: the state a
    displacement D (3, 3), a proposal its Cayley step w (3,); the joint ranges are tested after the
    walk, on its record (:func:`_segment_exit`)."""

    growth = STEP_GROWTH

    def __init__(self, eqs: LegEquations):
        self.eqs = eqs

    def predict(self, dcs, b0, b1):
        return predict_many(self.eqs, dcs, b0, b1)

    def certify(self, dcs, w, b0, b1):
        return _certify_steps(self.eqs, dcs, w, b0, b1)

    def advance(self, dc, w):
        return dc @ cayley(w)

    def locate(self, dc, b0, direction, t_max: float):
        return _locate(self.eqs, dc, b0, direction, 0.0, t_max)

    def check(self, *step) -> None:
        return None
