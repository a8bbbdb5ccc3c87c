"""The independent references of issue 31 (tests/singular_refs.py), each checked against sympy, a closed form
or a separate numeric construction here, and each shown able to fail (a point moved by 1e-3 fails its check)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from singular_refs import (EXAMPLES, FourBar, five_bar_count, five_bar_curve_points, five_bar_from_file,
                           five_bar_moving, five_bar_tangency, five_bar_tracked, four_bar_branch_inputs,
                           four_bar_closure_coefficients, four_bar_from_arcs, four_bar_from_file, four_bar_toml,
                           rodrigues, rrr_closure, rrr_counts, rrr_geometry, rrr_poses, rrr_tracked, seeded_lines,
                           singular_points_on_line, track_box_min_det, type2_det)

DEG = math.pi / 180


# ---------------------------------------------------------------- 1. four-bar

def _tan_half_closure(fb: FourBar, theta: float) -> sp.Poly:
    """The closure C(psi) . B(theta) = cos(coupler arc) as a polynomial in t = tan(psi / 2), built by sympy
    from the axes (Rodrigues' formula with cos psi, sin psi rational in t), not from the (P, Q, S) closed form."""
    t = sp.Symbol("t")
    c, s = (1 - t**2) / (1 + t**2), 2 * t / (1 + t**2)
    d = sp.Matrix([sp.Float(x, 30) for x in fb.D])
    c0 = sp.Matrix([sp.Float(x, 30) for x in fb.C])
    bt = sp.Matrix([sp.Float(x, 30) for x in rodrigues(fb.A, theta) @ fb.B])
    c_psi = c0 * c + d.cross(c0) * s + d * d.dot(c0) * (1 - c)
    cos_b = sp.Float(float(fb.B @ fb.C), 30)
    return sp.Poly(sp.numer(sp.together((c_psi.dot(bt) - cos_b) * (1 + t**2))), t)


def _normalized_discriminant(fb: FourBar, theta: float) -> float:
    """sympy's discriminant of the tan-half polynomial over the square of its largest coefficient (scale-free)."""
    poly = _tan_half_closure(fb, theta)
    return float(sp.discriminant(poly) / max(abs(x) for x in poly.all_coeffs()) ** 2)


def _rocker_count(fb: FourBar, theta: float, n: int = 20000) -> int:
    """Assemblies at input theta by an independent numeric solve: sign changes of C(psi) . B(theta) - cos b
    over a fine grid of the rocker angle psi (the closure as geometry, no polynomial)."""
    psi = np.linspace(-math.pi, math.pi, n, endpoint=False) + 0.3183 * (2 * math.pi / n)   # no root on a node
    bt = rodrigues(fb.A, theta) @ fb.B
    c = (fb.C * np.cos(psi)[:, None] + np.cross(fb.D, fb.C) * np.sin(psi)[:, None]
         + fb.D * (fb.D @ fb.C) * (1 - np.cos(psi))[:, None])
    f = c @ bt - float(fb.B @ fb.C)
    return int(np.sum(np.sign(f) != np.sign(np.roll(f, 1))))


#: non-Grashof variants (ground, crank, coupler, rocker) in degrees: one reaches arc(B, D) = b + c, one |b - c|
VARIANTS = [(80, 50, 40, 60), (70, 50, 80, 50)]


def _variant(arcs) -> FourBar:
    """A variant assembled at crank azimuth pi/2 (where both variants close)."""
    return four_bar_from_arcs(*(a * DEG for a in arcs), theta=math.pi / 2)


def test_four_bar_file_is_a_crank_rocker_without_branch_points():
    """examples/four_bar.toml (80/30/70/60 deg): arc(B, D) stays in [50, 110] deg, never 130 or 10, so the crank
    turns fully: no branch input, 2 assemblies and a nonzero discriminant all round."""
    fb = four_bar_from_file()
    assert np.allclose(np.array(fb.arcs) / DEG, [80, 30, 70, 60], atol=1e-6)
    assert len(four_bar_branch_inputs(fb)) == 0
    for theta in np.linspace(-math.pi, math.pi, 13):
        assert _rocker_count(fb, theta) == 2
        assert _normalized_discriminant(fb, theta) > 1e-3


def test_four_bar_from_arcs_builds_the_requested_links():
    """The variants' arcs are the requested ones and the reference configuration closes."""
    for arcs in VARIANTS:
        fb = _variant(arcs)
        assert np.allclose(np.array(fb.arcs) / DEG, arcs, atol=1e-9)


@pytest.mark.parametrize("arcs", VARIANTS)
def test_four_bar_branch_inputs_are_double_roots(arcs):
    """At each closed-form branch input the tan-half closure has a double root (sympy discriminant zero); moved
    by 1e-3 the discriminant is clearly nonzero (the check can fail), and the numeric count goes 2 -> 0."""
    fb = _variant(arcs)
    branch = four_bar_branch_inputs(fb)
    assert len(branch) == 2
    for theta in branch:
        assert abs(_normalized_discriminant(fb, theta)) < 1e-12
        sides = [_rocker_count(fb, theta + e) for e in (-1e-3, 1e-3)]
        assert sorted(sides) == [0, 2]
        for e in (-1e-3, 1e-3):
            assert abs(_normalized_discriminant(fb, theta + e)) > 1e-5
        # the docstring's closed form of the discriminant agrees with sympy's (up to the factor 4 / scale)
        P, Q, S = four_bar_closure_coefficients(fb, theta + 1e-2)
        poly = _tan_half_closure(fb, theta + 1e-2)
        assert math.isclose(float(sp.discriminant(poly)), 4 * (Q * Q + S * S - P * P), rel_tol=1e-9, abs_tol=1e-12)


@pytest.mark.parametrize("arcs", VARIANTS)
def test_four_bar_branch_inputs_are_every_count_change(arcs):
    """A scan of the input circle with the numeric count finds a change exactly next to each branch input."""
    fb = _variant(arcs)
    thetas = np.linspace(-math.pi, math.pi, 721)
    counts = np.array([_rocker_count(fb, th, 4000) for th in thetas])
    changes = 0.5 * (thetas[1:] + thetas[:-1])[counts[1:] != counts[:-1]]
    branch = four_bar_branch_inputs(fb)
    assert len(changes) == len(branch)
    assert np.allclose(np.sort(changes), branch, atol=thetas[1] - thetas[0])


def test_four_bar_toml_round_trip_and_spherekin_agrees(tmp_path):
    """four_bar_toml writes the variant as a mechanism file: read back with tomllib it is the same four-bar, and
    spherekin (public API) reads its input as the references do: 0 assemblies on one side of each branch
    input, 2 on the other, as the numeric count says (the conventions the issue's tests rely on)."""
    import spherekin as sk

    fb = _variant(VARIANTS[0])
    path = tmp_path / "variant.toml"
    path.write_text(four_bar_toml(fb, "variant"))
    back = four_bar_from_file(path)
    assert np.allclose(back.arcs, fb.arcs, atol=1e-12)
    assert np.allclose(four_bar_branch_inputs(back), four_bar_branch_inputs(fb), atol=1e-12)
    mech = sk.load_mechanism(path)
    for theta in four_bar_branch_inputs(fb):
        for e in (-1e-3, 1e-3):
            assert len(sk.solve(mech, [theta + e]).solutions) == _rocker_count(fb, theta + e)


# ---------------------------------------------------------------- 2. general_3rrr along lines

def test_type2_det_is_the_closure_jacobian():
    """det[(w_i x v_i)^T] = -det(dg/domega), dg/domega by central differences of the closure (random poses)."""
    geo = rrr_geometry()
    rng = np.random.default_rng(3)
    for _ in range(5):
        beta = rng.uniform(-math.pi, math.pi, 3)
        rot = rodrigues(rng.normal(size=3), rng.uniform(0, math.pi))
        h = 1e-6
        jac = np.column_stack([(rrr_closure(geo, beta, rodrigues(e, h) @ rot)
                                - rrr_closure(geo, beta, rodrigues(e, -h) @ rot))[0] / (2 * h) for e in np.eye(3)])
        assert math.isclose(np.linalg.det(jac), -type2_det(geo, beta, rot)[0], rel_tol=1e-6, abs_tol=1e-9)


def _quaternion_jacobian_det(geo, beta, rot) -> float:
    """det of the Jacobian of (q^T A_i q, |q|^2 - 1) at the pose's unit quaternion: another formulation of the
    same singularity (the quadrics of references/peers_closed_form), normalized by the norms of its rows."""
    from references.peers_closed_form import leg_quadrics, rotation_quaternion

    q = rotation_quaternion(rot)
    jac = np.vstack([2 * leg_quadrics(geo, beta) @ q, 2 * q])
    return float(np.linalg.det(jac) / np.prod(np.linalg.norm(jac, axis=1)))


@pytest.fixture(scope="module")
def line_points():
    """Singular points on two seeded lines of the plane beta3 = 0.5 across [-pi, pi]^2."""
    return [(p0, p1, singular_points_on_line(p0, p1, n_samples=150, seed=0)) for p0, p1 in seeded_lines(2, seed=1)]


def test_singular_points_on_line_are_singular(line_points):
    """Each point: the count changes by 2 across a bracket of 1e-10, and the merging root is singular in two
    formulations (Type-2 det, quaternion Jacobian); moved 1e-3 into the side with more roots, the closest pair's
    midpoint is clearly regular (the check can fail)."""
    geo = rrr_geometry()
    total = 0
    for p0, p1, points in line_points:
        length = np.linalg.norm(p1 - p0)
        direction = (p1 - p0) / length
        assert len(points) >= 4
        for s in points:
            total += 1
            assert abs(s.count_before - s.count_after) == 2
            assert np.allclose(s.inputs[:2], p0 + s.t * (p1 - p0)) and s.inputs[2] == 0.5
            near = np.array([s.inputs - 1e-9 * np.r_[direction, 0], s.inputs + 1e-9 * np.r_[direction, 0]])
            assert list(rrr_counts(geo, near)) == [s.count_before, s.count_after]
            assert s.gap < 1e-2                                    # two roots about to merge: ~sqrt(1e-8)
            assert abs(s.det) < 1e-6
            assert abs(_quaternion_jacobian_det(geo, s.inputs, s.rot)) < 1e-6
            assert np.abs(rrr_closure(geo, s.inputs, s.rot)).max() < 1e-6
            # mutation: 1e-3 inside, the two merging roots are ~sqrt(1e-3) apart and each is regular
            sign = -1.0 if s.count_before > s.count_after else 1.0
            moved = s.inputs + sign * 1e-3 * np.r_[direction, 0]
            dets = [abs(type2_det(geo, moved, r)[0]) for r in rrr_poses(geo, moved)]
            assert min(dets) > 1e-3
    assert total >= 8


def test_singular_points_do_not_depend_on_the_sample_phase(line_points):
    """Another seed samples other points of the line: the same singular inputs to 1e-9."""
    p0, p1, points = line_points[0]
    again = singular_points_on_line(p0, p1, n_samples=150, seed=7)
    assert len(again) == len(points)
    assert np.allclose([s.t for s in again], [s.t for s in points], atol=1e-9)


# ---------------------------------------------------------------- 3. five-bar

def test_five_bar_file_geometry():
    """examples/five_bar.toml: cranks 45 deg, coupler and right distal link 60 deg, ground 60 deg."""
    fb = five_bar_from_file()
    assert math.isclose(fb.bc / DEG, 60, abs_tol=1e-6) and math.isclose(fb.dc / DEG, 60, abs_tol=1e-6)
    b, d = five_bar_moving(fb, [[0.0, 0.0]])
    assert np.allclose(b[0], fb.B) and np.allclose(d[0], fb.D)
    assert math.isclose(math.degrees(math.acos(fb.A @ fb.E)), 60, abs_tol=1e-6)


def test_five_bar_tangency_sign_is_the_count():
    """Away from the curve, F < 0 exactly where the two circles meet (2 positions of C), F > 0 where not (0)."""
    fb = five_bar_from_file()
    x = np.random.default_rng(5).uniform(-math.pi, math.pi, (400, 2))
    f = five_bar_tangency(fb, x)
    keep = np.abs(f) > 1e-9
    assert set(five_bar_count(fb, x[keep][f[keep] < 0])) == {2}
    assert set(five_bar_count(fb, x[keep][f[keep] > 0])) == {0}
    assert (f < 0).any() and (f > 0).any()


def test_five_bar_count_is_spherekins():
    """spherekin (public API) reads the five-bar's inputs as the references do: the same counts at seeded inputs."""
    import spherekin as sk

    fb = five_bar_from_file()
    mech = sk.load_mechanism(EXAMPLES / "five_bar.toml")
    x = np.random.default_rng(1).uniform(-3, 3, (6, 2))
    counts = five_bar_count(fb, x)
    assert set(counts) == {0, 2}
    assert [len(sk.solve(mech, list(xx)).solutions) for xx in x] == list(counts)


def test_five_bar_curve_points_are_tangencies():
    """On each curve point arc(B, D) = 120 deg; the count is 2 on one side and 0 on the other (1e-7 along the
    gradient); C there (the double root) makes B, C, D coplanar (det C . (B x D) = 0); 1e-3 off it |F| is not 0."""
    fb = five_bar_from_file()
    pts = five_bar_curve_points(fb, n_lines=20, n_samples=200, seed=2)
    assert len(pts) >= 6
    for x in pts:
        b, d = five_bar_moving(fb, x)
        assert math.isclose(math.degrees(math.acos(float(b[0] @ d[0]))), 120, abs_tol=1e-7)
        h = 1e-7
        grad = np.array([(five_bar_tangency(fb, x + h * e) - five_bar_tangency(fb, x - h * e))[0] / (2 * h)
                         for e in np.eye(2)])
        n = grad / np.linalg.norm(grad)
        assert sorted(five_bar_count(fb, [x - 1e-7 * n, x + 1e-7 * n])) == [0, 2]
        c = (b[0] + d[0]) / np.linalg.norm(b[0] + d[0])           # the midpoint of the 120 deg arc: the double root
        assert math.isclose(float(c @ b[0]), 0.5, abs_tol=1e-7) and math.isclose(float(c @ d[0]), 0.5, abs_tol=1e-7)
        assert abs(five_bar_tracked(fb).det(x[None], c[None])[0]) < 1e-12
        assert abs(five_bar_tangency(fb, x + 1e-3 * n)[0]) > 1e-5


# ---------------------------------------------------------------- 4. tracking over a box

HOME = np.array([0.0, 0.0, 0.5])


def test_track_box_regular_box_keeps_the_assembly():
    """Small boxes around home, every assembly of general_3rrr: nothing lost, no sign change, min |det| close to
    |det| at home; the tracked pose at a far corner is one of the oracle's roots there (continuity, not a jump)."""
    from references.peers_closed_form import direct_kinematics

    geo = rrr_geometry()
    tracked = rrr_tracked(geo)
    poses = direct_kinematics(geo, HOME)
    assert len(poses) == 8
    for rot in poses:
        res = track_box_min_det(tracked, HOME, rot, HOME - [0.01, 0.01, 0], HOME + [0.01, 0.01, 0], n=5)
        assert res.lost == 0 and res.sign_changes == 0 and res.n_points == 25
        assert math.isclose(res.min_abs_det, abs(type2_det(geo, HOME, rot)[0]), rel_tol=0.1)
    res_state = track_box_min_det(tracked, HOME, poses[0], HOME - 0.1, HOME + 0.1, n=9)
    assert res_state.lost == 0 and res_state.n_points == 9**3


def test_track_box_sees_a_reference_singular_point(line_points):
    """Boxes along beta1 (beta2, beta3 fixed) from 0.05 on the side of a reference singular input with more
    roots, tracked with the branch that merges there: ending 0.02 before the point the track is clean; ending
    0.03 past it, points are lost, det changes sign or |det| gets tiny (the check can fail)."""
    geo = rrr_geometry()
    tracked = rrr_tracked(geo)
    s = line_points[0][2][0]
    e1 = np.array([1.0, 0.0, 0.0])
    more = max((1.0, -1.0), key=lambda sg: rrr_counts(geo, s.inputs + sg * 1e-6 * e1)[0])
    home = s.inputs + more * 0.05 * e1
    rots = rrr_poses(geo, home)
    start = min(rots, key=lambda r: np.linalg.norm(r - s.rot))            # a branch that merges at s
    clean_end, past_end = s.inputs + more * 0.02 * e1, s.inputs - more * 0.03 * e1
    clean = track_box_min_det(tracked, home, start, np.minimum(home, clean_end), np.maximum(home, clean_end), n=61)
    assert clean.lost == 0 and clean.sign_changes == 0 and clean.min_abs_det > 1e-3
    past = track_box_min_det(tracked, home, start, np.minimum(home, past_end), np.maximum(home, past_end), n=61)
    assert past.lost > 0 or past.sign_changes > 0 or past.min_abs_det < 1e-3
    assert past.lost > 0 or past.sign_changes > 0


def test_track_box_five_bar_free_and_crossing_boxes():
    """Five-bar: a box where F < 0 on a fine grid (independently) tracks cleanly; a box the curve crosses is lost."""
    fb = five_bar_from_file()
    tracked = five_bar_tracked(fb)
    g = np.stack(np.meshgrid(*2 * [np.linspace(-0.5, 0.5, 41)], indexing="ij"), -1).reshape(-1, 2)
    assert (five_bar_tangency(fb, g) < 0).all()
    free = track_box_min_det(tracked, [0.0, 0.0], fb.C, [-0.5, -0.5], [0.5, 0.5], n=41)
    assert free.lost == 0 and free.sign_changes == 0 and free.min_abs_det > 1e-2
    wide = track_box_min_det(tracked, [0.0, 0.0], fb.C, [-2.0, -2.0], [2.0, 2.0], n=41)
    assert wide.lost > 0
