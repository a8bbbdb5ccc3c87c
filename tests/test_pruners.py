"""Tests for spherekin.search.pruners against independent derivations.

* systems with KNOWN roots: polynomials built in the power basis as sums of (x_k - r_k) g_k(x)
  (simple roots) and -sum c_k (x_k - r_k)^2 (a tangential double root, like the scalar closure
  equation), and the Gosselin platform's loop equations at a configuration obtained from its
  inverse kinematics (Paden-Kahan, independent of the closure polynomials). Random boxes that
  contain the root are reduced; the root must stay inside the reduced box;
* the projected-polyhedron interval of one equation and variable against a brute-force 2-D convex
  hull (scipy.spatial.ConvexHull) of the points (i/m, w_I) clipped to the band |w| <= tol;
* the LP box (Eq. 12) lies inside the PP box up to the documented margins.
"""

import re
from fractions import Fraction

import numpy as np
import pytest
from scipy.spatial import ConvexHull
from scipy.spatial.transform import Rotation

from spherekin.core import bernstein
from tests.formulate_cases import formulate
from spherekin.search.lp_backends import FEASIBILITY_TOL, LP_BOUND_MARGIN
from spherekin.mechanism import gosselin
from spherekin.search import lp_backends
from spherekin.search.pruners import (INTERVAL_MARGIN, PRUNERS, HybridPruner, LinearProgramPruner, ProjectedPolyhedron,
                                      Pruner, check_pruner, excludes_zero, make_pruner, pp_intervals)
from spherekin.search.boxloop import ROUNDING_SAFETY
from conftest import times_linear

EPS = np.finfo(float).eps
#: The brute-force hull and the pruner compute the same crossings by different formulas (measured
#: agreement 1e-16; tight enough to see the 1e-12 INTERVAL_MARGIN).
HULL_AGREEMENT = 1e-14
#: How far (unit box coordinates) the LP box may reach beyond the PP box: the LP's reported optimum
#: is moved out by LP_BOUND_MARGIN and its point may violate Eq. (12) by FEASIBILITY_TOL.
LP_OUTSIDE_PP = LP_BOUND_MARGIN + 2 * INTERVAL_MARGIN + 10 * FEASIBILITY_TOL


def tolerances(coeffs):
    """The solver's rule: ROUNDING_SAFETY machine epsilons of each equation's largest control point."""
    return ROUNDING_SAFETY * EPS * np.abs(coeffs).reshape(len(coeffs), -1).max(axis=1)


# ---------------------------------------------------------------- polynomial systems with known roots


def random_factor(rng, shape, k):
    g = rng.normal(size=shape)
    idx = [slice(None)] * len(shape)
    idx[k] = -1
    g[tuple(idx)] = 0.0
    return g


def system_with_root(seed, n):
    """Blocks (Bernstein, unit box) of polynomials vanishing at a known root r in (0.1, 0.9)^n:
    n equations with a simple root, one with a double root, one in a subset of the variables."""
    rng = np.random.default_rng(seed)
    r = rng.uniform(0.1, 0.9, n)
    full = (3,) * n
    simple = np.stack([sum(times_linear(random_factor(rng, full, k), k, r[k]) for k in range(n)) for _ in range(n)])
    double = np.zeros(full)                  # -sum_k c_k (x_k - r_k)^2 in the power basis
    for k in range(n):
        c = rng.uniform(0.5, 2.0)
        for p, coef in enumerate((r[k] ** 2, -2 * r[k], 1.0)):
            idx = [0] * n
            idx[k] = p
            double[tuple(idx)] -= c * coef
    sub_shape = tuple(3 if k in (0, n - 1) else 1 for k in range(n))
    subset = times_linear(random_factor(rng, sub_shape, 0), 0, r[0]) + times_linear(
        random_factor(rng, sub_shape, n - 1), n - 1, r[n - 1])
    blocks = [bernstein.from_power(simple, nvars=n), bernstein.from_power(double[None], nvars=n),
              bernstein.from_power(subset[None], nvars=n)]
    for c in blocks:  # the construction really has the root
        assert np.abs(bernstein.evaluate(c, r, nvars=n)).max() < 1e-13 * np.abs(c).max()
    return blocks, r


def boxes_around(rng, root, count, log_width=(-3.0, -0.3)):
    """count random boxes (count, n, 2) inside [0, 1]^n that contain root."""
    n = len(root)
    w = 10 ** rng.uniform(*log_width, size=(count, n))
    a = np.clip(root - w * rng.uniform(0, 1, size=(count, n)), 0, 1)
    b = np.clip(a + w, 0, 1)
    b = np.maximum(b, root)
    return np.stack([a, b], axis=-1)


def restrict_all(blocks, boxes):
    """Control points on the boxes in the pruners' layout (batch axis last)."""
    n = boxes.shape[-2]
    return [np.moveaxis(bernstein.restrict(c, boxes[:, None], nvars=n), 0, -1) for c in blocks]


def assert_root_inside(lo, hi, boxes, root):
    u = (root - boxes[..., 0]) / (boxes[..., 1] - boxes[..., 0])
    bad = np.argwhere((u < lo) | (u > hi))
    assert len(bad) == 0, f"root lost in box {bad[0]}: u={u[tuple(bad[0])]}, [{lo[tuple(bad[0])]}, {hi[tuple(bad[0])]}]"


@pytest.mark.parametrize("n, seed", [(2, 0), (2, 1), (3, 2), (3, 3)])
def test_pp_keeps_known_root(n, seed):
    blocks, root = system_with_root(seed, n)
    rng = np.random.default_rng(100 + seed)
    boxes = boxes_around(rng, root, 200)
    lo, hi = make_pruner("pp", [c.shape for c in blocks]).reduce(restrict_all(blocks, boxes), [tolerances(c) for c in blocks])
    assert lo.shape == hi.shape == (200, n)
    assert_root_inside(lo, hi, boxes, root)
    # not a pruner that never prunes; PP alone contracts coupled systems little (measured: median
    # largest side 0.1-0.95 of the box even for boxes 1e-5 wide), unlike the LP (test below)
    assert np.mean(np.min(hi - lo, axis=1) < 0.9) > 0.25


@pytest.mark.parametrize("n, seed", [(2, 4), (3, 5)])
def test_lp_keeps_known_root_and_lies_inside_pp(n, seed):
    blocks, root = system_with_root(seed, n)
    rng = np.random.default_rng(200 + seed)
    boxes = boxes_around(rng, root, 12)
    cps, tols = restrict_all(blocks, boxes), [tolerances(c) for c in blocks]
    shapes = [c.shape for c in blocks]
    lp = make_pruner("lp", shapes)                     # default backend
    lo, hi = lp.reduce(cps, tols)
    assert_root_inside(lo, hi, boxes, root)
    assert lp.lp_count >= 2 * n * len(boxes) and lp.doubts == 0
    plo, phi = make_pruner("pp", shapes).reduce(cps, tols)
    assert np.all(lo >= plo - LP_OUTSIDE_PP) and np.all(hi <= phi + LP_OUTSIDE_PP)


@pytest.mark.parametrize("n, seed", [(2, 0), (3, 2)])
def test_lp_contracts_quadratically_at_a_simple_root(n, seed):
    """Section 4: near a simple root the hulls tend to the tangent planes, with a thickness
    O(width^2), so the Eq. (12) box shrinks to a fraction O(width) of the box."""
    blocks, root = system_with_root(seed, n)
    blocks = blocks[:1]                                # the n equations with a simple root
    rng = np.random.default_rng(300 + seed)
    shapes, tols = [c.shape for c in blocks], [tolerances(c) for c in blocks]
    ratios = []
    for log_w in (-2.0, -3.0, -4.0):
        boxes = boxes_around(rng, root, 4, (log_w, log_w))
        lo, hi = make_pruner("lp", shapes, "highspy").reduce(restrict_all(blocks, boxes), tols)
        assert_root_inside(lo, hi, boxes, root)
        ratios.append(np.max(hi - lo))
    assert ratios[2] < 0.05 * ratios[0]                # two decades of width -> ~two of ratio
    assert ratios[2] < 1e-2


@pytest.mark.parametrize("name", PRUNERS)
def test_tangential_root_on_a_box_face_survives_rounding(name):
    """-sum c (x - r)^2 touches 0 only at r; with r on a face of the box the exact hull touches the
    plane w = 0 at a corner, so restricted control points rounded to the wrong side of 0 would
    prune the root without the slab |w| <= tol (the bisection of the solver puts roots on faces)."""
    rng = np.random.default_rng(9)
    for seed in range(3):
        blocks, root = system_with_root(seed, 2)
        tangential = blocks[1:2]
        pruner = make_pruner(name, [c.shape for c in tangential], "highspy" if name == "lp" else None)
        for log_w in (-2, -4, -6, -8):
            boxes = boxes_around(rng, root, 30, (log_w, log_w))
            boxes[np.arange(30), 0, rng.integers(0, 2, size=30)] = root[0]
            lo, hi = pruner.reduce(restrict_all(tangential, boxes), [tolerances(c) for c in tangential])
            assert_root_inside(lo, hi, boxes, root)


@pytest.mark.parametrize("name", PRUNERS)
def test_per_box_tolerances_equal_one_box_at_a_time(name):
    """tols of shape (E, B) apply column b to box b: same result as B calls with (E,) tolerances."""
    blocks, root = system_with_root(6, 2)
    rng = np.random.default_rng(6)
    boxes = boxes_around(rng, root, 5, (-1.5, -0.5))
    cps = restrict_all(blocks, boxes)
    tols = [np.abs(c).reshape(len(c), -1).max(axis=1)[:, None] * rng.choice([1e-13, 0.05, 0.3], size=(len(c), 5))
            for c in blocks]
    pruner = make_pruner(name, [c.shape for c in blocks], "highspy" if name == "lp" else None)
    lo, hi = pruner.reduce(cps, tols)
    for b in range(5):
        lo1, hi1 = pruner.reduce([c[..., b:b + 1] for c in cps], [t[:, b] for t in tols])
        # (the LP may land on another optimal vertex from another warm start: rounding-level noise)
        np.testing.assert_allclose(np.r_[lo[b], hi[b]], np.r_[lo1[0], hi1[0]], rtol=0, atol=1e-9)
    assert len({tuple(np.round(np.r_[lo[b], hi[b]], 6)) for b in range(5)}) > 1


def test_pp_and_lp_discard_a_box_without_roots():
    blocks, root = system_with_root(7, 2)
    # shift the double-root equation up: -sum c (x - r)^2 + 0.01 has its roots on an ellipse
    # around r, so a small box at r holds no root while the simple equations still vanish there
    lifted = [blocks[0], blocks[1] + 0.01 * np.abs(blocks[1]).max(), blocks[2]]
    boxes = np.stack([root - 1e-3, root + 1e-3], axis=-1)[None]
    cps, tols = restrict_all(lifted, boxes), [tolerances(c) for c in lifted]
    shapes = [c.shape for c in lifted]
    for pruner in (make_pruner("pp", shapes), make_pruner("lp", shapes, "highspy")):
        lo, hi = pruner.reduce(cps, tols)
        assert np.all(lo > hi)


# ---------------------------------------------------------------- PP interval vs brute force

def clip(poly, a, c):
    """Sutherland-Hodgman: the part of a convex polygon (list of 2-D points) with a . p <= c."""
    out = []
    for i in range(len(poly)):
        p, q = poly[i], poly[(i + 1) % len(poly)]
        fp, fq = a @ p - c, a @ q - c
        if fp <= 0:
            out.append(p)
        if fp * fq < 0:
            out.append(p + (q - p) * (fp / (fp - fq)))
    return out


def brute_interval(w, tol, var):
    """x-extent of hull{(i_var / m_var, w_I)} cut by |w| <= tol, or None when empty."""
    d = w.shape[var]
    s = np.indices(w.shape)[var].ravel() / (d - 1)
    pts = np.stack([s, w.ravel()], axis=1)
    hull = ConvexHull(pts)
    poly = list(pts[hull.vertices])
    poly = clip(poly, np.array([0.0, 1.0]), tol)
    if poly:
        poly = clip(poly, np.array([0.0, -1.0]), tol)
    if not poly:
        return None
    xs = [p[0] for p in poly]
    return min(xs), max(xs)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_pp_interval_matches_brute_force_hull(seed):
    rng = np.random.default_rng(seed)
    shape = (3, 3, 3)
    cps = rng.normal(size=(40, 2) + shape) + rng.uniform(-4, 4, size=(40, 2, 1, 1, 1))
    tol = np.array([0.05, 0.2])
    seen = {"empty": 0, "cut": 0}
    for var in range(3):
        lo, hi = pp_intervals(np.moveaxis(cps, 0, -1), tol, var)
        assert lo.shape == hi.shape == (2, 40)
        for b in range(40):
            for e in range(2):
                ref = brute_interval(cps[b, e], tol[e], var)
                if ref is None:
                    assert lo[e, b] > hi[e, b]
                    seen["empty"] += 1
                else:
                    np.testing.assert_allclose([lo[e, b], hi[e, b]], ref, atol=HULL_AGREEMENT)
                    seen["cut"] += ref[0] > 1e-9 or ref[1] < 1 - 1e-9
    assert seen["empty"] > 10 and seen["cut"] > 10      # both cases are exercised


