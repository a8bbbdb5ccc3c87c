"""The 50-digit edge references of references/edge_references.py, checked against independent facts.

* Two-leg mechanisms (four-bar, five-bar): every reference assembly closes (the angles between the
  current axes equal the link angles to 1e-40, the rotation maps the reference coupler onto it and
  is a rotation), spherekin's forward kinematics at its passive angles gives the same pose, the
  count agrees with a brute-force scan of the coupler circle (no discriminant), the count changes
  exactly at every computed branch input (+-1e-30) where angle(B, Q) takes its limiting value, and
  the preset crank-rocker has 2 assemblies at every input.
* 3-RRR: the joint-axes reference agrees with references.reference_roots (built from the 3-RRR's
  description lists) at generic inputs, its poses satisfy the description's leg constraints, and
  the singular input of the issue-13 segment separates 8 from 6 assemblies at +-1e-18.
* The campaign's judge on made-up reports: an exact wrong count, an invented root and a lost one
  are wrong; a cluster holding the missing roots is flagged.
* On the files' numbers (issue 40): a text angle is the double the format's reader computes; the 3-RRR
  file reference has the joint-axes reference's count at generic inputs and its poses meet the file's
  leg constraints at 50 digits; the six-bar references count as tests/test_singular_loops.py's float
  references (circle intersections, the degree-8 eliminant), every joint reads 0 at the file's
  reference assembly, and each assembly closes every link's arcs at 50 digits.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import mpmath
import numpy as np
import pytest

from references import edge_references as er

@pytest.fixture(autouse=True)
def fifty_digits():
    """Every mpmath computation of these tests at the references' precision."""
    with mpmath.workdps(er.DIGITS):
        yield


FOUR_BARS = [(80, 30, 70, 60), (60, 70, 50, 80), (100, 120, 45, 80), (80, 70, 30, 60), (60, 50, 70, 45),
             (30, 70, 80, 60), (60, 40, 50, 30)]


def mpv(v):
    """The float vector v exactly in mpmath, normalized (an axis is a direction)."""
    x = [mpmath.mpf(float(t)) for t in v]
    n = mpmath.sqrt(sum(t * t for t in x))
    return [t / n for t in x]


def mp_angle(a, b):
    na = mpmath.sqrt(sum(x * x for x in a))
    nb = mpmath.sqrt(sum(x * x for x in b))
    cr = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    return mpmath.atan2(mpmath.sqrt(sum(x * x for x in cr)), sum(x * y for x, y in zip(a, b))) if na and nb else None


def link_angles(mech):
    """Every link angle of a two-leg mechanism from its axes as given, at 50 digits: (joint, joint) -> angle."""
    out = {}
    for leg in mech.legs:
        for j, k in zip(leg.joints, leg.joints[1:]):
            out[(j.name, k.name)] = mp_angle(mpv(j.given_axis), mpv(k.given_axis))
    b, c = mech.legs[0].joints[-1], mech.legs[1].joints[-1]
    out[(b.name, c.name)] = mp_angle(mpv(b.given_axis), mpv(c.given_axis))
    return out


def scan_count(mech, inputs, n=4000):
    """Independent count of a two-leg mechanism: C on the circle of radius angle(B0, C0) about B(theta),
    sign changes of angle(C, Q) - angle(D0, C0) over n points (floats, rotation by scipy-free Rodrigues)."""
    lb, lo = mech.legs
    a_ax, b0 = np.array(lb.joints[0].axis), np.array(lb.joints[1].axis)
    c0 = np.array(lo.joints[-1].axis)
    d0 = np.array(lo.joints[-2].axis)

    def rot(axis, t, v):
        return v * math.cos(t) + np.cross(axis, v) * math.sin(t) + axis * (axis @ v) * (1 - math.cos(t))

    b = rot(a_ax, inputs[0], b0)
    q = d0 if len(lo.joints) == 2 else rot(np.array(lo.joints[0].axis), inputs[1], d0)
    ra, rb = math.acos(np.clip(b0 @ c0, -1, 1)), math.acos(np.clip(d0 @ c0, -1, 1))
    e1 = np.cross(b, [0.3, -0.5, 0.8])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(b, e1)
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    pts = np.cos(ra) * b + np.sin(ra) * (np.cos(t)[:, None] * e1 + np.sin(t)[:, None] * e2)
    f = np.arccos(np.clip(pts @ q, -1, 1)) - rb
    return int(np.sum(np.sign(f) != np.sign(np.roll(f, 1))))


