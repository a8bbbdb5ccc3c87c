"""Issue 26: a count marked exact is never wrong, next to the branch and change points of four-bars.

The reproductions of the issue, each judged against a 50-digit closed form written here, from the
mechanism's float joint axes alone (not spherekin's loop equations): the coupler point C lies at
the link angles BC and DC from B(theta) = Rot(A, theta) B0 and from D, C = a B + b D + g (B x D),
and the sign of g^2 decides the number of real assemblies (2, 1 or 0). A report passes when its count
is exact and equal to the reference, or not exact (flagged) with no more proven entries than the
reference; every proven entry must be a reference assembly.
"""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest

from spherekin import solve
from spherekin.mechanism import Joint, Leg, SphericalMechanism
from spherekin.mechanism.chains import axis_rotation, sphere_point
from spherekin.trust.solutions import is_proven

#: Working precision of the reference (decimal digits).
DIGITS = 50
#: A proven entry is a reference assembly when its coupler rotation agrees to this (largest entry):
#: its polished pose is accurate to ~1e-16 / sigma_min, ~1e-9 at 1e-7 from a change point.
POSE_MATCH = 1e-6


def _polar(polar_deg: float, azimuth_deg: float) -> np.ndarray:
    p, a = math.radians(polar_deg), math.radians(azimuth_deg)
    return np.array([math.sin(p) * math.cos(a), math.sin(p) * math.sin(a), math.cos(p)])


def four_bar(ground: float, crank: float, coupler: float, rocker: float) -> SphericalMechanism:
    """A spherical four-bar (link angles in degrees) laid out as spherekin.mechanism.four_bar():
    A = z (crank pivot, actuated), D at the ground angle from A in the xz-plane, B0 = Rot(A, 90 deg) of
    the point at the crank angle from A towards D, C0 on the positive side of B0 x D."""
    a = np.array([0.0, 0.0, 1.0])
    d = _polar(ground, 0.0)
    b = axis_rotation(a, math.pi / 2) @ _polar(crank, 0.0)
    c = sphere_point(b, d, math.radians(coupler), math.radians(rocker), 1.0)
    return SphericalMechanism(legs=(Leg("crank", (Joint("A", a, actuated=True), Joint("B", b))),
                                    Leg("rocker", (Joint("D", d), Joint("C", c)))),
                              name=f"four-bar {ground}/{crank}/{coupler}/{rocker}")


def _mp_axes(mech):
    """A, B0, D, C0 as 50-digit unit vectors (the floats of the mechanism, normalized in mpmath)."""
    joints = {j.name: j.axis for leg in mech.legs for j in leg.joints}
    out = []
    for name in "ABDC":
        v = mpmath.matrix([mpmath.mpf(float(x)) for x in joints[name]])
        out.append(v / mpmath.norm(v))
    return out


def _cross(p, q):
    return mpmath.matrix([p[1] * q[2] - p[2] * q[1], p[2] * q[0] - p[0] * q[2], p[0] * q[1] - p[1] * q[0]])


def _dot(p, q):
    return sum(p[i] * q[i] for i in range(3))


def reference(mech, theta: float):
    """(g^2 numerator sign -> count, coupler rotations (3x3 floats)) at the float input ``theta``."""
    with mpmath.workdps(DIGITS):
        a, b0, d, c0 = _mp_axes(mech)
        t = mpmath.mpf(theta)
        b = b0 * mpmath.cos(t) + _cross(a, b0) * mpmath.sin(t) + a * _dot(a, b0) * (1 - mpmath.cos(t))
        cos3, cos4, cpq = _dot(b0, c0), _dot(d, c0), _dot(b, d)
        den = 1 - cpq ** 2
        ca = (cos3 - cpq * cos4) / den
        cb = (cos4 - cpq * cos3) / den
        n = _cross(b, d)
        g2 = (1 - ca ** 2 - cb ** 2 - 2 * ca * cb * cpq) / _dot(n, n)
        if g2 < 0:
            return 0, []
        frame0 = mpmath.matrix(3, 3)
        for k, v in enumerate((b0, c0, _cross(b0, c0))):
            frame0[:, k] = v
        poses = []
        for sign in ((1,) if g2 == 0 else (1, -1)):
            c = ca * b + cb * d + sign * mpmath.sqrt(g2) * n
            frame = mpmath.matrix(3, 3)
            for k, v in enumerate((b, c, _cross(b, c))):
                frame[:, k] = v
            r = frame * mpmath.inverse(frame0)
            poses.append(np.array([[float(r[i, j]) for j in range(3)] for i in range(3)]))
        return len(poses), poses


