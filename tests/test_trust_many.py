"""finalize_many: the trust layer over every point of a chunk of inputs at once (issue 30, item 1).

For every input of a chunk, finalize_many must return what finalize returns for that input alone
(field for field); a chunk's points are only ever polished, certified and compared with their own
input's equations (the input-index column of the stacked stages). Independent checks: the closure
of every returned assembly evaluated by the mechanism's forward map (not the trust layer's
equations), and the number of real assemblies of the 3-RRRs against the degree-8 eigenvalue solve
of references/peers_closed_form.py.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from references.peers_closed_form import direct_kinematics, geometry_of
from spherekin.mechanism import five_bar, four_bar, general_3rrr, gosselin
from spherekin.problem import REFINE_FACTOR, REFINE_MAX_BOXES, REFINE_MIN_TOL, compile
from spherekin.search.boxloop import SolverLimitError
from spherekin.closure import closure_plan
from spherekin.core.angles import RANGE_TOL
from spherekin.systems import Passed, Proven
from spherekin.trust import solutions
from spherekin.trust.krawczyk import certify_many, certify_stacked, krawczyk_many, krawczyk_stacked
from spherekin.trust.solutions import LOCAL_CHART, finalize, finalize_many, is_proven
from spherekin.trust.transversal import stack_inputs, stack_systems

from conftest import GOSSELIN_INPUTS


def actuated_at(mech, *positions):
    """``mech`` with each leg's joints at ``positions`` actuated instead of its first (1: elbows)."""
    legs = tuple(dataclasses.replace(leg, joints=tuple(dataclasses.replace(j, actuated=(k in positions))
                                                       for k, j in enumerate(leg.joints))) for leg in mech.legs)
    return dataclasses.replace(mech, legs=legs, name="elbow-actuated " + mech.name)


def rocker_driven_four_bar():
    """The preset crank-rocker driven at its rocker pivot D instead of A: the rocker swings through
    a limited arc, so inputs beyond it have no assembly and its ends are folds."""
    mech = four_bar()
    legs = tuple(dataclasses.replace(leg, joints=tuple(dataclasses.replace(j, actuated=(j.name == "D"))
                                                       for j in leg.joints)) for leg in mech.legs)
    return dataclasses.replace(mech, legs=legs, name="rocker-driven " + mech.name)


class Chunk:
    """A compiled mechanism and, per input, the clusters and tol its solve hands to the trust layer
    (the platform search where it applies and isolates every root, else the loop equations': not the
    complete count, whose answers need no trust layer), with
    the refine callable of Problem._trust for that input."""

    def __init__(self, mech, rows):
        self.problem = compile(mech)
        self.mech = self.problem.mechanism
        self.names = self.problem.names
        self.inputs, self.clusters, self.tols = [], [], []
        for x in rows:
            values = self.mech.check_inputs(x)
            found = next(f for f in (c.search_one(values, None, None) for c in self.problem.chain)
                         if not isinstance(f, (Passed, Proven)))   # the first search whose clusters the trust layer proves
            if found.limit is not None:
                continue                      # a covering run (another tol): not this chunk's
            report, tol = found.report, found.tol
            self.inputs.append(values)
            self.clusters.append(report.clusters)
            self.tols.append(tol)
        assert len(set(self.tols)) <= 1
        self.tol = self.tols[0]

    def refine(self, k):
        values, s = self.inputs[k], self.problem.strategy

        def again(lo, hi, t):             # Problem._trust's refined search of a cluster's hull
            finer = t * REFINE_FACTOR
            if finer < REFINE_MIN_TOL:
                return None
            box = {n: (float(a) - RANGE_TOL, float(b) + RANGE_TOL) for n, a, b in zip(self.names, lo, hi)}
            try:
                sub = self.problem.compiled("loops").search_box(values, box, finer, min(s.max_boxes, REFINE_MAX_BOXES))
            except SolverLimitError:
                return None
            return sub.clusters, finer
        return again

    def many(self, idx=None):
        idx = range(len(self.inputs)) if idx is None else idx
        return finalize_many(self.mech, np.array([self.inputs[k] for k in idx]), self.names,
                             [self.clusters[k] for k in idx], self.tol, refine=lambda j: self.refine(list(idx)[j]))

    def one(self, k):
        return finalize(self.mech, self.inputs[k], self.names, self.clusters[k], self.tol, refine=self.refine(k))


