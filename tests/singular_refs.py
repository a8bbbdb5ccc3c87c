"""Independent references for issue 31 (certified singular sets): branch points, singular inputs, tangency curves.

Used by the tests of the singular-set code (``from singular_refs import ...``; pytest puts tests/ on sys.path).
Everything here is written from the geometry of the mechanism files (read with tomllib, not with spherekin),
closed forms and numpy, so that a test comparing spherekin's singular sets with these compares it with
something else. The only shared code is the degree-8 / Macaulay solver of ``references/peers_closed_form.py``,
itself numpy only and independent of the Bernstein code (used as the root-count oracle of item 2).

Conventions (docs/mechanism-format.md): angles in radians; a joint reading theta turns the link after it by
Rot(axis, theta) (right-hand rule) from the reference configuration of the file, where every reading is 0.

1. Spherical four-bar (A driven, coupler B-C, rocker C-D): :func:`four_bar_branch_inputs`.
2. general_3rrr along a line of the plane beta3 = const: :func:`singular_points_on_line`, :func:`type2_det`.
3. Spherical five-bar (A, E driven): :func:`five_bar_tangency`, :func:`five_bar_curve_points`.
4. A singularity-free box check: :func:`track_box_min_det` with :func:`rrr_tracked` / :func:`five_bar_tracked`.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"

#: Bisection of a count change stops when the bracket is this narrow (radians along the line's parameter
#: scaled to the segment length): the issue's tests locate singular inputs to 1e-10.
BISECTION_WIDTH = 1e-10
#: The merging pair of a bisected fold is read this far (radians along the line) on the side with more roots.
#: Reason: within ~1e-12 of the fold the oracle's classification of the pair is rounding noise (ODD_COUNT);
#: at 1e-8 the pair is ~1e-4 apart (a square root) and cleanly real, and its midpoint is singular to O(1e-8).
MERGE_OFFSET = 1e-8
#: Newton iterations of the box tracker per grid step; the steps are short (a dense grid) so Newton
#: starts within ~step of the root and 8 quadratic iterations reach machine precision with margin.
TRACK_NEWTON_ITERS = 8
#: A tracked point whose closure residual is above this after the Newton iterations is "lost": the
#: assembly ended (a fold, where Newton has no root to converge to) or the step jumped.
TRACK_RESIDUAL_TOL = 1e-9


# ---------------------------------------------------------------- reading the example files (tomllib)

def _angle(value) -> float:
    """A file angle: a number or a text like "5*pi/12" (the format's pi expressions), radians."""
    if isinstance(value, (int, float)):
        return float(value)
    text = value.replace(" ", "")
    if not set(text) <= set("0123456789.+-*/pi"):
        raise ValueError(f"angle: expected a number or a pi expression, got {value!r}")
    return float(eval(text.replace("pi", repr(math.pi)), {"__builtins__": {}}))  # noqa: S307 (checked above)


def rodrigues(axis, angle: float) -> np.ndarray:
    """Rot(axis, angle): right-handed rotation by ``angle`` (radians) about the unit vector ``axis``, (3, 3)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * (k @ k)


def expmap_many(omega) -> np.ndarray:
    """exp([omega]x) for rotation vectors omega (K, 3) (radians): (K, 3, 3), Rodrigues with sin(t)/t series-safe."""
    om = np.asarray(omega, dtype=float)
    t = np.linalg.norm(om, axis=1)
    k = np.zeros(om.shape[:1] + (3, 3))
    k[:, 0, 1], k[:, 0, 2], k[:, 1, 2] = -om[:, 2], om[:, 1], -om[:, 0]
    k -= np.swapaxes(k, 1, 2)
    small = t < 1e-8                     # below this, sin(t)/t = 1 and (1 - cos t)/t^2 = 1/2 to double precision
    ts = np.where(small, 1.0, t)
    a = np.where(small, 1.0, np.sin(ts) / ts)[:, None, None]
    b = np.where(small, 0.5, (1.0 - np.cos(ts)) / ts**2)[:, None, None]
    return np.eye(3) + a * k + b * (k @ k)


def rotate_many(axis, vector, angles) -> np.ndarray:
    """Rot(axis, t) vector for every t of ``angles`` (shape (K,)), by Rodrigues' formula: shape (K, 3)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    v = np.asarray(vector, dtype=float)
    t = np.asarray(angles, dtype=float)[:, None]
    return v * np.cos(t) + np.cross(a, v) * np.sin(t) + a * (a @ v) * (1.0 - np.cos(t))


def general_axes(path) -> dict[str, np.ndarray]:
    """Joint name -> unit axis (reference configuration) of a kind "general" file, read with tomllib."""
    data = tomllib.loads(Path(path).read_text())
    if data.get("kind") != "general":
        raise ValueError(f"{path}: expected kind = \"general\", got {data.get('kind')!r}")
    out = {}
    for leg in data["legs"]:
        for joint in leg["joints"]:
            a = np.asarray(joint["axis"], dtype=float)
            out[joint["name"]] = a / np.linalg.norm(a)
    return out


def rrr_geometry(path=EXAMPLES / "general_3rrr.toml") -> tuple:
    """(u (3, 3), w0 (3, 3), v0 (3, 3), alpha2 (3,)) of a kind "3-RRR" file, read with tomllib (unit rows)."""
    data = tomllib.loads(Path(path).read_text())
    if data.get("kind") != "3-RRR":
        raise ValueError(f"{path}: expected kind = \"3-RRR\", got {data.get('kind')!r}")

    def units(key):
        a = np.asarray(data[key], dtype=float)
        return a / np.linalg.norm(a, axis=1, keepdims=True)

    return (units("base_axes"), units("elbow_axes_at_zero"), units("platform_axes"),
            np.array([_angle(x) for x in data["distal_link_angles"]]))


def arc(p, q) -> float:
    """The great-circle distance between unit vectors p and q (radians, in [0, pi]; atan2: exact near 0 and pi)."""
    return math.atan2(float(np.linalg.norm(np.cross(p, q))), float(np.dot(p, q)))


# ---------------------------------------------------------------- 1. spherical four-bar

@dataclass(frozen=True)
class FourBar:
    """A spherical four-bar in its reference configuration: base pivots A (driven) and D, moving joints B
    (crank-coupler) and C (coupler-rocker), unit axes (3,). The input theta turns B to Rot(A, theta) B."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray

    @property
    def arcs(self) -> tuple[float, float, float, float]:
        """(ground A-D, crank A-B, coupler B-C, rocker D-C), radians."""
        return arc(self.A, self.D), arc(self.A, self.B), arc(self.B, self.C), arc(self.D, self.C)


def four_bar_from_file(path=EXAMPLES / "four_bar.toml") -> FourBar:
    """The four-bar of ``examples/four_bar.toml`` (joints A, B, C, D)."""
    ax = general_axes(path)
    return FourBar(ax["A"], ax["B"], ax["C"], ax["D"])


def four_bar_from_arcs(ground: float, crank: float, coupler: float, rocker: float, theta: float = 0.0) -> FourBar:
    """A four-bar with the given link arcs (radians), assembled at crank angle ``theta`` from the x-z plane:
    A = z, D in the x-z plane at ``ground`` from A, B at ``crank`` from A and azimuth ``theta``; C is the
    intersection of the circles (B, coupler) and (D, rocker) on the side of +(B x D).
    Raises ValueError when that crank angle cannot be assembled."""
    a = np.array([0.0, 0.0, 1.0])
    d = np.array([math.sin(ground), 0.0, math.cos(ground)])
    b = np.array([math.sin(crank) * math.cos(theta), math.sin(crank) * math.sin(theta), math.cos(crank)])
    c = _circle_intersections(b, coupler, d, rocker)
    if c is None:
        raise ValueError(f"theta: the four-bar {ground, crank, coupler, rocker} does not assemble at {theta}")
    return FourBar(a, b, c[0], d)


def _circle_intersections(p, rp: float, q, rq: float):
    """The unit vectors x with arc(x, p) = rp and arc(x, q) = rq: (2, 3), the first on the side of +(p x q),
    or None when the circles do not meet. x = alpha p + beta q + gamma (p x q)."""
    pq = float(p @ q)
    n = np.cross(p, q)
    nn = float(n @ n)
    # alpha + beta pq = cos rp, alpha pq + beta = cos rq
    alpha, beta = np.linalg.solve([[1.0, pq], [pq, 1.0]], [math.cos(rp), math.cos(rq)])
    base = alpha * p + beta * q
    g2 = (1.0 - float(base @ base)) / nn
    if g2 < 0:
        return None
    g = math.sqrt(g2)
    return np.array([base + g * n, base - g * n])


def four_bar_toml(fb: FourBar, name: str = "four-bar") -> str:
    """The text of a kind "general" mechanism file of ``fb`` in the layout of examples/four_bar.toml (legs
    "crank" A-B, driven A, and "rocker" D-C; every reading 0 at ``fb``'s configuration), for tests that give a
    four-bar with branch points to spherekin."""
    def vec(v):
        return "[" + ", ".join(repr(float(x)) for x in v) + "]"

    return (f'kind = "general"\nname = "{name}"\nreference_leg = "crank"\n\n'
            f'[[legs]]\nname = "crank"\n[[legs.joints]]\nname = "A"\naxis = {vec(fb.A)}\nactuated = true\n'
            f'[[legs.joints]]\nname = "B"\naxis = {vec(fb.B)}\n\n'
            f'[[legs]]\nname = "rocker"\n[[legs.joints]]\nname = "D"\naxis = {vec(fb.D)}\n'
            f'[[legs.joints]]\nname = "C"\naxis = {vec(fb.C)}\n')


def four_bar_bd_cos(fb: FourBar):
    """(p, q, r) with cos arc(B(theta), D) = p + q cos theta + r sin theta, B(theta) = Rot(A, theta) B."""
    p = float(fb.A @ fb.B) * float(fb.A @ fb.D)
    q = float(fb.B @ fb.D) - p
    r = float(np.cross(fb.A, fb.B) @ fb.D)
    return p, q, r


def four_bar_branch_inputs(fb: FourBar) -> np.ndarray:
    """The crank inputs theta (radians, in (-pi, pi], sorted) where the passive configuration branches.

    The coupler B-C (arc b) and the rocker D-C (arc c) align exactly when the circle of C around B(theta)
    is tangent to the circle of C around D: arc(B, D) = b + c, |b - c| or 2 pi - (b + c) (both on one great
    circle through B and D). By the spherical law of cosines in the triangle A B D,
    cos arc(B(theta), D) = p + q cos theta + r sin theta (:func:`four_bar_bd_cos`), so with m = hypot(q, r),
    theta = atan2(r, q) +- arccos((cos s - p) / m) for each target arc s with |cos s - p| <= m.
    There the closure has a double root, dtheta_rocker / dtheta_input is infinite and the reachable input
    range ends (or the assembly count changes 2 -> 0). Empty for a crank that turns fully (a Grashof crank).
    """
    _, _, b, c = fb.arcs
    p, q, r = four_bar_bd_cos(fb)
    m = math.hypot(q, r)
    phase = math.atan2(r, q)
    targets = {b + c, abs(b - c), 2 * math.pi - (b + c)}
    out = []
    for s in targets:
        if not 0.0 <= s <= math.pi:
            continue
        x = (math.cos(s) - p) / m
        if abs(x) > 1.0:
            continue
        h = math.acos(x)
        for t in {phase + h, phase - h}:
            out.append(math.remainder(t, 2 * math.pi))
    return np.array(sorted(out))


def four_bar_closure_coefficients(fb: FourBar, theta: float) -> tuple[float, float, float]:
    """(P, Q, S) with the closure at input theta: g(psi) = P + Q cos psi + S sin psi = 0, where psi turns
    the rocker: C(psi) = Rot(D, psi) C and g = C(psi) . B(theta) - cos b (the coupler's arc b).
    With t = tan(psi / 2): (P - Q) t^2 + 2 S t + (P + Q) = 0, discriminant 4 (Q^2 + S^2 - P^2)."""
    b = arc(fb.B, fb.C)
    bt = rodrigues(fb.A, theta) @ fb.B
    dc = float(fb.D @ fb.C)
    P = dc * float(fb.D @ bt) - math.cos(b)
    Q = float(fb.C @ bt) - dc * float(fb.D @ bt)
    S = float(np.cross(fb.D, fb.C) @ bt)
    return P, Q, S


# ---------------------------------------------------------------- 2. general_3rrr: singular inputs along lines

def elbow_axes(geometry, inputs) -> np.ndarray:
    """w_i(beta_i) = Rot(u_i, beta_i) w_i^0 for inputs (K, 3): shape (K, 3, 3)."""
    u, w0, _, _ = geometry
    inputs = np.atleast_2d(np.asarray(inputs, dtype=float))
    return np.stack([rotate_many(u[i], w0[i], inputs[:, i]) for i in range(3)], axis=1)


def type2_det(geometry, inputs, rot) -> np.ndarray:
    """det of the 3-RRR's passive (Type-2) Jacobian, rows (w_i x v_i)^T with v_i = R v_i^0: shape (K,).

    Derivation: leg i closes when g_i = w_i(beta_i) . (R v_i^0) - cos alpha2_i = 0. Turning the platform by a
    small rotation vector omega (R -> exp([omega]x) R) changes v_i by omega x v_i, so
    dg_i = w_i . (omega x v_i) = omega . (v_i x w_i): dg/domega has rows (v_i x w_i)^T = -(w_i x v_i)^T, and
    det(dg/domega) = -det[(w_i x v_i)^T]. It vanishes exactly where the passive configuration is not locally
    unique (Type-2 / parallel singularity). ``inputs`` (K, 3) or (3,), ``rot`` (K, 3, 3) or (3, 3).
    """
    _, _, v0, _ = geometry
    w = elbow_axes(geometry, inputs)
    rot = np.asarray(rot, dtype=float).reshape(-1, 3, 3)
    v = np.einsum("kab,ib->kia", rot, v0)
    return np.linalg.det(np.cross(w, v))


def rrr_closure(geometry, inputs, rot) -> np.ndarray:
    """g_i = w_i(beta_i) . (R v_i^0) - cos alpha2_i for inputs (K, 3), rot (K, 3, 3): shape (K, 3)."""
    _, _, v0, alpha2 = geometry
    w = elbow_axes(geometry, inputs)
    v = np.einsum("kab,ib->kia", np.asarray(rot, dtype=float).reshape(-1, 3, 3), v0)
    return np.einsum("kia,kia->ki", w, v) - np.cos(alpha2)


def _quaternion_of(rot) -> np.ndarray:
    """A unit quaternion (w, x, y, z) of a rotation (3, 3) (Shepperd's method, the largest diagonal term)."""
    from references.peers_closed_form import rotation_quaternion

    return rotation_quaternion(rot)


def _oracle():
    """(quadrics_many, real_roots_many) of the degree-8 solver (imported late: benchmarks/ is a script package)."""
    from references.peers_closed_form import quadrics_many, real_roots_many

    return quadrics_many, real_roots_many


#: Frames in which the oracle counts: (G, H) turns the base frame by G and the platform frame by H (u, w0 ->
#: G u, G w0; v0 -> H v0; a pose R -> G R H^T), which leaves every count unchanged but moves the quaternions.
#: Reason: the oracle's eigenproblem reads the roots off the eigenvalues h1(p)/h0(p) of two fixed linear forms;
#: where two real roots share that value (a curve of the input plane, met on general_3rrr near
#: (1.4889, 1.4883, 0.5)) numpy's eig may return them as a complex pair and the count drops by 2 without any
#: singularity (or returns one real root twice: removed, DUPLICATE_TOL). That coincidence depends on the frame,
#: and the artifact only ever loses roots, so the count is the largest over three frames (identity and two
#: seeded random ones).
FRAME_SEED = 31


def _random_rotation(rng) -> np.ndarray:
    """A random rotation (3, 3) from a normal 4-vector (a uniformly distributed unit quaternion)."""
    q = rng.normal(size=4)
    return _quaternion_rotations(q / np.linalg.norm(q))




def rrr_poses_all_frames(geometry, inputs) -> tuple[np.ndarray, np.ndarray]:
    """The degree-8 oracle (``references.peers_closed_form.real_roots_many``) at inputs (K, 3), in each frame of
    FRAMES: (rotations (F, K, 8, 3, 3) in the original frame, NaN where not real; real (F, K, 8) bool).
    Raises ValueError where the oracle's Macaulay matrix has no clear null space (never met on general_3rrr)."""
    quadrics_many, real_roots_many = _oracle()
    u, w0, v0, alpha2 = geometry
    inputs = np.atleast_2d(np.asarray(inputs, dtype=float))
    rots, reals = [], []
    for g, h in FRAMES:
        w = elbow_axes((u @ g.T, w0 @ g.T, v0, alpha2), inputs)
        q, real, ok = real_roots_many(quadrics_many(w, v0 @ h.T, np.cos(alpha2)))
        if not ok.all():
            raise ValueError(f"inputs: the degree-8 oracle is degenerate at {inputs[~ok][:3]}")
        real = real & ~_duplicates(q, real)
        r = _quaternion_rotations(q)                                   # R' = G R H^T in the turned frames
        rots.append(np.einsum("ab,kibc,cd->kiad", g.T, r, h))
        reals.append(real)
    return np.array(rots), np.array(reals)


#: Two real roots closer than this (unit quaternions, up to sign) are one root found twice. Reason: where two
#: eigenvalues nearly coincide (see FRAMES) their eigenvectors mix, and Newton polishes both mixtures onto the
#: same root; the two roots that really merge at a fold are ~sqrt(distance) apart, 1e-5 at 1e-10 from it.
DUPLICATE_TOL = 1e-8


def _duplicates(q, real) -> np.ndarray:
    """(K, 8) bool: real roots that repeat an earlier real root of the same input within DUPLICATE_TOL."""
    qq = np.where(real[..., None], q, np.nan)
    dist = np.minimum(np.linalg.norm(qq[:, :, None] - qq[:, None], axis=3),
                      np.linalg.norm(qq[:, :, None] + qq[:, None], axis=3))            # (K, 8, 8)
    earlier = np.tril(np.ones((8, 8), dtype=bool), -1)
    return ((dist < DUPLICATE_TOL) & earlier).any(axis=2)


def _quaternion_rotations(q) -> np.ndarray:
    """R(q) of unit quaternions (..., 4) (NaN stays NaN): (..., 3, 3)."""
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
                     np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
                     np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1)], -2)


_rng = np.random.default_rng(FRAME_SEED)
FRAMES = [(np.eye(3), np.eye(3))] + [(_random_rotation(_rng), _random_rotation(_rng)) for _ in range(2)]


#: ODD_COUNT: complex roots come in conjugate pairs, so the real count of the degree-8 system is even. An odd
#: count means one root of a pair within rounding of a fold was classified on the other side (imaginary parts
#: straddling REAL_TOL, or two real roots closer than DUPLICATE_TOL): it is counted as the real side (+1),
#: which moves a bisected fold by ~1e-12 at most, below BISECTION_WIDTH.


def rrr_counts(geometry, inputs) -> np.ndarray:
    """Number of real assemblies of the 3-RRR at each of inputs (K, 3): the oracle's distinct real roots, made
    even (ODD_COUNT), the largest count over FRAMES (see there), (K,) int."""
    n = rrr_poses_all_frames(geometry, inputs)[1].sum(axis=2)
    return (n + n % 2).max(axis=0)      # parity: see ODD_COUNT


def rrr_poses(geometry, x) -> list[np.ndarray]:
    """Every real pose (3, 3) of the 3-RRR at one input x (3,), from the frame with the most real roots."""
    rots, real = rrr_poses_all_frames(geometry, x)
    f = int(np.argmax(real[:, 0].sum(axis=1)))
    return list(rots[f, 0][real[f, 0]])


@dataclass(frozen=True)
class SingularPoint:
    """A singular input found on a line of the plane: ``t`` in [0, 1] along p0 -> p1, ``inputs`` (3,) radians
    (bracket width <= BISECTION_WIDTH), the real counts on either side (more real roots on the inside
    side), the merging root as a rotation ``rot`` (3, 3) (the midpoint of the closest pair of real roots
    MERGE_OFFSET inside the bracket), the Type-2 determinant ``det`` there and the quaternion distance ``gap``
    of that pair (~1e-4 at MERGE_OFFSET from a fold: a large gap would mean a count change without a
    merging pair, which the tests reject)."""

    t: float
    inputs: np.ndarray
    count_before: int
    count_after: int
    rot: np.ndarray
    det: float
    gap: float


def singular_points_on_line(p0, p1, n_samples: int = 400, seed: int = 0, beta3: float = 0.5,
                            geometry=None) -> list[SingularPoint]:
    """The singular inputs of general_3rrr on the segment (beta1, beta2) = p0 -> p1 of the plane beta3 = const.

    The real-root count of the degree-8 oracle is sampled at ``n_samples`` points of the segment (the sample
    grid shifted by a random phase from ``seed``, so that different seeds sample different points), and every
    change of count between neighbouring samples is bisected to BISECTION_WIDTH (in t times the segment's
    length); a sample interval holding several changes gives each of them. Crossings between two samples
    that restore the count (4 -> 2 -> 4) are missed: use enough samples. Returns the points sorted by t
    (:class:`SingularPoint`).
    """
    geometry = rrr_geometry() if geometry is None else geometry
    p0, p1 = np.asarray(p0, dtype=float), np.asarray(p1, dtype=float)
    length = float(np.linalg.norm(p1 - p0))
    rng = np.random.default_rng(seed)
    step = 1.0 / n_samples
    ts = np.clip(np.concatenate([[0.0], step * (np.arange(n_samples) + rng.uniform(0, 1)), [1.0]]), 0.0, 1.0)

    def at(t):
        t = np.asarray(t, dtype=float)
        xy = p0 + t[:, None] * (p1 - p0)
        return np.column_stack([xy, np.full(len(t), beta3)])

    counts = rrr_counts(geometry, at(ts))
    change = np.flatnonzero(counts[1:] != counts[:-1])
    # brackets (lo, hi, count at lo, count at hi); a sample interval may hold several changes: after one is
    # bisected, the rest of the interval (its bracket's hi to the interval's end) is searched again
    todo = [(ts[k], ts[k + 1], counts[k], counts[k + 1]) for k in change]
    found = []
    while todo:
        lo, hi, c_lo, c_end = (np.array(x) for x in zip(*todo))
        end = hi.copy()
        c_hi = c_end.copy()
        while (hi - lo).max() * length > BISECTION_WIDTH:
            mid = 0.5 * (lo + hi)
            c_mid = rrr_counts(geometry, at(mid))
            same = c_mid == c_lo
            lo, hi, c_hi = np.where(same, mid, lo), np.where(same, hi, mid), np.where(same, c_hi, c_mid)
        found += list(zip(lo, hi, c_lo, c_hi))
        todo = [(h, e, ch, ce) for h, e, ch, ce in zip(hi, end, c_hi, c_end) if ch != ce]
    found.sort()
    out = []
    for a, b, ca, cb in found:
        inside = a - MERGE_OFFSET / length if ca > cb else b + MERGE_OFFSET / length
        poses = rrr_poses(geometry, at(np.array([inside]))[0])
        qs = [_quaternion_of(r) for r in poses]
        best, pair = math.inf, None
        for i in range(len(qs)):
            for j in range(i + 1, len(qs)):
                for sg in (1.0, -1.0):                             # q and -q are one pose
                    dist = float(np.linalg.norm(qs[i] - sg * qs[j]))
                    if dist < best:
                        best, pair = dist, 0.5 * (qs[i] + sg * qs[j])
        rot = _quaternion_rotations(pair / np.linalg.norm(pair))
        x = at(np.array([0.5 * (a + b)]))[0]
        out.append(SingularPoint(float(0.5 * (a + b)), x, int(ca), int(cb), rot, float(type2_det(geometry, x, rot)[0]),
                                 best))
    return out


def lines_across(square, n: int, seed: int) -> list:
    """Segments across the square ((x0, x1), (y0, y1)) (radians): its two diagonals, then n seeded
    segments from edge to opposite edge, alternately left-right and bottom-top; each ((x, y), (x, y))."""
    (x0, x1), (y0, y1) = square
    rng = np.random.default_rng(seed)
    out = [((x0, y0), (x1, y1)), ((x0, y1), (x1, y0))]
    for k in range(n):
        a, b = rng.uniform(0.05, 0.95, 2)
        if k % 2 == 0:
            out.append(((x0, y0 + a * (y1 - y0)), (x1, y0 + b * (y1 - y0))))
        else:
            out.append(((x0 + a * (x1 - x0), y0), (x0 + b * (x1 - x0), y1)))
    return out


def seeded_lines(n: int, seed: int, half_width: float = math.pi) -> np.ndarray:
    """n random segments of the square [-half_width, half_width]^2, each from one side to the opposite one
    (so every segment crosses the whole square): shape (n, 2, 2) = (line, end, (beta1, beta2))."""
    rng = np.random.default_rng(seed)
    out = np.empty((n, 2, 2))
    for k in range(n):
        a, b = rng.uniform(-half_width, half_width, 2)
        if k % 2 == 0:   # left side to right side
            out[k] = [[-half_width, a], [half_width, b]]
        else:            # bottom to top
            out[k] = [[a, -half_width], [b, half_width]]
    return out


# ---------------------------------------------------------------- 3. spherical five-bar

@dataclass(frozen=True)
class FiveBar:
    """The five-bar of examples/five_bar.toml: base pivots A, E (driven, inputs theta1, theta2), B = Rot(A,
    theta1) B^0 (left crank A-B), D = Rot(E, theta2) D^0 (right crank E-D), the passive joint C at arc ``bc``
    from B and ``dc`` from D (reference configuration axes, unit (3,))."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    E: np.ndarray

    @property
    def bc(self) -> float:
        return arc(self.B, self.C)

    @property
    def dc(self) -> float:
        return arc(self.D, self.C)


def five_bar_from_file(path=EXAMPLES / "five_bar.toml") -> FiveBar:
    """The five-bar of ``examples/five_bar.toml`` (joints A, B, C, D, E)."""
    ax = general_axes(path)
    return FiveBar(ax["A"], ax["B"], ax["C"], ax["D"], ax["E"])


def five_bar_moving(fb: FiveBar, inputs) -> tuple[np.ndarray, np.ndarray]:
    """(B, D) at inputs (K, 2) = (theta1, theta2): each (K, 3)."""
    x = np.atleast_2d(np.asarray(inputs, dtype=float))
    return rotate_many(fb.A, fb.B, x[:, 0]), rotate_many(fb.E, fb.D, x[:, 1])


def five_bar_tangency(fb: FiveBar, inputs) -> np.ndarray:
    """F(theta1, theta2) = (cos arc(B, D) - cos(bc + dc)) (cos arc(B, D) - cos(bc - dc)), shape (K,).

    C lies on the circle of arc bc around B and on the circle of arc dc around D; the two circles are
    tangent (a double root of the passive configuration: the singular curve) exactly when arc(B, D) equals
    bc + dc or |bc - dc| (2 pi - (bc + dc) is beyond pi unless bc + dc >= pi, then cos equals the first
    factor's). F > 0 where the circles miss each other (0 assemblies), F < 0 where they cross (2).
    For the example (bc = dc = 60 deg) the second factor is cos arc(B, D) - 1 <= 0, zero only where B = D
    (isolated points: coincident circles, a continuum of C, not a tangency); the curve is arc(B, D) = 120 deg.
    """
    b, d = five_bar_moving(fb, inputs)
    cbd = np.einsum("ka,ka->k", b, d)
    return (cbd - math.cos(fb.bc + fb.dc)) * (cbd - math.cos(fb.bc - fb.dc))


def five_bar_count(fb: FiveBar, inputs) -> np.ndarray:
    """Number of real positions of C at each input (K, 2), by an independent construction (the two circles'
    intersection, :func:`_circle_intersections`): 2, or 0 where the circles miss each other, (K,) int."""
    b, d = five_bar_moving(fb, inputs)
    return np.array([0 if _circle_intersections(bk, fb.bc, dk, fb.dc) is None else 2 for bk, dk in zip(b, d)])


def five_bar_curve_points(fb: FiveBar, n_lines: int = 8, n_samples: int = 400, seed: int = 0) -> np.ndarray:
    """Points (theta1, theta2) of the five-bar's singular curve F = 0 in [-pi, pi]^2, by bisection (to
    BISECTION_WIDTH) of every sign change of :func:`five_bar_tangency` along ``n_lines`` seeded segments
    (:func:`seeded_lines`) sampled at ``n_samples`` points: shape (M, 2)."""
    out = []
    for p0, p1 in seeded_lines(n_lines, seed):
        ts = np.linspace(0.0, 1.0, n_samples + 1)
        f = five_bar_tangency(fb, p0 + ts[:, None] * (p1 - p0))
        for k in np.flatnonzero(np.sign(f[1:]) != np.sign(f[:-1])):
            lo, hi, flo = ts[k], ts[k + 1], f[k]
            while (hi - lo) * np.linalg.norm(p1 - p0) > BISECTION_WIDTH:
                mid = 0.5 * (lo + hi)
                fm = five_bar_tangency(fb, p0 + mid * (p1 - p0))[0]
                if np.sign(fm) == np.sign(flo):
                    lo = mid
                else:
                    hi = mid
            out.append(p0 + 0.5 * (lo + hi) * (p1 - p0))
    return np.array(out).reshape(-1, 2)


# ---------------------------------------------------------------- 4. tracking an assembly over a box of inputs

@dataclass(frozen=True)
class Tracked:
    """A mechanism for :func:`track_box_min_det`, independent of spherekin: ``newton(inputs (K, m), state (K, ...))
    -> (state, residual (K,))`` runs TRACK_NEWTON_ITERS Newton steps of the closure at those inputs;
    ``det(inputs, state) -> (K,)`` is the passive Jacobian's determinant."""

    newton: object
    det: object
    n_inputs: int


def rrr_tracked(geometry=None) -> Tracked:
    """general_3rrr (or ``geometry``) with the state a rotation matrix (K, 3, 3); Newton on the rotation
    vector: dg/domega = rows (v_i x w_i)^T (see :func:`type2_det`), R <- exp([omega]x) R."""
    geometry = rrr_geometry() if geometry is None else geometry
    _, _, v0, _ = geometry

    def newton(inputs, rot):
        rot = np.array(rot, dtype=float)
        w = elbow_axes(geometry, inputs)
        for _ in range(TRACK_NEWTON_ITERS):
            v = np.einsum("kab,ib->kia", rot, v0)
            g = rrr_closure(geometry, inputs, rot)
            jac = np.cross(v, w)
            ok = np.abs(np.linalg.det(jac)) > 1e-300
            om = np.zeros((len(rot), 3))
            om[ok] = -np.linalg.solve(jac[ok], g[ok][..., None])[..., 0]
            rot = np.einsum("kab,kbc->kac", expmap_many(om), rot)
        return rot, np.abs(rrr_closure(geometry, inputs, rot)).max(axis=1)

    return Tracked(newton, lambda inputs, rot: type2_det(geometry, inputs, rot), 3)


def five_bar_tracked(fb: FiveBar | None = None) -> Tracked:
    """The five-bar with the state the axis C (K, 3); closure g = (C . B - cos bc, C . D - cos dc). Turning C
    by omega (omega perpendicular to C) gives dg = omega . (C x B), omega . (C x D); in a basis of the tangent
    plane the 2 x 2 determinant is ((C x B) x (C x D)) . C = C . (B x D): zero exactly when B, C, D lie on one
    great circle, the tangency of :func:`five_bar_tangency`."""
    fb = five_bar_from_file() if fb is None else fb

    def newton(inputs, c):
        c = np.array(c, dtype=float)
        b, d = five_bar_moving(fb, inputs)
        target = np.array([math.cos(fb.bc), math.cos(fb.dc)])
        for _ in range(TRACK_NEWTON_ITERS):
            g = np.column_stack([np.einsum("ka,ka->k", c, b), np.einsum("ka,ka->k", c, d)]) - target
            # least-norm step in the tangent plane: dc = J^T (J J^T)^-1 (-g), J rows = projected B, D
            pb = b - np.einsum("ka,ka->k", b, c)[:, None] * c
            pd = d - np.einsum("ka,ka->k", d, c)[:, None] * c
            jac = np.stack([pb, pd], axis=1)                                     # (K, 2, 3)
            gram = jac @ np.swapaxes(jac, 1, 2)
            ok = np.abs(np.linalg.det(gram)) > 1e-300
            step = np.zeros_like(c)
            step[ok] = np.einsum("kia,ki->ka", jac[ok], np.linalg.solve(gram[ok], -g[ok][..., None])[..., 0])
            c = c + step
            c = c / np.linalg.norm(c, axis=1, keepdims=True)
        g = np.column_stack([np.einsum("ka,ka->k", c, b), np.einsum("ka,ka->k", c, d)]) - target
        return c, np.abs(g).max(axis=1)

    def det(inputs, c):
        b, d = five_bar_moving(fb, inputs)
        return np.einsum("ka,ka->k", np.asarray(c, dtype=float), np.cross(b, d))

    return Tracked(newton, det, 2)


@dataclass(frozen=True)
class BoxTrack:
    """What :func:`track_box_min_det` found: the smallest |det| over the tracked grid and where (inputs),
    the number of grid points where tracking was lost (residual above TRACK_RESIDUAL_TOL), the number of
    grid edges where det changed sign (a singular crossing between neighbours), and the grid size."""

    min_abs_det: float
    argmin: np.ndarray
    lost: int
    sign_changes: int
    n_points: int


def _axis_grid(lo: float, hi: float, home: float, n: int) -> tuple[np.ndarray, int]:
    """n points from lo to hi plus the home value (sorted, unique), and the index of home."""
    if hi <= lo:
        return np.array([home]), 0
    g = np.unique(np.concatenate([np.linspace(lo, hi, n), [home]]))
    return g, int(np.flatnonzero(g == home)[0])


def track_box_min_det(tracked: Tracked, home, start_state, lo, hi, n: int = 41) -> BoxTrack:
    """Track one assembly from ``home`` over a dense grid of the box [lo, hi] of inputs; report the smallest |det|.

    ``home``, ``lo``, ``hi``: (m,) radians with lo <= home <= hi (lo == hi fixes that input: a plane of a
    3-input mechanism); ``start_state``: the assembly at home (a rotation (3, 3) for the 3-RRR, the axis C (3,)
    for the five-bar), polished by Newton first. The grid has ``n`` points per free axis plus home's value.
    Sweep order: along axis 0 from home (one chain), then from every point reached along axis 1, then axis
    2: every grid point is reached from a neighbour by one Newton solve (a tree of short steps). A box that
    holds a singular input of this assembly shows as a small ``min_abs_det``, a sign change of det between
    neighbours, or lost points (Newton finds no root past a fold).
    """
    home = np.asarray(home, dtype=float)
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    if not (np.all(lo <= home) and np.all(home <= hi)):
        raise ValueError(f"home: expected inside the box [{lo}, {hi}], got {home}")
    grids = [_axis_grid(lo[i], hi[i], home[i], n) for i in range(tracked.n_inputs)]
    state, res = tracked.newton(home[None], np.asarray(start_state, dtype=float)[None])
    shape = tuple(len(g) for g, _ in grids)
    states = np.full(shape + state.shape[1:], np.nan)
    resid = np.full(shape, np.nan)
    idx0 = tuple(h for _, h in grids)
    states[idx0], resid[idx0] = state[0], res[0]
    sign_changes = 0
    mesh = np.stack(np.meshgrid(*[g for g, _ in grids], indexing="ij"), axis=-1)      # shape + (m,)
    for axis in range(tracked.n_inputs):
        g, h = grids[axis]
        for direction in (1, -1):
            for k in range(h, len(g) - 1) if direction == 1 else range(h, 0, -1):
                # the slab reached so far at index k of this axis (earlier axes: all; later axes: home's index)
                src = tuple(slice(None) if a < axis else (k if a == axis else grids[a][1])
                            for a in range(tracked.n_inputs))
                dst = src[:axis] + (k + direction,) + src[axis + 1:]
                x_src, x_dst = mesh[src].reshape(-1, tracked.n_inputs), mesh[dst].reshape(-1, tracked.n_inputs)
                s_src = states[src].reshape((len(x_src),) + state.shape[1:])
                s_new, r_new = tracked.newton(x_dst, s_src)
                states[dst] = s_new.reshape(states[dst].shape)
                resid[dst] = r_new.reshape(resid[dst].shape)
                d0, d1 = tracked.det(x_src, s_src), tracked.det(x_dst, s_new)
                sign_changes += int(np.sum(np.sign(d0) * np.sign(d1) < 0))
    mesh = mesh.reshape(-1, tracked.n_inputs)
    flat = states.reshape((len(mesh),) + state.shape[1:])
    good = resid.reshape(-1) <= TRACK_RESIDUAL_TOL
    dets = np.abs(tracked.det(mesh[good], flat[good])) if good.any() else np.array([np.inf])
    k = int(np.argmin(dets))
    return BoxTrack(float(dets[k]), mesh[good][k] if good.any() else home, int((~good).sum()), sign_changes,
                    len(mesh))


# ---------------------------------------------------------------- 5. cusps of general_3rrr (three assemblies meet)

#: At a cusp input three of the oracle's roots coincide (a triple root); rounding spreads a triple root over
#: ~eps^(1/3) ~ 1e-5 (measured 3e-6..2e-5 at general_3rrr's cusps), a double root (a fold) over ~1e-8, and a
#: simple one not at all. A triple of roots within this of each other is a triple root: far above the rounding
#: floor, far below the spread at a fold (the third root is >= ~1e-2 away there) or 1e-3 away from a cusp
#: (three roots ~(1e-3)^(1/2) apart: >= 3e-2).
CUSP_SPREAD = 1e-4
#: Grid points of the scan whose spread is below this are local-minimum candidates refined by Nelder-Mead (the
#: spread grows fast away from a cusp: ~0.06 at 1e-4, ~0.28 at 1e-2, measured on general_3rrr).
CUSP_SCAN_SPREAD = 0.35


def triple_root_spread(inputs, geometry=None) -> np.ndarray:
    """(K,): for each input (K, 3) (radians), the smallest diameter of a triple of the degree-8 oracle's eight
    roots (complex, real or not; the distance of two roots p, q: sqrt(1 - |<p, q>|^2) of the unit vectors, the
    sine of their angle, so q and -q, and complex multiples, are one root). Near 0 (CUSP_SPREAD) exactly at a
    triple root, i.e. a cusp input; at a fold only two roots meet and the triple's diameter stays large."""
    from itertools import combinations

    from references.peers_closed_form import candidate_points_many, quadrics_many

    geometry = rrr_geometry() if geometry is None else geometry
    _, _, v0, alpha2 = geometry
    inputs = np.atleast_2d(np.asarray(inputs, dtype=float))
    pts, ok = candidate_points_many(quadrics_many(elbow_axes(geometry, inputs), v0, np.cos(alpha2)))
    if not ok.all():
        raise ValueError(f"inputs: the degree-8 oracle is degenerate at {inputs[~ok][:3]}")
    p = pts / np.linalg.norm(pts, axis=2, keepdims=True)
    gram = np.abs(np.einsum("kia,kja->kij", np.conj(p), p))
    d = np.sqrt(np.clip(1.0 - gram ** 2, 0.0, None))                                # (K, 8, 8)
    trip = np.array(list(combinations(range(8), 3)))
    diam = np.maximum.reduce([d[:, trip[:, 0], trip[:, 1]], d[:, trip[:, 0], trip[:, 2]], d[:, trip[:, 1], trip[:, 2]]])
    return diam.min(axis=1)


def cusps_in_square(square, beta3: float = 0.5, n: int = 41, geometry=None) -> np.ndarray:
    """The cusp inputs (M, 2) of general_3rrr in the square ((x0, x1), (y0, y1)) of the plane beta3 = const:
    the spread (:func:`triple_root_spread`) on an n x n grid, each grid local minimum below CUSP_SCAN_SPREAD
    refined by Nelder-Mead on log(spread) (scipy), kept when the spread there is below CUSP_SPREAD and the
    point is inside the square; duplicates (within 1e-6) merged. A cusp closer than a grid step to another
    may be missed: use a square around the cusps of interest."""
    from scipy.optimize import minimize

    geometry = rrr_geometry() if geometry is None else geometry
    (x0, x1), (y0, y1) = square
    xs, ys = np.linspace(x0, x1, n), np.linspace(y0, y1, n)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    grid = np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, beta3)])
    s = triple_root_spread(grid, geometry).reshape(n, n)
    padded = np.pad(s, 1, constant_values=np.inf)
    neigh = np.min([padded[1 + a:n + 1 + a, 1 + b:n + 1 + b] for a in (-1, 0, 1) for b in (-1, 0, 1)
                    if (a, b) != (0, 0)], axis=0)
    out = []
    for i, j in zip(*np.nonzero((s <= neigh) & (s < CUSP_SCAN_SPREAD))):
        f = lambda p: float(np.log(triple_root_spread([[p[0], p[1], beta3]], geometry)[0] + 1e-300))
        res = minimize(f, [xs[i], ys[j]], method="Nelder-Mead",
                       options={"xatol": 1e-11, "fatol": 1e-9, "maxiter": 4000, "initial_simplex":
                                [[xs[i], ys[j]], [xs[i] + 0.5 * (xs[1] - xs[0]), ys[j]], [xs[i], ys[j] + 0.5 * (ys[1] - ys[0])]]})
        x, y = res.x
        if math.exp(res.fun) < CUSP_SPREAD and x0 <= x <= x1 and y0 <= y <= y1:
            if all(math.hypot(x - a, y - b) > 1e-6 for a, b in out):
                out.append((float(x), float(y)))
    return np.array(out).reshape(-1, 2)


