"""From clusters of accepted boxes to solutions you can trust: polish, deduplicate, classify.

For each cluster of the box loop (see :mod:`spherekin.solver`):

1. polish its centre by Gauss-Newton on the full closure residuals (:mod:`spherekin.polish`);
2. merge polished points that coincide (:data:`DEDUPE_TOL`, angles modulo 2 pi);
3. give each a status with its evidence:
   * ``singular``: the mechanism is at a singularity there (:meth:`SphericalMechanism.singularity`):
     a serial one (the actuators can move while the platform stays still; the four "singular"
     Gosselin solutions of the paper) or a parallel one (the passive joints can move with the
     actuators locked; the direct-kinematics root is then not isolated). The evidence has the
     kind and the smallest singular values of the leg and loop Jacobians;
   * ``certified``: a Krawczyk test in outward-rounded interval arithmetic proves that a small box
     around the point holds exactly one solution (:mod:`spherekin.certify`);
   * ``unverified``: neither could be shown; the evidence says why.
   A serial singularity is an isolated, often certifiable, root of the direct kinematics; it is
   still reported ``singular`` (with the certificate in its evidence) because the actuators lose
   control of the platform there.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .polish import polish
from .results import Solution

__all__ = ["DEDUPE_TOL", "finalize"]

#: Polished solutions closer than this (radians, every passive angle, modulo 2 pi) are one solution:
#: polished points agree to ~1e-14, distinct solutions of a generic mechanism are far apart.
DEDUPE_TOL = 1e-8
#: Half-width (radians) of the chart used to evaluate the loops around a solution: any value
#: below pi/2 keeps tan((theta - shift)/2) well conditioned there.
LOCAL_CHART = 1.0


def _wrap(a):
    return np.mod(np.asarray(a) + math.pi, 2 * math.pi) - math.pi


def _in_range(theta: float, rng, tol: float) -> bool:
    """Is the angle within ``tol`` of the range [lo, hi] (modulo 2 pi)? None = the full circle."""
    if rng is None:
        return True
    lo, hi = rng
    return float(np.mod(theta - lo + tol, 2 * math.pi)) <= hi - lo + 2 * tol


def finalize(mechanism, inputs, names, clusters, tol, certify=None) -> list[Solution]:
    """Polish, deduplicate and classify the clusters found for ``mechanism`` at ``inputs``.

    ``names``: the passive unknowns (order of ``Solution.angles``); ``clusters``: Solutions from the
    box loop; ``tol``: the solver tolerance (radians); ``certify(system, theta)``: the certification
    function (default :func:`spherekin.certify.certify`).
    """
    if certify is None:
        from .certify import certify
    polished = []
    for sol in clusters:
        system = mechanism.loop_system(inputs, {n: (a - LOCAL_CHART, a + LOCAL_CHART)
                                                for n, a in zip(names, sol.angles)})
        p = polish(system.loops, system.unknowns, sol.angles)
        theta = _wrap(p.theta)
        evidence = {"polish_iterations": p.iterations, "polish_residual": p.residual,
                    "moved": float(np.abs(_wrap(theta - sol.angles)).max())}
        polished.append((sol, theta, p, evidence))
    # deduplicate polished points (two clusters may polish to the same root)
    merged: list[list] = []
    for sol, theta, p, ev in polished:
        for m in merged:
            if p.converged and m[2].converged and np.abs(_wrap(theta - m[1])).max() <= DEDUPE_TOL:
                m[0] = dataclasses.replace(m[0], lo=np.minimum(m[0].lo, sol.lo), hi=np.maximum(m[0].hi, sol.hi),
                                           n_boxes=m[0].n_boxes + sol.n_boxes)
                m[3]["merged_clusters"] = m[3].get("merged_clusters", 1) + 1
                break
        else:
            merged.append([sol, theta, p, ev])
    out = []
    ranges = mechanism.ranges
    for sol, theta, p, ev in merged:
        angles = dict(zip(names, (float(a) for a in theta)))
        if not all(_in_range(a, ranges[n], tol) for n, a in angles.items()):
            continue  # polishing left the joint ranges: the root lies outside them
        system = mechanism.loop_system(inputs, {n: (a - LOCAL_CHART, a + LOCAL_CHART) for n, a in angles.items()})
        joints = {**dict(zip(mechanism.actuated, (float(v) for v in inputs))), **angles}
        sing = mechanism.singularity(joints)
        ev.update(serial_margin=float(sing.serial_margin), parallel_margin=float(sing.parallel_margin),
                  singularity=sing.kind)
        if p.converged:
            cert = certify(system, theta)
            ev.update(krawczyk_certified=bool(cert.certified), krawczyk=cert.summary())
        else:
            cert = None
            ev["reason"] = f"polishing did not converge (residual {p.residual:.1e})"
        if sing.kind != "regular":
            status = "singular"
        elif cert is not None and cert.certified:
            status = "certified"
        else:
            status = "unverified"
            ev.setdefault("reason", f"Krawczyk test failed: {cert.reason}" if cert is not None else "")
        out.append(dataclasses.replace(
            sol, angles=theta, residual=p.residual, singularity=sing.kind,
            platform_rotation=mechanism.pose_from_passive(inputs, angles), status=status, evidence=ev))
    out.sort(key=lambda s: tuple(np.round(s.angles, 9)))
    return out
