"""Test helpers: equation blocks of tan-half loops built straight from closure loops.

They used to live in spherekin/search/formulations.py, which had to import the parameterizations
inside a function for them (the formulations <-> parameterizations cycle); the package builds its
blocks through :meth:`spherekin.search.parameterizations.LoopParameterization.charts` only.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from spherekin.closure import ClosureLoop, Unknown
from spherekin.search.formulations import FORMULATIONS, EquationBlock, embed_axes, formulate_polynomials
from spherekin.search.parameterizations import tan_half_loop


def positions(loop: ClosureLoop, unknowns: Sequence[Unknown]) -> list[int]:
    """The index in ``unknowns`` of each of the loop's unknowns (shared by identity)."""
    pos = []
    for u in loop.unknowns:
        try:
            pos.append(next(i for i, g in enumerate(unknowns) if g is u))
        except StopIteration:
            raise ValueError(f"unknowns: loop unknown {u.name!r} is not among the system's unknowns") from None
    return pos


def embed(loop: ClosureLoop, tensor: np.ndarray, unknowns: Sequence[Unknown]) -> np.ndarray:
    """Place a loop tensor (one axis per loop unknown) on the global axes of ``unknowns``.

    Axes of absent unknowns get length 1; axes are permuted into global order. Shape (..., n).
    """
    return embed_axes(tensor, positions(loop, unknowns), len(unknowns))


def formulate(name: str, loops: Sequence[ClosureLoop], unknowns: Sequence[Unknown]) -> list[EquationBlock]:
    """Equation blocks of formulation ``name`` for tan-half loops (the paper's parameterization)."""
    FORMULATIONS.lookup(name)
    if not loops:
        raise ValueError("loops: expected at least one closure loop, got none")
    polys = [tan_half_loop(j, lp, positions(lp, unknowns)) for j, lp in enumerate(loops)]
    return formulate_polynomials(name, polys, len(unknowns))
