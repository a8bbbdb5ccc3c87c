"""spherekin.trust.solutions: from the solver's clusters to entries whose status says what was proven.

finalize is fed clusters made by hand or by solve_system, and judged by reasons outside it: a
certification function that refuses everything (nothing can then be proven), joint ranges placed
around a root known from inverse kinematics, and the count rule applied to hand-made entries.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from conftest import GOSSELIN_INPUTS, rot
from spherekin import solve_system
from spherekin.trust.krawczyk import certify as real_certify
from references import peers_closed_form as pcf
from spherekin.mechanism import Joint, Leg, SphericalMechanism, general_3rrr, gosselin
from spherekin.results import Cluster, Solution, Status
from spherekin.trust.solutions import STATUSES, count_summary, finalize, is_proven


def clusters_of(mech, inputs, **kw):
    """(names, clusters) of the box loop of solve_system, before finalize."""
    names = mech.loop_unknowns

    def build(chart):
        system = mech.loop_system(inputs, chart)
        return system.loops, system.unknowns

    report = solve_system(build, {n: mech.ranges[n] for n in names}, **kw)
    return report.unknowns, report.clusters


def refusing_certify(system, thetas, radii=None, angle_tolerance=None):
    """A batch certification function that never certifies: the real tests' evidence, verdict False."""
    kw = {} if radii is None else {"radii": radii}
    return [dataclasses.replace(real_certify(system, theta, **kw), certified=False,
                                reason="not certified: refused by the test") for theta in thetas]


def test_nothing_is_certified_when_every_certificate_is_refused():
    """The Gosselin clusters are single Newton points of isolated boxes; with every point certificate
    refused, no entry may be certified and the count cannot be exact."""
    mech = gosselin()
    names, clusters = clusters_of(mech, GOSSELIN_INPUTS)
    assert len(clusters) == 8
    out = finalize(mech, GOSSELIN_INPUTS, names, clusters, 1e-6, certify=refusing_certify)
    assert out and not any(s.status == "certified" for s in out)
    assert not any(is_proven(s) for s in out)
    assert count_summary(out) == (0, False)
    for s in out:
        assert s.status in ("unverified", "singular") and not s.evidence["krawczyk_certified"]


def test_the_real_certificates_prove_all_eight():
    mech = gosselin()
    names, clusters = clusters_of(mech, GOSSELIN_INPUTS)
    out = finalize(mech, GOSSELIN_INPUTS, names, clusters, 1e-6)
    assert count_summary(out) == (8, True)


def _with_range(name, rng):
    base = gosselin()
    legs = tuple(Leg(leg.name, tuple(Joint(j.name, j.axis, j.actuated, rng if j.name == name else j.range,
                                           j.reference_angle) for j in leg.joints)) for leg in base.legs)
    return SphericalMechanism(legs, name="ranged", reference_leg=base.reference_leg)


@pytest.mark.parametrize("side", [-1, 1])
def test_a_root_outside_a_passive_range_is_dropped(side):
    """Clusters found over the full circles are handed to finalize with a mechanism whose gamma1 range
    stops 1e-6 short of a root chosen first (pose -> inverse kinematics -> inputs): that root must
    not be reported, and every reported entry must lie in the range."""
    R = rot([0.2, -0.1, 0.15])
    base = gosselin()
    ik = base.inverse_kinematics(R)[0]
    inputs = ik.inputs
    a = ik.joint_angles["gamma1"]
    rng = (a + 1e-6, a + 1.0) if side > 0 else (a - 1.0, a - 1e-6)
    names, clusters = clusters_of(base, inputs)
    assert any(np.abs(np.mod(c.angles[0] - a + np.pi, 2 * np.pi) - np.pi) < 1e-5 for c in clusters)
    out = finalize(_with_range("gamma1", rng), inputs, names, clusters, 1e-6)
    assert not any(np.abs(s.platform_rotation - R).max() < 1e-9 for s in out if s.platform_rotation is not None)
    for s in out:
        g = s.angles[list(names).index("gamma1")]
        assert rng[0] - 1e-9 <= g <= rng[1] + 1e-9


