"""spherekin against homotopy continuation (PHCpack) and a degree-8 closed form, on the same DK problems.

Problems (all joints over the full circle): the paper's Gosselin platform at inputs (0.3, -0.2, 0.5)
rad, the general_3rrr preset and random general 3-RRR geometries (seeded), each at the inputs of
a seeded random pose through one of its inverse-kinematics working modes (so a real assembly exists).
Methods:

* spherekin default, ``solve(mech, inputs)``; with both parameterizations ("tan-half", "sin-cos")
  when ``solve`` accepts ``parameterization=`` (inspected, not assumed);
* spherekin paper-faithful, ``formulation="paper", pruner="lp", lp_backend="clarabel"`` (tol
  :data:`PAPER_TOL`), in a subprocess killed at ``--paper-cap`` seconds and reported "capped";
* ``phc -b`` (PHCpack blackbox, one task, fixed seed) on (b) the quaternion system (3 leg quadrics
  + |q|^2 = 1, 16 paths) and (a) the sin/cos loop system (12 x 12; slow: once in total, on the first
  problem, unless ``--with-slow-phc``);
* the degree-8 eigen solver of ``peers_closed_form.py`` (numpy only).

Times: in-process medians (the call alone, in this process; for phc: write the system, run the phc
process, parse) and whole-process medians (a fresh ``python -c`` from interpreter start, imports
included, to the poses); ratios against spherekin default measured the same way in this run. Runs:
``--repeats`` each (3 when a run takes over ``--slow`` s, 1 over a minute; the table says how many).
Solutions: real solutions inside the joint ranges, each pose compared with spherekin default's poses
(rotation matrices within :data:`MATCH_TOL`) and checked against the leg constraints independently.
Prints a table, writes JSON to benchmarks/results/peers.json (peers_quick.json with ``--quick``).

    python -m benchmarks.bench_peers [--repeats 5] [--quick] [--skip-paper] [--with-slow-phc]
"""

from __future__ import annotations

import argparse
import inspect
import json
import math
import os
import platform
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
from references import peers_closed_form as pcf
from benchmarks import peers_phc as pphc
from references.random_designs import random_rotation, unit

from spherekin.mechanism import general_3rrr, gosselin, three_rrr  # noqa: E402
from spherekin.problem import solve  # noqa: E402

#: The paper's example inputs (radians) for the Gosselin platform.
GOSSELIN_INPUTS = (0.3, -0.2, 0.5)
#: Two poses are the same when every entry of their rotation matrices agrees within this. Reason:
#: every method polishes or refines its roots to ~1e-12 or better (phc prints 15 digits, singular
#: roots of the loop system come out to ~1e-8); distinct assembly modes differ by order 1e-1.
MATCH_TOL = 1e-6
#: A pose is spurious when a leg constraint |w_i . R v_i^0 - cos alpha2_i| exceeds this. Reason:
#: true poses satisfy it to ~1e-15 after polishing; 1e-9 leaves room for singular roots.
LEG_TOL = 1e-9
#: Inputs of a limited joint match an IK solution's when equal within this (radians, modulo 2 pi).
INPUT_TOL = 1e-9
#: Tolerance (radians) of the paper-faithful mode: its scalar equation has only double roots, so
#: the README recommends ~1e-3 (benchmarks/bench_solve.py measures it the same way).
PAPER_TOL = 1e-3
#: Seeds and counts of the problems: fixed so that every run solves the same problems.
SEED = 2024
RANDOM_GEOMETRIES = 2
#: Cheap methods (a run under this many seconds) are timed over at least CHEAP_RUNS runs: the
#: median of a millisecond call over 5 runs is noisy, and more runs cost nothing.
CHEAP_SECONDS, CHEAP_RUNS = 0.2, 25
#: Minimum spacing (seconds) of the progress lines of a capped child (boxes processed so far).
PROGRESS_EVERY = 1.0

#: The parameterizations given a column each when solve() accepts ``parameterization=``.
PARAMETERIZATIONS = ("tan-half", "sin-cos")

# --------------------------------------------------------------------------------------------
# Problems
# --------------------------------------------------------------------------------------------


def _random_geometry(rng) -> dict:
    """A random 3-RRR assembled at beta = 0, R = I (distal angles measured there), away from degeneracy."""
    while True:
        u, w0, v0 = ([unit(rng) for _ in range(3)] for _ in range(3))
        a2 = [float(np.arccos(np.clip(w @ v, -1, 1))) for w, v in zip(w0, v0)]
        a1 = [float(np.arccos(np.clip(a @ b, -1, 1))) for a, b in zip(u, w0)]
        if min(a1 + a2) < 0.3 or max(a1 + a2) > math.pi - 0.3:
            continue
        try:
            three_rrr(u, w0, v0, a2)
        except ValueError:
            continue
        return dict(base_axes=u, elbow_axes_at_zero=w0, platform_axes=v0, distal_link_angles=a2)