def branch_inputs(mech) -> list[float]:
    """The inputs (radians, 50 digits, as floats nearest) where angle(B, D) = coupler +- rocker."""
    out = []
    with mpmath.workdps(DIGITS):
        a, b0, d, c0 = _mp_axes(mech)
        k0 = _dot(a, b0) * _dot(a, d)
        k1, k2 = _dot(b0, d) - k0, _dot(_cross(a, b0), d)
        a3, a4 = mpmath.acos(_dot(b0, c0)), mpmath.acos(_dot(d, c0))
        for target in (a3 + a4, abs(a3 - a4)):
            ratio = (mpmath.cos(target) - k0) / mpmath.sqrt(k1 ** 2 + k2 ** 2)
            if abs(ratio) <= 1:
                phase = mpmath.atan2(k2, k1)
                out += [float(phase + mpmath.acos(ratio)), float(phase - mpmath.acos(ratio))]
    return out


def check_report(mech, theta: float, report) -> str:
    """'exact' or 'flagged' when the report is right by the issue's rules; raises otherwise."""
    count, poses = reference(mech, theta)
    proven = [s for s in report.solutions if is_proven(s)]
    for s in proven:
        assert any(np.abs(s.platform_rotation - p).max() < POSE_MATCH for p in poses), \
            f"theta={theta!r}: a proven entry is no assembly (reference: {count})"
    if report.count_exact:
        assert report.proven_count == count, \
            f"theta={theta!r}: count {report.proven_count} marked exact, the 50-digit reference has {count}"
        return "exact"
    assert report.proven_count <= count, f"theta={theta!r}: {report.proven_count} proven, reference {count}"
    return "flagged"


CHANGE_POINT = four_bar(60.0, 70.0, 50.0, 80.0)        # 50 + 80 = 60 + 70: a change-point linkage
BRANCH_POINTS = four_bar(100.0, 120.0, 45.0, 80.0)


def test_reference_closed_form_counts_the_presets_crank_rocker():
    """The closed form on a design with a known answer: a Grashof crank-rocker (shortest link the
    crank) assembles in exactly 2 ways at every input, and its two poses map B0, C0 to B, C."""
    mech = four_bar(80.0, 30.0, 70.0, 60.0)
    for theta in np.linspace(-3.0, 3.0, 7):
        count, poses = reference(mech, float(theta))
        assert count == 2
        b = axis_rotation(np.array([0.0, 0.0, 1.0]), float(theta)) @ mech.legs[0].joints[1].axis
        for r in poses:
            np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-14)
            np.testing.assert_allclose(r @ mech.legs[0].joints[1].axis, b, atol=1e-14)


def test_reference_branch_inputs_change_the_count():
    """At 1e-30 on either side of each branch input the reference counts differ (0 and 2)."""
    for mech in (BRANCH_POINTS,):
        inputs = branch_inputs(mech)
        assert inputs
        with mpmath.workdps(DIGITS):
            for x in inputs:
                counts = {reference(mech, float(x) + s * 1e-9)[0] for s in (-1, 1)}
                assert counts == {0, 2}


@pytest.mark.parametrize("distance", [1e-7, 3e-7, 1e-6, -1e-7, -3e-7, -1e-6])
def test_change_point_four_bar_is_never_proven_wrong(distance):
    """The issue's first reproduction: 60/70/50/80 deg at 1e-7 .. 1e-6 rad from the change point
    (pi/2), where two assemblies ~1e-6 apart exist; spherekin used to print '0 solutions, exact'."""
    theta = math.pi / 2 + distance
    assert reference(CHANGE_POINT, theta)[0] == 2
    check_report(CHANGE_POINT, theta, solve(CHANGE_POINT, [theta]))


def test_change_point_four_bar_at_a_fine_tolerance():
    """At tol 1e-8 the box loop isolated both roots and called them spurious ('isolated 2, spurious 2')."""
    theta = math.pi / 2 + 1e-6
    report = solve(CHANGE_POINT, [theta], tol=1e-8)
    check_report(CHANGE_POINT, theta, report)
    assert report.stats.spurious == 0


@pytest.mark.parametrize("ulps", [-2, -1, 0, 1, 2])
def test_four_bar_within_1e_16_of_a_branch_point(ulps):
    """The issue's second reproduction: 100/120/45/80 deg within a few ulps (~1e-16) of a branch
    input, where two roots ~5e-8 apart exist (or none): right, or flagged."""
    x = branch_inputs(BRANCH_POINTS)[0]
    theta = x
    for _ in range(abs(ulps)):
        theta = math.nextafter(theta, math.copysign(math.inf, ulps))
    check_report(BRANCH_POINTS, theta, solve(BRANCH_POINTS, [theta]))


