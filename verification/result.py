"""Result types of the verification: one :class:`ClaimResult` per checked claim of the paper.

A check is a plain function ``check(quick: bool) -> ClaimResult``. The verdict is one of
:data:`VERDICTS`:

* ``VERIFIED`` -- the claim holds as printed, backed by an exact (sympy) or numeric computation;
* ``VERIFIED UNDER CONDITIONS`` -- it holds once conditions the paper leaves implicit are stated
  (``correction`` lists them);
* ``ERRATUM`` -- the printed form is wrong; ``correction`` gives the corrected form and
  ``demonstration`` the numbers showing the printed form fail and the corrected one hold;
* ``NOT SUPPORTED`` -- the computation neither confirms nor corrects the claim as stated.

Implementation cross-checks (is spherekin consistent with the verified mathematics?) are not paper
claims: their ``claim_id`` starts with ``impl:``, they return ``VERIFIED`` on agreement and raise
:class:`ImplementationMismatch` otherwise, so that a mismatch fails the run.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Mapping

__all__ = [
    "VERIFIED",
    "VERIFIED_UNDER_CONDITIONS",
    "ERRATUM",
    "NOT_SUPPORTED",
    "VERDICTS",
    "IMPL_PREFIX",
    "ClaimResult",
    "CheckError",
    "VerificationRun",
    "ImplementationMismatch",
    "ROUNDOFF",
    "rounded",
]

VERIFIED = "VERIFIED"
VERIFIED_UNDER_CONDITIONS = "VERIFIED UNDER CONDITIONS"
ERRATUM = "ERRATUM"
NOT_SUPPORTED = "NOT SUPPORTED"
VERDICTS = (VERIFIED, VERIFIED_UNDER_CONDITIONS, ERRATUM, NOT_SUPPORTED)

#: claim_id prefix of implementation cross-checks (spherekin vs the verified mathematics).
IMPL_PREFIX = "impl:"

#: Double-precision residuals of the checks (products of up to 16 rotations, polynomials in 4
#: variables evaluated at O(1) points) are rounding noise of 1e-16..1e-14 whose digits depend on the
#: BLAS kernel the CPU selects (measured: 6.6e-16 on this machine's default kernel, 7.4e-16 with
#: OPENBLAS_CORETYPE=Prescott). Values below this bound are printed as "< 1e-12", so the report is the
#: same on every machine; 1e-12 is still 10^3 below the loosest tolerance a check accepts (1e-9).
ROUNDOFF = 1e-12


def rounded(value: float) -> str:
    """A residual or deviation as report text: "< 1e-12" when ``abs(value)`` is below :data:`ROUNDOFF`
    (rounding noise, machine dependent), else "= " and two significant digits ("= 3.1e-05")."""
    value = float(value)
    if abs(value) < ROUNDOFF:
        return f"< {ROUNDOFF:.0e}"
    return f"= {value:.1e}"


class ImplementationMismatch(AssertionError):
    """spherekin disagrees with an independent derivation (raised by ``impl:`` checks)."""


def _text(name: str, value) -> str:
    if not isinstance(value, str):
        raise ValueError(f"{name}: expected a string, got {type(value).__name__} {value!r}")
    return value


@dataclass(frozen=True)
class ClaimResult:
    """The verdict on one claim of the paper, with the computation behind it.

    claim_id: short stable id ("eq2-index-rule"); reference: where the claim is printed
    ("Eq. (2), Section 2"); verdict: one of :data:`VERDICTS`; evidence: what was computed (sizes,
    residuals); correction: the corrected form (ERRATUM) or the conditions (VERIFIED UNDER
    CONDITIONS); statement: the claim as printed, in one line; demonstration: for an ERRATUM, the
    numbers showing the printed form fail and the corrected form hold; data: key numbers, for
    tests and tools (read-only mapping).
    """

    claim_id: str
    reference: str
    verdict: str
    evidence: str
    correction: str = ""
    statement: str = ""
    demonstration: str = ""
    data: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self):
        for name in ("claim_id", "reference", "verdict", "evidence", "correction", "statement",
                     "demonstration"):
            _text(name, getattr(self, name))
        if not self.claim_id:
            raise ValueError("claim_id: expected a non-empty string, got ''")
        if self.verdict not in VERDICTS:
            raise ValueError(f"verdict: expected one of {VERDICTS}, got {self.verdict!r}")
        if self.verdict == ERRATUM and not (self.correction and self.demonstration):
            raise ValueError(f"{self.claim_id}: an ERRATUM needs a correction and a demonstration")
        if self.verdict == VERIFIED_UNDER_CONDITIONS and not self.correction:
            raise ValueError(f"{self.claim_id}: VERIFIED UNDER CONDITIONS needs the conditions in 'correction'")
        if not isinstance(self.data, Mapping):
            raise ValueError(f"data: expected a mapping, got {type(self.data).__name__}")
        object.__setattr__(self, "data", MappingProxyType(dict(self.data)))

    @property
    def is_implementation_check(self) -> bool:
        return self.claim_id.startswith(IMPL_PREFIX)

    def summary_line(self) -> str:
        """One line for the console: id, verdict, reference."""
        return f"{self.claim_id:<28} {self.verdict:<26} {self.reference}"


@dataclass(frozen=True)
class CheckError:
    """A check that raised instead of returning a result (the run then fails)."""

    check: str
    error: str
    traceback: str = ""

    def summary_line(self) -> str:
        return f"{self.check:<28} {'ERROR':<26} {self.error}"


@dataclass(frozen=True)
class VerificationRun:
    """All results of one run, in registry order; ``errors`` lists the checks that raised."""

    quick: bool
    results: tuple[ClaimResult, ...]
    errors: tuple[CheckError, ...]

    @property
    def ok(self) -> bool:
        return not self.errors

    @property
    def claims(self) -> tuple[ClaimResult, ...]:
        """Results about the paper's claims (implementation cross-checks excluded)."""
        return tuple(r for r in self.results if not r.is_implementation_check)

    @property
    def implementation_checks(self) -> tuple[ClaimResult, ...]:
        return tuple(r for r in self.results if r.is_implementation_check)

    def by_id(self, claim_id: str) -> ClaimResult:
        for r in self.results:
            if r.claim_id == claim_id:
                return r
        known = [r.claim_id for r in self.results]
        raise ValueError(f"claim_id: expected one of {known}, got {claim_id!r}")
