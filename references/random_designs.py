"""Seeded random designs for the benchmarks and tests: rotations and general 3-RRR manipulators.

Shared by benchmarks/sweep_roots.py (random poses), benchmarks/near_singular.py (random segments through a
singular input) and the tests that draw random geometries (one module, so neither benchmark imports the
other's internals).
"""

from __future__ import annotations

import math

import numpy as np

from spherekin.mechanism import three_rrr

__all__ = ["random_rotation", "unit", "random_3rrr"]


def random_rotation(rng) -> np.ndarray:
    q = rng.normal(size=4)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def unit(rng) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def random_3rrr(rng):
    """A random general 3-RRR assembled at beta = 0, R = I (distal angles measured there), and
    its geometry (u, w0, v0, alpha2) for the independent leg-constraint check."""
    while True:
        u = [unit(rng) for _ in range(3)]
        w0 = [unit(rng) for _ in range(3)]
        v0 = [unit(rng) for _ in range(3)]
        a2 = [float(np.arccos(np.clip(w @ v, -1, 1))) for w, v in zip(w0, v0)]
        if min(a2) < 0.2 or max(a2) > math.pi - 0.2:
            continue
        try:
            return three_rrr(u, w0, v0, a2, name="random 3-RRR"), (u, w0, v0, a2)
        except ValueError:
            continue
