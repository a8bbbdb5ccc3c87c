"""systems/complete.py: the complete count of a 3-RRR, against independent references.

The parts of Eq. (1) against exact rational arithmetic written here; the matrices at an input against
50-digit mpmath; the candidates against the 50-digit roots of references/reference_roots (every one
found); the solve against the platform system (the box search: same assemblies, statuses and
singularities) and against the 50-digit count next to folds, at the agile eye's self-motion input
and at joint-range ends (where the complete count must pass the input on).
"""

from __future__ import annotations

import dataclasses
import math
from fractions import Fraction

import mpmath
import numpy as np
import pytest

import spherekin
from references.peers_closed_form import geometry_of
from references.random_designs import random_3rrr
from references.reference_roots import near_singular_inputs, reference_roots, singular_input
from spherekin.core.angles import RANGE_TOL
from spherekin.mechanism import general_3rrr, gosselin
from spherekin.systems import Passed, Proven
from spherekin.systems.complete import MODEL_TOLERANCE, Complete, interval_leg_parts, model_gap
from spherekin.systems.platform import QUADRATIC_TENSOR, platform_legs

from conftest import with_range
from test_systems import actuated_at


def exact_parts(leg):
    """The three parts (Mc, Ms, M0) of Eq. (1)'s matrix for one leg, in Fractions of the model's floats,
    written from the module doc of systems/platform.py (e(d) . (D b(d)) = c(d); q^T M q = e . S(q) b - c |q|^2)."""
    f = [[Fraction(float(x)) for x in v] for v in (leg.a1, leg.a2, leg.a3)]
    a1, a2, a3 = f

    def dot(u, v):
        return sum(x * y for x, y in zip(u, v))

    def cross(u, v):
        return [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]

    def turn(axis, v, sign=1):                # Rot(axis, sign d) v = cos d (v - (a.v) a) + sin d sign a x v + (a.v) a
        along = dot(axis, v)
        return [[x - along * a for x, a in zip(v, axis)], [sign * x for x in cross(axis, v)], [along * a for a in axis]]

    t = [[[[Fraction(float(QUADRATIC_TENSOR[i, j, m, n])) for n in range(3)] for m in range(3)] for j in range(4)]
         for i in range(4)]

    def form(e, b, c):
        return [[sum(t[i][j][m][n] * e[m] * b[n] for m in range(3) for n in range(3)) - (c if i == j else 0)
                 for j in range(4)] for i in range(4)]

    zero = [Fraction(0)] * 3
    if leg.actuated == 0:
        e, b, c = turn(a1, a2), [zero, zero, a3], [0, 0, dot(a2, a3)]
    elif leg.actuated == 1:
        e, b, c = [zero, zero, a1], [zero, zero, a3], [dot(p, a1) for p in turn(a2, a3)]
    else:
        e, b, c = [zero, zero, a1], turn(a3, a2, -1), [0, 0, dot(a1, a2)]
    # M(d) = e(d) . S b(d) - c(d): one of e, b, c varies, the others are their constant part
    out = []
    for p in range(3):
        if p < 2:
            out.append([[x + y for x, y in zip(r1, r2)] for r1, r2 in zip(form(e[p], b[2], c[p]), form(e[2], b[p], 0))])
        else:
            out.append(form(e[2], b[2], c[2]))
    return out


@pytest.mark.parametrize("position", [0, 1, 2])
def test_the_interval_parts_hold_the_exact_rational_parts(position):
    mech = actuated_at(general_3rrr(), position) if position else general_3rrr()
    legs = platform_legs(mech)
    got = interval_leg_parts(legs)
    for li, leg in enumerate(legs):
        for p, mat in enumerate(exact_parts(leg)):
            for i in range(4):
                for j in range(4):
                    lo, hi = got[0, li, p, i, j], got[1, li, p, i, j]
                    assert Fraction(lo) <= mat[i][j] <= Fraction(hi), (li, p, i, j)
                    assert hi - lo <= 1e-14


