"""Tests for spherekin.trust.stepping (the one stepping loop of both trackers), on a toy of its own.

The toy follows the root x = sqrt(b) of x^2 = b as the input b moves; the root ends at the fold b = 0.
Its "proof" of a step b0 -> b1 passes when the step is at most half the distance to the fold (the
provable step of a real tracker shrinks like that distance), so where the walk must stop, and what
it must have walked through, is known in closed form.
"""

import math

import numpy as np
import pytest

from spherekin.trust.stepping import FIRST_STEP, MIN_STEP, Stop, walk


class Fold:
    growth = 1.5

    def __init__(self, verdicts=()):
        self.verdicts = list(verdicts)      # what check answers, in turn (then None)
        self.certified = []                 # every step proven: (b0, b1)

    def predict(self, states, b0, b1):
        found = b1[:, 0] > 0
        return np.sqrt(np.where(found, b1[:, 0], 1.0))[:, None], found

    def certify(self, states, proposals, b0, b1):
        a, b = b0[:, 0], b1[:, 0]
        ok = (np.minimum(a, b) > 0) & (np.abs(b - a) <= 0.5 * np.minimum(a, b))
        self.certified += [(x, y) for x, y, good in zip(a, b, ok) if good]
        lo = np.sqrt(np.clip(np.minimum(a, b), 0, None))[:, None]
        return ok, lo, np.sqrt(np.maximum(a, b))[:, None]

    def advance(self, state, proposal):
        return proposal

    def locate(self, state, b0, direction, t_max):
        lo, hi = 0.0, t_max
        while (hi - lo) * abs(direction[0]) > 1e-12:
            mid = 0.5 * (lo + hi)
            if b0[0] + mid * direction[0] > 0:
                lo = mid
            else:
                hi = mid
        return lo, hi

    def check(self, *step):
        return self.verdicts.pop(0) if self.verdicts else None


def test_a_walk_stops_at_the_fold_with_a_bracket_around_it():
    toy = Fold()
    (w,) = walk(toy, [[1.0]], [[1.0]], [[-1.0]], budget=10_000)
    assert w.end is None and w.stop.kind == "singular"
    assert w.stop.lo <= 0.5 <= w.stop.hi and (w.stop.hi - w.stop.lo) * 2.0 <= 2e-12   # b = 1 - 2 s: the fold at s = 1/2
    b_stop = 1.0 - 2.0 * w.stop.s
    assert 0 < b_stop < 2 * MIN_STEP / 0.5 + 1e-15          # the last proven input: within the provable reach of the fold
    assert w.stop.state[0] == pytest.approx(math.sqrt(b_stop))
    # every proven step holds the toy's rule, the records follow the root, nothing walked past the fold
    assert len(toy.certified) == w.steps and all(b > 0 and abs(b - a) <= 0.5 * min(a, b) for a, b in toy.certified)
    assert [r[0] for r in w.record] == sorted(r[0] for r in w.record)
    assert all(r[1][0] == pytest.approx(math.sqrt(1.0 - 2.0 * r[0])) for r in w.record)


def test_a_walk_that_reaches_its_end_grows_its_steps():
    toy = Fold()
    (w,) = walk(toy, [[1.0]], [[1.0]], [[0.5]], budget=10_000)
    assert w.stop is None and w.end[0] == math.sqrt(0.5)
    assert w.record[-1][0] == 1.0
    # from b = 1 the first step is FIRST_STEP (the segment is longer), then 1.5x after each success
    steps = [a - b for a, b in toy.certified]
    assert steps[0] == pytest.approx(FIRST_STEP) and steps[1] == pytest.approx(1.5 * FIRST_STEP)
    assert w.last_step == pytest.approx(max(abs(toy.certified[-1][1] - toy.certified[-1][0]), w.last_step))


def test_the_walks_after_one_that_stops_are_abandoned():
    # the third would walk longer than the second takes to stop (from 5 to its fold): abandoned when it stops
    walks = walk(Fold(), [[1.0], [1.0], [5.0]], [[1.0], [1.0], [5.0]], [[0.9], [-1.0], [-5.0]], budget=10_000)
    assert walks[0].end is not None and walks[1].stop.kind == "singular" and walks[2] is None


def test_a_short_budget_is_an_error_naming_the_cure():
    with pytest.raises(RuntimeError, match="split it into shorter paths"):
        walk(Fold(), [[1.0]], [[1.0]], [[-1.0]], budget=5)


def test_check_walks_a_step_finer_or_stops_the_track():
    plain, finer = Fold(), Fold(["finer"])
    (a,) = walk(plain, [[1.0]], [[1.0]], [[0.9]], budget=100)
    (b,) = walk(finer, [[1.0]], [[1.0]], [[0.9]], budget=100)
    assert b.rejected == a.rejected + 1 and b.end[0] == a.end[0]
    assert finer.certified[1][1] - finer.certified[1][0] == pytest.approx(0.5 * (plain.certified[0][1] - 1.0))
    at = Stop("range", 0.25, np.array([0.9]), 0.25, 0.3, "x")
    (c,) = walk(Fold([at]), [[1.0]], [[1.0]], [[0.9]], budget=100)
    assert c.end is None and c.stop is at and c.steps == 0


def test_the_first_step_is_the_given_one_when_shorter():
    toy = Fold()
    walk(toy, [[1.0]], [[1.0]], [[0.5]], budget=1000, firsts=[0.01])
    assert toy.certified[0][0] - toy.certified[0][1] == pytest.approx(0.01)