# ---------------------------------------------------------------- the agile eye's singular curve
def agile_t(b1, b2, b3):
    """T(beta) = cos b1 cos b2 cos b3 + sin b1 sin b2 sin b3: the agile eye's (examples/gosselin.toml) Type-2
    determinant at a stationary orientation, shared in absolute value by all its assemblies (derived with
    sympy in tests/test_singular_agile.py); its singular set in a plane of inputs is T = 0."""
    return np.cos(b1) * np.cos(b2) * np.cos(b3) + np.sin(b1) * np.sin(b2) * np.sin(b3)


def agile_curve_points(square, b3: float, n: int = 400) -> np.ndarray:
    """Points (M, 2) of T = 0 in the square ((x0, x1), (y0, y1)) of the plane beta3 = b3: for b1 on a grid of n,
    tan b2 = -cos b1 cos b3 / (sin b1 sin b3), every branch (b2 + k pi) inside the square."""
    (x0, x1), (y0, y1) = square
    b1 = np.linspace(x0, x1, n)
    b2 = np.arctan2(-np.cos(b1) * math.cos(b3), np.sin(b1) * math.sin(b3))
    pts = np.array([(a, c + k * math.pi) for a, c in zip(b1, b2) for k in (-2, -1, 0, 1, 2)])
    return pts[(pts[:, 1] >= y0) & (pts[:, 1] <= y1)]


