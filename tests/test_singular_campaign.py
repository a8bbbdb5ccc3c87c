"""The singular campaign (issue 40 item 2, benchmarks/singular_campaign.py) and its generated graph files
(references/graph_designs.py).

Fast: the generated six-bars are what they claim, checked from the file text alone (links and joints counted
with tomllib, Kutzbach's count, the cycle rank by union-find, which links are ternary and whether they are
joined) and against the issue's six-bar of tests/singular_refs.py (same axes, links, and the reference count
of assemblies on two inversions); the reference det K_p of a four-bar; the judge flags issue 40's cells.
Slow (``-m slow``): ``--quick`` finds no count change outside a complete cover.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

import spherekin
from references import graph_designs as gd
from benchmarks import singular_campaign as sc
from singular_refs import ISSUE40_AXES_DEG, TERNARY_SIX_BAR_LINKS, polar_axes, ternary_six_bar_count

ROOT = Path(__file__).resolve().parents[1]


def _file_graph(text: str) -> tuple[dict, str, list]:
    """(link -> joints, ground, actuated) read from a graph file's text alone."""
    data = tomllib.loads(text)
    links: dict = {}
    for j in data["joints"]:
        a, b = j["links"]
        links.setdefault(a, []).append(j["name"])
        links.setdefault(b, []).append(j["name"])
    return links, data["ground"], [j["name"] for j in data["joints"] if j.get("actuated", False)]


def _cycle_rank(text: str) -> int:
    """joints - links + components, the components by union-find over the file's joints."""
    data = tomllib.loads(text)
    parent: dict = {}

    def find(x):
        parent.setdefault(x, x)
        while parent[x] != x:
            x = parent[x]
        return x

    for j in data["joints"]:
        a, b = j["links"]
        parent[find(a)] = find(b)
    links = {l for j in data["joints"] for l in j["links"]}
    return len(data["joints"]) - len(links) + len({find(l) for l in links})


@pytest.mark.parametrize("topology", ["Watt", "Stephenson"])
@pytest.mark.parametrize("seed", sc.SEEDS)
def test_generated_six_bars_have_mobility_one_and_two_loops(topology, seed):
    """Every inversion of each seeded six-bar: six links, seven joints, M = 3 (6 - 1) - 2 x 7 = 1, two
    independent loops, two ternary links joined by a joint (Watt) or not (Stephenson), the ground as asked;
    spherekin reads the same (its graph's mobility and loops)."""
    topo = gd.TOPOLOGIES[topology]
    axes = gd.random_axes(topo, seed)
    assert all(abs(np.linalg.norm(a) - 1.0) < 1e-12 for a in axes.values())
    for ground in gd.links_of(topo):
        text = gd.graph_toml(topo, axes, ground, "J4", f"{topology} {seed} {ground}")
        links, file_ground, actuated = _file_graph(text)
        n_joints = len(tomllib.loads(text)["joints"])
        assert (len(links), n_joints, file_ground, actuated) == (6, 7, ground, ["J4"])
        assert 3 * (len(links) - 1) - 2 * n_joints == 1
        assert _cycle_rank(text) == 2
        ternary = [l for l, js in links.items() if len(js) == 3]
        assert len(ternary) == 2 and sorted(len(js) for js in links.values()) == [2, 2, 2, 2, 3, 3]
        joined = bool(set(links[ternary[0]]) & set(links[ternary[1]]))
        assert joined == (topology == "Watt")
        mech = spherekin.load_mechanism(_write(text, f"{topology}_{seed}_{ground}"))
        assert mech.link_graph.mobility == 1 and len(mech.link_graph.loops) == 2
        assert tuple(mech.actuated) == ("J4",)


def _write(text: str, name: str) -> Path:
    import tempfile

    path = Path(tempfile.mkdtemp(prefix="campaign_")) / f"{name}.toml"
    path.write_text(text)
    return path


def test_random_axes_are_seeded_and_spread():
    """The same seed draws the same axes, another seed others; every link's joints are MIN_ARC apart."""
    a, b, c = (gd.random_axes(gd.WATT, s) for s in (1, 1, 2))
    assert all(np.array_equal(a[j], b[j]) for j in a) and not all(np.array_equal(a[j], c[j]) for j in a)
    for link, js in _file_graph(gd.graph_toml(gd.WATT, a, "T1", "J1", "w"))[0].items():
        for i in range(len(js)):
            for k in range(i + 1, len(js)):
                arc = math.acos(float(np.clip(a[js[i]] @ a[js[k]], -1, 1)))
                assert gd.MIN_ARC <= arc <= math.pi - gd.MIN_ARC


def test_the_issue_six_bar_is_the_test_reference_one():
    """The campaign's issue-40 six-bar, ground T1, is tests/singular_refs.py's (links renamed: T1 = ground,
    T2 = plate, L1 = link1, L2 = link2, L3 = crank, L4 = conn), same axes."""
    assert sc.ISSUE40_AXES_DEG == ISSUE40_AXES_DEG
    rename = {"T1": "ground", "T2": "plate", "L1": "link1", "L2": "link2", "L3": "crank", "L4": "conn"}
    assert {j: tuple(rename[l] for l in pair) for j, pair in gd.STEPHENSON.items()} == TERNARY_SIX_BAR_LINKS
    ref = polar_axes(ISSUE40_AXES_DEG)
    ours = {j["name"]: j["axis"] for j in tomllib.loads(sc.cases(quick=True, only="issue")[0].text)["joints"]}
    assert all(np.allclose(ours[j], ref[j], atol=1e-15) for j in ref)


