"""The extended-precision Krawczyk test in FLINT/Arb balls against mpmath's intervals, same run (issue 44 item 4).

``spherekin.trust.extended`` decides the boxes the float test cannot (two assemblies closer than
~1e-5, inputs next to a singularity): up to 1,000 tests per input at 50 digits, most of an edge
solve's time in mpmath's ``iv`` (benchmarks/README.md). It now computes in python-flint's ``arb``
balls by default, with mpmath kept as the reference (``arithmetic="mpmath"``). For each input below,
the boxes are those a user's solve leaves to it: around every entry the solve reports (every
assembly, certified or not, and every unresolved cluster), of radii 1e-10, 1e-8 and 1e-6 rad,
centred and shifted by 0.5 and 3 radii (seeded); each arithmetic tests them all with
``krawczyk_boxes_extended``, timed over ``--runs`` runs (median). Reported: boxes, seconds per
arithmetic, the ratio, boxes certified / shown empty by each, and contradictions (a box one
certifies and the other shows empty: must be 0). JSON to benchmarks/results/extended.json.

    python -m benchmarks.bench_extended [--runs 3]
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
RADII = (1e-10, 1e-8, 1e-6)
SHIFTS = (0.0, 0.5, 3.0)


def _inputs():
    """(name, mechanism, inputs) of the cases: the agile eye 1e-6 and 1e-8 from its singular lines,
    general_3rrr next to its issue-13 fold (two assemblies 1.48e-5 apart)."""
    from references.edge_references import agile_eye_edge
    from spherekin.mechanism import general_3rrr, gosselin

    out = []
    for sign, beta3, direction in ((1, 0.3, (0.6, 0.8, 0.3)), (-1, -1.1, (0.2, -1.0, 0.5))):
        edge = agile_eye_edge(beta3, direction, sign)
        for d in (1e-6, 1e-8):
            x = tuple(float(a + d * b) for a, b in zip(edge.x_star, edge.direction))
            out.append((f"agile eye, line beta2={'+' if sign > 0 else '-'}pi/2, d={d:g}", gosselin(), x))
    out.append(("general_3rrr, issue-13 twins", general_3rrr(),
                (0.18613171226800826, -0.15119930525771785, 0.6382686351031328)))
    return out


def _boxes(report, seed: int):
    rng = np.random.default_rng(seed)
    lo, hi = [], []
    for s in report.solutions:
        c = np.asarray(s.angles, dtype=float)
        for r in RADII:
            for shift in SHIFTS:
                d = rng.normal(size=c.shape) * r * shift
                lo.append(c + d - r)
                hi.append(c + d + r)
    return np.array(lo), np.array(hi)


def main(argv=None) -> int:
    import spherekin
    from spherekin.trust.extended import krawczyk_boxes_extended

    ap = argparse.ArgumentParser(prog="python -m benchmarks.bench_extended", description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--json", default=str(ROOT / "benchmarks" / "results" / "extended.json"))
    args = ap.parse_args(argv)
    rows = []
    for k, (name, mech, x) in enumerate(_inputs()):
        report = spherekin.solve(mech, x)
        lo, hi = _boxes(report, seed=k)
        times, tests = {}, {}
        for _ in range(args.runs):
            for arithmetic in ("mpmath", "arb"):
                t = time.perf_counter()
                tests[arithmetic] = krawczyk_boxes_extended(mech, x, lo, hi, arithmetic=arithmetic)
                times.setdefault(arithmetic, []).append(time.perf_counter() - t)
        a, m = tests["arb"], tests["mpmath"]
        rows.append(dict(
            input=name, inputs=list(x), boxes=len(lo),
            mpmath_s=statistics.median(times["mpmath"]), arb_s=statistics.median(times["arb"]),
            ratio=statistics.median(times["mpmath"]) / statistics.median(times["arb"]),
            certified=dict(mpmath=int(m.certified.sum()), arb=int(a.certified.sum())),
            no_solution=dict(mpmath=int(m.no_solution.sum()), arb=int(a.no_solution.sum())),
            contradictions=int(np.sum(a.certified & m.no_solution) + np.sum(m.certified & a.no_solution)),
            both_certified=int(np.sum(a.certified & m.certified))))
    headers = ["input", "boxes", "mpmath s", "arb s", "mpmath / arb", "certified (mp / arb)", "empty (mp / arb)",
               "contradictions"]
    lines = [[r["input"], str(r["boxes"]), f"{r['mpmath_s']:.2f}", f"{r['arb_s']:.2f}", f"{r['ratio']:.1f}x",
              f"{r['certified']['mpmath']} / {r['certified']['arb']}",
              f"{r['no_solution']['mpmath']} / {r['no_solution']['arb']}", str(r["contradictions"])] for r in rows]
    widths = [max(len(h), *(len(line[i]) for line in lines)) for i, h in enumerate(headers)]
    print("  ".join(h.ljust(w) for h, w in zip(headers, widths)))
    print("  ".join("-" * w for w in widths))
    for line in lines:
        print("  ".join(v.ljust(w) for v, w in zip(line, widths)))
    total = sum(r["mpmath_s"] for r in rows) / sum(r["arb_s"] for r in rows)
    print(f"\nall boxes: mpmath / arb = {total:.1f}x (medians of {args.runs} runs; radii {RADII}, shifts {SHIFTS})")
    import flint
    import mpmath

    out = dict(benchmark="bench_extended", rows=rows, total_ratio=total, runs=args.runs, radii=RADII, shifts=SHIFTS,
               versions=dict(python=platform.python_version(), flint=flint.__version__, mpmath=mpmath.__version__,
                             spherekin=spherekin.__version__),
               machine=platform.processor() or platform.machine(), date=time.strftime("%Y-%m-%d"))
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps(out, indent=2))
    print(f"wrote {args.json}")
    return 0 if all(r["contradictions"] == 0 for r in rows) else 1


if __name__ == "__main__":
    raise SystemExit(main())
