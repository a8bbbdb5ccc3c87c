"""Angles modulo 2 pi: wrapping, and closed joint ranges with one documented tolerance.

A joint range [lo, hi] (radians, lo <= hi, hi - lo <= 2 pi) is closed at both ends and read modulo
2 pi: theta is in it when some theta + 2 k pi lies in [lo - RANGE_TOL, hi + RANGE_TOL]. The same
rule, with the same tolerance, applies to actuator inputs (:mod:`spherekin.mechanism`) and to the
passive angles of solutions (:mod:`spherekin.trust.solutions`), so that an input equal to a range end
is accepted and a solution on a range end is kept whichever end it is.
"""

from __future__ import annotations

import math

import numpy as np

from .groups import connected_groups

__all__ = ["TWO_PI", "RANGE_TOL", "MAX_INPUT_ANGLE", "wrap", "in_range", "in_range_many", "near", "span_in_range_many",
           "span_outside_range_many", "SPAN_ROUNDING",
           "into_range", "into_range_many", "room_in_range", "beyond_turn", "turn_error", "check_turn", "MAX_GEOMETRY_ANGLE",
           "check_geometry_angle", "near_groups", "PAIRWISE_MAX"]

TWO_PI = 2.0 * math.pi
#: Margin of :func:`span_outside_range_many` for its own rounding (the reduction modulo 2 pi and the
#: sums, a few ulps of 2 pi ~ 1e-15): an arc is called outside only when it is outside by this much
#: more. Reason: 1e-12 covers those roundings with room and is far below RANGE_TOL.
SPAN_ROUNDING = 1e-12
#: Tolerance (radians) of the range ends, applied to both ends alike. Reason: a range end written
#: in decimal or degrees and an angle computed from it (an input, a polished root ~1e-15 accurate,
#: an angle reduced modulo 2 pi: a few ulps of 2 pi ~ 1e-15) may differ by rounding alone; 1e-10
#: is far above that and far below the accuracy anyone states a joint range with.
RANGE_TOL = 1e-10
#: Largest |angle| (radians) accepted as an actuator input or a given pose angle: one full turn (plus
#: the range tolerance, so that 2 pi written as text is accepted). Reason: angles are read modulo
#: 2 pi, so an input beyond a turn names the same pose as its reduced value, and such an input comes
#: from a forgotten degrees flag (17 meant as 17 degrees) far more often than from a joint turned
#: several times; far beyond a turn the reduction itself loses digits (at 1e17 rad, every one).
MAX_INPUT_ANGLE = TWO_PI + RANGE_TOL
#: Largest |angle| (radians) of a mechanism's geometry: a joint range's end, a joint's reference
#: reading, a 3-RRR joint offset. Reason: these angles are used modulo 2 pi, and the reduction errs by
#: the float's spacing at the angle (1.5e-11 at 1e5) plus the turns times the error of the double
#: nearest 2 pi (1e5 / 2 pi * 2.4e-16 = 4e-12): below 1e5 together far under RANGE_TOL; beyond, the
#: mechanism would be solved for another geometry than the one written (at 1e17, no digit is left).
MAX_GEOMETRY_ANGLE = 1e5


def wrap(angle):
    """``angle`` (radians, a float or an array) modulo 2 pi, in [-pi, pi): the one angle reduction of
    the package (pi itself goes to -pi). Exact: the result is angle - 2 pi k for a whole k and the
    double TWO_PI, with no rounding (fmod is exact, and moving its remainder r, pi <= |r| < 2 pi, by
    TWO_PI is exact by Sterbenz's lemma), so an angle already in [-pi, pi) comes back unchanged and
    wrap(a - b) is the exact difference of a and b modulo TWO_PI. NaN and +-inf give NaN."""
    if isinstance(angle, float | int) and not isinstance(angle, bool):
        r = math.fmod(angle, TWO_PI) if math.isfinite(angle) else math.nan
        return r - TWO_PI if r >= math.pi else r + TWO_PI if r < -math.pi else r
    r = np.fmod(np.asarray(angle, dtype=float), TWO_PI)
    r = np.where(r >= math.pi, r - TWO_PI, np.where(r < -math.pi, r + TWO_PI, r))
    return float(r) if r.ndim == 0 else r


