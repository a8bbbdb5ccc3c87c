"""Families of actuator inputs: a CSV file, a grid, or an array; every one checked before any solve.

An :class:`InputSet` is K rows of actuator angles (radians, one column per actuated joint in the
mechanism's order) and, for error messages, where each row came from. A grid is given per joint as
``name=lo:hi:n`` (n points from lo to hi, both included, as ``numpy.linspace``; lo and hi as numbers or
text such as ``-pi`` or ``3*pi/4``) plus ``name=value`` for the joints held fixed; the first grid joint
varies slowest (row k = i * n2 + j for two grid joints). A CSV has a header naming exactly the
actuated joints (any order) and one row per input; blank lines are skipped, and a row's number is
its position among the data rows, counted from 0 (the ``input`` column of a batch's results).
"""

from __future__ import annotations

import csv
import math
from collections import Counter
import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from ..core.angles import beyond_turn, in_range_many, turn_error
from ..mechanism.checks import check_ascii, parse_angle, shown

__all__ = ["MAX_INPUTS", "GridAxis", "InputSet", "parse_grid", "parse_range", "parse_fix", "grid_inputs", "read_inputs_csv",
           "array_inputs", "check_inputs"]

#: Largest number of inputs of one job. Reason: the inputs themselves are held in memory (10^7 rows of
#: 3 angles are 240 MB); a grid spec beyond this is almost surely a typo (64000 for 64), and a
#: family that large is better split into jobs that each finish.
MAX_INPUTS = 10_000_000

#: Columns of a CSV header named in an error about them; the rest are counted. Reason: an error is
#: one line, and a header of 80,000 wrong columns is a wrong file, recognised by its first few.
NAMED_COLUMNS = 5


@dataclass(frozen=True)
class GridAxis:
    """One joint swept by a grid: its name and values (radians, increasing)."""

    name: str
    values: np.ndarray = field(repr=False)

    @property
    def spec(self) -> str:
        return f"{self.name}={self.values[0]:.6g}:{self.values[-1]:.6g}:{len(self.values)}"


@dataclass(frozen=True, eq=False)
class InputSet:
    """K actuator inputs: ``values`` (K, A) radians, columns ``names`` (the actuated joints in the
    mechanism's order). ``axes``/``fixed``: the grid it was built from (empty for a file or an array);
    ``lines``: the CSV line of each row (None otherwise); ``source``: the file or "grid"/"array";
    ``checked_for``: the mechanism :func:`check_inputs` checked the rows against (None: not checked), so
    that the batch API does not check a set the command line built and checked again."""

    names: tuple[str, ...]
    values: np.ndarray = field(repr=False)
    source: str
    axes: tuple[GridAxis, ...] = ()
    fixed: Mapping[str, float] = field(default_factory=dict)
    lines: np.ndarray | None = field(default=None, repr=False)
    checked_for: object = field(default=None, repr=False, compare=False)

    def __len__(self) -> int:
        return len(self.values)

    def where(self, k: int) -> str:
        """Where row ``k`` came from, for an error message."""
        if self.lines is not None:
            return f"{self.source} line {int(self.lines[k])} (input {k})"
        if self.axes:
            idx = np.unravel_index(k, tuple(len(a.values) for a in self.axes))
            at = ", ".join(f"{a.name} = {a.values[i]:.6g}" for a, i in zip(self.axes, idx))
            return f"grid point {k} ({at})"
        return f"inputs row {k}"


def parse_grid(spec: str, degrees: bool = False) -> GridAxis:
    """A grid axis from ``"name=lo:hi:n"`` (module doc); lo, hi in degrees with ``degrees`` (unless
    written with pi). ValueError naming the spec for anything else."""
    name, sep, rest = str(spec).partition("=")
    parts = rest.split(":")
    if not sep or not name.strip() or len(parts) != 3:
        raise ValueError(f"--grid {spec!r}: expected name=lo:hi:n, e.g. beta1=-pi:pi:64")
    name, lo, hi = parse_range(f"{name}={parts[0]}:{parts[1]}", "--grid", degrees=degrees)
    try:
        n = int(check_ascii(f"--grid {name} (n)", parts[2]))
    except ValueError:
        raise ValueError(f"--grid {name}: expected a whole number of points n >= 2 (digits 0-9), "
                         f"got {shown(parts[2])}") from None
    if n < 2:
        raise ValueError(f"--grid {name}: expected n >= 2 points (hold a joint still with --fix {name}=value), got {n}")
    return GridAxis(name, np.linspace(lo, hi, n))


