"""Benchmark of the loop system's compiled chart sets: ms per input of ``CompiledLoops.charts_many`` at
K inputs against the direct build (``make_charts``) per input, same run, medians.

    python -m benchmarks.bench_loop_charts [--k 256] [--repeats 7]

Prints one line per mechanism (four-bar, five-bar, the Watt six-bar, general_3rrr on the loop
equations): the compile time (3^A direct builds and the seeded check), the ms per input of each
path (charts_many also with ``dense=False``: the halves without the dense coefficients of the
bilinear blocks) and the ratio of the direct build to charts_many.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from pathlib import Path

import numpy as np

from spherekin.problem import compile
from spherekin.search.parameterizations import make_charts

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
CASES = (("four-bar", "four_bar.toml", {}), ("five-bar", "five_bar.toml", {}),
         ("Watt six-bar", "watt_six_bar.toml", {}), ("general_3rrr (loops)", "general_3rrr.toml", {"system": "loops"}))


def run(k: int = 256, repeats: int = 7, direct_inputs: int = 32) -> list[dict]:
    out = []
    for label, file, kw in CASES:
        p = compile(EXAMPLES / file, **kw)
        loops, m = p.loops, p.mechanism
        rng = np.random.default_rng(0)
        rows = np.array([[rng.uniform(*(m.joint(n).range or (-math.pi, math.pi))) for n in m.actuated]
                         for _ in range(k)])
        t0 = time.perf_counter()
        loops.compiled_charts(p.ranges)
        t_compile = time.perf_counter() - t0
        many, lean, one = [], [], []
        for _ in range(repeats):
            t0 = time.perf_counter()
            loops.charts_many(rows, p.ranges)
            many.append((time.perf_counter() - t0) / k)
            t0 = time.perf_counter()
            loops.charts_many(rows, p.ranges, dense=False)
            lean.append((time.perf_counter() - t0) / k)
        for _ in range(max(1, repeats // 2)):
            t0 = time.perf_counter()
            for x in rows[:direct_inputs]:
                make_charts(p.strategy.parameterization, loops.builder(tuple(x)), p.ranges, loops.formulation)
            one.append((time.perf_counter() - t0) / direct_inputs)
        row = {"mechanism": label, "compile_s": t_compile, "charts_many_ms": 1e3 * statistics.median(many),
               "halves_only_ms": 1e3 * statistics.median(lean),
               "make_charts_ms": 1e3 * statistics.median(one)}
        row["ratio"] = row["make_charts_ms"] / row["charts_many_ms"]
        out.append(row)
        print(f"{label:22s} compile {t_compile:6.2f} s  charts_many {row['charts_many_ms']:7.3f} ms/input (K={k})  "
              f"(halves only {row['halves_only_ms']:6.3f})  make_charts {row['make_charts_ms']:7.2f} ms/input  ratio {row['ratio']:6.0f}x", flush=True)
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--k", type=int, default=256)
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args(argv)
    run(args.k, args.repeats)


if __name__ == "__main__":
    main()
