"""Assembly-mode maps: how many solutions, and of which status, over a 2-D grid of actuator inputs.

The number of real assemblies changes only where the actuator inputs cross a parallel singularity
(two assembly modes meet and vanish, or appear), so the colour boundaries of the count drawn over a
grid are those singularity curves, sampled at the grid's resolution. Each grid point also carries how
many of its entries are certified, singular, or flagged (unverified, cluster, continuum: the count
there is not proven), and the smallest normalized parallel-singularity measure over its solutions
(:meth:`spherekin.mechanism.SphericalMechanism.parallel_measure`: 0 on a singularity). A map may also
carry the certified singular set of its plane (``singular_set``, :func:`spherekin.singular`): the cells
where the count can change, proven, drawn over the colours by :func:`spherekin.plot.plot_assembly_map`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from .inputs import GridAxis

__all__ = ["MAP_COLUMNS", "FLAGGED", "AssemblyMap", "aggregate"]

#: The columns of a results table a map reads.
MAP_COLUMNS = ("input", "solution", "status", "parallel_measure")
#: Statuses whose entries leave the count unproven (docs/results-format.md).
FLAGGED = ("unverified", "cluster", "continuum")
#: A singular set belongs to a map when its fixed joints' readings agree within this (radians): both are
#: the same parsed numbers, so any difference beyond rounding is another plane.
FIXED_MATCH = 1e-12


@dataclass(frozen=True, eq=False)
class AssemblyMap:
    """Per grid point (arrays of shape (len(x.values), len(y.values)), x first): ``solutions`` (the
    number of entries), ``certified``, ``singular``, ``flagged`` (module doc), ``measure`` (smallest
    parallel measure over the solutions; NaN without solution). ``fixed``: the other actuated joints
    (radians); ``mechanism``: its name. ``singular_set``: None, or the certified parallel-singular set
    (:class:`spherekin.results.SingularSet`) of the map's plane (same x and y joints, same fixed joints):
    outside its cells the count cannot change (``singular`` above is a count of entries, not this set)."""

    x: GridAxis
    y: GridAxis
    fixed: Mapping[str, float]
    mechanism: str
    solutions: np.ndarray = field(repr=False)
    certified: np.ndarray = field(repr=False)
    singular: np.ndarray = field(repr=False)
    flagged: np.ndarray = field(repr=False)
    measure: np.ndarray = field(repr=False)
    singular_set: object = field(default=None, repr=False)
    #: Under tolerances (the mechanism's, issue 45), per grid point: the largest proven worst-case
    #: rotation error over its assemblies (radians; NaN where one is not proven, or none); and whether
    #: its count is proven constant over the tolerances (1), proven to change (0: a singular
    #: configuration within them), or undecided (NaN). None for a map without tolerances.
    worst_error: np.ndarray | None = field(default=None, repr=False)
    count_constant: np.ndarray | None = field(default=None, repr=False)

    def __post_init__(self):
        s = self.singular_set
        if s is None:
            return
        plane = (s.x[0], None if s.y is None else s.y[0])
        if plane != (self.x.name, self.y.name):
            raise ValueError(f"singular_set: expected the map's plane {self.x.name} x {self.y.name}, got "
                             f"{plane[0]} x {plane[1]}")
        if set(s.fixed) != set(self.fixed) or any(abs(s.fixed[k] - self.fixed[k]) > FIXED_MATCH for k in s.fixed):
            raise ValueError(f"singular_set: expected the map's fixed joints {dict(self.fixed)}, got {dict(s.fixed)}")

    @property
    def proven(self) -> np.ndarray:
        """Whether every entry of a grid point is certified (its count carries a proof)."""
        return self.certified == self.solutions

    def histogram(self) -> dict[int, int]:
        """Number of grid points per number of solutions."""
        values, counts = np.unique(self.solutions, return_counts=True)
        return {int(v): int(c) for v, c in zip(values, counts)}

    def table(self) -> str:
        """A summary: grid points per number of solutions, with how many of them are fully certified."""
        rows = ["  solutions  grid points  of which every entry certified"]
        for n, c in self.histogram().items():
            proven = int(np.sum(self.proven & (self.solutions == n)))
            rows.append(f"  {n:9d}  {c:11d}  {proven:30d}")
        rows.append(f"  entries: {int(self.certified.sum())} certified, {int(self.singular.sum())} singular, "
                    f"{int(self.flagged.sum())} flagged (unverified, cluster or continuum)")
        if self.worst_error is not None:
            rows.append("  " + self.tolerance_text())
        if self.singular_set is not None:
            counts = self.singular_set.counts()
            rows.append(f"  certified singular set (cells <= {self.singular_set.tol:.3g} rad): "
                        f"{counts.get('singular', 0)} singular, {counts.get('unresolved', 0)} unresolved cell(s)"
                        + ("" if self.singular_set.complete else " (incomplete)"))
            if self.singular_set.cross_check is not None:
                rows.append("  " + self.singular_set.cross_check.text())
        return "\n".join(rows)

    def tolerance_text(self) -> str:
        """One line: the worst-case rotation error over the map and where the count may change."""
        err = self.worst_error
        known = np.isfinite(err)
        c = self.count_constant
        parts = []
        if known.any():
            parts.append(f"worst-case rotation error up to {np.degrees(err[known].max()):.4g} deg (median "
                         f"{np.degrees(np.median(err[known])):.4g} deg) at {int(known.sum())} grid point(s) with every "
                         "assembly bounded")
        parts.append(f"count proven constant at {int(np.sum(c == 1))} of {c.size} grid points, proven to change "
                     f"(a singular configuration within the tolerances) at {int(np.sum(c == 0))}, undecided at "
                     f"{int(np.sum(np.isnan(c)))}")
        return "under tolerances: " + "; ".join(parts)

    def frame(self):
        """The map as a table: one row per grid point (x, y, solutions, certified, singular, flagged, measure;
        under tolerances also worst_case_rotation_error and count_constant_over_tolerances)."""
        import pandas as pd

        xx, yy = np.meshgrid(self.x.values, self.y.values, indexing="ij")
        data = {self.x.name: xx.ravel(), self.y.name: yy.ravel(), "solutions": self.solutions.ravel(),
                "certified": self.certified.ravel(), "singular": self.singular.ravel(),
                "flagged": self.flagged.ravel(), "parallel_measure": self.measure.ravel()}
        if self.worst_error is not None:
            data["worst_case_rotation_error"] = self.worst_error.ravel()
            data["count_constant_over_tolerances"] = self.count_constant.ravel()
        return pd.DataFrame(data)


#: A map's grid point counts as on a cell's edge within this (radians): the grid's values and the cells' edges
#: are computed apart, each to rounding (~1e-16 rad); far above it, far below any grid step.
EDGE_SLACK = 1e-9


def grid_cross_check(amap: "AssemblyMap", sset):
    """The singular set ``sset`` of ``amap``'s plane held against its proven counts (issue 40 item 3): every two
    neighbours of the grid (along x, along y) whose counts are both proven (every entry certified) and differ
    must have a cell of ``sset`` (any status) meeting the segment between them, since outside the cells the
    count cannot change. A :class:`spherekin.results.CrossCheck` of the pairs that do not."""
    from ..results import CrossCheck

    xs, ys = np.asarray(amap.x.values, float), np.asarray(amap.y.values, float)
    lo = np.array([[b.x[0], b.y[0]] for b in sset.boxes]).reshape(-1, 2) - EDGE_SLACK
    hi = np.array([[b.x[1], b.y[1]] for b in sset.boxes]).reshape(-1, 2) + EDGE_SLACK
    proven, n = amap.proven, amap.solutions
    out = []
    for axis in (0, 1):
        a = (slice(None, -1), slice(None)) if axis == 0 else (slice(None), slice(None, -1))
        b = (slice(1, None), slice(None)) if axis == 0 else (slice(None), slice(1, None))
        for i, j in zip(*np.nonzero(proven[a] & proven[b] & (n[a] != n[b]))):
            i2, j2 = (i + 1, j) if axis == 0 else (i, j + 1)
            seg_lo = np.array([min(xs[i], xs[i2]), min(ys[j], ys[j2])])
            seg_hi = np.array([max(xs[i], xs[i2]), max(ys[j], ys[j2])])
            if not np.any(np.all((lo <= seg_hi) & (hi >= seg_lo), axis=1)):
                out.append(((float(seg_lo[0]), float(seg_hi[0]), float(seg_lo[1]), float(seg_hi[1])),
                            (int(n[i, j]), int(n[i2, j2]))))
    return CrossCheck(int(n.size), int(proven.sum()), tuple(out))


def aggregate(frame, x: GridAxis, y: GridAxis, fixed: Mapping[str, float], mechanism: str, *,
              singular_set=None) -> AssemblyMap:
    """The map of a results table (:mod:`spherekin.batch.rows`) of the grid x by y (input k = i * ny + j),
    with ``singular_set`` (:class:`AssemblyMap`) if given."""
    shape = (len(x.values), len(y.values))
    size = shape[0] * shape[1]
    idx = frame["input"].to_numpy()
    if len(idx) and (idx.min() < 0 or idx.max() >= size):
        raise ValueError(f"results: input {int(idx.max())} is outside the {shape[0]} x {shape[1]} grid")
    has = frame["solution"].notna().to_numpy()
    status = frame["status"].astype("string").fillna("").to_numpy()

    def count(mask):
        return np.bincount(idx[mask], minlength=size).reshape(shape)

    measure = np.full(size, np.inf)
    m = frame["parallel_measure"].to_numpy(dtype=float)
    ok = has & np.isfinite(m)
    np.minimum.at(measure, idx[ok], m[ok])
    measure[np.isinf(measure)] = np.nan
    worst = constant = None
    if "worst_case_rotation_error" in frame.columns:
        err = frame["worst_case_rotation_error"].to_numpy(dtype=float)
        worst = np.full(size, -np.inf)
        np.maximum.at(worst, idx[has], np.where(np.isnan(err[has]), np.inf, err[has]))   # one unproven: NaN
        worst[~np.isfinite(worst)] = np.nan
        flag = frame["count_constant_over_tolerances"].astype("string").fillna("").to_numpy()
        constant = np.full(size, np.nan)
        constant[idx[flag == "true"]] = 1.0
        constant[idx[flag == "false"]] = 0.0
        worst, constant = worst.reshape(shape), constant.reshape(shape)
    return AssemblyMap(x, y, dict(fixed), mechanism, count(has), count(has & (status == "certified")),
                       count(has & (status == "singular")), count(has & np.isin(status, FLAGGED)),
                       measure.reshape(shape), singular_set, worst, constant)
