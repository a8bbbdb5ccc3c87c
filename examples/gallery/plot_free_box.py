"""
How far the actuators can go from home: singularity-free boxes
==============================================================

A robot in one assembly at a home input can move its actuators anywhere in a box around home as
long as no input of the box is a parallel singularity *of that assembly* (another assembly's
singularities do not matter: the robot is not there). ``Problem.free_box`` returns the largest box
around home that is *proven* to hold the assembly without one: the box is covered by cells, each
proven by a Krawczyk test with the inputs ranging over the whole cell. First a cube home +- r; then
(``shape="box"``, the default) its faces are pushed out one at a time, so that a singularity close on
one side of home does not cap the others. Here the general 3-RRR at home (0, 0, 0.5), in the plane
of beta1 and beta2 (beta3 held), for its 8th assembly, faces up to 0.6 rad from home
(``spherekin singular FILE ... --home 0,0,0.5 --start-solution 8``).
"""

import matplotlib.patches as patches

import spherekin
from spherekin.batch import assembly_map
from spherekin.mechanism import general_3rrr
from spherekin.plot import plot_assembly_map

mechanism = general_3rrr()
HOME = [0.0, 0.0, 0.5]                                       # radians
K = 7                                                        # solution 8 (Python counts from 0)
problem = spherekin.compile(mechanism)
print(problem.solve(HOME).count_text())

boxes = {}
for shape in ("cube", "box"):
    box = problem.free_box(HOME, start=K, inputs=("beta1", "beta2"), shape=shape, max_radius=0.6)
    boxes[shape] = box
    print(f"{shape}: beta1 [{box.lo[0]:.4f}, {box.hi[0]:.4f}], beta2 [{box.lo[1]:.4f}, {box.hi[1]:.4f}] rad "
          f"({box.cells} cells)")
for face in boxes["box"].faces:
    print(f"  {face.input} {face.side}: {face.extent:.4f} rad from home, stopped by {face.limit}")

# %%
# The two boxes over the assembly-mode map of the plane around home (a coarse grid): the cube stops
# where its own assembly meets another one near the lower left corner; the box keeps the room up and
# to the right. Other changes of colour inside a box belong to other assemblies.

amap = assembly_map(mechanism, "beta1=-0.5:0.7:25", "beta2=-0.5:0.7:25", {"beta3": 0.5}, workers=0)
fig = plot_assembly_map(amap)
ax = fig.axes[0]
for (shape, box), style in zip(boxes.items(), ("--", "-")):
    ax.add_patch(patches.Rectangle((box.lo[0], box.lo[1]), box.hi[0] - box.lo[0], box.hi[1] - box.lo[1],
                                   facecolor="none", edgecolor="black", linewidth=1.8, linestyle=style,
                                   label=f"{shape} (solution {K + 1})"))
    if box.limit_at is not None:
        ax.plot(box.limit_at["beta1"], box.limit_at["beta2"], "kx")
ax.plot(HOME[0], HOME[1], "k+", markersize=10)
ax.legend(loc="upper left", fontsize=8)
