"""Singularity-free boxes (issue 31 item 4: spherekin/trust/free_box.py, the Krawczyk test over boxes of
inputs), checked against the independent references of tests/singular_refs.py: a dense tracking of the
assembly over the claimed box (numpy Newton on the closure, not spherekin's), the degree-8 oracle's singular
inputs along the box's edges and diagonals, and the box grown by 5 %."""

from __future__ import annotations

import math

import numpy as np
import pytest

import spherekin as sk
from singular_refs import (EXAMPLES, five_bar_from_file, five_bar_tracked, four_bar_branch_inputs, four_bar_from_arcs,
                           four_bar_toml, rodrigues, rrr_tracked, singular_points_on_line, track_box_min_det)
from spherekin.core import intervals as iv
from spherekin.trust.continuation import (SIGMA, LegEquations, cayley_coordinates, krawczyk_input_boxes,
                                          parametric_krawczyk)
from spherekin.trust.free_box import FreeBox, free_box
from spherekin.systems.platform import platform_legs

HOME = np.array([0.0, 0.0, 0.5])
#: The box grown by this factor about home must not be free per the reference (or the growth hit a cap).
GROW = 1.05
#: A grown box counts as not free per the reference when it loses the assembly, det changes sign, or
#: |det| gets below this (the dets of general_3rrr's regular assemblies here are 0.02 .. 0.9).
SINGULAR_DET = 1e-3
#: How close to a fold a free interval gets on the loop equations (the four-bar): the face stops where a
#: cell of MIN_CELL fails, which near its branch point depends on where the cells fall (measured: the
#: cell [0.3629, 0.3639] fails its Krawczyk test 0.024 rad from the fold while the box out to 0.364,
#: cut differently, is proven): within 10 %, not the 5 % (GROW) of the platform's cubes.
FOLD_REACH = 1.10
#: Two poses closer than this (largest entry of R) are one assembly; the merging pair of a reference
#: singular point is ~1e-4 apart, regular assemblies of general_3rrr at least ~0.1.
SAME_POSE = 1e-2


@pytest.fixture(scope="module")
def rrr():
    mech = sk.load_mechanism(EXAMPLES / "general_3rrr.toml")
    problem = sk.compile(mech)
    return mech, problem, problem.solve(HOME)


def _tracked_pose(x, rot0, steps: int = 60) -> np.ndarray:
    """The reference's assembly at input x (3,), continued from rot0 at HOME along the straight segment
    (rrr_tracked's Newton, `steps` short steps)."""
    tracked = rrr_tracked()
    rot = np.asarray(rot0, dtype=float)[None]
    for t in np.linspace(0.0, 1.0, steps + 1)[1:]:
        rot, res = tracked.newton((HOME + t * (x - HOME))[None], rot)
    assert res[0] < 1e-9
    return rot[0]


