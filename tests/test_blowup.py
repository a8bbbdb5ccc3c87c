"""The blow-up of the agile eye's stationary assemblies (spherekin/singularities/blowup.py, issue 31).

Independent references: the legs' forms q^T M q evaluated directly from the matrices (numpy), the direction w
built here from its definition, the chart maps of the quaternion written out here, and the closed-form
singular curve T(beta) = cos b1 cos b2 cos b3 + sin b1 sin b2 sin b3 = 0 of the agile eye (derived with sympy
in tests/test_singular_agile.py; every one of its eight assemblies has |det| = |T|).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import spherekin
from spherekin.core import bernstein
from spherekin.mechanism import load_mechanism
from spherekin.search.isolation import SquareSystem, full_rank_proven
from spherekin.singularities.blowup import BLOWUP_RADIUS, StationaryPlane, blowup_patches, outside
from spherekin.systems.platform import CHART_EXTENT
from spherekin.singularities.planes import PlatformPlane, SingularPlane
from singular_refs import EXAMPLES, agile_curve_points, agile_t

EYE = EXAMPLES / "gosselin.toml"
BETA3 = 0.5
#: A region of the plane the curve T = 0 crosses once (about 1.6 rad of curve), 12 x 12 cells of 0.1, away from the
#: self-motion inputs (+-pi/2, 0), (+-pi/2, pi) (a continuum of assemblies, where cusp candidates stay unresolved).
REGION = ((0.2, 1.4), (-1.4, -0.2))
TOL = 0.1


def _t(b1, b2, b3=BETA3):
    """T(beta) in the plane beta3 = BETA3 (tests/singular_refs.agile_t)."""
    return agile_t(b1, b2, b3)


@pytest.fixture(scope="module")
def eye_plane():
    plane = SingularPlane(("beta1", -math.pi, math.pi), ("beta2", -math.pi, math.pi), {"beta3": BETA3})
    return PlatformPlane(load_mechanism(EYE), plane)


def test_the_patches_are_the_legs_forms_divided_by_rho(eye_plane):
    """On each patch, rho G_i = q^T M_i q at q = q* + rho w (every part: cos d, sin d, 1), and the patch's
    linear nets are q's components: at random points, against the forms evaluated from the matrices."""
    rng = np.random.default_rng(7)
    for q in eye_plane.stationary:
        k = int(np.argmax(np.abs(q)))
        qs = q / q[k]
        others = [j for j in range(4) if j != k]
        for c, patch in enumerate(blowup_patches(eye_plane.mats, q)):
            for _ in range(5):
                x = rng.random(3)
                rho, a, b = -BLOWUP_RADIUS + 2 * BLOWUP_RADIUS * x[0], 2 * x[1] - 1, 2 * x[2] - 1
                w = np.zeros(4)
                w[others[c]], w[others[(c + 1) % 3]], w[others[(c + 2) % 3]] = 1.0, a, b
                quat = qs + rho * w
                forms = np.einsum("l,iplm,m->ip", quat, eye_plane.mats, quat)          # (3 legs, 3 parts)
                g = np.array([[bernstein.evaluate(patch.quad[i, p], x[None])[0] for p in range(3)] for i in range(3)])
                assert np.abs(rho * g - forms).max() < 1e-13
                lin = np.array([bernstein.evaluate(patch.lin[l], x[None])[0] for l in range(4)])
                assert np.abs(lin - quat).max() < 1e-15
                # the magnitudes' nets bound the values (tolerances are taken from them)
                assert np.all(np.abs(patch.quad) <= patch.quad_mag + 1e-15)