# ------------------------------------------------------------------------------ four-bar, five-bar

def test_four_bar_constructor_is_the_preset():
    from spherekin.mechanism import four_bar

    ours, preset = er.four_bar(80, 30, 70, 60), four_bar()
    for la, lb in zip(ours.legs, preset.legs):
        for ja, jb in zip(la.joints, lb.joints):
            assert (ja.name, ja.axis, ja.actuated) == (jb.name, jb.axis, jb.actuated)
    angles = link_angles(er.four_bar(100, 120, 45, 80))
    assert [float(mpmath.degrees(angles[k])) for k in [("A", "B"), ("B", "C"), ("D", "C")]] == \
        pytest.approx([120, 45, 80], abs=1e-12)


@pytest.mark.parametrize("angles", FOUR_BARS)
def test_four_bar_assemblies_close_and_match_the_model(angles):
    mech = er.four_bar(*angles)
    links = link_angles(mech)
    axes = {j.name: mpv(j.given_axis) for leg in mech.legs for j in leg.joints}
    rng = np.random.default_rng(sum(angles))
    seen = 0
    for theta in rng.uniform(-np.pi, np.pi, 6):
        ref = er.two_leg_reference(mech, (theta,))
        assert ref.count == len(ref.rotations) in (0, 2)
        assert ref.count == scan_count(mech, (theta,))
        for r, pts in zip(ref.mp_rotations, ref.points):
            seen += 1
            cur = {"A": axes["A"], "D": axes["D"], **pts}
            for (j, k), ang in links.items():
                assert abs(mp_angle(cur[j], cur[k]) - ang) < mpmath.mpf("1e-40")
            for name in ("B", "C"):       # R maps the reference coupler onto the assembly
                img = r * mpmath.matrix(axes[name])
                assert max(abs(img[i] - cur[name][i]) for i in range(3)) < mpmath.mpf("1e-40")
            assert mpmath.norm(r.T * r - mpmath.eye(3), 1) < mpmath.mpf("1e-40")
            assert abs(mpmath.det(r) - 1) < mpmath.mpf("1e-40")
            # spherekin's forward kinematics (product of exponentials) at the passive angles
            (pa,) = er.passive_angles(mech, ref.rotations[ref.mp_rotations.index(r)], (theta,))
            fwd = mech.forward({"A": float(theta), **pa})
            assert max(fwd.loop_residuals) < 1e-12
            assert np.abs(fwd.pose - er._to_float(r)).max() < 1e-12
    assert seen > 0


def test_preset_crank_rocker_has_two_assemblies_at_every_input():
    from spherekin.mechanism import four_bar

    mech = four_bar()
    assert {er.two_leg_reference(mech, (t,)).count for t in np.linspace(-np.pi, np.pi, 181)} == {2}
    assert {e.kind for e in er.two_leg_edges(mech)} == {"closest"}


@pytest.mark.parametrize("angles", [(100, 120, 45, 80), (80, 70, 30, 60), (60, 50, 70, 45), (60, 70, 50, 80),
                                    (60, 40, 50, 30)])
def test_the_count_changes_exactly_at_the_branch_inputs(angles):
    mech = er.four_bar(*angles)
    links = link_angles(mech)
    a, b = links[("B", "C")], links[("D", "C")]
    a_axis, b0, d0 = (mpv(j.given_axis) for j in (mech.legs[0].joints[0], mech.legs[0].joints[1], mech.legs[1].joints[0]))
    edges = er.two_leg_edges(mech)
    assert edges
    with mpmath.workdps(er.DIGITS):
        for e in edges:
            theta = e.x_star[0]
            c, s = mpmath.cos(theta), mpmath.sin(theta)        # B(theta), Rodrigues written out again
            k = [a_axis[1] * b0[2] - a_axis[2] * b0[1], a_axis[2] * b0[0] - a_axis[0] * b0[2],
                 a_axis[0] * b0[1] - a_axis[1] * b0[0]]
            ab = sum(x * y for x, y in zip(a_axis, b0))
            bt = [b0[i] * c + k[i] * s + a_axis[i] * ab * (1 - c) for i in range(3)]
            gap = mp_angle(bt, d0)
            limit = min(abs(gap - abs(a - b)), abs(gap - min(a + b, 2 * mpmath.pi - a - b)))
            eps = mpmath.mpf("1e-30")
            lo = er.two_leg_reference(mech, (theta - eps,)).count
            hi = er.two_leg_reference(mech, (theta + eps,)).count
            if e.kind in ("branch", "change-split"):
                assert limit < mpmath.mpf("1e-40")
                assert {lo, hi} == {0, 2}
            else:        # a change point of the paper design: within ~1e-16 in floats, no change of count
                assert e.kind == "change"
                assert limit < mpmath.mpf("1e-14")
                assert lo == hi
    if angles == (60, 70, 50, 80):   # its change point is at theta = pi/2, and the float design keeps 2 there
        (change,) = [e for e in edges if e.kind == "change"]
        assert abs(change.x_star[0] - mpmath.pi / 2) < 1e-15
        for d in (1e-16, 1e-8, 1e-6, 1e-2):
            for sg in (-1, 1):
                assert er.two_leg_reference(mech, er.inputs_at(change, sg * d)[0]).count == 2


