"""The registry of checks and :func:`run`, the entry point used by ``python -m verification`` and by
``spherekin verify``.

Every check is a plain function ``check(quick: bool) -> ClaimResult``. A check asserts the outcome its
verdict rests on; if the computation ever contradicts it, the check raises, the run records a
:class:`CheckError` and the command exits non-zero -- the report never shows a verdict that its
computation does not back. ``quick=True`` uses small sizes (n <= 4, fewer random poses and inputs) for
the test suite; the default is full size (Cor. 2 and Eq. 10 for n = 1..6 in exact arithmetic).
"""

from __future__ import annotations

import time
import traceback
from typing import Callable, Iterable, Sequence

from . import bernstein_form, convergence, gosselin_geometry, gosselin_solutions, polygon, scalar_equation
from .result import CheckError, ClaimResult, VerificationRun

__all__ = ["CHECKS", "run"]

Check = Callable[[bool], ClaimResult]

#: All checks, in the order of the paper (implementation cross-checks last).
CHECKS: tuple[Check, ...] = (
    # Section 2: one spherical polygon
    polygon.check_eq1,
    polygon.check_eq2_normalized,
    polygon.check_eq2_index_rule,
    # Section 2.1: the Gosselin platform
    gosselin_geometry.check_normal_form,
    gosselin_geometry.check_actuator_relations,
    gosselin_geometry.check_eq5,
    polygon.check_eq6,
    gosselin_geometry.check_final_loop1,
    gosselin_geometry.check_final_loop2,
    gosselin_solutions.check_eight_solutions,
    # Section 2.2: the scalar equation
    scalar_equation.check_eq7,
    scalar_equation.check_eq8,
    scalar_equation.check_eq9_sigma,
    polygon.check_range_shift,
    # Section 3: Bernstein form
    bernstein_form.check_prop1,
    bernstein_form.check_prop2,
    bernstein_form.check_cor1,
    bernstein_form.check_cor2_constants,
    bernstein_form.check_cor2_recursion,
    bernstein_form.check_eq10,
    gosselin_geometry.check_control_point_count,
    # Section 4: the subdivision method
    bernstein_form.check_eq11,
    convergence.check_quadratic_convergence,
    # spherekin against the verified mathematics
    polygon.check_impl_rotations,
    bernstein_form.check_impl_closure,
    gosselin_geometry.check_impl_paper_gosselin,
)


def run(quick: bool = False, checks: Sequence[Check] | None = None,
        progress: Callable[[ClaimResult | CheckError, float], None] | None = None) -> VerificationRun:
    """Run every check (or ``checks``) and collect the results; never raises for a failing check.

    quick: small sizes for the test suite (True) or full size (False).
    checks: the functions to run, default :data:`CHECKS`.
    progress: called after each check with its result (or error) and its run time in seconds.
    """
    if not isinstance(quick, bool):
        raise ValueError(f"quick: expected True or False, got {quick!r}")
    todo: Iterable[Check] = CHECKS if checks is None else checks
    results, errors = [], []
    for check in todo:
        if not callable(check):
            raise ValueError(f"checks: expected functions check(quick) -> ClaimResult, got {check!r}")
        name = getattr(check, "__qualname__", repr(check))
        start = time.perf_counter()
        try:
            result = check(quick)
            if not isinstance(result, ClaimResult):
                raise TypeError(f"{name} returned {type(result).__name__}, expected ClaimResult")
            results.append(result)
        except Exception as exc:  # a failing check is reported, the run goes on
            result = CheckError(name, f"{type(exc).__name__}: {exc}", traceback.format_exc())
            errors.append(result)
        if progress is not None:
            progress(result, time.perf_counter() - start)
    ids = [r.claim_id for r in results]
    duplicates = sorted({i for i in ids if ids.count(i) > 1})
    if duplicates:
        errors.append(CheckError("registry", f"duplicate claim ids {duplicates}"))
    return VerificationRun(quick, tuple(results), tuple(errors))
