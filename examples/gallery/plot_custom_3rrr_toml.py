"""
Your own 3-RRR from a TOML file
===============================

A mechanism is a small TOML file (:doc:`/mechanism-format`). This script writes one, a 3-RRR
with 50-degree proximal and 70-degree distal links, whose base and platform axes are given by
their directions, then solves it as ``spherekin solve FILE --inputs ...`` would. The joint range
of ``gamma1`` (the first elbow) keeps the assemblies with that elbow bent one way only.
"""

import tempfile
from pathlib import Path

import spherekin
from spherekin.plot import plot_report

MECHANISM = """
kind = "3-RRR"
name = "my 3-RRR (50/70 deg)"

# u_i: base axes, polar angle 110 deg from +z, azimuth 0, 120, 240 deg
base_axes = [
    [0.9396926207859084, 0.0, -0.3420201433256687],
    [-0.469846310392954, 0.8137976813493738, -0.3420201433256687],
    [-0.46984631039295466, -0.8137976813493735, -0.3420201433256687],
]
# w_i^0: elbow axes at zero input, u_i turned 50 deg towards +z
elbow_axes_at_zero = [
    [0.8660254037844386, 0.0, 0.5],
    [-0.4330127018922192, 0.75, 0.5],
    [-0.43301270189221974, -0.75, 0.5],
]
# v_i^0: platform axes in the platform frame, polar angle 60 deg, azimuth 60, 180, 300 deg
platform_axes = [
    [0.4330127018922194, 0.75, 0.5],
    [-0.8660254037844386, 0.0, 0.5],
    [0.4330127018922194, -0.75, 0.5],
]
distal_link_angles = ["7*pi/18", "7*pi/18", "7*pi/18"]    # 70 deg

[joint_ranges]
gamma1 = ["0", "pi"]
"""

with tempfile.TemporaryDirectory() as folder:
    path = Path(folder) / "my_3rrr.toml"
    path.write_text(MECHANISM)
    mechanism = spherekin.load_mechanism(path)
    report = spherekin.solve(mechanism, [0.3, -0.2, 0.5])

print(mechanism.actuated, mechanism.passive)
print(report.count_text())
print(report.table())

# %%
# The assemblies within the ranges, drawn on the sphere.

fig = plot_report(report)
