"""The results table of a batch: one row per solution of every input (docs/results-format.md).

Columns, in order: ``input`` (the input's 0-based row number), the actuated joints by name
(radians), ``solution`` (the solution's number among the input's entries, from 1: the number
``solve`` prints, the JSON's ``number`` and ``--start-solution`` take), ``status``, every passive
angle by name (radians), the platform rotation as a unit quaternion ``qw, qx, qy, qz`` (qw >= 0) and
as a matrix ``r11 ... r33`` (row-major; v_i = R v_i^0), ``residual`` (largest |F_n - I| entry),
``singularity`` (the mechanism's classification) and ``parallel_measure``: the normalized distance
to a parallel singularity, sigma_min / sigma_max of the passive-joint Jacobian K_p of the loop
constraints (1 for an isotropic configuration, 0 at a parallel singularity, where assembly modes
meet; :meth:`spherekin.mechanism.SphericalMechanism.parallel_measure`). An input with no solution has
one row whose solution columns are empty (null).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..results import QUATERNION_COLUMNS, ROTATION_COLUMNS, solution_table, table_columns

__all__ = ["ROTATION_COLUMNS", "QUATERNION_COLUMNS", "columns", "report_rows", "track_rows", "solution_rows", "empty_frame"]


def columns(mechanism) -> tuple[str, ...]:
    """The column names of the results table of ``mechanism`` (module doc)."""
    return table_columns(mechanism.actuated, mechanism.loop_unknowns)


def report_rows(mechanism, reports: Sequence, first: int, inputs: np.ndarray):
    """The results table (a pandas DataFrame, module doc) of ``reports`` (SolveReport of inputs
    ``first``, ``first + 1``, ...; ``inputs`` their rows, radians)."""
    return solution_rows(mechanism, ((first + k, inputs[k], r.unknowns, r.solutions) for k, r in enumerate(reports)))


def track_rows(mechanism, track):
    """The results table of a tracked path (:class:`spherekin.trust.continuation.Track`): one row per
    path row reached, its one solution the tracked assembly (status certified: every step proven)."""
    from ..results import Solution, Status

    poses = list(track.poses)
    kinds = []
    if poses:          # every pose's classification in one call (a path of 1,000 rows: not 1,000)
        readings = {n: [p.inputs[n] if n in p.inputs else p.passive_angles[n] for p in poses]
                    for n in {**poses[0].inputs, **poses[0].passive_angles}}
        kinds = [r.kind for r in mechanism.singularities(readings)]
    items = []
    for p, kind in zip(poses, kinds):
        angles = np.array(list(p.passive_angles.values()))
        sol = Solution(angles, angles, angles, 0, p.platform_rotation, p.residual, kind, Status.CERTIFIED)
        items.append((p.row, np.array(list(p.inputs.values())), tuple(p.passive_angles), (sol,)))
    return solution_rows(mechanism, items)


def solution_rows(mechanism, items):
    """The results table of ``items``: (input index, its inputs (radians), the unknowns' names, its
    solutions) each; an input without solutions gets one row with empty solution columns. Built by
    :func:`spherekin.results.solution_table`, as ``SolveReport.frame()`` is."""
    return solution_table(mechanism.actuated, mechanism.loop_unknowns, items, mechanism.parallel_measures)


def empty_frame(mechanism):
    """A results table with no rows (every column with its type)."""
    return report_rows(mechanism, (), 0, np.empty((0, len(mechanism.actuated))))
