"""Never lose a root: random poses -> inverse kinematics -> solve over full ranges -> is the pose found?

Alternates the agile eye (the Gosselin preset) and random general 3-RRR geometries. For each trial:
a random platform pose R0 (seeded), one of its inverse-kinematics working modes chosen at random
gives the actuator inputs; the direct kinematics over the full joint ranges must return a solution
whose platform rotation equals R0 (to MATCH_TOL). A *miss* is a trial where it does not; a
*spurious* solution is one whose pose violates the leg constraints w_i(beta_i) . (R v_i^0) =
cos(alpha2_i), computed here independently of the solver. Prints a summary table, writes JSON
(with the seeds of every miss, for regression tests) and exits 1 if anything was missed.

    python -m benchmarks.sweep_roots [--poses 1000] [--jobs 2] [--seed 0] [--parameterization sin-cos]

``--near-singular N``: instead, N inputs next to parallel singularities (issue 13). Seeded random
general 3-RRR geometries; on each, a segment of inputs along which the number of real assemblies
changes, its singular input found by bisection on the count of an independent 50-digit reference
(references/reference_roots.py), and the inputs at 1e-2, 1e-4, ..., 1e-12 on both sides (12 per
segment). Each input is judged by benchmarks/near_singular.py: exact and right, flagged (a lower
bound), wrong count, lost root, invented root. Table by distance band; JSON to
results/sweep_near_singular.json; exit 1 on any failure (a wrong or flagged-far count, a lost or
invented root).
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from spherekin.cluster import connect, map_in_order
from spherekin.mechanism import gosselin
from spherekin.search.boxloop import DEFAULT_PARAMETERIZATION, SolverLimitError
from spherekin.problem import solve

from references.random_designs import random_3rrr, random_rotation

#: A solution matches the pose when every entry of its rotation is this close to R0's: polished
#: solutions agree with the truth to ~1e-14; 1e-8 leaves room for ill-conditioned poses.
MATCH_TOL = 1e-8
#: A solution is spurious when a leg constraint is violated by more than this.
SPURIOUS_TOL = 1e-9


def leg_residual(mech_data, inputs, rot) -> float:
    u, w0, v0, a2 = mech_data
    worst = 0.0
    for i in range(3):
        k = u[i]
        kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        rot_u = np.eye(3) + math.sin(inputs[i]) * kx + (1 - math.cos(inputs[i])) * kx @ kx
        worst = max(worst, abs((rot_u @ w0[i]) @ (rot @ v0[i]) - math.cos(a2[i])))
    return worst


def trial(seed: int, parameterization: str = DEFAULT_PARAMETERIZATION) -> dict:
    rng = np.random.default_rng(seed)
    if seed % 2 == 0:
        mech = gosselin()
        data = ([np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, -1.0])],
                [np.array([0, 1.0, 0]), np.array([0, 0, -1.0]), np.array([1.0, 0, 0])],
                [np.array([0, 0, 1.0]), np.array([1.0, 0, 0]), np.array([0, 1.0, 0])],
                [math.pi / 2] * 3)
        kind = "agile eye"
    else:
        (mech, data), kind = random_3rrr(rng), "general"
    while True:
        r0 = random_rotation(rng)
        modes = mech.inverse_kinematics(r0)
        if modes:
            break
    mode = modes[int(rng.integers(len(modes)))]
    t0 = time.perf_counter()
    try:
        rep = solve(mech, mode.inputs, parameterization=parameterization)
    except SolverLimitError as exc:
        return dict(seed=seed, kind=kind, miss=True, spurious=0, solutions=0, seconds=time.perf_counter() - t0,
                    error=str(exc).split(";")[0])
    seconds = time.perf_counter() - t0
    miss = not any(np.abs(s.platform_rotation - r0).max() < MATCH_TOL for s in rep.solutions)
    spurious = sum(leg_residual(data, mode.inputs, s.platform_rotation) > SPURIOUS_TOL for s in rep.solutions
                   if s.platform_rotation is not None)
    statuses = [s.status for s in rep.solutions]
    return dict(seed=seed, kind=kind, miss=bool(miss), spurious=int(spurious), solutions=len(rep.solutions),
                seconds=seconds, statuses=statuses, boxes=rep.stats.boxes_processed)


def near_singular_segment(seed: int) -> list:
    """The judged near-singular inputs of one seeded segment (12 rows)."""
    from benchmarks.near_singular import judge, random_segment
    from references.reference_roots import near_singular_inputs

    mech, geometry, x_star, direction = random_segment(seed)
    rows = []
    for distance, inputs in near_singular_inputs(x_star, direction):
        t0 = time.perf_counter()
        verdict = judge(mech, geometry, inputs, distance)
        rows.append(dict(seed=seed, distance=float(distance), inputs=[float(v) for v in inputs],
                         seconds=time.perf_counter() - t0, **verdict))
    return rows


def near_singular_main(args) -> int:
    n_segments = -(-args.near_singular // 12)
    seeds = range(args.seed, args.seed + n_segments)
    t0 = time.perf_counter()
    rows = []
    with connect(workers=args.jobs if args.jobs > 1 else 0) as client:      # Dask: a local cluster of --jobs workers
        for i, part in enumerate(map_in_order(client, near_singular_segment, seeds), start=1):
            rows += part
            for r in part:
                if r["wrong"]:
                    print(f"  seed {r['seed']} distance {r['distance']:+.0e}: {r['wrong']}", flush=True)
            if i % 5 == 0:
                print(f"  {len(rows)} inputs, {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    rows = rows[:args.near_singular]
    wall = time.perf_counter() - t0
    bands = sorted({abs(r["distance"]) for r in rows}, reverse=True)
    head = (f"{'distance':>9s} {'inputs':>7s} {'exact&right':>12s} {'flagged':>8s} {'wrong count':>12s} "
            f"{'lost':>5s} {'invented':>9s} {'flagged>1e-8':>13s} {'median s':>9s} {'max s':>7s}")
    print(head)
    table = []
    for band in bands:
        part = [r for r in rows if abs(r["distance"]) == band]
        row = dict(distance=band, inputs=len(part),
                   exact_right=sum(r["exact"] and not r["wrong"] for r in part),
                   flagged=sum(not r["exact"] for r in part),
                   wrong_count=sum("wrong_count" in r["wrong"] for r in part),
                   lost=sum(r["wrong"].get("lost", 0) for r in part),
                   invented=sum(r["wrong"].get("invented", 0) for r in part),
                   flagged_far=sum("flagged_far" in r["wrong"] for r in part),
                   median_seconds=statistics.median(r["seconds"] for r in part),
                   max_seconds=max(r["seconds"] for r in part))
        table.append(row)
        print(f"{band:9.0e} {row['inputs']:7d} {row['exact_right']:12d} {row['flagged']:8d} {row['wrong_count']:12d} "
              f"{row['lost']:5d} {row['invented']:9d} {row['flagged_far']:13d} {row['median_seconds']:9.2f} "
              f"{row['max_seconds']:7.2f}")
    print(f"{len(rows)} inputs on {n_segments} segments, wall time {wall:.0f} s with {args.jobs} processes "
          "(times include the 50-digit reference)")
    out = args.out or Path(__file__).parent / "results" / "sweep_near_singular.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(dict(table=table, wall_seconds=wall, jobs=args.jobs, rows=rows), indent=1))
    print(f"wrote {out}")
    return 1 if any(r["wrong"] for r in rows) else 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=1000)
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1,
                        help="Dask worker processes of a local cluster (1: in this process; default: one per core)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--parameterization", default=DEFAULT_PARAMETERIZATION,
                        help="tan-half or sin-cos (default %(default)s)")
    parser.add_argument("--out", type=Path, default=None,
                        help="JSON output (default results/sweep_roots.json, sweep_roots_sin-cos.json for sin-cos)")
    parser.add_argument("--near-singular", type=int, default=0, metavar="N",
                        help="judge N inputs next to parallel singularities instead (12 per random segment)")
    args = parser.parse_args(argv)
    if args.near_singular:
        return near_singular_main(args)
    if args.out is None:
        suffix = "" if args.parameterization == DEFAULT_PARAMETERIZATION else f"_{args.parameterization}"
        args.out = Path(__file__).parent / "results" / f"sweep_roots{suffix}.json"
    seeds = range(args.seed, args.seed + args.poses)
    t0 = time.perf_counter()
    rows = []
    with connect(workers=args.jobs if args.jobs > 1 else 0) as client:      # Dask: a local cluster of --jobs workers
        for i, row in enumerate(map_in_order(client, functools.partial(trial, parameterization=args.parameterization),
                                             seeds), start=1):
            rows.append(row)
            if row["miss"] or row["spurious"]:
                print(f"  seed {row['seed']} ({row['kind']}): miss={row['miss']} spurious={row['spurious']} "
                      f"{row.get('error', '')}", flush=True)
            if i % 50 == 0:
                print(f"  {i}/{args.poses} poses, {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    wall = time.perf_counter() - t0
    print(f"parameterization {args.parameterization}")
    print(f"{'kind':10s} {'poses':>6s} {'misses':>7s} {'spurious':>9s} {'median s':>9s} {'max s':>7s} "
          f"{'solutions (median)':>19s}  statuses of all solutions")
    summary = {}
    for kind in ("agile eye", "general"):
        part = [r for r in rows if r["kind"] == kind]
        if not part:
            continue
        s = dict(poses=len(part), misses=sum(r["miss"] for r in part), spurious=sum(r["spurious"] for r in part),
                 median_seconds=statistics.median(r["seconds"] for r in part),
                 max_seconds=max(r["seconds"] for r in part),
                 median_solutions=statistics.median(r["solutions"] for r in part),
                 statuses={k: sum(st == k for r in part for st in r.get("statuses", ()))
                           for k in ("certified", "singular", "unverified", "cluster", "continuum")})
        summary[kind] = s
        print(f"{kind:10s} {s['poses']:6d} {s['misses']:7d} {s['spurious']:9d} {s['median_seconds']:9.2f} "
              f"{s['max_seconds']:7.2f} {s['median_solutions']:19.1f}  "
              + ", ".join(f"{v} {k}" for k, v in s["statuses"].items()))
    print(f"wall time {wall:.0f} s with {args.jobs} processes")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(dict(summary=summary, wall_seconds=wall, jobs=args.jobs,
                                        parameterization=args.parameterization,
                                        misses=[r for r in rows if r["miss"] or r["spurious"]], rows=rows),
                                   indent=1))
    print(f"wrote {args.out}")
    return 1 if any(r["miss"] for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
