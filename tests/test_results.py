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