@pytest.mark.parametrize("x", [0.3, 2.40])
def test_inversions_share_their_assemblies(tmp_path, x):
    """Driven at J5, the issue's six-bar with the ground T1 (the issue's) and with the ground L3 (the crank):
    spherekin proves the number of assemblies of the independent reference (singular_refs: the dyad
    eliminant) on both: a reading is a relative rotation, whichever link is fixed (graph_designs)."""
    ax = polar_axes(ISSUE40_AXES_DEG)
    expected = ternary_six_bar_count(ax, "J5", x)
    for ground in ("T1", "L3"):
        path = tmp_path / f"issue40_{ground}.toml"
        path.write_text(gd.graph_toml(gd.STEPHENSON, ax, ground, "J5", f"issue-40, ground {ground}"))
        report = spherekin.solve(path, (x,))
        assert report.count_exact and report.proven_count == expected, (ground, x)


def test_reference_det_of_a_four_bar():
    """graph_designs.passive_det from the file alone: for a four-bar driven at A, K_p's columns are the current
    axes of B, C, D up to sign, so |det K_p| = |det[B, C, D]| in the reference assembly; 0 where the four-bar is
    folded flat with B, C, D coplanar (axes B, C, D built coplanar here)."""
    topology, axes, ground, act = gd.graph_of(tomllib.loads((ROOT / "examples/four_bar_graph.toml").read_text()))
    zero = {j: 0.0 for j in topology}
    triple = abs(float(np.linalg.det(np.column_stack([axes["B"], axes["C"], axes["D"]]))))
    assert abs(abs(gd.passive_det(topology, axes, ground, act, zero)) - triple) < 1e-14
    flat = dict(axes)
    flat["C"] = (axes["B"] + axes["D"]) / np.linalg.norm(axes["B"] + axes["D"])
    assert abs(gd.passive_det(topology, flat, ground, act, zero)) < 1e-15


def test_judge_flags_the_cells_of_issue_40():
    """The cover the issue printed (cells of width 0.05 centred at -2.00, -1.63, -0.93, 2.37, "complete") against
    the true count changes (-2.0258, -1.6958, -0.8542, 2.4070, bracketed to 1e-3) and branch points: all four lie
    outside (the nearest, -2.0258 bracketed to [-2.0263, -2.0253], 3e-4 below the cell [-2.025, -1.975]); cells
    at the truth leave none outside."""
    truth = [-2.025789, -1.695815, -0.854246, 2.406960]
    ref = {"changes": [(x - 5e-4, 2, x + 5e-4, 0) for x in truth]}
    bref = {"points": [(x, 1e-14) for x in truth], "unresolved": []}
    wrong = {"cells": [(c - 0.025, c + 0.025, None, None, "singular") for c in (-2.00, -1.63, -0.93, 2.37)]}
    out = sc.judge_line(wrong, ref, bref)
    assert len(out["outside"]) == 4 and len(out["bp_outside"]) == 4
    right = {"cells": [(x - 0.004, x + 0.006, None, None, "singular") for x in truth]}
    out = sc.judge_line(right, ref, bref)
    assert out["outside"] == [] and out["bp_outside"] == [] and out["to_check"] == []


def test_judge_plane_segments():
    """A plane: a count change along x at y = 0.5 must meet a cell; a cell beside the segment does not count."""
    ref = {"changes": [(0.1, 2, 0.2, 0, 0, 0.5)]}
    near = {"cells": [(0.12, 0.15, 0.45, 0.55, "singular")]}
    beside = {"cells": [(0.12, 0.15, 0.51, 0.55, "singular")]}
    assert sc.judge_plane(near, ref)["outside"] == []
    assert len(sc.judge_plane(beside, ref)["outside"]) == 1


@pytest.mark.slow
def test_quick_campaign_has_no_count_change_outside_a_complete_cover(tmp_path):
    """``python -m benchmarks.singular_campaign --quick``: exit 0, every cover complete, no count change outside
    one, no branch point outside a cell; the issue's six-bar driven at J5 checked at its four changes."""
    out = tmp_path / "quick.json"
    run = subprocess.run([sys.executable, "-m", "benchmarks.singular_campaign", "--quick", "--json", str(out),
                          "--save", str(tmp_path / "wrong")], cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stdout + run.stderr
    data = json.loads(out.read_text())
    assert data["outside"] == 0
    rows = data["rows"]
    assert rows and all(r["status"] == "ok" and r["complete"] for r in rows)
    assert all(r["outside"] == [] and r["bp_outside"] == [] for r in rows)
    issue = [r for r in rows if r["family"] == "issue-40 six-bar"]
    assert len(issue) == 1 and issue[0]["changes"] == 4 and issue[0]["branch_points"] == 4
