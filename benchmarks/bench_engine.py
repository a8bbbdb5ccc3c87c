"""Solves per second per core of the engine (``Problem.solve_many``), against a loop of ``solve`` at
b4386ee's algorithm and against the degree-8 eigenvalue solve of the 3-RRR, in one run.

Why: every family question (maps, atlases, singularity covers, sweeps) is bounded by the cost of one
solve; issue 30's engine runs a chunk of inputs as one array program and must give >= 10x the
throughput of the per-input loop it replaces on the 3-RRR (platform system) and >= 5x on the loop
systems. The degree-8 eigenvalue solve (no proof, no ranges, no trust layer) is the physical floor
of the 3-RRR: the ratio to it says how much the proofs still cost.

Timed, on the same seeded inputs (uniform over each actuated joint's range; the full circle where a
joint is unlimited), one core (BLAS threads set to 1; everything runs in one process at a time):

* ``engine``: ``problem = spherekin.compile(mech)`` once (untimed), then ``problem.solve_many(rows,
  chunk=--chunk)`` (default: the problem's own chunk, ``problem.chunk``, recorded), each report read as callers read it (``proven_count``,
  ``count_exact``): this checkout's public API, whatever solve_many is (for the 3-RRRs driven at the
  base: the complete count of issue 44); the share of inputs the chosen system answered itself;
* ``boxes`` (where the engine is the complete count): the same with ``system=`` the next system of the
  chain (the platform search, the box engine before issue 44), same tree; counts compared per input;
* ``eigvals`` (3-RRR rows): ``np.linalg.eigvals`` of as many batched random 8 x 8 matrices: the
  eigenproblem alone, the floor of any method that solves one per input;
* ``baseline``: the source tree of ``--baseline`` (default b4386ee, the last commit before issue 30),
  exported with ``git archive`` into a temporary directory, in a child process with ``PYTHONPATH``
  set to that tree (checked: the child imports that tree's spherekin); it compiles each mechanism
  once (untimed) and times a loop of ``problem.solve(x)`` over the same inputs (handed over as a
  .npy file). The child stays up for the whole run, so engine and baseline repeats alternate and
  see the same machine load;
* ``floor`` (3-RRR rows): :func:`references.peers_closed_form.real_roots_many`, the Macaulay
  eigenproblem of the quaternion quadrics (:mod:`references.peers_closed_form`) vectorized over
  every input (batched SVD, pinv, eig; the real roots polished by Newton), from the inputs to the
  real roots. For the elbow-actuated 3-RRR the quadrics are the same with w_i := u_i and
  cos(alpha2_i) := u_i . v_i, the angle the locked elbow fixes (:func:`floor_quadrics`).

Mechanisms, by file (both trees read the same file): examples/general_3rrr.toml, gosselin.toml,
four_bar.toml, five_bar.toml, and the elbow-actuated 3-RRR (general_3rrr with each leg's middle
joint actuated; :func:`benchmarks.bench_systems.elbow_actuated_3rrr`) written as a legs file
(kind "general", which b4386ee reads) into the temporary directory.

Columns: solves per second (inputs / median wall time of ``--repeats`` runs) of each, the ratio
engine / baseline against its target, the ratios engine / box engine, engine / floor and engine /
eigvals, the mean number of solutions per input, and the inputs whose solution counts differ between
engine and baseline or box engine (or floor and engine): a difference is a bug to report, never
averaged away. Verdict: the complete count at or above the floor (issue 44), the other systems their
issue-30 target against the baseline. ``--baseline none`` leaves the baseline out; ``--agree N``
compares the complete count with the box engine on N more inputs per mechanism (issue 44: 10,000),
untimed. JSON to benchmarks/results/engine.json (with each row's strategy, read back from the problem).

    python -m benchmarks.bench_engine [--inputs 128] [--repeats 3] [--chunk N] [--baseline b4386ee|none]
                                      [--agree N]
"""

from __future__ import annotations

import os

