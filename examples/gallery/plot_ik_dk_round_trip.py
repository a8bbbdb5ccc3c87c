"""
Inverse and direct kinematics: a round trip
===========================================

A pose of the general 3-RRR's platform (a rotation R, from Euler angles) has several inverse
kinematics solutions, one per working mode of the legs (:func:`spherekin.inverse_kinematics`).
Solving the direct kinematics at each of those inputs (:func:`spherekin.solve`) must give back R as
one of its assemblies: the figure shows, for each working mode, the distance from R to the nearest
assembly found (the largest entry of the difference of the two matrices).
"""

import matplotlib.pyplot as plt
import numpy as np

import spherekin
from spherekin.core.orientation import rotation_from_euler
from spherekin.mechanism import general_3rrr

mechanism = general_3rrr()
R = rotation_from_euler(np.radians([10.0, -20.0, 30.0]), "ZYX")   # intrinsic Z-Y-X angles, radians

modes = spherekin.inverse_kinematics(mechanism, R)
errors = []
for ik in modes:
    report = spherekin.solve(mechanism, ik.inputs)
    errors.append(min(np.abs(s.platform_rotation - R).max() for s in report.solutions))
    print(ik.working_mode, np.round(ik.inputs, 6), report.count_text())

# %%
# Every working mode's inputs lead back to the pose, to rounding.

fig, ax = plt.subplots(figsize=(6, 3.5), layout="constrained")
ax.bar([str(ik.working_mode) for ik in modes], np.maximum(errors, 1e-17))
ax.set_yscale("log")
ax.set_xlabel("working mode (one sign per leg)")
ax.set_ylabel("max |R_dk - R|")
ax.set_title(f"{mechanism.name}: {len(modes)} working modes")
ax.tick_params(axis="x", labelrotation=30)
