"""Elementary rotations and the closure equation of a spherical polygon (paper Section 2).

Conventions (radians throughout, right-handed, active rotations acting on column vectors):

    Rx(a) = [[1, 0, 0], [0, cos a, -sin a], [0, sin a, cos a]]
    Rz(a) = [[cos a, -sin a, 0], [sin a, cos a, 0], [0, 0, 1]]
    Z     = Rz(pi/2) = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]

A spherical polygon with sides alpha_1..alpha_m and exterior angles theta_1..theta_m closes when
(Eq. 1)  prod_i Rx(theta_i) Rz(alpha_i) = I.  Its *normalized* form (Eq. 2) has n = 2m factors
F_n(Phi) = prod_i Rx(phi_i) Z, one per vertex of a polygon whose sides are all pi/2.

Errata handled here (verified in ``tests/test_rotations.py``):

* The paper's index rule for phi_i is swapped as printed ("i even -> theta_{(i+1)/2}, i odd ->
  alpha_{i/2}" gives non-integer indices). Reading it off the factor order
  Rx(theta_1 + pi) Z Rx(alpha_1 + pi) Z ... the correct rule is
  phi_{2k-1} = theta_k + pi and phi_{2k} = alpha_k + pi (1-based k).
* The normalized product is not equal to the Eq. 1 product factor by factor; it is its conjugate
  by Rx(pi/2):  prod Rx(theta_i+pi) Z Rx(alpha_i+pi) Z = Rx(pi/2) [prod Rx(theta_i) Rz(alpha_i)] Rx(pi/2)^T.
  Hence one equals I exactly when the other does, which is all the paper needs.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "cross",
    "rx",
    "rz",
    "Z",
    "normalized_factor",
    "normalized_closure",
    "polygon_closure",
    "normalize_polygon",
    "normalization_conjugator",
    "split_angle",
]


def cross(a, b) -> np.ndarray:
    """The cross product a x b of 3-vectors, shape (3,) or batches (..., 3) broadcast together.

    The same products and differences as ``np.cross`` (equal to it bit for bit, tested), without
    its axis handling: np.cross costs ~13 us on two 3-vectors, this ~1 us, and loading and solving
    a 3-RRR calls it ~80 times per process (benchmarks/bench_process.py).
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape == (3,) and b.shape == (3,):
        (a0, a1, a2), (b0, b1, b2) = a.tolist(), b.tolist()
        return np.array((a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0))
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack((a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0), axis=-1)


def _angles(name: str, value) -> np.ndarray:
    """Validate an angle (or array of angles, radians) and return it as a float array."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected real angle(s) in radians, got {value!r}") from None
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: expected finite angle(s) in radians, got {value!r}")
    return arr


def _axis_rotation(angle: np.ndarray, i: int, j: int) -> np.ndarray:
    """Rotation by ``angle`` in the (i, j) coordinate plane; shape (*angle.shape, 3, 3)."""
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros(angle.shape + (3, 3))
    out[..., :, :] = np.eye(3)
    out[..., i, i] = c
    out[..., i, j] = -s
    out[..., j, i] = s
    out[..., j, j] = c
    return out


def rx(angle) -> np.ndarray:
    """Rotation about the x axis by ``angle`` radians; shape (*angle.shape, 3, 3)."""
    return _axis_rotation(_angles("angle", angle), 1, 2)


def rz(angle) -> np.ndarray:
    """Rotation about the z axis by ``angle`` radians; shape (*angle.shape, 3, 3)."""
    return _axis_rotation(_angles("angle", angle), 0, 1)


#: Z = Rz(pi/2), written exactly (no rounding of cos(pi/2)); read-only.
Z = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
Z.flags.writeable = False


def normalized_factor(phi) -> np.ndarray:
    """One factor Rx(phi) Z of Eq. (2); shape (*phi.shape, 3, 3).

    Rx(phi) Z = [[0, -1, 0], [cos phi, 0, -sin phi], [sin phi, 0, cos phi]].
    """
    return rx(phi) @ Z


def _chain(mats: np.ndarray) -> np.ndarray:
    """Ordered product M_1 M_2 ... M_n of mats with shape (..., n, 3, 3)."""
    out = np.broadcast_to(np.eye(3), mats.shape[:-3] + (3, 3)).copy()
    for k in range(mats.shape[-3]):
        out = out @ mats[..., k, :, :]
    return out


def normalized_closure(phis) -> np.ndarray:
    """F_n(Phi) = prod_{i=1..n} Rx(phi_i) Z (Eq. 2).

    ``phis`` has shape (..., n) (radians); returns (..., 3, 3). The loop closes when this is I.
    """
    phis = _angles("phis", phis)
    if phis.ndim == 0:
        raise ValueError("phis: expected shape (..., n) with n >= 1 angles, got a scalar")
    return _chain(normalized_factor(phis))


def polygon_closure(sides, exterior) -> np.ndarray:
    """prod_{i=1..m} Rx(theta_i) Rz(alpha_i) (Eq. 1); sides alpha and exterior angles theta, shape (..., m)."""
    sides, exterior = _angles("sides", sides), _angles("exterior", exterior)
    if sides.ndim == 0 or sides.shape != exterior.shape:
        raise ValueError(
            "sides, exterior: expected equal shapes (..., m) with m >= 1, "
            f"got {sides.shape} and {exterior.shape}"
        )
    return _chain(rx(exterior) @ rz(sides))


def normalize_polygon(sides, exterior) -> np.ndarray:
    """Angles phi_1..phi_{2m} of the normalized form (Eq. 2) of a polygon given as in Eq. (1).

    Implements the *corrected* index rule phi_{2k-1} = theta_k + pi, phi_{2k} = alpha_k + pi
    (the paper prints the parities swapped). Shapes: (..., m) -> (..., 2m). The result closes
    exactly when Eq. (1) does; see :func:`normalization_conjugator`.
    """
    sides, exterior = _angles("sides", sides), _angles("exterior", exterior)
    if sides.ndim == 0 or sides.shape != exterior.shape:
        raise ValueError(
            "sides, exterior: expected equal shapes (..., m) with m >= 1, "
            f"got {sides.shape} and {exterior.shape}"
        )
    out = np.empty(sides.shape[:-1] + (2 * sides.shape[-1],))
    out[..., 0::2] = exterior + np.pi
    out[..., 1::2] = sides + np.pi
    return out


def normalization_conjugator() -> np.ndarray:
    """P = Rx(pi/2), with normalized_closure(normalize_polygon(a, t)) = P polygon_closure(a, t) P^T.

    Per factor, Rx(theta + pi) Z Rx(alpha + pi) Z = Rx(theta) Ry(-alpha) = P Rx(theta) Rz(alpha) P^T.
    """
    return np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def split_angle(phi1, phi2) -> tuple[float, float, float]:
    """Angle-splitting identity (Eq. 6) in factor form.

    Rx(phi1 + phi2) = Rx(phi2 + pi) Z Rx(pi) Z Rx(phi1), hence, in a normalized chain, the single
    factor Rx(phi1 + phi2) Z equals the three factors with angles (phi2 + pi, pi, phi1). The identity
    holds because Z Rx(pi) Z = Rx(pi). Used to move a known offset into separate known factors.
    """
    a1, a2 = _angles("phi1", phi1), _angles("phi2", phi2)
    for name, a in (("phi1", a1), ("phi2", a2)):
        if a.ndim:
            raise ValueError(f"{name}: expected a scalar angle, got shape {a.shape}")
    return (float(a2) + np.pi, np.pi, float(a1))
