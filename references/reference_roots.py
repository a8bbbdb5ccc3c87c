"""An independent reference for the direct kinematics of a 3-RRR near its singularities: 50 digits.

Independent of spherekin's loop equations and solver: the leg constraints
w_i(beta_i) . (R(q) v_i^0) = cos(alpha2_i) as homogeneous quadrics q^T A_i q = 0 in the quaternion q
(:mod:`references.peers_closed_form`, from the four lists u, w0, v0, alpha2 of the 3-RRR), here
rebuilt in mpmath at :data:`DIGITS` digits from the same floats. The roots:

1. the degree-8 eigenproblem of :func:`references.peers_closed_form.candidate_points` gives the 8
   projective roots, real or complex, to ~1e-10 (worse next to a double root);
2. each is polished by complex Newton on (q^T A_i q = 0, q . q = 1) in mpmath until the step is
   below 10^-(DIGITS - 10); a projective root is one pair +-q;
3. distinct roots: two polished roots closer than :data:`SAME_ROOT` (up to sign) are one; when fewer
   than 8 distinct roots remain (two eigen-candidates fell on the same root next to a fold), Newton
   is restarted from small complex perturbations of the roots found, until 8 are distinct (the
   Bezout number of three quadrics in P^3, attained by every geometry whose roots are isolated);
4. a root is real when its imaginary parts are below :data:`REAL_IMAG` (real roots have exactly 0
   up to the working precision; a complex pair next to a fold has imaginary parts ~sqrt of the
   distance to the singular input, 1e-8 at 1e-16);

so the number of real roots is decided at 50 digits even 1e-12 from a singular input, where the
two roots of a pair are ~1e-6 apart. :func:`singular_input` finds, by bisection on that count,
the input where the count changes along a segment of inputs.
"""

from __future__ import annotations

from dataclasses import dataclass

import mpmath
import numpy as np

from references.peers_closed_form import candidate_points, leg_quadrics, quaternion_rotation

__all__ = ["DIGITS", "REAL_IMAG", "SAME_ROOT", "Reference", "reference_roots", "singular_input", "near_singular_inputs",
           "leg_quadric_mp", "quadric_system_mp", "same_root"]

#: Working precision (decimal digits) of the polishing.
DIGITS = 50
#: A polished root is real when every imaginary part is below this: real roots polish to ~1e-40
#: imaginary parts (complex Newton from a real start stays real up to rounding); a complex pair at
#: 1e-16 from a fold has ~1e-8.
REAL_IMAG = mpmath.mpf("1e-30")
#: Polished roots closer than this (max norm, up to sign) are one root: polished roots agree to
#: ~1e-40; the two roots of a pair 1e-14 from a fold are ~1e-7 apart.
SAME_ROOT = mpmath.mpf("1e-25")
#: Newton steps at most per start (quadratic convergence from 1e-10 takes ~6; linear near a fold).
MAX_STEPS = 200
#: Restarts from perturbed roots when fewer than 8 distinct roots were found.
MAX_RESTARTS = 64


@dataclass(frozen=True)
class Reference:
    """The reference roots at one input: ``rotations`` of the real roots (float 3x3, from 50-digit
    quaternions), their ``quaternions`` (float), the number of distinct roots found (8 when the
    set is complete) and the smallest distance between two roots (real or complex, up to sign)."""

    rotations: tuple
    quaternions: tuple
    n_roots: int
    min_separation: float
    #: every root, real or complex, as complex128 (n_roots, 4), q . q = 1 (each one of a pair +-q)
    roots: np.ndarray = None
    #: which of ``roots`` are real (REAL_IMAG)
    real: np.ndarray = None

    @property
    def count(self) -> int:
        return len(self.rotations)