def test_the_box_form_of_the_parametric_krawczyk_operator_on_a_linear_family_with_known_roots():
    """parametric_krawczyk with P = 2 independent parameters on F(w, x) = A w - C x (roots w(x) = A^-1 C x,
    x in a box X: their hull is that of the four corners' roots, the map being linear): a box of unknowns
    holding the hull with room is proven and K holds every corner's root; a box missing one corner's root
    is not; a singular A is not. The segment form (one shared sigma) proves a box the box form cannot:
    the roots of a segment are a line, of a box a parallelogram."""
    a = np.array([[2.0, 0.5], [-0.3, 1.5]])
    c = np.array([[1.0, 0.4], [-0.2, 1.0]])
    x_lo, x_hi = np.array([0.1, -0.2]), np.array([0.16, -0.15])
    corners = np.array([[x_lo[0], x_lo[1]], [x_lo[0], x_hi[1]], [x_hi[0], x_lo[1]], [x_hi[0], x_hi[1]]])
    roots = np.linalg.solve(a, c @ corners.T).T
    lo_r, hi_r = roots.min(axis=0), roots.max(axis=0)
    boxes_lo = np.stack([lo_r - 0.01, lo_r - 0.01, lo_r + 0.3 * (hi_r - lo_r)])
    boxes_hi = np.stack([hi_r + 0.01, hi_r + 0.01, hi_r + 0.01])
    mats = np.stack([a, np.array([[1.0, 2.0], [0.5, 1.0]]), a])            # the second singular
    mid = 0.5 * (boxes_lo + boxes_hi)
    x_c = 0.5 * (x_lo + x_hi)
    f_m = iv.point(np.einsum("nij,nj->ni", mats, mid) - c @ x_c)           # F(m, x_c)
    rate = iv.point(np.broadcast_to(-c, (3, 2, 2)))                        # dF/dx = -C
    spread = iv.from_bounds(x_lo - x_c, x_hi - x_c)
    ok, k = parametric_krawczyk(boxes_lo, boxes_hi, mats, f_m, rate, iv.point(mats), spread)
    assert ok.tolist() == [True, False, False]
    assert np.all(k[0, 0] <= lo_r) and np.all(hi_r <= k[1, 0])
    # a box holding the diagonal segment's roots tightly: proven for the segment, not for the whole box
    seg = np.linalg.solve(a, c @ np.stack([x_lo, x_hi]).T).T
    pad = 0.02 * np.abs(seg[1] - seg[0]).max()
    t_lo, t_hi = (seg.min(axis=0) - pad)[None], (seg.max(axis=0) + pad)[None]
    t_mid = 0.5 * (t_lo + t_hi)
    sigma = iv.from_bounds(np.array([-SIGMA]), np.array([SIGMA - 1.0])).reshape(2, 1, 1)
    ok_seg, _ = parametric_krawczyk(t_lo, t_hi, a[None], iv.point(t_mid @ a.T - c @ x_hi),
                                    iv.point((-c @ (x_hi - x_lo))[None]), iv.point(a[None]), sigma)
    ok_box, _ = parametric_krawczyk(t_lo, t_hi, a[None], iv.point(t_mid @ a.T - c @ x_c), iv.point(-c[None]),
                                    iv.point(a[None]), spread)
    assert ok_seg.tolist() == [True] and ok_box.tolist() == [False]


def test_krawczyk_input_boxes_on_general_3rrr_holds_the_reference_roots_and_refuses_a_singular_point(rrr):
    """On general_3rrr at HOME: a box of inputs HOME +- 0.02 (beta3 fixed) with W = +-0.05 about the pose of
    solution 3 is proven, and K holds the reference's roots (rrr_tracked, continued from the pose) at the
    box's corners, in the same Cayley coordinates; a box of inputs around a singular input of the degree-8
    oracle (diagonal of the plane), W about the merging pose, is not proven."""
    mech, _, report = rrr
    eqs = LegEquations(platform_legs(mech))
    ref = np.array(mech.platform_reference_matrix, dtype=float)
    rot0 = report.solutions[2].platform_rotation
    dc = rot0 @ ref.T
    r = np.array([0.02, 0.02, 0.0])
    ok, k = krawczyk_input_boxes(eqs, dc[None], np.full((1, 3), -0.05), np.full((1, 3), 0.05), (HOME - r)[None],
                                 (HOME + r)[None])
    assert ok.tolist() == [True]
    for s1 in (-1, 1):
        for s2 in (-1, 1):
            x = HOME + r * np.array([s1, s2, 0.0])
            w = cayley_coordinates(dc.T @ _tracked_pose(x, rot0) @ ref.T)
            assert np.all(k[0, 0] <= w) and np.all(w <= k[1, 0])
    (point,) = singular_points_on_line([-0.3, -0.3], [-0.15, -0.15], 60, 0)
    d_sing = point.rot @ ref.T
    ok, _ = krawczyk_input_boxes(eqs, d_sing[None], np.full((1, 3), -0.05), np.full((1, 3), 0.05),
                                 (point.inputs - [0.01, 0.01, 0.0])[None], (point.inputs + [0.01, 0.01, 0.0])[None])
    assert ok.tolist() == [False]


def _edges_and_diagonals(lo, hi) -> list:
    """The 4 edges and 2 diagonals of the plane box [lo, hi] (beta1, beta2), as segments (p0, p1)."""
    (a, b), (c, d) = (lo[0], lo[1]), (hi[0], hi[1])
    corners = [(a, b), (c, b), (c, d), (a, d)]
    return [(corners[i], corners[(i + 1) % 4]) for i in range(4)] + [((a, b), (c, d)), ((a, d), (c, b))]


