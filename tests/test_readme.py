"""The README's code: every ```python block runs as a script file in a fresh interpreter (not under
a main guard, as a reader saves it), with a check of what it prints against an independent
derivation; every ``spherekin`` command line of its ```sh blocks parses.

A new python block needs a check here (a marker of its code in CHECKS): the test says so.
"""

from __future__ import annotations

import json
import math
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from benchmarks.peers_closed_form import direct_kinematics, geometry_of
from spherekin.cli import build_parser, protect_negative_values
from spherekin.mechanism import general_3rrr

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
#: Seconds a README block may run before its test fails (a hung script; the blocks take ~1-25 s).
BLOCK_TIMEOUT = 300
#: Two poses of the degree-8 reference closer than this (largest entry) make its count ambiguous
#: (an input next to a parallel singularity); as in tests/test_batch_reference.py.
REFERENCE_SEPARATION = 1e-3


def blocks(lang: str) -> list[str]:
    """The code of every ```lang block of the README, in order."""
    return re.findall(rf"^```{lang}\n(.*?)^```", README, re.S | re.M)


def run_script(tmp_path: Path, code: str) -> subprocess.CompletedProcess:
    """``code`` saved as tmp_path/readme_block.py and run by a fresh interpreter in tmp_path, this
    checkout on the path."""
    (tmp_path / "readme_block.py").write_text(code)
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    return subprocess.run([sys.executable, "readme_block.py"], cwd=tmp_path, env=env, capture_output=True,
                          text=True, timeout=BLOCK_TIMEOUT)


def random_inputs(code: str) -> np.ndarray:
    """The inputs a block draws: ``np.random.default_rng(SEED).uniform(-np.pi, np.pi, (K, 3))``."""
    m = re.search(r"default_rng\((\d+)\)\.uniform\(-np\.pi, np\.pi, \((\d+), 3\)\)", code)
    assert m, "the block's random inputs are not drawn as the test expects: update random_inputs"
    return np.random.default_rng(int(m[1])).uniform(-np.pi, np.pi, (int(m[2]), 3))


def reference_counts(inputs) -> tuple[np.ndarray, np.ndarray]:
    """(real assemblies of the general 3-RRR at each input by the degree-8 eigenvalue solver of
    benchmarks/peers_closed_form.py (numpy only, not spherekin's solver), whether that count is
    unambiguous there)."""
    geometry = geometry_of(general_3rrr())
    counts, clear = [], []
    for x in inputs:
        poses = direct_kinematics(geometry, x)
        gaps = [np.abs(p - q).max() for a, p in enumerate(poses) for q in poses[a + 1:]]
        counts.append(len(poses))
        clear.append(not gaps or min(gaps) >= REFERENCE_SEPARATION)
    return np.array(counts), np.array(clear)


def check_compiled_solve_many(proc, code, tmp_path):
    """'N assemblies; K solutions (count proven ...)': N over all inputs and K at the first, as the reference."""
    m = re.fullmatch(r"(\d+) assemblies; (\d+) solutions? \(count proven.*\)", proc.stdout.strip())
    assert m, proc.stdout
    counts, clear = reference_counts(random_inputs(code))
    assert clear.all()
    assert (int(m[1]), int(m[2])) == (counts.sum(), counts[0])
    assert "Warning" not in proc.stderr                  # Problem.solve_many runs here: no cluster, no warning


def check_batch(proc, code, tmp_path):
    """The histogram of assemblies per input and the map's table against the reference; the file
    of the grid per input against the reference; the map against that file; the plot; one warning
    (the block is not under a main guard: it runs here and says why, once)."""
    out = proc.stdout
    printed = dict((int(n), int(k)) for n, k in re.findall(r"^(\d+)\s+(\d+)$", out.split("Name: count")[0], re.M))
    counts, clear = reference_counts(random_inputs(code))
    assert clear.all()
    assert printed == dict(zip(*np.unique(counts, return_counts=True)))
    map_rows = re.findall(r"^\s+(\d+)\s+(\d+)\s+(\d+)$", out.split("solutions  grid points")[1], re.M)
    map_hist = {int(n): int(k) for n, k, _ in map_rows}

    table = pd.read_parquet(tmp_path / "results.parquet")
    per_input = table.groupby("input").agg(beta1=("beta1", "first"), beta2=("beta2", "first"),
                                           beta3=("beta3", "first"), n=("status", "count"))
    grid = re.findall(r'"beta1=-pi:pi:(\d+)", "beta2=-pi:pi:(\d+)"', code)
    assert len(set(grid)) == 1                           # the map and the file: the same grid
    nx, ny = map(int, grid[0])
    assert len(per_input) == nx * ny and sum(map_hist.values()) == nx * ny
    np.testing.assert_allclose(np.sort(per_input["beta1"].unique()), np.linspace(-np.pi, np.pi, nx))
    assert (per_input["beta3"] == 0.5).all()
    ref, ref_clear = reference_counts(per_input[["beta1", "beta2", "beta3"]].to_numpy(float))
    assert ref_clear.mean() > 0.9
    np.testing.assert_array_equal(per_input["n"].to_numpy()[ref_clear], ref[ref_clear])
    assert map_hist == dict(zip(*np.unique(per_input["n"], return_counts=True)))

    assert (tmp_path / "map.png").stat().st_size > 10_000
    # 144 + 100 inputs: each job runs in this process (batch.engine.IN_PROCESS_MAX_INPUTS), so the
    # unguarded script starts no cluster and gets no warning about its missing __main__ guard
    warned = [line for line in proc.stderr.splitlines() if "Warning" in line]
    assert not warned, proc.stderr


