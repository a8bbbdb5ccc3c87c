"""What a new user meets first (issue 17): the real `spherekin` command in a subprocess for what only a
process shows (negative inputs, paths checked before any work, Ctrl-C, --version), and the rest in process."""

from __future__ import annotations

import json
import math
import os
import re
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest

from spherekin import __version__
from spherekin.cli import main
from spherekin.cli.progress import Progress
from spherekin.mechanism import gosselin, mechanism_from_dict

ROOT = Path(__file__).resolve().parent.parent
GOSSELIN = str(ROOT / "examples" / "gosselin.toml")
BIN = Path(sys.executable).parent / "spherekin"


def spherekin(*args, cwd=None):
    return subprocess.run([str(BIN), *args], capture_output=True, text=True, timeout=300, cwd=cwd)


def test_version():
    run = spherekin("--version")
    assert run.returncode == 0 and run.stdout.strip() == f"spherekin {__version__}"


def test_negative_inputs_without_an_equals_sign():
    run = spherekin("solve", GOSSELIN, "--inputs", "-0.3,0.2,0.5")
    assert run.returncode == 0, run.stderr
    assert "beta1 = -0.3 rad" in run.stdout and "8 solutions" in run.stdout


@pytest.mark.parametrize("args, message", [
    (["--json", "/nonexistent/dir/out.json"], "--json /nonexistent/dir/out.json: the directory /nonexistent/dir does not exist"),
    (["--json", "out.txt"], "--json out.txt: expected a file name ending in .json"),
    (["--plot", "out.jpg"], "--plot: expected a file name ending in one of .png, .pdf, .svg, got 'out.jpg'"),
    (["--jobs", "0"], "jobs"),
    (["--tol", "0"], "tol: expected a positive number"),
])
def test_bad_arguments_are_refused_before_any_output(tmp_path, args, message):
    run = spherekin("solve", GOSSELIN, "--inputs", "0.3,-0.2,0.5", *args, cwd=tmp_path)
    assert run.returncode == 2
    assert message in run.stderr and "Traceback" not in run.stderr
    assert run.stdout == ""                       # not even the header: nothing was started
    assert not list(tmp_path.iterdir())


