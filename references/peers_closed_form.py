"""Direct kinematics of a 3-RRR from its geometry alone: quaternion quadrics and a degree-8 eigen solver.

numpy only (imported by ``bench_peers.py`` and by its whole-process timing), and independent of
spherekin's loop equations: everything is rebuilt from the four lists of the 3-RRR description
(u_i, w_i^0, v_i^0, alpha2_i; see ``spherekin/mechanism/rrr.py``) and the actuator inputs beta_i.

The pose. A quaternion q = (q0, qx, qy, qz) gives the rotation
    R(q) |q|^2 = (q0^2 - |qv|^2) I + 2 qv qv^T + 2 q0 [qv]x,
with v_i = R v_i^0. Leg i closes when its elbow axis w_i(beta_i) = Rot(u_i, beta_i) w_i^0 makes the
distal link angle with the platform axis: w_i . (R v_i^0) = cos(alpha2_i). Multiplied by |q|^2 this
is a *homogeneous* quadric q^T A_i q = 0 (:func:`leg_quadrics`), and three quadrics in P^3 meet in
2^3 = 8 points (Bezout): the 8 assembly modes, the "degree 8" of the 3-RRR direct kinematics.
Adding |q|^2 = 1 gives the square system of 4 equations in 4 unknowns (16 roots, q and -q alike)
that ``bench_peers.py`` hands to PHCpack.

The solver (:func:`solve_quadrics`). The roots are the eigenvalues of an 8 x 8 matrix, i.e. the
roots of its characteristic polynomial, a univariate polynomial of degree 8 (the classical
resultant of the 3-RRR, Gosselin-Sefrioui-Richard 1994), reached here by linear algebra instead
of symbolic elimination so that no coefficient is formed by hand:

1. the Macaulay matrix of degree 4: every quadric times every monomial of degree 2 (30 rows) over
   the 35 monomials of degree 4 in q; a complete intersection of three quadrics in P^3 has
   regularity 3, so at degree 4 the null space has dimension exactly 8 (one evaluation vector
   m4(p) per root p);
2. in that null space N, the rows of the monomials (degree 3) x h(q) for two random linear forms
   h0, h1 give H0 N and H1 N with H1 N y = lambda H0 N y for lambda = h1(p)/h0(p): an 8 x 8
   eigenproblem (least-squares reduced), whose eigenvectors give m3(p) and hence p;
3. each real root is polished by two Gauss-Newton steps on the quadrics plus |q|^2 = 1 (the
   eigenvectors are accurate to ~1e-10; spherekin polishes its roots too).

Real roots: a root is real when, scaled so that its largest coordinate is 1, its imaginary parts
are below :data:`REAL_TOL`. Poses are rotation matrices (q and -q give the same one).
"""

from __future__ import annotations

import itertools
import math

import numpy as np

__all__ = ["REAL_TOL", "NULL_GAP", "POLISH_STEPS", "MONOMIALS", "rodrigues", "elbow_axis", "leg_quadrics",
           "quaternion_rotation", "rotation_quaternion", "leg_residuals", "candidate_points", "solve_quadrics", "direct_kinematics",
           "geometry_of", "quadrics_many", "candidate_points_many", "real_roots_many"]

#: A root of the eigenproblem is real when the imaginary part of its coordinates (scaled so that
#: the largest is 1) is below this. Reason: eigenvectors of the 8 x 8 problem carry errors of
#: ~1e-10 on a well-separated real root, while a complex root of a generic problem has imaginary
#: parts of order 1e-2 or more; 1e-6 separates the two by orders of magnitude either side.
REAL_TOL = 1e-6
#: The Macaulay matrix must have a clear gap below its 27th singular value (rank 27 = 35 - 8).
#: Reason: a smaller ratio s_27 / s_26 means roots at a (near) positive-dimensional degeneracy,
#: where the eigenproblem is not trustworthy; the solver then says so instead of guessing.
NULL_GAP = 1e-8
#: Gauss-Newton steps polishing each real root; 2 take a 1e-10 root to machine precision.
POLISH_STEPS = 2
#: Seed of the two random linear forms h0, h1 (fixed: results are reproducible).
FORMS_SEED = 20240611

