"""Tests for spherekin.trust.krawczyk (the Krawczyk test in outward-rounded interval arithmetic).

Independent references (see tests/loop_system_cases.py): roots from inverse kinematics, not from
any solver; regularity and singularity from the mechanism's velocity model (mech.singularity, the
passive Jacobian K_p of mech.jacobians), whose singular values the transversal Jacobian must
share at a root; a spherical five-bar whose two assembly modes are built by intersecting two
circles on the sphere (spherical trigonometry), so that the two roots in a box are known; the
eight Gosselin roots found by least squares from many starts.

Two implementations are tested (``IMPLS``): the fast float-interval one and the mpmath reference.
They must agree on every verdict; each must contain the exact values (never one checked against
the other for containment).
"""

import math
from fractions import Fraction

import numpy as np
import pytest
from mpmath import mpf
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation

from spherekin.core import intervals
from spherekin.trust.krawczyk import (
    CERTIFY_RADII,
    KrawczykResult,
    _krawczyk_operator,
    certify,
    certify_many,
    certify_reference,
    krawczyk,
    krawczyk_many,
    krawczyk_reference,
)
from spherekin.mechanism import (Joint, Leg, LoopSystem, SphericalMechanism, five_bar, four_bar, general_3rrr,
                                 gosselin)
from spherekin.trust.transversal import (enclose_transversal, interval_transversal,
                                   interval_transversal_reference, transversal_equations, transversal_labels)
from conftest import rot
from loop_system_cases import (REGULAR_MARGIN, GOSSELIN_ROOTS, ROOT_SEPARATION, IMPLS, MECHS, system_at, theta_of, poses, mp_entries, gosselin_roots, contains)

# ----------------------------------------------------------------------------- (1) regular roots

@pytest.mark.parametrize("impl", sorted(IMPLS))
@pytest.mark.parametrize("name", sorted(MECHS))
def test_regular_ik_solutions_are_certified(name, impl):
    certify = IMPLS[impl]["certify"]
    mech = MECHS[name]()
    checked = 0
    for pose in poses(name, 4, seed=11):
        for sol in mech.inverse_kinematics(pose):
            rep = mech.singularity(sol.joint_angles)
            system = system_at(mech, sol)
            theta = theta_of(system, sol)
            res = certify(system, sol.joint_angles)
            # the transversal Jacobian at a root has the singular values of the velocity model's K_p
            k_p = mech.jacobians(sol.joint_angles)["K_p"]
            np.testing.assert_allclose(res.singular_values, np.linalg.svd(k_p, compute_uv=False), rtol=1e-9, atol=1e-12)
            if rep.parallel_margin < REGULAR_MARGIN:
                continue
            assert res.certified, (sol.working_mode, res.reason)
            assert res.reason == "" and res.contraction < 1 and not res.no_solution
            assert (res.n_equations, res.n_unknowns) == (6, 6) and res.names == system.names
            assert res.radius == CERTIFY_RADII[0] and res.radii_tried == (CERTIFY_RADII[0],)
            np.testing.assert_array_equal(res.center, theta)
            for (lo, hi), (klo, khi), t in zip(res.box, res.krawczyk_box, theta):
                assert lo < klo <= t <= khi < hi  # K(X) strictly inside X and around the exact root
            checked += 1
    assert checked >= 24


def test_certified_box_of_the_doubled_form():
    """The doubled form of Eq. (2) (n = 12 factors per loop) certifies the same roots."""
    mech = gosselin()
    sol = mech.inverse_kinematics(rot([0.3, -0.5, 0.2]))[5]
    ja = sol.joint_angles
    system = mech.loop_system(sol.inputs, {n: (ja[n] - 1, ja[n] + 1) for n in mech.passive}, form="doubled")
    assert all(loop.n == 12 for loop in system.loops)
    assert certify(system, ja).certified


def test_less_accurate_point_needs_a_larger_box():
    """A point 3e-9 rad off the root: the root lies outside the 1e-10 box, so only the 1e-8 box certifies."""
    mech = gosselin()
    sol = mech.inverse_kinematics(rot([0.4, 0.1, -0.7]))[2]
    system = system_at(mech, sol)
    theta = theta_of(system, sol) + 3e-9 * np.array([1, -1, 1, 1, -1, 1])
    small = krawczyk(system, theta, CERTIFY_RADII[0])
    assert not small.certified and small.no_solution  # the root is 3e-9 away: K(X) misses X
    res = certify(system, theta)
    first = next(i for i, r in enumerate(CERTIFY_RADII) if r > 3e-9)   # the first box holding the root
    assert res.certified and res.radius == CERTIFY_RADII[first] and res.radii_tried == CERTIFY_RADII[:first + 1]
    for (klo, khi), t in zip(res.krawczyk_box, theta_of(system, sol)):
        assert klo <= t <= khi  # the proven unique root is the IK root


