"""Tests for spherekin.search.parameterizations against independent derivations.

* arc_box against a dense sampling of the arc;
* sin-cos loop polynomials: the Bernstein tensors evaluated at (c, s) points equal the product of
  the factor matrices [[0,-1,0],[C,0,-S],[S,0,C]] with C, S computed here from the definition
  cos(o + sign theta) = cos(o) c - sign sin(o) s (on and off the circle), equal the direct
  rotation product on the circle, and are exact (sympy over the rationals) for a small loop;
* the halves of both parameterizations: q_a q_b (P - S^T) from numeric products of the two halves;
* the chart maps: unit coordinates <-> angles, and angle_box encloses sampled points;
* the circle equation's control points.
"""

import dataclasses
import itertools
import math
import re
from fractions import Fraction

import numpy as np
import pytest
import sympy as sp

from spherekin.core import bernstein
from spherekin.closure import ClosureLoop, Term, Unknown
from spherekin.mechanism import gosselin, general_3rrr
import spherekin
from spherekin.search.parameterizations import (ARC_BOX_MARGIN, PARAMETERIZATIONS, LoopParameterization, SinCos,
                                                TanHalf, arc_box, charts_for_range, make_charts, sin_cos_loop,
                                                tan_half_loop)
from spherekin.core.rotations import normalized_closure

INPUTS = (0.3, -0.2, 0.5)


def mechanism_build(mech):
    names = mech.loop_unknowns

    def build(chart):
        system = mech.loop_system(INPUTS, chart)
        return system.loops, system.unknowns

    return build, {n: mech.ranges[n] for n in names}


def factor_matrix(c, s):
    """Rx(phi) Z with cos phi = c, sin phi = s (any c, s: the polynomial, not only the rotation)."""
    z, o = np.zeros_like(c), np.ones_like(c)
    return np.stack([np.stack([z, -o, z], -1), np.stack([c, z, -s], -1), np.stack([s, z, c], -1)], -2)


def loop_product_cs(loop, names, cs):
    """prod of factor matrices at (c_k, s_k) = cs[..., k, :], straight from the definition."""
    out = np.broadcast_to(np.eye(3), cs.shape[:-2] + (3, 3))
    for f in loop.factors:
        if isinstance(f, Term):
            c, s = cs[..., names.index(f.unknown.name), 0], cs[..., names.index(f.unknown.name), 1]
            co, so = math.cos(f.offset), math.sin(f.offset)
            m = factor_matrix(co * c - f.sign * so * s, so * c + f.sign * co * s)
        else:
            m = factor_matrix(np.full(cs.shape[:-2], math.cos(f)), np.full(cs.shape[:-2], math.sin(f)))
        out = out @ m
    return out


# ---------------------------------------------------------------- arc boxes

@pytest.mark.parametrize("lo, hi", [(-0.3, 0.4), (1.0, 2.5), (2.9, 3.5), (-3.5, -2.8), (-1.0, 4.0),
                                    (0.0, math.pi / 2), (-math.pi, math.pi - 1e-9), (5.0, 6.0)])
def test_arc_box_is_the_tight_bounding_box_of_the_arc(lo, hi):
    t = np.linspace(lo, hi, 200_001)
    (clo, chi), (slo, shi) = arc_box((lo, hi))
    assert clo <= np.cos(t).min() and chi >= np.cos(t).max()
    assert slo <= np.sin(t).min() and shi >= np.sin(t).max()
    tight = 1e-9 + ARC_BOX_MARGIN                          # sampling step 3e-5: extremes within ~1e-10
    assert clo >= max(-1.0, np.cos(t).min() - tight) and chi <= min(1.0, np.cos(t).max() + tight)
    assert slo >= max(-1.0, np.sin(t).min() - tight) and shi <= min(1.0, np.sin(t).max() + tight)


def test_arc_box_full_circle_and_bad_ranges():
    assert arc_box(None) == ((-1.0, 1.0), (-1.0, 1.0))
    assert arc_box((0.0, 7.0)) == ((-1.0, 1.0), (-1.0, 1.0))
    with pytest.raises(ValueError, match="range"):
        arc_box((1.0, 1.0))
    with pytest.raises(ValueError, match="range"):
        arc_box((0.0, float("nan")))