#: Exponent tuples of the monomials of degree 4 and 3 in (q0, qx, qy, qz), in a fixed order.
MONOMIALS = {d: [e for e in itertools.product(range(d + 1), repeat=4) if sum(e) == d] for d in (2, 3, 4)}
_INDEX = {d: {e: k for k, e in enumerate(MONOMIALS[d])} for d in MONOMIALS}


def rodrigues(axis, angle: float) -> np.ndarray:
    """Right-handed rotation by ``angle`` (radians) about the unit vector ``axis``."""
    a = np.asarray(axis, dtype=float)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * (k @ k)


def elbow_axis(u, w0, beta: float) -> np.ndarray:
    """w(beta) = Rot(u, beta) w^0: the elbow axis of a leg at actuator reading beta."""
    return rodrigues(u, beta) @ np.asarray(w0, dtype=float)


def geometry_of(mech) -> tuple:
    """(u, w0, v0, alpha2) of a spherekin 3-RRR (its ``geometry``), as float arrays."""
    g = getattr(mech, "geometry", None)
    if g is None or not hasattr(g, "distal_link_angles"):
        raise ValueError(f"mech: expected a 3-RRR built by spherekin.mechanism.three_rrr, got {mech!r}")
    return (np.array(g.base_axes, dtype=float), np.array(g.elbow_axes_at_zero, dtype=float),
            np.array(g.platform_axes, dtype=float), np.array(g.distal_link_angles, dtype=float))


def leg_quadrics(geometry, inputs) -> np.ndarray:
    """Symmetric 4 x 4 matrices A_i with q^T A_i q = |q|^2 (w_i . R(q) v_i^0 - cos alpha2_i), shape (3, 4, 4).

    Expanding R(q)|q|^2 (module docstring): w . R v |q|^2 = (q0^2 - |qv|^2)(w . v) + 2 (w . qv)(v . qv)
    + 2 q0 qv . (v x w).
    """
    u, w0, v0, alpha2 = geometry
    if len(inputs) != 3:
        raise ValueError(f"inputs: expected 3 actuator angles (radians), got {inputs!r}")
    out = np.zeros((3, 4, 4))
    for i in range(3):
        w = elbow_axis(u[i], w0[i], float(inputs[i]))
        v = v0[i]
        c = math.cos(alpha2[i])
        wv = float(w @ v)
        a = out[i]
        a[0, 0] = wv - c
        a[1:, 1:] = (np.outer(w, v) + np.outer(v, w)) - (wv + c) * np.eye(3)
        a[0, 1:] = a[1:, 0] = np.cross(v, w)
    return out


def quaternion_rotation(q) -> np.ndarray:
    """R(q) for a (not necessarily unit) real quaternion q = (q0, qx, qy, qz)."""
    q = np.asarray(q, dtype=float)
    q0, qv = q[0], q[1:]
    k = np.array([[0.0, -qv[2], qv[1]], [qv[2], 0.0, -qv[0]], [-qv[1], qv[0], 0.0]])
    return ((q0 * q0 - qv @ qv) * np.eye(3) + 2 * np.outer(qv, qv) + 2 * q0 * k) / (q @ q)


def rotation_quaternion(rot) -> np.ndarray:
    """A unit quaternion q with R(q) = rot (q0 >= 0; Shepperd's method, well conditioned)."""
    r = np.asarray(rot, dtype=float)
    tr = np.trace(r)
    cand = np.array([1 + tr, 1 + 2 * r[0, 0] - tr, 1 + 2 * r[1, 1] - tr, 1 + 2 * r[2, 2] - tr])
    k = int(np.argmax(cand))
    q = np.empty(4)
    q[k] = 0.5 * math.sqrt(cand[k])
    s = 0.25 / q[k]
    if k == 0:
        q[1:] = s * np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    elif k == 1:
        q[0], q[2], q[3] = s * (r[2, 1] - r[1, 2]), s * (r[0, 1] + r[1, 0]), s * (r[0, 2] + r[2, 0])
    elif k == 2:
        q[0], q[1], q[3] = s * (r[0, 2] - r[2, 0]), s * (r[0, 1] + r[1, 0]), s * (r[1, 2] + r[2, 1])
    else:
        q[0], q[1], q[2] = s * (r[1, 0] - r[0, 1]), s * (r[0, 2] + r[2, 0]), s * (r[1, 2] + r[2, 1])
    return q if q[0] >= 0 else -q