def test_the_holes_lie_inside_the_blown_up_boxes(eye_plane):
    """Every orientation a chart does not search is in a box U of some stationary q* (so the blow-up covers
    it): random points of each chart's complement of the start boxes, mapped to q*'s chart, are within
    BLOWUP_RADIUS of q* there; and the start boxes with the holes fill each chart (volume 1)."""
    chart, lo, hi = outside(eye_plane, eye_plane.stationary)
    rng = np.random.default_rng(3)
    assert chart.max() == eye_plane.charts.n_charts - 1
    for c in range(4):                                       # the first plane combination's four charts
        mine = chart == c
        blo, bhi = lo[mine][:, :3], hi[mine][:, :3]
        assert np.all(lo[mine][:, 3:] == 0) and np.all(hi[mine][:, 3:] == 1)
        vol = np.prod(bhi - blo, axis=1).sum()
        x = rng.random((20000, 3))
        searched = np.any(np.all((x[:, None] >= blo[None]) & (x[:, None] <= bhi[None]), axis=2), axis=1)
        assert 0.0 < 1.0 - vol < 0.05 and abs((1.0 - vol) - (~searched).mean()) < 0.01
        u = CHART_EXTENT * (2 * x[~searched] - 1)
        quat = np.insert(u, c, 1.0, axis=1)
        inside_some = np.zeros(len(quat), dtype=bool)
        for q in eye_plane.stationary:
            j = int(np.argmax(np.abs(q)))
            image = np.delete(quat / quat[:, j:j + 1], j, axis=1)
            inside_some |= np.abs(image - np.delete(q / q[j], j)).max(axis=1) <= BLOWUP_RADIUS
        assert inside_some.all()
    # the unsearched region of q*'s own chart is U itself (minus rounding margins)
    assert np.isclose(1.0 - np.prod(hi[chart == 0][:, :3] - lo[chart == 0][:, :3], axis=1).sum(),
                      len(eye_plane.stationary) * (BLOWUP_RADIUS / CHART_EXTENT) ** 3, rtol=1e-6)


def test_full_rank_proven_fails_exactly_where_a_column_vanishes():
    """f1 = (x - 1/2)^2, f2 = y (unit box): the Jacobian in (x, y) is diag(2x - 1, 1), singular on x = 1/2.
    Boxes meeting x = 1/2 are never proven; boxes away from it are."""
    f1 = bernstein.from_power(np.array([[0.25, 0.0], [-1.0, 0.0], [1.0, 0.0]]), nvars=2)   # power in (x, y)
    f2 = bernstein.from_power(np.array([[0.0, 1.0], [0.0, 0.0], [0.0, 0.0]]), nvars=2)
    net = np.stack([f1, f2])[..., None]                                                     # (2, 3, 2, 1)
    lo = np.array([[0.0, 0.0], [0.4, 0.2], [0.49, 0.0], [0.6, 0.0], [0.0, 0.5], [0.55, 0.3]])
    hi = np.array([[1.0, 1.0], [0.6, 0.4], [0.51, 1.0], [0.9, 1.0], [0.3, 1.0], [0.56, 0.31]])
    cps = [bernstein.restrict_batch_last(np.repeat(net, len(lo), axis=-1), lo, hi, {})]
    tols = [np.full((2, len(lo)), 1e-15)]
    ok = full_rank_proven(SquareSystem(((0, 0), (0, 1))), cps, tols, (0, 1))
    assert ok.tolist() == [False, False, False, True, True, True]
    # one column of two equations: rank 1 wherever some row's derivative is away from 0 (f2's is 0 in x)
    assert full_rank_proven(SquareSystem(((0, 0), (0, 1))), cps, tols, (1,)).all()


@pytest.fixture(scope="module")
def region_set():
    (x0, x1), (y0, y1) = REGION
    return spherekin.singular(EYE, x=("beta1", x0, x1), y=("beta2", y0, y1), fixed={"beta3": BETA3}, tol=TOL)


