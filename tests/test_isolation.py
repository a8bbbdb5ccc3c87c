"""Tests for spherekin.search.isolation against independent references.

* square polynomial systems with KNOWN roots, built in the power basis:
  F_i(x) = sum_k (x_k - r_k) g_ik(x) has the simple root r (random g); a system with two roots a
  known distance apart; a box that holds no root;
* the Krawczyk contraction never loses the root; an isolated box holds the root (existence) and
  no box holding two roots is isolated (uniqueness); small boxes around a simple root are isolated;
* the Jacobian enclosure contains central finite differences at random points of the box;
* evaluate_at / jacobian_at against bernstein.evaluate and finite differences;
* Newton converges to the known root, and a root where another equation does not vanish is
  reported as spurious.
"""

import numpy as np
import pytest

from spherekin.core import bernstein
from spherekin.search.isolation import (KRAWCZYK_RCOND, SquareSystem, _derivative_bounds, _inverses, evaluate_at, jacobian_at, krawczyk_boxes,
                                 newton)
from conftest import times_linear

EPS = np.finfo(float).eps



def square_system(seed, n):
    """Bernstein control points (n, 3, ..., 3) on [0, 1]^n of n equations with the simple root r."""
    rng = np.random.default_rng(seed)
    r = rng.uniform(0.2, 0.8, n)
    eqs = []
    for i in range(n):
        total = np.zeros((3,) * n)
        for k in range(n):
            g = rng.normal(size=(3,) * n) * 0.3
            g[(slice(None),) * k + (-1,)] = 0.0
            g[(0,) * n] += 2.0 if k == i else 0.0          # diagonal dominance: G(r) well conditioned
            total = total + times_linear(g, k, r[k])
        eqs.append(total)
    c = bernstein.from_power(np.stack(eqs), nvars=n)
    assert np.abs(bernstein.evaluate(c, r, nvars=n)).max() < 1e-13
    return c, r


def two_root_system(n, r1, r2, rest):
    """(x_0 - r1)(x_0 - r2) = 0 and x_k = rest_k: roots (r1, rest) and (r2, rest)."""
    eqs = []
    first = np.zeros((3,) * n)
    first[(0,) * n] = r1 * r2
    first[(1,) + (0,) * (n - 1)] = -(r1 + r2)
    first[(2,) + (0,) * (n - 1)] = 1.0
    eqs.append(first)
    for k in range(1, n):
        e = np.zeros((3,) * n)
        e[(0,) * n] = -rest[k - 1]
        e[(0,) * k + (1,) + (0,) * (n - 1 - k)] = 1.0
        eqs.append(e)
    return bernstein.from_power(np.stack(eqs), nvars=n)


def on_boxes(c, boxes):
    """Control points restricted to boxes (B, n, 2), batch last, and the solver's tolerances."""
    cps = np.moveaxis(bernstein.restrict(c, boxes[:, None], nvars=boxes.shape[1]), 0, -1)
    tol = 1e3 * EPS * np.abs(c).reshape(len(c), -1).max(axis=1)
    return [cps], [np.repeat(tol[:, None], len(boxes), axis=1)]


def boxes_around(rng, point, count, log_width):
    n = len(point)
    w = 10 ** rng.uniform(*log_width, size=(count, n))
    a = np.clip(point - w * rng.uniform(0.05, 0.95, size=(count, n)), 0, 1)
    return np.stack([a, np.clip(a + w, 0, 1)], axis=-1)


def square(n):
    return SquareSystem(tuple((0, e) for e in range(n)))


@pytest.mark.parametrize("n, seed", [(2, 0), (3, 1), (4, 2)])
def test_contraction_keeps_the_root_and_small_boxes_are_isolated(n, seed):
    c, r = square_system(seed, n)
    rng = np.random.default_rng(seed)
    for log_w, must_isolate in (((-1.5, -0.7), False), ((-4.0, -2.5), True)):
        boxes = boxes_around(rng, r, 60, log_w)
        cps, tols = on_boxes(c, boxes)
        iso, lo, hi = krawczyk_boxes(square(n), cps, tols)
        u = (r - boxes[..., 0]) / (boxes[..., 1] - boxes[..., 0])
        assert np.all((lo <= u + 1e-12) & (u <= hi + 1e-12)), "the contraction lost the root"
        if must_isolate:
            assert iso.mean() > 0.9
            assert np.max(hi - lo) < 0.5                    # quadratic contraction of small boxes


