"""Near-singular inputs of 3-RRR mechanisms, judged against the 50-digit reference (issue 13).

Used by tests/test_near_singular.py and ``python -m benchmarks.sweep_roots --near-singular``.
:func:`random_segment` finds, for a seeded random geometry, a segment of inputs along which the
reference count of real assemblies changes and the singular input on it; :func:`judge` solves one
input with spherekin's defaults and says what, if anything, went wrong by the issue's rules:

* ``wrong_count``: the count is reported exact but differs from the reference;
* ``flagged_far``: the count is a lower bound farther than FLAG_ALLOWED_WITHIN from the singular input;
* ``invented``: a proven entry (certified, or singular with a certificate) far from every reference root;
* ``lost``: a reference root neither reported nor inside the box of an entry that is not proven.
"""

from __future__ import annotations

import numpy as np

from references.random_designs import random_3rrr
from references.reference_roots import reference_roots, singular_input
from spherekin import solve
from spherekin.trust.solutions import is_proven

__all__ = ["MATCH", "FLAG_ALLOWED_WITHIN", "BOX_SLACK", "in_box", "judge", "random_segment"]

#: A reported rotation matches a reference root when every entry agrees to this: spherekin's
#: polished roots are accurate to ~1e-13 / sigma_min (~1e-7 at 1e-12 from a fold, where the two
#: roots of a pair are ~1e-6 apart; which of the two matched is left to the count check).
MATCH = 1e-6
#: Beyond this distance from the singular input a lower-bound count is a failure (the issue's rule).
FLAG_ALLOWED_WITHIN = 1e-8
#: A reference root lies in an entry's box when every angle is within this of it (radians): the
#: box ends are floats rounded from the search's boxes.
BOX_SLACK = 1e-9


def in_box(theta, sol) -> bool:
    """Whether the angles theta lie in the entry's box modulo 2 pi (per angle, BOX_SLACK either side).

    theta is moved into [lo, lo + 2 pi) per angle, so that a box of any width up to 2 pi (a
    continuum's hull, a merged cluster) is tested whole, not only its part within pi of lo."""
    lo, hi = np.asarray(sol.lo, float), np.asarray(sol.hi, float)
    d = lo + np.mod(np.asarray(theta, float) - lo, 2 * np.pi)
    return bool(np.all((d <= hi + BOX_SLACK) | (d - 2 * np.pi >= lo - BOX_SLACK)))


def judge(mech, geometry, inputs, distance) -> dict:
    """The verdict of one near-singular input: a dict of what went wrong (empty when all is right)."""
    ref = reference_roots(geometry, inputs)
    rep = solve(mech, tuple(float(v) for v in inputs))
    wrong = {}
    rots = [(s, s.platform_rotation) for s in rep.solutions if s.platform_rotation is not None]
    for s, r in rots:
        if is_proven(s) and not any(np.abs(r - q).max() < MATCH for q in ref.rotations):
            wrong["invented"] = wrong.get("invented", 0) + 1
    for q in ref.rotations:
        if any(np.abs(r - q).max() < MATCH for _, r in rots):
            continue
        # not reported as a point: it must lie in the box of an entry that is not proven
        ik = [m for m in mech.inverse_kinematics(q)
              if np.abs(np.remainder(np.array(m.inputs) - inputs + np.pi, 2 * np.pi) - np.pi).max() < 1e-7]
        covered = False
        for m in ik:
            theta = np.array([m.joint_angles[n] for n in rep.unknowns])
            covered |= any(in_box(theta, s) for s in rep.solutions if not is_proven(s))
        if not covered:
            wrong["lost"] = wrong.get("lost", 0) + 1
    if rep.count_exact and rep.proven_count != ref.count:
        wrong["wrong_count"] = (rep.proven_count, ref.count)
    if not rep.count_exact and abs(distance) > FLAG_ALLOWED_WITHIN:
        wrong["flagged_far"] = abs(distance)
    return dict(wrong=wrong, exact=bool(rep.count_exact), reference=ref.count, proven=rep.proven_count,
                entries=len(rep.solutions))



def random_segment(seed, max_tries: int = 200):
    """(mechanism, geometry, singular input, direction) for a seeded random general 3-RRR."""
    rng = np.random.default_rng(seed)
    for _ in range(max_tries):
        mech, data = random_3rrr(rng)
        geometry = tuple(np.array(v, dtype=float) for v in data)
        x_a, x_b = rng.uniform(-np.pi, np.pi, 3), rng.uniform(-np.pi, np.pi, 3)
        try:
            if reference_roots(geometry, x_a).count != reference_roots(geometry, x_b).count:
                _, x_star = singular_input(geometry, x_a, x_b)
                return mech, geometry, x_star, x_b - x_a
        except ValueError:
            continue
    raise RuntimeError(f"seed {seed}: no segment with a change of count in {max_tries} tries")