# ----------------------------------------------------------------------------- (2) zero or two roots

def test_box_without_a_solution_is_not_certified():
    mech = general_3rrr()
    sol = mech.inverse_kinematics(rot([0.1, 0.2, -0.1]))[0]
    system = system_at(mech, sol)
    direction = np.random.default_rng(3).normal(size=6)
    centre = theta_of(system, sol) + 1e-3 * direction / np.abs(direction).max()
    res = krawczyk(system, centre, 1e-6)
    assert not res.certified and res.no_solution and "holds no solution" in res.reason
    assert not certify(system, centre).certified


def _five_bar_roots(e_offset):
    """The two assembly modes of the spherical five-bar at inputs (A, E) = (2.5, e_s - e_offset).

    e_s puts B and D 120 deg apart (= BC + CD): there the two modes merge (a parallel
    singularity). Each mode's C is a point 60 deg from both B and D (two circles on the sphere);
    the pose maps (B_ref, C_ref) to (B, C) and inverse kinematics gives every joint angle.
    """
    mech = five_bar()
    axes = {j.name: np.array(j.axis) for j in mech.joints}
    a_in = 2.5

    def ang(p, q):
        return math.atan2(np.linalg.norm(np.cross(p, q)), p @ q)

    def frame(p, q):
        n = np.cross(p, q) / np.linalg.norm(np.cross(p, q))
        return np.column_stack([p, n, np.cross(p, n)])

    link = ang(axes["B"], axes["C"])
    assert link == pytest.approx(math.pi / 3) and ang(axes["D"], axes["C"]) == pytest.approx(math.pi / 3)
    b = rot(a_in * axes["A"]) @ axes["B"]
    gap = lambda e: ang(b, rot(e * axes["E"]) @ axes["D"]) - 2 * link  # noqa: E731
    e_s = brentq(gap, -2.0, -1.5, xtol=1e-15)
    e_in = e_s - e_offset
    d = rot(e_in * axes["E"]) @ axes["D"]
    g = np.array([[1.0, b @ d], [b @ d, 1.0]])
    xy = np.linalg.solve(g, [math.cos(link)] * 2)
    n = np.cross(b, d)
    h = math.sqrt(max(0.0, (1 - xy @ g @ xy) / (n @ n)))
    out = []
    for sign in (1, -1) if h > 0 else (1,):
        c = xy[0] * b + xy[1] * d + sign * h * n
        pose = frame(b, c) @ frame(axes["B"], axes["C"]).T
        out += [s for s in mech.inverse_kinematics(pose)
                if abs(math.remainder(s.joint_angles["A"] - a_in, 2 * math.pi)) < 1e-9
                and abs(math.remainder(s.joint_angles["E"] - e_in, 2 * math.pi)) < 1e-9]
    return mech, out


@pytest.mark.parametrize("impl", sorted(IMPLS))
def test_krawczyk_box_holds_every_root_of_x(impl):
    """Whatever the verdict, every zero in X lies in K(X): roots off-centre in boxes large enough
    for the (I - C J(X)) (X - y) term to matter (the linearization error is ~ r^2 |F''| |C|)."""
    krawczyk_ = IMPLS[impl]["krawczyk"]
    rng = np.random.default_rng(23)
    checked = 0
    for name in sorted(MECHS):
        mech = MECHS[name]()
        for sol in mech.inverse_kinematics(poses(name, 1, seed=51)[0])[:3]:
            if mech.singularity(sol.joint_angles).parallel_margin < REGULAR_MARGIN:
                continue
            system = system_at(mech, sol)
            root = theta_of(system, sol)
            for radius in (1e-3, 1e-2, 5e-2):
                centre = root + rng.uniform(-0.9, 0.9, 6) * radius
                res = krawczyk_(system, centre, radius)
                assert res.krawczyk_box is not None and not res.no_solution
                assert all(klo <= t <= khi for (klo, khi), t in zip(res.krawczyk_box, root)), (name, radius)
                checked += 1
    assert checked >= 12