def test_ctrl_c_prints_and_saves_what_was_found_exit_130_no_traceback(tmp_path):
    out = tmp_path / "partial.json"
    proc = subprocess.Popen([str(BIN), "solve", GOSSELIN, "--inputs", "0.3,-0.2,0.5", "--formulation", "halves",
                             "--pruner", "lp", "--lp-backend", "highspy", "--json", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    header = proc.stdout.readline()
    assert "direct kinematics at" in header
    time.sleep(2.0)                                  # into the LP search (it takes minutes)
    t0 = time.perf_counter()
    os.killpg(proc.pid, signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    assert time.perf_counter() - t0 < 1.0 + 1.0      # within a second (+1 s for a loaded machine)
    assert proc.returncode == 130
    assert "Traceback" not in stderr
    assert "interrupted (Ctrl-C)" in stdout and "not necessarily every solution" in stdout
    assert "at least 0" not in stdout                # nothing found yet is not a count
    data = json.loads(out.read_text())
    assert data["settings"]["limit"]["interrupted"] is True and data["count"]["exact"] is False
    # the statistics are the work done until Ctrl-C, the same number as the note's (not zeros)
    done = int(re.search(r"after (\d+) boxes", stdout).group(1))
    assert done > 0 and re.search(rf"\b{done} boxes \(", stdout), stdout
    stats = data["statistics"]
    assert stats["boxes_processed"] == done and stats["charts"] >= 1 and stats["lps_solved"] > 0
    assert stats["time_total"] >= 1.0 and data["settings"]["charts"] == stats["charts"]


def test_an_empty_result_says_why(capsys):
    chart = str(ROOT / "examples" / "gosselin_chart.toml")
    assert main(["solve", chart, "--inputs", "-2.5,2.9,0.1"]) == 0
    assert "no assembly inside the joint ranges; 8 assemblies exist with the passive joints unlimited" \
        in capsys.readouterr().out
    assert main(["solve", str(ROOT / "examples" / "general_3rrr.toml"), "--inputs", "-2.5,2.9,0.1"]) == 0
    assert "no assembly at all at these inputs" in capsys.readouterr().out


def test_the_json_holds_the_mechanism(tmp_path, capsys):
    out = tmp_path / "r.json"
    assert main(["solve", GOSSELIN, "--inputs", "0.3,-0.2,0.5", "--json", str(out), "--quiet"]) == 0
    data = json.loads(out.read_text())
    again = mechanism_from_dict(tomllib.loads(data["mechanism_toml"]))
    ref = gosselin()
    assert [j.name for j in again.joints] == [j.name for j in ref.joints]
    np.testing.assert_allclose([j.axis for j in again.joints], [j.axis for j in ref.joints], atol=1e-15)


def test_progress_lines_in_a_log_and_silence_with_quiet(capsys, monkeypatch):
    counts = {"boxes_processed": 500, "pending": 3, "accepted": 1}
    log = Progress(terminal=False)
    log.t0 -= 30.0                                  # as if the solve had run for 30 s
    log(counts)
    log(counts)                                      # the next line only PROGRESS_INTERVAL later
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "boxes      500" in err and "/s)" in err and "\r" not in err
    quiet = Progress(terminal=True, quiet=True)
    quiet.t0 -= 30.0
    quiet(counts)
    quiet.close()
    assert capsys.readouterr().err == ""


def test_errors_speak_in_options_not_python_keywords(capsys):
    from spherekin.cli import as_options

    assert as_options("lp_backend: the 'pp' pruner solves no LP; pass lp_backend=None or pruner='lp'") == \
        "--lp-backend: the 'pp' pruner solves no LP; pass no --lp-backend or --pruner lp"
    assert main(["solve", GOSSELIN, "--inputs", "0.3,-0.2,0.5", "--pruner", "pp", "--lp-backend", "highspy"]) == 2
    captured = capsys.readouterr()
    assert "pass no --lp-backend or --pruner lp" in captured.err and "lp_backend=" not in captured.err
    assert captured.out == ""
    chart = str(ROOT / "examples" / "general_3rrr.toml")
    assert main(["batch", chart, "--grid", "beta1=0:1:3", "--fix", "beta2=0", "--fix", "beta3=0", "--out",
                 "never.csv", "--pruner", "pp", "--lp-backend", "clarabel"]) == 2
    captured = capsys.readouterr()
    assert "--pruner lp" in captured.err and captured.out == "" and not Path("never.csv").exists()


def test_the_json_of_an_empty_solve_says_why(tmp_path, capsys):
    out = tmp_path / "r.json"
    chart = str(ROOT / "examples" / "gosselin_chart.toml")
    assert main(["solve", chart, "--inputs", "-2.5,2.9,0.1", "--json", str(out), "--quiet"]) == 0
    printed = capsys.readouterr().out
    reason = json.loads(out.read_text())["empty_reason"]
    assert reason["kind"] == "outside_ranges" and reason["assemblies_without_ranges"] == 8
    assert f"note: {reason['note']}" in printed                 # the line printed is the JSON's


# ------------------------------------------------------------------ one error format (issue 27, items 10 and 11)

GENERAL = str(ROOT / "examples" / "general_3rrr.toml")
PATH = str(ROOT / "examples" / "path_general_3rrr.csv")
GRID = ["--grid", "beta1=0:1:3", "--fix", "beta2=0", "--fix", "beta3=0"]
MAP_GRID = ["--grid", "beta1=0:1:3", "--grid", "beta2=0:1:3", "--fix", "beta3=0"]
#: Stands for a copy of general_3rrr.toml with the range beta1 in [-pi/2, pi/2] (written by the test).
RANGED = "RANGED.toml"

#: (a bad command line, how its one error line starts after "spherekin: error: ": the option as typed)
BAD_COMMAND_LINES = [
    (["solve", GOSSELIN, "--inputs", "0.3,abc,0.5"], "--inputs (beta2): expected an angle"),
    (["solve", GOSSELIN, "--inputs", "0.3,-0.2"], "--inputs: expected 3 values"),
    (["solve", GOSSELIN, "--inputs", "pi/2,0,0", "--degrees"], "--inputs (beta1): with --degrees"),
    (["solve", RANGED, "--inputs", "2,0,0"], "--inputs (beta1): 2.0 is outside the joint range"),
    (["solve", GOSSELIN], "--inputs: required"),
    (["solve", GOSSELIN, "--inputs", "0,0,0", "--jobs", "0"], "--jobs: expected a whole number >= 1, got '0'"),
    (["solve", GOSSELIN, "--inputs", "0,0,0", "--jobs", "x"], "--jobs: expected a whole number >= 1, got 'x'"),
    (["solve", GOSSELIN, "--inputs", "0,0,0", "--tol", "1"], "--tol: expected at most 0.1 rad, got 1.0"),
    (["solve", GOSSELIN, "--inputs", "0,0,0", "--tol", "abc"], "--tol: expected a number, got 'abc'"),
    (["solve", GOSSELIN, "--inputs", "0,0,0", "--pruner", "qq"], "--pruner: expected one of"),
    (["solve", GOSSELIN, "--inputs", "0,0,0", "--lp-backend", "osqp"], "--lp-backend: expected one of"),
    (["solve", GOSSELIN, "--inputs", "0,0,0", "--pruner", "pp", "--lp-backend", "highspy"],
     "--lp-backend: the 'pp' pruner solves no LP; pass no --lp-backend or --pruner lp"),
    (["solve", GOSSELIN, "--inputs", "0,0,0", "--formulation", "platform", "--no-isolate"],
     "--formulation 'platform': --no-isolate asked for (the platform formulation proves its roots by the Krawczyk test)"),
    (["solve", GOSSELIN, "--inputs", "0,0,0", "--json", "out.txt"], "--json out.txt: expected a file name ending"),
    (["solve", GOSSELIN, "--inputs", "0,0,0", "--plot", "out.jpg"], "--plot: expected a file name ending"),
    (["solve", GOSSELIN, "--inputs", "0,0,0", "--quiet=1"], "--quiet: takes no value, got '1'"),
    (["solve", GOSSELIN, "--inputs", "0,0,0", "--bogus"], "--bogus: not an option or argument of spherekin solve"),
    (["ik", GENERAL, "--euler", "1,2"], "--euler: expected 3 values"),
    (["ik", GENERAL, "--euler", "1,2,x"], "--euler (c): expected an angle"),
    (["ik", GENERAL, "--euler", "1,2,3", "--convention", "QQQ"], "--convention: expected three axis letters"),
    (["ik", GENERAL, "--quaternion", "1,0,0,0", "--convention", "ZYX"], "--convention: only with --euler"),
    (["ik", GENERAL, "--quaternion", "0,0,0,0"], "--quaternion: expected a nonzero quaternion"),
    (["ik", GENERAL, "--rotation", "1,0,0"], "--rotation: expected 9"),
    (["ik", GENERAL, "--quaternion", "1,0,0,0", "--json", "nodir/ik.json"], "--json nodir/ik.json: the directory"),
    (["batch", GENERAL, *GRID, "--out", "r.csv", "--workers", "-1"],
     "--workers: expected a whole number >= 0 (0: in this process), got '-1'"),
    (["batch", GENERAL, *GRID, "--out", "r.csv", "--chunk-size", "0"], "--chunk-size: expected a whole number >= 1"),
    (["batch", GENERAL, *GRID, "--out", "r.txt"], "--out r.txt: expected a .parquet"),
    (["batch", GENERAL, *GRID], "--out: required"),
    (["batch", GENERAL, "--grid", "beta1=0:1:100000", "--grid", "beta2=0:1:1000", "--fix", "beta3=0", "--out", "r.csv"],
     "--grid: 100000000 points is more than one job takes (10,000,000)"),
    (["batch", GENERAL, "--grid", "beta1=0:1:3", "--fix", "beta2=0", "--fix", "beta3=abc", "--out", "r.csv"],
     "--fix beta3: expected an angle"),
    (["batch", GENERAL, "--inputs", "no.csv", "--out", "r.csv"], "--inputs no.csv: no such file"),
    (["batch", GENERAL, *GRID, "--out", "r.csv", "--pruner", "pp", "--lp-backend", "scs"], "--lp-backend: expected one of"),
    (["map", GENERAL, *MAP_GRID, "--plot", "nodir/m.png"], "--plot: the directory 'nodir'"),
    (["map", GENERAL, *MAP_GRID, "--table", "m.txt"], "--table m.txt: expected a .csv path"),
    (["map", GENERAL, *MAP_GRID, "--workers", "x"], "--workers: expected a whole number >= 0"),
    (["map", GENERAL, *GRID], "--grid: a map needs exactly two grid axes"),
    (["track", GENERAL, "--path", PATH, "--start-solution", "99"], "--start-solution: expected a whole number from 1 to 8"),
    (["track", GENERAL, "--path", PATH, "--start-solution", "0"], "--start-solution: expected a whole number from 1 to 8"),
    (["track", GENERAL, "--path", PATH, "--start-solution", "1", "--check", "0"], "--check: expected a whole number >= 1"),
    (["track", GENERAL, "--path", "no.csv", "--start-solution", "1"], "--path no.csv: no such file"),
    (["track", GENERAL, "--path", PATH, "--start-solution", "1", "--plot", "x.gif"], "--plot: expected a file name ending"),
    (["track", GENERAL, "--path", PATH, "--start-rotation", "1,0,0"], "--start-rotation: expected 9"),
    (["track", GENERAL, "--path", PATH, "--start-quaternion", "0,0,0,0"], "--start-quaternion: expected a nonzero"),
    (["gosselin", "--range", "1", "0"], "--range: expected lo < hi"),
    (["gosselin", "--beta", "1", "2", "nan"], "--beta (B3): expected an angle"),
    (["gosselin", "--samples", "0"], "--samples: expected a whole number >= 1"),
    (["sovle", GOSSELIN], "'sovle' is not a command; expected one of solve, ik, batch, map, singular, track, gosselin, verify"),
    ([], "expected a command, one of solve, ik"),
]
#: What an error line never holds: a constant's name (MAX_TOL), a Python name where the user typed an
#: option (workers:, lp_backend=, inputs (beta1):), argparse's usage block, a traceback.
INTERNAL = re.compile(r"\b[A-Z][A-Z0-9]*_[A-Z0-9_]+\b|(?<![-\w])(workers|chunk_size|lp_backend|path|convention|inputs|"
                      r"tol|jobs|start|isolate|formulation|pruner|plot|betas)( \([^)]*\))?\s*[:=]|usage:|Traceback")


@pytest.mark.parametrize("argv, start", BAD_COMMAND_LINES, ids=[" ".join(Path(a).name for a in argv) or "(none)"
                                                                 for argv, _ in BAD_COMMAND_LINES])
def test_every_bad_command_line_is_one_line_naming_the_option_before_any_output(tmp_path, monkeypatch, capsys,
                                                                                argv, start):
    """Exit status 2, exactly one line on stderr in the one format (argparse's errors too), starting
    with the option as the user typed it, no internal name; nothing on stdout and no file written:
    every check runs before any work (--workers before the job header, --start-solution before the
    full solve)."""
    ranged = tmp_path / "mech" / RANGED
    ranged.parent.mkdir()
    ranged.write_text(Path(GENERAL).read_text().replace("# [joint_ranges]\n# beta1 =", "[joint_ranges]\nbeta1 ="))
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    assert main([str(ranged) if a == RANGED else a for a in argv]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.count("\n") == 1 and err.endswith("\n"), err
    assert err.startswith(f"spherekin: error: {start}"), err
    assert not INTERNAL.search(err), err
    assert not list(work.iterdir())


def test_the_internal_names_pattern_catches_what_the_issue_saw():
    """The pattern of the test above recognizes each message issue 27 quoted."""
    for seen in ["spherekin: error: workers: expected a whole number >= 0", "spherekin: error: path: the directory x",
                 "spherekin: error: convention: expected", "spherekin: error: inputs (beta1): 3.0 is outside",
                 "spherekin: error: --tol: expected at most MAX_TOL = 0.1 rad", "more than MAX_INPUTS = 10000000",
                 "usage: spherekin solve [-h]"]:
        assert INTERNAL.search(seen), seen


def test_each_command_translates_its_own_python_names():
    """One translation, per command: track's ``path`` is --path; batch has no --path (its output is
    --out), so there a ``path:`` stays as it is rather than be named as another option."""
    from spherekin.cli import as_options, build_parser

    parser = build_parser()
    track, batch = parser.command("track").options(), parser.command("batch").options()
    assert track["path"] == "--path" and "path" not in batch
    assert (batch["workers"], batch["chunk_size"], parser.command("ik").options()["convention"]) == \
        ("--workers", "--chunk-size", "--convention")
    assert as_options("path: expected finite inputs (radians)", track) == "--path: expected finite inputs (radians)"
    assert as_options("path: expected finite inputs (radians)", batch) == "path: expected finite inputs (radians)"
    assert as_options("workers: expected a whole number, got -1", batch) == "--workers: expected a whole number, got -1"
    assert as_options("the path: and workers: inside a sentence", batch) == "the path: and workers: inside a sentence"


def test_tracks_start_is_named_as_the_option_given(capsys):
    """Python's ``start`` is the pose option the user gave (a pose that is no assembly is found by
    the track itself, after its header line)."""
    assert main(["track", GENERAL, "--path", PATH, "--start-quaternion", "1,0,0,0"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.startswith("spherekin: error: --start-quaternion: the start pose does not close the legs"), err


def test_a_start_solution_that_is_not_certified_is_named_as_the_option(tmp_path, capsys):
    import spherekin

    path = tmp_path / "p.csv"
    path.write_text("beta1,beta2,beta3\n0.3,-0.2,0.5\n0.31,-0.2,0.5\n")
    report = spherekin.solve(spherekin.load_mechanism(GOSSELIN), [0.3, -0.2, 0.5])
    k = next(i for i, s in enumerate(report.solutions, start=1) if s.status != "certified")   # a serial singularity
    assert main(["track", GOSSELIN, "--path", str(path), "--start-solution", str(k)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("spherekin: error: --start-solution: the solution"), err


def test_the_top_level_help_is_a_description_and_the_commands(capsys):
    from spherekin.cli import build_parser

    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    assert "``" not in out and "Command-line interface" not in out
    assert "Direct kinematics of parallel spherical mechanisms" in out and "commands:" in out
    commands = build_parser().command(None)._commands.choices
    for name in ("solve", "ik", "batch", "map", "track", "gosselin", "verify"):
        assert name in commands and re.search(rf"^\s+{name}\s+\S", out, re.M), name


def test_inputs_euler_and_beta_read_pi_as_the_files_do(tmp_path, capsys):
    """--inputs, --euler and gosselin's --beta take "pi/2" as --grid, --fix and the TOML files do
    (one parser): the inputs are math.pi / 2 etc. exactly, and ik's rotation is the closed form."""
    out = tmp_path / "r.json"
    assert main(["solve", GOSSELIN, "--inputs", "pi/2,-pi/4,3*pi/4", "--json", str(out), "--quiet"]) == 0
    assert json.loads(out.read_text())["settings"]["inputs"] == [math.pi / 2, -math.pi / 4, 3 * math.pi / 4]
    rz = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])      # Rz(pi/2), by hand
    for euler in (["--euler", "pi/2,0,0"], ["--euler", "90,0,0", "--degrees"]):
        ik = tmp_path / "ik.json"
        assert main(["ik", GENERAL, *euler, "--json", str(ik)]) == 0
        np.testing.assert_allclose(json.loads(ik.read_text())["platform_rotation"], rz, atol=1e-15)
    assert main(["gosselin", "--beta", "pi/2", "3*pi/4", "-0.5", "--samples", "10"]) == 0
    assert f"actuators beta = ({math.pi / 2:+.4f}, {3 * math.pi / 4:+.4f}, -0.5000) rad" in capsys.readouterr().out


def test_the_track_stop_reason_gives_the_step_in_radians_not_a_constant(tmp_path, capsys):
    """Solution 5 of the general 3-RRR at beta1 = -3 ends at the parallel singularity near -2.7141
    (tests/test_cli_families.py): the printed reason gives the smallest step as a number of radians."""
    from spherekin.trust.stepping import MIN_STEP

    path = tmp_path / "p.csv"
    path.write_text("beta1,beta2,beta3\n-3.0,0,0.5\n-2.6,0,0.5\n")
    assert main(["track", GENERAL, "--path", str(path), "--start-solution", "5"]) == 0
    out = capsys.readouterr().out
    assert f"no step longer than {MIN_STEP:g} rad of input could be proven" in out and "MIN_STEP" not in out