# One core: numpy's BLAS threads are fixed before numpy is imported (here and in the child).
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
for _var in THREAD_VARIABLES:
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import collections  # noqa: E402
import dataclasses  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from benchmarks.bench_process import export_tree  # noqa: E402
from benchmarks.bench_systems import elbow_actuated_3rrr  # noqa: E402
from references.peers_closed_form import geometry_of, quadrics_many, real_roots_many  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
#: The last commit before issue 30: its solve is the per-input loop the engine replaces.
BASELINE = "b4386ee"
#: The complete counts of issue 44 and their goals: "complete" at or above the degree-8 floor (its rows say
#: engine / floor); "complete-loop" (four-bar, five-bar) at least this many certified solves per second per core.
COMPLETE_GOALS = {"complete": None, "complete-loop": 20_000.0}
#: ``--baseline none``: no baseline tree (the columns of the engine, the box engine and the floor only).
NO_BASELINE = "none"
#: Throughput targets (engine / baseline, per core) of issue 30, by the system the engine runs.
TARGETS = {"platform": 10.0, "loops": 5.0}
#: Input rows per mechanism, timed runs and rows per solve_many call by default: ~2.5 min in all on
#: a quiet 2-core machine before the engine (25-50 ms a solve, ~130 ms the baseline's elbow-actuated
#: 3-RRR; ~5 min at load average 5), less once the engine is faster. Inputs a chunk: each problem's
#: own (None: ``Problem.chunk``, its first system's; read back into the JSON).
DEFAULT_INPUTS, DEFAULT_REPEATS, DEFAULT_CHUNK = 128, 3, None
SEED = 30
#: Mismatching inputs listed per row in the JSON (all are counted).
MISMATCHES_LISTED = 10


#: The table's rows, in order (the labels ``--only`` takes).
LABELS = ("general_3rrr", "gosselin", "elbow-actuated 3-RRR", "four-bar", "five-bar")


@dataclasses.dataclass(frozen=True)
class Case:
    """One row of the table: a label and the mechanism file both trees read."""

    label: str
    file: Path


def cases(tmp: Path) -> list[Case]:
    """The benchmark's mechanisms; the elbow-actuated 3-RRR is written to ``tmp`` as a legs file."""
    from spherekin.mechanism.io import dumps_mechanism

    elbow = tmp / "elbow_actuated_3rrr.toml"
    # kind "general" (the legs and their axes at the reference configuration), not "3-RRR", which
    # would write the base-actuated geometry and lose the elbow actuation
    elbow.write_text(dumps_mechanism(dataclasses.replace(elbow_actuated_3rrr(), kind="general", geometry=None)))
    ex = ROOT / "examples"
    files = (ex / "general_3rrr.toml", ex / "gosselin.toml", elbow, ex / "four_bar.toml", ex / "five_bar.toml")
    return [Case(label, file) for label, file in zip(LABELS, files)]


def uniform_inputs(mech, n: int, rng) -> np.ndarray:
    """``n`` rows (n, actuated) uniform over each actuated joint's range ([-pi, pi) when unlimited)."""
    cols = []
    for name in mech.actuated:
        lo, hi = mech.ranges.get(name) or (-np.pi, np.pi)
        cols.append(rng.uniform(lo, hi, n))
    return np.column_stack(cols)


# ---------------------------------------------------------------- the floor: degree 8, vectorized

def _rotate(axes, angles, vecs) -> np.ndarray:
    """Rodrigues for a stack: each of ``vecs`` (3, 3) turned about ``axes`` (3, 3) by ``angles`` (K, 3)."""
    axes, vecs = np.asarray(axes, float), np.asarray(vecs, float)
    c, s = np.cos(angles)[..., None], np.sin(angles)[..., None]
    return (vecs * c + np.cross(axes, vecs) * s
            + axes * np.einsum("ij,ij->i", axes, vecs)[:, None] * (1.0 - c))


def floor_layout(mech) -> str | None:
    """"base" (a 3-RRR with its base joints actuated), "elbow" (three R-R-R legs with the middle
    joints actuated) or None: the mechanisms whose direct kinematics are three quaternion quadrics."""
    if mech.geometry is not None and hasattr(mech.geometry, "distal_link_angles"):
        return "base"
    legs = mech.legs
    if len(legs) == 3 and all(len(leg.joints) == 3 for leg in legs) and \
            all([j.actuated for j in leg.joints] == [False, True, False] for leg in legs):
        return "elbow"
    return None