# ---------------------------------------------------------------- sin-cos loop polynomials

def gosselin_loops():
    mech = gosselin()
    system = mech.loop_system(INPUTS, {n: (-1.0, 1.0) for n in mech.passive})
    return system.loops, list(system.names), mech


@pytest.mark.parametrize("seed", [0, 1])
def test_sin_cos_control_points_equal_the_factor_product_on_and_off_the_circle(seed):
    loops, names, _ = gosselin_loops()
    rng = np.random.default_rng(seed)
    boxes = {n: tuple(tuple(sorted(rng.uniform(-1, 1, 2))) for _ in range(2)) for n in names}
    for j, loop in enumerate(loops):
        lp = sin_cos_loop(j, loop, names, boxes)
        k = len(loop.unknowns)
        assert lp.matrix.shape == (3, 3) + (2,) * (2 * k)   # degree 1 in every c and s
        x = rng.uniform(0, 1, size=(30, 2 * k))
        cs = np.zeros((30, len(names), 2))
        for a, u in enumerate(loop.unknowns):
            (c0, c1), (s0, s1) = boxes[u.name]
            i = names.index(u.name)
            cs[:, i, 0] = c0 + (c1 - c0) * x[:, 2 * a]
            cs[:, i, 1] = s0 + (s1 - s0) * x[:, 2 * a + 1]
        got = np.moveaxis(bernstein.evaluate(lp.matrix, x, nvars=2 * k), -1, 0)   # (P, 3, 3)
        np.testing.assert_allclose(got, loop_product_cs(loop, names, cs), atol=1e-13)
        assert lp.variables == tuple(v for u in loop.unknowns for v in (2 * names.index(u.name),
                                                                        2 * names.index(u.name) + 1))


def test_sin_cos_polynomial_is_the_closure_on_the_circle():
    loops, names, mech = gosselin_loops()
    rng = np.random.default_rng(3)
    boxes = {n: ((-1.0, 1.0), (-1.0, 1.0)) for n in names}
    theta = rng.uniform(-math.pi, math.pi, size=(20, len(names)))
    for j, loop in enumerate(loops):
        lp = sin_cos_loop(j, loop, names, boxes)
        idx = [names.index(u.name) for u in loop.unknowns]
        x = np.stack([(np.cos(theta[:, idx]) + 1) / 2, (np.sin(theta[:, idx]) + 1) / 2], -1).reshape(20, -1)
        got = np.moveaxis(bernstein.evaluate(lp.matrix, x, nvars=x.shape[1]), -1, 0)
        phis = np.stack([np.full(20, f) if not isinstance(f, Term) else f.offset + f.sign * theta[:, names.index(
            f.unknown.name)] for f in loop.factors], -1)
        np.testing.assert_allclose(got, normalized_closure(phis), atol=1e-13)


