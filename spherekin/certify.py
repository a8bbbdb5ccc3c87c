"""Certification of solutions: a Krawczyk test in outward-rounded interval arithmetic.

The system certified is the *transversal* closure system in angle space: for every loop of a
:class:`~spherekin.mechanism.LoopSystem`, the entries (2,1), (3,1), (3,2) (1-based) of
F_n = prod_i Rx(phi_i) Z (Eq. 2), which vanish at closure (F = I + [w]x near I gives
(f21, f31, f32) = (w_z, -w_y, w_x): simple roots where the mechanism is regular). The unknowns are
the passive angles theta (radians), in ``LoopSystem.unknowns`` order; a factor angle is a known
number or phi = offset + sign * theta. These are the entries of the ``transversal`` formulation
(:data:`spherekin.formulations.TRANSVERSAL_ENTRIES`) without the tan-half-angle substitution and
without the factor q_n, so the Jacobian is taken directly with respect to the joint angles.

Krawczyk's test (Krawczyk 1969; Moore 1977; Rump 1983): for a box X, a point y in X, any real
matrix C and an enclosure J(X) of the Jacobian over X,

    K(X) = y - C F(y) + (I - C J(X)) (X - y).

Every zero of F in X lies in K(X); if K(X) lies in the interior of X (and C is nonsingular) then X
holds exactly one zero and J is nonsingular on X. All of K is evaluated in outward-rounded
interval arithmetic (mpmath's ``iv`` context: rounding of every +, *, sin and cos is enclosed),
F(y) as an interval at the point y. C = J(y)^-1 is an ordinary float inverse (any C is valid; a
good one makes K small).

Evaluation: F = P_n with prefix products P_i = P_{i-1} Rx(phi_i) Z, and, since an unknown appears
at most once per loop, dF/dtheta = sign * P_{i-1} (dRx(phi_i)/dphi Z) S_{i+1} with suffix
products S_i = Rx(phi_i) Z S_{i+1}, using Rx(phi) Z = [[0,-1,0],[c,0,-s],[s,0,c]] and
d/dphi (Rx(phi) Z) = [[0,0,0],[-s,0,-c],[c,0,-s]]. One routine does this in floats and in
intervals.

Departures from the paper: the paper does not certify its solutions (subdivision returns small
boxes, not proofs); this module is an addition. Known factor angles and term offsets are floats
rounded from the geometry; the test treats each as an interval of half-width
``angle_tolerance`` (default :data:`ANGLE_TOLERANCE`), so a certificate holds for every system
whose constant angles are that close to the floats -- including the snapped angles of the
Bernstein equations (:data:`spherekin.closure.KNOWN_ANGLE_SNAP`) and the exact angles (pi/2, pi,
...) that the floats round.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Mapping, Sequence

import numpy as np
from mpmath import iv, mpf

from .closure import KNOWN_ANGLE_SNAP, Term
from .formulations import TRANSVERSAL_ENTRIES
from .mechanism import LoopSystem

__all__ = [
    "ANGLE_TOLERANCE",
    "CERTIFY_RADII",
    "MIDPOINT_RCOND_MIN",
    "KrawczykResult",
    "transversal_labels",
    "transversal_equations",
    "interval_transversal",
    "krawczyk",
    "certify",
]

#: Half-width (radians) of the interval that stands for each constant angle (known factor angle,
#: term offset). Reason: the floats of a LoopSystem are rounded (np.pi, offsets from atan2 of
#: float axes: errors ~1e-16) and the Bernstein equations snap cos/sin within KNOWN_ANGLE_SNAP of 0,
#: i.e. move an angle by up to ~1e-14; twice the snap covers both, so the certificate is about the
#: mechanism, not about one rounding of it. It widens F(y) by ~n_factors * 2e-14, far below the
#: smallest radius tried.
ANGLE_TOLERANCE = 2.0 * KNOWN_ANGLE_SNAP

#: Box radii (radians) tried by :func:`certify`, smallest first. Reason: K's width is about
#: |C| (|F(y)| + rounding) + cond(J) * radius^2, so a small box suffices for a regular root polished
#: to ~1e-15 (1e-10 sits well above that accuracy and the ~1e-13 width of F(y)); 1e-8 and 1e-6
#: rescue points polished less accurately or Jacobians with |J^-1| up to ~1e5, while 1e-6 stays
#: far below the distance between distinct solutions that the solver can separate (its default
#: tolerance is 1e-6).
CERTIFY_RADII = (1e-10, 1e-8, 1e-6)

#: The midpoint Jacobian is reported singular when sigma_min / sigma_max is below this. Reason:
#: entries of J are products of sines and cosines (|J_ij| <= 1), so then |C| >~ 1e12 and the width
#: of C F(y) alone (F(y) is at least ~1e-16 wide from rounding) exceeds the largest radius tried
#: (1e-6): the inclusion cannot succeed, and the singular Jacobian is the real reason.
MIDPOINT_RCOND_MIN = 1e-12


# --------------------------------------------------------------------------------------------
# Result
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class KrawczykResult:
    """Outcome of a Krawczyk test on the transversal system of a LoopSystem (radians throughout).

    * ``certified``: K(X) lies in the interior of X, so X holds exactly one solution;
    * ``reason``: why not (empty when certified);
    * ``names``, ``center`` (y), ``radius``: the unknowns and the box X = y +- radius;
    * ``box`` (X) and ``krawczyk_box`` (K(X), outward-rounded to floats; None when not computed):
      one (lo, hi) per unknown;
    * ``contraction``: max_k width(K_k) / width(X_k) (< 1 is necessary for success; nan when K was
      not computed);
    * ``no_solution``: K(X) and X are disjoint, which proves that X holds no solution;
    * ``residual``: an upper bound on max |F(y)| over the equations (for every system whose
      constant angles lie within the angle tolerance, so ~1e-13 at an exact root by default);
    * ``singular_values``: of the float Jacobian J(y), descending (its rank and conditioning);
    * ``n_equations``, ``n_unknowns``; ``radii_tried``: the radii tested, in order (by
      :func:`certify`; just ``(radius,)`` for a single test).
    """

    certified: bool
    reason: str
    names: tuple
    center: tuple
    radius: float
    box: tuple
    krawczyk_box: tuple | None
    contraction: float
    no_solution: bool
    residual: float
    singular_values: tuple
    n_equations: int
    n_unknowns: int
    radii_tried: tuple

    def summary(self) -> dict:
        """JSON-ready evidence: the verdict, radius, contraction, residual bound, singular values."""
        return {
            "certified": self.certified,
            "reason": self.reason,
            "radius": self.radius,
            "contraction": None if math.isnan(self.contraction) else self.contraction,
            "no_solution": self.no_solution,
            "residual_bound": self.residual,
            "min_singular_value": self.singular_values[-1] if self.singular_values else None,
            "n_equations": self.n_equations,
            "n_unknowns": self.n_unknowns,
            "radii_tried": list(self.radii_tried),
        }


# --------------------------------------------------------------------------------------------
# Evaluation of the transversal system (floats or intervals, one routine)
# --------------------------------------------------------------------------------------------

def transversal_labels(system: LoopSystem) -> tuple[str, ...]:
    """Names of the equations, in row order: "loop1:f21", "loop1:f31", "loop1:f32", "loop2:f21", ..."""
    _check_system(system)
    return tuple(f"loop{k + 1}:f{r + 1}{c + 1}" for k in range(len(system.loops)) for r, c in TRANSVERSAL_ENTRIES)


def _times_factor(p, c, s):
    """P Rx(phi) Z for a 3x3 nested list P: columns (c P1 + s P2, -P0, c P2 - s P1)."""
    return [[c * row[1] + s * row[2], -row[0], c * row[2] - s * row[1]] for row in p]


def _factor_times(c, s, m):
    """Rx(phi) Z M for a 3x3 nested list M: rows (-M1, c M0 - s M2, s M0 + c M2)."""
    m0, m1, m2 = m
    return [[-v for v in m1],
            [c * a - s * b for a, b in zip(m0, m2)],
            [s * a + c * b for a, b in zip(m0, m2)]]


def _evaluate(system: LoopSystem, theta: Sequence, constant, cos, sin, jacobian: bool = True):
    """F (list of E values) and J (E x M nested list) of the transversal system.

    ``theta``: one value per unknown (float or interval); ``constant(a)`` turns a float constant
    angle into the arithmetic's number; ``cos``/``sin`` of that arithmetic. Implements Eq. (2),
    F_n = prod Rx(phi_i) Z, with the derivative rule of the module docstring.
    """
    n_unk = len(system.unknowns)
    f_out, j_out = [], []
    for loop, indices in zip(system.loops, system.loop_indices):
        cs, var_at = [], {}   # (cos, sin) per factor; factor position -> (global unknown, sign)
        for pos, fac in enumerate(loop.factors):
            if isinstance(fac, Term):
                g = indices[len(var_at)]          # loop_indices follow the order of the loop's terms
                phi = constant(fac.offset) + (theta[g] if fac.sign == 1 else -theta[g])
                var_at[pos] = (g, fac.sign)
            else:
                phi = constant(fac)
            cs.append((cos(phi), sin(phi)))
        eye = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
        prefix = [eye]
        for c, s in cs:
            prefix.append(_times_factor(prefix[-1], c, s))
        f_out.extend(prefix[-1][r][col] for r, col in TRANSVERSAL_ENTRIES)
        if not jacobian:
            continue
        rows = [[0] * n_unk for _ in TRANSVERSAL_ENTRIES]
        suffix = eye
        for pos in range(len(cs) - 1, -1, -1):       # suffix = S_{pos+1} on entry
            c, s = cs[pos]
            if pos in var_at:
                g, sign = var_at[pos]
                left = prefix[pos]                    # P_{pos} = product of the factors before this one
                dcols = {}                            # D v for the needed columns v of the suffix
                for col in {col for _, col in TRANSVERSAL_ENTRIES}:
                    v0, v2 = suffix[0][col], suffix[2][col]
                    dcols[col] = (-s * v0 - c * v2, c * v0 - s * v2)
                for e, (r, col) in enumerate(TRANSVERSAL_ENTRIES):
                    d1, d2 = dcols[col]
                    val = left[r][1] * d1 + left[r][2] * d2
                    rows[e][g] = val if sign == 1 else -val
            suffix = _factor_times(c, s, suffix)
        j_out.extend(rows)
    return f_out, j_out


def transversal_equations(system: LoopSystem, theta) -> tuple[np.ndarray, np.ndarray]:
    """Float values F (E,) and Jacobian J (E, M) = dF/dtheta of the transversal system at ``theta``.

    ``theta``: passive angles (radians), a sequence in ``system.unknowns`` order or a mapping
    name -> angle. E = 3 * number of loops, M = number of unknowns.
    """
    _check_system(system)
    y = _check_theta(system, theta)
    f, j = _evaluate(system, list(y), float, math.cos, math.sin)
    return np.array(f, dtype=float), np.array(j, dtype=float).reshape(len(f), len(y))


def interval_transversal(system: LoopSystem, box, angle_tolerance: float = ANGLE_TOLERANCE,
                         jacobian: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """Outward-rounded enclosures of F (E,) and J (E, M) over a box of passive angles.

    ``box``: shape (M, 2), one (lo, hi) per unknown in ``system.unknowns`` order (radians; lo <= hi;
    lo == hi evaluates at a point). Every constant angle c is taken as [c - angle_tolerance,
    c + angle_tolerance]. Returns object arrays of ``mpmath.iv.mpf`` intervals (J is None unless
    ``jacobian``). Every value F(theta), dF/dtheta(theta) for theta in the box lies in them.
    """
    _check_system(system)
    tol = _check_tolerance(angle_tolerance)
    lo, hi = _check_box(system, box)
    xs = [iv.mpf([a, b]) for a, b in zip(lo, hi)]
    return _interval_eval(system, xs, tol, jacobian)


def _interval_eval(system: LoopSystem, xs: list, tol: float, jacobian: bool):
    spread = iv.mpf([-tol, tol])

    def constant(a: float):
        return iv.mpf(a) + spread if tol else iv.mpf(a)

    f, j = _evaluate(system, xs, constant, iv.cos, iv.sin, jacobian)
    f_arr = np.empty(len(f), dtype=object)
    f_arr[:] = [iv.mpf(v) for v in f]
    if not jacobian:
        return f_arr, None
    j_arr = np.empty((len(f), len(xs)), dtype=object)
    for e, row in enumerate(j):
        j_arr[e, :] = [iv.mpf(v) for v in row]   # structural zeros (int 0) become point intervals
    return f_arr, j_arr


# --------------------------------------------------------------------------------------------
# Krawczyk test
# --------------------------------------------------------------------------------------------

def krawczyk(system: LoopSystem, theta, radius: float, angle_tolerance: float = ANGLE_TOLERANCE) -> KrawczykResult:
    """Krawczyk test on X = theta +- radius (radians) for the transversal system of ``system``.

    K(X) = y - C F(y) + (I - C J(X)) (X - y), y = theta (the midpoint of X, up to the rounding of
    its float endpoints; any y in X is valid), C = J(y)^-1 (float), all in outward-rounded interval
    arithmetic; ``theta`` is a sequence in ``system.unknowns`` order or a mapping name -> angle. Certified iff K(X) lies in the interior of X: then X holds exactly one
    solution (Krawczyk/Moore). Not certified, with a reason, when the system is not square, the
    midpoint Jacobian is singular (sigma_min / sigma_max < MIDPOINT_RCOND_MIN) or K(X) is not
    inside X (then ``no_solution`` tells whether K(X) misses X, proving X holds no solution).
    """
    _check_system(system)
    y = _check_theta(system, theta)
    r = _check_radius("radius", radius)
    tol = _check_tolerance(angle_tolerance)
    names = system.names
    n_unk, n_eq = len(y), 3 * len(system.loops)
    lo, hi = y - r, y + r
    box = tuple((float(a), float(b)) for a, b in zip(lo, hi))
    f_y, _ = _interval_eval(system, [iv.mpf(v) for v in y], tol, jacobian=False)
    residual = max((_magnitude(v) for v in f_y), default=0.0)
    _, j_float = transversal_equations(system, y)
    sv = tuple(float(v) for v in np.linalg.svd(j_float, compute_uv=False)) if j_float.size else ()
    base = dict(names=names, center=tuple(float(v) for v in y), radius=r, box=box, krawczyk_box=None,
                contraction=math.nan, no_solution=False, residual=residual, singular_values=sv,
                n_equations=n_eq, n_unknowns=n_unk, radii_tried=(r,))
    if n_eq != n_unk:
        return KrawczykResult(certified=False, reason=f"not certified: {n_eq} equations, {n_unk} unknowns", **base)
    if not sv or sv[-1] <= MIDPOINT_RCOND_MIN * sv[0]:
        smin = sv[-1] if sv else 0.0
        return KrawczykResult(
            certified=False,
            reason=(f"not certified: singular midpoint Jacobian (smallest singular value {smin:.3g}, "
                    f"{smin / sv[0] if sv and sv[0] else 0.0:.3g} of the largest, below {MIDPOINT_RCOND_MIN:g})"),
            **base)
    c_float = np.linalg.inv(j_float)
    xs = [iv.mpf([a, b]) for a, b in zip(lo, hi)]
    _, j_box = _interval_eval(system, xs, tol, jacobian=True)
    c_iv = [[iv.mpf(float(v)) for v in row] for row in c_float]
    y_iv = [iv.mpf(v) for v in y]
    dx = [x - yv for x, yv in zip(xs, y_iv)]
    k_box = []
    for i in range(n_unk):
        acc = y_iv[i] - _dot(c_iv[i], f_y)
        for j in range(n_unk):
            cj = _dot(c_iv[i], j_box[:, j])
            a_ij = (1 - cj) if i == j else -cj       # (I - C J(X))_ij
            acc = acc + a_ij * dx[j]
        k_box.append(acc)
    k_float = tuple(_outward(k) for k in k_box)
    inside = all(k.a > x.a and k.b < x.b for k, x in zip(k_box, xs))
    disjoint = any(k.b < x.a or k.a > x.b for k, x in zip(k_box, xs))
    ratio = max(float(mpf((k.b - k.a).b)) / float(mpf((x.b - x.a).a)) for k, x in zip(k_box, xs))
    base.update(krawczyk_box=k_float, contraction=ratio, no_solution=disjoint)
    if inside:
        return KrawczykResult(certified=True, reason="", **base)
    if disjoint:
        why = "K(X) does not meet X, so X holds no solution"
    else:
        worst = max(range(n_unk), key=lambda k: _excess(k_box[k], xs[k]))
        why = (f"K(X) is not inside X (contraction {ratio:.3g}; {names[worst]!r} leaves X by "
               f"{_excess(k_box[worst], xs[worst]):.3g} rad)")
    return KrawczykResult(certified=False, reason=f"not certified at radius {r:g}: {why}", **base)


def certify(system: LoopSystem, theta, radii: Sequence[float] = CERTIFY_RADII,
            angle_tolerance: float = ANGLE_TOLERANCE) -> KrawczykResult:
    """Krawczyk tests at increasing radii (default CERTIFY_RADII); the first success or the last failure.

    A non-square system or a singular midpoint Jacobian fails the same way at every radius, so it
    is reported after the first try. ``radii_tried`` of the result lists the radii tested.
    """
    if isinstance(radii, (str, bytes)) or not isinstance(radii, (Sequence, np.ndarray)) or len(radii) == 0:
        raise ValueError(f"radii: expected a non-empty sequence of positive radii (radians), got {radii!r}")
    rs = [_check_radius(f"radii[{i}]", v) for i, v in enumerate(radii)]
    if any(b <= a for a, b in zip(rs, rs[1:])):
        raise ValueError(f"radii: expected strictly increasing radii, got {list(radii)!r}")
    tried = []
    for r in rs:
        res = krawczyk(system, theta, r, angle_tolerance)
        tried.append(r)
        if res.certified or res.krawczyk_box is None:
            break
    return replace(res, radii_tried=tuple(tried))


# --------------------------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------------------------

def _dot(row, col):
    acc = iv.mpf(0)
    for a, b in zip(row, col):
        acc = acc + a * b
    return acc


def _magnitude(v) -> float:
    """An upper bound (float) on |v| for an interval v."""
    m = max(abs(mpf(v.a)), abs(mpf(v.b)))
    out = float(m)
    return out if mpf(out) >= m else math.nextafter(out, math.inf)


def _outward(v) -> tuple[float, float]:
    """Float (lo, hi) enclosing the interval v (exact at iv's default 53-bit precision)."""
    a, b = mpf(v.a), mpf(v.b)
    lo, hi = float(a), float(b)
    if mpf(lo) > a:
        lo = math.nextafter(lo, -math.inf)
    if mpf(hi) < b:
        hi = math.nextafter(hi, math.inf)
    return lo, hi


def _excess(k, x) -> float:
    """How far (radians, float) the interval k reaches beyond x on either side (<= 0: inside)."""
    return float(max(mpf(x.a) - mpf(k.a), mpf(k.b) - mpf(x.b)))


def _check_system(system) -> None:
    if not isinstance(system, LoopSystem):
        raise ValueError(f"system: expected a LoopSystem (mechanism.loop_system(...)), got {type(system).__name__}")


def _check_theta(system: LoopSystem, theta) -> np.ndarray:
    names = system.names
    if isinstance(theta, Mapping):
        missing = [n for n in names if n not in theta]
        if missing:
            raise ValueError(f"theta: missing angle(s) for {missing}; expected one per unknown {names}")
        values = [theta[n] for n in names]
    elif isinstance(theta, (str, bytes)):
        raise ValueError(f"theta: expected {len(names)} passive angles (radians) {names}, got {theta!r}")
    else:
        values = theta
    try:
        y = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"theta: expected {len(names)} real angles (radians) {names}, got {theta!r}") from None
    if y.shape != (len(names),):
        raise ValueError(f"theta: expected shape ({len(names)},) (one angle per unknown {names}), got {y.shape}")
    if not np.all(np.isfinite(y)):
        raise ValueError(f"theta: expected finite angles (radians), got {theta!r}")
    return y