def floor_quadrics(mech, rows) -> np.ndarray:
    """The three quaternion quadrics (K, 3, 4, 4) of each input row (K, 3) of a 3-RRR (radians).

    Base-actuated (:func:`floor_layout` "base"): w_i = Rot(u_i, beta_i) w_i^0 and cos(alpha2_i).
    Elbow-actuated: the locked elbow makes leg i a rigid link from u_i to v_i, of angle c_i with
    cos c_i = u_i . Rot(w_i, gamma_i - gamma_i^ref) v_i^ref (axes and readings at the reference
    configuration, where the platform pose is ``platform_reference``); then w_i := u_i.
    """
    rows = np.asarray(rows, dtype=float)
    layout = floor_layout(mech)
    if layout == "base":
        u, w0, v0, alpha2 = geometry_of(mech)
        return quadrics_many(_rotate(u, rows, w0), v0, np.cos(alpha2))
    if layout == "elbow":
        u, w, v = (np.array([leg.joints[k].axis for leg in mech.legs], float) for k in range(3))
        ref = np.array([leg.joints[1].reference_angle for leg in mech.legs])
        cosines = np.einsum("ij,kij->ki", u, _rotate(w, rows - ref, v))
        v0 = v @ np.asarray(mech.platform_reference, float)      # P^T v_i: the platform frame
        return quadrics_many(np.broadcast_to(u, rows.shape[:1] + (3, 3)), v0, cosines)
    raise ValueError(f"mech: expected a 3-RRR (base or elbow joints actuated), got {mech.name!r}")


def floor_counts(mech, rows) -> np.ndarray:
    """Real roots (assemblies over unlimited ranges) of each row by the vectorized degree-8 solve;
    -1 where its eigenproblem is degenerate."""
    _, real, ok = real_roots_many(floor_quadrics(mech, rows))
    return np.where(ok, real.sum(axis=1), -1)


# ---------------------------------------------------------------- the baseline, in its own tree

#: The baseline child: reads {"mech": file, "inputs": .npy} lines, answers {"seconds", "counts"}.
CHILD = r"""
import json, sys, time
import numpy as np
import spherekin
from spherekin.mechanism import load_mechanism
from spherekin.problem import compile
print(json.dumps({"spherekin": spherekin.__file__}), flush=True)
problems = {}
for line in sys.stdin:
    req = json.loads(line)
    if req["mech"] not in problems:
        problems[req["mech"]] = compile(load_mechanism(req["mech"]))
    problem = problems[req["mech"]]
    rows = np.load(req["inputs"])
    t0 = time.perf_counter()
    reports = [problem.solve(x) for x in rows]
    seconds = time.perf_counter() - t0
    print(json.dumps({"seconds": seconds, "counts": [len(r.solutions) for r in reports]}), flush=True)
"""


class Baseline:
    """The baseline tree's child process: ``solve(file, npy)`` -> (seconds, counts)."""

    def __init__(self, tree: Path, tmp: Path):
        env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        env["PYTHONPATH"] = str(tree)
        self.tree = tree
        self.stderr = open(tmp / "baseline.stderr", "w+")
        self.proc = subprocess.Popen([sys.executable, "-c", CHILD], cwd=tmp, env=env, text=True,
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self.stderr)
        where = str(Path(self._answer()["spherekin"]).resolve())
        if not where.startswith(str(tree.resolve())):
            self.close()
            raise SystemExit(f"baseline: PYTHONPATH={tree} imports {where}, not that tree's package")

    def _answer(self) -> dict:
        line = self.proc.stdout.readline()
        if not line:
            self.stderr.seek(0)
            raise SystemExit(f"baseline child (tree {self.tree}) failed:\n{self.stderr.read()[-2000:]}")
        return json.loads(line)

    def solve(self, file: Path, npy: Path) -> tuple[float, list[int]]:
        self.proc.stdin.write(json.dumps({"mech": str(file), "inputs": str(npy)}) + "\n")
        self.proc.stdin.flush()
        ans = self._answer()
        return ans["seconds"], ans["counts"]

    def close(self) -> None:
        self.proc.stdin.close()
        self.proc.wait()
        self.stderr.close()


# ---------------------------------------------------------------- the run

def engine_run(problem, rows, chunk: int | None, systems: list | None = None) -> tuple[float, list[int]]:
    """Seconds of one ``solve_many`` of ``rows`` (``chunk``: its chunk; None: the problem's own),
    read as callers read it (each report's ``proven_count`` and ``count_exact``: the count, -1 where it
    is not exact), and the counts; ``systems``, when given, receives the system that answered each
    row (after the timing)."""
    t0 = time.perf_counter()
    reports = problem.solve_many(rows, chunk=chunk)
    counts = [r.proven_count if r.count_exact else -1 for r in reports]
    seconds = time.perf_counter() - t0
    if systems is not None:
        systems[:] = [r.settings.system for r in reports]
    return seconds, counts


