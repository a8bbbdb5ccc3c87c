"""Small numpy geometry of spherical polygons, written from first principles (no spherekin).

Conventions (radians, right-handed, active rotations on column vectors):

* a spherical polygon is a cyclic list of unit vectors (its vertices p_1..p_m);
* side i joins p_i to p_{i+1}; its length alpha_i = angle(p_i, p_{i+1}) in (0, pi) and its pole
  n_i = p_i x p_{i+1} / |p_i x p_{i+1}|;
* the exterior angle theta_i at p_i is the signed angle from n_{i-1} to n_i, measured about p_i by
  the right-hand rule -- the angle "from the prolongation of the first side beyond the common
  vertex to the second side" of Section 2, with the sign fixed by the frame of Eq. (1)
  (x along the vertex, z along the pole of the outgoing side).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "rx",
    "rz",
    "Z",
    "rotation_about",
    "signed_angle",
    "exterior_angles",
    "side_lengths",
    "random_rotations",
    "random_polygon",
    "normalized_product",
    "wrap",
]

Z = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
Z.flags.writeable = False

#: A side shorter than this (radians) has no well-defined pole: refuse it rather than return noise.
MIN_SIDE = 1e-9


def rx(a: float) -> np.ndarray:
    """Rx(a), shape (3, 3)."""
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rz(a: float) -> np.ndarray:
    """Rz(a), shape (3, 3)."""
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def normalized_product(phis) -> np.ndarray:
    """prod_k Rx(phi_k) Z (the form of Eq. 2) for a 1-D sequence of angles."""
    out = np.eye(3)
    for phi in phis:
        out = out @ rx(phi) @ Z
    return out


def rotation_about(axis, angle: float) -> np.ndarray:
    """Rodrigues: rotation by ``angle`` about the unit vector ``axis`` (right-hand rule)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


def signed_angle(a, b, axis) -> float:
    """Angle in (-pi, pi] rotating a onto b about ``axis`` (a, b perpendicular to axis)."""
    a, b, axis = (np.asarray(v, dtype=float) for v in (a, b, axis))
    return float(np.arctan2(np.dot(axis, np.cross(a, b)) / np.linalg.norm(axis), np.dot(a, b)))


def _poles(vertices: np.ndarray) -> np.ndarray:
    nxt = np.roll(vertices, -1, axis=0)
    cross = np.cross(vertices, nxt)
    norms = np.linalg.norm(cross, axis=1)
    if np.any(norms < np.sin(MIN_SIDE)):
        raise ValueError("vertices: expected consecutive vertices neither equal nor antipodal, "
                         f"got |p_i x p_i+1| = {norms.min():.3g}")
    return cross / norms[:, None]


def side_lengths(vertices) -> np.ndarray:
    """alpha_i = angle(p_i, p_{i+1}) of a closed polygon, shape (m,)."""
    p = np.asarray(vertices, dtype=float)
    nxt = np.roll(p, -1, axis=0)
    return np.arctan2(np.linalg.norm(np.cross(p, nxt), axis=1), np.sum(p * nxt, axis=1))


def exterior_angles(vertices) -> np.ndarray:
    """theta_i = signed angle from n_{i-1} to n_i about p_i (see the module docstring), shape (m,)."""
    p = np.asarray(vertices, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 3:
        raise ValueError(f"vertices: expected shape (m, 3) with m >= 3, got {p.shape}")
    poles = _poles(p)
    prev = np.roll(poles, 1, axis=0)
    return np.array([signed_angle(prev[i], poles[i], p[i]) for i in range(len(p))])


def random_rotations(rng: np.random.Generator, count: int) -> np.ndarray:
    """``count`` uniformly random rotations (unit quaternions from a normal sample), shape (count, 3, 3)."""
    q = rng.normal(size=(count, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    a, b, c, d = q.T
    return np.stack([
        np.stack([a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c)], -1),
        np.stack([2 * (b * c + a * d), a * a - b * b + c * c - d * d, 2 * (c * d - a * b)], -1),
        np.stack([2 * (b * d - a * c), 2 * (c * d + a * b), a * a - b * b - c * c + d * d], -1),
    ], axis=1)


def random_polygon(rng: np.random.Generator, m: int) -> np.ndarray:
    """m random unit vertices (a generic, possibly self-intersecting spherical polygon), shape (m, 3)."""
    p = rng.normal(size=(m, 3))
    return p / np.linalg.norm(p, axis=1, keepdims=True)


def wrap(angle):
    """Angle(s) reduced to [-pi, pi)."""
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi
