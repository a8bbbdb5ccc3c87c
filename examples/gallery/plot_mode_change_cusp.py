"""
A proven change of assembly mode around a cusp
==============================================

At a cusp of the singular curves three assemblies meet. Inside the wedge between the cusp's two
fold branches three assemblies exist locally, outside it one, so a robot can go once around the
cusp and come back to its first input in *another* assembly, without ever crossing a singularity.
This script finds the cusp of the general 3-RRR near (1.59, 0.10) with :func:`spherekin.singular`
(one cell of T = 0.1 rad around it), then follows each assembly around a circle of radius 0.02 rad
about it with ``Problem.track``, every step proven to stay in one assembly mode (``spherekin
singular FILE ... --mode-change`` does the same search).
"""

import numpy as np

import spherekin
from spherekin.mechanism import general_3rrr
from spherekin.plot import plot_track

mechanism = general_3rrr()
sset = spherekin.singular(mechanism, x=("beta1", 1.55, 1.65), y=("beta2", 0.05, 0.15), fixed={"beta3": 0.5},
                          tol=0.1)
cusp = next(c for c in sset.cusps if c.status == "cusp")      # proven: a Krawczyk-unique triple root
print(f"cusp at beta1 = {cusp.x:.8f}, beta2 = {cusp.y:.8f}")

# %%
# The circle starts where the solve finds the most assemblies: inside the wedge. Every assembly
# there is tracked once around, until one ends at another solution of the start: a proven change
# of assembly mode.

RADIUS = 0.02                                              # radians of input
problem = spherekin.compile(mechanism)


def circle(theta):
    """Inputs (len(theta), 3) on the circle about the cusp, beta3 = 0.5."""
    return np.column_stack([cusp.x + RADIUS * np.cos(theta), cusp.y + RADIUS * np.sin(theta),
                            np.full(len(theta), 0.5)])


angles = np.linspace(0, 2 * np.pi, 24, endpoint=False)
theta0 = angles[int(np.argmax([len(problem.solve(x).solutions) for x in circle(angles)]))]
path = circle(theta0 + np.linspace(0, 2 * np.pi, 129))
path[-1] = path[0]                                          # closed: back to the first input exactly
start = problem.solve(path[0])
print(start.count_text())

for k in range(len(start.solutions)):
    track = problem.track(path, start=k)
    if track.stop is not None:                              # met a singularity: not a closed loop
        print(f"solution {k + 1} meets a singularity at {track.stop.singular_inputs}")
        continue
    end = track.poses[-1].platform_rotation
    j = int(np.argmin([np.abs(end - s.platform_rotation).max() for s in start.solutions]))
    print(f"solution {k + 1} comes back as solution {j + 1} ({track.proven_steps} proven steps)")
    if j != k:
        print(f"assembly-mode change: solution {k + 1} -> solution {j + 1}")
        break

# %%
# The platform's orientation (a unit quaternion) around the circle: the track of the assembly that
# changes ends elsewhere than it started, at the other solution; its parallel measure (the distance
# to a parallel singularity) stays away from 0 all the way.

fig = plot_track(track)