def _spec(name: str, mech, inputs, note: str) -> dict:
    g = mech.geometry
    return dict(name=name, note=note, reference_leg=mech.reference_leg, inputs=[float(x) for x in inputs],
                geometry=dict(base_axes=[list(map(float, v)) for v in g.base_axes],
                              elbow_axes_at_zero=[list(map(float, v)) for v in g.elbow_axes_at_zero],
                              platform_axes=[list(map(float, v)) for v in g.platform_axes],
                              distal_link_angles=[float(a) for a in g.distal_link_angles]))


def _ik_inputs(mech, rng) -> tuple:
    while True:
        modes = mech.inverse_kinematics(random_rotation(rng))
        if modes:
            return modes[int(rng.integers(len(modes)))].inputs


def make_problems(seed: int = SEED, n_random: int = RANDOM_GEOMETRIES) -> list[dict]:
    """Gosselin at the paper's inputs, general_3rrr and ``n_random`` random geometries at IK inputs."""
    rng = np.random.default_rng(seed)
    out = [_spec("gosselin", gosselin(), GOSSELIN_INPUTS, "paper's agile eye, inputs (0.3, -0.2, 0.5)")]
    mech = general_3rrr()
    out.append(_spec("general_3rrr", mech, _ik_inputs(mech, rng), f"preset 50/75 deg, IK inputs (seed {seed})"))
    for k in range(n_random):
        mech = three_rrr(**_random_geometry(rng))
        out.append(_spec(f"random{k + 1}", mech, _ik_inputs(mech, rng), f"random geometry and pose (seed {seed})"))
    return out


def mechanism_of(spec: dict):
    return three_rrr(**spec["geometry"], reference_leg=spec["reference_leg"])


def geometry_of_spec(spec: dict) -> tuple:
    g = spec["geometry"]
    return tuple(np.array(g[k], dtype=float) for k in
                 ("base_axes", "elbow_axes_at_zero", "platform_axes", "distal_link_angles"))


# --------------------------------------------------------------------------------------------
# Poses: ranges, matching, independent checks
# --------------------------------------------------------------------------------------------

def _wrap(a):
    return (np.asarray(a, dtype=float) + math.pi) % (2 * math.pi) - math.pi


def pose_in_ranges(mech, inputs, rot) -> bool:
    """Is there an assembly with platform pose ``rot`` at these inputs with every joint in its range?"""
    if all(r is None for r in mech.ranges.values()):
        return True
    for sol in mech.inverse_kinematics(rot):
        if np.abs(_wrap(np.array(sol.inputs) - np.array(inputs))).max() <= INPUT_TOL and sol.in_range:
            return True
    return False


def dedupe(poses) -> list[np.ndarray]:
    out = []
    for p in poses:
        if not any(np.abs(p - o).max() <= MATCH_TOL for o in out):
            out.append(p)
    return out


def compare(poses, reference) -> dict:
    """How many of ``poses`` match a reference pose, and how many reference poses are matched."""
    hit = sum(any(np.abs(p - r).max() <= MATCH_TOL for r in reference) for p in poses)
    cover = sum(any(np.abs(p - r).max() <= MATCH_TOL for p in poses) for r in reference)
    return dict(matched=int(hit), reference_covered=int(cover), reference=len(reference),
                same_set=bool(hit == len(poses) and cover == len(reference)))


def count_solutions(spec: dict, mech, poses) -> dict:
    """Distinct real poses in the ranges, and the worst leg residual among them (independent check)."""
    geom = geometry_of_spec(spec)
    poses = dedupe([np.asarray(p, dtype=float) for p in poses])
    inside = [p for p in poses if pose_in_ranges(mech, spec["inputs"], p)]
    worst = max((float(pcf.leg_residuals(geom, spec["inputs"], p).max()) for p in inside), default=0.0)
    return dict(poses=inside, in_range=len(inside), worst_leg_residual=worst,
                spurious=sum(float(pcf.leg_residuals(geom, spec["inputs"], p).max()) > LEG_TOL for p in inside))


# --------------------------------------------------------------------------------------------
# The methods, in process
# --------------------------------------------------------------------------------------------

