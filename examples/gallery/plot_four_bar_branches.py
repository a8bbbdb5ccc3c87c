"""
A four-bar's branches and circuits
==================================

A spherical four-bar has one input, the crank angle A, and up to two assemblies at each input.
:func:`spherekin.batch.branch_map` solves it over a grid of inputs, joins the assemblies of
neighbouring inputs into branches, locates the branch points (where two assemblies meet: the
parallel singularity det K_p = 0) and groups the branches into circuits, the assemblies the
linkage reaches from one another without being taken apart (``spherekin map FILE --joint D``).
This one is a crank-rocker: its two assemblies never meet, so it has two circuits, each a crank
(covering the full turn of A), and no branch point.
"""

from spherekin.batch import branch_map
from spherekin.mechanism import four_bar
from spherekin.plot import plot_branches

bmap = branch_map(four_bar(), "A=-pi:pi:60", joint="D")
for k, circuit in enumerate(bmap.circuits, start=1):
    print(f"circuit {k}: crank={circuit.crank}, branches {circuit.branches}")
print(len(bmap.branch_points), "branch point(s)")

# %%
# The rocker angle D against the crank angle A, one colour per circuit.

fig = plot_branches(bmap)
