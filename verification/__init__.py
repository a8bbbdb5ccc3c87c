"""Symbolic verification of every claim of the paper, with an errata report (issue 3).

Each group of claims has its module; each check is a plain function ``check(quick: bool) ->
ClaimResult`` built on independent derivations (sympy over the rationals, a geometric model of the
Gosselin platform), never on spherekin's own output -- spherekin is *compared* with them in the
``impl:`` checks.

    polygon            Eq. (1), the normalization to Eq. (2) and its phi_i index rule, Eq. (6), range shift
    scalar_equation    Eq. (7), Eq. (8), F^sigma, Eq. (9) and the direction of the index shift
    bernstein_form     Prop. 1, Prop. 2, Cor. 1, Cor. 2 (constants and recursion), Eq. (10), Eq. (11)
    gosselin_geometry  Section 2.1 against a geometric 3-RRR model: actuator relations, Eq. (5), final equations
    gosselin_solutions Section 2.1: 8 solutions, 4 singular (exact Groebner solve)
    convergence        Section 4: the quadratic-convergence claim vs the double roots of Eq. (10)

API: :func:`run` (``run(quick: bool = False, checks=None, progress=None) -> VerificationRun``),
:func:`write_report`, :func:`main` (the command line, ``python -m verification [--quick]``).
"""

from .registry import CHECKS, run
from .report import DEFAULT_REPORT, render_report, write_report
from .result import (ERRATUM, NOT_SUPPORTED, VERDICTS, VERIFIED, VERIFIED_UNDER_CONDITIONS, CheckError,
                     ClaimResult, ImplementationMismatch, VerificationRun)
from .cli import main

__all__ = [
    "CHECKS", "run", "main", "render_report", "write_report", "DEFAULT_REPORT",
    "ClaimResult", "CheckError", "VerificationRun", "ImplementationMismatch",
    "VERDICTS", "VERIFIED", "VERIFIED_UNDER_CONDITIONS", "ERRATUM", "NOT_SUPPORTED",
]
