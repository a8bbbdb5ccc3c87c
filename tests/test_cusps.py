"""Certified cusps of the singular curves in a plane of inputs (issue 31 item 2): SingularSet.cusps, the JSON,
the plot markers, the printed count.

Checked against the independent reference of tests/singular_refs.py: at a cusp input three of the degree-8
oracle's roots meet (``triple_root_spread`` below CUSP_SPREAD), at a fold only two; ``cusps_in_square`` locates
the cusps of a square by minimizing that spread. Two sub-squares of general_3rrr's plane beta3 = 0.5 (found on
the whole plane at T = 0.2): CUSP_SQUARE holds a cusp; SPURIOUS_SQUARE holds a root of the spurious factor
l . r = 0 of the tangency for the first seeded r (a fold point, no cusp), which the adjugate test must rule out.
"""

from __future__ import annotations

import json
import math
from types import SimpleNamespace

import numpy as np
import pytest

import spherekin
from spherekin.cli import main
from spherekin.plot import plot_singular

from singular_refs import CUSP_SPREAD, EXAMPLES, cusps_in_square, triple_root_spread

RRR = EXAMPLES / "general_3rrr.toml"
#: A sub-square around the cusp near (1.5923, 0.1040) (~7 s at T = 0.1).
CUSP_SQUARE = ((1.5, 1.7), (0.0, 0.2))
#: A sub-square around a root of the tangency C_r with adj(G) r = 0 (near (1.4983, 1.0445)): no cusp (~3 s).
SPURIOUS_SQUARE = ((1.4, 1.6), (0.95, 1.15))
T = 0.1
#: The reference's cusps are Nelder-Mead minima of the triple spread: located to ~1e-9 (the spread is 1e-2 at
#: 1e-6 from a cusp); a certified cusp's box is ~1e-8 wide, so the distance allowed is the larger of the two.
REF_LOCATION = 1e-6


def _run(square):
    (x0, x1), (y0, y1) = square
    return spherekin.singular(RRR, x=("beta1", x0, x1), y=("beta2", y0, y1), fixed={"beta3": 0.5}, tol=T)


@pytest.fixture(scope="module")
def cusp_set():
    return _run(CUSP_SQUARE)


@pytest.fixture(scope="module")
def spurious_set():
    return _run(SPURIOUS_SQUARE)


def _check_proven(sset, reference):
    """Every ``cusp``: a triple root of the oracle at its inputs, within its box width (or REF_LOCATION) of a
    reference cusp, its box inside the plane and around its point."""
    for c in sset.cusps:
        if c.status != "cusp":
            continue
        assert c.box_x[0] <= c.x <= c.box_x[1] and c.box_y[0] <= c.y <= c.box_y[1]
        assert triple_root_spread([[c.x, c.y, 0.5]])[0] < CUSP_SPREAD, c
        width = max(c.box_x[1] - c.box_x[0], c.box_y[1] - c.box_y[0], REF_LOCATION)
        assert len(reference) and np.min(np.hypot(reference[:, 0] - c.x, reference[:, 1] - c.y)) <= width, c


def test_cusp_is_proven_where_the_reference_finds_one(cusp_set):
    reference = cusps_in_square(CUSP_SQUARE, n=21)
    assert len(reference) == 1                       # the square was chosen around one cusp
    proven = [c for c in cusp_set.cusps if c.status == "cusp"]
    assert len(proven) == 1
    _check_proven(cusp_set, reference)
    # no reference cusp missed: each lies in a candidate's box (proven or unresolved), up to REF_LOCATION
    for x, y in reference:
        assert any(c.box_x[0] - REF_LOCATION <= x <= c.box_x[1] + REF_LOCATION
                   and c.box_y[0] - REF_LOCATION <= y <= c.box_y[1] + REF_LOCATION for c in cusp_set.cusps)


def test_spurious_tangency_root_is_not_a_cusp(spurious_set):
    """The tangency C_r vanishes where adj(G) r = 0 (l . r = 0) at a fold point; kept without the adjugate
    test it would be listed as a cusp (the mutant "a cusp whose tangency was not proven")."""
    assert cusps_in_square(SPURIOUS_SQUARE, n=21).shape == (0, 2)
    assert not [c for c in spurious_set.cusps if c.status == "cusp"]
    _check_proven(spurious_set, np.zeros((0, 2)))


