"""The complex Krawczyk test of the complete count in three arithmetics (issue 44, item 4).

    python -m benchmarks.bench_bezout [--inputs 256] [--repeats 3]

The roots of general_3rrr's leg quadrics at seeded inputs (the complete count's own candidates and
interval matrices, ``spherekin/systems/complete.py``) are proven three ways, each timed (medians of
``--repeats``) and their verdicts compared root by root:

* ``fast``: :func:`spherekin.core.bezout.certify_roots` (midpoint-radius, a priori rounding bounds;
  batched over every root of every input: the default);
* ``intervals``: the same with ``arithmetic="intervals"`` (outward rounding at every operation, batched);
* ``acb``: FLINT's complex balls (python-flint ``acb``, ``acb_mat``) at 53 bits, the same test written
  root by root (ball arithmetic is per object: a Python loop over the roots), on the polished points of
  ``fast`` and the same radii.

Prints a table (seconds per input, roots proven, verdicts that differ from ``fast``) and writes
benchmarks/results/bezout.json.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import flint  # noqa: E402
import numpy as np  # noqa: E402

import spherekin  # noqa: E402
from spherekin.core import bezout  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SEED = 44


def acb_test(m_lo, m_hi, q, chart, radius) -> bool:
    """The Krawczyk test of :func:`spherekin.core.bezout._krawczyk_intervals` for one root q (4,) complex
    on its chart, in FLINT complex balls: F(y) and J(X) over every matrix in [m_lo, m_hi] (3, 4, 4)."""
    free = [j for j in range(4) if j != chart]
    mats = [[[flint.acb(flint.arb(0.5 * (m_lo[k, i, j] + m_hi[k, i, j]), 0.5 * (m_hi[k, i, j] - m_lo[k, i, j])))
              for j in range(4)] for i in range(4)] for k in range(3)]
    y = [flint.acb(complex(v).real, complex(v).imag) for v in q]
    r = flint.arb(0, radius)
    x = [y[j] + flint.acb(r, r) if j != chart else y[j] for j in range(4)]
    f = [sum((y[i] * mats[k][i][j] * y[j] for i in range(4) for j in range(4)), flint.acb(0)) for k in range(3)]
    jx = flint.acb_mat([[2 * sum((mats[k][c][j] * x[j] for j in range(4)), flint.acb(0)) for c in free] for k in range(3)])
    jc = np.array([[2 * sum(complex(mats[k][c][j].mid()) * complex(q[j]) for j in range(4)) for c in free]
                   for k in range(3)])
    try:
        c_np = np.linalg.inv(jc)
    except np.linalg.LinAlgError:
        return False
    c = flint.acb_mat([[flint.acb(v.real, v.imag) for v in row] for row in c_np])
    dx = flint.acb_mat([[x[j] - y[j]] for j in free])
    fy = flint.acb_mat([[v] for v in f])
    k = flint.acb_mat([[y[j]] for j in free]) - c * fy + (flint.acb_mat(3, 3, [1, 0, 0, 0, 1, 0, 0, 0, 1]) - c * jx) * dx
    for i, j in enumerate(free):
        box = flint.acb(flint.arb(complex(q[j]).real, radius), flint.arb(complex(q[j]).imag, radius))
        if not box.contains_interior(k[i, 0]):
            return False
    return True


def run(n_inputs: int, repeats: int) -> dict:
    problem = spherekin.compile(ROOT / "examples" / "general_3rrr.toml")
    compiled = problem.compiled("complete")
    rows = np.random.default_rng(SEED).uniform(-np.pi, np.pi, (n_inputs, 3))
    m_iv, cands = compiled.matrices(rows), compiled.candidates(rows)
    times: dict = {"fast": [], "intervals": [], "acb": []}
    proofs = {}
    for _ in range(repeats):
        for name in ("fast", "intervals"):
            t0 = time.perf_counter()
            proofs[name] = bezout.certify_roots(m_iv, cands, name)
            times[name].append(time.perf_counter() - t0)
        fast = proofs["fast"]
        t0 = time.perf_counter()
        verdicts = np.zeros(fast.certified.shape, dtype=bool)
        for k in range(n_inputs):
            for n in range(fast.certified.shape[1]):
                r = fast.radius[k, n] if np.isfinite(fast.radius[k, n]) else bezout.RADII[0]
                verdicts[k, n] = acb_test(m_iv[0, k], m_iv[1, k], fast.roots[k, n], fast.chart[k, n], r)
        times["acb"].append(time.perf_counter() - t0)
    fast = proofs["fast"]
    rows_out = []
    for name in times:
        proven = (proofs[name].certified if name != "acb" else verdicts)
        rows_out.append(dict(arithmetic=name, seconds_per_input=statistics.median(times[name]) / n_inputs,
                             roots_proven=int(proven.sum()), roots=int(proven.size),
                             differ_from_fast=int((proven != fast.certified).sum())))
    return dict(inputs=n_inputs, repeats=repeats, seed=SEED, python_flint=flint.__version__, rows=rows_out)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--inputs", type=int, default=256)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "bezout.json")
    args = parser.parse_args(argv)
    if args.inputs < 1 or args.repeats < 1:
        parser.error("--inputs, --repeats: expected whole numbers >= 1")
    data = run(args.inputs, args.repeats)
    fast = data["rows"][0]["seconds_per_input"]
    print(f"{'arithmetic':10s} {'us/input':>9s} {'x fast':>7s} {'proven':>9s} {'differ':>6s}")
    for r in data["rows"]:
        print(f"{r['arithmetic']:10s} {1e6 * r['seconds_per_input']:9.1f} {r['seconds_per_input'] / fast:7.1f} "
              f"{r['roots_proven']:5d}/{r['roots']:<3d} {r['differ_from_fast']:6d}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(data, indent=2))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
