"""Every gallery script (examples/gallery/plot_*.py, the site's gallery: docs/development.md) runs
as a test, so that a broken example fails ``make test`` without building the site.

Each script runs in this process (runpy, as ``__main__``) with the Agg backend, in an empty
temporary working directory: an example may read no file of the checkout. It must end in a figure:
a matplotlib Figure in its globals (what spherekin.plot returns) or an open pyplot figure.

The examples added for issue 32 item 3 are also checked against references written without spherekin's
solver (the names their scripts define, from the one run of each script): the six-bar's assemblies against
two four-bars in series in closed form (tests/test_mechanism_graph.py), the singular cells and cusps of
general_3rrr against the degree-8 oracle of tests/singular_refs.py, the free boxes against its dense Newton
tracking, the paper's configuration and the default against the four-bar's closed-form rocker angles.
"""

import ast
import math
import os
import runpy
import tempfile
from pathlib import Path

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

GALLERY = Path(__file__).resolve().parents[1] / "examples" / "gallery"
SCRIPTS = sorted(GALLERY.glob("plot_*.py"))


def test_gallery_has_examples():
    assert len(SCRIPTS) >= 10, f"expected at least 10 gallery scripts in {GALLERY}, got {len(SCRIPTS)}"
    assert (GALLERY / "README.rst").is_file(), "sphinx-gallery needs the gallery's README.rst"


@pytest.mark.parametrize("script", SCRIPTS, ids=[s.stem for s in SCRIPTS])
def test_gallery_script_has_a_title(script):
    """sphinx-gallery takes the page title from the module docstring: a title line underlined with '='."""
    doc = ast.get_docstring(ast.parse(script.read_text()))
    assert doc, f"{script.name}: expected a module docstring with a title, got none"
    lines = doc.splitlines()
    assert len(lines) >= 2 and lines[1].strip() and set(lines[1].strip()) == {"="} \
        and len(lines[1].strip()) >= len(lines[0].strip()), \
        f"{script.name}: expected a title underlined with '=' (as long as the title), got {lines[:2]}"


#: The globals of each script's run (by stem), kept for the reference checks below: each script runs once.
RUNS: dict = {}


def run_script(script: Path) -> dict:
    """Run ``script`` as ``__main__`` in an empty temporary working directory; check that it ends in a figure
    and leaves no file there; return its globals (cached in RUNS)."""
    if script.stem in RUNS:
        return RUNS[script.stem]
    cwd = os.getcwd()
    plt.close("all")
    with tempfile.TemporaryDirectory() as folder:
        os.chdir(folder)
        try:
            names = runpy.run_path(str(script), run_name="__main__")
            figures = [v for v in names.values() if isinstance(v, Figure)] + plt.get_fignums()
            assert figures, f"{script.name}: expected it to end in a matplotlib figure, got none"
            left = list(Path(folder).iterdir())
            assert left == [], f"{script.name}: left files in its working directory: {left}"
        finally:
            os.chdir(cwd)
            plt.close("all")
    RUNS[script.stem] = names
    return names


@pytest.mark.parametrize("script", SCRIPTS, ids=[s.stem for s in SCRIPTS])
def test_gallery_script_runs_and_ends_in_a_figure(script):
    run_script(script)


def ran(stem: str) -> dict:
    return run_script(GALLERY / f"{stem}.py")


# ---------------------------------------------------------------- the new examples against references

def test_six_bar_from_a_graph_against_two_four_bars_in_series():
    """plot_six_bar_graph: the Watt six-bar built from its graph has the loops counted by hand (closed by C
    and F), its 4 assemblies at A = 0.7 are those of the closed form (the four-bar A-B-C-D, then the dyad
    E-F-G on the crank and the coupler; scipy rotations), joint by joint, and the branch map's count at every
    grid input is the closed form's."""
    from test_mechanism_graph import close, watt_reference

    g = ran("plot_six_bar_graph")
    mech, report, bmap = g["mechanism"], g["report"], g["bmap"]
    assert [lp.closing for lp in mech.link_graph.loops] == ["C", "F"]
    refs = watt_reference(mech, 0.7)
    assert len(refs) == 4 and len(report.solutions) == 4 and report.count_exact
    for sol in report.solutions:
        angles = sol.joint_angles
        gaps = [max(close(angles[j], ref[j]) for j in "ABCDEFG") for ref in refs]
        assert min(gaps) < 1e-9, gaps
        ref = refs[int(np.argmin(gaps))]
        assert np.abs(sol.platform_rotation - ref["pose"]).max() < 1e-9
    assert [len(watt_reference(mech, float(u))) for u in bmap.grid] == list(bmap.counts)