def test_json_plot_and_table(cusp_set, tmp_path, capsys):
    doc = json.loads(json.dumps(cusp_set.as_dict()))
    cusps = [c for c in doc["cusps"] if c["status"] == "cusp"]
    assert len(cusps) == 1
    c = cusps[0]
    assert set(c) == {"x", "y", "box", "status"} and set(c["box"]) == {"x", "y"}
    assert c["box"]["x"][0] <= c["x"] <= c["box"]["x"][1] and c["box"]["y"][0] <= c["y"] <= c["box"]["y"][1]
    assert triple_root_spread([[c["x"], c["y"], 0.5]])[0] < CUSP_SPREAD
    fig = plot_singular(cusp_set, tmp_path / "s.png")
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert "cusp cusp (1)" not in labels and any(t.startswith("cusp (1)") for t in labels)
    assert (tmp_path / "s.png").stat().st_size > 0


def test_cli_prints_the_cusp_count(capsys):
    (x0, x1), (y0, y1) = CUSP_SQUARE
    assert main(["singular", str(RRR), "--x", f"beta1={x0}:{x1}", "--y", f"beta2={y0}:{y1}", "--fix", "beta3=0.5",
                 "--tol", str(T)]) == 0
    assert "cusps: 1 proven" in capsys.readouterr().out