@pytest.mark.parametrize("k, shape", [(1, "cube"), (7, "box")])
def test_free_box_of_general_3rrr_in_the_plane_matches_the_references(rrr, k, shape):
    """general_3rrr, HOME (0, 0, 0.5), the plane (beta1, beta2): the claimed box holds the assembly with no
    lost point, no sign change and |det| > 0 on a 41 x 41 grid (reference tracking); no singular input of the
    oracle on its edges and diagonals is a merging point of this assembly. A cube grown by 5 % is not free per
    the reference (the assembly is lost, det changes sign or nearly vanishes) or the growth hit a cap; a box
    (faces pushed out one at a time, up to 0.6 rad) holds the cube, and each face that stopped short of its
    cap, pushed out by 5 % alone, makes the box not free per the reference."""
    mech, problem, report = rrr
    rot0 = report.solutions[k].platform_rotation
    fb = problem.free_box(HOME, start=k, inputs=("beta1", "beta2"), shape=shape,
                          **({"max_radius": 0.6} if shape == "box" else {}))
    assert isinstance(fb, FreeBox) and fb.proven and fb.free == ("beta1", "beta2") and fb.shape == shape
    lo, hi = np.array(fb.lo), np.array(fb.hi)
    assert lo[2] == hi[2] == 0.5
    assert fb.as_dict()["x"] == [lo[0], hi[0]] and fb.as_dict()["y"] == [lo[1], hi[1]]
    if shape == "cube":
        assert np.allclose(hi[:2] - HOME[:2], fb.radius) and np.allclose(HOME[:2] - lo[:2], fb.radius)
    else:
        assert np.all(hi[:2] - HOME[:2] >= fb.radius) and np.all(HOME[:2] - lo[:2] >= fb.radius)
        assert [(f.input, f.side) for f in fb.faces] == [("beta1", "lo"), ("beta1", "hi"), ("beta2", "lo"),
                                                         ("beta2", "hi")]
        assert (hi - lo)[:2].prod() > 1.5 * (2 * fb.radius) ** 2        # the faces found room beyond the cube
    box = track_box_min_det(rrr_tracked(), HOME, rot0, lo, hi, 41)
    assert box.lost == 0 and box.sign_changes == 0 and box.min_abs_det > 0
    for p0, p1 in _edges_and_diagonals(lo, hi):
        for point in singular_points_on_line(p0, p1, 60, 0):
            assert np.abs(_tracked_pose(point.inputs, rot0) - point.rot).max() > SAME_POSE
    if shape == "cube":
        if fb.limit in ("cells", "radius"):
            return
        grown = track_box_min_det(rrr_tracked(), HOME, rot0, HOME - GROW * (HOME - lo), HOME + GROW * (hi - HOME),
                                  81)
        assert grown.lost > 0 or grown.sign_changes > 0 or grown.min_abs_det < SINGULAR_DET
        return
    assert {f.limit for f in fb.faces} <= {"unproven", "radius"} and any(f.limit == "unproven" for f in fb.faces)
    for face in fb.faces:
        a = ("beta1", "beta2").index(face.input)
        assert math.isclose(abs((lo, hi)[face.side == "hi"][a] - HOME[a]), face.extent)
        if face.limit == "radius":
            assert math.isclose(face.extent, 0.6)
            continue
        g_lo, g_hi = lo.copy(), hi.copy()
        if face.side == "lo":
            g_lo[a] = HOME[a] - GROW * face.extent
        else:
            g_hi[a] = HOME[a] + GROW * face.extent
        grown = track_box_min_det(rrr_tracked(), HOME, rot0, g_lo, g_hi, 81)
        assert grown.lost > 0 or grown.sign_changes > 0 or grown.min_abs_det < SINGULAR_DET, face


def test_free_box_of_general_3rrr_in_all_inputs_matches_the_reference(rrr):
    """The same with the three inputs free (a cube about HOME), solution 6: the reference tracks the cube on a
    21^3 grid with no lost point and no sign change; the cube grown by 5 % is not free."""
    mech, _, report = rrr
    rot0 = report.solutions[5].platform_rotation
    fb = free_box(mech, HOME, rot0, shape="cube")
    assert fb.proven and fb.free == ("beta1", "beta2", "beta3") and set(fb.as_dict()) >= {"x", "y", "beta3"}
    lo, hi = np.array(fb.lo), np.array(fb.hi)
    box = track_box_min_det(rrr_tracked(), HOME, rot0, lo, hi, 21)
    assert box.lost == 0 and box.sign_changes == 0 and box.min_abs_det > 0
    assert fb.limit not in ("cells", "radius")
    grown = track_box_min_det(rrr_tracked(), HOME, rot0, HOME - GROW * (HOME - lo), HOME + GROW * (hi - HOME), 31)
    assert grown.lost > 0 or grown.sign_changes > 0 or grown.min_abs_det < SINGULAR_DET


