"""A proven assembly-mode change around a cusp of a certified singular set (issue 31 item 5).

:func:`mode_change` tracks every assembly around a small circle of inputs about a cusp
(:meth:`spherekin.problem.Problem.track`, every step proven); a track that ends at another solution of the
start solve proves the mechanism changes assembly mode without crossing the singular set.
"""

from __future__ import annotations

import numpy as np

from ..problem import compile
from ..results import ModeChange

__all__ = ["MODE_RADII", "MODE_POINTS", "MODE_STARTS", "MODE_MATCH", "mode_change"]

#: Radii (radians of input) of the circles around a proven cusp tried by :func:`mode_change`, in order: small
#: enough that the circle meets only the cusp's two fold branches (general_3rrr's cusps are >= 0.1 apart
#: from other curves in the cases measured), large enough that the tracker's steps stay long.
MODE_RADII = (0.02, 0.05)
#: Points of the closed polygon on a circle (the tracker subdivides each side as it needs).
MODE_POINTS = 256
#: Start inputs tried on each circle: the solve at each; the track starts where the solve has the most
#: assemblies (the side of the cusp where three local assemblies exist, a wedge narrowing at the cusp).
MODE_STARTS = 48
#: A complete track's end pose is solution j of the start solve when their rotations agree to this (largest
#: entry): the tracker's poses are proven roots polished to ~1e-15; distinct certified solutions differ by
#: far more (disjoint proven boxes).
MODE_MATCH = 1e-9


def mode_change(mechanism, sset, *, radii=MODE_RADII, points: int = MODE_POINTS, starts: int = MODE_STARTS):
    """A proven assembly-mode change around a cusp of ``sset`` (a :class:`spherekin.results.SingularSet` of
    a plane of two inputs), issue 31 item 5: for each proven cusp (then each unresolved candidate) and
    each radius, the solve at ``starts`` inputs of the circle, the start where it has the most solutions,
    and every solution there tracked (:meth:`Problem.track`, every step proven) around the closed polygon
    of ``points`` sides; found when a complete track ends at another solution of the start solve. Returns
    a :class:`spherekin.results.ModeChange` (``found`` False with what was searched when none)."""
    if sset.y is None:
        raise ValueError("mode_change: expected a plane of two inputs, got a line")
    problem = compile(mechanism)
    names = problem.mechanism.actuated
    ordered = sorted(sset.cusps, key=lambda c: c.status != "cusp")
    tried = 0
    for c in ordered:
        for rho in radii:
            tried += 1

            def rows(theta):
                r = np.empty((len(theta), len(names)))
                for j, n in enumerate(names):
                    r[:, j] = (c.x + rho * np.cos(theta) if n == sset.x[0] else
                               c.y + rho * np.sin(theta) if n == sset.y[0] else sset.fixed[n])
                return r

            angles = 2 * np.pi * np.arange(starts) / starts
            counts = [len(problem.solve(row).solutions) for row in rows(angles)]
            theta0 = angles[int(np.argmax(counts))]
            path = rows(theta0 + 2 * np.pi * np.arange(points + 1) / points)
            path[-1] = path[0]
            sols = problem.solve(path[0]).solutions
            for k, s in enumerate(sols):
                if s.platform_rotation is None:
                    break
                track = problem.track(path, start=k)
                if track.stop is not None:
                    continue
                end = track.poses[-1].platform_rotation
                gaps = [np.abs(end - o.platform_rotation).max() for o in sols]
                j = int(np.argmin(gaps))
                if j != k and gaps[j] <= MODE_MATCH:
                    return ModeChange(True, (c.x, c.y), float(rho), path, k + 1, j + 1, int(track.proven_steps),
                                      {"cusps": len(ordered), "radii": list(radii), "starts": starts},
                                      np.array(track.poses[0].platform_rotation), np.array(end), tuple(names))
    return ModeChange(False, None, None, None, None, None, 0,
                      {"cusps": len(ordered), "radii": list(radii), "starts": starts, "circles": tried})