def eigvals_run(n: int, rng) -> float:
    """Seconds of ``np.linalg.eigvals`` of ``n`` batched random 8 x 8 matrices (the eigenproblem alone)."""
    mats = rng.normal(size=(n, 8, 8))
    t0 = time.perf_counter()
    np.linalg.eigvals(mats)
    return time.perf_counter() - t0


def floor_run(mech, rows) -> tuple[float, list[int]]:
    t0 = time.perf_counter()
    counts = floor_counts(mech, rows)
    return time.perf_counter() - t0, [int(c) for c in counts]


def mismatches(rows, a, b) -> tuple[int, list]:
    """How many rows have different counts in ``a`` and ``b``, and the first few (inputs, a, b)."""
    bad = [k for k, (x, y) in enumerate(zip(a, b)) if x != y]
    return len(bad), [dict(inputs=[float(v) for v in rows[k]], first=a[k], second=b[k])
                      for k in bad[:MISMATCHES_LISTED]]


def run(n_inputs: int, repeats: int, chunk: int, baseline_rev: str, only=None) -> list[dict]:
    """One dict per mechanism (``only``: labels to keep), the table's numbers and the raw times."""
    import spherekin
    from spherekin.mechanism import load_mechanism

    out = []
    with tempfile.TemporaryDirectory(prefix="spherekin-engine-") as tmp:
        tmp = Path(tmp)
        base = Baseline(export_tree(baseline_rev, tmp / "baseline"), tmp) if baseline_rev != NO_BASELINE else None
        try:
            for index, case in enumerate(cases(tmp)):
                if only is not None and case.label not in only:
                    continue
                mech = load_mechanism(case.file)
                problem = spherekin.compile(mech)
                # the box engine: the first system after the complete count (today's engine before it)
                boxes = (spherekin.compile(mech, system=problem.chain[1].system)
                         if problem.system in COMPLETE_GOALS else None)
                rows = uniform_inputs(mech, n_inputs, np.random.default_rng([SEED, index]))
                npy = tmp / "inputs.npy"
                np.save(npy, rows)
                has_floor = floor_layout(mech) is not None
                times = {"engine": [], "boxes": [], "baseline": [], "floor": [], "eigvals": []}
                counts, systems = {}, []
                for rep in range(repeats):           # alternating: each sees the same machine load
                    for name in times:
                        if name == "engine":
                            t, c = engine_run(problem, rows, chunk, systems if rep == 0 else None)
                        elif name == "boxes" and boxes is not None:
                            t, c = engine_run(boxes, rows, chunk)
                        elif name == "baseline" and base is not None:
                            t, c = base.solve(case.file, npy)
                        elif name == "floor" and has_floor:
                            t, c = floor_run(mech, rows)
                        elif name == "eigvals" and has_floor:
                            t, c = eigvals_run(n_inputs, np.random.default_rng(SEED)), None
                        else:
                            continue
                        times[name].append(t)
                        if counts.setdefault(name, c) != c:
                            raise SystemExit(f"{case.label}: {name} gave other solution counts on a repeat")
                rate = {k: n_inputs / statistics.median(v) for k, v in times.items() if v}
                target = TARGETS.get(problem.system, TARGETS["loops"])
                n_bad, listed = mismatches(rows, counts["engine"], counts["baseline"]) if base else (0, [])
                first = sum(name == problem.system for name in systems) / n_inputs
                row = dict(mechanism=case.label, system=problem.system, strategy=problem.strategy_keywords(),
                           inputs=n_inputs, chunk=chunk or problem.chunk,
                           boxes_chunk=None if boxes is None else chunk or boxes.chunk, mean_solutions=float(np.mean(counts["engine"])),
                           engine_per_s=rate["engine"], baseline_per_s=rate.get("baseline"),
                           ratio=rate["engine"] / rate["baseline"] if base else None, target=target,
                           answered_by_first_system=first, answered_by=dict(collections.Counter(systems)),
                           count_mismatches=n_bad, mismatched_inputs=listed,
                           boxes_per_s=rate.get("boxes"), engine_over_boxes=None, boxes_mismatches=None,
                           floor_per_s=rate.get("floor"), engine_over_floor=None, floor_mismatches=None,
                           eigvals_per_s=rate.get("eigvals"), engine_over_eigvals=None, times=times)
                if boxes is not None:
                    row["engine_over_boxes"] = rate["engine"] / rate["boxes"]
                    row["boxes_mismatches"], row["boxes_mismatched_inputs"] = mismatches(
                        rows, counts["engine"], counts["boxes"])
                if has_floor:
                    row["engine_over_floor"] = rate["engine"] / rate["floor"]
                    row["engine_over_eigvals"] = rate["engine"] / rate["eigvals"]
                    row["floor_mismatches"], row["floor_mismatched_inputs"] = mismatches(
                        rows, counts["floor"], counts["engine"])
                ok = n_bad == 0 and not row["boxes_mismatches"]
                if problem.system == "complete":       # issue 44: at or above the degree-8 floor
                    row["verdict"] = "PASS" if ok and row["engine_over_floor"] >= 1.0 else "FAIL"
                elif problem.system in COMPLETE_GOALS:  # issue 44: the one-loop count, solves per second
                    row["verdict"] = "PASS" if ok and rate["engine"] >= COMPLETE_GOALS[problem.system] else "FAIL"
                elif base is None:
                    row["verdict"] = "-"                  # no baseline run: its target is not judged
                else:
                    row["verdict"] = "PASS" if row["ratio"] >= target and ok else "FAIL"
                out.append(row)
                print(f"{case.label}: engine {rate['engine']:.1f}/s"
                      + (f", box engine {rate['boxes']:.1f}/s" if boxes is not None else "")
                      + (f", baseline {rate['baseline']:.1f}/s" if base else "")
                      + (f", floor {rate['floor']:.0f}/s, eigvals {rate['eigvals']:.0f}/s" if has_floor else ""),
                      flush=True)
        finally:
            if base is not None:
                base.close()
    return out