def same(a, b, path="") -> None:
    """Assert a == b recursively: exact for strings, ints, bools and statuses; floats to 1e-12."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and a.keys() == b.keys(), path
        for k in a:
            same(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, (list, tuple)):
        assert isinstance(b, (list, tuple)) and len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            same(x, y, f"{path}[{i}]")
    elif isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        assert a.shape == b.shape, path
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12, err_msg=path)
    elif isinstance(a, (bool, np.bool_, str, int)) or a is None:
        assert type(a) is type(b) and a == b, (path, a, b)
    elif isinstance(a, float):
        assert isinstance(b, float), path
        assert (math.isnan(a) and math.isnan(b)) or a == b or abs(a - b) <= 1e-12 * max(1.0, abs(a)), (path, a, b)
    else:
        assert a == b, (path, a, b)


def same_entries(got, want, where=""):
    assert len(got) == len(want), f"{where}: {len(got)} entries, finalize gives {len(want)}"
    for i, (g, w) in enumerate(zip(got, want)):
        for f in dataclasses.fields(g):
            same(getattr(g, f.name), getattr(w, f.name), f"{where}[{i}].{f.name}")


def closes(mech, names, inputs, sol) -> bool:
    """The assembly closes every loop, by the mechanism's forward map (Eq. 2 from the geometry)."""
    joints = {**dict(zip(mech.actuated, inputs)), **dict(zip(names, sol.angles))}
    return max(mech.forward(joints).loop_residuals) < 1e-10


def common_case(sol) -> bool:
    """Whether an entry of finalize is finalize_many's common case: a proven point, the one point of
    its cluster, certified in floats, the cluster accounted for without sub-boxes (its hull covered
    by one Krawczyk test, or its members inside the certified box), nothing refined."""
    ev = sol.evidence
    cl = ev.get("cluster", {})
    return (is_proven(sol) and cl.get("points") == 1 and cl.get("unresolved_boxes") == 0
            and cl.get("subbox_tests") == (1 if ev.get("covers_cluster") else 0)
            and not cl.get("extended_precision_tests") and "refined" not in ev
            and "polished_in_extended_precision" not in ev and "found_by" not in ev
            and ev["krawczyk"]["angle_tolerance"] > 0)


def counting_finalize(monkeypatch):
    """Count the inputs finalize_many hands to the per-input finalize (the inputs off the fast path)."""
    calls = []
    orig = solutions.finalize

    def spy(mechanism, inputs, *a, **kw):
        calls.append(tuple(inputs))
        return orig(mechanism, inputs, *a, **kw)
    monkeypatch.setattr(solutions, "finalize", spy)
    return calls


# ---------------------------------------------------------------- the chunks

def chunk_general_3rrr():
    x = np.random.default_rng(1).uniform(-math.pi, math.pi, (64, 3))
    return Chunk(general_3rrr(), x)


def chunk_gosselin():
    x = np.random.default_rng(2).uniform(-math.pi, math.pi, (28, 3))
    # singular solutions at the symmetric input, the paper's inputs, and inputs 1e-8 from (0, 0, 0)
    special = [(0.0, 0.0, 0.0), GOSSELIN_INPUTS, (1e-8, 0.0, 0.0), (0.0, -1e-8, 1e-8)]
    return Chunk(gosselin(), [*special[:2], *x[:14], *special[2:], *x[14:]])


def fold_of(mech, a, b):
    """An input (radians) where the number of assemblies of the one-input ``mech`` changes, by bisection on the solve's count."""
    p = compile(mech)
    n_a = len(p.solve([a]).solutions)
    assert len(p.solve([b]).solutions) != n_a
    for _ in range(32):
        mid = 0.5 * (a + b)
        if len(p.solve([mid]).solutions) == n_a:
            a = mid
        else:
            b = mid
    return 0.5 * (a + b)