def test_five_bar_references():
    from spherekin.mechanism import five_bar

    for mech in (five_bar(), er.five_bar(70, 40, 65, 55, 50)):
        links = link_angles(mech)
        axes = {j.name: mpv(j.given_axis) for leg in mech.legs for j in leg.joints}
        rng = np.random.default_rng(5)
        for x in rng.uniform(-np.pi, np.pi, (8, 2)):
            ref = er.two_leg_reference(mech, x)
            assert ref.count == scan_count(mech, x)
            for r, pts in zip(ref.rotations, ref.points):
                cur = {"A": axes["A"], "E": axes["E"], **pts}
                for (j, k), ang in links.items():
                    assert abs(mp_angle(cur[j], cur[k]) - ang) < mpmath.mpf("1e-40")
                (pa,) = er.passive_angles(mech, r, x)
                fwd = mech.forward({"A": float(x[0]), "E": float(x[1]), **pa})
                assert max(fwd.loop_residuals) < 1e-12 and np.abs(fwd.pose - r).max() < 1e-12
        for e in er.two_leg_edges(mech, (0.0, -1.0)):
            assert e.kind == "branch"
            counts = {er.two_leg_reference(mech, (e.x_star[0] + sg * mpmath.mpf("1e-30"), -1.0)).count for sg in (-1, 1)}
            assert counts == {0, 2}
    # the preset's coincidence inputs: B, turning about A, comes within rounding of D
    mech = five_bar()
    for theta_e in er.two_leg_coincidences(mech):
        (edge,) = er.two_leg_edges(mech, (0.0, theta_e))
        assert edge.kind == "coincident"
        ref = er.two_leg_reference(mech, [edge.x_star[0], theta_e])
        assert ref.count == 2 and abs(ref.discriminant) < 1e-30


# ------------------------------------------------------------------------------ 3-RRR

@pytest.mark.parametrize("name", ["gosselin", "general_3rrr"])
def test_rrr_reference_agrees_with_reference_roots(name):
    from references.peers_closed_form import geometry_of
    from references.reference_roots import reference_roots
    from benchmarks.sweep_roots import leg_residual
    from spherekin.mechanism import preset

    mech = preset(name)
    geometry = geometry_of(mech)
    rng = np.random.default_rng(3)
    for x in rng.uniform(-np.pi, np.pi, (3, 3)):
        ours, theirs = er.rrr_reference(mech, x), reference_roots(geometry, x)
        assert ours.count == theirs.count
        for r in ours.rotations:
            assert min(np.abs(r - q).max() for q in theirs.rotations) < 1e-12
            assert leg_residual(geometry, x, r) < 1e-14      # the description's leg constraints


def test_rrr_singular_input_separates_the_issue_counts():
    from spherekin.mechanism import general_3rrr

    twin = (0.18613171226800826, -0.15119930525771785, 0.6382686351031328)     # tests/test_near_singular.py
    six = (0.18613171214533802, -0.15119930520514488, 0.6382686352520895)
    mech = general_3rrr()
    x_star, direction = er.rrr_singular_input(mech, twin, six)
    assert max(abs(x_star[i] - twin[i]) for i in range(3)) < 2e-10
    edge = er.Edge(x_star, direction, "singular")
    with mpmath.workdps(er.DIGITS):
        side = [er.rrr_reference(mech, [x_star[i] + sg * mpmath.mpf("1e-18") * direction[i] for i in range(3)]).count
                for sg in (-1, 1)]
    assert side == [8, 6]
    inputs, actual = er.inputs_at(edge, 1e-8)
    assert actual == pytest.approx(1e-8, rel=1e-6)
    assert er.rrr_reference(mech, inputs).count == 6


