"""Tracking one assembly mode along a path against solving every input fully, same run.

The path: ``--steps`` (default 1,000) actuator inputs of general_3rrr from the inverse kinematics
(one working mode) of a smooth pose curve, chosen away from parallel singularities, its rows
``--spacing`` radians apart (default 0.01, a normal resolution: the mean over the rows of the largest
input change; the curve is walked forth and back as often as the rows need). ``--spacing 0`` gives
the path of issues 15-27 instead: 1,000 rows on one pass of the curve, ~0.0013 rad apart. Two ways
to follow the assembly that starts at the first pose:

* ``track``: ``problem.track(path, start=R0)``, every step proven (spherekin.trust.continuation);
* ``full solves (solve_many, the engine) + nearest``: the same with every input in chunks of the
  array engine (issue 30), the fastest full solves there are;
* ``full solves + nearest``: ``problem.solve(x)`` at every input (the compiled problem: the
  fastest full solve there is), then the solution nearest to the previous pose (what one would do
  without a tracker; it has no proof that it did not switch modes).

Both in this process (imports and compilation done before the clock starts), and as whole processes
(on by default; ``--no-cli`` skips them): ``spherekin track FILE --path P.csv --start-rotation R0``
writing its results three ways (the printed table only; ``--json`` too: every pose; ``--out T.csv``
too: the results table of batch) against ``spherekin batch FILE --inputs P.csv --workers 0 --out
B.csv`` (every row solved in that process by the engine, one core) and against a script that solves
every row with ``solve`` (:data:`SOLVE_LOOP_SCRIPT`: the full solves of issue 30's target), each
timed from the process's start to its
exit (Python's start, imports, reading the files, writing the results), with spherekin's compiled
modules cached as after ``pip install`` (in a temporary PYTHONPYCACHEPREFIX, filled by a first
untimed run); ``spherekin --help`` alone gives the start-up (Python, the imports, no work).

Reported: median seconds over ``--runs`` runs of each, per-row milliseconds, the speedups (full /
track; target >= 20 at 0.01 rad), whether both in-process methods gave the generating poses (to
1e-9), the proven and rejected steps. JSON to benchmarks/results/track.json.

    python -m benchmarks.bench_track [--steps 1000] [--spacing 0.01] [--runs 3] [--no-cli]
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
#: Samples of the pose curve on which its input length is measured (``--spacing``). Reason: the rows
#: are placed by linear interpolation of the curve parameter between samples; 1,000 keeps the
#: spacing within ~1e-4 of itself for the curve's 1.35 rad of input.
CURVE_SAMPLES = 1_000


def _curve(ts):
    """The pose curve (rotations (len(ts), 3, 3)) at parameters ts in [0, 1]."""
    from scipy.spatial.transform import Rotation

    ts = np.asarray(ts, dtype=float)
    return Rotation.from_rotvec(np.array([0.1, 0.05, -0.1]) + np.outer(ts, [0.6, -0.4, 0.8])
                                + 0.1 * np.outer(np.sin(4 * ts), [1.0, -1.0, 0.5])).as_matrix()


def _inputs(mech, rots):
    """The inputs (K, 3) of the working mode of the first pose's third IK solution along ``rots``,
    unwrapped (no 2 pi jump between rows: the straight segment between two rows is what is tracked)."""
    mode = mech.inverse_kinematics(rots[0])[2].working_mode
    return np.unwrap(np.array([[s for s in mech.inverse_kinematics(r) if s.working_mode == mode][0].inputs
                               for r in rots]), axis=0)


def smooth_path(mech, steps: int, spacing: float = 0.0):
    """(poses (steps, 3, 3), inputs (steps, 3)) of a smooth pose curve every leg reaches in one
    working mode. ``spacing`` 0: one pass of the curve in ``steps`` rows (parameter uniform); else rows
    ``spacing`` radians apart in input (the largest input change, measured along the curve), the
    curve walked forth and back as often as needed."""
    if spacing <= 0:
        rots = _curve(np.linspace(0.0, 1.0, steps))
        return rots, _inputs(mech, rots)
    ts = np.linspace(0.0, 1.0, CURVE_SAMPLES + 1)
    fine = _inputs(mech, _curve(ts))
    length = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(fine, axis=0)).max(axis=1))])
    u = np.mod(spacing * np.arange(steps), 2 * length[-1])
    u = np.where(u > length[-1], 2 * length[-1] - u, u)           # forth and back
    rots = _curve(np.interp(u, length, ts))
    return rots, _inputs(mech, rots)


def _env(pycache: str) -> dict:
    """The environment of a timed process: this checkout first on the path, compiled modules cached
    in ``pycache`` (PYTHONPYCACHEPREFIX; a first untimed run fills it), as after ``pip install``,
    which writes them. (A sandbox's PYTHONDONTWRITEBYTECODE=1 would make every process compile
    spherekin from source: ~0.25 s that no installed copy pays.)"""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONDONTWRITEBYTECODE", "PYTHONPYCACHEPREFIX")}
    env.update(PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""), PYTHONPYCACHEPREFIX=pycache)
    return env


#: The whole process of full solves one row at a time (issue 30's baseline: "full solves", a `solve`
#: per row, what the per-input pipeline was before the engine): a Python script reading the path's
#: CSV, compiling the mechanism once and solving every row.
SOLVE_LOOP_SCRIPT = (
    "import sys, numpy as np, spherekin\n"
    "from spherekin.mechanism.io import load_mechanism\n"
    "problem = spherekin.compile(load_mechanism(sys.argv[1]))\n"
    "for row in np.loadtxt(sys.argv[2], delimiter=',', skiprows=1, ndmin=2):\n"
    "    problem.solve(row)\n")


def _run(cmd, env) -> float:
    """Wall seconds of the process ``cmd`` (its exit status must be 0)."""
    t0 = time.perf_counter()
    done = subprocess.run(cmd, env=env, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, cmd))} exited {done.returncode}: {done.stderr.strip()[-500:]}")
    return seconds


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--spacing", type=float, default=0.01,
                    help="radians between rows (0: the single pass of issues 15-27, ~0.0013 rad)")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--no-cli", dest="cli", action="store_false", help="skip the whole-process timings")
    ap.add_argument("--json", default=str(ROOT / "benchmarks" / "results" / "track.json"))
    args = ap.parse_args(argv)

    from spherekin import compile as compile_problem
    from spherekin.mechanism import general_3rrr

    mech = general_3rrr()
    rots, path = smooth_path(mech, args.steps, args.spacing)
    gaps = np.abs(np.diff(path, axis=0)).max(axis=1)
    problem = compile_problem(mech)
    problem.track(path[:20], start=rots[0])                 # warm-up (imports, caches)
    problem.solve(path[0])
    t_track, t_full, t_engine, ok_track, ok_full, ok_engine = [], [], [], True, True, True
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
        t0 = time.perf_counter()                              # the same with the array engine (issue 30)
        previous, followed = rots[0], []
        for report in problem.solve_many(path):
            poses = [s.platform_rotation for s in report.solutions if s.platform_rotation is not None]
            previous = min(poses, key=lambda r: np.abs(r - previous).max())
            followed.append(previous)
        t_engine.append(time.perf_counter() - t0)
        ok_engine &= max(np.abs(f - r).max() for f, r in zip(followed, rots)) < 1e-9
        print(f"run {run + 1}/{args.runs}: track {t_track[-1]:.3f} s, full solves {t_full[-1]:.2f} s", flush=True)
    outputs = {"printed": [], "--json": [], "--out": []}
    t_cli_batch, t_help, t_solve_loop = [], [], []
    if args.cli:
        toml = ROOT / "examples" / "general_3rrr.toml"
        with tempfile.TemporaryDirectory() as tmp:
            env = _env(str(Path(tmp) / "pycache"))
            csv_path = Path(tmp) / "path.csv"
            with open(csv_path, "w", newline="") as fh:
                writer = csv.writer(fh)
                writer.writerow(mech.actuated)
                writer.writerows([[repr(float(v)) for v in row] for row in path])
            start = ",".join(repr(float(v)) for v in rots[0].reshape(-1))
            spherekin = [sys.executable, "-m", "spherekin"]
            extra = {"printed": [], "--json": ["--json", str(Path(tmp) / "t.json")],
                     "--out": ["--out", str(Path(tmp) / "t.csv")]}
            short = Path(tmp) / "short.csv"                  # untimed runs of each command: the bytecode cache
            short.write_text("".join(csv_path.read_text().splitlines(keepends=True)[:3]))
            _run([*spherekin, "track", str(toml), "--path", str(short), f"--start-rotation={start}", "--out",
                  str(Path(tmp) / "w.csv"), "--json", str(Path(tmp) / "w.json")], env)
            _run([*spherekin, "batch", str(toml), "--inputs", str(short), "--workers", "0", "--quiet", "--out",
                  str(Path(tmp) / "w.parquet")], env)
            for run in range(args.runs):
                t_help.append(_run([*spherekin, "--help"], env))
                for key, more in extra.items():
                    outputs[key].append(_run([*spherekin, "track", str(toml), "--path", str(csv_path),
                                              f"--start-rotation={start}", *more], env))
                    (Path(tmp) / "t.csv").unlink(missing_ok=True)
                t_cli_batch.append(_run([*spherekin, "batch", str(toml), "--inputs", str(csv_path), "--workers", "0",
                                         "--quiet", "--out", str(Path(tmp) / f"b{run}.csv")], env))
                t_solve_loop.append(_run([sys.executable, "-c", SOLVE_LOOP_SCRIPT, str(toml), str(csv_path)], env))
                print(f"process run {run + 1}/{args.runs}: spherekin --help {t_help[-1]:.2f} s, spherekin track "
                      + ", ".join(f"{t[-1]:.2f} s ({k})" for k, t in outputs.items())
                      + f"; spherekin batch {t_cli_batch[-1]:.2f} s; a solve per row {t_solve_loop[-1]:.2f} s",
                      flush=True)
    track_s, full_s, engine_s = statistics.median(t_track), statistics.median(t_full), statistics.median(t_engine)
    n = args.steps
    print(f"\ngeneral_3rrr, a smooth path of {n} inputs {gaps.mean():.4g} rad apart (largest input change between "
          f"rows; max {gaps.max():.4g}); medians of {args.runs} run(s); {os.cpu_count()} cores")
    print(f"{'method':44s} {'seconds':>8s} {'ms per row':>11s} {'poses right':>12s}")
    print(f"{'track (every step proven), in process':44s} {track_s:8.3f} {1e3 * track_s / n:11.3f} {str(ok_track):>12s}")
    print(f"{'full solves + nearest, in process':44s} {full_s:8.3f} {1e3 * full_s / n:11.3f} {str(ok_full):>12s}")
    print(f"{'full solves (solve_many, the engine) + nearest':44s} {engine_s:8.3f} {1e3 * engine_s / n:11.3f}"
          f" {str(ok_engine):>12s}")
    print(f"speedup of track in process: {full_s / track_s:.1f}x over solve, {engine_s / track_s:.1f}x over the engine "
          "(target >= 20 at 0.01 rad); "
          f"proven steps {tr.proven_steps}, rejected {tr.rejected_steps}")
    result = {"machine": {"cores": os.cpu_count(), "processor": platform.processor(),
                          "python": platform.python_version()},
              "date": time.strftime("%Y-%m-%d"), "steps": n, "spacing": float(gaps.mean()),
              "spacing_max": float(gaps.max()), "runs": args.runs, "track_s": t_track, "full_s": t_full,
              "speedup": full_s / track_s, "track_right": bool(ok_track), "full_right": bool(ok_full),
              "engine_s": t_engine, "speedup_engine": engine_s / track_s, "engine_right": bool(ok_engine),
              "proven_steps": tr.proven_steps, "rejected_steps": tr.rejected_steps}
    if args.cli:
        cli_batch = statistics.median(t_cli_batch)
        print(f"{'spherekin --help (start-up alone)':44s} {statistics.median(t_help):8.3f}")
        for key, times in outputs.items():
            label = f"spherekin track, {key} (whole process)"
            print(f"{label:44s} {statistics.median(times):8.3f} {1e3 * statistics.median(times) / n:11.3f}"
                  f"   {cli_batch / statistics.median(times):6.1f}x")
        print(f"{'spherekin batch --workers 0 (whole process)':44s} {cli_batch:8.3f} {1e3 * cli_batch / n:11.3f}")
        loop_s = statistics.median(t_solve_loop)
        print(f"{'a solve per row (whole process, a script)':44s} {loop_s:8.3f} {1e3 * loop_s / n:11.3f}")
        print("whole process, spherekin track (printed) is "
              f"{loop_s / statistics.median(outputs['printed']):.1f}x faster than a solve per row (target >= 20) and "
              f"{cli_batch / statistics.median(outputs['printed']):.1f}x faster than the engine's batch")
        result.update(cli_track_s=outputs, cli_batch_s=t_cli_batch, cli_help_s=t_help, cli_solve_loop_s=t_solve_loop,
                      cli_speedup={k: cli_batch / statistics.median(t) for k, t in outputs.items()},
                      cli_speedup_solve_loop={k: loop_s / statistics.median(t) for k, t in outputs.items()})
    out = Path(args.json)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=2))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
