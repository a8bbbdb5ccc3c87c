"""The cell width T of a certified singular set: its default, its bounds and the check before any work.

Light on purpose (no SciPy): the command line builds its options and checks ``--tol`` from here
without importing the cover (:mod:`spherekin.singularities.cover`).
"""

from __future__ import annotations

import math

__all__ = ["SINGULAR_TOL", "SINGULAR_MAX_TOL", "SLACK_MARGIN", "CELL_SLACK", "CUSP_REFINE_FRACTIONS",
           "REFINE_FRACTIONS", "singular_min_tol", "check_singular_tol"]

#: A rectangle meets a cell when it comes within this (radians) of it: the chart maps (tan-half angle) round
#: by ~1e-16 rad, so adjacent charts may leave gaps of that size between their rectangles; far above it.
CELL_SLACK = 1e-9

#: Default cell width (radians) of :func:`spherekin.singularities.cover.singular`: the issue's default; ~1e3 cells for a curve of length 10.
SINGULAR_TOL = 1e-2
#: Widest cell accepted (radians). Reason: the certificate of a cell is a Krawczyk test on the hull of the
#: cover's boxes over it (or a small box around Newton's root in it); measured on general_3rrr at beta3 = 0.5,
#: cells of 0.1 rad are proven for about two thirds of the cover; wider cells meet more branches and folds
#: of the curve per cell, where the slice has several roots or none, so they would mostly be ``unresolved``.
SINGULAR_MAX_TOL = 0.5
#: The finest boxes the cover searches (the smallest of REFINE_FRACTIONS and CUSP_REFINE_FRACTIONS times T,
#: T/32) must be at least this many times CELL_SLACK (1e-9 rad: the
#: allowance for the tan-half maps' rounding with which a box meets a cell); narrower, a box meets cells by its
#: slack alone and the refinement rounds cannot shrink the cover onto the curve. So T >= 4 x 1e-9 x 32 = 1.28e-7
#: rad (:func:`singular_min_tol`; a full turn is then 4.9e7 cells per axis, indices far inside int64).
SLACK_MARGIN = 4
#: Cusp candidates left without a proof are searched again at these fractions of T (as REFINE_FRACTIONS).
CUSP_REFINE_FRACTIONS = (0.03125,)

#: The pieces of the accepted boxes cut by the unresolved cells are searched again with boxes of these fractions
#: of T, one round each (the cells still unresolved after a round go to the next). Reason: a piece whose cell
#: the curve misses by less than a box width is not excluded by one pruning (the hull of a box's control
#: points overestimates by ~its width squared); measured on general_3rrr at T = 0.1 over [-0.5, 0.5]^2, one
#: round of T/8 cut the cells the reference curve misses from 15 to 6 (T/4: 14) and proved 4 more cells.
REFINE_FRACTIONS = (0.125, 0.03125)


def singular_min_tol() -> float:
    """The narrowest cell width T (radians) a singular set accepts: SLACK_MARGIN x CELL_SLACK over the finest
    fraction of T the cover searches."""
    return SLACK_MARGIN * CELL_SLACK / min(REFINE_FRACTIONS + CUSP_REFINE_FRACTIONS)


def check_singular_tol(value, name: str = "tol") -> float:
    """The cell width T (radians) of a certified singular set, checked before any work: a number with
    :func:`singular_min_tol` <= T <= SINGULAR_MAX_TOL. ValueError naming ``name`` (the keyword or option as
    typed). The plane's coordinates are within a full turn of 0 (refused beyond, as every input is), where a
    cell of T >= singular_min_tol() is more than 1e5 float spacings wide: its edges are distinct floats."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or not 0 < value <= SINGULAR_MAX_TOL:
        raise ValueError(f"{name}: expected 0 < T <= {SINGULAR_MAX_TOL:g} (radians), got {value!r}")
    if value < singular_min_tol():
        raise ValueError(f"{name}: T = {value:g} rad is below {singular_min_tol():.3g}, the narrowest cell the cover "
                         "can resolve in float64 (its finest boxes, T/32, must stay wider than the 1e-9 rad allowance "
                         "for rounding with which a box meets a cell); locate a singular input more finely with "
                         "solve or the branch map")
    return float(value)
