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

from ..core.columns import TOLERANCE_COLUMNS
from ..results import QUATERNION_COLUMNS, ROTATION_COLUMNS, ResultsTable, solution_columns, table_columns

__all__ = ["ROTATION_COLUMNS", "QUATERNION_COLUMNS", "columns", "report_rows", "track_rows", "solution_rows",
           "empty_frame", "report_table", "track_table", "items_table"]


def columns(mechanism) -> tuple[str, ...]:
    """The column names of the results table of ``mechanism`` (module doc)."""
    return table_columns(mechanism.actuated, mechanism.loop_unknowns, mechanism.tolerances is not None)


def report_table(mechanism, reports: Sequence, first: int, inputs: np.ndarray) -> ResultsTable:
    """The results table (module doc; a :class:`~spherekin.results.ResultsTable`: no pandas) of
    ``reports`` (SolveReport of inputs ``first``, ``first + 1``, ...; ``inputs`` their rows, radians);
    for a mechanism with tolerances, their columns last (:data:`TOLERANCE_COLUMNS`, each report's
    :class:`~spherekin.results.ToleranceReport`)."""
    table = items_table(mechanism, ((first + k, inputs[k], r.unknowns, r.solutions) for k, r in enumerate(reports)))
    if mechanism.tolerances is None:
        return table
    return _with_tolerance_columns(table, [(len(r.solutions), r.tolerances) for r in reports])


def _with_tolerance_columns(table, entries) -> ResultsTable:
    """``table`` with :data:`TOLERANCE_COLUMNS` last: ``entries`` (number of entries, ToleranceReport or
    None) per input, in the table's order (an input without entries has one row)."""
    worst, low, constant = [], [], []
    for count, tr in entries:
        per = list(tr.assemblies) if tr is not None else []
        for j in range(max(count, 1)):
            a = per[j] if j < len(per) and count else None
            worst.append(np.nan if a is None or a.worst_case_rotation_error is None else a.worst_case_rotation_error)
            low.append(np.nan if a is None or a.worst_case_rotation_error_lower_bound is None
                       else a.worst_case_rotation_error_lower_bound)
            verdict = None if tr is None else tr.count_constant_over_tolerances
            constant.append(None if verdict is None else ("true" if verdict else "false"))
    flags = np.empty(len(constant), dtype=object)
    flags[:] = constant
    return table.with_columns(TOLERANCE_COLUMNS, (np.array(worst, dtype=float), np.array(low, dtype=float), flags),
                              ("float64", "float64", "string"))


def report_rows(mechanism, reports: Sequence, first: int, inputs: np.ndarray):
    """:func:`report_table` as a pandas DataFrame."""
    return report_table(mechanism, reports, first, inputs).frame()


def track_table(mechanism, track) -> ResultsTable:
    """The results table (a :class:`~spherekin.results.ResultsTable`) of a tracked path
    (:class:`spherekin.trust.continuation.Track`): one row per path row reached, its one solution
    the tracked assembly (status certified: every step proven)."""
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
    table = items_table(mechanism, items)
    if mechanism.tolerances is None:
        return table
    return _with_tolerance_columns(table, [(1, p.tolerances) for p in poses])


def track_rows(mechanism, track):
    """:func:`track_table` as a pandas DataFrame."""
    return track_table(mechanism, track).frame()


def items_table(mechanism, items) -> ResultsTable:
    """The results table of ``items``: (input index, its inputs (radians), the unknowns' names, its
    solutions) each; an input without solutions gets one row with empty solution columns. Built by
    :func:`spherekin.results.solution_columns`, as ``SolveReport.frame()`` is."""
    return solution_columns(mechanism.actuated, mechanism.loop_unknowns, items, mechanism.parallel_measures)


def solution_rows(mechanism, items):
    """:func:`items_table` as a pandas DataFrame."""
    return items_table(mechanism, items).frame()


def empty_frame(mechanism):
    """A results table with no rows (every column with its type)."""
    return report_rows(mechanism, (), 0, np.empty((0, len(mechanism.actuated))))