def _check_radius(key: str, value) -> float:
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{key}: expected a positive radius (radians), got {value!r}")
    try:
        r = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{key}: expected a positive radius (radians), got {value!r}") from None
    if not (math.isfinite(r) and 0.0 < r < math.pi):
        raise ValueError(f"{key}: expected a radius in (0, pi) radians, got {value!r}")
    return r


def _check_tolerance(value) -> float:
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"angle_tolerance: expected a non-negative angle (radians), got {value!r}")
    try:
        t = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"angle_tolerance: expected a non-negative angle (radians), got {value!r}") from None
    if not (math.isfinite(t) and 0.0 <= t < 1e-3):
        raise ValueError(f"angle_tolerance: expected a value in [0, 1e-3) radians, got {value!r}")
    return t


def _check_box(system: LoopSystem, box) -> tuple[np.ndarray, np.ndarray]:
    m = len(system.unknowns)
    try:
        arr = np.asarray(box, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"box: expected shape ({m}, 2) of (lo, hi) angles in radians, got {box!r}") from None
    if arr.shape != (m, 2):
        raise ValueError(f"box: expected shape ({m}, 2) (one (lo, hi) per unknown {system.names}), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("box: expected finite bounds (radians)")
    if np.any(arr[:, 0] > arr[:, 1]):
        bad = [system.names[k] for k in np.flatnonzero(arr[:, 0] > arr[:, 1])]
        raise ValueError(f"box: expected lo <= hi, got lo > hi for {bad}")
    return arr[:, 0], arr[:, 1]
