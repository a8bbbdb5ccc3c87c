"""Benchmark of the Bernstein core on the paper's Gosselin loops.

Measures, on the 81-control-point tensor of loop 1:
  * sub-box restriction of B boxes: one batched ``restrict`` call vs a Python loop of single calls
    (baseline) vs the de Casteljau reference ``restrict_reference``;
  * building the loop's control points by the recursion route vs the product route.
Prints a table of medians over ``--repeats`` runs, with ratios against the baseline measured in
the same process, and writes the numbers as JSON.

    python -m benchmarks.bench_bernstein [--boxes 1000] [--repeats 7] [--out FILE]
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import time
from pathlib import Path

import numpy as np

from spherekin.core import bernstein
from spherekin.paper_gosselin import paper_gosselin_loops


def median_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def random_boxes(rng, count: int, n: int) -> np.ndarray:
    ends = np.sort(rng.uniform(0.0, 1.0, (count, n, 2)), axis=-1)
    ends[..., 1] = np.maximum(ends[..., 1], ends[..., 0] + 1e-3)
    return np.clip(ends, 0.0, 1.0)


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--boxes", type=int, default=1000)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results" / "bernstein.json")
    args = parser.parse_args(argv)

    loop = paper_gosselin_loops((0.3, -0.2, 0.5))[0]
    c = loop.scalar_control_points()
    boxes = random_boxes(np.random.default_rng(args.seed), args.boxes, c.ndim)
    n_ref = max(1, args.boxes // 10)  # the reference is slow: time a tenth and scale per box

    # correctness guard before timing: all three agree
    batched = bernstein.restrict(c, boxes)
    for k in range(0, args.boxes, max(1, args.boxes // 20)):
        np.testing.assert_allclose(batched[k], bernstein.restrict(c, boxes[k]), rtol=0, atol=1e-9 * np.abs(c).max())
        np.testing.assert_allclose(batched[k], bernstein.restrict_reference(c, boxes[k]), rtol=0,
                                   atol=1e-9 * np.abs(c).max())

    rows = {
        "restrict, loop of single calls (baseline)": median_time(
            lambda: [bernstein.restrict(c, b) for b in boxes], args.repeats) / args.boxes,
        "restrict, one batched call": median_time(lambda: bernstein.restrict(c, boxes), args.repeats) / args.boxes,
        "restrict_reference (de Casteljau), loop": median_time(
            lambda: [bernstein.restrict_reference(c, b) for b in boxes[:n_ref]], args.repeats) / n_ref,
        "control points, recursion route (per loop)": median_time(
            lambda: loop.scalar_control_points("recursion"), args.repeats),
        "control points, product route (per loop)": median_time(
            lambda: loop.scalar_control_points("product"), args.repeats),
    }
    baseline = rows["restrict, loop of single calls (baseline)"]
    print(f"Bernstein core on Gosselin loop 1 (81 control points), {args.boxes} boxes, "
          f"median of {args.repeats} runs")
    print(f"{'operation':48s} {'time':>12s} {'vs baseline':>12s}")
    for name, sec in rows.items():
        ratio = f"{baseline / sec:10.1f}x" if name.startswith("restrict") else ""
        print(f"{name:48s} {sec * 1e6:9.1f} us {ratio:>12s}")
    result = {
        "benchmark": "bernstein",
        "boxes": args.boxes,
        "repeats": args.repeats,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "seconds": rows,
        "speedup_batched_vs_loop": baseline / rows["restrict, one batched call"],
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2))
    print(f"wrote {args.out}")
    return result


if __name__ == "__main__":
    main()