def leg_residuals(geometry, inputs, rot) -> np.ndarray:
    """|w_i(beta_i) . (R v_i^0) - cos alpha2_i| per leg: zero exactly when the pose R assembles."""
    u, w0, v0, alpha2 = geometry
    rot = np.asarray(rot, dtype=float)
    return np.array([abs(float(elbow_axis(u[i], w0[i], float(inputs[i])) @ (rot @ v0[i])) - math.cos(alpha2[i]))
                     for i in range(3)])


# The quadric q^T A q = sum over pairs i <= j of mult_ij A_ij q_i q_j (mult 1 on the diagonal, else 2).
_PAIRS = [(i, j) for i in range(4) for j in range(i, 4)]
_PI, _PJ = np.array(_PAIRS).T
_MULT = np.where(_PI == _PJ, 1.0, 2.0)
# _MAC_COL[p, m]: column (degree-4 monomial) of the product of pair p with degree-2 monomial m.
_MAC_COL = np.array([[_INDEX[4][tuple(m[t] + (t == i) + (t == j) for t in range(4))] for m in MONOMIALS[2]]
                     for i, j in _PAIRS])


def _macaulay(quadrics: np.ndarray) -> np.ndarray:
    """Rows: each quadric times each monomial of degree 2 (30); columns: the 35 monomials of degree 4."""
    coef = quadrics[:, _PI, _PJ] * _MULT                       # (3, 10 pairs)
    mac = np.zeros((3, len(MONOMIALS[2]), len(MONOMIALS[4])))
    rows = np.arange(len(MONOMIALS[2]))
    for p in range(len(_PAIRS)):                               # pair p lands in a distinct column per row
        mac[:, rows, _MAC_COL[p]] = coef[:, p, None]
    return mac.reshape(-1, len(MONOMIALS[4]))


# Shift matrices: S[k] picks, from a degree-4 evaluation vector, the entries m3 * q_k (degree 3 m3).
_SHIFT = np.zeros((4, len(MONOMIALS[3]), len(MONOMIALS[4])))
for _k in range(4):
    for _r, _m in enumerate(MONOMIALS[3]):
        _e = list(_m)
        _e[_k] += 1
        _SHIFT[_k, _r, _INDEX[4][tuple(_e)]] = 1.0
_rng = np.random.default_rng(FORMS_SEED)
_SHIFT_H0, _SHIFT_H1 = (np.tensordot(_rng.normal(size=4), _SHIFT, 1) for _ in range(2))
# rows of m3 monomials q_a^2 q_k (a, k = 0..3), to read a root off its m3 vector
_CUBE_ROWS = np.array([[_INDEX[3][tuple(2 * (j == a) + (j == k) for j in range(4))] for k in range(4)]
                       for a in range(4)])