def chunk_four_bar():
    x = np.random.default_rng(3).uniform(-math.pi, math.pi, (48, 1))
    return Chunk(four_bar(), x)


def chunk_rocker_four_bar():
    mech = rocker_driven_four_bar()
    x = list(np.random.default_rng(4).uniform(-math.pi, math.pi, (24, 1)))
    p = compile(mech)
    grid = np.linspace(-math.pi, math.pi, 13)
    counts = [len(p.solve([g]).solutions) for g in grid]
    i = next(i for i in range(12) if counts[i] != counts[i + 1])
    fold = fold_of(mech, grid[i], grid[i + 1])
    near = [[fold + d] for d in (-1e-6, -1e-8, 1e-8, 1e-6)]
    return Chunk(mech, [*x[:12], *near, *x[12:]])


def chunk_five_bar():
    x = np.random.default_rng(5).uniform(-math.pi, math.pi, (64, 2))
    return Chunk(five_bar(), x)


def chunk_elbow_3rrr():
    """Inputs of assemblies (the elbow readings of random poses: most random inputs have none) and a few random ones."""
    mech = actuated_at(general_3rrr(), 1)
    rng = np.random.default_rng(6)
    poses = [np.linalg.qr(rng.normal(size=(3, 3)))[0] for _ in range(8)]
    reached = [mode.inputs for r in poses for mode in mech.inverse_kinematics(r * np.sign(np.linalg.det(r)))[:1]]
    return Chunk(mech, [*reached, *rng.uniform(-math.pi, math.pi, (4, 3))])


CHUNKS = {"general_3rrr": chunk_general_3rrr, "gosselin": chunk_gosselin, "four_bar": chunk_four_bar,
          "rocker_four_bar": chunk_rocker_four_bar, "five_bar": chunk_five_bar, "elbow_3rrr": chunk_elbow_3rrr}
_BUILT: dict = {}


def built(name) -> Chunk:
    if name not in _BUILT:
        _BUILT[name] = CHUNKS[name]()
    return _BUILT[name]


# ---------------------------------------------------------------- finalize_many is finalize, input for input

@pytest.mark.parametrize("name", list(CHUNKS))
def test_finalize_many_is_finalize_input_for_input(name, monkeypatch):
    ch = built(name)
    calls = counting_finalize(monkeypatch)
    got = ch.many()
    slow = len(calls)
    want = [ch.one(k) for k in range(len(ch.inputs))]
    for k, (g, w) in enumerate(zip(got, want)):
        same_entries(g, w, f"{name} input {k} {ch.inputs[k]}")
    # the inputs left to finalize are exactly those whose answer is not the common case (else a
    # fast-path stage refused points it should prove, e.g. tested in another input's system)
    # (a cluster without an entry, excluded or out of the ranges, may be either)
    off = {tuple(ch.inputs[k]) for k, w in enumerate(want) if not all(common_case(s) for s in w)}
    either = {tuple(ch.inputs[k]) for k, w in enumerate(want) if len(w) != len(ch.clusters[k])}
    assert off <= set(calls) <= off | either, (off, either, calls)
    assert slow < 0.5 * len(ch.inputs), f"{slow} of {len(ch.inputs)} inputs left the fast path"
    # independent: every proven assembly closes its own input's loops (the forward map)
    for k, entries in enumerate(got):
        for sol in entries:
            if is_proven(sol):
                assert closes(ch.mech, ch.names, ch.inputs[k], sol), (k, sol.angles)


