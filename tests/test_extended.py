"""Tests for spherekin.trust.extended (the Krawczyk test in extended precision on equations from the axes).

Independent references: the roots of spherical four-bars from their closed form (the coupler
point C on the circle of angular radius "coupler" about B(theta) and the circle "rocker" about D,
solved in mpmath at 50 digits from the mechanism's own float axes; the passive readings are then
the signed angles about B, D and C, also in mpmath: no float model and no polishing); the platform
rotations of the float model (``mech.forward``); the eight Gosselin solutions of ``spherekin.solve``;
spurious roots (M a half-turn) found by Newton's method on rotations from the float model.

Why the module exists: next to a change point the float test (spherekin.trust.krawczyk.certify)
fails on both roots at every radius and both angle tolerances; the extended test certifies each
with a box below 0.4 times their separation.

Note on the brief's four-bar (ground 60, crank 70, coupler 50, rocker 80 degrees, built from float
axes): its float geometry is not exactly a change point (the link angles of the float axes are off
by ~1e-16), so its two roots never come closer than ~5e-8 rad: 2.67e-6 apart at pi/2 + 1e-6, 5.8e-8
at + 1e-8, 5.2e-8 at + 1e-10 (closed form, from the vectors as given; the same vectors rounded to
unit floats, as ``Joint.axis`` stores them, give 6.1e-8 and 5.5e-8: another mechanism). Roots 3e-8 ..
3e-12 apart are tested on a four-bar that is an exact change point in floats: its axes are related by
the half-turn (x, y, z) -> (-x, -y, z), exact in floats, so crank = rocker and ground = coupler
exactly, with every axis in the xz-plane at input 0.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import mpmath
import numpy as np
import pytest
from mpmath import mp

import spherekin
from spherekin.mechanism import Joint, Leg, SphericalMechanism, general_3rrr, gosselin
from spherekin.mechanism.chains import axis_rotation, sphere_point
from spherekin.trust import extended
from spherekin.trust.extended import (ARITHMETICS, EXTENDED_RADII, certify_extended, krawczyk_boxes_extended,
                                      leg_rotations_extended, polish_extended)
from spherekin.trust.krawczyk import FINE_ANGLE_TOLERANCE, KrawczykResult, certify
from spherekin.trust.transversal import ANGLE_TOLERANCE

from references import edge_references as er
from conftest import GOSSELIN_INPUTS, rot


# --------------------------------------------------------------------------------------------
# Mechanisms and their closed-form roots
# --------------------------------------------------------------------------------------------

def polar(polar_deg: float, azimuth_deg: float) -> np.ndarray:
    p, a = math.radians(polar_deg), math.radians(azimuth_deg)
    return np.array([math.sin(p) * math.cos(a), math.sin(p) * math.sin(a), math.cos(p)])


def four_bar_of(a, b, c, d, d_actuated: bool = False) -> SphericalMechanism:
    """Legs "crank" = (A actuated, B) and "rocker" = (D, C), as spherekin.mechanism.presets.four_bar."""
    return SphericalMechanism(legs=(Leg("crank", (Joint("A", a, actuated=True), Joint("B", b))),
                                    Leg("rocker", (Joint("D", d, actuated=d_actuated), Joint("C", c)))))


def brief_axes() -> dict:
    """The float vectors of the brief's four-bar, as computed (Joint then normalizes them again)."""
    a = np.array([0.0, 0.0, 1.0])
    d = polar(60.0, 0.0)
    b = axis_rotation(a, math.pi / 2) @ polar(70.0, 0.0)
    c = sphere_point(b, d, math.radians(50.0), math.radians(80.0), 1.0)
    return {"A": a, "B": b, "C": c, "D": d}


def brief_four_bar() -> SphericalMechanism:
    """Ground 60, crank 70, coupler 50, rocker 80 degrees (issue 26): near a change point at input pi/2."""
    axes = brief_axes()
    return four_bar_of(axes["A"], axes["B"], axes["C"], axes["D"])


def change_point_four_bar() -> SphericalMechanism:
    """An exact change point at input 0: C = H A, B = H D with H the half-turn about z (exact in
    floats), so crank = rocker = 80 deg and ground = coupler = 60 deg, all axes in the xz-plane."""
    p, q = polar(10.0, 0.0), polar(70.0, 0.0)

    def half(v):
        return np.array([-v[0], -v[1], v[2]])

    return four_bar_of(p, half(q), half(p), q)