def _polish(quadrics: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Newton steps on (q^T A_i q, |q|^2 - 1) for a stack of roots q, shape (r, 4)."""
    for _ in range(POLISH_STEPS):
        aq = np.einsum("kij,rj->rki", quadrics, q)                      # (r, 3, 4): A_k q
        f = np.concatenate([np.einsum("rki,ri->rk", aq, q), (q * q).sum(1, keepdims=True) - 1.0], axis=1)
        jac = 2.0 * np.concatenate([aq, q[:, None, :]], axis=1)          # (r, 4, 4)
        q = q - np.linalg.solve(jac, f[..., None])[..., 0]
    return q


def candidate_points(quadrics: np.ndarray) -> np.ndarray:
    """Every root of three quadrics, real or complex, from the eigenproblem: shape (8, 4) complex,
    each scaled so that its largest coordinate is 1 (steps 1-2 of the module docstring; not polished).
    Raises ValueError as :func:`solve_quadrics`.
    """
    mac = _macaulay(quadrics)
    _, sv, vt = np.linalg.svd(mac)
    rank = len(MONOMIALS[4]) - 8
    if sv[rank] > NULL_GAP * sv[0] or sv[rank - 1] < NULL_GAP * sv[0]:
        raise ValueError(
            f"quadrics: the degree-4 Macaulay matrix has no clear 8-dimensional null space "
            f"(singular values {sv[rank - 1]:.2e}, {sv[rank]:.2e} around rank {rank}, largest {sv[0]:.2e}): "
            "the direct kinematics is degenerate (roots not isolated)"
        )
    null = vt[rank:].T                                   # 35 x 8
    h0 = _SHIFT_H0 @ null                                # 20 x 8: rows m3 * h0
    h1 = _SHIFT_H1 @ null
    b = np.linalg.lstsq(h0, h1, rcond=None)[0]           # 8 x 8: b y = lambda y, lambda = h1/h0 at a root
    _, vecs = np.linalg.eig(b)
    m3 = h0 @ vecs                                       # column r ~ m3(p_r)
    cubes = m3[_CUBE_ROWS]                               # (4, 4, 8): [a, k, r] ~ p_a^2 p_k
    diag = np.abs(cubes[np.arange(4), np.arange(4)])     # (4, 8): |p_a^3|
    pts = cubes[np.argmax(diag, axis=0), :, np.arange(vecs.shape[1])]   # (8, 4), ~ p_a^2 * p
    return pts / pts[np.arange(len(pts)), np.argmax(np.abs(pts), axis=1)][:, None]


def solve_quadrics(quadrics: np.ndarray) -> tuple[np.ndarray, int]:
    """Real unit quaternions of three quadrics, one of each pair +-q (first non-negligible entry > 0).

    Returns (real roots, shape (r, 4); the number of roots of the eigenproblem, real or complex:
    8 generically). Raises ValueError when the Macaulay matrix has no clear 8-dimensional null
    space (a degenerate geometry whose roots are not isolated).
    """
    pts = candidate_points(quadrics)
    real = pts[np.abs(pts.imag).max(axis=1) <= REAL_TOL].real
    if len(real) == 0:
        return np.zeros((0, 4)), len(pts)
    q = real / np.linalg.norm(real, axis=1, keepdims=True)
    q = _polish(quadrics, q)
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    lead = q[np.arange(len(q)), np.argmax(np.abs(q) > 1e-12, axis=1)]
    return q * np.sign(lead)[:, None], len(pts)


def direct_kinematics(geometry, inputs) -> list[np.ndarray]:
    """Every real platform pose R (v_i = R v_i^0) of the 3-RRR at actuator inputs (radians)."""
    roots, _ = solve_quadrics(leg_quadrics(geometry, inputs))
    return [quaternion_rotation(q) for q in roots]


# ---------------------------------------------------------------- many inputs at once (the floor of bench_engine)

def quadrics_many(w, v0, cosines) -> np.ndarray:
    """The quadrics of :func:`leg_quadrics` for a stack of inputs: q^T A q = |q|^2 (w . R(q) v0 - c).

    ``w``: the base-side axes (K, 3, 3) (elbow axes w_i(beta_i) of a base-actuated 3-RRR; base axes
    u_i when the elbows are actuated), ``v0``: the platform axes (3, 3) in the platform frame,
    ``cosines``: (K, 3) or (3,) the cosine of the angle each pair must make. Returns (K, 3, 4, 4).
    """
    w = np.asarray(w, dtype=float)
    v = np.broadcast_to(np.asarray(v0, dtype=float), w.shape)
    c = np.broadcast_to(np.asarray(cosines, dtype=float), w.shape[:2])
    wv = np.einsum("kij,kij->ki", w, v)
    out = np.zeros(w.shape[:2] + (4, 4))
    out[..., 0, 0] = wv - c
    out[..., 1:, 1:] = (w[..., :, None] * v[..., None, :] + v[..., :, None] * w[..., None, :]
                        - (wv + c)[..., None, None] * np.eye(3))
    out[..., 0, 1:] = out[..., 1:, 0] = np.cross(v, w)
    return out


def candidate_points_many(quadrics: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`candidate_points` of a stack of quadric triples (K, 3, 4, 4) at once, no loop over K.

    Returns (points (K, 8, 4) complex, each scaled so that its largest coordinate is 1; ok (K,) bool:
    False where the Macaulay matrix has no clear 8-dimensional null space, whose points are then
    meaningless, where the per-input function raises).
    """
    quadrics = np.asarray(quadrics, dtype=float)
    k = len(quadrics)
    n2, n4 = len(MONOMIALS[2]), len(MONOMIALS[4])
    coef = quadrics[:, :, _PI, _PJ] * _MULT                    # (K, 3, 10 pairs)
    mac = np.zeros((k, 3, n2, n4))
    rows = np.arange(n2)
    for p in range(len(_PAIRS)):                               # 10 pairs: a loop over the formula, not the inputs
        mac[:, :, rows, _MAC_COL[p]] = coef[:, :, p, None]
    _, sv, vt = np.linalg.svd(mac.reshape(k, 3 * n2, n4))
    rank = n4 - 8
    ok = (sv[:, rank] <= NULL_GAP * sv[:, 0]) & (sv[:, rank - 1] >= NULL_GAP * sv[:, 0])
    null = np.swapaxes(vt[:, rank:], 1, 2)                      # (K, 35, 8)
    h0, h1 = _SHIFT_H0 @ null, _SHIFT_H1 @ null                  # (K, 20, 8)
    b = np.linalg.pinv(h0) @ h1                                  # least squares, as lstsq per input
    _, vecs = np.linalg.eig(b)
    m3 = h0 @ vecs                                               # (K, 20, 8)
    cubes = m3[:, _CUBE_ROWS]                                    # (K, 4, 4, 8): [., a, k, r] ~ p_a^2 p_k
    diag = np.abs(cubes[:, np.arange(4), np.arange(4)])          # (K, 4, 8)
    best = np.argmax(diag, axis=1)                               # (K, 8)
    pts = cubes[np.arange(k)[:, None], best, :, np.arange(8)[None, :]]   # (K, 8, 4)
    big = np.take_along_axis(pts, np.argmax(np.abs(pts), axis=2)[..., None], axis=2)
    return pts / big, ok


def real_roots_many(quadrics: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The real roots of a stack of quadric triples (K, 3, 4, 4), as :func:`solve_quadrics` per input.

    Returns (quaternions (K, 8, 4): unit, polished by POLISH_STEPS Newton steps where real, NaN
    elsewhere; real (K, 8) bool; ok (K,) bool as :func:`candidate_points_many`). The number of
    real roots of input k is ``real[k].sum()``.
    """
    quadrics = np.asarray(quadrics, dtype=float)
    pts, ok = candidate_points_many(quadrics)
    real = (np.abs(pts.imag).max(axis=2) <= REAL_TOL) & ok[:, None]
    q = pts.real / np.linalg.norm(pts.real, axis=2, keepdims=True)
    for _ in range(POLISH_STEPS):                                # Newton on every point, real ones kept
        aq = np.einsum("kaij,krj->krai", quadrics, q)             # (K, 8, 3, 4): A_a q
        f = np.concatenate([np.einsum("krai,kri->kra", aq, q), (q * q).sum(2, keepdims=True) - 1.0], axis=2)
        jac = 2.0 * np.concatenate([aq, q[:, :, None, :]], axis=2)   # (K, 8, 4, 4)
        solvable = np.abs(np.linalg.det(jac)) > 0
        step = np.zeros_like(q)
        step[solvable] = np.linalg.solve(jac[solvable], f[solvable][..., None])[..., 0]
        q = q - step
    q = q / np.linalg.norm(q, axis=2, keepdims=True)
    return np.where(real[..., None], q, np.nan), real, ok
