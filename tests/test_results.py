"""spherekin.results in Python: the same names as the JSON, pose views, short reprs."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from spherekin import solve
from spherekin.core.orientation import rotation_from_euler
from spherekin.mechanism import general_3rrr


@pytest.fixture(scope="module")
def report():
    return solve(general_3rrr(), (0.3, -0.2, 0.5))


def test_solution_names_are_the_jsons(report):
    data = json.loads(json.dumps(report.as_dict()))
    assert len(data["solutions"]) == len(report.solutions) == 8
    for sol, js in zip(report.solutions, data["solutions"]):
        assert sol.passive_angles == js["passive_angles"]
        assert sol.joint_angles == js["joint_angles"]
        assert list(sol.joint_angles)[:3] == ["beta1", "beta2", "beta3"]


@pytest.mark.parametrize("convention", ["ZYX", "xyz", "ZYZ"])
def test_pose_views_give_the_rotation_back(report, convention):
    for sol in report.solutions:
        q = sol.quaternion
        assert q[0] >= 0 and abs(np.linalg.norm(q) - 1) < 1e-14
        np.testing.assert_allclose(Rotation.from_quat(np.roll(q, -1)).as_matrix(), sol.platform_rotation, atol=1e-12)
        np.testing.assert_allclose(rotation_from_euler(sol.euler(convention), convention), sol.platform_rotation,
                                   atol=1e-12)
    with pytest.raises(ValueError, match="convention"):
        report.solutions[0].euler("ZZY")


def test_reprs_are_short_and_the_notebook_view_is_a_table(report):
    assert len(repr(report)) < 300 and "8 solutions" in repr(report)
    assert all(len(repr(s)) < 250 and "gamma1=" in repr(s) for s in report.solutions)
    html = report._repr_html_()
    assert html.count("<tr>") == 1 + 8 and "delta3" in html and "certified" in html


def test_json_boxes_are_moved_next_to_their_angles():
    import dataclasses

    from spherekin.results import Solution, box_near

    sol = Solution(np.array([-2.84, 0.5]), np.array([3.43, 0.49]), np.array([3.45, 0.51]), 1)
    lo, hi = box_near(sol)
    np.testing.assert_allclose(lo, [3.43 - 2 * np.pi, 0.49])
    np.testing.assert_allclose(hi, [3.45 - 2 * np.pi, 0.51])
    assert lo[0] <= -2.84 <= hi[0]
    same = dataclasses.replace(sol, lo=np.array([-2.85, 0.49]), hi=np.array([-2.83, 0.51]))
    np.testing.assert_array_equal(box_near(same)[0], same.lo)


def test_frame_holds_the_solutions_in_the_batch_tables_columns(report, tmp_path):
    from spherekin import batch
    from spherekin.mechanism import general_3rrr

    frame = report.frame()
    names = list(report.unknowns)
    assert list(frame.columns) == (["input", "beta1", "beta2", "beta3", "solution", "status", *names,
                                    "qw", "qx", "qy", "qz", *[f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)],
                                    "residual", "singularity", "parallel_measure"])
    assert len(frame) == len(report.solutions) == 8
    np.testing.assert_array_equal(frame[["beta1", "beta2", "beta3"]].to_numpy(), np.tile([0.3, -0.2, 0.5], (8, 1)))
    for k, sol in enumerate(report.solutions):
        row = frame.iloc[k]
        assert row["status"] == str(sol.status) and row["singularity"] == sol.singularity
        np.testing.assert_array_equal(row[names].to_numpy(dtype=float), sol.angles)
        np.testing.assert_array_equal(row[[f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]].to_numpy(dtype=float),
                                      sol.platform_rotation.ravel())
        # the quaternion, independently: scipy's (x, y, z, w), sign chosen with w >= 0
        q = np.roll(Rotation.from_matrix(sol.platform_rotation).as_quat(), 1)
        q = q if q[0] >= 0 else -q
        np.testing.assert_allclose(row[["qw", "qx", "qy", "qz"]].to_numpy(dtype=float), q, atol=1e-14)
        assert row["residual"] == sol.residual
    # the same rows as a batch's CSV for the same input, column for column
    out = tmp_path / "one.csv"
    batch.solve_to_file(general_3rrr(), np.array([[0.3, -0.2, 0.5]]), out, workers=0)
    written = batch.read_results(out)
    assert list(written.columns) == list(frame.columns)
    for col in frame.columns:
        if frame[col].dtype.kind == "f":
            np.testing.assert_allclose(written[col].to_numpy(dtype=float), frame[col].to_numpy(dtype=float),
                                       rtol=1e-15, atol=0, err_msg=col)
        else:
            assert written[col].astype(str).tolist() == frame[col].astype(str).tolist(), col
    assert np.isfinite(frame["parallel_measure"]).all() and (frame["parallel_measure"] > 0).all()


def hand_made_report(angles):
    """A SolveReport of one certified solution with these passive angles (no solve)."""
    from spherekin.results import Settings, SolveReport, SolverStats, Solution, Status

    sol = Solution(np.array(angles), np.array(angles), np.array(angles), 1, np.eye(3), 1e-16, "regular",
                   Status.CERTIFIED, unknowns=("a", "b", "c"))
    settings = Settings("halves", "pp", None, "tan-half", 1e-6, True, 1, 1, "m", ("x",), (0.0,))
    return SolveReport(("a", "b", "c"), (sol,), (), SolverStats(), settings, 1, True)


def test_printed_tables_never_show_minus_zero():
    report = hand_made_report([-1e-17, -0.0, -2e-7])
    for text in (report.table(), report.table(degrees=True), repr(report.solutions[0]), report._repr_html_()):
        assert "-0.000000" not in text
    assert report.table().splitlines()[1].split()[1:4] == ["+0.000000"] * 3

    from spherekin.results import format_number

    assert format_number(-1e-17) == "+0.000000" and format_number(-0.0, "+.6g") == "+0"
    assert format_number(-4e-6) == "-0.000004" and format_number(0.5, "+11.6f") == "  +0.500000"
    assert format_number(float("nan")) == "+nan"


def test_frame_of_an_empty_report_is_one_row_without_a_solution():
    from spherekin import solve
    from spherekin.mechanism import general_3rrr

    empty = solve(general_3rrr(), (-2.5, 2.9, 0.1))
    frame = empty.frame()
    assert len(frame) == 1 and frame["solution"].isna().all() and frame["status"].isna().all()
    assert frame["beta1"].iloc[0] == -2.5 and np.isnan(frame["gamma1"].iloc[0])
