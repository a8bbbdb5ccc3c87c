"""The whole ``spherekin solve`` process, today against a baseline revision, same run.

A researcher who types ``spherekin solve examples/gosselin.toml --inputs ...`` pays for the
interpreter's start, every import, the solve and the interpreter's exit. This benchmark runs that
command (each tree's console entry point from its pyproject.toml, called as pip's generated
script calls it) as a fresh process for each tree, alternating between them, and reports medians
and their ratio:

* ``baseline``: the source tree of ``--baseline`` (default ``b54b793``, the last commit before
  issue 14: the loop equations in the halves formulation, every module imported up front),
  exported with ``git archive`` into a temporary directory;
* ``current``: this checkout's ``spherekin``.

Each process runs with ``PYTHONPATH`` set to its tree, which Python searches before the installed
(editable) package: the script then imports that tree's ``spherekin`` (checked before timing).
Two conditions:

* ``bytecode``: compiled modules cached (``PYTHONPYCACHEPREFIX`` set to a temporary directory,
  filled by a first untimed run), as after ``pip install``, which writes them;
* ``source``: spherekin's modules compiled from source in every process (``PYTHONDONTWRITEBYTECODE=1``
  and no ``__pycache__`` in either tree), numpy's and the standard library's from their installed
  bytecode: the condition of a sandbox that forbids writing bytecode files.

Ratios: of the medians, and of the fastest runs of each tree (on a shared machine other jobs
inflate some runs of either tree; the fastest runs are the least affected). Also printed:
``-X importtime`` of one current process, grouped (numpy, mpmath, spherekin, the
rest). JSON to benchmarks/results/process.json.

    python -m benchmarks.bench_process [--runs 11] [--baseline b54b793]
"""

from __future__ import annotations

import argparse
import io
import json
import os
import platform
import re
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: The last commit before issue 14 ("today's" process of that issue).
BASELINE = "b54b793"
#: The commands timed: (label, example file, inputs in radians).
COMMANDS = (("gosselin", "examples/gosselin.toml", "0.3,-0.2,0.5"),
            ("general_3rrr", "examples/general_3rrr.toml", "0.3,-0.2,0.5"))


def export_tree(rev: str, dest: Path) -> Path:
    """The files of ``rev`` (git archive) under ``dest``; a clear error when rev is unknown."""
    proc = subprocess.run(["git", "-C", str(ROOT), "archive", "--format=tar", rev], capture_output=True)
    if proc.returncode != 0:
        raise SystemExit(f"--baseline: git archive {rev!r} failed: {proc.stderr.decode().strip()}")
    with tarfile.open(fileobj=io.BytesIO(proc.stdout)) as tar:
        tar.extractall(dest, filter="data")
    return dest


def _env(condition: str, prefix: Path, tree: Path) -> dict:
    env = {k: v for k, v in os.environ.items()       # (PYTHONUNBUFFERED: a user's shell does not set it)
           if k not in ("PYTHONPATH", "PYTHONDONTWRITEBYTECODE", "PYTHONPYCACHEPREFIX", "PYTHONUNBUFFERED")}
    env["PYTHONPATH"] = str(tree)
    if condition == "bytecode":
        env["PYTHONPYCACHEPREFIX"] = str(prefix)
    else:
        env["PYTHONDONTWRITEBYTECODE"] = "1"
    return env


def check_no_bytecode(tree: Path) -> None:
    """The source condition needs trees without compiled modules (else they would be used)."""
    found = sorted(str(p) for p in (tree / "spherekin").rglob("__pycache__"))
    if found:
        raise SystemExit(f"{found[0]}: remove the bytecode caches of {tree / 'spherekin'} first "
                         f"(find spherekin -name __pycache__ -exec rm -r {{}} +), or the source condition uses them")


def entry_command(tree: Path) -> list[str]:
    """What the ``spherekin`` console script of ``tree`` runs: its ``[project.scripts]`` entry point,
    called as pip's generated script calls it (``sys.exit(func())``)."""
    import tomllib

    scripts = tomllib.loads((tree / "pyproject.toml").read_text()).get("project", {}).get("scripts", {})
    if "spherekin" not in scripts:
        raise SystemExit(f"{tree / 'pyproject.toml'}: no [project.scripts] entry 'spherekin'")
    module, func = scripts["spherekin"].split(":")
    return [sys.executable, "-c", f"import sys; from {module} import {func}; sys.argv[0] = 'spherekin'; sys.exit({func}())"]


def imported_from(env: dict) -> str:
    out = subprocess.run([sys.executable, "-c", "import spherekin; print(spherekin.__file__)"], cwd=tempfile.gettempdir(),
                         env=env, capture_output=True, text=True, check=True).stdout.strip()
    return str(Path(out).resolve())