def test_free_box_of_the_five_bar_on_the_loop_equations():
    """The five-bar (loop equations), home 0.05 rad from its singular curve, both assemblies, radius capped at
    0.004: each box is proven to the cap, and the reference (five_bar_tracked: the axis C by Newton) tracks
    it with no lost point, no sign change and |det| > 0."""
    mech = sk.load_mechanism(EXAMPLES / "five_bar.toml")
    home = np.array([1.21, -0.71])
    report = sk.solve(mech, home)
    fb5 = five_bar_from_file()
    assert len(report.solutions) == 2
    for sol in report.solutions:
        fb = free_box(mech, home, sol.passive_angles, shape="cube", max_radius=0.004)
        assert fb.proven and fb.limit == "radius" and math.isclose(fb.radius, 0.004)
        c = rodrigues(fb5.A, home[0]) @ rodrigues(fb5.B, sol.passive_angles["B"]) @ fb5.C
        box = track_box_min_det(five_bar_tracked(), home, c, np.array(fb.lo), np.array(fb.hi), 21)
        assert box.lost == 0 and box.sign_changes == 0 and box.min_abs_det > 0


def test_free_box_of_a_four_bar_ends_before_its_branch_point(tmp_path):
    """A non-Grashof four-bar (80/50/40/60 deg, one input): the free interval about reading 0 holds none of
    its branch inputs (closed form), and FOLD_REACH more reaches the nearest one (0.3878 rad). The crank-rocker of
    examples/four_bar.toml has none: its free interval reaches any radius asked (0.7 rad here; the loop
    equations' J_p is regular all round; a box side of a coordinate that is stationary over a cell must
    not be thinner than the enclosure's overestimation, W_EVEN: without it the box stopped at 0.60 rad)."""
    deg = math.pi / 180
    fb = four_bar_from_arcs(80 * deg, 50 * deg, 40 * deg, 60 * deg, theta=math.pi / 2)
    path = tmp_path / "variant.toml"
    path.write_text(four_bar_toml(fb, "variant"))
    mech = sk.load_mechanism(path)
    branch = four_bar_branch_inputs(fb)
    box = free_box(mech, [0.0], sk.solve(mech, [0.0]).solutions[0].passive_angles, max_radius=1.0)
    assert box.proven and box.limit == "unproven" and box.shape == "box"
    assert not np.any((box.lo[0] <= branch) & (branch <= box.hi[0]))
    assert np.any(np.abs(branch) <= FOLD_REACH * box.radius)
    # the box's faces: the upper stops just before the branch input 0.3878; below 0 the nearest one is
    # 2.7538 - 2 pi, beyond half a turn, so the lower face reaches the radius cap (1 rad here)
    assert branch.min() > 0 and branch.max() - 2 * math.pi < -math.pi
    (lo_face, hi_face) = box.faces
    assert (lo_face.side, hi_face.side) == ("lo", "hi")
    assert hi_face.limit == "unproven" and hi_face.extent < branch.min() <= FOLD_REACH * hi_face.extent
    assert lo_face.limit == "radius" and lo_face.extent == 1.0 and box.lo[0] == -1.0
    crank = sk.load_mechanism(EXAMPLES / "four_bar.toml")
    whole = free_box(crank, [0.0], sk.solve(crank, [0.0]).solutions[0].passive_angles, max_radius=0.7)
    assert whole.limit == "radius" and whole.radius == 0.7