def solve_accepts_parameterization() -> tuple[bool, str | None]:
    """(does spherekin's solve take ``parameterization=``, its default value or None)."""
    from spherekin.problem import compile as compile_problem     # solve's strategy keywords are compile's

    p = inspect.signature(compile_problem).parameters.get("parameterization")
    if p is None:
        return False, None
    return True, (p.default if p.default is not inspect.Parameter.empty else None)


def spherekin_poses(mech, inputs, **kwargs) -> list[np.ndarray]:
    rep = solve(mech, inputs, **kwargs)
    return [np.asarray(s.platform_rotation) for s in rep.solutions]


def quaternion_phc(spec: dict, timeout: float | None = None):
    polys, names = pphc.quaternion_system(pcf.leg_quadrics(geometry_of_spec(spec), spec["inputs"]))
    run = pphc.run_phc(polys, names, timeout=timeout)
    real = [r for r in run.roots if r.is_real()]
    poses = [pcf.quaternion_rotation(r.values.real) for r in real]
    return poses, run, dict(roots=len(run.roots), real_roots=len(real), paths=run.paths, phc_summary=run.summary)


def sincos_system_for(spec: dict, mech):
    """(loop system, polys, names, sympy exprs, symbols) of the sin/cos system (any chart ranges will do)."""
    system = mech.loop_system(spec["inputs"], {n: (-1.0, 1.0) for n in mech.passive})
    polys, names, exprs, cs = pphc.sincos_system(system.loops, system.names)
    return system, polys, names, exprs, cs


def check_sincos_system(spec: dict, mech, reference_angles) -> dict:
    """sympy check: the system is square and vanishes at spherekin's solutions ({passive name: angle})."""
    import sympy as sp

    system, polys, names, exprs, cs = sincos_system_for(spec, mech)
    symbols = [x for pair in cs for x in pair]
    f = sp.lambdify(symbols, exprs, "numpy")
    worst = 0.0
    for angles in reference_angles:
        vals = [v for n in system.names for v in (math.cos(angles[n]), math.sin(angles[n]))]
        worst = max(worst, max(abs(float(x)) for x in f(*vals)))
    return dict(equations=len(exprs), variables=len(symbols), square=len(exprs) == len(symbols),
                worst_residual_at_spherekin_solutions=worst, terms=[len(p) for p in polys])


def sincos_phc(spec: dict, mech, timeout: float | None = None):
    system, polys, names, _, _ = sincos_system_for(spec, mech)
    run = pphc.run_phc(polys, names, timeout=timeout)
    real = [r for r in run.roots if r.is_real()]
    poses, spurious = [], 0
    for r in real:
        v = r.values.real
        theta = np.arctan2(v[1::2], v[0::2])           # (c_k, s_k) -> theta_k
        if not pphc.loop_closes(system.loops, system.names, theta):
            spurious += 1                              # a loop at diag(1,-1,-1) & co, not a solution
            continue
        if not all(_angle_in_range(t, mech.ranges[n]) for n, t in zip(system.names, theta)):
            continue
        poses.append(mech.pose_from_passive(spec["inputs"], dict(zip(system.names, theta))))
    return poses, run, dict(roots=len(run.roots), real_roots=len(real), real_spurious=spurious, paths=run.paths,
                            phc_summary=run.summary)


def _angle_in_range(theta: float, rng) -> bool:
    if rng is None:
        return True
    lo, hi = rng
    return float((theta - lo) % (2 * math.pi)) <= hi - lo


def closed_form_poses(spec: dict) -> list[np.ndarray]:
    return pcf.direct_kinematics(geometry_of_spec(spec), spec["inputs"])


# --------------------------------------------------------------------------------------------
# Whole-process children (python -c): import only what the method needs
# --------------------------------------------------------------------------------------------

_CHILD_SPHEREKIN = r"""
import json, sys, time
t0 = time.perf_counter()
from spherekin.mechanism import three_rrr
from spherekin.problem import solve
spec, kwargs = json.loads(sys.argv[1]), json.loads(sys.argv[2])
mech = three_rrr(**spec["geometry"], reference_leg=spec["reference_leg"])
last = [0.0]
def progress(counts):
    now = time.perf_counter()
    if now - last[0] >= float(sys.argv[3]):
        last[0] = now
        print("PROGRESS " + json.dumps(counts), flush=True)
t1 = time.perf_counter()
try:
    rep = solve(mech, spec["inputs"], progress=progress, **kwargs)
except Exception as exc:
    print("FAILED " + json.dumps({"error": f"{type(exc).__name__}: {str(exc).split(';')[0]}",
                                  "seconds": time.perf_counter() - t1}), flush=True)
    sys.exit(0)
t2 = time.perf_counter()
print("RESULT " + json.dumps({"seconds": t2 - t1, "imports": t1 - t0, "boxes": rep.stats.boxes_processed,
                              "lps": rep.stats.lps_solved, "statuses": [s.status for s in rep.solutions],
                              "poses": [s.platform_rotation.tolist() for s in rep.solutions]}), flush=True)
"""