def agreement(n_inputs: int, only=None) -> list[dict]:
    """Counts of the chosen system against the box engine (the next system of its chain) on ``n_inputs``
    seeded inputs per mechanism whose chosen system is the complete count (no timing): one dict per
    mechanism, the inputs whose counts differ listed (any is a bug)."""
    import spherekin
    from spherekin.mechanism import load_mechanism

    out = []
    with tempfile.TemporaryDirectory(prefix="spherekin-agree-") as tmp:
        for index, case in enumerate(cases(Path(tmp))):
            if only is not None and case.label not in only:
                continue
            mech = load_mechanism(case.file)
            problem = spherekin.compile(mech)
            if problem.system not in COMPLETE_GOALS:
                continue
            boxes = spherekin.compile(mech, system=problem.chain[1].system)
            rows = uniform_inputs(mech, n_inputs, np.random.default_rng([SEED, index, 1]))
            systems: list = []
            _, fast = engine_run(problem, rows, DEFAULT_CHUNK, systems)
            _, slow = engine_run(boxes, rows, DEFAULT_CHUNK)
            n_bad, listed = mismatches(rows, fast, slow)
            out.append(dict(mechanism=case.label, inputs=n_inputs, answered_by=dict(collections.Counter(systems)),
                            count_mismatches=n_bad, mismatched_inputs=listed,
                            not_exact=sum(c < 0 for c in fast)))
            print(f"{case.label}: {n_inputs} inputs, {n_bad} count mismatches against the box engine, answered by "
                  f"{dict(collections.Counter(systems))}", flush=True)
    return out


