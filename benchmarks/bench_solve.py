"""Benchmark of the solver on the Gosselin platform: formulation x pruner x LP backend x tolerance.

Two problems, actuator inputs (0.3, -0.2, 0.5) rad:
  * "full": every passive joint over the full circle (64 charts), all 8 solutions;
  * "chart": one chart of width pi per joint (the width of the charts of a full circle), centred
    near a regular solution, where the slow configurations (LP backends, the paper's scalar
    formulation) are measured.
Each configuration runs ``--repeats`` times (3 when one run takes over ``--slow`` seconds, 1 when
it takes over a minute; the table says how many); the table gives the median wall time, the ratio against the default
configuration measured in the same process, boxes, LPs and the solutions found. A configuration
that hits a cap is reported as such. JSON goes to benchmarks/results/solve.json.

    python benchmarks/bench_solve.py [--repeats 5] [--quick]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import statistics
import time
from pathlib import Path

import numpy as np

from spherekin.mechanism import gosselin
from spherekin.solver import SolverLimitError, solve, solve_system

INPUTS = (0.3, -0.2, 0.5)
#: Centre of the "chart" problem (radians, passive joints in the mechanism's order): rounded from
#: a regular solution at INPUTS, so the chart [c - pi/2, c + pi/2] holds a root away from its faces.
CHART_CENTRE = (-2.0, 1.0, -1.0, 1.0, -1.0, 2.0)

# (problem, formulation, pruner, lp_backend, tol)
CONFIGS = [
    ("full", "transversal", "hybrid", None, 1e-6),  # the default: the baseline of the ratios
    ("full", "transversal", "pp", None, 1e-6),
    ("full", "transversal", "hybrid", None, 1e-9),
    ("full", "transversal", "hybrid", None, 1e-3),
    ("full", "paper", "pp", None, 1e-3),
    ("full", "paper", "pp", None, 1e-6),
    ("chart", "transversal", "hybrid", None, 1e-6),
    ("chart", "transversal", "pp", None, 1e-6),
    ("chart", "transversal", "lp", "highspy", 1e-6),
    ("chart", "transversal", "lp", "highs", 1e-6),
    ("chart", "transversal", "lp", "clarabel", 1e-6),
    ("chart", "paper", "pp", None, 1e-3),
    ("chart", "paper", "lp", "highspy", 1e-3),
    ("chart", "paper", "lp", "clarabel", 1e-3),        # the paper-faithful mode
]
QUICK = [0, 4, 6, 8, 11]

#: A configuration is stopped (and reported) past this many boxes: it is a measure of failure.
MAX_BOXES = 300_000


def run_once(problem, formulation, pruner, backend, tol):
    mech = gosselin()
    t0 = time.perf_counter()
    if problem == "full":
        rep = solve(mech, INPUTS, formulation=formulation, pruner=pruner, lp_backend=backend, tol=tol,
                    max_boxes=MAX_BOXES)
    else:
        ranges = {n: (c - math.pi / 2, c + math.pi / 2) for n, c in zip(mech.passive, CHART_CENTRE)}

        def build(chart):
            system = mech.loop_system(INPUTS, chart)
            return system.loops, system.unknowns

        rep = solve_system(build, ranges, formulation=formulation, pruner=pruner, lp_backend=backend, tol=tol,
                           max_boxes=MAX_BOXES)
    return time.perf_counter() - t0, rep


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--slow", type=float, default=20.0, help="seconds above which a config runs 3 times")
    parser.add_argument("--quick", action="store_true", help="a few configurations, for a smoke test")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results" / "solve.json")
    args = parser.parse_args(argv)
    configs = [CONFIGS[i] for i in QUICK] if args.quick else CONFIGS
    rows = []
    print(f"Gosselin platform, inputs {INPUTS} rad; medians of {args.repeats} runs "
          f"(3 when a run takes over {args.slow:.0f} s, 1 over 60 s); {os.cpu_count()} cores, Python {platform.python_version()}")
    header = f"{'problem':7s} {'formulation':12s} {'pruner':6s} {'backend':9s} {'tol':>6s} {'median s':>9s} " \
             f"{'ratio':>7s} {'runs':>4s} {'boxes':>8s} {'LPs':>8s} {'sols':>5s} {'per root':>8s}"
    print(header)
    print("-" * len(header))
    baseline = None
    for problem, form, pruner, backend, tol in configs:
        times, rep, failure = [], None, None
        repeats = args.repeats
        i = 0
        while i < repeats:
            try:
                t, rep = run_once(problem, form, pruner, backend, tol)
            except SolverLimitError as exc:
                failure = str(exc).split(";")[0]
                t = None
            if t is None:
                break
            times.append(t)
            if t > args.slow:
                repeats = min(repeats, 3 if t < 60 else 1)
            i += 1
        row = dict(problem=problem, formulation=form, pruner=pruner, lp_backend=backend, tol=tol)
        if failure:
            row.update(failed=failure)
            print(f"{problem:7s} {form:12s} {pruner:6s} {str(backend):9s} {tol:6.0e}  cap hit: {failure}")
        else:
            med = statistics.median(times)
            if baseline is None:
                baseline = med
            st = rep.stats
            per_root = st.accepted / max(1, len(rep.solutions))
            row.update(median_seconds=med, runs=len(times), times=times, ratio_vs_default=med / baseline,
                       boxes=st.boxes_processed, lps=st.lps_solved, lp_doubts=st.lp_doubts,
                       solutions=len(rep.solutions), accepted_boxes_per_solution=per_root,
                       solution_angles=[np.asarray(s.angles).tolist() for s in rep.solutions])
            print(f"{problem:7s} {form:12s} {pruner:6s} {str(backend):9s} {tol:6.0e} {med:9.3f} "
                  f"{med / baseline:7.2f} {len(times):4d} {st.boxes_processed:8d} {st.lps_solved:8d} "
                  f"{len(rep.solutions):5d} {per_root:8.1f}", flush=True)
        rows.append(row)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"benchmark": "solve", "inputs": INPUTS, "cores": os.cpu_count(),
                                    "python": platform.python_version(), "machine": platform.machine(),
                                    "rows": rows}, indent=2))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
