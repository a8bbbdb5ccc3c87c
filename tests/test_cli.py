"""Tests for the command line: spherekin solve / gosselin, readable output, JSON, clear errors."""

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from spherekin.cli import main
from spherekin.problem import DEFAULT_FORMULATION, formulation_choices
from spherekin.systems import ON_CAP_CHOICES, SYSTEMS
from spherekin.search.lp_backends import LP_BACKENDS, REJECTED_LP_BACKENDS
from spherekin.search.parameterizations import PARAMETERIZATIONS
from spherekin.search.pruners import PRUNERS, ProjectedPolyhedron

GOSSELIN = str(Path(__file__).resolve().parent.parent / "examples" / "gosselin.toml")


def test_solve_prints_table_and_writes_json(tmp_path, capsys):
    out = tmp_path / "report.json"
    assert main(["solve", GOSSELIN, "--inputs", "0.3,-0.2,0.5", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "8 solutions (count proven" in text and "gamma1" in text and "serial" in text
    data = json.loads(out.read_text())
    assert data["count"] == {"proven": 8, "exact": True, "entries": 8}
    assert data["unknowns"] == ["gamma1", "delta1", "gamma2", "delta2", "gamma3", "delta3"]
    assert len(data["solutions"]) == 8
    for sol in data["solutions"]:
        r = np.array(sol["platform_rotation"])
        np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
        assert set(sol["passive_angles"]) == set(data["unknowns"])
    assert data["statistics"]["boxes_processed"] == 0          # the complete count searches no box
    # the default ("auto") resolves to the complete count for a base-actuated 3-RRR, and the JSON says so
    assert DEFAULT_FORMULATION == "auto"
    assert (data["settings"]["formulation"], data["settings"]["parameterization"]) == ("complete", "quaternion")
    assert "quaternion, formulation complete" in text
    assert all(sol["evidence"]["bezout"]["roots_proven"] == 8 for sol in data["solutions"])


def test_loop_formulation_fallback_is_reported(capsys):
    # 3e-9 from a parallel singularity of general_3rrr (tests/test_trust_edge.py, repro 1): the complete
    # count cannot prove all 8 roots, the platform search cannot isolate the two nearby roots, and the
    # loop equations answer; the note gives both reasons, in the chain's order
    path = str(Path(GOSSELIN).parent / "general_3rrr.toml")
    assert main(["solve", path, "--inputs=0.18613171226800826,-0.15119930525771785,0.6382686351031328"]) == 0
    text = capsys.readouterr().out
    assert "8 solutions (count proven" in text
    assert "tan-half, formulation halves" in text and "note: the complete count proved" in text
    assert "; then the platform search left" in text


def test_strategy_options_reach_the_solver(tmp_path, capsys):
    out = tmp_path / "sc.json"
    argv = ["solve", GOSSELIN, "--inputs", "0.3,-0.2,0.5", "--parameterization", "sin-cos", "--formulation",
            "transversal", "--no-isolate", "--jobs", "2", "--json", str(out)]
    assert main(argv) == 0
    assert "sin-cos, formulation transversal" in capsys.readouterr().out
    settings = json.loads(out.read_text())["settings"]
    assert (settings["parameterization"], settings["formulation"], settings["isolate"], settings["jobs"]) == \
        ("sin-cos", "transversal", False, 2)
    assert len(json.loads(out.read_text())["solutions"]) == 8


def test_unknown_strategy_name_is_a_usage_error(capsys):
    """argparse's own errors in spherekin's one format: one line, the option first, exit status 2."""
    assert main(["solve", GOSSELIN, "--inputs", "0,0,0", "--parameterization", "quaternion"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1
    assert err.startswith(f"spherekin: error: --parameterization: expected one of {', '.join(PARAMETERIZATIONS)}, "
                          "got 'quaternion' (see spherekin solve --help)")


@pytest.mark.parametrize("pruner", [None, *PRUNERS])
@pytest.mark.parametrize("name", sorted(REJECTED_LP_BACKENDS))
def test_a_refused_lp_backend_is_one_line_with_its_measured_reason(name, pruner, capsys):
    """Not argparse's "invalid choice": spherekin knows the name and says why it refuses it (exit 2,
    nothing on stdout, no traceback), whatever the pruner (the default pp solves no LP, and said only
    that); --help still lists only the offered backends."""
    chosen = [] if pruner is None else ["--pruner", pruner]
    assert main(["solve", GOSSELIN, "--inputs=0.3,-0.2,0.5", *chosen, "--lp-backend", name]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"spherekin: error: --lp-backend: expected one of {list(LP_BACKENDS)}, got {name!r}")
    assert REJECTED_LP_BACKENDS[name] in err
    assert name not in _help_choices(capsys)["--lp-backend"]


def _help_choices(capsys) -> dict:
    """option -> its choices, as ``spherekin solve --help`` prints them ({a,b,c})."""
    assert main(["solve", "--help"]) == 0
    text = capsys.readouterr().out
    return {option: choices.split(",") for option, choices in re.findall(r"(--[a-z-]+) \{([^}]*)\}", text)}


def test_help_choices_are_the_registries(capsys):
    assert _help_choices(capsys) == {"--parameterization": list(PARAMETERIZATIONS),
                                     "--system": ["auto", *SYSTEMS],
                                     "--formulation": list(formulation_choices()),
                                     "--pruner": list(PRUNERS), "--lp-backend": list(LP_BACKENDS),
                                     "--on-cap": list(ON_CAP_CHOICES)}


def test_help_lists_a_registered_strategy(registered, capsys):
    class PPAgain(ProjectedPolyhedron):
        name = "pp-again"

    registered(PRUNERS, PPAgain)
    assert _help_choices(capsys)["--pruner"] == [*PRUNERS] and "pp-again" in PRUNERS


def test_degrees_give_the_same_solutions(tmp_path):
    a, b = tmp_path / "rad.json", tmp_path / "deg.json"
    main(["solve", GOSSELIN, "--inputs", "0.3,-0.2,0.5", "--json", str(a)])
    deg = ",".join(f"{math.degrees(v):.15g}" for v in (0.3, -0.2, 0.5))
    main(["solve", GOSSELIN, "--inputs", deg, "--degrees", "--json", str(b)])
    ra = [s["platform_rotation"] for s in json.loads(a.read_text())["solutions"]]
    rb = [s["platform_rotation"] for s in json.loads(b.read_text())["solutions"]]
    np.testing.assert_allclose(ra, rb, atol=1e-9)


@pytest.mark.parametrize(
    "argv, message",
    [
        (["solve", GOSSELIN, "--inputs", "0.3,-0.2"], "expected 3 values"),
        (["solve", GOSSELIN, "--inputs", "0.3,abc,0.1"], "--inputs"),
        (["solve", GOSSELIN, "--inputs", "0.3,nan,0.1"], "--inputs (beta2): expected an angle in radians"),
        (["solve", "no/such/file.toml", "--inputs", "0,0,0"], "file.toml"),
        (["solve", GOSSELIN, "--inputs", "0,0,0", "--jobs", "0"], "jobs"),
        (["gosselin", "--range", "1", "0"], "lo < hi"),
    ],
)
def test_bad_input_exits_2_with_message(argv, message, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("spherekin: error:") and message in err and "Traceback" not in err


def test_gosselin_summary(capsys):
    assert main(["gosselin", "--samples", "200"]) == 0
    text = capsys.readouterr().out
    assert "total control points: 162" in text


@pytest.mark.parametrize("entry", [["-m", "spherekin"],
                                   ["-c", "import sys; from spherekin.cli import run; sys.argv[0] = 'spherekin'; run()"]])
def test_the_console_entry_flushes_its_output_before_the_fast_exit(tmp_path, entry):
    """run() ends the process with os._exit: everything main printed to a pipe (block-buffered)
    must still arrive, the JSON must be complete, and the exit codes are main's."""
    import subprocess
    import sys

    import os

    out = tmp_path / "r.json"
    root = Path(__file__).resolve().parent.parent
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}     # a pipe is block-buffered
    proc = subprocess.run([sys.executable, *entry, "solve", GOSSELIN, "--inputs", "0.3,-0.2,0.5", "--json", str(out)],
                          capture_output=True, text=True, cwd=root, timeout=120, env=env)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert "8 solutions (count proven" in proc.stdout and lines[-1] == f"wrote {out}"
    assert len(json.loads(out.read_text())["solutions"]) == 8
    bad = subprocess.run([sys.executable, *entry, "solve", GOSSELIN, "--inputs", "0.3,-0.2"],
                         capture_output=True, text=True, cwd=root, timeout=120, env=env)
    assert bad.returncode == 2 and "expected 3 values" in bad.stderr and "Traceback" not in bad.stderr


def test_verify_runs_the_checkouts_verification_as_its_own_process(tmp_path, capfd):
    """spherekin verify runs python -m verification of this checkout (the package never imports it)."""
    report = tmp_path / "REPORT.md"
    assert main(["verify", "--quick", "--report", str(report)]) == 0
    assert "report written to" in capfd.readouterr().out
    assert "ERRATUM" in report.read_text()


def test_verify_without_a_checkout_says_where_the_verification_lives(tmp_path):
    """An installation with no verification/ beside it: one clear message, exit 2, no traceback."""
    import shutil
    import subprocess
    import sys

    root = Path(__file__).resolve().parent.parent
    shutil.copytree(root / "spherekin", tmp_path / "spherekin", ignore=shutil.ignore_patterns("__pycache__"))
    proc = subprocess.run([sys.executable, "-c", "import sys; from spherekin.cli import main; sys.exit(main(['verify']))"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "source checkout" in proc.stderr and "make verify" in proc.stderr


@pytest.mark.parametrize("columns", ["50", "200"])
def test_help_is_argparses_own_at_the_terminal_width(monkeypatch, columns):
    """The parser's formatter reads the terminal width without importing shutil; the help it prints
    is exactly what argparse's stock formatter (which asks shutil) prints, for every command."""
    import argparse

    from spherekin.cli import build_parser

    monkeypatch.setenv("COLUMNS", columns)
    parser = build_parser()
    (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    for p in (parser, *sub.choices.values()):
        ours = p.format_help()
        p.formatter_class = argparse.HelpFormatter
        assert ours == p.format_help()
    assert max(len(line) for line in ours.splitlines()) <= int(columns)


def _modules_after(argv, cwd=None) -> set[str]:
    """The top-level names of the modules a fresh process holds after ``main(argv)`` returned 0
    (its printed output discarded)."""
    import subprocess
    import sys

    root = Path(__file__).resolve().parent.parent
    code = ("import io, sys, contextlib; from spherekin.cli import main\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n"
            f"    assert main({list(argv)!r}) == 0\n"
            "print(' '.join(sorted(sys.modules)))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=cwd or root, timeout=120)
    assert proc.returncode == 0, proc.stderr
    return {name.split(".")[0] for name in proc.stdout.split()}


def test_the_default_solve_imports_only_what_it_uses():
    """spherekin solve with the defaults (the complete count, then the platform formulation and the pp
    pruner it falls back to) imports no LP solver, no
    plotting, no exact arithmetic and no JSON: each import is paid by every process (issue 14:
    import time counts). Checked in a fresh process, by the modules it holds at the end."""
    loaded = _modules_after(["solve", GOSSELIN, "--inputs", "0.3,-0.2,0.5"])
    assert "spherekin" in loaded and "numpy" in loaded
    unused = {"cvxpy", "highspy", "clarabel", "scipy", "matplotlib", "mpmath", "sympy", "fractions", "json",
              "shutil", "multiprocessing", "concurrent"}
    assert loaded & unused == set()


#: Third-party modules no command below uses: tables (pandas, pyarrow: ~0.3 s of a process to import),
#: Dask (distributed, dask, tornado, cloudpickle: ~0.3-0.5 s; only for a job on a cluster), SciPy,
#: plotting, symbolic and exact arithmetic, LP solvers.
HEAVY = {"pandas", "pyarrow", "distributed", "dask", "tornado", "cloudpickle", "scipy", "matplotlib", "sympy",
         "mpmath", "cvxpy", "highspy", "clarabel"}


@pytest.mark.parametrize("command", ["track", "track --out", "batch --out"])
def test_track_and_a_batch_in_this_process_import_no_tables_and_no_dask(tmp_path, command):
    """spherekin track (printed, and its results table written as CSV) and spherekin batch --workers 0
    --out CSV: no pandas (the CSV is written from the table's columns) and no Dask (a job in this
    process needs no worker plugin), issue 30: a path tracks at ~0.2 ms a row, and these imports
    cost ~0.3-0.5 s each; a printed track, nothing of the outputs (~15 ms). Checked in a fresh
    process, by the modules it holds at the end; the file is written."""
    example = str(Path(GOSSELIN).with_name("general_3rrr.toml"))
    path = tmp_path / "path.csv"
    path.write_text("beta1,beta2,beta3\n" + "".join(f"{x!r},2.83,-2.24\n" for x in (0.07, 0.08, 0.09, 0.1)))
    out = tmp_path / "out.csv"
    argv = {"track": ["track", example, "--path", str(path), "--start-solution", "1"],
            "track --out": ["track", example, "--path", str(path), "--start-solution", "1", "--out", str(out)],
            "batch --out": ["batch", example, "--inputs", str(path), "--workers", "0", "--quiet", "--out", str(out)]}
    loaded = _modules_after(argv[command])
    assert "spherekin" in loaded and "numpy" in loaded
    assert loaded & HEAVY == set()
    assert out.is_file() == command.endswith("--out")
    if command == "track":      # nothing written: no output lock or fingerprint (socket, hashlib, json)
        assert loaded & {"socket", "secrets", "hashlib", "json"} == set()


def test_the_console_entry_collects_garbage_while_it_solves():
    """run() pauses the garbage collector only while the modules are imported: importing the CLI
    module imports no numpy (so the pause covers it), and during the solve the collector is on."""
    import subprocess
    import sys

    root = Path(__file__).resolve().parent.parent
    code = ("import sys, gc\n"
            "import spherekin.cli\n"
            "print('numpy at import:', 'numpy' in sys.modules, file=sys.stderr)\n"
            "import spherekin.problem as p\n"
            "solve = p.Problem.solve\n"
            "def spy(self, *a, **k):\n"
            "    print('gc during solve:', gc.isenabled(), file=sys.stderr)\n"
            "    return solve(self, *a, **k)\n"
            "p.Problem.solve = spy\n"
            "sys.argv = ['spherekin', 'solve', sys.argv[1], '--inputs', '0.3,-0.2,0.5']\n"
            "spherekin.cli.run()\n")
    proc = subprocess.run([sys.executable, "-c", code, GOSSELIN], capture_output=True, text=True, cwd=root, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "numpy at import: False" in proc.stderr and "gc during solve: True" in proc.stderr
    assert "8 solutions (count proven" in proc.stdout


def test_a_notes_python_keywords_are_given_as_options(monkeypatch, capsys):
    """A cap's note speaks the command line too: "try --formulation transversal", not the Python
    keyword formulation='transversal' (caps made tiny so that the solve reaches them at once)."""
    import functools

    import spherekin.problem

    monkeypatch.setattr(spherekin.problem, "compile", functools.partial(spherekin.problem.compile, max_boxes=100))
    assert main(["solve", GOSSELIN, "--inputs", "0.3,-0.2,0.5", "--quiet", "--system", "platform"]) == 0
    notes = [line for line in capsys.readouterr().out.splitlines() if line.startswith("note: ")]
    assert notes and any("max_boxes=100" in n for n in notes)
    assert all("formulation='" not in n for n in notes) and any("try --formulation transversal" in n for n in notes)


@pytest.mark.parametrize("signum, expected", [("SIGTERM", "Terminated"), ("SIGINT", "KeyboardInterrupt")])
def test_an_interrupt_raised_inside_a_finalizer_is_not_lost(signum, expected):
    """Python runs a signal handler at the main thread's next bytecode, which can be a finalizer's
    (a dask Future's __del__ on CI): the exception is dropped there. The command must still stop."""
    import os
    import signal
    import time

    from spherekin.cli.errors import Terminated, sigterm_as_interrupt

    class SignalsWhileFinalized:
        def __del__(self):
            os.kill(os.getpid(), getattr(signal, signum))
            for _ in range(100):       # the handler runs here, inside __del__, and its raise is dropped
                time.sleep(0)

    caught = None
    with sigterm_as_interrupt():
        try:
            SignalsWhileFinalized()    # unbound: finalized at once (no gc pass, which would run others' callbacks)
            for _ in range(2000):      # the command goes on: the interrupt must reach it here
                time.sleep(0.0005)
        except KeyboardInterrupt as exc:
            caught = exc
    assert type(caught).__name__ == expected
    assert isinstance(caught, KeyboardInterrupt) and (signum != "SIGTERM" or isinstance(caught, Terminated))


def test_a_tolerance_given_in_degrees_is_told_it_is_read_in_radians(capsys):
    """`--degrees --tol 45` (issue 42 item 17): the error says --tol is in radians, also with --degrees."""
    assert main(["solve", GOSSELIN, "--inputs", "10,20,30", "--degrees", "--tol", "45"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--tol is in radians, also with --degrees (45 deg is 0.785 rad)" in err


def test_a_growing_job_logs_one_progress_line_not_one_per_round(capsys):
    """A branch map's total grows with its refinements and reaches done == total once per round (issue 42
    item 14: ~18 bars in a log). In a log, within one PROGRESS_INTERVAL: the first state, then nothing until
    close, then the last state once."""
    from spherekin.cli.progress import BatchProgress

    progress = BatchProgress(terminal=False)
    for rounds in range(1, 19):
        for done in range(0, 10 * rounds + 1, 5):
            progress(done, 10 * rounds)
    before = capsys.readouterr().err.splitlines()
    assert len(before) == 1 and "0/10 inputs" in before[0]
    progress.close()
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and "180/180 inputs" in lines[0]


@pytest.mark.parametrize("command", [["solve", GOSSELIN, "--inputs", "0.3,-0.2,0.5", "--plot", "/proc/x.png"],
                                     ["solve", GOSSELIN, "--inputs", "0.3,-0.2,0.5", "--json", "/proc/x.json"],
                                     ["singular", GOSSELIN.replace("gosselin", "four_bar"), "--x", "A=-pi:pi",
                                      "--json", "/proc/x.json"]])
def test_an_output_where_nothing_can_be_written_is_refused_before_the_work(command, capsys):
    """A directory no file can be created in (/proc, a read-only mount: os.access says yes to root there) is
    one line naming the option before any work (issue 42 item 10), found by creating a probe file."""
    assert main(command) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and "cannot write in the directory '/proc'" in err


@pytest.mark.parametrize("where", ["compile", "solve"])
@pytest.mark.parametrize("signal_name", ["SIGINT", "SIGTERM"])
def test_a_stop_before_the_search_still_writes_a_json_saying_nothing_was_searched(tmp_path, capsys, monkeypatch,
                                                                                    where, signal_name):
    """Issue 42 item 17: Ctrl-C (or SIGTERM) during start-up, before the search could keep anything,
    wrote no --json: the document must exist and say nothing was searched (no count, no solution)."""
    import spherekin.problem
    from spherekin.cli import Terminated
    from spherekin.mechanism import load_mechanism

    def stop(*args, **kwargs):
        raise Terminated("SIGTERM") if signal_name == "SIGTERM" else KeyboardInterrupt()

    monkeypatch.setattr(spherekin.problem, "compile", stop) if where == "compile" else \
        monkeypatch.setattr(spherekin.problem.Problem, "solve", stop)
    out = tmp_path / "r.json"
    code = main(["solve", GOSSELIN, "--inputs", "0.3,-0.2,0.5", "--json", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert code == 130 and "nothing searched" in err, err
    data = json.loads(out.read_text())
    assert data["searched"] is False and data["solutions"] == [] and data["count"]["proven"] is None
    assert data["count"]["exact"] is False and data["settings"]["limit"]["interrupted"] is True
    assert signal_name in data["settings"]["limit"]["error"]
    assert data["settings"]["inputs"] == [0.3, -0.2, 0.5]
    assert data["unknowns"] == list(load_mechanism(GOSSELIN).loop_unknowns)
