"""Formulations: which polynomial equations of each loop the solver works on (Section 2.2 and beyond).

A formulation turns closure loops into *equation blocks*: for each loop, a stack of Bernstein
tensors over the global unit box [0, 1]^n of all unknowns. An unknown that a loop does not contain
gets a tensor axis of length 1 (degree 0), so every block has n polynomial axes and the Bernstein
core can restrict all of them to a batch of boxes in one call.

* ``paper``: the scalar closure equation of Eq. (10), f = f11bar + f22bar - 2 q_n, one per loop.
  f <= 0 everywhere and f = 0 exactly at closure, so every root is a double root (a maximum): the
  hull-based pruning converges only linearly there (measured in the benchmarks).
* ``transversal``: per loop the three strictly lower-triangular entries q_n f21, q_n f31, q_n f32 of
  q_n F_n, which vanish at F = I with a Jacobian of full rank on so(3) (F = I + [w]x gives
  (f21, f31, f32) = (w_z, -w_y, w_x)), so roots are simple where the mechanism is regular; plus the
  scalar equation, which removes the spurious upper-triangular rotations diag(1, -1, -1),
  diag(-1, 1, -1), diag(-1, -1, 1). This departs from the paper (Section 5 asks for better
  conditioned formulations).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .closure import ClosureLoop, Unknown

__all__ = ["EquationBlock", "FORMULATIONS", "TRANSVERSAL_ENTRIES", "formulate", "embed"]

#: Entries (row, column) of q_n F_n used by the transversal formulation (strictly lower triangle).
TRANSVERSAL_ENTRIES = ((1, 0), (2, 0), (2, 1))


@dataclass(frozen=True)
class EquationBlock:
    """Equations of one loop, each = 0 at a solution, as Bernstein tensors on the unit box.

    ``coeffs`` has shape (E, d_1, ..., d_n), d_k = 3 if the loop contains unknown k else 1;
    ``labels`` names the E equations; ``scale`` (E,) is max |control point| on the whole unit box,
    the magnitude that rounding errors of later restrictions are relative to.
    """

    loop_index: int
    labels: tuple[str, ...]
    coeffs: np.ndarray
    scale: np.ndarray

    @property
    def variables(self) -> tuple[int, ...]:
        """Global indices of the unknowns this block depends on."""
        return tuple(k for k, d in enumerate(self.coeffs.shape[1:]) if d > 1)


def embed(loop: ClosureLoop, tensor: np.ndarray, unknowns: Sequence[Unknown]) -> np.ndarray:
    """Place a loop tensor (one axis per loop unknown) on the global axes of ``unknowns``.

    Axes of absent unknowns get length 1; axes are permuted into global order. Shape (..., n).
    """
    k = len(loop.unknowns)
    lead = tensor.ndim - k
    pos = []
    for u in loop.unknowns:
        try:
            pos.append(next(i for i, g in enumerate(unknowns) if g is u))
        except StopIteration:
            raise ValueError(f"unknowns: loop unknown {u.name!r} is not among the system's unknowns") from None
    order = np.argsort(pos)
    out = np.transpose(tensor, tuple(range(lead)) + tuple(lead + int(i) for i in order))
    shape = list(tensor.shape[:lead]) + [1] * len(unknowns)
    for i in sorted(pos):
        shape[lead + i] = 3
    return out.reshape(shape)


def _block(index: int, loop: ClosureLoop, unknowns, labels, tensors) -> EquationBlock:
    coeffs = embed(loop, np.stack(tensors), unknowns)
    scale = np.abs(coeffs).reshape(len(tensors), -1).max(axis=1)
    return EquationBlock(index, tuple(labels), coeffs, scale)


def paper(loops: Sequence[ClosureLoop], unknowns: Sequence[Unknown]) -> list[EquationBlock]:
    """One scalar equation per loop (Eq. 10), by the paper's recursion route."""
    return [_block(j, lp, unknowns, [f"loop{j + 1}:f11+f22-2q"], [lp.scalar_control_points("recursion")])
            for j, lp in enumerate(loops)]


def transversal(loops: Sequence[ClosureLoop], unknowns: Sequence[Unknown]) -> list[EquationBlock]:
    """Per loop q f21, q f31, q f32 (simple roots) plus the scalar equation (removes spurious roots)."""
    blocks = []
    for j, lp in enumerate(loops):
        m = lp.matrix_control_points()
        q = lp.q_control_points()
        tensors = [m[r, c] for r, c in TRANSVERSAL_ENTRIES] + [m[0, 0] + m[1, 1] - 2 * q]
        labels = [f"loop{j + 1}:qf{r + 1}{c + 1}" for r, c in TRANSVERSAL_ENTRIES] + [f"loop{j + 1}:f11+f22-2q"]
        blocks.append(_block(j, lp, unknowns, labels, tensors))
    return blocks


FORMULATIONS = {"paper": paper, "transversal": transversal}


def formulate(name: str, loops: Sequence[ClosureLoop], unknowns: Sequence[Unknown]) -> list[EquationBlock]:
    """Equation blocks of the formulation called ``name`` (one of FORMULATIONS)."""
    if name not in FORMULATIONS:
        raise ValueError(f"formulation: expected one of {sorted(FORMULATIONS)}, got {name!r}")
    if not loops:
        raise ValueError("loops: expected at least one closure loop, got none")
    return FORMULATIONS[name](loops, unknowns)