def test_the_matrices_at_an_input_hold_eq_1_at_50_digits():
    problem = spherekin.compile(general_3rrr())
    compiled = problem.compiled("complete")
    rows = np.random.default_rng(5).uniform(-math.pi, math.pi, (6, 3))
    m = compiled.matrices(rows)
    legs = compiled.legs
    with mpmath.workdps(50):
        for k, row in enumerate(rows):
            for li, leg in enumerate(legs):
                d = mpmath.mpf(float(row[li])) - mpmath.mpf(float(leg.reference[0]))
                w = (mpmath.cos(d), mpmath.sin(d), 1)
                parts = exact_parts(leg)
                for i in range(4):
                    for j in range(4):
                        exact = sum(w[p] * mpmath.mpf(parts[p][i][j].numerator) / parts[p][i][j].denominator
                                    for p in range(3))
                        lo, hi = m[0, k, li, i, j], m[1, k, li, i, j]
                        assert lo + MODEL_TOLERANCE * 0.99 <= exact <= hi - MODEL_TOLERANCE * 0.99
                        assert hi - lo <= 2 * MODEL_TOLERANCE + 1e-13


def _rotations(q):
    """Rotations (..., 3, 3) (complex) of quaternions q (..., 4), S(q) / q.q."""
    w, x, y, z = np.moveaxis(q, -1, 0)
    s = np.stack([np.stack([w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
                  np.stack([2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)], -1),
                  np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z], -1)], -2)
    return s / (q * q).sum(-1)[..., None, None]


@pytest.mark.parametrize("seed", range(4))
def test_the_candidates_are_every_root_of_the_50_digit_reference(seed):
    """Every one of the 8 complex roots (as a complex rotation, which fixes q up to sign) is within
    1e-6 of a candidate; random 3-RRRs assembled at R = I (so D = R)."""
    rng = np.random.default_rng(200 + seed)
    mech, data = random_3rrr(rng)
    np.testing.assert_allclose(mech.platform_reference_matrix, np.eye(3), atol=1e-15)
    geometry = tuple(np.array(v, dtype=float) for v in data)
    rows = rng.uniform(-math.pi, math.pi, (3, 3))
    compiled = spherekin.compile(mech).compiled("complete")
    cands = _rotations(compiled.candidates(rows))                          # (3, 8, 3, 3)
    for k, row in enumerate(rows):
        ref = reference_roots(geometry, row)
        assert ref.n_roots == 8
        for q in ref.roots:
            r = _rotations(q)
            assert np.nanmin(np.abs(cands[k] - r).max(axis=(1, 2))) < 1e-6


def _same_as_the_box_search(mech, rows):
    """The complete count's reports equal the platform system's at every row it proves: counts,
    statuses, singularities, angles; and each reading lies in its proven enclosure."""
    fast = spherekin.compile(mech).solve_many(rows)
    boxes = spherekin.compile(mech, system="platform").solve_many(rows)
    proven = 0
    for row, a, b in zip(rows, fast, boxes):
        assert a.count_exact and b.count_exact and a.proven_count == b.proven_count, row
        for s in a.solutions:                      # the same assemblies (the order may differ at angles +-pi)
            t = min(b.solutions, key=lambda t: np.abs(t.platform_rotation - s.platform_rotation).max())
            np.testing.assert_allclose(s.platform_rotation, t.platform_rotation, atol=1e-9)
            assert (s.status, s.singularity) == (t.status, t.singularity)
            assert np.abs(np.remainder(s.angles - t.angles + np.pi, 2 * np.pi) - np.pi).max() < 1e-9
            if a.settings.system == "complete":
                enc = s.evidence["root_enclosure"]
                assert np.all(np.array(enc["lo"]) <= s.angles) and np.all(s.angles <= np.array(enc["hi"]))
                assert s.evidence["bezout"]["roots_proven"] == 8 and s.residual < 1e-12
        proven += a.settings.system == "complete"
    return proven


def test_general_3rrr_and_the_agile_eye_agree_with_the_box_search_on_random_inputs():
    rng = np.random.default_rng(11)
    for mech in (general_3rrr(), gosselin()):
        rows = rng.uniform(-math.pi, math.pi, (40, 3))
        assert _same_as_the_box_search(mech, rows) == len(rows)      # every generic input proven at once