def parse_range(spec: str, option: str, degrees: bool = False) -> tuple[str, float, float]:
    """``"name=lo:hi"`` -> (name, lo, hi) radians (degrees with ``degrees`` unless written with pi), as
    :func:`parse_grid` reads its ends; ``option``: the option named in errors ("--x")."""
    name, sep, rest = str(spec).partition("=")
    parts = rest.split(":")
    if not sep or not name.strip() or len(parts) != 2:
        raise ValueError(f"{option} {spec!r}: expected NAME=LO:HI, e.g. beta1=-pi:pi")
    name = name.strip()
    lo = parse_angle(f"{option} {name} (lo)", parts[0], degrees=degrees)
    hi = parse_angle(f"{option} {name} (hi)", parts[1], degrees=degrees)
    if not lo < hi:
        raise ValueError(f"{option} {name}: expected lo < hi, got lo = {lo:.6g}, hi = {hi:.6g}")
    return name, lo, hi


def parse_fix(spec: str, degrees: bool = False) -> tuple[str, float]:
    """``"name=value"`` -> (name, radians)."""
    name, sep, value = str(spec).partition("=")
    if not sep or not name.strip() or not value.strip():
        raise ValueError(f"--fix {spec!r}: expected name=value, e.g. beta3=0.5")
    return name.strip(), parse_angle(f"--fix {name.strip()}", value, degrees=degrees)


def grid_inputs(mechanism, axes: Sequence[GridAxis | str], fixed: Mapping[str, float] | Sequence[str] = (),
                degrees: bool = False) -> InputSet:
    """The inputs of a grid: ``axes`` (GridAxis or "name=lo:hi:n") and ``fixed`` (name -> radians, or
    "name=value" strings); every actuated joint exactly once. Checked against the joint ranges."""
    axes = tuple(a if isinstance(a, GridAxis) else parse_grid(a, degrees) for a in axes)
    if isinstance(fixed, Mapping):
        fixed = {str(k): parse_angle(f"--fix {k}", v) for k, v in fixed.items()}
    else:
        pairs = [parse_fix(s, degrees) for s in fixed]
        fixed = dict(pairs)
        if len(fixed) != len(pairs):
            raise ValueError(f"--fix: a joint is given twice in {list(fixed)}")
    names = tuple(mechanism.actuated)
    given = [a.name for a in axes] + list(fixed)
    unknown = [n for n in given if n not in names]
    if unknown:
        raise ValueError(f"--grid/--fix: {', '.join(unknown)} is not an actuated joint of this mechanism; "
                         f"expected the actuated joints {', '.join(names)}")
    twice = sorted({n for n in given if given.count(n) > 1})
    if twice:
        raise ValueError(f"--grid/--fix: {', '.join(twice)} given more than once")
    missing = [n for n in names if n not in given]
    if missing:
        raise ValueError(f"--grid/--fix: no value for {', '.join(missing)}; give every actuated joint "
                         f"({', '.join(names)}) a --grid or a --fix")
    if not axes:
        raise ValueError("--grid: expected at least one grid axis (name=lo:hi:n)")
    total = math.prod(len(a.values) for a in axes)
    if total > MAX_INPUTS:
        raise ValueError(f"--grid: {total} points is more than one job takes ({MAX_INPUTS:,}); split the job")
    mesh = np.meshgrid(*(a.values for a in axes), indexing="ij")
    cols = {a.name: m.ravel() for a, m in zip(axes, mesh)}
    values = np.column_stack([cols[n] if n in cols else np.full(total, fixed[n]) for n in names])
    return check_inputs(mechanism, InputSet(names, values, "grid", axes, dict(fixed)))


