"""spherekin.core.orientation against scipy's Rotation (an independent implementation)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from spherekin.core.orientation import (check_euler_convention, quaternion_matrix, quaternions_from_rotations,
                                        rotation_from_euler, rotation_from_quaternion)

quaternions = st.lists(st.floats(-1, 1, allow_nan=False), min_size=4, max_size=4).filter(
    lambda q: np.linalg.norm(q) > 1e-3)


@given(quaternions)
@settings(max_examples=200, deadline=None)
def test_rotation_from_quaternion_is_scipys(q):
    w, x, y, z = q
    ref = Rotation.from_quat([x, y, z, w]).as_matrix()          # scipy: scalar last
    np.testing.assert_allclose(rotation_from_quaternion(q), ref, atol=1e-13)


@given(quaternions)
@settings(max_examples=200, deadline=None)
def test_quaternion_of_a_rotation_gives_it_back_with_w_non_negative(q):
    w, x, y, z = q
    rot = Rotation.from_quat([x, y, z, w]).as_matrix()
    got = quaternions_from_rotations(rot)
    assert got.shape == (4,)
    assert got[0] >= 0
    np.testing.assert_allclose(np.linalg.norm(got), 1.0, atol=1e-15)
    expected = np.array(q) / np.linalg.norm(q)
    expected = expected if expected[0] > 0 else -expected
    if abs(expected[0]) > 1e-6:            # away from w = 0 the representative is unique
        np.testing.assert_allclose(got, expected, atol=1e-12)
    np.testing.assert_allclose(quaternion_matrix(got), rot, atol=1e-13)


def test_quaternions_of_many_rotations_at_once_including_half_turns():
    rots = Rotation.random(500, random_state=3).as_matrix()
    # half turns (w = 0) about the axes and a diagonal: the branch of Shepperd's method with x, y or z largest
    half = [np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, 1.0, -1.0]), np.diag([-1.0, -1.0, 1.0]),
            Rotation.from_rotvec(np.pi * np.array([1.0, 1.0, 0.0]) / np.sqrt(2)).as_matrix()]
    rots = np.concatenate([rots, np.array(half)]).reshape(2, 252, 3, 3)
    q = quaternions_from_rotations(rots)
    assert q.shape == (2, 252, 4)
    back = Rotation.from_quat(np.roll(q.reshape(-1, 4), -1, axis=1)).as_matrix()
    np.testing.assert_allclose(back, rots.reshape(-1, 3, 3), atol=1e-13)
    flat = q.reshape(-1, 4)
    assert np.all(flat[:, 0] >= 0)
    np.testing.assert_allclose(flat[-4:-1], [[0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], atol=1e-15)


@pytest.mark.parametrize("convention", ["ZYX", "XYZ", "ZYZ", "ZXZ", "YXY", "xyz", "zyx", "zyz", "xzx"])
def test_euler_angles_are_scipys(convention):
    rng = np.random.default_rng(7)
    for angles in rng.uniform(-np.pi, np.pi, (20, 3)):
        ref = Rotation.from_euler(convention, angles).as_matrix()
        np.testing.assert_allclose(rotation_from_euler(angles, convention), ref, atol=1e-14)


@pytest.mark.parametrize("bad", ["ZY", "ZZY", "ZyX", "abc", "XYZW", "", 3, None, "xxy"])
def test_a_bad_euler_convention_is_named(bad):
    with pytest.raises(ValueError, match="convention: expected three axis letters"):
        check_euler_convention(bad)


@pytest.mark.parametrize("q, match", [([0, 0, 0, 0], "nonzero"), ([1, 0, 0], "4 numbers"),
                                      ([1, float("nan"), 0, 0], "finite"), ("abcd", "4 numbers")])
def test_a_bad_quaternion_is_named(q, match):
    with pytest.raises(ValueError, match=match):
        rotation_from_quaternion(q, "--quaternion")


def test_bad_euler_angles_are_named():
    with pytest.raises(ValueError, match="euler: expected 3 finite angles"):
        rotation_from_euler([0.1, 0.2], "ZYX")
    with pytest.raises(ValueError, match="euler: expected 3 finite angles"):
        rotation_from_euler([0.1, 0.2, float("inf")], "ZYX")
