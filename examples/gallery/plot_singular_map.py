"""
An assembly-mode map with its certified singular curves
=======================================================

Where the number of assemblies changes across a map of two inputs, two assemblies meet: a parallel
(Type-2) singularity. :func:`spherekin.singular` covers that singular set by cells no wider than a
tolerance T and proves that the plane outside them holds no parallel singularity; each cell is
``singular`` (a singular configuration proven inside it) or ``unresolved`` (no proof either way,
e.g. next to a cusp, where three assemblies meet). Here the general 3-RRR on a small square of the
plane (beta1, beta2) at beta3 = 0.5, T = 0.1 rad: :func:`spherekin.batch.assembly_map` with
``singular_tol`` computes the map and the singular set of its plane together (``spherekin map FILE
--grid ... --grid ... --singular --singular-tol 0.1``; over the full plane this takes a minute or more).
"""

from spherekin.batch import assembly_map
from spherekin.mechanism import general_3rrr
from spherekin.plot import plot_assembly_map

mechanism = general_3rrr()
amap = assembly_map(mechanism, "beta1=1.2:2.0:33", "beta2=-0.3:0.5:33", {"beta3": 0.5}, workers=0,
                    singular_tol=0.1)
sset = amap.singular_set       # as spherekin.singular(mechanism, x=..., y=..., fixed=..., tol=0.1) gives it
print(sset.counts(), "complete" if sset.complete else "incomplete")
for cusp in sset.cusps:
    print(f"{cusp.status} at beta1 = {cusp.x:.6f}, beta2 = {cusp.y:.6f}")

# %%
# The number of assemblies at each point of a 33 x 33 grid (solved in this process), with the
# singular cells drawn over it: every change of colour lies in a cell; the star is the proven cusp.

fig = plot_assembly_map(amap)
