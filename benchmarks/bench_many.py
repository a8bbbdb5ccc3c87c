"""Many inputs, one mechanism: ``problem.solve_many`` against a loop of ``solve`` calls, same run.

For general_3rrr and the Gosselin platform, ``--inputs`` actuator inputs (default 1,000) from the
inverse kinematics of seeded random poses (one working mode each, so every input assembles), then:

* ``loop of solve (halves)``: ``solve(mech, x, formulation="halves")`` per input, the default
  before issue 14 (the baseline of the ratios);
* ``loop of solve (default)``: ``solve(mech, x)`` per input (compiles the mechanism every call);
* ``solve_many``: ``compile(mech)`` once, then ``problem.solve_many(rows)``.

And the loop equations with LP models (``--lp-inputs``, default 10, the first inputs): the
``halves`` formulation with the ``hybrid`` pruner on the ``highs`` backend (cvxpy: its DPP LP model
is compiled when the pruner is built), as a loop of ``solve`` calls (one model per input) and as
``compile`` + ``solve_many`` (one model per chart layout, reused); the ratio is between those two.
The ``lp`` pruner itself takes ~90 s per full-range input (13,000 LPs), of which the model is <1 %.

Reported: total seconds, the median per-solve time (ms), the compile (setup) time, throughput
relative to the baseline (inputs per second / baseline's), solutions found, how many inputs fell
back to the loop equations, and whether every input's poses agree with the baseline's (to 1e-8).
The baseline's loop is the slow part (~0.1 s per input): ``--baseline-inputs`` (default 200) limits
it to the first inputs, and its throughput is measured on those. JSON to benchmarks/results/many.json.

    python -m benchmarks.bench_many [--inputs 1000] [--baseline-inputs 200] [--lp-inputs 10]
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

from references.random_designs import random_rotation
from spherekin.mechanism import general_3rrr, gosselin
from spherekin.problem import compile, solve

ROOT = Path(__file__).resolve().parent.parent
#: Two solves found the same assembly when their poses agree to this (both polished to ~1e-14).
MATCH = 1e-8


def ik_inputs(mech, count: int, seed: int) -> np.ndarray:
    """(count, 3) actuator inputs: one inverse-kinematics working mode of each seeded random pose."""
    rng = np.random.default_rng(seed)
    rows = []
    while len(rows) < count:
        modes = mech.inverse_kinematics(random_rotation(rng))
        if modes:
            rows.append(modes[int(rng.integers(len(modes)))].inputs)
    return np.array(rows, dtype=float)


def _poses(report):
    return [s.platform_rotation for s in report.solutions if s.platform_rotation is not None]


def _agree(a, b) -> bool:
    pa, pb = _poses(a), _poses(b)
    return len(pa) == len(pb) and all(any(np.abs(p - q).max() <= MATCH for q in pb) for p in pa)


def _timed_loop(fn, rows):
    reports, times = [], []
    for row in rows:
        t = time.perf_counter()
        reports.append(fn(tuple(row)))
        times.append(time.perf_counter() - t)
    return reports, times


def run(mech, rows, baseline_rows: int) -> list[dict]:
    out = []
    base, base_t = _timed_loop(lambda x: solve(mech, x, formulation="halves"), rows[:baseline_rows])
    base_rate = len(base_t) / sum(base_t)
    out.append(dict(method="loop of solve (halves)", inputs=len(base_t), total=sum(base_t),
                    per_solve_ms=1e3 * statistics.median(base_t), setup_ms=0.0, ratio=1.0,
                    solutions=sum(len(r.solutions) for r in base), fallbacks=0, agree=len(base_t)))
    loop, loop_t = _timed_loop(lambda x: solve(mech, x), rows)
    out.append(dict(method="loop of solve (default)", inputs=len(rows), total=sum(loop_t),
                    per_solve_ms=1e3 * statistics.median(loop_t), setup_ms=0.0,
                    ratio=(len(rows) / sum(loop_t)) / base_rate, solutions=sum(len(r.solutions) for r in loop),
                    fallbacks=sum(r.settings.fallback is not None for r in loop),
                    agree=sum(_agree(a, b) for a, b in zip(loop, base))))
    t0 = time.perf_counter()
    problem = compile(mech)
    setup = time.perf_counter() - t0
    per = []
    last = [time.perf_counter()]

    def tick(done, total):
        now = time.perf_counter()
        per.append(now - last[0])
        last[0] = now

    t1 = time.perf_counter()
    many = problem.solve_many(rows, progress=tick)
    total = time.perf_counter() - t1 + setup
    out.append(dict(method="solve_many", inputs=len(rows), total=total, per_solve_ms=1e3 * statistics.median(per),
                    setup_ms=1e3 * setup, ratio=(len(rows) / total) / base_rate,
                    solutions=sum(len(r.solutions) for r in many), fallbacks=sum(r.settings.fallback is not None for r in many),
                    agree=sum(_agree(a, b) for a, b in zip(many, base))))
    return out


#: The loop-equation strategy with LP models whose per-input rebuild solve_many avoids.
LP_STRATEGY = dict(formulation="halves", pruner="hybrid", lp_backend="highs")


def run_lp(mech, rows) -> list[dict]:
    """A loop of solve against compile + solve_many with :data:`LP_STRATEGY` (same rows, same run)."""
    loop, loop_t = _timed_loop(lambda x: solve(mech, x, **LP_STRATEGY), rows)
    rate = len(rows) / sum(loop_t)
    out = [dict(method="loop of solve (halves, hybrid/highs)", inputs=len(rows), total=sum(loop_t),
                per_solve_ms=1e3 * statistics.median(loop_t), setup_ms=0.0, ratio=1.0,
                solutions=sum(len(r.solutions) for r in loop), fallbacks=0, agree=len(rows))]
    t0 = time.perf_counter()
    problem = compile(mech, **LP_STRATEGY)
    setup = time.perf_counter() - t0
    many_t, last = [], [time.perf_counter()]

    def tick(done, total):
        now = time.perf_counter()
        many_t.append(now - last[0])
        last[0] = now

    many = problem.solve_many(rows, progress=tick)
    total = sum(many_t) + setup
    out.append(dict(method="solve_many (halves, hybrid/highs)", inputs=len(rows), total=total,
                    per_solve_ms=1e3 * statistics.median(many_t), setup_ms=1e3 * setup, ratio=(len(rows) / total) / rate,
                    solutions=sum(len(r.solutions) for r in many), fallbacks=0,
                    agree=sum(_agree(a, b) for a, b in zip(many, loop))))
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--inputs", type=int, default=1000, help="inputs per mechanism (default %(default)s)")
    parser.add_argument("--baseline-inputs", type=int, default=200,
                        help="inputs of the slow baseline loop (the first ones; default %(default)s)")
    parser.add_argument("--lp-inputs", type=int, default=10,
                        help="inputs of the loop equations with LP models (the first ones; 0: skip; default %(default)s)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "many.json"))
    args = parser.parse_args(argv)
    if args.inputs < 1 or not 1 <= args.baseline_inputs or args.lp_inputs < 0:
        parser.error("--inputs and --baseline-inputs: expected positive integers")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    rows_all = []
    print(f"{'problem':13s} {'method':35s} {'inputs':>6s} {'total s':>8s} {'ms/solve':>9s} {'setup ms':>9s} "
          f"{'throughput':>10s} {'sols':>6s} {'fallback':>8s} {'agree':>6s}")
    for name, mech in (("general_3rrr", general_3rrr()), ("gosselin", gosselin())):
        rows = ik_inputs(mech, args.inputs, args.seed)
        lp_rows = run_lp(mech, rows[:args.lp_inputs]) if args.lp_inputs else []
        for r in run(mech, rows, min(args.baseline_inputs, args.inputs)) + lp_rows:
            r["problem"] = name
            rows_all.append(r)
            print(f"{name:13s} {r['method']:35s} {r['inputs']:6d} {r['total']:8.2f} {r['per_solve_ms']:9.2f} "
                  f"{r['setup_ms']:9.2f} {r['ratio']:9.2f}x {r['solutions']:6d} {r['fallbacks']:8d} {r['agree']:6d}")
    meta = dict(machine=dict(cpus=os.cpu_count(), python=platform.python_version(), load=os.getloadavg()),
                inputs=args.inputs, baseline_inputs=args.baseline_inputs, lp_inputs=args.lp_inputs, seed=args.seed)
    out.write_text(json.dumps(dict(meta=meta, rows=rows_all), indent=2))
    print("agree: inputs whose poses equal the baseline's (the baseline's inputs only); throughput: inputs per "
          "second relative to the loop of solve (halves), same run; the hybrid/highs rows: relative to their own loop")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