def print_table(rows, baseline_rev: str) -> None:
    head = (f"{'mechanism':21s} {'system':8s} {'first':>5s} {'sols':>5s} {'engine/s':>9s} {'boxes/s':>8s} "
            f"{'eng/box':>7s} {'base/s':>8s} {'ratio':>6s} {'floor/s':>8s} {'eng/flr':>7s} {'eig/s':>7s} "
            f"{'eng/eig':>7s} {'counts':>9s}  verdict")
    print(head)
    print("-" * len(head))
    for r in rows:
        boxes = (f"{r['boxes_per_s']:8.0f} {r['engine_over_boxes']:7.2f}" if r.get("boxes_per_s")
                 else f"{'-':>8s} {'-':>7s}")
        floor = (f"{r['floor_per_s']:8.0f} {r['engine_over_floor']:7.3f} {r['eigvals_per_s']:7.0f} "
                 f"{r['engine_over_eigvals']:7.4f}" if r["floor_per_s"] else f"{'-':>8s} {'-':>7s} {'-':>7s} {'-':>7s}")
        bad = r["count_mismatches"] + (r.get("boxes_mismatches") or 0)
        agree = "agree" if bad == 0 else f"{bad} differ"
        base = (f"{r['baseline_per_s']:8.1f} {r['ratio']:6.2f}" if r["baseline_per_s"] else f"{'-':>8s} {'-':>6s}")
        print(f"{r['mechanism']:21s} {r['system']:8s} {r['answered_by_first_system']:5.0%} {r['mean_solutions']:5.2f} "
              f"{r['engine_per_s']:9.1f} {boxes} {base} {floor} {agree:>9s}  {r['verdict']}")
    print(f"certified solves per second per core (medians), read as callers read them (proven_count, count_exact); "
          f"first: the share of inputs the chosen system answered itself (the rest fell back); boxes: the box "
          f"engine (the next system of the chain: the platform search) in this tree; base: a loop of solve at "
          f"{baseline_rev}; ratio = engine / base; eng/flr = engine / the vectorized degree-8 eigen solve (no proof); "
          "eig/s: np.linalg.eigvals of as many batched 8 x 8 matrices; counts: engine vs base and vs the box "
          "engine, per input. Verdict: the complete count at or above the floor, the one-loop count at >= 20,000/s; "
          "other systems their issue-30 target against base")
    for r in rows:
        if r.get("boxes_mismatches"):
            print(f"BUG: {r['mechanism']}: {r['boxes_mismatches']} inputs where the engine's and the box engine's "
                  f"counts differ, e.g. {r['boxes_mismatched_inputs'][0]}")
        if r["count_mismatches"]:
            print(f"BUG: {r['mechanism']}: {r['count_mismatches']} inputs where engine and baseline counts differ, "
                  f"e.g. {r['mismatched_inputs'][0]}")
        if r.get("floor_mismatches"):
            print(f"note: {r['mechanism']}: {r['floor_mismatches']} inputs where the floor's real roots and the "
                  f"engine's count differ, e.g. {r['floor_mismatched_inputs'][0]}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--inputs", type=int, default=DEFAULT_INPUTS, help="seeded inputs per mechanism")
    parser.add_argument("--repeats", type=int, default=DEFAULT_REPEATS, help="timed runs; medians are shown")
    parser.add_argument("--chunk", type=int, default=DEFAULT_CHUNK,
                        help="inputs per array program (solve_many's chunk; default: each problem's own, "
                             "Problem.chunk, recorded in the JSON)")
    parser.add_argument("--baseline", default=BASELINE, help=f"git revision of the baseline (default %(default)s; "
                        f"{NO_BASELINE!r}: no baseline column)")
    parser.add_argument("--only", nargs="+", metavar="LABEL", help="these mechanisms only (labels of the table)")
    parser.add_argument("--agree", type=int, default=0, metavar="N",
                        help="also compare the complete count's counts with the box engine's on N more seeded inputs "
                             "per mechanism (untimed; issue 44 asks for 10,000)")
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "engine.json")
    args = parser.parse_args(argv)
    for key in ("inputs", "repeats", "chunk"):
        if getattr(args, key) is not None and getattr(args, key) < 1:
            parser.error(f"--{key}: expected a whole number >= 1, got {getattr(args, key)}")
    unknown = [label for label in args.only or () if label not in LABELS]
    if unknown:
        parser.error(f"--only: expected labels among {', '.join(LABELS)}, got {unknown[0]!r}")
    try:
        args.out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        parser.error(f"--out: cannot create {args.out.parent}: {exc}")
    per_chunk = args.chunk or "each problem's own"
    print(f"{args.inputs} inputs per mechanism (seed {SEED}), chunks of {per_chunk}, medians of {args.repeats} "
          f"runs; one core; Python {platform.python_version()}, numpy {np.__version__}; "
          f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores", flush=True)
    rows = run(args.inputs, args.repeats, args.chunk, args.baseline, args.only)
    agreed = agreement(args.agree, args.only) if args.agree > 0 else []
    print(f"\nload average at the end {os.getloadavg()[0]:.1f}")
    print_table(rows, args.baseline)
    machine = dict(python=platform.python_version(), numpy=np.__version__, machine=platform.machine(),
                   cpus=os.cpu_count(), load_average=os.getloadavg(), date=time.strftime("%Y-%m-%d %H:%M"))
    for a in agreed:
        print(f"agreement: {a['mechanism']}: {a['inputs']} inputs, {a['count_mismatches']} differ from the box engine, "
              f"answered by {a['answered_by']}" + (" BUG" if a["count_mismatches"] else ""))
    args.out.write_text(json.dumps(dict(benchmark="engine", baseline=args.baseline, seed=SEED, repeats=args.repeats,
                                        machine=machine, rows=rows, agreement=agreed), indent=2))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