def _mp_quadrics(geometry, inputs) -> list:
    u, w0, v0, alpha2 = geometry
    out = []
    with mpmath.workdps(DIGITS):
        for i in range(3):
            k = [mpmath.mpf(float(x)) for x in u[i]]
            b = mpmath.mpf(float(inputs[i]))
            c, s = mpmath.cos(b), mpmath.sin(b)
            kx = mpmath.matrix([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
            rot = mpmath.eye(3) + s * kx + (1 - c) * (kx * kx)
            w = rot * mpmath.matrix([mpmath.mpf(float(x)) for x in w0[i]])
            v = mpmath.matrix([mpmath.mpf(float(x)) for x in v0[i]])
            out.append(leg_quadric_mp(w, v, mpmath.cos(mpmath.mpf(float(alpha2[i])))))
    return out


def quadric_system_mp(quadrics, q):
    """(F, J) of the square system (q^T A_i q for the three legs, q . q - 1) at the mpmath vector q:
    F a 4 x 1 and J a 4 x 4 mpmath matrix (J = 2 A_i q in the first rows, 2 q in the last)."""
    aq = [a * q for a in quadrics]
    f = mpmath.matrix([sum(q[j] * aq[i][j] for j in range(4)) for i in range(3)] + [sum(x * x for x in q) - 1])
    jac = mpmath.matrix(4, 4)
    for i in range(3):
        for j in range(4):
            jac[i, j] = 2 * aq[i][j]
    for j in range(4):
        jac[3, j] = 2 * q[j]
    return f, jac


def leg_quadric_mp(w, v, ca):
    """The 4 x 4 mpmath matrix A of one leg's quadric q^T A q = |q|^2 (w . R(q) v - ca), from the
    elbow axis w and platform axis v (3 mpmath numbers each) and ca = cos(alpha2), in the working
    precision of the caller."""
    wv = sum(w[j] * v[j] for j in range(3))
    a = mpmath.zeros(4, 4)
    a[0, 0] = wv - ca
    cross = [v[1] * w[2] - v[2] * w[1], v[2] * w[0] - v[0] * w[2], v[0] * w[1] - v[1] * w[0]]
    for r in range(3):
        a[0, r + 1] = a[r + 1, 0] = cross[r]
        for c2 in range(3):
            a[r + 1, c2 + 1] = w[r] * v[c2] + v[r] * w[c2] - ((wv + ca) if r == c2 else 0)
    return a


def _newton(quadrics, q0):
    """Complex Newton from q0 on (q^T A_i q, q . q - 1); (q, converged)."""
    with mpmath.workdps(DIGITS):
        q = mpmath.matrix([mpmath.mpc(x) for x in q0])
        norm = mpmath.sqrt(sum(x * x for x in q))
        q = q / norm
        tol = mpmath.mpf(10) ** (-(DIGITS - 10))
        for _ in range(MAX_STEPS):
            f, jac = quadric_system_mp(quadrics, q)
            try:
                step = mpmath.lu_solve(jac, f)
            except ZeroDivisionError:
                return q, False
            q = q - step
            if mpmath.norm(step, mpmath.inf) < tol:
                return q, True
        return q, False


def same_root(p, q) -> bool:
    return min(max(abs(p[j] - s * q[j]) for j in range(4)) for s in (1, -1)) < SAME_ROOT


def reference_roots(geometry, inputs, seed: int = 0) -> Reference:
    """The reference roots of the 3-RRR ``geometry`` (u, w0, v0, alpha2) at actuator ``inputs``.

    Raises ValueError when 8 distinct roots cannot be found (a degenerate input)."""
    quadrics = _mp_quadrics(geometry, inputs)
    starts = list(candidate_points(leg_quadrics(geometry, inputs)))
    roots: list = []
    rng = np.random.default_rng(seed)
    restarts = 0
    while True:
        for start in starts:
            q, ok = _newton(quadrics, start)
            if ok and not any(same_root(q, r) for r in roots):
                roots.append(q)
        if len(roots) >= 8 or restarts >= MAX_RESTARTS:
            break
        restarts += 1
        base = roots[restarts % len(roots)] if roots else np.ones(4)
        scale = 10.0 ** rng.uniform(-8, -2)
        starts = [np.array([complex(base[j]) for j in range(4)]) + scale * (rng.normal(size=4) + 1j * rng.normal(size=4))]
    if len(roots) != 8:
        raise ValueError(f"inputs {list(inputs)}: found {len(roots)} distinct roots of the quaternion quadrics, not 8")
    real = [r for r in roots if max(abs(mpmath.im(x)) for x in r) < REAL_IMAG]
    quats = tuple(np.array([float(mpmath.re(x)) for x in r]) for r in real)
    sep = min(float(min(max(abs(a[j] - s * b[j]) for j in range(4)) for s in (1, -1)))
              for i, a in enumerate(roots) for b in roots[i + 1:])
    every = np.array([[complex(x) for x in r] for r in roots])
    is_real = np.array([max(abs(mpmath.im(x)) for x in r) < REAL_IMAG for r in roots])
    return Reference(tuple(quaternion_rotation(q) for q in quats), quats, len(roots), sep, every, is_real)


def singular_input(geometry, x_a, x_b, rel_tol: float = 1e-15):
    """(s*, x(s*)) on the segment x(s) = x_a + s (x_b - x_a), s in [0, 1], where the reference count
    changes, by bisection to |x_b - x_a| * rel_tol; requires different counts at the two ends."""
    x_a, x_b = np.asarray(x_a, float), np.asarray(x_b, float)
    c_a = reference_roots(geometry, x_a).count
    if reference_roots(geometry, x_b).count == c_a:
        raise ValueError("singular_input: the reference counts at the two ends are equal")
    lo, hi = 0.0, 1.0
    while hi - lo > rel_tol:
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            break
        if reference_roots(geometry, x_a + mid * (x_b - x_a)).count == c_a:
            lo = mid
        else:
            hi = mid
    s = 0.5 * (lo + hi)
    return s, x_a + s * (x_b - x_a)


def near_singular_inputs(x_star, direction, distances=(1e-2, 1e-4, 1e-6, 1e-8, 1e-10, 1e-12)):
    """Inputs at each distance (radians, max norm) on both sides of ``x_star`` along ``direction``:
    a list of (signed distance, inputs)."""
    d = np.asarray(direction, float)
    d = d / np.abs(d).max()
    x_star = np.asarray(x_star, float)
    return [(sign * dist, x_star + sign * dist * d) for dist in distances for sign in (-1.0, 1.0)]
