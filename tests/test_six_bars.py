"""The Watt and Stephenson six-bars written as graphs (examples/*.toml) through the commands a linkage
designer runs: solve, track (and map, with circuits: tests/test_branches.py). References written here:
the Watt six-bar as two four-bars in series (tests/test_mechanism_graph.py's closed form), the
Stephenson six-bar's singular input as the root of its closure equations plus det = 0, solved by
scipy on rotation products written in this file."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
from scipy.optimize import fsolve
from scipy.spatial.transform import Rotation

import spherekin as sk
from spherekin.mechanism import load_mechanism
from test_mechanism_graph import close, watt_reference

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def rot(axis, angle) -> np.ndarray:
    a = np.asarray(axis, dtype=float)
    return Rotation.from_rotvec(a / np.linalg.norm(a) * angle).as_matrix()


def test_a_watt_six_bar_tracked_along_its_input_stays_on_one_of_its_four_branches():
    mech = load_mechanism(EXAMPLES / "watt_six_bar.toml")
    path = np.linspace(0.3, 1.5, 25)[:, None]
    problem = sk.compile(mech)
    for start in range(4):
        track = problem.track(path, start=start)
        assert track.complete and len(track.poses) == len(path)
        labels = set()
        for pose, a_in in zip(track.poses, path[:, 0]):
            refs = watt_reference(mech, float(a_in))             # enumerated in the same order at every input
            gaps = [max(close(pose.passive_angles[n], r[n]) for n in "BCDEFG") for r in refs]
            k = int(np.argmin(gaps))
            assert gaps[k] < 1e-9 and sorted(gaps)[1] > 1e-3
            assert np.abs(pose.platform_rotation - refs[k]["pose"]).max() < 1e-9
            labels.add(k)
        assert len(labels) == 1                                # never another assembly


def stephenson_closures(mech):
    """closures(x) for x = (A, B, ..., G): the skew parts of ternary2's rotation along B-C against D-E and
    F-G (6 equations), every rotation a scipy product of Rot(axis, reading)."""
    ax = {j.name: np.array(j.axis) for j in mech.joints}

    def closures(x):
        r = dict(zip("ABCDEFG", x))
        t1 = rot(ax["A"], r["A"])
        via_bc = t1 @ rot(ax["B"], r["B"]) @ rot(ax["C"], r["C"])
        via_de = t1 @ rot(ax["D"], r["D"]) @ rot(ax["E"], r["E"])
        via_fg = rot(ax["F"], r["F"]) @ rot(ax["G"], r["G"])
        out = []
        for other in (via_de, via_fg):
            m = via_bc.T @ other
            out += [m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]]
        return np.array(out)

    return closures


def test_a_stephenson_six_bar_tracked_into_a_fold_stops_at_the_singular_input():
    """The fold is where the input A is extreme along the assembly's curve: with B as the curve's
    parameter (regular there), A(B) from the closures by scipy's fsolve, maximized by minimize_scalar."""
    from scipy.optimize import minimize_scalar

    mech = load_mechanism(EXAMPLES / "stephenson_six_bar.toml")
    path = np.linspace(0.3, 1.5, 61)[:, None]
    track = sk.compile(mech).track(path, start=1)
    stop = track.stop
    assert stop is not None and stop.kind == "singular"
    last = track.poses[-1]
    closures = stephenson_closures(mech)
    x_last = np.array([last.inputs["A"], *(last.passive_angles[n] for n in "BCDEFG")])
    solved = {}                                  # B -> the other readings, for warm starts along the curve

    def input_at(b, near):
        y, info, _, _ = fsolve(lambda y: closures(np.insert(y, 1, b)), near, full_output=True, xtol=1e-14)
        assert np.abs(info["fvec"]).max() < 1e-12          # (xtol 1e-14 may report "no further progress")
        solved[b] = y
        return y[0]

    # walk the curve from the last row reached with B decreasing (the way A grows: the tangent), small steps
    y, b = np.delete(x_last, 1), x_last[1]
    walk = [(b, input_at(b, y))]
    while walk[-1][1] >= walk[max(len(walk) - 2, 0)][1] and len(walk) < 400:
        y = solved[b]
        b -= 2e-3
        walk.append((b, input_at(b, y)))
    k = int(np.argmax([a_ for _, a_ in walk]))
    assert 0 < k < len(walk) - 1                 # the input peaks inside the walk: the fold
    lo, hi = walk[k + 1][0], walk[k - 1][0]
    best = minimize_scalar(lambda b_: -input_at(b_, solved[walk[k][0]]), bounds=(lo, hi), method="bounded",
                           options={"xatol": 1e-10})
    fold = -best.fun
    assert abs(fold - stop.singular_inputs["A"]) < 1e-8
    assert last.inputs["A"] <= stop.last_proven_inputs["A"] <= stop.singular_inputs["A"]


