"""Tests for spherekin.search.formulations against independent derivations.

* embed: a random loop tensor evaluated at a loop's own coordinates equals the embedded tensor
  evaluated at global points (the loop's coordinates are a permuted subset of the global ones);
* the equation blocks evaluated with the Bernstein core equal q_n times entries of the closure
  matrix computed by direct numeric matrix products (rotations.normalized_closure);
* closed configurations are built from random spherical polygons measured from their vertices
  (verification.spherical, first principles) and normalized by the corrected Eq. (2) rule;
  there every equation vanishes; at F = diag(1, -1, -1) only the transversal entries vanish;
* the transversal entries have a Jacobian of rank 3 at a regular closed configuration (finite
  differences of the numeric matrix product), while the scalar equation has a double root;
* the halves equations q_a q_b (P - S^T) equal numeric products of the two halves of the loop;
  their bilinear form (what the solver restricts) equals the dense block at random points.
"""

import dataclasses
import math
import re

import numpy as np
import pytest

from spherekin.core import bernstein
from spherekin.closure import ClosureLoop, Unknown
from spherekin.search.formulations import (FORMULATIONS, ChartBilinear, Formulation, Halves, Paper, Transversal,
                                          formulate_polynomials)
from tests.formulate_cases import embed, formulate
from spherekin.core.rotations import normalize_polygon, normalized_closure
from verification.spherical import exterior_angles, random_polygon, side_lengths
from conftest import wrap

#: Closure at a random polygon's normalized angles holds to rounding (products of ~10 rotations).
CLOSURE_TOL = 1e-12
#: An equation "vanishes" when its value is below this fraction of its largest control point.
ROOT_REL_TOL = 1e-12
#: Central finite-difference step in unit-box coordinates (error ~ h^2 ~ 1e-10 relative).
FD_STEP = 1e-5
#: Agreement of finite-difference Jacobians (truncation ~h^2 plus rounding ~eps/h).
FD_TOL = 1e-7


# ---------------------------------------------------------------- closed loops from polygons

def closed_polygon_angles(rng, m):
    """phi_1..phi_2m of a random closed spherical m-gon (Eq. 2, corrected index rule)."""
    vertices = random_polygon(rng, m)
    phis = normalize_polygon(side_lengths(vertices), exterior_angles(vertices))
    assert np.abs(normalized_closure(phis) - np.eye(3)).max() < CLOSURE_TOL
    return phis



def new_unknown(rng, name, theta):
    """An Unknown whose range contains theta strictly inside (width < 2.4 rad)."""
    return Unknown(name, theta - rng.uniform(0.3, 1.2), theta + rng.uniform(0.3, 1.2))


def factor_for(unknown, theta, phi, kind):
    """A factor of angle phi when unknown = theta: theta itself, theta + offset or offset - theta."""
    if kind == "plain":
        assert abs(wrap(phi - theta)) < 1e-15
        return unknown
    if kind == "plus":
        return unknown + (phi - theta)
    if kind == "minus":
        return (phi + theta) - unknown
    raise AssertionError(kind)


def loop_from(phis, assignments):
    """ClosureLoop with phis as known factors except assignments {index: (unknown, theta, kind)}."""
    return ClosureLoop([factor_for(*assignments[i][:2], phi, assignments[i][2]) if i in assignments else float(phi)
                        for i, phi in enumerate(phis)])


def closed_single_loop(seed):
    """One closed loop (triangle, 6 factors) with 3 unknowns of mixed kinds, and its true angles."""
    rng = np.random.default_rng(seed)
    phis = closed_polygon_angles(rng, 3)
    idx = sorted(rng.choice(6, size=3, replace=False))
    kinds = ["plain", "plus", "minus"]
    assignments, truth = {}, {}
    for j, (i, kind) in enumerate(zip(idx, kinds)):
        theta = wrap(phis[i]) if kind == "plain" else rng.uniform(-2.5, 2.5)
        u = new_unknown(rng, f"u{j}", theta)
        assignments[i] = (u, theta, kind)
        truth[u] = theta
    return phis, assignments, truth


