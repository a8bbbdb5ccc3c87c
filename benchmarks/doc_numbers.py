"""The times and counts the documentation quotes, measured by running the documented commands.

The pages quote how long a command takes and how many boxes and LPs it needs (README, getting started,
the paper-configuration and maps guides). Measured once by hand, such numbers drift: a default
changes, or the reader's machine is not the one they were taken on (issue 42 item 13: "about 0.1 s"
was 0.55-0.79 s wall on a 2-core machine). This script runs each documented command as its own
process (``spherekin ...``, as a reader types it), ``--repeats`` times, and writes
``benchmarks/doc_numbers.json``: per command the median wall time and median CPU time (user +
system of the process, which a loaded machine inflates much less than wall time), the counts the page
quotes, and the strategy that ran, read back from the command's own JSON report; plus the machine
(CPU model, cores, Python, numpy). The pages quote these numbers and name the file;
``tests/test_doc_numbers.py`` checks every quote against it, so a page cannot drift from what the
file holds.

    python -m benchmarks.doc_numbers [--repeats 3] [--only ID ...]      (make doc-numbers)
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "benchmarks" / "doc_numbers.json"
SPHEREKIN = [sys.executable, "-m", "spherekin"]
#: Runs of each command (the median is quoted). Reason: on a shared 2-core machine single runs vary
#: by 2-3x; three is the fewest with a median, and the slowest command (the paper-faithful chart)
#: takes minutes a run.
REPEATS = 3
#: The strategy keys read back from a solve's JSON report (settings): what ran, not what was asked.
STRATEGY_KEYS = ("system", "formulation", "parameterization", "pruner", "lp_backend", "tol", "isolate", "charts")


def _solve_facts(report: dict) -> dict:
    """The counts and strategy of a ``solve --json`` report that the pages quote."""
    st, s = report["statistics"], report["settings"]
    return {"solutions": report["count"]["entries"], "proven": report["count"]["proven"],
            "boxes": st["boxes_processed"], "lps": st["lps_solved"], "solve_seconds": st["time_total"],
            "strategy": {k: s.get(k) for k in STRATEGY_KEYS}}


def _mode_change_facts(report: dict) -> dict:
    """The proven assembly-mode change of a ``singular --mode-change --json`` report."""
    mc = report.get("mode_change") or {}
    return {"mode_change": {k: mc.get(k) for k in ("found", "cusp", "radius", "start_solution", "end_solution",
                                                   "proven_steps")},
            "system": report.get("system"), "tol": report.get("tol")}


def _engine_facts(report: dict) -> dict:
    """The certified throughput of ``bench_engine`` (issue 44) the README quotes: per mechanism the
    engine's, the box engine's and the floor's solves per second, the share the chosen system
    answered, and the strategy (read back from the compiled problem)."""
    return {"engine": {r["mechanism"]: {"system": r["system"], "engine_per_s": r["engine_per_s"],
                                        "boxes_per_s": r["boxes_per_s"], "floor_per_s": r["floor_per_s"],
                                        "engine_over_floor": r["engine_over_floor"],
                                        "engine_over_boxes": r["engine_over_boxes"],
                                        "answered_by_first_system": r["answered_by_first_system"],
                                        "strategy": r["strategy"], "inputs": r["inputs"], "chunk": r.get("chunk"),
                                        "repeats": report["repeats"]}
                       for r in report["rows"]}}


@dataclass(frozen=True)
class Run:
    """One documented command: ``argv`` after ``program`` (default ``spherekin``; ``{json}``: where its
    report goes), and ``facts(report)``: what the pages quote from its JSON."""

    id: str
    argv: tuple[str, ...]
    facts: Callable[[dict], dict]
    where: str                                     # the page(s) that quote it
    #: Timed without ``--json`` (as the page shows it), the facts read from one more, untimed run.
    #: For a command of a fraction of a second, where writing the report is part of the time.
    json_apart: bool = False
    #: The program the command runs (a benchmark's module for a throughput: its rates are the facts,
    #: measured inside it; the process's own time is then of no interest, but recorded).
    program: tuple[str, ...] = ("spherekin",)
    #: Processes of the command (None: --repeats); a benchmark repeats inside itself.
    processes: int | None = None


RUNS = (
    Run("make-run", ("solve", "examples/gosselin.toml", "--inputs", "0.3,-0.2,0.5", "--json", "{json}"),
        _solve_facts, "README.md, docs/getting-started.md", json_apart=True),
    Run("paper-chart-highspy", ("solve", "examples/gosselin_chart.toml", "--inputs", "0.3,-0.2,0.5", "--formulation",
                                "paper", "--pruner", "lp", "--lp-backend", "highspy", "--no-isolate", "--tol", "1e-3",
                                "--quiet", "--json", "{json}"),
        _solve_facts, "docs/howto/paper-configuration.md"),
    Run("paper-chart-clarabel", ("solve", "examples/gosselin_chart.toml", "--inputs", "0.3,-0.2,0.5", "--formulation",
                                 "paper", "--pruner", "lp", "--lp-backend", "clarabel", "--no-isolate", "--tol", "1e-3",
                                 "--quiet", "--json", "{json}"),
        _solve_facts, "docs/howto/paper-configuration.md"),
    Run("mode-change", ("singular", "examples/general_3rrr.toml", "--x", "beta1=1.5:1.7", "--y", "beta2=0:0.2", "--fix",
                        "beta3=0.5", "--tol", "0.1", "--mode-change", "--json", "{json}"),
        _mode_change_facts, "docs/howto/maps-singularities.md"),
    Run("engine-throughput", ("--inputs", "4096", "--repeats", "3", "--baseline", "none", "--only", "general_3rrr",
                              "gosselin", "four-bar", "five-bar", "--out", "{json}"),
        _engine_facts, "README.md", program=("python", "-m", "benchmarks.bench_engine"), processes=1),
)


def machine() -> dict:
    """What the numbers were measured on."""
    import numpy

    model = platform.processor() or ""
    try:
        model = next(line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                     if line.startswith("model name")) or model
    except (OSError, StopIteration):
        pass
    return {"cpu": model, "cores": os.cpu_count(), "python": platform.python_version(), "numpy": numpy.__version__,
            "system": platform.platform(), "date": time.strftime("%Y-%m-%d")}


def run_once(run: Run, workdir: Path, report: bool = True) -> tuple[float, float, dict | None]:
    """(wall seconds, CPU seconds, facts: None without ``report``) of one process of ``run``."""
    path = workdir / f"{run.id}.json"
    program = SPHEREKIN if run.program == ("spherekin",) else [sys.executable, *run.program[1:]]
    argv = [*program, *(a.replace("{json}", str(path)) for a in run.argv)]
    if not report:
        argv = [a for k, a in enumerate(argv) if a != "--json" and (k == 0 or argv[k - 1] != "--json")]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(argv, cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"{run.id}: exit {proc.returncode}: {proc.stderr.strip()[-500:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, run.facts(json.loads(path.read_text())) if report else None


def measure(run: Run, repeats: int, workdir: Path) -> dict:
    """The medians of ``repeats`` processes of ``run``; its counts must be the same in every run."""
    walls, cpus, solves, facts = [], [], [], None
    repeats = run.processes or repeats
    for k in range(repeats + run.json_apart):
        timed = not run.json_apart or k > 0
        wall, cpu, got = run_once(run, workdir, report=not (run.json_apart and timed))
        if timed:
            walls.append(wall)
            cpus.append(cpu)
        if got is None:
            continue
        if "solve_seconds" in got:
            solves.append(got.pop("solve_seconds"))
        if facts is not None and got != facts:
            raise SystemExit(f"{run.id}: the counts differ between runs ({facts} then {got})")
        facts = got
    shown = [a for k, a in enumerate(run.argv) if a not in ("--json", "--out", "{json}")]
    return {"command": " ".join(run.program) + " " + " ".join(shown), "quoted_in": run.where, "repeats": repeats,
            "wall_median_s": statistics.median(walls), "cpu_median_s": statistics.median(cpus),
            "wall_s": walls, "cpu_s": cpus, **({"solve_median_s": statistics.median(solves)} if solves else {}),
            **facts}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=REPEATS, help=f"processes per command (default {REPEATS})")
    parser.add_argument("--only", nargs="*", choices=[r.id for r in RUNS], help="measure these commands only "
                        "(the others keep their numbers in the file)")
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error("--repeats: expected at least 1")
    data = json.loads(OUT.read_text()) if OUT.exists() and args.only else {"runs": {}}
    runs = [r for r in RUNS if not args.only or r.id in args.only]
    print(f"{'command':<22} {'wall (median)':>14} {'CPU (median)':>13}  counts")
    with tempfile.TemporaryDirectory() as tmp:
        for run in runs:
            got = measure(run, args.repeats, Path(tmp))
            data["runs"][run.id] = got
            counts = ({k: got[k] for k in ("solutions", "boxes", "lps") if k in got} or got.get("mode_change")
                      or {m: round(e["engine_per_s"]) for m, e in got.get("engine", {}).items()})
            print(f"{run.id:<22} {got['wall_median_s']:>12.2f} s {got['cpu_median_s']:>11.2f} s  {counts}", flush=True)
    data["machine"] = machine()
    data["generated_by"] = "python -m benchmarks.doc_numbers"
    OUT.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
    print(f"wrote {OUT.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