def test_sin_cos_control_points_exact_for_a_small_loop():
    """sympy over QQ: expand prod Rx(phi_i) Z for a loop with two unknowns (c_k = a_k + w_k x_k, ...)
    and take the exact Bernstein coefficients; the code's corner products must match them."""
    u1, u2 = Unknown("u1", -1.0, 1.0), Unknown("u2", -1.0, 1.0)
    loop = ClosureLoop([0.0, u1, math.pi / 2, Term(u2, math.pi, -1)])   # offsets with exact cos/sin
    box = {"u1": ((-1.0, 0.5), (-0.25, 1.0)), "u2": ((0.0, 0.75), (-1.0, -0.5))}
    lp = sin_cos_loop(0, loop, ["u1", "u2"], box)
    xs = sp.symbols("x0:4")
    rat = {k: [[sp.Rational(Fraction(v)) for v in pair] for pair in val] for k, val in box.items()}
    c1 = rat["u1"][0][0] + (rat["u1"][0][1] - rat["u1"][0][0]) * xs[0]
    s1 = rat["u1"][1][0] + (rat["u1"][1][1] - rat["u1"][1][0]) * xs[1]
    c2 = rat["u2"][0][0] + (rat["u2"][0][1] - rat["u2"][0][0]) * xs[2]
    s2 = rat["u2"][1][0] + (rat["u2"][1][1] - rat["u2"][1][0]) * xs[3]

    def fm(c, s):
        return sp.Matrix([[0, -1, 0], [c, 0, -s], [s, 0, c]])

    # phi = 0, theta_1, pi/2, pi - theta_2: cos(pi - t) = -c, sin(pi - t) = s
    prod = fm(1, 0) * fm(c1, s1) * fm(0, 1) * fm(-c2, s2)
    for r, c in itertools.product(range(3), range(3)):
        poly = sp.Poly(sp.expand(prod[r, c]), *xs)
        power = np.zeros((2, 2, 2, 2), dtype=object)
        for mono, coef in poly.terms():
            power[mono] = Fraction(int(coef.p), int(coef.q))
        power = np.vectorize(lambda v: Fraction(v), otypes=[object])(power)
        exact = bernstein.from_power(power)
        assert np.array_equal(lp.matrix[r, c], exact.astype(float)), (r, c)


# ---------------------------------------------------------------- the halves

