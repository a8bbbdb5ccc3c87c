"""The array engine (issue 30): a chunk of inputs solved as one array program.

``Problem.solve_many`` stacks the chart sets of a chunk of inputs and runs one box loop over all
their boxes, the input being the owner of a box's chart; the trust layer then runs over every
point. The rules checked here:

* each input's report is the one it gets alone (``Problem.solve_alone``: its own box loop, the
  per-input pipeline), and the same for chunks of 1, 7 and 256: counts, statuses, evidence kinds,
  fallbacks, angles to 1e-12 -- on seeded inputs of general_3rrr, the Gosselin platform (singular
  solutions), a four-bar, a five-bar and an elbow-actuated 3-RRR, with inputs 1e-8 from a fold,
  inputs with no assembly and solutions outside the passive joints' ranges;
* the counts agree with independent references: the 3-RRR's degree-8 quaternion reference at 50
  digits (references/reference_roots.py), the two-leg closed form (references/edge_references.py);
* an input that reaches a cap inside a chunk is reported as it is alone, and does not disturb the
  others.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from references.edge_references import four_bar as edge_four_bar, two_leg_edges, two_leg_reference
from references.peers_closed_form import geometry_of
from references.reference_roots import reference_roots
from spherekin import compile
from spherekin.mechanism import five_bar, general_3rrr, gosselin
from spherekin.mechanism.io import load_mechanism
from spherekin.systems.platform import DUPLICATE_POSE, first_of_duplicates
from spherekin.search.boxloop import search_platform, search_platform_many
from spherekin.search.parameterizations import stack_chart_sets
from test_systems import elbow_actuated

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
#: general_3rrr inputs ~6e-11 from a parallel singularity, with 8 and 6 assemblies (test_near_singular.py).
TWIN_INPUTS = (0.18613171226800826, -0.15119930525771785, 0.6382686351031328)
SIX_INPUTS = (0.18613171214533802, -0.15119930520514488, 0.6382686352520895)
#: Distance (radians) of the near-fold rows from the fold: the issue's 1e-8.
NEAR_FOLD = 1e-8
#: Angles of one input's solutions from a chunk and alone agree to this (the issue's 1e-12) ...
ANGLE_MATCH = 1e-12
#: ... plus this over the solution's parallel margin (sigma_min of its loop Jacobian): a root is
#: determined only to ~eps / sigma_min, so two polishes that start from different boxes (the
#: engine's compiled charts and the per-input direct build differ in their tolerances) agree to
#: that; 1e-8 from a four-bar's fold (sigma_min ~6e-5) they were measured 1.5e-11 apart.
ROOT_ROUNDING = 4e-15


def _near(x_star, direction, distance=NEAR_FOLD):
    d = np.asarray(direction, float)
    d = d / np.abs(d).max()
    return [np.asarray(x_star, float) + s * distance * d for s in (-1.0, 1.0)]


def _uniform(mech, n, seed):
    rng = np.random.default_rng(seed)
    return list(rng.uniform(-math.pi, math.pi, (n, len(mech.actuated))))


def _rows(name):
    """(mechanism, rows): seeded inputs plus the special ones of each mechanism."""
    if name == "general_3rrr":
        mech = general_3rrr()
        fold = np.subtract(SIX_INPUTS, TWIN_INPUTS)
        return mech, _uniform(mech, 40, 1) + _near(TWIN_INPUTS, fold) + [np.array(TWIN_INPUTS), np.array(SIX_INPUTS)]
    if name == "gosselin":
        mech = gosselin()
        # (0, 0, 0) and the paper's inputs hold singular solutions (the platform system falls back)
        return mech, _uniform(mech, 24, 2) + [np.zeros(3), np.array([0.0, 0.0, 0.0]) + 0.3]
    if name == "elbow_3rrr":
        mech = elbow_actuated(general_3rrr())
        return mech, _uniform(mech, 30, 3)
    if name == "gosselin_ranges":
        # passive joints limited to a width of pi: some assemblies lie outside the ranges
        mech = load_mechanism(EXAMPLES / "gosselin_chart.toml")
        return mech, _uniform(mech, 16, 4)
    # a four-bar driven by its rocker and the preset five-bar with its second input at -1: both have
    # branch inputs (2 <-> 0 assemblies) in closed form, and inputs without an assembly
    mech = edge_four_bar(80, 60, 70, 30) if name == "four_bar" else five_bar()
    fixed = [0.0] * len(mech.actuated) if name == "four_bar" else [0.0, -1.0]
    edges = [e for e in two_leg_edges(mech, fixed) if e.kind == "branch"][:2]
    near = [x for e in edges for x in _near([float(v) for v in e.x_star], e.direction)]
    return mech, _uniform(mech, 40, 5) + near


NAMES = ["general_3rrr", "gosselin", "four_bar", "five_bar", "elbow_3rrr", "gosselin_ranges"]


def table(report):
    """What must not depend on the chunk: counts, statuses, evidence kinds, fallbacks, the system."""
    s = report.settings
    return (report.proven_count, report.count_exact, s.system, s.fallback, s.limit is None,
            tuple((sol.status, sol.singularity, tuple(sorted(sol.evidence))) for sol in report.solutions))


def angles(report):
    return [np.asarray(sol.angles, float) for sol in report.solutions]


def same_angles(a, b, margins=None) -> bool:
    """Each solution's angles within ANGLE_MATCH (+ ROOT_ROUNDING / its parallel margin, given ``margins``)."""
    margins = [math.inf] * len(a) if margins is None else margins
    return len(a) == len(b) and all(np.abs(x - y).max() <= ANGLE_MATCH + ROOT_ROUNDING / m
                                    for x, y, m in zip(a, b, margins))


