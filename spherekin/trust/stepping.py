"""The one stepping loop of certified tracking: segments of inputs walked in adaptive proven steps.

Both trackers (:mod:`spherekin.trust.continuation` on the platform's leg equations,
:mod:`spherekin.trust.loop_continuation` on the loop equations) walk a segment x0 -> x1 of actuator
inputs the same way; what differs is the equations, given here as a :class:`Stepper`:

* ``predict(states, b0, b1)``: float Newton from each state at inputs b0 to inputs b1: the
  proposals (k, ...) and which were found (k,);
* ``certify(states, proposals, b0, b1)``: one parametric Krawczyk test per step (every input of
  the segment b0 -> b1 has exactly one root in the step's box): (ok, lo, hi), the boxes (k, M);
* ``advance(state, proposal)``: the state at b1 after a proven step;
* ``locate(state, b0, direction, t_max)``: where the branch from ``state`` ends (a parallel
  singularity), as a bracket (lo, hi) of t in [0, t_max] along b0 + t direction;
* ``check(...)``: optional, what the joint ranges say of a proven step (accept, walk it finer, or
  stop the track at a :class:`Stop` of kind "range");
* ``growth``: the factor a step grows by after a success.

Each round proves the next step of every walk still going in one call (:func:`walk`): a failed
step is halved, a proven one followed by one ``growth`` times longer; a walk ends at x1 or where no
step of MIN_STEP radians of input can be proven (then ``locate`` brackets the singular input). The
walks after one that stops are abandoned: the track ends there.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

__all__ = ["FIRST_STEP", "MIN_STEP", "MAX_STEPS", "STEPS_PER_INPUT", "Stop", "Walk", "Stepper", "walk"]

#: The first step of a segment tries the whole segment when its largest input change is below this
#: (radians), else this much; later steps grow after a success and halve after a failure.
FIRST_STEP = 0.1
#: A step (largest input change, radians) below this that still cannot be proven ends the track.
#: Reason: next to a fold the provable step shrinks like the distance d to it, while the two modes
#: that meet there are ~sqrt(d) apart; 1e-13 follows a mode to within ~1e-12 of its end (the modes
#: then ~1e-6 apart, the Jacobian's condition ~1e6, still well inside double precision), so two
#: modes that only come close (1e-4 apart: d ~ 1e-9) are followed through, never stopped at.
MIN_STEP = 1e-13
#: Largest number of steps (proven or rejected) of one track. Reason: a smooth path of N inputs
#: needs a few steps per input; 200 per input plus 10,000 covers folds approached geometrically.
STEPS_PER_INPUT = 200
MAX_STEPS = 10_000


@dataclass(frozen=True)
class Stop:
    """Where a walk stopped: ``kind`` "singular" (no step of MIN_STEP proven) or "range" (a joint
    leaves its range); ``s`` the last proven fraction of the segment and ``state`` the root there;
    ``lo``/``hi`` the bracket (fractions of the segment) of the singular input or of the range's exit;
    ``joint`` the joint outside (a range stop)."""

    kind: str
    s: float
    state: Any
    lo: float
    hi: float
    joint: str | None = None


@dataclass(frozen=True)
class Walk:
    """One walked segment: ``end`` (the state at x1; None when the walk stopped or was abandoned),
    ``steps`` and ``rejected`` (steps tried), ``last_step`` (the input change, radians, of its last
    proven step: the first one the next segment tries), ``stop`` (a :class:`Stop`, or None) and
    ``record``: (s, state, proposal, lo, hi) at the end of every proven step (s along the segment,
    lo/hi the box holding the root of every input of the step)."""

    end: Any
    steps: int
    rejected: int
    last_step: float
    stop: Stop | None = None
    record: list = field(default_factory=list)


class Stepper(Protocol):
    growth: float

    def predict(self, states, b0, b1) -> tuple[np.ndarray, np.ndarray]: ...

    def certify(self, states, proposals, b0, b1) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...

    def advance(self, state, proposal): ...

    def locate(self, state, b0, direction, t_max: float) -> tuple[float, float]: ...

    def check(self, state, proposal, x0, direction, s: float, t: float, b0, b1, lo, hi) -> str | Stop | None: ...


def walk(stepper: Stepper, states, x0, x1, budget: int, firsts=None) -> list[Walk]:
    """Walk W segments x0 -> x1 (W, A each, in path order) from the proven roots ``states`` (W, ...)
    in proven steps (module doc): a :class:`Walk` per segment, None for a walk abandoned after an
    earlier one stopped. A walk's first step is min(``firsts``[i], FIRST_STEP) radians of input
    (default FIRST_STEP; a tracker passes the previous segment's last proven step where the provable
    steps are short) or the whole segment when shorter. ``budget``: steps (proven and rejected) of
    all walks before RuntimeError. ``stepper.check`` answers None (the step stands), "finer" (proven,
    but not inside the joint ranges: walked again in halves) or a range :class:`Stop`."""
    n = len(states)
    x0, x1 = np.asarray(x0, dtype=float), np.asarray(x1, dtype=float)
    direction = x1 - x0
    span = np.abs(direction).max(axis=1, initial=0.0)
    last = np.full(n, FIRST_STEP) if firsts is None else np.minimum(np.asarray(firsts, dtype=float), FIRST_STEP)
    s = np.zeros(n)
    h = np.where(span <= last, 1.0, last / np.maximum(span, last))
    state = np.array(states, dtype=float)
    steps, rejected = np.zeros(n, dtype=int), np.zeros(n, dtype=int)
    records: list = [[] for _ in range(n)]
    out: list = [None] * n
    active = np.ones(n, dtype=bool)
    while active.any():
        if steps.sum() + rejected.sum() > budget:
            raise RuntimeError(f"track: gave up after {MAX_STEPS:,} steps plus {STEPS_PER_INPUT} per path row "
                               "(proven and rejected): the path is too long or too close to a singularity for "
                               "one track; split it into shorter paths")
        idx = np.flatnonzero(active)
        t = np.minimum(1.0, s[idx] + h[idx])
        b0 = x0[idx] + s[idx, None] * direction[idx]
        b1 = np.where((t == 1.0)[:, None], x1[idx], x0[idx] + t[:, None] * direction[idx])
        proposals, found = stepper.predict(state[idx], b0, b1)
        ok = np.zeros(len(idx), dtype=bool)
        lo = np.zeros((len(idx),) + proposals.shape[1:2])
        hi = np.zeros_like(lo)
        if found.any():
            ok[found], lo[found], hi[found] = stepper.certify(state[idx[found]], proposals[found], b0[found],
                                                              b1[found])
        for q, i in enumerate(idx):
            if not active[i]:                       # abandoned this round: a walk before it stopped
                continue
            if ok[q]:                               # every root of the step lies in [lo, hi]
                verdict = stepper.check(state[i], proposals[q], x0[i], direction[i], s[i], t[q], b0[q], b1[q], lo[q],
                                        hi[q])
                if isinstance(verdict, Stop):
                    out[i] = Walk(None, int(steps[i]), int(rejected[i]), float(last[i]), verdict, records[i])
                    active[i:] = False
                    continue
                if verdict == "finer":
                    rejected[i] += 1
                    h[i] *= 0.5
                    continue
                if span[i]:
                    last[i] = h[i] * span[i]        # the step tried (not cut at the segment end) was proven
                state[i] = stepper.advance(state[i], proposals[q])
                s[i], h[i] = t[q], h[i] * stepper.growth
                steps[i] += 1
                records[i].append((float(s[i]), state[i].copy(), proposals[q], lo[q], hi[q]))
                if s[i] == 1.0:
                    out[i] = Walk(state[i].copy(), int(steps[i]), int(rejected[i]), float(last[i]), None, records[i])
                    active[i] = False
                continue
            rejected[i] += 1
            h[i] *= 0.5
            if h[i] * span[i] < MIN_STEP:
                a, b = stepper.locate(state[i], b0[q], direction[i], 1.0 - s[i])
                stop = Stop("singular", float(s[i]), state[i].copy(), float(s[i] + a), float(s[i] + b))
                out[i] = Walk(None, int(steps[i]), int(rejected[i]), float(last[i]), stop, records[i])
                active[i:] = False
    return out