def test_pp_reduce_is_the_intersection_of_brute_force_intervals():
    rng = np.random.default_rng(11)
    bsz = 60
    a = rng.normal(size=(bsz, 2, 3, 3, 3)) + rng.uniform(-1, 1, size=(bsz, 2, 1, 1, 1))
    b = rng.normal(size=(bsz, 1, 3, 1, 3)) + rng.uniform(-1, 1, size=(bsz, 1, 1, 1, 1))   # no x_1
    tols = [np.array([0.05, 0.1]), np.array([0.02])]
    lo, hi = make_pruner("pp", [a.shape[1:], b.shape[1:]]).reduce([np.moveaxis(a, 0, -1), np.moveaxis(b, 0, -1)],
                                                                   tols)
    n_empty = 0
    for i in range(bsz):
        rlo, rhi = np.zeros(3), np.ones(3)
        for block, tol in ((a, tols[0]), (b, tols[1])):
            for e in range(block.shape[1]):
                for k in range(3):
                    if block.shape[2 + k] == 1:
                        continue
                    ref = brute_interval(block[i, e], tol[e], k)
                    ref = (1.0, 0.0) if ref is None else ref
                    rlo[k], rhi[k] = max(rlo[k], ref[0]), min(rhi[k], ref[1])
        if np.any(rlo > rhi):
            n_empty += 1
            assert np.all(lo[i] > hi[i])
        else:
            np.testing.assert_allclose(lo[i], np.maximum(rlo - INTERVAL_MARGIN, 0), atol=HULL_AGREEMENT)
            np.testing.assert_allclose(hi[i], np.minimum(rhi + INTERVAL_MARGIN, 1), atol=HULL_AGREEMENT)
    assert 0 < n_empty < bsz


def test_pp_constant_nonzero_equation_excludes_the_box():
    c = np.full((1, 1, 1, 1), 0.5)                      # one equation, w = 0.5 everywhere, 2 variables, 1 box
    other = np.zeros((1, 3, 3, 1))                      # an equation that vanishes identically
    tols = [np.array([1e-3]), np.array([1e-3])]
    lo, hi = make_pruner("pp", [(1, 1, 1), (1, 3, 3)]).reduce([c, other], tols)
    assert np.all(lo > hi)


# ---------------------------------------------------------------- Gosselin loops at a known assembly

def gosselin_with_root(seed):
    """The Gosselin platform's loop system around an assembly found by inverse kinematics."""
    rng = np.random.default_rng(seed)
    mech = gosselin()
    pose = Rotation.from_rotvec(0.3 * rng.normal(size=3)).as_matrix()
    sol = mech.inverse_kinematics(pose)[int(rng.integers(8))]
    passive = sol.passive(mech.passive)
    ranges = {n: (a - rng.uniform(0.4, 0.9), a + rng.uniform(0.4, 0.9)) for n, a in passive.items()}
    system = mech.loop_system(sol.inputs, ranges)
    root = system.to_unit(passive)
    assert system.residuals(root).max() < 1e-12
    return system, root


@pytest.mark.parametrize("formulation", ["transversal", "paper"])
def test_gosselin_root_survives_pp_and_lp(formulation):
    system, root = gosselin_with_root(3)
    blocks = formulate(formulation, system.loops, system.unknowns)
    coeffs = [b.coeffs for b in blocks]
    tols = [ROUNDING_SAFETY * EPS * b.scale for b in blocks]
    shapes = [c.shape for c in coeffs]
    rng = np.random.default_rng(33)
    boxes = boxes_around(rng, root, 60, log_width=(-4.0, -0.5))
    cps = restrict_all(coeffs, boxes)
    plo, phi = make_pruner("pp", shapes).reduce(cps, tols)
    assert_root_inside(plo, phi, boxes, root)
    few = slice(0, 5)
    lp = make_pruner("lp", shapes, "highspy")
    lo, hi = lp.reduce([c[..., few] for c in cps], tols)
    assert_root_inside(lo, hi, boxes[few], root)
    assert np.all(lo >= plo[few] - LP_OUTSIDE_PP) and np.all(hi <= phi[few] + LP_OUTSIDE_PP)