def test_the_watt_six_bars_circuits_and_branch_points_against_two_four_bars_in_series():
    """Branch points: where the closed form's count changes (the dyad E-F-G's two assemblies meet),
    located here by bisection on that count; each circuit joins the branches that meet there."""
    from spherekin.batch import branch_map

    mech = load_mechanism(EXAMPLES / "watt_six_bar.toml")
    bmap = branch_map(mech, "A=-pi:pi:36", joint="E")
    grid = np.linspace(-math.pi, math.pi, 4001)
    counts = np.array([len(watt_reference(mech, float(u))) for u in grid])
    want = []
    for k in np.flatnonzero(np.diff(counts)):
        lo, hi = grid[k], grid[k + 1]
        while hi - lo > 1e-13:
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if len(watt_reference(mech, mid)) == counts[k] else (lo, mid)
        want.append(0.5 * (lo + hi))
    assert len(want) == 4 and len(bmap.branch_points) == 4
    data = json.loads(json.dumps(bmap.as_dict()))          # plain JSON types throughout
    assert [p["input"] for p in data["branch_points"]] == [p.input for p in bmap.branch_points]
    for u in want:
        assert min(abs(p.input - u) for p in bmap.branch_points) < 1e-9
    # between the branch points the count is the closed form's, grid input by grid input
    for u, n in zip(bmap.grid, bmap.counts):
        assert n == len(watt_reference(mech, float(u)))
    # each branch point joins two branches of one circuit; every branch belongs to one circuit
    members = [set(c.branches) for c in bmap.circuits]
    assert sorted(b for m in members for b in m) == list(range(len(bmap.branches)))
    for p in bmap.branch_points:
        assert sum(set(p.branches) <= m for m in members) == 1
    # every sampled E against the closed form's assemblies at that input (away from the branch points,
    # where the closed form's acos has only ~sqrt(eps) of its digits)
    col = bmap.joints.index("E")
    checked = 0
    for br in bmap.branches:
        for u, row in zip(br.inputs, br.angles):
            if min(abs(u - w) for w in want) > 1e-4:
                assert min(close(row[col], r["E"]) for r in watt_reference(mech, float(u))) < 1e-9
                checked += 1
    assert checked > 50


def test_the_stephenson_six_bars_map_joins_its_two_assemblies_at_the_fold_it_tracks_into():
    """Around the fold of the track test: two assemblies below it, none above; the map must join them
    into one circuit at one branch point (not leave the two, 1e-3 apart next to it, unconnected), at
    the input the track locates and the rotation products confirm (the track test's reference)."""
    from spherekin.batch import branch_map

    mech = load_mechanism(EXAMPLES / "stephenson_six_bar.toml")
    # the two inputs of the default full-turn grid (90 points) that hold the fold between them
    grid = np.linspace(-math.pi, math.pi, 90)
    k = int(np.searchsorted(grid, 1.38378))
    bmap = branch_map(mech, f"A={float(grid[k - 1])!r}:{float(grid[k])!r}:2")
    assert bmap.counts[0] == 2 and bmap.counts[-1] == 0
    assert bmap.unresolved == () and len(bmap.branch_points) == 1 and len(bmap.circuits) == 1
    (point,) = bmap.branch_points
    assert set(point.branches) == set(bmap.circuits[0].branches) and len(bmap.branches) == 2
    track = sk.compile(mech).track(np.linspace(1.2, 1.5, 7)[:, None], start=0)
    assert track.stop is not None and track.stop.kind == "singular"
    assert abs(point.input - track.stop.singular_inputs["A"]) < 1e-9
    closures = stephenson_closures(mech)
    x = np.array([point.input, *(point.angles[bmap.joints.index(n)] for n in "BCDEFG")])
    assert np.abs(closures(x)).max() < 1e-9


def test_the_parallel_measure_of_a_graph_vanishes_where_the_closed_forms_assemblies_meet():
    """The map's singularity measure (sigma_min / sigma_max of the loop equations' passive Jacobian, any
    graph): ~0 at the Watt six-bar's branch point (where the closed form's dyad has a double root),
    O(1) away from it, at readings from the closed form."""
    mech = load_mechanism(EXAMPLES / "watt_six_bar.toml")
    lo, hi = -1.6, -1.5                                    # one of its branch points lies in between
    n_lo = len(watt_reference(mech, lo))
    assert n_lo != len(watt_reference(mech, hi))
    while hi - lo > 1e-14:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if len(watt_reference(mech, mid)) == n_lo else (lo, mid)
    inside = lo if n_lo > len(watt_reference(mech, hi)) else hi       # the side with the meeting pair
    refs = watt_reference(mech, inside)
    measures = [mech.parallel_measure({n: r[n] for n in "ABCDEFG"}) for r in refs]
    assert min(measures) < 1e-5                               # the two that meet: ~sqrt of the distance
    assert max(mech.parallel_measure({n: r[n] for n in "ABCDEFG"}) for r in watt_reference(mech, 0.7)) > 1e-2
    assert min(mech.parallel_measure({n: r[n] for n in "ABCDEFG"}) for r in watt_reference(mech, 0.7)) > 1e-3