def closed_two_loops(seed):
    """Two closed loops (a quadrilateral and a triangle) sharing one unknown, plus an unknown in
    neither loop; global unknowns in an order unrelated to the loops' axis orders."""
    rng = np.random.default_rng(seed)
    pa, pb = closed_polygon_angles(rng, 4), closed_polygon_angles(rng, 3)
    thetas = rng.uniform(-2.5, 2.5, 5)
    s, a1, a2, b1, idle = (new_unknown(rng, nm, th) for nm, th in zip(("s", "a1", "a2", "b1", "idle"), thetas))
    truth = dict(zip((s, a1, a2, b1, idle), thetas))
    loop_a = loop_from(pa, {1: (a2, truth[a2], "minus"), 4: (s, truth[s], "plus"), 6: (a1, truth[a1], "plus")})
    loop_b = loop_from(pb, {0: (b1, truth[b1], "minus"), 3: (s, truth[s], "minus")})
    unknowns = (b1, idle, a1, s, a2)
    return (loop_a, loop_b), unknowns, truth


def unit_coords(unknowns, truth):
    return np.array([float(u.to_unit(truth[u])) for u in unknowns])


def q_of(loop, x_loop):
    """q_n = prod (1 + t_k^2) over the loop's unknowns, t_k = t_lo + (t_hi - t_lo) x_k (Prop. 1)."""
    q = np.ones(x_loop.shape[:-1])
    for k, u in enumerate(loop.unknowns):
        t_lo, t_hi = u.t_range
        t = t_lo + (t_hi - t_lo) * x_loop[..., k]
        q = q * (1 + t * t)
    return q


