"""core/bezout.py: every root of three quadrics in P^3 proven, against an independent reference.

The quadrics are the references' own (references/peers_closed_form.leg_quadrics: the 3-RRR's legs in
the platform rotation R, written from the four lists of the 3-RRR description, not from spherekin's
equations), their roots the 50-digit complex Newton roots of references/reference_roots. What is
checked: a complete count is the reference's real count; every proven enclosure holds exactly one
reference root; a count missing a root, two candidates for one root, or a near-real complex pair are
never proven complete; the fast arithmetic never contradicts the interval reference.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from references.peers_closed_form import geometry_of, leg_quadrics
from references.random_designs import random_3rrr
from references.reference_roots import near_singular_inputs, reference_roots, singular_input
from spherekin.core import bezout
from spherekin.mechanism import general_3rrr, gosselin

#: Half-width of the interval matrices the tests hand over (the float quadrics taken as exact, plus room).
WIDTH = 1e-13


def interval(quadrics) -> np.ndarray:
    """(2, K, 3, 4, 4) intervals [A - WIDTH, A + WIDTH] around float quadrics (K, 3, 4, 4)."""
    a = np.asarray(quadrics, dtype=float)
    return np.stack([a - WIDTH, a + WIDTH])


def case(seed):
    """(geometry, inputs, reference) of a random 3-RRR at a random input."""
    rng = np.random.default_rng(seed)
    _, data = random_3rrr(rng)
    geometry = tuple(np.array(v, dtype=float) for v in data)
    inputs = rng.uniform(-math.pi, math.pi, 3)
    return geometry, inputs, reference_roots(geometry, inputs)


def on_its_chart(q):
    """q (4,) complex scaled so that its largest component is 1."""
    return q / q[np.argmax(np.abs(q))]


def holds(proof, k, n, q) -> bool:
    """Whether the proven enclosure n of system k holds the point q of P^3 (scaled to its chart)."""
    p = q / q[proof.chart[k, n]]
    p[proof.chart[k, n]] = 1.0                   # exactly (the division rounds it to 1 +- 1e-16 i)
    return bool(np.all((proof.re_lo[k, n] <= p.real) & (p.real <= proof.re_hi[k, n])
                       & (proof.im_lo[k, n] <= p.imag) & (p.imag <= proof.im_hi[k, n])))


def check_against(proof, k, ref):
    """Every proven root of system k holds exactly one reference root, each reference root is in one,
    and the proven real roots are the reference's real ones."""
    for n in np.flatnonzero(proof.certified[k]):
        inside = [i for i, q in enumerate(ref.roots) if holds(proof, k, n, q)]
        assert len(inside) == 1, (k, n, inside)
        if proof.real[k, n]:
            assert ref.real[inside[0]], (k, n)
        if proof.nonreal[k, n]:
            assert not ref.real[inside[0]], (k, n)
    if proof.complete[k]:
        assert proof.real[k].sum() == ref.count
        for q in ref.roots:
            assert sum(holds(proof, k, n, q) for n in range(proof.chart.shape[1])) == 1


@pytest.mark.parametrize("arithmetic", bezout.ARITHMETICS)
def test_the_50_digit_roots_as_candidates_give_a_complete_count_that_is_the_references(arithmetic):
    cases = [case(seed) for seed in range(40, 46)]
    quadrics = np.array([leg_quadrics(g, x) for g, x, _ in cases])
    cands = np.array([[on_its_chart(q) for q in ref.roots] for _, _, ref in cases])
    proof = bezout.certify_roots(interval(quadrics), cands, arithmetic)
    assert proof.complete.all()
    for k, (_, _, ref) in enumerate(cases):
        check_against(proof, k, ref)


def test_candidates_a_hair_off_are_polished_onto_the_roots():
    cases = [case(seed) for seed in range(50, 54)]
    quadrics = np.array([leg_quadrics(g, x) for g, x, _ in cases])
    rng = np.random.default_rng(3)
    cands = np.array([[on_its_chart(q) * (1 + 1e-5 * (rng.normal() + 1j * rng.normal())) for q in ref.roots]
                      for _, _, ref in cases])
    proof = bezout.certify_roots(interval(quadrics), cands)
    assert proof.complete.all()
    for k, (_, _, ref) in enumerate(cases):
        check_against(proof, k, ref)


def test_a_root_missing_leaves_the_count_unproven():
    """Seven of the eight roots proven is not a complete count (Bezout's bound is 8)."""
    g, x, ref = case(60)
    cands = np.array([[on_its_chart(q) for q in ref.roots]])
    cands[0, 3] = np.nan
    proof = bezout.certify_roots(interval([leg_quadrics(g, x)]), cands)
    assert proof.certified[0].sum() == 7 and not proof.complete[0]
    check_against(proof, 0, ref)


def test_one_root_given_twice_is_not_two_roots():
    """Two candidates of one root both contract onto it: proven each, but not distinct, so not complete."""
    g, x, ref = case(61)
    roots = [on_its_chart(q) for q in ref.roots]
    roots[5] = roots[2] * (1 + 1e-9)                 # the root of slot 5 lost, slot 2's found twice
    proof = bezout.certify_roots(interval([leg_quadrics(g, x)]), np.array([roots]))
    assert proof.certified[0].all() and not proof.distinct[0] and not proof.complete[0]


