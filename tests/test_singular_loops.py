"""Certified singular inputs of mechanisms with several loops (issue 31 item 6): the spherical six-bars.

D = det K_p of the loop equations (:func:`spherekin.systems.singular.det_plan`) is checked against two
references written here, independent of the Bernstein code and of K_p:

* Watt I six-bar (examples/watt_six_bar.toml): two four-bars in series. At crank input A, joint C lies on
  the circle of radius arc(B, C) about B(A) and on the circle arc(D, C) about D (ground): 0 or 2 points;
  each places the coupler, and joint F lies on the circles arc(E, F) about E(A) and arc(G, F) about G: 0 or 2.
  The number of assemblies is the sum; it changes where two assemblies meet (a parallel singularity).
* Stephenson six-bar (examples/stephenson_six_bar.toml): ternary2 = Rot(F, phi) Rot(G, psi) (the chain
  ground - link4 - ternary2); the links B-C and D-E give r_i = a_i(phi) + b_i(phi) cos psi + c_i(phi) sin psi
  = 0 (i = 1, 2), and eliminating psi (Cramer, cos^2 + sin^2 = 1) leaves the degree-8 polynomial
  h(t) = (a2 c1 - a1 c2)^2 + (a1 b2 - a2 b1)^2 - (b1 c2 - b2 c1)^2 in t = tan((phi - phi0) / 2) (each of a, b,
  c times 1 + t^2): its real roots are the assemblies.

Along the input line both counts are sampled densely and each change located by bisection (to BISECT_TOL):
the reference singular inputs. Invariants (as tests/test_singular.py): every reference input lies in a box
of the cover, every box lies within its width of one.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

import spherekin
from spherekin.systems.singular import MAX_DET_COEFFS, SingularPlane, det_plan, LoopPlane
from singular_refs import EXAMPLES, _circle_intersections, arc, rodrigues

#: Bisection of a count change stops at this width (radians of input): far below the cells' width.
BISECT_TOL = 1e-10
#: A root of h (companion eigenvalue) is real when its imaginary part is below this (relative to 1 + |t|):
#: near a merging pair the parts grow like sqrt(distance to the fold), so the count is wrong only within
#: ~1e-14 rad of it; rounding of well separated roots stays ~1e-12.
REAL_TOL = 1e-7
#: Closed boxes: a reference point on a box edge counts as inside within this.
EDGE = 1e-9


def graph_axes(path) -> dict[str, np.ndarray]:
    """Joint name -> unit axis (reference configuration, every reading 0) of a kind "graph" file (tomllib)."""
    data = tomllib.loads(path.read_text())
    assert data["kind"] == "graph"
    return {j["name"]: np.asarray(j["axis"], float) / np.linalg.norm(j["axis"]) for j in data["joints"]}


def _frame(p, q) -> np.ndarray:
    """Orthonormal columns (p, n, p x n), n = unit(p x q): R maps the frame of (p0, q0) to (p, q) by R = F F0^T."""
    n = np.cross(p, q)
    n = n / np.linalg.norm(n)
    return np.column_stack([p, n, np.cross(p, n)])


def watt_count(ax, a: float) -> int:
    """Assemblies of the Watt six-bar at input A = a (radians), by circle intersections (module doc)."""
    r1 = rodrigues(ax["A"], a)
    b, e = r1 @ ax["B"], r1 @ ax["E"]
    cs = _circle_intersections(b, arc(ax["B"], ax["C"]), ax["D"], arc(ax["D"], ax["C"]))
    if cs is None:
        return 0
    n = 0
    for c in cs:
        r2 = _frame(b, c) @ _frame(ax["B"], ax["C"]).T         # the coupler: B -> b, C -> c
        fs = _circle_intersections(e, arc(ax["E"], ax["F"]), r2 @ ax["G"], arc(ax["G"], ax["F"]))
        n += 0 if fs is None else 2
    return n


def stephenson_h(ax, a: float, phi0: float) -> np.ndarray:
    """Coefficients (highest first, numpy.roots order) of h(t), t = tan((phi - phi0) / 2), at input A = a."""
    r1 = rodrigues(ax["A"], a)
    f, g = ax["F"], ax["G"]

    def circle(axis, v):                 # Rot(axis, x) v = v0 + cos x v1 + sin x v2
        v0 = (axis @ v) * axis
        return v0, v - v0, np.cross(axis, v)

    def poly(w0, w1, w2):                # (1 + t^2) (w0 + cos phi w1 + sin phi w2), phi = phi0 + 2 atan t: coefficients
        c, s = math.cos(phi0), math.sin(phi0)
        # cos phi = c cos u - s sin u, sin phi = s cos u + c sin u; (1 + t^2) cos u = 1 - t^2, (1 + t^2) sin u = 2t
        p1 = c * w1 + s * w2             # times cos u
        p2 = -s * w1 + c * w2            # times sin u
        return [w0 + p1, 2 * p2, w0 - p1]   # coefficients of 1, t, t^2

    out = []
    for near, far in (("B", "C"), ("D", "E")):
        target = r1 @ ax[near]           # the moving joint on ternary1
        k = float(ax[near] @ ax[far])
        # r = target . Rot(f, phi) Rot(g, psi) far0 - k = (Rot(f, -phi) target) . (u0 + cos psi u1 + sin psi u2) - k
        u = circle(g, ax[far])
        v0, v1, v2 = circle(f, target)   # Rot(f, -phi) target = v0 + cos phi v1 - sin phi v2
        vp = poly(v0, v1, -v2)
        coef = []
        for j, uj in enumerate(u):
            cj = [float(vk @ uj) for vk in vp]
            if j == 0:
                cj = [cj[0] - k, cj[1], cj[2] - k]      # - k (1 + t^2)
            coef.append(np.polynomial.Polynomial(cj))
        out.append(coef)
    (a1, b1, c1), (a2, b2, c2) = out
    h = (a2 * c1 - a1 * c2) ** 2 + (a1 * b2 - a2 * b1) ** 2 - (b1 * c2 - b2 * c1) ** 2
    return h.coef[::-1]


def stephenson_count(ax, a: float, phi0: float = 0.3) -> int:
    """Assemblies of the Stephenson six-bar at input A = a: the real roots of h (module doc); phi0 puts
    phi = phi0 + pi (t infinite) away from the roots."""
    roots = np.roots(stephenson_h(ax, a, phi0))
    return int(np.sum(np.abs(roots.imag) < REAL_TOL * (1.0 + np.abs(roots))))


def count_changes(count, lo: float, hi: float, n: int) -> np.ndarray:
    """The inputs in [lo, hi] where ``count`` (input -> int) changes: n samples, each change bisected."""
    xs = np.linspace(lo, hi, n)
    ks = [count(x) for x in xs]
    out = []
    for x0, x1, k0, k1 in zip(xs[:-1], xs[1:], ks[:-1], ks[1:]):
        if k0 == k1:
            continue
        while x1 - x0 > BISECT_TOL:
            m = 0.5 * (x0 + x1)
            if count(m) == k0:
                x0 = m
            else:
                x1 = m
        out.append(0.5 * (x0 + x1))
    return np.array(out)


def _check_cover(sset, ref, width_lo: float, width_hi: float) -> None:
    """Every reference input in [width_lo, width_hi] lies in a box; every box is within its width of one."""
    assert sset.complete and sset.system == "loops"
    inside = ref[(ref >= width_lo) & (ref <= width_hi)]
    assert len(inside)
    for r in inside:
        assert any(b.x[0] - EDGE <= r <= b.x[1] + EDGE for b in sset.boxes), r
    for b in sset.boxes:
        w = b.x[1] - b.x[0]
        assert np.min(np.abs(ref - 0.5 * (b.x[0] + b.x[1]))) <= w, b


def test_watt_six_bar_singular_inputs():
    """Watt I six-bar over a full turn of its crank: the cover holds each input where the circle-intersection
    count changes, every box is within its width of one, and each is proven ``singular``."""
    ax = graph_axes(EXAMPLES / "watt_six_bar.toml")
    assert watt_count(ax, 0.3) == 4
    ref = count_changes(lambda a: watt_count(ax, a), -math.pi, math.pi, 1000)
    assert len(ref) == 4
    sset = spherekin.singular(EXAMPLES / "watt_six_bar.toml", x=("A", -math.pi, math.pi), tol=0.05)
    _check_cover(sset, ref, -math.pi, math.pi)
    assert [b.status for b in sset.boxes] == ["singular"] * len(sset.boxes)


def test_stephenson_six_bar_singular_inputs():
    """Stephenson six-bar (two loops sharing F and G: det K_p has two Laplace terms) on an input range with
    three singular inputs, two of them 0.064 apart: the same invariants against the eliminant's root count."""
    ax = graph_axes(EXAMPLES / "stephenson_six_bar.toml")
    lo, hi = -1.1, -0.45
    ref = count_changes(lambda a: stephenson_count(ax, a), lo - 0.2, hi + 0.2, 400)
    assert np.sum((ref >= lo) & (ref <= hi)) == 3
    sset = spherekin.singular(EXAMPLES / "stephenson_six_bar.toml", x=("A", lo, hi), tol=0.05)
    _check_cover(sset, ref, lo, hi)
    assert sum(b.status == "singular" for b in sset.boxes) >= 3