def test_five_bar_has_no_cusps(tmp_path, capsys):
    """A five-bar's singular curves (two circles tangent) have no cusps: the list is empty."""
    out = tmp_path / "f.json"
    assert main(["singular", str(EXAMPLES / "five_bar.toml"), "--x", "A=-0.5:0.5", "--y", "E=-0.5:0.5",
                 "--tol", "0.2", "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["cusps"] == [] and doc["cusp_search"] == "none_possible"
    assert "cusps: none possible (one loop" in capsys.readouterr().out


def test_a_plane_of_several_loops_says_its_cusps_are_not_searched(monkeypatch, capsys):
    """general_3rrr as a graph on the loop equations (the platform system declined: two loops): its cusps
    exist (tests above) and are not searched there, so the JSON and the table say so rather than list none;
    a line of one input has no cusps to search."""
    from spherekin.systems.platform import Platform

    graph = EXAMPLES / "general_3rrr_graph.toml"
    monkeypatch.setattr(Platform, "accepts", classmethod(lambda cls, mech, strategy=None: "declined for this test"))
    sset = spherekin.singular(graph, x=("beta1", 1.5, 1.6), y=("beta2", 0.0, 0.1), fixed={"beta3": 0.5}, tol=0.2,
                              max_boxes=50)
    assert sset.system == "loops" and sset.cusps == () and sset.as_dict()["cusp_search"] == "not_searched"
    assert main(["singular", str(graph), "--x", "beta1=1.5:1.6", "--y", "beta2=0:0.1", "--fix", "beta3=0.5",
                 "--tol", "0.2", "--max-boxes", "50"]) == 0
    assert "cusps: not searched" in capsys.readouterr().out
    line = spherekin.singular(EXAMPLES / "four_bar.toml", x=("A", -1.0, 1.0), tol=0.2)
    assert line.as_dict()["cusp_search"] == "not_applicable"


def test_proven_mode_change_around_the_cusp(cusp_set):
    """Item 5: a closed loop of inputs around the proven cusp, tracked with every step proven, that comes back
    in another assembly. Checked with the oracle: start and end poses are both real roots of the degree-8
    solver at the loop's first input (to 1e-9) and different poses; the loop winds once around the cusp."""
    from spherekin.singularities import mode_change

    from singular_refs import rrr_geometry, rrr_poses

    mc = mode_change(RRR, cusp_set)
    assert mc.found and mc.start_solution != mc.end_solution and mc.proven_steps > 0
    path = np.asarray(mc.path)
    assert np.array_equal(path[0], path[-1]) and np.allclose(path[:, 2], 0.5)
    cusp = next(c for c in cusp_set.cusps if c.status == "cusp")
    turn = np.unwrap(np.arctan2(path[:, 1] - cusp.y, path[:, 0] - cusp.x))
    assert round(abs(turn[-1] - turn[0]) / (2 * math.pi)) == 1
    poses = rrr_poses(rrr_geometry(), path[0])
    for pose in (mc.start_pose, mc.end_pose):
        assert min(np.abs(pose - r).max() for r in poses) < 1e-9
    assert np.abs(mc.start_pose - mc.end_pose).max() > 1e-3
    doc = json.loads(json.dumps(mc.as_dict()))
    assert doc["found"] is True and doc["columns"] == ["beta1", "beta2", "beta3"]


def _clusters_by_hand(chart, lo, hi):
    """The clusters' definition, all pairs: per chart, merge two groups while their hulls meet (closed boxes)."""
    out = []
    for c in sorted(set(chart.tolist())):
        groups = [[i] for i in range(len(chart)) if chart[i] == c]
        merged = True
        while merged:
            merged = False
            for a in range(len(groups)):
                for b in range(a + 1, len(groups)):
                    alo, ahi = lo[groups[a]].min(axis=0), hi[groups[a]].max(axis=0)
                    blo, bhi = lo[groups[b]].min(axis=0), hi[groups[b]].max(axis=0)
                    if np.all(alo <= bhi) and np.all(blo <= ahi):
                        groups[a] += groups.pop(b)
                        merged = True
                        break
                if merged:
                    break
        out.extend(sorted(g) for g in groups)
    return sorted(out)


@pytest.mark.parametrize("seed", range(4))
def test_clusters_are_the_hull_closure_of_meeting_boxes(seed):
    """Random boxes on two charts (some touching at a face, some overlapping, some chains whose hulls meet
    though no two of their boxes do): the k-d tree clusters equal the all-pairs hull closure."""
    from spherekin.singularities.cells import _clusters

    rng = np.random.default_rng(seed)
    n = 60
    lo = np.round(rng.random((n, 3)) * 8) / 8
    hi = lo + np.round(rng.random((n, 3)) * 2 + 1) / 16
    chart = rng.integers(0, 2, n)
    got = sorted(sorted(g.tolist()) for g in _clusters(chart, lo, hi))
    assert got == _clusters_by_hand(chart, lo, hi)
    assert 1 < len(got) < n


def test_rank_candidates_keep_the_reference_cusp():
    """The cusp candidates without a tangency system (the blow-up's route: boxes not proven cusp-free by the rank
    of the orientation Jacobian, singularities.cells.rank_candidates) on general_3rrr's cusp square: the reference
    cusp lies in a candidate's box (a box holding a cusp can never be proven cusp-free)."""
    from spherekin.budget import Budget
    from spherekin.mechanism import load_mechanism
    from spherekin.singularities.cover import _plane_run
    from spherekin.singularities.planes import PlatformPlane, SingularPlane
    from spherekin.singularities.cells import Grid

    (x0, x1), (y0, y1) = CUSP_SQUARE
    plane = SingularPlane(("beta1", x0, x1), ("beta2", y0, y1), {"beta3": 0.5})
    system = PlatformPlane(load_mechanism(RRR), plane)
    run = _plane_run(system, Grid.over(plane.axes, T), T, 10**6, None, "rank", Budget())
    reference = cusps_in_square(CUSP_SQUARE, n=21)
    assert len(reference) == 1 and run.cusps
    for x, y in reference:
        assert any(c.box_x[0] <= x <= c.box_x[1] and c.box_y[0] <= y <= c.box_y[1] for c in run.cusps)
    assert all(c.status == "unresolved" for c in run.cusps)


def test_a_cusp_on_the_whole_planes_charts_is_proven():
    """The cusp near (-1.9253, 0.7221) on the charts of the whole plane [-pi, pi]^2 at T = 0.05 (the cusp
    search started from that square only, ~2 s): there the Krawczyk box PROOF_RADIUS times the cluster's hull
    is too small for the nets' rounding, and the cusp is proven only on a wider box of the ladder
    (singularities.cells.PROOF_LADDER; before, `spherekin singular` over the whole plane listed it unresolved).
    The proven cusp is the reference's."""
    from spherekin.mechanism import load_mechanism
    from spherekin.problem import DEFAULT_PRUNER
    from spherekin.singularities.cover import CUSP_FRACTION, CUSP_VECTORS
    from spherekin.search.boxloop import pruner_for, search_cover
    from spherekin.singularities.planes import PlatformPlane, SingularPlane
    from spherekin.singularities.cells import certify_cusps

    square = ((-1.95, -1.90), (0.70, 0.75))
    plane = SingularPlane(("beta1", -math.pi, math.pi), ("beta2", -math.pi, math.pi), {"beta3": 0.5})
    system = PlatformPlane(load_mechanism(RRR), plane)
    n = len(system.charts.map_lo)
    ulo, uhi = np.zeros((n, 5)), np.ones((n, 5))
    for col, ends in zip(system.plane_columns, square):
        u = [system.unit(np.arange(n), np.where(np.arange(5) == col, e, 0.0)[None].repeat(n, 0))[:, col] for e in ends]
        ulo[:, col], uhi[:, col] = np.clip(np.minimum(*u), 0, 1), np.clip(np.maximum(*u), 0, 1)
    keep = np.all(uhi > ulo, axis=1)
    sets = system.cusp_charts(CUSP_VECTORS)
    found = search_cover(sets[0], pruner_for(sets[0], DEFAULT_PRUNER, None), CUSP_FRACTION * 0.05, 10**6,
                         start=(np.flatnonzero(keep), ulo[keep], uhi[keep]))
    got = SimpleNamespace(cusps=certify_cusps(system, sets, found))     # what _check_proven reads of a SingularSet
    reference = cusps_in_square(square, n=21)
    assert len(reference) == 1
    assert sum(c.status == "cusp" for c in got.cusps) == 1
    _check_proven(got, reference)