def test_box_with_two_solutions_is_not_certified():
    mech, sols = _five_bar_roots(1e-6)
    assert len(sols) == 2
    system = system_at(mech, sols[0])
    t0, t1 = theta_of(system, sols[0]), theta_of(system, sols[1])
    sep = np.abs(t0 - t1).max()
    assert 1e-4 < sep < 1e-2  # two distinct roots, close together
    for sol, t in zip(sols, (t0, t1)):
        assert not mech.singularity(sol.joint_angles).parallel
        alone = certify(system, t)  # each root alone is certified in a box that excludes the other
        assert alone.certified and alone.radius < sep / 2
    # an off-centre box holding both roots (|centre - root| <= 0.7 sep < radius)
    centre = 0.5 * (t0 + t1) + 0.2 * (t0 - t1)
    both = krawczyk(system, centre, 0.75 * sep)
    assert all(lo < a < hi and lo < b < hi for (lo, hi), a, b in zip(both.box, t0, t1))
    assert not both.certified and not both.no_solution and "not inside X" in both.reason
    assert all(klo <= a <= khi and klo <= b <= khi for (klo, khi), a, b in zip(both.krawczyk_box, t0, t1))
    # the box centred between the modes sits on the fold: its midpoint Jacobian is singular
    mid = krawczyk(system, 0.5 * (t0 + t1), 0.75 * sep)
    assert not mid.certified and "singular midpoint Jacobian" in mid.reason


# ----------------------------------------------------------------------------- (3) enclosures









def _exact_interval_krawczyk(y, x_lo, x_hi, f_y, j_x, c):
    """K(X) = y - C F(y) + (I - C J(X)) (X - y) in exact rational interval arithmetic (Fraction
    endpoints), one box: y, x_lo, x_hi (M,), f_y (2, M), j_x (2, M, M), c (M, M)."""
    def imul(a, b):
        p = [a[0] * b[0], a[0] * b[1], a[1] * b[0], a[1] * b[1]]
        return min(p), max(p)

    m = len(y)
    fr = lambda v: Fraction(float(v))  # noqa: E731
    out = []
    for i in range(m):
        lo = hi = fr(y[i])
        for j in range(m):
            t = imul((fr(c[i, j]), fr(c[i, j])), (fr(f_y[0, j]), fr(f_y[1, j])))
            lo, hi = lo - t[1], hi - t[0]
            a_lo, a_hi = Fraction(int(i == j)), Fraction(int(i == j))
            for k in range(m):
                t = imul((fr(c[i, k]), fr(c[i, k])), (fr(j_x[0, k, j]), fr(j_x[1, k, j])))
                a_lo, a_hi = a_lo - t[1], a_hi - t[0]
            t = imul((a_lo, a_hi), (fr(x_lo[j]) - fr(y[j]), fr(x_hi[j]) - fr(y[j])))
            lo, hi = lo + t[0], hi + t[1]
        out.append((lo, hi))
    return out


def test_fast_krawczyk_operator_contains_the_exact_interval_evaluation():
    """With any C, the fast K(X) contains K evaluated in exact rational interval arithmetic from the same
    enclosures: the rounding of every step and the symmetric bound of (I - C J(X))(X - y) are sound."""
    rng = np.random.default_rng(29)
    mech = general_3rrr()
    sol = mech.inverse_kinematics(rot([0.2, -0.1, 0.3]))[0]
    system = system_at(mech, sol)
    y = theta_of(system, sol) + rng.uniform(-1e-3, 1e-3, 6)
    for radius in (1e-8, 1e-3, 5e-2):
        x_lo, x_hi = y - radius, y + radius
        f_y, _ = enclose_transversal(system, np.column_stack([y, y]))
        _, j_x = enclose_transversal(system, np.column_stack([x_lo, x_hi]))
        for c in (np.linalg.inv(transversal_equations(system, y)[1]), rng.normal(size=(6, 6))):
            k_lo, k_hi = _krawczyk_operator(y[None], x_lo[None, None], x_hi[None, None], f_y[:, None],
                                            j_x[:, None, None], c[None])
            for (lo, hi), a, b in zip(_exact_interval_krawczyk(y, x_lo, x_hi, f_y, j_x, c), k_lo[0, 0], k_hi[0, 0]):
                assert Fraction(a) <= lo and hi <= Fraction(b)