# ---------------------------------------------------------------- 6. six-bars with a ternary ground and plate (issue 40)
#
# Three chains join the ground to the plate: C1 = J1 (ground-link1), J2 (link1-plate); C2 = J3 (ground-link2),
# J4 (link2-plate); C3 = J5 (ground-crank), J6 (crank-conn), J7 (conn-plate). A link's rotation is the product of
# Rot(axis, reading) along its chain from the ground (the file's convention), so a joint [a, b]'s current axis
# is R_a axis = R_b axis, and a binary link keeps the arc between its two joints' current axes.
#
# With the input on C3 the plate turns as Rot(a1, th1) Rot(a2, th2) (C1 free) and each of C2 and C3 is one
# equation u . R v = k in (th1, th2): :func:`dyad_pair_eliminant` gives a degree-8 polynomial in tan(th1 / 2)
# whose real roots are the assemblies. With the input on C1 (or C2) that chain and the other 2R chain are a
# four-bar (A + B cos th + C sin th = 0: 0 or 2 solutions) and C3's crank-conn dyad reaches the plate's J7
# where two circles meet (0 or 2): the count is the sum.

#: The issue's six-bar: joint -> (polar, azimuth) in degrees, and its links; J5 is the input of the report.
ISSUE40_AXES_DEG = {"J1": (20, 0), "J2": (55, 30), "J3": (35, 140), "J4": (70, 110), "J5": (40, 260),
                    "J6": (75, 230), "J7": (85, 170)}
