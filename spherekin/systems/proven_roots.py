"""The roots a complete count proves for a chunk of inputs, as arrays: what its reports read.

The complete counts (:mod:`spherekin.systems.complete`, :mod:`spherekin.systems.one_loop`) prove a
whole chunk of inputs at once and hand over the real roots they kept as arrays: which input owns
each, its passive readings (radians) and their enclosures, its platform rotation and residual.
:class:`ChunkRoots` puts them in the trust layer's order (by input, then by angles), classifies every
configuration in one call (:meth:`~spherekin.mechanism.SphericalMechanism.singularities`) and gives
each input's entries two ways: their table columns (:meth:`ChunkRoots.arrays`, read by the results
table: batch, map, ``frame()``) and, only when someone asks for them, :class:`~spherekin.results.Solution`
objects (:meth:`ChunkRoots.entries`, built for the whole chunk at once). Issue 44 item 2: results for
many inputs without an object per solution.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ..results import Solution, SolutionArrays, Status

__all__ = ["ChunkRoots", "ANGLE_ORDER_DIGITS", "PROVEN_CHUNK"]

#: Inputs a complete count proves as one array program by default (its ``Compiled.chunk``). Reason:
#: measured (``python -m benchmarks.bench_engine --baseline none --chunk C``, C = 256 ... 4096): its
#: cost per chunk is fixed (a few hundred interval operations whatever the chunk holds), so the
#: one-loop count's rate rises from ~13-27k/s at 256 inputs to ~33-37k/s at 1,024 and no further;
#: the 3-RRR's within the noise; 1,024 inputs of 8 roots are ~1 MB of arrays. The inputs it passes
#: on are searched in chunks of the next system's own size.
PROVEN_CHUNK = 1024

#: Entries of one input are ordered by their angles rounded to this many decimals (radians), as the
#: trust layer orders its solutions (:mod:`spherekin.trust.solutions`). Reason: two certified roots
#: of one input are far further apart than 1e-9, and rounding keeps the order of a root that moved
#: by a last bit from one run to the next.
ANGLE_ORDER_DIGITS = 9


class ChunkRoots:
    """Kept roots of a chunk (R of them, in any order) and the K inputs they belong to.

    ``owner`` (R,) the input of each root; ``angles`` (R, M) its passive readings (radians, in the order
    of ``names``); ``enclosures()``: (lo, hi) (R, M), their enclosures (called only when the entries are
    built: the table does not read them); ``rotations`` (R, 3, 3) or None; ``residual``
    (R,); ``evidence(r)``: the system's own evidence of root r (a dict: its certificate), to which the
    margins, the singularity and the enclosure are added.
    """

    def __init__(self, mechanism, names: tuple, values: np.ndarray, owner, angles, enclosures, rotations, residual,
                 evidence: Callable[[int], dict]):
        self.mechanism, self.names, self.values = mechanism, tuple(names), np.asarray(values, dtype=float)
        owner = np.asarray(owner, dtype=np.int64)
        angles = np.asarray(angles, dtype=float).reshape(len(owner), len(self.names))
        keys = np.round(angles, ANGLE_ORDER_DIGITS)
        order = np.lexsort((*keys.T[::-1], owner)) if len(owner) else np.zeros(0, dtype=np.int64)
        self.order = order                                          # sorted position -> given row
        self.owner = owner[order]
        self.angles = angles[order]
        self._enclosures = enclosures
        self.rotations = None if rotations is None else np.asarray(rotations, dtype=float)[order]
        self.residual = np.asarray(residual, dtype=float)[order]
        self._evidence = evidence
        at = self.values[self.owner]
        joints = {**{nm: at[:, i] for i, nm in enumerate(mechanism.actuated)},
                  **{nm: self.angles[:, j] for j, nm in enumerate(self.names)}}
        reports = mechanism.singularities(joints) if len(order) else []
        self.reports = reports
        kinds = [rep.kind for rep in reports]
        self.kind = np.empty(len(kinds), dtype=object)
        self.kind[:] = kinds
        self.status = np.empty(len(kinds), dtype=object)
        self.status[:] = [str(Status.CERTIFIED if k == "regular" else Status.SINGULAR) for k in kinds]
        self.start = np.searchsorted(self.owner, np.arange(len(self.values) + 1))
        self._entries: tuple | None = None

    def count(self, k: int) -> int:
        """How many entries input k has."""
        return int(self.start[k + 1] - self.start[k])

    def arrays(self, k: int) -> SolutionArrays:
        """Input k's entries as the table's columns (no Solution built)."""
        part = slice(self.start[k], self.start[k + 1])
        rots = np.full((self.count(k), 3, 3), np.nan) if self.rotations is None else self.rotations[part]
        return SolutionArrays(self.angles[part], self.status[part], self.kind[part], self.residual[part], rots)

    def entries(self, k: int) -> tuple:
        """Input k's :class:`~spherekin.results.Solution` entries (every input's built on the first call)."""
        if self._entries is None:
            self._entries = self._build()
        return self._entries[self.start[k]:self.start[k + 1]]

    def _build(self) -> tuple:
        mech = self.mechanism
        lo, hi = (np.asarray(x, dtype=float)[self.order] for x in self._enclosures())
        out = []
        for r, given in enumerate(self.order):
            rep = self.reports[r]
            ev = {"serial_margin": float(rep.serial_margin), "parallel_margin": float(rep.parallel_margin),
                  "singularity": rep.kind, "krawczyk_certified": True, **self._evidence(int(given)),
                  "root_enclosure": {"lo": lo[r].tolist(), "hi": hi[r].tolist()}}
            k = int(self.owner[r])
            out.append(Solution(
                self.angles[r], lo[r], hi[r], 1,
                platform_rotation=None if self.rotations is None else self.rotations[r],
                residual=float(self.residual[r]), singularity=rep.kind, status=Status(self.status[r]), evidence=ev,
                unknowns=self.names, actuated=dict(zip(mech.actuated, (float(v) for v in self.values[k])))))
        return tuple(out)