# ----------------------------------------------------------------------------- (4) singular points

def test_parallel_singularity_of_general_3rrr_fails_with_a_reason():
    """Bisect det K_p (velocity model) along poses Rx(s) in working mode (1, 1, 1) to a parallel singularity."""
    mech = general_3rrr()

    def at(s):
        (sol,) = [q for q in mech.inverse_kinematics(rot([s, 0.0, 0.0])) if q.working_mode == (1, 1, 1)]
        return sol, np.linalg.det(mech.jacobians(sol.joint_angles)["K_p"])

    lo, hi = 1.3, 1.5   # det K_p changes sign between these (it is ~ +0.005 at 1.4 and ~ -0.045 at 1.5)
    d_lo = at(lo)[1]
    assert d_lo * at(hi)[1] < 0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if at(mid)[1] * d_lo > 0:
            lo = mid
        else:
            hi = mid
    sol, _ = at(lo)
    rep = mech.singularity(sol.joint_angles)
    assert rep.kind == "parallel"
    res = certify(mech.loop_system(sol.inputs, {n: (sol.joint_angles[n] - 1, sol.joint_angles[n] + 1)
                                                for n in mech.passive}), sol.joint_angles)
    assert not res.certified and "singular midpoint Jacobian" in res.reason
    assert res.singular_values[-1] < 1e-12 and res.radii_tried == (CERTIFY_RADII[0],)


def test_five_bar_at_its_fold_fails_with_a_reason():
    mech, sols = _five_bar_roots(0.0)
    assert sols
    for sol in sols:
        assert mech.singularity(sol.joint_angles).parallel
        system = system_at(mech, sol)
        res = certify(system, sol.joint_angles)
        assert not res.certified and res.reason.startswith("not certified")
        assert res.radii_tried in (CERTIFY_RADII, (CERTIFY_RADII[0],))


# ----------------------------------------------------------------------------- non-square, API, input

def _four_bar_two_inputs():
    base = four_bar()
    legs = tuple(Leg(leg.name, tuple(Joint(j.name, j.axis, actuated=j.name in ("A", "D")) for j in leg.joints))
                 for leg in base.legs)
    return SphericalMechanism(legs, name="4R, two inputs")


def test_over_determined_system_certifies_a_square_subsystem():
    """A four-bar with both ground joints actuated: 3 equations, 2 unknowns (B, C). Its reference
    configuration (all joints at 0) closes by construction, so a square subsystem of two rows has a
    root there and the third row vanishes with it; the evidence names the rows and bounds the other."""
    mech = _four_bar_two_inputs()
    system = mech.loop_system((0.0, 0.0), {"B": (-1.0, 1.0), "C": (-1.0, 1.0)})
    res = certify(system, (0.0, 0.0))
    assert res.certified, res.reason
    assert (res.n_equations, res.n_unknowns) == (3, 2) and len(res.singular_values) == 2
    assert len(res.subsystem_rows) == 2 and set(res.subsystem_rows) <= {0, 1, 2}
    assert 0.0 <= res.other_bound <= 10 * res.radius
    assert res.summary()["subsystem_rows"] == list(res.subsystem_rows)
    _same_verdict(res, certify_reference(system, (0.0, 0.0)))


def test_over_determined_system_with_inconsistent_inputs_is_not_certified():
    """Moving one actuator of the rigid two-input four-bar off a consistent value by 0.05 rad leaves no
    assembly near the old one: the subsystem still has a root, the left-out equation does not vanish."""
    mech = _four_bar_two_inputs()
    system = mech.loop_system((0.0, 0.05), {"B": (-1.0, 1.0), "C": (-1.0, 1.0)})
    f, _ = transversal_equations(system, (0.0, 0.0))
    assert np.abs(f).max() > 1e-3           # the old assembly no longer closes
    res = certify(system, (0.0, 0.0), radii=(0.2,))
    assert not res.certified


# ----------------------------------------------------------------------------- fast vs reference

def _same_verdict(a: KrawczykResult, b: KrawczykResult) -> None:
    assert (a.certified, a.no_solution, a.radius, a.radii_tried) == (b.certified, b.no_solution, b.radius, b.radii_tried)
    assert a.reason.split(":")[0] == b.reason.split(":")[0] and (a.krawczyk_box is None) == (b.krawczyk_box is None)
    assert (a.names, a.center, a.box, a.n_equations, a.n_unknowns) == (b.names, b.center, b.box, b.n_equations, b.n_unknowns)
    np.testing.assert_allclose(a.singular_values, b.singular_values, rtol=1e-9, atol=1e-14)