def closed_form_roots(mech: SphericalMechanism, theta: float, axes=None) -> list[list]:
    """Both assemblies (B, D, C readings as mpf, 50 digits) of a four-bar of :func:`four_bar_of` at input theta.

    From the mechanism's axis vectors as given (``Joint.given_axis``: the floats the mechanism was
    written with; or ``axes``, name -> vector, instead), normalized in mpmath:
    B = Rot(A, theta) B0; C on the circles of
    angular radius angle(B0, C0) about B and angle(D, C0) about D (c = alpha B + beta D + gamma B x D);
    the readings are the signed angles of the rotations that carry the reference configuration there.
    """
    with mp.workdps(50):
        def axis(name):
            v = mp.matrix([mp.mpf(float(t)) for t in (mech.joint(name).given_axis if axes is None else axes[name])])
            return v / mp.norm(v)

        def cross(p, q):
            return mp.matrix([p[1] * q[2] - p[2] * q[1], p[2] * q[0] - p[0] * q[2], p[0] * q[1] - p[1] * q[0]])

        def dot(p, q):
            return p[0] * q[0] + p[1] * q[1] + p[2] * q[2]

        def rot(n, t):
            k = mp.matrix([[0, -n[2], n[1]], [n[2], 0, -n[0]], [-n[1], n[0], 0]])
            return mp.eye(3) + mp.sin(t) * k + (1 - mp.cos(t)) * k * k

        def angle_about(n, x, y):
            xp, yp = x - n * dot(n, x), y - n * dot(n, y)
            return mp.atan2(dot(n, cross(xp, yp)), dot(xp, yp))

        a, b0, c0, d = axis("A"), axis("B"), axis("C"), axis("D")
        coupler, rocker = mp.acos(dot(b0, c0)), mp.acos(dot(d, c0))
        t = mp.mpf(theta)
        b = rot(a, t) * b0
        cbd = dot(b, d)
        alpha = (mp.cos(coupler) - cbd * mp.cos(rocker)) / (1 - cbd ** 2)
        beta = (mp.cos(rocker) - cbd * mp.cos(coupler)) / (1 - cbd ** 2)
        n = cross(b, d)
        g2 = (1 - alpha ** 2 - beta ** 2 - 2 * alpha * beta * cbd) / dot(n, n)
        assert g2 > 0
        out = []
        for branch in (1, -1):
            c = alpha * b + beta * d + branch * mp.sqrt(g2) * n
            phi_d = angle_about(d, c0, c)                      # rocker: Rot(D, phi_d) C0 = C
            phi_b = angle_about(b0, c0, rot(a, -t) * c)        # crank: Rot(A, t) Rot(B0, phi_b) C0 = C
            phi_c = angle_about(c0, b0, rot(d, -phi_d) * b)    # Rot(D, phi_d) Rot(C0, phi_c) B0 = B
            out.append([phi_b, phi_d, phi_c])
        return out


def separation(roots) -> float:
    return float(max(abs(p - q) for p, q in zip(*roots)))


def float_point(root) -> list[float]:
    return [float(v) for v in root]


def contains(box, root) -> bool:
    return all(mpmath.mpf(lo) < v < mpmath.mpf(hi) for (lo, hi), v in zip(box, root))


def disjoint(box1, box2) -> bool:
    return any(h1 < l2 or h2 < l1 for (l1, h1), (l2, h2) in zip(box1, box2))


def float_system(mech, inputs, y):
    return mech.loop_system(inputs, passive_ranges={n: (v - 1.0, v + 1.0) for n, v in zip(mech.loop_unknowns, y)})


#: (mechanism, input, expected separation of its two roots): the brief's four-bar and the exact change point.
CLOSE_CASES = [
    pytest.param(brief_four_bar, math.pi / 2 + 1e-6, 2.67e-6, id="brief+1e-6"),
    pytest.param(brief_four_bar, math.pi / 2 + 1e-8, 5.82e-8, id="brief+1e-8"),
    pytest.param(brief_four_bar, math.pi / 2 + 1e-10, 5.18e-8, id="brief+1e-10"),
    pytest.param(change_point_four_bar, 1e-8, 3.06e-8, id="exact+1e-8"),
    pytest.param(change_point_four_bar, 1e-10, 3.06e-10, id="exact+1e-10"),
    pytest.param(change_point_four_bar, 1e-12, 3.06e-12, id="exact+1e-12"),
]


