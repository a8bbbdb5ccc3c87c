"""Tracking one assembly mode along a path against solving every input fully, same run.

The path: ``--steps`` (default 1,000) actuator inputs of general_3rrr from the inverse kinematics
(one working mode) of a smooth pose curve, chosen away from parallel singularities. Two ways to
follow the assembly that starts at the first pose:

* ``track``: ``problem.track(path, start=R0)``, every step proven (spherekin.trust.continuation);
* ``full solves + nearest``: ``problem.solve(x)`` at every input (the compiled problem: the
  fastest full solve there is), then the solution nearest to the previous pose (what one would do
  without a tracker; it has no proof that it did not switch modes).

Reported: median seconds over ``--runs`` runs of each, per-row milliseconds, the speedup (full /
track; target >= 50), and whether both gave the generating poses (to 1e-9). JSON to
benchmarks/results/track.json.

    python -m benchmarks.bench_track [--steps 1000] [--runs 3]
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

ROOT = Path(__file__).resolve().parent.parent


def smooth_path(mech, steps: int):
    """(poses (steps, 3, 3), inputs (steps, 3)) of a smooth pose curve every leg reaches in one working mode."""
    from scipy.spatial.transform import Rotation

    ts = np.linspace(0.0, 1.0, steps)
    rots = Rotation.from_rotvec(np.array([0.1, 0.05, -0.1]) + np.outer(ts, [0.6, -0.4, 0.8])
                                + 0.1 * np.outer(np.sin(4 * ts), [1.0, -1.0, 0.5])).as_matrix()
    mode = mech.inverse_kinematics(rots[0])[2].working_mode
    inputs = np.array([[s for s in mech.inverse_kinematics(r) if s.working_mode == mode][0].inputs for r in rots])
    return rots, inputs


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--json", default=str(ROOT / "benchmarks" / "results" / "track.json"))
    args = ap.parse_args(argv)

    from spherekin import compile as compile_problem
    from spherekin.mechanism import general_3rrr

    mech = general_3rrr()
    rots, path = smooth_path(mech, args.steps)
    problem = compile_problem(mech)
    problem.track(path[:20], start=rots[0])                 # warm-up (imports, caches)
    problem.solve(path[0])
    t_track, t_full, ok_track, ok_full = [], [], True, True
    for run in range(args.runs):
        t0 = time.perf_counter()
        tr = problem.track(path, start=rots[0])
        t_track.append(time.perf_counter() - t0)
        ok_track &= tr.complete and max(np.abs(p.platform_rotation - r).max() for p, r in zip(tr.poses, rots)) < 1e-9
        t0 = time.perf_counter()
        previous, followed = rots[0], []
        for x in path:
            report = problem.solve(x)
            poses = [s.platform_rotation for s in report.solutions if s.platform_rotation is not None]
            previous = min(poses, key=lambda r: np.abs(r - previous).max())
            followed.append(previous)
        t_full.append(time.perf_counter() - t0)
        ok_full &= max(np.abs(f - r).max() for f, r in zip(followed, rots)) < 1e-9
        print(f"run {run + 1}/{args.runs}: track {t_track[-1]:.3f} s, full solves {t_full[-1]:.2f} s", flush=True)
    track_s, full_s = statistics.median(t_track), statistics.median(t_full)
    print(f"\ngeneral_3rrr, a smooth path of {args.steps} inputs; medians of {args.runs} run(s); {os.cpu_count()} cores")
    print(f"{'method':28s} {'seconds':>8s} {'ms per row':>11s} {'poses right':>12s}")
    print(f"{'track (every step proven)':28s} {track_s:8.3f} {1e3 * track_s / args.steps:11.3f} {str(ok_track):>12s}")
    print(f"{'full solves + nearest':28s} {full_s:8.3f} {1e3 * full_s / args.steps:11.3f} {str(ok_full):>12s}")
    print(f"speedup of track: {full_s / track_s:.1f}x (target >= 50); proven steps {tr.proven_steps}, rejected {tr.rejected_steps}")
    out = Path(args.json)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"machine": {"cores": os.cpu_count(), "processor": platform.processor(),
                                           "python": platform.python_version()},
                               "date": time.strftime("%Y-%m-%d"), "steps": args.steps, "runs": args.runs,
                               "track_s": t_track, "full_s": t_full, "speedup": full_s / track_s,
                               "track_right": bool(ok_track), "full_right": bool(ok_full)}, indent=2))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
