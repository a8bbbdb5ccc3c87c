"""Polishing: Gauss-Newton on the full closure residuals, from a solver box to machine precision.

The residual of a system of loops at passive angles theta (radians) stacks, for every loop, the nine
entries of F_n(theta) - I (Eq. 2 evaluated directly with trigonometric functions, no tan(phi/2)).
Its Jacobian is analytic: with M_i = Rx(phi_i) Z and phi_i = offset_i + sign_i theta_k(i),

    dF_n / d theta_k = sum_{i : k(i) = k} sign_i  M_1 ... M_{i-1} (dRx/dphi)(phi_i) Z  M_{i+1} ... M_n.

Each step solves the linearized system in the least-squares sense with the minimum-norm solution
(from the SVD of the Jacobian, singular values below :data:`STEP_RCOND` of the largest dropped, as
numpy.linalg.lstsq does), which converges quadratically at a regular root and still converges, more
slowly, at a singular one. Departure from the paper: the paper stops at boxes below a tolerance;
polishing turns each box into a point to ~1e-15 so that it can be certified and compared.

:func:`polish_many` runs Gauss-Newton on many points at once, each with its own constants (one
mechanism at several inputs: :func:`spherekin.closure.closure_many`); :func:`polish` is it at one
point, so a point polishes to the same floats alone or in a chunk.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..closure import ClosurePlan, closure_at, closure_many, closure_plan

__all__ = ["POLISH_TOL", "POLISH_MAX_ITER", "STEP_RCOND", "PolishResult", "PolishBatch", "closure_residual", "polish",
           "polish_many"]

#: Polishing stops when the largest closure residual |F_n - I| entry is below this: a few ulps of
#: the O(1) entries of a product of rotations.
POLISH_TOL = 1e-14
#: Gauss-Newton steps at most: quadratic convergence needs ~5 from a 1e-6 box; singular roots
#: converge linearly (about one bit per step), so allow enough for them to reach ~1e-12.
POLISH_MAX_ITER = 60
#: A polished point counts as converged when its residual is below this (the issue's 1e-12).
CONVERGED_TOL = 1e-12
#: Singular values of the Jacobian below this times (the largest one times max(rows, columns)) are
#: taken as 0 in a step (the minimum-norm least-squares solution). Reason: numpy.linalg.lstsq's
#: default cutoff (machine epsilon times the larger dimension): below it a singular value is
#: rounding, and dividing by it would throw the step off at a singular root.
STEP_RCOND = float(np.finfo(float).eps)


@dataclass(slots=True, eq=False)
class PolishResult:
    """Polished passive angles (radians), largest residual entry, steps taken, convergence flag."""

    theta: np.ndarray
    residual: float
    iterations: int
    converged: bool


def closure_residual(loops, unknowns, theta, jacobian: bool = False):
    """Stacked F_n(theta) - I of every loop, shape (9 L,), and optionally its Jacobian (9 L, n)
    (:func:`spherekin.closure.closure_at`, loop by loop, entries row-major)."""
    theta = np.asarray(theta, dtype=float)
    if not jacobian:
        return (closure_at(loops, unknowns, theta) - np.eye(3)).reshape(-1)
    f, j = closure_at(loops, unknowns, theta, jacobian=True)
    return (f - np.eye(3)).reshape(-1), j.reshape(-1, len(theta))


class PolishBatch:
    """Polished points of :func:`polish_many` as arrays: ``theta`` (P, M) radians, ``residual`` (P,)
    the largest residual entry, ``iterations`` (P,) steps taken, ``converged`` (P,)."""

    __slots__ = ("theta", "residual", "iterations", "converged")

    def __init__(self, theta, residual, iterations, converged):
        self.theta = theta
        self.residual = residual
        self.iterations = iterations
        self.converged = converged

    def __len__(self) -> int:
        return len(self.theta)

    def result(self, i: int) -> PolishResult:
        """The :class:`PolishResult` of point ``i``."""
        return PolishResult(self.theta[i].copy(), float(self.residual[i]), int(self.iterations[i]),
                            bool(self.converged[i]))


def _min_norm_steps(jac: np.ndarray, r: np.ndarray) -> np.ndarray:
    """The minimum-norm least-squares solutions of jac x = -r for a stack: jac (P, E, M), r (P, E) -> (P, M)."""
    u, sv, vt = np.linalg.svd(jac, full_matrices=False)
    keep = sv > STEP_RCOND * max(jac.shape[1:]) * sv[:, :1]
    inv = np.divide(1.0, sv, out=np.zeros_like(sv), where=keep)
    coef = inv * np.einsum("pek,pe->pk", u, -r)
    return np.einsum("pkm,pk->pm", vt, coef)


def polish_many(plan: ClosurePlan, theta0, offsets=None, *, tol: float = POLISH_TOL,
                max_iter: int = POLISH_MAX_ITER) -> PolishBatch:
    """Gauss-Newton from every row of ``theta0`` (P, M; radians) on the closure residuals of
    ``plan`` (:func:`spherekin.closure.closure_plan`), point p with the constants ``offsets[p]``
    (P, L, n; default the plan's own for every point). Each point steps until its residual is at
    most ``tol``, it diverges (residual above 1e3 times its best: the best point seen is kept) or
    ``max_iter`` steps; the points still going step together (one stack of small SVDs a step).
    """
    theta = np.array(theta0, dtype=float)
    if theta.ndim != 2 or theta.shape[1] != plan.n_unknowns or not np.all(np.isfinite(theta)):
        raise ValueError(f"theta0: expected (P, {plan.n_unknowns}) finite angles, got {theta0!r}")
    offs = None if offsets is None else np.asarray(offsets, dtype=float)

    def residuals(rows):
        f, j = closure_many(plan, theta[rows], None if offs is None else offs[rows], jacobian=True)
        n = len(rows)
        return (f - np.eye(3)).reshape(n, -1), j.reshape(n, -1, plan.n_unknowns)

    everyone = np.arange(len(theta))
    r, jac = residuals(everyone)
    best_err = np.abs(r).max(axis=1, initial=0.0)
    best = theta.copy()
    steps = np.zeros(len(theta), dtype=int)
    going = np.flatnonzero(best_err > tol)
    for it in range(1, max_iter + 1):
        if not len(going):
            break
        theta[going] += _min_norm_steps(jac[going], r[going])
        r_g, jac_g = residuals(going)
        r[going], jac[going] = r_g, jac_g
        err = np.abs(r_g).max(axis=1, initial=0.0)
        steps[going] = it
        better = err < best_err[going]
        best_err[going[better]] = err[better]
        best[going[better]] = theta[going[better]]
        diverged = ~better & (err > 1e3 * best_err[going])      # diverging: keep the best point seen
        going = going[~diverged & (best_err[going] > tol)]
    return PolishBatch(best, best_err, steps, best_err <= CONVERGED_TOL)


def polish(loops, unknowns, theta0, *, tol: float = POLISH_TOL, max_iter: int = POLISH_MAX_ITER) -> PolishResult:
    """Gauss-Newton from ``theta0`` (radians) on :func:`closure_residual`; see the module docstring
    (:func:`polish_many` at one point)."""
    theta = np.asarray(theta0, dtype=float).copy()
    if theta.shape != (len(unknowns),) or not np.all(np.isfinite(theta)):
        raise ValueError(f"theta0: expected {len(unknowns)} finite angles, got {theta0!r}")
    return polish_many(closure_plan(loops, unknowns), theta[None], tol=tol, max_iter=max_iter).result(0)