def run_once(tree: Path, env: dict, file: str, inputs: str) -> float:
    cmd = [*entry_command(tree), "solve", str(ROOT / file), "--inputs", inputs]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=tempfile.gettempdir(), env=env, capture_output=True, text=True,
                          stdin=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} (in {tree}) failed with code {proc.returncode}:\n{proc.stderr[-2000:]}")
    return wall


def import_groups(tree: Path, env: dict, file: str, inputs: str) -> dict:
    """Milliseconds of imports by group (top-level packages; cumulative time of each top import)."""
    python, *rest = entry_command(tree)
    proc = subprocess.run([python, "-X", "importtime", *rest, "solve", str(ROOT / file), "--inputs", inputs],
                          cwd=tempfile.gettempdir(), env=env, capture_output=True, text=True)
    groups: dict[str, float] = {}
    for line in proc.stderr.splitlines():
        m = re.match(r"import time:\s+(\d+) \|\s+(\d+) \|( *)(\S+)", line)
        if not m:
            continue
        self_us, name = int(m.group(1)), m.group(4)
        top = name.split(".")[0]
        group = top if top in ("numpy", "mpmath", "spherekin") else "other"
        groups[group] = groups.get(group, 0.0) + self_us / 1e3
    return {k: round(v, 1) for k, v in sorted(groups.items())}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=11, help="timed processes per tree, command and condition")
    parser.add_argument("--baseline", default=BASELINE, help="git revision of the baseline (default %(default)s)")
    parser.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "process.json"))
    args = parser.parse_args(argv)
    if args.runs < 1:
        parser.error(f"--runs: expected a positive number, got {args.runs}")
    out_path = Path(args.out)
    try:
        out_path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        parser.error(f"--out: cannot create {out_path.parent}: {exc}")

    rows = []
    with tempfile.TemporaryDirectory(prefix="spherekin-process-") as tmp:
        tmp = Path(tmp)
        trees = {"baseline": export_tree(args.baseline, tmp / "baseline"), "current": ROOT}
        for condition in ("bytecode", "source"):
            prefix = tmp / f"pycache-{condition}"
            envs = {label: _env(condition, prefix, tree) for label, tree in trees.items()}
            for label, tree in trees.items():
                if condition == "source":
                    check_no_bytecode(tree)
                got = imported_from(envs[label])
                if not got.startswith(str(tree.resolve())):
                    raise SystemExit(f"{label}: PYTHONPATH={tree} imports {got}, not that tree's package")
            for name, file, inputs in COMMANDS:
                for label, tree in trees.items():
                    run_once(tree, envs[label], file, inputs)   # untimed: fills the bytecode cache (bytecode)
                times: dict[str, list[float]] = {k: [] for k in trees}
                for _ in range(args.runs):
                    for label, tree in trees.items():       # alternating: both see the same machine load
                        times[label].append(run_once(tree, envs[label], file, inputs))
                med = {k: statistics.median(v) for k, v in times.items()}
                row = dict(command=name, condition=condition, runs=args.runs,
                           baseline_s=med["baseline"], current_s=med["current"],
                           ratio=med["current"] / med["baseline"],
                           ratio_fastest=min(times["current"]) / min(times["baseline"]), times=times)
                if name == COMMANDS[0][0]:
                    row["imports_ms"] = {k: import_groups(tree, envs[k], file, inputs) for k, tree in trees.items()}
                rows.append(row)
                print(f"{name:13s} {condition:9s} baseline {med['baseline']:.3f} s  current {med['current']:.3f} s  "
                      f"ratio {row['ratio']:.2f} (fastest runs {row['ratio_fastest']:.2f})", flush=True)

    print()
    print(f"{'command':13s} {'condition':9s} {'baseline s':>10s} {'current s':>10s} {'ratio':>6s} {'fastest':>8s}")
    for r in rows:
        print(f"{r['command']:13s} {r['condition']:9s} {r['baseline_s']:10.3f} {r['current_s']:10.3f} {r['ratio']:6.2f} "
              f"{r['ratio_fastest']:8.2f}")
    print("ratio: of the medians; fastest: of the fastest runs (less sensitive to other jobs on a shared machine)")
    for r in rows:
        if "imports_ms" in r:
            print(f"imports ({r['condition']}, ms of self time by package): "
                  + "; ".join(f"{k}: {v}" for k, v in r["imports_ms"].items()))
    machine = dict(python=platform.python_version(), machine=platform.machine(), processor=platform.processor(),
                   cpus=os.cpu_count(), load_average=os.getloadavg(), baseline=args.baseline,
                   date=time.strftime("%Y-%m-%d %H:%M"))
    out_path.write_text(json.dumps(dict(machine=machine, rows=rows), indent=2))
    print(f"wrote {out_path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