def test_agile_eye_singular_line_and_passive_angles():
    """The agile eye's joint axes (exact unit vectors, every distal link angle exactly pi/2, as a kind "general"
    mechanism: judged on its joint axes) has 8 assemblies 1e-12 from its singular line, pairs merging on it.
    Its description's distal link angles are the double of pi/2 (6.1e-17 short of it): that 3-RRR, the one
    a proof is about (issue 40), has 6 there."""
    import dataclasses

    from spherekin.mechanism import gosselin

    described = gosselin()
    mech = dataclasses.replace(described, kind="general", geometry=None)
    edge = er.agile_eye_edge()
    inputs, _ = er.inputs_at(edge, 1e-12)
    ref = er.rrr_reference(mech, inputs)
    assert ref.count == 8 and ref.min_separation < 1e-11     # pairs merging on the line
    assert er.rrr_reference(described, inputs).count == 6
    for r in ref.rotations:                                  # some legs at u_i = v_i: actuator free
        (pa,) = er.passive_angles(mech, r, inputs)
        fwd = mech.forward({**dict(zip(mech.actuated, inputs)), **pa})
        assert max(fwd.loop_residuals) < 1e-12 and np.abs(fwd.pose - r).max() < 1e-12


# ------------------------------------------------------------------------------ the campaign's judge

def _entry(mech, inputs, rotation, status, box=None):
    from spherekin.results import Solution, Status

    (pa,) = er.passive_angles(mech, rotation, inputs)
    angles = np.array([pa[n] for n in mech.passive])
    lo, hi = (angles - 1e-9, angles + 1e-9) if box is None else box
    return Solution(angles=angles, lo=lo, hi=hi, n_boxes=1, platform_rotation=np.asarray(rotation),
                    status=Status(status), unknowns=mech.passive)


def _report(entries, exact):
    from spherekin.trust.solutions import is_proven

    return SimpleNamespace(solutions=tuple(entries), proven_count=sum(is_proven(s) for s in entries),
                           count_exact=exact, unknowns=entries[0].unknowns if entries else ())


def test_judge_on_made_up_reports():
    from benchmarks.edge_campaign import judge

    mech = er.four_bar(60, 70, 50, 80)
    x = (math.pi / 2 + 1e-6,)
    ref = er.two_leg_reference(mech, x)
    assert ref.count == 2
    r1, r2 = ref.rotations
    good = [_entry(mech, x, r, "certified") for r in (r1, r2)]
    assert judge(mech, ref, _report(good, True), x)["verdict"] == "exact_right"
    # the false proof the campaign is for: "0 solutions, exact" where 2 exist
    verdict = judge(mech, ref, _report([], True), x)
    assert verdict["verdict"] == "wrong" and verdict["kinds"]["wrong_count"] == [0, 2]
    # a duplicate proof of one assembly: the second is invented (and the other assembly lost)
    verdict = judge(mech, ref, _report([good[0], good[0]], True), x)
    assert verdict["verdict"] == "wrong" and verdict["kinds"]["invented"] == 1 and verdict["kinds"]["lost"] == 1
    # a lower bound whose cluster holds the missing assembly: flagged; a cluster elsewhere: lost
    (pa,) = er.passive_angles(mech, r2, x)
    theta = np.array([pa[n] for n in mech.passive])
    cluster = _entry(mech, x, r1, "cluster", box=(theta - 1e-3, theta + 1e-3))
    object.__setattr__(cluster, "platform_rotation", None)
    assert judge(mech, ref, _report([good[0], cluster], False), x)["verdict"] == "flagged"
    far = _entry(mech, x, r1, "cluster", box=(theta + 1.0, theta + 1.1))
    object.__setattr__(far, "platform_rotation", None)
    verdict = judge(mech, ref, _report([good[0], far], False), x)
    assert verdict["verdict"] == "wrong" and verdict["kinds"] == {"lost": 1}