def test_count_summary_rule():
    """Exact only when every entry is proven: certified, or singular with a certificate."""
    z = np.zeros(1)

    def entry(status, certified=None):
        ev = {} if certified is None else {"krawczyk_certified": certified}
        return Solution(z, z, z, 1, status=status, evidence=ev)

    assert count_summary([entry("certified"), entry("singular", True)]) == (2, True)
    assert count_summary([entry("certified"), entry("singular", False)]) == (1, False)
    for other in ("unverified", "cluster", "continuum"):
        assert count_summary([entry("certified"), entry(other)]) == (1, False)
    assert count_summary([]) == (0, True)
    assert set(STATUSES) == {"certified", "singular", "unverified", "cluster", "continuum"}
    assert all(isinstance(s, Status) for s in STATUSES) and f"{Status.CERTIFIED}" == "certified"


def _cluster_at(angles, half=1e-7):
    """A cluster as the box loop returns it: a tiny hull around (not at) the root."""
    a = np.asarray(angles, float) + 0.3 * half
    return Cluster(a, a - half, a + half, 1)


def test_clusters_polishing_to_one_root_give_one_solution():
    """Two clusters 1e-6 apart around the same inverse-kinematics root (as stray boxes of one root
    come out of the box loop) polish to that root: one solution, not two."""
    mech = general_3rrr()
    ik = mech.inverse_kinematics(rot([0.1, 0.2, -0.1]))[0]
    assert mech.singularity(ik.joint_angles).kind == "regular"
    names = mech.loop_unknowns
    root = np.array([ik.joint_angles[n] for n in names])
    sols = finalize(mech, ik.inputs, names, [_cluster_at(root), _cluster_at(root - 1e-6)], 1e-6)
    assert len(sols) == 1 and sols[0].status == "certified"
    np.testing.assert_allclose(sols[0].angles, root, atol=1e-12)


def test_distinct_roots_stay_distinct():
    """Two regular roots of the Gosselin platform at the same inputs, from the closed-form solver
    (references/peers_closed_form.py) and inverse kinematics: two certified solutions, each at its own root."""
    mech = gosselin()
    names = mech.loop_unknowns
    roots = [np.array([m.joint_angles[n] for n in names])
             for pose in pcf.direct_kinematics(pcf.geometry_of(mech), GOSSELIN_INPUTS)
             for m in mech.inverse_kinematics(pose)
             if np.abs(np.remainder(np.array(m.inputs) - GOSSELIN_INPUTS + np.pi, 2 * np.pi) - np.pi).max() < 1e-12]
    assert len(roots) >= 2
    sols = finalize(mech, GOSSELIN_INPUTS, names, [_cluster_at(r) for r in roots[:2]], 1e-6)
    assert len(sols) == 2 and all(s.status == "certified" for s in sols)
    for r in roots[:2]:
        assert min(np.abs(np.remainder(s.angles - r + np.pi, 2 * np.pi) - np.pi).max() for s in sols) < 1e-12


def test_a_cluster_whose_finer_search_finds_nothing_is_reported_not_dropped(monkeypatch):
    """Issue 26: a cluster holding a real root (from inverse kinematics) that cannot be resolved
    (every certificate refused, every sub-box test undecided) is searched again finer; when that
    search lets go of everything, the cluster must still be reported (not proven), never dropped:
    the count cannot be '0, exact'."""
    import spherekin.trust.solutions as trust_solutions
    from spherekin.trust.krawczyk import BoxTests

    def undecided(system, lo, hi, ys=None, angle_tolerance=None):
        b, m = np.shape(lo)
        no = np.zeros(b, dtype=bool)
        return BoxTests(no, no.copy(), np.full((b, m), np.nan), np.full((b, m), np.nan))

    monkeypatch.setattr(trust_solutions, "krawczyk_many", undecided)
    mech = general_3rrr()
    ik = mech.inverse_kinematics(rot([0.1, 0.2, -0.1]))[0]
    names = mech.loop_unknowns
    root = np.array([ik.joint_angles[n] for n in names])
    calls = []

    def empty_refine(lo, hi, tol):
        calls.append(tol)
        return [], tol * 1e-2

    sols = finalize(mech, ik.inputs, names, [_cluster_at(root)], 1e-6, certify=refusing_certify,
                    refine=empty_refine)
    assert calls, "the unresolved cluster was not searched again"
    assert sols and count_summary(sols)[1] is False
    assert any(np.all(s.lo - 1e-9 <= root) and np.all(root <= s.hi + 1e-9) or np.abs(s.angles - root).max() < 1e-9
               for s in sols)