def test_a_box_without_root_is_never_isolated_and_far_ones_are_discarded():
    c, r = square_system(3, 3)
    rng = np.random.default_rng(3)
    centres = np.clip(r + rng.choice([-1, 1], (80, 3)) * rng.uniform(0.02, 0.15, (80, 3)), 0.05, 0.95)
    boxes = np.stack([centres - 5e-3, centres + 5e-3], axis=-1)
    holds = np.all((boxes[..., 0] <= r) & (r <= boxes[..., 1]), axis=1)
    assert not holds.any()
    iso, lo, hi = krawczyk_boxes(square(3), *on_boxes(c, boxes))
    assert not iso.any()
    assert np.any(lo > hi, axis=1).mean() > 0.5             # most are proven empty


@pytest.mark.parametrize("gap", [1e-2, 1e-4])
def test_a_box_holding_two_roots_is_not_isolated(gap):
    n = 3
    c = two_root_system(n, 0.5, 0.5 + gap, [0.3, 0.6])
    rng = np.random.default_rng(4)
    lo0 = np.array([0.5 - gap, 0.29, 0.59]) - rng.uniform(0, gap, (40, 3))
    hi0 = np.array([0.5 + 2 * gap, 0.31, 0.61]) + rng.uniform(0, gap, (40, 3))
    boxes = np.stack([lo0, hi0], axis=-1)
    iso, lo, hi = krawczyk_boxes(square(n), *on_boxes(c, boxes))
    assert not iso.any()
    for root in ([0.5, 0.3, 0.6], [0.5 + gap, 0.3, 0.6]):
        u = (np.array(root) - boxes[..., 0]) / (boxes[..., 1] - boxes[..., 0])
        assert np.all((lo <= u + 1e-12) & (u <= hi + 1e-12))
    # each root alone in a small box is isolated
    single = np.stack([np.array([0.5, 0.3, 0.6]) - gap / 4, np.array([0.5, 0.3, 0.6]) + gap / 3], axis=-1)[None]
    iso1, _, _ = krawczyk_boxes(square(n), *on_boxes(c, single))
    assert iso1.all()


@pytest.mark.parametrize("seed", [5, 6])
def test_jacobian_enclosure_contains_finite_differences(seed):
    c, r = square_system(seed, 3)
    rng = np.random.default_rng(seed)
    boxes = boxes_around(rng, r, 10, (-1.0, -0.3))
    (cps,), (tols,) = on_boxes(c, boxes)
    jlo, jhi = _derivative_bounds(cps, tols)                 # (E, N, B), d/du on the box
    h = 1e-6
    for _ in range(30):
        u = rng.uniform(h, 1 - h, (10, 3))
        for k in range(3):
            e = np.zeros(3)
            e[k] = h
            fd = (evaluate_at(cps, u + e) - evaluate_at(cps, u - e)) / (2 * h)      # (E, B)
            assert np.all(fd >= jlo[:, k] - 1e-6) and np.all(fd <= jhi[:, k] + 1e-6)
        np.testing.assert_allclose(jacobian_at(cps, u)[:, 0], (evaluate_at(cps, u + [h, 0, 0]) -
                                                              evaluate_at(cps, u - [h, 0, 0])) / (2 * h), atol=1e-6)


def test_evaluate_at_matches_bernstein_evaluate():
    rng = np.random.default_rng(7)
    c = rng.normal(size=(2, 3, 1, 2, 5))                    # batch last, mixed degrees
    u = rng.uniform(0, 1, (5, 3))
    ref = np.stack([bernstein.evaluate(c[..., b], u[b], nvars=3) for b in range(5)], axis=-1)
    np.testing.assert_allclose(evaluate_at(c, u), ref, atol=1e-14)


@pytest.mark.parametrize("n, seed", [(2, 8), (3, 9)])
def test_newton_converges_to_the_root_and_tells_spurious_roots(n, seed):
    c, r = square_system(seed, n)
    rng = np.random.default_rng(seed)
    boxes = boxes_around(rng, r, 12, (-3.0, -2.0))
    cps, tols = on_boxes(c, boxes)
    iso, _, _ = krawczyk_boxes(square(n), cps, tols)
    assert iso.all()
    # an extra equation that vanishes at r (a closure) and one that does not (a spurious root)
    x0 = np.zeros((3,) * n)
    x0[(0,) * n] = -r[0]
    x0[(1,) + (0,) * (n - 1)] = 1.0
    vanishing = bernstein.from_power(x0[None], nvars=n)
    offset = vanishing + 0.1
    for extra, expect in ((vanishing, True), (offset, False)):
        full = np.concatenate([c, extra])
        cps, tols = on_boxes(full, boxes)
        u, converged, closure = newton(square(n), cps, tols)
        assert converged.all()
        x = boxes[..., 0] + u * (boxes[..., 1] - boxes[..., 0])
        np.testing.assert_allclose(x, np.broadcast_to(r, x.shape), atol=1e-14)
        assert np.all(closure == expect)


def test_square_system_size_mismatch_is_an_error():
    c, r = square_system(0, 3)
    cps, tols = on_boxes(c[:2], np.stack([r - 0.01, r + 0.01], axis=-1)[None])
    with pytest.raises(ValueError, match="square"):
        krawczyk_boxes(square(2), cps, tols)


