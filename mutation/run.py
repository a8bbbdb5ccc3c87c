"""Run the hand-written mutants of mutation/mutants.toml and report which ones the tests kill.

Usage (from anywhere; the repository is the parent of this file's directory):

    python mutation/run.py            # every mutant; exit 1 if one survives
    python mutation/run.py --only ID  # one mutant (repeatable)
    python mutation/run.py --list     # the mutants, nothing run

How: the files of the repository (``git ls-files``: tracked plus untracked, not ignored) are
copied to a temporary directory. Every mutant is checked first: its original text must occur
exactly once in its file (otherwise exit 2 before any test runs). In the copy, the mutated
``spherekin`` must be the one imported (PYTHONPATH = the copy; checked). Each distinct test
selection is run once unmutated (the baseline: it must pass, else exit 2). Then, one mutant at a
time, the original text is replaced, ``python -m pytest -x -q -p no:cacheprovider -m 'slow or not slow' <selection>`` (every tier)
runs in the copy with the same interpreter, and the file is restored. A failing run (exit 1, or 2
for a collection error) or a timeout kills the mutant; a passing run means it survived.
Bytecode writing is off (PYTHONDONTWRITEBYTECODE), so a mutant of the same size written within
the same second as its original can never be served from a stale .pyc.

Results: a table on stdout and mutation/results.json (git-ignored). Exit 0 when every mutant is
killed, 1 when one survives, 2 on a configuration error, 130 on Ctrl-C (the copy is restored and
removed first). Standard library only (tomllib: Python >= 3.11).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
MUTANTS_FILE = HERE / "mutants.toml"
RESULTS_FILE = HERE / "results.json"
#: Every tier: a mutant's tests may be in the long tier (tests/tiers.toml), which make test leaves out.
PYTEST_ARGS = ["-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", "-m", "slow or not slow"]
#: Seconds allowed to one mutant's run at least; the limit is max(this, TIMEOUT_FACTOR x its baseline).
#: Reason: a mutant of a loop's exit test may loop forever; a run that slow counts as killed.
TIMEOUT_MIN = 120.0
TIMEOUT_FACTOR = 10.0
REQUIRED = ("id", "file", "original", "replacement", "tests", "why")


class ConfigError(Exception):
    """mutants.toml does not match the code or the tests (exit 2)."""


@dataclass
class Mutant:
    id: str
    file: str
    original: str
    replacement: str
    tests: list[str]
    why: str
    outcome: str = ""
    seconds: float = 0.0
    detail: str = field(default="")


def load_mutants(path: Path = MUTANTS_FILE) -> list[Mutant]:
    with open(path, "rb") as fh:
        data = tomllib.load(fh)
    out, seen = [], set()
    for n, entry in enumerate(data.get("mutant", []), 1):
        missing = [k for k in REQUIRED if k not in entry]
        if missing:
            raise ConfigError(f"{path.name}: mutant #{n} ({entry.get('id', '?')}): missing {', '.join(missing)}")
        unknown = sorted(set(entry) - set(REQUIRED))
        if unknown:
            raise ConfigError(f"{path.name}: mutant {entry['id']}: unknown keys {', '.join(unknown)}")
        if entry["id"] in seen:
            raise ConfigError(f"{path.name}: mutant id {entry['id']} used twice")
        seen.add(entry["id"])
        tests = entry["tests"]
        if isinstance(tests, str) or not tests or not all(isinstance(t, str) for t in tests):
            raise ConfigError(f"{path.name}: mutant {entry['id']}: tests must be a non-empty list of pytest node ids or files")
        if entry["original"] == entry["replacement"]:
            raise ConfigError(f"{path.name}: mutant {entry['id']}: replacement equals the original text")
        out.append(Mutant(**{k: entry[k] for k in REQUIRED}))
    if not out:
        raise ConfigError(f"{path.name}: no [[mutant]] entries")
    return out


def check_mutants(mutants: list[Mutant], root: Path) -> None:
    """Every original text occurs exactly once in its file; every test file exists."""
    for m in mutants:
        src = root / m.file
        if not src.is_file():
            raise ConfigError(f"mutant {m.id}: file {m.file} not found — update mutation/mutants.toml")
        count = src.read_text(encoding="utf-8").count(m.original)
        if count == 0:
            raise ConfigError(f"mutant {m.id}: original text not found in {m.file} — update mutation/mutants.toml")
        if count > 1:
            raise ConfigError(f"mutant {m.id}: original text occurs {count} times in {m.file} (must be exactly once) "
                              f"— update mutation/mutants.toml")
        for t in m.tests:
            if not (root / t.split("::", 1)[0]).is_file():
                raise ConfigError(f"mutant {m.id}: test file {t.split('::', 1)[0]} not found — update mutation/mutants.toml")


def repo_files(root: Path) -> list[str]:
    """Tracked and untracked-but-not-ignored files of the repository (those that exist)."""
    out = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"], cwd=root,
                         capture_output=True, check=True).stdout.decode()
    return sorted({f for f in out.split("\0") if f and (root / f).is_file()})


def copy_repo(root: Path, dest: Path) -> None:
    for f in repo_files(root):
        target = dest / f
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(root / f, target)


def child_env(copy: Path) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(copy)
    env["PYTHONDONTWRITEBYTECODE"] = "1"
    env.setdefault("MPLBACKEND", "Agg")
    return env


def check_import(copy: Path) -> str:
    """The spherekin that the copy's runs import must be the copy's (not an installed one)."""
    r = subprocess.run([sys.executable, "-c", "import spherekin; print(spherekin.__file__)"], cwd=copy,
                       env=child_env(copy), capture_output=True, text=True)
    where = r.stdout.strip()
    if r.returncode != 0 or not Path(where).resolve().is_relative_to(copy.resolve()):
        raise ConfigError(f"the copy does not import its own spherekin (got {where or r.stderr.strip()!r}); "
                          f"mutants would be tested against another copy")
    return where


class Runner:
    """Runs pytest in the copy; keeps the running process so that Ctrl-C can stop it."""

    def __init__(self, copy: Path):
        self.copy = copy
        self.proc: subprocess.Popen | None = None

    def pytest(self, tests: list[str], timeout: float | None) -> tuple[int | None, float, str]:
        """(exit code or None on timeout, seconds, the first FAILED/ERROR line or else the last lines of output)."""
        t0 = time.perf_counter()
        self.proc = subprocess.Popen([sys.executable, *PYTEST_ARGS, *tests], cwd=self.copy, env=child_env(self.copy),
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                     start_new_session=True)
        try:
            out, _ = self.proc.communicate(timeout=timeout)
            code = self.proc.returncode
        except subprocess.TimeoutExpired:
            self.stop()
            out, code = "", None
        finally:
            self.proc = None
        lines = out.strip().splitlines()
        failed = [ln for ln in lines if ln.startswith(("FAILED ", "ERROR "))]
        return code, time.perf_counter() - t0, failed[0] if failed else "\n".join(lines[-3:])

    def stop(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, signal.SIGTERM)
                self.proc.wait(timeout=10)
            except (ProcessLookupError, subprocess.TimeoutExpired):
                try:
                    os.killpg(self.proc.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
                self.proc.wait()


def run(mutants: list[Mutant], copy: Path, runner: Runner, log=print) -> None:
    log(f"spherekin imported from {check_import(copy)}")
    baseline: dict[tuple, float] = {}
    for m in mutants:
        key = tuple(m.tests)
        if key in baseline:
            continue
        log(f"baseline: {' '.join(m.tests)} ...", end=" ", flush=True)
        code, secs, tail = runner.pytest(m.tests, timeout=None)
        log(f"{'passed' if code == 0 else 'FAILED'} ({secs:.1f} s)")
        if code != 0:
            raise ConfigError(f"mutant {m.id}: selection fails without mutation ({' '.join(m.tests)}, "
                              f"exit {code}):\n{tail}")
        baseline[key] = secs
    for m in mutants:
        path = copy / m.file
        text = path.read_text(encoding="utf-8")
        path.write_text(text.replace(m.original, m.replacement, 1), encoding="utf-8")
        try:
            log(f"{m.id}: ...", end=" ", flush=True)
            code, m.seconds, tail = runner.pytest(m.tests, timeout=max(TIMEOUT_MIN, TIMEOUT_FACTOR * baseline[tuple(m.tests)]))
        finally:
            path.write_text(text, encoding="utf-8")
        if code == 0:
            m.outcome = "survived"
        elif code in (1, 2):   # 2: a collection error (e.g. the mutated module fails to import)
            m.outcome, m.detail = "killed", tail.splitlines()[0] if tail else f"pytest exit {code}"
        elif code is None:
            m.outcome, m.detail = "killed", "timeout"
        else:
            raise ConfigError(f"mutant {m.id}: pytest exit {code} (usage error or no tests collected):\n{tail}")
        log(f"{m.outcome} ({m.seconds:.1f} s)")


def table(mutants: list[Mutant]) -> str:
    w = max(len(m.id) for m in mutants)
    rows = [f"{'mutant':<{w}}  {'outcome':<8}  {'time':>7}  killed by (first failure) / selection", "-" * (w + 70)]
    for m in mutants:
        by = m.detail.removeprefix("FAILED ").removeprefix("ERROR ").split(" - ")[0] if m.outcome == "killed" else ""
        rows.append(f"{m.id:<{w}}  {m.outcome or '-':<8}  {m.seconds:6.1f}s  {by or ' '.join(m.tests)}")
    killed = sum(m.outcome == "killed" for m in mutants)
    rows.append(f"{killed} of {len(mutants)} mutants killed")
    return "\n".join(rows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", action="append", metavar="ID", help="run only this mutant (repeatable)")
    ap.add_argument("--list", action="store_true", help="list the mutants and exit")
    args = ap.parse_args(argv)
    try:
        mutants = load_mutants()
        if args.only:
            unknown = sorted(set(args.only) - {m.id for m in mutants})
            if unknown:
                raise ConfigError(f"--only: unknown mutant {', '.join(unknown)}; known: {', '.join(m.id for m in mutants)}")
            mutants = [m for m in mutants if m.id in args.only]
        check_mutants(mutants, ROOT)
    except ConfigError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if args.list:
        for m in mutants:
            print(f"{m.id}  {m.file}  [{' '.join(m.tests)}]\n    {m.why}")
        return 0
    runner = None
    copy = Path(tempfile.mkdtemp(prefix="spherekin-mutants-"))
    try:
        copy_repo(ROOT, copy)
        check_mutants(mutants, copy)
        runner = Runner(copy)
        t0 = time.perf_counter()
        run(mutants, copy, runner)
    except ConfigError as e:
        print(f"\nerror: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        if runner is not None:
            runner.stop()
        print("\ninterrupted: the copy is removed, the repository was never modified", file=sys.stderr)
        return 130
    finally:
        shutil.rmtree(copy, ignore_errors=True)
    print()
    print(table(mutants))
    RESULTS_FILE.write_text(json.dumps({
        "python": sys.executable,
        "seconds": round(time.perf_counter() - t0, 1),
        "mutants": [dict(id=m.id, file=m.file, tests=m.tests, outcome=m.outcome, seconds=round(m.seconds, 2),
                         detail=m.detail, why=m.why) for m in mutants],
    }, indent=2) + "\n", encoding="utf-8")
    print(f"wrote {RESULTS_FILE.relative_to(ROOT)}")
    return 1 if any(m.outcome == "survived" for m in mutants) else 0


if __name__ == "__main__":
    sys.exit(main())
