"""Polishing: Gauss-Newton on the full closure residuals, from a solver box to machine precision.

The residual of a system of loops at passive angles theta (radians) stacks, for every loop, the nine
entries of F_n(theta) - I (Eq. 2 evaluated directly with trigonometric functions, no tan(phi/2)).
Its Jacobian is analytic: with M_i = Rx(phi_i) Z and phi_i = offset_i + sign_i theta_k(i),

    dF_n / d theta_k = sum_{i : k(i) = k} sign_i  M_1 ... M_{i-1} (dRx/dphi)(phi_i) Z  M_{i+1} ... M_n.

Each step solves the linearized system in the least-squares sense with the minimum-norm solution
(numpy.linalg.lstsq), which converges quadratically at a regular root and still converges, more
slowly, at a singular one. Departure from the paper: the paper stops at boxes below a tolerance;
polishing turns each box into a point to ~1e-15 so that it can be certified and compared.
"""

from __future__ import annotations

import numpy as np

from ..closure import closure_at

__all__ = ["POLISH_TOL", "POLISH_MAX_ITER", "PolishResult", "closure_residual", "polish"]

#: Polishing stops when the largest closure residual |F_n - I| entry is below this: a few ulps of
#: the O(1) entries of a product of rotations.
POLISH_TOL = 1e-14
#: Gauss-Newton steps at most: quadratic convergence needs ~5 from a 1e-6 box; singular roots
#: converge linearly (about one bit per step), so allow enough for them to reach ~1e-12.
POLISH_MAX_ITER = 60
#: A polished point counts as converged when its residual is below this (the issue's 1e-12).
CONVERGED_TOL = 1e-12


class PolishResult:
    """Polished passive angles (radians), largest residual entry, steps taken, convergence flag."""

    __slots__ = ("theta", "residual", "iterations", "converged")

    theta: np.ndarray
    residual: float
    iterations: int
    converged: bool

    def __init__(self, theta, residual, iterations, converged):
        self.theta = theta
        self.residual = residual
        self.iterations = iterations
        self.converged = converged


def closure_residual(loops, unknowns, theta, jacobian: bool = False):
    """Stacked F_n(theta) - I of every loop, shape (9 L,), and optionally its Jacobian (9 L, n)
    (:func:`spherekin.closure.closure_at`, loop by loop, entries row-major)."""
    theta = np.asarray(theta, dtype=float)
    if not jacobian:
        return (closure_at(loops, unknowns, theta) - np.eye(3)).reshape(-1)
    f, j = closure_at(loops, unknowns, theta, jacobian=True)
    return (f - np.eye(3)).reshape(-1), j.reshape(-1, len(theta))


def polish(loops, unknowns, theta0, *, tol: float = POLISH_TOL, max_iter: int = POLISH_MAX_ITER) -> PolishResult:
    """Gauss-Newton from ``theta0`` (radians) on :func:`closure_residual`; see the module docstring."""
    theta = np.asarray(theta0, dtype=float).copy()
    if theta.shape != (len(unknowns),) or not np.all(np.isfinite(theta)):
        raise ValueError(f"theta0: expected {len(unknowns)} finite angles, got {theta0!r}")
    r, jac = closure_residual(loops, unknowns, theta, jacobian=True)
    best = (np.abs(r).max(), theta.copy())
    it = 0
    for it in range(1, max_iter + 1):
        if best[0] <= tol:
            it -= 1
            break
        step = np.linalg.lstsq(jac, -r, rcond=None)[0]
        theta = theta + step
        r, jac = closure_residual(loops, unknowns, theta, jacobian=True)
        err = np.abs(r).max()
        if err < best[0]:
            best = (err, theta.copy())
        elif err > 1e3 * best[0]:  # diverging: keep the best point seen
            break
    err, theta = best
    return PolishResult(theta, float(err), it, bool(err <= CONVERGED_TOL))