def test_count_complete_rule():
    yes = np.ones((1, 8), dtype=bool)
    real = np.zeros((1, 8), dtype=bool)
    real[0, :4] = True
    assert bezout.count_complete(yes, real, ~real, np.array([True]))[0]
    assert not bezout.count_complete(yes, real, ~real, np.array([False]))[0]          # not distinct
    undecided = ~real
    undecided[0, 7] = False
    assert not bezout.count_complete(yes, real, undecided, np.array([True]))[0]      # one neither real nor not
    short = yes.copy()
    short[0, 0] = False
    assert not bezout.count_complete(short, real & short, ~real & short, np.array([True]))[0]


def test_next_to_a_fold_a_complex_pair_is_never_called_real():
    """Inputs 1e-6 .. 1e-14 from a parallel singularity (the 50-digit count changes there), on both
    sides: the pair is real on one side and complex (imaginary parts ~ sqrt of the distance) on the
    other. Whatever is proven agrees with the reference; a complete count is the reference's."""
    mech = general_3rrr()
    geometry = geometry_of(mech)
    _, x_star = singular_input(geometry, (0.3, -0.2, 0.5), (0.3, -0.2, 1.7))
    rows = [x for _, x in near_singular_inputs(x_star, (0.0, 0.0, 1.0),
                                               distances=(1e-4, 1e-6, 1e-8, 1e-10, 1e-11, 1e-12, 1e-14))]
    refs = [reference_roots(geometry, x) for x in rows]
    assert len({r.count for r in refs}) == 2                      # the count changes across the fold
    quadrics = np.array([leg_quadrics(geometry, x) for x in rows])
    for source in ("reference", "perturbed"):
        rng = np.random.default_rng(7)
        cands = np.array([[on_its_chart(q) * (1 + (1e-7 if source == "perturbed" else 0) * rng.normal())
                           for q in ref.roots] for ref in refs])
        for arithmetic in bezout.ARITHMETICS:
            proof = bezout.certify_roots(interval(quadrics), cands, arithmetic)
            for k, ref in enumerate(refs):
                check_against(proof, k, ref)
            assert not proof.complete[-2:].any()                  # 1e-12, 1e-14 from the fold: never proven
            assert proof.complete[:2].all()                       # 1e-4 away: proven


def test_the_fast_arithmetic_never_contradicts_the_intervals():
    rng = np.random.default_rng(8)
    mech = gosselin()
    geometry = geometry_of(mech)
    rows = rng.uniform(-math.pi, math.pi, (24, 3))
    quadrics = np.array([leg_quadrics(geometry, x) for x in rows])
    refs = [reference_roots(geometry, x) for x in rows[:4]]
    cands = np.array([[on_its_chart(q) for q in ref.roots] for ref in refs])
    fast = bezout.certify_roots(interval(quadrics[:4]), cands, "fast")
    slow = bezout.certify_roots(interval(quadrics[:4]), cands, "intervals")
    assert fast.complete.all() and slow.complete.all()
    assert (fast.real == slow.real).all() and (fast.nonreal == slow.nonreal).all()
    both = fast.certified & slow.certified
    for part in ("re", "im"):                       # the two enclosures of one root intersect
        lo = np.maximum(getattr(fast, part + "_lo"), getattr(slow, part + "_lo"))
        hi = np.minimum(getattr(fast, part + "_hi"), getattr(slow, part + "_hi"))
        assert np.all((lo <= hi)[both])


def test_wide_matrices_prove_nothing_and_a_bad_arithmetic_is_refused():
    g, x, ref = case(62)
    cands = np.array([[on_its_chart(q) for q in ref.roots]])
    a = np.asarray([leg_quadrics(g, x)])
    proof = bezout.certify_roots(np.stack([a - 1e-3, a + 1e-3]), cands)
    assert not proof.certified.any() and not proof.complete.any()
    with pytest.raises(ValueError, match=r"arithmetic: expected one of \['fast', 'intervals'\], got 'arb'"):
        bezout.certify_roots(interval(a), cands, "arb")


def test_a_point_on_its_chart_has_its_component_exactly_one():
    """x / x in complex floats is not always 1 (a fifth of random points here): the chart, the realness
    argument (a real chart) and the distinctness test take the component as exact."""
    rng = np.random.default_rng(9)
    q = rng.normal(size=(2000, 4)) + 1j * rng.normal(size=(2000, 4))
    chart = bezout.charts_of(q)
    assert np.any(np.take_along_axis(q / np.take_along_axis(q, chart[:, None], 1), chart[:, None], 1) != 1)
    on = bezout.on_chart(q, chart)
    assert np.all(np.take_along_axis(on, chart[:, None], 1) == 1)
    g, x, ref = case(63)
    proof = bezout.certify_roots(interval([leg_quadrics(g, x)]), np.array([[on_its_chart(r) for r in ref.roots]]))
    assert np.all(np.take_along_axis(proof.roots[0], proof.chart[0][:, None], 1) == 1)
    assert proof.complete[0]
