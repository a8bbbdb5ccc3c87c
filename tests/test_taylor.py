"""Second-order Taylor forms over a tolerance set (spherekin/core/taylor.py): every value of the
function, at every parameter of the set, lies within the form's bounds; the reach of a linear form is
exact; a quadratic part is carried exactly (no second-order term left in the bound).

The functions are evaluated here directly in floats at sampled parameters (disks' rims and insides,
intervals' ends), not through the module.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from spherekin.core.taylor import TaylorForm, ToleranceSet, cos_sin_shift, inverse_norm, stack

#: Two disks (parameters 0-1 and 2-3) and an interval (parameter 4).
BLOCKS = (([0, 1], 0.01), ([2, 3], 0.003), ([4], 0.02))


def samples(rng, n=400):
    """Parameters of the set: half on the disks' rims and the interval's ends."""
    out = []
    for k in range(n):
        p = np.zeros(5)
        for cols, r in BLOCKS:
            if len(cols) == 2:
                ang = rng.uniform(0, 2 * math.pi)
                rad = r if k % 2 == 0 else r * math.sqrt(rng.uniform())
                p[cols] = rad * math.cos(ang), rad * math.sin(ang)
            else:
                p[cols] = r * (rng.choice([-1.0, 1.0]) if k % 2 == 0 else rng.uniform(-1, 1))
        out.append(p)
    return out


def test_the_reach_of_a_linear_form_is_its_maximum_over_the_set():
    space = ToleranceSet(BLOCKS, 5)
    rng = np.random.default_rng(1)
    lin = rng.normal(size=5)
    best = np.zeros(5)                         # the maximizer: each block along the form's gradient
    for cols, r in BLOCKS:
        best[cols] = r * lin[cols] / np.linalg.norm(lin[cols])
    assert space.reach(lin) >= lin @ best and math.isclose(space.reach(lin), lin @ best, rel_tol=1e-12)
    assert all(abs(lin @ p) <= space.reach(lin) for p in samples(rng))


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_products_rotations_and_trig_hold_every_sampled_value(seed):
    """x(p) = (a + s u) x (b + t v) . (c cos(d + e)) + (a + s u) . (b + t v) sin(d + e): each sampled
    value inside the form's bounds."""
    rng = np.random.default_rng(seed)
    space = ToleranceSet(BLOCKS, 5)
    a, u, b, v, c = (rng.normal(size=3) for _ in range(5))
    d = float(rng.uniform(-math.pi, math.pi))
    sym = [space.symbol(k) for k in range(5)]
    left = space.constant(a) + sym[0] * space.constant(u) + sym[1] * space.constant(2.0 * u)
    right = space.constant(b) + sym[2] * space.constant(v) - sym[3] * space.constant(v)
    cos_t, sin_t = cos_sin_shift(space, d, 4, 0.02)
    form = left.cross(right).dot(space.constant(c) * cos_t) + left.dot(right) * sin_t
    lo, hi = form.bounds()

    def direct(p):
        aa = a + p[0] * u + p[1] * 2.0 * u
        bb = b + p[2] * v - p[3] * v
        return float(np.cross(aa, bb) @ (c * math.cos(d + p[4])) + (aa @ bb) * math.sin(d + p[4]))

    values = [direct(p) for p in samples(rng, 200)]
    assert lo <= min(values) and max(values) <= hi
    # and the bounds are tight: not much wider than the spread of the samples (which falls short of the extremes)
    assert hi - lo <= 1.5 * (max(values) - min(values)) + 1e-5


def test_complex_forms_hold_every_sampled_value():
    rng = np.random.default_rng(3)
    space = ToleranceSet(BLOCKS, 5)
    z0 = rng.normal(size=3) + 1j * rng.normal(size=3)
    g = rng.normal(size=(3, 5)) + 1j * rng.normal(size=(3, 5))
    y = TaylorForm(space, z0, g, np.zeros((3, 5, 5)), np.zeros(3))
    m = rng.normal(size=(3, 3)) + 1j * rng.normal(size=(3, 3))
    form = (y * y).matvec(m)
    centre, radius = form.disk()
    for p in samples(rng, 200):
        w = z0 + g @ p
        assert np.all(np.abs(m @ (w * w) - centre) <= radius)


def test_a_quadratic_part_is_carried_exactly():
    """(a + L p)^2 has no rest but rounding: its quadratic part is L L^T, its bound tiny; the unit-norm
    factor 1 / sqrt(1 + s^2 + t^2) holds every sampled value."""
    space = ToleranceSet(BLOCKS, 5)
    rng = np.random.default_rng(4)
    lin = rng.normal(size=5)
    x = TaylorForm(space, np.array(0.7), lin, np.zeros((5, 5)), np.array(0.0))
    sq = x * x
    assert np.allclose(sq.quad, np.outer(lin, lin)) and sq.rad < 1e-13
    lam = inverse_norm(space, (0, 1), 0.01, 0.0)
    lo, hi = lam.bounds()
    for p in samples(rng, 200):
        assert lo <= 1.0 / math.sqrt(1.0 + p[0] ** 2 + p[1] ** 2) <= hi
        value = 0.7 + lin @ p
        assert abs(value * value - (sq.c + sq.lin @ p + p @ sq.quad @ p)) <= sq.rad + 1e-15


def test_stack_and_indexing_keep_each_form():
    space = ToleranceSet(BLOCKS, 5)
    x = stack([space.symbol(0), space.symbol(4).scale(3.0)], 0)
    assert x.shape == (2,) and x[1].lin[4] == 3.0 and x[0].lin[0] == 1.0
