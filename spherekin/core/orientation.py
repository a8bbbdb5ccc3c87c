"""Views of a rotation: unit quaternions and Euler angles (radians), to and from 3x3 matrices.

Conventions (as everywhere in spherekin): active rotations acting on column vectors, right-handed.
A quaternion is (w, x, y, z) with w the scalar part; q and -q are the same rotation, and the one
returned has w >= 0 (for w = 0 the first nonzero of x, y, z is positive), so that a rotation has one
printed form. Euler angles follow the naming of most robotics texts (and of scipy's ``Rotation``):
a convention is three axis letters; upper case ("ZYX") means intrinsic rotations, about the axes of
the frame as it turns, R = R_1(a) R_2(b) R_3(c); lower case ("zyx") means extrinsic rotations, about
the fixed axes, R = R_3(c) R_2(b) R_1(a). Consecutive axes must differ ("ZYZ" is fine, "ZZY" not).
"""

from __future__ import annotations

import math

import numpy as np

from .angles import check_turn

__all__ = ["quaternion_matrix", "quaternion_matrices", "rotation_from_quaternion", "quaternions_from_rotations", "rotation_from_euler",
           "EULER_AXES", "check_euler_convention", "QUATERNION_COLUMNS", "ROTATION_COLUMNS"]

#: Column names of a platform rotation in a table (batch's results, a track's frame): the unit
#: quaternion (qw >= 0) and the matrix R row-major (v_i = R v_i^0).
QUATERNION_COLUMNS = ("qw", "qx", "qy", "qz")
ROTATION_COLUMNS = tuple(f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3))

#: The axis letters of an Euler convention.
EULER_AXES = "xyz"
#: |q| below this is not a rotation but a typo (a quaternion typed by hand is normalized; one of
#: norm ~0 has no direction to normalize).
QUATERNION_MIN_NORM = 1e-6


def quaternion_matrix(q) -> np.ndarray:
    """S(q) (3, 3): the rotation of the quaternion q = (w, x, y, z) times |q|^2 (quadratic in q).

    S(q) / |q|^2 is the right-handed rotation by 2 acos(w / |q|) about (x, y, z).
    """
    return quaternion_matrices(np.asarray(q, dtype=float)[None])[0]


def quaternion_matrices(q) -> np.ndarray:
    """S(q) (B, 3, 3) of quaternions q (B, 4), each as :func:`quaternion_matrix`."""
    w, x, y, z = np.moveaxis(np.asarray(q, dtype=float), -1, 0)
    return np.stack([
        np.stack([w * w + x * x - y * y - z * z, 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)], axis=-1),
        np.stack([2.0 * (x * y + w * z), w * w - x * x + y * y - z * z, 2.0 * (y * z - w * x)], axis=-1),
        np.stack([2.0 * (x * z - w * y), 2.0 * (y * z + w * x), w * w - x * x - y * y + z * z], axis=-1),
    ], axis=-2)