_CHILD_PEERS = r"""
import json, sys, time
t0 = time.perf_counter()
import numpy as np
from references import peers_closed_form as pcf  # the repository root is on PYTHONPATH
spec, method = json.loads(sys.argv[1]), sys.argv[2]
g = spec["geometry"]
geom = tuple(np.array(g[k], dtype=float) for k in ("base_axes", "elbow_axes_at_zero", "platform_axes",
                                                   "distal_link_angles"))
if method == "phc-quaternion":
    import peers_phc as pphc
t1 = time.perf_counter()
if method == "phc-quaternion":
    polys, names = pphc.quaternion_system(pcf.leg_quadrics(geom, spec["inputs"]))
    run = pphc.run_phc(polys, names)
    poses = [pcf.quaternion_rotation(r.values.real) for r in run.roots if r.is_real()]
else:
    poses = pcf.direct_kinematics(geom, spec["inputs"])
t2 = time.perf_counter()
print("RESULT " + json.dumps({"seconds": t2 - t1, "imports": t1 - t0, "poses": [p.tolist() for p in poses]}))
"""


def _cpu_children() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run_child(code: str, args: list[str], timeout: float | None) -> dict:
    """One whole-process run: wall and CPU (parent's view), the child's RESULT/FAILED, or capped."""
    import spherekin

    # the child imports the very spherekin this process imports (not whatever its cwd holds)
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(Path(spherekin.__file__).resolve().parent.parent),
                                         *filter(None, [os.environ.get("PYTHONPATH")])])
    cpu0, t0 = _cpu_children(), time.perf_counter()
    try:
        proc = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True,
                              timeout=timeout, stdin=subprocess.DEVNULL, cwd=str(HERE), env=env)
    except subprocess.TimeoutExpired as exc:
        out = exc.stdout.decode() if isinstance(exc.stdout, bytes) else (exc.stdout or "")
        prog = [ln for ln in out.splitlines() if ln.startswith("PROGRESS ")]
        last = json.loads(prog[-1][9:]) if prog else {}
        return dict(capped=True, wall=time.perf_counter() - t0, cpu=_cpu_children() - cpu0, progress=last)
    wall, cpu = time.perf_counter() - t0, _cpu_children() - cpu0
    lines = proc.stdout.splitlines()
    for ln in reversed(lines):
        if ln.startswith("RESULT "):
            return dict(capped=False, wall=wall, cpu=cpu, **json.loads(ln[7:]))
        if ln.startswith("FAILED "):
            return dict(capped=False, failed=True, wall=wall, cpu=cpu, **json.loads(ln[7:]))
    raise RuntimeError(f"child exited with code {proc.returncode} and no RESULT line:\n{proc.stderr[-2000:]}")


# --------------------------------------------------------------------------------------------
# Timing
# --------------------------------------------------------------------------------------------

def planned_runs(first: float, repeats: int, slow: float) -> int:
    if first > 60:
        return 1
    if first > slow:
        return min(repeats, 3)
    if first < CHEAP_SECONDS:
        return max(repeats, CHEAP_RUNS)
    return repeats


def time_in_process(fn, repeats: int, slow: float) -> dict:
    """Median wall (and CPU: this process + children) of fn() over the planned runs; fn's last result."""
    times, cpus, result = [], [], None
    n = 1
    while len(times) < n:
        c0, t0 = time.process_time() + _cpu_children(), time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
        cpus.append(time.process_time() + _cpu_children() - c0)
        if len(times) == 1:
            n = planned_runs(times[0], repeats, slow)
    return dict(median=statistics.median(times), runs=len(times), times=times, cpu=statistics.median(cpus),
                result=result)


def time_whole_process(code: str, args: list[str], repeats: int, slow: float, timeout: float | None) -> dict:
    runs, n = [], 1
    while len(runs) < n:
        r = run_child(code, args, timeout)
        runs.append(r)
        if r.get("capped") or r.get("failed"):
            break
        if len(runs) == 1:
            n = planned_runs(r["wall"], repeats, slow) if r["wall"] > CHEAP_SECONDS else repeats
    ok = [r for r in runs if not r.get("capped") and not r.get("failed")]
    out = dict(runs=len(runs), last=runs[-1])
    if ok:
        out.update(median=statistics.median(r["wall"] for r in ok), cpu=statistics.median(r["cpu"] for r in ok),
                   child_median=statistics.median(r["seconds"] for r in ok), times=[r["wall"] for r in ok])
    return out


# --------------------------------------------------------------------------------------------
# Machine
# --------------------------------------------------------------------------------------------

def machine_info() -> dict:
    model = "unknown"
    try:
        for ln in Path("/proc/cpuinfo").read_text().splitlines():
            if ln.startswith("model name"):
                model = ln.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    info = dict(cores=os.cpu_count(), cpu_model=model, python=platform.python_version(),
                platform=platform.platform(), numpy=np.__version__, load_average_start=os.getloadavg())
    try:
        import sympy
        info["sympy"] = sympy.__version__
    except ImportError:
        pass
    try:
        import spherekin
        root = Path(spherekin.__file__).resolve().parent
        git = ["git", "-C", str(root.parent)]
        head = subprocess.run([*git, "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run([*git, "status", "--porcelain", "--", "spherekin"], capture_output=True,
                               text=True).stdout.strip()
        import hashlib
        digest = hashlib.sha256()
        for f in sorted(root.rglob("*.py")):
            digest.update(f.relative_to(root).as_posix().encode() + b"\0" + f.read_bytes())
        info["spherekin"] = dict(path=str(root), commit=head or None, uncommitted_changes=bool(dirty) if head else None,
                                 sources_sha256=digest.hexdigest()[:16])
    except OSError:
        info["spherekin"] = dict(path=None, commit=None, uncommitted_changes=None)
    if pphc.phc_available():
        out = subprocess.run([pphc.PHC, "--version"], capture_output=True, text=True, stdin=subprocess.DEVNULL)
        info["phc"] = (out.stdout or out.stderr).strip().splitlines()[0] if (out.stdout or out.stderr) else "?"
    else:
        info["phc"] = None
    return info


# --------------------------------------------------------------------------------------------
# Main
# --------------------------------------------------------------------------------------------

def _fmt(x, width=9, digits=3):
    if x is None:
        return f"{'-':>{width}s}"
    if x >= 100:
        return f"{x:{width}.0f}"
    if x >= 0.01:
        return f"{x:{width}.{digits}f}"
    return f"{x:{width}.1e}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5, help="runs per measurement (default 5)")
    parser.add_argument("--slow", type=float, default=20.0, help="seconds above which a measurement runs 3 times")
    parser.add_argument("--quick", action="store_true",
                        help="smoke test: Gosselin only, 2 runs, paper mode capped at 5 s, no slow phc run")
    parser.add_argument("--skip-paper", action="store_true", help="do not run spherekin's paper-faithful mode")
    parser.add_argument("--paper-cap", type=float, default=120.0, help="wall-time cap (s) of one paper-mode run")
    parser.add_argument("--with-slow-phc", action="store_true",
                        help="run phc -b on the sin/cos system (a) for every problem (default: the first only)")
    parser.add_argument("--skip-slow-phc", action="store_true", help="never run phc -b on the sin/cos system (a)")
    parser.add_argument("--slow-phc-cap", type=float, default=1800.0, help="wall-time cap (s) of one phc (a) run")
    parser.add_argument("--problems", type=str, default=None, help="comma-separated problem names (default: all)")
    parser.add_argument("--out", type=Path, default=None, help="JSON output (default results/peers.json)")
    parser.add_argument("--note", type=str, default=None,
                        help="free text stored with the results (e.g. which spherekin snapshot was measured)")
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error("--repeats: expected at least 1")
    if args.quick:
        args.repeats, args.paper_cap = min(args.repeats, 2), min(args.paper_cap, 5.0)
    out_path = args.out or HERE / "results" / ("peers_quick.json" if args.quick else "peers.json")

    problems = make_problems()
    if args.quick:
        problems = problems[:1]
    if args.problems:
        wanted = args.problems.split(",")
        unknown = sorted(set(wanted) - {p["name"] for p in problems})
        if unknown:
            parser.error(f"--problems: unknown {unknown}; valid: {[p['name'] for p in problems]}")
        problems = [p for p in problems if p["name"] in wanted]

    machine = machine_info()
    if args.note:
        print(f"note: {args.note}")
    has_param, param_default = solve_accepts_parameterization()
    has_phc = machine["phc"] is not None
    print(f"machine: {machine['cores']} cores, {machine['cpu_model']}, Python {machine['python']}, "
          f"phc: {machine['phc'] or 'absent'}; load average at start {machine['load_average_start']}")
    sk = machine["spherekin"]
    print(f"spherekin: {sk['path']} (git commit {sk['commit']}"
          + (", WITH UNCOMMITTED CHANGES in spherekin/" if sk["uncommitted_changes"] else "")
          + f"; sources sha256 {sk.get('sources_sha256')})")
    if not has_phc:
        print("phc not found on PATH: the PHCpack columns are skipped (install: apt-get install -y phcpack, "
              "or make bench-peers)")
    if has_param:
        print(f"solve() accepts parameterization= (default {param_default!r}): one spherekin row per value")
    else:
        print("solve() has no parameterization= argument yet: one spherekin default row (its built-in "
              "parameterization, tan-half)")
    slow_phc_left = 0 if (args.quick or args.skip_slow_phc or not has_phc) else \
        (len(problems) if args.with_slow_phc else 1)

    rows, checks = [], {}
    for spec in problems:
        mech = mechanism_of(spec)
        inputs = spec["inputs"]
        print(f"\n== {spec['name']}: {spec['note']}; inputs {tuple(round(x, 6) for x in inputs)} rad", flush=True)

        def add(method, inproc=None, whole=None, found=None, extra=None, status="ok"):
            row = dict(problem=spec["name"], method=method, status=status, extra=extra or {})
            if inproc is not None:
                row["in_process"] = {k: v for k, v in inproc.items() if k != "result"}
            if whole is not None:
                row["whole_process"] = {k: v for k, v in whole.items() if k != "last"}
                last = whole["last"]
                row["whole_process"]["last_run"] = {k: v for k, v in last.items() if k != "poses"}
            if found is not None:
                row["solutions"] = {k: v for k, v in found.items() if k != "poses"}
            rows.append(row)
            return row

        # 1. spherekin default (baseline of the ratios), then the other parameterization
        variants = [("spherekin default (platform)", {}), ("spherekin halves (before #14)",
                                                       {"formulation": "halves"})]
        if has_param:
            variants += [(f"spherekin {p}", {"parameterization": p}) for p in PARAMETERIZATIONS if p != param_default]
        reference, ref_angles = None, []
        for label, kwargs in variants:
            try:
                ip = time_in_process(lambda: solve(mech, inputs, **kwargs), args.repeats, args.slow)
            except Exception as exc:  # a broken variant is reported, the other methods still run
                add(label, status=f"failed: {type(exc).__name__}: {str(exc)[:160]}", extra=dict(kwargs=kwargs))
                print(f"  {label}: FAILED: {type(exc).__name__}: {exc}", flush=True)
                reference = [] if reference is None else reference
                continue
            rep = ip["result"]
            wp = time_whole_process(_CHILD_SPHEREKIN, [json.dumps(spec), json.dumps(kwargs), "1e9"],
                                    args.repeats, args.slow, None)
            poses = [np.asarray(s.platform_rotation) for s in rep.solutions]
            if reference is None:
                reference = dedupe(poses)
                ref_angles = [dict(zip(rep.unknowns, np.asarray(s.angles, dtype=float))) for s in rep.solutions]
            found = count_solutions(spec, mech, poses)
            found.update(compare(found["poses"], reference))
            add(label, ip, wp, found, dict(statuses=[s.status for s in rep.solutions],
                                           boxes=rep.stats.boxes_processed, kwargs=kwargs))
            print(f"  {label}: {ip['median']:.3f} s in process, {wp.get('median', float('nan')):.3f} s whole, "
                  f"{found['in_range']} solutions", flush=True)

        # 2. spherekin paper-faithful, capped
        paper_kwargs = dict(formulation="paper", pruner="lp", lp_backend="clarabel", tol=PAPER_TOL)
        label = "spherekin paper (lp, clarabel)"
        if args.skip_paper:
            add(label, status="skipped (--skip-paper)")
        else:
            wp = time_whole_process(_CHILD_SPHEREKIN, [json.dumps(spec), json.dumps(paper_kwargs), str(PROGRESS_EVERY)],
                                    args.repeats, args.slow, args.paper_cap)
            last = wp["last"]
            if last.get("capped"):
                prog = last.get("progress", {})
                add(label, whole=wp, status=f"capped at {args.paper_cap:.0f} s",
                    extra=dict(kwargs=paper_kwargs, boxes_at_cap=prog.get("boxes_processed"),
                               accepted_at_cap=prog.get("accepted"), pending_at_cap=prog.get("pending")))
                print(f"  {label}: capped at {args.paper_cap:.0f} s after {prog.get('boxes_processed')} boxes",
                      flush=True)
            elif last.get("failed"):
                add(label, whole=wp, status=f"failed: {last['error']}", extra=dict(kwargs=paper_kwargs))
                print(f"  {label}: failed: {last['error']}", flush=True)
            else:
                found = count_solutions(spec, mech, [np.array(p) for p in last["poses"]])
                found.update(compare(found["poses"], reference))
                ip = dict(median=wp["child_median"], runs=wp["runs"], cpu=None)
                add(label, ip, wp, found, dict(kwargs=paper_kwargs, boxes=last["boxes"], lps=last["lps"],
                                               statuses=last["statuses"]))
                print(f"  {label}: {wp['median']:.1f} s whole, {found['in_range']} solutions", flush=True)

        # 3. PHCpack: (b) quaternion system; (a) sin/cos loop system, checked first (with or without phc)
        check = check_sincos_system(spec, mech, ref_angles)
        checks[spec["name"]] = check
        print(f"  sin/cos system (a): {check['equations']} equations in {check['variables']} unknowns, "
              f"residual at spherekin's {len(ref_angles)} solutions "
              f"{check['worst_residual_at_spherekin_solutions']:.1e}", flush=True)
        if not check["square"]:
            raise RuntimeError(f"{spec['name']}: the sin/cos system is not square: {check}")
        if not has_phc:
            add("phc -b quaternion (b)", status="skipped: phc absent")
            add("phc -b sin/cos (a)", status="skipped: phc absent")
        else:
            ip = time_in_process(lambda: quaternion_phc(spec), args.repeats, args.slow)
            poses, run, extra = ip["result"]
            wp = time_whole_process(_CHILD_PEERS, [json.dumps(spec), "phc-quaternion"],
                                    args.repeats, args.slow, None)
            found = count_solutions(spec, mech, poses)
            found.update(compare(found["poses"], reference))
            extra["phc_process_wall"] = run.wall
            add("phc -b quaternion (b)", ip, wp, found, extra)
            print(f"  phc -b quaternion (b): {ip['median']:.3f} s, {extra['real_roots']} real roots of "
                  f"{extra['roots']} -> {found['in_range']} poses", flush=True)

            if slow_phc_left > 0:
                slow_phc_left -= 1
                try:
                    ip = time_in_process(lambda: sincos_phc(spec, mech, timeout=args.slow_phc_cap), 1, args.slow)
                except pphc.PhcError as exc:
                    add("phc -b sin/cos (a)", status=f"capped/failed: {exc}")
                    print(f"  phc -b sin/cos (a): {exc}", flush=True)
                else:
                    poses, run, extra = ip["result"]
                    extra["phc_process_wall"] = run.wall
                    found = count_solutions(spec, mech, poses)
                    found.update(compare(found["poses"], reference))
                    add("phc -b sin/cos (a)", ip, None, found, extra)
                    print(f"  phc -b sin/cos (a): {ip['median']:.1f} s (cpu {ip['cpu']:.1f} s), {extra['paths']} "
                          f"paths, {extra['real_roots']} real roots ({extra['real_spurious']} spurious) -> "
                          f"{found['in_range']} poses", flush=True)
            else:
                why = ("--quick" if args.quick else "--skip-slow-phc" if args.skip_slow_phc else
                       "run once in total, on the first problem; --with-slow-phc for all")
                add("phc -b sin/cos (a)", status=f"not run ({why})")

        # 4. degree-8 closed form
        ip = time_in_process(lambda: closed_form_poses(spec), args.repeats, args.slow)
        wp = time_whole_process(_CHILD_PEERS, [json.dumps(spec), "closed-form"], args.repeats,
                                args.slow, None)
        found = count_solutions(spec, mech, ip["result"])
        found.update(compare(found["poses"], reference))
        _, n_roots = pcf.solve_quadrics(pcf.leg_quadrics(geometry_of_spec(spec), inputs))
        add("degree-8 eigen (numpy)", ip, wp, found, dict(eigen_roots=n_roots))
        print(f"  degree-8 eigen: {ip['median'] * 1e3:.2f} ms, {found['in_range']} poses", flush=True)

    # ratios against spherekin default of the same problem, and the table
    base = {}
    for r in rows:
        if r["method"].startswith("spherekin default") and "in_process" in r:
            base[r["problem"]] = (r["in_process"]["median"], r["whole_process"].get("median"))
    for r in rows:
        b_in, b_whole = base.get(r["problem"], (None, None))
        if "in_process" in r and r["in_process"].get("median") is not None and b_in:
            r["in_process"]["ratio_vs_default"] = r["in_process"]["median"] / b_in
        if "whole_process" in r and r["whole_process"].get("median") is not None and b_whole:
            r["whole_process"]["ratio_vs_default"] = r["whole_process"]["median"] / b_whole
    machine["load_average_end"] = os.getloadavg()
    print_table(rows, machine)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    out_path.write_text(json.dumps(dict(
        benchmark="peers", note=args.note, machine=machine, problems=problems, match_tol=MATCH_TOL, leg_tol=LEG_TOL,
        imag_tol=pphc.IMAG_TOL, closure_tol=pphc.CLOSURE_TOL, eigen_real_tol=pcf.REAL_TOL, paper_tol=PAPER_TOL,
        phc_seed=pphc.PHC_SEED, solve_parameterization=dict(accepted=has_param, default=param_default),
        args={k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()},
        sincos_checks=checks, rows=rows), indent=2, default=_json_default))
    print(f"wrote {out_path}")
    return 0


def _json_default(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.integer, np.floating, np.bool_)):
        return o.item()
    raise TypeError(f"not JSON serializable: {type(o).__name__}")