# --------------------------------------------------------------------------------------------
# The closed form is about the same mechanism as the model
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("make, theta, sep", CLOSE_CASES)
def test_closed_form_roots_close_the_float_model(make, theta, sep):
    mech = make()
    roots = closed_form_roots(mech, theta)
    assert separation(roots) == pytest.approx(sep, rel=0.01)
    for root in roots:
        readings = {"A": theta, **dict(zip(mech.loop_unknowns, float_point(root)))}
        fwd = mech.forward(readings)
        assert max(fwd.loop_residuals) < 1e-12
        assert np.abs(fwd.leg_poses[0] - fwd.leg_poses[1]).max() < 1e-13


def test_brief_roots_match_the_issue():
    roots = closed_form_roots(brief_four_bar(), math.pi / 2 + 1e-6)
    assert np.allclose(np.mod(float_point(roots[0]), 2 * math.pi), (3.7232157, 2.1522957, 4.6335828), atol=1e-7)
    assert np.allclose(np.mod(float_point(roots[1]), 2 * math.pi), (3.7232130, 2.1522978, 4.6335807), atol=1e-7)


# --------------------------------------------------------------------------------------------
# Close roots: certified in extended precision, not in float
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("arithmetic", sorted(ARITHMETICS))
@pytest.mark.parametrize("make, theta, sep", CLOSE_CASES)
def test_close_roots_certified_separately(make, theta, sep, arithmetic):
    mech = make()
    roots = closed_form_roots(mech, theta)
    sep = separation(roots)
    results = [certify_extended(mech, [theta], float_point(r), arithmetic=arithmetic) for r in roots]
    for res, root in zip(results, roots):
        assert isinstance(res, KrawczykResult)
        assert res.certified, res.reason
        assert res.reason == ""
        assert res.radius < 0.4 * sep
        assert res.radii_tried == tuple(EXTENDED_RADII[:len(res.radii_tried)])
        assert contains(res.box, root)            # the certified box holds the closed-form root
        assert contains(res.krawczyk_box, root)   # and so does K(X)
        assert all(xl < kl and kh < xh for (xl, xh), (kl, kh) in zip(res.box, res.krawczyk_box))
        assert res.contraction < 1.0
        assert not res.no_solution
        assert res.angle_tolerance == 0.0
        assert res.residual < 1e-15
        assert res.names == mech.loop_unknowns and res.n_equations == res.n_unknowns == 3
        assert res.singular_values[-1] < 10 * sep        # the roots are close: J(y) nearly singular
    assert disjoint(results[0].box, results[1].box)


@pytest.mark.parametrize("make, theta, sep", CLOSE_CASES)
def test_float_certify_fails_on_close_roots(make, theta, sep):
    """Why the module exists: the float test certifies neither root, at any radius or angle tolerance."""
    mech = make()
    for root in closed_form_roots(mech, theta):
        y = float_point(root)
        system = float_system(mech, [theta], y)
        for tol in (ANGLE_TOLERANCE, FINE_ANGLE_TOLERANCE):
            res = certify(system, y, angle_tolerance=tol)
            assert not res.certified


def test_extended_certificate_is_about_the_given_floats():
    """Joint rounds the direction of the brief's vectors to floats (``axis``), moving B's axis by one ulp
    (1e-16): next to the change point that moves the roots by ~3e-11. The extended test is about the vectors
    as given (``given_axis``, issue 40: a file's numbers), and tells the two mechanisms apart: a tight box
    around a root of the rounded axes holds no root of the mechanism; a box that reaches the root of the
    given vectors is certified."""
    mech = brief_four_bar()
    raw = brief_axes()
    assert all(mech.joint(n).given_axis == tuple(float(t) for t in raw[n]) for n in "ABCD")
    assert 0 < max(np.abs(np.array(mech.joint(n).axis) - raw[n]).max() for n in "ABCD") <= 2.3e-16
    theta = math.pi / 2 + 1e-6
    rounded = closed_form_roots(mech, theta, axes={n: mech.joint(n).axis for n in "ABCD"})
    for root, other in zip(closed_form_roots(mech, theta, axes=raw), rounded):
        assert 1e-11 < separation([root, other]) < 1e-10
        res = certify_extended(mech, [theta], float_point(other), radii=[1e-13])
        assert not res.certified and res.no_solution, res.reason
        res = certify_extended(mech, [theta], float_point(other))     # a radius that reaches the root
        assert res.certified and contains(res.box, root)


