"""spherekin.batch.rows: the results table of a batch, checked against the reports and an independent Jacobian."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from spherekin import compile as compile_problem
from spherekin.batch.rows import columns, empty_frame, report_rows


@pytest.fixture(scope="module")
def solved(mech):
    rows = np.array([[0.3, -0.2, 0.5], [-2.5, 2.9, 0.1], [0.1, 0.2, 0.3]])
    return rows, compile_problem(mech).solve_many(rows)


def test_columns_are_the_documented_ones(mech):
    assert columns(mech) == ("input", "beta1", "beta2", "beta3", "solution", "status", "gamma1", "delta1", "gamma2",
                             "delta2", "gamma3", "delta3", "qw", "qx", "qy", "qz", "r11", "r12", "r13", "r21",
                             "r22", "r23", "r31", "r32", "r33", "residual", "singularity", "parallel_measure")
    assert list(empty_frame(mech).columns) == list(columns(mech))


def test_one_row_per_solution_and_one_empty_row_for_an_input_without_any(mech, solved):
    rows, reports = solved
    counts = [len(r.solutions) for r in reports]
    assert counts[1] == 0 and counts[0] > 0 and counts[2] > 0   # the second input has no assembly
    frame = report_rows(mech, reports, 40, rows)
    assert len(frame) == counts[0] + 1 + counts[2]
    assert list(frame["input"]) == [40] * counts[0] + [41] + [42] * counts[2]
    empty = frame[frame["input"] == 41].iloc[0]
    assert empty["solution"] is __import__("pandas").NA and empty["status"] is __import__("pandas").NA
    assert np.isnan(empty[["gamma1", "qw", "r11", "residual", "parallel_measure"]].to_numpy(dtype=float)).all()
    np.testing.assert_array_equal(empty[["beta1", "beta2", "beta3"]].to_numpy(dtype=float), rows[1])
    first = frame[frame["input"] == 40]
    assert list(first["solution"]) == list(range(1, counts[0] + 1))          # numbered from 1, as printed
    for (_, row), sol in zip(first.iterrows(), reports[0].solutions):
        np.testing.assert_array_equal(row[list(reports[0].unknowns)].to_numpy(dtype=float), sol.angles)
        rot = row[[f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]].to_numpy(dtype=float).reshape(3, 3)
        np.testing.assert_array_equal(rot, sol.platform_rotation)
        q = row[["qw", "qx", "qy", "qz"]].to_numpy(dtype=float)
        assert q[0] >= 0
        # the quaternion is the rotation (scipy, scalar last)
        np.testing.assert_allclose(Rotation.from_quat(np.roll(q, -1)).as_matrix(), rot, atol=1e-12)
        assert row["status"] == str(sol.status) and row["residual"] == sol.residual
