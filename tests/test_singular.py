"""Certified parallel-singular sets in a plane of inputs (issue 31 items 1, 6): spherekin.singular, the CLI.

Checked against the independent references of tests/singular_refs.py: general_3rrr's singular inputs along
lines of the plane beta3 = 0.5 (where the degree-8 oracle's real-root count changes, located by bisection).
Invariants: every reference point lies in a box of the cover (everything outside is claimed free), and every
box claimed ``singular`` has a reference point within its width (a curve through the box crosses the boundary
of the box widened by half its width, where the reference finds it).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import spherekin
from spherekin.cli import main
from spherekin.results import SINGULAR_SCHEMA
from singular_refs import (EXAMPLES, count_changes, five_bar_count, five_bar_curve_points, five_bar_from_file, five_bar_moving, five_bar_tangency,
                           four_bar_branch_inputs, four_bar_from_arcs, four_bar_from_file, four_bar_toml,
                           lines_across, singular_points_on_line)

RRR = EXAMPLES / "general_3rrr.toml"
#: A sub-square of the plane beta3 = 0.5 that the singular curves cross several times (fast: ~2 s at T = 0.1).
SQUARE = ((0.9, 1.9), (1.1, 2.1))
T = 0.1
#: Closed boxes: a reference point (bisected to 1e-10) on a box edge counts as inside within this.
EDGE = 1e-9


@pytest.fixture(scope="module")
def reference_points():
    pts = [s.inputs[:2] for p0, p1 in lines_across(SQUARE, 4, 31)
           for s in singular_points_on_line(p0, p1, n_samples=60, seed=0)]
    assert len(pts) >= 6                 # the square is crossed by the curves
    return np.array(pts)


@pytest.fixture(scope="module")
def square_set():
    (x0, x1), (y0, y1) = SQUARE
    return spherekin.singular(RRR, x=("beta1", x0, x1), y=("beta2", y0, y1), fixed={"beta3": 0.5}, tol=T)


def _covered(sset, points) -> np.ndarray:
    lo = np.array([[b.x[0], b.y[0]] for b in sset.boxes])
    hi = np.array([[b.x[1], b.y[1]] for b in sset.boxes])
    return np.array([np.any(np.all((lo - EDGE <= p) & (p <= hi + EDGE), axis=1)) for p in points])


def test_every_reference_point_is_covered(square_set, reference_points):
    assert square_set.complete
    assert _covered(square_set, reference_points).all()
    assert all(b.x[1] - b.x[0] <= T + 1e-12 and b.y[1] - b.y[0] <= T + 1e-12 for b in square_set.boxes)


@pytest.fixture(scope="module")
def quarter_set():
    """A quarter of SQUARE (the check below runs the reference on every singular box's boundary)."""
    return spherekin.singular(RRR, x=("beta1", 0.9, 1.4), y=("beta2", 1.1, 1.6), fixed={"beta3": 0.5}, tol=T)


def test_singular_boxes_hold_a_reference_point(quarter_set):
    """Each ``singular`` box: the reference finds a singular input on the boundary of the box widened by half
    its width (a curve through the box leaves that square), so within its width of the box."""
    sing = [b for b in quarter_set.boxes if b.status == "singular"]
    assert len(sing) >= 0.4 * len(quarter_set.boxes)       # most cells of the cover are proven
    for b in sing:
        w = b.x[1] - b.x[0]
        x0, x1, y0, y1 = b.x[0] - w / 2, b.x[1] + w / 2, b.y[0] - w / 2, b.y[1] + w / 2
        edges = [((x0, y0), (x1, y0)), ((x1, y0), (x1, y1)), ((x1, y1), (x0, y1)), ((x0, y1), (x0, y0))]
        found = [s for p0, p1 in edges for s in singular_points_on_line(p0, p1, n_samples=12, seed=1)]
        assert found, f"no reference singular input near the singular box {b}"


def test_cover_outside_is_free_on_a_line_far_from_the_curve():
    """A line (y None) along which the reference finds no singular input: no box at all (and complete)."""
    p0, p1 = (-0.5, 0.0), (0.5, 0.0)
    assert singular_points_on_line(p0, p1, n_samples=60) == []
    sset = spherekin.singular(RRR, x=("beta1", -0.5, 0.5), fixed={"beta2": 0.0, "beta3": 0.5}, tol=T)
    assert sset.complete and sset.boxes == ()


def test_line_singular_points():
    """One plane input (the other two fixed): the cover holds each reference point of the line, each
    ``singular`` box is within its width of one."""
    y = 1.6
    ref = [s.inputs[0] for s in singular_points_on_line((0.9, y), (1.9, y), n_samples=100, seed=0)]
    assert len(ref) >= 2
    sset = spherekin.singular(RRR, x=("beta1", 0.9, 1.9), fixed={"beta2": y, "beta3": 0.5}, tol=0.05)
    assert all(b.y is None for b in sset.boxes)
    for r in ref:
        assert any(b.x[0] - EDGE <= r <= b.x[1] + EDGE for b in sset.boxes)
    sing = [b for b in sset.boxes if b.status == "singular"]
    assert sing
    for b in sing:
        w = b.x[1] - b.x[0]
        assert min(abs(r - 0.5 * (b.x[0] + b.x[1])) for r in ref) <= w


def test_box_cap_leaves_the_rest_unresolved(reference_points):
    """A tiny box cap: not complete, the unprocessed part reported ``unresolved`` (never dropped): every
    reference point is still covered, and no box is claimed singular without its proof."""
    (x0, x1), (y0, y1) = SQUARE
    sset = spherekin.singular(RRR, x=("beta1", x0, x1), y=("beta2", y0, y1), fixed={"beta3": 0.5}, tol=T,
                              max_boxes=300)
    assert not sset.complete
    assert sset.stats.pending > 0
    assert sset.counts()["unresolved"] > 0
    assert _covered(sset, reference_points).all()


def test_a_capped_run_at_a_fine_tolerance_reports_its_unprocessed_part_as_regions(reference_points):
    """At T = 1e-3 the square is 1e6 cells: a run capped at 300 boxes leaves most of it pending. The pending
    boxes come back as unresolved regions (their plane projections on the grid, wider than T: before, every
    cell they met was listed, and over the whole plane that ran out of memory), every reference singular
    input is still in a box, no region is claimed singular, and every region is a cusp candidate (never
    searched for cusps)."""
    (x0, x1), (y0, y1) = SQUARE
    fine = 1e-3
    sset = spherekin.singular(RRR, x=("beta1", x0, x1), y=("beta2", y0, y1), fixed={"beta3": 0.5}, tol=fine,
                              max_boxes=300)
    assert not sset.complete and sset.stats.pending > 0
    assert _covered(sset, reference_points).all()
    wide = [b for b in sset.boxes if max(b.x[1] - b.x[0], b.y[1] - b.y[0]) > fine + 1e-12]
    assert wide and all(b.status == "unresolved" for b in wide)
    assert len(sset.boxes) <= sset.stats.pending + sum(b.status == "singular" for b in sset.boxes)
    for b in wide:
        assert any(c.status == "unresolved" and (c.box_x, c.box_y) == (b.x, b.y) for c in sset.cusps)


class StopAfter:
    """A budget (duck-typed as :class:`spherekin.budget.Budget`) that names a reason to stop at its k-th check:
    a stop at a chosen stage of the run, as a Ctrl-C at that moment does."""

    def __init__(self, k: int):
        self.k, self.calls, self.reason = k, 0, None

    def stop(self, reason):
        self.reason = self.reason or reason

    def exhausted(self):
        self.calls += 1
        if self.calls >= self.k:
            self.stop("SIGINT")
        return self.reason


@pytest.mark.parametrize("k", [1, 20, 48, 100, 120, 130, 135])
def test_a_run_stopped_at_any_stage_still_holds_every_singular_input(square_set, reference_points, k):
    """Stopped at its k-th check (the square's run checks 136 times: 46-52 between trace batches, the others in
    the box loops, between proof batches, before the refinement and the cusps): not complete, ``stopped`` names the reason, every reference
    singular input is still in a box (the unprocessed part unresolved regions, the untested cells unresolved),
    and every cell claimed singular is one the finished run proves too."""
    (x0, x1), (y0, y1) = SQUARE
    budget = StopAfter(k)
    sset = spherekin.singular(RRR, x=("beta1", x0, x1), y=("beta2", y0, y1), fixed={"beta3": 0.5}, tol=T,
                              budget=budget)
    assert budget.calls >= k and not sset.complete and sset.stopped == "SIGINT"
    assert sset.as_dict()["stopped"] == "SIGINT" and sset.as_dict()["complete"] is False
    assert _covered(sset, reference_points).all()
    proven = {(b.x, b.y) for b in square_set.boxes if b.status == "singular"}
    assert {(b.x, b.y) for b in sset.boxes if b.status == "singular"} <= proven
    if k == 1:                            # stopped at the first check: nothing processed, the whole square open
        assert sset.counts()["singular"] == 0 and sset.cusp_search == "not_searched"


def test_the_memory_cap_ends_a_run_as_the_box_cap_does(reference_points):
    """A budget whose memory cap is below what the process already holds: the run stops at once, says so
    (``stopped``: "memory cap"), and the whole square is one unresolved region, never dropped."""
    from spherekin.budget import MEMORY, Budget

    (x0, x1), (y0, y1) = SQUARE
    sset = spherekin.singular(RRR, x=("beta1", x0, x1), y=("beta2", y0, y1), fixed={"beta3": 0.5}, tol=T,
                              budget=Budget(max_memory=1))
    assert not sset.complete and sset.stopped == MEMORY == "memory cap"
    assert _covered(sset, reference_points).all()
    assert sset.counts()["singular"] == 0


@pytest.mark.parametrize("sig, code, word", [("SIGINT", 130, "interrupted"), ("SIGTERM", 143, "terminated")])
def test_an_interrupted_singular_writes_what_it_found(tmp_path, sig, code, word):
    """Ctrl-C or SIGTERM during a long cover (the whole plane at T = 1e-3, minutes): the command stops within
    seconds, exits 130 or 143 with one line on stderr, and writes its JSON whole, marked incomplete with the
    signal named (before: exit 1 with "error: interrupted () after N boxes", or 130/143 and no JSON)."""
    import os
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "s.json"
    proc = subprocess.Popen([sys.executable, "-m", "spherekin", "singular", str(RRR), "--x", "beta1=-pi:pi", "--y",
                             "beta2=-pi:pi", "--fix", "beta3=0.5", "--tol", "1e-3", "--json", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONPATH": str(EXAMPLES.parent)})
    time.sleep(6)                        # past the imports and the compile: inside the cover
    t0 = time.monotonic()
    proc.send_signal(getattr(signal, sig))
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == code, stderr
    assert time.monotonic() - t0 < 60
    assert stderr.count("\n") == 1 and stderr.startswith(f"spherekin: {word} ({sig}) after"), stderr
    doc = json.loads(out.read_text())
    assert doc["complete"] is False and doc["stopped"] == sig and doc["boxes"]
    assert "complete: no" in stdout


def _edges(square, eps: float) -> list:
    """The four edges of ``square`` ((x0, x1), (y0, y1)), each moved ``eps`` inward: segments (p0, p1)."""
    (x0, x1), (y0, y1) = square
    return [((x0 + eps, y0), (x0 + eps, y1)), ((x1 - eps, y0), (x1 - eps, y1)),
            ((x0, y0 + eps), (x1, y0 + eps)), ((x0, y1 - eps), (x1, y1 - eps))]


@pytest.mark.parametrize("eps", [0.0, 1e-6])
def test_singular_inputs_on_the_window_edges_are_covered(square_set, eps):
    """Issue 40: a cover that says complete holds the window's closed edges too (a 3-RRR missed 2 of 19,376
    points within 2e-6 of its window's lower edges). The reference's singular inputs on each edge of the square,
    and 1e-6 inside it, all lie in a box."""
    pts = [s.inputs[:2] for p0, p1 in _edges(SQUARE, eps) for s in singular_points_on_line(p0, p1, n_samples=60)]
    assert len(pts) >= 4                 # the curves cross the square's edges
    assert square_set.complete and _covered(square_set, np.array(pts)).all()


def test_json_schema(square_set):
    doc = square_set.as_dict()
    assert doc["schema"] == SINGULAR_SCHEMA == "spherekin.singular/1"
    assert (doc["x"], doc["y"], doc["fixed"], doc["tol"]) == ("beta1", "beta2", {"beta3": 0.5}, T)
    assert doc["complete"] is True and doc["free_box"] is None and doc["cusp_search"] == "searched"
    assert doc["stopped"] is None
    assert all(set(c) == {"x", "y", "box", "status"} and c["status"] in ("cusp", "unresolved") for c in doc["cusps"])
    assert {"boxes_processed", "seconds"} <= set(doc["stats"])
    assert doc["boxes"] and all(set(b) == {"x", "y", "status"} and b["status"] in ("singular", "unresolved")
                                for b in doc["boxes"])
    json.dumps(doc)


def test_cli_json_and_table(tmp_path, capsys):
    out = tmp_path / "s.json"
    code = main(["singular", str(RRR), "--x", "beta1=0.9:1.4", "--y", "beta2=1.1:1.6", "--fix", "beta3=0.5",
                 "--tol", "0.1", "--json", str(out)])
    assert code == 0
    text = capsys.readouterr().out
    assert "singular" in text and "complete: yes" in text
    doc = json.loads(out.read_text())
    assert doc["schema"] == "spherekin.singular/1" and doc["x"] == "beta1" and doc["y"] == "beta2"
    assert doc["fixed"] == {"beta3": 0.5} and doc["boxes"]


@pytest.mark.parametrize("args, words", [
    (["--x", "beta9=0:1", "--y", "beta2=0:1", "--fix", "beta3=0.5"], "--x: expected an actuated joint"),
    (["--x", "beta1=1:0", "--y", "beta2=0:1", "--fix", "beta3=0.5"], "--x beta1: expected lo < hi"),
    (["--x", "beta1=0:1", "--y", "beta2=0:1", "--fix", "beta3=0.5", "--tol", "0"], "--tol: expected 0 < T"),
    (["--x", "beta1=0:1", "--y", "beta2=0:1", "--fix", "beta3=0.5", "--tol", "nan"], "--tol: expected 0 < T"),
    # issue 40: T from ~1e-21 down gave 'complete: yes', no cell, and overflowed cell indices (RuntimeWarnings)
    (["--x", "beta1=0.9:1.4", "--y", "beta2=1.1:1.6", "--fix", "beta3=0.5", "--tol", "1e-30"],
     "--tol: T = 1e-30 rad is below 1.28e-07"),
    (["--x", "beta1=0.9:1.4", "--y", "beta2=1.1:1.6", "--fix", "beta3=0.5", "--tol", "1e-300"], "is below 1.28e-07"),
    (["--x", "beta1=0.9:1.4", "--y", "beta2=1.1:1.6", "--fix", "beta3=0.5", "--tol", "1.2e-7"], "is below 1.28e-07"),
    # a plane far from 0 (its cells' edges would merge in float64) is refused as any input beyond a turn is
    (["--x", "beta1=1000000000000:1000000000001", "--fix", "beta2=1", "--fix", "beta3=0.5", "--tol", "0.001"],
     "--x (beta1) lo: 1e+12 is more than a full turn in radians"),
    (["--x", "beta1=0:1", "--y", "beta2=0:1"], "--fix: expected a reading for every actuated joint"),
    (["--x", "beta1=0:1", "--y", "beta1=0:1", "--fix", "beta3=0.5"], "--y: expected another actuated joint"),
    (["--x", "beta1=0:1", "--y", "beta2=0:1", "--fix", "beta3=0.5", "--fix", "beta3=1"], "--fix beta3: given twice"),
    (["--x", "beta1=0:1", "--y", "beta2=0:1", "--fix", "beta1=0.5", "--fix", "beta3=1"], "--fix: beta1 is an axis"),
    (["--x", "beta1=0:1", "--y", "beta2=0:1", "--fix", "beta3=0.5", "--json", "out.txt"], "--json out.txt: expected"),
    (["--x", "beta1=0:1", "--y", "beta2=0:1", "--fix", "beta3=0.5", "--home", "0,0,0.5"], "--home and --start-solution"),
    (["--x", "beta1=0:1", "--y", "beta2=0:1", "--fix", "beta3=0.5", "--home", "0,0,0.7", "--start-solution", "1"],
     "--home: expected beta3 = 0.5"),
    (["--x", "beta1=0:1", "--y", "beta2=0:1", "--fix", "beta3=0.5", "--home", "0,0", "--start-solution", "1"],
     "--home"),
    (["--x", "beta1=0:1", "--y", "beta2=0:1", "--fix", "beta3=0.5", "--home", "0,0,0.5", "--start-solution", "9"],
     "--start-solution"),
])
def test_cli_errors_are_one_line(args, words, capsys):
    code = main(["singular", str(RRR), *args])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("spherekin: error: ") and words in err


def test_narrowest_tolerance_is_derived_from_the_cell_slack():
    """The floor on T is CELL_SLACK's margin over the finest box fraction, not a number of its own, and it is
    accepted exactly there (refused just below) by the API before any work."""
    from spherekin.singularities.cell_width import (CUSP_REFINE_FRACTIONS, REFINE_FRACTIONS, SLACK_MARGIN, check_singular_tol,
                                              singular_min_tol)
    from spherekin.singularities.cell_width import CELL_SLACK
    from spherekin.singularities.cells import Grid

    floor = singular_min_tol()
    assert floor == SLACK_MARGIN * CELL_SLACK / min(REFINE_FRACTIONS + CUSP_REFINE_FRACTIONS) == pytest.approx(1.28e-7)
    assert check_singular_tol(floor, "tol") == floor
    with pytest.raises(ValueError, match="^tol: T = .* is below"):
        spherekin.singular(RRR, x=("beta1", 0.9, 1.4), y=("beta2", 1.1, 1.6), fixed={"beta3": 0.5},
                           tol=math.nextafter(floor, 0.0))
    # the grid itself refuses what it cannot index (a caller that bypasses the check)
    with pytest.raises(ValueError, match="cannot be indexed"):
        Grid.over((("x", 0.9, 1.4),), 1e-30)


# ---------------------------------------------------------------- the loop equations (item 6)

DEG = math.pi / 180
#: Non-Grashof four-bar variants (ground, crank, coupler, rocker; degrees), as tests/test_singular_refs.py:
#: one reaches arc(B, D) = b + c, one |b - c|; each has two branch points of its crank input.
VARIANTS = [(80, 50, 40, 60), (70, 50, 80, 50)]


@pytest.mark.parametrize("arcs", VARIANTS)
def test_four_bar_branch_points(arcs, tmp_path):
    """A 1-DOF mechanism on the line of its input: the cover holds each closed-form branch input and every
    box is within its width of one (the cover is exactly the branch points' cells)."""
    fb = four_bar_from_arcs(*(a * DEG for a in arcs), theta=math.pi / 2)
    path = tmp_path / "four_bar.toml"
    path.write_text(four_bar_toml(fb))
    ref = four_bar_branch_inputs(fb)
    assert len(ref) == 2
    mech = spherekin.load_mechanism(path)
    sset = spherekin.singular(mech, x=(mech.actuated[0], -math.pi, math.pi), tol=0.05)
    assert sset.complete and sset.system == "loops" and sset.boxes
    for r in ref:
        assert any(b.x[0] - EDGE <= r <= b.x[1] + EDGE for b in sset.boxes), r
    for b in sset.boxes:
        w = b.x[1] - b.x[0]
        assert min(abs(math.remainder(r - 0.5 * (b.x[0] + b.x[1]), 2 * math.pi)) for r in ref) <= w, b
    assert [b.status for b in sset.boxes] == ["singular"] * len(sset.boxes)     # each branch point proven


def test_crank_four_bar_has_no_singular_input():
    """examples/four_bar.toml is a crank (the reference has no branch input): the whole turn is proven free."""
    assert len(four_bar_branch_inputs(four_bar_from_file())) == 0
    sset = spherekin.singular(EXAMPLES / "four_bar.toml", x=("A", -math.pi, math.pi), tol=0.05)
    assert sset.complete and sset.boxes == ()


def test_five_bar_curve():
    """examples/five_bar.toml over [-pi, pi]^2: every point of the reference curve (two circles tangent) is
    covered; every box is within its width of the curve (the tangency function changes sign on the box widened
    by its width) or of a point where the two circles coincide (B = D: a continuum of C, singular too), a
    ``singular`` box within half its width; most boxes are proven."""
    fb = five_bar_from_file()
    sset = spherekin.singular(EXAMPLES / "five_bar.toml", x=("A", -math.pi, math.pi), y=("E", -math.pi, math.pi),
                              tol=0.1)
    assert sset.complete and sset.boxes
    points = five_bar_curve_points(fb)
    assert len(points) >= 8
    assert _covered(sset, points).all()
    sing = [b for b in sset.boxes if b.status == "singular"]
    assert len(sing) >= 0.5 * len(sset.boxes)
    for b in sset.boxes:
        w = b.x[1] - b.x[0]
        # a proven box holds a singular input: the reference's sign change is within half its width
        for margin in ((w / 2,) if b.status == "singular" else ()) + (w,):
            g = np.linspace(-margin, w + margin, 13)
            grid = np.column_stack([a.ravel() for a in np.meshgrid(b.x[0] + g, b.y[0] + g)])
            f = five_bar_tangency(fb, grid)
            bb, dd = five_bar_moving(fb, grid)
            coincide = np.arccos(np.clip(np.einsum("ka,ka->k", bb, dd), -1, 1)).min() <= margin
            assert f.min() <= 0.0 <= f.max() or coincide, b


def test_five_bar_singular_inputs_on_the_window_edges_are_covered():
    """Issue 40: a window of the five-bar's plane whose lower edges pass through points of its singular curve
    (two of the reference curve's points as the corner): every input where the reference count changes along
    each edge, and 1e-6 inside it, lies in a box of the window's complete cover."""
    fb = five_bar_from_file()
    points = five_bar_curve_points(fb)
    px, py = points[0]
    square = ((px, px + 0.8), (py, py + 0.8))
    sset = spherekin.singular(EXAMPLES / "five_bar.toml", x=("A", *square[0]), y=("E", *square[1]), tol=0.05)
    edge_points = []
    for eps in (0.0, 1e-6):
        for p0, p1 in _edges(square, eps):
            p0, p1 = np.array(p0), np.array(p1)
            on = count_changes(lambda t: int(five_bar_count(fb, [p0 + t * (p1 - p0)])[0]), 0.0, 1.0, 200)
            edge_points += [p0 + t * (p1 - p0) for t in on]
    assert len(edge_points) >= 2
    assert sset.complete and _covered(sset, np.array(edge_points)).all()


def test_cli_free_box_of_a_home_pose_against_the_reference_tracking(tmp_path, capsys):
    """--home --start-solution: the JSON's free box (in the plane, beta3 at home) holds the assembly of
    solution 2 at home without a singularity by the independent tracking of tests/singular_refs.py (no
    loss, no sign change of the Type-2 determinant over a 31 x 31 grid), and the plot draws it."""
    from singular_refs import rrr_closure, rrr_geometry, rrr_tracked, track_box_min_det

    out, fig = tmp_path / "s.json", tmp_path / "s.png"
    code = main(["singular", str(RRR), "--x", "beta1=-0.4:0.4", "--y", "beta2=-0.4:0.4", "--fix", "beta3=0.5",
                 "--tol", "0.2", "--home", "0,0,0.5", "--start-solution", "2", "--free-shape", "cube",
                 "--json", str(out), "--plot", str(fig)])
    assert code == 0
    assert "free box of solution 2 at home" in capsys.readouterr().out and fig.stat().st_size > 0
    doc = json.loads(out.read_text())
    free = doc["free_box"]
    assert free["proven"] and free["start_solution"] == 2 and free["inputs"]["beta3"] == [0.5, 0.5]
    assert free["shape"] == "cube" and [(f["input"], f["side"]) for f in free["faces"]] == [
        ("beta1", "lo"), ("beta1", "hi"), ("beta2", "lo"), ("beta2", "hi")]
    assert all(f["extent"] == free["radius"] and f["limit"] == free["limit"] for f in free["faces"])
    home = np.array([0.0, 0.0, 0.5])
    sols = spherekin.solve(spherekin.load_mechanism(RRR), tuple(home)).solutions
    rot = sols[1].platform_rotation
    assert np.abs(rrr_closure(rrr_geometry(), home, rot)).max() < 1e-9
    assert np.abs(np.array(free["start"]) - rot).max() < 1e-12            # solution 2's assembly, numbered from 1
    lo = np.array([free["x"][0], free["y"][0], 0.5])
    hi = np.array([free["x"][1], free["y"][1], 0.5])
    assert np.all(hi[:2] - lo[:2] > 0.1)
    box = track_box_min_det(rrr_tracked(), home, rot, lo, hi, 31)
    assert box.lost == 0 and box.sign_changes == 0 and box.min_abs_det > 0
