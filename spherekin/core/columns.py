"""The column names of spherekin's tables, and the names a joint may not take because of them.

A results table (docs/results-format.md) has a column per actuated joint and per passive unknown,
named by the joint, between fixed columns; a track's frame and an assembly map's table likewise.
A joint named like a fixed column would overwrite it (CSV) or make the table unwritable (Parquet:
duplicate column names), so the mechanism layer refuses such names with :data:`RESERVED_COLUMNS`.
Here, below every layer that names a column, so that the mechanism (which builds joints) and the
results (which build tables) read one list.
"""

from __future__ import annotations

from .orientation import QUATERNION_COLUMNS, ROTATION_COLUMNS

__all__ = ["ENTRY_COLUMNS", "MEASURE_COLUMNS", "TOLERANCE_COLUMNS", "TRACK_COLUMNS", "MAP_TABLE_COLUMNS", "RESERVED_COLUMNS",
           "table_columns"]

#: After the actuated joints of a results table: which entry of the input, and its status.
ENTRY_COLUMNS = ("solution", "status")
#: After the platform rotation of a results table: the closure residual, the singularity class and
#: the parallel measure of the entry.
MEASURE_COLUMNS = ("residual", "singularity", "parallel_measure")
#: The columns of a track's frame (:meth:`spherekin.trust.continuation.Track.frame`) besides the joints
#: and the rotation.
TRACK_COLUMNS = ("row", "proven_steps")
#: The columns of an assembly map's table (:meth:`spherekin.batch.maps.AssemblyMap.frame`) besides
#: its two joints.
MAP_TABLE_COLUMNS = ("solutions", "certified", "singular", "flagged", "parallel_measure")


def table_columns(actuated, unknowns, tolerances: bool = False) -> tuple[str, ...]:
    """The columns of the results table (:func:`spherekin.results.solution_table`) of a mechanism with
    these actuated joints and passive unknowns (names); ``tolerances``: of a mechanism with tolerances
    (then :data:`TOLERANCE_COLUMNS` last)."""
    return ("input", *actuated, *ENTRY_COLUMNS, *unknowns, *QUATERNION_COLUMNS, *ROTATION_COLUMNS,
            *MEASURE_COLUMNS, *(TOLERANCE_COLUMNS if tolerances else ()))


#: The last columns of the results table of a mechanism with tolerances (issue 45): each entry's
#: proven worst-case rotation error and the lower bound a geometry reaches (radians; empty where not
#: proven), and whether its input's count is proven constant over the tolerances ("true", "false":
#: a singular configuration proven within them; empty: undecided).
TOLERANCE_COLUMNS = ("worst_case_rotation_error", "worst_case_rotation_error_lower_bound",
                     "count_constant_over_tolerances")
#: Every fixed column of a table that also has a column per joint: no joint may be named so.
RESERVED_COLUMNS = tuple(dict.fromkeys((*table_columns((), (), True), *TRACK_COLUMNS, *MAP_TABLE_COLUMNS)))
