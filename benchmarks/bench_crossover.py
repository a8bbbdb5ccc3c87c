"""Where a local Dask cluster starts paying: ``spherekin.batch`` in this process against 2 local workers.

Why: ``spherekin.batch`` starts an embedded ``LocalCluster`` (worker processes that import numpy,
pandas and spherekin: seconds), which only pays once the job is long enough to share. Below the
crossover a job should run in this process (``spherekin.batch.engine.IN_PROCESS_MAX_INPUTS``); this
benchmark measures that crossover.

Timed, for each N of ``--sizes`` (default 10 30 100 300 1000) seeded inputs of general_3rrr uniform
over its full ranges ([-pi, pi)^3), the wall time of the whole call:

* ``in process``: ``spherekin.batch.solve_many(mech, X, workers=0)`` (compile, ``Problem.solve_many``
  over chunks, the results table);
* ``2 workers``: ``spherekin.batch.solve_many(mech, X, workers=2)``: starting the local cluster of 2
  single-threaded worker processes, the job, closing the cluster.

This process's first imports (pandas and the batch modules, ~0.5 s) are paid by an untimed call
first; a cluster's workers pay theirs in every timed call (they are new processes). Both tables must be equal (checked). Medians of ``--repeats`` runs (the two modes alternate). The
crossover is reported twice: the smallest N of the sizes where the cluster's median wall time is
below the in-process one, and the N where the least-squares lines wall = a + b N of the two modes
cross, N* = (a_cluster - a_here) / (b_here - b_cluster) (a: the start-up; b: seconds per input).
JSON to benchmarks/results/crossover.json.

    python -m benchmarks.bench_crossover [--sizes 10 30 100 300 1000] [--repeats 3] [--workers 2]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_SIZES = (10, 30, 100, 300, 1000)
SEED = 30


def line_fit(sizes, walls) -> tuple[float, float]:
    """(a, b) of the least-squares line wall = a + b N."""
    b, a = np.polyfit(np.asarray(sizes, float), np.asarray(walls, float), 1)
    return float(a), float(b)


def crossover(sizes, here, cluster) -> dict:
    """The two crossovers of the module docstring from median walls per size (None where none)."""
    first = next((n for n, h, c in zip(sizes, here, cluster) if c < h), None)
    fit = None
    if len(sizes) >= 2:
        (a_h, b_h), (a_c, b_c) = line_fit(sizes, here), line_fit(sizes, cluster)
        fit = dict(here_start_s=a_h, here_s_per_input=b_h, cluster_start_s=a_c, cluster_s_per_input=b_c,
                   crossover_n=(a_c - a_h) / (b_h - b_c) if b_h > b_c else None)
    return dict(first_size_where_cluster_wins=first, fit=fit)


def run(sizes, repeats: int, workers: int) -> list[dict]:
    from spherekin import batch
    from spherekin.mechanism import general_3rrr

    mech = general_3rrr()
    inputs = np.random.default_rng(SEED).uniform(-np.pi, np.pi, (max(sizes), 3))
    walls = {n: {"here": [], "cluster": []} for n in sizes}
    batch.solve_many(mech, inputs[:1], workers=0)   # untimed: this process's first imports (pandas, ...)
    for rep in range(repeats):
        for n in sizes:
            t0 = time.perf_counter()
            here = batch.solve_many(mech, inputs[:n], workers=0)
            walls[n]["here"].append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            there = batch.solve_many(mech, inputs[:n], workers=workers)
            walls[n]["cluster"].append(time.perf_counter() - t0)
            if not here.equals(there):
                raise SystemExit(f"N = {n}: the tables in process and on {workers} workers differ")
            print(f"run {rep + 1}/{repeats}, N = {n}: in process {walls[n]['here'][-1]:.2f} s, "
                  f"{workers} workers {walls[n]['cluster'][-1]:.2f} s", flush=True)
    return [dict(inputs=n, here_s=statistics.median(w["here"]), cluster_s=statistics.median(w["cluster"]),
                 here_runs=w["here"], cluster_runs=w["cluster"]) for n, w in walls.items()]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=list(DEFAULT_SIZES), help="numbers of inputs")
    parser.add_argument("--repeats", type=int, default=3, help="runs of each (size, mode); medians are shown")
    parser.add_argument("--workers", type=int, default=2, help="local cluster workers (default %(default)s)")
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "crossover.json")
    args = parser.parse_args(argv)
    if min(args.sizes) < 1:
        parser.error(f"--sizes: expected whole numbers >= 1, got {min(args.sizes)}")
    for key in ("repeats", "workers"):
        if getattr(args, key) < 1:
            parser.error(f"--{key}: expected a whole number >= 1, got {getattr(args, key)}")
    sizes = sorted(set(args.sizes))
    rows = run(sizes, args.repeats, args.workers)
    cross = crossover(sizes, [r["here_s"] for r in rows], [r["cluster_s"] for r in rows])
    print(f"\ngeneral_3rrr, inputs uniform over [-pi, pi)^3 (seed {SEED}); whole call, medians of {args.repeats} "
          f"run(s); {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at the end (the cluster needs a free core)")
    print(f"{'inputs':>7s} {'in process s':>13s} {f'{args.workers} workers s':>12s} {'faster':>10s}")
    for r in rows:
        faster = "cluster" if r["cluster_s"] < r["here_s"] else "in process"
        print(f"{r['inputs']:7d} {r['here_s']:13.2f} {r['cluster_s']:12.2f} {faster:>10s}")
    fit = cross["fit"]
    print(f"cluster wins first at N = {cross['first_size_where_cluster_wins']} (of the sizes run)")
    if fit is not None:
        n_star = fit["crossover_n"]
        print(f"lines: in process {fit['here_start_s']:.2f} s + {1e3 * fit['here_s_per_input']:.1f} ms/input, "
              f"cluster {fit['cluster_start_s']:.2f} s + {1e3 * fit['cluster_s_per_input']:.1f} ms/input: "
              + (f"they cross at N = {n_star:.0f}" if n_star is not None else "the cluster never catches up"))
    machine = dict(python=platform.python_version(), cpus=os.cpu_count(), load_average=os.getloadavg(),
                   date=time.strftime("%Y-%m-%d %H:%M"))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(dict(benchmark="crossover", workers=args.workers, seed=SEED, repeats=args.repeats,
                                        machine=machine, rows=rows, crossover=cross), indent=2))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
