"""spherekin.batch.maps: the aggregation of a results table into a map, against counts made by hand."""

from __future__ import annotations

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
