"""Tracking at a normal resolution (issue 30): 0.01-rad rows proven in batches at the first try,
and steps that fail the batched proof split and proven, against the poses that generated the path
and the degree-8 eigenvalue reference (references/peers_closed_form.py)."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.bench_track import smooth_path
from references.peers_closed_form import direct_kinematics, geometry_of
from tests.conftest import singular_beta1
from spherekin.mechanism import general_3rrr, gosselin
from spherekin.systems.platform import platform_legs
from scipy.spatial.transform import Rotation

from spherekin.trust.continuation import LegEquations, _predict, cayley, cayley_coordinates, track


def test_cayley_coordinates_invert_cayley_for_many_rotations_at_once():
    rng = np.random.default_rng(30)
    rots = Rotation.random(50, random_state=rng)
    vec = rots.as_rotvec()                           # angle t about n: w = 2 tan(t / 2) n
    t = np.linalg.norm(vec, axis=1, keepdims=True)
    w = 2 * np.tan(t / 2) * vec / t
    np.testing.assert_allclose(cayley_coordinates(rots.as_matrix()), w, rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(cayley(w), rots.as_matrix(), atol=1e-13)   # (N, 3) -> (N, 3, 3)


@pytest.mark.parametrize("make", [general_3rrr, gosselin])
def test_a_path_at_0_01_rad_rows_is_proven_step_by_step_at_the_first_try(make):
    mech = make()
    rots, path = smooth_path(mech, 150, 0.01)        # inverse kinematics (one working mode) of a pose curve
    gaps = np.abs(np.diff(path, axis=0)).max(axis=1)
    assert 0.0099 < gaps.mean() < 0.0101 and gaps.max() < 0.0102
    tr = track(mech, path, rots[0])
    assert tr.complete and len(tr.poses) == len(path)
    for p, r in zip(tr.poses, rots):                  # the generating poses are the reference
        np.testing.assert_allclose(p.platform_rotation, r, atol=1e-12)
    # one proven step per row, none rejected: the 0.01-rad steps pass the batched proof as they are
    # (before issue 30 every one of them failed it and was walked in halves, one segment at a time)
    assert tr.rejected_steps == 0 and tr.proven_steps == len(path) - 1
    assert [p.proven_steps for p in tr.poses] == [0] + [1] * (len(path) - 1)


def _continued(geometry, x0, x1, poses, samples):
    """The reference's continuation of each of ``poses`` (at x0) along the straight inputs x0 -> x1:
    the nearest of its poses at each of ``samples`` points (the modes stay far apart against the
    poses' moves between samples here)."""
    poses = list(poses)
    for t in np.linspace(0.0, 1.0, samples)[1:]:
        ref = direct_kinematics(geometry, x0 + t * (x1 - x0))
        poses = [min(ref, key=lambda r: np.abs(r - p).max()) for p in poses]
    return poses


def test_big_jumps_next_to_a_fold_are_split_proven_and_never_swap_modes():
    # 0.01-rad rows from beta1 = -3.05 to -3.0, one jump to 1e-3 before the fold at ~-2.7141 (where two
    # of the six assemblies meet; beta2 = 0, beta3 = 0.5), one jump back, 0.01-rad rows back to -3.05
    mech = general_3rrr()
    geometry = geometry_of(mech)
    turn = singular_beta1(geometry, -2.72, -2.71, 6) - 1e-3
    out = np.linspace(-3.05, -3.0, 6)
    xs = np.concatenate([out, [turn], out[::-1]])
    path = np.column_stack([xs, np.zeros(len(xs)), np.full(len(xs), 0.5)])
    jump = len(out)                                   # rows jump - 1 -> jump -> jump + 1: the two jumps
    ref = np.array(mech.platform_reference_matrix)
    eqs = LegEquations(platform_legs(mech))
    starts = direct_kinematics(geometry, path[0])
    assert len(starts) == 6
    expected = [starts]                               # every row's poses: the reference's continuations
    for k in range(1, len(path)):
        expected.append(_continued(geometry, path[k - 1], path[k], expected[-1], 200 if k in (jump, jump + 1) else 3))
    tracks = [track(mech, path, start) for start in starts]
    for i, (tr, start) in enumerate(zip(tracks, starts)):
        assert tr.complete and len(tr.poses) == len(path)
        for p, poses in zip(tr.poses, expected):
            np.testing.assert_allclose(p.platform_rotation, poses[i], atol=1e-9)
        np.testing.assert_allclose(tr.poses[-1].platform_rotation, start, atol=1e-12)      # back: no swap
    swaps_unproven = 0
    for tr in tracks:
        # the jumps failed the batched proof and were split into several proven steps; the rows around
        # them were not
        assert tr.poses[jump].proven_steps > 1 and tr.poses[jump + 1].proven_steps > 1
        assert [p.proven_steps for p in tr.poses[1:jump]] == [1] * (jump - 1)
        assert tr.rejected_steps >= 2
        # the float prediction alone (tangent + Newton over each jump, no proof) there and back
        d = tr.poses[jump - 1].platform_rotation @ ref.T
        for a, b in ((jump - 1, jump), (jump, jump + 1)):
            w = _predict(eqs, d, path[a], path[b])
            d = None if w is None else d @ cayley(w)
            if d is None:
                break
        swaps_unproven += d is None or np.abs(d @ ref - tr.poses[jump + 1].platform_rotation).max() > 1e-6
    # what the proofs are for: accepting the predicted jumps unproven loses or swaps an assembly
    assert swaps_unproven >= 1
