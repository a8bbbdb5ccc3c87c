"""Families on Dask: ``spherekin.batch`` with 1 and 2 local workers against a loop of ``spherekin.solve``, same run.

``--inputs`` (default 10,000) actuator inputs of general_3rrr drawn uniformly over the full ranges
([-pi, pi)^3, seeded; about one in eight has no assembly). Rows of the table:

* ``loop of spherekin.solve``: one call per input, on the first ``--loop-inputs`` (default 300;
  its rate is measured on those): the baseline of the ratios;
* ``batch, in this process``: ``batch.solve_many(..., workers=0)`` (compile once, ``solve_many``,
  the results table) on the first ``--loop-inputs`` too;
* ``batch, N local workers``: ``batch.solve_many(..., workers=N)`` on all inputs, an embedded
  ``LocalCluster`` of N single-threaded worker processes; the wall time includes starting and
  closing the cluster.

Reported per row and run: wall seconds, solves per second, the ratio to the loop's rate, the scaling
from 1 to 2 workers; medians over ``--runs`` runs. The tables of the worker counts must be
identical (checked). JSON to benchmarks/results/batch.json.

    python -m benchmarks.bench_batch [--inputs 10000] [--loop-inputs 300] [--runs 3] [--workers 1 2]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--inputs", type=int, default=10_000)
    ap.add_argument("--loop-inputs", type=int, default=300)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--seed", type=int, default=15)
    ap.add_argument("--json", default=str(ROOT / "benchmarks" / "results" / "batch.json"))
    args = ap.parse_args(argv)

    import pandas as pd

    from spherekin import batch, solve
    from spherekin.mechanism import general_3rrr

    mech = general_3rrr()
    rng = np.random.default_rng(args.seed)
    inputs = rng.uniform(-np.pi, np.pi, (args.inputs, 3))
    head = inputs[:args.loop_inputs]
    rows = {"loop": [], "here": [], **{w: [] for w in args.workers}}
    tables = {}
    for run in range(args.runs):
        t0 = time.perf_counter()
        for x in head:
            solve(mech, x)
        rows["loop"].append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        batch.solve_many(mech, head, workers=0)
        rows["here"].append(time.perf_counter() - t0)
        for w in args.workers:
            t0 = time.perf_counter()
            frame = batch.solve_many(mech, inputs, workers=w)
            rows[w].append(time.perf_counter() - t0)
            tables.setdefault(w, frame)
        print(f"run {run + 1}/{args.runs}: " + ", ".join(
            f"{k}: {v[-1]:.1f} s" for k, v in rows.items()), flush=True)
    first = tables[args.workers[0]]
    identical = all(first.equals(t) for t in tables.values())
    for t in tables.values():
        pd.testing.assert_frame_equal(t, first)

    loop_rate = args.loop_inputs / statistics.median(rows["loop"])
    table = []

    def add(name, n, times):
        wall = statistics.median(times)
        rate = n / wall
        table.append({"method": name, "inputs": n, "wall_s": wall, "solves_per_s": rate,
                      "ratio_to_loop": rate / loop_rate, "runs": [float(t) for t in times]})

    add("loop of spherekin.solve", args.loop_inputs, rows["loop"])
    add("batch, in this process", args.loop_inputs, rows["here"])
    for w in args.workers:
        add(f"batch, {w} local worker(s)", args.inputs, rows[w])
    print(f"\ngeneral_3rrr, inputs uniform over [-pi, pi)^3 (seed {args.seed}); medians of {args.runs} run(s); "
          f"{os.cpu_count()} cores")
    print(f"{'method':34s} {'inputs':>7s} {'wall s':>8s} {'solves/s':>9s} {'x loop':>7s}")
    for r in table:
        print(f"{r['method']:34s} {r['inputs']:7d} {r['wall_s']:8.2f} {r['solves_per_s']:9.1f} {r['ratio_to_loop']:7.2f}")
    scaling = None
    if 1 in rows and 2 in rows:
        scaling = statistics.median(rows[1]) / statistics.median(rows[2])
        print(f"scaling 1 -> 2 workers: {scaling:.2f}x (2.0 = linear)")
    print(f"tables identical for every worker count: {identical}; "
          f"{int(first['solution'].notna().sum())} solutions, {len(first)} rows")
    out = Path(args.json)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"machine": {"cores": os.cpu_count(), "processor": platform.processor(),
                                           "python": platform.python_version()},
                               "date": time.strftime("%Y-%m-%d"), "inputs": args.inputs,
                               "loop_inputs": args.loop_inputs, "runs": args.runs, "rows": table,
                               "scaling_1_to_2": scaling, "identical": identical}, indent=2))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