def test_free_box_refuses_bad_arguments_before_any_proof(rrr):
    mech, problem, report = rrr
    rot = report.solutions[0].platform_rotation
    for home, match in (([0.0, 0.0], "home: expected 3 inputs"), ([0.0, 0.0, 99.0], "home: inputs \\(beta3\\)")):
        with pytest.raises(ValueError, match=match):
            free_box(mech, home, rot)
    with pytest.raises(ValueError, match="start: the start pose does not close the legs at home"):
        free_box(mech, HOME, np.eye(3))
    with pytest.raises(ValueError, match="inputs: expected distinct actuated joint names"):
        free_box(mech, HOME, rot, inputs=("beta1", "beta1"))
    with pytest.raises(ValueError, match="max_radius: expected 0 < R"):
        free_box(mech, HOME, rot, max_radius=0.0)
    with pytest.raises(ValueError, match="start: expected a solution index 0..7 of the solve at home"):
        problem.free_box(HOME, start=8)
    five = sk.compile(sk.load_mechanism(EXAMPLES / "five_bar.toml"))
    with pytest.raises(ValueError, match="start: a start rotation needs the platform tracker"):
        five.free_box([0.0, 0.0], start=np.eye(3))


def test_free_box_faces_stop_at_the_actuated_joint_ranges(tmp_path):
    """general_3rrr with beta1 limited to [-0.1, 0.25] rad and beta2 to [-0.15, 2.0]: the free box of solution 2
    about HOME in the plane ends at beta1's range on both sides and at beta2's below (limit "range", the
    extents the ranges leave: 0.1, 0.25, 0.15), while beta2's upper face (room 2.0) stops short of it
    at a singularity or the radius cap."""
    text = (EXAMPLES / "general_3rrr.toml").read_text()
    text += '\n[joint_ranges]\nbeta1 = [-0.1, 0.25]\nbeta2 = [-0.15, 2.0]\n'
    path = tmp_path / "ranged.toml"
    path.write_text(text)
    mech = sk.load_mechanism(path)
    problem = sk.compile(mech)
    fb = problem.free_box(HOME, start=1, inputs=("beta1", "beta2"), max_radius=0.5)
    faces = {(f.input, f.side): f for f in fb.faces}
    for key, room in ((("beta1", "lo"), 0.1), (("beta1", "hi"), 0.25), (("beta2", "lo"), 0.15)):
        assert faces[key].limit == "range" and math.isclose(faces[key].extent, room, abs_tol=1e-12), faces[key]
    assert faces[("beta2", "hi")].limit in ("radius", "unproven") and faces[("beta2", "hi")].extent > 0.15
    assert math.isclose(fb.lo[0], -0.1) and math.isclose(fb.hi[0], 0.25) and math.isclose(fb.lo[1], -0.15)
    assert fb.radius >= 0.25                       # the cube (each face capped by its room) grew past the ranges
    rows = np.array([[fb.lo[0], fb.lo[1], 0.5], [fb.hi[0], fb.hi[1], 0.5]])
    mech.check_input_rows(rows, "corner {k}")                              # both corners inside the ranges


def test_free_box_faces_stop_at_the_bounds_asked_for(rrr, tmp_path, capsys):
    """Issue 42 item 4: the box drawn in a plane ran outside it (beta1 up to 1.35 over [-0.5, 0.5]). With
    ``bounds`` every face stays inside them (limit "bounds" where it reaches them), home must lie inside,
    and the command bounds it by its plane and prints each face as a coordinate."""
    mech, problem, _ = rrr
    window = {"beta1": (-0.1, 0.2), "beta2": (-0.15, 0.3)}
    fb = problem.free_box(HOME, start=1, inputs=("beta1", "beta2"), bounds=window)
    for k, name in enumerate(("beta1", "beta2")):
        assert window[name][0] - 1e-12 <= fb.lo[k] and fb.hi[k] <= window[name][1] + 1e-12
    faces = {(f.input, f.side): f for f in fb.faces}
    assert faces[("beta1", "lo")].limit == "bounds" and math.isclose(faces[("beta1", "lo")].extent, 0.1)
    assert all(f.limit in ("bounds", "unproven", "link", "cells") for f in fb.faces)
    with pytest.raises(ValueError, match="bounds: expected"):
        problem.free_box(HOME, start=1, inputs=("beta1",), bounds={"beta1": (0.1, 0.2)})   # home outside
    from spherekin.cli import main

    assert main(["singular", str(EXAMPLES / "general_3rrr.toml"), "--x", "beta1=-0.1:0.2", "--y", "beta2=-0.15:0.3",
                 "--fix", "beta3=0.5", "--tol", "0.1", "--home", "0,0,0.5", "--start-solution", "2"]) == 0
    out = capsys.readouterr().out
    assert "beta1 lo = -0.1 (0.1 from home; bounds)" in out and "beta1 [-0.1, " in out
