"""Tests for spherekin.core.rotations: closed forms, an independent geometric model of Eq. (1), errata."""

import numpy as np
import pytest

from spherekin.core import rotations as R
from spherekin.core.rotations import cross


def random_polygon(rng, m):
    """Sides and exterior angles of a random spherical polygon, measured from its vertices.

    Independent of Eq. (1): vertices p_i are random unit vectors, side i joins p_i to p_{i+1} with
    pole n_i = p_i x p_{i+1} / |.|, alpha_i = angle(p_i, p_{i+1}), and the exterior angle theta_i at
    p_i is the signed angle from n_{i-1} to n_i about p_i (right-hand rule).
    """
    p = rng.normal(size=(m, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    nxt = np.roll(p, -1, axis=0)
    poles = np.cross(p, nxt)
    poles /= np.linalg.norm(poles, axis=1, keepdims=True)
    sides = np.arccos(np.clip(np.sum(p * nxt, axis=1), -1, 1))
    prev = np.roll(poles, 1, axis=0)
    exterior = np.arctan2(np.sum(p * np.cross(prev, poles), axis=1), np.sum(prev * poles, axis=1))
    return sides, exterior


def test_elementary_rotations_closed_form():
    np.testing.assert_array_almost_equal(R.rx(np.pi / 2), [[1, 0, 0], [0, 0, -1], [0, 1, 0]], 15)
    np.testing.assert_array_almost_equal(R.rz(np.pi / 2), R.Z, 15)
    a = np.linspace(-4, 4, 7)
    for m in (R.rx(a), R.rz(a), R.normalized_factor(a)):
        assert m.shape == (7, 3, 3)
        np.testing.assert_allclose(m @ np.swapaxes(m, -1, -2), np.broadcast_to(np.eye(3), m.shape), atol=1e-14)
        np.testing.assert_allclose(np.linalg.det(m), 1.0, atol=1e-14)


def test_normalized_factor_matrix():
    phi = 0.7
    c, s = np.cos(phi), np.sin(phi)
    np.testing.assert_allclose(R.normalized_factor(phi), [[0, -1, 0], [c, 0, -s], [s, 0, c]], atol=1e-15)


@pytest.mark.parametrize("m", [3, 4, 5, 7])
def test_eq1_closes_for_geometric_polygons(m):
    rng = np.random.default_rng(m)
    sides, exterior = random_polygon(rng, m)
    np.testing.assert_allclose(R.polygon_closure(sides, exterior), np.eye(3), atol=1e-12)


@pytest.mark.parametrize("m", [3, 4, 6])
def test_normalization_corrected_index_rule(m):
    rng = np.random.default_rng(10 + m)
    sides, exterior = random_polygon(rng, m)
    phis = R.normalize_polygon(sides, exterior)
    assert phis.shape == (2 * m,)
    # corrected rule: phi_{2k-1} = theta_k + pi, phi_{2k} = alpha_k + pi (1-based)
    np.testing.assert_allclose(phis[0], exterior[0] + np.pi)
    np.testing.assert_allclose(phis[1], sides[0] + np.pi)
    np.testing.assert_allclose(R.normalized_closure(phis), np.eye(3), atol=1e-12)
    # the rule as printed (parities swapped) does not close a closed polygon
    printed = np.empty(2 * m)
    printed[0::2], printed[1::2] = sides + np.pi, exterior + np.pi
    assert np.abs(R.normalized_closure(printed) - np.eye(3)).max() > 1e-3


def test_normalization_is_a_conjugation_not_an_equality():
    rng = np.random.default_rng(3)
    sides, exterior = rng.uniform(-3, 3, (2, 4))  # an arbitrary (non-closing) chain
    p = R.normalization_conjugator()
    np.testing.assert_allclose(p, R.rx(np.pi / 2), atol=1e-15)
    f1 = R.polygon_closure(sides, exterior)
    f2 = R.normalized_closure(R.normalize_polygon(sides, exterior))
    np.testing.assert_allclose(f2, p @ f1 @ p.T, atol=1e-13)
    assert np.abs(f2 - f1).max() > 1e-2  # not equal factor by factor


def test_eq6_angle_splitting():
    rng = np.random.default_rng(6)
    for phi1, phi2 in rng.uniform(-4, 4, (10, 2)):
        split = R.split_angle(phi1, phi2)
        np.testing.assert_allclose(R.normalized_closure(list(split)), R.normalized_factor(phi1 + phi2), atol=1e-14)
        np.testing.assert_allclose(
            R.rx(phi1 + phi2), R.normalized_factor(split[0]) @ R.normalized_factor(split[1]) @ R.rx(split[2]),
            atol=1e-14,
        )
    np.testing.assert_allclose(R.Z @ R.rx(np.pi) @ R.Z, R.rx(np.pi), atol=1e-15)


def test_batch_closure_equals_loop():
    rng = np.random.default_rng(1)
    phis = rng.uniform(-3, 3, (5, 6))
    batch = R.normalized_closure(phis)
    for k in range(5):
        single = np.eye(3)
        for p in phis[k]:
            single = single @ R.rx(p) @ R.Z
        np.testing.assert_allclose(batch[k], single, atol=1e-14)


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: R.rx(np.nan), "angle"),
        (lambda: R.rz("a"), "angle"),
        (lambda: R.normalized_closure(1.0), "phis"),
        (lambda: R.normalized_closure([0.1, np.inf]), "phis"),
        (lambda: R.polygon_closure([1, 2], [1]), "sides, exterior"),
        (lambda: R.normalize_polygon([1, 2, 3], [1, 2]), "sides, exterior"),
        (lambda: R.split_angle([1, 2], 0.0), "phi1"),
    ],
)
def test_bad_input_names_argument(call, name):
    with pytest.raises(ValueError, match=name):
        call()


@pytest.mark.parametrize("shape_a, shape_b", [((3,), (3,)), ((7, 3), (7, 3)), ((7, 3), (3,)), ((2, 1, 3), (4, 3))])
def test_cross_is_numpys_bit_for_bit(shape_a, shape_b):
    """rotations.cross: the same value as np.cross, exactly, for single vectors and broadcast batches."""
    rng = np.random.default_rng(len(shape_a) * 10 + len(shape_b))
    a, b = rng.normal(size=shape_a), rng.normal(size=shape_b)
    got = cross(a, b)
    assert got.shape == np.cross(a, b).shape and np.array_equal(got, np.cross(a, b))
    assert np.array_equal(cross([1, 0, 0], [0, 1, 0]), [0.0, 0.0, 1.0])