def in_range(theta: float, rng, tol: float = RANGE_TOL) -> bool:
    """Whether ``theta`` (radians) lies in the closed range ``rng`` = (lo, hi) modulo 2 pi, ends widened by ``tol``.

    ``rng`` None is the full circle. The test is symmetric: theta = lo - tol and theta = hi + tol
    are both in, anything farther from the range on either side is out.
    """
    if rng is None:
        return True
    lo, hi = float(rng[0]), float(rng[1])
    return float(np.mod(float(theta) - (lo - tol), TWO_PI)) <= (hi - lo) + 2.0 * tol


def room_in_range(theta: float, rng, tol: float = RANGE_TOL) -> tuple[float, float]:
    """How far ``theta`` (radians, in ``rng`` by :func:`in_range`) can move down and up and stay in the
    range (lo, hi) modulo 2 pi: (below, above), each >= 0, below + above = hi - lo; (inf, inf) for
    ``rng`` None (the full circle). An angle within ``tol`` outside an end counts as at that end."""
    if rng is None:
        return math.inf, math.inf
    lo, hi = float(rng[0]), float(rng[1])
    span = hi - lo
    below = float(np.mod(float(theta) - lo, TWO_PI))
    if below > span:                           # outside the range: at its nearer end (within tol)
        below = span if below - span <= TWO_PI - below else 0.0
    return below, span - below


def in_range_many(theta, rng, tol: float = RANGE_TOL) -> np.ndarray:
    """:func:`in_range` of every entry of the array ``theta`` (radians): a boolean array of its shape."""
    theta = np.asarray(theta, dtype=float)
    if rng is None:
        return np.ones(theta.shape, dtype=bool)
    lo, hi = float(rng[0]), float(rng[1])
    return np.mod(theta - (lo - tol), TWO_PI) <= (hi - lo) + 2.0 * tol


def span_in_range_many(lo, hi, rng, tol: float = RANGE_TOL) -> np.ndarray:
    """Whether every angle of the arcs [lo, hi] (radians, arrays of one shape, hi - lo < 2 pi; NaN
    or infinite: an unknown arc) lies in ``rng``, by the rule of :func:`in_range`: the arc's start
    is in the range and its end no farther than the range's widened end."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    if rng is None:
        return np.ones(np.broadcast_shapes(lo.shape, hi.shape), dtype=bool)
    a, b = float(rng[0]), float(rng[1])
    with np.errstate(invalid="ignore"):
        start = np.mod(lo - (a - tol), TWO_PI)           # from the widened start of the range
        return np.isfinite(lo) & np.isfinite(hi) & (start + (hi - lo) <= (b - a) + 2.0 * tol)



def span_outside_range_many(lo, hi, rng, tol: float = RANGE_TOL) -> np.ndarray:
    """Whether no angle of the arcs [lo, hi] (radians, arrays of one shape, hi - lo < 2 pi; NaN or
    infinite: an unknown arc, never outside) lies in ``rng`` widened by ``tol`` at both ends (the
    rule of :func:`in_range`): the arc starts after the widened range's end and ends before its
    start comes round again. False everywhere for ``rng`` None (the full circle)."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    if rng is None:
        return np.zeros(np.broadcast_shapes(lo.shape, hi.shape), dtype=bool)
    a, b = float(rng[0]), float(rng[1])
    with np.errstate(invalid="ignore"):
        start = np.mod(lo - (a - tol), TWO_PI)           # from the widened start of the range
        return (np.isfinite(lo) & np.isfinite(hi) & (start > (b - a) + 2.0 * tol + SPAN_ROUNDING)
                & (start + (hi - lo) < TWO_PI - SPAN_ROUNDING))

def into_range(theta: float, rng, tol: float = RANGE_TOL) -> float:
    """The representative of ``theta`` modulo 2 pi that lies in ``rng`` (see :func:`in_range`); theta if none."""
    if rng is None or not in_range(theta, rng, tol):
        return float(theta)
    lo = float(rng[0])
    return lo - tol + float(np.mod(float(theta) - (lo - tol), TWO_PI))