def halves_numeric(loop, x_loop):
    """q_a q_b (P - S^T), row-major (..., 9): P the numeric product of the factors up to the
    loop's floor(k/2)-th unknown, S of the others, q_a, q_b over their unknowns."""
    phis = loop.angles(x_loop)
    unknown_factors = [i for i, f in enumerate(loop.factors) if hasattr(f, "unknown")]
    cut = unknown_factors[len(unknown_factors) // 2 - 1] + 1
    ka = sum(1 for i in unknown_factors if i < cut)
    p = normalized_closure(phis[..., :cut])
    s = normalized_closure(phis[..., cut:])
    qa = q_of(ClosureLoop(loop.factors[:cut]), x_loop[..., :ka])
    qb = q_of(ClosureLoop(loop.factors[cut:]), x_loop[..., ka:])
    diff = (p - np.swapaxes(s, -1, -2)) * (qa * qb)[..., None, None]
    return diff.reshape(diff.shape[:-2] + (9,))


def numeric_equations(loop, x_loop, formulation):
    """Values of the formulation's equations from the numeric closure matrix, shape (..., E)."""
    f = loop.closure_matrix(x_loop)
    q = q_of(loop, x_loop)
    scalar = q * (f[..., 0, 0] + f[..., 1, 1] - 2.0)
    if formulation == "paper":
        return scalar[..., None]
    lower = np.stack([q * f[..., 1, 0], q * f[..., 2, 0], q * f[..., 2, 1]], axis=-1)
    if formulation == "halves":   # the pruned block (P - S^T), then the square block (transversal)
        return np.concatenate([halves_numeric(loop, x_loop), lower], axis=-1)
    return np.concatenate([lower, scalar[..., None]], axis=-1)


def loop_positions(loop, unknowns):
    return [next(i for i, g in enumerate(unknowns) if g is u) for u in loop.unknowns]


# ---------------------------------------------------------------- embed

@pytest.mark.parametrize("seed", [0, 1])
def test_embed_matches_loop_coordinates(seed):
    rng = np.random.default_rng(seed)
    loops, unknowns, _ = closed_two_loops(seed)
    x = rng.uniform(0, 1, size=(20, len(unknowns)))
    for loop in loops:
        k = len(loop.unknowns)
        tensor = rng.normal(size=(2,) + (3,) * k)   # asymmetric, so a wrong axis order shows
        out = embed(loop, tensor, unknowns)
        pos = loop_positions(loop, unknowns)
        assert out.shape == (2,) + tuple(3 if i in pos else 1 for i in range(len(unknowns)))
        np.testing.assert_allclose(bernstein.evaluate(out, x, nvars=len(unknowns)),
                                   bernstein.evaluate(tensor, x[:, pos], nvars=k), rtol=1e-12, atol=1e-12)


def test_embed_rejects_foreign_unknown():
    loops, unknowns, _ = closed_two_loops(0)
    lookalike = Unknown("s", -1.0, 1.0)  # same name as the shared unknown, different object
    others = tuple(lookalike if u.name == "s" else u for u in unknowns)
    with pytest.raises(ValueError, match="'s'"):
        embed(loops[0], loops[0].scalar_control_points(), others)


# ---------------------------------------------------------------- blocks vs numeric products

@pytest.mark.parametrize("formulation", sorted(FORMULATIONS))
def test_blocks_equal_numeric_closure_entries(formulation):
    rng = np.random.default_rng(5)
    loops, unknowns, _ = closed_two_loops(3)
    blocks = formulate(formulation, loops, unknowns)
    per_loop = 2 if formulation == "halves" else 1        # halves: a pruned and a square-only block
    assert [b.loop_index for b in blocks] == [0] * per_loop + [1] * per_loop
    assert [b.prune for b in blocks] == [True, False][:per_loop] * 2
    x = rng.uniform(0, 1, size=(25, len(unknowns)))
    for j, loop in enumerate(loops):
        mine = [b for b in blocks if b.loop_index == j]
        pos = loop_positions(loop, unknowns)
        assert all(b.variables == tuple(sorted(pos)) for b in mine)
        expected = numeric_equations(loop, x[:, pos], formulation)                           # (P, E)
        got = np.concatenate([bernstein.evaluate(b.coeffs, x, nvars=len(unknowns)) for b in mine]).T
        scale = np.concatenate([b.scale for b in mine])
        assert got.shape == expected.shape == (25, sum(len(b.labels) for b in mine))
        np.testing.assert_allclose(got, expected, rtol=1e-10, atol=1e-12 * scale.max())
        # convex-hull property: |value| <= scale >= max |control point| on the unit box
        assert np.all(np.abs(got) <= scale * (1 + 1e-12))


# ---------------------------------------------------------------- closed configurations

@pytest.mark.parametrize("formulation", sorted(FORMULATIONS))
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_every_equation_vanishes_at_closure(formulation, seed):
    loops, unknowns, truth = closed_two_loops(seed)
    x = unit_coords(unknowns, truth)
    assert np.all((x > 0) & (x < 1))
    for block in formulate(formulation, loops, unknowns):
        vals = bernstein.evaluate(block.coeffs, x, nvars=len(unknowns))
        assert np.all(np.abs(vals) <= ROOT_REL_TOL * block.scale), (block.labels, vals, block.scale)
    # control: moving one shared unknown away from closure makes some equation clearly nonzero
    off = x.copy()
    off[[u.name for u in unknowns].index("s")] += 0.05
    worst = max(np.max(np.abs(bernstein.evaluate(b.coeffs, off, nvars=len(unknowns))) / b.scale)
                for b in formulate(formulation, loops, unknowns))
    assert worst > 1e-4


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rotation_by_pi_keeps_transversal_zero_but_not_scalar(seed):
    """F = Rx(pi) F_closed = diag(1, -1, -1): the transversal entries vanish, f11 + f22 - 2 = -2."""
    phis, assignments, truth = closed_single_loop(seed)
    shifted = phis.copy()
    shifted[0] += math.pi
    if assignments.get(0, (None, None, ""))[2] == "plain":  # an unknown factor: pi goes into an offset
        u, theta, _ = assignments[0]
        assignments = {**assignments, 0: (u, theta, "plus")}
    loop = loop_from(shifted, assignments)
    unknowns = loop.unknowns
    x = unit_coords(unknowns, truth)
    np.testing.assert_allclose(loop.closure_matrix(x), np.diag([1.0, -1.0, -1.0]), atol=1e-12)
    (block,) = formulate("transversal", [loop], unknowns)
    vals = bernstein.evaluate(block.coeffs, x, nvars=len(unknowns))
    assert np.all(np.abs(vals[:3]) <= ROOT_REL_TOL * block.scale[:3])
    np.testing.assert_allclose(vals[3], -2.0 * q_of(loop, x), rtol=1e-12)
    (paper_block,) = formulate("paper", [loop], unknowns)
    np.testing.assert_allclose(bernstein.evaluate(paper_block.coeffs, x, nvars=len(unknowns))[0],
                               -2.0 * q_of(loop, x), rtol=1e-12)
    # the halves formulation has no spurious root there: P - S^T = (diag(1,-1,-1) - I) S^T != 0
    halves_block, square_block = formulate("halves", [loop], unknowns)
    vals = bernstein.evaluate(square_block.coeffs, x, nvars=len(unknowns))
    assert np.all(np.abs(vals) <= ROOT_REL_TOL * square_block.scale)
    assert np.abs(bernstein.evaluate(halves_block.coeffs, x, nvars=len(unknowns))).max() > 0.5


@pytest.mark.parametrize("formulation", ["transversal", "halves"])
def test_bilinear_form_equals_the_dense_blocks(formulation):
    """The solver restricts the loop's halves and assembles their outer products; on the unit box
    (and on any sub-box) that must be the same polynomial as the dense block."""
    rng = np.random.default_rng(8)
    loops, unknowns, _ = closed_two_loops(4)
    for block in formulate(formulation, loops, unknowns):
        bil = block.bilinear
        assert bil is not None and set(bil.a_vars).isdisjoint(bil.b_vars)
        assert tuple(sorted(bil.a_vars + bil.b_vars)) == block.variables
        assert np.all(block.scale >= bil.magnitude() * (1 - 1e-15))
        x = rng.uniform(0, 1, size=(15, len(unknowns)))
        dense = bernstein.evaluate(block.coeffs, x, nvars=len(unknowns))
        ta = bernstein.evaluate(bil.a, x[:, list(bil.a_vars)], nvars=len(bil.a_vars))     # (U, P)
        tb = bernstein.evaluate(bil.b, x[:, list(bil.b_vars)], nvars=len(bil.b_vars))     # (V, P)
        e, u, v = (bil.terms[:, i].astype(int) for i in range(3))
        assembled = np.zeros_like(dense)
        np.add.at(assembled, e, bil.terms[:, 3, None] * ta[u] * tb[v])
        np.testing.assert_allclose(assembled, dense, atol=1e-12 * block.scale.max())


@pytest.mark.parametrize("formulation", ["transversal", "halves"])
def test_chart_bilinear_assembly_equals_the_reference_assembly_on_sub_boxes(formulation):
    """ChartBilinear.assemble (the box loop's sparse sums, reordered to the global variables) equals
    Bilinear.assemble (the dense reference) on halves restricted to random boxes of several charts."""
    rng = np.random.default_rng(21)
    loops, unknowns, _ = closed_two_loops(4)
    n = len(unknowns)
    for block in formulate(formulation, loops, unknowns):
        bil = block.bilinear
        # three "charts": the form and two copies with perturbed halves (same terms and variables)
        forms = [bil] + [dataclasses.replace(bil, a=bil.a * rng.uniform(0.5, 2.0, bil.a.shape),
                                             b=bil.b + rng.normal(0, 0.1, bil.b.shape)) for _ in range(2)]
        stacked = ChartBilinear.stack(forms, n)
        chart = np.array([0, 2, 1, 2, 0])
        lo = rng.uniform(0.0, 0.5, (len(chart), n))
        hi = lo + rng.uniform(0.05, 0.5, (len(chart), n))
        av, bv = list(bil.a_vars), list(bil.b_vars)
        ra = bernstein.restrict_batch_last(np.take(stacked.a, chart, axis=-1), lo[:, av], hi[:, av])
        rb = bernstein.restrict_batch_last(np.take(stacked.b, chart, axis=-1), lo[:, bv], hi[:, bv])
        fast = stacked.assemble(ra, rb)
        assert fast.shape == block.coeffs.shape + (len(chart),)
        for k, c in enumerate(chart):
            ref = forms[c].assemble(ra[..., k], rb[..., k])             # (E, *dims_a, *dims_b)
            lv = av + bv
            ref = np.transpose(ref, (0,) + tuple(1 + int(i) for i in np.argsort(lv))).reshape(block.coeffs.shape)
            np.testing.assert_allclose(fast[..., k], ref, rtol=1e-13, atol=1e-13 * np.abs(ref).max())


def central_jacobian(fun, x, h=FD_STEP):
    cols = []
    for k in range(len(x)):
        e = np.zeros(len(x))
        e[k] = h
        cols.append((fun(x + e) - fun(x - e)) / (2 * h))
    return np.stack(cols, axis=-1)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_transversal_jacobian_full_rank_and_scalar_double_root(seed):
    phis, assignments, truth = closed_single_loop(seed)
    loop = loop_from(phis, assignments)
    unknowns = loop.unknowns
    x = unit_coords(unknowns, truth)
    (block,) = formulate("transversal", [loop], unknowns)

    def bern(z):
        return bernstein.evaluate(block.coeffs, z, nvars=3)

    def numeric(z):
        return numeric_equations(loop, z, "transversal")

    j_bern, j_num = central_jacobian(bern, x), central_jacobian(numeric, x)
    scale = block.scale.max()
    np.testing.assert_allclose(j_bern, j_num, atol=FD_TOL * scale)
    sv = np.linalg.svd(j_num[:3], compute_uv=False)
    assert sv[-1] > 1e-3 * sv[0], sv                       # simple root of the transversal entries
    # the scalar equation f11 + f22 - 2 <= 0 (trace of a rotation block) has a double root there
    assert np.abs(j_num[3]).max() < 1e-6 * scale
    rng = np.random.default_rng(seed)
    near = np.clip(x + rng.uniform(-0.05, 0.05, size=(50, 3)), 0, 1)
    assert np.all(bern(near)[3] <= 1e-12 * scale)


# ---------------------------------------------------------------- input validation

def test_unknown_formulation_name_lists_valid_ones():
    loops, unknowns, _ = closed_two_loops(0)
    with pytest.raises(ValueError) as err:
        formulate("bogus", loops, unknowns)
    for name in FORMULATIONS:
        assert repr(name) in str(err.value) or name in str(err.value)
    assert "bogus" in str(err.value)


def test_the_registry_lists_exactly_the_loop_formulations():
    assert list(FORMULATIONS) == ["paper", "transversal", "halves"]
    assert [FORMULATIONS[n] for n in FORMULATIONS] == [Paper, Transversal, Halves]
    assert all(issubclass(cls, Formulation) for cls in FORMULATIONS.values())
    # the parameterizations ask the class, not its name, whether Eq. (10) is needed on every loop
    assert [cls.uses_scalar for cls in FORMULATIONS.values()] == [True, True, False]


@pytest.mark.parametrize("call", [lambda: formulate_polynomials("bogus", [], 2),
                                  lambda: formulate("bogus", *closed_two_loops(0)[:2])],
                         ids=["formulate_polynomials", "formulate"])
def test_an_unknown_formulation_is_the_registry_error(call):
    with pytest.raises(ValueError, match=re.escape(f"formulation: expected one of {list(FORMULATIONS)}, got 'bogus'")):
        call()


def test_a_registered_formulation_is_accepted_by_the_lookup(registered):
    class ScalarOnly(Formulation):
        """Eq. (10) alone, as a strategy of its own (the paper's equations by another name)."""

        name = "scalar-only"

        def blocks(self, polys, n_vars):
            return Paper().blocks(polys, n_vars)

    registered(FORMULATIONS, ScalarOnly)
    loops, unknowns, _ = closed_two_loops(0)
    got, want = formulate("scalar-only", loops, unknowns), formulate("paper", loops, unknowns)
    assert [b.labels for b in got] == [b.labels for b in want]
    assert all(np.array_equal(g.coeffs, w.coeffs) for g, w in zip(got, want))


def test_no_loops_is_an_error():
    _, unknowns, _ = closed_two_loops(0)
    with pytest.raises(ValueError, match="loops"):
        formulate("transversal", [], unknowns)