# --------------------------------------------------------------------------------------------
# A fold of general_3rrr.toml, judged on the file's floats (issue 40 item 7)
# --------------------------------------------------------------------------------------------

GENERAL_3RRR = Path(__file__).resolve().parents[1] / "examples" / "general_3rrr.toml"

#: A fold of examples/general_3rrr.toml (6 assemblies on one side, 4 on the other), located to ~1e-32 on
#: the file's numbers at 60 digits (references.edge_references: rrr_segment(read_rrr_file(...),
#: default_rng(12)), refined by rrr_singular_input on +-1e-12 about it with accuracy 1e-32), and the
#: direction of the segment (max norm 1) towards 4.
FOLD_X = (mpmath.mpf("-1.65830694578772710929222193448129612"), mpmath.mpf("2.03362956828797813827798585315481541"),
          mpmath.mpf("-1.89864457080576819035662346681819776"))
FOLD_DIRECTION = (-0.11989342806394317, -1.0, 0.06904973357015985)


def fold_input(distance: float):
    """The float input nearest FOLD_X + distance * FOLD_DIRECTION."""
    with er.precision(60):
        return er.inputs_at(er.Edge(FOLD_X, FOLD_DIRECTION, "singular"), distance)[0]


def test_fold_of_the_file_nothing_proven_beyond_the_reference():
    """1e-15 past a fold of general_3rrr.toml, on the side with fewer assemblies: the 60-digit reference on the
    file's floats (tomllib, mpmath) finds 4 real assemblies (6 at 1e-15 before the fold). The legs written from
    the float model's joint axes (float64 intermediates: elbow axes rotated by the float reference input,
    normalized axes, reference readings) are another mechanism whose fold lies ~4e-15 further: it still has 6
    there, and its two extra assemblies, 3e-8 apart, were certified. Now neither is, and a tight box about each
    is proven to hold none; Newton in extended precision finds no root next to them; the file's four are
    certified."""
    mech = spherekin.load_mechanism(GENERAL_3RRR)
    past, before = fold_input(1e-15), fold_input(-1e-15)
    with er.precision(60):
        ref = er.rrr_reference(er.read_rrr_file(GENERAL_3RRR), past)
        assert ref.count == 4
        assert er.rrr_reference(er.read_rrr_file(GENERAL_3RRR), before).count == 6
        # the float model's joint axes (the mechanism without its description, which the reference would read)
        neighbour = er.rrr_reference(dataclasses.replace(mech, geometry=None), past)
    assert neighbour.count == 6
    extra = [q for q in neighbour.rotations if not any(np.abs(q - r).max() < 1e-6 for r in ref.rotations)]
    assert len(extra) == 2
    points = [np.array([pa[n] for n in mech.loop_unknowns]) for q in extra for pa in er.passive_angles(mech, q, past)]
    assert len(points) == 2 and 1e-8 < np.abs(points[0] - points[1]).max() < 1e-7
    for y in points:
        res = certify_extended(mech, past, y)
        assert not res.certified, res.radius
        tight = certify_extended(mech, past, y, radii=[1e-13])
        assert not tight.certified and tight.no_solution, tight.reason
        assert polish_extended(mech, past, y) is None
    for q in ref.rotations:
        y = np.array([er.passive_angles(mech, q, past)[0][n] for n in mech.loop_unknowns])
        assert certify_extended(mech, past, y).certified