def test_inputs_without_assemblies_and_next_to_folds_are_in_the_chunks():
    """The rocker-driven four-bar chunk holds inputs without any assembly (empty cluster lists and
    clusters that polish to nothing) and inputs 1e-8 from a fold; the Gosselin chunk singular
    solutions at (0, 0, 0), which leave the fast path."""
    ch = built("rocker_four_bar")
    out = ch.many()
    assert len(ch.inputs) == 28                        # none dropped, the four next to the fold included
    assert any(not o for o in out) and any(o for o in out)
    assert any(not c for c in ch.clusters)
    g = built("gosselin")
    sing = g.many([0])[0]
    assert sing and any(s.singularity != "regular" for s in sing)


@pytest.mark.parametrize("name", ["general_3rrr", "gosselin"])
def test_the_count_is_the_degree_8_count(name):
    """Away from parallel singularities (every entry proven), the number of assemblies is the
    number of real roots of the degree-8 eigenvalue solve (no joint ranges on these presets)."""
    ch = built(name)
    geo = geometry_of(ch.mech)
    checked = 0
    for k, entries in enumerate(ch.many()):
        if entries and all(is_proven(s) for s in entries) and \
                min(s.evidence["parallel_margin"] for s in entries) > 1e-3:
            poses = direct_kinematics(geo, ch.inputs[k])
            assert len(poses) == len(entries), ch.inputs[k]
            for s in entries:
                assert min(np.abs(s.platform_rotation - r).max() for r in poses) < 1e-8
            checked += 1
    assert checked >= 0.5 * len(ch.inputs)


# ---------------------------------------------------------------- chunks: sizes and mixing

@pytest.mark.parametrize("size", [1, 7, 256])
def test_chunk_size_does_not_change_the_answer(size):
    """Bit for bit: a stage gives a point the same floats alone or in a chunk of any size."""
    ch = built("general_3rrr")
    whole = ch.many()
    n = len(ch.inputs)
    for start in range(0, min(n, 3 * size), size):
        idx = list(range(start, min(n, start + size)))
        for k, entries in zip(idx, ch.many(idx)):
            assert len(entries) == len(whole[k])
            for a, b in zip(entries, whole[k]):
                assert np.array_equal(a.angles, b.angles) and a.status == b.status and a.evidence == b.evidence


def test_mixing_inputs_in_one_chunk_is_one_by_one():
    """Interleaved inputs (and mechanisms' own orders reversed) in one chunk, or each alone."""
    ch = built("five_bar")
    idx = list(range(len(ch.inputs)))[::-1]
    mixed = ch.many(idx)
    for k, entries in zip(idx, mixed):
        alone = ch.many([k])[0]
        assert len(entries) == len(alone)
        for a, b in zip(entries, alone):
            assert np.array_equal(a.angles, b.angles) and a.status == b.status and a.evidence == b.evidence


# ---------------------------------------------------------------- mutants: another input's equations

def test_a_point_is_certified_only_in_its_own_inputs_system():
    """certify_stacked: a root of input A is certified in A's system, never in B's (the which
    column); each result is certify_many's in the system it names."""
    ch = built("general_3rrr")
    a, b = next((i, j) for i in range(len(ch.inputs)) for j in range(i + 1, len(ch.inputs))
                if ch.many([i])[0] and ch.many([j])[0])
    systems = [ch.mech.loop_system(ch.inputs[k], {n: (-LOCAL_CHART, LOCAL_CHART) for n in ch.names}) for k in (a, b)]
    stack = stack_systems(systems)
    pts = np.array([s.angles for s in ch.many([a])[0]])
    own = certify_stacked(stack, np.zeros(len(pts), int), pts)
    other = certify_stacked(stack, np.ones(len(pts), int), pts)
    assert all(c.certified for c in own) and not any(c.certified for c in other)
    assert own == certify_many(systems[0], pts) and other == certify_many(systems[1], pts)
    # boxes too (the hull tests): each verdict is krawczyk_many's in the system ``which`` names
    lo, hi = pts - 1e-7, pts + 1e-7
    for which in (np.zeros(len(pts), int), np.ones(len(pts), int)):
        got = krawczyk_stacked(stack, which, lo, hi, pts)
        want = krawczyk_many(systems[which[0]], lo, hi, pts)
        assert np.array_equal(got.certified, want.certified) and np.array_equal(got.no_solution, want.no_solution)
        assert np.array_equal(got.krawczyk_lo, want.krawczyk_lo, equal_nan=True)
        assert got.certified.all() == (which[0] == 0) and not (which[0] == 1 and got.certified.any())