def test_gosselin_roots_certified_alike_by_fast_and_reference(gosselin_roots):
    """The 8 roots of the paper's example (found without the solver): both certify each, in the same box."""
    system, roots = gosselin_roots
    assert len(roots) == GOSSELIN_ROOTS
    fast = certify_many(system, roots)
    for theta, res in zip(roots, fast):
        ref = certify_reference(system, theta)
        _same_verdict(res, ref)
        assert res.certified and res.radius == CERTIFY_RADII[0]
        for (lo, hi), (klo, khi), (rlo, rhi) in zip(res.box, res.krawczyk_box, ref.krawczyk_box):
            assert lo < klo <= khi < hi and klo <= rhi and rlo <= khi   # both inside X, and they meet
        assert res.contraction == pytest.approx(ref.contraction, rel=0.1)
        assert res.residual == pytest.approx(ref.residual, rel=0.2)


def test_random_general_3rrr_points_get_the_same_verdicts():
    """Exact IK roots, points 3e-9 off (a larger radius certifies), 1e-3 off (no solution) and a far point."""
    mech = general_3rrr()
    rng = np.random.default_rng(17)
    counts = {"certified": 0, "no_solution": 0, "other": 0}
    for pose in poses("general_3rrr", 2, seed=41):
        for sol in mech.inverse_kinematics(pose):
            system = system_at(mech, sol)
            root = theta_of(system, sol)
            if mech.singularity(sol.joint_angles).parallel_margin < REGULAR_MARGIN:
                continue
            direction = rng.choice([-1.0, 1.0], size=6)
            for theta in (root, root + 3e-9 * direction, root + 1e-3 * direction, root + rng.uniform(-0.5, 0.5, 6)):
                res, ref = certify(system, theta), certify_reference(system, theta)
                _same_verdict(res, ref)
                if res.certified:
                    if np.abs(theta - root).max() < 1e-6:
                        assert all(klo <= t <= khi for (klo, khi), t in zip(res.krawczyk_box, root))
                    counts["certified"] += 1
                else:
                    counts["no_solution" if res.no_solution else "other"] += 1
    assert counts["certified"] >= 20 and counts["no_solution"] >= 10


def test_certify_many_equals_certify_one_by_one(gosselin_roots):
    system, roots = gosselin_roots
    points = list(roots) + [roots[0] + 1e-3, roots[1] + 3e-9, dict(zip(system.names, roots[2]))]
    many = certify_many(system, points)
    assert len(many) == len(points)
    for theta, res in zip(points, many):
        assert res == certify(system, theta)
    assert certify_many(system, []) == []
    assert certify_many(system, np.array(roots[:2]), radii=(1e-8,))[0].radii_tried == (1e-8,)


def test_unequal_loop_lengths_are_padded():
    """Loop 1 in the 6-factor form and loop 2 in the 12-factor doubled form: still a closure system of the
    same mechanism, so the IK root certifies, and fast and reference enclosures both hold the exact F."""
    mech = gosselin()
    sol = mech.inverse_kinematics(rot([0.2, -0.4, 0.3]))[1]
    ja = sol.joint_angles
    ranges = {n: (ja[n] - 1.0, ja[n] + 1.0) for n in mech.passive}
    auto, doubled = mech.loop_system(sol.inputs, ranges), mech.loop_system(sol.inputs, ranges, form="doubled")
    assert auto.names == doubled.names and len(auto.loops[0].factors) < len(doubled.loops[1].factors)
    mixed = LoopSystem(loops=(auto.loops[0], doubled.loops[1]), unknowns=auto.unknowns,
                       loop_indices=(auto.loop_indices[0], doubled.loop_indices[1]), shared=auto.shared,
                       inputs=auto.inputs, input_names=auto.input_names, loop_legs=auto.loop_legs, form="mixed")
    theta = theta_of(mixed, sol)
    res = certify(mixed, theta)
    _same_verdict(res, certify_reference(mixed, theta))
    assert res.certified
    p = theta + 0.1
    f_iv, _ = interval_transversal(mixed, np.column_stack([p, p]))
    assert all(contains(iv_, v) for iv_, v in zip(f_iv, mp_entries(mixed, p)))


