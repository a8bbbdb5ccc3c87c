"""
The paper's configuration against the default
=============================================

The paper's solver subdivides every box down to the tolerance, with its scalar loop equation
(Eq. 10) and linear programs (Eq. 12) on every box: ``formulation="paper", pruner="lp",
lp_backend="clarabel", isolate=False``. The default stops subdividing at a box that a Krawczyk test
proves to hold exactly one root and finishes with Newton, with a projected-polyhedron pruner (no
LP) on tighter equations. Both find the same solutions; the figure shows what each costs as the
tolerance shrinks. A spherical four-bar at one input, so that the paper's configuration runs in
seconds (on the Gosselin platform it takes minutes: README, "Strategies"); HiGHS instead of
Clarabel for its LPs (the same LPs and boxes, faster).
"""

import matplotlib.pyplot as plt
import numpy as np

import spherekin
from spherekin.mechanism import four_bar

mechanism = four_bar()
INPUTS = [0.7]                                                 # the crank angle A, radians
TOLS = [1e-1, 1e-2, 1e-3]                                      # radians on every passive joint angle
CONFIGS = {
    "paper (Eq. 10, LP, no isolation)": dict(formulation="paper", pruner="lp", lp_backend="highspy",
                                             isolate=False),
    "default": {},
}

reports = {}
for name, strategy in CONFIGS.items():
    for tol in TOLS:
        reports[name, tol] = report = spherekin.solve(mechanism, INPUTS, tol=tol, **strategy)
        print(f"{name:34s} tol {tol:g}: {report.count_text()}; {report.stats.boxes_processed} boxes, "
              f"{report.stats.lps_solved} LPs")

# %%
# The solutions agree: the largest difference of a passive angle between the two configurations, at
# each tolerance (each solution is polished by Newton, so the difference is far below the tolerance).

for tol in TOLS:
    paper = sorted(s.angles.tolist() for s in reports["paper (Eq. 10, LP, no isolation)", tol].solutions)
    default = sorted(s.angles.tolist() for s in reports["default", tol].solutions)
    print(f"tol {tol:g}: max |paper - default| = {np.abs(np.subtract(paper, default)).max():.1e} rad")

# %%
# Boxes processed and the solver's time (``report.stats.time_total``) against the tolerance: the
# paper's configuration subdivides each root's neighbourhood down to the tolerance, so its boxes grow
# as the tolerance shrinks; the default's stop at the first proven box and do not depend on it.

fig, (ax_boxes, ax_time) = plt.subplots(1, 2, figsize=(8, 3.5), layout="constrained")
for name in CONFIGS:
    runs = [reports[name, tol] for tol in TOLS]
    ax_boxes.plot(TOLS, [r.stats.boxes_processed for r in runs], "o-", label=name)
    ax_time.plot(TOLS, [r.stats.time_total for r in runs], "o-", label=name)
for ax, label in ((ax_boxes, "boxes processed"), (ax_time, "solver time (s)")):
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.invert_xaxis()
    ax.set_xlabel("tolerance (rad)")
    ax.set_ylabel(label)
    ax.grid(alpha=0.3)
ax_boxes.legend(fontsize=8)
fig.suptitle(f"{mechanism.name} at A = {INPUTS[0]} rad")
