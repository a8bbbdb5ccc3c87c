"""
A six-bar written as a graph
============================

Any spherical mechanism of links and revolute joints is a graph (``kind = "graph"``,
:doc:`/mechanism-format`): each joint names the two links it joins and its axis in a reference
assembly, where every joint reads 0. This script builds a Watt I six-bar from such a graph (six
links, seven joints), lets spherekin find its two independent loops and its mobility, solves it at
one input, then follows its assemblies over the full turn of the input.
"""

import math

import spherekin
from spherekin.batch import branch_map
from spherekin.mechanism import mechanism_from_dict
from spherekin.plot import plot_branches


def axis(polar_deg, azimuth_deg):
    """The unit vector at a polar angle from +z and an azimuth from +x (degrees)."""
    p, a = math.radians(polar_deg), math.radians(azimuth_deg)
    return [math.sin(p) * math.cos(a), math.sin(p) * math.sin(a), math.cos(p)]


# joint: (the two links it joins, its axis as polar and azimuth angles in degrees)
JOINTS = {
    "A": ("ground", "crank", 0, 0),         # the input, driven
    "B": ("crank", "coupler", 35, 90),      # crank and coupler are the two ternary links
    "C": ("coupler", "rocker", 70, 40),
    "D": ("ground", "rocker", 60, -20),
    "E": ("crank", "link5", 40, 160),       # the dyad E-F-G closes the second loop
    "F": ("link5", "link6", 80, 150),
    "G": ("link6", "coupler", 75, 100),
}
graph = {
    "kind": "graph", "name": "Watt I six-bar", "ground": "ground", "output": "coupler",
    "joints": [{"name": name, "links": [a, b], "axis": axis(polar, azimuth), "actuated": name == "A"}
               for name, (a, b, polar, azimuth) in JOINTS.items()],
}
mechanism = mechanism_from_dict(graph)
print("loops closed by", [loop.closing for loop in mechanism.link_graph.loops],
      "; mobility", mechanism.link_graph.mobility)

report = spherekin.solve(mechanism, [0.7])
print(report.count_text())
print(report.table())

# %%
# Over the full turn of the input A: the angle E of the second loop's dyad against A. Each four-bar of the chain
# has up to two assemblies, so the six-bar has up to four; where two of them meet (a branch point)
# the number of assemblies changes.

bmap = branch_map(mechanism, "A=-pi:pi:36", joint="E")
for k, circuit in enumerate(bmap.circuits, start=1):
    print(f"circuit {k}: crank={circuit.crank}, branches {circuit.branches}")
print(len(bmap.branch_points), "branch point(s)")
fig = plot_branches(bmap)