def margins(report):
    return [sol.evidence.get("parallel_margin") or math.inf for sol in report.solutions]


@pytest.fixture(scope="module", params=NAMES)
def solved(request):
    mech, rows = _rows(request.param)
    problem = compile(mech)
    rows = np.array(rows)
    return request.param, problem, rows, {size: problem.solve_many(rows, chunk=size) for size in (256, 7, 1)}


def test_chunks_of_1_7_and_256_give_the_same_table(solved):
    name, _, rows, by_size = solved
    for size in (7, 1):
        for k, (a, b) in enumerate(zip(by_size[256], by_size[size])):
            assert table(a) == table(b), (name, size, k, rows[k])
            assert same_angles(angles(a), angles(b)), (name, size, k)


def test_each_input_gets_the_report_it_gets_alone(solved):
    name, problem, rows, by_size = solved
    for k, (row, rep) in enumerate(zip(rows, by_size[256])):
        alone = problem.solve_alone(row)
        assert table(rep) == table(alone), (name, k, row)
        assert same_angles(angles(rep), angles(alone), margins(alone)), (name, k)
        assert list(rep.settings.inputs) == list(row)


def test_the_rows_hold_what_the_issue_asks_for(solved):
    """Not vacuous: the chunks hold inputs without assemblies, the 3-RRR's fold, fallbacks."""
    name, problem, rows, by_size = solved
    reports = by_size[256]
    if name in ("four_bar", "five_bar"):
        assert any(not r.solutions for r in reports)                   # inputs with no assembly
    if name == "gosselin":
        assert any(sol.status == "singular" for r in reports for sol in r.solutions)
    if name == "general_3rrr":                                         # next to the fold: the loop equations
        assert any(r.settings.fallback for r in reports[-4:])
    if name == "gosselin_ranges":
        free = compile(gosselin())
        assert any(len(r.solutions) < len(free.solve(row).solutions) for r, row in zip(reports, rows))


def test_counts_against_the_independent_references(solved):
    name, problem, rows, by_size = solved
    reports = by_size[256]
    if name == "general_3rrr":
        geometry = geometry_of(problem.mechanism)
        for row, rep in list(zip(rows, reports))[:12] + list(zip(rows, reports))[-2:]:
            expected = len(reference_roots(geometry, row).rotations)
            assert rep.count_exact and rep.proven_count == expected, (row, rep.proven_count, expected)
    elif name in ("four_bar", "five_bar"):
        for row, rep in zip(rows, reports):
            ref = two_leg_reference(problem.mechanism, row)
            if ref.count is None:
                continue
            # exact and equal, or flagged as a lower bound (only next to the fold)
            assert (rep.count_exact and rep.proven_count == ref.count) or \
                (not rep.count_exact and rep.proven_count <= ref.count), (row, rep.proven_count, ref.count)


def test_the_platform_search_of_a_chunk_is_each_inputs_own_search():
    """Box for box: the roots (bit for bit), the counters and the unresolved boxes of each input
    of a stacked chunk are those of its search alone; the roots carry the input's own charts."""
    mech, rows = _rows("gosselin")
    problem = compile(mech)
    s = problem.strategy
    sets = [problem.compiled("platform").charts(row) for row in rows]
    many = search_platform_many(stack_chart_sets(sets), len(rows), problem.compiled("platform").pruner, s.tol, s.max_boxes,
                                s.max_depth)
    for k, (charts, got) in enumerate(zip(sets, many)):
        alone = search_platform(charts, problem.compiled("platform").pruner, s.tol, s.max_boxes, s.max_depth)
        assert got.unresolved == alone.unresolved, k
        assert [(c, x.tolist()) for c, x in got.points] == [(c, x.tolist()) for c, x in alone.points], k
        for counter in ("boxes_processed", "discarded", "split", "reduced_again", "accepted", "isolated",
                        "max_depth", "spurious", "newton_failures"):
            assert getattr(got.stats, counter) == getattr(alone.stats, counter), (k, counter)