def test_fold_of_the_file_certified_roots_are_the_file_s():
    """1e-15 before that fold (6 assemblies, two of them 2e-8 apart): Newton in extended precision from each of
    the reference's 6 (60 digits on the file's floats, rounded to floats) stays there, and the certified
    enclosure of the root lies within 1e-12 of it. Equations from the description's vectors rounded to unit
    floats (one float64 intermediate) move the close pair by 5e-9."""
    mech = spherekin.load_mechanism(GENERAL_3RRR)
    before = fold_input(-1e-15)
    with er.precision(60):
        ref = er.rrr_reference(er.read_rrr_file(GENERAL_3RRR), before)
    assert ref.count == 6 and ref.min_separation < 3e-8
    for q in ref.rotations:
        y = np.array([er.passive_angles(mech, q, before)[0][n] for n in mech.loop_unknowns])
        root = polish_extended(mech, before, y)
        assert root is not None and np.abs(root - y).max() < 1e-12
        res = certify_extended(mech, before, root)
        assert res.certified, res.reason
        k_lo, k_hi = np.array(res.krawczyk_box).T
        assert np.all(k_lo - 1e-12 < y) and np.all(y < k_hi + 1e-12)


@pytest.mark.parametrize("arithmetic", sorted(ARITHMETICS))
def test_newton_gives_up_where_no_root_is(monkeypatch, arithmetic):
    """1e-15 past the fold, next to the complex pair, Newton in extended precision bounces at the pair's
    imaginary part (~3e-8): it gives up once its smallest step has not halved for EXTENDED_NEWTON_STALL
    steps (~0.5 s per point for all EXTENDED_NEWTON_STEPS at a 3-RRR, paid by every point of a cluster)."""
    mech = spherekin.load_mechanism(GENERAL_3RRR)
    past = fold_input(1e-15)
    y = np.array([-1.92818005, 1.53194891, -0.1522432, 3.02461638, -0.74858013, 2.34897804])   # the pair
    steps = []
    cls = ARITHMETICS[arithmetic]
    step = cls.newton_step
    monkeypatch.setattr(cls, "newton_step", lambda self, jac, f: steps.append(1) or step(self, jac, f))
    assert polish_extended(mech, past, y, arithmetic=arithmetic) is None
    assert extended.EXTENDED_NEWTON_STALL < len(steps) <= 3 * extended.EXTENDED_NEWTON_STALL


def test_three_rrr_offsets_move_the_readings_only():
    """A joint offset moves the zero of the joint's reading (docs/mechanism-format.md: it reads its angle minus
    the offset): the file's roots, shifted by minus the offsets, are the roots of the same 3-RRR with offsets,
    certified there with the enclosure of each root at the shifted point (the offsets are exact in extended
    precision, as given)."""
    mech = spherekin.load_mechanism(GENERAL_3RRR)
    offsets = {"beta1": 0.3, "gamma2": -1.1, "delta3": 0.7}
    g = mech.geometry
    moved = spherekin.mechanism.three_rrr(*g.given_axes, g.distal_link_angles, joint_offsets=offsets)
    x = (0.3, -0.2, 0.5)
    x_moved = tuple(v - offsets.get(n, 0.0) for n, v in zip(mech.actuated, x))
    for sol in spherekin.solve(mech, x).solutions:
        y = np.array([sol.passive_angles[n] - offsets.get(n, 0.0) for n in mech.loop_unknowns])
        res = certify_extended(moved, x_moved, y, radii=[1e-13])
        assert res.certified, res.reason
        k_lo, k_hi = np.array(res.krawczyk_box).T
        assert np.all(k_lo - 1e-13 < y) and np.all(y < k_hi + 1e-13)


@pytest.mark.parametrize("arithmetic", sorted(ARITHMETICS))
def test_shifted_box_is_never_certified(arithmetic):
    mech = brief_four_bar()
    theta = math.pi / 2 + 1e-6
    for root in closed_form_roots(mech, theta):
        y = np.array(float_point(root))
        for r in (1e-12, 1e-10, 1e-9):
            for direction in (np.ones(3), np.array([1.0, -1.0, 0.5])):
                res = certify_extended(mech, [theta], y + 10 * r * direction, radii=[r], arithmetic=arithmetic)
                assert not res.certified
                assert res.no_solution, res.reason