TERNARY_SIX_BAR_LINKS = {"J1": ("ground", "link1"), "J2": ("link1", "plate"), "J3": ("ground", "link2"),
                         "J4": ("link2", "plate"), "J5": ("ground", "crank"), "J6": ("crank", "conn"),
                         "J7": ("conn", "plate")}


def polar_axes(degrees: dict) -> dict[str, np.ndarray]:
    """name -> unit axis from (polar, azimuth) in degrees."""
    out = {}
    for name, (p, a) in degrees.items():
        p, a = math.radians(p), math.radians(a)
        out[name] = np.array([math.sin(p) * math.cos(a), math.sin(p) * math.sin(a), math.cos(p)])
    return out


def ternary_six_bar_toml(ax: dict, actuated: str, name: str = "six-bar") -> str:
    """A kind "graph" file of the six-bar of this section with axes ``ax`` (name -> (3,)) and ``actuated`` driven."""
    text = f'kind = "graph"\nname = "{name}"\nground = "ground"\noutput = "plate"\n'
    for joint, (a, b) in TERNARY_SIX_BAR_LINKS.items():
        v = ", ".join(repr(float(x)) for x in ax[joint])
        text += f'\n[[joints]]\nname = "{joint}"\nlinks = ["{a}", "{b}"]\naxis = [{v}]\n'
        text += "actuated = true\n" if joint == actuated else ""
    return text