def test_an_input_that_reaches_a_cap_in_a_chunk_is_reported_as_alone_and_the_others_are_not_disturbed():
    mech = general_3rrr()
    rows = np.array(_uniform(mech, 12, 7))
    capped = compile(mech, max_boxes=180, system="platform")   # some inputs need more boxes than this (129-269), some fewer
    free = compile(mech, system="platform")
    reports = capped.solve_many(rows)
    hit = [r.settings.fallback is not None and "cap" in r.settings.fallback for r in reports]
    assert any(hit) and not all(hit)
    for row, rep, was_hit in zip(rows, reports, hit):
        alone = capped.solve_alone(row)
        assert table(rep) == table(alone) and same_angles(angles(rep), angles(alone), margins(alone))
        if not was_hit:
            assert table(rep)[:2] == table(free.solve(row))[:2]


def test_a_chunk_in_which_no_input_has_a_root():
    """Chunks of one and of several inputs of general_3rrr without any assembly (the degree-8
    reference finds no real root): empty reports, and solve says why."""
    mech = general_3rrr()
    x = (-0.12569221115499563, -2.0415665121775284, 1.4074629084552868)
    assert reference_roots(geometry_of(mech), x).count == 0
    problem = compile(mech)
    report = problem.solve(x)
    assert report.solutions == () and report.count_exact and report.empty_reason is not None
    assert [len(r.solutions) for r in problem.solve_many([x, x], chunk=2)] == [0, 0]


def test_roots_found_twice_on_overlapping_charts_are_kept_once_per_input():
    """first_of_duplicates against the rule written as a loop: in each input's list, a root is
    dropped when a root kept before it, of the same input, is within DUPLICATE_POSE; roots of
    different inputs never drop each other; a chain a ~ b ~ c with a and c apart keeps a and c."""
    rng = np.random.default_rng(30)
    poses, owner = [], []
    for k in range(12):
        base = [np.linalg.qr(rng.normal(size=(3, 3)))[0] for _ in range(k % 5)]
        mine = []
        for p in base:
            mine.append(p)
            if rng.random() < 0.6:
                mine.append(p + rng.uniform(-1, 1, (3, 3)) * 0.5 * DUPLICATE_POSE)    # the same root again
        mine = [mine[i] for i in rng.permutation(len(mine))]
        if k == 7:
            a = base[0]
            mine += [a + 1e-3, a + 1e-3 + 0.9 * DUPLICATE_POSE, a + 1e-3 + 1.8 * DUPLICATE_POSE]   # a chain
        poses += mine
        owner += [k] * len(mine)
    poses.append(poses[0].copy())                     # the first input's root at another input: kept
    owner.append(12)
    poses, owner = np.array(poses), np.array(owner)
    expect = []
    for i in range(len(poses)):
        kept_before = [j for j in range(i) if owner[j] == owner[i] and expect[j]]
        expect.append(not any(np.abs(poses[i] - poses[j]).max() <= DUPLICATE_POSE for j in kept_before))
    got = first_of_duplicates(poses, owner, 13)
    assert got.tolist() == expect
    assert 0 < sum(expect) < len(expect) and got[-1]
    assert got[np.flatnonzero(owner == 7)[-3:]].tolist() == [True, False, True]



def test_each_system_searches_in_chunks_of_its_own_size(monkeypatch):
    """``solve_many``'s chunk defaults to the first system's (the complete count's PROVEN_CHUNK, the box
    search's SEARCH_CHUNK); what a system passes on, the next one searches in chunks of its own size,
    and those inputs get the box search's answers."""
    from spherekin.systems import SEARCH_CHUNK, Passed
    from spherekin.systems.complete import CompiledComplete
    from spherekin.systems.platform import CompiledPlatform
    from spherekin.systems.proven_roots import PROVEN_CHUNK

    assert SEARCH_CHUNK < PROVEN_CHUNK
    problem = compile(general_3rrr())
    assert problem.chunk == PROVEN_CHUNK and compile(general_3rrr(), system="platform").chunk == SEARCH_CHUNK
    rows = np.random.default_rng(44).uniform(-math.pi, math.pi, (600, 3))
    sizes = {"complete": [], "platform": []}
    proven, searched = CompiledComplete.search_many, CompiledPlatform.search_many

    def spy_complete(self, values, progress):
        sizes["complete"].append(len(values))
        return [Passed("test: passed on") if k % 2 else a for k, a in enumerate(proven(self, values, progress))]

    def spy_platform(self, values, progress):
        sizes["platform"].append(len(values))
        return searched(self, values, progress)

    monkeypatch.setattr(CompiledComplete, "search_many", spy_complete)
    monkeypatch.setattr(CompiledPlatform, "search_many", spy_platform)
    reports = problem.solve_many(rows)
    assert sizes == {"complete": [600], "platform": [SEARCH_CHUNK, 300 - SEARCH_CHUNK]}
    assert [r.settings.system for r in reports] == ["platform" if k % 2 else "complete" for k in range(600)]
    sizes["platform"].clear()
    assert problem.solve_many(rows[:300], chunk=100) and sizes["complete"][1:] == [100, 100, 100]
    assert sizes["platform"] == [50, 50, 50]                     # an explicit chunk bounds every system's
