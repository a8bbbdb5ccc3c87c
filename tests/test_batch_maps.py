"""spherekin.batch.maps: the aggregation of a results table into a map, against counts made by hand."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from spherekin.batch.inputs import GridAxis
from spherekin.batch.maps import aggregate


def table(rows):
    """A results table with only the columns a map reads: (input, solution or None, status or None, measure)."""
    return pd.DataFrame({"input": np.array([r[0] for r in rows], dtype=np.int64),
                         "solution": pd.array([r[1] for r in rows], dtype="Int64"),
                         "status": pd.array([r[2] for r in rows], dtype="string"),
                         "parallel_measure": np.array([np.nan if r[3] is None else r[3] for r in rows])})


def test_counts_per_status_and_the_smallest_measure_per_grid_point():
    x, y = GridAxis("beta1", np.array([0.0, 1.0])), GridAxis("beta2", np.array([0.0, 1.0, 2.0]))
    frame = table([
        (0, 0, "certified", 0.5), (0, 1, "certified", 0.2),
        (1, None, None, None),
        (2, 0, "certified", 0.3), (2, 1, "singular", 1e-9), (2, 2, "unverified", 0.1), (2, 3, "cluster", None),
        (3, 0, "continuum", None),
        (4, None, None, None),
        (5, 0, "certified", 0.9),
    ])
    m = aggregate(frame, x, y, {"beta3": 0.5}, "test")
    np.testing.assert_array_equal(m.solutions, [[2, 0, 4], [1, 0, 1]])
    np.testing.assert_array_equal(m.certified, [[2, 0, 1], [0, 0, 1]])
    np.testing.assert_array_equal(m.singular, [[0, 0, 1], [0, 0, 0]])
    np.testing.assert_array_equal(m.flagged, [[0, 0, 2], [1, 0, 0]])
    np.testing.assert_array_equal(m.proven, [[True, True, False], [False, True, True]])
    np.testing.assert_allclose(m.measure, [[0.2, np.nan, 1e-9], [np.nan, np.nan, 0.9]])
    assert m.histogram() == {0: 2, 1: 2, 2: 1, 4: 1}
    assert "3 flagged" in m.table() and "1 singular" in m.table()
    f = m.frame()
    assert list(f["beta2"]) == [0.0, 1.0, 2.0, 0.0, 1.0, 2.0] and list(f["solutions"]) == [2, 0, 4, 1, 0, 1]


def test_an_input_outside_the_grid_is_an_error():
    x, y = GridAxis("a", np.array([0.0, 1.0])), GridAxis("b", np.array([0.0, 1.0]))
    with pytest.raises(ValueError, match="outside the 2 x 2 grid"):
        aggregate(table([(4, 0, "certified", 0.5)]), x, y, {}, "test")


# --------------------------------------------------------------------------------------------
# The certified singular set on a map (issue 31 item 3: ``map --singular``)
# --------------------------------------------------------------------------------------------

from pathlib import Path   # noqa: E402  (the section's own imports)

RRR = Path(__file__).resolve().parents[1] / "examples" / "general_3rrr.toml"
#: A sub-square of the plane beta3 = 0.5 that general_3rrr's singular curves cross several times (as
#: tests/test_singular.py's), its grid (step 0.05 rad) and the singular set's cell width.
SQUARE = ((0.9, 1.9), (1.1, 2.1))
GRID_N = 21
SING_T = 0.1
#: Closed cells: a point (bisected to 1e-10, or a grid point on a cell edge) counts as inside within this.
EDGE = 1e-9


@pytest.fixture(scope="module")
def map_with_set():
    from spherekin import batch

    (x0, x1), (y0, y1) = SQUARE
    return batch.assembly_map(RRR, f"beta1={x0}:{x1}:{GRID_N}", f"beta2={y0}:{y1}:{GRID_N}", {"beta3": 0.5},
                              workers=0, singular_tol=SING_T)


def _cells(sset):
    lo = np.array([[b.x[0], b.y[0]] for b in sset.boxes])
    hi = np.array([[b.x[1], b.y[1]] for b in sset.boxes])
    return lo, hi


def test_map_carries_the_singular_set_of_its_plane(map_with_set):
    s = map_with_set.singular_set
    (x0, x1), (y0, y1) = SQUARE
    assert s is not None and s.complete
    assert (s.x[0], s.y[0]) == ("beta1", "beta2") and dict(s.fixed) == {"beta3": 0.5}
    np.testing.assert_allclose([s.x[1], s.x[2], s.y[1], s.y[2]], [x0, x1, y0, y1])
    assert s.tol == SING_T and s.counts()["singular"] > 0
    assert "certified singular set (cells <= 0.1 rad)" in map_with_set.table()


def test_count_changes_of_the_map_lie_in_cells_of_the_set(map_with_set):
    """Independent of the set: wherever two neighbouring grid points of the map (solved point by point)
    have different counts, the segment between them crosses a parallel singularity (general_3rrr's joints
    are unlimited, so a count changes only there), so some cell of the set meets that segment."""
    m = map_with_set
    xs, ys = m.x.values, m.y.values
    lo, hi = _cells(m.singular_set)
    changes = 0
    for di, dj in ((1, 0), (0, 1)):
        a = m.solutions[:len(xs) - di, :len(ys) - dj]
        b = m.solutions[di:, dj:]
        for i, j in zip(*np.nonzero(a != b)):
            p = np.array([xs[i], ys[j]])
            q = np.array([xs[i + di], ys[j + dj]])
            seg_lo, seg_hi = np.minimum(p, q), np.maximum(p, q)
            meets = np.all((lo - EDGE <= seg_hi) & (seg_lo <= hi + EDGE), axis=1)
            assert meets.any(), f"count {a[i, j]} -> {b[i, j]} between {p} and {q}: no cell of the set there"
            changes += 1
    assert changes >= 10                 # the square is crossed by the curves


def test_the_map_holds_its_set_against_its_proven_counts(map_with_set):
    """Issue 40 item 3, inside the product: the map checks its own set as the test above does. On the true set
    every count change has a cell (``complete`` stays, the table says so); with the cells near half the count
    changes removed, the same check finds those pairs and the set is not complete (a cover missing a
    branch point is never silently called complete)."""
    from spherekin.batch.maps import grid_cross_check

    s = map_with_set.singular_set
    assert s.cross_check is not None and s.cross_check.skipped is None and not s.cross_check.disagreements
    assert s.cross_check.samples == GRID_N ** 2 and s.cross_check.proven > 0 and s.complete
    assert "cross-check: the proven counts at" in map_with_set.table()
    keep = tuple(b for b in s.boxes if b.x[0] > 1.4)               # the cells of the left half dropped
    check = grid_cross_check(map_with_set, dataclasses.replace(s, boxes=keep))
    assert check.disagreements
    for (x0, x1, y0, y1), (a, b) in check.disagreements:
        assert x0 <= 1.4 + SING_T and a != b
    assert "DISAGREES" in check.text()


def test_reference_singular_inputs_across_the_map_are_in_cells(map_with_set):
    from singular_refs import singular_points_on_line

    (x0, x1), (y0, y1) = SQUARE
    lo, hi = _cells(map_with_set.singular_set)
    pts = [s.inputs[:2] for p0, p1 in (((x0, y0), (x1, y1)), ((x0, y1), (x1, y0)))
           for s in singular_points_on_line(p0, p1, n_samples=60, seed=0)]
    assert len(pts) >= 2
    for p in pts:
        assert np.any(np.all((lo - EDGE <= p) & (p <= hi + EDGE), axis=1)), p


def test_plot_draws_one_patch_per_cell_by_status(map_with_set):
    from spherekin.plot import plot_assembly_map

    s = map_with_set.singular_set
    fig = plot_assembly_map(map_with_set)
    ax = fig.axes[0]
    drawn = {}
    for patch in ax.patches:
        gid = patch.get_gid() or ""
        if gid.startswith("singular-cell:"):
            drawn.setdefault(gid.split(":", 1)[1], []).append(patch)
    expected = {}
    for b in s.boxes:
        expected.setdefault(b.status, []).append(b)
    assert {k: len(v) for k, v in drawn.items()} == {k: len(v) for k, v in expected.items()}
    for status, patches in drawn.items():     # each patch is a cell of that status (radians: no scaling)
        got = sorted((p.get_x(), p.get_y(), p.get_width(), p.get_height()) for p in patches)
        want = sorted((b.x[0], b.y[0], b.x[1] - b.x[0], b.y[1] - b.y[0]) for b in expected[status])
        np.testing.assert_allclose(got, want)
    hatched = {p.get_hatch() for p in drawn.get("unresolved", [])}
    assert hatched <= {"////"} and all(p.get_hatch() is None for p in drawn["singular"])
    labels = ax.get_legend_handles_labels()[1]
    assert any(lab.startswith("singular cell") for lab in labels)
    # without a set: no cell drawn (the numeric --singularity panel is another thing)
    plain = dataclasses.replace(map_with_set, singular_set=None)
    assert not any((p.get_gid() or "").startswith("singular-cell:") for p in plot_assembly_map(plain).axes[0].patches)


def test_a_set_of_another_plane_is_refused(map_with_set):
    s = map_with_set.singular_set
    with pytest.raises(ValueError, match="singular_set: expected the map's plane beta1 x beta2"):
        dataclasses.replace(map_with_set, singular_set=dataclasses.replace(s, x=("beta3",) + tuple(s.x[1:])))
    with pytest.raises(ValueError, match="singular_set: expected the map's fixed joints"):
        dataclasses.replace(map_with_set, singular_set=dataclasses.replace(s, fixed={"beta3": 0.6}))


def test_singular_tol_is_checked_before_any_work():
    from spherekin import batch

    with pytest.raises(ValueError, match=r"^singular_tol: expected 0 < T <= 0.5 \(radians\), got 2"):
        batch.assembly_map(RRR, "beta1=0:1:3", "beta2=0:1:3", {"beta3": 0.5}, workers=0, singular_tol=2)
    with pytest.raises(ValueError, match="^singular_max_boxes: only with singular_tol"):
        batch.assembly_map(RRR, "beta1=0:1:3", "beta2=0:1:3", {"beta3": 0.5}, workers=0, singular_max_boxes=10)


@pytest.mark.parametrize("args, words", [
    (["--grid", "beta1=0:1:3", "--grid", "beta2=0:1:3", "--fix", "beta3=0.5", "--singular-tol", "0.1"],
     "--singular-tol: only with --singular"),
    (["--grid", "beta1=0:1:3", "--grid", "beta2=0:1:3", "--fix", "beta3=0.5", "--singular", "--singular-tol", "1"],
     "--singular-tol: expected 0 < T <= 0.5"),
    (["--grid", "beta1=0:1:3", "--grid", "beta2=0:1:3", "--fix", "beta3=0.5", "--singular", "--singular-tol", "1e-30"],
     "--singular-tol: T = 1e-30 rad is below 1.28e-07"),
])
def test_cli_singular_option_errors_are_one_line(args, words, capsys):
    from spherekin.cli import main

    assert main(["map", str(RRR), *args]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.strip().count("\n") == 0 and words in err


def test_cli_map_singular_draws_the_cells(tmp_path, capsys):
    from spherekin.cli import main

    png = tmp_path / "map.png"
    assert main(["map", str(RRR), "--grid", "beta1=0.9:1.4:3", "--grid", "beta2=1.1:1.6:3", "--fix", "beta3=0.5",
                 "--singular", "--singular-tol", "0.1", "--workers", "0", "--quiet", "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "certified singular set (cells <= 0.1 rad):" in out and png.stat().st_size > 0


def test_cli_singular_is_refused_for_the_branches_of_one_input(capsys):
    from spherekin.cli import main

    assert main(["map", str(RRR.parent / "four_bar.toml"), "--singular"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--singular: only for a map of two inputs" in err
