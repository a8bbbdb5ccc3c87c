"""
A five-bar's assembly-mode map
==============================

A spherical five-bar has two inputs, A and E. :func:`spherekin.batch.assembly_map` counts its
assemblies over a grid of both inputs (``spherekin map FILE --grid ... --grid ...``): where the
count changes, two assemblies meet at a parallel singularity. A coarse 24 x 24 grid, solved in
this process (``workers=0``); the command line's default grids are finer.
"""

from spherekin.batch import assembly_map
from spherekin.mechanism import five_bar
from spherekin.plot import plot_assembly_map

amap = assembly_map(five_bar(), "A=-pi:pi:24", "E=-pi:pi:24", workers=0)
print(amap.table())

# %%
# The number of assemblies at each grid point.

fig = plot_assembly_map(amap)