def test_the_agile_eye_has_8_real_assemblies_four_of_them_serially_singular():
    rep = spherekin.solve(gosselin(), (0.3, -0.2, 0.5))
    assert rep.settings.system == "complete" and rep.count_exact and rep.proven_count == 8
    assert sorted(s.status for s in rep.solutions) == ["certified"] * 4 + ["singular"] * 4
    assert {s.singularity for s in rep.solutions if s.status == "singular"} == {"serial"}


@pytest.fixture(scope="module")
def fold():
    """general_3rrr, its geometry and inputs on both sides of a parallel singularity (the 50-digit count
    changes there), at 1e-2 .. 1e-16 from it."""
    mech = general_3rrr()
    geometry = geometry_of(mech)
    _, x_star = singular_input(geometry, (0.3, -0.2, 0.5), (0.3, -0.2, 1.7))
    return mech, geometry, near_singular_inputs(x_star, (0.0, 0.0, 1.0), distances=(1e-2, 1e-6, 1e-10, 1e-14, 1e-16))


def test_next_to_a_fold_the_complete_count_is_the_references_or_it_passes(fold):
    """The system alone (no fallback run): what it proves is the 50-digit count; within 1e-10 it passes."""
    mech, geometry, pairs = fold
    answers = spherekin.compile(mech).compiled("complete").search_many([tuple(x) for _, x in pairs], None)
    for (dist, x), answer in zip(pairs, answers):
        if isinstance(answer, Proven):
            assert len(answer.solutions) == reference_roots(geometry, x).count, dist
        else:
            assert isinstance(answer, Passed) and "complete count" in answer.reason
        if abs(dist) >= 1e-2:
            assert isinstance(answer, Proven), dist
        if abs(dist) <= 1e-10:                       # a pair ~1e-5 apart or closer: not proven at once
            assert isinstance(answer, Passed), dist


def test_next_to_a_fold_the_count_is_the_references_and_close_inputs_fall_back(fold):
    mech, geometry, pairs = fold
    reports = spherekin.compile(mech).solve_many([x for _, x in pairs])
    for (dist, x), rep in zip(pairs, reports):
        ref = reference_roots(geometry, x)
        if rep.count_exact:
            assert rep.proven_count == ref.count, (dist, rep.proven_count, ref.count)
        else:
            assert rep.proven_count <= ref.count
        if abs(dist) <= 1e-10:                       # a pair of roots ~1e-5 apart or closer: not proven at once
            assert rep.settings.system != "complete" and "complete count" in rep.settings.fallback, dist
        if abs(dist) >= 1e-2:
            assert rep.settings.system == "complete", dist


def test_the_agile_eyes_self_motion_input_is_passed_on():
    """At (pi/2, 0, beta3) the agile eye has a continuum of assemblies: no count is proven at once (the
    box search then covers the continuum: tests/test_trust_edge.py)."""
    compiled = spherekin.compile(gosselin()).compiled("complete")
    for beta3 in (0.5, -1.2):
        (answer,) = compiled.search_many([(math.pi / 2, 0.0, beta3)], None)
        assert isinstance(answer, Passed) and "complete count" in answer.reason


def test_a_root_at_a_range_end_is_passed_on_and_ranges_a_hair_away_are_decided():
    mech, x = general_3rrr(), (0.3, -0.2, 0.5)
    full = spherekin.solve(mech, x)
    assert full.settings.system == "complete" and full.proven_count >= 2
    g = full.solutions[0].passive_angles["gamma1"]
    others = [s.passive_angles["gamma1"] for s in full.solutions[1:]]
    assert min(abs(math.remainder(o - g, 2 * math.pi)) for o in others) > 0.1
    # a range whose end, widened by RANGE_TOL, is exactly the root's reading: the enclosure straddles it,
    # and the box search answers by its rule
    at_end = with_range(mech, "gamma1", (g - 0.05, g - RANGE_TOL))
    rep = spherekin.solve(at_end, x)
    assert rep.settings.system != "complete" and "range" in rep.settings.fallback
    assert rep.proven_count == spherekin.solve(at_end, x, system="platform").proven_count and rep.count_exact
    # ends 1e-6 inside or outside the reading: decided by the complete count, as the box search decides
    for end, kept in ((g + 1e-6, 1), (g - 1e-6, 0)):
        ranged = with_range(mech, "gamma1", (g - 0.05, end))
        rep, boxes = spherekin.solve(ranged, x), spherekin.solve(ranged, x, system="platform")
        assert rep.settings.system == "complete" and rep.proven_count == boxes.proven_count == kept


