"""experiments/tan_vs_sincos.py and its figure (issue 41 item 3): both parameterizations run the paper's
algorithm as asked (checked against the paper's text: Eq. (10) on the loop equations, Eq. (12) LPs,
subdivision without isolation), the four-bar's two assemblies are the closed form's, boxes never
decrease as the tolerance shrinks unless capped, the order fit is right on sequences of known order,
and the figure is drawn from a run's JSON."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from experiments import tan_vs_sincos as tvs

#: Tolerances of the small run (radians): loose enough for seconds.
TOLS = (1e-1, 1e-2)


@pytest.fixture(scope="module")
def small():
    return tvs.run(quick=True, tols=TOLS, trace_tol=1e-2, repeats=1)


def test_both_parameterizations_ran_the_papers_algorithm(small):
    for r in small["sweep"] + small["traces"]:
        assert not r["capped"]
        assert r["ran"] == r["asked"]
        assert (r["ran"]["system"], r["ran"]["formulation"], r["ran"]["pruner"]) == ("loops", "paper", "lp")
    assert {r["parameterization"] for r in small["sweep"]} == {"tan-half", "sin-cos"}


def test_the_four_bar_has_its_two_closed_form_assemblies(small):
    """A spherical four-bar at a crank input has two assemblies (two circle intersections; the closed form
    of tests/test_branches.py), found by both parameterizations at every tol."""
    from test_branches import outputs, read_axes

    assert len(outputs(read_axes(tvs.ROOT / "examples" / "four_bar.toml"), tvs.FOUR_BAR_INPUTS[0])) == 2
    assert all(r["solutions"] == 2 for r in small["sweep"])


def test_boxes_never_decrease_as_the_tolerance_shrinks(small):
    for p in tvs.PARAMETERIZATIONS:
        boxes = [r["boxes"] for r in small["sweep"] if r["parameterization"] == p]
        assert len(boxes) == len(TOLS) and boxes == sorted(boxes)
    for t in small["traces"]:                     # the per-depth counts add up to the traced run's boxes
        same = next(r for r in small["sweep"] if r["parameterization"] == t["parameterization"] and r["tol"] == t["tol"])
        assert sum(lv["boxes"] for lv in t["levels"]) == same["boxes"]


def test_a_capped_tolerance_ends_its_sweep_with_no_count():
    data = tvs.run(quick=True, tols=(1e-1, 1e-2, 1e-3), trace_tol=1e-1, repeats=1, max_boxes=350)
    for p in tvs.PARAMETERIZATIONS:
        rows = [r for r in data["sweep"] if r["parameterization"] == p]
        first = next(i for i, r in enumerate(rows) if r["capped"])
        assert all(r["capped"] and r.get("boxes") is None for r in rows[first:])
        assert all(not r["capped"] and r["boxes"] <= 350 for r in rows[:first])


@pytest.mark.parametrize("order", [1.0, 2.0])
def test_the_hull_order_of_a_sequence_of_known_order(order):
    h = [0.09]
    while h[-1] > 1e-12:
        h.append(0.5 * h[-1] ** order)             # H_(k+1) = C H_k^p
    rows = [dict(depth=k, boxes=1, hull_width=w) for k, w in enumerate([0.6, 0.3, *h])]
    assert tvs.hull_order(rows) == pytest.approx(order, abs=1e-6)
    assert math.isnan(tvs.hull_order(rows[:3]))    # too few levels below ORDER_MAX_WIDTH


def test_levels_count_boxes_and_exclude_discarded_hulls():
    from spherekin.search.boxloop import TRACE_OUTCOMES

    disc, kept = TRACE_OUTCOMES.index("discarded"), TRACE_OUTCOMES.index("split")
    rec = dict(depth=np.array([0, 1, 1, 2]), outcome=np.array([kept, kept, disc, kept]),
               reduced_lo=np.zeros((4, 2)), reduced_hi=np.array([[0.9, 0.5], [0.4, 0.1], [0.8, 0.8], [0.05, 0.02]]))
    assert tvs.levels(rec) == [dict(depth=0, boxes=1, hull_width=0.9), dict(depth=1, boxes=2, hull_width=0.4),
                               dict(depth=2, boxes=1, hull_width=0.05)]


def test_the_figure_is_drawn_from_the_json(small, tmp_path):
    from paper_figures import exp_tan_vs_sincos

    data = json.loads(json.dumps(small, default=float))
    fig = exp_tan_vs_sincos.draw(data)
    path = tmp_path / "f.png"
    fig.savefig(path)
    assert path.read_bytes()[:4] == b"\x89PNG" and len(fig.axes) == 4