# ---------------------------------------------------------------- names

def test_pruner_names():
    with pytest.raises(ValueError) as err:
        make_pruner("simplex", [(1, 3)])
    assert all(name in str(err.value) for name in PRUNERS) and "simplex" in str(err.value)
    with pytest.raises(ValueError, match="lp_backend"):
        make_pruner("pp", [(1, 3)], "highs")
    with pytest.raises(ValueError, match="lp_backend"):
        make_pruner("lp", [(1, 3)], "glpk")


def test_the_registry_lists_exactly_the_pruners():
    assert list(PRUNERS) == ["pp", "lp", "hybrid"]
    assert [PRUNERS[n] for n in PRUNERS] == [ProjectedPolyhedron, LinearProgramPruner, HybridPruner]
    assert all(issubclass(cls, Pruner) for cls in PRUNERS.values())
    assert all(cls.default_lp_backend is None or cls.default_lp_backend in lp_backends.LP_BACKENDS
               for cls in PRUNERS.values())


@pytest.mark.parametrize("call", [lambda: make_pruner("simplex", [(1, 3)]), lambda: check_pruner("simplex")],
                         ids=["make_pruner", "check_pruner"])
def test_an_unknown_pruner_is_the_registry_error(call):
    with pytest.raises(ValueError, match=re.escape(f"pruner: expected one of {list(PRUNERS)}, got 'simplex'")):
        call()


def test_check_pruner_builds_no_pruner_and_no_lp_model(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("built")

    for cls in PRUNERS.values():
        monkeypatch.setattr(cls, "build", classmethod(refuse))
    for cls in lp_backends.LP_BACKENDS.values():
        monkeypatch.setattr(cls, "__init__", refuse)
    for name in PRUNERS:
        check_pruner(name)
    check_pruner("lp", "clarabel")
    check_pruner("hybrid", "highs")
    with pytest.raises(ValueError, match=re.escape(f"lp_backend: expected one of {list(lp_backends.LP_BACKENDS)}")):
        check_pruner("lp", "glpk")


def test_a_registered_pruner_is_accepted_by_the_lookup(registered):
    class PPAgain(ProjectedPolyhedron):
        name = "pp-again"

    registered(PRUNERS, PPAgain)
    check_pruner("pp-again")
    assert isinstance(make_pruner("pp-again", [(1, 3)]), PPAgain)
    with pytest.raises(ValueError, match="solves no LP"):
        check_pruner("pp-again", "highspy")


def test_excludes_zero_keeps_a_box_whose_control_points_clear_zero_by_less_than_their_tolerance():
    """p(x) = x^2 on [0, 1] has exact Bernstein control points (0, 0, 1) and a root at x = 0. Float
    control points that carry rounding errors (here +1e-17 on the zeros) stay within their tolerance
    1e-15 of the exact ones, so the box must be kept: only points beyond the slab |w| <= tol prove
    that no root is there. Checked in exact rationals."""
    exact = [Fraction(0), Fraction(0), Fraction(1)]
    noisy = np.array([[1e-17, 1e-17, 1.0]])[..., None]                  # (E=1, 3, B=1)
    tol = np.array([1e-15])
    assert all(abs(Fraction(float(f)) - e) <= Fraction(float(tol[0])) for f, e in zip(noisy[0, :, 0], exact))
    assert min(exact) == 0                                               # p(0) = b_0 = 0: a root in the box
    assert not excludes_zero([noisy], [tol])[0]
    clear = np.array([[2e-15, 3e-15, 1.0]])[..., None]                  # beyond the slab: p >= 2e-15 - 1e-15 > 0
    assert Fraction(float(clear.min())) - Fraction(float(tol[0])) > 0
    assert excludes_zero([clear], [tol])[0] and excludes_zero([-clear], [tol])[0]
