"""The how-to guides (docs/howto/*.md) run as written: every ```python block as a script
(tests/doc_blocks.py), with a check of what it prints (and writes) against an independent derivation:
the degree-8 eigenvalue solver of references/peers_closed_form.py (numpy only), a four-bar's closed
form (tests/test_branches.py), matrix products of scipy rotations, tests/singular_refs.py, the command
line's parser. Their command lines: tests/test_docs_pages.py.

A new python block needs a check here (a marker of its code in CHECKS): the test says so.
"""

from __future__ import annotations

import argparse
import ast
import json
import math
import re

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from doc_blocks import ROOT, blocks, doc_pages, page_text, run_script
from spherekin.cli import build_parser
from test_readme import reference_counts, random_inputs

#: Largest difference (radians) between a printed rocker angle (rounded to 9 decimals: 5e-10) and the
#: four-bar's closed form (exact to ~1e-15): far below the two assemblies' separation (~2 rad).
ANGLE_MATCH = 1e-8


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
    of the grid per input against the reference; the map against that file; the plot; no warning
    (the block is not under a main guard, but its jobs are small enough to run in this process)."""
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
    t = tan((b - 3.25)/2), docs/howto/paper-configuration.md, "Conventions"); t maps affinely to x in [0, 1];
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



def check_strategies(proc, code, tmp_path):
    """Each strategy of the block finds the reference's number of assemblies at (0.3, -0.2, 0.5), by
    the system, parameterization and pruner it asked for; `auto` is the complete count (no box searched)
    for this 3-RRR, and its formulation `halves` on the loop equations (the documented rule)."""
    strategies = ast.literal_eval(re.search(r"for strategy in (\(.*?\)):", code, re.S)[1])
    lines = proc.stdout.strip().splitlines()
    assert len(lines) == len(strategies) == 4, proc.stdout
    counts, clear = reference_counts([[0.3, -0.2, 0.5]])
    assert clear.all()
    for strategy, line in zip(strategies, lines):
        count, system, formulation, parameterization, pruner, boxes = line.split()
        assert system == strategy.get("system", "complete")
        assert int(count) == counts[0] and (int(boxes) == 0 if system == "complete" else int(boxes) > 0)
        assert formulation == {"complete": "complete", "platform": "platform", "loops": "halves"}[system]
        if system == "loops":
            assert parameterization == strategy.get("parameterization", "tan-half")
        assert pruner == strategy.get("pruner", "pp")


def solve_choices() -> dict[str, set]:
    """The choices of ``spherekin solve``'s strategy options (the real parser), by option string."""
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return {a.option_strings[0]: set(a.choices) for a in sub.choices["solve"]._actions if a.choices}


#: The strategy options of the page's table, by the registry family the block prints.
FAMILY_OPTION = {"parameterization": "--parameterization", "system": "--system", "formulation": "--formulation",
                 "pruner": "--pruner", "lp_backend": "--lp-backend"}


def check_registries(proc, code, tmp_path):
    """The registries' names are the command line's choices (less `auto` and the formulations the
    complete and platform systems name) and each is named in the page's table row of its option."""
    printed = {family: ast.literal_eval(names) for family, names in
               (line.split(" ", 1) for line in proc.stdout.strip().splitlines())}
    assert set(printed) == set(FAMILY_OPTION)
    choices = solve_choices()
    rows = {m[1]: m[2] for m in re.finditer(r"^\| `(--[\w-]+)[^`]*` \|(.*)$", page_text("docs/howto/strategy.md"), re.M)}
    for family, names in printed.items():
        option = FAMILY_OPTION[family]
        own = {"platform", "complete", "complete-loop"} if family == "formulation" else set()   # the systems' own
        assert set(names) == choices[option] - {"auto"} - own
        assert all(f"`{name}`" in rows[option] for name in names), (option, names)


def check_paper_four_bar(proc, code, tmp_path):
    """The four-bar at A = 0.7 both ways: the two assemblies of the closed form (tests/test_branches.py:
    the rocker angle D from a x cos + b x sin + c = 0), each way; the paper's way processes more boxes and
    solves LPs, the default none."""
    from test_branches import outputs, read_axes, wrapped

    assert 'solve("examples/four_bar.toml", [0.7]' in code
    want = sorted(wrapped(d) for d in outputs(read_axes(ROOT / "examples" / "four_bar.toml"), 0.7))
    rows = {}
    for line in proc.stdout.strip().splitlines():
        name, count, boxes, lps, angles = line.split(" ", 4)
        rows[name] = (int(count), int(boxes), int(lps))
        np.testing.assert_allclose(sorted(ast.literal_eval(angles)), want, atol=ANGLE_MATCH)
        assert int(count) == 2
    assert set(rows) == {"default", "paper"}
    assert rows["paper"][1] > rows["default"][1] and rows["paper"][2] > 0 == rows["default"][2]


