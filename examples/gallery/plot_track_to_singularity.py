"""
A proven track that ends at a singularity
=========================================

``Problem.track`` follows the one assembly mode a robot is in along a path of inputs, each step
*proven* to stay in that mode (a Krawczyk test with the inputs ranging over the whole step), and
stops where the mode ends: here, the general 3-RRR's fifth assembly meets another one at a parallel
singularity near beta1 = -2.714 rad, where the number of assemblies drops from 6 to 4. The track
reports the last proven input and the singular input, located by bisection
(``spherekin track FILE --path ... --start-solution 5``).
"""

import numpy as np

import spherekin
from spherekin.mechanism import general_3rrr
from spherekin.plot import plot_track

mechanism = general_3rrr()
beta1 = np.linspace(-3.1, -2.5, 25)                       # the path: beta1 swept, beta2 = 0, beta3 = 0.5
path = np.column_stack([beta1, np.zeros_like(beta1), np.full_like(beta1, 0.5)])

problem = spherekin.compile(mechanism)
start = problem.solve(path[0]).solutions[4]               # solution number 5 (Python counts from 0)
track = problem.track(path, start=start)
print(len(track.poses), "poses;", track.proven_steps, "proven steps")
print(track.stop)

# %%
# The platform's orientation (a unit quaternion) along the path, its parallel measure (the distance
# to a parallel singularity, 0 at one) and where the track stopped.

fig = plot_track(track)