def _line(r: float, scale: float = 1.0) -> np.ndarray:
    """Degree-2 Bernstein control points (1, 3, 1) of scale * (u - r) on [0, 1] (one box, batch last)."""
    return (scale * (np.array([0.0, 0.5, 1.0]) - r)).reshape(1, 3, 1)


def test_spurious_only_when_proven():
    """Issue 26: a root of the square system is spurious only when another equation has no zero on a
    box holding it. A real closure (the other equation vanishes at the same root) seen from a Newton
    point 1e-9 off the root (next to a singularity Newton errs that much) is not spurious, however
    far above its rounding tolerance the other equation is at that point; an equation that stays
    near 1 is."""
    from spherekin.search.isolation import spurious_proven

    square = SquareSystem.from_blocks([[0], []])
    r = 0.3
    u = np.array([[r + 1e-9]])
    tols = [np.array([[1e-18]]), np.array([[1e-18]])]
    real = [_line(r), _line(r, 1e-3)]                  # g(u*) = 0 at the root u* = r; g(u) = 1e-12 >> 1e-18
    assert not spurious_proven(square, real, tols, u)[0]
    spurious = [_line(r), (np.full(3, 1.0) + 0.1 * np.array([0.0, 0.5, 1.0])).reshape(1, 3, 1)]
    assert spurious_proven(square, spurious, tols, u)[0]
    # on a wide box the other equation's hull may contain 0; the small box around u decides
    near = [_line(r), (np.array([-1.0, 3.0, -1.0]) + 0.0).reshape(1, 3, 1)]   # g ~ 0.5 near u = 0.3
    near_vals = evaluate_at(near[1], u)
    assert abs(float(near_vals[0, 0])) > 0.1
    assert spurious_proven(square, near, tols, u)[0]



def test_a_batch_with_an_exactly_singular_midpoint_jacobian_gives_the_other_boxes_their_own_verdicts():
    """A box centred between the two roots of (x0 - r1)(x0 - r2) has mid(J) with a zero row (the
    derivative's range is symmetric about 0; dyadic data, so exactly): no inverse, the whole box
    back, not isolated; the boxes batched with it get exactly what they get alone (LAPACK's
    inverse raises for a whole batch holding a singular matrix)."""
    n, r1, r2 = 3, 0.25, 0.75
    c = two_root_system(n, r1, r2, [0.5, 0.25])
    singular = np.array([[0.25, 0.75], [0.25, 0.75], [0.0, 0.5]])
    regular = np.stack([np.array([r1, 0.5, 0.25]) - 1e-3, np.array([r1, 0.5, 0.25]) + 2e-3], axis=-1)
    regular2 = np.stack([np.array([r2, 0.5, 0.25]) - 2e-3, np.array([r2, 0.5, 0.25]) + 1e-3], axis=-1)
    batch = np.stack([regular, singular, regular2])
    cps, tols = on_boxes(c, batch)
    jlo, jhi = _derivative_bounds(cps[0], tols[0])
    assert np.all(jlo[0, :, 1] + jhi[0, :, 1] == 0.0)                       # mid(J) row 0 is exactly 0
    iso, lo, hi = krawczyk_boxes(square(n), cps, tols)
    assert not iso[1] and np.array_equal(lo[1], np.zeros(n)) and np.array_equal(hi[1], np.ones(n))
    for b in (0, 2):
        iso1, lo1, hi1 = krawczyk_boxes(square(n), *on_boxes(c, batch[b:b + 1]))
        assert iso1[0] and iso[b]
        assert np.array_equal(lo1[0], lo[b]) and np.array_equal(hi1[0], hi[b])


def test_the_conditioning_gate_agrees_with_the_svd_away_from_its_threshold():
    """mid(J) is inverted where its reciprocal condition number (1-norm estimate) is above
    KRAWCZYK_RCOND: checked against numpy's SVD (the 2-norm one, within a factor N) on matrices
    of prescribed singular values 1 and rc, rc far from the threshold on either side."""
    rng = np.random.default_rng(7)
    for rc in (1e-14, 1e-12, 1e-8, 1e-4):
        q1, _ = np.linalg.qr(rng.normal(size=(40, 3, 3)))
        q2, _ = np.linalg.qr(rng.normal(size=(40, 3, 3)))
        jmid = q1 @ (np.array([1.0, 0.5, rc])[:, None] * q2)
        sv = np.linalg.svd(jmid, compute_uv=False)
        ok, c = _inverses(jmid)
        assert np.all(ok == (sv[:, -1] / sv[:, 0] > KRAWCZYK_RCOND))
        assert np.allclose(c[ok] @ jmid[ok], np.eye(3), atol=1e-6)