def read_inputs_csv(mechanism, path, degrees: bool = False, key: str = "--inputs") -> InputSet:
    """The inputs of a CSV file (module doc); with ``degrees`` its numbers are degrees. One
    ValueError naming the line and column of the first problem (a missing or extra column, an empty
    cell, text, NaN, a digit other than 0-9, a field over csv's size limit, a value outside a joint
    range); ``key``: the option that named the file."""
    path = Path(path)
    names = tuple(mechanism.actuated)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise ValueError(f"{key} {path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"{key} {path}: cannot read it ({exc})") from None
    reader = csv.reader(text.splitlines())
    try:
        rows = [(k + 1, r) for k, r in enumerate(reader) if any(c.strip() for c in r)]
    except csv.Error as exc:              # a field over csv.field_size_limit() characters, ...
        raise ValueError(f"{path} line {reader.line_num}: not a CSV of numbers: {exc}") from None
    if not rows:
        raise ValueError(f"{path}: empty; expected a header line naming the actuated joints ({', '.join(names)})")
    header_line, header = rows[0]
    header = [h.strip() for h in header]
    counts = Counter(header)
    twice = [h for h, c in counts.items() if c > 1]
    if twice:
        raise ValueError(f"{path} line {header_line}: column{'s' if len(twice) > 1 else ''} {_some(twice, str)} "
                         f"appear{'' if len(twice) > 1 else 's'} more than once")
    extra = [h for h in counts if h not in names]
    missing = [n for n in names if n not in counts]
    if extra or missing:
        what = "; ".join(filter(None, [f"missing column(s) {', '.join(missing)}" if missing else "",
                                       f"unexpected column(s) {_some(extra)}" if extra else ""]))
        raise ValueError(f"{path} line {header_line}: {what}; expected exactly one column per actuated joint "
                         f"({', '.join(names)})")
    if len(rows) == 1:
        raise ValueError(f"{path}: no input rows after the header")
    if len(rows) - 1 > MAX_INPUTS:
        raise ValueError(f"{path}: {len(rows) - 1} rows is more than one job takes ({MAX_INPUTS:,}); split the job")
    order = [header.index(n) for n in names]
    values = np.empty((len(rows) - 1, len(names)))
    lines = np.empty(len(rows) - 1, dtype=np.int64)
    for k, (line, row) in enumerate(rows[1:]):
        if len(row) != len(header):
            raise ValueError(f"{path} line {line}: expected {len(header)} values ({', '.join(header)}), got {len(row)}")
        for j, col in enumerate(order):
            cell = row[col].strip()
            where = f"{path} line {line}, column {names[j]}"
            if not cell:
                raise ValueError(f"{where}: empty; expected a number (radians"
                                 f"{' or degrees with --degrees' if not degrees else ''})")
            check_ascii(where, cell)
            try:
                values[k, j] = parse_angle(where, cell, degrees=degrees)
            except ValueError:
                raise ValueError(f"{where}: expected a finite number, got {shown(cell)}") from None
        lines[k] = line
    return check_inputs(mechanism, InputSet(names, values, str(path), lines=lines))


def _some(columns: Sequence[str], show=shown) -> str:
    """The first NAMED_COLUMNS of ``columns`` (each as ``show`` writes it), and how many more there are."""
    named = ", ".join(show(c) for c in columns[:NAMED_COLUMNS])
    return named if len(columns) <= NAMED_COLUMNS else f"{named} and {len(columns) - NAMED_COLUMNS} more"


def array_inputs(mechanism, inputs) -> InputSet:
    """An InputSet of an array (K, A) (radians, columns in the order of ``mechanism.actuated``), of a
    pandas DataFrame with one column per actuated joint, or an InputSet (checked again)."""
    names = tuple(mechanism.actuated)
    if isinstance(inputs, InputSet):
        if inputs.names != names:
            raise ValueError(f"inputs: columns {inputs.names} are not this mechanism's actuated joints {names}")
        return inputs if inputs.checked_for is mechanism else check_inputs(mechanism, inputs)
    if hasattr(inputs, "columns") and hasattr(inputs, "to_numpy"):        # a DataFrame
        cols = [str(c) for c in inputs.columns]
        extra, missing = [c for c in cols if c not in names], [n for n in names if n not in cols]
        if extra or missing:
            raise ValueError(f"inputs: expected exactly the columns {', '.join(names)}, got {', '.join(cols)}")
        inputs = inputs[list(names)].to_numpy()
    try:
        values = np.asarray(inputs, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"inputs: expected an array of numbers of shape (K, {len(names)}), got {type(inputs).__name__}") from None
    if values.ndim == 1 and len(names) == 1:
        values = values[:, None]
    if values.ndim != 2 or values.shape[1] != len(names) or not len(values):
        raise ValueError(f"inputs: expected an array of shape (K, {len(names)}) (one column per actuated joint: "
                         f"{', '.join(names)}), got shape {values.shape}")
    if len(values) > MAX_INPUTS:
        raise ValueError(f"inputs: {len(values)} rows is more than one job takes ({MAX_INPUTS:,}); split the job")
    return check_inputs(mechanism, InputSet(names, values.copy(), "array"))


def check_inputs(mechanism, inputs: InputSet) -> InputSet:
    """``inputs`` marked as checked for ``mechanism``; ValueError naming the first row (and where it came
    from) that is not finite, is more than a full turn from 0 (:data:`~spherekin.core.angles.MAX_INPUT_ANGLE`)
    or leaves a joint range."""
    bad = ~np.isfinite(inputs.values)
    if bad.any():
        k, j = np.argwhere(bad)[0]
        raise ValueError(f"{inputs.where(int(k))}: {inputs.names[j]} is {float(inputs.values[k, j])}; expected a finite angle")
    far = beyond_turn(inputs.values)
    if far.any():
        k, j = np.argwhere(far)[0]
        raise ValueError(turn_error(f"{inputs.where(int(k))}: {inputs.names[j]}", inputs.values[k, j]))
    for j, name in enumerate(inputs.names):
        rng = mechanism.joint(name).range
        ok = in_range_many(inputs.values[:, j], rng)
        if not ok.all():
            k = int(np.flatnonzero(~ok)[0])
            raise ValueError(f"{inputs.where(k)}: {name} = {float(inputs.values[k, j])!r} is outside its joint range "
                             f"[{rng[0]!r}, {rng[1]!r}]")
    return dataclasses.replace(inputs, checked_for=mechanism)