#: A square about general_3rrr's cusp near (1.5923, 0.1040) (beta3 = 0.5) where the oracle's cusp scan is
#: quick (~2 s at n = 11; some squares about the same cusp take 20x longer, Nelder-Mead from many minima).
CUSP_SQUARE = ((1.55, 1.65), (0.05, 0.15))


def _in_cells(sset, points, edge=1e-9):
    """Whether each point (beta1, beta2) lies in a cell of ``sset`` (closed, ``edge`` of rounding)."""
    lo = np.array([[b.x[0], b.y[0]] for b in sset.boxes])
    hi = np.array([[b.x[1], b.y[1]] for b in sset.boxes])
    return [bool(np.any(np.all((lo - edge <= p) & (p <= hi + edge), axis=1))) for p in points]


def test_singular_map_cells_hold_the_oracles_singular_inputs_and_cusp():
    """plot_singular_map: every singular input the degree-8 oracle finds (a change of its real-root count,
    bisected) on the square's two diagonals and its midlines lies in a cell of the set; its one proven cusp is
    the oracle's triple root (found in CUSP_SQUARE: a scan of the whole square takes ~40 s); the map's count at
    every grid point is the oracle's real-root count."""
    from singular_refs import cusps_in_square, rrr_counts, rrr_geometry, singular_points_on_line

    g = ran("plot_singular_map")
    sset, amap = g["sset"], g["amap"]
    (_, x0, x1), (_, y0, y1) = sset.x, sset.y
    assert sset.complete and dict(sset.fixed) == {"beta3": 0.5}
    xm, ym = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    lines = [((x0, y0), (x1, y1)), ((x0, y1), (x1, y0)), ((x0, ym), (x1, ym)), ((xm, y0), (xm, y1))]
    points = [p.inputs[:2] for a, b in lines for p in singular_points_on_line(a, b, n_samples=40, seed=0)]
    assert len(points) >= 4
    assert all(_in_cells(sset, points)), points
    proven = [c for c in sset.cusps if c.status == "cusp"]
    assert len(proven) == 1
    (ref,) = cusps_in_square(CUSP_SQUARE, n=11)
    assert math.hypot(proven[0].x - ref[0], proven[0].y - ref[1]) < 1e-6
    gx, gy = np.meshgrid(amap.x.values, amap.y.values, indexing="ij")
    grid = np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, 0.5)])
    want = rrr_counts(rrr_geometry(), grid).reshape(gx.shape)
    assert np.array_equal(np.asarray(amap.solutions), want)


def test_mode_change_around_a_cusp_against_an_independent_newton_tracking():
    """plot_mode_change_cusp: the cusp is the oracle's triple root; the circle's first input has the start
    and end poses of the changing track among the degree-8 oracle's roots, as two different ones; a numpy
    Newton tracking (tests/singular_refs.py) of the start pose along the same closed polygon, in short steps,
    ends at the pose the proven track ends at."""
    from references.peers_closed_form import direct_kinematics, geometry_of
    from singular_refs import cusps_in_square, rrr_tracked

    g = ran("plot_mode_change_cusp")
    cusp, path, track, start, k, j = g["cusp"], g["path"], g["track"], g["start"], g["k"], g["j"]
    assert (g["sset"].x[1:], g["sset"].y[1:]) == CUSP_SQUARE
    (ref,) = cusps_in_square(CUSP_SQUARE, n=11)
    assert math.hypot(cusp.x - ref[0], cusp.y - ref[1]) < 1e-6
    r0, r1 = start.solutions[k].platform_rotation, track.poses[-1].platform_rotation
    assert track.stop is None and k != j and np.abs(r0 - r1).max() > 0.1
    poses = direct_kinematics(geometry_of(g["mechanism"]), path[0])
    assert min(np.abs(p - r0).max() for p in poses) < 1e-9 and min(np.abs(p - r1).max() for p in poses) < 1e-9
    newton = rrr_tracked().newton
    rot = np.asarray(r0, dtype=float)[None]
    for a, b in zip(path[:-1], path[1:]):
        for t in np.linspace(0.0, 1.0, 5)[1:]:      # 4 Newton steps per side (sides ~1e-3 rad long)
            rot, res = newton((a + t * (b - a))[None], rot)
            assert res[0] < 1e-9
    assert np.abs(rot[0] - r1).max() < 1e-8