def test_the_region_completes_and_its_cover_hugs_the_curve(region_set):
    """With the blow-up the cover of a region crossed by the curve completes (before: the box cap), holds
    every point of the curve, and no cell is farther than its width from the curve."""
    s = region_set
    assert s.complete
    pts = agile_curve_points(REGION, BETA3, 2000)
    assert len(pts) > 1000 and np.abs(_t(pts[:, 0], pts[:, 1])).max() < 1e-12
    lo = np.array([[b.x[0], b.y[0]] for b in s.boxes])
    hi = np.array([[b.x[1], b.y[1]] for b in s.boxes])
    inside = ((pts[:, None] >= lo[None] - 1e-9) & (pts[:, None] <= hi[None] + 1e-9)).all(axis=2).any(axis=1)
    assert inside.all()
    for b in s.boxes:
        g1, g2 = np.meshgrid(np.linspace(b.x[0] - TOL, b.x[1] + TOL, 41), np.linspace(b.y[0] - TOL, b.y[1] + TOL, 41))
        v = _t(g1, g2)
        assert v.min() <= 0.0 <= v.max(), b


def test_the_region_is_mostly_proven_and_each_proof_is_on_the_curve(region_set):
    """Most cells are `singular` (the blow-up makes the crossings regular roots the Krawczyk slices prove;
    before, every cell away from the stationary sign changes was unresolved), each with T changing sign in
    it; the agile eye has no cusp (T = 0 is smooth), so none is claimed."""
    singular = [b for b in region_set.boxes if b.status == "singular"]
    assert len(singular) >= 0.8 * len(region_set.boxes)
    for b in singular:
        g1, g2 = np.meshgrid(np.linspace(*b.x, 41), np.linspace(*b.y, 41))
        v = _t(g1, g2)
        assert v.min() < 0.0 < v.max(), b
    assert region_set.cusps == ()                 # every box proven cusp-free (rank test), not only none proven


def test_the_stationary_plane_refuses_the_tangency_system(eye_plane):
    blown = StationaryPlane(load_mechanism(EYE), eye_plane.plane, eye_plane.stationary)
    assert len(blown.patches) == 3 * len(eye_plane.stationary)
    with pytest.raises(ValueError, match="blow-up"):
        blown.cusp_charts(((1.0, 0.0, 0.0),))


#: A square around the self-motion input (pi/2, 0) (a continuum of singular assemblies over that one input).
SELF_MOTION = (math.pi / 2, 0.0)
SELF_SQUARE = ((1.45, 1.7), (-0.125, 0.125))


@pytest.fixture(scope="module")
def self_motion_set():
    (x0, x1), (y0, y1) = SELF_SQUARE
    return spherekin.singular(EYE, x=("beta1", x0, x1), y=("beta2", y0, y1), fixed={"beta3": BETA3}, tol=0.01)


def test_a_self_motion_input_is_an_unresolved_region_and_the_curve_is_still_covered(self_motion_set):
    """Around (pi/2, 0) the cover crowds (singularities.cells.CROWDED_CELL): its boxes are set aside as unresolved
    regions wider than a cell, all close to the self-motion input, each a cusp candidate; the run completes,
    every closed-form point of T = 0 in the square is in a box, and every `singular` cell holds a sign change
    of T (~13 s)."""
    s = self_motion_set
    assert s.complete and s.stats.crowded > 0
    pts = agile_curve_points(SELF_SQUARE, BETA3, 2000)
    lo = np.array([[b.x[0], b.y[0]] for b in s.boxes])
    hi = np.array([[b.x[1], b.y[1]] for b in s.boxes])
    inside = ((pts[:, None] >= lo[None] - 1e-9) & (pts[:, None] <= hi[None] + 1e-9)).all(axis=2).any(axis=1)
    assert len(pts) > 1000 and inside.all()
    wide = [b for b in s.boxes if max(b.x[1] - b.x[0], b.y[1] - b.y[0]) > 0.01 + 1e-12]
    assert wide
    for b in wide:
        assert b.status == "unresolved"
        assert math.hypot(0.5 * sum(b.x) - SELF_MOTION[0], 0.5 * sum(b.y) - SELF_MOTION[1]) < 0.05, b
        assert any((c.box_x, c.box_y) == (b.x, b.y) for c in s.cusps)
    for b in s.boxes:
        if b.status == "singular":
            g1, g2 = np.meshgrid(np.linspace(*b.x, 41), np.linspace(*b.y, 41))
            v = _t(g1, g2)
            assert v.min() < 0.0 < v.max(), b
