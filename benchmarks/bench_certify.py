"""Benchmark of certification: the Krawczyk test per Gosselin solution, fast float intervals vs mpmath.

The solutions are those of ``spherekin.search.boxloop.solve`` on the Gosselin platform at inputs
(0.3, -0.2, 0.5) rad (8 solutions), each certified on the loop system that
``spherekin.trust.solutions.finalize`` builds for it (a chart of half-width LOCAL_CHART around it).
All in one process, ``--repeats`` runs (>= 5) of each configuration:

  * reference: ``certify_reference`` (mpmath ``iv`` for every operation), one call per solution;
  * fast: ``certify``, one call per solution, the cache of mpmath point cos/sin cleared before
    each run's 8 calls (what one solve pays: the constant angles are shared by its solutions);
  * fast, warm: the same calls again with the cache kept (every point value already known);
  * fast, batched: ``certify_many`` on the 8 points in one call (one loop system), cache cleared.

The table gives, per configuration, the median over runs of the time per solution (run time / 8),
the fastest run, the slowest single call (one-point configurations), and the ratio
reference / configuration. Verdicts must agree. The last lines compare the cold fast
configuration with two targets (reported, never enforced; they were assertions of
tests/test_krawczyk.py, moved here because a test must not fail on a loaded machine): the slowest
fast call under TARGET_SLOWEST_CALL, and the median ratio reference / fast at least
TARGET_SPEEDUP. JSON goes to benchmarks/results/certify.json.

    python -m benchmarks.bench_certify [--repeats 7]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time
from pathlib import Path

import mpmath
import numpy as np

from spherekin.core import intervals
from spherekin.trust.krawczyk import certify, certify_many, certify_reference
from spherekin.mechanism import gosselin
from spherekin.trust.solutions import LOCAL_CHART
from spherekin.problem import solve

INPUTS = (0.3, -0.2, 0.5)
#: Fewest runs per configuration (the brief asks for >= 5 in one process).
MIN_REPEATS = 5
#: Target (s) for the slowest cold fast certify() call on a Gosselin solution: ~100x the measured
#: ~0.3-1 ms; a return to the mpmath cost (~10-30 ms per call) misses it.
TARGET_SLOWEST_CALL = 0.05
#: Target for the median ratio reference / fast (cold) in one process (measured ~15-30x).
TARGET_SPEEDUP = 4.0


def problems():
    """(system, theta) per solution of the Gosselin example, as finalize() certifies them."""
    mech = gosselin()
    report = solve(mech, INPUTS)
    names = report.unknowns
    out = []
    for sol in report.solutions:
        theta = np.asarray(sol.angles, dtype=float)
        system = mech.loop_system(INPUTS, {n: (a - LOCAL_CHART, a + LOCAL_CHART) for n, a in zip(names, theta)})
        out.append((system, theta))
    return mech, out


def _timed_calls(fn, items) -> tuple[list, float]:
    """fn(system, theta) per item: the results and the slowest call's seconds."""
    res, slowest = [], 0.0
    for s, t in items:
        t0 = time.perf_counter()
        res.append(fn(s, t))
        slowest = max(slowest, time.perf_counter() - t0)
    return res, slowest


def run(config: str, items) -> tuple[float, list, float]:
    """Seconds for certifying every item once under ``config``, the results, and the slowest
    single call (NaN for the batched configuration, which makes one call)."""
    if config in ("fast", "batched"):
        intervals.point_cos_sin.cache_clear()
    t0 = time.perf_counter()
    slowest = float("nan")
    if config == "reference":
        res, slowest = _timed_calls(certify_reference, items)
    elif config in ("fast", "fast_warm"):
        res, slowest = _timed_calls(certify, items)
    else:
        res = certify_many(items[0][0], [t for _, t in items])
    return time.perf_counter() - t0, res, slowest


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results" / "certify.json")
    args = parser.parse_args(argv)
    if args.repeats < MIN_REPEATS:
        parser.error(f"--repeats: expected at least {MIN_REPEATS}, got {args.repeats}")
    mech, items = problems()
    n = len(items)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
    print(f"{mech.name}, inputs {INPUTS} rad: {n} solutions; {args.repeats} runs per configuration; "
          f"{os.cpu_count()} cores, load {load:.2f}; Python {platform.python_version()}, numpy {np.__version__}, "
          f"mpmath {mpmath.__version__}")
    configs = ["reference", "fast", "fast_warm", "batched"]
    times = {c: [] for c in configs}
    slowest = {c: [] for c in configs}
    verdicts = {}
    run("fast", items)                                   # imports and first-call costs out of the way
    for _ in range(args.repeats):                        # interleaved, so load changes hit all alike
        for c in configs:
            t, res, worst = run(c, items)
            times[c].append(t / n)
            slowest[c].append(worst)
            verdicts[c] = [(r.certified, r.radius) for r in res]
    if len({tuple(v) for v in verdicts.values()}) != 1:
        raise SystemExit(f"verdicts differ between configurations: {verdicts}")
    ref = statistics.median(times["reference"])
    header = f"{'configuration':14s} {'median ms/sol':>13s} {'min ms/sol':>10s} {'max ms/call':>11s} {'ratio':>7s}"
    print(header)
    print("-" * len(header))
    rows = []
    for c in configs:
        med = statistics.median(times[c])
        worst = max(slowest[c])
        rows.append(dict(configuration=c, median_seconds_per_solution=med, min_seconds_per_solution=min(times[c]),
                         slowest_call_seconds=None if worst != worst else worst,
                         ratio_reference_over_this=ref / med, seconds_per_solution=times[c]))
        print(f"{c:14s} {med * 1e3:13.3f} {min(times[c]) * 1e3:10.3f} {worst * 1e3:11.3f} {ref / med:7.1f}")
    certified = sum(v for v, _ in verdicts["fast"])
    print(f"verdicts agree: {certified}/{n} certified (radius {sorted({r for _, r in verdicts['fast']})})")
    fast_worst, speedup = max(slowest["fast"]), ref / statistics.median(times["fast"])
    targets = dict(slowest_fast_call_seconds=fast_worst, slowest_fast_call_target=TARGET_SLOWEST_CALL,
                   slowest_fast_call_met=fast_worst < TARGET_SLOWEST_CALL, speedup_reference_over_fast=speedup,
                   speedup_target=TARGET_SPEEDUP, speedup_met=speedup >= TARGET_SPEEDUP)
    print(f"target: slowest cold fast call {fast_worst * 1e3:.2f} ms < {TARGET_SLOWEST_CALL * 1e3:g} ms: "
          f"{'met' if targets['slowest_fast_call_met'] else 'MISSED'}")
    print(f"target: reference / fast {speedup:.1f}x >= {TARGET_SPEEDUP:g}x: {'met' if targets['speedup_met'] else 'MISSED'}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({
        "benchmark": "certify", "mechanism": mech.name, "inputs": INPUTS, "solutions": n, "repeats": args.repeats,
        "certified": certified, "cores": os.cpu_count(), "load_average_1min": load,
        "python": platform.python_version(), "numpy": np.__version__, "mpmath": mpmath.__version__,
        "machine": platform.machine(), "rows": rows, "targets": targets}, indent=2))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
