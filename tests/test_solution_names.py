"""Issue 27, item 9: a solution's Python attributes carry the JSON's names and values (a solve's JSON,
docs/results-format.md), and the JSON's ``number`` is the solution's position from 1."""

from __future__ import annotations

import json

import numpy as np

from spherekin import compile as compile_problem
from spherekin.mechanism import general_3rrr


def test_every_key_of_a_json_solution_is_the_attribute_of_that_name():
    report = compile_problem(general_3rrr()).solve([0.3, -0.2, 0.5])
    data = json.loads(json.dumps(report.as_dict()))
    assert len(data["solutions"]) == len(report.solutions) > 1
    for k, (sol, entry) in enumerate(zip(report.solutions, data["solutions"])):
        assert entry["number"] == k + 1                  # report.solutions[k] is solution k + 1, as printed
        for key, value in entry.items():
            if key == "number":
                continue
            got = getattr(sol, key)
            got = np.asarray(got).tolist() if isinstance(got, np.ndarray) else got
            assert got == value, key
        # the box next to the angles: it holds them
        assert np.all(sol.box_lo <= sol.angles) and np.all(sol.angles <= sol.box_hi)