def both_roots_box(mech, theta):
    """A box around root 1 (y = root 1) of radius twice the separation: it holds both roots."""
    roots = closed_form_roots(mech, theta)
    y = float_point(roots[0])
    r = 2.0 * separation(roots)
    return roots, y, r


@pytest.mark.parametrize("arithmetic", sorted(ARITHMETICS))
@pytest.mark.parametrize("make, theta", [(brief_four_bar, math.pi / 2 + 1e-6), (change_point_four_bar, 1e-10)])
def test_box_with_both_roots_is_not_certified(make, theta, arithmetic):
    mech = make()
    roots, y, r = both_roots_box(mech, theta)
    res = certify_extended(mech, [theta], y, radii=[r], arithmetic=arithmetic)
    assert all(contains(res.box, root) for root in roots)
    assert res.krawczyk_box is not None           # K(X) was computed (J(y) regular) ...
    assert not res.certified and not res.no_solution
    assert "not inside X" in res.reason           # ... and it does not fit: X holds two roots
    # at the midpoint of the two roots J is singular: refused, never certified
    mid = [float((p + q) / 2) for p, q in zip(*roots)]
    res = certify_extended(mech, [theta], mid, radii=[r])
    assert not res.certified


def test_dropping_the_jacobian_term_is_caught(monkeypatch):
    """A broken operator K(X) = y - C F(y) (without (I - C J(X)) (X - y)) would certify the box holding
    both roots: the test above is the one that catches it."""
    mech = brief_four_bar()
    theta = math.pi / 2 + 1e-6
    roots, y, r = both_roots_box(mech, theta)
    honest = extended._krawczyk_operator

    def broken(num, y_iv, f_y, c, j_x, x):
        out = []
        for i in range(len(y_iv)):
            acc = y_iv[i]
            for p in range(len(y_iv)):
                acc = acc - c[i][p] * f_y[p]
            out.append(acc)                       # y - C F(y): the (I - C J(X)) (X - y) term dropped
        return out

    monkeypatch.setattr(extended, "_krawczyk_operator", broken)
    res = certify_extended(mech, [theta], y, radii=[r])
    assert res.certified                          # the broken operator "proves" one root in a box of two
    monkeypatch.setattr(extended, "_krawczyk_operator", honest)
    assert not certify_extended(mech, [theta], y, radii=[r]).certified


# --------------------------------------------------------------------------------------------
# Spurious roots: M a half-turn about a coordinate axis
# --------------------------------------------------------------------------------------------

def half_turn_root(mech, theta, start):
    """Newton's method (central differences) on the entries (2,1), (3,1), (3,2) of M = R_crank^T R_rocker
    from the float model, from ``start``: a root of the loop entries that need not be an assembly."""
    def m_of(q):
        poses = mech.forward({"A": theta, **dict(zip(mech.loop_unknowns, q))}).leg_poses
        return poses[0].T @ poses[1]

    def f(q):
        m = m_of(q)
        return np.array([m[1, 0], m[2, 0], m[2, 1]])

    q = np.array(start, dtype=float)
    for _ in range(30):
        h = 1e-7
        jac = np.array([(f(q + h * e) - f(q - h * e)) / (2 * h) for e in np.eye(3)]).T
        step = np.linalg.solve(jac, f(q))
        q = q - step
        if np.abs(step).max() < 1e-15:
            break
    assert np.abs(f(q)).max() < 1e-14
    return q, np.diag(m_of(q))


@pytest.mark.parametrize("start", [(-1.00487787, -2.98251966, -0.13468858), (1.38374176, 1.40286079, -1.68225871),
                                   (-2.24503124, -1.67587263, -2.04048914)])
def test_half_turn_roots_are_not_certified(start):
    mech = brief_four_bar()
    q, diag = half_turn_root(mech, 0.3, start)
    assert np.sum(diag < 0) == 2                  # M = diag(+-1) with two -1: a half-turn, not I
    res = certify_extended(mech, [0.3], q, radii=[1e-10])
    assert not res.certified
    assert "diagonal entry" in res.reason
    # K(X) lies inside X: without the diagonal check this spurious root would be certified
    assert all(xl < kl and kh < xh for (xl, xh), (kl, kh) in zip(res.box, res.krawczyk_box))
    assert not certify_extended(mech, [0.3], q).certified
    tests = krawczyk_boxes_extended(mech, [0.3], (q - 1e-10)[None], (q + 1e-10)[None])
    assert not tests.certified[0] and not tests.no_solution[0]