def dyad_pair_eliminant(f, g, constraints, phi0: float) -> np.ndarray:
    """Coefficients (highest first, numpy.roots order) of h(t), t = tan((phi - phi0) / 2), whose real roots
    are the phi of the solutions (phi, psi) of u_i . Rot(f, phi) Rot(g, psi) v_i = k_i, i = 1, 2
    (``constraints`` = ((u1, v1, k1), (u2, v2, k2))). Each equation is a_i + b_i cos psi + c_i sin psi = 0 with
    a_i, b_i, c_i of degree 2 in t once multiplied by 1 + t^2; eliminating psi (Cramer, cos^2 + sin^2 = 1):
    h = (a2 c1 - a1 c2)^2 + (a1 b2 - a2 b1)^2 - (b1 c2 - b2 c1)^2, degree 8."""
    f, g = np.asarray(f, float), np.asarray(g, float)

    def circle(axis, v):                 # Rot(axis, x) v = v0 + cos x v1 + sin x v2
        v0 = (axis @ v) * axis
        return v0, v - v0, np.cross(axis, v)

    def poly(w0, w1, w2):                # (1 + t^2) (w0 + cos phi w1 + sin phi w2), phi = phi0 + 2 atan t
        c, s = math.cos(phi0), math.sin(phi0)
        p1 = c * w1 + s * w2             # times cos u; (1 + t^2) cos u = 1 - t^2, (1 + t^2) sin u = 2t
        p2 = -s * w1 + c * w2            # times sin u
        return [w0 + p1, 2 * p2, w0 - p1]   # coefficients of 1, t, t^2

    out = []
    for u_, v_, k in constraints:
        # u . Rot(f, phi) Rot(g, psi) v - k = (Rot(f, -phi) u) . (v0 + cos psi v1 + sin psi v2) - k
        parts = circle(g, np.asarray(v_, float))
        w0, w1, w2 = circle(f, np.asarray(u_, float))   # Rot(f, -phi) u = w0 + cos phi w1 - sin phi w2
        wp = poly(w0, w1, -w2)
        coef = []
        for j, pj in enumerate(parts):
            cj = [float(wk @ pj) for wk in wp]
            if j == 0:
                cj = [cj[0] - k, cj[1], cj[2] - k]      # - k (1 + t^2)
            coef.append(np.polynomial.Polynomial(cj))
        out.append(coef)
    (a1, b1, c1), (a2, b2, c2) = out
    h = (a2 * c1 - a1 * c2) ** 2 + (a1 * b2 - a2 * b1) ** 2 - (b1 * c2 - b2 * c1) ** 2
    return h.coef[::-1]