def rotation_from_quaternion(q, key: str = "quaternion") -> np.ndarray:
    """The rotation matrix (3, 3) of the quaternion q = (w, x, y, z), normalized first.

    ValueError naming ``key`` unless q is 4 finite numbers of norm at least QUATERNION_MIN_NORM.
    """
    try:
        arr = np.asarray(q, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{key}: expected 4 numbers w, x, y, z, got {q!r}") from None
    if arr.shape != (4,):
        raise ValueError(f"{key}: expected 4 numbers w, x, y, z, got {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{key}: expected finite numbers, got {arr.tolist()}")
    norm = float(np.linalg.norm(arr))
    if norm < QUATERNION_MIN_NORM:
        raise ValueError(f"{key}: expected a nonzero quaternion (norm >= {QUATERNION_MIN_NORM:g}), got norm {norm:.3g}")
    return quaternion_matrix(arr / norm)


def quaternions_from_rotations(rot) -> np.ndarray:
    """Unit quaternions (..., 4) = (w, x, y, z) of rotation matrices (..., 3, 3), w >= 0.

    Shepperd's method, vectorized: of 1 + tr R and 1 + 2 R_kk - tr R (4 |w|^2, 4 |x|^2, ...), the
    largest gives the component computed by a square root, well away from 0, and the others by
    division; then the sign is fixed (module doc).
    """
    r = np.asarray(rot, dtype=float)
    shape = r.shape[:-2]
    r = r.reshape(-1, 3, 3)
    tr = r[:, 0, 0] + r[:, 1, 1] + r[:, 2, 2]
    cand = np.stack([1 + tr, 1 + 2 * r[:, 0, 0] - tr, 1 + 2 * r[:, 1, 1] - tr, 1 + 2 * r[:, 2, 2] - tr], axis=1)
    k = np.argmax(cand, axis=1)
    big = 0.5 * np.sqrt(np.maximum(cand[np.arange(len(k)), k], 0.0))
    s = 0.25 / big
    # the sums and differences of off-diagonal pairs: 4 w x, 4 w y, 4 w z, 4 x y, 4 x z, 4 y z
    wx, wy, wz = r[:, 2, 1] - r[:, 1, 2], r[:, 0, 2] - r[:, 2, 0], r[:, 1, 0] - r[:, 0, 1]
    xy, xz, yz = r[:, 0, 1] + r[:, 1, 0], r[:, 0, 2] + r[:, 2, 0], r[:, 1, 2] + r[:, 2, 1]
    rows = {
        0: (big, wx * s, wy * s, wz * s),
        1: (wx * s, big, xy * s, xz * s),
        2: (wy * s, xy * s, big, yz * s),
        3: (wz * s, xz * s, yz * s, big),
    }
    q = np.empty((len(k), 4))
    for j, comps in rows.items():
        sel = k == j
        q[sel] = np.stack(comps, axis=1)[sel]
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    # one representative of +-q: w > 0, or the first nonzero of x, y, z positive when w == 0
    lead = np.where(q[:, 0] != 0, q[:, 0], np.where(q[:, 1] != 0, q[:, 1], np.where(q[:, 2] != 0, q[:, 2], q[:, 3])))
    q *= np.where(lead < 0, -1.0, 1.0)[:, None]
    return q.reshape(*shape, 4)


def check_euler_convention(convention: str, key: str = "convention") -> str:
    """An Euler convention (module doc): three letters of x, y, z, all upper or all lower case,
    consecutive ones different. ValueError naming ``key`` otherwise."""
    ok = (isinstance(convention, str) and len(convention) == 3 and convention.lower() == convention.lower()
          and all(c in EULER_AXES for c in convention.lower()) and (convention.isupper() or convention.islower())
          and convention[0].lower() != convention[1].lower() and convention[1].lower() != convention[2].lower())
    if not ok:
        raise ValueError(f"{key}: expected three axis letters of x, y, z, upper case for intrinsic rotations "
                         f"(e.g. 'ZYX', 'ZYZ') or lower case for extrinsic ones (e.g. 'xyz'), consecutive axes "
                         f"different, got {convention!r}")
    return convention


def _axis_rotation(axis: str, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    i = EULER_AXES.index(axis)
    j, k = (i + 1) % 3, (i + 2) % 3
    out = np.eye(3)
    out[j, j], out[j, k], out[k, j], out[k, k] = c, -s, s, c
    return out


def rotation_from_euler(angles, convention: str, key: str = "euler") -> np.ndarray:
    """The rotation matrix (3, 3) of three Euler angles (radians) in ``convention`` (module doc)."""
    check_euler_convention(convention)
    try:
        a = [float(v) for v in angles]
    except (TypeError, ValueError):
        raise ValueError(f"{key}: expected 3 angles in radians, got {angles!r}") from None
    if len(a) != 3 or not all(math.isfinite(v) for v in a):
        raise ValueError(f"{key}: expected 3 finite angles in radians, got {list(a)}")
    a = [check_turn(key, v) for v in a]          # 10,-20,30 without --degrees: refused, not misread
    mats = [_axis_rotation(c.lower(), v) for c, v in zip(convention, a)]
    if convention.isupper():            # intrinsic: R = R_1 R_2 R_3
        return mats[0] @ mats[1] @ mats[2]
    return mats[2] @ mats[1] @ mats[0]  # extrinsic: R = R_3 R_2 R_1
