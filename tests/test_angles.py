"""Tests for spherekin.core.angles: grouping boxes of angles by nearness modulo 2 pi.

The reference is independent of the code: nearness by explicit shifts of 2 pi k (k in -2..2) on
each coordinate, and the groups as connected components by scipy's graph routine.
"""

import math

import numpy as np
import pytest
from scipy.sparse.csgraph import connected_components

from spherekin.core.angles import RANGE_TOL, in_range_many, near_groups, span_outside_range_many


def _reference_groups(lo, hi, gap):
    k = len(lo)
    near = np.zeros((k, k), dtype=bool)
    for i in range(k):
        for j in range(k):
            ok = True
            for m in range(lo.shape[1]):
                # the gap between [lo_i, hi_i] and [lo_j, hi_j] + 2 pi s, the smallest over s
                gaps = [max(lo[j, m] + 2 * math.pi * s - hi[i, m], lo[i, m] - hi[j, m] - 2 * math.pi * s)
                        for s in range(-2, 3)]
                ok &= min(gaps) <= gap
            near[i, j] = ok
    _, labels = connected_components(near, directed=False)
    groups = {}
    for i, lab in enumerate(labels):
        groups.setdefault(lab, []).append(i)
    return sorted(groups.values())


@pytest.mark.parametrize("seed", range(6))
def test_near_groups_are_the_components_of_nearness_modulo_two_pi(seed):
    rng = np.random.default_rng(seed)
    k, m = 25, 2
    centre = rng.uniform(-math.pi, math.pi, (k, m))
    centre[: k // 3] = rng.choice([-math.pi + 1e-3, math.pi - 1e-3], (k // 3, m))   # boxes across +-pi
    half = rng.uniform(0.0, 0.3, (k, m))
    lo, hi = centre - half, centre + half
    gap = 0.05
    got = near_groups(lo, hi, gap)
    assert sorted(got) == _reference_groups(lo, hi, gap)
    assert [g[0] for g in got] == sorted(g[0] for g in got) and all(g == sorted(g) for g in got)


def test_boxes_across_pi_are_near_and_a_wider_gap_joins_more():
    lo = np.array([[3.1], [-3.14], [0.0]])
    hi = np.array([[3.14], [-3.1], [0.1]])
    assert near_groups(lo, hi, 0.01) == [[0, 1], [2]]          # 3.14 and -3.14 are 2 pi - 6.28 ~ 0.003 apart
    assert near_groups(lo, hi, 3.05) == [[0, 1, 2]]         # [0, 0.1] is 3.0 from [3.1, 3.14]
    assert near_groups(np.zeros((0, 2)), np.zeros((0, 2)), 1.0) == []


# ------------------------------------------------------------------ a full turn (forgotten --degrees)

from spherekin.core.angles import MAX_INPUT_ANGLE, beyond_turn, check_turn  # noqa: E402


@pytest.mark.parametrize("theta", [0.0, 3.0, -3.0, 2 * math.pi, -2 * math.pi, math.pi, 6.28318])
def test_angles_within_a_turn_are_accepted_unchanged(theta):
    assert check_turn("x", theta) == theta
    assert not beyond_turn(np.array([theta])).any()


@pytest.mark.parametrize("theta", [17.0, -17.0, 2 * math.pi + 1e-9, 30.0, 1e17, -1e300])
def test_angles_beyond_a_turn_are_refused_with_the_degrees_hint(theta):
    with pytest.raises(ValueError, match=r"^x: .* more than a full turn in radians .*--degrees"):
        check_turn("x", theta)
    assert beyond_turn(np.array([0.1, theta]))[1]


def test_the_turn_bound_is_two_pi_with_the_range_tolerance():
    # independent: 2 pi from its digits, and the tolerance the range ends use (1e-10)
    assert 6.283185307179586 + 0.5e-10 <= MAX_INPUT_ANGLE <= 6.283185307179586 + 1.5e-10


def test_into_range_many_is_into_range_entry_by_entry():
    from spherekin.core.angles import into_range, into_range_many

    theta = np.random.default_rng(3).uniform(-7.0, 7.0, 400)
    for rng in (None, (-1.0, 2.0), (2.5, 4.0), (-math.pi, math.pi)):
        got = into_range_many(theta, rng)
        assert np.array_equal(got, [into_range(t, rng) for t in theta])
        inside = [t for t, g in zip(theta, got) if rng is not None and rng[0] - 1e-10 <= g <= rng[1] + 1e-10]
        # an angle moved into the range is the same angle modulo 2 pi (independent of the code's rule)
        assert all(abs(math.remainder(g - t, 2 * math.pi)) < 1e-12 for t, g in zip(theta, got))
        assert rng is None or len(inside) > 0


from hypothesis import given, strategies as st  # noqa: E402

from spherekin.core.angles import in_range, room_in_range  # noqa: E402


@given(lo=st.floats(-math.pi, math.pi), span=st.floats(1e-3, 2 * math.pi - 1e-3), frac=st.floats(0.0, 1.0),
       turns=st.integers(-1, 1))
def test_room_in_range_reaches_both_ends_of_the_range_and_no_farther(lo, span, frac, turns):
    """From an angle in a range (any representative modulo 2 pi), moving down by `below` or up by `above`
    lands on the range's ends (in the range by in_range, the rule the solver applies), a little farther does
    not, and below + above is the range's width."""
    rng = (lo, lo + span)
    theta = lo + frac * span + 2 * math.pi * turns
    below, above = room_in_range(theta, rng)
    assert below >= 0 and above >= 0 and math.isclose(below + above, span, abs_tol=1e-12)
    assert math.isclose(math.remainder(theta - below - lo, 2 * math.pi), 0.0, abs_tol=1e-9)
    assert in_range(theta - below, rng) and in_range(theta + above, rng)
    step = 1e-6
    if span + 2 * step < 2 * math.pi - 1e-9:
        assert not in_range(theta - below - step, rng) and not in_range(theta + above + step, rng)


def test_room_in_range_of_a_full_circle_and_of_an_angle_at_an_end():
    assert room_in_range(1.0, None) == (math.inf, math.inf)
    below, above = room_in_range(-1.0 - RANGE_TOL / 2, (-1.0, 0.5))    # within tol below the start: at it
    assert below == 0.0 and above == 1.5
    below, above = room_in_range(0.5 + RANGE_TOL / 2, (-1.0, 0.5))     # within tol above the end: at it
    assert below == 1.5 and above == 0.0


# ---------------------------------------------------------------- the one wrap (issue 43 item 2)

from fractions import Fraction  # noqa: E402

from spherekin.core.angles import TWO_PI, wrap  # noqa: E402


def exact_wrap(x: float) -> Fraction:
    """x - k TWO_PI in [-TWO_PI/2, TWO_PI/2), k whole, in exact rational arithmetic (TWO_PI the double)."""
    X, P = Fraction(x), Fraction(TWO_PI)
    k = math.floor((X + P / 2) / P)
    return X - k * P


@given(st.floats(min_value=-1e6, max_value=1e6, allow_nan=False))
def test_wrap_is_the_exact_reduction_into_minus_pi_to_pi(x):
    """The float wrap returns is the rational x - k TWO_PI itself (no rounding), for a scalar and in an array."""
    r = wrap(x)
    assert Fraction(r) == exact_wrap(x) and -math.pi <= r < math.pi
    assert wrap(np.array([x]))[0] == r and wrap(np.float64(x)) == r


@given(st.floats(min_value=-math.pi, max_value=math.pi, exclude_max=True))
def test_an_angle_already_in_range_comes_back_unchanged(x):
    """np.mod(x + pi, 2 pi) - pi, the reduction it replaces, moved such angles by an ulp."""
    assert wrap(x) == x


def test_wrap_at_plus_and_minus_pi_and_beyond_a_turn():
    """One convention at +-pi for every caller (mechanism.chains' math.remainder gave +pi, core's -pi):
    pi and -pi both go to -pi; NaN and infinities give NaN."""
    assert wrap(math.pi) == -math.pi and wrap(-math.pi) == -math.pi
    assert wrap(3 * math.pi) == -math.pi
    assert np.array_equal(wrap(np.array([math.pi, -math.pi, TWO_PI, 0.0])), [-math.pi, -math.pi, 0.0, 0.0])
    assert all(math.isnan(wrap(v)) for v in (math.nan, math.inf, -math.inf))
    assert np.isnan(wrap(np.array([math.inf]))).all()


def test_an_arc_is_outside_a_range_only_when_no_angle_of_it_is_in_the_range():
    """span_outside_range_many against sampling: 3,000 random arcs and ranges (on both sides of +-pi); an
    arc called outside has no sampled angle in the range (by in_range_many, which widens it by RANGE_TOL),
    and an arc with a sampled angle in the range is never outside; arcs well clear of it are outside."""
    rng = np.random.default_rng(12)
    called = 0
    for _ in range(3000):
        a = rng.uniform(-4.0, 4.0)
        rng_ = (a, a + rng.uniform(0.01, 6.0))
        lo = rng.uniform(-4.0, 4.0)
        hi = lo + rng.uniform(0.0, 3.0)
        samples = np.linspace(lo, hi, 200)
        inside_any = in_range_many(samples, rng_).any()
        outside = bool(span_outside_range_many(np.array([lo]), np.array([hi]), rng_)[0])
        assert not (outside and inside_any), (lo, hi, rng_)
        called += outside
    assert called > 300
    assert not span_outside_range_many(np.array([0.0]), np.array([0.1]), None)[0]            # the full circle
    assert not span_outside_range_many(np.array([np.nan]), np.array([0.1]), (1.0, 2.0))[0]   # unknown arc
    # an arc ending RANGE_TOL / 2 short of the range: inside the widened range, so not outside
    assert not span_outside_range_many(np.array([0.5]), np.array([1.0 - RANGE_TOL / 2]), (1.0, 2.0))[0]
    assert span_outside_range_many(np.array([0.5]), np.array([1.0 - 1e-9]), (1.0, 2.0))[0]