def check_closure_loop(proc, code, tmp_path):
    """Eq. (10)'s control points of the block's loop against f = q (F11 + F22 - 2) computed by
    matrix products (scipy rotations) at points of the box, and [lo, hi] their extremes.

    The block's unknowns: a in [-1, 1] (inside (-pi, pi): t = tan(a/2)), b in [2.5, 4] (not inside:
    t = tan((b - 3.25)/2), README "Conventions"); t maps affinely to x in [0, 1];
    q = (1 + t_a^2)(1 + t_b^2); F = Rx(pi) Z Rx(a) Z Rx(b + pi/2) Z Rx(0.3) Z, Z = Rz(pi/2)."""
    assert "Unknown(\"a\", -1.0, 1.0), Unknown(\"b\", 2.5, 4.0)" in code
    assert "ClosureLoop([np.pi, a, b + np.pi / 2, 0.3])" in code
    numbers = [float(v) for v in re.findall(r"-?\d+\.\d*(?:e-?\d+)?", proc.stdout)]
    assert len(numbers) == 11, proc.stdout
    c, lo, hi = np.array(numbers[:9]).reshape(3, 3), numbers[9], numbers[10]
    np.testing.assert_allclose((lo, hi), (c.min(), c.max()), atol=1e-8)   # c printed to 8 decimals
    z = Rotation.from_euler("z", np.pi / 2).as_matrix()

    def f(xa, xb):
        ta = math.tan(-0.5) + xa * 2 * math.tan(0.5)
        tb = math.tan(-0.375) + xb * 2 * math.tan(0.375)
        m = np.eye(3)
        for phi in (np.pi, 2 * math.atan(ta), 3.25 + 2 * math.atan(tb) + np.pi / 2, 0.3):
            m = m @ Rotation.from_euler("x", phi).as_matrix() @ z
        return (1 + ta ** 2) * (1 + tb ** 2) * (m[0, 0] + m[1, 1] - 2)

    def basis(x):
        return np.array([math.comb(2, i) * x ** i * (1 - x) ** (2 - i) for i in range(3)])

    for xa in np.linspace(0, 1, 7):
        for xb in np.linspace(0, 1, 7):
            want = f(xa, xb)
            assert basis(xa) @ c @ basis(xb) == pytest.approx(want, abs=1e-7)
            assert lo <= want <= hi


def check_free_box(proc, code, tmp_path):
    """The printed box and start pose against the references of tests/singular_refs.py: the pose closes
    the legs at home, the reference tracks the assembly over the box without loss, sign change or
    |det| = 0 (41 x 41 grid), and loses it (or |det| < 1e-3) on the box 5 % larger."""
    from singular_refs import rrr_closure, rrr_geometry, rrr_tracked, track_box_min_det

    first, second = proc.stdout.strip().splitlines()
    numbers = [float(v) for v in re.findall(r"-?\d+\.\d*(?:e-?\d+)?", first)]
    assert len(numbers) == 4 and first.split()[-2] in ("unproven", "link", "cells"), proc.stdout
    rot = np.array(eval(second, {"__builtins__": {}}), dtype=float)          # noqa: S307 (a list of lists)
    home = np.array([0.0, 0.0, 0.5])
    assert np.abs(rrr_closure(rrr_geometry(), home, rot)).max() < 1e-9
    lo, hi = np.array([numbers[0], numbers[2], 0.5]), np.array([numbers[1], numbers[3], 0.5])
    assert np.all(lo[:2] < 0) and np.all(hi[:2] > 0)
    box = track_box_min_det(rrr_tracked(), home, rot, lo, hi, 41)
    assert box.lost == 0 and box.sign_changes == 0 and box.min_abs_det > 0
    grown = track_box_min_det(rrr_tracked(), home, rot, home - 1.05 * (home - lo), home + 1.05 * (hi - home), 81)
    assert grown.lost > 0 or grown.sign_changes > 0 or grown.min_abs_det < 1e-3

