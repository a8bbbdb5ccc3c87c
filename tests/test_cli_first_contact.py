"""What a new user meets first (issue 17): the real `spherekin` command in a subprocess for what only a
process shows (negative inputs, paths checked before any work, Ctrl-C, --version), and the rest in process."""

from __future__ import annotations

import json
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
from spherekin.cli import _Progress, main
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
    (["--plot", "out.jpg"], "--plot out.jpg: expected a file name ending in one of .png, .pdf, .svg"),
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
    log = _Progress(terminal=False)
    log.t0 -= 30.0                                  # as if the solve had run for 30 s
    log(counts)
    log(counts)                                      # the next line only PROGRESS_INTERVAL later
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "boxes      500" in err and "/s)" in err and "\r" not in err
    quiet = _Progress(terminal=True, quiet=True)
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