def print_table(rows, machine) -> None:
    print(f"\nmedians in seconds; n = runs; ratio = median / spherekin default's median (same problem, same "
          f"run); sols = real solutions in the ranges; = sk: all of them match spherekin default's poses "
          f"(and vice versa) within {MATCH_TOL:g}")
    print(f"machine: {machine['cores']} cores, {machine['cpu_model']}, Python {machine['python']}; "
          f"load average start {tuple(round(x, 2) for x in machine['load_average_start'])}, end "
          f"{tuple(round(x, 2) for x in machine['load_average_end'])}")
    head = (f"{'problem':12s} {'method':32s} {'in-proc':>9s} {'n':>3s} {'ratio':>8s} {'whole':>9s} {'n':>3s} "
            f"{'ratio':>7s} {'cpu':>8s} {'sols':>4s} {'= sk':>4s}  notes")
    print(head)
    print("-" * len(head))
    for r in rows:
        ip, wp, sol = r.get("in_process", {}), r.get("whole_process", {}), r.get("solutions")
        notes = []
        if r["status"] != "ok":
            notes.append(r["status"])
        ex = r.get("extra", {})
        if "paths" in ex:
            notes.append(f"{ex['paths']} paths, {ex['roots']} roots, {ex['real_roots']} real")
        if ex.get("real_spurious"):
            notes.append(f"{ex['real_spurious']} real spurious (loop at diag(+-1))")
        if ex.get("boxes_at_cap") is not None:
            notes.append(f"{ex['boxes_at_cap']} boxes, {ex['accepted_at_cap']} accepted at the cap")
        last = wp.get("last_run", {})
        if last.get("failed") and r["status"] == "ok":
            notes.append(f"whole-process run failed: {last.get('error', '?')[:90]}")
        if sol and sol.get("spurious"):
            notes.append(f"{sol['spurious']} poses fail the leg check")
        if "statuses" in ex:
            n_sing = sum(s == "singular" for s in ex["statuses"])
            if n_sing:
                notes.append(f"{n_sing} singular")
        cpu = ip.get("cpu") if ip else None
        if cpu is None and wp:
            cpu = wp.get("cpu")
        ratio_in = ip.get("ratio_vs_default")
        ratio_wp = wp.get("ratio_vs_default")
        capped_wall = wp.get("last_run", {}).get("wall") if r["status"].startswith("capped") else None
        print(f"{r['problem']:12s} {r['method']:32s} {_fmt(ip.get('median'))} {ip.get('runs', '-'):>3} "
              f"{_fmt(ratio_in, 8, 2)} "
              f"{_fmt(wp.get('median') if not capped_wall else capped_wall)}{'+' if capped_wall else ' '}"
              f"{wp.get('runs', '-'):>2} {_fmt(ratio_wp, 7, 2)} {_fmt(cpu, 8)} "
              f"{(sol['in_range'] if sol else '-'):>4} "
              f"{('yes' if sol and sol['same_set'] else ('no' if sol else '-')):>4}  {'; '.join(notes)}")


if __name__ == "__main__":
    sys.exit(main())