def test_true_assemblies_next_to_the_half_turns_are_certified():
    mech = brief_four_bar()
    for root in closed_form_roots(mech, 0.3):
        res = certify_extended(mech, [0.3], float_point(root))
        assert res.certified and res.radius == EXTENDED_RADII[0], res.reason


# --------------------------------------------------------------------------------------------
# The agile eye (6 x 6) and general boxes
# --------------------------------------------------------------------------------------------

def test_agile_eye_solutions_certified():
    mech = gosselin()
    report = spherekin.solve(mech, GOSSELIN_INPUTS)
    assert len(report.solutions) == 8
    boxes = []
    turned = turned_gosselin()
    for sol in report.solutions:
        res = certify_extended(mech, GOSSELIN_INPUTS, sol.passive_angles, radii=[1e-10])
        assert res.certified, res.reason
        assert certify_extended(turned, GOSSELIN_INPUTS, sol.passive_angles, radii=[1e-10]) == res
        assert res.n_equations == res.n_unknowns == 6 and res.names == mech.loop_unknowns
        assert res.residual < 1e-14
        boxes.append(res.box)
        # a sequence in loop_unknowns order gives the same verdict
        again = certify_extended(mech, GOSSELIN_INPUTS, [sol.passive_angles[n] for n in mech.loop_unknowns],
                                 radii=[1e-10])
        assert again.krawczyk_box == res.krawczyk_box
    assert all(disjoint(boxes[i], boxes[j]) for i in range(8) for j in range(i))


def test_boxes_extended_agree_with_certify():
    mech = brief_four_bar()
    theta = math.pi / 2 + 1e-6
    roots = closed_form_roots(mech, theta)
    y1, y2 = (np.array(float_point(r)) for r in roots)
    sep = separation(roots)
    lo = np.array([y1 - 1e-9, y2 - 1e-9, y1 - 2 * sep, y1 + 1e-3 - 1e-6, y1 - 1e-9])
    hi = np.array([y1 + 1e-9, y2 + 1e-9, y1 + 2 * sep, y1 + 1e-3 + 1e-6, y1 + 3e-9])
    tests = krawczyk_boxes_extended(mech, [theta], lo, hi)
    assert tests.certified.tolist() == [True, True, False, False, True]
    assert tests.no_solution.tolist() == [False, False, False, True, False]
    assert tests.krawczyk_lo.shape == tests.krawczyk_hi.shape == (5, 3)
    for i in (0, 1, 4):
        assert np.all((tests.krawczyk_lo[i] > lo[i]) & (tests.krawczyk_hi[i] < hi[i]))
        root = roots[0] if i != 1 else roots[1]
        k_box = list(zip(tests.krawczyk_lo[i], tests.krawczyk_hi[i]))
        assert all(mpmath.mpf(a) <= v <= mpmath.mpf(b) for (a, b), v in zip(k_box, root))
    empty = krawczyk_boxes_extended(mech, [theta], np.zeros((0, 3)), np.zeros((0, 3)))
    assert empty.certified.shape == (0,)
    with pytest.raises(ValueError, match="lo, hi"):
        krawczyk_boxes_extended(mech, [theta], hi, lo)


# --------------------------------------------------------------------------------------------
# The equations: leg rotations against the float model, scope, arguments, state
# --------------------------------------------------------------------------------------------

def turned_gosselin() -> SphericalMechanism:
    """The agile eye with a platform reference R_ref != I (the certified equations do not use it)."""
    return dataclasses.replace(gosselin(), platform_reference=rot([0.3, -0.5, 0.7]))


@pytest.mark.parametrize("make", [gosselin, turned_gosselin, general_3rrr, brief_four_bar, change_point_four_bar])
def test_leg_rotations_match_float_model(make):
    mech = make()
    rng = np.random.default_rng(7)
    for _ in range(5):
        values = rng.uniform(-math.pi, math.pi, len(mech.joint_names))
        readings = {n: float(v) for n, v in zip(mech.joint_names, values)}
        poses = mech.forward(readings).leg_poses
        enclosed = leg_rotations_extended(mech, readings)
        for leg, pose in zip(mech.legs, poses):
            lo, hi = enclosed[leg.name]
            assert np.all(hi - lo <= 4e-16)
            assert np.all(lo - 1e-13 <= pose) and np.all(pose <= hi + 1e-13)
            assert np.abs(pose - lo).max() < 1e-14