@pytest.mark.parametrize("name", ["watt_six_bar", "stephenson_six_bar"])
def test_determinant_is_det_kp_at_assemblies(name):
    """D (Bernstein form, loop frames) at each solved assembly equals det K_p of the mechanism's Jacobians
    there (the code's other route, columns in the ground frame) times prod (1 + t_v^2)^(deg_v / 2): every
    Laplace term carries the same factors; signs included."""
    from spherekin.core import bernstein

    m = spherekin.load_mechanism(EXAMPLES / f"{name}.toml")
    lp = LoopPlane(m, SingularPlane(("A", -1.5, 1.5), None, {}))
    cs = lp.charts
    cols = [m.passive.index(n) for n in m.loop_unknowns]
    checked = 0
    for a in (-1.1,):                     # 4 assemblies of each six-bar
        for s in spherekin.solve(m, (a,)).solutions:
            angles = {**dict(zip(m.loop_unknowns, s.angles)), "A": a}
            v = np.array([[angles[n] for n in cs.variables]])
            chart = next(c for c in range(cs.n_charts) if np.all(np.abs(lp.unit(np.array([c]), v) - 0.5) <= 0.5))
            u = lp.unit(np.array([chart]), v)[0]
            t = np.tan((v[0] - cs.shift[chart]) / 2)
            scale = np.prod([(1 + t[k] ** 2) ** (d // 2) for k, d in enumerate(lp.plan.degrees)])
            kp = np.linalg.det(m.jacobians(angles)["K_p"][:, cols])
            assert abs(float(bernstein.evaluate(cs.coeffs[-1][chart, 0], u)) / scale - kp) < 1e-12
            checked += 1
    assert checked >= 4


def test_refuses_a_determinant_too_large(monkeypatch, capsys):
    """A det K_p over the coefficient cap is refused before any chart is built, in one line naming why."""
    import spherekin.systems.singular as sing
    from spherekin.cli import main

    m = spherekin.load_mechanism(EXAMPLES / "watt_six_bar.toml")
    assert det_plan(m, list(m.loop_unknowns) + ["A"]).coefficients == 27 <= MAX_DET_COEFFS
    monkeypatch.setattr(sing, "MAX_DET_COEFFS", 8)
    code = main(["singular", str(EXAMPLES / "watt_six_bar.toml"), "--x", "A=-1:1"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1
    assert err.startswith("spherekin: error: mechanism: det K_p of its 2 loops would have 27 Bernstein coefficients")


# ---------------------------------------------------------------- cusps on the loop equations (item 2 on loops)

def _five_bar_60_45(tmp_path):
    """examples/five_bar.toml with C moved so that its distal links are 60 and 45 deg (arc(B, C), arc(C, D)):
    folded, B and D stay 15 deg apart, so the circles of C about B and about D never coincide."""
    from singular_refs import general_axes

    text = (EXAMPLES / "five_bar.toml").read_text()
    ax = general_axes(EXAMPLES / "five_bar.toml")
    c = _circle_intersections(ax["B"], math.radians(60), ax["D"], math.radians(45))
    c = c[int(np.argmax(c[:, 2]))]
    old = "axis = [0.0, -0.1492223173516034, 0.9888036711118225]"
    assert old in text
    path = tmp_path / "five_bar_60_45.toml"
    path.write_text(text.replace(old, "axis = [" + ", ".join(repr(float(v)) for v in c) + "]"))
    return spherekin.load_mechanism(path)


def test_one_loop_five_bar_has_no_cusps(tmp_path):
    """A one-loop mechanism has at most 2 assemblies at an input (its 3 passive joints close a spherical 3R
    chain: two solutions or a continuum), so no three meet: no cusps. On a five-bar whose circles never
    coincide, the cusp system (curve + tangency, :meth:`LoopPlane.cusp_charts`) searched from the curve's cover
    over the whole plane is empty: a certified absence. Not vacuous: with r orthogonal to the left kernel l
    (the normal of a_C, a_D in the loop's frame link, constant on the curve) the tangency C_r = (l . r)(...)
    vanishes along the whole curve, the search keeps it, and none of its candidates is called a ``cusp`` (their
    roots are not isolated and adj(K~) r vanishes there)."""
    from spherekin.problem import CUSP_VECTORS
    from spherekin.search.boxloop import pruner_for, search_cover
    from spherekin.trust.singular import certify_cusps

    m = _five_bar_60_45(tmp_path)
    lp = LoopPlane(m, SingularPlane(("A", -math.pi, math.pi), ("E", -math.pi, math.pi), {}))
    assert [(c.joint, c.path) for c in lp.plan.loops[0]] == [("D", ()), ("C", ()), ("B", (("C", 1),))]
    cover = search_cover(lp.charts, pruner_for(lp.charts, "pp", None), 0.1, 10**6)
    chart, lo, hi = cover.accepted
    assert len(chart) and not len(cover.pending[0])
    start = (chart, lp.unit(chart, lo), lp.unit(chart, hi))
    sets = lp.cusp_charts(CUSP_VECTORS)
    found = search_cover(sets[0], pruner_for(sets[0], "pp", None), 0.05, 10**6, start=start)
    assert len(found.accepted[0]) == 0 and len(found.pending[0]) == 0
    assert certify_cusps(lp, sets, found, lp.closes) == ()
    r_bad = np.asarray(m.joint("C").axis, float)               # orthogonal to l = a_C x a_D
    bad = lp.cusp_charts([r_bad, CUSP_VECTORS[1]])
    found = search_cover(bad[0], pruner_for(bad[0], "pp", None), 0.1, 10**6, start=start)
    assert len(found.accepted[0]) > 100
    cands = certify_cusps(lp, bad, found, lp.closes)
    assert cands and all(c.status == "unresolved" for c in cands)


def test_two_loop_plane_matches_the_platform_oracle():
    """general_3rrr as a graph (two loops sharing gamma1, delta1: det K_p has two Laplace terms) on the loop
    equations, in a 0.4 x 0.4 square of the plane beta3 = 0.5: every singular input that the degree-8
    oracle's root count locates along lines across the square (tests/singular_refs.py) lies in a covered cell,
    and the reference finds a singular input on the boundary of each ``singular`` cell widened by half its
    width (as tests/test_singular.py checks the platform system)."""
    from spherekin.search.boxloop import pruner_for, search_cover
    from spherekin.trust.singular import Grid, certify_cover
    from singular_refs import singular_points_on_line

    m = spherekin.load_mechanism(EXAMPLES / "general_3rrr_graph.toml")
    (x0, x1), (y0, y1), t = (0.9, 1.3), (1.1, 1.5), 0.1
    lp = LoopPlane(m, SingularPlane(("beta1", x0, x1), ("beta2", y0, y1), {"beta3": 0.5}))
    assert len(lp.plan.terms) == 2
    grid = Grid.over(lp.plane.axes, t)
    cover = search_cover(lp.charts, pruner_for(lp.charts, "pp", None), 0.5 * t, 10**6)
    assert not len(cover.pending[0])
    cells = certify_cover(lp, cover, grid)
    boxes = [(grid.edges(0, c.i), grid.edges(1, c.j), c.status) for c in cells]
    lines = [((x0, y0), (x1, y1)), ((x0, y1), (x1, y0)), ((x0, 1.3), (x1, 1.35)), ((1.1, y0), (1.15, y1))]
    ref = [s.inputs[:2] for p0, p1 in lines for s in singular_points_on_line(p0, p1, n_samples=40, seed=0)]
    assert len(ref) >= 3
    for p in ref:
        assert any(bx[0] - EDGE <= p[0] <= bx[1] + EDGE and by[0] - EDGE <= p[1] <= by[1] + EDGE
                   for bx, by, _ in boxes), p
    sing = [(bx, by) for bx, by, s in boxes if s == "singular"]
    assert len(sing) >= 3
    for (a0, a1), (b0, b1) in sing:
        w = a1 - a0
        u0, u1, v0, v1 = a0 - w / 2, a1 + w / 2, b0 - w / 2, b1 + w / 2
        edges = [((u0, v0), (u1, v0)), ((u1, v0), (u1, v1)), ((u1, v1), (u0, v1)), ((u0, v1), (u0, v0))]
        assert any(singular_points_on_line(p0, p1, n_samples=12, seed=1) for p0, p1 in edges), (a0, b0)