def _proven(x, box, enc):
    """A proven entry at angle x (one unknown) with its certified box x +- box, root enclosure x +- enc."""
    a = np.array([x])
    return Solution(a, a - box, a + box, 1, residual=1e-16, status=Status.CERTIFIED,
                    evidence={"krawczyk_certified": True, "root_enclosure": {"lo": [x - enc], "hi": [x + enc]}})


def test_proven_entries_are_one_root_only_when_their_certificates_say_so():
    """Issue 26: two certified roots 6e-9 apart (the agile eye next to a singular line, certified in
    extended precision) are two roots: nearness of points proves nothing; an entry whose root
    enclosure lies in another's box is that root, found twice; an unproven point inside a proven
    box is that box's one root, one outside it is kept (the count then cannot be exact)."""
    from spherekin.trust.solutions import _unique

    a = _proven(0.5, 2e-9, 1e-15)
    b = _proven(0.5 + 6e-9, 2e-9, 1e-15)
    twice = _proven(0.5 + 1e-15, 2e-9, 1e-15)
    near = Solution(np.array([0.5 + 1e-9]), np.array([0.5]), np.array([0.5 + 2e-9]), 1, status=Status.UNVERIFIED)
    outside = Solution(np.array([0.5 + 3e-9]), np.array([0.5]), np.array([0.5 + 4e-9]), 1, status=Status.UNVERIFIED)
    out = _unique([a, b, twice, near, outside])
    assert [float(e.angles[0]) for e in out if is_proven(e)] == [0.5, 0.5 + 6e-9]
    assert [float(e.angles[0]) for e in out if not is_proven(e)] == [0.5 + 3e-9]
    assert count_summary(out) == (2, False)
    # the same roots a whole turn apart are still one
    assert len(_unique([a, _proven(0.5 + 2 * np.pi, 2e-9, 1e-15)])) == 1
    # certificates that overlap without either enclosing the other's root: not two proven roots
    wide = _unique([_proven(0.5, 2e-9, 1.5e-9), _proven(0.5 + 3e-9, 2e-9, 1.5e-9)])
    assert count_summary(wide) == (1, False)


def test_one_root_reached_twice_in_extended_precision_is_kept_once():
    """Newton in extended precision returns the same floats for one root from every start; the points it
    came from sit a whole turn away in one angle (a cluster next to -pi). Brought back next to the cluster by
    whole turns, the root is one new point, not two 1 ulp apart (p + wrap(root - p) rounds differently for
    each p: the second copy, 4e-16 from the first, could only be tested on a box of radius 2e-16, and the
    root went unproven next to general_3rrr's fold; issue 40)."""
    from spherekin.trust import solutions as sol_mod

    root = np.array([4.355005308974469, 1.5319488948170208, -0.1522431426361721, 3.0246163691633017,
                     -0.7485801211630532, 2.3489779844202126])
    # two starts for which p + wrap(root - p) rounds to different floats (with the exact wrap of core/angles)
    starts = [np.array([-1.9281799809034452, 1.5319488816065345, -0.15224307859390707, 3.024616379653313,
                        -0.7485801747299905, 2.348978020579718]),
              np.array([-1.9281798678051123, 1.531948989525117, -0.1522432130096957, 3.0246162426211547,
                        -0.7485801834904994, 2.3489779885528104])]

    class Extended:                       # Newton's root from anywhere; no certificate
        def polish(self, theta):
            return root.copy()

        def certify(self, theta, radii):
            return None

    class NoCertificate:
        certified, krawczyk_box, no_solution = False, None, False

    def certify_fn(system, thetas, radii, angle_tolerance):
        return [NoCertificate() for _ in thetas]

    points = [sol_mod._Point(p, None, 0.0) for p in starts]
    out = sol_mod._sharpen(certify_fn, None, points, Extended())
    assert len(out) == 1
    expected = root.copy()
    expected[0] -= 2 * np.pi
    assert np.array_equal(out[0].theta, expected)
