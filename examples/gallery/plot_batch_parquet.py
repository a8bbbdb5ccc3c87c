"""
A batch to Parquet, read back with pandas
=========================================

Many inputs of one mechanism: :func:`spherekin.batch.solve_to_file` solves every input of a grid
and writes the results table (one row per solution, :doc:`/results-format`) to a Parquet
dataset as it goes, like ``spherekin batch FILE --grid ... --out results.parquet``. Here a
coarse 12 x 12 grid of the general 3-RRR's first two inputs, in this process (``workers=0``; leave
it out to run on a local Dask cluster, one worker per core).
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import pandas as pd

from spherekin.batch import grid_inputs, solve_to_file
from spherekin.mechanism import general_3rrr

mechanism = general_3rrr()
inputs = grid_inputs(mechanism, ["beta1=-pi:pi:12", "beta2=-pi:pi:12"], {"beta3": 0.5})

with tempfile.TemporaryDirectory() as folder:
    out = Path(folder) / "results.parquet"
    summary = solve_to_file(mechanism, inputs, out, workers=0)
    table = pd.read_parquet(out)                    # plain pandas: the dataset is ordinary Parquet

print(summary)
print(table.columns.tolist())
print(table.head())

# %%
# The number of assemblies at each input, from the table's ``input`` and ``status`` columns.

counts = table.dropna(subset=["status"]).groupby("input").size()
counts = counts.reindex(range(len(inputs.values)), fill_value=0)
fig, ax = plt.subplots(figsize=(6, 3.5), layout="constrained")
ax.hist(counts, bins=range(0, counts.max() + 2), align="left", rwidth=0.8)
ax.set_xlabel("assemblies at the input")
ax.set_ylabel("inputs")
ax.set_title(f"{mechanism.name}: {len(inputs.values)} inputs, {len(table)} rows")