def test_not_square_is_refused():
    base = brief_four_bar()
    mech = four_bar_of(*(base.joint(n).axis for n in "ABCD"), d_actuated=True)    # A and D actuated: 2 unknowns
    res = certify_extended(mech, [0.3, 0.2], [0.1, 0.2])
    assert not res.certified and res.reason.startswith("not certified: not square")
    assert res.krawczyk_box is None and res.radii_tried == (EXTENDED_RADII[0],)
    assert res.no_solution          # (0.1, 0.2) is far from closing the loop: F excludes 0 on the box
    tests = krawczyk_boxes_extended(mech, [0.3, 0.2], np.array([[0.0, 0.0], [0.1, 0.2]]),
                                    np.array([[2 * math.pi, 2 * math.pi], [0.1 + 1e-9, 0.2 + 1e-9]]))
    assert not tests.certified.any() and np.all(np.isnan(tests.krawczyk_lo))
    assert tests.no_solution.tolist() == [False, True]


def test_arguments_checked():
    mech = brief_four_bar()
    with pytest.raises(ValueError, match="theta"):
        certify_extended(mech, [0.3], [1.0, 2.0])
    with pytest.raises(ValueError, match="theta"):
        certify_extended(mech, [0.3], {"B": 1.0})
    with pytest.raises(ValueError, match="radii"):
        certify_extended(mech, [0.3], [1.0, 2.0, 3.0], radii=[1e-8, 1e-9])
    with pytest.raises(ValueError, match="inputs"):
        certify_extended(mech, [0.3, 0.1], [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="mechanism"):
        certify_extended("four_bar", [0.3], [1.0, 2.0, 3.0])


def test_global_mpmath_state_untouched():
    import flint

    before = (mpmath.mp.prec, mpmath.iv.prec, flint.ctx.prec)
    mech = brief_four_bar()
    for arithmetic in ARITHMETICS:
        certify_extended(mech, [0.3], float_point(closed_form_roots(mech, 0.3)[0]), arithmetic=arithmetic)
    assert (mpmath.mp.prec, mpmath.iv.prec, flint.ctx.prec) == before


def test_an_unknown_arithmetic_is_refused_with_the_valid_names():
    mech = brief_four_bar()
    with pytest.raises(ValueError, match="arithmetic: expected one of arb, mpmath"):
        certify_extended(mech, [0.3], [1.0, 2.0, 3.0], arithmetic="double")


def test_the_arithmetics_never_contradict_each_other():
    """Boxes around and between the two roots next to the change point, and shifted off them: a box one
    arithmetic certifies the other never calls empty (and conversely); both enclose the same roots."""
    mech = change_point_four_bar()
    theta = 1e-10
    roots = closed_form_roots(mech, theta)
    sep = separation(roots)
    rng = np.random.default_rng(4)
    centres = [np.array(float_point(r)) for r in roots]
    lo, hi = [], []
    for c in centres:
        for r in (0.05 * sep, 0.3 * sep, 2 * sep):
            for shift in (0.0, 0.5, 3.0):
                d = rng.normal(size=3) * r * shift
                lo.append(c + d - r)
                hi.append(c + d + r)
    lo, hi = np.array(lo), np.array(hi)
    arb, ref = (krawczyk_boxes_extended(mech, [theta], lo, hi, arithmetic=a) for a in ("arb", "mpmath"))
    assert not np.any(arb.certified & ref.no_solution) and not np.any(ref.certified & arb.no_solution)
    assert arb.certified.any() and arb.no_solution.any()              # the boxes decide both ways
    for tests in (arb, ref):
        for i in np.flatnonzero(tests.certified):
            inside = [r for r in roots if contains(tuple(zip(lo[i], hi[i])), r)]
            assert len(inside) == 1 and contains(tuple(zip(tests.krawczyk_lo[i], tests.krawczyk_hi[i])), inside[0])
