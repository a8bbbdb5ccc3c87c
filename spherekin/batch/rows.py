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

from ..core.orientation import QUATERNION_COLUMNS, ROTATION_COLUMNS, quaternions_from_rotations

__all__ = ["ROTATION_COLUMNS", "QUATERNION_COLUMNS", "columns", "report_rows", "track_rows", "solution_rows", "empty_frame"]



def columns(mechanism) -> tuple[str, ...]:
    """The column names of the results table of ``mechanism`` (module doc)."""
    return ("input", *mechanism.actuated, "solution", "status", *mechanism.loop_unknowns, *QUATERNION_COLUMNS,
            *ROTATION_COLUMNS, "residual", "singularity", "parallel_measure")


def report_rows(mechanism, reports: Sequence, first: int, inputs: np.ndarray):
    """The results table (a pandas DataFrame, module doc) of ``reports`` (SolveReport of inputs
    ``first``, ``first + 1``, ...; ``inputs`` their rows, radians)."""
    return solution_rows(mechanism, ((first + k, inputs[k], r.unknowns, r.solutions) for k, r in enumerate(reports)))


def track_rows(mechanism, track):
    """The results table of a tracked path (:class:`spherekin.trust.continuation.Track`): one row per
    path row reached, its one solution the tracked assembly (status certified: every step proven)."""
    from ..results import Solution, Status

    items = []
    for p in track.poses:
        angles = np.array(list(p.passive_angles.values()))
        sol = Solution(angles, angles, angles, 0, p.platform_rotation, p.residual,
                       mechanism.singularity({**p.inputs, **p.passive_angles}).kind, Status.CERTIFIED)
        items.append((p.row, np.array(list(p.inputs.values())), tuple(p.passive_angles), (sol,)))
    return solution_rows(mechanism, items)


def solution_rows(mechanism, items):
    """The results table of ``items``: (input index, its inputs (radians), the unknowns' names, its
    solutions) each; an input without solutions gets one row with empty solution columns."""
    import pandas as pd

    names = list(mechanism.loop_unknowns)
    actuated = list(mechanism.actuated)
    idx, sol, status, sing, resid, measure, angles, rots, inp = [], [], [], [], [], [], [], [], []
    nan_rot = np.full((3, 3), np.nan)
    for index, row, unknowns, solutions in items:
        row = np.asarray(row, dtype=float)
        order = None if tuple(unknowns) == tuple(names) else [list(unknowns).index(n) for n in names]
        entries = solutions or (None,)
        for j, s in enumerate(entries):
            idx.append(index)
            inp.append(row)
            if s is None:
                sol.append(pd.NA)
                status.append(None)
                sing.append(None)
                resid.append(np.nan)
                measure.append(np.nan)
                angles.append(np.full(len(names), np.nan))
                rots.append(nan_rot)
                continue
            a = np.asarray(s.angles, dtype=float)
            a = a if order is None else a[order]
            sol.append(j + 1)                  # numbered from 1, as printed tables and the JSON
            status.append(str(s.status))
            sing.append(s.singularity)
            resid.append(np.nan if s.residual is None else float(s.residual))
            angles.append(a)
            rots.append(nan_rot if s.platform_rotation is None else np.asarray(s.platform_rotation, dtype=float))
            joints = {**dict(zip(actuated, (float(v) for v in row))), **dict(zip(names, (float(v) for v in a)))}
            try:
                measure.append(mechanism.parallel_measure(joints))
            except ValueError:             # a joint the loop equations do not carry: no Jacobian
                measure.append(np.nan)
    rots = np.array(rots).reshape(-1, 3, 3)
    quats = np.full((len(rots), 4), np.nan)
    known = np.isfinite(rots).all(axis=(1, 2))
    if known.any():
        quats[known] = quaternions_from_rotations(rots[known])
    data = {"input": np.array(idx, dtype=np.int64)}
    inp = np.array(inp, dtype=float).reshape(-1, len(actuated))
    data.update({n: inp[:, j] for j, n in enumerate(actuated)})
    data["solution"] = pd.array(sol, dtype="Int64")
    data["status"] = pd.array(status, dtype="string")
    angles = np.array(angles, dtype=float).reshape(-1, len(names))
    data.update({n: angles[:, j] for j, n in enumerate(names)})
    data.update({c: quats[:, j] for j, c in enumerate(QUATERNION_COLUMNS)})
    flat = rots.reshape(-1, 9)
    data.update({c: flat[:, j] for j, c in enumerate(ROTATION_COLUMNS)})
    data["residual"] = np.array(resid, dtype=float)
    data["singularity"] = pd.array(sing, dtype="string")
    data["parallel_measure"] = np.array(measure, dtype=float)
    return pd.DataFrame(data, columns=list(columns(mechanism)))


def empty_frame(mechanism):
    """A results table with no rows (every column with its type)."""
    return report_rows(mechanism, (), 0, np.empty((0, len(mechanism.actuated))))
