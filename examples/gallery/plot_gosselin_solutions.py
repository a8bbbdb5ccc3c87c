"""
The Gosselin platform's 8 assemblies
====================================

The paper's example: the Gosselin platform (the "agile eye", a 3-RRR with right-angled links),
driven to the inputs beta = (0.3, -0.2, 0.5) rad. :func:`spherekin.solve` finds its 8 assemblies
over the full joint ranges, proves each one (4 certified, 4 at a serial singularity, as the paper
says) and proves that there are no others: "count proven".
"""

import spherekin
from spherekin.mechanism import gosselin
from spherekin.plot import plot_report

report = spherekin.solve(gosselin(), [0.3, -0.2, 0.5])   # inputs in radians, one per actuated joint
print(report.count_text())
print(report.table())

# %%
# Each solution on the unit sphere: the base, elbow and platform axes of every leg and the
# links between them. :func:`spherekin.plot.plot_report` returns a matplotlib Figure (pass a
# path to also write it to a file).

fig = plot_report(report)
