"""
How far the actuators can go from home: singularity-free boxes
==============================================================

A robot in one assembly at a home input can move its actuators anywhere in a box around home as
long as no input of the box is a parallel singularity *of that assembly* (another assembly's
singularities do not matter: the robot is not there). ``Problem.free_box`` returns the largest box
home +- r that is *proven* to hold the assembly without one: the box is covered by cells, each
proven by a Krawczyk test with the inputs ranging over the whole cell. Here the general 3-RRR at
home (0, 0, 0.5), in the plane of beta1 and beta2 (beta3 held), for two of its eight assemblies
(``spherekin singular FILE ... --home 0,0,0.5 --start-solution K``).
"""

import matplotlib.patches as patches

import spherekin
from spherekin.batch import assembly_map
from spherekin.mechanism import general_3rrr
from spherekin.plot import plot_assembly_map

mechanism = general_3rrr()
HOME = [0.0, 0.0, 0.5]                                       # radians
problem = spherekin.compile(mechanism)
print(problem.solve(HOME).count_text())

boxes = {}
for k in (1, 5):                                             # solutions 2 and 6 (Python counts from 0)
    box = problem.free_box(HOME, start=k, inputs=("beta1", "beta2"))
    boxes[k] = box
    print(f"solution {k + 1}: r = {box.radius:.4f} rad ({box.cells} cells), stopped: {box.limit} "
          f"near {box.limit_at}")

# %%
# The boxes over the assembly-mode map of the plane around home (a coarse grid): each box stops
# where its own assembly meets another one, at a change of colour; other changes may lie inside it.

amap = assembly_map(mechanism, "beta1=-0.5:0.5:21", "beta2=-0.5:0.5:21", {"beta3": 0.5}, workers=0)
fig = plot_assembly_map(amap)
ax = fig.axes[0]
for k, box in boxes.items():
    ax.add_patch(patches.Rectangle((box.lo[0], box.lo[1]), box.hi[0] - box.lo[0], box.hi[1] - box.lo[1],
                                   facecolor="none", edgecolor="black", linewidth=1.5))
    ax.annotate(f"solution {k + 1}", (box.hi[0], box.hi[1]), xytext=(-4, 4), textcoords="offset points",
                ha="right", fontsize=9)
    ax.plot(box.limit_at["beta1"], box.limit_at["beta2"], "kx")
ax.plot(HOME[0], HOME[1], "k+", markersize=10)