def test_box_test_modulo_two_pi():
    """An entry's box is tested whole modulo 2 pi, even when it is wider than pi (a continuum's hull)."""
    from benchmarks.near_singular import in_box

    box = SimpleNamespace(lo=np.array([-3 * np.pi / 2, -0.1]), hi=np.array([np.pi / 2, 0.1]))
    for a in (-0.607, 2.534, -4.0, 1.5, 1.5 - 2 * np.pi, np.pi / 2 + 5e-10, -3 * np.pi / 2 - 5e-10):
        assert in_box(np.array([a, 0.0]), box)
    assert not in_box(np.array([0.0, 0.2]), box)
    narrow = SimpleNamespace(lo=np.array([3.0, 0.0]), hi=np.array([3.2, 0.0]))
    assert in_box(np.array([3.1 - 2 * np.pi, 0.0]), narrow) and not in_box(np.array([2.9, 0.0]), narrow)


# ---------------------------------------------------------------- the files' numbers (issue 40)

EXAMPLES = __import__("pathlib").Path(__file__).resolve().parents[1] / "examples"


def test_file_angle_is_the_readers_double():
    from spherekin.mechanism.checks import parse_angle

    for text in ("5*pi/12", "pi/2", "-3*pi/4", "2pi", "0.25", "1.5 * pi / 3", "-pi"):
        assert er.file_angle(text) == parse_angle("a", text)
    assert er.file_angle("5*pi/12") == 5 * math.pi / 12


def test_rrr_file_reference_is_the_files_3rrr():
    import spherekin

    path = EXAMPLES / "general_3rrr.toml"
    f = er.read_rrr_file(path)
    mech = spherekin.load_mechanism(path)
    assert f.u == mech.geometry.given_axes[0] and f.alpha2 == (5 * math.pi / 12,) * 3
    for x in ((0.3, -0.2, 0.5), (1.0, 2.0, -1.5)):
        ref = er.rrr_reference(f, x)
        assert ref.count == er.rrr_reference(mech, x).count and ref.count >= 2
        for rot in ref.mp_rotations:                    # w_i(beta_i) . R v_i^0 = cos alpha2_i, at 50 digits
            for i in range(3):
                u, w0, v0 = (mpv(vs[i]) for vs in (f.u, f.w0, f.v0))
                b = mpmath.mpf(x[i])
                uw = er._cross(u, w0)
                w = [w0[k] * mpmath.cos(b) + uw[k] * mpmath.sin(b) + u[k] * er._dot(u, w0) * (1 - mpmath.cos(b))
                     for k in range(3)]
                v = [sum(rot[k, j] * v0[j] for j in range(3)) for k in range(3)]
                assert abs(er._dot(w, v) - mpmath.cos(mpmath.mpf(f.alpha2[i]))) < mpmath.mpf("1e-40")


@pytest.mark.parametrize("name", ["watt_six_bar.toml", "stephenson_six_bar.toml"])
def test_six_bar_references(name):
    from singular_refs import EXAMPLES as EX
    from test_singular_loops import graph_axes, stephenson_count, watt_count

    g = er.read_graph_file(EXAMPLES / name)
    ax = graph_axes(EX / name)
    count = watt_count if name.startswith("watt") else stephenson_count
    for a in (-2.9, -2.0, -0.8, 0.0, 0.3, 1.0, 2.5):
        ref = er.graph_reference(g, (a,))
        assert ref.count == count(ax, a), a
    home = er.graph_reference(g, (0.0,))
    assert min(max(abs(v) for v in r.values()) for r in home.readings) < 1e-14     # the file's assembly
    axes = {n: mpv(v) for n, _, v, _, _ in g.joints}
    ref = er.graph_reference(g, (1.0,))
    assert len(ref.readings) == ref.count
    for readings in ref.readings:      # every joint [a, b]: R_a^T R_b = Rot(axis, reading - reference), both loops
        rot = {g.ground: mpmath.eye(3)}
        pending = list(g.joints)
        while pending:
            for j in list(pending):
                n, (a, b), _, _, r0 = j
                if a in rot and b not in rot:
                    rot[b] = rot[a] * er._rot_mat(axes[n], mpmath.mpf(readings[n]) - r0)
                    pending.remove(j)
                elif a in rot and b in rot:              # a loop's closing joint: its reading closes it
                    q = rot[a].T * rot[b] - er._rot_mat(axes[n], mpmath.mpf(readings[n]) - r0)
                    assert max(abs(q[i, k]) for i in range(3) for k in range(3)) < 1e-14
                    pending.remove(j)
                elif b in rot and a not in rot:
                    rot[a] = rot[b] * er._rot_mat(axes[n], mpmath.mpf(readings[n]) - r0).T
                    pending.remove(j)