def into_range_many(theta, rng, tol: float = RANGE_TOL) -> np.ndarray:
    """:func:`into_range` of every entry of the array ``theta`` (radians): an array of its shape."""
    theta = np.asarray(theta, dtype=float)
    if rng is None:
        return theta.copy()
    lo = float(rng[0])
    return np.where(in_range_many(theta, rng, tol), lo - tol + np.mod(theta - (lo - tol), TWO_PI), theta)


def beyond_turn(theta) -> np.ndarray:
    """Whether each entry of ``theta`` (radians, an array) is more than a full turn from 0
    (|theta| > MAX_INPUT_ANGLE): a boolean array of its shape."""
    return np.abs(np.asarray(theta, dtype=float)) > MAX_INPUT_ANGLE


def turn_error(key: str, theta: float) -> str:
    """The one message for an angle beyond a full turn (see :data:`MAX_INPUT_ANGLE`), naming ``key``."""
    return (f"{key}: {float(theta):g} is more than a full turn in radians (expected |angle| <= 2 pi); "
            "an angle in degrees? convert it (on the command line: --degrees)")


def check_turn(key: str, theta: float) -> float:
    """``theta`` (radians) as a float when it is within a full turn of 0, else ValueError naming ``key``."""
    theta = float(theta)
    if abs(theta) > MAX_INPUT_ANGLE:
        raise ValueError(turn_error(key, theta))
    return theta


def check_geometry_angle(key: str, theta: float) -> float:
    """``theta`` (radians) as a float when |theta| <= MAX_GEOMETRY_ANGLE, else ValueError naming ``key``
    and the reason (the precision of the reduction modulo 2 pi)."""
    theta = float(theta)
    if not abs(theta) <= MAX_GEOMETRY_ANGLE:
        raise ValueError(f"{key}: expected an angle within {MAX_GEOMETRY_ANGLE:g} rad of 0, got {theta:g}: angles "
                         "are read modulo 2 pi, and reducing this one would lose digits; write the reduced angle")
    return theta


#: :func:`near_groups` compares every pair of up to this many boxes in one array operation (an
#: N x N x M array: 512 boxes of 6 angles are 1.5 M entries, 12 MB); more boxes (a continuum's
#: covering) are compared row by row. The groups are the same either way.
PAIRWISE_MAX = 512


def near_groups(lo, hi, gap: float) -> list[list[int]]:
    """The boxes [lo_k, hi_k] (K, M; radians) grouped by nearness modulo 2 pi, transitively.

    Boxes j and k are near when on every coordinate their gap modulo 2 pi is at most ``gap``:
    |wrap(c_j - c_k)| <= r_j + r_k + gap, with c the centres and r the half-widths. The groups are
    the connected components of that relation (union-find): lists of indices, each in increasing
    order, the groups in the order of their first index. The search merges accepted boxes into
    clusters with it, the trust layer unproven entries next to each other.
    """
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    if len(lo) <= PAIRWISE_MAX:           # every pair in one array operation
        close = near(mid[:, None], half[:, None], mid[None, :], half[None, :], gap)
        i, j = np.nonzero(np.triu(close, 1))
        return connected_groups(len(lo), list(zip(i.tolist(), j.tolist())))
    edges = []
    for i in range(len(lo)):              # row by row: memory linear in the number of boxes
        close = near(mid[i], half[i], mid[i + 1:], half[i + 1:], gap)
        edges += [(i, int(j)) for j in np.flatnonzero(close) + i + 1]
    return connected_groups(len(lo), edges)


def near(mid_i, half_i, mid_j, half_j, gap: float) -> np.ndarray:
    """Whether boxes i and j (centres ``mid``, half-widths ``half``: radians, arrays broadcasting
    against each other, the last axis the coordinates) are near, the relation of :func:`near_groups`:
    on every coordinate |wrap(c_j - c_i)| <= r_j + r_i + ``gap``. NaN coordinates are never near."""
    return np.all(np.abs(wrap(mid_j - mid_i)) <= half_j + half_i + gap, axis=-1)
