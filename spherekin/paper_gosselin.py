"""The paper's two closure loops of the Gosselin platform, as printed in Section 2.1.

These are the hand-written equations of the paper (Eqs. 3-5 and the final pair after Eq. 6), kept
verbatim so they can be checked against an independent geometric model (verification) and against
the loops that the mechanism model derives from joint axes. With actuator angles beta_1..beta_3:

    loop 1: Rx(pi + b1) Z Rx(th2^1) Z Rx(th3^1) Z Rx(th4^1) Z Rx(th5^1) Z Rx(pi/2 - b2) Z = I
    loop 2: Rx(pi - b2) Z Rx(th2^2) Z Rx(th3^2) Z Rx(-pi/2) Z Rx(pi) Z Rx(th4^1) Z Rx(th5^1) Z
            Rx(3 pi/2 + b3) Z = I

Loop 2 uses Eq. (5), th4^2 = th4^1 + pi/2 and th5^2 = th5^1, with th4^2 split by Eq. (6) into the
factors (-pi/2, pi, th4^1) ("split" form, n = 8, as printed) or kept as one factor th4^1 + pi/2
("offset" form, n = 6). Six unknowns in all, four per loop, two shared.

Erratum (verification claim ``s21-final-loop2``): loop 2 as printed has its first and last factors
swapped. The paper's own relations give theta_1^2 = 3 pi/2 + b3 first and theta_6^2 = pi - b2 last;
as printed it closes at no configuration of the platform. ``corrected=True`` gives the corrected
loop; the default reproduces the paper as printed.
"""

from __future__ import annotations

import math

from .closure import ClosureLoop, Unknown

__all__ = ["DEFAULT_PASSIVE_RANGE", "paper_gosselin_unknowns", "paper_gosselin_loops"]

#: Default range (radians) of every passive joint when none is given: a symmetric range of
#: 0.9 * 2 pi around 0, wide enough to show the method on almost full turns while keeping
#: tan((theta - shift)/2) bounded (|t| <= tan(0.45 pi) ~ 6.3).
DEFAULT_PASSIVE_RANGE = (-0.9 * math.pi, 0.9 * math.pi)

UNKNOWN_NAMES = ("theta2_1", "theta3_1", "theta4_1", "theta5_1", "theta2_2", "theta3_2")


def paper_gosselin_unknowns(passive_range=DEFAULT_PASSIVE_RANGE) -> dict[str, Unknown]:
    """The six passive joint angles of Section 2.1 (names thetaK_L = theta_K^L).

    ``passive_range``: one (lo, hi) for all, or a mapping name -> (lo, hi) (radians).
    """
    if isinstance(passive_range, dict):
        missing = [n for n in UNKNOWN_NAMES if n not in passive_range]
        if missing:
            raise ValueError(f"passive_range: expected a range for every unknown, missing {missing}")
        return {name: Unknown(name, *passive_range[name]) for name in UNKNOWN_NAMES}
    lo, hi = passive_range
    return {name: Unknown(name, lo, hi) for name in UNKNOWN_NAMES}


def paper_gosselin_loops(betas, passive_range=DEFAULT_PASSIVE_RANGE, loop2_form: str = "split",
                         corrected: bool = False):
    """The two loop equations of the paper's Gosselin example, as :class:`ClosureLoop` objects.

    ``betas``: the three actuator angles (radians). ``loop2_form``: "split" (as printed) or "offset".
    ``corrected``: swap loop 2's first and last factors (the erratum in the module docstring).
    """
    if loop2_form not in ("split", "offset"):
        raise ValueError(f"loop2_form: expected one of ('split', 'offset'), got {loop2_form!r}")
    try:
        b1, b2, b3 = (float(b) for b in betas)
    except (TypeError, ValueError):
        raise ValueError(f"betas: expected three actuator angles in radians, got {betas!r}") from None
    u = paper_gosselin_unknowns(passive_range)
    loop1 = ClosureLoop([math.pi + b1, u["theta2_1"], u["theta3_1"], u["theta4_1"], u["theta5_1"],
                         math.pi / 2 - b2])
    th4 = [-math.pi / 2, math.pi, u["theta4_1"]] if loop2_form == "split" else [u["theta4_1"] + math.pi / 2]
    first, last = math.pi - b2, 3 * math.pi / 2 + b3
    if corrected:
        first, last = last, first
    loop2 = ClosureLoop([first, u["theta2_2"], u["theta3_2"], *th4, u["theta5_1"], last])
    return loop1, loop2