def test_far_from_the_change_point_the_count_is_exact():
    """Where the two roots are well apart, the count is proven and right (flagging is not the answer)."""
    for theta in (math.pi / 2 + 1e-2, math.pi / 2 - 1e-3, 0.3):
        assert check_report(CHANGE_POINT, theta, solve(CHANGE_POINT, [theta])) == "exact"


@pytest.mark.parametrize("distance", [1e-8, 0.0])
def test_extended_precision_resolves_the_pair_next_to_the_change_point(distance):
    """Issue 26, item 3: where float64 cannot separate the two assemblies (~5e-8 apart in this float
    design), Newton and the Krawczyk test in extended precision (spherekin/trust/extended.py) separate
    and certify them, and account for the rest of the cluster: the count is exact and right."""
    theta = math.pi / 2 + distance
    report = solve(CHANGE_POINT, [theta])
    assert check_report(CHANGE_POINT, theta, report) == "exact"
    assert report.proven_count == 2


@pytest.mark.parametrize("distance", [1e-7, 1e-6])
def test_a_search_around_a_root_keeps_it(distance):
    """The box loop alone, on a box 1e-9 around a reference assembly of the change-point four-bar
    (what a refined search of a cluster does): its tolerance must cover the rounding of entries that
    are ~1e-8 on the whole chart, or it discards every box (it did: issue 26's 'finer search returns
    nothing'). The root's readings come from inverse kinematics of the 50-digit reference pose."""
    from spherekin.search.boxloop import solve_system

    theta = math.pi / 2 + distance
    count, poses = reference(CHANGE_POINT, theta)
    names = CHANGE_POINT.loop_unknowns
    for pose in poses:
        ik = [s for s in CHANGE_POINT.inverse_kinematics(pose)
              if abs(math.remainder(s.inputs[0] - theta, 2 * math.pi)) < 1e-9]
        assert ik
        root = np.array([ik[0].joint_angles[n] for n in names])

        def build(chart):
            system = CHANGE_POINT.loop_system([theta], chart)
            return system.loops, system.unknowns

        report = solve_system(build, {n: (float(r) - 1e-9, float(r) + 1e-9) for n, r in zip(names, root)}, tol=1e-11)
        assert any(np.all(c.lo - 1e-12 <= root) and np.all(root <= c.hi + 1e-12) for c in report.clusters), \
            f"the search discarded the box holding the root at input pi/2 + {distance:g}"


@pytest.mark.parametrize("inputs", [(0.0, 0.0, 0.0), (0.3, 0.3, 0.3)])
def test_coaxial_agile_eye_keeps_its_four_half_turn_assemblies(inputs):
    """The issue's third reproduction, as far as its words fix it: a coaxial agile eye (every base
    axis on z, right link angles, elbow and platform axes on coordinate axes) answered '0 solutions,
    exact' at (0, 0, 0) where I, Rx(pi), Ry(pi), Rz(pi) are assemblies. Checked here independently of
    spherekin: those four poses (turned by Rz(beta) for equal inputs beta, the design being symmetric
    about z) close every leg, w_i(beta) . R v_i = cos(pi/2) = 0; each must be reported, as a proven
    entry or inside an unproven entry's box, and every proven entry must close every leg."""
    from spherekin.mechanism import three_rrr

    x, y, z = np.eye(3)
    elbows, platform = [x, y, x], [y, z, z]
    mech = three_rrr([z, z, z], elbows, platform, [math.pi / 2] * 3, name="coaxial agile eye")
    beta = inputs[0]
    turn = axis_rotation(z, beta)
    expected = [turn @ np.diag(d) for d in ((1.0, 1.0, 1.0), (1.0, -1.0, -1.0), (-1.0, 1.0, -1.0), (-1.0, -1.0, 1.0))]

    def closes(rot) -> bool:
        return all(abs(float((turn @ w) @ (rot @ v))) < 1e-12 for w, v in zip(elbows, platform))

    assert all(closes(r) for r in expected)
    report = solve(mech, inputs)
    for r in expected:
        assert any(s.platform_rotation is not None and np.abs(s.platform_rotation - r).max() < 1e-9
                   for s in report.solutions), f"the assembly {np.round(r, 3).tolist()} is missing"
    for s in report.solutions:
        if is_proven(s):
            assert closes(s.platform_rotation)
    assert report.proven_count >= 4 or not report.count_exact
