"""Benchmark of the solver on the Gosselin platform: parameterization x formulation x pruner x backend x tol.

Two problems, actuator inputs (0.3, -0.2, 0.5) rad:
  * "full": every passive joint over the full circle, all 8 solutions (tan-half: 64 charts);
  * "chart": one chart of width pi per joint (the width of the tan-half charts of a full circle),
    centred near a regular solution, where the slow configurations (LP backends on every box, the
    paper's scalar formulation) are measured.
Each configuration runs ``--repeats`` times (3 when one run takes over ``--slow`` seconds, 1 when
it takes over a minute; the table says how many); the table gives the median wall time of the
library call ``solve`` / ``solve_system`` (polishing and classification included for "full"), the
ratio against the default configuration measured in the same process, where the time goes
(setup, restriction, pruning, isolation, finishing), boxes, LPs, the solutions found ("sols") and
how many of them are classified certified or singular ("c+s"; the rest are unverified). A
configuration that hits a cap is reported as such. The default's whole ``spherekin solve``
process is timed too (``--process-runs``). JSON goes to benchmarks/results/solve.json.

    python -m benchmarks.bench_solve [--repeats 5] [--quick]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from spherekin.mechanism import gosselin
from spherekin.search.boxloop import SolverLimitError, solve_system
from spherekin.problem import solve
from spherekin.results import SolveReport

INPUTS = (0.3, -0.2, 0.5)
#: Centre of the "chart" problem (radians, passive joints in the mechanism's order): rounded from
#: a regular solution at INPUTS, so the chart [c - pi/2, c + pi/2] holds a root away from its faces.
CHART_CENTRE = (-2.0, 1.0, -1.0, 1.0, -1.0, 2.0)
ROOT = Path(__file__).resolve().parent.parent


def config(name, problem="full", parameterization="tan-half", formulation="halves", pruner="pp", lp_backend=None,
           tol=1e-6, isolate=True, jobs=1):
    return dict(name=name, problem=problem, parameterization=parameterization, formulation=formulation,
                pruner=pruner, lp_backend=lp_backend, tol=tol, isolate=isolate, jobs=jobs)


CONFIGS = [
    config("halves (default before 14)"),                                # the baseline of the ratios
    config("platform (default)", formulation="platform"),                # issue 14: "auto" picks it for a 3-RRR
    config("jobs 2", jobs=2),
    config("no isolation", isolate=False),
    config("transversal", formulation="transversal"),
    config("hybrid", pruner="hybrid"),
    config("tol 1e-9", tol=1e-9),
    config("tol 1e-3", tol=1e-3),
    config("sin-cos", parameterization="sin-cos"),
    config("sin-cos transversal", parameterization="sin-cos", formulation="transversal"),
    config("issue-5 default", formulation="transversal", pruner="hybrid", isolate=False),
    config("paper pp 1e-3", formulation="paper", tol=1e-3, isolate=False),
    config("paper pp 1e-6", formulation="paper", tol=1e-6, isolate=False),
    config("chart default", problem="chart"),
    config("chart lp highspy", problem="chart", pruner="lp", lp_backend="highspy"),
    config("chart lp highs", problem="chart", pruner="lp", lp_backend="highs"),
    config("chart lp clarabel", problem="chart", pruner="lp", lp_backend="clarabel"),
    config("chart sin-cos lp highspy", problem="chart", parameterization="sin-cos", pruner="lp",
           lp_backend="highspy"),
    config("chart paper lp highspy", problem="chart", formulation="paper", pruner="lp", lp_backend="highspy",
           tol=1e-3, isolate=False),
    config("chart paper-faithful", problem="chart", formulation="paper", pruner="lp", lp_backend="clarabel",
           tol=1e-3, isolate=False),
]
QUICK = ["halves (default before 14)", "platform (default)", "no isolation", "sin-cos", "chart default", "chart lp highspy"]

#: A configuration is stopped (and reported) past this many boxes: it is a measure of failure.
MAX_BOXES = 300_000


def run_once(cfg):
    mech = gosselin()
    kwargs = {k: cfg[k] for k in ("parameterization", "formulation", "pruner", "lp_backend", "tol", "isolate", "jobs")}
    t0 = time.perf_counter()
    if cfg["problem"] == "full":
        rep = solve(mech, INPUTS, max_boxes=MAX_BOXES, **kwargs)
    else:
        ranges = {n: (c - math.pi / 2, c + math.pi / 2) for n, c in zip(mech.passive, CHART_CENTRE)}

        def build(chart):
            system = mech.loop_system(INPUTS, chart)
            return system.loops, system.unknowns

        rep = solve_system(build, ranges, max_boxes=MAX_BOXES, **kwargs)
    return time.perf_counter() - t0, rep


def process_times(runs: int) -> list[float]:
    """Wall time of the whole ``spherekin solve`` process on the example file (imports included)."""
    exe = Path(sys.executable).with_name("spherekin")
    cmd = [str(exe), "solve", str(ROOT / "examples" / "gosselin.toml"), "--inputs", ",".join(map(str, INPUTS))]
    out = []
    for _ in range(runs):
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True)
        out.append(time.perf_counter() - t0)
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--slow", type=float, default=20.0, help="seconds above which a config runs 3 times")
    parser.add_argument("--process-runs", type=int, default=7, help="runs of the whole spherekin solve process")
    parser.add_argument("--quick", action="store_true", help="a few configurations, for a smoke test")
    parser.add_argument("--only", nargs="*", help="names of configurations to run")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results" / "solve.json")
    args = parser.parse_args(argv)
    names = args.only or (QUICK if args.quick else [c["name"] for c in CONFIGS])
    configs = [c for c in CONFIGS if c["name"] in names]
    rows = []
    print(f"Gosselin platform, inputs {INPUTS} rad; medians of {args.repeats} runs (3 when a run takes over "
          f"{args.slow:.0f} s, 1 over 60 s); {os.cpu_count()} cores, Python {platform.python_version()}")
    header = (f"{'configuration':26s} {'median s':>9s} {'ratio':>6s} {'runs':>4s} {'setup':>6s} {'restr':>6s} "
              f"{'prune':>6s} {'isol':>6s} {'final':>6s} {'boxes':>7s} {'LPs':>6s} {'sols':>4s} {'c+s':>4s}")
    print(header)
    print("-" * len(header))
    baseline = None
    for cfg in configs:
        times, rep, failure = [], None, None
        repeats = args.repeats
        while len(times) < repeats:
            try:
                t, rep = run_once(cfg)
            except SolverLimitError as exc:
                failure = str(exc).split(";")[0]
                break
            times.append(t)
            if t > args.slow:
                repeats = min(repeats, 3 if t < 60 else 1)
        row = dict(cfg)
        if failure:
            row.update(failed=failure)
            print(f"{cfg['name']:27s}  cap hit: {failure}")
            rows.append(row)
            continue
        med = statistics.median(times)
        if baseline is None:
            baseline = med
        st = rep.stats
        # a chart problem's solve_system returns clusters (nothing polished or classified: c+s is 0)
        found = rep.solutions if isinstance(rep, SolveReport) else rep.clusters
        certified = sum(s.status in ("certified", "singular") for s in found) if isinstance(rep, SolveReport) else 0
        row.update(median_seconds=med, runs=len(times), times=times, ratio_vs_default=med / baseline,
                   stats=st.as_dict(), solutions=len(found), classified=certified,
                   solution_angles=[np.asarray(s.angles).tolist() for s in found])
        print(f"{cfg['name']:27s} {med:9.3f} {med / baseline:6.2f} {len(times):4d} {st.time_setup:6.3f} "
              f"{st.time_restrict:6.3f} {st.time_prune:6.3f} {st.time_isolate:6.3f} {st.time_finalize:6.3f} "
              f"{st.boxes_processed:7d} {st.lps_solved:6d} {len(found):4d} {certified:4d}", flush=True)
        rows.append(row)
    proc = process_times(args.process_runs) if args.process_runs else []
    if proc:
        print(f"whole 'spherekin solve examples/gosselin.toml' process (default configuration): median "
              f"{statistics.median(proc):.3f} s over {len(proc)} runs")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"benchmark": "solve", "inputs": INPUTS, "cores": os.cpu_count(),
                                    "python": platform.python_version(), "machine": platform.machine(),
                                    "process_seconds": proc, "rows": rows}, indent=2))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