def check_track_plot(proc, code, tmp_path):
    """The tracking page's Python: the track stops at the singular input the page states (checked against
    the degree-8 reference by test_docs_pages.check_track_stop) and plot_track(track, path) writes the figure."""
    stated = float(re.search(r"meets the singularity at beta1 =\s*(-?\d+\.\d+)", page_text("docs/howto/tracking.md"))[1])
    found = float(re.search(r"beta1['\"]?:\s*(-?\d+\.\d+)", proc.stdout)[1])
    assert "SingularStop" in proc.stdout and abs(found - stated) < 1e-9, proc.stdout
    png = tmp_path / "track.png"                 # run_script ran it in tmp_path (doc_blocks.workdir)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def check_tolerances(proc, code, tmp_path):
    """The tolerances page's Python: the count line and one line per solution; each printed pose is one of
    the degree-8 reference's at the input, its bound above its lower bound, and 12 geometries sampled in
    the cones (tests/test_tolerances.py's own tilts and Newton solve) stay within the bound."""
    from test_tolerances import built_legs, nominal_axes, rotation_angle, solve_built, tilt
    from spherekin.mechanism import general_3rrr

    lines = proc.stdout.strip().splitlines()
    assert lines[0] == "True 8", proc.stdout
    mech = general_3rrr()
    x = np.array([0.3, -0.2, 0.5])
    ref_poses = reference_poses_of(mech, x)
    rng = np.random.default_rng(2)
    for line in lines[1:]:
        number, bound, low, rest = line.split(" ", 3)
        rot = np.array(ast.literal_eval(rest.split("] {")[0] + "]"))
        assert min(np.abs(rot - r).max() for r in ref_poses) < 1e-8
        assert 0 < float(low) <= float(bound)
        d0 = rot @ np.asarray(mech.platform_reference_matrix).T
        for _ in range(12):
            axes = [[tilt(a, math.radians(0.1), rng) for a in leg] for leg in nominal_axes(mech)]
            d = solve_built(built_legs(mech, axes, x + rng.uniform(-1, 1, 3) * math.radians(0.01)), d0)
            assert rotation_angle(d @ d0.T) <= float(bound)


def reference_poses_of(mech, x):
    from references.peers_closed_form import direct_kinematics, geometry_of

    return direct_kinematics(geometry_of(mech), x)


#: Per how-to page: a marker of each python block's code -> its check.
CHECKS = {
    "docs/howto/own-mechanism.md": {"problem.solve_many": check_compiled_solve_many},
    "docs/howto/families.md": {"batch.assembly_map": check_batch},
    "docs/howto/tracking.md": {"free_box": check_free_box, "plot_track": check_track_plot},
    "docs/howto/maps-singularities.md": {"spherekin.singular(": check_singular},
    "docs/howto/strategy.md": {"for strategy in": check_strategies, "registry.family": check_registries},
    "docs/howto/paper-configuration.md": {"ClosureLoop": check_closure_loop, "four_bar.toml": check_paper_four_bar},
    "docs/howto/tolerances.md": {"Tolerances(": check_tolerances},
}


def check_of(page: str, code: str):
    found = [check for marker, check in CHECKS[page].items() if marker in code]
    assert len(found) == 1, f"{page}: a python block without exactly one check in tests/test_howto.py:\n{code}"
    return found[0]


CASES = [(page, code) for page in CHECKS for code in blocks(page, "python")]


@pytest.mark.parametrize("page, code", CASES, ids=[f"{page.split('/')[-1]}-{check_of(page, code).__name__}"
                                                   for page, code in CASES])
def test_howto_python_block_runs_as_a_script(tmp_path, page, code):
    check = check_of(page, code)
    proc = run_script(tmp_path, code)
    assert proc.returncode == 0, proc.stderr[-3000:]
    check(proc, code, tmp_path)


def test_every_howto_page_has_the_python_blocks_its_checks_are_for():
    assert sorted(p for p in doc_pages() if p.startswith("docs/howto/") and blocks(p, "python")) == sorted(CHECKS)
    for page, checks in CHECKS.items():
        assert sorted(check_of(page, code).__name__ for code in blocks(page, "python")) == \
            sorted(f.__name__ for f in checks.values())