def test_fast_functions_fall_back_to_the_reference_outside_the_ieee_default(monkeypatch):
    mech = gosselin()
    sol = mech.inverse_kinematics(rot([0.3, 0.3, 0.3]))[0]
    system = system_at(mech, sol)
    theta = theta_of(system, sol)
    monkeypatch.setattr(intervals, "rounding_environment_ok", lambda: False)
    assert certify(system, theta) == certify_reference(system, theta)
    assert certify_many(system, [theta]) == [certify_reference(system, theta)]
    assert krawczyk(system, theta, 1e-8) == krawczyk_reference(system, theta, 1e-8)
    box = np.column_stack([theta - 1e-3, theta + 1e-3])
    f_iv, _ = interval_transversal(system, box)
    f_ref, _ = interval_transversal_reference(system, box)
    assert all(mpf(a.a) == mpf(b.a) and mpf(a.b) == mpf(b.b) for a, b in zip(f_iv, f_ref))
    with pytest.raises(RuntimeError, match="floating-point environment"):
        enclose_transversal(system, box)


# ----------------------------------------------------------------------------- API, input
# (the speed of certify() against certify_reference() is measured by benchmarks/bench_certify.py,
# not asserted here: a test must not fail on a loaded machine)

def test_labels_and_summary():
    mech = gosselin()
    sols = mech.inverse_kinematics(rot([0.3, -0.2, 0.5]))
    system = system_at(mech, sols[0])
    assert transversal_labels(system) == ("loop1:f21", "loop1:f31", "loop1:f32", "loop2:f21", "loop2:f31", "loop2:f32")
    for sol in sols:
        system = system_at(mech, sol)
        res = certify(system, theta_of(system, sol))
        assert isinstance(res, KrawczykResult) and res.certified
    summary = res.summary()
    assert summary["certified"] is True and summary["radius"] == CERTIFY_RADII[0]
    assert 0 < summary["contraction"] < 1 and summary["residual_bound"] < 1e-12
    assert set(summary) >= {"reason", "no_solution", "min_singular_value", "radii_tried"}


@pytest.mark.parametrize("call, message", [
    (lambda s: certify("system", [0.0] * 6), r"system: expected a LoopSystem"),
    (lambda s: certify(s, [0.0] * 5), r"theta: expected shape \(6,\)"),
    (lambda s: certify(s, {"gamma1": 0.0}), r"theta: missing angle\(s\) for \['delta1'"),
    (lambda s: certify(s, [0.0] * 5 + [float("nan")]), r"theta: expected finite"),
    (lambda s: certify(s, "abcdef"), r"theta: expected 6 passive angles"),
    (lambda s: krawczyk(s, [0.0] * 6, -1e-8), r"radius: expected a radius in \(0, pi\)"),
    (lambda s: certify(s, [0.0] * 6, radii=()), r"radii: expected a non-empty sequence"),
    (lambda s: certify(s, [0.0] * 6, radii=(1e-8, 1e-10)), r"radii: expected strictly increasing"),
    (lambda s: certify(s, [0.0] * 6, radii=(1e-8, "x")), r"radii\[1\]: expected a positive radius"),
    (lambda s: certify(s, [0.0] * 6, angle_tolerance=-1.0), r"angle_tolerance: expected a value in \[0, 1e-3\)"),
    (lambda s: interval_transversal(s, np.zeros((6, 3))), r"box: expected shape \(6, 2\)"),
    (lambda s: interval_transversal(s, np.tile([0.1, 0.0], (6, 1))), r"box: expected lo <= hi"),
    (lambda s: certify_reference(s, [0.0] * 5), r"theta: expected shape \(6,\)"),
    (lambda s: krawczyk_reference(s, [0.0] * 6, 0.0), r"radius: expected a radius in \(0, pi\)"),
    (lambda s: interval_transversal_reference(s, np.zeros((5, 2))), r"box: expected shape \(6, 2\)"),
    (lambda s: certify_many(s, [0.0] * 6), r"thetas\[0\]: expected shape \(6,\)"),
    (lambda s: certify_many(s, [[0.0] * 6, [0.0] * 5]), r"thetas\[1\]: expected shape \(6,\)"),
    (lambda s: certify_many(s, {"gamma1": 0.0}), r"thetas: expected a sequence of points"),
    (lambda s: certify_many(s, [[0.0] * 6], radii=[]), r"radii: expected a non-empty sequence"),
    (lambda s: enclose_transversal(s, np.zeros((6,))), r"boxes: expected shape \(6, 2\) or \(B, 6, 2\)"),
    (lambda s: enclose_transversal(s, np.zeros((2, 5, 2))), r"boxes\[0\]: expected shape \(6, 2\)"),
    (lambda s: enclose_transversal(s, [[0.1, 0.0]] * 6), r"boxes: expected lo <= hi"),
    (lambda s: enclose_transversal(s, "box"), r"boxes: expected shape"),
])
def test_bad_input_raises_value_error(call, message):
    system = gosselin().loop_system((0.0, 0.0, 0.0), {n: (-1.0, 1.0) for n in gosselin().passive})
    with pytest.raises(ValueError, match=message):
        call(system)


