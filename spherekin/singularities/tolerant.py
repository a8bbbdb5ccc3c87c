"""The singular set under tolerances (issue 45): the region of a plane of inputs a real robot must avoid.

A cell of the plane (a box of its two inputs, the other actuated joints fixed) is *free under the
tolerances* when the complete count over every geometry within the tolerances and every input of the
cell (the input tolerance widened by the cell's half-widths) proves the real count constant
(:func:`spherekin.trust.tolerances.count_over`): no parallel singularity there, for any such
mechanism. The plane is cut into cells (a quadtree: a cell not proven free is split in four until
its sides are at most ``tol``); the cells left are ``singular`` (two geometries and inputs in the
cell proven to have different counts: a singular configuration lies there, for some built
mechanism) or ``unresolved``. Everything outside them is proven free for every geometry within the
tolerances: the widened singular set, as a :class:`spherekin.results.SingularSet` (system
"tolerances"; no cusps searched).
"""

from __future__ import annotations

import time

import numpy as np

from ..problem import as_mechanism
from ..results import CuspSearch, SingularBox, SingularSet, SingularStats
from ..trust.tolerances import count_over, not_analysed

__all__ = ["MAX_CELLS", "tolerant_singular"]

#: Cells tested at most (each ~10-20 ms: the complete count over the tolerances). Reason: a plane of
#: two radians at cells of 0.05 rad near a curve is ~2,000 cells; past the cap the untested cells are
#: reported unresolved (the set stays sound, not complete).
MAX_CELLS = 20_000


def tolerant_singular(mechanism, tolerances, x, y=None, fixed=None, *, tol: float, max_cells: int = MAX_CELLS,
                      budget=None) -> SingularSet:
    """The cells of the plane ``x`` by ``y`` ((name, lo, hi), radians; ``y`` None: a line) not proven
    free of parallel singularities for every geometry within ``tolerances`` (module doc), at most ``tol``
    (radians) wide; ``fixed``: the other actuated joints (radians). ``budget``: a
    :class:`spherekin.budget.Budget` checked between cells (a stop leaves the rest unresolved)."""
    mech = as_mechanism(mechanism)
    why = not_analysed(mech)
    if why is not None:
        raise ValueError(f"tolerances: {why}")
    if not (isinstance(tol, (int, float)) and np.isfinite(tol) and tol > 0):
        raise ValueError(f"tol: expected a positive cell width (radians), got {tol!r}")
    fixed = dict(fixed or {})
    axes = [a for a in (x, y) if a is not None]
    names = [a[0] for a in axes]
    missing = [n for n in mech.actuated if n not in names and n not in fixed]
    if missing:
        raise ValueError(f"fixed: expected a reading for {', '.join(missing)} (the actuated joints off the plane)")
    t0 = time.perf_counter()
    todo = [(tuple(float(a[1]) for a in axes), tuple(float(a[2]) for a in axes))]
    boxes, tested, stopped = [], 0, None
    while todo:
        lo, hi = todo.pop()
        if stopped is None and budget is not None:
            stopped = budget.exhausted()
        if stopped is not None or tested >= max_cells:
            stopped = stopped or "cell cap"
            boxes.append((lo, hi, "unresolved"))
            continue
        centre = {n: 0.5 * (a + b) for n, a, b in zip(names, lo, hi)}
        widen = {n: 0.5 * (b - a) for n, a, b in zip(names, lo, hi)}
        values = [centre[n] if n in centre else float(fixed[n]) for n in mech.actuated]
        tested += 1
        verdict, _ = count_over(mech, tolerances, values, widen)
        if verdict is True:
            continue
        if max(b - a for a, b in zip(lo, hi)) <= tol:
            boxes.append((lo, hi, "singular" if verdict is False else "unresolved"))
            continue
        mids = [0.5 * (a + b) for a, b in zip(lo, hi)]
        halves = [((a, m), (m, b)) for a, m, b in zip(lo, mids, hi)]
        for parts in np.array(np.meshgrid(*[[0, 1]] * len(axes))).T.reshape(-1, len(axes)):
            todo.append((tuple(halves[k][p][0] for k, p in enumerate(parts)),
                         tuple(halves[k][p][1] for k, p in enumerate(parts))))
    seconds = time.perf_counter() - t0
    cells = tuple(SingularBox((lo[0], hi[0]), None if y is None else (lo[1], hi[1]), status)
                  for lo, hi, status in sorted(boxes))
    stats = SingularStats(boxes_processed=tested, accepted=len(cells), pending=0, seconds_cover=seconds,
                          seconds_certify=0.0, seconds=seconds)
    return SingularSet(tuple(x), None if y is None else tuple(y), fixed, float(tol), cells, stopped is None, stats,
                       "tolerances", (), CuspSearch.NOT_SEARCHED if y is not None else CuspSearch.NOT_APPLICABLE,
                       stopped=stopped)
