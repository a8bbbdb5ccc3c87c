"""The trust layer over a chunk of inputs at once against a loop of the per-input trust layer, same run.

For each mechanism: ``--inputs`` (default 256) seeded random actuator inputs whose search finishes
at the strategy's tol (the platform search where it applies and isolates every root, else the loop
equations'), their clusters found once; then, ``--runs`` times, alternating:

* ``finalize_many``: :func:`spherekin.trust.solutions.finalize_many` on the whole chunk;
* ``loop of finalize``: :func:`spherekin.trust.solutions.finalize` on each input.

Reported: the median milliseconds per input of each and their ratio, and whether the answers agree
entry for entry (statuses and angles).

    python -m benchmarks.bench_trust_many [--inputs 256] [--runs 3] [examples/general_3rrr.toml ...]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from spherekin.problem import compile
from spherekin.systems import Passed
from spherekin.trust.solutions import finalize, finalize_many

DEFAULT_MECHANISMS = ("examples/general_3rrr.toml", "examples/four_bar.toml")


def chunk(path: str, n: int, seed: int = 0):
    """(mechanism, inputs (n, A), names, clusters per input, tol) of n seeded random inputs."""
    p = compile(path)
    m = p.mechanism
    rng = np.random.default_rng(seed)
    inputs, clusters = [], []
    while len(inputs) < n:
        values = m.check_inputs(rng.uniform(-np.pi, np.pi, len(m.actuated)))
        found = next(f for f in (c.search_one(values, None, None) for c in p.chain)
                     if not isinstance(f, Passed))                # the first system of the chain that answers
        if found.limit is not None:
            continue                                  # a covering run: another tol
        inputs.append(values)
        clusters.append(found.report.clusters)
    return m, np.array(inputs), p.names, clusters, p.strategy.tol


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mechanisms", nargs="*", default=list(DEFAULT_MECHANISMS))
    ap.add_argument("--inputs", type=int, default=256)
    ap.add_argument("--runs", type=int, default=3)
    args = ap.parse_args(argv)
    for path in args.mechanisms:
        m, inputs, names, clusters, tol = chunk(path, args.inputs)
        finalize_many(m, inputs[:8], names, clusters[:8], tol)          # warm the caches alike
        many, loop = [], []
        for _ in range(args.runs):
            t0 = time.perf_counter()
            got = finalize_many(m, inputs, names, clusters, tol)
            t1 = time.perf_counter()
            want = [finalize(m, tuple(x), names, c, tol) for x, c in zip(inputs, clusters)]
            t2 = time.perf_counter()
            many.append((t1 - t0) / len(inputs) * 1e3)
            loop.append((t2 - t1) / len(inputs) * 1e3)
        agree = all(len(g) == len(w) and all(a.status == b.status and np.allclose(a.angles, b.angles, atol=1e-12, rtol=0)
                                             for a, b in zip(g, w)) for g, w in zip(got, want))
        a, b = statistics.median(many), statistics.median(loop)
        print(f"{path}: {len(inputs)} inputs, {sum(map(len, clusters)) / len(inputs):.1f} clusters each; "
              f"finalize_many {a:.2f} ms/input, loop of finalize {b:.2f} ms/input, {b / a:.1f}x; agree: {agree}")


if __name__ == "__main__":
    main()