@pytest.mark.parametrize("name", ["general_3rrr", "five_bar"])
def test_a_stack_of_inputs_has_each_inputs_own_constants(name):
    """stack_inputs (constants from loop_constants, no system built per input) holds exactly the
    constants of each input's own loop_system, and builds that system when asked for it."""
    ch = built(name)
    chart = {n: (-LOCAL_CHART, LOCAL_CHART) for n in ch.names}
    rows = np.array(ch.inputs[:9])
    systems = [ch.mech.loop_system(tuple(r), chart) for r in rows]
    lazy, eager = stack_inputs(ch.mech, rows, chart), stack_systems(systems)
    assert np.array_equal(lazy.consts, eager.consts) and len(lazy.systems) == len(rows)
    assert lazy.closure.same_structure(eager.closure)
    built5 = lazy.systems[5]
    assert built5.inputs == systems[5].inputs and built5.names == systems[5].names
    assert np.array_equal(closure_plan(built5.loops, built5.unknowns, built5.loop_indices).offsets, eager.consts[5])


def test_swapped_clusters_are_not_certified_at_the_other_input():
    """Two inputs with their clusters swapped: a cluster's points are no roots of the other input,
    so no entry may be proven there unless it closes that input's loops, and finalize_many still
    agrees with finalize input for input."""
    ch = built("general_3rrr")
    a, b = 0, 1
    assert ch.clusters[a] and ch.clusters[b]
    got = finalize_many(ch.mech, np.array([ch.inputs[a], ch.inputs[b]]), ch.names, [ch.clusters[b], ch.clusters[a]],
                        ch.tol)
    for k, clusters, entries in ((a, ch.clusters[b], got[0]), (b, ch.clusters[a], got[1])):
        same_entries(entries, finalize(ch.mech, ch.inputs[k], ch.names, clusters, ch.tol), f"swapped {k}")
        for s in entries:
            assert not is_proven(s) or closes(ch.mech, ch.names, ch.inputs[k], s)
    assert not any(is_proven(s) for e in got for s in e)


def test_nearby_inputs_keep_their_own_roots():
    """Inputs 3e-8 apart in one chunk (with the clusters of the first): each proven entry is its own
    input's root (it closes that input's loops, by the forward map, and not the other's), as finalize
    gives it."""
    ch = built("general_3rrr")
    k = next(k for k in range(len(ch.inputs)) if ch.many([k])[0])
    x = np.array(ch.inputs[k])
    y = x + np.array([3e-8, 0.0, 0.0])
    got = finalize_many(ch.mech, np.array([x, y]), ch.names, [ch.clusters[k], ch.clusters[k]], ch.tol)
    for row, other, entries in ((x, y, got[0]), (y, x, got[1])):
        same_entries(entries, finalize(ch.mech, tuple(row), ch.names, ch.clusters[k], ch.tol), f"input {row}")
        proven = [s for s in entries if is_proven(s)]
        assert proven
        for s in proven:
            assert closes(ch.mech, ch.names, row, s) and not closes(ch.mech, ch.names, other, s)


def test_finalize_many_refuses_a_bad_chunk():
    ch = built("four_bar")
    with pytest.raises(ValueError, match="inputs: expected shape"):
        finalize_many(ch.mech, np.zeros((2, 3)), ch.names, [[], []], ch.tol)
    with pytest.raises(ValueError, match="clusters: expected one sequence"):
        finalize_many(ch.mech, np.zeros((2, 1)), ch.names, [[]], ch.tol)
    assert finalize_many(ch.mech, [], ch.names, [], ch.tol) == []
    assert finalize_many(ch.mech, np.zeros((2, 1)), ch.names, [[], []], ch.tol) == [[], []]