def halves_numeric_cs(loop, names, cs):
    """P - S^T (q = 1) from numeric products of the two halves of the loop."""
    unknown_factors = [i for i, f in enumerate(loop.factors) if isinstance(f, Term)]
    cut = unknown_factors[len(unknown_factors) // 2 - 1] + 1
    p = loop_product_cs(ClosureLoop(loop.factors[:cut]), names, cs)
    s = loop_product_cs(ClosureLoop(loop.factors[cut:]), names, cs)
    return p - np.swapaxes(s, -1, -2)


def test_sin_cos_halves_equal_numeric_half_products():
    loops, names, _ = gosselin_loops()
    rng = np.random.default_rng(4)
    boxes = {n: ((-1.0, 1.0), (-1.0, 1.0)) for n in names}
    for j, loop in enumerate(loops):
        lp = sin_cos_loop(j, loop, names, boxes)
        ka = lp.split
        x = rng.uniform(0, 1, size=(25, 2 * len(loop.unknowns)))
        cs = np.zeros((25, len(names), 2))
        for a, u in enumerate(loop.unknowns):
            cs[:, names.index(u.name)] = -1 + 2 * x[:, 2 * a:2 * a + 2]
        ta = bernstein.evaluate(lp.half_a, x[:, :ka], nvars=ka)                  # (10, P); ka axes
        tb = bernstein.evaluate(lp.half_b, x[:, ka:], nvars=x.shape[1] - ka)
        diff = (ta[:9] * tb[9] - ta[9] * tb[:9].reshape(3, 3, -1).transpose(1, 0, 2).reshape(9, -1)).T
        np.testing.assert_allclose(diff, halves_numeric_cs(loop, names, cs).reshape(25, 9), atol=1e-13)
        np.testing.assert_array_equal(ta[9], 1.0)


def test_tan_half_halves_vanish_at_assemblies():
    mech = gosselin()
    rng = np.random.default_rng(5)
    from scipy.spatial.transform import Rotation

    for seed in range(3):
        pose = Rotation.random(random_state=seed).as_matrix()
        sol = mech.inverse_kinematics(pose)[int(rng.integers(8))]
        passive = sol.passive(mech.passive)
        system = mech.loop_system(sol.inputs, {n: (a - 0.7, a + 0.6) for n, a in passive.items()})
        x = system.to_unit(passive)
        for j, (loop, idx) in enumerate(zip(system.loops, system.loop_indices)):
            lp = tan_half_loop(j, loop, idx)
            ka = lp.split
            xl = x[list(idx)]
            ta = bernstein.evaluate(lp.half_a, xl[:ka], nvars=ka)
            tb = bernstein.evaluate(lp.half_b, xl[ka:], nvars=len(idx) - ka)
            diff = ta[:9] * tb[9] - ta[9] * tb[:9].reshape(3, 3).T.ravel()
            assert np.abs(diff).max() < 1e-12 * np.abs(lp.half_a).max() * np.abs(lp.half_b).max()


# ---------------------------------------------------------------- chart sets

@pytest.mark.parametrize("name", sorted(PARAMETERIZATIONS))
@pytest.mark.parametrize("preset", [gosselin, general_3rrr])
def test_chart_maps_round_trip_and_angle_boxes_enclose(name, preset):
    build, ranges = mechanism_build(preset())
    charts = make_charts(name, build, ranges, "halves")
    rng = np.random.default_rng(6)
    nb, nv = 40, len(charts.variables)
    chart = rng.integers(0, charts.n_charts, nb)
    lo = rng.uniform(0, 0.9, (nb, nv))
    hi = lo + rng.uniform(0, 1e-3, (nb, nv))
    alo, ahi = charts.angle_box(chart, lo, hi)
    for _ in range(20):
        x = lo + (hi - lo) * rng.uniform(0, 1, (nb, nv))
        a = charts.angles(chart, x)
        d_lo = np.mod(a - alo + math.pi, 2 * math.pi) - math.pi
        d_hi = np.mod(ahi - a + math.pi, 2 * math.pi) - math.pi
        assert np.all(d_lo >= -1e-12) and np.all(d_hi >= -1e-12)
    if name == "tan-half":
        theta = rng.uniform(-math.pi, math.pi, len(charts.unknowns))
        for c in range(charts.n_charts):
            centre = charts.shift[c]
            inside = np.abs(np.mod(theta - centre + math.pi, 2 * math.pi) - math.pi) < math.pi / 2
            if inside.all():
                t = np.tan(0.5 * (np.mod(theta - centre + math.pi, 2 * math.pi) - math.pi))
                x = (t - charts.map_lo[c]) / (charts.map_hi[c] - charts.map_lo[c])
                got = charts.angles(np.array([c]), x[None])[0]
                np.testing.assert_allclose(np.mod(got - theta + math.pi, 2 * math.pi) - math.pi, 0, atol=1e-12)
    else:
        assert charts.n_charts == 1
        theta = rng.uniform(-math.pi, math.pi, len(charts.unknowns))
        cs = np.stack([np.cos(theta), np.sin(theta)], -1).ravel()
        x = (cs - charts.map_lo[0]) / (charts.map_hi[0] - charts.map_lo[0])
        np.testing.assert_allclose(charts.angles(np.array([0]), x[None])[0], theta, atol=1e-12)


def test_tan_half_chart_angles_are_the_chart_unknowns_angles():
    """One map from unit box to angle: a tan-half chart's angles are those of the closure Unknown
    over that chart's range (both call closure.tan_half_angle)."""
    mech = general_3rrr()
    build, ranges = mechanism_build(mech)
    charts = make_charts("tan-half", build, ranges, "halves")
    per_name = [charts_for_range(ranges[n]) for n in charts.unknowns]
    combos = list(itertools.product(*per_name))
    assert len(combos) == charts.n_charts
    x = np.random.default_rng(8).uniform(0, 1, (charts.n_charts, len(charts.unknowns)))
    got = charts.angles(np.arange(charts.n_charts), x)
    want = np.array([[Unknown(n, *rng).to_angle(xi) for n, rng, xi in zip(charts.unknowns, combo, row)]
                     for combo, row in zip(combos, x)])
    assert np.array_equal(got, want)


def test_sin_cos_has_one_circle_equation_per_unknown():
    build, ranges = mechanism_build(gosselin())
    charts = make_charts("sin-cos", build, ranges, "halves")
    circles = [b for b, labels in enumerate(charts.labels) if labels[0].startswith("circle")]
    assert len(circles) == len(charts.unknowns) == 6
    rng = np.random.default_rng(7)
    x = rng.uniform(0, 1, (10, 12))
    cs = charts.map_lo[0] + (charts.map_hi[0] - charts.map_lo[0]) * x
    for k, b in enumerate(circles):
        got = bernstein.evaluate(charts.coeffs[b][0], x, nvars=12)[0]
        np.testing.assert_allclose(got, cs[:, 2 * k] ** 2 + cs[:, 2 * k + 1] ** 2 - 1, atol=1e-14)
        assert charts.square[b] == (0,)
    assert sum(len(s) for s in charts.square) == 12       # 2 loops x 3 + 6 circles: a square system


def test_tan_half_charts_cover_full_circles_with_two_charts_each():
    build, ranges = mechanism_build(gosselin())
    charts = make_charts("tan-half", build, ranges, "transversal")
    assert charts.n_charts == 2 ** 6
    assert np.allclose(np.abs(charts.map_lo), 1) and np.allclose(np.abs(charts.map_hi), 1)
    assert set(np.round(charts.shift.ravel(), 12)) == {0.0, round(math.pi, 12)}


def test_unknown_parameterization_lists_valid_ones():
    build, ranges = mechanism_build(gosselin())
    with pytest.raises(ValueError) as err:
        make_charts("quaternion", build, ranges, "halves")
    assert "quaternion" in str(err.value) and all(n in str(err.value) for n in PARAMETERIZATIONS)


def test_the_registry_lists_exactly_tan_half_and_sin_cos():
    assert list(PARAMETERIZATIONS) == ["tan-half", "sin-cos"]
    assert [PARAMETERIZATIONS[n] for n in PARAMETERIZATIONS] == [TanHalf, SinCos]
    assert all(issubclass(cls, LoopParameterization) for cls in PARAMETERIZATIONS.values())


def test_an_unknown_parameterization_is_the_registry_error():
    build, ranges = mechanism_build(gosselin())
    expected = f"parameterization: expected one of {list(PARAMETERIZATIONS)}, got 'quaternion'"
    with pytest.raises(ValueError, match=re.escape(expected)):
        make_charts("quaternion", build, ranges, "halves")


@pytest.mark.parametrize("name", list(PARAMETERIZATIONS))
def test_a_chart_set_is_frozen_and_holds_its_parameterization_object(name):
    build, ranges = mechanism_build(gosselin())
    charts = make_charts(name, build, ranges, "halves")
    assert type(charts.parameterization) is PARAMETERIZATIONS[name]
    with pytest.raises(dataclasses.FrozenInstanceError):
        charts.accept_width = 2.0


def test_a_registered_parameterization_is_accepted_by_the_lookup(registered):
    class TanHalfAgain(TanHalf):
        name = "tan-half-again"

    registered(PARAMETERIZATIONS, TanHalfAgain)
    build, ranges = mechanism_build(gosselin())
    got, want = make_charts("tan-half-again", build, ranges, "halves"), make_charts("tan-half", build, ranges, "halves")
    assert isinstance(got.parameterization, TanHalfAgain) and got.n_charts == want.n_charts
    assert all(np.array_equal(g, w) for g, w in zip(got.coeffs, want.coeffs))
    problem = spherekin.compile(gosselin(), formulation="halves", parameterization="tan-half-again")
    assert problem.strategy.parameterization == "tan-half-again"


def test_circle_bounds_against_dense_samples_of_the_circle():
    """circle_bounds(rectangle) vs brute force: 200,000 points of the unit circle, those inside each
    random rectangle, and their bounding box. The bounds must contain every sample (soundness) and
    exceed the samples' box by no more than the sampling gap (tightness); empty iff no sample."""
    from spherekin.search.parameterizations import CIRCLE_SLACK, circle_bounds

    theta = np.linspace(-np.pi, np.pi, 200_001)
    pc, ps = np.cos(theta), np.sin(theta)
    gap = 2 * np.pi / 200_000 + CIRCLE_SLACK
    rng = np.random.default_rng(4)
    n_empty = n_cut = 0
    for _ in range(300):
        c = np.sort(rng.uniform(-1.2, 1.2, 2))
        s = np.sort(rng.uniform(-1.2, 1.2, 2))
        (clo, slo), (chi, shi) = circle_bounds(*(np.array([v]) for v in (c[0], c[1], s[0], s[1])))
        inside = (pc >= c[0]) & (pc <= c[1]) & (ps >= s[0]) & (ps <= s[1])
        if not inside.any():
            # no sample inside: either truly empty or a sliver thinner than the sampling gap
            assert clo[0] > chi[0] or (chi[0] - clo[0] < 4 * gap and shi[0] - slo[0] < 4 * gap)
            n_empty += clo[0] > chi[0]
            continue
        sc, ss = pc[inside], ps[inside]
        assert clo[0] <= sc.min() and sc.max() <= chi[0]
        assert slo[0] <= ss.min() and ss.max() <= shi[0]
        assert clo[0] >= sc.min() - 2 * gap and chi[0] <= sc.max() + 2 * gap
        assert slo[0] >= ss.min() - 2 * gap and shi[0] <= ss.max() + 2 * gap
        n_cut += (chi[0] - clo[0] < c[1] - c[0] - 1e-3) or (shi[0] - slo[0] < s[1] - s[0] - 1e-3)
    assert n_empty > 10 and n_cut > 50


def test_contract_does_nothing_for_tan_half_and_keeps_roots_for_sin_cos():
    """The circle contraction must keep every point of the circles c_k^2 + s_k^2 = 1; the points
    tried are passive angles of inverse-kinematics configurations (not solver output)."""
    from scipy.spatial.transform import Rotation

    mech = gosselin()
    names = mech.loop_unknowns
    ranges = {n: mech.ranges[n] for n in names}

    def build(chart):
        system = mech.loop_system((0.3, -0.2, 0.5), chart)
        return system.loops, system.unknowns

    tan = make_charts("tan-half", build, ranges, "halves")
    rlo, rhi = np.full((1, 6), 0.25), np.full((1, 6), 0.75)
    tan.contract(np.zeros(1, dtype=int), np.zeros((1, 6)), np.ones((1, 6)), rlo, rhi)
    assert np.all(rlo == 0.25) and np.all(rhi == 0.75)
    sc = make_charts("sin-cos", build, ranges, "halves")
    roots = [[sol.joint_angles[n] for n in names] for seed in range(2)
             for sol in mech.inverse_kinematics(Rotation.random(random_state=seed).as_matrix())]
    chart = np.zeros(len(roots), dtype=int)
    # boxes of unit side 0.2 around each configuration's (c, s) point: contraction keeps the point
    pts = np.array([[f(a) for a in angles for f in (np.cos, np.sin)] for angles in roots])
    u = (pts - sc.map_lo[chart]) / (sc.map_hi[chart] - sc.map_lo[chart])
    lo, hi = np.clip(u - 0.1, 0, 1), np.clip(u + 0.1, 0, 1)
    tlo, thi = lo.copy(), hi.copy()          # reductions of the whole chart box [0, 1]^N
    sc.contract(chart, np.zeros_like(lo), np.ones_like(hi), tlo, thi)
    assert np.all(tlo <= u + 1e-12) and np.all(u - 1e-12 <= thi)
    assert np.all(thi - tlo <= hi - lo + 1e-15)


def test_too_many_charts_is_one_error_before_any_chart_is_built():
    """2^n charts for n full-circle joints (issue 42: a 25-joint chain grew to 4.3 GB before its first
    box): past MAX_CHARTS the count is refused, naming the joints, before ``build`` is ever called;
    at MAX_CHARTS exactly the count is not what stops it."""
    from spherekin.search.parameterizations import MAX_CHARTS, make_charts

    def build(_):
        raise AssertionError("build called: the charts were materialised before the count was checked")

    n = int(math.log2(MAX_CHARTS)) + 1
    with pytest.raises(ValueError, match=f"{2 ** n:,} charts .*MAX_CHARTS.*sin-cos"):
        make_charts("tan-half", build, {f"j{k}": None for k in range(n)}, "halves")
    narrow = {f"j{k}": (None if k < n - 1 else (0.0, 1.0)) for k in range(n)}    # one joint narrower than pi
    with pytest.raises(AssertionError, match="build called"):
        make_charts("tan-half", build, narrow, "halves")