#: A root of an eliminant (companion eigenvalue) is real when its imaginary part is below this (relative to
#: 1 + |t|): near a merging pair the parts grow like sqrt(distance to the fold), so a count is wrong only
#: within ~1e-14 rad of a fold; rounding of well separated roots stays ~1e-12.
REAL_ROOT_TOL = 1e-7


def real_root_count(coefficients) -> int:
    """Real roots of a polynomial (highest first), by REAL_ROOT_TOL."""
    roots = np.roots(coefficients)
    return int(np.sum(np.abs(roots.imag) < REAL_ROOT_TOL * (1.0 + np.abs(roots))))


def _cos_sin_roots(a: float, b: float, c: float) -> list[float]:
    """The th in (-pi, pi] with a + b cos th + c sin th = 0 (0 or 2; a tangency counts as none or two by
    rounding, which the bisection of count changes steps over)."""
    r = math.hypot(b, c)
    if abs(a) > r:
        return []
    h = math.acos(-a / r)
    return [math.atan2(c, b) + h, math.atan2(c, b) - h]


def ternary_six_bar_count(ax: dict, joint: str, x: float, phi0: float = 0.3) -> int:
    """Assemblies of the six-bar of this section (axes ``ax``) with ``joint`` driven at reading ``x`` (radians)."""
    a = {n: np.asarray(v, float) for n, v in ax.items()}
    if joint in ("J5", "J6", "J7"):
        c2 = (a["J3"], a["J4"], float(a["J3"] @ a["J4"]))
        if joint == "J5":                # conn keeps arc(J6, J7): J6 at Rot(a5, x) a6
            c3 = (rodrigues(a["J5"], x) @ a["J6"], a["J7"], float(a["J6"] @ a["J7"]))
        elif joint == "J6":              # crank + conn one body: arc(J5, J7 in it) fixed by x
            c3 = (a["J5"], a["J7"], float(a["J5"] @ rodrigues(a["J6"], x) @ a["J7"]))
        else:                            # conn + plate one body: J6's axis in the plate's frame is Rot(a7, -x) a6
            c3 = (a["J5"], rodrigues(a["J7"], -x) @ a["J6"], float(a["J5"] @ a["J6"]))
        return real_root_count(dyad_pair_eliminant(a["J1"], a["J2"], (c2, c3), phi0))
    # the input on C1 or C2: that chain (p, q) and the other 2R chain (u, v) form a four-bar
    (p, q), (u, v) = (("J1", "J2"), ("J3", "J4")) if joint in ("J1", "J2") else (("J3", "J4"), ("J1", "J2"))
    k = float(a[u] @ a[v])
    rotations = []
    if joint in ("J1", "J3"):            # R = Rot(a_p, x) Rot(a_q, th): u . R v = k in th
        w = rodrigues(a[p], -x) @ a[u]
        v0 = (a[q] @ a[v]) * a[q]
        for th in _cos_sin_roots(float(w @ v0) - k, float(w @ (a[v] - v0)), float(w @ np.cross(a[q], a[v]))):
            rotations.append(rodrigues(a[p], x) @ rodrigues(a[q], th))
    else:                                # R = Rot(a_p, th) Rot(a_q, x): u . Rot(a_p, th) v' = k, v' = Rot(a_q, x) v
        vv = rodrigues(a[q], x) @ a[v]
        v0 = (a[p] @ vv) * a[p]
        # u . Rot(a_p, th) vv = u . (v0 + cos th (vv - v0) + sin th (a_p x vv))
        for th in _cos_sin_roots(float(a[u] @ v0) - k, float(a[u] @ (vv - v0)), float(a[u] @ np.cross(a[p], vv))):
            rotations.append(rodrigues(a[p], th) @ rodrigues(a[q], x))
    n = 0
    for rot in rotations:                # the crank-conn dyad reaches the plate's J7: J6 on two circles
        n += 0 if _circle_intersections(a["J5"], arc(a["J5"], a["J6"]), rot @ a["J7"],
                                        arc(a["J6"], a["J7"])) is None else 2
    return n


#: Bisection of a count change stops at this width (radians of input).
CHANGE_BISECT_TOL = 1e-12


def count_changes(count, lo: float, hi: float, n: int, tol: float = CHANGE_BISECT_TOL) -> np.ndarray:
    """The inputs in [lo, hi] where ``count`` (input -> int) changes: n samples, each change bisected to ``tol``."""
    xs = np.linspace(lo, hi, n)
    ks = [count(x) for x in xs]
    out = []
    for x0, x1, k0, k1 in zip(xs[:-1], xs[1:], ks[:-1], ks[1:]):
        if k0 == k1:
            continue
        while x1 - x0 > tol:
            m = 0.5 * (x0 + x1)
            if count(m) == k0:
                x0 = m
            else:
                x1 = m
        out.append(0.5 * (x0 + x1))
    return np.array(out)