def test_what_it_accepts():
    assert Complete.accepts(general_3rrr()) is None and Complete.accepts(gosselin()) is None
    why = Complete.accepts(actuated_at(general_3rrr(), 1))
    assert "base-actuated" in why and "gamma1" in why
    with pytest.raises(ValueError, match="formulation 'complete': the platform formulation needs 3 legs"):
        spherekin.compile(spherekin.mechanism.four_bar(), formulation="complete")
    strategy = dataclasses.replace(spherekin.compile(gosselin()).strategy, formulation="auto", isolate=False)
    assert "isolate=False" in Complete.accepts(gosselin(), strategy)
    # a description whose distal link angles the model's axes do not give (1e-12 off): not proven about it
    mech = general_3rrr()
    assert model_gap(mech) < 1e-15
    off = dataclasses.replace(mech, geometry=dataclasses.replace(
        mech.geometry, distal_link_angles=tuple(a + 1e-12 for a in mech.geometry.distal_link_angles)))
    assert model_gap(off) > 9e-13 and "distal link angles" in Complete.accepts(off)
    assert spherekin.compile(off).system == "platform"


def test_entries_are_built_when_read_once_for_the_whole_chunk(monkeypatch):
    """A chunk's counts need no Solution object; the first entry read builds every entry of the chunk
    (once); a report pickles and compares as one holding a tuple."""
    import pickle

    from spherekin.results import LazySolutions, SolutionArrays
    from spherekin.systems.proven_roots import ChunkRoots

    calls = []
    real = ChunkRoots._build
    monkeypatch.setattr(ChunkRoots, "_build", lambda self: calls.append(1) or real(self))
    rows = np.random.default_rng(13).uniform(-math.pi, math.pi, (10, 3))
    reports = spherekin.compile(general_3rrr()).solve_many(rows)
    counts = [(r.proven_count, r.count_exact, len(r.solutions)) for r in reports]
    assert calls == [] and all(isinstance(r.solutions, LazySolutions) for r in reports)
    # the results table reads the arrays: still no Solution built
    frames = [r.frame() for r in reports]
    assert calls == [] and [len(f) for f in frames] == [max(c[2], 1) for c in counts]
    assert reports[3].solutions[0].status in ("certified", "singular") and calls == [1]
    # the arrays are the entries' own columns, in their order
    for r in reports:
        a, b = r.solutions.arrays(), SolutionArrays.of(tuple(r.solutions), len(r.unknowns))
        assert np.array_equal(a.angles, b.angles) and list(a.status) == list(b.status)
        assert list(a.singularity) == list(b.singularity) and np.array_equal(a.residual, b.residual)
        assert np.array_equal(a.rotations, b.rotations)
        keys = [tuple(np.round(sol.angles, 9)) for sol in r.solutions]
        assert keys == sorted(keys)                                           # the trust layer's order
    assert [len(r.solutions) for r in reports[5:]] == [c[2] for c in counts[5:]] and list(reports[5].solutions)
    assert calls == [1]
    again = pickle.loads(pickle.dumps(reports[3]))
    assert isinstance(again.solutions, tuple) and len(again.solutions) == len(reports[3].solutions)
    assert all(np.array_equal(a.angles, b.angles) for a, b in zip(again.solutions, reports[3].solutions))
    assert reports[3].solutions == tuple(reports[3].solutions)              # compares as the tuple it holds
    assert [c[0] for c in counts] == [len(r.solutions) for r in reports]
    assert all(r.solutions[0].actuated == dict(zip(("beta1", "beta2", "beta3"), row))
               for r, row in zip(reports, rows) if len(r.solutions))