def test_free_boxes_against_a_dense_newton_tracking():
    """plot_free_box: the cube and the box each hold the assembly on a 41 x 41 grid of the reference's Newton
    tracking with no lost point, no sign change of the Type-2 determinant and |det| > 0; the cube 5 % larger
    is not free per the reference, nor the box with any face that stopped at a failed proof pushed out 5 %;
    the box holds the cube and its other faces are at the 0.6 rad asked for."""
    from singular_refs import rrr_tracked, track_box_min_det

    g = ran("plot_free_box")
    home, report = np.array(g["HOME"]), g["problem"].solve(g["HOME"])
    rot0 = report.solutions[g["K"]].platform_rotation
    cube, box = g["boxes"]["cube"], g["boxes"]["box"]
    for fb in (cube, box):
        lo, hi = np.array(fb.lo), np.array(fb.hi)
        assert fb.proven and fb.free == ("beta1", "beta2") and lo[2] == hi[2] == 0.5
        inside = track_box_min_det(rrr_tracked(), home, rot0, lo, hi, 41)
        assert inside.lost == 0 and inside.sign_changes == 0 and inside.min_abs_det > 0
    lo, hi = np.array(cube.lo), np.array(cube.hi)
    assert cube.limit == "unproven"
    grown = track_box_min_det(rrr_tracked(), home, rot0, home - 1.05 * (home - lo), home + 1.05 * (hi - home), 41)
    assert grown.lost > 0 or grown.sign_changes > 0 or grown.min_abs_det < 1e-3
    assert np.all(np.array(box.lo) <= lo) and np.all(np.array(box.hi) >= hi)
    assert any(f.limit == "unproven" for f in box.faces) and any(f.limit == "radius" for f in box.faces)
    for face in box.faces:
        a = ("beta1", "beta2").index(face.input)
        if face.limit == "radius":
            assert math.isclose(face.extent, 0.6)
            continue
        assert face.limit == "unproven"
        g_lo, g_hi = np.array(box.lo), np.array(box.hi)
        if face.side == "lo":
            g_lo[a] = home[a] - 1.05 * face.extent
        else:
            g_hi[a] = home[a] + 1.05 * face.extent
        grown = track_box_min_det(rrr_tracked(), home, rot0, g_lo, g_hi, 41)
        assert grown.lost > 0 or grown.sign_changes > 0 or grown.min_abs_det < 1e-3, face


def test_paper_configuration_and_default_find_the_four_bars_closed_form_rocker_angles():
    """plot_paper_vs_default: at every tolerance both configurations (the paper's really used: Eq. 10, LPs,
    no isolation) find exactly the rocker angles D of the four-bar's closed form at the input (the roots of
    its quadratic in tan(D/2)), and the paper's configuration processes more boxes at a smaller tolerance."""
    from singular_refs import four_bar_closure_coefficients, four_bar_from_file

    g = ran("plot_paper_vs_default")
    (a_in,) = g["INPUTS"]
    P, Q, S = four_bar_closure_coefficients(four_bar_from_file(), a_in)
    want = sorted(2 * math.atan(t.real) for t in np.roots([P - Q, 2 * S, P + Q]))
    assert len(want) == 2
    paper_boxes = []
    for (name, tol), report in g["reports"].items():
        if name.startswith("paper"):
            used = (report.settings.formulation, report.settings.pruner, report.settings.isolate)
            assert used == ("paper", "lp", False)
            paper_boxes.append(report.stats.boxes_processed)
        got = [s.joint_angles["D"] for s in report.solutions]
        assert report.count_exact and len(got) == 2
        nearest = [int(np.argmin([abs(math.remainder(a - b, 2 * math.pi)) for b in want])) for a in got]
        assert sorted(nearest) == [0, 1], (got, want)
        assert max(abs(math.remainder(a - want[n], 2 * math.pi)) for a, n in zip(got, nearest)) < 1e-9
    assert paper_boxes == sorted(paper_boxes) and paper_boxes[0] < paper_boxes[-1]