def check_singular(proc, code, tmp_path):
    """The block's sub-square of the plane beta3 = 0.5: every singular input the reference finds on lines across
    it (tests/singular_refs.py: count changes of the degree-8 oracle) lies in a cell of the JSON; the printed
    counts are the JSON's."""
    from singular_refs import singular_points_on_line

    doc = json.loads((tmp_path / "singular.json").read_text())
    assert doc["schema"] == "spherekin.singular/1" and doc["complete"]
    statuses = [b["status"] for b in doc["boxes"]]
    assert proc.stdout.strip().startswith(str({"singular": statuses.count("singular"),
                                               "unresolved": statuses.count("unresolved")}))
    lo = np.array([[b["x"][0], b["y"][0]] for b in doc["boxes"]])
    hi = np.array([[b["x"][1], b["y"][1]] for b in doc["boxes"]])
    points = [s.inputs[:2] for p0, p1 in (((0.9, 1.1), (1.4, 1.6)), ((0.9, 1.35), (1.4, 1.35)))
              for s in singular_points_on_line(p0, p1, n_samples=50)]
    assert points
    for p in points:
        assert np.any(np.all((lo - 1e-9 <= p) & (p <= hi + 1e-9), axis=1)), p


#: A marker of each python block's code -> its check.
CHECKS = {"spherekin.singular(": check_singular,
          "problem.solve_many": check_compiled_solve_many,
          "batch.assembly_map": check_batch,
          "ClosureLoop": check_closure_loop,
          "free_box": check_free_box}


def check_of(code: str):
    found = [check for marker, check in CHECKS.items() if marker in code]
    assert len(found) == 1, f"README python block without exactly one check in tests/test_readme.py:\n{code}"
    return found[0]


@pytest.mark.parametrize("code", blocks("python"), ids=lambda code: next(
    (m for m in CHECKS if m in code), code.splitlines()[-1][:30]))
def test_readme_python_block_runs_as_a_script(tmp_path, code):
    check = check_of(code)
    proc = run_script(tmp_path, code)
    assert proc.returncode == 0, proc.stderr[-3000:]
    check(proc, code, tmp_path)


def test_readme_has_the_python_blocks_the_checks_are_for():
    assert sorted(check_of(code).__name__ for code in blocks("python")) == sorted(f.__name__ for f in CHECKS.values())


def command_lines() -> list[str]:
    """The ``spherekin`` command lines of the README's ```sh blocks: continuations joined, comments
    dropped, ``.venv/bin/`` stripped."""
    out = []
    for block in blocks("sh"):
        for line in block.replace("\\\n", " ").splitlines():
            words = shlex.split(line, comments=True)
            if words and Path(words[0]).name == "spherekin":
                out.append(words[1:])
    return out


def test_readme_command_lines_parse():
    lines = command_lines()
    assert {words[0] for words in lines} >= {"solve", "ik", "batch", "map", "track"}
    parser = build_parser()
    for words in lines:
        try:
            parser.parse_args(protect_negative_values(words))
        except SystemExit:
            pytest.fail(f"the README's `spherekin {shlex.join(words)}` does not parse")


# ------------------------------------------------------------------ the guides' python blocks

MECHANISM_FORMAT = ROOT / "docs" / "mechanism-format.md"


def test_mechanism_format_python_blocks_run_as_scripts_from_the_repository_root(tmp_path):
    """docs/mechanism-format.md's blocks, each a script in a fresh interpreter (run from the checkout's
    root, where its example files are): the names it prints are those its comment shows, and every
    inverse-kinematics solution of the identity pose closes: the degree-8 eigenvalue reference
    (benchmarks/peers_closed_form.py) has the identity among its poses at those inputs."""
    code = re.findall(r"^```python\n(.*?)^```", MECHANISM_FORMAT.read_text(), re.S | re.M)
    assert len(code) == 3, "a new python block in docs/mechanism-format.md needs a check here"
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    outs = []
    for k, block in enumerate(code):
        (tmp_path / f"block{k}.py").write_text(block)
        run = subprocess.run([sys.executable, str(tmp_path / f"block{k}.py")], cwd=ROOT, env=env, capture_output=True,
                             text=True, timeout=BLOCK_TIMEOUT)
        assert run.returncode == 0, run.stderr[-2000:]
        outs.append(run.stdout)
    assert outs[0].startswith("('beta1', 'beta2', 'beta3') ('gamma1', 'delta1'")
    # the Watt six-bar: loops closed by C and F (counted by hand in tests/test_mechanism_graph.py), its 4
    # assemblies at 0.7 (two four-bars in series, checked there in closed form), the input given back twice
    watt = outs[1].strip().splitlines()
    assert watt[0] == "['C', 'F'] 1" and watt[1].startswith("4 solutions (count proven")
    assert watt[2:] == ["0.7 certified", "0.7 certified"]
    lines = outs[2].strip().splitlines()
    assert 1 <= len(lines) <= 8
    geometry = geometry_of(general_3rrr())
    for line in lines:
        inputs = [float(v) for v in re.match(r"^\(([^)]*)\)", line)[1].split(",")]
        poses = direct_kinematics(geometry, inputs)
        assert min(np.abs(p - np.eye(3)).max() for p in poses) < 1e-8, line