# ----------------------------------------------------------------------------- general boxes

def test_krawczyk_many_decides_boxes_by_where_the_roots_are():
    """Boxes placed around roots known independently (IK of two chosen poses of the Gosselin
    platform at the same inputs would need equal inputs, so one pose: its root, and points 1e-3
    away from it in each direction): a small box around the root is certified, boxes 1e-3 away with
    radius 1e-4 hold no root (the roots of a regular mechanism are ~0.1 rad apart) and are
    excluded, and a box too large to contract is neither."""
    mech = gosselin()
    R = Rotation.from_rotvec([0.3, -0.2, 0.25]).as_matrix()
    ik = mech.inverse_kinematics(R)[0]
    system = mech.loop_system(ik.inputs, {n: (ik.joint_angles[n] - 1, ik.joint_angles[n] + 1)
                                          for n in mech.passive})
    root = np.array([ik.joint_angles[n] for n in system.names])
    m = len(root)
    shifts = np.vstack((np.zeros(m), 1e-3 * np.eye(m), -1e-3 * np.eye(m)))
    centres = root + shifts
    r = np.array([1e-6] + [1e-4] * (2 * m))[:, None]
    test = krawczyk_many(system, centres - r, centres + r)
    assert test.certified[0] and not test.no_solution[0]
    assert np.all(test.krawczyk_lo[0] <= root) and np.all(root <= test.krawczyk_hi[0])
    assert not test.certified[1:].any() and test.no_solution[1:].all()
    big = krawczyk_many(system, (root - 0.8)[None], (root + 0.8)[None])
    assert not big.certified[0]


def test_krawczyk_many_never_certifies_a_box_with_two_roots():
    """The general_3rrr twins of issue 13 (8 real assemblies, two 1.48e-5 rad apart: found by
    spherekin and checked by IK in tests/test_trust_edge.py): a box holding both is not isolated."""
    from spherekin import solve

    inputs = (0.18613171226800826, -0.15119930525771785, 0.6382686351031328)
    mech = general_3rrr()
    sols = solve(mech, inputs).solutions
    a, b = min(((p, q) for i, p in enumerate(sols) for q in sols[i + 1:]),
               key=lambda pq: np.abs(pq[0].angles - pq[1].angles).max())
    system = mech.loop_system(inputs, {n: (v - 1, v + 1) for n, v in zip(system_names(mech, inputs), a.angles)})
    lo = np.minimum(a.angles, b.angles) - 2e-6
    hi = np.maximum(a.angles, b.angles) + 2e-6
    test = krawczyk_many(system, lo[None], hi[None])
    assert not test.certified[0] and not test.no_solution[0]


def system_names(mech, inputs):
    return mech.loop_unknowns


def test_a_box_that_misses_the_root_in_one_coordinate_only_is_not_certified(gosselin_roots):
    """X = (root + 1e-3 e_k) +- 1e-4 holds no root: the root is 1e-3 away along e_k and the other
    Gosselin roots are farther than ROOT_SEPARATION. K(X) then lies inside X in every coordinate but
    k (it encloses the root), so a test of the inclusion in one coordinate would certify it."""
    system, roots = gosselin_roots
    root = roots[0]
    for k in range(len(root)):
        centre = root.copy()
        centre[k] += 1e-3
        res = krawczyk(system, centre, 1e-4)
        assert not res.certified and res.no_solution
        k_lo, k_hi = (np.array(v) for v in zip(*res.krawczyk_box))
        x_lo, x_hi = (np.array(v) for v in zip(*res.box))
        inside = (k_lo > x_lo) & (k_hi < x_hi)
        assert not inside[k] and inside.sum() == len(root) - 1     # the case the test is about
